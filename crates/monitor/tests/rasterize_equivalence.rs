//! The blocked rasterizer (the default, with AVX2 where the processor has it, and on the baseline instruction set)
//! and the reference per-point loop give identical results: three monitors, one per `Rasterizer`, fed the same frames one after the other, return identical `FrameReport`s (objects,
//! clusters, grid statistics, compared field by field and by their `Debug` text, which tells `-0.0` from `0.0`)
//! and identical grids (touched cells in the same order, the same hits and flags in every touched cell).
//!
//! Frames: the synthetic 64- and 32-beam sequences of the benchmarks (`crates/bench/src/frames.rs`, through
//! `#[path]`), clouds with NaN and infinite coordinates, points exactly on cell borders and on the band limits,
//! empty clouds, clouds of 1 to 200 points (every remainder of the 64-point blocks), and the real KITTI and nuScenes
//! sweeps of the shared data (`PMON_DATA_DIR`, default `<workspace>/../shared/data`; skipped with a message when
//! absent); plus a property test over random small clouds, grids, bands and extrinsics.
//!
//! A fourth monitor runs every frame through [`Monitor::check_split`] on two threads (sweeps of at least
//! `pmon_monitor::split::SPLIT_MIN_POINTS` points rasterized in two halves): the same reports and grids.
//!
//! Four more monitors (the same four paths) get every frame's sweep as columns ([`Monitor::check_columns`],
//! [`PointColumns`]: separate `x`, `y`, `z` slices): the same reports and grids as from `[x, y, z]` records.
//!
//! The bit-exactness of the visibility map itself (both range arrays and the cells) is tested inside the crate
//! (`src/rasterize.rs`), where the map's arrays are visible.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    clippy::std_instead_of_core,
    missing_docs
)]

#[path = "../../bench/src/frames.rs"]
#[allow(dead_code)]
mod frames;

use frames::{Sequence, Sweep, SyntheticSpec};
use pmon_monitor::split::SPLIT_MIN_POINTS;
use pmon_monitor::{
    ClusterReport, ColumnCloud, ColumnLengthError, Frame, GridStats, Isometry3, Join, Monitor, MonitorParams,
    NotMonitoredReason, ObjectClass, ObjectReport, ObjectState, PointCloud, PointColumns, Pose2, Rasterizer,
};
use proptest::prelude::*;

/// A touched cell: index, hits, flags, sums (as bits) and tall bit.
type CellRecord = (u32, u16, u8, Option<[u32; 3]>, bool);

/// A `FrameReport` and the grid after it, owned.
#[derive(Debug, PartialEq)]
struct Outcome {
    objects: Vec<ObjectReport>,
    clusters: Vec<ClusterReport>,
    grid: GridStats,
    sensor_status: Option<NotMonitoredReason>,
    /// Every touched cell, in the order of first touch: hits, flags, the sums of its returns' x and y and their
    /// number (as bits; with `jump_from_returns`), and whether a return above the grazing height fell in it (with
    /// `roi_graze_fraction`).
    cells: Vec<CellRecord>,
}

/// [`Join`] on two threads (`std::thread::scope`): the rasterize stage's halves at the same time.
struct Threads;

impl Join for Threads {
    fn join(&self, a: &mut (dyn FnMut() + Send), b: &mut (dyn FnMut() + Send)) {
        std::thread::scope(|s| {
            s.spawn(b);
            a();
        });
    }
}

fn outcome(monitor: &mut Monitor, frame: &Frame<'_>) -> Result<Outcome, String> {
    outcome_of(monitor, frame, false)
}

/// The outcome of [`Monitor::check`], or with `split` of [`Monitor::check_split`] on two threads.
fn outcome_of(monitor: &mut Monitor, frame: &Frame<'_>, split: bool) -> Result<Outcome, String> {
    let report = if split { monitor.check_split(frame, &Threads) } else { monitor.check(frame) };
    let report = owned(report)?;
    Ok(with_grid(monitor, report))
}

/// The frame's sweep as three columns.
fn columns_of(frame: &Frame<'_>) -> Option<([Vec<f32>; 3], Isometry3)> {
    frame.cloud.map(|c| {
        let p = c.points_in_sensor;
        (
            [p.iter().map(|p| p[0]).collect(), p.iter().map(|p| p[1]).collect(), p.iter().map(|p| p[2]).collect()],
            c.ego_from_sensor,
        )
    })
}

/// [`outcome_of`] with the frame's sweep handed over as columns ([`Monitor::check_columns`], or with `split`
/// [`Monitor::check_columns_split_with_stages`] on two threads); a frame without a cloud goes through
/// [`Monitor::check`].
fn outcome_of_columns(monitor: &mut Monitor, frame: &Frame<'_>, split: bool) -> Result<Outcome, String> {
    let Some(([x, y, z], ego_from_sensor)) = columns_of(frame) else { return outcome_of(monitor, frame, split) };
    let cloud = ColumnCloud { points_in_sensor: PointColumns::new(&x, &y, &z).unwrap(), ego_from_sensor };
    let without = Frame { cloud: None, ..*frame };
    let report = if split {
        monitor.check_columns_split_with_stages(&without, &cloud, &Threads, &mut |_| {})
    } else {
        monitor.check_columns(&without, &cloud)
    };
    let report = owned(report)?;
    Ok(with_grid(monitor, report))
}

/// A report, owned (without the grid's cells).
fn owned(report: Result<pmon_monitor::FrameReport<'_>, pmon_monitor::FrameError>) -> Result<Outcome, String> {
    let report = report.map_err(|e| e.to_string())?;
    let (objects, clusters, grid, sensor_status) =
        (report.objects.to_vec(), report.clusters.to_vec(), report.grid, report.sensor_status);
    Ok(Outcome { objects, clusters, grid, sensor_status, cells: Vec::new() })
}

/// `outcome` with the monitor's touched cells after the check.
fn with_grid(monitor: &Monitor, outcome: Outcome) -> Outcome {
    let g = monitor.grid();
    let cells = g
        .touched()
        .iter()
        .map(|&c| (c, g.hits(c), g.flags(c), g.sums(c).map(|s| s.map(f32::to_bits)), g.tall(c)))
        .collect();
    Outcome { cells, ..outcome }
}

/// Monitors with the same parameters, one per rasterizer: the blocked loop with the widest vector unit of this
/// processor (AVX2 on most x86-64 machines), the blocked loop on the baseline instruction set, the reference;
/// and the blocked loop with large sweeps cut in two halves on two threads ([`Monitor::check_split`]).
struct Pair {
    blocked: Monitor,
    baseline: Monitor,
    scalar: Monitor,
    split: Monitor,
    /// The same four, given the sweeps as columns.
    columns: [Monitor; 4],
    frames: usize,
}

impl Pair {
    fn new(params: MonitorParams) -> Self {
        let blocked = Monitor::new(params).unwrap();
        let mut baseline = Monitor::new(params).unwrap();
        baseline.set_rasterizer(Rasterizer::BlockedBaseline);
        let mut scalar = Monitor::new(params).unwrap();
        scalar.set_rasterizer(Rasterizer::Scalar);
        let mut split = Monitor::new(params).unwrap();
        split.enable_split();
        let columns =
            [Rasterizer::Blocked, Rasterizer::BlockedBaseline, Rasterizer::Scalar, Rasterizer::Blocked].map(|r| {
                let mut m = Monitor::new(params).unwrap();
                m.set_rasterizer(r);
                m
            });
        let mut columns = columns;
        columns[3].enable_split();
        Self { blocked, baseline, scalar, split, columns, frames: 0 }
    }

    /// Checks one frame with all three; panics (with `what`) on any difference; returns the blocked outcome.
    fn check(&mut self, frame: &Frame<'_>, what: &str) -> Result<Outcome, String> {
        let a = outcome(&mut self.blocked, frame);
        let b = outcome(&mut self.scalar, frame);
        let c = outcome(&mut self.baseline, frame);
        let d = outcome_of(&mut self.split, frame, true);
        let isa = Rasterizer::Blocked.instruction_set();
        assert_eq!(a, b, "{what}: blocked ({isa}) and scalar rasterizers differ");
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "{what}: blocked ({isa}) and scalar differ in some bit");
        assert_eq!(format!("{c:?}"), format!("{b:?}"), "{what}: blocked (baseline) and scalar differ in some bit");
        assert_eq!(format!("{d:?}"), format!("{b:?}"), "{what}: split on two threads and scalar differ in some bit");
        for (k, m) in self.columns.iter_mut().enumerate() {
            let e = outcome_of_columns(m, frame, k == 3);
            let path = ["blocked", "baseline", "scalar", "split"][k];
            assert_eq!(format!("{e:?}"), format!("{b:?}"), "{what}: columns ({path}) and records differ in some bit");
        }
        self.frames += 1;
        a
    }
}

fn frame<'a>(t_s: f64, objects: &'a [ObjectState], cloud: Option<PointCloud<'a>>) -> Frame<'a> {
    Frame { timestamp_s: t_s, world_from_ego: Pose2::default(), objects, cloud, roi_in_ego: &[], static_in_ego: &[] }
}

fn car(id: u64, x: f32, y: f32) -> ObjectState {
    ObjectState {
        id,
        class: ObjectClass::Car,
        x_m: x,
        y_m: y,
        heading_rad: 0.3,
        speed_mps: 0.0,
        length_m: 4.5,
        width_m: 1.9,
        uncertainty: None,
    }
}

/// Runs a sequence through both rasterizers, frame after frame (two cycles, so the second sees history and the
/// touched-cell reset); returns the points in band summed over all frames.
fn run_sequence(seq: &Sequence, params: MonitorParams, extrinsics: &[Isometry3]) -> u64 {
    let mut pair = Pair::new(params);
    let mut in_band = 0u64;
    let n = seq.frames.len();
    for i in 0..2 * n {
        let f = seq.frame(i, Sequence::timestamp_s(i)).unwrap();
        for (k, ext) in extrinsics.iter().enumerate() {
            let cloud = f.cloud.map(|c| PointCloud { ego_from_sensor: *ext, ..c });
            let f = Frame { cloud, timestamp_s: Sequence::timestamp_s(i * extrinsics.len() + k), ..f };
            let out = pair.check(&f, &format!("{} frame {i} extrinsic {ext:?}", seq.name)).unwrap();
            in_band += u64::from(out.grid.points_in_band);
        }
    }
    in_band
}

#[test]
fn synthetic_sequences_give_identical_reports() {
    let seq32 = Sequence::synthetic(&SyntheticSpec::BEAMS_32);
    let seq64 = Sequence::synthetic(&SyntheticSpec { frames: 3, ..SyntheticSpec::BEAMS_64 });
    let upright = Isometry3::from_translation(0.0, 0.0, frames::SENSOR_HEIGHT_M);
    let yawed = Isometry3::from_yaw_translation(0.7, [1.2, -0.3, frames::SENSOR_HEIGHT_M]);
    for cell_size_m in [0.5, 0.2] {
        let params = MonitorParams { cell_size_m, ..MonitorParams::PAPER };
        let in_band = run_sequence(&seq32, params, &[upright, yawed]);
        assert!(in_band > 10_000, "the 32-beam frames have obstacle points: {in_band}");
        let in_band = run_sequence(&seq64, params, &[upright]);
        assert!(in_band > 100_000, "the 64-beam frames have obstacle points: {in_band}");
    }
    // With the params keys whose per-cell data the rasterizer keeps (`jump_from_returns`: each hit cell's sums;
    // the grazing rule: the tall bits; frames without a region of interest keep none, see the test below).
    let params = MonitorParams { jump_from_returns: true, roi_graze_fraction: 0.5, ..MonitorParams::PAPER };
    run_sequence(&seq32, params, &[upright, yawed]);
    run_sequence(&seq64, params, &[upright]);
    // And with each hit cell's first return instead of its sums (`jump_first_return`).
    let params = MonitorParams { jump_first_return: true, ..params };
    run_sequence(&seq32, params, &[upright, yawed]);
    run_sequence(&seq64, params, &[upright]);
    // With `seen_over`: every frame's cells recorded (the 64-beam frames on two threads too), and the returns of the
    // cells it reads gathered from them before the verdicts (`monitor/over.rs`).
    let params = MonitorParams { seen_over: true, ..MonitorParams::PAPER };
    run_sequence(&seq32, params, &[upright, yawed]);
    run_sequence(&seq64, params, &[upright]);
}

#[test]
fn special_frames_give_identical_reports() {
    let params = MonitorParams::PAPER;
    let mut pair = Pair::new(params);
    let objects = [car(1, 12.0, 3.0), car(2, -20.0, -7.5), car(3, 30.0, 30.0)];
    let ext = Isometry3::from_translation(0.0, 0.0, 1.8);
    let mut t = 0.0;
    let mut next = |pair: &mut Pair, points: &[[f32; 3]], ext: Isometry3, what: &str| {
        t += 0.1;
        let cloud = PointCloud { points_in_sensor: points, ego_from_sensor: ext };
        pair.check(&frame(t, &objects, Some(cloud)), what).unwrap()
    };

    // Empty cloud, no cloud.
    let out = next(&mut pair, &[], ext, "empty cloud");
    assert_eq!(out.sensor_status, Some(NotMonitoredReason::EmptyCloud));
    pair.check(&frame(9.0, &objects, None), "no cloud").unwrap();

    // NaN and infinite coordinates (in every position), huge values whose range overflows.
    let specials = [0.0, -0.0, 1.5, -1.5, 3e38, -3e38, f32::MAX, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
    let mut weird = Vec::new();
    for &a in &specials {
        for &b in &specials {
            for z in [-1.8, -1.0, 0.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                weird.extend([[a, b, z], [12.0, a, z], [b, 3.0, z]]);
            }
        }
    }
    let out = next(&mut pair, &weird, ext, "NaN and infinite points");
    assert!(out.grid.points_in_band > 0);

    // Points exactly on cell borders (the 100 m grid of 0.5 m cells spans -50 m .. 50 m), just inside and just
    // outside, at the band limits (z = 0.3 m and 2.5 m in the ego frame), and at the sensor's own position.
    let (lo, hi) = (params.ground_z_m + params.min_obstacle_height_m, params.ground_z_m + params.max_obstacle_height_m);
    let mut borders = Vec::new();
    for k in -2..=202 {
        let v = -50.0 + 0.5 * k as f32;
        for w in [v, v.next_up(), v.next_down()] {
            for z in [lo, hi, lo.next_down(), hi.next_up(), 1.0] {
                let z = z - 1.8;
                borders.extend([[w, 3.25, z], [-11.0, w, z], [w, w, z], [w, -w, z]]);
            }
        }
    }
    borders.extend([[0.0, 0.0, -1.0], [0.0, 0.0, 0.0], [-0.0, -0.0, -1.8]]);
    let out = next(&mut pair, &borders, ext, "cell borders and band limits");
    assert!(out.grid.cells_hit > 200, "{:?}", out.grid);
    // The same with an extrinsic that is not a pure translation (every rotation entry used).
    let tilted =
        Isometry3 { rotation: [[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]], translation_m: [0.5, 0.25, 1.8] };
    next(&mut pair, &borders, tilted, "cell borders, rotated extrinsic");
    next(&mut pair, &weird, tilted, "NaN and infinite points, rotated extrinsic");

    // Clouds of 1 to 200 points: every remainder of a block, and blocks plus remainders.
    let ring: Vec<[f32; 3]> = (0..200)
        .map(|i| {
            let a = i as f32 * 0.173;
            let r = 5.0 + (i % 37) as f32;
            [r * a.cos(), r * a.sin(), if i % 3 == 0 { -1.8 } else { -0.5 }]
        })
        .collect();
    for len in 1..=200 {
        next(&mut pair, &ring[..len], ext, &format!("{len} points"));
    }

    // More points than max_points: not monitored, by both.
    let mut small = Pair::new(MonitorParams { max_points: 10, ..MonitorParams::PAPER });
    let cloud = PointCloud { points_in_sensor: &ring[..11], ego_from_sensor: ext };
    let out = small.check(&frame(1.0, &objects, Some(cloud)), "too many points").unwrap();
    assert_eq!(out.sensor_status, Some(NotMonitoredReason::TooManyPoints));
    assert!(pair.frames > 200);
}

#[test]
fn real_sweeps_give_identical_reports() {
    let data = frames::data_dir();
    let kitti = frames::kitti_sweeps(&data).unwrap_or_else(|e| panic!("{e}"));
    let nuscenes = frames::nuscenes_sweeps(&data).unwrap_or_else(|e| panic!("{e}"));
    if kitti.is_empty() && nuscenes.is_empty() {
        eprintln!("skipped: no KITTI or nuScenes sweeps under {} (set PMON_DATA_DIR)", data.display());
        return;
    }
    // The extrinsics of the data sets (KITTI 1.73 m; nuScenes LIDAR_TOP 1.84 m, and the 1.8 m the benchmarks use),
    // and one with a yaw and an offset.
    let cases: [(&str, Vec<Sweep>, SyntheticSpec, Vec<Isometry3>); 2] = [
        (
            "kitti",
            kitti,
            SyntheticSpec::BEAMS_64,
            vec![Isometry3::from_translation(0.0, 0.0, 1.73), Isometry3::from_yaw_translation(-0.4, [0.8, 0.1, 1.73])],
        ),
        (
            "nuscenes",
            nuscenes,
            SyntheticSpec::BEAMS_32,
            vec![
                Isometry3::from_translation(0.0, 0.0, 1.84),
                Isometry3::from_translation(0.0, 0.0, 1.8),
                Isometry3::from_yaw_translation(1.57, [0.9, 0.0, 1.84]),
            ],
        ),
    ];
    for (name, sweeps, objects, extrinsics) in cases {
        let count = sweeps.len();
        let Some(seq) = Sequence::real(name, sweeps, &objects) else {
            eprintln!("skipped {name}: no sweeps under {}", data.display());
            continue;
        };
        for cell_size_m in [0.5, 0.2] {
            let params = MonitorParams { cell_size_m, ..MonitorParams::PAPER };
            let in_band = run_sequence(&seq, params, &extrinsics);
            assert!(in_band > 1_000 * count as u64, "{name}: obstacle points in band: {in_band}");
        }
    }
}

fn arb_point() -> impl Strategy<Value = [f32; 3]> {
    let coord = prop_oneof![
        8 => -60.0f32..60.0,
        1 => prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY), Just(0.0), Just(-0.0)],
        1 => (-100i32..=100).prop_map(|k| k as f32 * 0.5),
    ];
    let z = prop_oneof![4 => -2.5f32..1.5, 1 => prop_oneof![Just(-1.5f32), Just(0.7), Just(f32::NAN)]];
    (coord.clone(), coord, z).prop_map(|(x, y, z)| [x, y, z])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, .. ProptestConfig::default() })]

    /// Random small clouds, grids, bands, bin counts and extrinsics: identical reports and grids, over two
    /// consecutive frames (the second resets the touched cells of the first).
    #[test]
    fn random_small_clouds_give_identical_reports(
        clouds in proptest::collection::vec(proptest::collection::vec(arb_point(), 0..300), 2),
        cell_size_m in prop_oneof![Just(0.5f32), Just(0.2), Just(0.37), Just(1.0)],
        grid_size_m in prop_oneof![Just(100.0f32), Just(40.0), Just(73.3)],
        bins in prop_oneof![Just(8u32), Just(720), Just(1001), Just(1024), Just(1025), Just(65_536)],
        ground_z_m in -0.3f32..0.3,
        yaw in -3.2f32..3.2,
        offset in (-2.0f32..2.0, -2.0f32..2.0, 0.0f32..2.5),
        object_at in (-30.0f32..30.0, -30.0f32..30.0),
    ) {
        let params = MonitorParams { cell_size_m, grid_size_m, visibility_bins: bins, ground_z_m, ..MonitorParams::PAPER };
        let mut pair = Pair::new(params);
        let ext = Isometry3::from_yaw_translation(yaw, [offset.0, offset.1, offset.2]);
        let objects = [car(1, object_at.0, object_at.1), car(2, -object_at.1, object_at.0)];
        for (k, points) in clouds.iter().enumerate() {
            let cloud = PointCloud { points_in_sensor: points, ego_from_sensor: ext };
            let f = frame(0.1 * k as f64, &objects, Some(cloud));
            // Panics (fails the case) on any difference.
            let _ = pair.check(&f, "random cloud");
        }
    }
}

/// Frames with a region of interest (the rasterizer then records each point's cell for the ROI's edge cells):
/// [`Monitor::check_split`] on two threads gives the reports and grids of [`Monitor::check`], frame after frame.
#[test]
fn frames_with_a_region_of_interest_split_identically() {
    let seq = Sequence::synthetic(&SyntheticSpec { frames: 3, ..SyntheticSpec::BEAMS_64 });
    // A road 14 m wide along x, and a sidewalk polygon at an angle (edges through many cells).
    let road: [[f32; 2]; 4] = [[-40.0, -7.0], [40.0, -7.0], [40.0, 7.0], [-40.0, 7.0]];
    let walk: [[f32; 2]; 4] = [[-10.0, 7.0], [25.0, 9.0], [24.0, 12.5], [-11.0, 10.5]];
    let roi: [&[[f32; 2]]; 2] = [&road, &walk];
    let off = MonitorParams { cell_size_m: 0.5, ..MonitorParams::PAPER };
    // Also with the keys whose per-cell data the rasterizer keeps: each hit cell's sums (`jump_from_returns`) and
    // the tall bits (`roi_graze_fraction`), folded across the halves (`split.rs`), compared cell by cell.
    let on = MonitorParams { jump_from_returns: true, roi_graze_fraction: 0.5, ..off };
    // And each hit cell's first return instead of its sums (`jump_first_return`): a cell both halves touched keeps
    // the first half's.
    let first = MonitorParams { jump_first_return: true, ..on };
    let mut tall_cells = 0usize;
    for params in [off, on, first] {
        tall_cells += roi_frames_split_identically(&seq, &roi, params);
    }
    assert!(tall_cells > 100, "the 64-beam frames have returns above the grazing height in hit cells: {tall_cells}");
}

/// [`frames_with_a_region_of_interest_split_identically`] with one set of parameters; returns the number of hit
/// cells marked tall over all frames.
fn roi_frames_split_identically(seq: &Sequence, roi: &[&[[f32; 2]]], params: MonitorParams) -> usize {
    let mut tall_cells = 0;
    let mut one = Monitor::new(params).unwrap();
    let mut two = Monitor::new(params).unwrap();
    two.enable_split();
    let mut columns = Monitor::new(params).unwrap();
    let mut columns_split = Monitor::new(params).unwrap();
    columns_split.enable_split();
    let mut split_frames = 0;
    for i in 0..2 * seq.frames.len() {
        let f = seq.frame(i, Sequence::timestamp_s(i)).unwrap();
        // Every 50th return again 7 m higher: returns above the grazing height (4.5 m) over hit cells (the
        // synthetic scene has nothing taller than 3 m).
        let mut points = f.cloud.map(|c| c.points_in_sensor.to_vec()).unwrap_or_default();
        let tall: Vec<[f32; 3]> = points.iter().step_by(50).map(|p| [p[0], p[1], p[2] + 7.0]).collect();
        points.extend(tall);
        let cloud = f.cloud.map(|c| PointCloud { points_in_sensor: &points, ..c });
        let f = Frame { roi_in_ego: roi, cloud, ..f };
        split_frames += usize::from(f.cloud.is_some_and(|c| c.points_in_sensor.len() >= SPLIT_MIN_POINTS));
        let a = outcome_of(&mut one, &f, false).unwrap();
        let b = outcome_of(&mut two, &f, true).unwrap();
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "frame {i}: split on two threads differs in some bit");
        // The same frames with the sweep as columns (the ROI scan reads the returns of its edge cells from them).
        let c = outcome_of_columns(&mut columns, &f, false).unwrap();
        let d = outcome_of_columns(&mut columns_split, &f, true).unwrap();
        assert_eq!(format!("{c:?}"), format!("{a:?}"), "frame {i}: columns differ from records in some bit");
        assert_eq!(format!("{d:?}"), format!("{a:?}"), "frame {i}: columns, split, differ in some bit");
        assert_eq!(a.cells.iter().any(|c| c.3.is_some()), params.jump_from_returns, "frame {i}: sums kept");
        tall_cells += a.cells.iter().filter(|c| c.4).count();
    }
    assert_eq!(split_frames, 2 * seq.frames.len(), "every 64-beam sweep is large enough to be split");
    tall_cells
}

/// Columns of different lengths are refused when the view is made, with the three lengths in the error.
#[test]
fn columns_of_different_lengths_are_an_error() {
    let (a, b) = ([1.0f32, 2.0, 3.0], [1.0f32, 2.0]);
    let e = PointColumns::new(&a, &b, &a).unwrap_err();
    assert_eq!(e, ColumnLengthError { x: 3, y: 2, z: 3 });
    assert_eq!(
        e.to_string(),
        "point columns differ in length: x has 3, y has 2, z has 3 values (one value per point in each)"
    );
    assert!(PointColumns::new(&a, &a, &b).is_err());
    assert!(PointColumns::new(&b, &a, &a).is_err());
    let ok = PointColumns::new(&a, &a, &a).unwrap();
    assert_eq!((ok.len(), ok.get(2), ok.get(3)), (3, Some([3.0, 3.0, 3.0]), None));
    assert!(PointColumns::new(&[], &[], &[]).unwrap().is_empty());
}

/// A frame that carries a sweep of its own, handed over with a column sweep too, is refused: which sweep to check
/// would be a guess. Nothing is checked (the tracks do not advance: the same frame without its own sweep is
/// accepted afterwards at the same timestamp).
#[test]
fn a_frame_with_two_sweeps_is_refused() {
    let points = [[10.0f32, 0.0, 1.0], [10.1, 0.1, 1.2]];
    let own = PointCloud { points_in_sensor: &points, ego_from_sensor: Isometry3::IDENTITY };
    let frame = Frame {
        timestamp_s: 1.0,
        world_from_ego: Default::default(),
        objects: &[],
        cloud: Some(own),
        roi_in_ego: &[],
        static_in_ego: &[],
    };
    let ([x, y, z], extrinsic) = columns_of(&frame).unwrap();
    let columns = ColumnCloud { points_in_sensor: PointColumns::new(&x, &y, &z).unwrap(), ego_from_sensor: extrinsic };
    let mut monitor = Monitor::new(MonitorParams::default()).unwrap();
    let e = monitor.check_columns(&frame, &columns).unwrap_err();
    assert_eq!(e, pmon_monitor::FrameError::CloudGivenTwice);
    assert!(e.to_string().contains("column cloud"), "{e}");
    assert_eq!(monitor.check_columns_split_with_stages(&frame, &columns, &Threads, &mut |_| {}).unwrap_err(), e);
    let report = monitor.check_columns(&Frame { cloud: None, ..frame }, &columns).unwrap();
    assert_eq!(report.grid.points_total, 2);
}
