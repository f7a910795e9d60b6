//! `Monitor::check` on arbitrary frames: the bytes become timestamps, poses, objects (any f32 bit pattern:
//! NaN, infinities, subnormals) and points, over three frames so that the plausibility checks run. Asserts the
//! monitor's promises: no panic, one report per object, and no plausible verdict from non-finite estimates. With
//! and without the params keys `seen_over`, `face_in_front` (with `returns_beyond_cells`), `roi_graze_fraction`
//! (with a region of interest) and `jump_from_returns`, with or without uncertainties on the objects and a turned
//! sensor, and with or without `seen_body` (with `follow_gate`) and `memory_gate`, and with `jump_from_returns`,
//! with or without `jump_first_return` (without it, with or without `front_cluster`).
#![no_main]
use libfuzzer_sys::fuzz_target;
use pmon_monitor::{
    Frame, Isometry3, Monitor, MonitorParams, MotionVerdict, ObjectClass, ObjectState, PointCloud, Pose2, Uncertainty,
};
use pmon_ros::convert::isometry;
use pmon_ros::msg::{Quaternion, Transform, Vector3};

struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        let (b, rest) = self.0.split_first().map_or((0, &[][..]), |(b, r)| (*b, r));
        self.0 = rest;
        b
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }
    /// Mostly ordinary values, sometimes raw bit patterns.
    fn value(&mut self, scale: f32) -> f32 {
        match self.u8() % 8 {
            0 => self.f32(),
            k => f32::from(k) * scale + f32::from(self.u8()) * scale / 64.0,
        }
    }
    /// A sensor mount as a bag's `/tf` gives it, turned into the extrinsic by the bag reader's own conversion
    /// (`pmon_ros::convert::isometry`: the quaternion normalised, NaN when it is zero): any orientation, pitched
    /// and rolled too, and a translation anywhere, near the grid's centre or far outside it.
    fn mount(&mut self) -> Isometry3 {
        let mut v = |scale: f32, offset: f32| f64::from(self.value(scale) - offset);
        let rotation = Quaternion { x: v(0.25, 1.0), y: v(0.25, 1.0), z: v(0.25, 1.0), w: v(0.25, 1.0) };
        let translation = Vector3 { x: v(4.0, 16.0), y: v(4.0, 16.0), z: v(0.5, 0.0) };
        isometry(&Transform { translation, rotation })
    }
    fn f64(&mut self) -> f64 {
        let bits = u64::from_le_bytes([
            self.u8(),
            self.u8(),
            self.u8(),
            self.u8(),
            self.u8(),
            self.u8(),
            self.u8(),
            self.u8(),
        ]);
        f64::from_bits(bits)
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes(data);
    // The first byte's top bit also switches the free-space test over nearer obstacles on (`seen_over`), without
    // shifting how the rest of the input is read.
    let seen_over = data.first().is_some_and(|b| b & 0x80 != 0);
    // And its next bit the face-in-front test (`face_in_front`), with own returns beyond the grown region
    // (`returns_beyond_cells = 1`).
    let face_in_front = data.first().is_some_and(|b| b & 0x40 != 0);
    // And its next bit the grazing rule of a region of interest (`roi_graze_fraction`; the half plane x < 0, the
    // height low enough for the input's returns to reach it).
    let graze = data.first().is_some_and(|b| b & 0x20 != 0);
    // And its next bit step 9 from the returns (`jump_from_returns`).
    let jump_from_returns = data.first().is_some_and(|b| b & 0x10 != 0);
    // And its next bit: every object carries an uncertainty read from the input (any f32: huge, zero, negative,
    // NaN), as a bag's covariances or an object list's sigmas give it, and the sensor is mounted turned.
    let with_uncertainty = data.first().is_some_and(|b| b & 0x08 != 0);
    // And its next bit the free-space test's rays on the body only (`seen_body`) and step 8 bounded by the gate
    // (`follow_gate`), the pair that is the default since issue #10's round "Rays on the body with step 8 gated".
    let seen_body = data.first().is_some_and(|b| b & 0x04 != 0);
    // And its next bit evidence bounded by the gate (`memory_gate`), and displaced offsets held over frames without
    // an alarm for a second (`memory_hold_s`).
    let memory_gate = data.first().is_some_and(|b| b & 0x02 != 0);
    // And its last bit, with `jump_from_returns`, each cell's first return for step 9 (`jump_first_return`, which
    // needs `jump_from_returns`).
    let jump_first_return = jump_from_returns && data.first().is_some_and(|b| b & 0x01 != 0);
    // Without `jump_from_returns` the same bit gives a box its free cluster of its shape in front of it
    // (`front_cluster`).
    let front_cluster = !jump_from_returns && data.first().is_some_and(|b| b & 0x01 != 0);
    let half_plane: &[[f32; 2]] = &[[-20.0, -20.0], [0.0, -20.0], [0.0, 20.0], [-20.0, 20.0]];
    let polygons = [half_plane];
    let roi: &[&[[f32; 2]]] = if graze { &polygons } else { &[] };
    let params = MonitorParams {
        max_points: 4096,
        max_objects: 64,
        grid_size_m: 40.0,
        seen_over,
        face_in_front,
        returns_beyond_cells: u32::from(face_in_front),
        jump_from_returns,
        jump_first_return,
        seen_body,
        follow_gate: seen_body,
        memory_gate,
        front_cluster,
        // The step 8 fit test reads the first returns: on whenever they are kept.
        follow_owner_fit: jump_first_return,
        // The released claims walk the owners' clusters: on with the body rules.
        release_flagged_claims: seen_body,
        release_to_confirmed: seen_body,
        // The margin walk of `evidence_runs_on`: on with `front_cluster`, the other rule that reads owned cells'
        // neighbours beyond a region.
        evidence_runs_on: front_cluster,
        memory_hold_s: if memory_gate { 1.0 } else { 0.0 },
        // The parked hold reads the memory the held offsets go to: on with them.
        parked_hold_s: if memory_gate { 3.0 } else { 0.0 },
        // Spill-over's choice by stretch (off by default): on without `seen_over`, so both are fuzzed.
        spill_least_stretch: !seen_over,
        roi_graze_fraction: if graze { 0.5 } else { 0.0 },
        roi_graze_height_m: 2.5,
        ..MonitorParams::default()
    };
    let Ok(mut monitor) = Monitor::new(params) else { return };
    let mut t = 0.0f64;
    for _ in 0..3 {
        t += if b.u8() % 4 == 0 { b.f64() } else { 0.1 };
        let n = usize::from(b.u8() % 8);
        let objects: Vec<ObjectState> = (0..n)
            .map(|_| ObjectState {
                id: u64::from(b.u8() % 4),
                class: ObjectClass::ALL[usize::from(b.u8()) % ObjectClass::ALL.len()],
                x_m: b.value(2.0) - 8.0,
                y_m: b.value(2.0) - 8.0,
                heading_rad: b.value(0.5),
                speed_mps: b.value(1.0),
                length_m: b.value(0.5),
                width_m: b.value(0.5),
                uncertainty: with_uncertainty.then(|| Uncertainty {
                    x_m: b.value(0.25),
                    y_m: b.value(0.25),
                    heading_rad: b.value(0.05),
                    speed_mps: b.value(0.25),
                    length_m: b.value(0.1),
                    width_m: b.value(0.1),
                }),
            })
            .collect();
        let points: Vec<[f32; 3]> = (0..usize::from(b.u8()) * 4)
            .map(|_| [b.value(2.0) - 8.0, b.value(2.0) - 8.0, b.value(0.3) - 1.5])
            .collect();
        let with_cloud = b.u8() % 4 != 0;
        let cloud = with_cloud.then(|| PointCloud {
            points_in_sensor: &points,
            ego_from_sensor: if with_uncertainty { b.mount() } else { Isometry3::from_translation(0.0, 0.0, 1.8) },
        });
        let pose = Pose2 { x_m: f64::from(b.value(1.0)), y_m: 0.0, yaw_rad: f64::from(b.value(0.1)) };
        let frame = Frame {
            timestamp_s: t,
            world_from_ego: pose,
            objects: &objects,
            cloud,
            roi_in_ego: roi,
            static_in_ego: &[],
        };
        let Ok(report) = monitor.check(&frame) else { continue };
        assert_eq!(report.objects.len(), objects.len());
        for r in report.objects {
            if r.motion.verdict == MotionVerdict::Plausible {
                assert!(r.motion.position_residual_m.is_finite() && r.motion.accel_mps2.is_finite(), "{r:?}");
            }
        }
    }
});
