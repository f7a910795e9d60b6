//! nuScenes (Caesar et al., CVPR 2020): LIDAR_TOP `.pcd.bin` sweeps, the native v1.0 JSON tables, and a
//! converted single-keyframe `sample_annotations.json`.
//!
//! Frames: nuScenes' ego frame has its origin at the rear-axle centre on the ground (ground near z = 0), x
//! forward, y left, z up; the LIDAR_TOP sensor frame is rotated about 90 degrees in yaw and 1.84 m above it.
//! Points stay in the sensor frame with `ego_from_sensor` = the calibrated extrinsic; boxes are converted to
//! the ego frame. `world_from_ego` is the ego pose (global frame) of the LIDAR_TOP sample_data.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use pmon_monitor::{ObjectClass, ObjectState};
use pmon_recording::RecordedFrame;
use serde::Deserialize;

use crate::geometry::{wrap_angle, Rigid3};
use crate::sweeps::{SweepFile, SweepFormat};
use crate::util::{f32_of, finite_difference_speeds, list_dir, python_json_to_strict, read_bytes, read_text};
use crate::{Dataset, DatasetError, DatasetFormat, DatasetFrame, DatasetInfo, ObjectExtra, ReadOptions, SpeedSource};

/// Floats per point in a nuScenes LiDAR `.pcd.bin`: `x, y, z, intensity, ring`.
pub const PCD_BIN_FLOATS: usize = 5;

/// Largest gap between two annotations of an instance used for a finite difference, seconds (as the devkit).
const MAX_GAP_S: f64 = 1.5;

/// Reads a nuScenes LiDAR `.pcd.bin` (N x 5 little-endian f32), sensor frame.
///
/// # Errors
/// I/O errors, a size that is not a whole number of 20-byte points.
pub fn read_pcd_bin(path: &Path) -> Result<Vec<[f32; 3]>, DatasetError> {
    let bytes = read_bytes(path)?;
    pmon_recording::points_from_le_bytes(&bytes, PCD_BIN_FLOATS).map_err(|m| DatasetError::malformed(path, m))
}

/// The monitor's class for a nuScenes category, either the v1.0 name (`vehicle.car`, `human.pedestrian.adult`)
/// or the detection name (`car`, `pedestrian`, `traffic_cone`).
#[must_use]
pub fn class_of(category: &str) -> ObjectClass {
    let c = category;
    if c == "car" || c.starts_with("vehicle.car") || c.starts_with("vehicle.emergency") {
        ObjectClass::Car
    } else if matches!(c, "truck" | "bus" | "trailer" | "construction_vehicle")
        || c.starts_with("vehicle.truck")
        || c.starts_with("vehicle.bus")
        || c.starts_with("vehicle.trailer")
        || c.starts_with("vehicle.construction")
    {
        ObjectClass::Truck
    } else if c == "pedestrian" || c.starts_with("human.pedestrian") {
        ObjectClass::Pedestrian
    } else if c == "bicycle" || c.starts_with("vehicle.bicycle") {
        ObjectClass::Cyclist
    } else if c == "motorcycle" || c.starts_with("vehicle.motorcycle") {
        ObjectClass::Motorcyclist
    } else if matches!(c, "traffic_cone" | "barrier")
        || c.starts_with("movable_object")
        || c.starts_with("static_object")
        || c.starts_with("animal")
    {
        ObjectClass::Other
    } else {
        ObjectClass::Unknown
    }
}

// -------------------------------------------------------------------------------------------------------------
// Converted single keyframe
// -------------------------------------------------------------------------------------------------------------

#[derive(Deserialize)]
struct ConvertedSample {
    #[serde(default)]
    sample_token: String,
    timestamp_s: f64,
    lidar_file: String,
    lidar2ego_4x4: [[f64; 4]; 4],
    ego2global_4x4: [[f64; 4]; 4],
    instances: Vec<ConvertedInstance>,
}

#[derive(Deserialize)]
struct ConvertedInstance {
    label_name: String,
    bbox_3d: Vec<f64>,
    #[serde(default)]
    velocity: Option<Vec<Option<f64>>>,
    #[serde(default)]
    num_lidar_pts: Option<i64>,
    #[serde(default)]
    bbox_3d_isvalid: Option<bool>,
}

/// Reads the converted keyframe: `PATH` is the folder with `sample_annotations.json` (or the JSON file itself);
/// the sweep is `lidar_file` beside it. Boxes `[x, y, z, l, w, h, yaw]` (LIDAR_TOP frame, geometric centre) and
/// velocities `[vx, vy]` (LIDAR_TOP frame, m/s) are rotated into the ego frame; speed is the velocity's norm.
///
/// # Errors
/// I/O errors, JSON that does not match the layout, non-rigid transforms, boxes with 7 values missing.
pub fn open_converted(path: &Path, opts: &ReadOptions) -> Result<Dataset, DatasetError> {
    open_converted_with(path, opts, false).map(|(ds, _)| ds)
}

/// [`open_converted`]; with `defer` the sweep is not read but returned (the frame's cloud `None`), for
/// [`crate::sweeps::open_deferred`].
pub(crate) fn open_converted_with(
    path: &Path,
    opts: &ReadOptions,
    defer: bool,
) -> Result<(Dataset, Vec<Option<SweepFile>>), DatasetError> {
    let json_path = if path.is_dir() { path.join("sample_annotations.json") } else { path.to_path_buf() };
    let dir = json_path.parent().map_or_else(PathBuf::new, Path::to_path_buf);
    let text = read_text(&json_path)?;
    // written by Python's json module: unknown velocities are the non-standard token NaN
    let text = python_json_to_strict(&text);
    let s: ConvertedSample =
        serde_json::from_str(&text).map_err(|e| DatasetError::malformed(&json_path, e.to_string()))?;
    let bad = |m: String| DatasetError::malformed(&json_path, m);
    let ego_from_lidar = Rigid3::from_homogeneous(&s.lidar2ego_4x4)
        .ok_or_else(|| bad("`lidar2ego_4x4` is not a finite rigid transform".into()))?;
    let world_from_ego = Rigid3::from_homogeneous(&s.ego2global_4x4)
        .ok_or_else(|| bad("`ego2global_4x4` is not a finite rigid transform".into()))?;
    if !s.timestamp_s.is_finite() {
        return Err(bad("`timestamp_s` is not finite".into()));
    }
    let mut frame = RecordedFrame::empty(0, s.timestamp_s, world_from_ego.to_pose2());
    let mut extras = Vec::new();
    let mut no_velocity = 0usize;
    let mut invalid = 0usize;
    for (i, inst) in s.instances.iter().enumerate() {
        let bad_inst = |m: &str| bad(format!("instances[{i}]: {m}"));
        let [x, y, z, l, w, h, yaw] = inst.bbox_3d.as_slice() else {
            return Err(bad_inst("`bbox_3d` must have 7 values [x, y, z, l, w, h, yaw]"));
        };
        if !([x, y, z, l, w, h, yaw].iter().all(|v| v.is_finite()) && *l > 0.0 && *w > 0.0 && *h > 0.0) {
            return Err(bad_inst("`bbox_3d` has non-finite values or non-positive size"));
        }
        if inst.bbox_3d_isvalid == Some(false) {
            invalid += 1;
        }
        let c = ego_from_lidar.apply([*x, *y, *z]);
        let heading = wrap_angle(ego_from_lidar.map_yaw(*yaw));
        let speed = match inst.velocity.as_deref() {
            Some([Some(vx), Some(vy)]) if vx.is_finite() && vy.is_finite() => {
                let v = ego_from_lidar.rotate([*vx, *vy, 0.0]);
                v[0].hypot(v[1])
            }
            Some([_, _]) | None => {
                no_velocity += 1;
                0.0
            }
            Some(_) => return Err(bad_inst("`velocity` must have 2 values [vx, vy]")),
        };
        let num_points = match inst.num_lidar_pts {
            Some(n) => Some(u32::try_from(n).map_err(|_| bad_inst("`num_lidar_pts` out of range"))?),
            None => None,
        };
        frame.objects.push(ObjectState {
            id: u64::try_from(i + 1).unwrap_or(u64::MAX),
            class: class_of(&inst.label_name),
            x_m: f32_of(c[0]),
            y_m: f32_of(c[1]),
            heading_rad: f32_of(heading),
            speed_mps: f32_of(speed),
            length_m: f32_of(*l),
            width_m: f32_of(*w),
            uncertainty: None,
        });
        extras.push(ObjectExtra {
            track_key: format!("{}:{i}", s.sample_token),
            category: inst.label_name.clone(),
            height_m: Some(f32_of(*h)),
            z_center_m: Some(f32_of(c[2])),
            num_points,
            accel_mps2: None,
        });
    }
    let lidar_path = dir.join(&s.lidar_file);
    let file = opts.load_clouds.then(|| SweepFile {
        path: lidar_path,
        format: SweepFormat::NuScenesPcdBin,
        ego_from_sensor: ego_from_lidar.to_isometry3(),
    });
    if let (Some(f), false) = (&file, defer) {
        frame.cloud = Some(f.read()?);
    }
    let mut notes = vec![
        "ego frame = nuScenes ego frame (rear-axle centre on the ground): ground_z_m = 0; points stay in \
         LIDAR_TOP with ego_from_sensor = lidar2ego"
            .to_string(),
        "boxes and velocities converted LIDAR_TOP -> ego; speed = |velocity| (the dataset's velocity, over \
         ground)"
            .to_string(),
        "one keyframe: object ids are per-sample indices, not tracks".to_string(),
    ];
    if no_velocity > 0 {
        notes.push(format!("{no_velocity} boxes without a finite velocity get speed 0"));
    }
    if invalid > 0 {
        notes.push(format!("{invalid} boxes flagged bbox_3d_isvalid = false (kept)"));
    }
    let ds = Dataset {
        info: DatasetInfo {
            name: if s.sample_token.is_empty() { "nuscenes".into() } else { s.sample_token.clone() },
            format: DatasetFormat::NuScenesConverted,
            source: json_path,
            ground_z_m: 0.0,
            ego_pose_known: true,
            speed_source: SpeedSource::Dataset,
            frame_period_s: None,
            notes,
        },
        frames: vec![DatasetFrame { frame, extras }],
    };
    Ok((ds, vec![if defer { file } else { None }]))
}

// -------------------------------------------------------------------------------------------------------------
// Native v1.0 tables
// -------------------------------------------------------------------------------------------------------------

/// `sample.json` record (fields used here).
#[derive(Clone, Debug, Deserialize)]
pub struct Sample {
    /// Token.
    pub token: String,
    /// Microseconds.
    pub timestamp: i64,
    /// Scene token.
    pub scene_token: String,
}

/// `sample_data.json` record (fields used here).
#[derive(Clone, Debug, Deserialize)]
pub struct SampleData {
    /// Token.
    pub token: String,
    /// Sample this belongs to.
    pub sample_token: String,
    /// Ego pose at the data's timestamp.
    pub ego_pose_token: String,
    /// Sensor extrinsic.
    pub calibrated_sensor_token: String,
    /// Path relative to the dataroot.
    pub filename: String,
    /// Microseconds.
    pub timestamp: i64,
    /// True for the keyframe (annotated) sweep.
    pub is_key_frame: bool,
}

/// `sample_annotation.json` record (fields used here).
#[derive(Clone, Debug, Deserialize)]
pub struct SampleAnnotation {
    /// Token.
    pub token: String,
    /// Sample.
    pub sample_token: String,
    /// Instance (the track).
    pub instance_token: String,
    /// Box centre, global frame, metres.
    pub translation: [f64; 3],
    /// Width, length, height, metres.
    pub size: [f64; 3],
    /// Quaternion `w, x, y, z`, global frame.
    pub rotation: [f64; 4],
    /// LiDAR points in the box (all sweeps of the sample's LIDAR_TOP keyframe).
    #[serde(default)]
    pub num_lidar_pts: Option<i64>,
}

/// `instance.json` record (fields used here).
#[derive(Clone, Debug, Deserialize)]
pub struct Instance {
    /// Token.
    pub token: String,
    /// Category.
    pub category_token: String,
}

/// `category.json` record.
#[derive(Clone, Debug, Deserialize)]
pub struct Category {
    /// Token.
    pub token: String,
    /// Name such as `vehicle.car`.
    pub name: String,
}

/// `ego_pose.json` and `calibrated_sensor.json` record (fields used here).
#[derive(Clone, Debug, Deserialize)]
pub struct PoseRecord {
    /// Token.
    pub token: String,
    /// Translation, metres.
    pub translation: [f64; 3],
    /// Quaternion `w, x, y, z`.
    pub rotation: [f64; 4],
    /// Sensor (calibrated_sensor only).
    #[serde(default)]
    pub sensor_token: Option<String>,
}

/// `sensor.json` record.
#[derive(Clone, Debug, Deserialize)]
pub struct Sensor {
    /// Token.
    pub token: String,
    /// Channel such as `LIDAR_TOP`.
    pub channel: String,
}

/// `scene.json` record (fields used here).
#[derive(Clone, Debug, Deserialize)]
pub struct Scene {
    /// Token.
    pub token: String,
    /// Name such as `scene-0061`.
    pub name: String,
}

/// The v1.0 tables this crate uses.
#[derive(Clone, Debug)]
pub struct Tables {
    /// The directory holding the JSON tables.
    pub dir: PathBuf,
    /// `sample.json`.
    pub samples: Vec<Sample>,
    /// `sample_data.json`.
    pub sample_data: Vec<SampleData>,
    /// `sample_annotation.json`.
    pub annotations: Vec<SampleAnnotation>,
    /// `instance.json`.
    pub instances: Vec<Instance>,
    /// `category.json`.
    pub categories: Vec<Category>,
    /// `ego_pose.json`.
    pub ego_poses: Vec<PoseRecord>,
    /// `calibrated_sensor.json`.
    pub calibrated_sensors: Vec<PoseRecord>,
    /// `sensor.json` (optional: without it LIDAR_TOP data is recognised by its file name).
    pub sensors: Option<Vec<Sensor>>,
    /// `scene.json` (optional: needed only to select a scene by name).
    pub scenes: Option<Vec<Scene>>,
}

fn read_table<T: for<'de> Deserialize<'de>>(dir: &Path, name: &str) -> Result<Vec<T>, DatasetError> {
    let path = dir.join(name);
    parse_table(&path, &read_text(&path)?)
}

/// A table file's text (Python's `NaN` allowed) as its records; errors name `path`.
pub(crate) fn parse_table<T: for<'de> Deserialize<'de>>(path: &Path, text: &str) -> Result<Vec<T>, DatasetError> {
    serde_json::from_str(&python_json_to_strict(text)).map_err(|e| DatasetError::malformed(path, e.to_string()))
}

fn read_optional_table<T: for<'de> Deserialize<'de>>(dir: &Path, name: &str) -> Result<Option<Vec<T>>, DatasetError> {
    if dir.join(name).exists() {
        read_table(dir, name).map(Some)
    } else {
        Ok(None)
    }
}

impl Tables {
    /// Reads the tables from `dir` (the `v1.0-*` folder).
    ///
    /// # Errors
    /// A missing required table or one that does not match the v1.0 layout.
    pub fn read(dir: &Path) -> Result<Self, DatasetError> {
        Ok(Self {
            dir: dir.to_path_buf(),
            samples: read_table(dir, "sample.json")?,
            sample_data: read_table(dir, "sample_data.json")?,
            annotations: read_table(dir, "sample_annotation.json")?,
            instances: read_table(dir, "instance.json")?,
            categories: read_table(dir, "category.json")?,
            ego_poses: read_table(dir, "ego_pose.json")?,
            calibrated_sensors: read_table(dir, "calibrated_sensor.json")?,
            sensors: read_optional_table(dir, "sensor.json")?,
            scenes: read_optional_table(dir, "scene.json")?,
        })
    }

    /// The tables of one scene, from the text of its slice ([`crate::nuscenes_slice`]: one JSON object whose keys
    /// are the table files' names and whose values are their rows for the scene). `dir` is the table folder the
    /// slice was cut from: errors name its files.
    ///
    /// # Errors
    /// The text is not such an object, a required table is missing from it, or a row does not match the layout.
    pub fn from_slice(dir: &Path, text: &str) -> Result<Self, DatasetError> {
        let bad = |m: String| DatasetError::malformed(dir, format!("scene slice: {m}"));
        let parts: BTreeMap<String, &serde_json::value::RawValue> =
            serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        if let Some(unknown) =
            parts.keys().find(|k| !REQUIRED_TABLES.contains(&k.as_str()) && !OPTIONAL_TABLES.contains(&k.as_str()))
        {
            return Err(bad(format!("unknown table `{unknown}`")));
        }
        let optional = |name: &str| parts.get(name).map(|r| r.get());
        let required = |name: &str| optional(name).ok_or_else(|| bad(format!("no `{name}`")));
        Ok(Self {
            dir: dir.to_path_buf(),
            samples: parse_table(&dir.join("sample.json"), required("sample.json")?)?,
            sample_data: parse_table(&dir.join("sample_data.json"), required("sample_data.json")?)?,
            annotations: parse_table(&dir.join("sample_annotation.json"), required("sample_annotation.json")?)?,
            instances: parse_table(&dir.join("instance.json"), required("instance.json")?)?,
            categories: parse_table(&dir.join("category.json"), required("category.json")?)?,
            ego_poses: parse_table(&dir.join("ego_pose.json"), required("ego_pose.json")?)?,
            calibrated_sensors: parse_table(&dir.join("calibrated_sensor.json"), required("calibrated_sensor.json")?)?,
            sensors: optional("sensor.json").map(|t| parse_table(&dir.join("sensor.json"), t)).transpose()?,
            scenes: optional("scene.json").map(|t| parse_table(&dir.join("scene.json"), t)).transpose()?,
        })
    }
}

/// The tables [`Tables`] requires, in a folder or a scene slice.
pub(crate) const REQUIRED_TABLES: [&str; 7] = [
    "calibrated_sensor.json",
    "category.json",
    "ego_pose.json",
    "instance.json",
    "sample.json",
    "sample_annotation.json",
    "sample_data.json",
];

/// The tables [`Tables`] reads when they are there.
pub(crate) const OPTIONAL_TABLES: [&str; 2] = ["scene.json", "sensor.json"];

/// Whether a `sample_data` row is the LIDAR_TOP channel's.
pub(crate) enum LidarTop<'a> {
    Yes,
    No,
    /// Its calibrated sensor is not in `calibrated_sensor.json`.
    UnknownCalibration,
    /// Its calibrated sensor's sensor token (given) is not in `sensor.json`.
    UnknownSensor(&'a str),
}

/// The channel test of the reader (and of the slicer, which keeps what the reader looks at): with `sensor.json`
/// (`channels`: sensor token -> channel) by the channel of the row's calibrated sensor, whose sensor token is
/// `cal_sensor` (`None`: no such calibrated sensor; `Some(None)`: it names none); without it by the file name.
pub(crate) fn lidar_top<'a>(
    channels: Option<&BTreeMap<&str, &str>>,
    cal_sensor: Option<Option<&'a str>>,
    filename: &str,
) -> LidarTop<'a> {
    let Some(ch) = channels else {
        return if filename.contains("LIDAR_TOP") { LidarTop::Yes } else { LidarTop::No };
    };
    let Some(sensor) = cal_sensor else { return LidarTop::UnknownCalibration };
    let sensor = sensor.unwrap_or_default();
    match ch.get(sensor) {
        Some(&"LIDAR_TOP") => LidarTop::Yes,
        Some(_) => LidarTop::No,
        None => LidarTop::UnknownSensor(sensor),
    }
}

/// Finds the table folder and the dataroot: `path` is either the dataroot holding exactly one `v1.0-*` folder,
/// or the table folder itself (then the dataroot is its parent).
pub(crate) fn locate_tables(path: &Path) -> Result<(PathBuf, PathBuf), DatasetError> {
    if path.join("sample.json").exists() {
        let root = path.parent().map_or_else(PathBuf::new, Path::to_path_buf);
        return Ok((path.to_path_buf(), root));
    }
    let dirs = list_dir(path, |n| n.starts_with("v1.0-"))?;
    let dirs: Vec<PathBuf> = dirs.into_iter().filter(|d| d.join("sample.json").exists()).collect();
    match dirs.as_slice() {
        [one] => Ok((one.clone(), path.to_path_buf())),
        [] => Err(DatasetError::malformed(path, "no `v1.0-*` folder with `sample.json` (and no `sample.json` here)")),
        many => Err(DatasetError::malformed(
            path,
            format!(
                "several table folders ({}): give the table folder itself as the path",
                many.iter().filter_map(|d| d.file_name()?.to_str()).collect::<Vec<_>>().join(", ")
            ),
        )),
    }
}

#[allow(clippy::cast_precision_loss)] // microsecond timestamps < 2^53
fn seconds_of_us(us: i64) -> f64 {
    us as f64 * 1e-6
}

/// Reads the native v1.0 tables under `path` (the dataroot holding one `v1.0-*` folder, or that folder) into one
/// frame per sample (keyframe), in time order; `scene` selects one scene by name (needs `scene.json`).
///
/// Per sample: the LIDAR_TOP keyframe sweep (`samples/LIDAR_TOP/*.pcd.bin` relative to the dataroot) with its
/// calibrated extrinsic; the ego pose of that sample_data; each annotation converted from the global frame
/// into that ego frame. Speeds are central differences of the instance's global positions over neighbouring
/// annotated samples (at most 1.5 s apart), as the devkit's `box_velocity`: speed over ground.
///
/// # Errors
/// Missing or malformed tables, dangling tokens, non-unit quaternions, malformed sweeps.
pub fn open_v1(path: &Path, scene: Option<&str>, opts: &ReadOptions) -> Result<Dataset, DatasetError> {
    open_v1_with(path, scene, opts, false, None).map(|(ds, _)| ds)
}

/// [`open_v1`]; with `defer` the sweeps are not read but returned per frame (the frames' clouds `None`), for
/// [`crate::sweeps::open_deferred`]. Without `defer` each sweep is read where it always was. With `slice` (the
/// text of the scene's slice, [`crate::nuscenes_slice`]) the tables come from it instead of the table folder;
/// the frames are the same bits.
pub(crate) fn open_v1_with(
    path: &Path,
    scene: Option<&str>,
    opts: &ReadOptions,
    defer: bool,
    slice: Option<&str>,
) -> Result<(Dataset, Vec<Option<SweepFile>>), DatasetError> {
    let (table_dir, root) = locate_tables(path)?;
    let t = match slice {
        Some(text) => Tables::from_slice(&table_dir, text)?,
        None => Tables::read(&table_dir)?,
    };
    let tp = |name: &str| table_dir.join(name);
    let dangling = |table: &str, what: &str, token: &str| {
        DatasetError::malformed(&tp(table), format!("{what} token `{token}` not found"))
    };
    let ego_idx: BTreeMap<&str, usize> = t.ego_poses.iter().enumerate().map(|(i, r)| (r.token.as_str(), i)).collect();
    let cal_idx: BTreeMap<&str, usize> =
        t.calibrated_sensors.iter().enumerate().map(|(i, r)| (r.token.as_str(), i)).collect();
    let inst_idx: BTreeMap<&str, usize> = t.instances.iter().enumerate().map(|(i, r)| (r.token.as_str(), i)).collect();
    let cat_idx: BTreeMap<&str, usize> = t.categories.iter().enumerate().map(|(i, r)| (r.token.as_str(), i)).collect();
    let sensor_channel: Option<BTreeMap<&str, &str>> =
        t.sensors.as_ref().map(|s| s.iter().map(|r| (r.token.as_str(), r.channel.as_str())).collect());

    // scene selection
    let scene_token: Option<String> = match scene {
        None => None,
        Some(name) => {
            let scenes = t.scenes.as_ref().ok_or_else(|| {
                DatasetError::malformed(
                    &tp("scene.json"),
                    format!("scene `{name}` requested but there is no scene.json"),
                )
            })?;
            let found = scenes
                .iter()
                .find(|s| s.name == name)
                .ok_or_else(|| DatasetError::malformed(&tp("scene.json"), format!("no scene named `{name}`")))?;
            Some(found.token.clone())
        }
    };
    let mut samples: Vec<&Sample> =
        t.samples.iter().filter(|s| scene_token.as_ref().is_none_or(|tok| &s.scene_token == tok)).collect();
    samples.sort_by(|a, b| a.timestamp.cmp(&b.timestamp).then_with(|| a.token.cmp(&b.token)));
    if samples.windows(2).any(|w| w.first().map(|a| a.timestamp) == w.get(1).map(|b| b.timestamp)) {
        return Err(DatasetError::malformed(&tp("sample.json"), "two samples share a timestamp"));
    }
    let sample_ts: BTreeMap<&str, i64> = t.samples.iter().map(|s| (s.token.as_str(), s.timestamp)).collect();

    // LIDAR_TOP keyframe sample_data per sample
    let is_lidar_top = |sd: &SampleData| -> Result<bool, DatasetError> {
        let cal = cal_idx.get(sd.calibrated_sensor_token.as_str()).and_then(|i| t.calibrated_sensors.get(*i));
        match lidar_top(sensor_channel.as_ref(), cal.map(|c| c.sensor_token.as_deref()), &sd.filename) {
            LidarTop::Yes => Ok(true),
            LidarTop::No => Ok(false),
            LidarTop::UnknownCalibration => {
                Err(dangling("sample_data.json", "calibrated_sensor", &sd.calibrated_sensor_token))
            }
            LidarTop::UnknownSensor(sensor) => Err(dangling("calibrated_sensor.json", "sensor", sensor)),
        }
    };
    let mut lidar_of_sample: BTreeMap<&str, &SampleData> = BTreeMap::new();
    for sd in &t.sample_data {
        if sd.is_key_frame && is_lidar_top(sd)? && lidar_of_sample.insert(sd.sample_token.as_str(), sd).is_some() {
            return Err(DatasetError::malformed(
                &tp("sample_data.json"),
                format!("sample `{}` has two LIDAR_TOP keyframes", sd.sample_token),
            ));
        }
    }

    // annotations per sample, and per-instance global tracks for speeds
    let mut ann_of_sample: BTreeMap<&str, Vec<&SampleAnnotation>> = BTreeMap::new();
    let mut instance_obs: BTreeMap<&str, Vec<(i64, &str, f64, f64)>> = BTreeMap::new();
    for a in &t.annotations {
        let ts = *sample_ts
            .get(a.sample_token.as_str())
            .ok_or_else(|| dangling("sample_annotation.json", "sample", &a.sample_token))?;
        if !a.translation.iter().chain(a.size.iter()).all(|v| v.is_finite()) || !a.size.iter().all(|v| *v > 0.0) {
            return Err(DatasetError::malformed(
                &tp("sample_annotation.json"),
                format!("annotation `{}`: non-finite translation or non-positive size", a.token),
            ));
        }
        ann_of_sample.entry(a.sample_token.as_str()).or_default().push(a);
        instance_obs.entry(a.instance_token.as_str()).or_default().push((
            ts,
            a.token.as_str(),
            a.translation[0],
            a.translation[1],
        ));
    }
    let mut speed_of_ann: BTreeMap<&str, Option<f64>> = BTreeMap::new();
    for obs in instance_obs.values_mut() {
        obs.sort_by(|a, b| a.0.cmp(&b.0).then_with(|| a.1.cmp(b.1)));
        let pts: Vec<(f64, f64, f64)> = obs.iter().map(|o| (seconds_of_us(o.0), o.2, o.3)).collect();
        for (o, v) in obs.iter().zip(finite_difference_speeds(&pts, MAX_GAP_S)) {
            speed_of_ann.insert(o.1, v);
        }
    }
    // stable u64 ids: the instances seen on the samples read, numbered in token order (the same numbers whether
    // the other scenes' rows are in the tables or not: a scene read from its slice is the same bits)
    let seen: std::collections::BTreeSet<&str> = samples
        .iter()
        .filter_map(|s| ann_of_sample.get(s.token.as_str()))
        .flatten()
        .map(|a| a.instance_token.as_str())
        .collect();
    let instance_id: BTreeMap<&str, u64> =
        seen.iter().enumerate().map(|(i, k)| (*k, u64::try_from(i + 1).unwrap_or(u64::MAX))).collect();

    let mut frames = Vec::new();
    let mut files = Vec::new();
    let mut no_speed = 0usize;
    let mut missing_sweeps = 0usize;
    for s in &samples {
        let sd = lidar_of_sample.get(s.token.as_str()).ok_or_else(|| {
            DatasetError::malformed(&tp("sample_data.json"), format!("sample `{}` has no LIDAR_TOP keyframe", s.token))
        })?;
        let ego = ego_idx
            .get(sd.ego_pose_token.as_str())
            .and_then(|i| t.ego_poses.get(*i))
            .ok_or_else(|| dangling("sample_data.json", "ego_pose", &sd.ego_pose_token))?;
        let world_from_ego = Rigid3::from_quat_translation(ego.rotation, ego.translation).ok_or_else(|| {
            DatasetError::malformed(&tp("ego_pose.json"), format!("ego pose `{}`: not a unit quaternion", ego.token))
        })?;
        let cal = cal_idx
            .get(sd.calibrated_sensor_token.as_str())
            .and_then(|i| t.calibrated_sensors.get(*i))
            .ok_or_else(|| dangling("sample_data.json", "calibrated_sensor", &sd.calibrated_sensor_token))?;
        let ego_from_lidar = Rigid3::from_quat_translation(cal.rotation, cal.translation).ok_or_else(|| {
            DatasetError::malformed(
                &tp("calibrated_sensor.json"),
                format!("calibrated sensor `{}`: not a unit quaternion", cal.token),
            )
        })?;
        let ego_from_world = world_from_ego.inverse();
        let index = u64::try_from(frames.len()).unwrap_or(u64::MAX);
        let mut frame = RecordedFrame::empty(index, seconds_of_us(s.timestamp), world_from_ego.to_pose2());
        let mut extras = Vec::new();
        let mut anns = ann_of_sample.get(s.token.as_str()).cloned().unwrap_or_default();
        anns.sort_by(|a, b| a.instance_token.cmp(&b.instance_token).then_with(|| a.token.cmp(&b.token)));
        for a in anns {
            let bad = |m: &str| {
                DatasetError::malformed(&tp("sample_annotation.json"), format!("annotation `{}`: {m}", a.token))
            };
            let world_from_box = Rigid3::from_quat_translation(a.rotation, a.translation)
                .ok_or_else(|| bad("rotation is not a unit quaternion"))?;
            let ego_from_box = ego_from_world.compose(&world_from_box);
            let inst = inst_idx
                .get(a.instance_token.as_str())
                .and_then(|i| t.instances.get(*i))
                .ok_or_else(|| dangling("sample_annotation.json", "instance", &a.instance_token))?;
            let cat = cat_idx
                .get(inst.category_token.as_str())
                .and_then(|i| t.categories.get(*i))
                .ok_or_else(|| dangling("instance.json", "category", &inst.category_token))?;
            let speed = speed_of_ann.get(a.token.as_str()).copied().flatten();
            if speed.is_none() {
                no_speed += 1;
            }
            let num_points = match a.num_lidar_pts {
                Some(n) => Some(u32::try_from(n).map_err(|_| bad("num_lidar_pts out of range"))?),
                None => None,
            };
            let [w, l, h] = a.size;
            let c = ego_from_box.translation_m;
            frame.objects.push(ObjectState {
                id: instance_id.get(a.instance_token.as_str()).copied().unwrap_or(0),
                class: class_of(&cat.name),
                x_m: f32_of(c[0]),
                y_m: f32_of(c[1]),
                heading_rad: f32_of(wrap_angle(ego_from_box.yaw_rad())),
                speed_mps: f32_of(speed.unwrap_or(0.0)),
                length_m: f32_of(l),
                width_m: f32_of(w),
                uncertainty: None,
            });
            extras.push(ObjectExtra {
                track_key: a.instance_token.clone(),
                category: cat.name.clone(),
                height_m: Some(f32_of(h)),
                z_center_m: Some(f32_of(c[2])),
                num_points,
                accel_mps2: None,
            });
        }
        let mut file = None;
        if opts.load_clouds {
            let sweep = root.join(&sd.filename);
            if sweep.exists() {
                let f = SweepFile {
                    path: sweep,
                    format: SweepFormat::NuScenesPcdBin,
                    ego_from_sensor: ego_from_lidar.to_isometry3(),
                };
                if defer {
                    file = Some(f);
                } else {
                    frame.cloud = Some(f.read()?);
                }
            } else {
                missing_sweeps += 1;
            }
        }
        files.push(file);
        frames.push(DatasetFrame { frame, extras });
    }
    let mut notes = vec![
        "ego frame = nuScenes ego frame (rear-axle centre on the ground): ground_z_m = 0; points stay in \
         LIDAR_TOP with ego_from_sensor = calibrated_sensor"
            .to_string(),
        "boxes converted global -> ego with the ego pose of the LIDAR_TOP keyframe; object id = instance number \
         in token order among the instances on the samples read; speed = central difference of global positions over neighbouring samples (<= 1.5 s)"
            .to_string(),
        "only the keyframe sweep is read (nuScenes num_lidar_pts counts that sweep)".to_string(),
    ];
    if no_speed > 0 {
        notes.push(format!("{no_speed} annotations whose instance has no neighbour within 1.5 s get speed 0"));
    }
    if missing_sweeps > 0 {
        notes.push(format!("{missing_sweeps} samples have no sweep file on disk (frames without a cloud)"));
    }
    let ds = Dataset {
        info: DatasetInfo {
            name: scene.map_or_else(
                || table_dir.file_name().and_then(|s| s.to_str()).unwrap_or("nuscenes").to_string(),
                ToString::to_string,
            ),
            format: DatasetFormat::NuScenesV1,
            source: table_dir.clone(),
            ground_z_m: 0.0,
            ego_pose_known: true,
            speed_source: SpeedSource::FiniteDifferenceWorld,
            frame_period_s: Some(0.5),
            notes,
        },
        frames,
    };
    Ok((ds, files))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes() {
        assert_eq!(class_of("vehicle.bus.rigid"), ObjectClass::Truck);
        assert_eq!(class_of("human.pedestrian.adult"), ObjectClass::Pedestrian);
        assert_eq!(class_of("movable_object.barrier"), ObjectClass::Other);
        assert_eq!(class_of("traffic_cone"), ObjectClass::Other);
        assert_eq!(class_of("vehicle.motorcycle"), ObjectClass::Motorcyclist);
        assert_eq!(class_of("weird"), ObjectClass::Unknown);
    }
}
