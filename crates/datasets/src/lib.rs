//! Readers of real driving datasets, in their native layouts, into the monitor's frame type
//! [`pmon_recording::RecordedFrame`].
//!
//! | spec | reader | what it gives |
//! |---|---|---|
//! | `kitti:DIR` | [`kitti::open_object`] | KITTI 3D object training frames: Velodyne sweep + `label_2` boxes |
//! | `kitti-tracking:DIR/label_02/SSSS.txt` | [`kitti::open_tracking`] | KITTI tracking object lists with track ids, 10 Hz, no clouds |
//! | `nuscenes:DIR` | [`nuscenes::open_converted`] | one keyframe: converted `sample_annotations.json` + `.pcd.bin` |
//! | `nuscenes-v1:DATAROOT[#scene]` | [`nuscenes::open_v1`] | native nuScenes v1.0 JSON tables + LIDAR_TOP key-frame sweeps |
//! | `av2:DIR/<log>` | [`av2::open_log`] | an Argoverse 2 sensor log: cuboids, sweeps, city poses |
//! | `commonroad:FILE.xml` | [`commonroad::open_scenario`] | CommonRoad 2018b / 2020a dynamic obstacles as tracks |
//!
//! Every reader returns a [`Dataset`]: metadata ([`DatasetInfo`], including the recommended
//! `ground_z_m` for the monitor) and one [`DatasetFrame`] per annotated frame. Objects are in the ego
//! frame (x forward, y left, z up), points in the sensor frame with the `ego_from_sensor` extrinsic. The
//! conventions of each dataset and how they are converted are in `docs/datasets.md`.
//!
//! Every reader rejects a malformed or truncated file with a [`DatasetError`] naming the file and what is
//! wrong; none panics on bad input.

pub mod av2;
pub mod av2_map;
pub mod commonroad;
mod error;
pub mod geometry;
pub mod ground;
pub mod kitti;
pub mod motion;
pub mod nuscenes;
pub mod nuscenes_slice;
pub mod roi;
pub mod sweeps;
mod util;

use std::path::{Path, PathBuf};

pub use error::DatasetError;
pub use geometry::{points_in_box, Box3};
use pmon_recording::{RecordedFrame, RecordingMeta};
pub use sweeps::{open_deferred, open_deferred_with_slice, DeferredSweeps};

/// Which reader produced a [`Dataset`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum DatasetFormat {
    /// KITTI 3D object benchmark (`velodyne/`, `label_2/`, `calib/`).
    KittiObject,
    /// KITTI tracking benchmark ground truth (`label_02/SSSS.txt`).
    KittiTracking,
    /// nuScenes keyframe converted from a public toolkit's info file (`sample_annotations.json`).
    NuScenesConverted,
    /// nuScenes native v1.0 JSON tables.
    NuScenesV1,
    /// Argoverse 2 sensor dataset log.
    Argoverse2,
    /// CommonRoad XML scenario.
    CommonRoad,
    /// A pmon recording (its `params.toml`, when present, says the ground height and ego footprint).
    Recording,
}

impl DatasetFormat {
    /// True for the formats whose frames carry no LiDAR sweep (object lists only): the sensor checks never run on
    /// them. A recording may or may not hold sweeps: false.
    #[must_use]
    pub const fn is_object_list_only(self) -> bool {
        matches!(self, Self::KittiTracking | Self::CommonRoad)
    }

    /// The recording vehicle's footprint in this format's ego frame, `[min_x, min_y, max_x, max_y]` metres, for
    /// the monitor's `ego_footprint_m` (returns inside it are the vehicle itself): KITTI's frame is centred on
    /// the roof LiDAR of a 4.8 m x 1.8 m car; nuScenes' and Argoverse 2's on the rear axle. Zeros where the
    /// data has no LiDAR.
    #[must_use]
    pub const fn ego_footprint_m(self) -> [f32; 4] {
        match self {
            // Wider than the body: the sensor rack and mirrors return at up to 1.5 m to the side.
            Self::KittiObject => [-2.7, -1.6, 2.6, 1.6],
            Self::NuScenesConverted | Self::NuScenesV1 | Self::Argoverse2 => [-1.2, -1.2, 4.2, 1.2],
            Self::KittiTracking | Self::CommonRoad | Self::Recording => [0.0; 4],
        }
    }
}

impl DatasetFormat {
    /// The scheme of the spec string accepted by [`open`] for this format.
    #[must_use]
    pub const fn scheme(self) -> &'static str {
        match self {
            Self::KittiObject => "kitti",
            Self::KittiTracking => "kitti-tracking",
            Self::NuScenesConverted => "nuscenes",
            Self::NuScenesV1 => "nuscenes-v1",
            Self::Argoverse2 => "av2",
            Self::CommonRoad => "commonroad",
            Self::Recording => "recording",
        }
    }
}

/// Where the objects' `speed_mps` comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpeedSource {
    /// The dataset's own velocity or speed field (nuScenes box velocity, CommonRoad state velocity).
    Dataset,
    /// Central finite differences of the track's positions in the world frame: speed over ground.
    FiniteDifferenceWorld,
    /// Central finite differences of positions in the moving ego frame: includes the ego vehicle's own motion,
    /// so it is NOT speed over ground (KITTI tracking, which ships no ego motion).
    FiniteDifferenceEgoRelative,
    /// No speed information: `speed_mps` is 0 (single, unrelated frames).
    Unknown,
}

/// What a reader knows about the data it read.
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetInfo {
    /// Short name (file stem, log id, benchmark id).
    pub name: String,
    /// Which reader produced it.
    pub format: DatasetFormat,
    /// The path that was read.
    pub source: PathBuf,
    /// Recommended `MonitorParams::ground_z_m`: the ground height in the ego frame, metres.
    pub ground_z_m: f32,
    /// True when `world_from_ego` is a real ego pose; false when it is the identity (unknown ego motion, or a
    /// dataset such as CommonRoad whose objects are already given in the world frame).
    pub ego_pose_known: bool,
    /// Where the objects' speeds come from.
    pub speed_source: SpeedSource,
    /// Nominal frame period, seconds (`None` for unrelated frames such as the KITTI object benchmark).
    pub frame_period_s: Option<f64>,
    /// Human-readable notes: conventions, conversions, what is missing, counts of skipped records.
    pub notes: Vec<String>,
}

/// Dataset-specific facts about one object, parallel to `RecordedFrame::objects`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectExtra {
    /// The dataset's own identifier of the object or track (KITTI `file:line` or track id, nuScenes instance
    /// token, AV2 track uuid, CommonRoad obstacle id).
    pub track_key: String,
    /// The dataset's category string, as written in the data.
    pub category: String,
    /// Box height, metres (`None` when the dataset has none, e.g. CommonRoad).
    pub height_m: Option<f32>,
    /// Height of the box's geometric centre in the ego frame, metres (`None` when the dataset has none).
    pub z_center_m: Option<f32>,
    /// The dataset's own count of LiDAR points in the box (`num_lidar_pts`, `num_interior_pts`), when given.
    pub num_points: Option<u32>,
    /// The dataset's recorded acceleration along the heading, m/s^2 (CommonRoad), when given.
    pub accel_mps2: Option<f32>,
}

/// One frame of a dataset: the monitor's frame plus per-object extras.
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetFrame {
    /// The frame as the monitor sees it.
    pub frame: RecordedFrame,
    /// One entry per `frame.objects`, same order.
    pub extras: Vec<ObjectExtra>,
}

impl DatasetFrame {
    /// The 3D box of object `i` in the ego frame, when the dataset gives a height and a z-centre.
    #[must_use]
    pub fn box_in_ego(&self, i: usize) -> Option<Box3> {
        let o = self.frame.objects.get(i)?;
        let e = self.extras.get(i)?;
        Some(Box3 {
            center_m: [o.x_m, o.y_m, e.z_center_m?],
            length_m: o.length_m,
            width_m: o.width_m,
            height_m: e.height_m?,
            yaw_rad: o.heading_rad,
        })
    }

    /// The cloud's points transformed into the ego frame (empty when the frame has no cloud).
    #[must_use]
    pub fn points_in_ego(&self) -> Vec<[f32; 3]> {
        self.frame
            .cloud
            .as_ref()
            .map(|c| c.points_in_sensor.iter().map(|p| c.ego_from_sensor.transform(*p)).collect())
            .unwrap_or_default()
    }
}

/// A dataset read into memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// Metadata.
    pub info: DatasetInfo,
    /// Frames in time order (strictly increasing timestamps).
    pub frames: Vec<DatasetFrame>,
}

impl Dataset {
    /// Writes the frames as a pmon recording directory (see `pmon_recording`).
    ///
    /// # Errors
    /// I/O errors, named by file.
    pub fn write_recording(&self, dir: &Path) -> Result<RecordingMeta, pmon_recording::RecordingError> {
        let meta = RecordingMeta::new(
            self.info.name.clone(),
            format!("{}:{}", self.info.format.scheme(), self.info.source.display()),
        );
        let mut w = pmon_recording::RecordingWriter::create(dir, meta)?;
        for f in &self.frames {
            w.write_frame(&f.frame)?;
        }
        w.finish()
    }

    /// Total number of objects over all frames.
    #[must_use]
    pub fn object_count(&self) -> usize {
        self.frames.iter().map(|f| f.frame.objects.len()).sum()
    }
}

/// Options shared by the readers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReadOptions {
    /// Read LiDAR sweeps (false: object lists and poses only, much less memory).
    pub load_clouds: bool,
    /// Where the frames' region of interest (`roi_in_ego`) comes from.
    pub roi: roi::RoiOptions,
    /// Whether the sweeps are levelled to the local ground ([`ground`]); the default keeps them as recorded.
    pub ground: ground::GroundMode,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self { load_clouds: true, roi: roi::RoiOptions::default(), ground: ground::GroundMode::AsRecorded }
    }
}

/// Opens a dataset from a spec string `scheme:path` (see the crate docs and `docs/datasets.md`).
///
/// # Errors
/// An unknown scheme, or any error of the reader.
pub fn open(spec: &str) -> Result<Dataset, DatasetError> {
    open_with(spec, &ReadOptions::default())
}

/// [`open`] with options.
///
/// # Errors
/// An unknown scheme, or any error of the reader.
pub fn open_with(spec: &str, opts: &ReadOptions) -> Result<Dataset, DatasetError> {
    open_with_tables(spec, opts, None)
}

/// [`open_with`] for a nuScenes v1.0 scene (`nuscenes-v1:DATAROOT#scene`) whose tables come from its slice (the
/// text [`nuscenes_slice::slice_scenes`] gives) instead of the table folder: the same dataset, bit for bit, without
/// reading the whole tables.
///
/// # Errors
/// A spec that is not `nuscenes-v1:...#scene`, a malformed slice, or any error of the reader.
pub fn open_with_slice(spec: &str, opts: &ReadOptions, slice: &str) -> Result<Dataset, DatasetError> {
    open_with_tables(spec, opts, Some(slice))
}

fn open_with_tables(spec: &str, opts: &ReadOptions, slice: Option<&str>) -> Result<Dataset, DatasetError> {
    let parsed = Spec::parse(spec)?;
    parsed.check_slice(spec, slice)?;
    let mut ds = match parsed {
        Spec::Kitti(p) => kitti::open_object(p, opts),
        Spec::KittiTracking(p) => kitti::open_tracking(p),
        Spec::NuScenes(p) => nuscenes::open_converted(p, opts),
        Spec::NuScenesV1(p, scene) => nuscenes::open_v1_with(p, scene, opts, false, slice).map(|(ds, _)| ds),
        Spec::Av2(p) => av2::open_log(p, opts),
        Spec::CommonRoad(p) => commonroad::open_scenario(p),
    }?;
    roi::finish(&mut ds, &opts.roi);
    ground::finish(&mut ds, opts.ground);
    check_finite(&ds)?;
    Ok(ds)
}

/// A dataset spec `scheme:path` taken apart ([`open_with`] and [`sweeps::open_deferred`] read the same specs).
pub(crate) enum Spec<'a> {
    Kitti(&'a Path),
    KittiTracking(&'a Path),
    NuScenes(&'a Path),
    /// The path and the scene after `#`, if any.
    NuScenesV1(&'a Path, Option<&'a str>),
    Av2(&'a Path),
    CommonRoad(&'a Path),
}

impl<'a> Spec<'a> {
    /// # Errors
    /// No `scheme:`, an empty path or an unknown scheme, naming the spec and the schemes known.
    pub(crate) fn parse(spec: &'a str) -> Result<Self, DatasetError> {
        let spec_err = |message: String| DatasetError::Spec { spec: spec.to_string(), message };
        let Some((scheme, rest)) = spec.split_once(':') else {
            return Err(spec_err(format!("expected `scheme:path`, scheme one of: {}", SCHEMES.join(", "))));
        };
        if rest.is_empty() {
            return Err(spec_err("the path is empty".into()));
        }
        let path = Path::new(rest);
        Ok(match scheme {
            "kitti" => Spec::Kitti(path),
            "kitti-tracking" => Spec::KittiTracking(path),
            "nuscenes" => Spec::NuScenes(path),
            "nuscenes-v1" => match rest.rsplit_once('#') {
                Some((p, s)) if !s.is_empty() => Spec::NuScenesV1(Path::new(p), Some(s)),
                _ => Spec::NuScenesV1(path, None),
            },
            "av2" => Spec::Av2(path),
            "commonroad" => Spec::CommonRoad(path),
            other => {
                return Err(spec_err(format!("unknown scheme `{other}`, expected one of: {}", SCHEMES.join(", "))))
            }
        })
    }
}

impl Spec<'_> {
    /// A table slice is for one nuScenes v1.0 scene only.
    pub(crate) fn check_slice(&self, spec: &str, slice: Option<&str>) -> Result<(), DatasetError> {
        match (self, slice) {
            (_, None) | (Spec::NuScenesV1(_, Some(_)), Some(_)) => Ok(()),
            _ => Err(DatasetError::Spec {
                spec: spec.to_string(),
                message: "a table slice applies to one nuScenes v1.0 scene only (`nuscenes-v1:DATAROOT#scene`)".into(),
            }),
        }
    }
}

/// Every reader's values end up as f32: one beyond f32's range (or NaN) would become an infinity the monitor
/// calls `invalid_state` and `pmon convert` writes as `null`. An error naming the source instead (issue 15).
fn check_finite(ds: &Dataset) -> Result<(), DatasetError> {
    for f in &ds.frames {
        let frame = &f.frame;
        for o in &frame.objects {
            let values = [o.x_m, o.y_m, o.heading_rad, o.speed_mps, o.length_m, o.width_m];
            if !values.iter().all(|v| v.is_finite()) {
                return Err(DatasetError::malformed(
                    &ds.info.source,
                    format!(
                        "frame {}: object {}: a value is not finite or beyond the f32 range: {values:?}",
                        frame.index, o.id
                    ),
                ));
            }
        }
        if !frame.timestamp_s.is_finite() {
            return Err(DatasetError::malformed(
                &ds.info.source,
                format!("frame {}: timestamp not finite", frame.index),
            ));
        }
    }
    Ok(())
}

/// Notes in [`DatasetInfo::notes`] that start with this are warnings: something the reader substituted (a
/// nominal calibration, ...) that a user should hear about; the CLI prints them on stderr.
pub const WARNING_PREFIX: &str = "warning: ";

/// The schemes [`open`] accepts.
pub const SCHEMES: [&str; 6] = ["kitti", "kitti-tracking", "nuscenes", "nuscenes-v1", "av2", "commonroad"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_specs_are_errors() {
        for spec in ["", "kitti", "kitti:", "bogus:/x", "nuscenes-v1:#"] {
            let err = open(spec).unwrap_err();
            assert!(matches!(err, DatasetError::Spec { .. }) || matches!(err, DatasetError::Io { .. }), "{spec}");
        }
        let err = open("bogus:/x").unwrap_err().to_string();
        assert!(err.contains("bogus") && err.contains("kitti-tracking"), "{err}");
    }

    #[test]
    fn missing_paths_name_the_path() {
        for spec in [
            "kitti:/nonexistent/k",
            "kitti-tracking:/nonexistent/t/label_02/0000.txt",
            "nuscenes:/nonexistent/n",
            "nuscenes-v1:/nonexistent/v",
            "av2:/nonexistent/a",
            "commonroad:/nonexistent/c.xml",
        ] {
            let err = open(spec).unwrap_err().to_string();
            assert!(err.contains("/nonexistent/"), "{spec}: {err}");
        }
    }
}
