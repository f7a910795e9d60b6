//! Realism numbers: simulated LiDAR sweeps side by side with the real sweeps in the shared data folder.
//!
//! ```text
//! PMON_DATA_DIR=/path/to/shared/data cargo run -p pmon-scenario --release --example realism
//! ```
//!
//! Real data (read directly, native formats): KITTI object `velodyne/*.bin` (N x 4 f32) with `label_2` and `calib`
//! for the car boxes; the nuScenes keyframe `.pcd.bin` (N x 5 f32) with `sample_annotations.json`; the Argoverse 2
//! sweeps (Feather, through `pmon-datasets`) with their annotated cuboids. Without the data folder only the
//! simulated numbers are printed.
//!
//! Numbers: points per sweep; fraction of ground points (`|z - ground| < 0.2 m`, ground at -1.73 m (KITTI) and
//! -1.8 m (nuScenes) in the sensor frame, at the reader's ground height in AV2's ego frame, at minus the mount
//! height in the simulator); points on a car at about
//! 10 m (7-15 m) and about 40 m (30-50 m) from the sensor.

use std::path::{Path, PathBuf};

use pmon_monitor::ObjectClass;
use pmon_recording::read_points_f32;
use pmon_scenario::{LidarPreset, ScenarioConfig, Simulator};

fn data_dir() -> PathBuf {
    std::env::var_os("PMON_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"))
}

/// Per-source numbers.
#[derive(Default)]
struct Stats {
    sweeps: usize,
    points: Vec<usize>,
    ground_fraction: Vec<f64>,
    /// (distance to the sensor, points) of each car.
    cars: Vec<(f64, usize)>,
}

fn ground_fraction(points: &[[f32; 3]], ground_z: f32) -> f64 {
    let g = points.iter().filter(|p| (p[2] - ground_z).abs() < 0.2).count();
    g as f64 / points.len().max(1) as f64
}

/// An upright box in the sensor frame: centre, size (l, w, h), yaw.
struct SensorBox {
    c: [f64; 3],
    lwh: [f64; 3],
    yaw: f64,
}

impl SensorBox {
    fn count(&self, points: &[[f32; 3]]) -> usize {
        let (s, c) = self.yaw.sin_cos();
        points
            .iter()
            .filter(|p| {
                let (dx, dy, dz) =
                    (f64::from(p[0]) - self.c[0], f64::from(p[1]) - self.c[1], f64::from(p[2]) - self.c[2]);
                let u = c * dx + s * dy;
                let v = -s * dx + c * dy;
                u.abs() <= self.lwh[0] / 2.0 && v.abs() <= self.lwh[1] / 2.0 && dz.abs() <= self.lwh[2] / 2.0
            })
            .count()
    }
    fn range(&self) -> f64 {
        self.c[0].hypot(self.c[1])
    }
}

type Mat3 = [[f64; 3]; 3];

fn mat_inv(m: &Mat3) -> Option<Mat3> {
    let c = |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let cof = [
        [c(1, 2, 1, 2), -c(1, 2, 0, 2), c(1, 2, 0, 1)],
        [-c(0, 2, 1, 2), c(0, 2, 0, 2), -c(0, 2, 0, 1)],
        [c(0, 1, 1, 2), -c(0, 1, 0, 2), c(0, 1, 0, 1)],
    ];
    let det: f64 = (0..3).map(|j| m[0][j] * cof[0][j]).sum();
    if det.abs() < 1e-12 {
        return None;
    }
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = cof[j][i] / det;
        }
    }
    Some(inv)
}

fn parse_calib(text: &str, key: &str) -> Option<Vec<f64>> {
    text.lines().find_map(|l| {
        let rest = l.strip_prefix(key)?.strip_prefix(':')?;
        rest.split_whitespace().map(|v| v.parse().ok()).collect()
    })
}

/// KITTI object frames: points, ground, and car boxes converted from the camera frame with the calibration.
fn kitti(dir: &Path) -> Result<Stats, String> {
    let base = dir.join("kitti/object/training");
    let mut st = Stats::default();
    for i in 0..6 {
        let id = format!("{i:06}");
        let points = read_points_f32(&base.join(format!("velodyne/{id}.bin")), 4).map_err(|e| e.to_string())?;
        let calib_path = base.join(format!("calib/{id}.txt"));
        let calib = std::fs::read_to_string(&calib_path).map_err(|e| format!("{}: {e}", calib_path.display()))?;
        let r0 = parse_calib(&calib, "R0_rect").ok_or("no R0_rect")?;
        let tr = parse_calib(&calib, "Tr_velo_to_cam").ok_or("no Tr_velo_to_cam")?;
        if r0.len() != 9 || tr.len() != 12 {
            return Err(format!("{}: bad matrix sizes", calib_path.display()));
        }
        let r0m: Mat3 = [[r0[0], r0[1], r0[2]], [r0[3], r0[4], r0[5]], [r0[6], r0[7], r0[8]]];
        let trr: Mat3 = [[tr[0], tr[1], tr[2]], [tr[4], tr[5], tr[6]], [tr[8], tr[9], tr[10]]];
        let trt = [tr[3], tr[7], tr[11]];
        // rect_from_velo = R0 * (R_tr p + t_tr); velo_from_rect = R_tr^-1 (R0^-1 p_rect - t_tr).
        let r0_inv = mat_inv(&r0m).ok_or("singular R0_rect")?;
        let tr_inv = mat_inv(&trr).ok_or("singular Tr_velo_to_cam")?;
        let to_velo = |p: [f64; 3]| {
            let q: Vec<f64> = (0..3).map(|r| (0..3).map(|k| r0_inv[r][k] * p[k]).sum::<f64>() - trt[r]).collect();
            let r = |row: usize| (0..3).map(|k| tr_inv[row][k] * q[k]).sum::<f64>();
            [r(0), r(1), r(2)]
        };
        let labels_path = base.join(format!("label_2/{id}.txt"));
        let labels = std::fs::read_to_string(&labels_path).map_err(|e| format!("{}: {e}", labels_path.display()))?;
        for line in labels.lines() {
            let f: Vec<&str> = line.split_whitespace().collect();
            if f.len() < 15 || f[0] != "Car" {
                continue;
            }
            let v: Vec<f64> = f[8..15].iter().map(|s| s.parse().unwrap_or(f64::NAN)).collect();
            let (h, w, l, x, y, z, ry) = (v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
            let c = to_velo([x, y - h / 2.0, z]);
            let b = SensorBox { c, lwh: [l, w, h], yaw: -ry - std::f64::consts::FRAC_PI_2 };
            st.cars.push((b.range(), b.count(&points)));
        }
        st.ground_fraction.push(ground_fraction(&points, -1.73));
        st.points.push(points.len());
        st.sweeps += 1;
    }
    Ok(st)
}

fn nuscenes(dir: &Path) -> Result<Stats, String> {
    let base = dir.join("nuscenes");
    let ann_path = base.join("sample_annotations.json");
    let text = std::fs::read_to_string(&ann_path).map_err(|e| format!("{}: {e}", ann_path.display()))?;
    // The converted file writes unknown velocities as bare `NaN`, which is not JSON.
    let text = text.replace("NaN", "null");
    let ann: serde_json::Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", ann_path.display()))?;
    let file = ann["lidar_file"].as_str().ok_or("no lidar_file")?;
    let points = read_points_f32(&base.join(file), 5).map_err(|e| e.to_string())?;
    let mut st = Stats { sweeps: 1, ..Stats::default() };
    for inst in ann["instances"].as_array().ok_or("no instances")? {
        if inst["label_name"].as_str() != Some("car") {
            continue;
        }
        let b: Vec<f64> = inst["bbox_3d"].as_array().ok_or("no bbox_3d")?.iter().filter_map(|v| v.as_f64()).collect();
        if b.len() != 7 {
            return Err("bbox_3d must have 7 numbers".into());
        }
        let sb = SensorBox { c: [b[0], b[1], b[2]], lwh: [b[3], b[4], b[5]], yaw: b[6] };
        st.cars.push((sb.range(), sb.count(&points)));
    }
    st.ground_fraction.push(ground_fraction(&points, -1.8));
    st.points.push(points.len());
    Ok(st)
}

/// Argoverse 2: the sweeps of log 7fab2350 with the cuboids annotated at the same timestamps.
fn av2(dir: &Path) -> Result<Stats, String> {
    let log = dir.join("av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede");
    let ds = pmon_datasets::open(&format!("av2:{}", log.display())).map_err(|e| e.to_string())?;
    let ground = ds.info.ground_z_m;
    let mut st = Stats::default();
    for f in ds.frames.iter().filter(|f| f.frame.cloud.is_some()) {
        let points = f.points_in_ego();
        let origin = f.frame.cloud.as_ref().map_or([0.0; 3], |c| c.ego_from_sensor.translation_m);
        for (i, o) in f.frame.objects.iter().enumerate() {
            if o.class != ObjectClass::Car {
                continue;
            }
            let Some(b) = f.box_in_ego(i) else { continue };
            let r = f64::from(o.x_m - origin[0]).hypot(f64::from(o.y_m - origin[1]));
            st.cars.push((r, pmon_datasets::points_in_box(&points, &b) as usize));
        }
        st.ground_fraction.push(ground_fraction(&points, ground));
        st.points.push(points.len());
        st.sweeps += 1;
    }
    if st.sweeps == 0 {
        return Err("no sweep in the log".into());
    }
    Ok(st)
}

fn simulated(name: &str, preset: LidarPreset, frames: usize) -> Result<Stats, String> {
    let mut cfg = ScenarioConfig::builtin(name).ok_or("no built-in")?;
    cfg.lidar.preset = preset;
    let model = cfg.lidar.resolve();
    let mut sim = Simulator::new(&cfg).map_err(|e| e.to_string())?;
    let mut st = Stats::default();
    let mut k = 0;
    while let Some(f) = sim.step() {
        k += 1;
        // Every 5th frame (0.5 s apart) over the whole scenario.
        if k % 5 != 1 {
            continue;
        }
        let Some(cloud) = &f.frame.cloud else { continue };
        st.points.push(cloud.points_in_sensor.len());
        st.ground_fraction.push(ground_fraction(&cloud.points_in_sensor, -(model.mount_height_m as f32)));
        for o in f.truth.iter().filter(|o| o.class == ObjectClass::Car) {
            let r = (o.x_ego_m - model.forward_offset_m).hypot(o.y_ego_m);
            st.cars.push((r, o.lidar_points as usize));
        }
        st.sweeps += 1;
        if st.sweeps >= frames {
            break;
        }
    }
    Ok(st)
}

fn median(mut v: Vec<usize>) -> Option<usize> {
    v.sort_unstable();
    v.get(v.len() / 2).copied()
}

fn cars_at(st: &Stats, lo: f64, hi: f64) -> String {
    let seen: Vec<usize> = st.cars.iter().filter(|(r, n)| *r >= lo && *r <= hi && *n > 0).map(|c| c.1).collect();
    let all = st.cars.iter().filter(|(r, _)| *r >= lo && *r <= hi).count();
    if all == 0 {
        return "-".into();
    }
    let (mn, mx) = (seen.iter().min().copied().unwrap_or(0), seen.iter().max().copied().unwrap_or(0));
    match median(seen.clone()) {
        Some(m) if seen.len() > 3 => format!("median {m} (range {mn}-{mx}; {} seen of {all})", seen.len()),
        Some(_) => {
            let mut list: Vec<String> =
                st.cars.iter().filter(|(r, _)| *r >= lo && *r <= hi).map(|(r, n)| format!("{n} @ {r:.0} m")).collect();
            list.sort();
            list.join(", ")
        }
        None => format!("0 of {all} seen"),
    }
}

fn row(label: &str, st: &Stats) {
    let pts = median(st.points.clone()).unwrap_or(0);
    let (mn, mx) = (st.points.iter().min().copied().unwrap_or(0), st.points.iter().max().copied().unwrap_or(0));
    let g = st.ground_fraction.iter().sum::<f64>() / st.ground_fraction.len().max(1) as f64;
    println!(
        "| {label} | {} | {pts} ({mn}-{mx}) | {:.0} % | {} | {} |",
        st.sweeps,
        100.0 * g,
        cars_at(st, 7.0, 15.0),
        cars_at(st, 30.0, 50.0)
    );
}

fn main() {
    let dir = data_dir();
    println!("| source | sweeps | points per sweep, median (range) | ground points | points on a car at 7-15 m | at 30-50 m |");
    println!("|---|---|---|---|---|---|");
    if dir.is_dir() {
        match kitti(&dir) {
            Ok(st) => row("KITTI HDL-64E (object 000000-000005)", &st),
            Err(e) => eprintln!("KITTI skipped: {e}"),
        }
        match nuscenes(&dir) {
            Ok(st) => row("nuScenes 32-beam (1 keyframe)", &st),
            Err(e) => eprintln!("nuScenes skipped: {e}"),
        }
        match av2(&dir) {
            Ok(st) => row("Argoverse 2, two 32-beam LiDARs (log 7fab2350)", &st),
            Err(e) => eprintln!("Argoverse 2 skipped: {e}"),
        }
    } else {
        eprintln!("real data skipped: {} is not a directory (set PMON_DATA_DIR)", dir.display());
    }
    for (name, preset, label) in [
        ("pedestrians", LidarPreset::Hdl64, "sim `pedestrians`, hdl64"),
        ("intersection", LidarPreset::Hdl64, "sim `intersection`, hdl64"),
        ("pedestrians", LidarPreset::Vlp32, "sim `pedestrians`, vlp32"),
        ("intersection", LidarPreset::Vlp32, "sim `intersection`, vlp32"),
    ] {
        match simulated(name, preset, 100) {
            Ok(st) => row(label, &st),
            Err(e) => eprintln!("{label}: {e}"),
        }
    }
}
