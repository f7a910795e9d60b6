//! End-to-end tests of the `pmon` binary on recordings written here.

use std::path::Path;
use std::process::{Command, Output};

use pmon_monitor::{Isometry3, ObjectClass, ObjectState, Pose2};
use pmon_recording::{write_recording, OwnedCloud, RecordedFrame, RecordingMeta};

fn pmon(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pmon")).args(args).output().expect("pmon runs")
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// A pedestrian walking at 1.2 m/s along y, 10 m ahead, seen by a LiDAR 1.8 m up (points on its near face,
/// ground all around). `displace_from` shifts the reported position 1.5 m away from frame k on.
fn write_walk(dir: &Path, frames: u64, displace_from: Option<u64>) {
    let mut out = Vec::new();
    for k in 0..frames {
        let t = k as f64 * 0.1;
        let y = -3.0 + 1.2 * t as f32;
        let mut points = Vec::new();
        for i in 0..=12 {
            let py = y - 0.3 + 0.05 * i as f32;
            for z in [0.6f32, 1.0, 1.4] {
                points.push([9.7, py, z - 1.8]);
            }
        }
        for r in 2..45 {
            for a in 0..720 {
                let a = (a as f32 * 0.5).to_radians();
                points.push([r as f32 * a.cos(), r as f32 * a.sin(), -1.8]);
            }
        }
        let x = if displace_from.is_some_and(|d| k >= d) { 11.5 } else { 10.0 };
        let mut f = RecordedFrame::empty(k, t, Pose2::default());
        f.objects.push(ObjectState {
            id: 4,
            class: ObjectClass::Pedestrian,
            x_m: x,
            y_m: y,
            heading_rad: std::f32::consts::FRAC_PI_2,
            speed_mps: 1.2,
            length_m: 0.6,
            width_m: 0.6,
            uncertainty: None,
        });
        f.cloud =
            Some(OwnedCloud { points_in_sensor: points, ego_from_sensor: Isometry3::from_translation(0.0, 0.0, 1.8) });
        out.push(f);
    }
    write_recording(dir, RecordingMeta::new("walk", "cli test"), &out).expect("write");
}

#[test]
fn params_round_trip_and_unknown_keys_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let o = pmon(&["params"]);
    assert!(o.status.success());
    let p = dir.path().join("p.toml");
    std::fs::write(&p, &o.stdout).unwrap();
    let again = pmon(&["params", "--params", p.to_str().unwrap()]);
    assert_eq!(again.stdout, o.stdout);
    std::fs::write(&p, "cell_size_m = 0.2\nsafety_margn_m = 0.1\n").unwrap();
    let bad = pmon(&["params", "--params", p.to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("safety_margn_m"), "{}", text(&bad));
    std::fs::write(&p, "cell_size_m = -1.0\n").unwrap();
    let bad = pmon(&["params", "--params", p.to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("cell_size_m"), "{}", text(&bad));
}

#[test]
fn clean_walk_has_no_alarm_and_displacement_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("clean");
    write_walk(&clean, 6, None);
    let o = pmon(&["check", clean.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("6 frames, 6 object states, 0 frames with alarms"), "{}", text(&o));

    let shifted = dir.path().join("shifted");
    write_walk(&shifted, 6, Some(3));
    let o = pmon(&["check", shifted.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let out = text(&o);
    assert!(out.contains("frame     3") && out.contains("position error"), "{out}");
    // The jump also breaks the motion history: frame 3 is a position error (sensor first) and the
    // plausibility check sees the 1.5 m jump.
    let o = pmon(&["check", "--format", "jsonl", shifted.to_str().unwrap()]);
    let lines: Vec<serde_json::Value> =
        String::from_utf8_lossy(&o.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 6);
    assert_eq!(lines[2]["verdict"], "consistent");
    assert_eq!(lines[3]["verdict"], "position_error");
    assert!(lines[3]["motion"].as_str().unwrap().contains("position"), "{}", lines[3]);
    assert_eq!(lines[0]["reason"], serde_json::Value::Null);
    assert_eq!(lines[0]["motion"], "not_monitored(first_frame_of_track)");
}

#[test]
fn malformed_input_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    write_walk(&rec, 3, None);
    let frames = rec.join("frames.jsonl");
    let text_in = std::fs::read_to_string(&frames).unwrap();
    let mut lines: Vec<&str> = text_in.lines().collect();
    let cut = &lines[1][..lines[1].len() / 2];
    lines[1] = cut;
    std::fs::write(&frames, lines.join("\n")).unwrap();
    let o = pmon(&["check", rec.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("frames.jsonl:2"), "{}", text(&o));

    let o = pmon(&["check", dir.path().join("nothing-here").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("nothing-here"), "{}", text(&o));
}

#[test]
fn object_list_without_clouds_runs_plausibility_only() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("objects.jsonl");
    let mut s = String::new();
    for k in 0..4 {
        let x = if k == 3 { 5.0 } else { 1.0 * k as f64 * 0.1 };
        s.push_str(&format!(
            "{{\"frame\":{k},\"timestamp_s\":{},\"objects\":[{{\"id\":1,\"class\":\"car\",\"x_m\":{x},\"y_m\":0,\"heading_rad\":0,\"speed_mps\":1,\"length_m\":4,\"width_m\":2}}]}}\n",
            k as f64 * 0.1
        ));
    }
    std::fs::write(&p, s).unwrap();
    let o = pmon(&["check", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    // The alarm names its kind and size (issue #11), and the summary counts alarms by kind.
    assert!(text(&o).contains("implausible motion: position_jump +"), "{}", text(&o));
    assert!(text(&o).contains("implausible motion by kind"), "{}", text(&o));
    assert!(text(&o).contains("consistent"), "{}", text(&o));
}

/// `pmon reproduce --smoke` runs every experiment end to end (tiny scenes, three points per sweep) and writes
/// the report; its numbers come from the runs: a deliberately weakened monitor turns the permanent position
/// claims into misses and lowers the measured recall.
#[test]
fn reproduce_writes_a_report_derived_from_the_runs() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, params: Option<&str>| -> serde_json::Value {
        let out = dir.path().join(name);
        let mut args = vec!["reproduce", "--smoke", "--seed", "3", "--out", out.to_str().unwrap()];
        let p = dir.path().join(format!("{name}.toml"));
        if let Some(text) = params {
            std::fs::write(&p, text).unwrap();
            args.extend(["--params", p.to_str().unwrap()]);
        }
        let o = pmon(&args);
        assert!(o.status.success(), "{}", text(&o));
        for f in [
            "index.html",
            "results.json",
            "permanent_position.svg",
            "permanent_position.png",
            "permanent_position.csv",
            "latency.png",
            "dv_theory_transient.png",
        ] {
            let path = out.join(f);
            assert!(std::fs::metadata(&path).map(|m| m.len() > 0).unwrap_or(false), "{} missing", path.display());
        }
        let html = std::fs::read_to_string(out.join("index.html")).unwrap();
        assert!(html.contains("Paper vs pmon"));
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap()
    };
    let recall_at = |r: &serde_json::Value, curve: &str, x: f64| -> f64 {
        let figs = r["figures"].as_array().unwrap();
        let fig = figs.iter().find(|f| f["spec"]["id"] == "permanent_position").unwrap();
        let c = fig["curves"].as_array().unwrap().iter().find(|c| c["label"] == curve).unwrap();
        let p = c["points"].as_array().unwrap().iter().find(|p| (p["x"].as_f64().unwrap() - x).abs() < 1e-9).unwrap();
        p["rate"]["value"].as_f64().unwrap()
    };
    let normal = run("normal", None);
    // A monitor whose safety margin swallows every displacement.
    let weak = run("weak", Some("safety_margin_m = 3.0\n"));
    let r_normal = recall_at(&normal, "sensor recall, 0.5 m cells", 2.0);
    let r_weak = recall_at(&weak, "sensor recall, 0.5 m cells", 2.0);
    assert!(r_normal > r_weak + 0.2, "normal {r_normal} vs weakened {r_weak}");
    let claims = weak["claims"].as_array().unwrap();
    let permanent: Vec<_> =
        claims.iter().filter(|c| c["paper"].as_str().unwrap().starts_with("Permanent position")).collect();
    assert_eq!(permanent.len(), 2);
    assert!(permanent.iter().all(|c| c["met"] == serde_json::Value::Bool(false)), "{permanent:?}");
}

fn data_dir() -> Option<std::path::PathBuf> {
    let dir = std::env::var_os("PMON_DATA_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    if dir.exists() {
        Some(dir)
    } else {
        eprintln!("SKIPPED: no real data at {} (set PMON_DATA_DIR)", dir.display());
        None
    }
}

#[test]
fn datasets_convert_to_recordings_that_check_the_same() {
    let Some(data) = data_dir() else { return };
    let dir = tempfile::tempdir().unwrap();
    let spec = format!("nuscenes:{}", data.join("nuscenes").display());
    let direct = pmon(&["check", "--format", "jsonl", &spec]);
    assert_ne!(direct.status.code(), Some(2), "{}", text(&direct));
    let rec = dir.path().join("nusc");
    let o = pmon(&["convert", &spec, "--out", rec.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let p = dir.path().join("p.toml");
    std::fs::write(&p, "ground_z_m = 0.0\nego_footprint_m = [-1.2, -1.2, 4.2, 1.2]\n").unwrap();
    let converted = pmon(&["check", "--format", "jsonl", "--params", p.to_str().unwrap(), rec.to_str().unwrap()]);
    assert_ne!(converted.status.code(), Some(2), "{}", text(&converted));
    let verdicts = |o: &Output| -> Vec<String> {
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
            .map(|v| format!("{} {}", v["id"], v["verdict"]))
            .collect()
    };
    // The direct check applies nuScenes' ground (z = 0) and vehicle footprint; the converted run gets them
    // from the parameter file: the same parameters, the same verdicts.
    assert_eq!(verdicts(&direct), verdicts(&converted));
    assert_eq!(verdicts(&direct).iter().filter(|v| !v.contains("missed_object")).count(), 69);
    let bad = pmon(&["check", "kitti:/nonexistent/kitti"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("nonexistent"), "{}", text(&bad));
}
