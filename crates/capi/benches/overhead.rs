//! Overhead of the C API: `pmon_monitor_check` against `Monitor::check` on the same 64-beam synthetic frames
//! (120,000 points, 100 objects, paper parameters; `crates/bench/src/frames.rs`), in one run:
//! `cargo bench -p pmon-capi --bench overhead`.
//!
//! The C side gets its input as a C caller would hold it: the object list already in `PmonObject` records and
//! the points as a flat `float` array (stride 3), converted once before timing; what is timed is the call,
//! including the validation of the arguments, the copy of the objects into the monitor's buffer and the writing
//! of the result records with their texts.
#![allow(unsafe_code, clippy::expect_used, clippy::panic, clippy::indexing_slicing, missing_docs)]

#[path = "../../bench/src/frames.rs"]
#[allow(dead_code)]
mod frames;

use std::sync::LazyLock;

use divan::Bencher;
use frames::{Sequence, SyntheticSpec};
use pmon_capi::ffi::*;
use pmon_monitor::{Monitor, MonitorParams};

fn main() {
    divan::main();
}

static SEQ: LazyLock<Sequence> = LazyLock::new(|| Sequence::synthetic(&SyntheticSpec::BEAMS_64));

#[divan::bench]
fn rust_check(bencher: Bencher<'_, '_>) {
    let seq = &*SEQ;
    let mut monitor = Monitor::new(MonitorParams::PAPER).expect("valid parameters");
    let mut i = 0usize;
    bencher.bench_local(|| {
        let f = seq.frame(i, Sequence::timestamp_s(i)).expect("frame");
        i += 1;
        let report = monitor.check(divan::black_box(&f)).expect("within capacity");
        divan::black_box(report.objects.len() + report.clusters.len())
    });
}

struct CFrame {
    objects: Vec<PmonObject>,
    frame: PmonFrame,
}

fn c_frames(seq: &Sequence) -> Vec<CFrame> {
    (0..seq.frames.len())
        .map(|k| {
            let f = seq.frame(k, 0.0).expect("frame");
            let objects: Vec<PmonObject> = f
                .objects
                .iter()
                .map(|o| PmonObject {
                    id: o.id,
                    class_: u32::try_from(o.class.index()).expect("class"),
                    has_uncertainty: 0,
                    x_m: o.x_m,
                    y_m: o.y_m,
                    heading_rad: o.heading_rad,
                    speed_mps: o.speed_mps,
                    length_m: o.length_m,
                    width_m: o.width_m,
                    uncertainty: PmonUncertainty::default(),
                })
                .collect();
            assert!(f.objects.iter().all(|o| o.uncertainty.is_none()), "the synthetic objects carry no sigma");
            let cloud = f.cloud.expect("a cloud");
            let r = cloud.ego_from_sensor.rotation;
            let frame = PmonFrame {
                timestamp_s: 0.0,
                world_x_m: f.world_from_ego.x_m,
                world_y_m: f.world_from_ego.y_m,
                world_yaw_rad: f.world_from_ego.yaw_rad,
                objects: objects.as_ptr(),
                object_count: objects.len(),
                has_cloud: 1,
                point_stride: 3,
                points: cloud.points_in_sensor.as_ptr().cast::<f32>(),
                point_count: cloud.points_in_sensor.len(),
                ego_from_sensor_rotation: [
                    r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2],
                ],
                ego_from_sensor_translation_m: cloud.ego_from_sensor.translation_m,
                roi: std::ptr::null(),
                roi_count: 0,
                scenery: std::ptr::null(),
                scenery_count: 0,
            };
            CFrame { objects, frame }
        })
        .collect()
}

#[divan::bench]
fn c_api_check(bencher: Bencher<'_, '_>) {
    let frames = c_frames(&SEQ);
    let mut monitor = std::ptr::null_mut();
    // SAFETY: valid out pointer.
    assert_eq!(unsafe { pmon_monitor_new(std::ptr::null(), &mut monitor) }, PMON_OK);
    // SAFETY: all-zero is a valid PmonObjectResult (integers, floats, byte arrays).
    let mut results = vec![unsafe { std::mem::zeroed::<PmonObjectResult>() }; 1024];
    let mut clusters = vec![PmonCluster::default(); 512];
    let mut i = 0usize;
    bencher.bench_local(|| {
        let c = &frames[i % frames.len()];
        debug_assert_eq!(c.objects.len(), c.frame.object_count);
        let mut frame = c.frame;
        frame.timestamp_s = Sequence::timestamp_s(i);
        i += 1;
        let mut summary = PmonFrameSummary::default();
        // SAFETY: every pointer is valid for its count.
        let rc = unsafe {
            pmon_monitor_check(
                monitor,
                divan::black_box(&frame),
                results.as_mut_ptr(),
                results.len(),
                clusters.as_mut_ptr(),
                clusters.len(),
                &mut summary,
            )
        };
        assert_eq!(rc, PMON_OK);
        divan::black_box(summary.object_count + summary.cluster_count)
    });
    // SAFETY: created above, freed once.
    unsafe { pmon_monitor_free(monitor) };
}
