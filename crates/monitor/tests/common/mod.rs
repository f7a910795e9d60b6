//! Synthetic frames for the monitor's integration tests: boxes seen by an idealised LiDAR.
#![allow(
    dead_code,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing,
    clippy::panic,
    clippy::std_instead_of_core
)]

use pmon_monitor::{Frame, Isometry3, ObjectClass, ObjectState, PointCloud, Pose2};

/// Sensor mounted 1.8 m above the ego origin.
pub const SENSOR_HEIGHT_M: f32 = 1.8;

pub fn extrinsic() -> Isometry3 {
    Isometry3::from_translation(0.0, 0.0, SENSOR_HEIGHT_M)
}

pub fn object(id: u64, x: f32, y: f32, heading: f32, length: f32, width: f32) -> ObjectState {
    ObjectState {
        id,
        class: ObjectClass::Car,
        x_m: x,
        y_m: y,
        heading_rad: heading,
        speed_mps: 0.0,
        length_m: length,
        width_m: width,
        uncertainty: None,
    }
}

/// Ego-frame points on the faces of the object's box that face the sensor at the ego origin, every
/// `spacing` metres along the faces, at heights 0.5, 1.0 and 1.5 m.
pub fn visible_face_points(o: &ObjectState, spacing: f32) -> Vec<[f32; 3]> {
    let (s, c) = o.heading_rad.sin_cos();
    let (hl, hw) = (o.length_m / 2.0, o.width_m / 2.0);
    let corner = |u: f32, v: f32| [o.x_m + u * c - v * s, o.y_m + u * s + v * c];
    let corners = [corner(hl, hw), corner(-hl, hw), corner(-hl, -hw), corner(hl, -hw)];
    let mut out = Vec::new();
    for k in 0..4 {
        let a = corners[k];
        let b = corners[(k + 1) % 4];
        let mid = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
        // Outward normal of edge a->b (counter-clockwise corners: normal is (dy, -dx)).
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        let normal = [ey, -ex];
        let to_sensor = [-mid[0], -mid[1]];
        if normal[0] * to_sensor[0] + normal[1] * to_sensor[1] <= 0.0 {
            continue;
        }
        let len = (ex * ex + ey * ey).sqrt();
        let steps = (len / spacing).ceil().max(1.0) as usize;
        for i in 0..=steps {
            let t = i as f32 / steps as f32;
            for z in [0.5, 1.0, 1.5] {
                out.push([a[0] + t * ex, a[1] + t * ey, z]);
            }
        }
    }
    out
}

/// Ground returns on rings around the sensor out to `max_range` (every 0.25 degree, every metre).
pub fn ground_points(max_range: f32) -> Vec<[f32; 3]> {
    let mut out = Vec::new();
    let mut r = 2.0;
    while r <= max_range {
        for k in 0..1440 {
            let a = (k as f32 * 0.25).to_radians();
            out.push([r * a.cos(), r * a.sin(), 0.0]);
        }
        r += 1.0;
    }
    out
}

/// Ego-frame points -> sensor frame for [`extrinsic`].
pub fn to_sensor(points: &[[f32; 3]]) -> Vec<[f32; 3]> {
    points.iter().map(|p| [p[0], p[1], p[2] - SENSOR_HEIGHT_M]).collect()
}

/// A frame at t = 0 with the ego at the origin, the cloud given in the sensor frame of [`extrinsic`].
pub fn frame_at_origin<'a>(
    objects: &'a [ObjectState],
    points_in_sensor: &'a [[f32; 3]],
    roi: &'a [&'a [[f32; 2]]],
    scenery: &'a [&'a [[f32; 2]]],
) -> Frame<'a> {
    Frame {
        timestamp_s: 0.0,
        world_from_ego: Pose2::default(),
        objects,
        cloud: Some(PointCloud { points_in_sensor, ego_from_sensor: extrinsic() }),
        roi_in_ego: roi,
        static_in_ego: scenery,
    }
}
