//! `Monitor::check` allocates nothing: counted through a global allocator.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    unsafe_code,
    clippy::std_instead_of_core
)]

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use common::*;
use pmon_monitor::{ColumnCloud, Frame, Monitor, MonitorParams, ObjectState, PointCloud, PointColumns, Pose2};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    // Only the test's own thread counts: the test harness allocates on other threads meanwhile.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
    }
}

// SAFETY: forwards to the system allocator and only counts calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn check_allocates_nothing_after_construction() {
    // Also with the free-space test over nearer obstacles (its per-cell returns are allocated with the grid), and
    // with the face-in-front test, and with the grazing rule of the ROI (a tree below grazes the road's edge), and
    // with step 9 from the returns (`jump_from_returns`: per-cell sums kept by the grid, allocated in `new`; the
    // last frame's boxes jump), and with both (the rasterizer's instantiation that keeps sums and tall bits), and
    // with the free-space test's rays on the body only (`seen_body`: a walk over the visibility map's bins), and
    // with evidence bounded by the gate (`memory_gate`), and with step 9 from each cell's first return
    // (`jump_first_return`, with and without the grazing rule), and with a free cluster in front of a confirmed box
    // offered to it (`front_cluster`). The last two cases also keep displaced offsets over frames (`memory_hold_s`),
    // and the last one bounds step 8 by the gate (`follow_gate`) with `seen_body`, and counts own first returns
    // beyond the grown regions (`returns_beyond_cells = 1`).
    for (seen_over, face_in_front, roi_graze_fraction, jump, seen_body, memory_gate, front_cluster) in [
        (false, false, 0.0, (false, false), false, false, false),
        (true, false, 0.0, (false, false), false, false, false),
        (false, true, 0.0, (false, false), false, false, false),
        (false, false, 0.5, (false, false), false, false, false),
        (false, false, 0.0, (true, false), false, false, false),
        (false, false, 0.5, (true, false), false, false, false),
        (false, false, 0.0, (false, false), true, false, false),
        (false, false, 0.0, (false, false), false, true, false),
        (false, false, 0.0, (true, true), false, false, false),
        (false, false, 0.5, (true, true), false, false, false),
        (false, false, 0.0, (false, false), false, false, true),
        (false, false, 0.5, (true, true), false, false, true),
        (false, false, 0.5, (true, true), true, false, true),
    ] {
        let (jump_from_returns, jump_first_return) = jump;
        let params = MonitorParams {
            max_objects: 64,
            max_points: 200_000,
            seen_over,
            face_in_front,
            roi_graze_fraction,
            jump_from_returns,
            jump_first_return,
            seen_body,
            memory_gate,
            // With `seen_body` and the defaults' two rules: step 8 bounded by the gate too (`follow_gate`).
            follow_gate: seen_body && front_cluster,
            front_cluster,
            memory_hold_s: if front_cluster && jump_first_return { 1.0 } else { 0.0 },
            returns_beyond_cells: u32::from(seen_body && front_cluster),
            ..MonitorParams::default()
        };
        let mut monitor = Monitor::new(params).unwrap();
        // A busy frame: many objects (some displaced, some duplicated, some invalid), evidence, ground, an
        // unlisted obstacle in the ROI, and then frames with bad input.
        let mut objects: Vec<ObjectState> = (0..40)
            .map(|i| {
                let a = i as f32 * 0.4;
                let r = 8.0 + (i % 7) as f32 * 4.0;
                ObjectState { speed_mps: 2.0, ..object(i, r * a.cos(), r * a.sin(), a, 2.0 + (i % 3) as f32, 1.0) }
            })
            .collect();
        let mut points: Vec<[f32; 3]> = objects.iter().flat_map(|o| visible_face_points(o, 0.1)).collect();
        points.extend(visible_face_points(&object(999, -12.0, 3.0, 0.0, 0.6, 0.6), 0.05));
        points.extend(ground_points(48.0));
        // A tree behind the road's edge (y = 5): its trunk outside, a few branches over the road, its canopy.
        for i in 0..8 {
            for j in 0..8 {
                let (x, y) = (20.05 + 0.1 * i as f32, 5.05 + 0.1 * j as f32);
                points.extend([[x, y, 1.0], [x, y, 1.5], [x, y - 1.0, 6.0]]);
            }
            points.push([20.05 + 0.1 * i as f32, 4.95, 2.0]);
        }
        let points = to_sensor(&points);
        for o in objects.iter_mut().step_by(5) {
            o.x_m += 2.0;
        }
        objects[3].id = objects[4].id;
        objects[7].length_m = f32::NAN;
        // The last frame: every third box jumps 1.5 m away from its evidence.
        let mut jumped = objects.clone();
        for o in jumped.iter_mut().step_by(3) {
            o.x_m += 1.5;
        }
        let road: &[[f32; 2]] = &[[-30.0, -5.0], [30.0, -5.0], [30.0, 5.0], [-30.0, 5.0]];
        let roi = [road];
        let frames: Vec<Frame<'_>> = (0..6)
            .map(|k| Frame {
                timestamp_s: if k == 4 { f64::NAN } else { k as f64 * 0.1 },
                world_from_ego: Pose2 { x_m: k as f64, y_m: 0.0, yaw_rad: 0.01 * k as f64 },
                objects: if k == 5 { &jumped } else { &objects },
                cloud: match k {
                    2 => None,
                    3 => Some(PointCloud { points_in_sensor: &[], ego_from_sensor: extrinsic() }),
                    _ => Some(PointCloud { points_in_sensor: &points, ego_from_sensor: extrinsic() }),
                },
                roi_in_ego: &roi,
                static_in_ego: &[],
            })
            .collect();
        // Warm up once (nothing is lazily allocated, but be fair to first-use effects of the test harness).
        let _ = monitor.check(&frames[0]).unwrap().objects.len();
        let mut alarms = 0;
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        COUNTING.with(|c| c.set(true));
        for f in &frames {
            let report = monitor.check(f).unwrap();
            alarms += report.object_alarms() + report.missed_objects();
        }
        COUNTING.with(|c| c.set(false));
        // The same sweep handed over as columns (`check_columns`).
        let [x, y, z]: [Vec<f32>; 3] = std::array::from_fn(|k| points.iter().map(|p| p[k]).collect());
        let columns =
            ColumnCloud { points_in_sensor: PointColumns::new(&x, &y, &z).unwrap(), ego_from_sensor: extrinsic() };
        COUNTING.with(|c| c.set(true));
        for (k, f) in frames.iter().enumerate() {
            let f = Frame { cloud: None, timestamp_s: 1.0 + 0.1 * k as f64, ..*f };
            let report = monitor.check_columns(&f, &columns).unwrap();
            alarms += report.object_alarms() + report.missed_objects();
        }
        COUNTING.with(|c| c.set(false));
        let after = ALLOCATIONS.load(Ordering::SeqCst);
        assert_eq!(after - before, 0, "check() allocated {} times", after - before);
        assert!(alarms > 0, "the frames exercise the alarm paths");
        // The counter works: an allocation on this thread while counting is seen.
        COUNTING.with(|c| c.set(true));
        let v: Vec<u8> = Vec::with_capacity(16);
        COUNTING.with(|c| c.set(false));
        drop(v);
        assert_eq!(ALLOCATIONS.load(Ordering::SeqCst), after + 1);
    }
}
