//! Interop with independent ROS 2 tooling: bags written by the pure-Python `rosbags` library (Autoware
//! messages from the upstream `.msg` files) are checked by `pmon check`, and pmon's results MCAP is read back
//! by the Python `mcap` reader with `mcap-ros2-support` decoding the CDR (crates/ros/tests/interop).
//!
//! Needs a Python with `rosbags`, `mcap` and `mcap-ros2-support`, named by `PMON_ROS_PYTHON` (`.ci/ros.sh`
//! makes one); without it the tests print why and pass.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

fn python() -> Option<PathBuf> {
    let p = std::env::var_os("PMON_ROS_PYTHON").map(PathBuf::from);
    if p.is_none() {
        eprintln!("skipped: PMON_ROS_PYTHON is not set (run .ci/ros.sh)");
    }
    p
}

fn interop_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../ros/tests/interop")
}

fn make_bag(py: &Path, dir: &Path, mode: Option<&str>) -> PathBuf {
    let out = dir.join("bag");
    let mut cmd = Command::new(py);
    cmd.arg(interop_dir().join("make_bag.py")).arg(&out);
    if let Some(m) = mode {
        cmd.arg(m);
    }
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "make_bag.py failed: {}", String::from_utf8_lossy(&o.stderr));
    PathBuf::from(String::from_utf8(o.stdout).unwrap().trim())
}

fn pmon_check(bag: &Path, out: Option<&Path>) -> (Output, Vec<Value>) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_pmon"));
    cmd.arg("check").arg(bag).args(["--format", "jsonl"]);
    if let Some(o) = out {
        cmd.arg("--out").arg(o);
    }
    let o = cmd.output().unwrap();
    let frames = String::from_utf8_lossy(&o.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    (o, frames)
}

fn verdicts(frame: &Value) -> Vec<(u64, String, String)> {
    frame["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| {
            (
                o["id"].as_u64().unwrap(),
                o["verdict_name"].as_str().unwrap().into(),
                o["reason"].as_str().unwrap().into(),
            )
        })
        .collect()
}

#[test]
fn rosbags_bag_gives_the_expected_verdicts_and_python_mcap_reads_the_results() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bag = make_bag(&py, dir.path(), None);
    let results = dir.path().join("results.mcap");
    let (o, frames) = pmon_check(&bag, Some(&results));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "alarms give status 1: {stderr}");
    assert_eq!(frames.len(), 3);
    assert!(
        stderr.contains("object lists without a cloud (plausibility only): 1") && stderr.contains("at t = 1.300 s"),
        "{stderr}"
    );
    assert!(stderr.contains("clouds without an object list: 1") && stderr.contains("at t = 1.600 s"), "{stderr}");
    let jsonl = dir.path().join("verdicts.jsonl");
    std::fs::write(&jsonl, &o.stdout).unwrap();
    let check =
        Command::new(&py).arg(interop_dir().join("check_results.py")).args([&results, &bag, &jsonl]).output().unwrap();
    assert!(
        check.status.success(),
        "check_results.py: {}{}",
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
    // The top view of a bag frame (the docs' picture) is drawn.
    let png = dir.path().join("view.png");
    let v = Command::new(env!("CARGO_BIN_EXE_pmon"))
        .arg("check")
        .arg(&bag)
        .args(["--view-frame", "0", "--view-out"])
        .arg(&png)
        .output()
        .unwrap();
    assert_eq!(v.status.code(), Some(1));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    // The results file is never overwritten.
    let (again, _) = pmon_check(&bag, Some(&results));
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("already exists"));
}

#[test]
fn malformed_cloud_is_reported_and_its_frame_not_sensor_checked() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bag = make_bag(&py, dir.path(), Some("--malformed"));
    let (o, frames) = pmon_check(&bag, None);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "bad input gives status 2: {stderr}");
    assert!(stderr.contains("cloud not used (sensor checks not run): malformed CDR"), "{stderr}");
    assert_eq!(frames.len(), 3, "the frame is still checked and reported");
    assert!(frames[1]["sensor_status"].as_str().unwrap().starts_with("malformed cloud"), "{}", frames[1]);
    assert!(verdicts(&frames[1]).iter().all(|v| v.1 != "ghost"));
    assert!(verdicts(&frames[0]).iter().any(|v| v.1 == "ghost"), "the good clouds are still used");
}

#[test]
fn empty_cloud_leaves_sensor_checks_not_monitored() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bag = make_bag(&py, dir.path(), Some("--empty-cloud"));
    let (_, frames) = pmon_check(&bag, None);
    assert_eq!(frames[0]["sensor_status"], "empty_cloud");
    assert_eq!(
        verdicts(&frames[0]),
        vec![(1, "not_monitored".into(), "empty_cloud".into()), (2, "not_monitored".into(), "empty_cloud".into())]
    );
    assert_eq!(verdicts(&frames[1])[1].1, "ghost");
}

#[test]
fn missing_transform_is_reported_and_sensor_checks_do_not_run() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bag = make_bag(&py, dir.path(), Some("--no-tf"));
    let (o, frames) = pmon_check(&bag, None);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("missing transform base_link <- lidar: sensor checks not run"), "{stderr}");
    for f in &frames[..2] {
        assert_eq!(f["sensor_status"], "missing transform base_link <- lidar");
        assert!(verdicts(f).iter().all(|v| v.1 != "ghost"));
    }
}

#[test]
fn time_jump_backwards_is_not_monitored_not_an_alarm() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bag = make_bag(&py, dir.path(), Some("--time-jump"));
    let (_, frames) = pmon_check(&bag, None);
    assert_eq!(frames.len(), 3);
    assert_eq!(frames[2]["header"]["stamp"]["sec"], 0);
    for v in verdicts(&frames[2]) {
        assert_eq!((v.1.as_str(), v.2.as_str()), ("not_monitored", "time_step_not_positive"), "{v:?}");
    }
}

#[test]
fn converted_recording_decodes_in_python_with_the_same_objects_and_points() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("sim");
    let pmon = env!("CARGO_BIN_EXE_pmon");
    let s = Command::new(pmon).args(["simulate", "--duration-s", "0.3", "--out"]).arg(&rec).output().unwrap();
    assert!(s.status.success());
    let out = dir.path().join("sim.mcap");
    let c = Command::new(pmon).arg("convert").arg(&rec).args(["--format", "mcap", "--out"]).arg(&out).output().unwrap();
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
    let r = Command::new(&py).arg(interop_dir().join("read_converted.py")).arg(&out).output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: Value = serde_json::from_slice(&r.stdout).unwrap();
    let frames: Vec<_> = pmon_recording::RecordingReader::open(&rec).unwrap().map(Result::unwrap).collect();
    assert_eq!(v["counts"]["/perception/object_recognition/tracking/objects"], frames.len());
    assert_eq!(v["counts"]["/sensing/lidar/concatenated/pointcloud"], frames.len());
    let decoded = v["frames"].as_array().unwrap();
    let (clouds, lists): (Vec<&Value>, Vec<&Value>) = decoded.iter().partition(|f| f.get("points").is_some());
    for ((f, cloud), list) in frames.iter().zip(clouds).zip(lists) {
        let c = f.cloud.as_ref().unwrap();
        assert_eq!(cloud["points"], c.points_in_sensor.len());
        // Python prints the float32 values widened to float64; compared as float32 they are the same bits.
        #[allow(clippy::cast_possible_truncation)]
        let first: Vec<f32> =
            cloud["first_point"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect();
        assert_eq!(first, c.points_in_sensor[0].to_vec());
        let ids: Vec<u64> = list["ids"].as_array().unwrap().iter().map(|x| x.as_u64().unwrap()).collect();
        assert_eq!(ids, f.objects.iter().map(|o| o.id).collect::<Vec<_>>());
        #[allow(clippy::cast_possible_truncation)]
        let xs: Vec<f32> = list["xs"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect();
        assert_eq!(xs, f.objects.iter().map(|o| o.x_m).collect::<Vec<_>>());
        assert!((list["stamp"].as_f64().unwrap() - f.timestamp_s).abs() < 1e-9);
    }
}

#[test]
fn detected_objects_with_polygon_footprints_are_checked_as_new_tracks() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let bag = make_bag(&py, dir.path(), Some("--detected"));
    let o = Command::new(env!("CARGO_BIN_EXE_pmon"))
        .arg("check")
        .arg(&bag)
        .args(["--format", "jsonl", "--objects-topic", "/perception/object_recognition/detection/objects"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    let frames: Vec<Value> =
        String::from_utf8_lossy(&o.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(frames.len(), 3);
    for f in &frames[..2] {
        let v = verdicts(f);
        assert_eq!((v[0].1.as_str(), v[1].1.as_str()), ("consistent", "ghost"), "{v:?}");
        assert!(f["objects"][0]["object_id"]["uuid"].as_array().unwrap().iter().all(|b| b == 0));
    }
    // Detections get fresh ids each frame: without a cloud they are a first frame, never a motion alarm.
    for v in verdicts(&frames[2]) {
        assert_eq!((v.1.as_str(), v.2.as_str()), ("not_monitored", "first_frame_of_track"), "{v:?}");
    }
    let ids: Vec<u64> = frames.iter().flat_map(verdicts).map(|v| v.0).collect();
    let mut unique = ids.clone();
    unique.sort_unstable();
    unique.dedup();
    assert_eq!(unique.len(), ids.len(), "{ids:?}");
}
