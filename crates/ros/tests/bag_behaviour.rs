//! Bag reading on bad input, with bags built here (the interop tests use bags written by Python's `rosbags`).

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;

use pmon_monitor::MonitorParams;
use pmon_ros::bag::{check_bag, BagConfig, BagError};
use pmon_ros::cdr::encode;
use pmon_ros::msg::{FrameVerdicts, Header, Time, TrackedObject, TrackedObjects};

fn objects(sec: i32, frame: &str) -> TrackedObjects {
    let mut o = TrackedObject::default();
    o.object_id.uuid[0] = 5;
    o.shape.dimensions.x = 4.0;
    o.shape.dimensions.y = 2.0;
    o.kinematics.pose_with_covariance.pose.position.x = 10.0;
    o.kinematics.pose_with_covariance.covariance[0] = 0.01;
    o.kinematics.pose_with_covariance.covariance[7] = 0.01;
    TrackedObjects { header: Header { stamp: Time { sec, nanosec: 0 }, frame_id: frame.into() }, objects: vec![o] }
}

/// A bag with only an object topic: (payload, schema name) per message.
fn bag(topic: &str, messages: &[(Vec<u8>, &str)]) -> Vec<u8> {
    let mut w = mcap::Writer::new(Cursor::new(Vec::new())).unwrap();
    for (i, (data, schema)) in messages.iter().enumerate() {
        let s = w.add_schema(schema, "ros2msg", b"").unwrap();
        let c = w.add_channel(s, topic, "cdr", &BTreeMap::new()).unwrap();
        let t = (i as u64 + 1) * 100_000_000;
        let h = mcap::records::MessageHeader { channel_id: c, sequence: i as u32, log_time: t, publish_time: t };
        w.write_to_known_channel(&h, data).unwrap();
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}

const TRACKED: &str = "autoware_perception_msgs/msg/TrackedObjects";

fn run(bytes: &[u8]) -> (Result<pmon_ros::bag::BagSummary, BagError>, Vec<FrameVerdicts>) {
    let mut out = Vec::new();
    let cfg = BagConfig::default();
    let r = check_bag(Path::new("test.mcap"), bytes, &cfg, &MonitorParams::default(), &mut |f| {
        out.push(f.verdicts.clone());
        Ok(())
    });
    (r, out)
}

#[test]
fn missing_object_topic_is_an_error_naming_the_file_and_topic() {
    let bytes = bag("/other", &[(encode(&objects(1, "base_link")).unwrap(), TRACKED)]);
    let e = run(&bytes).0.unwrap_err().to_string();
    assert!(e.contains("test.mcap") && e.contains("/perception/object_recognition/tracking/objects"), "{e}");
}

#[test]
fn unknown_object_type_is_an_error() {
    let topic = BagConfig::default().objects_topic;
    let bytes = bag(&topic, &[(encode(&objects(1, "base_link")).unwrap(), "std_msgs/msg/String")]);
    assert!(run(&bytes).0.unwrap_err().to_string().contains("std_msgs/msg/String"));
}

#[test]
fn malformed_object_list_is_listed_and_the_others_checked() {
    let topic = BagConfig::default().objects_topic;
    let good = encode(&objects(1, "base_link")).unwrap();
    let bad = good[..good.len() / 3].to_vec();
    let bytes =
        bag(&topic, &[(good.clone(), TRACKED), (bad, TRACKED), (encode(&objects(2, "base_link")).unwrap(), TRACKED)]);
    let (s, frames) = run(&bytes);
    let s = s.unwrap();
    assert_eq!((s.frames, s.undecodable, frames.len()), (2, 1, 2));
    assert!(
        s.problems.iter().any(|p| p.message.starts_with("object list not checked: malformed CDR")),
        "{:?}",
        s.problems
    );
    // Every object list is reported without a cloud, and so is the missing ego pose.
    assert_eq!(s.unpaired_object_lists.len(), 2);
    assert!(s.problems.iter().any(|p| p.message.starts_with("no ego pose")));
    assert_eq!(frames[0].sensor_status, "no_lidar_data");
}

#[test]
fn objects_in_a_frame_without_transform_are_not_monitored() {
    let topic = BagConfig::default().objects_topic;
    let bytes = bag(&topic, &[(encode(&objects(1, "radar")).unwrap(), TRACKED)]);
    let (s, frames) = run(&bytes);
    let s = s.unwrap();
    assert!(s.problems.iter().any(|p| p.message.contains("missing transform base_link <- radar")), "{:?}", s.problems);
    assert_eq!(frames[0].objects[0].verdict_name, "not_monitored");
    assert_eq!(frames[0].objects[0].reason, "invalid_state");
}

#[test]
fn an_object_judged_by_its_motion_only_carries_the_reason_the_sensor_could_not_judge_it() {
    let topic = BagConfig::default().objects_topic;
    let mut second = objects(1, "base_link");
    second.header.stamp.nanosec = 100_000_000;
    let bytes =
        bag(&topic, &[(encode(&objects(1, "base_link")).unwrap(), TRACKED), (encode(&second).unwrap(), TRACKED)]);
    let (s, frames) = run(&bytes);
    s.unwrap();
    assert_eq!(frames.len(), 2);
    // No cloud in the bag: the second frame's object is judged by the plausibility checks alone, and says why.
    assert_eq!(frames[1].objects[0].verdict_name, "motion_only_consistent", "{:?}", frames[1].objects[0]);
    assert_eq!(frames[1].objects[0].reason, "no_lidar_data", "{:?}", frames[1].objects[0]);
}
