//! Autoware objects -> the monitor's [`ObjectState`], odometry and transforms -> poses.

use pmon_monitor::{Isometry3, ObjectClass, ObjectState, Pose2, Uncertainty};

use crate::msg::{
    DetectedObject, ObjectClassification, PoseWithCovariance, Quaternion, Shape, TrackedObject, Transform,
    TwistWithCovariance, Uuid,
};

/// Yaw (rotation about z) of a quaternion, radians.
#[must_use]
pub fn yaw(q: &Quaternion) -> f64 {
    (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z))
}

/// The planar pose of a transform or pose (x, y, yaw).
#[must_use]
pub fn pose2(translation_x: f64, translation_y: f64, q: &Quaternion) -> Pose2 {
    Pose2 { x_m: translation_x, y_m: translation_y, yaw_rad: yaw(q) }
}

/// `a * b` for planar poses.
#[must_use]
pub fn compose(a: &Pose2, b: &Pose2) -> Pose2 {
    let (x, y) = a.transform_point(b.x_m, b.y_m);
    Pose2 { x_m: x, y_m: y, yaw_rad: wrap(a.yaw_rad + b.yaw_rad) }
}

/// The inverse of a planar pose.
#[must_use]
pub fn inverse(p: &Pose2) -> Pose2 {
    let (s, c) = p.yaw_rad.sin_cos();
    Pose2 { x_m: -(c * p.x_m + s * p.y_m), y_m: s * p.x_m - c * p.y_m, yaw_rad: wrap(-p.yaw_rad) }
}

fn wrap(a: f64) -> f64 {
    let t = a.rem_euclid(std::f64::consts::TAU);
    if t > std::f64::consts::PI {
        t - std::f64::consts::TAU
    } else {
        t
    }
}

/// A full 3D transform as the monitor's extrinsic (`ego_from_sensor`).
#[must_use]
#[allow(clippy::cast_possible_truncation)]
pub fn isometry(t: &Transform) -> Isometry3 {
    let q = &t.rotation;
    let n = (q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z).sqrt();
    let (w, x, y, z) = if n > 0.0 { (q.w / n, q.x / n, q.y / n, q.z / n) } else { (f64::NAN, 0.0, 0.0, 0.0) };
    let r = [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
        [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
        [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
    ];
    Isometry3 {
        rotation: r.map(|row| row.map(|v| v as f32)),
        translation_m: [t.translation.x as f32, t.translation.y as f32, t.translation.z as f32],
    }
}

/// `a * b` for 3D transforms (`parent_from_child` chains).
#[must_use]
pub fn compose3(a: &Isometry3, b: &Isometry3) -> Isometry3 {
    let mut r = [[0.0f32; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a.rotation[i][k] * b.rotation[k][j]).sum();
        }
    }
    Isometry3 { rotation: r, translation_m: a.transform(b.translation_m) }
}

/// The monitor's class for the most probable Autoware label (`autoware_perception_msgs/ObjectClassification`):
/// car -> car; truck, bus, trailer -> truck; motorcycle -> motorcyclist; bicycle -> cyclist; pedestrian ->
/// pedestrian; animal, hazard, over/under-drivable -> other; unknown or none -> unknown.
#[must_use]
pub fn class_of(classification: &[ObjectClassification]) -> ObjectClass {
    let best = classification.iter().max_by(|a, b| a.probability.total_cmp(&b.probability));
    match best.map(|c| c.label) {
        Some(1) => ObjectClass::Car,
        Some(2..=4) => ObjectClass::Truck,
        Some(5) => ObjectClass::Motorcyclist,
        Some(6) => ObjectClass::Cyclist,
        Some(7) => ObjectClass::Pedestrian,
        Some(8..=11) => ObjectClass::Other,
        _ => ObjectClass::Unknown,
    }
}

/// Footprint length and width of a shape: a box's `dimensions.x/y`, a cylinder's diameter, a polygon's extent
/// along the object's axes (falling back to `dimensions` for an empty polygon).
#[must_use]
#[allow(clippy::cast_possible_truncation)]
pub fn size_of(shape: &Shape) -> (f32, f32) {
    match shape.shape_type {
        1 => (shape.dimensions.x as f32, shape.dimensions.x as f32),
        2 if !shape.footprint.is_empty() => {
            let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
            for p in &shape.footprint {
                lo = [lo[0].min(p.x), lo[1].min(p.y)];
                hi = [hi[0].max(p.x), hi[1].max(p.y)];
            }
            (hi[0] - lo[0], hi[1] - lo[1])
        }
        _ => (shape.dimensions.x as f32, shape.dimensions.y as f32),
    }
}

/// pmon's id of a tracked object: the first 8 bytes of its UUID, little endian.
#[must_use]
pub fn id_of(uuid: &Uuid) -> u64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(&uuid.uuid[..8]);
    u64::from_le_bytes(b)
}

/// The object's kinematics in the message frame.
struct Kinematics<'a> {
    pose: &'a PoseWithCovariance,
    twist: &'a TwistWithCovariance,
    has_covariance: bool,
}

/// Builds an object in the ego frame from its pose in the message frame and `ego_from_msg`.
#[allow(clippy::cast_possible_truncation)]
fn object(
    id: u64,
    k: &Kinematics<'_>,
    classification: &[ObjectClassification],
    shape: &Shape,
    ego_from_msg: &Pose2,
    default: &Uncertainty,
) -> ObjectState {
    let p = &k.pose.pose;
    let (x, y) = ego_from_msg.transform_point(p.position.x, p.position.y);
    let t = &k.twist.twist.linear;
    // The twist is in the object's frame: a negative longitudinal speed moves the box backwards.
    let backwards = if t.x < 0.0 { std::f64::consts::PI } else { 0.0 };
    let heading = wrap(yaw(&p.orientation) + ego_from_msg.yaw_rad + backwards);
    let (length, width) = size_of(shape);
    let uncertainty = k.has_covariance.then(|| {
        // Rotate the position covariance into the ego frame: S' = R S R^T, keep the diagonal.
        let c = &k.pose.covariance;
        let (sxx, sxy, syy) = (c[0], 0.5 * (c[1] + c[6]), c[7]);
        let (s, co) = ego_from_msg.yaw_rad.sin_cos();
        let vx = co * co * sxx - 2.0 * s * co * sxy + s * s * syy;
        let vy = s * s * sxx + 2.0 * s * co * sxy + co * co * syy;
        Uncertainty {
            x_m: vx.sqrt() as f32,
            y_m: vy.sqrt() as f32,
            heading_rad: c[35].sqrt() as f32,
            speed_mps: k.twist.covariance[0].sqrt() as f32,
            length_m: default.length_m,
            width_m: default.width_m,
        }
    });
    ObjectState {
        id,
        class: class_of(classification),
        x_m: x as f32,
        y_m: y as f32,
        heading_rad: heading as f32,
        speed_mps: t.x.hypot(t.y) as f32,
        length_m: length,
        width_m: width,
        uncertainty,
    }
}

/// A tracked object in the ego frame. The covariances are used (negative variances give NaN, which the
/// monitor reports as *not monitored: invalid state*); the length and width sigmas, which Autoware does not
/// carry, come from `default` (the monitor's `default_uncertainty`).
#[must_use]
pub fn tracked(o: &TrackedObject, ego_from_msg: &Pose2, default: &Uncertainty) -> ObjectState {
    let k = Kinematics {
        pose: &o.kinematics.pose_with_covariance,
        twist: &o.kinematics.twist_with_covariance,
        has_covariance: true,
    };
    object(id_of(&o.object_id), &k, &o.classification, &o.shape, ego_from_msg, default)
}

/// A detected object in the ego frame, with a caller-chosen id (detections have no track id: give each a
/// fresh one so the plausibility checks treat it as a new track). Its covariance is used only when
/// `has_position_covariance` is set; otherwise the monitor's default uncertainty applies.
#[must_use]
pub fn detected(o: &DetectedObject, id: u64, ego_from_msg: &Pose2, default: &Uncertainty) -> ObjectState {
    let k = Kinematics {
        pose: &o.kinematics.pose_with_covariance,
        twist: &o.kinematics.twist_with_covariance,
        has_covariance: o.kinematics.has_position_covariance,
    };
    let mut s = object(id, &k, &o.classification, &o.shape, ego_from_msg, default);
    if !o.kinematics.has_twist {
        s.speed_mps = 0.0;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Pose, Vector3};

    fn q_yaw(a: f64) -> Quaternion {
        Quaternion { x: 0.0, y: 0.0, z: (a / 2.0).sin(), w: (a / 2.0).cos() }
    }

    #[test]
    fn poses_compose_and_invert() {
        let a = Pose2 { x_m: 3.0, y_m: -1.0, yaw_rad: 0.7 };
        let i = compose(&a, &inverse(&a));
        assert!(i.x_m.abs() < 1e-12 && i.y_m.abs() < 1e-12 && i.yaw_rad.abs() < 1e-12);
        assert!((yaw(&q_yaw(-2.5)) + 2.5).abs() < 1e-12);
    }

    #[test]
    fn tracked_object_in_map_frame_lands_in_ego_frame() {
        let mut o = TrackedObject::default();
        o.object_id.uuid[0] = 42;
        o.classification = vec![
            ObjectClassification { label: 7, probability: 0.2 },
            ObjectClassification { label: 3, probability: 0.8 },
        ];
        o.shape.dimensions = Vector3 { x: 10.0, y: 2.5, z: 3.0 };
        let k = &mut o.kinematics;
        k.pose_with_covariance.pose =
            Pose { position: Vector3 { x: 110.0, y: 200.0, z: 0.0 }, orientation: q_yaw(0.5) };
        k.pose_with_covariance.covariance[0] = 0.04; // sigma_x 0.2 m in map
        k.pose_with_covariance.covariance[7] = 0.01; // sigma_y 0.1 m in map
        k.pose_with_covariance.covariance[35] = 0.0025;
        k.twist_with_covariance.twist.linear.x = 5.0;
        k.twist_with_covariance.covariance[0] = 0.09;
        // Ego at (100, 200) facing +y (yaw pi/2): the object is 10 m to its right.
        let world_from_ego = Pose2 { x_m: 100.0, y_m: 200.0, yaw_rad: std::f64::consts::FRAC_PI_2 };
        let default = Uncertainty { x_m: 1.0, y_m: 1.0, heading_rad: 1.0, speed_mps: 1.0, length_m: 0.3, width_m: 0.2 };
        let s = tracked(&o, &inverse(&world_from_ego), &default);
        assert_eq!(s.id, 42);
        assert_eq!(s.class, ObjectClass::Truck);
        assert!((s.x_m - 0.0).abs() < 1e-4 && (s.y_m + 10.0).abs() < 1e-4, "{s:?}");
        assert!((f64::from(s.heading_rad) - (0.5 - std::f64::consts::FRAC_PI_2)).abs() < 1e-6);
        assert_eq!((s.length_m, s.width_m, s.speed_mps), (10.0, 2.5, 5.0));
        let u = s.uncertainty.unwrap();
        // Rotated by -90 degrees: map x becomes ego -y.
        assert!((u.x_m - 0.1).abs() < 1e-6 && (u.y_m - 0.2).abs() < 1e-6, "{u:?}");
        assert!((u.heading_rad - 0.05).abs() < 1e-6 && (u.speed_mps - 0.3).abs() < 1e-6);
        assert_eq!((u.length_m, u.width_m), (0.3, 0.2));
    }

    #[test]
    fn backwards_twist_flips_heading_and_shapes_size() {
        let mut o = DetectedObject::default();
        o.kinematics.twist_with_covariance.twist.linear.x = -2.0;
        o.kinematics.has_twist = true;
        o.shape.shape_type = 1;
        o.shape.dimensions.x = 0.6;
        let d = Uncertainty { x_m: 0.0, y_m: 0.0, heading_rad: 0.0, speed_mps: 0.0, length_m: 0.0, width_m: 0.0 };
        let s = detected(&o, 9, &Pose2::default(), &d);
        assert!((f64::from(s.heading_rad).abs() - std::f64::consts::PI).abs() < 1e-6);
        assert_eq!((s.speed_mps, s.length_m, s.width_m, s.id, s.uncertainty), (2.0, 0.6, 0.6, 9, None));
        let poly = Shape {
            shape_type: 2,
            footprint: [(-1.0, -0.5), (2.0, -0.5), (2.0, 0.7), (-1.0, 0.7)]
                .map(|(x, y)| crate::msg::Point32 { x, y, z: 0.0 })
                .to_vec(),
            ..Shape::default()
        };
        let (l, w) = size_of(&poly);
        assert!((l - 3.0).abs() < 1e-6 && (w - 1.2).abs() < 1e-6);
    }

    #[test]
    fn quaternion_to_rotation_matches_yaw() {
        let t =
            Transform { translation: Vector3 { x: 1.0, y: 2.0, z: 3.0 }, rotation: q_yaw(std::f64::consts::FRAC_PI_2) };
        let m = isometry(&t);
        let p = m.transform([1.0, 0.0, 0.0]);
        assert!((p[0] - 1.0).abs() < 1e-6 && (p[1] - 3.0).abs() < 1e-6 && (p[2] - 3.0).abs() < 1e-6);
        let two = compose3(&m, &m);
        let q = two.transform([0.0, 0.0, 0.0]);
        assert!((q[0] - (1.0 - 2.0)).abs() < 1e-5 && (q[1] - 3.0).abs() < 1e-5, "{q:?}");
    }
}
