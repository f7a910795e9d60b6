//! The evidence attribution (`Monitor::check`'s ownership, gated assignment and spill-over rules): a displaced
//! object's evidence goes to that object, not to its clean neighbours; evidence that cannot be an object's
//! (too large, or merely near a confirmed box) is nobody's.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use common::*;
use pmon_monitor::{
    Frame, Monitor, MonitorParams, ObjectReport, PointCloud, Pose2, PositionCause, SensorVerdict, SpillOverFit,
};

fn run(monitor: &mut Monitor, objects: &[pmon_monitor::ObjectState], points_ego: &[[f32; 3]]) -> Vec<ObjectReport> {
    run_frame(monitor, objects, points_ego).0
}

/// Runs one frame; returns the reports and the number of missed-object clusters.
fn run_frame(
    monitor: &mut Monitor,
    objects: &[pmon_monitor::ObjectState],
    points_ego: &[[f32; 3]],
) -> (Vec<ObjectReport>, usize) {
    let pts = to_sensor(points_ego);
    let frame = Frame {
        timestamp_s: 0.0,
        world_from_ego: Pose2::default(),
        objects,
        cloud: Some(PointCloud { points_in_sensor: &pts, ego_from_sensor: extrinsic() }),
        roi_in_ego: &[],
        static_in_ego: &[],
    };
    let report = monitor.check(&frame).unwrap();
    (report.objects.to_vec(), report.missed_objects())
}

/// Two pedestrians side by side; one is reported 1.5 m further away than it is. The displaced one is the
/// position error, with its own evidence; the clean one stays consistent.
#[test]
fn displaced_pedestrian_takes_its_evidence_and_its_neighbour_is_not_blamed() {
    for cells in [0.5, 0.2] {
        let mut m = Monitor::new(MonitorParams { cell_size_m: cells, ..MonitorParams::default() }).unwrap();
        let clean = object(1, 14.0, 1.2, 0.0, 0.6, 0.6);
        let truth = object(2, 14.0, 0.0, 0.0, 0.6, 0.6);
        let mut pts = visible_face_points(&clean, 0.05);
        pts.extend(visible_face_points(&truth, 0.05));
        pts.extend(ground_points(45.0));
        let mut reported = truth;
        reported.x_m += 1.5;
        let r = run(&mut m, &[clean, reported], &pts);
        assert_eq!(
            r[0].sensor.verdict,
            SensorVerdict::Consistent,
            "{cells} m cells: clean neighbour {:?}",
            r[0].sensor
        );
        assert_eq!(r[1].sensor.verdict, SensorVerdict::PositionError, "{cells} m cells: displaced {:?}", r[1].sensor);
        // Found by its evidence outside its region (a cluster attributed to it); the neighbour has no cause.
        assert_eq!(r[1].sensor.position_cause, Some(PositionCause::DisplacedEvidence), "{:?}", r[1].sensor);
        assert_eq!(r[0].sensor.position_cause, None);
        // The offset points from the evidence back to the reported box: about +1.5 m along x, less the box.
        assert!(r[1].sensor.offset_m[0] > 0.5 && r[1].sensor.offset_m[0] < 1.7, "{:?}", r[1].sensor.offset_m);
    }
}

/// A pedestrian reported on top of its neighbour's evidence (it borrows it: `eta` is high) while its own
/// evidence stands 1.5 m nearer: the borrowed evidence does not confirm it.
#[test]
fn object_on_a_neighbours_evidence_is_not_confirmed_by_it() {
    let mut m = Monitor::new(MonitorParams { release_flagged_claims: true, ..MonitorParams::default() }).unwrap();
    let neighbour = object(1, 16.0, 0.4, 0.0, 0.6, 0.6);
    let truth = object(2, 14.5, -0.3, 0.0, 0.6, 0.6);
    let mut pts = visible_face_points(&neighbour, 0.05);
    pts.extend(visible_face_points(&truth, 0.05));
    pts.extend(ground_points(45.0));
    let mut reported = truth;
    reported.x_m = 16.2;
    reported.y_m = 0.0;
    let r = run(&mut m, &[neighbour, reported], &pts);
    assert!(r[1].sensor.eta >= 0.8, "the displaced box covers the neighbour's evidence: {:?}", r[1].sensor);
    assert!(r[1].sensor.eta_own < 0.8, "but does not own it: {:?}", r[1].sensor);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{:?}", r[0].sensor);
    assert_eq!(r[1].sensor.verdict, SensorVerdict::PositionError, "{:?}", r[1].sensor);
}

/// A wall 1 m beside a confirmed car and near an evidence-free ghost is nobody's evidence: it is too long to be
/// either box's, so it becomes a missed object and neither box is blamed for it.
#[test]
fn a_wall_is_too_large_to_be_a_pedestrians_evidence() {
    let mut m = Monitor::new(MonitorParams { release_flagged_claims: true, ..MonitorParams::default() }).unwrap();
    let car = object(1, 15.0, 3.0, 0.0, 4.5, 1.9);
    let ghost = object(2, 20.0, -3.0, 0.0, 0.6, 0.6);
    let mut pts = visible_face_points(&car, 0.1);
    // A 6 m wall along x at y = -4.6, from x = 17 to 23 (1 m from the ghost's region, beside the car's lane).
    let mut x = 17.0f32;
    while x <= 23.0 {
        for z in [0.5f32, 1.0, 1.5] {
            pts.push([x, -4.6, z]);
        }
        x += 0.05;
    }
    pts.extend(ground_points(45.0));
    let r = run(&mut m, &[car, ghost], &pts);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{:?}", r[0].sensor);
    assert_ne!(r[1].sensor.verdict, SensorVerdict::PositionError, "{:?}", r[1].sensor);
}

/// Spill-over (attribution step 5) counts every return: a confirmed pedestrian whose occupied returns run on from
/// its box into a two-cell cluster beyond its margin, together no longer than the box may be, is flagged (its box
/// may be displaced, its evidence reaching over the edge). The same frame with one more return, too sparse to make
/// its cell occupied, where the row continues beyond the cluster, or at the box's far end, is not: the returns
/// then span more than the box, so the cluster is unlabelled returns next to a clean box (a missed object), as on
/// the clean nuScenes and KITTI frames (docs/attribution.md). The rule is [`SpillOverFit::EveryReturn`], the
/// default since issue #10's clean-box round: with the older fit (`SpillOverFit::Occupied`, occupied cells only)
/// all three frames flag the box. The rule is chosen by the params key `spill_over_fit`;
/// [`Monitor::set_spill_over_fit`] gives the same verdicts.
#[test]
fn spill_over_counts_every_return_not_only_the_occupied_cells() {
    let every = MonitorParams { spill_over_fit: SpillOverFit::EveryReturn, ..MonitorParams::default() };
    assert_eq!(every, MonitorParams::default(), "every return is the default fit");
    let occupied = MonitorParams { spill_over_fit: SpillOverFit::Occupied, ..MonitorParams::default() };
    let mut m = Monitor::new(every).unwrap();
    let mut by_setter = Monitor::new(occupied).unwrap();
    by_setter.set_spill_over_fit(SpillOverFit::EveryReturn);
    assert_eq!(*by_setter.params(), every);
    let mut occupied_only = Monitor::new(occupied).unwrap();
    // 0.5 m cells with edges on multiples of 0.5 m: the box and its grown region (0.4 m margins) reach from
    // x = 13.55 to 14.95; the cells centred at x = 14.25 and 14.75 are its own, 15.25 and 15.75 a conflict.
    let ped = object(1, 14.25, 0.25, 0.0, 0.6, 0.6);
    let cell = |x: f32, hits: usize| -> Vec<[f32; 3]> {
        (0..hits).map(|i| [x - 0.1 + 0.05 * i as f32, 0.2 + 0.02 * i as f32, 1.0]).collect()
    };
    let mut row = Vec::new();
    for x in [14.25f32, 14.75, 15.25, 15.75] {
        row.extend(cell(x, 4));
    }
    row.extend(ground_points(45.0));
    let (r, missed) = run_frame(&mut m, &[ped], &row);
    let (r2, missed2) = run_frame(&mut by_setter, &[ped], &row);
    assert_eq!((r2[0].sensor.verdict, missed2), (r[0].sensor.verdict, missed), "the setter");
    assert!(r[0].sensor.eta_own >= 0.8, "{:?}", r[0].sensor);
    assert_eq!(
        r[0].sensor.verdict,
        SensorVerdict::PositionError,
        "its evidence reaches over the edge: {:?}",
        r[0].sensor
    );
    assert_eq!(missed, 0);
    for (sparse, what) in [(16.25f32, "beyond the cluster"), (13.75, "at the box's far end")] {
        let mut pts = row.clone();
        pts.extend(cell(sparse, 1));
        let (r, missed) = run_frame(&mut m, &[ped], &pts);
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "one return {what}: {:?}", r[0].sensor);
        assert_eq!(missed, 1, "one return {what}: the cluster is a missed object");
        let (r2, missed2) = run_frame(&mut by_setter, &[ped], &pts);
        assert_eq!((r2[0].sensor.verdict, missed2), (r[0].sensor.verdict, missed), "the setter: {what}");
        let (r, missed) = run_frame(&mut occupied_only, &[ped], &pts);
        assert_eq!(
            r[0].sensor.verdict,
            SensorVerdict::PositionError,
            "occupied-cells fit, one return {what}: {:?}",
            r[0].sensor
        );
        assert_eq!(missed, 0);
    }
}

/// A pedestrian hidden behind a car, whose noisy box pokes half out of the car's shadow: its stated uncertainty
/// allows it to stand in the shadow, so the sensor cannot call it a ghost (`not_monitored(occluded)`). The same
/// box stated exact (no uncertainty, margin `delta_safe` only), and a box with nothing in open space whatever
/// its uncertainty, stay ghosts.
#[test]
fn a_hidden_object_is_no_ghost_while_its_uncertainty_allows_the_shadow() {
    let car = object(1, 10.0, 0.0, 0.0, 4.5, 1.9);
    let mut pts = visible_face_points(&car, 0.05);
    pts.extend(ground_points(45.0));
    let mut m = Monitor::new(MonitorParams { release_flagged_claims: true, ..MonitorParams::default() }).unwrap();
    // The car's shadow at 14 m reaches about 0.95 * 14 / 7.75 = 1.7 m to each side: the box (y from 1.65 to
    // 2.25 m) is mostly out of it. Stated exact, its margin is `delta_safe` (0.1 m): moved by it, the box stays
    // mostly in sight. With a 0.3 m sigma (margin 1 m), its place may be in the shadow.
    let hidden = object(2, 14.0, 1.95, 0.0, 0.6, 0.6);
    let sigma = |s: f32| pmon_monitor::Uncertainty {
        x_m: s,
        y_m: s,
        length_m: 0.0,
        width_m: 0.0,
        heading_rad: 0.1,
        speed_mps: 0.5,
    };
    let noisy = pmon_monitor::ObjectState { uncertainty: Some(sigma(0.3)), ..hidden };
    let exact = pmon_monitor::ObjectState { uncertainty: Some(sigma(0.0)), ..hidden };
    let open = pmon_monitor::ObjectState { id: 3, x_m: 14.0, y_m: -8.0, uncertainty: Some(sigma(0.3)), ..hidden };
    let r = run(&mut m, &[car, noisy, open], &pts);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{:?}", r[0].sensor);
    assert_eq!(
        r[1].sensor.verdict,
        SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::Occluded),
        "{:?}",
        r[1].sensor
    );
    assert_eq!(r[2].sensor.verdict, SensorVerdict::Ghost, "nothing in open space: {:?}", r[2].sensor);
    let mut m = Monitor::new(MonitorParams { release_flagged_claims: true, ..MonitorParams::default() }).unwrap();
    let r = run(&mut m, &[car, exact], &pts);
    assert_eq!(r[1].sensor.verdict, SensorVerdict::Ghost, "stated exact, mostly seen empty: {:?}", r[1].sensor);
}

/// The defaults before issue #10's round "Two rules together" (`front_cluster` off, `memory_hold_s` 0, and the keys of
/// the later round of rays on the body off too): the base of the tests that show what one opt-in key changes alone.
fn before_two_rules() -> MonitorParams {
    MonitorParams { front_cluster: false, memory_hold_s: 0.0, ..before_body_rules() }
}

/// The defaults before issue #10's round "Rays on the body with step 8 gated" (docs/attribution.md): `seen_body` and
/// `follow_gate` off.
fn before_body_rules() -> MonitorParams {
    MonitorParams { seen_body: false, follow_gate: false, ..MonitorParams::default() }
}

/// The uncertainty of a noisy object list: position sigma `s`, nothing else that grows the region.
fn sigma(s: f32) -> pmon_monitor::Uncertainty {
    pmon_monitor::Uncertainty { x_m: s, y_m: s, length_m: 0.0, width_m: 0.0, heading_rad: 0.1, speed_mps: 0.5 }
}

/// A pedestrian hidden behind a thin post (a listed object) 22 m out, reported 0.8 m beside its place with a
/// 0.5 m sigma (margin 1.6 m). The post's shadow at 22 m is about 0.36 m to each side: the reported box, and the
/// box moved by its whole margin either way or along, stand mostly in sight; its true place, half a margin
/// from the reported one, is in the shadow. The object may stand there: `not_monitored(occluded)`, no ghost.
/// (The rule tried only the eight extreme places of `A_o` until this round.)
#[test]
fn a_hidden_object_is_no_ghost_when_its_place_lies_between_the_extremes_of_its_margin() {
    let post = object(1, 10.0, 0.0, 0.0, 0.32, 0.32);
    let mut pts = visible_face_points(&post, 0.01);
    // Ground returns only where the post does not block them.
    pts.extend(ground_points(45.0).into_iter().filter(|p| !(p[0] > 9.8 && (p[1] / p[0]).abs() < 0.17 / 9.84)));
    let truth = object(2, 22.0, 0.0, 0.0, 0.5, 0.5);
    let reported = pmon_monitor::ObjectState { y_m: 0.8, uncertainty: Some(sigma(0.5)), ..truth };
    let mut m = Monitor::new(MonitorParams { release_flagged_claims: true, ..MonitorParams::default() }).unwrap();
    let region = m.region_of(&reported).unwrap();
    assert!((region.margin_width_m - 1.6).abs() < 1e-4, "{region:?}");
    let r = run(&mut m, &[post, reported], &pts);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{:?}", r[0].sensor);
    assert_eq!(
        r[1].sensor.verdict,
        SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::Occluded),
        "{:?}",
        r[1].sensor
    );
    // In open space, the same box far from any shadow is still a ghost.
    let open = pmon_monitor::ObjectState { id: 3, y_m: -8.0, ..reported };
    let mut m = Monitor::new(MonitorParams { release_flagged_claims: true, ..MonitorParams::default() }).unwrap();
    let r = run(&mut m, &[post, open], &pts);
    assert_eq!(r[1].sensor.verdict, SensorVerdict::Ghost, "nothing in open space: {:?}", r[1].sensor);
}

/// A track found displaced in one frame keeps its evidence in the next although a neighbour, arriving beside
/// that evidence with a wide margin (0.3 m sigma), now explains it: the evidence is no conflict any more, but it
/// lies outside the neighbour's box, where the track's remembered offset puts it, so it still follows the track
/// (`position_error`). A monitor that sees the second frame alone calls the track hidden.
#[test]
fn displaced_evidence_in_a_neighbours_margin_still_follows_its_track() {
    let truth = object(2, 14.0, 0.0, 0.0, 0.6, 0.6);
    let mut reported = truth;
    reported.x_m += 1.5;
    let wide = sigma(0.3);
    let neighbour = pmon_monitor::ObjectState { uncertainty: Some(wide), ..object(1, 13.9, 0.8, 0.0, 0.6, 0.6) };
    let mut first = visible_face_points(&truth, 0.05);
    first.extend(ground_points(45.0));
    let mut second = first.clone();
    second.extend(visible_face_points(&neighbour, 0.05));
    let mut m = Monitor::new(MonitorParams { release_flagged_claims: true, ..MonitorParams::default() }).unwrap();
    let r = check_at(&mut m, 0.0, &[reported], &first, Pose2::default());
    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "first frame: {:?}", r[0].sensor);
    let r = check_at(&mut m, 0.1, &[neighbour, reported], &second, Pose2::default());
    assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "neighbour: {:?}", r[0].sensor);
    assert_eq!(r[1].sensor.verdict, SensorVerdict::PositionError, "followed: {:?}", r[1].sensor);
    assert_eq!(r[1].sensor.position_cause, Some(PositionCause::EvidenceFollowed), "{:?}", r[1].sensor);
    assert!(r[1].sensor.offset_m[0] > 0.5, "from its evidence back to the box: {:?}", r[1].sensor.offset_m);
    let mut alone = Monitor::new(MonitorParams::default()).unwrap();
    let r = check_at(&mut alone, 0.1, &[neighbour, reported], &second, Pose2::default());
    assert_ne!(r[1].sensor.verdict, SensorVerdict::PositionError, "without the memory: {:?}", r[1].sensor);
    // With `follow_owner_fit` too: the track's returns and the neighbour's, side by side, are wider than the
    // neighbour's box, so they are no spill of its body and step 8 still follows them.
    let mut fit = Monitor::new(MonitorParams { follow_owner_fit: true, ..MonitorParams::default() }).unwrap();
    check_at(&mut fit, 0.0, &[reported], &first, Pose2::default());
    let r = check_at(&mut fit, 0.1, &[neighbour, reported], &second, Pose2::default());
    assert_eq!(r[1].sensor.position_cause, Some(PositionCause::EvidenceFollowed), "with the key: {:?}", r[1].sensor);
}

/// Step 8's false alarm on a transient error (docs/attribution.md, "Step 8 judged by the evidence it follows"): a
/// pedestrian reported 1.5 m beyond its face is flagged with that face (right); in the next sweep its box is back
/// where it stands (the error ended), but a neighbour now walks in front of it and hides it. The neighbour's box
/// stands 0.7 m short of its body, within its wide stated uncertainty, so its returns lie in its margin, outside its
/// box, exactly where the track's remembered offset points from the clean box. Step 8 follows them and flags the
/// clean track; with `follow_owner_fit` those returns fit the neighbour's own box (they can be its body), step 8
/// does not follow them, and the hidden track is occluded. Fails if the key is ignored, or if the default changes.
#[test]
fn step_8_does_not_follow_a_neighbours_body_with_follow_owner_fit() {
    let truth = object(2, 14.0, 0.0, 0.0, 0.6, 0.6);
    let mut displaced = truth;
    displaced.x_m += 1.5;
    let body = object(1, 13.0, 0.0, 0.0, 0.6, 0.6);
    let neighbour = pmon_monitor::ObjectState { x_m: 12.3, uncertainty: Some(sigma(0.3)), ..body };
    let mut first = visible_face_points(&truth, 0.05);
    first.extend(ground_points(45.0));
    let mut second = visible_face_points(&body, 0.05);
    second.extend(ground_points(45.0));
    for (key, want_followed) in [(false, true), (true, false)] {
        let mut m = Monitor::new(MonitorParams { follow_owner_fit: key, ..MonitorParams::default() }).unwrap();
        let r = check_at(&mut m, 0.0, &[displaced], &first, Pose2::default());
        assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "key {key}, error frame: {:?}", r[0].sensor);
        let r = check_at(&mut m, 0.1, &[neighbour, truth], &second, Pose2::default());
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "key {key}, neighbour: {:?}", r[0].sensor);
        let followed = r[1].sensor.position_cause == Some(PositionCause::EvidenceFollowed);
        assert_eq!(followed, want_followed, "key {key}, clean hidden track: {:?}", r[1].sensor);
        if key {
            assert_eq!(
                r[1].sensor.verdict,
                SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::Occluded),
                "{:?}",
                r[1].sensor
            );
        }
    }
}

/// Step 8 after a gap (params key `memory_hold_s`): a track found displaced in two frames in a row, then not flagged
/// for a frame (its box stepped onto an unlabelled post's returns, 2 m beside its line of sight, and is confirmed by
/// them), then hidden behind its own evidence again, which a neighbour's wide margin now explains. With the key the
/// offset found by the alarms is held over the gap and step 8 finds the evidence where it puts it
/// (`position_error`); without the key, once the hold has run out, or after a single alarm (a run of one is not
/// held), the offset lived one frame and the box is called occluded.
#[test]
fn displaced_evidence_in_a_neighbours_margin_is_followed_over_a_gap_while_the_offset_is_held() {
    let truth = object(2, 14.0, 0.0, 0.0, 0.6, 0.6);
    let reported = pmon_monitor::ObjectState { x_m: 15.5, ..truth };
    // The gap: the box beside its line of sight, on a post nobody listed.
    let on_post = pmon_monitor::ObjectState { y_m: 2.0, ..reported };
    let post = object(90, 15.5, 2.0, 0.0, 0.3, 0.3);
    let wide = sigma(0.3);
    let neighbour = pmon_monitor::ObjectState { uncertainty: Some(wide), ..object(1, 13.9, 0.8, 0.0, 0.6, 0.6) };
    let mut first = visible_face_points(&truth, 0.05);
    first.extend(ground_points(45.0));
    let mut gap = first.clone();
    gap.extend(visible_face_points(&post, 0.05));
    let mut third = first.clone();
    third.extend(visible_face_points(&neighbour, 0.05));
    let occluded = SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::Occluded);
    // (memory_hold_s, frames flagged before the gap, time of the third frame, flagged then)
    for (hold, alarms, third_t, flagged) in
        [(1.0, 2, 0.3, true), (1.0, 2, 0.8, true), (0.0, 2, 0.3, false), (1.0, 2, 1.4, false), (1.0, 1, 0.3, false)]
    {
        let what = format!("hold {hold}, {alarms} alarms, third frame at {third_t}");
        let params = MonitorParams { memory_hold_s: hold, ..MonitorParams::default() };
        let mut m = Monitor::new(params).unwrap();
        let mut t = 0.0;
        for _ in 0..alarms {
            let r = check_at(&mut m, t, &[reported], &first, Pose2::default());
            assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "{what}, at {t}: {:?}", r[0].sensor);
            t += 0.1;
        }
        // The gap, as many frames as it takes to reach the third frame's time.
        while t < third_t - 0.05 {
            let r = check_at(&mut m, t, &[on_post], &gap, Pose2::default());
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{what}, gap at {t}: {:?}", r[0].sensor);
            t += 0.1;
        }
        let r = check_at(&mut m, third_t, &[neighbour, reported], &third, Pose2::default());
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{what}, neighbour: {:?}", r[0].sensor);
        if flagged {
            assert_eq!(r[1].sensor.verdict, SensorVerdict::PositionError, "{what}: {:?}", r[1].sensor);
            assert!(r[1].sensor.offset_m[0] > 0.5, "from its evidence back to the box: {:?}", r[1].sensor.offset_m);
        } else {
            assert_eq!(r[1].sensor.verdict, occluded, "{what}: {:?}", r[1].sensor);
        }
    }
}

/// Two pedestrians walking through each other (their true boxes overlap: one blob of evidence), both reported
/// 1.5 m further away: both are position errors. The one that does not get the blob in the one-to-one assignment
/// shares it (its box and the other's stand in one place); before, it was called occluded behind the blob.
#[test]
fn two_boxes_reported_in_one_place_share_the_evidence_they_left() {
    for cells in [0.5, 0.2] {
        let mut m = Monitor::new(MonitorParams { cell_size_m: cells, ..MonitorParams::default() }).unwrap();
        let a = object(1, 14.0, 0.0, 0.0, 0.6, 0.6);
        let b = object(2, 14.1, 0.25, 0.0, 0.6, 0.6);
        let mut pts = visible_face_points(&a, 0.05);
        pts.extend(visible_face_points(&b, 0.05));
        pts.extend(ground_points(45.0));
        let (mut ra, mut rb) = (a, b);
        ra.x_m += 1.5;
        rb.x_m += 1.5;
        let r = run(&mut m, &[ra, rb], &pts);
        for (i, o) in r.iter().enumerate() {
            assert_eq!(o.sensor.verdict, SensorVerdict::PositionError, "{cells} m cells, object {i}: {:?}", o.sensor);
        }
        // A clean pedestrian beside a displaced one, their reported boxes apart: the clean one is not blamed.
        let c = object(3, 14.0, 1.4, 0.0, 0.6, 0.6);
        let mut pts = visible_face_points(&a, 0.05);
        pts.extend(visible_face_points(&c, 0.05));
        pts.extend(ground_points(45.0));
        let mut m = Monitor::new(MonitorParams { cell_size_m: cells, ..MonitorParams::default() }).unwrap();
        let r = run(&mut m, &[ra, c], &pts);
        assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "{cells} m cells: {:?}", r[0].sensor);
        assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "{cells} m cells: {:?}", r[1].sensor);
    }
}

mod guarantee {
    use super::*;
    use pmon_monitor::theory::dx_min_m;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 300, .. ProptestConfig::default() })]

        /// An object reported `d >= dx_min` from where it is (any position, heading, size and direction) never
        /// stays consistent while the evidence it left is reported beside it as a missed object: the evidence
        /// is attributed to it. (Towards the sensor, all of its evidence may still lie in its region: then it
        /// is consistent with no missed object, and the next property applies.)
        #[test]
        fn displaced_object_never_leaves_its_evidence_to_a_missed_object(
            range in 6.0f32..30.0,
            bearing in -3.1f32..3.1,
            heading in -3.1f32..3.1,
            length in 0.4f32..6.0,
            width in 0.4f32..2.5,
            direction in -3.1f32..3.1,
            extra in 0.001f32..1.0,
            cell in prop_oneof![Just(0.5f32), Just(0.2f32)],
        ) {
            let params = MonitorParams { cell_size_m: cell, ..MonitorParams::default() };
            let mut m = Monitor::new(params).unwrap();
            prop_assume!(range > 0.5 * length.hypot(width) + 2.0);
            let truth = object(1, range * bearing.cos(), range * bearing.sin(), heading, length, width);
            let u = params.default_uncertainty;
            let bound = dx_min_m(cell, params.safety_margin_m, params.gamma_sens, pmon_monitor::region::delta_b(&u, heading));
            let d = bound + extra;
            let reported = pmon_monitor::ObjectState {
                x_m: truth.x_m + d * direction.cos(),
                y_m: truth.y_m + d * direction.sin(),
                ..truth
            };
            prop_assume!(reported.x_m.hypot(reported.y_m) > 0.5 * length.hypot(width) + 1.0);
            let mut pts = visible_face_points(&truth, 0.05);
            pts.extend(ground_points(45.0));
            let (reports, missed) = run_frame(&mut m, &[reported], &pts);
            let r = reports[0];
            prop_assert!(
                !(r.sensor.verdict == SensorVerdict::Consistent && missed > 0),
                "d {d:.2} (dx_min {bound:.2}): consistent with {missed} missed objects beside it: {:?}", r.sensor
            );
        }

        /// Towards the sensor (the paper's blind spot): an object reported nearer than it is by more than 0.8
        /// of its own extent along that direction plus its margin stands in front of its evidence, in space the
        /// rays prove empty, and is flagged (`position_error`), whatever the cell size: also while that
        /// evidence still lies inside its grown region.
        #[test]
        fn displacement_towards_the_sensor_is_seen_through(
            range in 8.0f32..30.0,
            bearing in -3.1f32..3.1,
            heading in -3.1f32..3.1,
            length in 0.4f32..6.0,
            width in 0.4f32..2.5,
            spread in -0.35f32..0.35,
            extra in 0.05f32..1.0,
            cell in prop_oneof![Just(0.5f32), Just(0.2f32), Just(0.1f32)],
        ) {
            let params = MonitorParams { cell_size_m: cell, ..MonitorParams::default() };
            let mut m = Monitor::new(params).unwrap();
            let truth = object(1, range * bearing.cos(), range * bearing.sin(), heading, length, width);
            let region = m.region_of(&truth).unwrap();
            let direction = bearing + core::f32::consts::PI + spread;
            let t = direction - heading;
            let extent = (length * t.cos()).abs() + (width * t.sin()).abs();
            // Its evidence leaves the grown region only beyond `extent + margin`; the rays prove the footprint
            // empty from about `0.8 extent + margin` on (the test's sample points sit at 0.6 of the half sizes).
            let d = 0.8 * extent + region.margin_length_m.max(region.margin_width_m) + extra;
            let reported = pmon_monitor::ObjectState {
                x_m: truth.x_m + d * direction.cos(),
                y_m: truth.y_m + d * direction.sin(),
                ..truth
            };
            prop_assume!(reported.x_m.hypot(reported.y_m) > 0.5 * length.hypot(width) + 2.0);
            // The rays through the box must end on its evidence: the box's sideways offset from the ray to the
            // object, `d |sin(spread)|`, leaves the rays through its central sample points (0.6 of its half
            // extent across the ray) on the evidence. (A 3.7 m x 0.4 m box along the ray, moved 3.4 m towards the
            // sensor 0.15 rad off the ray, stands 0.5 m beside it: its rays pass beside the 0.4 m face and prove
            // nothing. This assumption was added when proptest found that case; the rule is unchanged.)
            let across = (length * (bearing - heading).sin()).abs() + (width * (bearing - heading).cos()).abs();
            prop_assume!(d * spread.sin().abs() <= 0.2 * across);
            let mut pts = visible_face_points(&truth, 0.05);
            pts.extend(ground_points(45.0));
            let r = run(&mut m, &[reported], &pts)[0];
            prop_assert!(
                matches!(r.sensor.verdict, SensorVerdict::PositionError | SensorVerdict::Ghost),
                "towards by {d:.2} (extent {extent:.2}) not flagged: {:?}", r.sensor
            );
        }
    }
}

/// A street seen from an ego driving at 10 m/s: a parked car 28 m ahead (4.5 m long, its length along the ray), an
/// unlabelled post just beyond it, and a pedestrian crossing at 1.5 m/s, two sweeps 0.1 s apart. Returns the objects in the ego frame at `t_s`
/// (the car displaced by `car_error_m` away from the ego, the pedestrian by `ped_error_m`), the points and the pose.
fn street_at(t_s: f32, car_error_m: f32, ped_error_m: f32) -> Scene {
    let ego_x = 10.0 * t_s;
    let mut car = object(1, 30.0 - ego_x, 3.0, 0.05, 4.5, 1.8);
    let mut ped = object(2, 20.0 - ego_x, -4.0 + 1.5 * t_s, core::f32::consts::FRAC_PI_2, 0.6, 0.6);
    ped.class = pmon_monitor::ObjectClass::Pedestrian;
    ped.speed_mps = 1.5;
    let mut pts = visible_face_points(&car, 0.05);
    pts.extend(visible_face_points(&ped, 0.05));
    // A post 1.75 m beyond the car's front, unlabelled: the displaced car's region reaches it.
    pts.extend(visible_face_points(&object(9, 34.0 - ego_x, 3.1, 0.0, 0.3, 0.3), 0.05));
    pts.extend(ground_points(45.0));
    for (o, e) in [(&mut car, car_error_m), (&mut ped, ped_error_m)] {
        let r = o.x_m.hypot(o.y_m);
        o.x_m += e * o.x_m / r;
        o.y_m += e * o.y_m / r;
    }
    (vec![car, ped], pts, Pose2 { x_m: f64::from(ego_x), y_m: 0.0, yaw_rad: 0.0 })
}

fn check_at(
    m: &mut Monitor,
    t_s: f32,
    objects: &[pmon_monitor::ObjectState],
    pts: &[[f32; 3]],
    pose: Pose2,
) -> Vec<ObjectReport> {
    let pts = to_sensor(pts);
    let frame = Frame {
        timestamp_s: f64::from(t_s),
        world_from_ego: pose,
        objects,
        cloud: Some(PointCloud { points_in_sensor: &pts, ego_from_sensor: extrinsic() }),
        roi_in_ego: &[],
        static_in_ego: &[],
    };
    m.check(&frame).unwrap().objects.to_vec()
}

/// A scene of one sweep: the objects, the points (ego frame) and the pose, as [`street_at`] and [`post_at`] give it.
type Scene = (Vec<pmon_monitor::ObjectState>, Vec<[f32; 3]>, Pose2);

/// Step 9's two sweeps 0.1 s apart with one monitor: `first` at 0 s, where every object must be consistent (the
/// clean sweep), then `second` at 0.1 s; returns the second sweep's reports.
fn after_clean_sweep(params: MonitorParams, first: Scene, second: Scene) -> Vec<ObjectReport> {
    let mut m = Monitor::new(params).unwrap();
    let (objects, pts, pose) = first;
    let r0 = check_at(&mut m, 0.0, &objects, &pts, pose);
    assert!(r0.iter().all(|r| r.sensor.verdict == SensorVerdict::Consistent), "{r0:?}");
    let (objects, pts, pose) = second;
    check_at(&mut m, 0.1, &objects, &pts, pose)
}

/// Issue #10, evidence that follows its object: a car reported 2 m further away than it stands keeps most of its
/// own returns inside its grown region (it is longer than the error), so one frame confirms it (the returns left
/// outside do not fit the car together with the post its region now covers, so they do not spill over to it). With the previous
/// sweep, where the car was reported right, its evidence is expected where the car's stated motion puts it; the
/// box jumped away from it and the evidence did not follow: a position error, and it stays one while the error
/// persists (the track is then remembered as displaced, step 4). The same sweeps with the boxes
/// right, or off by less than the two frames' uncertainty allows, raise nothing, and the walking pedestrian,
/// predicted by its own speed, stays consistent.
#[test]
fn a_box_that_jumps_away_from_evidence_that_stayed_is_a_position_error() {
    for cells in [0.5, 0.2] {
        let params = MonitorParams { cell_size_m: cells, ..MonitorParams::default() };
        let (clean0, pts0, pose0) = street_at(0.0, 0.0, 0.0);
        // One frame alone: the displaced car is confirmed by its own returns (what the experiment measured so far).
        let mut m = Monitor::new(params).unwrap();
        let (moved, pts1, pose1) = street_at(0.1, 2.0, 0.0);
        let r = check_at(&mut m, 0.1, &moved, &pts1, pose1);
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{cells} m cells, no history: {:?}", r[0].sensor);
        // With the previous sweep: flagged, the offset pointing from its evidence back to the box.
        for (car_error, ped_error, car_flagged) in
            [(2.0, 0.0, true), (0.0, 0.0, false), (0.3, 0.0, false), (0.0, 0.3, false)]
        {
            let mut m = Monitor::new(params).unwrap();
            let r0 = check_at(&mut m, 0.0, &clean0, &pts0, pose0);
            assert!(r0.iter().all(|r| r.sensor.verdict == SensorVerdict::Consistent), "{cells} m cells: {r0:?}");
            let (objects, pts, pose) = street_at(0.1, car_error, ped_error);
            let r = check_at(&mut m, 0.1, &objects, &pts, pose);
            let want = if car_flagged { SensorVerdict::PositionError } else { SensorVerdict::Consistent };
            assert_eq!(r[0].sensor.verdict, want, "{cells} m cells, car off by {car_error} m: {:?}", r[0].sensor);
            assert_eq!(
                r[1].sensor.verdict,
                SensorVerdict::Consistent,
                "{cells} m cells, pedestrian: {:?}",
                r[1].sensor
            );
            if car_flagged {
                // Step 3c hands it the evidence it left behind, a cluster outside its region.
                assert_eq!(r[0].sensor.position_cause, Some(PositionCause::DisplacedEvidence), "{:?}", r[0].sensor);
                // From where the evidence puts the car to the reported box: about the 2 m along the ray.
                let o = r[0].sensor.offset_m;
                assert!(o[0] > 1.4 && o[0] < 2.6 && o[1].abs() < 0.6, "{o:?}");
                // The error persists: the track is remembered as displaced and its evidence followed.
                for k in 2..5 {
                    let t = 0.1 * k as f32;
                    let (objects, pts, pose) = street_at(t, car_error, ped_error);
                    let r = check_at(&mut m, t, &objects, &pts, pose);
                    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "{cells} m cells, sweep {k}");
                    assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "{cells} m cells, sweep {k}");
                }
            }
        }
    }
}

/// Step 9 from the returns (params key `jump_from_returns`): the same street, the parked car reported right in one
/// sweep and 1 m further away in the next, its returns where they were. With 0.5 m cells the cells' centres allow
/// 1.2 m (half a cell of rounding in each sweep), so the jump is left to the one-frame rules, which confirm the
/// car; the returns' mean allows 0.9 m, and the box is a position error, the offset pointing from where its
/// evidence puts it back to the box. Jumps a box's stated uncertainty allows over two sweeps (0.3 m one way in
/// the first and 0.3 m the other way in the next), 0.3 m errors of either object, and the walking pedestrian
/// predicted by its own speed raise nothing with the key; a single sweep (no history) is the same with it.
#[test]
fn a_box_that_jumps_1_m_from_returns_that_stayed_is_caught_by_their_mean() {
    // The default: step 9 from each cell's first return; `sums`: from all the returns; `off`: the cells' centres
    // only (the default before issue #10; the first-return key alone changes nothing: `off_first`).
    let on = MonitorParams::default();
    let sums = MonitorParams { jump_first_return: false, ..on };
    let off = MonitorParams { jump_from_returns: false, jump_first_return: false, ..on };
    let off_first = MonitorParams { jump_from_returns: false, ..on };
    let verdicts = |params: MonitorParams, first: (f32, f32), second: (f32, f32)| {
        after_clean_sweep(params, street_at(0.0, first.0, first.1), street_at(0.1, second.0, second.1))
    };
    // The jump of 1 m: confirmed by the cells, a position error by the returns.
    for params in [off, off_first] {
        let r = verdicts(params, (0.0, 0.0), (1.0, 0.0));
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "without the key: {:?}", r[0].sensor);
    }
    for params in [on, sums] {
        let r = verdicts(params, (0.0, 0.0), (1.0, 0.0));
        let first = params.jump_first_return;
        assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "with the key ({first}): {:?}", r[0].sensor);
        assert_eq!(r[0].sensor.position_cause, Some(PositionCause::JumpedFromEvidence), "{:?}", r[0].sensor);
        let o = r[0].sensor.offset_m;
        assert!(o[0] > 0.7 && o[0] < 1.3 && o[1].abs() < 0.3, "offset {o:?} ({first})");
        assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "pedestrian ({first}): {:?}", r[1].sensor);
    }
    // Noise-like jumps and small errors: nothing, with the key as without it.
    for (first, second) in
        [((-0.3, 0.0), (0.3, 0.0)), ((0.0, 0.0), (0.3, 0.0)), ((0.0, 0.0), (0.0, 0.3)), ((0.0, -0.3), (0.0, 0.3))]
    {
        for params in [off, on, sums] {
            let r = verdicts(params, first, second);
            assert!(
                r.iter().all(|r| r.sensor.verdict == SensorVerdict::Consistent),
                "{first:?} then {second:?}, key {}: {r:?}",
                params.jump_from_returns
            );
        }
    }
    // No history: a single sweep is judged the same with the key.
    for params in [off, on, sums] {
        let mut m = Monitor::new(params).unwrap();
        let (objects, pts, pose) = street_at(0.1, 1.0, 0.0);
        let r = check_at(&mut m, 0.1, &objects, &pts, pose);
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "one sweep, key {}", params.jump_from_returns);
    }
}

/// A parked object seen from an ego driving at 10 m/s, two sweeps 0.1 s apart: a 1.6 m x 1.6 m box, turned 0.4 rad,
/// 25 m ahead and 4 m to the right, whose returns come from a 0.6 m x 0.6 m post at its centre (a box larger than
/// its evidence, as labels of partly seen objects are), and the walking pedestrian of [`street_at`]. The box is
/// reported off by `box_m` along and across itself, the pedestrian by `ped_m` along and across its own box.
fn post_at(t_s: f32, box_m: [f32; 2], ped_m: [f32; 2]) -> Scene {
    post_shifted_at(t_s, box_m, ped_m, [0.0; 2])
}

/// [`post_at`] with the post's returns shifted by `post_m` along and across the box (the labelled box stays where
/// [`post_at`] puts it): returns that came some way in a sweep.
fn post_shifted_at(t_s: f32, box_m: [f32; 2], ped_m: [f32; 2], post_m: [f32; 2]) -> Scene {
    let ego_x = 10.0 * t_s;
    let mut post = object(1, 25.0 - ego_x, -4.0, 0.4, 1.6, 1.6);
    post.class = pmon_monitor::ObjectClass::Unknown;
    let mut ped = object(2, 20.0 - ego_x, 4.0 + 1.5 * t_s, core::f32::consts::FRAC_PI_2, 0.6, 0.6);
    ped.class = pmon_monitor::ObjectClass::Pedestrian;
    ped.speed_mps = 1.5;
    let (s, c) = post.heading_rad.sin_cos();
    let at = [post.x_m + post_m[0] * c - post_m[1] * s, post.y_m + post_m[0] * s + post_m[1] * c];
    let mut pts = visible_face_points(&object(9, at[0], at[1], 0.4, 0.6, 0.6), 0.05);
    pts.extend(visible_face_points(&ped, 0.05));
    pts.extend(ground_points(45.0));
    for (o, d) in [(&mut post, box_m), (&mut ped, ped_m)] {
        let (s, c) = o.heading_rad.sin_cos();
        o.x_m += d[0] * c - d[1] * s;
        o.y_m += d[0] * s + d[1] * c;
    }
    (vec![post, ped], pts, Pose2 { x_m: f64::from(ego_x), y_m: 0.0, yaw_rad: 0.0 })
}

/// Step 9's diagonal test (params key `jump_from_returns`): a box reported right in one sweep and 1 m off
/// diagonally to it in the next (0.71 m along and 0.71 m across it, under the returns' 0.9 m allowance along each
/// axis, away from the sensor), its returns where they were and still inside its grown region (one frame confirms it): consistent
/// without the key, a position error with it (its returns stand where the prediction puts them, and the jump
/// reaches beyond the allowance's ellipse), the offset pointing from where the returns put the box back to it.
/// Noise at the corners of two frames' stated uncertainty (0.3 m along and across one way in the first sweep, the
/// other way in the next: a 0.85 m diagonal jump, within the ellipse) raises nothing, for the box or the walking
/// pedestrian.
#[test]
fn a_box_that_jumps_1_m_diagonally_from_returns_that_stayed_is_a_position_error() {
    // The default (each cell's first return) and the cells' centres only (the default before issue #10).
    let on = MonitorParams::default();
    let off = MonitorParams { jump_from_returns: false, jump_first_return: false, ..on };
    let verdicts = |params: MonitorParams, first: ([f32; 2], [f32; 2]), second: ([f32; 2], [f32; 2])| {
        after_clean_sweep(params, post_at(0.0, first.0, first.1), post_at(0.1, second.0, second.1))
    };
    let k = core::f32::consts::FRAC_1_SQRT_2;
    // Away from the sensor along the box and to either side (towards the sensor the free-space test of one sweep
    // already sees through the box).
    for d in [[k, k], [k, -k]] {
        // One sweep alone confirms the displaced box.
        for params in [off, on] {
            let mut m = Monitor::new(params).unwrap();
            let (objects, pts, pose) = post_at(0.1, d, [0.0; 2]);
            let r = check_at(&mut m, 0.1, &objects, &pts, pose);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{d:?}, one sweep: {:?}", r[0].sensor);
        }
        let r = verdicts(off, ([0.0; 2], [0.0; 2]), (d, [0.0; 2]));
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{d:?} without the key: {:?}", r[0].sensor);
        let r = verdicts(on, ([0.0; 2], [0.0; 2]), (d, [0.0; 2]));
        assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "{d:?} with the key: {:?}", r[0].sensor);
        assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "{d:?}, pedestrian: {:?}", r[1].sensor);
        // The offset: the 1 m displacement, in ego axes.
        let (s, c) = 0.4f32.sin_cos();
        let want = [d[0] * c - d[1] * s, d[0] * s + d[1] * c];
        let o = r[0].sensor.offset_m;
        assert!((o[0] - want[0]).hypot(o[1] - want[1]) < 0.3, "{d:?}: offset {o:?}, displaced by {want:?}");
    }
    for which in [0usize, 1] {
        for (a, b) in [([-0.3, -0.3], [0.3, 0.3]), ([0.3, -0.3], [-0.3, 0.3]), ([0.0; 2], [0.3, 0.3])] {
            let pick = |d: [f32; 2], o: usize| if o == which { d } else { [0.0; 2] };
            for params in [off, on] {
                let r = verdicts(params, (pick(a, 0), pick(a, 1)), (pick(b, 0), pick(b, 1)));
                assert!(
                    r.iter().all(|r| r.sensor.verdict == SensorVerdict::Consistent),
                    "object {which}, {a:?} then {b:?}, key {}: {r:?}",
                    params.jump_from_returns
                );
            }
        }
    }
}

/// Step 9's diagonal test takes returns standing where the prediction puts them as the evidence that stayed
/// (params key `jump_evidence_at_prediction`, the default since issue #10): the post of [`post_at`] reported right
/// in one sweep and 1 m off diagonally in the next, its returns 0.25 m the box's way in that sweep (within the
/// returns' scatter, `3 delta_safe`, of the prediction). The box is then 0.75 m from where the returns put it,
/// inside the allowance's ellipse (0.9 m), so without the key (which also asks the box to be beyond the ellipse
/// from there) it stays consistent; with it, the 1 m jump from the prediction makes it a position error. Returns
/// that came half way with the box (0.5 m) did not stay: nothing with either, and nothing for the walking
/// pedestrian.
#[test]
fn a_box_that_jumps_1_m_diagonally_from_returns_at_its_prediction_is_a_position_error() {
    let on = MonitorParams::default();
    let off = MonitorParams { jump_evidence_at_prediction: false, ..on };
    let verdicts = |params: MonitorParams, second: [f32; 2], post: [f32; 2]| {
        after_clean_sweep(params, post_at(0.0, [0.0; 2], [0.0; 2]), post_shifted_at(0.1, second, [0.0; 2], post))
    };
    let k = core::f32::consts::FRAC_1_SQRT_2;
    for d in [[k, k], [k, -k]] {
        let came = |f: f32| [f * d[0], f * d[1]];
        let r = verdicts(off, d, came(0.25));
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{d:?} without the key: {:?}", r[0].sensor);
        let r = verdicts(on, d, came(0.25));
        assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "{d:?} with the key: {:?}", r[0].sensor);
        assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "{d:?}, pedestrian: {:?}", r[1].sensor);
        for params in [off, on] {
            let r = verdicts(params, d, came(0.5));
            assert!(
                r.iter().all(|r| r.sensor.verdict == SensorVerdict::Consistent),
                "{d:?}, returns half way, key {}: {r:?}",
                params.jump_evidence_at_prediction
            );
        }
    }
}

/// Two labels on one car (an annotation or tracker duplicate): the street of [`street_at`], without its post, with
/// a second box where the car stands, in both sweeps. In the second sweep the first label jumps 1 m away from the car's returns; the
/// second stays. Step 9 leaves out cells that stand in another object's box (a neighbour that moved onto the
/// place is no evidence that the track's evidence stayed), which here leaves out the car's own returns: without
/// the params key `jump_coincident_boxes` the jumped label stays consistent. With it (the default since issue
/// #10) a box reported where the track's predicted box stands counts as the same place, and the label that
/// jumped is a position error; the pedestrian stays consistent and the label that stayed is not flagged (it is
/// `not_monitored(occluded)` in every sweep: its place is taken by returns the first label owns), as in sweeps
/// where neither label jumped or one moved by 0.3 m.
#[test]
fn a_label_that_jumps_away_from_its_twin_on_one_car_is_a_position_error() {
    let on = MonitorParams::default();
    let off = MonitorParams { jump_coincident_boxes: false, ..on };
    // The street without its post (which the label displaced 1 m would reach and take by spill-over).
    let with_twin = |t: f32, car_error: f32| {
        let (mut objects, _, pose) = street_at(t, 0.0, 0.0);
        let mut pts = visible_face_points(&objects[0], 0.05);
        pts.extend(visible_face_points(&objects[1], 0.05));
        pts.extend(ground_points(45.0));
        let mut twin = objects[0];
        twin.id = 3;
        objects.push(twin);
        let r = objects[0].x_m.hypot(objects[0].y_m);
        let (ux, uy) = (objects[0].x_m / r, objects[0].y_m / r);
        objects[0].x_m += car_error * ux;
        objects[0].y_m += car_error * uy;
        (objects, pts, pose)
    };
    let verdicts = |params: MonitorParams, car_error: f32| {
        let mut m = Monitor::new(params).unwrap();
        let (objects, pts, pose) = with_twin(0.0, 0.0);
        let r0 = check_at(&mut m, 0.0, &objects, &pts, pose);
        // The first label owns the car's returns (ties go to the lower index); the second, its place taken by
        // them, is not flagged (`not_monitored(occluded)`: the two cannot be told apart in one sweep).
        assert!(r0[..2].iter().all(|r| r.sensor.verdict == SensorVerdict::Consistent), "{r0:?}");
        let twin = r0[2].sensor.verdict;
        assert!(!matches!(twin, SensorVerdict::PositionError | SensorVerdict::Ghost), "{r0:?}");
        let (objects, pts, pose) = with_twin(0.1, car_error);
        (check_at(&mut m, 0.1, &objects, &pts, pose), twin)
    };
    let (r, _) = verdicts(off, 1.0);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "without the key: {:?}", r[0].sensor);
    let (r, twin) = verdicts(on, 1.0);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "with the key: {:?}", r[0].sensor);
    let o = r[0].sensor.offset_m;
    assert!(o[0] > 0.7 && o[0] < 1.3 && o[1].abs() < 0.3, "offset {o:?}");
    assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "pedestrian: {:?}", r[1].sensor);
    assert!(!matches!(r[2].sensor.verdict, SensorVerdict::PositionError | SensorVerdict::Ghost), "{:?}", r[2]);
    assert!(matches!(twin, SensorVerdict::NotMonitored(_)), "the label that stayed, clean sweep: {twin:?}");
    for params in [off, on] {
        for err in [0.0, 0.3] {
            let (r, _) = verdicts(params, err);
            assert!(
                r[..2].iter().all(|r| r.sensor.verdict == SensorVerdict::Consistent)
                    && !matches!(r[2].sensor.verdict, SensorVerdict::PositionError | SensorVerdict::Ghost),
                "label off by {err} m, key {}: {r:?}",
                params.jump_coincident_boxes
            );
        }
    }
}

/// A post with a 1 m wide object 1.5 m in front of it along the ray (returns of both in the cloud) and an unlabelled
/// post 1.5 m behind it, the two labelled ones reported 1.5 m further away in the second sweep, as when every box of
/// a frame is displaced at once: the nearer object's box now stands over the post's returns, and the post's box on
/// the unlabelled post (one sweep alone confirms it). Step 9 leaves out cells inside another object's box, except, with
/// the params key `jump_jumped_boxes` (the default), the box of a track that itself jumped from its prediction: the
/// post is then a position error; without the key its returns count as the nearer object's and it stays unflagged.
/// Boxes right, or 0.3 m off, raise nothing either way.
#[test]
fn returns_under_a_neighbour_box_that_jumped_too_count_for_step_9() {
    let on = MonitorParams::default();
    let off = MonitorParams { jump_jumped_boxes: false, ..on };
    let posts = |error: f32| {
        // On the middle of a row of 0.5 m cells, so that every cell of the farther post's returns lies inside the
        // nearer object's box once that box moved 1.5 m; the nearer one 1 m wide, so that its box does not stand
        // in one place with the farther post's predicted box (`jump_coincident_boxes` would count its cells).
        let (far, near) = (object(1, 20.0, 0.25, 0.0, 0.6, 0.4), object(2, 18.5, 0.25, 0.0, 0.6, 1.0));
        let mut pts = visible_face_points(&far, 0.05);
        pts.extend(visible_face_points(&near, 0.05));
        // An unlabelled post 1.5 m behind the farther one: the farther box, displaced, stands on it and is confirmed by
        // it (one sweep alone judges it consistent), so only step 9 can tell.
        pts.extend(visible_face_points(&object(9, 21.5, 0.25, 0.0, 0.6, 0.4), 0.05));
        pts.extend(ground_points(45.0));
        let mut objects = vec![far, near];
        for o in &mut objects {
            let r = o.x_m.hypot(o.y_m);
            o.x_m += error * o.x_m / r;
            o.y_m += error * o.y_m / r;
        }
        (objects, pts, Pose2 { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 })
    };
    let second = |params: MonitorParams, error: f32| after_clean_sweep(params, posts(0.0), posts(error));
    let alarm = |r: &ObjectReport| matches!(r.sensor.verdict, SensorVerdict::PositionError | SensorVerdict::Ghost);
    let r = second(off, 1.5);
    assert!(!alarm(&r[0]), "without the key: {:?}", r[0].sensor);
    let r = second(on, 1.5);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "with the key: {:?}", r[0].sensor);
    for params in [off, on] {
        for error in [0.0, 0.3] {
            let r = second(params, error);
            assert!(!r.iter().any(alarm), "posts off by {error} m, key {}: {r:?}", params.jump_jumped_boxes);
        }
    }
}

/// A ray-cast sweep from the sensor of [`extrinsic`] over axis-aligned boxes `[x0, y0, x1, y1, top]` standing on
/// the ground (and the ground itself): beams every 0.2 degrees from -15 to +2 degrees of elevation, every 0.1
/// degrees of azimuth from -30 to +30 degrees. Returns the first hit of each ray within 60 m, ego frame.
fn ray_cast(boxes: &[[f32; 5]]) -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    for e in 0..=85 {
        let elevation = (-15.0f32 + 0.2 * e as f32).to_radians();
        for a in 0..=600 {
            let azimuth = (-30.0f32 + 0.1 * a as f32).to_radians();
            let d = [elevation.cos() * azimuth.cos(), elevation.cos() * azimuth.sin(), elevation.sin()];
            let o = [0.0f32, 0.0, SENSOR_HEIGHT_M];
            let mut best = if d[2] < 0.0 { -o[2] / d[2] } else { f32::INFINITY };
            for b in boxes {
                // Slabs along x, y and z.
                let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
                for (axis, (lo, hi)) in [(b[0], b[2]), (b[1], b[3]), (0.0, b[4])].into_iter().enumerate() {
                    if d[axis].abs() < 1e-9 {
                        if o[axis] < lo || o[axis] > hi {
                            t0 = f32::INFINITY;
                        }
                        continue;
                    }
                    let (ta, tb) = ((lo - o[axis]) / d[axis], (hi - o[axis]) / d[axis]);
                    t0 = t0.max(ta.min(tb));
                    t1 = t1.min(ta.max(tb));
                }
                if t0 <= t1 && t0 < best {
                    best = t0;
                }
            }
            if best < 60.0 {
                out.push([o[0] + best * d[0], o[1] + best * d[1], o[2] + best * d[2]]);
            }
        }
    }
    out
}

/// Seen over the occluder (params key `seen_over`): a pedestrian 15 m ahead stands behind a parked car 1.5 m
/// high, 6-10 m ahead, and the LiDAR sees its upper body over the car's roof. Reported 1 m nearer the sensor, its
/// box keeps its evidence inside its grown region, and every point of the box lies in the car's shadow on the 2-D
/// visibility map: without `seen_over` the box is consistent. With it, the rays that reached the pedestrian crossed
/// the box at 1.4 m, below its evidence's top: position error. Reported where it stands, it stays consistent; and
/// behind a car so tall that only the top 7 cm of the pedestrian show, the rays may have passed over a shorter
/// body at the box: no alarm either.
#[test]
fn a_box_displaced_towards_the_sensor_is_seen_over_a_parked_car() {
    let car = object(1, 8.0, 0.0, 0.0, 4.0, 2.0);
    let truth = object(2, 15.0, 0.0, 0.0, 0.6, 0.6);
    let mut displaced = truth;
    displaced.x_m -= 1.0;
    for (car_top, seen) in [(1.5f32, true), (1.72, false)] {
        let pts = ray_cast(&[[6.0, -1.0, 10.0, 1.0, car_top], [14.7, -0.3, 15.3, 0.3, 1.75]]);
        let on = MonitorParams { seen_over: true, ..MonitorParams::default() };
        for (params, want) in [(MonitorParams::default(), false), (on, seen)] {
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[car, displaced], &pts);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "car top {car_top}: {:?}", r[0].sensor);
            assert!(r[1].sensor.eta_own >= 0.8, "car top {car_top}: the box keeps its evidence: {:?}", r[1].sensor);
            let verdict = if want { SensorVerdict::PositionError } else { SensorVerdict::Consistent };
            assert_eq!(
                r[1].sensor.verdict, verdict,
                "car top {car_top}, seen_over {}: {:?}",
                params.seen_over, r[1].sensor
            );
            if want {
                assert_eq!(r[1].sensor.position_cause, Some(PositionCause::SeenThrough), "{:?}", r[1].sensor);
                // From the evidence (about 14.7-15 m) back to the box: about -0.5 to -1 m along x.
                assert!(r[1].sensor.offset_m[0] < -0.3 && r[1].sensor.offset_m[0] > -1.2, "{:?}", r[1].sensor.offset_m);
            }
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[car, truth], &pts);
            assert_eq!(
                r[1].sensor.verdict,
                SensorVerdict::Consistent,
                "car top {car_top}, at the truth: {:?}",
                r[1].sensor
            );
        }
    }
}

/// The near side seen through (params key `seen_through_near_side`, the default since issue #10's round of that
/// name): a car 18.05-22.45 m ahead, its length along the ray, reported 1.6 m nearer, and the same car broadside
/// (1.8 m deep) reported 1 m nearer. Each box keeps part of the car by the cells (it is confirmed), and of its
/// 3 x 3 sample points only the row on its near side lies in front of the car's face (0.6-0.7 m, more than the
/// 0.4 m the box may move along the ray): the majority of the free-space test is not reached, so without the key
/// the box is `consistent`; with it, a `position_error` with the cause `seen_through`. At the truth, and moved
/// within its margins (0.3 m towards the sensor, 0.3 m across), the car is consistent with the key.
#[test]
fn a_box_displaced_towards_the_sensor_by_less_than_its_depth_is_seen_through_its_near_side() {
    let off = MonitorParams { seen_through_near_side: false, ..MonitorParams::default() };
    let lengthwise = object(1, 20.25, 0.0, 0.0, 4.4, 1.8);
    let broadside = object(1, 20.9, 0.0, core::f32::consts::FRAC_PI_2, 4.4, 1.8);
    for (label, truth, body, shift) in [
        ("lengthwise", lengthwise, [18.05, -0.9, 22.45, 0.9, 1.5], 1.6f32),
        ("broadside", broadside, [20.0, -2.2, 21.8, 2.2, 1.5], 1.0),
    ] {
        let pts = ray_cast(&[body]);
        let mut towards = truth;
        towards.x_m -= shift;
        for (key, params, want) in
            [(true, MonitorParams::default(), SensorVerdict::PositionError), (false, off, SensorVerdict::Consistent)]
        {
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[towards], &pts);
            assert!(r[0].sensor.eta_own >= 0.8, "{label}: the box keeps evidence of its own: {:?}", r[0].sensor);
            assert_eq!(r[0].sensor.verdict, want, "{label}, key {key}: {:?}", r[0].sensor);
            if key {
                assert_eq!(r[0].sensor.position_cause, Some(PositionCause::SeenThrough), "{label}: {:?}", r[0].sensor);
                // From the evidence back to the box: towards the sensor by about the displacement.
                let [ox, oy] = r[0].sensor.offset_m;
                assert!((ox + shift).abs() < 0.3 && oy.abs() < 0.1, "{label}: offset {:?}", r[0].sensor.offset_m);
            }
        }
        for [dx, dy] in [[0.0f32, 0.0], [-0.3, 0.0], [0.0, 0.3], [0.0, -0.3]] {
            let mut at = truth;
            at.x_m += dx;
            at.y_m += dy;
            let mut m = Monitor::new(MonitorParams::default()).unwrap();
            let r = run(&mut m, &[at], &pts);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{label} moved ({dx}, {dy}): {:?}", r[0].sensor);
        }
    }
}

/// The face in front (params key `face_in_front`): a car 18-22.5 m ahead, reported 0.7 m further away. Its grown
/// region (margin 0.4 m) then begins at 18.35 m, and the cell of its face (18.0-18.5 m) overlaps it: by the cells,
/// the box keeps its evidence and is consistent (0.7 m is below `dx_min`). The rays say more: every return of the
/// car's face lies 0.3 m in front of the grown region. With the key, position error, the offset pointing from the
/// face back to the box (about +0.7 m along x); at the truth, and shifted sideways within its margin (0.3 m), the
/// car stays consistent.
#[test]
fn a_box_displaced_away_below_dx_min_is_caught_by_its_face_in_front() {
    let on = MonitorParams { face_in_front: true, ..MonitorParams::default() };
    let cases = [
        ("face_in_front false", MonitorParams::default(), SensorVerdict::Consistent),
        ("face_in_front true", on, SensorVerdict::PositionError),
    ];
    car_displaced_away_below_dx_min(&cases, 0.1, &[[0.0, 0.0], [0.0, 0.3]]);
}

/// The car of the two tests below dx_min, 18.05-22.45 m ahead, reported 0.7 m further away: for each case (a label,
/// the params, the verdict wanted), the displaced box keeps its evidence by the cells and gets the verdict, a position
/// error with its offset from the face back to the box (+0.5-0.8 m along x, less than `across` across); the car
/// shifted by each of `clean` (metres along x and y, within its margin) stays consistent.
fn car_displaced_away_below_dx_min(cases: &[(&str, MonitorParams, SensorVerdict)], across: f32, clean: &[[f32; 2]]) {
    let truth = object(1, 20.25, 0.0, 0.0, 4.4, 1.8);
    let pts = ray_cast(&[[18.05, -0.9, 22.45, 0.9, 1.5]]);
    let mut away = truth;
    away.x_m += 0.7;
    for &(label, params, want) in cases {
        let mut m = Monitor::new(params).unwrap();
        let r = run(&mut m, &[away], &pts);
        assert!(r[0].sensor.eta_own >= 0.8, "the box keeps its evidence by the cells: {:?}", r[0].sensor);
        assert_eq!(r[0].sensor.verdict, want, "{label}: {:?}", r[0].sensor);
        if want == SensorVerdict::PositionError {
            let cause = if params.face_in_front { PositionCause::FaceInFront } else { PositionCause::ReturnsBeyond };
            assert_eq!(r[0].sensor.position_cause, Some(cause), "{label}: {:?}", r[0].sensor);
            assert!(r[0].sensor.offset_m[0] > 0.5 && r[0].sensor.offset_m[0] < 0.8, "{:?}", r[0].sensor.offset_m);
            assert!(r[0].sensor.offset_m[1].abs() < across, "{:?}", r[0].sensor.offset_m);
        }
        for &[dx, dy] in clean {
            let mut at = truth;
            at.x_m += dx;
            at.y_m += dy;
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[at], &pts);
            assert_eq!(
                r[0].sensor.verdict,
                SensorVerdict::Consistent,
                "{label} at ({}, {}): {:?}",
                at.x_m,
                at.y_m,
                r[0].sensor
            );
        }
    }
}

/// Own returns beyond the grown region (params key `returns_beyond_cells`): the car of the test above, 18.05-22.45 m
/// ahead, reported 0.7 m further away. Its grown region (margin 0.4 m) begins at 18.35 m; the 0.5 m cells of its face
/// (18.0-18.5 m) overlap it, so by the cells it keeps its evidence (consistent: 0.7 m is below `dx_min`). The first
/// returns of those cells stand 0.3 m beyond the region: with the key (one or two cells), position error, the offset
/// from the face back to the box (about +0.7 m along x). At the truth, shifted sideways within its margin (0.3 m) or
/// away within it (0.3 m), the car stays consistent.
#[test]
fn a_box_displaced_away_below_dx_min_is_caught_by_its_returns_beyond_the_region() {
    let with = |n: u32| MonitorParams { returns_beyond_cells: n, ..MonitorParams::default() };
    let cases = [
        ("returns_beyond_cells 0", with(0), SensorVerdict::Consistent),
        ("returns_beyond_cells 1", with(1), SensorVerdict::PositionError),
        ("returns_beyond_cells 2", with(2), SensorVerdict::PositionError),
    ];
    car_displaced_away_below_dx_min(&cases, 0.3, &[[0.0, 0.0], [0.0, 0.3], [0.3, 0.0]]);
}

/// What `returns_beyond_cells = 1` gives up, and what it leaves out: the same car where it stands, with a thin post
/// 0.53 m in front of its face (17.50-17.56 m ahead, beside its axis), in the 0.5 m cell (17.5-18.0 m) that the car's
/// grown region (from 17.65 m) overlaps. Unlabelled, the post's returns are the car's by the cells and stand 0.1-0.15 m
/// beyond its region, and the car with the post still fits the car's length: one cell, so one cell flags the clean
/// car (the real-data cost measured in docs/attribution.md) and two do not. Labelled as an object of its own, the
/// post's returns lie in its region and are left out: the car stays consistent with one cell too.
#[test]
fn a_post_beside_a_clean_box_is_its_returns_beyond_unless_labelled() {
    let car = object(1, 20.25, 0.0, 0.0, 4.4, 1.8);
    let post = object(2, 17.53, 0.6, 0.0, 0.06, 0.1);
    let pts = ray_cast(&[[18.05, -0.9, 22.45, 0.9, 1.5], [17.50, 0.55, 17.56, 0.65, 1.5]]);
    for (n, objects, want) in [
        (1, vec![car], SensorVerdict::PositionError),
        (2, vec![car], SensorVerdict::Consistent),
        (1, vec![car, post], SensorVerdict::Consistent),
        (0, vec![car], SensorVerdict::Consistent),
    ] {
        let params = MonitorParams { returns_beyond_cells: n, ..MonitorParams::default() };
        let mut m = Monitor::new(params).unwrap();
        let r = run(&mut m, &objects, &pts);
        assert_eq!(r[0].sensor.verdict, want, "returns_beyond_cells {n}, {} objects: {:?}", objects.len(), r[0].sensor);
    }
}

/// What a cell's first return alone would flag and the whole cell does not: the clean car of the test above with
/// two thin posts in the one 0.5 m cell (17.5-18.0 m ahead, 0.5-1.0 m aside) in front of its face, like a bush
/// standing into its margin: the first, 17.50 m ahead (0.15 m beyond the grown region), gives the cell its first
/// return; the second, 17.62 m ahead, stands within `delta_safe` of the region (0.03 m beyond it). The cell is not
/// wholly beyond the region, so it is not counted, and the car stays consistent with one cell; without the second
/// post (the test above) the same first return flags it.
#[test]
fn a_cell_reaching_into_the_margin_of_a_clean_box_is_not_its_returns_beyond() {
    let car = object(1, 20.25, 0.0, 0.0, 4.4, 1.8);
    let pts =
        ray_cast(&[[18.05, -0.9, 22.45, 0.9, 1.5], [17.50, 0.55, 17.56, 0.65, 1.5], [17.62, 0.70, 17.68, 0.80, 1.5]]);
    let params = MonitorParams { returns_beyond_cells: 1, ..MonitorParams::default() };
    let mut m = Monitor::new(params).unwrap();
    let r = run(&mut m, &[car], &pts);
    assert!(r[0].sensor.eta_own >= 0.8, "confirmed by its own evidence: {:?}", r[0].sensor);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{:?}", r[0].sensor);
}

/// Seen over the occluder, but not by returns that came beside it: a pedestrian 30 m ahead stands behind another,
/// 20 m ahead, 1.75 m tall (the sensor is at 1.8 m, so nothing lower than 1.72 m at 30 m passed over it), and is
/// confirmed by the edge of it the sensor sees beside the nearer one. An unlisted pedestrian 0.3 m behind it shows
/// its legs beside both, in a 0.5 m cell the box's grown region owns. The box, reported where it stands (or 0.1 m
/// off, well within its 0.4 m margin), is consistent. Without condition (5) of `Monitor::seen_over` the lowest
/// of those returns (0.3 m high) stood for a ray that crossed the box's sample points at 0.4 m and found them
/// empty: a position error on a clean box (the cause of the sensor false alarms `seen_over` added on the full
/// plans of seeds 7 and 23, docs/attribution.md). The rays along the points' directions passed over the nearer
/// pedestrian, no lower than its shadow line, and that line lies above the returns' top less 0.2 m.
#[test]
fn a_box_is_not_seen_over_an_occluder_by_returns_that_came_beside_it() {
    let front = object(1, 20.2, 0.0, 0.0, 0.4, 0.5);
    let truth = object(2, 30.2, 0.05, 0.0, 0.6, 0.6);
    let pts =
        ray_cast(&[[20.0, -0.25, 20.4, 0.25, 1.75], [29.9, -0.25, 30.5, 0.35, 1.7], [30.8, -0.25, 31.3, 0.75, 1.75]]);
    for (dx, dy) in [(0.0f32, 0.0f32), (-0.1, 0.0), (0.0, 0.1), (-0.1, 0.1)] {
        let (mut a, mut b) = (front, truth);
        a.uncertainty = Some(sigma(0.1));
        b.uncertainty = Some(sigma(0.1));
        b.x_m += dx;
        b.y_m += dy;
        for seen_over in [false, true] {
            let mut m = Monitor::new(MonitorParams { seen_over, ..MonitorParams::default() }).unwrap();
            let r = run(&mut m, &[a, b], &pts);
            assert!(r[1].sensor.eta_own >= 0.8, "the box keeps its evidence: {:?}", r[1].sensor);
            assert_eq!(
                r[1].sensor.verdict,
                SensorVerdict::Consistent,
                "box off by ({dx}, {dy}), seen_over {seen_over}: {:?}",
                r[1].sensor
            );
        }
    }
}

/// Step 3c, evidence that stayed is its track's (issue #10: a displaced object's evidence blamed on its
/// neighbour). A pedestrian 20 m ahead, confirmed by its returns in one sweep, is reported 1 m further away in the
/// next while its returns stay where they were; a small labelled object beside those returns (one return of its
/// own: not confirmed by it) touches them with its grown region. By geometry alone the neighbour is nearer the
/// left-behind returns than the displaced box and takes them: the clean neighbour is a position error. With the
/// previous sweep, the returns stand where the pedestrian's own evidence should be (its reported motion: standing)
/// and its box jumped beyond its stated uncertainty: they are the pedestrian's, the pedestrian is the position
/// error and the neighbour keeps its verdict of the clean sweep. A jump within the stated uncertainty (0.3 m) and
/// the clean sweep twice change nothing.
#[test]
fn evidence_left_behind_by_a_jump_follows_its_track_not_a_touching_neighbour() {
    let scene = |ped_error_m: f32| {
        let mut ped = object(1, 20.0, 0.0, 0.0, 0.6, 0.6);
        ped.class = pmon_monitor::ObjectClass::Pedestrian;
        let mut pts = visible_face_points(&ped, 0.05);
        ped.x_m += ped_error_m;
        let post = object(2, 18.9, -0.25, 0.0, 0.3, 0.3);
        pts.push([18.9, -0.25, 0.8]);
        pts.extend(ground_points(45.0));
        (vec![ped, post], pts)
    };
    let pose = Pose2 { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
    let params = MonitorParams::default();
    let (clean, pts) = scene(0.0);
    let (jumped, _) = scene(1.0);
    // One sweep alone: the neighbour is blamed (what step 3c is for; if this changes, the test no longer tests it).
    let mut m = Monitor::new(params).unwrap();
    let r = check_at(&mut m, 0.1, &jumped, &pts, pose);
    assert_eq!(r[1].sensor.verdict, SensorVerdict::PositionError, "one sweep: {:?}", r[1].sensor);
    // After a clean sweep.
    let mut m = Monitor::new(params).unwrap();
    let r0 = check_at(&mut m, 0.0, &clean, &pts, pose);
    assert_eq!(r0[0].sensor.verdict, SensorVerdict::Consistent, "clean sweep: {:?}", r0[0].sensor);
    let r = check_at(&mut m, 0.1, &jumped, &pts, pose);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "the pedestrian: {:?}", r[0].sensor);
    let o = r[0].sensor.offset_m;
    assert!(o[0] > 0.6 && o[0] < 1.5 && o[1].abs() < 0.4, "offset from its evidence to the box: {o:?}");
    assert_eq!(r[1].sensor.verdict, r0[1].sensor.verdict, "the neighbour: {:?}", r[1].sensor);
    // Within the stated uncertainty, or no jump: the verdicts of the clean sweep.
    for e in [0.0, 0.3] {
        let (objects, _) = scene(e);
        let mut m = Monitor::new(params).unwrap();
        check_at(&mut m, 0.0, &clean, &pts, pose);
        let r = check_at(&mut m, 0.1, &objects, &pts, pose);
        let v: Vec<_> = r.iter().map(|r| r.sensor.verdict).collect();
        let v0: Vec<_> = r0.iter().map(|r| r.sensor.verdict).collect();
        assert_eq!(v, v0, "jump of {e} m");
    }
}

/// Rays that end on the body (params key `seen_body`; cause (c) of the sensor false alarms up to 0.3 m noise,
/// docs/attribution.md, "Rays that end on the body"). A pedestrian 10 m ahead (0.6 x 0.6 m, 1.75 m tall) with a
/// post 0.9 m behind its back, beside the line of sight, inside the grown region of a box with 0.3 m sigma (margin
/// 1.0 m). The box moved 0.6 m sideways (0.6 of its margin: a correct box by its stated uncertainty) has every
/// sample point beside the body: the rays through them end on the post, which the grown region owns, more than
/// the margin behind the box. Without the key that is a position error on a clean box; with it, the rays end
/// 0.9 m beyond the body's depth behind the nearest return of the object's own evidence (its front face): not its
/// body, no proof, consistent. A box reported 1.5 m nearer the sensor than the body, whose rays end on the body's
/// front face, stays a position error with the key; the box at its true place is consistent either way.
#[test]
fn rays_that_pass_beside_the_body_and_end_on_a_post_behind_it_prove_nothing() {
    let pts = ray_cast(&[[9.7, -0.3, 10.3, 0.3, 1.75], [11.2, 0.3, 11.4, 1.0, 1.5]]);
    let truth = pmon_monitor::ObjectState {
        class: pmon_monitor::ObjectClass::Pedestrian,
        uncertainty: Some(sigma(0.3)),
        ..object(1, 10.0, 0.0, 0.0, 0.6, 0.6)
    };
    let aside = pmon_monitor::ObjectState { y_m: 0.6, ..truth };
    let nearer = pmon_monitor::ObjectState { x_m: 8.5, ..truth };
    let on = MonitorParams { seen_body: true, ..before_two_rules() };
    let m = Monitor::new(on).unwrap();
    let region = m.region_of(&aside).unwrap();
    assert!((region.margin_width_m - 1.0).abs() < 1e-4, "{region:?}");
    // Without the key (the defaults before the round of rays on the body, and those before the round of two rules)
    // and with it (alone, and as the default since that round).
    for (params, aside_verdict) in [
        (before_body_rules(), SensorVerdict::PositionError),
        (before_two_rules(), SensorVerdict::PositionError),
        (on, SensorVerdict::Consistent),
        (MonitorParams::default(), SensorVerdict::Consistent),
    ] {
        let key = params.seen_body;
        let mut m = Monitor::new(params).unwrap();
        let r = run(&mut m, &[aside], &pts);
        assert!(r[0].sensor.eta_own >= 0.8, "seen_body {key}: the box keeps its evidence: {:?}", r[0].sensor);
        assert_eq!(r[0].sensor.verdict, aside_verdict, "seen_body {key}, moved aside: {:?}", r[0].sensor);
        let mut m = Monitor::new(params).unwrap();
        let r = run(&mut m, &[nearer], &pts);
        assert!(r[0].sensor.eta_own >= 0.8, "seen_body {key}: the box keeps its evidence: {:?}", r[0].sensor);
        assert_eq!(
            r[0].sensor.verdict,
            SensorVerdict::PositionError,
            "seen_body {key}, 1.5 m nearer: {:?}",
            r[0].sensor
        );
        let mut m = Monitor::new(params).unwrap();
        let r = run(&mut m, &[truth], &pts);
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "seen_body {key}, at the truth: {:?}", r[0].sensor);
    }
}

/// The two sweeps of `evidence_beyond_the_gate_does_not_flag_a_hidden_box` and
/// `follow_gate_stops_step_8_beyond_the_gate_and_leaves_step_6_alone`.
struct PostScene {
    /// A clean pedestrian 30 m out, hidden behind an unlisted post (0.3 m square) 20 m in front of it.
    hidden: pmon_monitor::ObjectState,
    /// A pedestrian whose true place is (14, -3), reported 1.5 m further away.
    displaced: pmon_monitor::ObjectState,
    /// Second sweep: neighbours whose wide margins (0.3 m sigma) explain the post and the displaced pedestrian's returns.
    beside_post: pmon_monitor::ObjectState,
    beside_truth: pmon_monitor::ObjectState,
    /// The returns of the post, the displaced pedestrian's true place and the ground; the second sweep adds the
    /// neighbours'.
    first: Vec<[f32; 3]>,
    second: Vec<[f32; 3]>,
}

fn post_scene() -> PostScene {
    let wide = sigma(0.3);
    let post = object(90, 10.15, 0.5, 0.0, 0.3, 0.3);
    let bearing = 0.5f32.atan2(10.15);
    let hidden = object(1, 30.0, 30.0 * bearing.tan(), 0.0, 0.6, 0.6);
    let truth = object(2, 14.0, -3.0, 0.0, 0.6, 0.6);
    let displaced = pmon_monitor::ObjectState { x_m: 15.5, ..truth };
    let beside_post = pmon_monitor::ObjectState { uncertainty: Some(wide), ..object(3, 10.1, 1.3, 0.0, 0.6, 0.6) };
    let beside_truth = pmon_monitor::ObjectState { uncertainty: Some(wide), ..object(4, 13.9, -2.2, 0.0, 0.6, 0.6) };
    let mut first = visible_face_points(&post, 0.05);
    first.extend(visible_face_points(&truth, 0.05));
    first.extend(ground_points(45.0));
    let mut second = first.clone();
    second.extend(visible_face_points(&beside_post, 0.05));
    second.extend(visible_face_points(&beside_truth, 0.05));
    PostScene { hidden, displaced, beside_post, beside_truth, first, second }
}

/// Evidence beyond the gate is never a box's (params key `memory_gate`). A clean pedestrian 30 m out, hidden
/// behind an unlisted post 10 m out (no returns of its own), and a pedestrian truly displaced 1.5 m away from its
/// returns, over two sweeps. In the first, the hidden box stands behind evidence nobody explains; without the key it
/// takes that evidence, 20 m in front of it, as its own (`position_error`). In the second a listed neighbour with a
/// wide margin arrives beside the post and explains it through its margin: without the key the evidence memory
/// (step 8) holds the hidden box displaced by those cells, 20 m away. With the key the hidden box is
/// `not_monitored(occluded)` in both sweeps, and the displaced pedestrian, whose evidence a second wide neighbour's
/// margin explains in the second sweep, stays a `position_error` in both with and without it (its evidence lies
/// within the gate).
#[test]
fn evidence_beyond_the_gate_does_not_flag_a_hidden_box() {
    let PostScene { hidden, displaced, beside_post, beside_truth, first, second } = post_scene();
    let occluded = SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::Occluded);
    for memory_gate in [false, true] {
        let mut m = Monitor::new(MonitorParams { memory_gate, ..before_two_rules() }).unwrap();
        let r = check_at(&mut m, 0.0, &[hidden, displaced], &first, Pose2::default());
        let (h, d) = (&r[0].sensor, &r[1].sensor);
        assert_eq!(d.verdict, SensorVerdict::PositionError, "key {memory_gate}, first sweep, displaced: {d:?}");
        if memory_gate {
            assert_eq!(h.verdict, occluded, "first sweep, hidden box behind the post: {h:?}");
        } else {
            // Today: the post's evidence, 20 m in front of the box, is taken as the box's own.
            assert_eq!(h.verdict, SensorVerdict::PositionError, "first sweep without the key: {h:?}");
            assert!(h.offset_m[0] > 15.0, "the offset points 20 m back to the post: {:?}", h.offset_m);
        }
        let r = check_at(&mut m, 0.1, &[hidden, displaced, beside_post, beside_truth], &second, Pose2::default());
        let (h, d) = (&r[0].sensor, &r[1].sensor);
        assert_eq!(r[2].sensor.verdict, SensorVerdict::Consistent, "neighbour of the post: {:?}", r[2].sensor);
        assert_eq!(r[3].sensor.verdict, SensorVerdict::Consistent, "neighbour of the truth: {:?}", r[3].sensor);
        assert_eq!(d.verdict, SensorVerdict::PositionError, "key {memory_gate}, second sweep, displaced: {d:?}");
        if memory_gate {
            assert_eq!(h.verdict, occluded, "second sweep, hidden box: {h:?}");
        } else {
            // Today: held displaced by cells 20 m away that the neighbour's margin explains (step 8).
            assert_eq!(h.verdict, SensorVerdict::PositionError, "second sweep without the key: {h:?}");
            assert!(h.cluster.is_none() && h.offset_m[0] > 15.0, "held by the memory: {h:?}");
        }
    }
}

/// `follow_gate`, the half of `memory_gate` that bounds step 8 alone (docs/attribution.md, "Rays on the body with
/// step 8 gated"): the same two sweeps as above. In the first the hidden pedestrian still takes the post's returns
/// 20 m in front of it (step 6 is not gated: a box displaced that far behind its own returns is still flagged); in
/// the second, where a neighbour's margin explains the post, step 8 no longer holds it by cells 20 m away, while
/// the pedestrian displaced 1.5 m is held by its returns in the other neighbour's margin.
#[test]
fn follow_gate_stops_step_8_beyond_the_gate_and_leaves_step_6_alone() {
    let PostScene { hidden, displaced, beside_post, beside_truth, first, second } = post_scene();
    let occluded = SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::Occluded);
    let mut m = Monitor::new(MonitorParams { release_flagged_claims: true, ..MonitorParams::default() }).unwrap();
    assert!(m.params().follow_gate, "the default since the round of rays on the body");
    let r = check_at(&mut m, 0.0, &[hidden, displaced], &first, Pose2::default());
    let (h, d) = (&r[0].sensor, &r[1].sensor);
    assert_eq!(d.verdict, SensorVerdict::PositionError, "first sweep, displaced: {d:?}");
    assert_eq!(h.verdict, SensorVerdict::PositionError, "first sweep, step 6 not gated: {h:?}");
    assert!(h.offset_m[0] > 15.0, "the offset points 20 m back to the post: {:?}", h.offset_m);
    let r = check_at(&mut m, 0.1, &[hidden, displaced, beside_post, beside_truth], &second, Pose2::default());
    let (h, d) = (&r[0].sensor, &r[1].sensor);
    assert_eq!(r[2].sensor.verdict, SensorVerdict::Consistent, "neighbour of the post: {:?}", r[2].sensor);
    assert_eq!(r[3].sensor.verdict, SensorVerdict::Consistent, "neighbour of the truth: {:?}", r[3].sensor);
    assert_eq!(d.verdict, SensorVerdict::PositionError, "second sweep, displaced: {d:?}");
    assert!(d.cluster.is_none(), "held by step 8, its returns in a neighbour's margin: {d:?}");
    assert_eq!(h.verdict, occluded, "second sweep, hidden box no longer held from 20 m: {h:?}");
    // Without the key (the defaults before that round) step 8 holds it.
    let mut m = Monitor::new(MonitorParams { follow_gate: false, ..MonitorParams::default() }).unwrap();
    check_at(&mut m, 0.0, &[hidden, displaced], &first, Pose2::default());
    let r = check_at(&mut m, 0.1, &[hidden, displaced, beside_post, beside_truth], &second, Pose2::default());
    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "held without the key: {:?}", r[0].sensor);
}

/// A free cluster in front of a confirmed box goes to it when the evidence that confirms the box is a piece of
/// something larger than it (params key `front_cluster`, on by default since the round "Two rules together";
/// docs/attribution.md, "One box displaced 2 m in a single sweep"; here alone, on the defaults before that round). A
/// car reported 2 m further away than it stands, in one sweep (no history): its rear face is a free cluster 1.6 m in
/// front of its displaced region, and the region's far corner covers the end of a wall that runs on for 7 m behind it.
/// The wall's cells confirm the box (it owns them) and the rear face alone fits the car, but the wall with it does not,
/// so spill-over refuses it: without the key the box is `consistent`, with it a `position_error` with the rear face.
/// The clean car, reported where it stands with an unlabelled object of its size 2 m in front of it, stays `consistent`
/// with the key: its own evidence ends within its box. (The later rounds' spill-over in front of the box with its near
/// side, `spill_in_front` and `spill_near_side`, off here as before those rounds, finds the same car without
/// `front_cluster`: the wall's cells stand beyond the box's centre, so the rear face alone is fitted.)
#[test]
fn a_box_confirmed_by_scenery_takes_the_cluster_of_its_shape_in_front_of_it() {
    let truth = object(1, 15.0, 0.0, 0.0, 4.5, 1.8);
    let mut pts = visible_face_points(&truth, 0.05);
    // The wall: along x at y = 1.45, from x = 18 to 25 (the displaced region reaches y = 1.3 and x = 19.65).
    let mut x = 18.0f32;
    while x <= 25.0 {
        for z in [0.5f32, 1.0, 1.5] {
            pts.push([x, 1.45, z]);
        }
        x += 0.05;
    }
    pts.extend(ground_points(45.0));
    let mut reported = truth;
    reported.x_m += 2.0;
    // Today's defaults without `front_cluster`: spill-over in front of the box takes the rear face.
    let mut m = Monitor::new(MonitorParams { front_cluster: false, ..MonitorParams::default() }).unwrap();
    let r = run(&mut m, &[reported], &pts);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "spill_near_side: {:?}", r[0].sensor);
    for front_cluster in [false, true] {
        let before = MonitorParams { spill_in_front: false, spill_near_side: false, ..before_two_rules() };
        let mut m = Monitor::new(MonitorParams { front_cluster, ..before }).unwrap();
        let r = run(&mut m, &[reported], &pts);
        let want = if front_cluster { SensorVerdict::PositionError } else { SensorVerdict::Consistent };
        assert_eq!(r[0].sensor.verdict, want, "key {front_cluster}: {:?}", r[0].sensor);
        if front_cluster {
            // The offset points from the rear face back to the reported box: about +2 m plus half the car along x.
            assert!(r[0].sensor.offset_m[0] > 1.5 && r[0].sensor.offset_m[0] < 5.0, "{:?}", r[0].sensor.offset_m);
        }
        // The clean car, an unlabelled object of about its width 2 m in front of it.
        let crate_box = object(9, 10.2, 0.0, 0.0, 0.6, 1.8);
        let mut clean_pts = visible_face_points(&truth, 0.05);
        clean_pts.extend(visible_face_points(&crate_box, 0.05));
        clean_pts.extend(ground_points(45.0));
        let r = run(&mut m, &[truth], &clean_pts);
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "key {front_cluster}, clean: {:?}", r[0].sensor);
    }
}

/// Only evidence within reach contradicts a box it hides (params key `shadow_gate`, off by default;
/// docs/attribution.md, "The shadow of far evidence"). A clean pedestrian 30 m out, hidden behind an unlisted post 10 m
/// out (no returns of its own), with a small unlisted post 2 m beside it in plain sight. Without the key the box counts
/// as contradicted (its place lies behind evidence nobody explains, 20 m in front of it), is offered every cluster
/// within the full gate and takes the small post beside it (`position_error`). With the key the post 10 m out is too
/// far to be the box displaced: its footprint is merely hidden, and the small post is not its.
#[test]
fn far_evidence_in_front_does_not_open_the_gate_of_a_hidden_box() {
    let post = object(90, 10.15, 0.5, 0.0, 0.3, 0.3);
    let bearing = 0.5f32.atan2(10.15);
    let hidden = object(1, 30.0, 30.0 * bearing.tan(), 0.0, 0.6, 0.6);
    let beside = object(91, 30.0, hidden.y_m + 2.0, 0.0, 0.2, 0.2);
    let mut pts = visible_face_points(&post, 0.05);
    pts.extend(visible_face_points(&beside, 0.05));
    pts.extend(ground_points(45.0));
    for shadow_gate in [false, true] {
        let mut m = Monitor::new(MonitorParams { shadow_gate, ..before_two_rules() }).unwrap();
        let r = check_at(&mut m, 0.0, &[hidden], &pts, Pose2::default());
        let h = &r[0].sensor;
        eprintln!("shadow_gate {shadow_gate}: {h:?}");
        if shadow_gate {
            assert_ne!(h.verdict, SensorVerdict::PositionError, "with the key: {h:?}");
        } else {
            assert_eq!(h.verdict, SensorVerdict::PositionError, "without the key: {h:?}");
            assert!(h.offset_m[1].abs() > 0.8 && h.offset_m[0].abs() < 1.0, "the post beside it: {h:?}");
        }
    }
}

/// The other half of `shadow_gate`: a pedestrian displaced 1.8 m towards the sensor, whose place is hidden behind an
/// unlisted post 10 m out (the shadow the gate sets aside), while its own returns stand 1.8 m beyond the box on the
/// same bearing (seen over the post). Without the key the box is contradicted by the post's shadow and is offered
/// every cluster within the gate, and takes its own. With the key the post is beyond the gate and the box is merely
/// hidden, so it would be occluded; it takes the free evidence beyond it on its line of sight, within the gate, as
/// its displaced evidence: `position_error` either way, the offset about 1.5 m.
#[test]
fn a_box_hidden_behind_far_evidence_takes_the_free_evidence_beyond_it() {
    let post = object(90, 10.15, 0.5, 0.0, 0.3, 0.3);
    let bearing = 0.5f32.atan2(10.15);
    let (r_true, r_box) = (30.0f32, 28.2f32);
    let truth = object(1, r_true * bearing.cos(), r_true * bearing.sin(), 0.0, 0.6, 0.6);
    let shown = object(1, r_box * bearing.cos(), r_box * bearing.sin(), 0.0, 0.6, 0.6);
    let mut pts = visible_face_points(&post, 0.05);
    pts.extend(visible_face_points(&truth, 0.05));
    pts.extend(ground_points(45.0));
    for shadow_gate in [false, true] {
        let mut m = Monitor::new(MonitorParams { shadow_gate, ..before_two_rules() }).unwrap();
        let r = check_at(&mut m, 0.0, &[shown], &pts, Pose2::default());
        let h = &r[0].sensor;
        eprintln!("shadow_gate {shadow_gate}: {h:?}");
        assert_eq!(h.verdict, SensorVerdict::PositionError, "shadow_gate {shadow_gate}: {h:?}");
        let offset = h.offset_m[0].hypot(h.offset_m[1]);
        assert!((1.0..2.5).contains(&offset), "shadow_gate {shadow_gate}, its own returns beyond it: {h:?}");
    }
}

/// A column of returns across a car's width (one every 5 cm, three heights): the face the sensor sees.
fn face_column(x: f32, y_from: f32, width: f32) -> Vec<[f32; 3]> {
    line_of_returns(y_from, y_from + width, |y| [x, y])
}

/// Returns every 5 cm of `v` from `from` to `to` at the ground position `at(v)`, at heights 0.5, 1.0 and 1.5 m.
fn line_of_returns(from: f32, to: f32, at: impl Fn(f32) -> [f32; 2]) -> Vec<[f32; 3]> {
    let mut pts = Vec::new();
    let mut v = from;
    while v <= to + 1e-3 {
        let [x, y] = at(v);
        for z in [0.5f32, 1.0, 1.5] {
            pts.push([x, y, z]);
        }
        v += 0.05;
    }
    pts
}

/// The returns of a car seen along its length from the side at a grazing angle: its near face (x = `near`, across
/// its width) every 5 cm, and its side facing the sensor (y = `side`) one return column per metre, as a 64-beam
/// lidar sees a car 46 m out (heights 0.5, 1.0, 1.5 m).
fn grazing_car_points(near: f32, side: f32, width: f32, length: f32) -> Vec<[f32; 3]> {
    let mut pts = face_column(near, side, width);
    let mut x = near + 1.0;
    while x <= near + length + 1e-3 {
        for z in [0.5f32, 1.0, 1.5] {
            pts.push([x, side, z]);
        }
        x += 1.0;
    }
    pts
}

/// Spill-over in front of the box (params key `spill_in_front`, on by default since issue #10's round of that name;
/// docs/attribution.md, "Spill-over in front of the box"). A car 44 m out, seen along its length, reported 0.7-2 m
/// further away than it stands: its displaced region still holds returns of its side (one column per metre), and its
/// near face is a free cluster in front of the region (within a cell diagonal of it, or up to 1.6 m in front of it,
/// within the gate) that touches none of them (the side between is too sparse to join them). Spill-over wants a cluster that continues the box's own evidence: without the key the box is
/// `consistent` and the face a missed object; with it the face stands in front of the box on its line of sight, holds
/// more cells than the box owns and touches no one else's evidence, so it is the box's: a `position_error` with the
/// face. The car reported where it stands is `consistent` either way. A pedestrian standing against the face (its
/// returns 8-adjacent to the face's) makes the face possibly the pedestrian's: the displaced car is `consistent` with
/// the key too.
#[test]
fn a_near_face_in_front_of_a_box_displaced_away_goes_to_it_without_touching_its_evidence() {
    let truth = object(1, 44.0, 6.3, 0.0, 4.8, 1.9);
    let car = grazing_car_points(44.0 - 2.4, 6.3 - 0.95, 1.9, 4.8);
    let mut pts = car.clone();
    pts.extend(ground_points(60.0));
    // A pedestrian against the face, nearer the sensor, beside its upper end.
    let ped = object(2, 44.0 - 2.4 - 0.45, 6.3 + 0.6, 0.0, 0.6, 0.6);
    let mut with_ped = car;
    with_ped.extend(visible_face_points(&ped, 0.05));
    with_ped.extend(ground_points(60.0));
    // 0.7 m and 1 m leave the face within a cell diagonal of the displaced grown region; 1.5 m and 2 m about 1 m and
    // 1.6 m in front of it, within the gate (`conflict_association_m`, 2 m).
    for (cells, d) in [(0.2f32, 0.7f32), (0.5, 1.0), (0.2, 1.5), (0.5, 2.0)] {
        let mut reported = truth;
        reported.x_m += d;
        for spill_in_front in [false, true] {
            let params = MonitorParams { cell_size_m: cells, spill_in_front, ..MonitorParams::default() };
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[reported], &pts);
            let at = format!("{cells} m cells, {d} m, key {spill_in_front}");
            let want = if spill_in_front { SensorVerdict::PositionError } else { SensorVerdict::Consistent };
            assert_eq!(r[0].sensor.verdict, want, "{at}: {:?}", r[0].sensor);
            if spill_in_front {
                // The offset points from the face back to the reported box: along +x.
                let o = r[0].sensor.offset_m;
                assert!(o[0] > 0.3 && o[0] < d + 0.5 && o[1].abs() < 0.3, "{at}: {o:?}");
            }
            let r = run(&mut m, &[truth], &pts);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{at}, clean: {:?}", r[0].sensor);
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[reported, ped], &with_ped);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{at}, pedestrian: {:?}", r[0].sensor);
            assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "{at}, the pedestrian: {:?}", r[1].sensor);
        }
    }
}

/// The near side of the box (params key `spill_near_side`, on by default since issue #10's round of that name;
/// docs/attribution.md, "The near side of the box"). A car 30 m out, seen from behind (its near face, a column across
/// its width), reported 1.8 m further away than it stands, with the face of something else (a neighbour displaced
/// elsewhere, or unlabelled) 1.6 m behind the car: the displaced box's far end holds that face, so the box is
/// confirmed, and its own face is a free cluster in front of it. Without the key spill-over's fit test takes the face
/// behind as the box's own evidence and the two faces 6.4 m apart do not fit a 4.8 m car: `consistent`. With it the
/// test counts only the box's evidence on its near side (none: the face it holds stands beyond its centre), and the
/// cluster in front is its own: `position_error`. The clean car is `consistent` either way. The returns along a box
/// still bound its evidence when they are sparse (one per cell, not occupied): the clean car with such returns along
/// its side, to its far end, and a free face 1.6 m in front of it is not given that face (it would be with the far
/// side left out entirely); what a box displaced away from the sensor holds at its far side and the key leaves out is
/// evidence dense enough to be occupied.
#[test]
fn a_face_behind_a_box_displaced_away_does_not_keep_its_own_face_from_it() {
    let truth = object(1, 30.0, 3.0, 0.0, 4.8, 1.8);
    let mut pts = face_column(30.0 - 2.4, 3.0 - 0.9, 1.8);
    pts.extend(face_column(34.0, 3.0 - 0.9, 1.8));
    pts.extend(ground_points(45.0));
    // The clean car with sparse returns along its near side (one every 0.5 m, one height) and a free face in front.
    let mut sparse = face_column(30.0 - 2.4, 3.0 - 0.9, 1.8);
    let mut x = 30.0 - 2.4 + 0.5;
    while x <= 30.0 + 2.4 {
        sparse.push([x, 3.0 - 0.9, 1.0]);
        x += 0.5;
    }
    sparse.extend(face_column(30.0 - 2.4 - 1.6, 3.0 - 0.9, 1.8));
    sparse.extend(ground_points(45.0));
    let mut reported = truth;
    reported.x_m += 1.8;
    for cells in [0.2f32, 0.5] {
        for spill_near_side in [false, true] {
            let params = MonitorParams { cell_size_m: cells, spill_near_side, ..MonitorParams::default() };
            let at = format!("{cells} m cells, key {spill_near_side}");
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[reported], &pts);
            assert!(r[0].sensor.eta_own >= params.tau_tp, "{at}: the face behind confirms the box: {:?}", r[0].sensor);
            let want = if spill_near_side { SensorVerdict::PositionError } else { SensorVerdict::Consistent };
            assert_eq!(r[0].sensor.verdict, want, "{at}: {:?}", r[0].sensor);
            if spill_near_side {
                // The offset points from the car's own face back to the reported box: along +x.
                let o = r[0].sensor.offset_m;
                assert!(o[0] > 0.3 && o[1].abs() < 0.3, "{at}: {o:?}");
            }
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[truth], &pts);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{at}, clean: {:?}", r[0].sensor);
            let mut m = Monitor::new(params).unwrap();
            let r = run(&mut m, &[truth], &sparse);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{at}, sparse returns: {:?}", r[0].sensor);
        }
    }
}

/// The scene of the released-claims tests: pedestrian B stands 20 m ahead and `a_truth` behind it; both are reported
/// 1.4 m further away. B and A as reported, the first frame's points (B's visible faces and the ground) and the
/// second's (A's visible faces too).
fn released_claims_scene(
    a_truth: pmon_monitor::ObjectState,
) -> (pmon_monitor::ObjectState, pmon_monitor::ObjectState, Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let b_truth = object(1, 20.0, 0.0, 0.0, 0.6, 0.6);
    let mut first = visible_face_points(&b_truth, 0.05);
    first.extend(ground_points(45.0));
    let mut second = first.clone();
    second.extend(visible_face_points(&a_truth, 0.05));
    let (mut b, mut a) = (b_truth, a_truth);
    b.x_m += 1.4;
    a.x_m += 1.4;
    (b, a, first, second)
}

/// One frame at time `t_s` with the sensor at the origin: the object reports.
fn checked_at(
    m: &mut Monitor,
    t_s: f64,
    objects: &[pmon_monitor::ObjectState],
    points: &[[f32; 3]],
) -> Vec<pmon_monitor::ObjectReport> {
    let pts = to_sensor(points);
    let frame = Frame { timestamp_s: t_s, ..frame_at_origin(objects, &pts, &[], &[]) };
    m.check(&frame).unwrap().objects.to_vec()
}

/// Claims a flagged neighbour releases (params key `release_flagged_claims`): pedestrian B stands 20 m ahead and is
/// reported 1.4 m further away in two frames; in the second, pedestrian A stands just behind where B is reported and
/// is reported 1.4 m further away still. B, flagged in the first frame, is offered its own returns again at its
/// remembered offset (step 4) and keeps them: a `position_error`. B's displaced region covers A's returns, so B owns
/// them (step 1); A's box stands in the shadow of its own returns with no evidence of its own: without the key it is
/// `not_monitored(occluded)`. With the key, the cells B held only by its wrong place (B's cluster does not continue
/// them) are released, and A, behind them, takes them: a `position_error` with the cause `evidence_released` and an
/// offset back to its returns. Reported where it stands, A is `consistent` either way.
#[test]
fn a_hidden_box_takes_the_returns_a_displaced_neighbour_held_only_by_its_wrong_place() {
    let a_truth = object(2, 21.6, 0.25, 0.0, 0.6, 0.4);
    let (b, a, first, second) = released_claims_scene(a_truth);
    for (key, a_verdict, a_cause) in [
        (false, SensorVerdict::NotMonitored(pmon_monitor::NotMonitoredReason::Occluded), None),
        (true, SensorVerdict::PositionError, Some(PositionCause::EvidenceReleased)),
    ] {
        for (a_reported, clean) in [(a, false), (a_truth, true)] {
            let mut m =
                Monitor::new(MonitorParams { release_flagged_claims: key, ..MonitorParams::default() }).unwrap();
            let r = checked_at(&mut m, 0.0, &[b], &first);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "key {key}: B alone {:?}", r[0].sensor);
            let r = checked_at(&mut m, 0.1, &[b, a_reported], &second);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "key {key}: B {:?}", r[0].sensor);
            assert_eq!(
                r[0].sensor.position_cause,
                Some(PositionCause::DisplacedEvidence),
                "key {key}: B {:?}",
                r[0].sensor
            );
            if clean {
                // A reported where it stands: its returns are its own.
                assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "key {key}: clean A {:?}", r[1].sensor);
                continue;
            }
            assert_eq!(r[1].sensor.verdict, a_verdict, "key {key}: A {:?}", r[1].sensor);
            assert_eq!(r[1].sensor.position_cause, a_cause, "key {key}: A {:?}", r[1].sensor);
            if key {
                // From its returns (21.3-21.9 m) back to the box's near face (22.7 m): about +1 m along x.
                assert!(r[1].sensor.offset_m[0] > 0.5 && r[1].sensor.offset_m[0] < 1.7, "{:?}", r[1].sensor.offset_m);
            }
        }
    }
}

/// Released claims for a confirmed box (params key `release_to_confirmed`, with `release_flagged_claims`): as above,
/// pedestrian B stands 20 m ahead, reported 1.4 m further away and flagged in the first frame. In the second, cyclist
/// A (1.8 m long) stands just behind B, its near face and the side the sensor sees reaching from 20.7 to 22.5 m, and
/// is reported 1.4 m further away. A's grown region keeps the far end of that side, so A is confirmed by evidence of
/// its own; the rest, in front of it, lies in B's displaced region. Without `release_to_confirmed` A is `consistent`;
/// with it, the cells B held only by its wrong place are A's: a `position_error` with the cause `evidence_released`.
/// Reported where it stands, A is `consistent` either way.
#[test]
fn a_confirmed_box_takes_the_rest_of_its_body_a_displaced_neighbour_held_only_by_its_wrong_place() {
    let a_truth = object(2, 21.6, 0.4, 0.0, 1.8, 0.6);
    let (b, a, first, second) = released_claims_scene(a_truth);
    for (key, a_verdict, a_cause) in [
        (false, SensorVerdict::Consistent, None),
        (true, SensorVerdict::PositionError, Some(PositionCause::EvidenceReleased)),
    ] {
        for (a_reported, clean) in [(a, false), (a_truth, true)] {
            let params = MonitorParams { release_to_confirmed: key, ..MonitorParams::default() };
            let mut m = Monitor::new(params).unwrap();
            let r = checked_at(&mut m, 0.0, &[b], &first);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "key {key}: B alone {:?}", r[0].sensor);
            let r = checked_at(&mut m, 0.1, &[b, a_reported], &second);
            assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "key {key}: B {:?}", r[0].sensor);
            if clean {
                assert_eq!(r[1].sensor.verdict, SensorVerdict::Consistent, "key {key}: clean A {:?}", r[1].sensor);
                continue;
            }
            assert!(r[1].sensor.eta_own >= params.tau_tp, "key {key}: A is confirmed by its own: {:?}", r[1].sensor);
            assert_eq!(r[1].sensor.verdict, a_verdict, "key {key}: A {:?}", r[1].sensor);
            assert_eq!(r[1].sensor.position_cause, a_cause, "key {key}: A {:?}", r[1].sensor);
            if key {
                // From the released cells (about 20.7-21.7 m) back to the box's near face (22.1 m): along +x.
                assert!(r[1].sensor.offset_m[0] > 0.3 && r[1].sensor.offset_m[1].abs() < 0.5, "{:?}", r[1].sensor);
            }
        }
    }
}

/// Evidence in the margin that runs on (params key `evidence_runs_on`): a hedge 1 m high runs from 13 m to 18.45 m
/// ahead, 0.9-1.3 m aside. A pedestrian box A reported behind its end, at 19.1 m (footprint from 18.8 m, grown
/// region from 18.4 m), stands in the hedge's shadow and owns only the hedge's far end, in its margin: no occupied
/// cell it owns overlaps its footprint. A trailer box B (5.5 m long) is reported 2.1 m to the right of the hedge,
/// where the sensor sees the ground: B takes the rest of the hedge as its displaced evidence (steps 3-4), so A's
/// cells continue into evidence attributed to another box. Without the key A is `consistent`, confirmed by the
/// hedge; with it, a `position_error` with the cause `evidence_runs_on` and an offset from the evidence to the box
/// (away from the sensor). Without B the rest of the hedge is nobody's (a missed object, as scenery is): A stays
/// `consistent` with the key. A pedestrian who stands at A, seen over the hedge (its returns inside the footprint),
/// is `consistent` with the key.
#[test]
fn a_box_confirmed_only_by_evidence_in_its_margin_that_runs_on_is_displaced() {
    let hedge = [13.0, 0.9, 18.45, 1.3, 1.0];
    let a = object(1, 19.1, 1.1, 0.0, 0.6, 0.6);
    let b = object(2, 15.7, -1.0, 0.0, 5.5, 0.5);
    for (key, with_b, body, want, cause) in [
        (false, true, false, SensorVerdict::Consistent, None),
        (true, true, false, SensorVerdict::PositionError, Some(PositionCause::EvidenceRunsOn)),
        (true, false, false, SensorVerdict::Consistent, None),
        (true, true, true, SensorVerdict::Consistent, None),
    ] {
        let boxes: Vec<[f32; 5]> = if body { vec![hedge, [18.85, 0.85, 19.35, 1.35, 1.7]] } else { vec![hedge] };
        let pts = ray_cast(&boxes);
        let objects: Vec<_> = if with_b { vec![a, b] } else { vec![a] };
        let mut m = Monitor::new(MonitorParams { evidence_runs_on: key, ..MonitorParams::default() }).unwrap();
        let (r, missed) = run_frame(&mut m, &objects, &pts);
        let s = &r[0].sensor;
        let case = format!("key {key}, B {with_b}, body {body}");
        assert!(s.eta_own >= 0.8, "{case}: A is confirmed by evidence it owns: {s:?}");
        assert_eq!((s.verdict, s.position_cause), (want, cause), "{case}: A {s:?}");
        if with_b {
            let sb = &r[1].sensor;
            assert_eq!(
                (sb.verdict, sb.position_cause),
                (SensorVerdict::PositionError, Some(PositionCause::DisplacedEvidence)),
                "{case}: B {sb:?}"
            );
        } else {
            assert!(missed >= 1, "{case}: the rest of the hedge is nobody's");
        }
        if cause.is_some() {
            assert!(s.offset_m[0] > 0.1 && s.offset_m[0] < 1.0, "from the hedge's end to the box: {s:?}");
        }
    }
}

/// Returns at every `x` of `xs` and `y` of `ys`, at heights 0.5, 1.0 and 1.5 m.
fn returns_at(xs: &[f32], ys: &[f32]) -> Vec<[f32; 3]> {
    xs.iter().flat_map(|&x| ys.iter().flat_map(move |&y| [0.5f32, 1.0, 1.5].map(|z| [x, y, z]))).collect()
}

/// Spill-over across a gap (params key `spill_gap_m`, 0.4 m by default since issue #10's round of that name;
/// docs/attribution.md, "Spill-over across a gap"). At 0.2 m cells, a car 25 m out seen along its side at a grazing
/// angle: the side's returns are dense over most of its length, and its near end is one cell of returns two empty
/// cells apart from the rest. Reported 1 m further along its length, the box still holds most of its side, so it is
/// confirmed; its near end is a one-cell cluster beyond the grown region that touches none of its evidence (two cells
/// between) and outweighs none of it. With `spill_gap_m = 0` spill-over leaves it: `consistent`. By default it bridges
/// the gap (two 0.2 m cells), the cluster with the side fits the car, and the box is a `position_error` with its own
/// evidence. The car reported where it stands is `consistent` either way. A pedestrian (no covariance stated, its
/// margin the 0.1 m safety margin) with an unlabelled cell of returns one empty cell beyond its own evidence, outside
/// its region, stays `consistent` even with the widest gap: the key bridges gaps only beside boxes of a vehicle's
/// length (at least 2 m), whose sides a ray samples sparsely; beside a pedestrian that cell is someone else's.
#[test]
fn a_car_side_sampled_sparsely_spills_over_across_a_gap_of_empty_cells() {
    let truth = object(1, 25.1, 4.0, 0.0, 4.8, 1.8);
    // The side facing the sensor (y = 3.1): returns from 23.35 m to the far end, and the near end's cell 22.6-22.8 m.
    let mut pts = line_of_returns(23.35, 27.5, |x| [x, 3.15]);
    pts.extend(returns_at(&[22.71, 22.74, 22.77], &[3.12, 3.15, 3.18]));
    pts.extend(ground_points(40.0));
    let mut reported = truth;
    reported.x_m += 1.0;
    let d = MonitorParams { cell_size_m: 0.2, ..MonitorParams::default() };
    assert_eq!(d.spill_gap_m.to_bits(), 0.4f32.to_bits(), "the default");
    for spill_gap_m in [0.0f32, 0.4] {
        let params = MonitorParams { spill_gap_m, ..d };
        let mut m = Monitor::new(params).unwrap();
        let r = run(&mut m, &[reported], &pts);
        let s = r[0].sensor;
        assert!(s.eta_own >= params.tau_tp, "gap {spill_gap_m}: its side confirms the box: {s:?}");
        if spill_gap_m > 0.0 {
            assert_eq!(s.verdict, SensorVerdict::PositionError, "gap {spill_gap_m}: {s:?}");
            assert_eq!(s.position_cause, Some(PositionCause::DisplacedEvidence), "{s:?}");
            // From the car's evidence to the reported box: along +x.
            assert!(s.offset_m[0] > 0.1 && s.offset_m[1].abs() < 0.3, "{s:?}");
        } else {
            assert_eq!(s.verdict, SensorVerdict::Consistent, "gap {spill_gap_m}: {s:?}");
        }
        let mut m = Monitor::new(params).unwrap();
        let r = run(&mut m, &[truth], &pts);
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "gap {spill_gap_m}, clean: {:?}", r[0].sensor);
    }
    // A pedestrian with an unlabelled cell one empty cell beyond its evidence, outside its region.
    let mut ped = object(2, 15.1, -3.1, 0.0, 0.6, 0.6);
    ped.class = pmon_monitor::ObjectClass::Pedestrian;
    ped.uncertainty = Some(pmon_monitor::Uncertainty { x_m: 0.0, y_m: 0.0, ..d.default_uncertainty });
    let mut near = returns_at(&[14.85], &[-3.15, -3.1, -3.05, -3.0, -2.95, -2.9, -2.85]);
    near.extend(returns_at(&[14.83, 14.86, 14.89], &[-2.55, -2.5, -2.45]));
    near.extend(ground_points(40.0));
    for spill_gap_m in [0.0f32, 0.4, 1.0] {
        let params = MonitorParams { spill_gap_m, ..d };
        let mut m = Monitor::new(params).unwrap();
        let (r, missed) = run_frame(&mut m, &[ped], &near);
        assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "gap {spill_gap_m}, pedestrian: {:?}", r[0].sensor);
        assert_eq!(missed, 1, "gap {spill_gap_m}: the cell beyond is a missed object");
    }
}

/// A parked car held (params key `parked_hold_s`; docs/attribution.md, "Parked cars in a row"): a car reported
/// 1.5 m further along its length than it stands is flagged while its near end is in view (its evidence in front of
/// the box), then the near end hides and only the side, inside the displaced box's region, stays in view. Without
/// the key the box is `consistent` from then on; with it, after two alarms in a row, it stays a `position_error`
/// (`held_while_parked`, the offset pointing away from the sensor) for the key's time, and no longer; a single alarm
/// is not held, nor a car that moves (0.6 m/s), a box shorter than 3 m, or a box reported back where the car stands
/// (an error that ended).
#[test]
fn a_parked_car_found_displaced_twice_is_held_while_its_near_end_hides() {
    let car = object(7, 20.0, -3.0, 0.0, 4.5, 1.8);
    let whole = visible_face_points(&car, 0.05);
    // Only its side: the returns beyond the displaced box's near edge (20 + 1.5 - 2.25 - 0.4 = 18.85 m).
    let side: Vec<[f32; 3]> = whole.iter().copied().filter(|p| p[0] > 19.5).collect();
    let (mut seen, mut hidden) = (whole.clone(), side.clone());
    seen.extend(ground_points(45.0));
    hidden.extend(ground_points(45.0));
    let held = Some(PositionCause::HeldWhileParked);
    // (parked_hold_s, alarms before the near end hides, the box's speed and length, where it is reported once the
    // near end hides, time of the frame looked at, held then)
    for (hold, alarms, speed, length, then_x, at, want) in [
        (3.0, 2, 0.0, 4.5, 21.5, 0.3, true),
        (3.0, 2, 0.0, 4.5, 21.5, 2.9, true),
        (0.0, 2, 0.0, 4.5, 21.5, 0.3, false),
        (3.0, 2, 0.0, 4.5, 21.5, 3.5, false),
        (3.0, 1, 0.0, 4.5, 21.5, 0.3, false),
        (3.0, 2, 0.6, 4.5, 21.5, 0.3, false),
        (3.0, 2, 0.0, 2.5, 21.5, 0.3, false),
        (3.0, 2, 0.0, 4.5, 20.0, 0.3, false),
    ] {
        let what = format!("hold {hold}, {alarms} alarms, {speed} m/s, {length} m long, then at x {then_x}, at {at} s");
        let body = pmon_monitor::ObjectState { length_m: length, ..car };
        let mut body_seen = visible_face_points(&body, 0.05);
        body_seen.extend(ground_points(45.0));
        let mut body_hidden: Vec<[f32; 3]> =
            visible_face_points(&body, 0.05).into_iter().filter(|p| p[0] > 19.5).collect();
        body_hidden.extend(ground_points(45.0));
        let (first, rest) = if length < 4.0 { (&body_seen, &body_hidden) } else { (&seen, &hidden) };
        let reported = pmon_monitor::ObjectState { x_m: 21.5, speed_mps: speed, ..body };
        let mut m = Monitor::new(MonitorParams { parked_hold_s: hold, ..MonitorParams::default() }).unwrap();
        let mut t = 0.0f32;
        for _ in 0..alarms {
            let r = check_at(&mut m, t, &[reported], first, Pose2::default());
            assert_eq!(
                r[0].sensor.verdict,
                SensorVerdict::PositionError,
                "{what}, near end seen at {t}: {:?}",
                r[0].sensor
            );
            assert_eq!(r[0].sensor.position_cause, Some(PositionCause::DisplacedEvidence), "{what}");
            t += 0.1;
        }
        let then = pmon_monitor::ObjectState { x_m: then_x, ..reported };
        let mut last = None;
        while t <= at + 0.05 {
            last = Some(check_at(&mut m, t, &[then], rest, Pose2::default()));
            t += 0.1;
        }
        let r = last.unwrap();
        if want {
            assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "{what}: {:?}", r[0].sensor);
            assert_eq!(r[0].sensor.position_cause, held, "{what}");
            assert!(r[0].sensor.offset_m[0] > 0.5, "from the evidence back to the box, away: {:?}", r[0].sensor);
        } else {
            assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "{what}: {:?}", r[0].sensor);
        }
    }
}

/// Points filling the 0.5 m cell whose centre is `(cx, cy)` (a 3 x 3 pattern at three heights: occupied).
fn cell_points(cx: f32, cy: f32) -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    for dx in [-0.15f32, 0.0, 0.15] {
        for dy in [-0.15f32, 0.0, 0.15] {
            for z in [0.5f32, 1.0, 1.5] {
                out.push([cx + dx, cy + dy, z]);
            }
        }
    }
    out
}

/// Spill-over's choice between confirmed boxes with the params key `spill_least_stretch` (off by default;
/// docs/attribution.md, "The box a cluster stretches least"): a parked
/// car 10.45-14.85 m ahead, beside the lane, and a pedestrian box just in front of its near end whose evidence
/// reaches one cell beyond its region, into the gap between them. That cell continues both boxes' own evidence and
/// fits either box (within the fit's slack); it is nearer the car's grown region (its centre 0.3 m from it against
/// 0.35 m), but with it the car's evidence would span 0.6 m more than its length (over cell centres), the
/// pedestrian's not at all. The cell goes to the
/// pedestrian (a `position_error` on its own evidence) and the car stays `consistent`; with no pedestrian there,
/// the car takes the cell (it is then its own evidence reaching over its edge). Without the key (the default), the
/// car takes it beside the pedestrian too (the nearest).
#[test]
fn a_cell_between_a_car_and_a_pedestrian_goes_to_the_box_it_stretches_least() {
    let car = object(1, 12.65, -2.8, 0.0, 4.4, 1.8);
    let pedestrian = object(2, 8.7, -3.25, 0.0, 0.6, 0.6);
    let mut pts = visible_face_points(&car, 0.05);
    pts.extend(cell_points(9.25, -3.25));
    pts.extend(cell_points(9.75, -3.25));
    pts.extend(ground_points(30.0));
    let on = MonitorParams { spill_least_stretch: true, ..MonitorParams::default() };
    let mut m = Monitor::new(on).unwrap();
    let r = run(&mut m, &[car, pedestrian], &pts);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::Consistent, "car: {:?}", r[0].sensor);
    assert_eq!(r[1].sensor.verdict, SensorVerdict::PositionError, "pedestrian: {:?}", r[1].sensor);
    assert_eq!(r[1].sensor.position_cause, Some(PositionCause::DisplacedEvidence), "{:?}", r[1].sensor);
    let mut m = Monitor::new(MonitorParams::default()).unwrap();
    let r = run(&mut m, &[car, pedestrian], &pts);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "car, without the key: {:?}", r[0].sensor);
    // (The pedestrian is then flagged too, by `evidence_runs_on`: its evidence runs on into the cell the car took.)
    assert_ne!(r[1].sensor.position_cause, Some(PositionCause::DisplacedEvidence), "{:?}", r[1].sensor);
    // With no pedestrian there (nor its evidence), the car takes the cell.
    let mut alone = visible_face_points(&car, 0.05);
    alone.extend(cell_points(9.75, -3.25));
    alone.extend(ground_points(30.0));
    let mut m = Monitor::new(on).unwrap();
    let r = run(&mut m, &[car], &alone);
    assert_eq!(r[0].sensor.verdict, SensorVerdict::PositionError, "car alone: {:?}", r[0].sensor);
}
