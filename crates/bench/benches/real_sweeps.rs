//! Latency of `Monitor::check` on the real sweeps of the shared data, single thread (divan):
//! `cargo bench -p pmon-bench --bench real_sweeps`.
//!
//! The Argoverse 2 sweeps (two stacked 32-beam lidars, about 99,000 points, read with `pmon-datasets`) with 100
//! synthetic objects, and for comparison the KITTI HDL-64E sweeps (100 objects) and the nuScenes 32-beam sweep
//! (30 objects): the same sequences as the `av2/0.5m`, `kitti/0.5m` and `nuscenes/0.5m` cases of `pmon bench`
//! (`pmon_bench::av2`, `pmon_bench::frames`; with their regions of interest: AV2's vector map, KITTI's labelled
//! field of view), paper parameters (100 m grid, 0.5 m cells). The data folder is
//! `PMON_DATA_DIR`, default `<workspace>/../shared/data`; a benchmark whose sweeps are absent prints a message
//! and measures nothing. The `floor` benchmarks read every point once (a sum of all coordinates).
//!
//! Each benchmark reuses one `Monitor` and cycles through its frames with increasing timestamps, as in a car
//! (the same loop as `pmon-monitor`'s benchmarks, whose KITTI and nuScenes figures these should match).
// A benchmark binary: a failure to build its fixed inputs is a bug worth a panic with a message.
#![allow(clippy::expect_used, clippy::panic, missing_docs)]

use std::sync::LazyLock;

use divan::counter::ItemsCount;
use divan::Bencher;
use pmon_bench::frames::{self, Sequence, SyntheticSpec};
use pmon_monitor::{Monitor, MonitorParams};

fn main() {
    divan::main();
}

static AV2: LazyLock<Option<Sequence>> = LazyLock::new(|| {
    pmon_bench::av2::sequence(pmon_bench::av2::sweeps(&frames::data_dir()).unwrap_or_else(|e| panic!("{e}")))
});
static KITTI: LazyLock<Option<Sequence>> = LazyLock::new(|| {
    let dir = frames::data_dir();
    let mut sweeps = frames::kitti_sweeps(&dir).unwrap_or_else(|e| panic!("{e}"));
    pmon_bench::kitti_fields_of_view(&dir, &mut sweeps).unwrap_or_else(|e| panic!("{e}"));
    Sequence::real("kitti", sweeps, &SyntheticSpec::BEAMS_64)
});
static NUSCENES: LazyLock<Option<Sequence>> = LazyLock::new(|| {
    let sweeps = frames::nuscenes_sweeps(&frames::data_dir()).unwrap_or_else(|e| panic!("{e}"));
    Sequence::real("nuscenes", sweeps, &SyntheticSpec::BEAMS_32)
});

/// Benchmarks `check` on `seq` with one reused monitor (paper parameters), cycling through the frames with
/// increasing timestamps.
fn bench_check(bencher: Bencher<'_, '_>, seq: &Sequence) {
    let mut monitor = Monitor::new(MonitorParams::PAPER).expect("valid parameters");
    let n = seq.frames.len();
    // Warm-up: one cycle.
    for i in 0..n {
        let mut roi = Vec::new();
        let f = seq.frame_with_roi(i, Sequence::timestamp_s(i), &mut roi).expect("non-empty sequence");
        monitor.check(&f).expect("frame within capacity");
    }
    let mut i = n;
    bencher.counter(ItemsCount::new(seq.max_points())).bench_local(|| {
        let mut roi = Vec::new();
        let f = seq.frame_with_roi(i, Sequence::timestamp_s(i), &mut roi).expect("non-empty sequence");
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

/// Runs `run` on the sequence, or says why there is none.
fn with(seq: &Option<Sequence>, what: &str, run: impl FnOnce(&Sequence)) {
    match seq {
        Some(seq) => run(seq),
        None => eprintln!("skipped {what}: no sweeps under {} (set PMON_DATA_DIR)", frames::data_dir().display()),
    }
}

/// The Argoverse 2 sweeps (about 99,000 points) with 100 synthetic objects, paper grid.
#[divan::bench]
fn check_av2_100_objects(bencher: Bencher<'_, '_>) {
    with(&AV2, "Argoverse 2", |seq| bench_check(bencher, seq));
}

/// KITTI HDL-64E sweeps (about 120,000 points) with 100 synthetic objects, paper grid.
#[divan::bench]
fn check_kitti_100_objects(bencher: Bencher<'_, '_>) {
    with(&KITTI, "KITTI", |seq| bench_check(bencher, seq));
}

/// The nuScenes 32-beam sweep (34,688 points) with 30 synthetic objects, paper grid.
#[divan::bench]
fn check_nuscenes_30_objects(bencher: Bencher<'_, '_>) {
    with(&NUSCENES, "nuScenes", |seq| bench_check(bencher, seq));
}

/// Reading every point once.
#[divan::bench_group]
mod floor {
    use super::*;

    #[divan::bench]
    fn av2(bencher: Bencher<'_, '_>) {
        with(&AV2, "Argoverse 2", |seq| bench_floor(bencher, seq));
    }

    #[divan::bench]
    fn kitti(bencher: Bencher<'_, '_>) {
        with(&KITTI, "KITTI", |seq| bench_floor(bencher, seq));
    }

    #[divan::bench]
    fn nuscenes(bencher: Bencher<'_, '_>) {
        with(&NUSCENES, "nuScenes", |seq| bench_floor(bencher, seq));
    }
}
