//! nuScenes v1.0 tables cut into scene slices (`nuscenes_slice`): reading a scene from its slice gives the
//! dataset that reading it from the table folder gives, bit for bit, on generated tables of several scenes
//! (cameras and non-keyframe rows to skip, an instance annotated in two scenes, numbers with many digits); bad
//! rows are reported naming the file and line, or by their own scene only.

mod common;

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use pmon_datasets::ground::GroundMode;
use pmon_datasets::nuscenes_slice::slice_scenes;
use pmon_datasets::{open_deferred, open_deferred_with_slice, open_with, open_with_slice, ReadOptions};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{json, Value};

const SCENES: usize = 3;
const SAMPLES: usize = 4;

/// A unit quaternion of a yaw, with the digits a float prints (many of them).
fn yaw_quat(yaw: f64) -> [f64; 4] {
    [(0.5 * yaw).cos(), 0.0, 0.0, (0.5 * yaw).sin()]
}

/// Writes generated v1.0 tables into `root/v1.0-test` and a small sweep per LIDAR_TOP keyframe into
/// `root/samples/LIDAR_TOP/`; returns the scene names.
fn write_tables(root: &Path, seed: u64) -> Vec<String> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dir = root.join("v1.0-test");
    fs::create_dir_all(&dir).unwrap();
    fs::create_dir_all(root.join("samples/LIDAR_TOP")).unwrap();
    let mut scenes = Vec::new();
    let mut samples = Vec::new();
    let mut sample_data = Vec::new();
    let mut ego = Vec::new();
    let mut anns = Vec::new();
    let mut instances = Vec::new();
    let categories = json!([
        {"token": "cat-car", "name": "vehicle.car", "description": ""},
        {"token": "cat-ped", "name": "human.pedestrian.adult", "description": ""}]);
    let mut names = Vec::new();
    let mut t_us: i64 = 1_533_151_603_547_590;
    for sc in 0..SCENES {
        let name = format!("scene-{:04}", 10 * sc + 1);
        names.push(name.clone());
        scenes.push(json!({"token": format!("sc{sc}"), "name": name, "log_token": "l0", "nbr_samples": SAMPLES}));
        // 3 instances per scene, plus inst-shared annotated in scenes 0 and 1
        let mut scene_instances: Vec<String> = (0..3).map(|k| format!("inst-{sc}-{k}")).collect();
        if sc < 2 {
            scene_instances.push("inst-shared".into());
        }
        for s in 0..SAMPLES {
            let sample = format!("s{sc}-{s}");
            t_us += 500_000 + rng.random_range(0..1000);
            samples.push(json!({"token": sample, "timestamp": t_us, "scene_token": format!("sc{sc}"),
                "prev": "", "next": ""}));
            let (ex, ey, eyaw) = (
                rng.random_range(-500.0..500.0_f64),
                rng.random_range(-500.0..500.0_f64),
                rng.random_range(-3.0..3.0_f64),
            );
            for (channel, cal, key) in
                [("CAM_FRONT", "cs-cam", true), ("LIDAR_TOP", "cs-lidar", true), ("LIDAR_TOP", "cs-lidar", false)]
            {
                let tok = format!("sd-{sample}-{channel}-{key}");
                let ep = format!("ep-{tok}");
                ego.push(json!({"token": ep, "timestamp": t_us, "rotation": yaw_quat(eyaw),
                    "translation": [ex, ey, 0.0]}));
                let filename =
                    format!("samples/{channel}/{tok}.{}", if channel == "LIDAR_TOP" { "pcd.bin" } else { "jpg" });
                if channel == "LIDAR_TOP" && key {
                    let mut bytes = Vec::new();
                    for _ in 0..200 {
                        for v in [
                            rng.random_range(-30.0..30.0_f32),
                            rng.random_range(-30.0..30.0),
                            rng.random_range(-1.5..2.0),
                            1.0,
                            0.0,
                        ] {
                            bytes.extend_from_slice(&v.to_le_bytes());
                        }
                    }
                    fs::write(root.join(&filename), bytes).unwrap();
                }
                sample_data.push(json!({"token": tok, "sample_token": sample, "ego_pose_token": ep,
                    "calibrated_sensor_token": cal, "timestamp": t_us, "fileformat": "pcd", "is_key_frame": key,
                    "height": 0, "width": 0, "filename": filename, "prev": "", "next": ""}));
            }
            for inst in &scene_instances {
                let (x, y) = (ex + rng.random_range(-20.0..20.0), ey + rng.random_range(-20.0..20.0));
                anns.push(json!({"token": format!("a-{sample}-{inst}"), "sample_token": sample,
                    "instance_token": inst, "translation": [x, y, rng.random_range(0.5..1.5_f64)],
                    "size": [1.9, 4.5, 1.6], "rotation": yaw_quat(rng.random_range(-3.0..3.0)),
                    "num_lidar_pts": rng.random_range(0..50), "visibility_token": "4", "attribute_tokens": []}));
            }
        }
        for inst in scene_instances.iter().filter(|i| i.as_str() != "inst-shared") {
            instances.push(
                json!({"token": inst, "category_token": if inst.ends_with('0') { "cat-ped" } else { "cat-car" }}),
            );
        }
    }
    instances.push(json!({"token": "inst-shared", "category_token": "cat-car"}));
    let sensors = json!([{"token": "sens-lidar", "channel": "LIDAR_TOP", "modality": "lidar"},
        {"token": "sens-cam", "channel": "CAM_FRONT", "modality": "camera"}]);
    let cals = json!([
        {"token": "cs-lidar", "sensor_token": "sens-lidar", "translation": [0.943713, 0.0, 1.84023],
         "rotation": [0.7077955119163518, -0.006492242056004365, 0.010646214713995808, -0.7063073142877817]},
        {"token": "cs-cam", "sensor_token": "sens-cam", "translation": [1.7, 0.0, 1.5], "rotation": [0.5, -0.5, 0.5, -0.5]}]);
    for (name, v) in [
        ("scene.json", Value::Array(scenes)),
        ("sample.json", Value::Array(samples)),
        ("sample_data.json", Value::Array(sample_data)),
        ("ego_pose.json", Value::Array(ego)),
        ("sample_annotation.json", Value::Array(anns)),
        ("instance.json", Value::Array(instances)),
        ("category.json", categories),
        ("sensor.json", sensors),
        ("calibrated_sensor.json", cals),
    ] {
        fs::write(dir.join(name), serde_json::to_string_pretty(&v).unwrap()).unwrap();
    }
    names
}

fn slices(root: &Path, names: &[String]) -> Vec<(String, String)> {
    let mut out = Vec::new();
    slice_scenes(root, names, |n, text| {
        out.push((n.to_string(), text));
        Ok(())
    })
    .unwrap();
    out
}

#[test]
fn a_scene_read_from_its_slice_is_the_scene_read_from_the_tables() {
    let tmp = tempfile::tempdir().unwrap();
    let names = write_tables(tmp.path(), 7);
    let cut = slices(tmp.path(), &names);
    assert_eq!(cut.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>(), names, "one slice per scene, in order");
    for (name, text) in &cut {
        let spec = format!("nuscenes-v1:{}#{name}", tmp.path().display());
        for ground in [GroundMode::AsRecorded, GroundMode::Auto] {
            let opts = ReadOptions { ground, ..ReadOptions::default() };
            let whole = open_with(&spec, &opts).unwrap();
            let sliced = open_with_slice(&spec, &opts, text).unwrap();
            assert_eq!(whole.frames.len(), SAMPLES);
            assert!(whole.frames.iter().all(|f| f.frame.cloud.is_some()));
            assert!(sliced == whole, "{name}: the datasets differ");
            // Debug tells -0.0 from 0.0 and prints every digit
            assert_eq!(format!("{sliced:?}"), format!("{whole:?}"), "{name}");
            let (mut ds, sweeps) = open_deferred_with_slice(&spec, &opts, text).unwrap();
            let (ds2, _) = open_deferred(&spec, &opts).unwrap();
            assert_eq!(format!("{ds:?}"), format!("{ds2:?}"), "{name}: deferred");
            for (i, f) in ds.frames.iter_mut().enumerate() {
                f.frame.cloud = sweeps.cloud(i).unwrap();
            }
            assert!(ds.frames == whole.frames, "{name}: deferred sweeps");
        }
        // the slice holds its scene's rows, not the others'
        let value: Value = serde_json::from_str(text).unwrap();
        let samples = value["sample.json"].as_array().unwrap();
        let own = samples
            .iter()
            .filter(|s| s["scene_token"] == format!("sc{}", names.iter().position(|n| n == name).unwrap()))
            .count();
        assert_eq!(own, SAMPLES, "{name}");
        let sd = value["sample_data.json"].as_array().unwrap();
        assert_eq!(sd.len(), SAMPLES, "{name}: the LIDAR_TOP keyframes only");
        assert_eq!(value["ego_pose.json"].as_array().unwrap().len(), SAMPLES, "{name}");
        assert_eq!(value["calibrated_sensor.json"].as_array().unwrap().len(), 1, "{name}");
    }
    // the shared instance brings the other scene's annotations (and samples) along: its speeds see them
    let first: Value = serde_json::from_str(&cut[0].1).unwrap();
    let anns = first["sample_annotation.json"].as_array().unwrap();
    assert_eq!(anns.len(), SAMPLES * 4 + SAMPLES, "scene 0: its 4 instances and the shared one's other annotations");
    assert_eq!(first["sample.json"].as_array().unwrap().len(), 2 * SAMPLES);
    let third: Value = serde_json::from_str(&cut[2].1).unwrap();
    assert_eq!(third["sample_annotation.json"].as_array().unwrap().len(), SAMPLES * 3);
    // one scene asked for: one slice, the same text
    let one = slices(tmp.path(), &names[1..2]);
    assert_eq!(one.len(), 1);
    assert_eq!(one[0], cut[1]);
}

#[test]
fn slicing_names_the_file_and_line_of_a_bad_row_and_a_bad_scene_fails_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let names = write_tables(tmp.path(), 11);
    let dir = tmp.path().join("v1.0-test");
    let sd_path = dir.join("sample_data.json");
    let sd = fs::read_to_string(&sd_path).unwrap();
    let err_of = |names: &[String]| slice_scenes(tmp.path(), names, |_, _| Ok(())).unwrap_err().to_string();

    // a timestamp that is a string, on a known line of the file
    let line = sd.lines().position(|l| l.contains("\"timestamp\"")).unwrap() + 1;
    let mut bad = String::new();
    for (i, l) in sd.lines().enumerate() {
        let l = if i + 1 == line { l.replacen(": 1", ": \"1", 1).replacen(',', "\",", 1) } else { l.to_string() };
        let _ = writeln!(bad, "{l}");
    }
    fs::write(&sd_path, bad).unwrap();
    let err = err_of(&names);
    assert!(err.contains("sample_data.json") && err.contains(&format!("line {line}:")), "{err}");
    fs::write(&sd_path, &sd).unwrap();

    // an unknown scene name
    let err = err_of(&["scene-9999".to_string()]);
    assert!(err.contains("scene.json") && err.contains("scene-9999"), "{err}");

    // an annotation on a sample no table row has
    let ann_path = dir.join("sample_annotation.json");
    let ann = fs::read_to_string(&ann_path).unwrap();
    fs::write(&ann_path, ann.replacen("\"sample_token\": \"s2-3\"", "\"sample_token\": \"nowhere\"", 1)).unwrap();
    let err = err_of(&names);
    assert!(err.contains("sample_annotation.json") && err.contains("nowhere"), "{err}");

    // a non-positive size in scene 2: its own reading fails naming the file, scene 0's does not
    let mut v: Value = serde_json::from_str(&ann).unwrap();
    let k = v.as_array().unwrap().iter().position(|a| a["sample_token"] == "s2-1").unwrap();
    v[k]["size"] = json!([1.9, 0.0, 1.6]);
    fs::write(&ann_path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    let cut = slices(tmp.path(), &names);
    let spec = |n: &str| format!("nuscenes-v1:{}#{n}", tmp.path().display());
    let opts = ReadOptions::default();
    assert!(open_with_slice(&spec(&names[0]), &opts, &cut[0].1).is_ok());
    let err = open_with_slice(&spec(&names[2]), &opts, &cut[2].1).unwrap_err().to_string();
    assert!(err.contains("sample_annotation.json") && err.contains("non-positive size"), "{err}");
    // read from the folder, the bad row fails every scene (as before slicing)
    assert!(open_with(&spec(&names[0]), &opts).is_err());

    // a slice is for a nuScenes v1.0 scene only; a slice that is not one is an error
    let err = open_with_slice(&format!("nuscenes-v1:{}", tmp.path().display()), &opts, &cut[0].1).unwrap_err();
    assert!(err.to_string().contains("one nuScenes v1.0 scene"), "{err}");
    let err = open_with_slice(&spec(&names[0]), &opts, "{\"sample.json\": []}").unwrap_err().to_string();
    assert!(err.contains("scene slice") && err.contains("sample_data.json"), "{err}");
    let err = open_with_slice(&spec(&names[0]), &opts, "[1, 2").unwrap_err().to_string();
    assert!(err.contains("scene slice"), "{err}");
}
