//! Plausibility checks over whole frames: the transient speed bound, track bookkeeping, bad input.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    clippy::std_instead_of_core
)]

mod common;

use common::object;
use pmon_monitor::theory::dv_min_transient_accel_only_mps;
use pmon_monitor::{
    Conditions, Frame, Monitor, MonitorParams, MotionVerdict, NotMonitoredReason, ObjectState, Pose2, Uncertainty,
    Verdict,
};
use proptest::prelude::*;

fn frame(t: f64, objects: &[ObjectState]) -> Frame<'_> {
    Frame {
        timestamp_s: t,
        world_from_ego: Pose2::default(),
        objects,
        cloud: None,
        roi_in_ego: &[],
        static_in_ego: &[],
    }
}

fn moving(id: u64, x: f32, v: f32) -> ObjectState {
    ObjectState { speed_mps: v, ..object(id, x, 0.0, 0.0, 4.0, 1.8) }
}

fn motion_of(m: &mut Monitor, t: f64, objects: &[ObjectState]) -> Vec<MotionVerdict> {
    m.check(&frame(t, objects)).unwrap().objects.iter().map(|r| r.motion.verdict).collect()
}

#[test]
fn constant_speed_track_is_plausible_after_its_first_frame() {
    let mut m = Monitor::new(MonitorParams::default()).unwrap();
    let v = 10.0;
    let first = motion_of(&mut m, 0.0, &[moving(1, 0.0, v)]);
    assert_eq!(first[0], MotionVerdict::NotMonitored(NotMonitoredReason::FirstFrameOfTrack));
    for k in 1..20 {
        let t = k as f64 * 0.1;
        let r = motion_of(&mut m, t, &[moving(1, v * t as f32, v)]);
        assert_eq!(r[0], MotionVerdict::Plausible, "frame {k}");
    }
}

#[test]
fn ego_motion_is_removed_through_the_pose() {
    // The ego drives at 10 m/s behind an object that also drives at 10 m/s: in the ego frame it stands still.
    let mut m = Monitor::new(MonitorParams::default()).unwrap();
    for k in 0..10 {
        let t = k as f64 * 0.1;
        let pose = Pose2 { x_m: 10.0 * t, y_m: 0.0, yaw_rad: 0.0 };
        let objects = [moving(1, 20.0, 10.0)];
        let f = Frame {
            timestamp_s: t,
            world_from_ego: pose,
            objects: &objects,
            cloud: None,
            roi_in_ego: &[],
            static_in_ego: &[],
        };
        let r = m.check(&f).unwrap();
        if k > 0 {
            assert_eq!(r.objects[0].motion.verdict, MotionVerdict::Plausible, "frame {k}");
        }
    }
}

#[test]
fn bad_time_steps_and_duplicates_get_reasons() {
    let mut m = Monitor::new(MonitorParams::default()).unwrap();
    motion_of(&mut m, 1.0, &[moving(1, 0.0, 1.0)]);
    // Same timestamp again: dt = 0.
    let r = motion_of(&mut m, 1.0, &[moving(1, 0.0, 1.0)]);
    assert_eq!(r[0], MotionVerdict::NotMonitored(NotMonitoredReason::TimeStepNotPositive));
    // Time going backwards.
    let r = motion_of(&mut m, 0.5, &[moving(1, 0.0, 1.0)]);
    assert_eq!(r[0], MotionVerdict::NotMonitored(NotMonitoredReason::TimeStepNotPositive));
    // NaN timestamp.
    let r = motion_of(&mut m, f64::NAN, &[moving(1, 0.0, 1.0)]);
    assert_eq!(r[0], MotionVerdict::NotMonitored(NotMonitoredReason::InvalidTimestamp));
    // Duplicate ids: both flagged, the track keeps its last good state.
    let r = motion_of(&mut m, 1.1, &[moving(1, 0.1, 1.0), moving(1, 5.0, 1.0)]);
    assert_eq!(r, vec![MotionVerdict::NotMonitored(NotMonitoredReason::DuplicateId); 2]);
    let r = motion_of(&mut m, 1.2, &[moving(1, 0.2, 1.0)]);
    assert_eq!(r[0], MotionVerdict::Plausible);
    // A long gap restarts the track.
    let r = motion_of(&mut m, 5.0, &[moving(1, 4.0, 1.0)]);
    assert_eq!(r[0], MotionVerdict::NotMonitored(NotMonitoredReason::TimeStepTooLong));
    let r = motion_of(&mut m, 5.1, &[moving(1, 4.1, 1.0)]);
    assert_eq!(r[0], MotionVerdict::Plausible);
}

#[test]
fn invalid_states_are_not_monitored_and_never_panic() {
    let mut m = Monitor::new(MonitorParams::default()).unwrap();
    let good = moving(1, 0.0, 1.0);
    let bad_unc = Uncertainty { x_m: -1.0, y_m: 0.1, heading_rad: 0.1, speed_mps: 1.0, length_m: 0.0, width_m: 0.0 };
    let cases = [
        ObjectState { x_m: f32::NAN, ..good },
        ObjectState { y_m: f32::INFINITY, ..good },
        ObjectState { heading_rad: f32::NAN, ..good },
        ObjectState { speed_mps: -1.0, ..good },
        ObjectState { length_m: 0.0, ..good },
        ObjectState { width_m: -2.0, ..good },
        ObjectState { length_m: 1.0e9, ..good },
        ObjectState { uncertainty: Some(bad_unc), ..good },
    ];
    for (i, c) in cases.iter().enumerate() {
        let objs = [ObjectState { id: i as u64, ..*c }];
        let r = m.check(&frame(i as f64, &objs)).unwrap();
        assert_eq!(r.objects.len(), 1);
        assert_eq!(r.objects[0].verdict, Verdict::NotMonitored(NotMonitoredReason::InvalidState), "case {i}");
    }
}

#[test]
fn a_missed_frame_keeps_the_track() {
    let mut m = Monitor::new(MonitorParams::default()).unwrap();
    motion_of(&mut m, 0.0, &[moving(1, 0.0, 5.0), moving(2, 10.0, 0.0)]);
    motion_of(&mut m, 0.1, &[moving(2, 10.0, 0.0)]); // object 1 not detected this frame
    let r = motion_of(&mut m, 0.2, &[moving(1, 1.0, 5.0)]);
    assert_eq!(r[0], MotionVerdict::Plausible);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, .. ProptestConfig::default() })]

    /// Section III-C-2: with no position evidence involved, a transient speed error larger than
    /// min(a_acc, -a_br) dt + sqrt(2) dv is flagged by the acceleration condition, and a smaller one is not.
    #[test]
    fn transient_speed_error_bound(
        dt in 0.02f64..0.2,
        v in 0.0f32..25.0,
        speed_sigma in 0.1f32..2.0,
        rel in prop_oneof![0.0f64..0.98, 1.02f64..3.0],
        positive in any::<bool>(),
    ) {
        let p = MonitorParams::default();
        let bound = dv_min_transient_accel_only_mps(&p.motion_limits, dt, f64::from(speed_sigma));
        let dv = (rel * bound) as f32;
        // A negative error must keep the measured speed >= 0: start from a speed above the error.
        let v = if positive { v } else { v + dv };
        let dv = if positive { dv } else { -dv };
        let u = Uncertainty { speed_mps: speed_sigma, ..p.default_uncertainty };
        let mut m = Monitor::new(p).unwrap();
        let o0 = ObjectState { uncertainty: Some(u), ..moving(1, 0.0, v) };
        // The true position advances with the true speed; only the reported speed jumps.
        let o1 = ObjectState { x_m: v * dt as f32, speed_mps: v + dv, ..o0 };
        m.check(&frame(0.0, &[o0])).unwrap();
        let r = m.check(&frame(dt, &[o1])).unwrap().objects[0].motion.verdict;
        let fired_a = matches!(r, MotionVerdict::Implausible(c) if c.contains(Conditions::ACCELERATION));
        prop_assert_eq!(fired_a, rel > 1.0, "dv {} bound {} verdict {:?}", dv, bound, r);
    }
}

/// Issue 15 (found by fuzzing): two frames 1e-310 s apart made the acceleration infinite and the residual NaN;
/// no comparison with NaN fires, so a 573 m jump was called plausible. Now: not monitored, with the reason.
#[test]
fn issue_15_nan_from_a_subnormal_time_step_is_not_a_plausible_verdict() {
    for dt in [1e-310, 5e-324, 1e-300] {
        let mut m = Monitor::new(MonitorParams::default()).unwrap();
        let _ = motion_of(&mut m, 0.0, &[moving(1, 0.0, 10.0)]);
        let r = m.check(&frame(dt, &[moving(1, 573.0, 10.0)])).unwrap().objects[0];
        assert_ne!(r.motion.verdict, MotionVerdict::Plausible, "dt {dt}");
        assert!(!matches!(r.verdict, Verdict::Consistent | Verdict::MotionOnlyConsistent(_)), "dt {dt}: {r:?}");
        if !r.verdict.is_alarm() {
            assert_eq!(r.motion.verdict, MotionVerdict::NotMonitored(NotMonitoredReason::NonFiniteEstimate));
        }
    }
}
