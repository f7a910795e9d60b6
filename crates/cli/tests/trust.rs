//! Issue 15: a tool you can trust with your data. End-to-end regression tests of the `pmon` binary, each
//! named after what broke.

mod common;
use common::{data_dir, pmon, text};
use std::path::Path;
use std::process::{Command, Stdio};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A one-object, cloud-free object list with the given lines' frame numbers and timestamps.
fn object_lines(frames: &[(u64, f64)]) -> String {
    frames
        .iter()
        .map(|(k, t)| {
            format!(
                "{{\"frame\":{k},\"timestamp_s\":{t},\"objects\":[{{\"id\":1,\"class\":\"car\",\"x_m\":{},\"y_m\":0,\"heading_rad\":0,\"speed_mps\":10,\"length_m\":4,\"width_m\":2}}]}}\n",
                10.0 + 10.0 * t
            )
        })
        .collect()
}

#[test]
fn issue_15_simulate_refuses_to_overwrite_a_folder_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rec");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("thesis.tex"), "years of work").unwrap();
    let args = ["simulate", "--scenario", "pedestrians", "--duration-s", "0.3", "--out", s(&out)];
    let o = pmon(&args);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--force"), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(out.join("thesis.tex")).unwrap(), "years of work");
    assert!(!out.join("recording.json").exists());
    // With --force the folder is replaced as a whole: no old file mixed into the new recording.
    let mut forced = args.to_vec();
    forced.push("--force");
    let o = pmon(&forced);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!out.join("thesis.tex").exists() && out.join("recording.json").exists());
    // Its own previous output is replaced without --force (running a command twice works).
    let o = pmon(&args);
    assert!(o.status.success(), "{}", text(&o));
    // A different command does not take it over.
    let o = pmon(&["view", s(&out), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // No temporary folder is left beside it.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 1, "{names:?}");
}

#[test]
fn issue_15_view_refuses_to_overwrite_a_foreign_file_but_replaces_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("objects.jsonl");
    std::fs::write(&rec, object_lines(&[(0, 0.0), (1, 0.1)])).unwrap();
    let png = dir.path().join("photo.png");
    std::fs::write(&png, "a holiday photo").unwrap();
    let o = pmon(&["view", s(&rec), "--frame", "1", "--out", s(&png)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&png).unwrap(), "a holiday photo");
    let o = pmon(&["view", s(&rec), "--frame", "1", "--out", s(&png), "--force"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    // Now it is pmon's own image (tagged): the same command again replaces it.
    let o = pmon(&["view", s(&rec), "--frame", "0", "--out", s(&png)]);
    assert!(o.status.success(), "{}", text(&o));
    for svg in [false, true] {
        let p = dir.path().join(if svg { "v.svg" } else { "v2.png" });
        for _ in 0..2 {
            let o = pmon(&["view", s(&rec), "--out", s(&p)]);
            assert!(o.status.success(), "{}", text(&o));
        }
    }
}

#[test]
fn issue_15_check_out_refuses_to_overwrite_a_foreign_file() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("objects.jsonl");
    std::fs::write(&rec, object_lines(&[(0, 0.0), (1, 0.1)])).unwrap();
    let out = dir.path().join("notes.txt");
    std::fs::write(&out, "my notes").unwrap();
    let o = pmon(&["check", s(&rec), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "my notes");
    let fresh = dir.path().join("verdicts.jsonl");
    for _ in 0..2 {
        let o = pmon(&["check", s(&rec), "--format", "jsonl", "--out", s(&fresh)]);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
}

#[test]
fn issue_15_empty_input_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("empty.jsonl");
    std::fs::write(&rec, "").unwrap();
    let o = pmon(&["check", s(&rec)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("no frames"), "{}", text(&o));
}

#[test]
fn issue_15_time_going_backwards_is_an_error_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("back.jsonl");
    std::fs::write(&rec, object_lines(&[(0, 0.0), (1, 0.1), (2, 0.05)])).unwrap();
    let o = pmon(&["check", s(&rec)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("back.jsonl:3") && text(&o).contains("increase"), "{}", text(&o));
}

#[test]
fn issue_15_skipped_frame_numbers_are_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("skip.jsonl");
    std::fs::write(&rec, object_lines(&[(0, 0.0), (2, 0.1)])).unwrap();
    let o = pmon(&["check", s(&rec)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("skip.jsonl:2") && text(&o).contains("frame number 2"), "{}", text(&o));
}

#[test]
fn issue_15_negative_size_and_speed_are_errors_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("neg.jsonl");
    for (bad, key) in [("\"length_m\":4", "\"length_m\":-4"), ("\"speed_mps\":10", "\"speed_mps\":-1")] {
        std::fs::write(&rec, object_lines(&[(0, 0.0), (1, 0.1)]).replacen(bad, key, 2).replacen(key, bad, 1)).unwrap();
        let o = pmon(&["check", s(&rec)]);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains("neg.jsonl:2"), "{}", text(&o));
    }
    // A value beyond f32 is an error, not an infinity.
    std::fs::write(&rec, object_lines(&[(0, 0.0)]).replace("\"x_m\":10", "\"x_m\":1e39")).unwrap();
    let o = pmon(&["check", s(&rec)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("neg.jsonl:1") && text(&o).contains("finite"), "{}", text(&o));
}

/// A recording directory with one frame whose cloud entry is `file` promising `points` points.
fn recording_with_cloud(dir: &Path, file: &str, points: u64) {
    std::fs::create_dir_all(dir.join("clouds")).unwrap();
    std::fs::write(
        dir.join("recording.json"),
        "{\"format\":\"pmon-recording\",\"version\":1,\"name\":\"t\",\"source\":\"t\",\"frames\":1}\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("frames.jsonl"),
        format!("{{\"frame\":0,\"timestamp_s\":0.0,\"objects\":[],\"cloud\":{{\"file\":\"{file}\",\"points\":{points},\"ego_from_sensor\":{{\"rotation\":[[1,0,0],[0,1,0],[0,0,1]],\"translation_m\":[0,0,1.8]}}}}}}\n"),
    )
    .unwrap();
}

#[test]
fn issue_15_cloud_paths_stay_inside_the_recording() {
    let dir = tempfile::tempdir().unwrap();
    for file in ["/dev/zero", "../outside.bin", "clouds/../../outside.bin"] {
        let rec = dir.path().join("rec");
        recording_with_cloud(&rec, file, 10);
        let o = pmon(&["check", s(&rec)]);
        assert_eq!(o.status.code(), Some(2), "{file}: {}", text(&o));
        assert!(text(&o).contains("frames.jsonl:1") && text(&o).contains("relative path"), "{}", text(&o));
    }
}

#[test]
fn issue_15_cloud_is_not_read_past_the_size_its_frame_promises() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    recording_with_cloud(&rec, "clouds/000000.bin", 1);
    std::fs::write(rec.join("clouds/000000.bin"), vec![0u8; 12 * 1000]).unwrap();
    let o = pmon(&["check", s(&rec)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("frames.jsonl:1") && text(&o).contains("12000 bytes"), "{}", text(&o));
    // A symbolic link to a device is not a regular file: refused before reading (no hang, no endless read).
    #[cfg(unix)]
    {
        std::fs::remove_file(rec.join("clouds/000000.bin")).unwrap();
        std::os::unix::fs::symlink("/dev/zero", rec.join("clouds/000000.bin")).unwrap();
        let o = pmon(&["check", s(&rec)]);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains("not a regular file"), "{}", text(&o));
    }
}

#[test]
fn issue_15_missing_cloud_file_names_the_referencing_line() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    recording_with_cloud(&rec, "clouds/000000.bin", 1);
    let o = pmon(&["check", s(&rec)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("frames.jsonl:1") && text(&o).contains("000000.bin"), "{}", text(&o));
}

#[test]
fn issue_15_os_errors_are_printed_once() {
    let o = pmon(&["check", "/nonexistent/rec"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
    let o = pmon(&["view", "/nonexistent/rec"]);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
}

#[test]
fn issue_15_whole_file_errors_carry_no_line_zero() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    recording_with_cloud(&rec, "clouds/000000.bin", 1);
    std::fs::write(
        rec.join("recording.json"),
        "{\"format\":\"other\",\"version\":1,\"name\":\"t\",\"source\":\"t\",\"frames\":1}\n",
    )
    .unwrap();
    let o = pmon(&["check", s(&rec)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!text(&o).contains(":0:") && text(&o).contains("recording.json: format"), "{}", text(&o));
}

#[test]
fn issue_15_unknown_dataset_prefix_says_so() {
    for cmd in ["check", "view", "convert"] {
        let mut args = vec![cmd, "kiti:/some/dir"];
        if cmd == "convert" {
            args.extend(["--out", "/nonexistent/never-written"]);
        }
        let o = pmon(&args);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains("unknown dataset prefix `kiti:`"), "{cmd}: {}", text(&o));
    }
}

#[test]
fn issue_15_dash_reads_standard_input() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_pmon"))
        .args(["check", "-", "--format", "jsonl"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    child.stdin.take().unwrap().write_all(object_lines(&[(0, 0.0), (1, 0.1), (2, 0.2)]).as_bytes()).unwrap();
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().filter(|l| l.contains("\"id\":1")).count(), 3);
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
    }
}

/// Issue 10/11 (d): an Argoverse 2 log without `calibration/` falls back to the documented nominal up-LiDAR
/// origin with a warning on stderr, for `check` and `convert`, instead of failing.
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn issue_11_av2_log_without_calibration_uses_the_nominal_sensor_pose_with_a_warning() {
    let Some(data) = data_dir() else { return };
    let log = data.join("av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede");
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("log");
    copy_tree(&log, &copy);
    std::fs::remove_dir_all(copy.join("calibration")).unwrap();
    let spec = format!("av2:{}", copy.display());
    let o = pmon(&["check", &spec]);
    assert_ne!(o.status.code(), Some(2), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("warning:") && err.contains("nominal") && err.contains("calibration"), "{err}");
    let out = dir.path().join("rec");
    let o = pmon(&["convert", &spec, "--out", s(&out)]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nominal"), "{}", text(&o));
}

#[test]
fn issue_15_checks_choose_which_checks_run() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("objects.jsonl");
    // Frame 2 jumps 50 m: an implausible motion when the motion checks run.
    std::fs::write(&rec, object_lines(&[(0, 0.0), (1, 0.1), (2, 0.2)]).replace("\"x_m\":12,", "\"x_m\":62,")).unwrap();
    let jsonl = |checks: &str| -> Vec<serde_json::Value> {
        let o = pmon(&["check", s(&rec), "--format", "jsonl", "--checks", checks]);
        assert_ne!(o.status.code(), Some(2), "{}", text(&o));
        String::from_utf8_lossy(&o.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect()
    };
    let both = jsonl("sensor,motion");
    assert_eq!(both[2]["verdict"], "implausible_motion", "{}", both[2]);
    // Without a LiDAR sweep, a plausible track is motion-only consistent, never `consistent`.
    assert_eq!(both[1]["verdict"], "motion_only_consistent", "{}", both[1]);
    assert_eq!(both[1]["reason"], "no_lidar_data", "{}", both[1]);
    let sensor_only = jsonl("sensor");
    for r in &sensor_only[..3] {
        assert_eq!(r["motion"], "not_monitored(check_disabled)", "{r}");
        assert_eq!(r["verdict"], "not_monitored", "{r}");
    }
    let totals = &sensor_only[3];
    assert_eq!(totals["record"], "totals");
    assert_eq!(totals["frames_with_alarms"], 0);
    let motion_only = jsonl("motion");
    assert_eq!(motion_only[2]["verdict"], "implausible_motion");
    assert_eq!(motion_only[1]["sensor"], "not_monitored(check_disabled)");
    let o = pmon(&["check", s(&rec), "--checks", "lidar"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

#[test]
fn issue_15_check_piped_into_head_ends_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("objects.jsonl");
    let frames: Vec<(u64, f64)> = (0..20_000).map(|k| (k, k as f64 * 0.1)).collect();
    std::fs::write(&rec, object_lines(&frames)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_pmon"))
        .args(["check", s(&rec), "--format", "jsonl"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        use std::io::Read;
        let mut first = [0u8; 100];
        child.stdout.take().unwrap().read_exact(&mut first).unwrap();
        // the pipe's reader goes away here, like `head`
    }
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("error") && !err.contains("panicked"), "{err}");
    assert_eq!(o.status.code(), Some(141), "{err}");
}

#[test]
fn license_files_match_cargo_toml() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let manifest = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    assert!(manifest.contains("license = \"MIT OR Apache-2.0\""));
    assert!(std::fs::read_to_string(root.join("LICENSE-MIT")).unwrap().contains("MIT License"));
    assert!(std::fs::read_to_string(root.join("LICENSE-APACHE")).unwrap().contains("Apache License"));
}

/// Issue 10/11 (b): `pmon view` takes dataset specs like `check` does, with the dataset's ground height.
#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn issue_11_view_accepts_dataset_specs() {
    let Some(data) = data_dir() else { return };
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("kitti.png");
    let spec = format!("kitti:{}", data.join("kitti/object/training").display());
    let o = pmon(&["view", &spec, "--frame", "0", "--out", s(&png)]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
}
