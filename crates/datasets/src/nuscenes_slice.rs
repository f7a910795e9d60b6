//! nuScenes v1.0 tables cut into one slice per scene, reading each table once.
//!
//! A dataset-scale evaluation (`pmon evaluate nuscenes:DATAROOT`) runs one task per scene. Reading the whole
//! tables in every task (trainval's `sample_data.json`, `ego_pose.json` and `sample_annotation.json` are millions
//! of rows) would cost each task the whole dataset's labels in time and memory. Instead the tables are read once,
//! when the run is planned, and each scene gets a *slice*: the rows of every table that reading that scene looks
//! at, as their original JSON text. [`crate::nuscenes::Tables::from_slice`] reads a slice; the frames it gives
//! are the same bits as reading the scene from the table folder (the rows are the same text, parsed by the same
//! code).
//!
//! A scene's slice holds:
//! - `scene.json`: the scene's row;
//! - `sample_annotation.json`: every annotation of each instance annotated on one of the scene's samples (in the
//!   table's order), so the finite-difference speeds see the same neighbours;
//! - `sample.json`: the scene's samples and those the annotations above are on;
//! - `sample_data.json`: the scene's keyframe rows that are LIDAR_TOP, or whose sensor cannot be told (a dangling
//!   token: reading the scene reports it, as it would from the folder); the other rows are never looked at;
//! - `ego_pose.json`, `calibrated_sensor.json`, `instance.json`: the rows these reference;
//! - `sensor.json`, `category.json`: whole (a few dozen rows).
//!
//! What differs from reading the folder: a row that is malformed or dangling is reported when the slices are cut
//! (an annotation on no sample of the tables: an error naming `sample_annotation.json` and the token), or, when it
//! belongs to one scene, by that scene's task alone. Read from the folder, it failed every scene.

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

use serde::Deserialize;
use serde_json::value::RawValue;

use crate::nuscenes::{lidar_top, locate_tables, parse_table, LidarTop, REQUIRED_TABLES};
use crate::util::{python_json_to_strict, read_text};
use crate::DatasetError;

/// The fields of a `sample_data.json` row that slicing looks at, borrowed from the table's text. They have the
/// types of [`crate::nuscenes::SampleData`]'s, so a row that passes here is read there.
#[derive(Deserialize)]
struct SampleDataRow<'a> {
    #[allow(dead_code)] // checked for its type
    #[serde(borrow)]
    token: Cow<'a, str>,
    #[serde(borrow)]
    sample_token: Cow<'a, str>,
    #[serde(borrow)]
    ego_pose_token: Cow<'a, str>,
    #[serde(borrow)]
    calibrated_sensor_token: Cow<'a, str>,
    #[serde(borrow)]
    filename: Cow<'a, str>,
    #[allow(dead_code)] // checked for its type
    timestamp: i64,
    is_key_frame: bool,
}

/// An `ego_pose.json` or `calibrated_sensor.json` row ([`crate::nuscenes::PoseRecord`]'s types).
#[derive(Deserialize)]
struct PoseRow<'a> {
    #[serde(borrow)]
    token: Cow<'a, str>,
    #[allow(dead_code)]
    translation: [f64; 3],
    #[allow(dead_code)]
    rotation: [f64; 4],
    #[serde(default, borrow)]
    sensor_token: Option<Cow<'a, str>>,
}

/// A `sample_annotation.json` row ([`crate::nuscenes::SampleAnnotation`]'s types).
#[derive(Deserialize)]
struct AnnotationRow<'a> {
    #[allow(dead_code)]
    #[serde(borrow)]
    token: Cow<'a, str>,
    #[serde(borrow)]
    sample_token: Cow<'a, str>,
    #[serde(borrow)]
    instance_token: Cow<'a, str>,
    #[allow(dead_code)]
    translation: [f64; 3],
    #[allow(dead_code)]
    size: [f64; 3],
    #[allow(dead_code)]
    rotation: [f64; 4],
    #[allow(dead_code)]
    #[serde(default)]
    num_lidar_pts: Option<i64>,
}

/// A row with a token only, for the small tables ([`crate::nuscenes::Instance`], [`crate::nuscenes::Sensor`],
/// [`crate::nuscenes::Category`] are parsed whole to check their types).
#[derive(Deserialize)]
struct TokenRow<'a> {
    #[serde(borrow)]
    token: Cow<'a, str>,
}

/// A table file's text made strict (Python's `NaN` as `null`), kept while its rows are borrowed.
struct TableText {
    path: std::path::PathBuf,
    text: String,
}

impl TableText {
    fn read(dir: &Path, name: &str) -> Result<Option<Self>, DatasetError> {
        let path = dir.join(name);
        if !path.exists() {
            return Ok(None);
        }
        let raw = read_text(&path)?;
        let text = match python_json_to_strict(&raw) {
            Cow::Borrowed(_) => raw,
            Cow::Owned(s) => s,
        };
        Ok(Some(Self { path, text }))
    }

    fn required(dir: &Path, name: &str) -> Result<Self, DatasetError> {
        Self::read(dir, name)?.ok_or_else(|| {
            DatasetError::io(&dir.join(name), std::io::Error::new(std::io::ErrorKind::NotFound, "not found"))
        })
    }

    /// The rows: each one's text and its fields as `T`. A file that is not an array, or a row that is not a `T`,
    /// is an error naming the file and the row's line.
    fn rows<'t, T: Deserialize<'t>>(&'t self) -> Result<Vec<(&'t str, T)>, DatasetError> {
        self.each_row()?.collect()
    }

    /// [`Self::rows`] one at a time (the big tables: only the rows kept are held).
    fn each_row<'t, T: Deserialize<'t>>(
        &'t self,
    ) -> Result<impl Iterator<Item = Result<(&'t str, T), DatasetError>> + 't, DatasetError> {
        let raws: Vec<&'t RawValue> =
            serde_json::from_str(&self.text).map_err(|e| DatasetError::malformed(&self.path, e.to_string()))?;
        Ok(raws.into_iter().map(move |r| {
            let row = r.get();
            serde_json::from_str::<T>(row).map(|t| (row, t)).map_err(|e| {
                // the row's own position is relative to the row: give the file's line instead
                let offset = (row.as_ptr() as usize).saturating_sub(self.text.as_ptr() as usize);
                let line = 1 + self.text.get(..offset).map_or(0, |s| s.matches('\n').count()) + e.line() - 1;
                let msg = e.to_string();
                let suffix = format!(" at line {} column {}", e.line(), e.column());
                let msg = msg.strip_suffix(&suffix).unwrap_or(&msg);
                DatasetError::malformed(&self.path, format!("line {line}: {msg}"))
            })
        }))
    }

    /// Checks every row against the reader's record type `T` (small tables), as the reader parses them.
    fn check<T: for<'de> Deserialize<'de>>(&self) -> Result<(), DatasetError> {
        parse_table::<T>(&self.path, &self.text).map(drop)
    }
}

/// One scene's rows, table by table, in the tables' order.
#[derive(Clone, Default)]
struct Slice {
    tables: BTreeMap<&'static str, Vec<String>>,
}

impl Slice {
    fn push(&mut self, table: &'static str, row: &str) {
        self.tables.entry(table).or_default().push(row.to_string());
    }

    /// The slice's text: `{"table.json": [rows...], ...}` with the rows as they were in the files.
    fn text(&self, whole: &BTreeMap<&'static str, String>) -> String {
        let mut names: BTreeSet<&'static str> = self.tables.keys().copied().collect();
        names.extend(whole.keys().copied());
        names.extend(REQUIRED_TABLES); // empty when the scene has none of their rows
        let mut out = String::from("{");
        for (k, name) in names.iter().enumerate() {
            if k > 0 {
                out.push(',');
            }
            let _ = write!(out, "\n\"{name}\": ");
            if let Some(rows) = whole.get(name) {
                out.push_str(rows);
            } else {
                out.push('[');
                for (i, r) in self.tables.get(name).into_iter().flatten().enumerate() {
                    out.push_str(if i == 0 { "\n" } else { ",\n" });
                    out.push_str(r);
                }
                out.push_str("\n]");
            }
        }
        out.push_str("\n}\n");
        out
    }
}

/// The dataroot (or table folder) and the scene of a `nuscenes-v1:PATH#scene` spec, read as [`crate::open`]
/// reads it; `None` for any other spec (a slice is for one scene).
#[must_use]
pub fn scene_of_spec(spec: &str) -> Option<(&Path, &str)> {
    match crate::Spec::parse(spec) {
        Ok(crate::Spec::NuScenesV1(path, Some(scene))) => Some((path, scene)),
        _ => None,
    }
}

/// Cuts the v1.0 tables under `path` (a dataroot holding one `v1.0-*` folder, or that folder) into one slice per
/// scene named in `scenes`, reading each table once, and hands each slice's text to `emit(scene name, text)` in
/// the order of `scenes`. Memory: one table's text at a time, the kept rows, and `sample_annotation.json`'s
/// text while the slices are written.
///
/// # Errors
/// A missing required table (`scene.json` is required here), a malformed row (naming the file and line), a
/// scene name that is not in `scene.json`, an annotation whose sample is in no table row, or `emit`'s error.
pub fn slice_scenes(
    path: &Path,
    scenes: &[String],
    mut emit: impl FnMut(&str, String) -> Result<(), DatasetError>,
) -> Result<(), DatasetError> {
    let (dir, _) = locate_tables(path)?;
    // scene.json: the scenes asked for
    let scene_text = TableText::required(&dir, "scene.json")?;
    scene_text.check::<crate::nuscenes::Scene>()?;
    #[derive(Deserialize)]
    struct SceneRow<'a> {
        #[serde(borrow)]
        token: Cow<'a, str>,
        #[serde(borrow)]
        name: Cow<'a, str>,
    }
    let mut slices: BTreeMap<String, Slice> = BTreeMap::new(); // by scene token
    let mut token_of_name: BTreeMap<String, String> = BTreeMap::new();
    for (row, s) in scene_text.rows::<SceneRow<'_>>()? {
        if scenes.iter().any(|n| *n == s.name) && !token_of_name.contains_key(s.name.as_ref()) {
            token_of_name.insert(s.name.to_string(), s.token.to_string());
            slices.entry(s.token.to_string()).or_default().push("scene.json", row);
        }
    }
    if let Some(missing) = scenes.iter().find(|n| !token_of_name.contains_key(n.as_str())) {
        return Err(DatasetError::malformed(&scene_text.path, format!("no scene named `{missing}`")));
    }
    drop(scene_text);

    // sample.json: every row kept (a few per cent of the labels), the scene of each
    let sample_text = TableText::required(&dir, "sample.json")?;
    sample_text.check::<crate::nuscenes::Sample>()?;
    #[derive(Deserialize)]
    struct SampleRow<'a> {
        #[serde(borrow)]
        token: Cow<'a, str>,
        #[serde(borrow)]
        scene_token: Cow<'a, str>,
    }
    let sample_rows = sample_text.rows::<SampleRow<'_>>()?;
    // a sample token's scenes (one, unless the token is repeated) and its rows
    let mut scenes_of_sample: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    let mut rows_of_sample: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for (i, (_, s)) in sample_rows.iter().enumerate() {
        scenes_of_sample.entry(s.token.as_ref()).or_default().insert(s.scene_token.as_ref());
        rows_of_sample.entry(s.token.as_ref()).or_default().push(i);
    }

    // the small tables: sensor (whole), calibrated_sensor (by token), category (whole), instance (by token)
    let mut whole: BTreeMap<&'static str, String> = BTreeMap::new();
    let sensor_text = TableText::read(&dir, "sensor.json")?;
    #[derive(Deserialize)]
    struct SensorRow<'a> {
        #[serde(borrow)]
        token: Cow<'a, str>,
        #[serde(borrow)]
        channel: Cow<'a, str>,
    }
    let sensor_rows = match &sensor_text {
        Some(t) => {
            t.check::<crate::nuscenes::Sensor>()?;
            whole.insert("sensor.json", t.text.trim().to_string());
            Some(t.rows::<SensorRow<'_>>()?)
        }
        None => None,
    };
    let channels: Option<BTreeMap<&str, &str>> =
        sensor_rows.as_ref().map(|rows| rows.iter().map(|(_, s)| (s.token.as_ref(), s.channel.as_ref())).collect());
    let category_text = TableText::required(&dir, "category.json")?;
    category_text.check::<crate::nuscenes::Category>()?;
    whole.insert("category.json", category_text.text.trim().to_string());
    drop(category_text);
    let cal_text = TableText::required(&dir, "calibrated_sensor.json")?;
    let cal_rows = cal_text.rows::<PoseRow<'_>>()?;
    let cal_by_token: BTreeMap<&str, (&str, Option<&str>)> =
        cal_rows.iter().map(|(row, c)| (c.token.as_ref(), (*row, c.sensor_token.as_deref()))).collect();

    // sample_data.json: the keyframe rows reading looks at (LIDAR_TOP, or a sensor it cannot tell)
    let sd_text = TableText::required(&dir, "sample_data.json")?;
    let mut ego_wanted: BTreeMap<String, BTreeSet<String>> = BTreeMap::new(); // ego pose token -> scene tokens
    for r in sd_text.each_row::<SampleDataRow<'_>>()? {
        let (row, sd) = r?;
        if !sd.is_key_frame {
            continue;
        }
        let Some(scenes) = scenes_of_sample.get(sd.sample_token.as_ref()) else { continue };
        // LIDAR_TOP, or a dangling token (reading the scene reports it, as it would from the folder)
        let cal_sensor = cal_by_token.get(sd.calibrated_sensor_token.as_ref()).map(|(_, sensor)| *sensor);
        if matches!(lidar_top(channels.as_ref(), cal_sensor, &sd.filename), LidarTop::No) {
            continue;
        }
        for scene in scenes {
            let Some(slice) = slices.get_mut(*scene) else { continue };
            slice.push("sample_data.json", row);
            if let Some((cal_row, _)) = cal_by_token.get(sd.calibrated_sensor_token.as_ref()) {
                let rows = slice.tables.entry("calibrated_sensor.json").or_default();
                if !rows.iter().any(|r| r == cal_row) {
                    rows.push((*cal_row).to_string());
                }
            }
            ego_wanted.entry(sd.ego_pose_token.to_string()).or_default().insert((*scene).to_string());
        }
    }
    drop(sd_text);
    drop(cal_rows);
    drop(cal_text);

    // ego_pose.json: the rows the kept sample_data reference
    let ego_text = TableText::required(&dir, "ego_pose.json")?;
    for r in ego_text.each_row::<PoseRow<'_>>()? {
        let (row, e) = r?;
        if let Some(scenes) = ego_wanted.get(e.token.as_ref()) {
            for s in scenes {
                if let Some(slice) = slices.get_mut(s) {
                    slice.push("ego_pose.json", row);
                }
            }
        }
    }
    drop(ego_text);
    drop(ego_wanted);

    // instance.json, checked whole, kept by token
    let inst_text = TableText::required(&dir, "instance.json")?;
    inst_text.check::<crate::nuscenes::Instance>()?;
    let inst_rows = inst_text.rows::<TokenRow<'_>>()?;
    let inst_by_token: BTreeMap<&str, &str> = inst_rows.iter().map(|(row, i)| (i.token.as_ref(), *row)).collect();

    // sample_annotation.json: the annotations of each instance, and the scenes it is annotated in
    let ann_text = TableText::required(&dir, "sample_annotation.json")?;
    // each row checked against the reader's types, then only its text and two tokens kept
    let ann_rows: Vec<(&str, Cow<'_, str>, Cow<'_, str>)> = ann_text
        .each_row::<AnnotationRow<'_>>()?
        .map(|r| r.map(|(row, a)| (row, a.sample_token, a.instance_token)))
        .collect::<Result<_, _>>()?;
    let mut of_instance: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    let mut scenes_of_instance: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (k, (_, sample, instance)) in ann_rows.iter().enumerate() {
        let scenes = scenes_of_sample
            .get(sample.as_ref())
            .ok_or_else(|| DatasetError::malformed(&ann_text.path, format!("sample token `{sample}` not found")))?;
        of_instance.entry(instance.as_ref()).or_default().push(k);
        scenes_of_instance.entry(instance.as_ref()).or_default().extend(scenes.iter().copied());
    }
    // per scene: its instances, then their annotations in the table's order, their samples and instance rows
    let mut instances_of_scene: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (inst, scenes) in &scenes_of_instance {
        for s in scenes {
            instances_of_scene.entry(s).or_default().insert(inst);
        }
    }
    let mut samples_of_scene: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (_, s) in &sample_rows {
        samples_of_scene.entry(s.scene_token.as_ref()).or_default().push(s.token.as_ref());
    }
    for name in scenes {
        let Some(token) = token_of_name.get(name) else { continue };
        // (cloned: two scene rows may share a token)
        let Some(mut slice) = slices.get(token).cloned() else { continue };
        let instances = instances_of_scene.get(token.as_str());
        let mut anns: Vec<usize> =
            instances.into_iter().flatten().filter_map(|i| of_instance.get(i)).flatten().copied().collect();
        anns.sort_unstable();
        // the samples: the scene's own and those of its instances' annotations, every row of each such token, in
        // the table's order
        let mut tokens: BTreeSet<&str> = samples_of_scene.get(token.as_str()).into_iter().flatten().copied().collect();
        for &k in &anns {
            if let Some((row, sample, _)) = ann_rows.get(k) {
                slice.push("sample_annotation.json", row);
                tokens.insert(sample.as_ref());
            }
        }
        let mut rows: Vec<usize> = tokens.iter().filter_map(|t| rows_of_sample.get(t)).flatten().copied().collect();
        rows.sort_unstable();
        for i in rows {
            if let Some((row, _)) = sample_rows.get(i) {
                slice.push("sample.json", row);
            }
        }
        for inst in instances.into_iter().flatten() {
            if let Some(row) = inst_by_token.get(inst) {
                slice.push("instance.json", row);
            }
        }
        emit(name, slice.text(&whole))?;
    }
    Ok(())
}
