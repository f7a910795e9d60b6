//! The optimised path of the monitor (one reused `Monitor` that resets only the cells touched by the previous
//! frame) gives exactly the same reports as a new `Monitor` given the same frames, and its grid holds exactly
//! what a new `Monitor`'s freshly zeroed grid holds after the same frame alone; repeated runs give the same
//! reports. On the synthetic benchmark frames and, when present, on the real sweeps of the shared data (KITTI,
//! nuScenes, Argoverse 2). On the real sweeps, the three rasterizers (`Blocked`, `BlockedBaseline`, `Scalar`) give
//! identical reports and grids too, and so do the sweeps handed over as columns (`Monitor::check_columns`), with
//! the Argoverse 2 sweeps' region of interest (whose scan reads the returns of its edge cells from the columns).
//!
//! The reports depend on history (the tracks, and the evidence memory: where each track's evidence stood last
//! frame, which depended on the frame before), so the new monitor of frame `k` replays frames `0..k` first. The
//! grid does not, except for the flag of cells attributed to an object (which follows the evidence memory): a
//! third monitor that sees frame `k` alone must have the same hits and the same other flags in every cell, so a
//! hit or flag left from any older frame would show.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::collections::BTreeSet;

use std::ops::Range;

use pmon_bench::frames::{self, Sequence, SequenceFrame, SyntheticSpec};
use pmon_monitor::grid::{FLAG_ATTRIBUTED, FLAG_RETURN_IN_ROI};
use pmon_monitor::{
    ClusterReport, ColumnCloud, Frame, FrameReport, GridStats, Monitor, MonitorParams, NotMonitoredReason,
    ObjectReport, PointColumns, Rasterizer, Verdict,
};

#[derive(Clone, Debug, PartialEq)]
struct Outcome {
    objects: Vec<ObjectReport>,
    clusters: Vec<ClusterReport>,
    grid: GridStats,
    sensor_status: Option<NotMonitoredReason>,
}

impl From<FrameReport<'_>> for Outcome {
    fn from(r: FrameReport<'_>) -> Self {
        Self {
            objects: r.objects.to_vec(),
            clusters: r.clusters.to_vec(),
            grid: r.grid,
            sensor_status: r.sensor_status,
        }
    }
}

fn params(cell_size_m: f32) -> MonitorParams {
    MonitorParams { cell_size_m, ..MonitorParams::PAPER }
}

/// Runs `iterations` frames through one reused monitor.
fn reused_run(seq: &Sequence, p: MonitorParams, iterations: usize) -> Vec<Outcome> {
    let mut m = Monitor::new(p).unwrap();
    (0..iterations).map(|i| m.check(&seq.frame(i, Sequence::timestamp_s(i)).unwrap()).unwrap().into()).collect()
}

/// Compares the reused monitor with new monitors per frame, report by report and cell by cell.
fn assert_paths_agree(seq: &Sequence, p: MonitorParams, iterations: usize) -> Vec<Outcome> {
    let mut reused = Monitor::new(p).unwrap();
    let mut outcomes = Vec::new();
    for i in 0..iterations {
        let frame = seq.frame(i, Sequence::timestamp_s(i)).unwrap();
        let optimised: Outcome = reused.check(&frame).unwrap().into();
        let mut replay = Monitor::new(p).unwrap();
        for h in 0..i {
            replay.check(&seq.frame(h, Sequence::timestamp_s(h)).unwrap()).unwrap();
        }
        let straightforward: Outcome = replay.check(&frame).unwrap().into();
        assert_eq!(optimised, straightforward, "{}: frame {i} (cell {} m)", seq.name, p.cell_size_m);
        // Every cell, not only the touched ones: a stale hit or flag anywhere would show here.
        let mut alone = Monitor::new(p).unwrap();
        alone.check(&frame).unwrap();
        let cells = u32::try_from(reused.grid().geometry.cell_count()).unwrap();
        let own_flags = |m: &Monitor, c: u32| m.grid().flags(c) & !FLAG_ATTRIBUTED;
        let stale = (0..cells)
            .find(|&c| reused.grid().hits(c) != alone.grid().hits(c) || own_flags(&reused, c) != own_flags(&alone, c));
        assert_eq!(stale, None, "{}: frame {i}: grids differ at this cell", seq.name);
        outcomes.push(optimised);
    }
    outcomes
}

fn verdict_names(outcomes: &[Outcome]) -> BTreeSet<&'static str> {
    outcomes.iter().flat_map(|o| o.objects.iter().map(|r| r.verdict.name())).collect()
}

/// The synthetic 64-beam frames, alternating with the 32-beam ones: consecutive frames touch very different
/// cells, so an incomplete reset would leave stale evidence behind.
fn alternating_sequence() -> Sequence {
    let a = Sequence::synthetic(&SyntheticSpec::BEAMS_64);
    let b = Sequence::synthetic(&SyntheticSpec::BEAMS_32);
    let offset = a.sweeps.len();
    let mut sweeps = a.sweeps.clone();
    sweeps.extend(b.sweeps.iter().cloned());
    let frames = a
        .frames
        .iter()
        .zip(&b.frames)
        .enumerate()
        .map(|(k, (fa, fb))| {
            // Objects always from the 64-beam scene (tracks continue), the sweep alternates.
            let sweep = if k % 2 == 0 { fa.sweep } else { fb.sweep.map(|s| s + offset) };
            SequenceFrame { objects: fa.objects.clone(), sweep, world_from_ego: fa.world_from_ego }
        })
        .collect();
    Sequence { name: "alternating 64/32-beam".to_string(), sweeps, frames }
}

#[test]
fn synthetic_frames_are_deterministic() {
    assert_eq!(Sequence::synthetic(&SyntheticSpec::BEAMS_32), Sequence::synthetic(&SyntheticSpec::BEAMS_32));
    let seq = Sequence::synthetic(&SyntheticSpec::BEAMS_64);
    assert_eq!(seq.sweeps.len(), 6);
    assert!(seq.sweeps.iter().all(|s| s.points_in_sensor.len() == 120_000));
    assert!(seq.frames.iter().all(|f| f.objects.len() == 100));
}

#[test]
fn reused_and_fresh_monitors_agree_on_synthetic_frames() {
    let seq = Sequence::synthetic(&SyntheticSpec::BEAMS_64);
    // Two cycles: the second starts with the objects jumping back (implausible motion).
    let iterations = 2 * seq.frames.len();
    for cell in [0.5, 0.1] {
        let outcomes = assert_paths_agree(&seq, params(cell), iterations);
        let names = verdict_names(&outcomes);
        for expected in ["consistent", "ghost", "position_error", "implausible_motion"] {
            assert!(names.contains(expected), "cell {cell} m: no `{expected}` verdict among {names:?}");
        }
        assert!(outcomes.iter().all(|o| o.grid.cells_hit > 0 && o.sensor_status.is_none()));
        assert!(outcomes.iter().any(|o| !o.clusters.is_empty()), "no conflict cluster at all");
        assert!(
            outcomes.iter().skip(1).flat_map(|o| &o.objects).any(|r| r.verdict == Verdict::Consistent
                && matches!(r.motion.verdict, pmon_monitor::MotionVerdict::Plausible)),
            "no plausible track"
        );
        assert_eq!(outcomes, reused_run(&seq, params(cell), iterations), "a repeated run differs");
    }
}

#[test]
fn reused_and_fresh_monitors_agree_when_the_cloud_changes_a_lot() {
    let seq = alternating_sequence();
    let outcomes = assert_paths_agree(&seq, params(0.2), seq.frames.len());
    let hit: Vec<u32> = outcomes.iter().map(|o| o.grid.cells_hit).collect();
    assert!(hit.windows(2).all(|w| w[0] != w[1]), "consecutive frames should touch different cells: {hit:?}");
}

#[test]
fn reused_and_fresh_monitors_agree_on_object_lists_without_cloud() {
    let seq = Sequence::synthetic(&SyntheticSpec::objects_only(300));
    let outcomes = assert_paths_agree(&seq, params(0.5), 2 * seq.frames.len());
    assert!(outcomes.iter().all(|o| o.sensor_status == Some(NotMonitoredReason::NoLidarData)));
}

/// The real sequences of the shared data that are present, with the range their point counts must lie in;
/// empty (after a message) when there are none.
fn real_sequences() -> Vec<(Sequence, Range<u32>)> {
    let dir = frames::data_dir();
    let kitti = frames::kitti_sweeps(&dir).expect("readable KITTI sweeps");
    let nuscenes = frames::nuscenes_sweeps(&dir).expect("readable nuScenes sweeps");
    let av2 = pmon_bench::av2::sweeps(&dir).expect("readable Argoverse 2 sweeps");
    for (what, n) in [("KITTI", kitti.len()), ("nuScenes", nuscenes.len()), ("Argoverse 2", av2.len())] {
        if n == 0 {
            eprintln!("skipped {what}: no sweeps under {} (set PMON_DATA_DIR)", dir.display());
        }
    }
    [
        (Sequence::real("kitti", kitti, &SyntheticSpec::BEAMS_64), 100_000..130_000),
        (Sequence::real("nuscenes", nuscenes, &SyntheticSpec::BEAMS_32), 34_000..35_000),
        // Two VLP-32C lidars merged: 99,229 and 99,466 points in the two sweeps of log 7fab2350.
        (pmon_bench::av2::sequence(av2), 90_000..110_000),
    ]
    .into_iter()
    .filter_map(|(seq, points)| seq.map(|s| (s, points)))
    .collect()
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn reused_and_fresh_monitors_agree_on_real_sweeps() {
    for (seq, expected_points) in real_sequences() {
        let iterations = seq.frames.len() + 2;
        let outcomes = assert_paths_agree(&seq, params(0.5), iterations);
        for o in &outcomes {
            assert!(expected_points.contains(&o.grid.points_total), "{}: {} points", seq.name, o.grid.points_total);
            assert!(o.grid.points_in_band > 1000, "{}: ground plane wrong? {:?}", seq.name, o.grid);
        }
        assert_eq!(outcomes, reused_run(&seq, params(0.5), iterations), "{}: a repeated run differs", seq.name);
    }
}

/// The three rasterizers give the same reports (compared by their `Debug` text too, which tells -0.0 from 0.0)
/// and the same hits and flags in every cell, frame after frame, on the real sweeps.
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn rasterizers_agree_on_real_sweeps() {
    const ALL: [Rasterizer; 3] = [Rasterizer::Blocked, Rasterizer::BlockedBaseline, Rasterizer::Scalar];
    for (seq, _) in real_sequences() {
        for cell in [0.5, 0.2] {
            let mut monitors: Vec<Monitor> = ALL
                .iter()
                .map(|r| {
                    let mut m = Monitor::new(params(cell)).unwrap();
                    m.set_rasterizer(*r);
                    m
                })
                .collect();
            let mut verdicts = BTreeSet::new();
            for i in 0..seq.frames.len() + 2 {
                let frame = seq.frame(i, Sequence::timestamp_s(i)).unwrap();
                let outcomes: Vec<Outcome> = monitors.iter_mut().map(|m| m.check(&frame).unwrap().into()).collect();
                let texts: Vec<String> = outcomes.iter().map(|o| format!("{o:?}")).collect();
                for (r, (o, t)) in ALL.iter().zip(outcomes.iter().zip(&texts)).skip(1) {
                    let at = format!("{}: frame {i}, cell {cell} m: {r:?} vs {:?}", seq.name, ALL[0]);
                    assert_eq!(o, &outcomes[0], "{at}");
                    assert!(*t == texts[0], "{at}: Debug texts differ");
                }
                let grids: Vec<_> = monitors.iter().map(Monitor::grid).collect();
                let cells = u32::try_from(grids[0].geometry.cell_count()).unwrap();
                for (r, g) in ALL.iter().zip(&grids).skip(1) {
                    assert_eq!(g.touched(), grids[0].touched(), "{}: frame {i}: {r:?}: touched cells", seq.name);
                    let differ = (0..cells).find(|&c| g.hits(c) != grids[0].hits(c) || g.flags(c) != grids[0].flags(c));
                    assert_eq!(
                        differ, None,
                        "{}: frame {i}, cell {cell} m: {r:?}: grids differ at this cell",
                        seq.name
                    );
                }
                assert!(outcomes[0].grid.cells_hit > 0, "{}: frame {i}: no cell hit", seq.name);
                verdicts.extend(outcomes[0].objects.iter().map(|r| r.verdict.name()));
            }
            assert!(verdicts.len() > 1, "{}: cell {cell} m: a single verdict kind {verdicts:?}", seq.name);
        }
    }
}

/// The real sweeps handed over as columns (`Monitor::check_columns`) give the reports (by their `Debug` text) and
/// grids (hits and flags of every touched cell) of the same sweeps as `[x, y, z]` records, frame after frame, with
/// each rasterizer; the Argoverse 2 frames carry their map's region of interest, and returns in it are found
/// through the columns: with the grazing rule (the default: its count of the edge cells' returns) and without it
/// (`roi_graze_fraction = 0`: the scan that marks `FLAG_RETURN_IN_ROI`, which the rule's count takes the place of).
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn columns_agree_with_records_on_real_sweeps() {
    let mut returns_in_roi = 0usize;
    let off = MonitorParams { roi_graze_fraction: 0.0, ..params(0.5) };
    for (seq, _) in real_sequences() {
        let columns = seq.sweep_columns();
        for (rasterizer, p) in [
            (Rasterizer::Blocked, params(0.5)),
            (Rasterizer::Scalar, params(0.5)),
            (Rasterizer::Blocked, off),
            (Rasterizer::Scalar, off),
        ] {
            let mut records = Monitor::new(p).unwrap();
            let mut by_columns = Monitor::new(p).unwrap();
            records.set_rasterizer(rasterizer);
            by_columns.set_rasterizer(rasterizer);
            for i in 0..seq.frames.len() + 2 {
                let mut roi = Vec::new();
                let frame = seq.frame_with_roi(i, Sequence::timestamp_s(i), &mut roi).unwrap();
                let a = format!("{:?}", Outcome::from(records.check(&frame).unwrap()));
                let sweep = seq.frames[i % seq.frames.len()].sweep.unwrap();
                let [x, y, z] = &columns[sweep];
                let cloud = ColumnCloud {
                    points_in_sensor: PointColumns::new(x, y, z).unwrap(),
                    ego_from_sensor: seq.sweeps[sweep].ego_from_sensor,
                };
                let b = format!(
                    "{:?}",
                    Outcome::from(by_columns.check_columns(&Frame { cloud: None, ..frame }, &cloud).unwrap())
                );
                let at = format!("{}: frame {i}, {rasterizer:?}, graze {}", seq.name, p.roi_graze_fraction);
                assert!(a == b, "{at}: reports from columns differ from those from records");
                let (g, h) = (records.grid(), by_columns.grid());
                assert_eq!(g.touched(), h.touched(), "{at}: touched cells");
                for &c in g.touched() {
                    assert_eq!((g.hits(c), g.flags(c)), (h.hits(c), h.flags(c)), "{at}: cell {c}");
                }
                returns_in_roi += g.touched().iter().filter(|&&c| g.flags(c) & FLAG_RETURN_IN_ROI != 0).count();
            }
        }
    }
    if real_sequences().iter().any(|(s, _)| s.sweeps.iter().any(|s| !s.roi_in_ego.is_empty())) {
        assert!(returns_in_roi > 0, "the region of interest's scan of the returns is exercised");
    }
}
