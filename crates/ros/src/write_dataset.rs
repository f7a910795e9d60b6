//! `pmon convert SPEC --out x.mcap --format mcap`: any pmon frame source as a rosbag2-style MCAP with
//! Autoware's topics, so it opens in Foxglove and `pmon check x.mcap` reads it back.
//!
//! Per frame: `/sensing/lidar/concatenated/pointcloud` (`sensor_msgs/PointCloud2`, FLOAT32 x y z intensity,
//! frame `lidar`), `/perception/object_recognition/tracking/objects` (`autoware_perception_msgs/TrackedObjects`,
//! frame `base_link`, the id in the UUID's first 8 bytes), `/localization/kinematic_state` (`nav_msgs/Odometry`)
//! and, once, `/tf_static` (`base_link` -> `lidar`, the frame's extrinsic).

use std::collections::BTreeMap;
use std::path::Path;

use pmon_monitor::{Isometry3, ObjectClass, Pose2};
use pmon_recording::RecordedFrame;

use crate::bag::BagConfig;
use crate::cdr::encode;
use crate::msg::{
    Header, ObjectClassification, Odometry, Pose, PoseWithCovariance, Quaternion, Shape, TfMessage, Time,
    TrackedObject, TrackedObjectKinematics, TrackedObjects, Transform, TransformStamped, TwistWithCovariance, Uuid,
    Vector3,
};
use crate::output::{create_new, OutputError};
use crate::pointcloud::from_points;

const SEP: &str = "================================================================================\nMSG: ";

fn defs(root: &str, deps: &[(&str, &str)]) -> String {
    let mut s = root.to_string();
    for (name, text) in deps {
        s.push_str(&format!("\n{SEP}{name}\n{text}"));
    }
    s
}

const HEADER: (&str, &str) = ("std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id\n");
const TIME: (&str, &str) = ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec\n");
const VECTOR3: (&str, &str) = ("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n");
const POINT: (&str, &str) = ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n");
const QUAT: (&str, &str) = ("geometry_msgs/Quaternion", "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n");
const POSE: (&str, &str) = ("geometry_msgs/Pose", "Point position\nQuaternion orientation\n");
const POSE_COV: (&str, &str) = ("geometry_msgs/PoseWithCovariance", "Pose pose\nfloat64[36] covariance\n");
const TWIST: (&str, &str) = ("geometry_msgs/Twist", "Vector3 linear\nVector3 angular\n");
const TWIST_COV: (&str, &str) = ("geometry_msgs/TwistWithCovariance", "Twist twist\nfloat64[36] covariance\n");
const ACCEL: (&str, &str) = ("geometry_msgs/Accel", "Vector3 linear\nVector3 angular\n");
const ACCEL_COV: (&str, &str) = ("geometry_msgs/AccelWithCovariance", "Accel accel\nfloat64[36] covariance\n");

/// `ros2msg` schema texts (with dependencies) of the messages written here.
#[must_use]
pub fn schemas() -> [(&'static str, String); 4] {
    let point_field = (
        "sensor_msgs/PointField",
        "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\n\
         uint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n",
    );
    let cloud = defs(
        "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\nbool is_bigendian\n\
         uint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
        &[HEADER, TIME, point_field],
    );
    let odometry = defs(
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n\
         geometry_msgs/TwistWithCovariance twist\n",
        &[HEADER, TIME, POSE_COV, POSE, POINT, QUAT, TWIST_COV, TWIST, VECTOR3],
    );
    let tf = defs(
        "geometry_msgs/TransformStamped[] transforms\n",
        &[
            ("geometry_msgs/TransformStamped", "std_msgs/Header header\nstring child_frame_id\nTransform transform\n"),
            HEADER,
            TIME,
            ("geometry_msgs/Transform", "Vector3 translation\nQuaternion rotation\n"),
            VECTOR3,
            QUAT,
        ],
    );
    let aw = |name: &str, text: &'static str| -> (String, &'static str) {
        (format!("autoware_perception_msgs/{name}"), text)
    };
    let aw_deps = [
        aw("TrackedObject", include_str!("../msg/autoware_perception_msgs/TrackedObject.msg")),
        aw("ObjectClassification", include_str!("../msg/autoware_perception_msgs/ObjectClassification.msg")),
        aw("TrackedObjectKinematics", include_str!("../msg/autoware_perception_msgs/TrackedObjectKinematics.msg")),
        aw("Shape", include_str!("../msg/autoware_perception_msgs/Shape.msg")),
    ];
    let mut deps: Vec<(&str, &str)> = aw_deps.iter().map(|(n, t)| (n.as_str(), *t)).collect();
    deps.extend([
        HEADER,
        TIME,
        ("unique_identifier_msgs/UUID", "uint8[16] uuid\n"),
        POSE_COV,
        POSE,
        POINT,
        QUAT,
        TWIST_COV,
        TWIST,
        VECTOR3,
        ACCEL_COV,
        ACCEL,
        ("geometry_msgs/Polygon", "Point32[] points\n"),
        ("geometry_msgs/Point32", "float32 x\nfloat32 y\nfloat32 z\n"),
    ]);
    let objects = defs(include_str!("../msg/autoware_perception_msgs/TrackedObjects.msg"), &deps);
    [
        ("sensor_msgs/msg/PointCloud2", cloud),
        ("autoware_perception_msgs/msg/TrackedObjects", objects),
        ("nav_msgs/msg/Odometry", odometry),
        ("tf2_msgs/msg/TFMessage", tf),
    ]
}

/// Quaternion of a yaw angle.
#[must_use]
pub fn quat_yaw(yaw: f64) -> Quaternion {
    Quaternion { x: 0.0, y: 0.0, z: (yaw / 2.0).sin(), w: (yaw / 2.0).cos() }
}

/// Quaternion of a rotation matrix (Shepperd's method).
#[must_use]
pub fn quat_of(m: &[[f32; 3]; 3]) -> Quaternion {
    let r = m.map(|row| row.map(f64::from));
    let tr = r[0][0] + r[1][1] + r[2][2];
    let (w, x, y, z) = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        (0.25 * s, (r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s)
    } else if r[0][0] > r[1][1] && r[0][0] > r[2][2] {
        let s = (1.0 + r[0][0] - r[1][1] - r[2][2]).sqrt() * 2.0;
        ((r[2][1] - r[1][2]) / s, 0.25 * s, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s)
    } else if r[1][1] > r[2][2] {
        let s = (1.0 + r[1][1] - r[0][0] - r[2][2]).sqrt() * 2.0;
        ((r[0][2] - r[2][0]) / s, (r[0][1] + r[1][0]) / s, 0.25 * s, (r[1][2] + r[2][1]) / s)
    } else {
        let s = (1.0 + r[2][2] - r[0][0] - r[1][1]).sqrt() * 2.0;
        ((r[1][0] - r[0][1]) / s, (r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, 0.25 * s)
    };
    Quaternion { x, y, z, w }
}

fn label_of(c: ObjectClass) -> u8 {
    match c {
        ObjectClass::Unknown => 0,
        ObjectClass::Car => 1,
        ObjectClass::Truck => 2,
        ObjectClass::Motorcyclist => 5,
        ObjectClass::Cyclist => 6,
        ObjectClass::Pedestrian => 7,
        ObjectClass::Other => 9,
    }
}

fn stamp(t_s: f64) -> Time {
    // Datasets may start at 0 s; negative or non-finite stamps clamp to 0.
    Time::from_nanos(if t_s.is_finite() && t_s > 0.0 { (t_s * 1e9).round() as u64 } else { 0 })
}

/// One frame's object list in the ego frame.
#[must_use]
pub fn tracked_objects(f: &RecordedFrame, default: &pmon_monitor::Uncertainty, ego_frame: &str) -> TrackedObjects {
    let objects = f
        .objects
        .iter()
        .map(|o| {
            let u = o.uncertainty.unwrap_or(*default);
            let mut pose_cov = [0.0; 36];
            pose_cov[0] = f64::from(u.x_m).powi(2);
            pose_cov[7] = f64::from(u.y_m).powi(2);
            pose_cov[35] = f64::from(u.heading_rad).powi(2);
            let mut twist_cov = [0.0; 36];
            twist_cov[0] = f64::from(u.speed_mps).powi(2);
            let mut uuid = [0u8; 16];
            uuid[..8].copy_from_slice(&o.id.to_le_bytes());
            TrackedObject {
                object_id: Uuid { uuid },
                existence_probability: 1.0,
                classification: vec![ObjectClassification { label: label_of(o.class), probability: 1.0 }],
                kinematics: TrackedObjectKinematics {
                    pose_with_covariance: PoseWithCovariance {
                        pose: Pose {
                            position: Vector3 { x: f64::from(o.x_m), y: f64::from(o.y_m), z: 0.0 },
                            orientation: quat_yaw(f64::from(o.heading_rad)),
                        },
                        covariance: pose_cov,
                    },
                    twist_with_covariance: TwistWithCovariance {
                        twist: crate::msg::Twist {
                            linear: Vector3 { x: f64::from(o.speed_mps), y: 0.0, z: 0.0 },
                            angular: Vector3::default(),
                        },
                        covariance: twist_cov,
                    },
                    acceleration_with_covariance: TwistWithCovariance::default(),
                    orientation_availability: 2,
                    is_stationary: o.speed_mps == 0.0,
                },
                shape: Shape {
                    shape_type: 0,
                    footprint: Vec::new(),
                    dimensions: Vector3 { x: f64::from(o.length_m), y: f64::from(o.width_m), z: 1.5 },
                },
            }
        })
        .collect();
    TrackedObjects { header: Header { stamp: stamp(f.timestamp_s), frame_id: ego_frame.into() }, objects }
}

fn transform_of(e: &Isometry3) -> Transform {
    let t = e.translation_m.map(f64::from);
    Transform { translation: Vector3 { x: t[0], y: t[1], z: t[2] }, rotation: quat_of(&e.rotation) }
}

fn odometry(t: Time, p: &Pose2, cfg: &BagConfig) -> Odometry {
    Odometry {
        header: Header { stamp: t, frame_id: cfg.world_frame.clone() },
        child_frame_id: cfg.ego_frame.clone(),
        pose: PoseWithCovariance {
            pose: Pose { position: Vector3 { x: p.x_m, y: p.y_m, z: 0.0 }, orientation: quat_yaw(p.yaw_rad) },
            covariance: [0.0; 36],
        },
        twist: TwistWithCovariance::default(),
    }
}

/// Writes frames as a new MCAP file (an existing file is an error). Returns the number of frames.
///
/// # Errors
/// [`OutputError`] when the file exists or cannot be written, or a frame's source fails (`frames` yields
/// `Err(message)`).
pub fn write_frames(
    path: &Path,
    frames: impl Iterator<Item = Result<RecordedFrame, String>>,
    default: &pmon_monitor::Uncertainty,
) -> Result<u64, OutputError> {
    let cfg = BagConfig::default();
    let mut w = create_new(path)?;
    let none = BTreeMap::new();
    let [cloud_s, objects_s, odo_s, tf_s] = schemas();
    let mut channel = |(name, text): &(&str, String), topic: &str| -> Result<u16, OutputError> {
        let id = w.add_schema(name, "ros2msg", text.as_bytes())?;
        Ok(w.add_channel(id, topic, "cdr", &none)?)
    };
    let (c_tf, c_odo, c_cloud, c_obj) = (
        channel(&tf_s, &cfg.tf_static_topic)?,
        channel(&odo_s, &cfg.odometry_topic)?,
        channel(&cloud_s, &cfg.cloud_topic)?,
        channel(&objects_s, &cfg.objects_topic)?,
    );
    let enc = |e: crate::cdr::CdrError| OutputError::Encode(e.to_string());
    let mut seq = 0u32;
    let mut put = |w: &mut mcap::Writer<_>, channel_id, t: Time, data: &[u8]| -> Result<(), OutputError> {
        seq = seq.wrapping_add(1);
        let h = mcap::records::MessageHeader {
            channel_id,
            sequence: seq,
            log_time: t.as_nanos(),
            publish_time: t.as_nanos(),
        };
        Ok(w.write_to_known_channel(&h, data)?)
    };
    let mut extrinsic: Option<Isometry3> = None;
    let mut n = 0u64;
    for f in frames {
        let f = f.map_err(OutputError::Encode)?;
        let t = stamp(f.timestamp_s);
        if let Some(c) = &f.cloud {
            // One static extrinsic per file: a later different one would be a second sensor frame.
            if extrinsic.is_none() {
                let tf = TfMessage {
                    transforms: vec![TransformStamped {
                        header: Header { stamp: t, frame_id: cfg.ego_frame.clone() },
                        child_frame_id: "lidar".into(),
                        transform: transform_of(&c.ego_from_sensor),
                    }],
                };
                put(&mut w, c_tf, t, &encode(&tf).map_err(enc)?)?;
                extrinsic = Some(c.ego_from_sensor);
            }
            if extrinsic != Some(c.ego_from_sensor) {
                return Err(OutputError::Encode(format!(
                    "frame {}: the LiDAR extrinsic changes within the dataset; one static transform per file is written",
                    f.index
                )));
            }
            let pc = from_points(Header { stamp: t, frame_id: "lidar".into() }, &c.points_in_sensor);
            put(&mut w, c_cloud, t, &encode(&pc).map_err(enc)?)?;
        }
        put(&mut w, c_odo, t, &encode(&odometry(t, &f.world_from_ego, &cfg)).map_err(enc)?)?;
        put(&mut w, c_obj, t, &encode(&tracked_objects(&f, default, &cfg.ego_frame)).map_err(enc)?)?;
        n += 1;
    }
    w.finish()?;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_to_quaternion_and_back() {
        for yaw in [-3.0f32, -1.0, 0.0, 0.5, 2.9] {
            let m = Isometry3::from_yaw_translation(yaw, [1.0, 2.0, 3.0]);
            let t = transform_of(&m);
            let back = crate::convert::isometry(&t);
            for i in 0..3 {
                for j in 0..3 {
                    assert!((back.rotation[i][j] - m.rotation[i][j]).abs() < 1e-5, "{yaw}");
                }
            }
        }
    }
}
