//! The pmon recording format, version 1 (see `docs/recording-format.md`).
//!
//! A recording is a directory:
//!
//! ```text
//! recording.json        {"format": "pmon-recording", "version": 1, "name": ..., "source": ..., "frames": N}
//! frames.jsonl          one JSON object per frame (timestamp, ego pose, objects, cloud reference, ROI)
//! clouds/000000.bin     the frame's LiDAR points, little-endian f32 x, y, z (sensor frame), no header
//! ```
//!
//! A single `.jsonl` file of frames without clouds is also a recording (object lists only: plausibility only).
//! [`RecordedFrame`] is the owned frame every source produces (simulator, dataset readers) and
//! [`RecordedFrame::as_frame`] lends it to the monitor.

use std::fs::{self, File};
use std::io::{self, BufRead, BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use pmon_monitor::{Frame, Isometry3, ObjectClass, ObjectState, PointCloud, Pose2, Uncertainty};
use serde::{Deserialize, Serialize};

/// The README's Rust snippet, compiled and run as a doctest (`cargo test --doc -p pmon-recording`), so that it
/// keeps compiling as the API changes.
#[cfg(doctest)]
#[doc = include_str!("../../../README.md")]
pub struct ReadmeDoctests;

/// Format name in `recording.json`.
pub const FORMAT_NAME: &str = "pmon-recording";
/// Version this crate writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// An owned LiDAR sweep.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OwnedCloud {
    /// Points in the sensor frame, metres.
    pub points_in_sensor: Vec<[f32; 3]>,
    /// Extrinsic `ego_from_sensor`.
    pub ego_from_sensor: Isometry3,
}

/// One frame, owned: what the simulator and the dataset readers produce.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedFrame {
    /// Frame number within the recording, from 0.
    pub index: u64,
    /// Timestamp, seconds.
    pub timestamp_s: f64,
    /// Ego pose in the world frame.
    pub world_from_ego: Pose2,
    /// Object list (the primary channel's output), ego frame.
    pub objects: Vec<ObjectState>,
    /// LiDAR sweep, if any.
    pub cloud: Option<OwnedCloud>,
    /// Region of interest polygons, ego frame.
    pub roi_in_ego: Vec<Vec<[f32; 2]>>,
    /// Known static scenery polygons, ego frame.
    pub static_in_ego: Vec<Vec<[f32; 2]>>,
}

impl RecordedFrame {
    /// A frame with no objects, cloud or ROI.
    #[must_use]
    pub fn empty(index: u64, timestamp_s: f64, world_from_ego: Pose2) -> Self {
        Self {
            index,
            timestamp_s,
            world_from_ego,
            objects: Vec::new(),
            cloud: None,
            roi_in_ego: Vec::new(),
            static_in_ego: Vec::new(),
        }
    }

    /// Lends the frame to the monitor. `polygons` is scratch space for the ROI and scenery slices.
    #[must_use]
    pub fn as_frame<'a>(&'a self, polygons: &'a mut Vec<&'a [[f32; 2]]>) -> Frame<'a> {
        polygons.clear();
        polygons.extend(self.roi_in_ego.iter().map(Vec::as_slice));
        polygons.extend(self.static_in_ego.iter().map(Vec::as_slice));
        let (roi, scenery) = polygons.split_at(self.roi_in_ego.len().min(polygons.len()));
        Frame {
            timestamp_s: self.timestamp_s,
            world_from_ego: self.world_from_ego,
            objects: &self.objects,
            cloud: self
                .cloud
                .as_ref()
                .map(|c| PointCloud { points_in_sensor: &c.points_in_sensor, ego_from_sensor: c.ego_from_sensor }),
            roi_in_ego: roi,
            static_in_ego: scenery,
        }
    }
}

/// `recording.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordingMeta {
    /// Always [`FORMAT_NAME`].
    pub format: String,
    /// Always [`FORMAT_VERSION`].
    pub version: u32,
    /// Free-form name.
    #[serde(default)]
    pub name: String,
    /// Where the data came from (simulator scenario and seed, dataset and log, ...).
    #[serde(default)]
    pub source: String,
    /// Number of frames in `frames.jsonl`.
    pub frames: u64,
}

impl RecordingMeta {
    /// Metadata of a new recording.
    #[must_use]
    pub fn new(name: impl Into<String>, source: impl Into<String>) -> Self {
        Self {
            format: FORMAT_NAME.into(),
            version: FORMAT_VERSION,
            name: name.into(),
            source: source.into(),
            frames: 0,
        }
    }
}

/// A reading or writing error, naming the file (and line) and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// I/O failure.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// Malformed content.
    #[error("{}: {message}", located(path, *line))]
    Malformed {
        /// The file.
        path: PathBuf,
        /// 1-based line (0 when not line-based).
        line: u64,
        /// What is wrong.
        message: String,
    },
}

/// `file:line`, or just `file` for whole-file errors (line 0).
fn located(path: &Path, line: u64) -> String {
    if line == 0 {
        path.display().to_string()
    } else {
        format!("{}:{line}", path.display())
    }
}

impl RecordingError {
    fn io(path: &Path, source: io::Error) -> Self {
        Self::Io { path: path.to_path_buf(), source }
    }
    fn malformed(path: &Path, line: u64, message: impl Into<String>) -> Self {
        Self::Malformed { path: path.to_path_buf(), line, message: message.into() }
    }
}

// ---------------------------------------------------------------------------------------------------------
// JSON shapes
// ---------------------------------------------------------------------------------------------------------

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonObject {
    id: u64,
    #[serde(default)]
    class: String,
    x_m: f32,
    y_m: f32,
    heading_rad: f32,
    speed_mps: f32,
    length_m: f32,
    width_m: f32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sigma: Option<Uncertainty>,
    /// Row-major 6x6 covariance of (x, y, heading, speed, length, width); only its diagonal is used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    covariance: Option<Vec<f64>>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonCloud {
    file: String,
    points: u64,
    ego_from_sensor: Isometry3,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonFrame {
    frame: u64,
    timestamp_s: f64,
    #[serde(default)]
    world_from_ego: Pose2,
    objects: Vec<JsonObject>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    cloud: Option<JsonCloud>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    roi_in_ego: Vec<Vec<[f32; 2]>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    static_in_ego: Vec<Vec<[f32; 2]>>,
}

fn object_from_json(o: JsonObject) -> Result<ObjectState, String> {
    let class = if o.class.is_empty() {
        ObjectClass::Unknown
    } else {
        ObjectClass::from_name(&o.class).ok_or_else(|| {
            format!(
                "object {}: unknown class `{}` (expected one of: {})",
                o.id,
                o.class,
                ObjectClass::ALL.iter().map(|c| c.name()).collect::<Vec<_>>().join(", ")
            )
        })?
    };
    let uncertainty = match (o.sigma, o.covariance) {
        (Some(_), Some(_)) => return Err(format!("object {}: give `sigma` or `covariance`, not both", o.id)),
        (Some(s), None) => Some(s),
        (None, Some(c)) => {
            if c.len() != 36 {
                return Err(format!(
                    "object {}: `covariance` must have 36 entries (6x6 row-major), got {}",
                    o.id,
                    c.len()
                ));
            }
            let d = |i: usize| c.get(i * 7).copied().unwrap_or(f64::NAN);
            let sd = |i: usize| -> Result<f32, String> {
                let v = d(i);
                if v.is_finite() && v >= 0.0 {
                    Ok(v.sqrt() as f32)
                } else {
                    Err(format!("object {}: covariance diagonal entry {i} is {v}, must be finite and >= 0", o.id))
                }
            };
            Some(Uncertainty {
                x_m: sd(0)?,
                y_m: sd(1)?,
                heading_rad: sd(2)?,
                speed_mps: sd(3)?,
                length_m: sd(4)?,
                width_m: sd(5)?,
            })
        }
        (None, None) => None,
    };
    let finite = [o.x_m, o.y_m, o.heading_rad, o.speed_mps, o.length_m, o.width_m].iter().all(|v| v.is_finite());
    if !finite {
        return Err(format!("object {}: a value is not finite (or too large for f32)", o.id));
    }
    if !(o.length_m > 0.0 && o.width_m > 0.0) {
        return Err(format!("object {}: length_m {} and width_m {} must be > 0", o.id, o.length_m, o.width_m));
    }
    if o.speed_mps < 0.0 {
        return Err(format!("object {}: speed_mps {} must be >= 0", o.id, o.speed_mps));
    }
    if let Some(s) = uncertainty {
        if !s.is_valid() {
            return Err(format!("object {}: every sigma must be finite and >= 0", o.id));
        }
    }
    Ok(ObjectState {
        id: o.id,
        class,
        x_m: o.x_m,
        y_m: o.y_m,
        heading_rad: o.heading_rad,
        speed_mps: o.speed_mps,
        length_m: o.length_m,
        width_m: o.width_m,
        uncertainty,
    })
}

fn object_to_json(o: &ObjectState) -> JsonObject {
    JsonObject {
        id: o.id,
        class: o.class.name().to_string(),
        x_m: o.x_m,
        y_m: o.y_m,
        heading_rad: o.heading_rad,
        speed_mps: o.speed_mps,
        length_m: o.length_m,
        width_m: o.width_m,
        sigma: o.uncertainty,
        covariance: None,
    }
}

// ---------------------------------------------------------------------------------------------------------
// Point files
// ---------------------------------------------------------------------------------------------------------

/// Reads a little-endian f32 point file with `stride` floats per point (x, y, z first).
///
/// # Errors
/// I/O errors, and a size that is not a whole number of points.
pub fn read_points_f32(path: &Path, stride: usize) -> Result<Vec<[f32; 3]>, RecordingError> {
    let mut bytes = Vec::new();
    File::open(path).and_then(|mut f| f.read_to_end(&mut bytes)).map_err(|e| RecordingError::io(path, e))?;
    points_from_le_bytes(&bytes, stride).map_err(|m| RecordingError::malformed(path, 0, m))
}

/// Decodes little-endian f32 points with `stride` floats per point (x, y, z first).
///
/// # Errors
/// A stride below 3, or a length that is not a whole number of points.
pub fn points_from_le_bytes(bytes: &[u8], stride: usize) -> Result<Vec<[f32; 3]>, String> {
    if stride < 3 {
        return Err(format!("point stride {stride} is below 3"));
    }
    let rec = stride * 4;
    if !bytes.len().is_multiple_of(rec) {
        return Err(format!(
            "size {} bytes is not a whole number of {stride}-float points ({rec} bytes each): truncated?",
            bytes.len()
        ));
    }
    Ok(bytes
        .chunks_exact(rec)
        .map(|c| {
            let f = |i: usize| {
                let b = [c[i * 4], c[i * 4 + 1], c[i * 4 + 2], c[i * 4 + 3]];
                f32::from_le_bytes(b)
            };
            [f(0), f(1), f(2)]
        })
        .collect())
}

fn write_points_f32(path: &Path, points: &[[f32; 3]]) -> Result<(), RecordingError> {
    let mut bytes = Vec::with_capacity(points.len() * 12);
    for p in points {
        for v in p {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    fs::write(path, bytes).map_err(|e| RecordingError::io(path, e))
}

// ---------------------------------------------------------------------------------------------------------
// Writer
// ---------------------------------------------------------------------------------------------------------

/// Writes a recording directory frame by frame.
pub struct RecordingWriter {
    dir: PathBuf,
    meta: RecordingMeta,
    frames: BufWriter<File>,
    frames_path: PathBuf,
}

impl RecordingWriter {
    /// Creates `dir` (and `dir/clouds`) and starts `frames.jsonl`. Existing files of the same names are
    /// overwritten.
    ///
    /// # Errors
    /// I/O errors.
    pub fn create(dir: &Path, meta: RecordingMeta) -> Result<Self, RecordingError> {
        let clouds = dir.join("clouds");
        fs::create_dir_all(&clouds).map_err(|e| RecordingError::io(&clouds, e))?;
        let frames_path = dir.join("frames.jsonl");
        let file = File::create(&frames_path).map_err(|e| RecordingError::io(&frames_path, e))?;
        Ok(Self { dir: dir.to_path_buf(), meta, frames: BufWriter::new(file), frames_path })
    }

    /// Appends one frame (its cloud goes to `clouds/NNNNNN.bin`, named by the frame's index).
    ///
    /// # Errors
    /// I/O errors.
    pub fn write_frame(&mut self, frame: &RecordedFrame) -> Result<(), RecordingError> {
        let cloud = match &frame.cloud {
            Some(c) => {
                let file = format!("clouds/{:06}.bin", frame.index);
                write_points_f32(&self.dir.join(&file), &c.points_in_sensor)?;
                Some(JsonCloud { file, points: c.points_in_sensor.len() as u64, ego_from_sensor: c.ego_from_sensor })
            }
            None => None,
        };
        let json = JsonFrame {
            frame: frame.index,
            timestamp_s: frame.timestamp_s,
            world_from_ego: frame.world_from_ego,
            objects: frame.objects.iter().map(object_to_json).collect(),
            cloud,
            roi_in_ego: frame.roi_in_ego.clone(),
            static_in_ego: frame.static_in_ego.clone(),
        };
        let line = serde_json::to_string(&json)
            .map_err(|e| RecordingError::malformed(&self.frames_path, 0, format!("cannot serialise frame: {e}")))?;
        writeln!(self.frames, "{line}").map_err(|e| RecordingError::io(&self.frames_path, e))?;
        self.meta.frames += 1;
        Ok(())
    }

    /// Flushes `frames.jsonl` and writes `recording.json`.
    ///
    /// # Errors
    /// I/O errors.
    pub fn finish(mut self) -> Result<RecordingMeta, RecordingError> {
        self.frames.flush().map_err(|e| RecordingError::io(&self.frames_path, e))?;
        let meta_path = self.dir.join("recording.json");
        let text = serde_json::to_string_pretty(&self.meta)
            .map_err(|e| RecordingError::malformed(&meta_path, 0, e.to_string()))?;
        fs::write(&meta_path, text + "\n").map_err(|e| RecordingError::io(&meta_path, e))?;
        Ok(self.meta)
    }
}

/// Writes a whole recording at once.
///
/// # Errors
/// I/O errors.
pub fn write_recording(
    dir: &Path,
    meta: RecordingMeta,
    frames: &[RecordedFrame],
) -> Result<RecordingMeta, RecordingError> {
    let mut w = RecordingWriter::create(dir, meta)?;
    for f in frames {
        w.write_frame(f)?;
    }
    w.finish()
}

// ---------------------------------------------------------------------------------------------------------
// Reader
// ---------------------------------------------------------------------------------------------------------

/// Reads a recording frame by frame. Every frame comes back, or an error naming file and line.
pub struct RecordingReader {
    base: PathBuf,
    frames_path: PathBuf,
    lines: io::Lines<Box<dyn BufRead>>,
    line_no: u64,
    /// The metadata (synthesised for a bare `.jsonl` file).
    pub meta: RecordingMeta,
    expected_frames: Option<u64>,
    read_frames: u64,
    /// Timestamp of the previous frame (they must increase strictly).
    last_timestamp_s: Option<f64>,
}

impl RecordingReader {
    /// Opens a recording directory, or a bare `frames.jsonl`-style file of object lists.
    ///
    /// # Errors
    /// A missing or malformed `recording.json`, a wrong format name or version, or an unreadable file.
    pub fn open(path: &Path) -> Result<Self, RecordingError> {
        let (base, frames_path, meta, expected) = if path.is_dir() {
            let meta_path = path.join("recording.json");
            let text = fs::read_to_string(&meta_path).map_err(|e| RecordingError::io(&meta_path, e))?;
            let meta: RecordingMeta = serde_json::from_str(&text)
                .map_err(|e| RecordingError::malformed(&meta_path, e.line() as u64, e.to_string()))?;
            if meta.format != FORMAT_NAME {
                return Err(RecordingError::malformed(
                    &meta_path,
                    0,
                    format!("format is `{}`, expected `{FORMAT_NAME}`", meta.format),
                ));
            }
            if meta.version != FORMAT_VERSION {
                return Err(RecordingError::malformed(
                    &meta_path,
                    0,
                    format!("version {} is not supported (this pmon reads version {FORMAT_VERSION})", meta.version),
                ));
            }
            let expected = Some(meta.frames);
            (path.to_path_buf(), path.join("frames.jsonl"), meta, expected)
        } else {
            let base = path.parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf);
            let meta = RecordingMeta::new(path.display().to_string(), "object list (.jsonl)");
            (base, path.to_path_buf(), meta, None)
        };
        let file = File::open(&frames_path).map_err(|e| RecordingError::io(&frames_path, e))?;
        Ok(Self {
            base,
            frames_path,
            lines: (Box::new(BufReader::new(file)) as Box<dyn BufRead>).lines(),
            line_no: 0,
            meta,
            expected_frames: expected,
            read_frames: 0,
            last_timestamp_s: None,
        })
    }

    /// Reads frames (a `.jsonl` object list) from a stream, for example standard input; `name` stands for the
    /// file in error messages. Cloud files are resolved against the current directory.
    ///
    /// # Errors
    /// None today; a `Result` for symmetry with [`RecordingReader::open`].
    pub fn from_reader(reader: Box<dyn BufRead>, name: &Path) -> Result<Self, RecordingError> {
        Ok(Self {
            base: PathBuf::from("."),
            frames_path: name.to_path_buf(),
            lines: reader.lines(),
            line_no: 0,
            meta: RecordingMeta::new(name.display().to_string(), "object list (stream)"),
            expected_frames: None,
            read_frames: 0,
            last_timestamp_s: None,
        })
    }

    /// Path of the frames file.
    #[must_use]
    pub fn frames_path(&self) -> &Path {
        &self.frames_path
    }

    fn parse_line(&mut self, line: &str) -> Result<RecordedFrame, RecordingError> {
        let here = |m: String| RecordingError::malformed(&self.frames_path, self.line_no, m);
        let json: JsonFrame = serde_json::from_str(line).map_err(|e| here(e.to_string()))?;
        // Frames are numbered 0, 1, 2, ... in file order, and time increases strictly (docs/recording-format.md).
        let expected_index = self.read_frames - 1;
        if json.frame != expected_index {
            return Err(here(format!(
                "frame number {} where {expected_index} was expected: frames are numbered from 0 without gaps",
                json.frame
            )));
        }
        if !json.timestamp_s.is_finite() {
            return Err(here(format!("timestamp_s is {}, must be finite", json.timestamp_s)));
        }
        if let Some(prev) = self.last_timestamp_s {
            if json.timestamp_s <= prev {
                return Err(here(format!(
                    "timestamp_s {} is not after the previous frame's {prev}: time must increase strictly",
                    json.timestamp_s
                )));
            }
        }
        self.last_timestamp_s = Some(json.timestamp_s);
        let objects = json.objects.into_iter().map(object_from_json).collect::<Result<Vec<_>, _>>().map_err(here)?;
        let cloud = match json.cloud {
            Some(c) => {
                let path = confined_cloud_path(&self.base, &c.file).map_err(here)?;
                let points = read_points_exact(&path, c.points).map_err(|e| match e {
                    CloudReadError::Io(e) => here(format!("cloud `{}`: {e}", path.display())),
                    CloudReadError::Size(m) => here(format!("cloud `{}`: {m}", c.file)),
                })?;
                Some(OwnedCloud { points_in_sensor: points, ego_from_sensor: c.ego_from_sensor })
            }
            None => None,
        };
        Ok(RecordedFrame {
            index: json.frame,
            timestamp_s: json.timestamp_s,
            world_from_ego: json.world_from_ego,
            objects,
            cloud,
            roi_in_ego: json.roi_in_ego,
            static_in_ego: json.static_in_ego,
        })
    }
}

impl Iterator for RecordingReader {
    type Item = Result<RecordedFrame, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            match self.lines.next() {
                None => {
                    if let Some(n) = self.expected_frames.take() {
                        if n != self.read_frames {
                            return Some(Err(RecordingError::malformed(
                                &self.frames_path,
                                self.line_no,
                                format!(
                                    "recording.json says {n} frames, the file has {}: truncated?",
                                    self.read_frames
                                ),
                            )));
                        }
                    }
                    return None;
                }
                Some(Err(e)) => {
                    self.line_no += 1;
                    return Some(Err(RecordingError::malformed(&self.frames_path, self.line_no, e.to_string())));
                }
                Some(Ok(line)) => {
                    self.line_no += 1;
                    if line.trim().is_empty() {
                        continue;
                    }
                    self.read_frames += 1;
                    return Some(self.parse_line(&line));
                }
            }
        }
    }
}

/// A cloud `file` entry resolved inside the recording: relative, no `..`, no root, no drive.
fn confined_cloud_path(base: &Path, file: &str) -> Result<PathBuf, String> {
    use std::path::Component;
    let rel = Path::new(file);
    if file.is_empty() || !rel.components().all(|c| matches!(c, Component::Normal(_) | Component::CurDir)) {
        return Err(format!(
            "cloud file `{file}` must be a relative path inside the recording (no `..`, no absolute path)"
        ));
    }
    Ok(base.join(rel))
}

enum CloudReadError {
    Io(io::Error),
    Size(String),
}

/// Reads exactly `points` points from a regular file whose size must be `12 * points` bytes: devices, FIFOs
/// and files of another size are refused before anything is read.
fn read_points_exact(path: &Path, points: u64) -> Result<Vec<[f32; 3]>, CloudReadError> {
    let meta = fs::metadata(path).map_err(CloudReadError::Io)?;
    if !meta.is_file() {
        return Err(CloudReadError::Size("not a regular file".into()));
    }
    let want = points.checked_mul(12).ok_or_else(|| CloudReadError::Size(format!("{points} points is too many")))?;
    if meta.len() != want {
        return Err(CloudReadError::Size(format!(
            "has {} bytes, the frame says {points} points ({want} bytes): truncated or wrong `points`?",
            meta.len()
        )));
    }
    let len = usize::try_from(want).map_err(|_| CloudReadError::Size("too large for this machine".into()))?;
    let mut bytes = vec![0u8; len];
    File::open(path).and_then(|mut f| f.read_exact(&mut bytes)).map_err(CloudReadError::Io)?;
    points_from_le_bytes(&bytes, 3).map_err(CloudReadError::Size)
}

/// Reads a whole recording into memory.
///
/// # Errors
/// The first error of [`RecordingReader`].
pub fn read_recording(path: &Path) -> Result<(RecordingMeta, Vec<RecordedFrame>), RecordingError> {
    let reader = RecordingReader::open(path)?;
    let meta = reader.meta.clone();
    let frames = reader.collect::<Result<Vec<_>, _>>()?;
    Ok((meta, frames))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> RecordedFrame {
        let mut f = RecordedFrame::empty(0, 1.5, Pose2 { x_m: 10.0, y_m: -2.0, yaw_rad: 0.3 });
        f.objects.push(ObjectState {
            id: 7,
            class: ObjectClass::Pedestrian,
            x_m: 5.0,
            y_m: 1.0,
            heading_rad: 1.0,
            speed_mps: 1.2,
            length_m: 0.6,
            width_m: 0.6,
            uncertainty: Some(Uncertainty {
                x_m: 0.1,
                y_m: 0.1,
                heading_rad: 0.17,
                speed_mps: 0.5,
                length_m: 0.0,
                width_m: 0.0,
            }),
        });
        f.cloud = Some(OwnedCloud {
            points_in_sensor: vec![[1.0, 2.0, 3.0], [4.5, -1.0, 0.25]],
            ego_from_sensor: Isometry3::from_translation(0.0, 0.0, 1.8),
        });
        f.roi_in_ego = vec![vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]];
        f.static_in_ego = vec![vec![[1.0, 1.0], [2.0, 1.0], [2.0, 2.0]]];
        f
    }

    #[test]
    fn round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let mut b = sample();
        b.index = 1;
        b.timestamp_s = 1.6;
        b.cloud = None;
        write_recording(dir.path(), RecordingMeta::new("t", "test"), &[sample(), b.clone()]).unwrap();
        let (meta, frames) = read_recording(dir.path()).unwrap();
        assert_eq!(meta.frames, 2);
        assert_eq!(frames, vec![sample(), b]);
    }

    #[test]
    fn truncated_cloud_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        write_recording(dir.path(), RecordingMeta::new("t", "test"), &[sample()]).unwrap();
        let cloud = dir.path().join("clouds/000000.bin");
        let bytes = fs::read(&cloud).unwrap();
        fs::write(&cloud, &bytes[..bytes.len() - 5]).unwrap();
        let err = read_recording(dir.path()).unwrap_err().to_string();
        assert!(err.contains("000000.bin") && err.contains("truncated"), "{err}");
    }

    #[test]
    fn unknown_key_and_bad_class_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("objs.jsonl");
        fs::write(&p, "{\"frame\":0,\"timestamp_s\":0.0,\"objects\":[]}\n{\"frame\":1,\"timestamp_s\":0.1,\"objects\":[],\"bogus\":1}\n").unwrap();
        let err = read_recording(&p).unwrap_err().to_string();
        assert!(err.contains("objs.jsonl:2") && err.contains("bogus"), "{err}");
        fs::write(&p, "{\"frame\":0,\"timestamp_s\":0.0,\"objects\":[{\"id\":1,\"class\":\"dragon\",\"x_m\":0,\"y_m\":0,\"heading_rad\":0,\"speed_mps\":0,\"length_m\":1,\"width_m\":1}]}\n").unwrap();
        let err = read_recording(&p).unwrap_err().to_string();
        assert!(err.contains("objs.jsonl:1") && err.contains("dragon"), "{err}");
    }

    #[test]
    fn missing_frames_are_reported() {
        let dir = tempfile::tempdir().unwrap();
        write_recording(dir.path(), RecordingMeta::new("t", "test"), &[sample()]).unwrap();
        let meta = dir.path().join("recording.json");
        let text = fs::read_to_string(&meta).unwrap().replace("\"frames\": 1", "\"frames\": 3");
        fs::write(&meta, text).unwrap();
        let err = read_recording(dir.path()).unwrap_err().to_string();
        assert!(err.contains("3 frames"), "{err}");
    }

    #[test]
    fn covariance_diagonal_becomes_sigma() {
        let mut cov = vec![0.0; 36];
        for (i, v) in [0.04, 0.09, 0.01, 0.25, 0.0, 0.0].iter().enumerate() {
            cov[i * 7] = *v;
        }
        let o = JsonObject {
            id: 1,
            class: "car".into(),
            x_m: 0.0,
            y_m: 0.0,
            heading_rad: 0.0,
            speed_mps: 0.0,
            length_m: 4.0,
            width_m: 2.0,
            sigma: None,
            covariance: Some(cov),
        };
        let s = object_from_json(o).unwrap().uncertainty.unwrap();
        assert!((s.x_m - 0.2).abs() < 1e-6 && (s.y_m - 0.3).abs() < 1e-6 && (s.speed_mps - 0.5).abs() < 1e-6);
    }
}
