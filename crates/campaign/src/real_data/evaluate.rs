//! Dataset-scale evaluation (`pmon evaluate`, docs/campaigns.md): the real-data experiments of `pmon reproduce`
//! over every log of a dataset, one independent task per log and part.
//!
//! - [`plan`] finds the logs of a source (`av2:DIR` with one folder per log, the scenes of nuScenes v1.0 tables,
//!   a folder of pmon recordings, ...) without reading them, and makes one [`LogTask`] per log and part: the
//!   `sensor` part (the real-sensor experiment and the clean-frame tables: frames with a LiDAR sweep) and the
//!   `tracks` part (the plausibility experiments on the labelled motion, clouds not read). Each task is seeded
//!   by its identity (family, log, part), never by its position or the worker that runs it.
//! - [`run_task`] reads that one log (a worker holds one log at a time, never the dataset) and runs the same code
//!   as `pmon reproduce` on it. A log that fails (missing or malformed files, a panic) gives a [`TaskResult`]
//!   with the error and the log's name; it never stops the campaign.
//! - [`merge`] pools the task results: the curves of each figure by adding the counts behind every point
//!   (`k` of `n`) and taking the Wilson interval of the sums, the table rows and claims per log in log order,
//!   the notes without repeats. Integer sums in a fixed order: the same bytes whatever ran the tasks.
//!
//! The per-class limits of the plausibility experiment (a configuration derived from the clean tracks) are
//! derived per log here, where `pmon reproduce` pools the logs of a family first: a task sees its log only.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fs;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use pmon_datasets::ground::GroundMode;
use pmon_datasets::nuscenes_slice::scene_of_spec;
use pmon_datasets::roi::RoiOptions;
use pmon_datasets::{
    open_deferred, open_deferred_with_slice, open_with, open_with_slice, Dataset, DatasetFormat, DatasetFrame,
    DatasetInfo, DeferredSweeps, ReadOptions, SpeedSource,
};
use pmon_monitor::MonitorParams;
use pmon_recording::RecordedFrame;
use serde::{Deserialize, Serialize};

use super::plausibility::{plausibility_experiments, TrackScene};
use super::sensor::{sensor_experiments, FrameStream, SensorSet};
use super::{mix, roi_label, RealDataOptions, RealDataResults, Table};
use crate::experiments::{Claim, Curve, Figure, FigureSpec, Point};
use crate::metrics::{CauseTally, Rate};

/// `format` of a task description.
pub const TASK_FORMAT: &str = "pmon-evaluate-task/1";
/// `format` of a task result.
pub const RESULT_FORMAT: &str = "pmon-evaluate-result/1";
/// `format` of the merged evaluation (`results.json` of `pmon evaluate`).
pub const REPORT_FORMAT: &str = "pmon-evaluate/1";

/// Which experiments a task runs on its log.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    /// The real-sensor experiment and the clean-frame tables (frames with a LiDAR sweep).
    Sensor,
    /// The plausibility experiments on the labelled tracks (clouds not read).
    Tracks,
}

impl Part {
    /// `sensor` or `tracks`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Sensor => "sensor",
            Self::Tracks => "tracks",
        }
    }
}

/// The datasets `pmon evaluate` knows: (family, label, the paper's figure, parts, reader scheme).
const FAMILIES: [(&str, &str, &str); 5] = [
    ("av2", "Argoverse 2", "beyond the paper (Fig. positionNuScenes, other data)"),
    ("nuscenes", "nuScenes", "Fig. positionNuScenes"),
    ("kitti", "KITTI object frames", "beyond the paper (Fig. positionNuScenes, other data)"),
    ("commonroad", "CommonRoad (NGSIM)", "beyond the paper"),
    ("recording", "pmon recordings", "beyond the paper (Fig. positionNuScenes, other data)"),
];

fn family(name: &str) -> Result<(&'static str, &'static str, &'static str), String> {
    FAMILIES
        .iter()
        .find(|f| f.0 == name)
        .copied()
        .ok_or_else(|| format!("unknown dataset family `{name}` (known: av2, nuscenes, kitti, commonroad, recording)"))
}

/// One task: one log (or scene, or recording) of a dataset, one part of the experiments.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LogTask {
    /// Always [`TASK_FORMAT`].
    pub format: String,
    /// Unique within a plan and usable as a file name: `<family>-<log>-<part>`.
    pub id: String,
    /// `av2`, `nuscenes`, `kitti`, `commonroad` or `recording`.
    pub family: String,
    /// The log's name (AV2 log id, nuScenes scene name, recording folder name, ...).
    pub log: String,
    /// What the reader opens (`av2:/data/av2/sensor/val/<log>`, `nuscenes-v1:/data/nuscenes#scene-0003`,
    /// `recording:/runs/drive-1`, ...).
    pub spec: String,
    /// Which experiments.
    pub part: Part,
    /// The task's seed: the campaign seed mixed with a hash of `family/log/part`.
    pub seed: u64,
    /// Magnitudes and repeats (the full sweeps of `pmon reproduce`, or the smoke ones).
    pub options: RealDataOptions,
    /// Monitor parameters (the dataset's ground height and ego footprint go over them).
    pub params: MonitorParams,
    /// A nuScenes v1.0 scene: its slice of the tables in the run folder (`tables/<scene>.json`), cut once for
    /// the whole run by [`write_scene_tables`] so that a task does not read the dataset's tables.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tables: Option<String>,
    /// The text of that slice, put into the task by the runner that ships it ([`with_scene_tables`]); never in
    /// `tasks.json`. Without it a nuScenes v1.0 task reads the table folder (the same results, slower).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene_tables: Option<String>,
}

/// A figure whose points keep their counts only (`[x, k, n]`): what a task returns, merged by addition.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CountFigure {
    /// Layout.
    pub spec: FigureSpec,
    /// Curves.
    pub curves: Vec<CountCurve>,
}

/// A curve of a [`CountFigure`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CountCurve {
    /// Label.
    pub label: String,
    /// Drawn dashed.
    pub dashed: bool,
    /// `[x, k, n]` by increasing x.
    pub points: Vec<(f64, u64, u64)>,
    /// The sensor alarms behind the points that keep them (`Point::causes`), by x.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub causes: Vec<(f64, CauseTally)>,
}

/// What one task found on its log.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LogOutput {
    /// Frames read (with a sweep for the sensor part).
    pub frames: u64,
    /// Curves with counts.
    pub figures: Vec<CountFigure>,
    /// Claims, their text naming the log.
    pub claims: Vec<Claim>,
    /// Notes.
    pub notes: Vec<String>,
    /// Tables (title, headers, rows); the rows name the log.
    pub tables: Vec<Table>,
}

/// The outcome of a task.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// The task ran.
    Ok(LogOutput),
    /// The log could not be read or checked: the error, naming the file where the reader says.
    Error(String),
}

/// A task's result: the task's identity and its outcome. No timing, no worker: the same bytes wherever it ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskResult {
    /// Always [`RESULT_FORMAT`].
    pub format: String,
    /// The task's id.
    pub id: String,
    /// The log's name.
    pub log: String,
    /// The part.
    pub part: Part,
    /// What happened.
    pub outcome: Outcome,
}

impl TaskResult {
    /// True when the task ran (its outcome is not an error).
    #[must_use]
    pub const fn is_ok(&self) -> bool {
        matches!(self.outcome, Outcome::Ok(_))
    }
}

/// A log found by [`plan`].
#[derive(Clone, Debug)]
struct LogRef {
    family: &'static str,
    log: String,
    spec: String,
    parts: &'static [Part],
}

const BOTH: &[Part] = &[Part::Sensor, Part::Tracks];
const SENSOR: &[Part] = &[Part::Sensor];
const TRACKS: &[Part] = &[Part::Tracks];

/// The sub-folders of `dir` (hidden ones left out), sorted by name.
fn sub_dirs(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let rd = fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut out = Vec::new();
    for entry in rd {
        let entry = entry.map_err(|e| format!("{}: {e}", dir.display()))?;
        let p = entry.path();
        let hidden = p.file_name().and_then(|n| n.to_str()).is_none_or(|n| n.starts_with('.'));
        if p.is_dir() && !hidden {
            out.push(p);
        }
    }
    out.sort();
    Ok(out)
}

fn name_of(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

fn is_av2_log(dir: &Path) -> bool {
    dir.join("annotations.feather").exists() || dir.join("annotations_with_ego.feather").exists()
}

fn is_recording(dir: &Path) -> bool {
    dir.join("frames.jsonl").exists() || dir.join("recording.json").exists()
}

/// The nuScenes table folder under a dataroot (or the folder itself).
fn nuscenes_tables(root: &Path) -> Result<PathBuf, String> {
    if root.join("sample.json").exists() {
        return Ok(root.to_path_buf());
    }
    let dirs: Vec<PathBuf> = sub_dirs(root)?
        .into_iter()
        .filter(|d| name_of(d).starts_with("v1.0-") && d.join("sample.json").exists())
        .collect();
    match dirs.as_slice() {
        [one] => Ok(one.clone()),
        [] => Err(format!("{}: no `v1.0-*` folder with `sample.json` (and no `sample.json` here)", root.display())),
        _ => Err(format!("{}: several `v1.0-*` table folders: give the table folder itself", root.display())),
    }
}

#[derive(Deserialize)]
struct SceneName {
    name: String,
}

fn discover(source: &str, scenes: Option<&[String]>, notes: &mut Vec<String>) -> Result<Vec<LogRef>, String> {
    let (scheme, rest) = match source.split_once(':') {
        Some((s, r)) if ["av2", "nuscenes", "kitti", "commonroad", "recordings"].contains(&s) => (s, r),
        _ => ("recordings", source),
    };
    let path = Path::new(rest);
    if !path.exists() {
        return Err(format!("{}: not found", path.display()));
    }
    if scenes.is_some() && scheme != "nuscenes" {
        return Err("a scene list (--split, --scenes) applies to nuscenes:DATAROOT only".into());
    }
    let spec = |scheme: &str, p: &Path| format!("{scheme}:{}", p.display());
    let logs = match scheme {
        "av2" => {
            let dirs = if is_av2_log(path) { vec![path.to_path_buf()] } else { sub_dirs(path)? };
            dirs.iter().map(|d| LogRef { family: "av2", log: name_of(d), spec: spec("av2", d), parts: BOTH }).collect()
        }
        "nuscenes" if path.join("sample_annotations.json").exists() => {
            vec![LogRef { family: "nuscenes", log: name_of(path), spec: spec("nuscenes", path), parts: SENSOR }]
        }
        "nuscenes" => {
            let tables = nuscenes_tables(path)?;
            let scene_file = tables.join("scene.json");
            let text = fs::read_to_string(&scene_file).map_err(|e| format!("{}: {e}", scene_file.display()))?;
            let mut names: Vec<String> = serde_json::from_str::<Vec<SceneName>>(&text)
                .map_err(|e| format!("{}: {e}", scene_file.display()))?
                .into_iter()
                .map(|s| s.name)
                .collect();
            names.sort();
            names.dedup();
            if let Some(wanted) = scenes {
                let missing: Vec<&String> = wanted.iter().filter(|w| !names.contains(w)).collect();
                if !missing.is_empty() {
                    notes.push(format!(
                        "{} of the {} scenes asked for are not in {} (first: {})",
                        missing.len(),
                        wanted.len(),
                        scene_file.display(),
                        missing.first().map_or("", |s| s.as_str())
                    ));
                }
                names.retain(|n| wanted.contains(n));
            }
            names
                .into_iter()
                .map(|n| LogRef {
                    family: "nuscenes",
                    spec: format!("nuscenes-v1:{}#{n}", path.display()),
                    log: n,
                    parts: BOTH,
                })
                .collect()
        }
        "kitti" => vec![LogRef { family: "kitti", log: name_of(path), spec: spec("kitti", path), parts: SENSOR }],
        "commonroad" => {
            let files = if path.is_dir() {
                let rd = fs::read_dir(path).map_err(|e| format!("{}: {e}", path.display()))?;
                let mut v: Vec<PathBuf> = rd
                    .filter_map(Result::ok)
                    .map(|e| e.path())
                    .filter(|p| p.extension().is_some_and(|x| x == "xml"))
                    .collect();
                v.sort();
                v
            } else {
                vec![path.to_path_buf()]
            };
            files
                .iter()
                .map(|f| LogRef {
                    family: "commonroad",
                    log: name_of(f).trim_end_matches(".xml").to_string(),
                    spec: spec("commonroad", f),
                    parts: TRACKS,
                })
                .collect()
        }
        _ => {
            let dirs = if is_recording(path) { vec![path.to_path_buf()] } else { sub_dirs(path)? };
            dirs.iter()
                .map(|d| LogRef { family: "recording", log: name_of(d), spec: spec("recording", d), parts: BOTH })
                .collect()
        }
    };
    Ok(logs)
}

/// FNV-1a, 64 bits: a stable hash of a task's identity (the same on every platform and in every version).
pub(crate) fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

fn file_safe(text: &str) -> String {
    text.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') { c } else { '_' }).collect()
}

/// A plan: the tasks, sorted by id, and what was noticed while finding the logs.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The tasks, sorted by id.
    pub tasks: Vec<LogTask>,
    /// Notes (scenes asked for but absent, ...).
    pub notes: Vec<String>,
}

/// Finds the logs of `source` and makes the tasks. `source`: `av2:DIR` (a folder of logs, or one log),
/// `nuscenes:DATAROOT` (native v1.0 tables: one task per scene, `scenes` keeps the named ones; or the
/// converted keyframe folder), `kitti:DIR`, `commonroad:DIR|FILE`, `recordings:DIR` or a plain folder (of pmon
/// recordings, or one recording). Nothing is read but folder listings (and nuScenes' `scene.json`).
///
/// # Errors
/// The source does not exist, is not a folder of the kind, or no log was found; two logs with the same id.
pub fn plan(
    source: &str,
    scenes: Option<&[String]>,
    seed: u64,
    options: &RealDataOptions,
    params: &MonitorParams,
) -> Result<Plan, String> {
    let mut notes = Vec::new();
    let logs = discover(source, scenes, &mut notes)?;
    if logs.is_empty() {
        return Err(format!("{source}: no log found"));
    }
    let mut tasks: BTreeMap<String, LogTask> = BTreeMap::new();
    for l in logs {
        for &part in l.parts {
            let id = format!("{}-{}-{}", l.family, file_safe(&l.log), part.name());
            let task = LogTask {
                format: TASK_FORMAT.into(),
                id: id.clone(),
                family: l.family.into(),
                log: l.log.clone(),
                spec: l.spec.clone(),
                part,
                seed: mix(seed, fnv1a(&format!("{}/{}/{}", l.family, l.log, part.name()))),
                options: options.clone(),
                params: *params,
                tables: scene_of_spec(&l.spec).map(|_| scene_tables_path(&l.log)),
                scene_tables: None,
            };
            if tasks.insert(id.clone(), task).is_some() {
                return Err(format!("two logs give the task id `{id}`: rename one"));
            }
        }
    }
    Ok(Plan { tasks: tasks.into_values().collect(), notes })
}

/// Where a nuScenes v1.0 scene's slice of the tables goes in the run folder.
fn scene_tables_path(scene: &str) -> String {
    format!("tables/{}.json", file_safe(scene))
}

/// Cuts the tables of the given nuScenes v1.0 scene tasks into slices (`pmon_datasets::nuscenes_slice`), one
/// file per scene in `run_dir` (the task's `tables`), reading each dataset's tables once. Slices already there
/// (a resumed run) are kept; each file is written under a temporary name and renamed. Returns the number of
/// slices written.
///
/// # Errors
/// A table the slicer cannot read (naming the file, and the line of a malformed row), or a write error.
pub fn write_scene_tables<'t>(tasks: impl IntoIterator<Item = &'t LogTask>, run_dir: &Path) -> Result<usize, String> {
    // dataroot -> (scene, slice file), each scene once
    let mut wanted: BTreeMap<&Path, BTreeMap<String, PathBuf>> = BTreeMap::new();
    for t in tasks {
        let (Some(rel), Some((root, scene))) = (&t.tables, scene_of_spec(&t.spec)) else { continue };
        let file = run_dir.join(rel);
        if !file.exists() {
            wanted.entry(root).or_default().insert(scene.to_string(), file);
        }
    }
    let mut written = 0;
    for (root, scenes) in wanted {
        let names: Vec<String> = scenes.keys().cloned().collect();
        pmon_datasets::nuscenes_slice::slice_scenes(root, &names, |scene, text| {
            let Some(file) = scenes.get(scene) else { return Ok(()) };
            let io = |e: std::io::Error| pmon_datasets::DatasetError::Io { path: file.clone(), source: e };
            if let Some(dir) = file.parent() {
                fs::create_dir_all(dir).map_err(io)?;
            }
            let tmp = file.with_extension(format!("json.tmp-{}", std::process::id()));
            fs::write(&tmp, text).map_err(io)?;
            fs::rename(&tmp, file).map_err(io)?;
            written += 1;
            Ok(())
        })
        .map_err(|e| e.to_string())?;
    }
    Ok(written)
}

/// The task as a runner ships it: with its nuScenes v1.0 slice's text read from `run_dir` (unchanged when it has
/// none, or when the file is gone: it then reads the table folder, with the same results).
#[must_use]
pub fn with_scene_tables<'t>(task: &'t LogTask, run_dir: &Path) -> Cow<'t, LogTask> {
    match task.tables.as_ref().and_then(|rel| fs::read_to_string(run_dir.join(rel)).ok()) {
        Some(text) => Cow::Owned(LogTask { scene_tables: Some(text), ..task.clone() }),
        None => Cow::Borrowed(task),
    }
}

/// A recording's parameters: `base` with the ground height and ego footprint of its `params.toml`, if any.
fn recording_params(path: &Path, base: MonitorParams) -> Result<MonitorParams, String> {
    let mut params = base;
    let sidecar = path.join("params.toml");
    if sidecar.is_file() {
        let text = fs::read_to_string(&sidecar).map_err(|e| format!("{}: {e}", sidecar.display()))?;
        let table: toml::Table = text.parse().map_err(|e| format!("{}: {e}", sidecar.display()))?;
        if let Some(z) = table.get("ground_z_m").and_then(toml::Value::as_float) {
            params.ground_z_m = z as f32;
        }
        if let Some(fp) = table.get("ego_footprint_m").and_then(toml::Value::as_array) {
            let v: Vec<f32> = fp.iter().filter_map(toml::Value::as_float).map(|x| x as f32).collect();
            params.ego_footprint_m =
                v.try_into().map_err(|_| format!("{}: ego_footprint_m needs 4 numbers", sidecar.display()))?;
        }
    }
    Ok(params)
}

/// The path of a recording task.
fn recording_path(task: &LogTask) -> PathBuf {
    PathBuf::from(task.spec.strip_prefix("recording:").unwrap_or(&task.spec))
}

/// Reads the task's log: a dataset reader, or a pmon recording (with its `params.toml`: ground height and ego
/// footprint). Returns the dataset and the parameters for it.
fn open_log(task: &LogTask, load_clouds: bool) -> Result<(Dataset, MonitorParams), String> {
    let base = task.params;
    if task.family == "recording" {
        let path = recording_path(task);
        // Frame by frame, each cloud dropped as soon as it is read when the clouds are not wanted.
        let reader = pmon_recording::RecordingReader::open(&path).map_err(|e| e.to_string())?;
        let frames = reader
            .map(|f| {
                let mut f = f.map_err(|e| e.to_string())?;
                if !load_clouds {
                    f.cloud = None;
                }
                Ok(DatasetFrame { frame: f, extras: Vec::new() })
            })
            .collect::<Result<Vec<_>, String>>()?;
        let params = recording_params(&path, base)?;
        let info = DatasetInfo {
            // The folder's name: recordings of one simulator share their `name`.
            name: task.log.clone(),
            format: DatasetFormat::Recording,
            source: path,
            ground_z_m: params.ground_z_m,
            ego_pose_known: true,
            speed_source: SpeedSource::Dataset,
            frame_period_s: None,
            notes: Vec::new(),
        };
        return Ok((Dataset { info, frames }, params));
    }
    let roi = RoiOptions { grid_half_extent_m: 0.5 * f64::from(base.grid_size_m), ..RoiOptions::default() };
    let opts = ReadOptions { load_clouds, roi, ground: GroundMode::Auto };
    let ds = match &task.scene_tables {
        Some(slice) => open_with_slice(&task.spec, &opts, slice),
        None => open_with(&task.spec, &opts),
    }
    .map_err(|e| e.to_string())?;
    let params =
        MonitorParams { ground_z_m: ds.info.ground_z_m, ego_footprint_m: ds.info.format.ego_footprint_m(), ..base };
    Ok((ds, params))
}

/// Where a `sensor` task's frames come from.
enum SensorSource {
    /// A pmon recording: read frame by frame from its `frames.jsonl`, once per pass.
    Recording(PathBuf),
    /// A dataset's log (Argoverse 2, KITTI object frames, nuScenes keyframe or v1.0 scene): its annotations, poses
    /// and map read first ([`open_deferred`]), then one sweep per frame, once per pass.
    Deferred(Box<(Dataset, DeferredSweeps)>),
}

impl SensorSource {
    /// Opens the task's log for the sensor part: the source, the parameters and the ROI label.
    fn open(task: &LogTask) -> Result<(Self, MonitorParams, String), String> {
        if task.family == "recording" {
            let path = recording_path(task);
            let params = recording_params(&path, task.params)?;
            return Ok((Self::Recording(path), params, "none".to_string()));
        }
        let roi = RoiOptions { grid_half_extent_m: 0.5 * f64::from(task.params.grid_size_m), ..RoiOptions::default() };
        let opts = ReadOptions { load_clouds: true, roi, ground: GroundMode::Auto };
        let (ds, sweeps) = match &task.scene_tables {
            Some(slice) => open_deferred_with_slice(&task.spec, &opts, slice),
            None => open_deferred(&task.spec, &opts),
        }
        .map_err(|e| e.to_string())?;
        let params = MonitorParams {
            ground_z_m: ds.info.ground_z_m,
            ego_footprint_m: ds.info.format.ego_footprint_m(),
            ..task.params
        };
        let roi = ds.roi_note().map_or_else(|| "none".to_string(), roi_label);
        Ok((Self::Deferred(Box::new((ds, sweeps))), params, roi))
    }

    /// One reading of the frames with a LiDAR sweep.
    fn frames(&self) -> Result<FrameStream<'_>, String> {
        Ok(match self {
            Self::Recording(path) => {
                let reader = pmon_recording::RecordingReader::open(path).map_err(|e| e.to_string())?;
                Box::new(reader.filter_map(|f| match f {
                    Ok(frame) if frame.cloud.is_none() => None,
                    Ok(frame) => Some(Ok(Cow::Owned(DatasetFrame { frame, extras: Vec::new() }))),
                    Err(e) => Some(Err(e.to_string())),
                }))
            }
            Self::Deferred(log) => {
                let (ds, sweeps) = &**log;
                Box::new(ds.frames.iter().enumerate().filter(|(i, _)| sweeps.has_sweep(*i)).map(|(i, f)| {
                    let cloud = sweeps.cloud(i).map_err(|e| e.to_string())?;
                    Ok(Cow::Owned(DatasetFrame {
                        frame: RecordedFrame { cloud, ..f.frame.clone() },
                        extras: f.extras.clone(),
                    }))
                }))
            }
        })
    }
}

fn count_figure(f: &Figure) -> CountFigure {
    CountFigure {
        spec: f.spec.clone(),
        curves: f
            .curves
            .iter()
            .map(|c| CountCurve {
                label: c.label.clone(),
                dashed: c.dashed,
                points: c.points.iter().map(|p| (p.x, p.rate.k, p.rate.n)).collect(),
                causes: c.points.iter().filter_map(|p| Some((p.x, p.causes?))).collect(),
            })
            .collect(),
    }
}

fn run_task_inner(task: &LogTask) -> Result<LogOutput, String> {
    if task.format != TASK_FORMAT {
        return Err(format!("task format `{}`, expected `{TASK_FORMAT}`", task.format));
    }
    let (key, label, paper_ref) = family(&task.family)?;
    let mut out = RealDataResults { figures: Vec::new(), claims: Vec::new(), notes: Vec::new(), tables: Vec::new() };
    let frames;
    match task.part {
        Part::Sensor => {
            let (source, params, roi) = SensorSource::open(task)?;
            let mut set = SensorSet {
                key,
                name: format!("{label} {}", task.log),
                paper_ref,
                params,
                frames: Box::new(|| source.frames()),
                roi,
            };
            let counts = sensor_experiments(std::slice::from_mut(&mut set), task.seed, &task.options, &mut out)?;
            frames = counts.first().copied().unwrap_or(0) as u64;
            if frames == 0 {
                out.notes
                    .push(format!("{label} {}: no frame with a LiDAR sweep, sensor experiments skipped", task.log));
            }
        }
        Part::Tracks => {
            let (ds, params) = open_log(task, false)?;
            frames = ds.frames.len() as u64;
            let scene = TrackScene::new(key, label, &ds, &params);
            plausibility_experiments(std::slice::from_ref(&scene), task.seed, &task.options, &mut out)?;
        }
    }
    Ok(LogOutput {
        frames,
        figures: out.figures.iter().map(count_figure).collect(),
        claims: out
            .claims
            .into_iter()
            .map(|c| Claim { pmon: format!("[{} {}] {}", task.family, task.log, c.pmon), ..c })
            .collect(),
        notes: out.notes,
        tables: out.tables,
    })
}

/// Runs one task in this process. Never fails: an unreadable log, a monitor error or a panic becomes an
/// [`Outcome::Error`] that names the log.
#[must_use]
pub fn run_task(task: &LogTask) -> TaskResult {
    let outcome = match catch_unwind(AssertUnwindSafe(|| run_task_inner(task))) {
        Ok(Ok(out)) => Outcome::Ok(out),
        Ok(Err(e)) => Outcome::Error(format!("{} ({}): {e}", task.log, task.spec)),
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| (*s).to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Outcome::Error(format!("{} ({}): internal error (panic: {what})", task.log, task.spec))
        }
    };
    TaskResult { format: RESULT_FORMAT.into(), id: task.id.clone(), log: task.log.clone(), part: task.part, outcome }
}

/// Runs a task given as JSON and returns its result as JSON (the call a Dask or Ray worker makes).
///
/// # Errors
/// The JSON is not a [`LogTask`]. (A task that fails on its data is an `Ok` result holding the error.)
pub fn run_task_json(task_json: &str) -> Result<String, String> {
    let task: LogTask = serde_json::from_str(task_json).map_err(|e| format!("task: {e}"))?;
    result_json(&run_task(&task))
}

/// A result as the text of its file: pretty JSON with a final newline.
///
/// # Errors
/// Serialisation (not expected).
pub fn result_json(r: &TaskResult) -> Result<String, String> {
    serde_json::to_string_pretty(r).map(|s| s + "\n").map_err(|e| format!("internal: {e}"))
}

/// A task that did not run, with its error.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Failure {
    /// Task id.
    pub id: String,
    /// The log.
    pub log: String,
    /// The part.
    pub part: Part,
    /// The error.
    pub error: String,
}

/// One task as the report lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TaskSummary {
    /// Task id.
    pub id: String,
    /// Dataset family.
    pub family: String,
    /// The log.
    pub log: String,
    /// The part.
    pub part: Part,
    /// Frames the task read (0 when it failed).
    pub frames: u64,
}

/// The merged evaluation: what `results.json` of `pmon evaluate` holds (no timing, no worker, no engine).
#[derive(Clone, Debug, Serialize)]
pub struct Evaluation {
    /// Always [`REPORT_FORMAT`].
    pub format: &'static str,
    /// Every task, sorted by id.
    pub tasks: Vec<TaskSummary>,
    /// The tasks that failed, with their errors (also counted in `tasks`).
    pub failed: Vec<Failure>,
    /// The merged results, in the layout of `pmon reproduce`'s `real_data`.
    pub real_data: RealDataResults,
}

struct MergedCurve {
    label: String,
    dashed: bool,
    /// (x, k, n) in first-seen order of x.
    points: Vec<(f64, u64, u64)>,
    /// The alarms by cause, summed per x.
    causes: Vec<(f64, CauseTally)>,
}

struct MergedFigure {
    spec: FigureSpec,
    family: String,
    logs: Vec<String>,
    curves: Vec<MergedCurve>,
}

/// Merges the results of a plan's tasks (in the order of `tasks`, i.e. by id; the order of `results` does not
/// matter). A task without a result, or whose result belongs to another task, is a failure.
#[must_use]
pub fn merge(tasks: &[LogTask], results: &BTreeMap<String, TaskResult>) -> Evaluation {
    let mut summaries = Vec::new();
    let mut failed = Vec::new();
    let mut figures: Vec<MergedFigure> = Vec::new();
    let mut tables: Vec<Table> = Vec::new();
    let mut claims = Vec::new();
    let mut notes: Vec<String> = Vec::new();
    for t in tasks {
        let fail = |error: String| Failure { id: t.id.clone(), log: t.log.clone(), part: t.part, error };
        let mut frames = 0;
        match results.get(&t.id) {
            None => failed.push(fail("no result (the task did not finish)".into())),
            Some(r) if r.id != t.id || r.log != t.log || r.part != t.part => {
                failed.push(fail(format!("the result file holds task `{}`", r.id)));
            }
            Some(TaskResult { outcome: Outcome::Error(e), .. }) => failed.push(fail(e.clone())),
            Some(TaskResult { outcome: Outcome::Ok(out), .. }) => {
                frames = out.frames;
                for f in &out.figures {
                    let m = match figures.iter_mut().find(|m| m.spec.id == f.spec.id) {
                        Some(m) => m,
                        None => {
                            figures.push(MergedFigure {
                                spec: f.spec.clone(),
                                family: t.family.clone(),
                                logs: Vec::new(),
                                curves: Vec::new(),
                            });
                            let Some(m) = figures.last_mut() else { continue };
                            m
                        }
                    };
                    m.logs.push(t.log.clone());
                    for c in &f.curves {
                        let mc = match m.curves.iter_mut().find(|mc| mc.label == c.label) {
                            Some(mc) => mc,
                            None => {
                                m.curves.push(MergedCurve {
                                    label: c.label.clone(),
                                    dashed: c.dashed,
                                    points: Vec::new(),
                                    causes: Vec::new(),
                                });
                                let Some(mc) = m.curves.last_mut() else { continue };
                                mc
                            }
                        };
                        for &(x, k, n) in &c.points {
                            match mc.points.iter_mut().find(|p| p.0.to_bits() == x.to_bits()) {
                                Some(p) => {
                                    p.1 += k;
                                    p.2 += n;
                                }
                                None => mc.points.push((x, k, n)),
                            }
                        }
                        for (x, t) in &c.causes {
                            match mc.causes.iter_mut().find(|p| p.0.to_bits() == x.to_bits()) {
                                Some(p) => p.1.add(t),
                                None => mc.causes.push((*x, *t)),
                            }
                        }
                    }
                }
                for (title, headers, rows) in &out.tables {
                    match tables.iter_mut().find(|(t, h, _)| t == title && h == headers) {
                        Some((_, _, r)) => r.extend(rows.iter().cloned()),
                        None => tables.push((title.clone(), headers.clone(), rows.clone())),
                    }
                }
                claims.extend(out.claims.iter().cloned());
                for n in &out.notes {
                    if !notes.contains(n) {
                        notes.push(n.clone());
                    }
                }
            }
        }
        summaries.push(TaskSummary {
            id: t.id.clone(),
            family: t.family.clone(),
            log: t.log.clone(),
            part: t.part,
            frames,
        });
    }
    let figures: Vec<Figure> = figures
        .into_iter()
        .map(|m| {
            let label = family(&m.family).map_or(m.family.as_str(), |f| f.1);
            let what = m.spec.title.split_once(": ").map_or(m.spec.title.as_str(), |(a, _)| a);
            let n = m.logs.len();
            let title = format!("{what}: {label}, pooled over {n} log{}", if n == 1 { "" } else { "s" });
            Figure {
                spec: FigureSpec { title, ..m.spec },
                curves: m
                    .curves
                    .into_iter()
                    .map(|c| Curve {
                        label: c.label,
                        dashed: c.dashed,
                        points: c
                            .points
                            .into_iter()
                            .map(|(x, k, n)| Point {
                                causes: c.causes.iter().find(|p| p.0.to_bits() == x.to_bits()).map(|p| p.1),
                                ..Point::new(x, Rate::wilson(k, n))
                            })
                            .collect(),
                    })
                    .collect(),
            }
        })
        .collect();
    if !failed.is_empty() {
        notes.insert(
            0,
            format!(
                "{} of {} tasks FAILED and are not in the figures (see `failed`): {}",
                failed.len(),
                tasks.len(),
                failed.iter().map(|f| format!("{} {}", f.log, f.part.name())).collect::<Vec<_>>().join(", ")
            ),
        );
    }
    Evaluation {
        format: REPORT_FORMAT,
        tasks: summaries,
        failed,
        real_data: RealDataResults { figures, claims, notes, tables },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder_of(names: &[&str], tag: &str) -> PathBuf {
        let root = std::env::temp_dir().join(format!("pmon-eval-plan-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&root);
        for n in names {
            fs::create_dir_all(root.join(n)).unwrap_or_else(|e| panic!("{e}"));
        }
        root
    }

    #[test]
    fn tasks_are_seeded_by_identity_not_by_position() {
        let opts = RealDataOptions::smoke();
        let p = MonitorParams::PAPER;
        let two = folder_of(&["a", "zz"], "two");
        let one = folder_of(&["zz"], "one");
        let plan2 = plan(two.to_str().unwrap_or_default(), None, 9, &opts, &p).unwrap_or_else(|e| panic!("{e}"));
        let plan1 = plan(one.to_str().unwrap_or_default(), None, 9, &opts, &p).unwrap_or_else(|e| panic!("{e}"));
        let seeds = |pl: &Plan| pl.tasks.iter().map(|t| (t.id.clone(), t.seed)).collect::<BTreeMap<_, _>>();
        let (s1, s2) = (seeds(&plan1), seeds(&plan2));
        assert_eq!(plan2.tasks.len(), 4);
        assert_eq!(s1.len(), 2);
        for (id, seed) in &s1 {
            assert_eq!(s2.get(id), Some(seed), "{id}");
        }
        // Another campaign seed, other task seeds; parts of one log have different seeds.
        let other = plan(one.to_str().unwrap_or_default(), None, 10, &opts, &p).unwrap_or_else(|e| panic!("{e}"));
        assert!(other.tasks.iter().all(|t| s1.get(&t.id) != Some(&t.seed)));
        assert_ne!(plan1.tasks.first().map(|t| t.seed), plan1.tasks.get(1).map(|t| t.seed));
        let _ = fs::remove_dir_all(two);
        let _ = fs::remove_dir_all(one);
    }

    #[test]
    fn a_missing_result_or_a_foreign_one_is_a_failure_not_dropped() {
        let root = folder_of(&["a", "b"], "merge");
        let pl = plan(root.to_str().unwrap_or_default(), None, 1, &RealDataOptions::smoke(), &MonitorParams::PAPER)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut results = BTreeMap::new();
        let first = pl.tasks.first().map(|t| t.id.clone()).unwrap_or_default();
        let second = pl.tasks.get(1).map(|t| t.id.clone()).unwrap_or_default();
        results.insert(
            first.clone(),
            TaskResult {
                format: RESULT_FORMAT.into(),
                id: second,
                log: "a".into(),
                part: Part::Sensor,
                outcome: Outcome::Ok(LogOutput::default()),
            },
        );
        let ev = merge(&pl.tasks, &results);
        assert_eq!(ev.tasks.len(), 4);
        assert_eq!(ev.failed.len(), 4, "{:?}", ev.failed);
        assert!(ev.failed.iter().any(|f| f.id == first && f.error.contains("holds task")));
        assert!(ev.real_data.notes.first().is_some_and(|n| n.contains("4 of 4 tasks FAILED")));
        let _ = fs::remove_dir_all(root);
    }
}
