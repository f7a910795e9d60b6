//! Latency of `Monitor::check`, single thread (divan): `cargo bench -p pmon-monitor`.
//!
//! Frames come from `crates/bench/src/frames.rs` (shared with the `pmon-bench` crate through `#[path]`, since this
//! crate may not depend on it): a synthetic 64-beam sweep (120,000 points) with 100 objects, a 32-beam sweep
//! (34,720 points) with 30 objects, the largest accepted frame (400,000 points, 1,024 objects), object lists
//! without a cloud, and the real KITTI and nuScenes sweeps of the shared data (`PMON_DATA_DIR`, default
//! `<workspace>/../shared/data`; skipped with a message when absent). Argoverse 2 sweeps (Feather) are
//! benched in `pmon-bench` (`cargo bench -p pmon-bench --bench real_sweeps`), which has the Arrow reader this
//! crate does not.
//!
//! Each benchmark reuses one `Monitor` and cycles through its frames with increasing timestamps, as in a car.
//! Per-stage medians (rasterize, regions, conflicts, plausibility, verdicts) come from `pmon bench` (the
//! `pmon-bench` crate), which reads the clock at the stage boundaries of `Monitor::check_with_stages`.
//! The `floor` benchmarks read every point once (a sum of all coordinates): no check can be faster.
// A benchmark binary: a failure to build its fixed inputs is a bug worth a panic with a message.
#![allow(clippy::expect_used, clippy::panic, clippy::std_instead_of_core, missing_docs)]

#[path = "../../bench/src/frames.rs"]
#[allow(dead_code)]
mod frames;

use std::sync::LazyLock;

use divan::counter::ItemsCount;
use divan::Bencher;
use frames::{Sequence, SyntheticSpec};
use pmon_monitor::{Monitor, MonitorParams};

fn main() {
    divan::main();
}

static SYNTHETIC_64: LazyLock<Sequence> = LazyLock::new(|| Sequence::synthetic(&SyntheticSpec::BEAMS_64));
static SYNTHETIC_32: LazyLock<Sequence> = LazyLock::new(|| Sequence::synthetic(&SyntheticSpec::BEAMS_32));
static WORST_CASE: LazyLock<Sequence> = LazyLock::new(|| Sequence::synthetic(&SyntheticSpec::WORST_CASE));
static KITTI: LazyLock<Option<Sequence>> = LazyLock::new(|| {
    let sweeps = frames::kitti_sweeps(&frames::data_dir()).unwrap_or_else(|e| panic!("{e}"));
    Sequence::real("kitti", sweeps, &SyntheticSpec::BEAMS_64)
});
static NUSCENES: LazyLock<Option<Sequence>> = LazyLock::new(|| {
    let sweeps = frames::nuscenes_sweeps(&frames::data_dir()).unwrap_or_else(|e| panic!("{e}"));
    Sequence::real("nuscenes", sweeps, &SyntheticSpec::BEAMS_32)
});

fn params(cell_size_m: f32, grid_size_m: f32) -> MonitorParams {
    MonitorParams { cell_size_m, grid_size_m, ..MonitorParams::PAPER }
}

/// Benchmarks `check` on `seq` with one reused monitor, cycling through the frames with increasing timestamps.
fn bench_check(bencher: Bencher<'_, '_>, seq: &Sequence, params: MonitorParams, with_cloud: bool) {
    let mut monitor = Monitor::new(params).expect("valid parameters");
    let n = seq.frames.len();
    let frame = |i: usize| {
        let t = Sequence::timestamp_s(i);
        if with_cloud { seq.frame(i, t) } else { seq.frame_without_cloud(i, t) }.expect("non-empty sequence")
    };
    // Warm-up: one cycle.
    for i in 0..n {
        monitor.check(&frame(i)).expect("frame within capacity");
    }
    let mut i = n;
    // Throughput in points per second, or in objects per second without a cloud.
    let items = if with_cloud { seq.max_points() } else { seq.max_objects() };
    bencher.counter(ItemsCount::new(items)).bench_local(|| {
        let f = frame(i);
        i += 1;
        let report = monitor.check(divan::black_box(&f)).expect("frame within capacity");
        divan::black_box(report.objects.len() + report.clusters.len())
    });
}

fn bench_floor(bencher: Bencher<'_, '_>, seq: &Sequence) {
    let mut i = 0usize;
    bencher.counter(ItemsCount::new(seq.max_points())).bench_local(|| {
        let cloud = seq.frame(i, 0.0).and_then(|f| f.cloud).expect("a sweep");
        i += 1;
        frames::coordinate_sum(divan::black_box(cloud.points_in_sensor))
    });
}

fn skip(what: &str) {
    eprintln!("skipped {what}: no sweeps under {} (set PMON_DATA_DIR)", frames::data_dir().display());
}

/// 64-beam synthetic sweep, 100 objects, 100 m grid: the cell size sweeps 0.5 m (paper), 0.2 m, 0.1 m.
#[divan::bench(args = [0.5, 0.2, 0.1])]
fn check_64_beams_100_objects(bencher: Bencher<'_, '_>, cell_size_m: f32) {
    bench_check(bencher, &SYNTHETIC_64, params(cell_size_m, 100.0), true);
}

/// Same frames and 0.2 m cells on grids of 100 m, 150 m and 200 m: 1x, 2.25x and 4x the cells.
#[divan::bench(args = [100.0, 150.0, 200.0])]
fn grid_area_64_beams_0_2m_cells(bencher: Bencher<'_, '_>, grid_size_m: f32) {
    bench_check(bencher, &SYNTHETIC_64, params(0.2, grid_size_m), true);
}

/// 32-beam synthetic sweep, 30 objects, paper grid.
#[divan::bench]
fn check_32_beams_30_objects(bencher: Bencher<'_, '_>) {
    bench_check(bencher, &SYNTHETIC_32, params(0.5, 100.0), true);
}

/// The largest frame the paper parameters accept: 400,000 points, 1,024 objects.
#[divan::bench]
fn check_worst_case_400k_points_1024_objects(bencher: Bencher<'_, '_>) {
    bench_check(bencher, &WORST_CASE, params(0.5, 100.0), true);
}

/// The 64-beam frames' object lists without their clouds: the plausibility checks (plus building each object's
/// region and the verdicts) for 30 to 1,000 objects.
#[divan::bench(args = [30, 100, 300, 1000])]
fn check_without_cloud(bencher: Bencher<'_, '_>, objects: u32) {
    let seq = Sequence::synthetic(&SyntheticSpec::objects_only(objects));
    bench_check(bencher, &seq, params(0.5, 100.0), false);
}

/// KITTI HDL-64E sweeps (about 120,000 points) with 100 synthetic objects, paper grid.
#[divan::bench]
fn check_kitti_100_objects(bencher: Bencher<'_, '_>) {
    match KITTI.as_ref() {
        Some(seq) => bench_check(bencher, seq, params(0.5, 100.0), true),
        None => skip("KITTI"),
    }
}

/// The nuScenes 32-beam sweep (34,688 points) with 30 synthetic objects, paper grid.
#[divan::bench]
fn check_nuscenes_30_objects(bencher: Bencher<'_, '_>) {
    match NUSCENES.as_ref() {
        Some(seq) => bench_check(bencher, seq, params(0.5, 100.0), true),
        None => skip("nuScenes"),
    }
}

/// Reading every point once.
#[divan::bench_group]
mod floor {
    use super::*;

    #[divan::bench]
    fn synthetic_64_beams(bencher: Bencher<'_, '_>) {
        bench_floor(bencher, &SYNTHETIC_64);
    }

    #[divan::bench]
    fn synthetic_32_beams(bencher: Bencher<'_, '_>) {
        bench_floor(bencher, &SYNTHETIC_32);
    }

    #[divan::bench]
    fn worst_case(bencher: Bencher<'_, '_>) {
        bench_floor(bencher, &WORST_CASE);
    }

    #[divan::bench]
    fn kitti(bencher: Bencher<'_, '_>) {
        match KITTI.as_ref() {
            Some(seq) => bench_floor(bencher, seq),
            None => skip("KITTI"),
        }
    }

    #[divan::bench]
    fn nuscenes(bencher: Bencher<'_, '_>) {
        match NUSCENES.as_ref() {
            Some(seq) => bench_floor(bencher, seq),
            None => skip("nuScenes"),
        }
    }
}
