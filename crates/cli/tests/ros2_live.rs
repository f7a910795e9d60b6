//! The live node `pmon ros2` against an independent DDS peer over loopback: Cyclone DDS (PyPI `cyclonedds`,
//! C library + Python binding, not pmon's RustDDS) replays a bag's messages, decoded with its own CDR from the
//! types in `crates/ros/tests/interop/ros2_types.py`, and records pmon's verdicts and `/diagnostics`; they
//! must equal `pmon check` on the same bag (`compare_live.py`). The node is stopped with SIGINT (Ctrl-C) and
//! must shut down cleanly with its summary.
//!
//! Needs `PMON_ROS2_LIVE=1` and a Python with `cyclonedds`, `mcap`, `mcap-ros2-support` and `rosbags` named by
//! `PMON_ROS_PYTHON`, on a network where DDS multicast discovery works (`.ci/ros2_live.sh` runs it in a
//! network namespace of its own); otherwise the tests print why and pass.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

/// Cyclone DDS on the loopback interface with multicast (discovery), as in the namespace the CI script makes.
const CYCLONE_URI: &str = "<CycloneDDS><Domain><General><Interfaces><NetworkInterface name=\"lo\" \
                           multicast=\"true\"/></Interfaces><AllowMulticast>true</AllowMulticast></General>\
                           </Domain></CycloneDDS>";

fn python() -> Option<PathBuf> {
    if std::env::var_os("PMON_ROS2_LIVE").is_none_or(|v| v != "1") {
        eprintln!("skipped: PMON_ROS2_LIVE is not 1 (run .ci/ros2_live.sh: it needs a network namespace)");
        return None;
    }
    let p = std::env::var_os("PMON_ROS_PYTHON").map(PathBuf::from);
    if p.is_none() {
        eprintln!("skipped: PMON_ROS_PYTHON is not set (run .ci/ros2_live.sh)");
    }
    p
}

fn interop_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../ros/tests/interop")
}

fn pmon() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pmon"))
}

fn run_ok(cmd: &mut Command, what: &str) -> String {
    let o = cmd.output().unwrap();
    assert!(
        o.status.success(),
        "{what} failed ({}): {}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Waits for the child up to `timeout`; kills it (and fails) if it does not end.
fn wait(child: &mut Child, timeout: Duration, what: &str) -> std::process::ExitStatus {
    let t0 = Instant::now();
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        if t0.elapsed() > timeout {
            child.kill().ok();
            child.wait().ok();
            panic!("{what} did not stop within {timeout:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

struct Live {
    /// compare_live.py's summary.
    summary: Value,
    /// The node's standard output (its shutdown summary).
    node_stdout: String,
    node_stderr: String,
}

/// Starts `pmon ros2`, replays `bag` through the Cyclone peer, stops the node with SIGINT, compares with
/// `pmon check`. The node waits up to 2 s (instead of 0.3 s) for a list's cloud and pose: on a loaded
/// 2-core machine a retransmitted cloud fragment can come late, and a list checked without its cloud would
/// differ from pmon check for a reason that is not the node's logic (lists whose inputs are there are checked
/// at once either way).
fn live_run(py: &Path, dir: &Path, bag: &Path, domain: u16, node_args: &[&str], peer_args: &[&str]) -> Live {
    let node_out = dir.join("node.out");
    let node_err = dir.join("node.err");
    let mut node = pmon()
        .arg("ros2")
        .args(["--domain-id", &domain.to_string(), "--pairing-wait-s", "2"])
        .args(node_args)
        .env_remove("ROS_DOMAIN_ID")
        .stdout(Stdio::from(std::fs::File::create(&node_out).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(&node_err).unwrap()))
        .spawn()
        .unwrap();
    let peer_json = dir.join("peer.json");
    let peer = Command::new(py)
        .arg(interop_dir().join("dds_peer.py"))
        .arg(bag)
        .arg(&peer_json)
        .args(["--domain", &domain.to_string()])
        .args(peer_args)
        .env("CYCLONEDDS_URI", CYCLONE_URI)
        .output()
        .unwrap();
    // Ctrl-C: the node checks what is still waiting, prints its summary and exits 0.
    let killed = Command::new("kill").args(["-INT", &node.id().to_string()]).status().unwrap();
    assert!(killed.success());
    let status = wait(&mut node, Duration::from_secs(20), "pmon ros2 after SIGINT");
    let node_stdout = std::fs::read_to_string(&node_out).unwrap();
    let node_stderr = std::fs::read_to_string(&node_err).unwrap();
    assert!(
        peer.status.success(),
        "peer failed: {}\n{}\nnode: {node_stdout}\n{node_stderr}",
        String::from_utf8_lossy(&peer.stdout),
        String::from_utf8_lossy(&peer.stderr)
    );
    eprintln!("{}", String::from_utf8_lossy(&peer.stdout));
    assert!(status.success(), "pmon ros2 exit status {status} after SIGINT: {node_stdout}\n{node_stderr}");
    assert!(node_stderr.contains("stopping (Ctrl-C or SIGTERM)"), "{node_stderr}");

    // pmon check on the same bag: JSON lines and the results MCAP (for /diagnostics).
    let results = dir.join("results.mcap");
    let o = pmon().arg("check").arg(bag).args(["--format", "jsonl", "--out"]).arg(&results).output().unwrap();
    assert!(matches!(o.status.code(), Some(0 | 1)), "pmon check: {}", String::from_utf8_lossy(&o.stderr));
    let jsonl = dir.join("check.jsonl");
    std::fs::write(&jsonl, &o.stdout).unwrap();
    let summary_path = dir.join("summary.json");
    let cmp = Command::new(py)
        .arg(interop_dir().join("compare_live.py"))
        .args([&peer_json, &jsonl, &results, &summary_path])
        .output()
        .unwrap();
    assert!(
        cmp.status.success(),
        "the node's results differ from pmon check: {}\n{}\nnode: {node_stdout}\n{node_stderr}",
        String::from_utf8_lossy(&cmp.stdout),
        String::from_utf8_lossy(&cmp.stderr)
    );
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(&summary_path).unwrap()).unwrap();
    eprintln!("live run: {summary}\nnode summary:\n{node_stdout}");
    Live { summary, node_stdout, node_stderr }
}

#[test]
fn rosbags_scene_over_dds_gives_the_verdicts_and_diagnostics_of_pmon_check() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = run_ok(Command::new(&py).arg(interop_dir().join("make_bag.py")).arg(dir.path().join("bag")), "make_bag");
    let bag = PathBuf::from(out.trim());
    let live = live_run(&py, dir.path(), &bag, 41, &[], &[]);
    let s = &live.summary;
    // Three object lists: a consistent car, a ghost, a missed object, and one list without a cloud.
    assert_eq!(s["frames_compared"], 3, "{s}");
    assert_eq!(s["diagnostics_compared"], 3, "{s}");
    assert!(s["object_alarms"].as_u64().unwrap() >= 2 && s["missed_objects"].as_u64().unwrap() >= 2, "{s}");
    let levels = &s["levels_seen"];
    assert!(levels["pmon: object consistency"].as_array().unwrap().iter().any(|l| l == "ERROR"), "{s}");
    assert!(levels["pmon: sensor input"].as_array().unwrap().iter().any(|l| l == "WARN"), "{s}");
    // The node status names the parameters it runs with, as the DDS peer read it.
    assert_eq!(s["node_params"], serde_json::json!(["the defaults (Table I)"]), "{s}");
    // The same pairing report as pmon check: the list at 1.3 s without a cloud, the cloud at 1.6 s alone.
    let n = &live.node_stdout;
    assert!(n.contains("pmon ros2: 3 frames (object lists)"), "{n}");
    assert!(n.contains("object lists without a cloud (plausibility only): 1") && n.contains("at t = 1.300 s"), "{n}");
    assert!(n.contains("clouds without an object list: 1") && n.contains("at t = 1.600 s"), "{n}");
    assert!(n.contains("object lists dropped 0") && n.contains("lost in DDS 0 object lists and 0 clouds"), "{n}");
    assert!(!live.node_stderr.contains("not published"), "{}", live.node_stderr);
}

#[test]
fn simulated_drive_at_10_hz_over_dds_equals_pmon_check() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    run_ok(
        pmon().args(["simulate", "--scenario", "pedestrians", "--seed", "7", "--duration-s", "3", "--out"]).arg(&rec),
        "pmon simulate",
    );
    let bag = dir.path().join("sim.mcap");
    run_ok(pmon().arg("convert").arg(&rec).args(["--format", "mcap", "--out"]).arg(&bag), "pmon convert");
    let live = live_run(&py, dir.path(), &bag, 42, &[], &["--rate-hz", "10"]);
    let s = &live.summary;
    let frames = s["frames_compared"].as_u64().unwrap();
    assert!(frames >= 25, "a 3 s drive at 10 Hz: {s}");
    assert_eq!(s["diagnostics_compared"].as_u64().unwrap(), frames, "{s}");
    assert!(s["object_verdicts_compared"].as_u64().unwrap() > frames, "{s}");
    let n = &live.node_stdout;
    assert!(n.contains(&format!("pmon ros2: {frames} frames (object lists)")), "{n}");
    assert!(n.contains("object lists dropped 0") && n.contains("lost in DDS 0 object lists and 0 clouds"), "{n}");
}

/// The KITTI object extracts (113k-127k points a sweep), as `pmon convert --format mcap` writes them; `None`
/// (with a message) when `../shared/data` (or `PMON_DATA_DIR`) does not have them.
fn kitti_bag(dir: &Path) -> Option<PathBuf> {
    let data = std::env::var_os("PMON_DATA_DIR")
        .map_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"), PathBuf::from);
    let kitti = data.join("kitti/object/training");
    if !kitti.join("velodyne").is_dir() {
        eprintln!("skipped: no KITTI extracts in {}", kitti.display());
        return None;
    }
    let bag = dir.join("kitti.mcap");
    let spec = format!("kitti:{}", kitti.display());
    run_ok(pmon().args(["convert", &spec, "--format", "mcap", "--out"]).arg(&bag), "pmon convert kitti");
    Some(bag)
}

#[test]
fn kitti_sweeps_of_115k_points_over_dds_equal_pmon_check() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let Some(bag) = kitti_bag(dir.path()) else { return };
    let live = live_run(&py, dir.path(), &bag, 43, &[], &["--rate-hz", "10"]);
    let s = &live.summary;
    assert_eq!(s["frames_compared"], 6, "{s}");
    assert_eq!(s["diagnostics_compared"], 6, "{s}");
    assert!(live.node_stdout.contains("lost in DDS 0 object lists and 0 clouds"), "{}", live.node_stdout);
}

/// Load: the KITTI sweeps replayed ten times at 10 Hz (60 frames, each stamped past the previous pass). Prints
/// the node's check time and arrival-to-publication time (median, p99), the peer's publish-to-verdict time and
/// the drops; asserts only that no frame went missing silently (each object list sent got its verdicts or was
/// counted as dropped or lost). Opt-in: `PMON_ROS2_LOAD=1 .ci/ros2_live.sh` (timings are measured, never
/// asserted).
#[test]
#[ignore = "load measurement, run by PMON_ROS2_LOAD=1 .ci/ros2_live.sh"]
fn kitti_at_10_hz_load_every_frame_accounted_for() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let Some(bag) = kitti_bag(dir.path()) else { return };
    let node_out = dir.path().join("node.out");
    let mut node = pmon()
        .args(["ros2", "--domain-id", "44"])
        .stdout(Stdio::from(std::fs::File::create(&node_out).unwrap()))
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let peer_json = dir.path().join("peer.json");
    let peer = Command::new(&py)
        .arg(interop_dir().join("dds_peer.py"))
        .arg(&bag)
        .arg(&peer_json)
        .args(["--domain", "44", "--rate-hz", "10", "--repeat", "10", "--timeout-s", "120"])
        .env("CYCLONEDDS_URI", CYCLONE_URI)
        .output()
        .unwrap();
    Command::new("kill").args(["-INT", &node.id().to_string()]).status().unwrap();
    let status = wait(&mut node, Duration::from_secs(30), "pmon ros2 after SIGINT");
    assert!(status.success());
    let node_stdout = std::fs::read_to_string(&node_out).unwrap();
    eprintln!("{}\n{node_stdout}", String::from_utf8_lossy(&peer.stdout));
    let p: Value = serde_json::from_str(&std::fs::read_to_string(&peer_json).unwrap()).unwrap();
    let sent = p["object_lists_sent"].as_u64().unwrap();
    let received = p["verdicts"].as_array().unwrap().len() as u64;
    let count = |label: &str| -> u64 {
        let i = node_stdout.find(label).unwrap_or_else(|| panic!("{label} not in {node_stdout}")) + label.len();
        node_stdout[i..].split_whitespace().next().unwrap().parse().unwrap()
    };
    let dropped = count("object lists dropped ");
    let lost = count("lost in DDS ");
    assert_eq!(received + dropped + lost, sent, "every object list sent is checked or counted: {node_stdout}");
    let mut lat: Vec<f64> = p["latency_s"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    lat.sort_by(f64::total_cmp);
    if !lat.is_empty() {
        let q = |f: f64| lat[((f * lat.len() as f64).ceil() as usize).clamp(1, lat.len()) - 1] * 1e3;
        eprintln!(
            "load: {sent} object lists at 10 Hz in {:.1} s ({} sent late by the peer), {received} verdicts, \
             {dropped} dropped, {lost} lost in DDS; peer publish-to-verdict median {:.2} ms, p99 {:.2} ms",
            p["replay_s"].as_f64().unwrap(),
            p["lists_sent_late"],
            q(0.5),
            q(0.99)
        );
    }
}

#[test]
fn a_malformed_cloud_over_dds_is_reported_and_the_node_goes_on() {
    let Some(py) = python() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = run_ok(
        Command::new(&py).arg(interop_dir().join("make_bag.py")).arg(dir.path().join("bag")).arg("--malformed"),
        "make_bag --malformed",
    );
    let bag = PathBuf::from(out.trim());
    let node_out = dir.path().join("node.out");
    let node_err = dir.path().join("node.err");
    let mut node = pmon()
        .args(["ros2", "--domain-id", "45"])
        .stdout(Stdio::from(std::fs::File::create(&node_out).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(&node_err).unwrap()))
        .spawn()
        .unwrap();
    let peer_json = dir.path().join("peer.json");
    let peer = Command::new(&py)
        .arg(interop_dir().join("dds_peer.py"))
        .arg(&bag)
        .arg(&peer_json)
        .args(["--domain", "45"])
        .env("CYCLONEDDS_URI", CYCLONE_URI)
        .output()
        .unwrap();
    Command::new("kill").args(["-INT", &node.id().to_string()]).status().unwrap();
    let status = wait(&mut node, Duration::from_secs(20), "pmon ros2 after SIGINT");
    let (n_out, n_err) = (std::fs::read_to_string(&node_out).unwrap(), std::fs::read_to_string(&node_err).unwrap());
    let peer_out = String::from_utf8_lossy(&peer.stdout);
    assert!(peer.status.success() && peer_out.contains("header-only PointCloud2"), "{peer_out}\n{n_out}\n{n_err}");
    assert!(status.success(), "{n_out}\n{n_err}");
    // The cut cloud is reported when it arrives; its object list is still checked (without a cloud).
    assert!(n_err.contains("/sensing/lidar/concatenated/pointcloud: cloud not used:"), "{n_err}");
    assert!(n_out.contains("pmon ros2: 3 frames (object lists), 2 clouds"), "{n_out}");
    assert!(n_out.contains("(1 undecodable messages)"), "{n_out}");
    let p: Value = serde_json::from_str(&std::fs::read_to_string(&peer_json).unwrap()).unwrap();
    let v = p["verdicts"].as_array().unwrap();
    assert_eq!(v.len(), 3);
    assert_eq!(v[1]["sensor_status"], "no_lidar_data", "the list whose cloud was cut: {}", v[1]);
}
