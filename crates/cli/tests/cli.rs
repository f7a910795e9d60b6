//! End-to-end tests of the `pmon` binary on recordings written here.

mod common;
use common::{data_dir, pmon, text};
use std::path::Path;
use std::process::Output;

use pmon_monitor::{Isometry3, ObjectClass, ObjectState, Pose2};
use pmon_recording::{write_recording, OwnedCloud, RecordedFrame, RecordingMeta};

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
    // The spill-over fit is a key (default `every_return`): `occupied` is kept, a misspelt value is named.
    assert!(text(&o).contains("spill_over_fit = \"every_return\""), "{}", text(&o));
    std::fs::write(&p, "spill_over_fit = \"occupied\"\n").unwrap();
    let occupied = pmon(&["params", "--params", p.to_str().unwrap()]);
    assert!(occupied.status.success(), "{}", text(&occupied));
    assert!(text(&occupied).contains("spill_over_fit = \"occupied\""), "{}", text(&occupied));
    std::fs::write(&p, "spill_over_fit = \"every_returns\"\n").unwrap();
    let bad = pmon(&["params", "--params", p.to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("every_returns"), "{}", text(&bad));
}

/// `--params profile:recall` is the shipped profile: `pmon params` prints the defaults with its three keys turned
/// on (and says which profile), `check` runs with it, an unknown profile exits 2 and names the ones there are, and
/// the printed set read back as a file gives the same parameters.
#[test]
fn the_recall_profile_loads_everywhere_params_do() {
    let dir = tempfile::tempdir().unwrap();
    let defaults = text(&pmon(&["params"]));
    let o = pmon(&["params", "--params", "profile:recall"]);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    assert!(out.contains("The profile `recall`"), "{out}");
    for (key, on, off) in [
        ("returns_beyond_cells", "returns_beyond_cells = 1", "returns_beyond_cells = 0"),
        ("face_in_front", "face_in_front = true", "face_in_front = false"),
        ("seen_over", "seen_over = true", "seen_over = false"),
    ] {
        assert!(out.contains(on) && defaults.contains(off), "{key}: {out}");
    }
    let p = dir.path().join("recall.toml");
    std::fs::write(&p, &o.stdout).unwrap();
    let again = pmon(&["params", "--params", p.to_str().unwrap()]);
    assert!(text(&again).contains("returns_beyond_cells = 1"), "{}", text(&again));
    let bad = pmon(&["params", "--params", "profile:fastest"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("unknown parameter profile `fastest`"), "{}", text(&bad));
    assert!(text(&bad).contains("profile:recall"), "{}", text(&bad));
    let walk = dir.path().join("walk");
    write_walk(&walk, 4, Some(2));
    let o = pmon(&["check", walk.to_str().unwrap(), "--params", "profile:recall"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("position error"), "{}", text(&o));
    // `pmon bench --params` measures what a profile costs, and says so in its notes.
    let quick =
        ["bench", "--only", "objects-30/no-cloud", "--no-real-data", "--iterations", "2", "--no-machine-reference"];
    let o = pmon(&[&quick[..], &["--params", "profile:recall"]].concat());
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains(
            "parameters: the defaults with --params profile:recall over them: face_in_front = true, \
             returns_beyond_cells = 1, seen_over = true; each case keeps its own cell_size_m and grid_size_m"
        ),
        "{}",
        text(&o)
    );
    let bad = pmon(&[&quick[..], &["--params", "profile:fastest"]].concat());
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("unknown parameter profile `fastest`"), "{}", text(&bad));
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
    assert!(out.contains("its evidence lies outside its region"), "the alarm says why: {out}");
    assert!(out.contains("position errors by the test that found them"), "{out}");
    // The jump also breaks the motion history: frame 3 is a position error (sensor first) and the
    // plausibility check sees the 1.5 m jump.
    let o = pmon(&["check", "--format", "jsonl", shifted.to_str().unwrap()]);
    let mut lines: Vec<serde_json::Value> =
        String::from_utf8_lossy(&o.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    // The last record holds the totals.
    let totals = lines.pop().unwrap();
    assert_eq!(totals["record"], "totals");
    assert_eq!(totals["frames"], 6);
    assert_eq!(totals["frames_with_alarms"], 3);
    // Every position error counted by its cause.
    let causes = totals["position_causes"].as_object().unwrap();
    let errors = lines.iter().filter(|l| l["verdict"] == "position_error").count() as u64;
    assert!(errors > 0);
    assert_eq!(causes.values().map(|v| v.as_u64().unwrap()).sum::<u64>(), errors, "{totals}");
    assert_eq!(lines.len(), 6);
    assert_eq!(lines[2]["verdict"], "consistent");
    assert_eq!(lines[3]["verdict"], "position_error");
    // Why: the box jumped 1.5 m away from its evidence, which the cells show outside its region.
    assert_eq!(lines[3]["position_cause"], "displaced_evidence", "{}", lines[3]);
    assert_eq!(lines[2]["position_cause"], serde_json::Value::Null, "only a position error has a cause");
    assert!(lines[3]["motion"].as_str().unwrap().contains("position"), "{}", lines[3]);
    assert_eq!(lines[0]["reason"], serde_json::Value::Null);
    assert_eq!(lines[0]["motion"], "not_monitored(first_frame_of_track)");
}

/// Returns filling the box `x0..x1` x `y0..y1` (ego frame) every 0.1 m at the heights `zs` over the ground, in
/// the frame of a sensor 1.8 m up.
fn block(x0: f32, x1: f32, y0: f32, y1: f32, zs: &[f32]) -> Vec<[f32; 3]> {
    let steps = |a: f32, b: f32| ((b - a) / 0.1).round() as usize;
    let mut out = Vec::new();
    for i in 0..steps(x0, x1) {
        for j in 0..steps(y0, y1) {
            for &z in zs {
                out.push([x0 + 0.05 + 0.1 * i as f32, y0 + 0.05 + 0.1 * j as f32, z - 1.8]);
            }
        }
    }
    out
}

/// Issue #10 follow-up: what the region of interest excused is reported with its reason, not left out. A street
/// whose road is `y < 5` (the ROI), one frame, no objects: a post 3 m behind the kerb (no return in the ROI), a tree
/// behind the kerb whose low branches graze the road under a canopy 5-7 m up (the grazing rule), and, in the
/// second recording only, an unlisted pedestrian in the road (a missed object). The JSON Lines carry the missed
/// object first, then one `outside_roi` record per excused cluster with its reason; the exit code is that of the
/// alarms (0 without the pedestrian); the text summary counts both reasons.
#[test]
fn clusters_outside_the_roi_are_reported_with_their_reason_and_raise_no_alarm() {
    let dir = tempfile::tempdir().unwrap();
    let band = [0.5, 1.0, 1.5, 2.0];
    let write = |name: &str, pedestrian: bool| {
        let mut points = Vec::new();
        for r in 2..45 {
            for a in 0..720 {
                let a = (a as f32 * 0.5).to_radians();
                points.push([r as f32 * a.cos(), r as f32 * a.sin(), -1.8]);
            }
        }
        points.extend(block(25.0, 25.4, 8.0, 8.4, &band)); // the post
        points.extend(block(15.0, 15.4, 5.1, 6.0, &band)); // the trunk, 180 band returns
        points.extend(block(15.0, 15.5, 4.8, 4.9, &[2.0, 2.4])); // 10 returns of low branches over the road
        points.extend(block(14.0, 16.5, 4.0, 7.0, &[5.0, 6.0, 7.0])); // the canopy
        if pedestrian {
            points.extend(block(10.0, 10.5, 2.5, 3.0, &band));
        }
        let mut f = RecordedFrame::empty(0, 0.0, Pose2::default());
        f.cloud =
            Some(OwnedCloud { points_in_sensor: points, ego_from_sensor: Isometry3::from_translation(0.0, 0.0, 1.8) });
        f.roi_in_ego = vec![vec![[0.0, -20.0], [40.0, -20.0], [40.0, 5.0], [0.0, 5.0]]];
        let path = dir.path().join(name);
        write_recording(&path, RecordingMeta::new(name, "cli test"), &[f]).expect("write");
        path
    };
    for (pedestrian, code) in [(true, 1), (false, 0)] {
        let rec = write(if pedestrian { "with" } else { "without" }, pedestrian);
        let o = pmon(&["check", "--format", "jsonl", rec.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(code), "{}", text(&o));
        let mut lines: Vec<serde_json::Value> =
            String::from_utf8_lossy(&o.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let totals = lines.pop().unwrap();
        assert_eq!(totals["record"], "totals");
        assert_eq!(totals["missed_objects"], u64::from(pedestrian));
        // The missed object first, then the two excused clusters (in the cluster stage's order), each found by
        // where it lies with the reason the map gave it.
        let verdicts: Vec<&str> = lines.iter().map(|l| l["verdict"].as_str().unwrap()).collect();
        let mut want = vec!["outside_roi"; 2];
        if pedestrian {
            want.insert(0, "missed_object");
            assert!(lines[0].get("reason").is_none(), "{}", lines[0]);
        }
        assert_eq!(verdicts, want, "{lines:?}");
        let reason_at = |x: f64, y: f64| -> &str {
            let near = |l: &&serde_json::Value| {
                let c = [l["centroid_m"][0].as_f64().unwrap(), l["centroid_m"][1].as_f64().unwrap()];
                (c[0] - x).abs() < 0.8 && (c[1] - y).abs() < 0.8
            };
            let l = lines.iter().filter(|l| l["verdict"] == "outside_roi").find(near).expect("a record there");
            assert!(l["cells"].as_u64().unwrap() >= 1 && l["bounds_m"].as_array().unwrap().len() == 4, "{l}");
            assert!(l.get("id").is_none() && l["frame"] == 0, "{l}");
            l["reason"].as_str().unwrap()
        };
        assert_eq!(reason_at(15.2, 5.3), "grazing", "{lines:?}");
        assert_eq!(reason_at(25.2, 8.2), "no_return_in_roi", "{lines:?}");
        let o = pmon(&["check", rec.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(code), "{}", text(&o));
        let want = format!(
            "{} missed-object alarms; 2 clusters outside the region of interest (not alarms): 1 without a return in it, 1 grazing",
            u8::from(pedestrian)
        );
        assert!(text(&o).contains(&want), "{}", text(&o));
    }
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
        let mut args =
            vec!["reproduce", "--smoke", "--seed", "3", "--data", "/nonexistent", "--out", out.to_str().unwrap()];
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
            "permanent_position_paper.png",
            "permanent_position_one_tracks.csv",
            "latency.png",
            "dv_theory_transient.png",
        ] {
            let path = out.join(f);
            assert!(std::fs::metadata(&path).map(|m| m.len() > 0).unwrap_or(false), "{} missing", path.display());
        }
        let html = std::fs::read_to_string(out.join("index.html")).unwrap();
        assert!(html.contains("Paper vs pmon"));
        // The parameters say where they came from: the defaults, or the --params file over them.
        let source = match params {
            Some(_) => format!("The defaults with --params {} over them", p.display()),
            None => "The defaults: the paper".to_string(),
        };
        assert!(html.contains(&source), "{source}");
        let results: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
        // Issue 15: the Markdown table (what the README's results table is pasted from) has every claim of
        // results.json as a row, missed ones included, with the same verdict.
        let md = std::fs::read_to_string(out.join("paper-vs-pmon.md")).unwrap();
        let rows: Vec<&str> = md.lines().skip(2).collect();
        let claims = results["claims"].as_array().unwrap();
        assert_eq!(rows.len(), claims.len(), "{md}");
        for (row, c) in rows.iter().zip(claims) {
            let want = match c["met"].as_bool() {
                Some(true) => "| met |",
                Some(false) => "| missed |",
                None => "| informational |",
            };
            assert!(row.ends_with(want), "{row} vs {c}");
        }
        // The run used no real data folder beside the temp dir: that is said in the table, not dropped.
        assert!(md.contains("NOT RUN") || claims.len() > 12, "{md}");
        // The report folder carries pmon's marker: a second run into it is allowed.
        assert!(out.join(".pmon-output").exists());
        results
    };
    let recall_at = |r: &serde_json::Value, curve: &str, x: f64| -> f64 {
        let figs = r["figures"].as_array().unwrap();
        let fig = figs.iter().find(|f| f["spec"]["id"] == "permanent_position").unwrap();
        let c = fig["curves"].as_array().unwrap().iter().find(|c| c["label"] == curve).unwrap();
        let p = c["points"].as_array().unwrap().iter().find(|p| (p["x"].as_f64().unwrap() - x).abs() < 1e-9).unwrap();
        p["rate"]["value"].as_f64().unwrap()
    };
    let normal = run("normal", None);
    // Issue 15: the README's results table is the generated one. `--readme` writes it between the markers of
    // a copy of the README, leaving the rest untouched ...
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md")).unwrap();
    let copy = dir.path().join("README.md");
    std::fs::write(&copy, &readme).unwrap();
    let out = dir.path().join("readme-run");
    let o = pmon(&[
        "reproduce",
        "--smoke",
        "--seed",
        "3",
        "--data",
        "/nonexistent",
        "--out",
        out.to_str().unwrap(),
        "--readme",
        copy.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let md = std::fs::read_to_string(out.join("paper-vs-pmon.md")).unwrap();
    let updated = std::fs::read_to_string(&copy).unwrap();
    let block = |t: &str| -> String {
        let b = t.find("<!-- paper-vs-pmon:begin").expect("README has no results block");
        let e = t.find("<!-- paper-vs-pmon:end -->").expect("README has no end marker");
        t[b..e].to_string()
    };
    assert!(block(&updated).contains(&md), "{}", block(&updated));
    assert!(block(&updated).contains("Seed 3, smoke run"), "{}", block(&updated));
    let outside = |t: &str| t.replace(&block(t), "");
    assert_eq!(outside(&updated), outside(&readme));
    // ... and the committed README's table has a row for every claim the simulated experiments make, with a
    // verdict (the numbers are those of the full run it was generated from; the real-data rows need the data).
    let committed = block(&readme);
    for c in normal["claims"].as_array().unwrap() {
        let paper = c["paper"].as_str().unwrap().replace('|', "\\|");
        if paper.contains("NOT RUN") || c["pmon"].as_str().unwrap().contains("NOT RUN") {
            continue;
        }
        let row = committed.lines().find(|l| l.starts_with(&format!("| {paper} |")));
        let row = row.unwrap_or_else(|| panic!("README's results table has no row for claim `{paper}`"));
        assert!(row.ends_with("| met |") || row.ends_with("| missed |") || row.ends_with("| informational |"), "{row}");
    }
    // A monitor whose safety margin swallows every displacement.
    let weak = run("weak", Some("safety_margin_m = 3.0\n"));
    let r_normal = recall_at(&normal, "sensor recall, 0.5 m cells", 2.0);
    let r_weak = recall_at(&weak, "sensor recall, 0.5 m cells", 2.0);
    assert!(r_normal > r_weak + 0.2, "normal {r_normal} vs weakened {r_weak}");
    let claims = weak["claims"].as_array().unwrap();
    let permanent: Vec<_> =
        claims.iter().filter(|c| c["paper"].as_str().unwrap().starts_with("Permanent position")).collect();
    // Paper conditions, hard conditions and hard conditions one faulty object at a time, 0.5 m and 0.2 m cells each.
    assert_eq!(permanent.len(), 6);
    assert!(permanent.iter().all(|c| c["met"] == serde_json::Value::Bool(false)), "{permanent:?}");
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn datasets_convert_to_recordings_that_check_the_same() {
    let Some(data) = data_dir() else { return };
    let dir = tempfile::tempdir().unwrap();
    let verdicts = |o: &Output| -> Vec<String> {
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
            .filter(|v| v["record"].is_null())
            .map(|v| format!("{} {} {}", v["id"], v["verdict"], v["sensor"]))
            .collect()
    };
    // Issue 10/11 (c): `convert` keeps what `check` applies for the dataset (ground height, ego footprint) in
    // the recording's params.toml: checking the recording without any --params gives the dataset's verdicts.
    // KITTI and Argoverse 2 have their ground well below the ego origin, so a lost ground height shows.
    let mut boxes = Vec::new();
    for (i, spec) in [
        format!("nuscenes:{}", data.join("nuscenes").display()),
        format!("kitti:{}", data.join("kitti/object/training").display()),
        format!("av2:{}", data.join("av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede").display()),
    ]
    .iter()
    .enumerate()
    {
        let direct = pmon(&["check", "--format", "jsonl", spec]);
        assert_ne!(direct.status.code(), Some(2), "{}", text(&direct));
        let rec = dir.path().join(format!("rec{i}"));
        let o = pmon(&["convert", spec, "--out", rec.to_str().unwrap()]);
        assert!(o.status.success(), "{}", text(&o));
        let converted = pmon(&["check", "--format", "jsonl", rec.to_str().unwrap()]);
        assert_ne!(converted.status.code(), Some(2), "{}", text(&converted));
        assert_eq!(verdicts(&direct), verdicts(&converted), "{spec}");
        // A partial --params file keeps the dataset's settings under it (issue 10/11 (a)).
        let p = dir.path().join("p.toml");
        std::fs::write(&p, "tau_tp = 0.8\n").unwrap();
        let partial = pmon(&["check", "--format", "jsonl", "--params", p.to_str().unwrap(), spec]);
        assert_eq!(verdicts(&direct), verdicts(&partial), "{spec}");
        boxes.push(
            verdicts(&direct).iter().filter(|v| !v.contains("missed_object") && !v.contains("outside_roi")).count(),
        );
    }
    assert_eq!(boxes[0], 69);
    let bad = pmon(&["check", "kitti:/nonexistent/kitti"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("nonexistent"), "{}", text(&bad));
}

/// The AV2 vector map reaches `check` and `convert` (the recording carries the ROI and checks the same); without
/// a map the summary says so; `--roi` values are validated.
#[test]
fn regions_of_interest_reach_check_and_convert() {
    let bad = pmon(&["check", "--roi", "corridor:-3", "kitti:/nonexistent/k"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(text(&bad).contains("corridor width"), "{}", text(&bad));
    let bad = pmon(&["check", "--roi", "lanes", "kitti:/nonexistent/k"]);
    assert!(text(&bad).contains("corridor:<width_m>"), "{}", text(&bad));
    let Some(data) = data_dir() else { return };
    let log = data.join("av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede");
    if !log.exists() {
        eprintln!("SKIPPED: no Argoverse 2 log at {}", log.display());
        return;
    }
    let spec = format!("av2:{}", log.display());
    let summary = |args: &[&str]| -> (String, f64) {
        let o = pmon(args);
        assert_ne!(o.status.code(), Some(2), "{}", text(&o));
        let out = String::from_utf8_lossy(&o.stdout).to_string();
        let per_frame = out
            .lines()
            .find_map(|l| l.trim().strip_prefix("missed-object alarms per frame with a LiDAR sweep: "))
            .and_then(|r| r.split(' ').next())
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or_else(|| panic!("no per-frame count in {out}"));
        (out, per_frame)
    };
    let (with_map, mapped) = summary(&["check", &spec]);
    assert!(with_map.contains("region of interest: the log's vector map"), "{with_map}");
    let (without, whole) = summary(&["check", "--roi", "none", &spec]);
    assert!(without.contains("region of interest: none"), "{without}");
    // Measured: 15 vs 153.5 per sweep; the map must remove most of the scenery.
    assert!(mapped * 4.0 < whole, "with the map {mapped}, without {whole}");
    // The converted recording carries the ROI: checked with the same ground and footprint, the same count.
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("av2");
    let o = pmon(&["convert", &spec, "--out", rec.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("region of interest: the log's vector map"), "{}", text(&o));
    let p = dir.path().join("p.toml");
    std::fs::write(&p, "ground_z_m = -0.3234\nego_footprint_m = [-1.2, -1.2, 4.2, 1.2]\n").unwrap();
    let (_, converted) = summary(&["check", "--params", p.to_str().unwrap(), rec.to_str().unwrap()]);
    assert!((converted - mapped).abs() <= 1.0, "converted {converted}, direct {mapped}");
    // KITTI has no map: its labels cover camera 2's image, and the summary says that this field of view is the
    // ROI and names the other modes. Measured: 48.0 missed-object alarms per sweep in it, 104.3 in the whole grid.
    let kitti = format!("kitti:{}", data.join("kitti/object/training").display());
    let (out, in_view) = summary(&["check", &kitti]);
    assert!(
        out.contains("labelled field of view") && out.contains("--roi none") && out.contains("--roi corridor:"),
        "{out}"
    );
    let (out, whole) = summary(&["check", "--roi", "none", &kitti]);
    assert!(out.contains("none (--roi none)"), "{out}");
    assert!(in_view * 1.5 < whole, "in the field of view {in_view}, whole grid {whole}");
}

/// `pmon calibrate`: reads a recording, writes a parameter file that `check` and `params` accept, refuses to
/// replace a file it did not write, and replaces its own.
#[test]
fn calibrate_writes_params_check_accepts_and_never_overwrites_foreign_files() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("walk");
    write_walk(&rec, 30, None);
    let out = dir.path().join("tracker.toml");
    let o = pmon(&["calibrate", rec.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(written.contains("plausibility_mode = \"calibrated\""), "{written}");
    assert!(written.contains("[per_class_noise.pedestrian]"), "{written}");
    assert!(written.contains("Expected false alarms"), "{written}");
    let o = pmon(&["params", "--params", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = pmon(&["check", rec.to_str().unwrap(), "--params", out.to_str().unwrap()]);
    assert!(o.status.code() == Some(0) || o.status.code() == Some(1), "{}", text(&o));
    // Its own file is replaced; someone else's is not.
    let o = pmon(&["calibrate", rec.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let foreign = dir.path().join("mine.toml");
    std::fs::write(&foreign, "tau_tp = 0.9\n").unwrap();
    let o = pmon(&["calibrate", rec.to_str().unwrap(), "--out", foreign.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("was not written by pmon"), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&foreign).unwrap(), "tau_tp = 0.9\n");
}
