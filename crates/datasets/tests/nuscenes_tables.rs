//! The native nuScenes v1.0 table reader, on a small table set written into a temporary directory around the
//! real LIDAR_TOP sweep: two samples of one scene (the second 0.5 s later with every moving box displaced by its
//! velocity), camera sample_data to be ignored, and broken variants that must be rejected.

mod common;

use std::f64::consts::PI;
use std::fs;
use std::path::Path;

use common::data;
use pmon_datasets::{open, points_in_box, DatasetError, SpeedSource};
use serde_json::{json, Value};

type M3 = [[f64; 3]; 3];

fn mul(a: &M3, b: &M3) -> M3 {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

fn apply(m: &M3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

fn rot_z(a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// Quaternion (w, x, y, z) of a rotation matrix (re-orthonormalised through the quaternion's normalisation).
fn quat(m: &M3) -> [f64; 4] {
    let tr = m[0][0] + m[1][1] + m[2][2];
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s]
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        [(m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s]
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        [(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s]
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        [(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s]
    };
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    q.map(|v| v / n)
}

fn block(m: &Value) -> (M3, [f64; 3]) {
    let g = |i: usize, j: usize| m[i][j].as_f64().unwrap();
    (
        [[g(0, 0), g(0, 1), g(0, 2)], [g(1, 0), g(1, 1), g(1, 2)], [g(2, 0), g(2, 1), g(2, 2)]],
        [g(0, 3), g(1, 3), g(2, 3)],
    )
}

fn v1_category(label: &str) -> &'static str {
    match label {
        "car" => "vehicle.car",
        "truck" => "vehicle.truck",
        "bus" => "vehicle.bus.rigid",
        "trailer" => "vehicle.trailer",
        "construction_vehicle" => "vehicle.construction",
        "bicycle" => "vehicle.bicycle",
        "motorcycle" => "vehicle.motorcycle",
        "pedestrian" => "human.pedestrian.adult",
        "traffic_cone" => "movable_object.trafficcone",
        "barrier" => "movable_object.barrier",
        _ => "ignored", // the converted file's `ignored(-1: ...)` label: unknown in both readers
    }
}

const DT_S: f64 = 0.5;

/// Writes the tables into `root/v1.0-mini` and the sweep into `root/samples/LIDAR_TOP/`.
fn write_tables(src: &Path, root: &Path) -> Value {
    let text = fs::read_to_string(src.join("sample_annotations.json")).unwrap().replace("NaN", "null");
    let conv: Value = serde_json::from_str(&text).unwrap();
    let lidar_file = conv["lidar_file"].as_str().unwrap();
    fs::create_dir_all(root.join("samples/LIDAR_TOP")).unwrap();
    fs::copy(src.join(lidar_file), root.join("samples/LIDAR_TOP").join(lidar_file)).unwrap();
    let (r_le, t_le) = block(&conv["lidar2ego_4x4"]);
    let (r_eg, t_eg) = block(&conv["ego2global_4x4"]);
    let t0 = (conv["timestamp_s"].as_f64().unwrap() * 1e6).round() as i64;
    let t1 = t0 + (DT_S * 1e6) as i64;

    let mut anns = Vec::new();
    let mut instances = Vec::new();
    let mut categories: Vec<Value> = Vec::new();
    for (i, inst) in conv["instances"].as_array().unwrap().iter().enumerate() {
        let b: Vec<f64> = inst["bbox_3d"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        // centre and heading in the ego frame, then global; boxes upright in the ego frame
        let c_ego = apply(&r_le, [b[0], b[1], b[2]]);
        let c_ego = [c_ego[0] + t_le[0], c_ego[1] + t_le[1], c_ego[2] + t_le[2]];
        let d = apply(&r_le, [b[6].cos(), b[6].sin(), 0.0]);
        let heading_ego = d[1].atan2(d[0]);
        let c_glob = apply(&r_eg, c_ego);
        let c_glob = [c_glob[0] + t_eg[0], c_glob[1] + t_eg[1], c_glob[2] + t_eg[2]];
        let q = quat(&mul(&r_eg, &rot_z(heading_ego)));
        let cat = v1_category(inst["label_name"].as_str().unwrap());
        if !categories.iter().any(|c| c["name"] == cat) {
            categories.push(json!({"token": format!("cat-{cat}"), "name": cat, "description": ""}));
        }
        let inst_tok = format!("inst{i:03}");
        let vel = &inst["velocity"];
        let moving = vel[0].is_f64() && vel[1].is_f64();
        instances.push(json!({"token": inst_tok, "category_token": format!("cat-{cat}"),
            "nbr_annotations": if moving { 2 } else { 1 }, "first_annotation_token": format!("a0-{i}"),
            "last_annotation_token": format!("a{}-{i}", usize::from(moving))}));
        let size = [b[4], b[3], b[5]]; // w, l, h
        anns.push(json!({"token": format!("a0-{i}"), "sample_token": "s0", "instance_token": inst_tok,
            "visibility_token": "4", "attribute_tokens": [], "translation": c_glob, "size": size, "rotation": q,
            "prev": "", "next": if moving { format!("a1-{i}") } else { String::new() },
            "num_lidar_pts": inst["num_lidar_pts"], "num_radar_pts": 0}));
        if moving {
            let v_lidar = [vel[0].as_f64().unwrap(), vel[1].as_f64().unwrap(), 0.0];
            let v_glob = apply(&r_eg, apply(&r_le, v_lidar));
            let c1 = [c_glob[0] + v_glob[0] * DT_S, c_glob[1] + v_glob[1] * DT_S, c_glob[2]];
            anns.push(json!({"token": format!("a1-{i}"), "sample_token": "s1", "instance_token": inst_tok,
                "visibility_token": "4", "attribute_tokens": [], "translation": c1, "size": size, "rotation": q,
                "prev": format!("a0-{i}"), "next": "", "num_lidar_pts": 0, "num_radar_pts": 0}));
        }
    }
    let q_eg = quat(&r_eg);
    let q_le = quat(&r_le);
    let filename = format!("samples/LIDAR_TOP/{lidar_file}");
    let tables = [
        (
            "scene.json",
            json!([{"token": "sc0", "name": "scene-0001", "log_token": "l0", "nbr_samples": 2,
            "first_sample_token": "s0", "last_sample_token": "s1", "description": "test"}]),
        ),
        (
            "sample.json",
            json!([
            {"token": "s1", "timestamp": t1, "prev": "s0", "next": "", "scene_token": "sc0"},
            {"token": "s0", "timestamp": t0, "prev": "", "next": "s1", "scene_token": "sc0"}]),
        ),
        (
            "sensor.json",
            json!([{"token": "sens-lidar", "channel": "LIDAR_TOP", "modality": "lidar"},
            {"token": "sens-cam", "channel": "CAM_FRONT", "modality": "camera"}]),
        ),
        (
            "calibrated_sensor.json",
            json!([
            {"token": "cs-lidar", "sensor_token": "sens-lidar", "translation": t_le, "rotation": q_le,
             "camera_intrinsic": []},
            {"token": "cs-cam", "sensor_token": "sens-cam", "translation": [1.7, 0.0, 1.5],
             "rotation": [0.5, -0.5, 0.5, -0.5], "camera_intrinsic": [[1266.4, 0.0, 816.3], [0.0, 1266.4, 491.5], [0.0, 0.0, 1.0]]}]),
        ),
        (
            "ego_pose.json",
            json!([
            {"token": "ep0", "timestamp": t0, "rotation": q_eg, "translation": t_eg},
            {"token": "ep1", "timestamp": t1, "rotation": q_eg, "translation": t_eg},
            {"token": "ep-cam", "timestamp": t0, "rotation": q_eg, "translation": t_eg}]),
        ),
        (
            "sample_data.json",
            json!([
            {"token": "sd-cam", "sample_token": "s0", "ego_pose_token": "ep-cam", "calibrated_sensor_token": "cs-cam",
             "timestamp": t0, "fileformat": "jpg", "is_key_frame": true, "height": 900, "width": 1600,
             "filename": "samples/CAM_FRONT/x.jpg", "prev": "", "next": ""},
            {"token": "sd0", "sample_token": "s0", "ego_pose_token": "ep0", "calibrated_sensor_token": "cs-lidar",
             "timestamp": t0, "fileformat": "pcd", "is_key_frame": true, "height": 0, "width": 0,
             "filename": filename, "prev": "", "next": "sd1"},
            {"token": "sd1", "sample_token": "s1", "ego_pose_token": "ep1", "calibrated_sensor_token": "cs-lidar",
             "timestamp": t1, "fileformat": "pcd", "is_key_frame": true, "height": 0, "width": 0,
             "filename": filename, "prev": "sd0", "next": ""}]),
        ),
        ("sample_annotation.json", Value::Array(anns)),
        ("instance.json", Value::Array(instances)),
        ("category.json", Value::Array(categories)),
    ];
    let dir = root.join("v1.0-mini");
    fs::create_dir_all(&dir).unwrap();
    for (name, v) in tables {
        fs::write(dir.join(name), serde_json::to_string_pretty(&v).unwrap()).unwrap();
    }
    conv
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn v1_tables_around_the_real_sweep() {
    let Some(src) = data("nuscenes") else { return };
    let tmp = tempfile::tempdir().unwrap();
    let conv = write_tables(&src, tmp.path());
    let reference = open(&format!("nuscenes:{}", src.display())).unwrap();
    let ds = open(&format!("nuscenes-v1:{}", tmp.path().display())).unwrap();
    assert_eq!(ds.info.speed_source, SpeedSource::FiniteDifferenceWorld);
    assert_eq!(ds.frames.len(), 2);
    assert!((ds.frames[1].frame.timestamp_s - ds.frames[0].frame.timestamp_s - DT_S).abs() < 1e-6);
    let (f0, r0) = (&ds.frames[0], &reference.frames[0]);
    assert_eq!(f0.frame.objects.len(), 69);
    assert_eq!(f0.frame.cloud.as_ref().unwrap().points_in_sensor.len(), 34_688);
    let pose = f0.frame.world_from_ego;
    assert!((pose.x_m - 411.3039).abs() < 1e-3 && (pose.y_m - 1180.8904).abs() < 1e-3);
    assert!((pose.yaw_rad - r0.frame.world_from_ego.yaw_rad).abs() < 1e-6);
    let pts = f0.points_in_ego();
    let ref_pts = r0.points_in_ego();
    // reader sorts by instance token = input order here
    let mut exact = 0;
    for (k, (o, want)) in f0.frame.objects.iter().zip(&r0.frame.objects).enumerate() {
        assert!((o.x_m - want.x_m).abs() < 1e-3 && (o.y_m - want.y_m).abs() < 1e-3, "{o:?} vs {want:?}");
        let dh = (f64::from(o.heading_rad - want.heading_rad)).rem_euclid(2.0 * PI);
        assert!(dh.min(2.0 * PI - dh) < 1e-4, "{o:?} vs {want:?}");
        assert_eq!((o.class, o.length_m, o.width_m), (want.class, want.length_m, want.width_m));
        // finite-difference speed over 0.5 s reproduces the velocity's horizontal norm
        assert!(
            (o.speed_mps - want.speed_mps).abs() < 1e-3 + 1e-3 * want.speed_mps,
            "{k}: {} vs {}",
            o.speed_mps,
            want.speed_mps
        );
        let (e, we) = (&f0.extras[k], &r0.extras[k]);
        assert_eq!(e.num_points, we.num_points);
        assert!((e.z_center_m.unwrap() - we.z_center_m.unwrap()).abs() < 1e-3);
        let n = points_in_box(&pts, &f0.box_in_ego(k).unwrap());
        assert_eq!(n, points_in_box(&ref_pts, &r0.box_in_ego(k).unwrap()));
        exact += usize::from(Some(n) == e.num_points);
    }
    eprintln!("nuscenes v1 tables: 2 frames, 69 + {} boxes, num_lidar_pts exact {exact}/69", ds.frames[1].extras.len());
    let moving = conv["instances"].as_array().unwrap().iter().filter(|i| i["velocity"][0].is_f64()).count();
    assert_eq!(ds.frames[1].frame.objects.len(), moving);
    // same scene by name; an unknown scene is an error naming scene.json
    let by_scene = open(&format!("nuscenes-v1:{}#scene-0001", tmp.path().display())).unwrap();
    assert_eq!(by_scene.frames.len(), 2);
    let err = open(&format!("nuscenes-v1:{}#scene-9999", tmp.path().display())).unwrap_err().to_string();
    assert!(err.contains("scene.json") && err.contains("scene-9999"), "{err}");
    // the table folder itself is accepted too
    assert_eq!(open(&format!("nuscenes-v1:{}/v1.0-mini", tmp.path().display())).unwrap().frames.len(), 2);
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn v1_tables_reject_dangling_tokens_and_bad_quaternions() {
    let Some(src) = data("nuscenes") else { return };
    let tmp = tempfile::tempdir().unwrap();
    write_tables(&src, tmp.path());
    let dir = tmp.path().join("v1.0-mini");
    let spec = format!("nuscenes-v1:{}", tmp.path().display());

    let inst = fs::read_to_string(dir.join("instance.json")).unwrap();
    fs::write(dir.join("instance.json"), inst.replace("\"inst005\"", "\"other\"")).unwrap();
    let err = open(&spec).unwrap_err();
    assert!(matches!(err, DatasetError::Malformed { .. }));
    assert!(err.to_string().contains("inst005") && err.to_string().contains("sample_annotation.json"), "{err}");
    fs::write(dir.join("instance.json"), &inst).unwrap();

    let ep = fs::read_to_string(dir.join("ego_pose.json")).unwrap();
    let v: Value = serde_json::from_str(&ep).unwrap();
    let mut v2 = v.clone();
    v2[0]["rotation"] = json!([2.0, 0.0, 0.0, 0.0]);
    fs::write(dir.join("ego_pose.json"), v2.to_string()).unwrap();
    let err = open(&spec).unwrap_err().to_string();
    assert!(err.contains("ego_pose.json") && err.contains("quaternion"), "{err}");
    fs::write(dir.join("ego_pose.json"), &ep).unwrap();

    fs::remove_file(dir.join("category.json")).unwrap();
    let err = open(&spec).unwrap_err().to_string();
    assert!(err.contains("category.json"), "{err}");
}

#[test]
#[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
fn v1_deferred_sweeps_are_the_sweeps_of_open() {
    let Some(src) = data("nuscenes") else { return };
    let tmp = tempfile::tempdir().unwrap();
    write_tables(&src, tmp.path());
    common::assert_deferred_same(&format!("nuscenes-v1:{}#scene-0001", tmp.path().display()));
}
