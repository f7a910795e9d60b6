//! Any frame, however malformed, gets exactly one report per object and never a panic (both rasterizers).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    clippy::std_instead_of_core
)]

use pmon_monitor::{
    Frame, Isometry3, Monitor, MonitorParams, ObjectClass, ObjectState, PointCloud, Pose2, Rasterizer, Uncertainty,
};
use proptest::prelude::*;

fn wild_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => -60.0f32..60.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::MAX),
        1 => Just(-0.0f32),
        1 => -1.0e30f32..1.0e30,
    ]
}

fn object() -> impl Strategy<Value = ObjectState> {
    (0u64..6, wild_f32(), wild_f32(), wild_f32(), wild_f32(), wild_f32(), wild_f32(), proptest::option::of(wild_f32()))
        .prop_map(|(id, x, y, h, v, l, w, sigma)| ObjectState {
            id,
            class: ObjectClass::Car,
            x_m: x,
            y_m: y,
            heading_rad: h,
            speed_mps: v.abs(),
            length_m: l.abs(),
            width_m: w.abs(),
            uncertainty: sigma.map(|s| Uncertainty {
                x_m: s,
                y_m: s.abs(),
                heading_rad: 0.1,
                speed_mps: s.abs(),
                length_m: 0.0,
                width_m: 0.0,
            }),
        })
}

fn point() -> impl Strategy<Value = [f32; 3]> {
    (wild_f32(), wild_f32(), prop_oneof![4 => -2.0f32..1.0, 1 => wild_f32()]).prop_map(|(x, y, z)| [x, y, z])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, .. ProptestConfig::default() })]

    #[test]
    fn one_report_per_object_and_no_panic(
        objects in proptest::collection::vec(object(), 0..12),
        points in proptest::collection::vec(point(), 0..300),
        times in proptest::collection::vec(prop_oneof![4 => 0.0f64..2.0, 1 => Just(f64::NAN), 1 => Just(-1.0f64)], 3),
        yaw in wild_f32(),
        tz in wild_f32(),
        pose_x in prop_oneof![4 => -1.0e4f64..1.0e4, 1 => Just(f64::NAN)],
        roi in proptest::collection::vec(proptest::collection::vec((wild_f32(), wild_f32()).prop_map(|(a, b)| [a, b]), 0..6), 0..3),
        with_cloud in any::<bool>(),
        rasterizer in prop_oneof![Just(Rasterizer::Blocked), Just(Rasterizer::BlockedBaseline), Just(Rasterizer::Scalar)],
        ego in any::<bool>(),
    ) {
        let params = MonitorParams {
            max_points: 256,
            max_objects: 16,
            ego_footprint_m: if ego { [-2.0, -1.0, 2.0, 1.0] } else { [0.0; 4] },
            ..MonitorParams::default()
        };
        let mut m = Monitor::new(params).unwrap();
        m.set_rasterizer(rasterizer);
        let roi_slices: Vec<&[[f32; 2]]> = roi.iter().map(Vec::as_slice).collect();
        let extrinsic = Isometry3::from_yaw_translation(yaw, [0.0, 0.0, tz]);
        for &t in &times {
            let frame = Frame {
                timestamp_s: t,
                world_from_ego: Pose2 { x_m: pose_x, y_m: 0.0, yaw_rad: 0.1 },
                objects: &objects,
                cloud: with_cloud.then_some(PointCloud { points_in_sensor: &points, ego_from_sensor: extrinsic }),
                roi_in_ego: &roi_slices,
                static_in_ego: &roi_slices,
            };
            match m.check(&frame) {
                Ok(report) => {
                    prop_assert_eq!(report.objects.len(), objects.len());
                    for (r, o) in report.objects.iter().zip(&objects) {
                        prop_assert_eq!(r.id, o.id);
                    }
                }
                Err(e) => prop_assert!(objects.len() > 16 || points.len() > 256, "{e}"),
            }
        }
    }
}
