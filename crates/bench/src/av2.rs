//! The Argoverse 2 sweeps of the shared data, read in place with the AV2 reader of `pmon-datasets`, as a
//! benchmark [`Sequence`].
//!
//! This is a module of its own (not part of [`crate::frames`]) because `frames.rs` is also compiled into the
//! benchmarks and tests of `pmon-monitor`, which may depend on nothing but `pmon-monitor`; reading Feather
//! (Arrow IPC) files needs `pmon-datasets`.
//!
//! # Layout and frames
//! Every log folder `av2/sensor/<split>/<log>/` with sweeps under `sensors/lidar/*.feather` is read with
//! [`pmon_datasets::av2::open_log`]. An AV2 sweep merges the two stacked 32-beam lidars (`up_lidar`, laser numbers
//! 0-31, and `down_lidar`, 32-63; about 99,000 points in all) and is stored in AV2's ego-vehicle frame, whose
//! origin is the rear-axle centre about 0.32 m above the ground. The reader hands the points over centred on the
//! `up_lidar` origin (`calibration/egovehicle_SE3_sensor.feather`) with `ego_from_sensor = translation(up_lidar
//! origin)`. The benchmark keeps those points and that extrinsic, raised by the depth of the ground under the ego
//! origin (the reader's `ground_z_m`, the median of the log's ground-height raster under the ego poses), so that
//! the ground is at `z = 0` as in every other case and the paper parameters (`ground_z_m = 0`) apply unchanged:
//! the sensor sits at its real place, about 1.96 m above the ground and 1.35 m ahead of the rear axle.
//!
//! Returns of the down lidar get the up lidar's origin (as in the reader): a small error in ray directions near
//! the car, none in where the points are.
//!
//! # Region of interest
//! Each sweep carries its frame's region of interest from the log's vector map (`map/log_map_archive_*.json`:
//! drivable areas and pedestrian crossings, the reader's defaults), so the cluster stage pays for the ROI test as
//! it does in `pmon check`.
//!
//! # Objects
//! Like the KITTI sweeps, which come from a 64-beam sensor of about the same point count, the AV2 sweeps carry the
//! synthetic object list of [`OBJECTS`] (100 objects, the goal size of a 64-beam frame), not the log's cuboids:
//! the cases then differ only in their clouds.

use std::path::{Path, PathBuf};

use pmon_datasets::{av2, ReadOptions};
use pmon_monitor::{Isometry3, MonitorParams};

use crate::frames::{files_ending, Sequence, Sweep, SyntheticSpec};

/// The object lists the AV2 sweeps carry: those of the 64-beam synthetic scene (100 objects), as for KITTI.
pub const OBJECTS: SyntheticSpec = SyntheticSpec::BEAMS_64;

/// Name of the AV2 sequence in reports.
pub const SEQUENCE_NAME: &str = "Argoverse 2 sweeps (2 x 32-beam VLP-32C), 100 synthetic objects";

/// One AV2 log with sweeps, as read for the benchmark.
#[derive(Clone, Debug, PartialEq)]
pub struct Av2Log {
    /// The log folder.
    pub dir: PathBuf,
    /// Ground height under the ego origin in AV2's ego frame (the reader's `ground_z_m`), metres.
    pub ground_z_m: f32,
    /// The `up_lidar` origin in AV2's ego frame, metres.
    pub up_lidar_m: [f32; 3],
    /// Sweep files in `sensors/lidar` (the reader uses those whose timestamp is an annotation timestamp).
    pub sweep_files: usize,
    /// The sweeps, in time order, with `ego_from_sensor` raised so that the ground is at `z = 0`.
    pub sweeps: Vec<Sweep>,
}

impl Av2Log {
    /// The log's id (the folder's name).
    #[must_use]
    pub fn name(&self) -> &str {
        self.dir.file_name().and_then(|n| n.to_str()).unwrap_or("?")
    }
}

/// The folders `av2/sensor/<split>/<log>` of `data` that hold sweeps (`sensors/lidar/*.feather`), sorted; empty
/// when there are none.
#[must_use]
pub fn log_dirs(data: &Path) -> Vec<PathBuf> {
    let sorted_dirs = |dir: &Path| -> Vec<PathBuf> {
        let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
        let mut dirs: Vec<PathBuf> = entries.filter_map(Result::ok).map(|e| e.path()).filter(|p| p.is_dir()).collect();
        dirs.sort();
        dirs
    };
    sorted_dirs(&data.join("av2/sensor"))
        .iter()
        .flat_map(|split| sorted_dirs(split))
        .filter(|log| !files_ending(&log.join("sensors/lidar"), ".feather").is_empty())
        .collect()
}

/// Reads the AV2 logs of `data` that have sweeps (see the module documentation); empty when there are none.
///
/// # Errors
/// A present but unreadable or malformed file (annotations, poses, calibration, ground raster, sweep), a log
/// whose sweep files match no annotation timestamp, a sweep with more points than the paper parameters'
/// `max_points`: a message naming the file or the folder.
pub fn logs(data: &Path) -> Result<Vec<Av2Log>, String> {
    log_dirs(data).iter().map(|dir| read_log(dir)).collect()
}

/// The sweeps of all [`logs`], in order.
///
/// # Errors
/// As [`logs`].
pub fn sweeps(data: &Path) -> Result<Vec<Sweep>, String> {
    Ok(logs(data)?.into_iter().flat_map(|log| log.sweeps).collect())
}

/// The benchmark sequence of AV2 sweeps: [`Sequence::real`] with the object lists of [`OBJECTS`]; `None` without
/// sweeps.
#[must_use]
pub fn sequence(sweeps: Vec<Sweep>) -> Option<Sequence> {
    Sequence::real(SEQUENCE_NAME, sweeps, &OBJECTS)
}

#[allow(clippy::cast_precision_loss)] // nanosecond timestamps as seconds, as the reader computes them
fn seconds_of_ns(ns: i64) -> f64 {
    ns as f64 * 1e-9
}

fn read_log(dir: &Path) -> Result<Av2Log, String> {
    let files = files_ending(&dir.join("sensors/lidar"), ".feather");
    let stamped: Vec<(f64, String)> = files
        .iter()
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?;
            let ns = name.strip_suffix(".feather")?.parse::<i64>().ok()?;
            Some((seconds_of_ns(ns), name.to_string()))
        })
        .collect();
    let dataset = av2::open_log(
        dir,
        &ReadOptions { load_clouds: true, ground: pmon_datasets::ground::GroundMode::Auto, ..ReadOptions::default() },
    )
    .map_err(|e| format!("Argoverse 2 log {}: {e}", dir.display()))?;
    let ground_z_m = dataset.info.ground_z_m;
    if !ground_z_m.is_finite() {
        return Err(format!("Argoverse 2 log {}: ground height {ground_z_m} is not finite", dir.display()));
    }
    let max_points = usize::try_from(MonitorParams::PAPER.max_points).unwrap_or(usize::MAX);
    let short = dir.file_name().and_then(|n| n.to_str()).and_then(|n| n.get(..8)).unwrap_or("av2");
    let mut up_lidar_m = [0.0; 3];
    let mut sweeps = Vec::new();
    for frame in dataset.frames {
        let Some(cloud) = frame.frame.cloud else { continue };
        // The sweep file of this frame: the one whose timestamp the reader matched (nearest, to be robust).
        let t = frame.frame.timestamp_s;
        let file = stamped
            .iter()
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
            .map_or_else(|| format!("{t:.3} s"), |s| s.1.clone());
        let path = dir.join("sensors/lidar").join(&file);
        if cloud.points_in_sensor.is_empty() {
            return Err(format!("{}: sweep has no points", path.display()));
        }
        if cloud.points_in_sensor.len() > max_points {
            return Err(format!(
                "{}: {} points, more than the monitor's max_points ({max_points})",
                path.display(),
                cloud.points_in_sensor.len()
            ));
        }
        let e = cloud.ego_from_sensor;
        up_lidar_m = e.translation_m;
        let [x, y, z] = e.translation_m;
        sweeps.push(Sweep {
            label: format!("{short}/{file}"),
            points_in_sensor: cloud.points_in_sensor,
            ego_from_sensor: Isometry3 { rotation: e.rotation, translation_m: [x, y, z - ground_z_m] },
            roi_in_ego: frame.frame.roi_in_ego,
        });
    }
    if sweeps.is_empty() {
        return Err(format!(
            "{}: {} sweep file(s) but none matches an annotation timestamp of the log",
            dir.join("sensors/lidar").display(),
            files.len()
        ));
    }
    Ok(Av2Log { dir: dir.to_path_buf(), ground_z_m, up_lidar_m, sweep_files: files.len(), sweeps })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::data_dir;

    const LOG: &str = "av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede";
    const SWEEP: &str = "315966265259836000.feather";

    fn write(path: &Path, bytes: &[u8]) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }

    #[test]
    fn no_av2_folder_gives_no_logs() {
        let dir = tempfile::tempdir().unwrap();
        assert!(log_dirs(dir.path()).is_empty());
        assert_eq!(logs(dir.path()).unwrap(), Vec::new());
        // A log without sweeps (like 3b3570b4, annotations and poses only) is not a benchmark log.
        write(&dir.path().join("av2/sensor/val/x/annotations.feather"), b"not read");
        assert!(log_dirs(dir.path()).is_empty());
    }

    #[test]
    fn a_log_without_annotations_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        write(&dir.path().join("av2/sensor/val/x/sensors/lidar/1.feather"), b"not a feather file");
        let err = logs(dir.path()).unwrap_err();
        assert!(err.contains("annotations.feather"), "{err}");
    }

    /// The real log's tables beside a truncated sweep (in a temporary folder): the error names the sweep, in
    /// `pmon bench` too.
    #[test]
    fn a_truncated_sweep_is_an_error_naming_the_file() {
        let real = data_dir().join(LOG);
        if !real.join("sensors/lidar").join(SWEEP).is_file() {
            eprintln!("skipped: no Argoverse 2 sweeps under {} (set PMON_DATA_DIR)", data_dir().display());
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join(LOG);
        for f in ["annotations.feather", "city_SE3_egovehicle.feather", "calibration/egovehicle_SE3_sensor.feather"] {
            write(&log.join(f), &std::fs::read(real.join(f)).unwrap());
        }
        let sweep = std::fs::read(real.join("sensors/lidar").join(SWEEP)).unwrap();
        write(&log.join("sensors/lidar").join(SWEEP), sweep.get(..4000).unwrap());
        let err = logs(dir.path()).unwrap_err();
        assert!(err.contains(SWEEP) && err.contains("Feather"), "{err}");
        let opts = crate::BenchOptions {
            iterations: 1,
            data_dir: Some(dir.path().to_path_buf()),
            worst_case: false,
            ..crate::BenchOptions::default()
        };
        let err = crate::run_bench(&opts).unwrap_err();
        assert!(matches!(&err, crate::BenchError::Data(m) if m.contains(SWEEP)), "{err}");
    }

    /// The shared log: two sweeps of two VLP-32C lidars, the ground at z = 0 after the extrinsic.
    #[test]
    fn the_shared_log_is_read_with_the_ground_at_zero() {
        let logs = logs(&data_dir()).unwrap();
        let Some(log) = logs.first() else {
            eprintln!("skipped: no Argoverse 2 sweeps under {} (set PMON_DATA_DIR)", data_dir().display());
            return;
        };
        assert_eq!(log.name(), "7fab2350-7eaf-3b7e-a39d-6937a4c1bede");
        let counts: Vec<usize> = log.sweeps.iter().map(|s| s.points_in_sensor.len()).collect();
        assert_eq!(counts, [99_229, 99_466]);
        assert_eq!(log.sweep_files, 2);
        assert!((log.ground_z_m + 0.323).abs() < 0.01, "{}", log.ground_z_m);
        for s in &log.sweeps {
            let [x, y, z] = s.ego_from_sensor.translation_m;
            assert!((x - 1.350).abs() < 0.01 && y.abs() < 0.01 && (z - 1.963).abs() < 0.01, "{s:?}");
            // Within 15 m of the car most returns are ground: their 10th percentile height is near z = 0.
            let mut near: Vec<f32> = s
                .points_in_sensor
                .iter()
                .map(|p| s.ego_from_sensor.transform(*p))
                .filter(|p| p[0].hypot(p[1]) < 15.0)
                .map(|p| p[2])
                .collect();
            near.sort_by(f32::total_cmp);
            let p10 = near[near.len() / 10];
            assert!(p10.abs() < 0.15, "{}: ground at {p10} m", s.label);
        }
        let seq = sequence(log.sweeps.clone()).unwrap();
        assert_eq!((seq.frames.len(), seq.max_objects(), seq.max_points()), (6, 100, 99_466));
        // The log's vector map reaches the benchmark frames: the ego stands in the region of interest.
        for k in 0..seq.frames.len() {
            let mut roi = Vec::new();
            let f = seq.frame_with_roi(k, 0.0, &mut roi).unwrap();
            assert!(!f.roi_in_ego.is_empty(), "frame {k}: no ROI");
            assert!(f.roi_in_ego.iter().any(|p| pmon_monitor::geometry::polygon_contains(p, 1.0, 0.0)), "frame {k}");
        }
        assert!(seq.frame(0, 0.0).unwrap().roi_in_ego.is_empty(), "frame() keeps the whole grid");
    }
}
