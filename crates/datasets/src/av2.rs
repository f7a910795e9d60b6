//! Argoverse 2 sensor dataset logs ((c) 2022 Argo AI, LLC, CC BY-NC-SA 4.0): Feather (Arrow IPC) tables,
//! float16 LiDAR sweeps, city poses, sensor extrinsics and the ground-height raster.
//!
//! Frames: AV2's ego-vehicle frame (x forward, y left, z up) has its origin at the rear-axle centre, about
//! 0.33 m ABOVE the ground. This reader keeps that frame unchanged (so the AV2 city poses, cuboid heights and the
//! ground raster stay consistent) and reports the ground height in it as `DatasetInfo::ground_z_m` (measured
//! from the ground raster under the ego origin, median over the log) for the monitor's `ground_z_m`.
//!
//! Sweeps are stored in the ego frame, merged from the `up_lidar` and `down_lidar`. They are handed to the
//! monitor in a sensor-CENTRED frame: `points_in_sensor = p_ego - up_lidar_origin` with `ego_from_sensor =
//! translation(up_lidar_origin)` (no rotation), so the extrinsic's translation is the roof LiDAR's origin,
//! which the monitor uses as the origin of its free-space rays. Returns of the down LiDAR (laser numbers
//! 32..63) get the up LiDAR's origin too: a small error in ray directions near the car.

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use arrow_array::cast::AsArray;
use arrow_array::types::{
    Float16Type, Float32Type, Float64Type, Int16Type, Int32Type, Int64Type, Int8Type, UInt16Type, UInt32Type,
    UInt64Type, UInt8Type,
};
use arrow_array::{Array, RecordBatch};
use arrow_ipc::reader::FileReader;
use arrow_schema::DataType;
use pmon_monitor::{Isometry3, ObjectClass, ObjectState};
use pmon_recording::{OwnedCloud, RecordedFrame};
use serde::Deserialize;

use crate::av2_map::{find_vector_map, MapRoiOptions, VectorMap};
use crate::geometry::{wrap_angle, Rigid3};
use crate::ground::{level_cloud, GroundMode, LevelStats, GROUND_NOTE_PREFIX};
use crate::roi::{RoiMode, ROI_NOTE_PREFIX};
use crate::util::{f32_of, finite_difference_speeds, list_dir, read_bytes, read_text};
use crate::WARNING_PREFIX;
use crate::{Dataset, DatasetError, DatasetFormat, DatasetFrame, DatasetInfo, ObjectExtra, ReadOptions, SpeedSource};

/// Category of the synthetic ego-vehicle track some AV2 files add (dropped by the reader).
pub const EGO_CATEGORY: &str = "EGO_VEHICLE";

/// Ground height in AV2's ego frame used when the log has no ground raster, metres (typical value measured
/// under the ego origin on the logs with a raster).
pub const NOMINAL_GROUND_Z_M: f32 = -0.33;
/// The up-LiDAR's origin in the AV2 ego frame used when a log has no `calibration/` folder, metres (the
/// vehicles' typical mounting: about 1.35 m ahead of the rear axle, 1.64 m up).
pub const NOMINAL_UP_LIDAR_ORIGIN_M: [f64; 3] = [1.35, 0.0, 1.64];

/// Largest gap between two annotation frames of a track used for a finite difference, seconds.
const MAX_GAP_S: f64 = 0.5;

// -------------------------------------------------------------------------------------------------------------
// Feather
// -------------------------------------------------------------------------------------------------------------

/// A Feather v2 (Arrow IPC file) table read into memory, with typed column access.
pub struct FeatherTable {
    path: PathBuf,
    batches: Vec<RecordBatch>,
}

impl std::fmt::Debug for FeatherTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FeatherTable").field("path", &self.path).field("rows", &self.rows()).finish()
    }
}

impl FeatherTable {
    /// Reads a Feather v2 file (uncompressed or LZ4-frame compressed buffers).
    ///
    /// # Errors
    /// I/O errors and anything the Arrow IPC reader rejects (bad magic, truncated footer or buffers).
    pub fn read(path: &Path) -> Result<Self, DatasetError> {
        let bytes = read_bytes(path)?;
        Self::from_bytes(path, bytes)
    }

    /// Decodes a Feather v2 file from memory; `path` is used in errors.
    ///
    /// # Errors
    /// Anything the Arrow IPC reader rejects.
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<Self, DatasetError> {
        let bad =
            |e: &dyn std::fmt::Display| DatasetError::malformed(path, format!("not a valid Feather v2 file: {e}"));
        // arrow-ipc 60 trusts some lengths in the file: out-of-range buffer offsets panic, and a corrupted LZ4
        // "uncompressed length" is handed to `Vec::with_capacity` (an abort, not even a panic). Check the layout
        // first; catch_unwind stays as a backstop for anything this check misses.
        check_ipc_layout(&bytes).map_err(|e| bad(&e))?;
        let decoded = std::panic::catch_unwind(move || -> Result<Vec<RecordBatch>, String> {
            let reader = FileReader::try_new(Cursor::new(bytes), None).map_err(|e| e.to_string())?;
            reader.collect::<Result<Vec<_>, _>>().map_err(|e| e.to_string())
        });
        match decoded {
            Ok(Ok(batches)) => Ok(Self { path: path.to_path_buf(), batches }),
            Ok(Err(e)) => Err(bad(&e)),
            Err(_) => Err(bad(&"the Arrow IPC decoder panicked")),
        }
    }

    /// Number of rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.batches.iter().map(RecordBatch::num_rows).sum()
    }

    fn columns(&self, name: &str) -> Result<Vec<&dyn Array>, DatasetError> {
        let mut out = Vec::with_capacity(self.batches.len());
        for b in &self.batches {
            let col = b
                .column_by_name(name)
                .ok_or_else(|| DatasetError::malformed(&self.path, format!("no column `{name}`")))?;
            if col.null_count() > 0 {
                return Err(DatasetError::malformed(&self.path, format!("column `{name}` has null values")));
            }
            out.push(col.as_ref());
        }
        Ok(out)
    }

    fn type_error(&self, name: &str, dt: &DataType, want: &str) -> DatasetError {
        DatasetError::malformed(&self.path, format!("column `{name}` has type {dt}, expected {want}"))
    }

    /// A numeric column as f64 (float16/32/64 and integer columns).
    ///
    /// # Errors
    /// A missing column, nulls, a non-numeric type.
    #[allow(clippy::cast_precision_loss)] // integer columns converted to f64 on purpose
    pub fn f64_column(&self, name: &str) -> Result<Vec<f64>, DatasetError> {
        // No reservation by `self.rows()`: a batch may promise 2^31 rows of a type with no buffers (Null), and an
        // allocation failure aborts (issue 15, found by fuzzing). `extend` reserves by the buffers really there.
        let mut out = Vec::new();
        for a in self.columns(name)? {
            macro_rules! ext {
                ($t:ty, $f:expr) => {
                    match a.as_primitive_opt::<$t>() {
                        Some(p) => out.extend(p.values().iter().map($f)),
                        None => return Err(self.type_error(name, a.data_type(), "a number")),
                    }
                };
            }
            match a.data_type() {
                DataType::Float16 => ext!(Float16Type, |v| f64::from(v.to_f32())),
                DataType::Float32 => ext!(Float32Type, |v| f64::from(*v)),
                DataType::Float64 => ext!(Float64Type, |v| *v),
                DataType::Int8 => ext!(Int8Type, |v| f64::from(*v)),
                DataType::Int16 => ext!(Int16Type, |v| f64::from(*v)),
                DataType::Int32 => ext!(Int32Type, |v| f64::from(*v)),
                DataType::Int64 => ext!(Int64Type, |v| *v as f64),
                DataType::UInt8 => ext!(UInt8Type, |v| f64::from(*v)),
                DataType::UInt16 => ext!(UInt16Type, |v| f64::from(*v)),
                DataType::UInt32 => ext!(UInt32Type, |v| f64::from(*v)),
                DataType::UInt64 => ext!(UInt64Type, |v| *v as f64),
                other => return Err(self.type_error(name, other, "a number")),
            }
        }
        Ok(out)
    }

    /// A float column as f32 (float16 and float32 exactly, float64 rounded).
    ///
    /// # Errors
    /// A missing column, nulls, a non-float type.
    pub fn f32_column(&self, name: &str) -> Result<Vec<f32>, DatasetError> {
        let mut out = Vec::new();
        for a in self.columns(name)? {
            match a.data_type() {
                DataType::Float16 => match a.as_primitive_opt::<Float16Type>() {
                    Some(p) => out.extend(p.values().iter().map(|v| v.to_f32())),
                    None => return Err(self.type_error(name, a.data_type(), "float")),
                },
                DataType::Float32 => match a.as_primitive_opt::<Float32Type>() {
                    Some(p) => out.extend(p.values().iter().copied()),
                    None => return Err(self.type_error(name, a.data_type(), "float")),
                },
                DataType::Float64 => match a.as_primitive_opt::<Float64Type>() {
                    Some(p) => {
                        if let Some(v) = p.values().iter().find(|v| v.abs() > f64::from(f32::MAX)) {
                            return Err(DatasetError::malformed(
                                &self.path,
                                format!("column `{name}`: value {v} is beyond the f32 range"),
                            ));
                        }
                        out.extend(p.values().iter().map(|v| f32_of(*v)));
                    }
                    None => return Err(self.type_error(name, a.data_type(), "float")),
                },
                other => return Err(self.type_error(name, other, "float16/32/64")),
            }
        }
        Ok(out)
    }

    /// An integer column as i64 (signed, or unsigned up to `i64::MAX`).
    ///
    /// # Errors
    /// A missing column, nulls, a non-integer type, an unsigned value above `i64::MAX`.
    pub fn i64_column(&self, name: &str) -> Result<Vec<i64>, DatasetError> {
        let mut out = Vec::new();
        for a in self.columns(name)? {
            macro_rules! ext {
                ($t:ty) => {
                    match a.as_primitive_opt::<$t>() {
                        Some(p) => out.extend(p.values().iter().map(|v| i64::from(*v))),
                        None => return Err(self.type_error(name, a.data_type(), "an integer")),
                    }
                };
            }
            match a.data_type() {
                DataType::Int8 => ext!(Int8Type),
                DataType::Int16 => ext!(Int16Type),
                DataType::Int32 => ext!(Int32Type),
                DataType::Int64 => ext!(Int64Type),
                DataType::UInt8 => ext!(UInt8Type),
                DataType::UInt16 => ext!(UInt16Type),
                DataType::UInt32 => ext!(UInt32Type),
                DataType::UInt64 => match a.as_primitive_opt::<UInt64Type>() {
                    Some(p) => {
                        for v in p.values().iter() {
                            out.push(i64::try_from(*v).map_err(|_| {
                                DatasetError::malformed(&self.path, format!("column `{name}`: value {v} too large"))
                            })?);
                        }
                    }
                    None => return Err(self.type_error(name, a.data_type(), "an integer")),
                },
                other => return Err(self.type_error(name, other, "an integer")),
            }
        }
        Ok(out)
    }

    /// A string column (utf8, large utf8, utf8 view, or a dictionary of utf8).
    ///
    /// # Errors
    /// A missing column, nulls, a non-string type.
    pub fn string_column(&self, name: &str) -> Result<Vec<String>, DatasetError> {
        let mut out = Vec::new();
        for a in self.columns(name)? {
            self.extend_strings(name, a, &mut out)?;
        }
        Ok(out)
    }

    fn extend_strings(&self, name: &str, a: &dyn Array, out: &mut Vec<String>) -> Result<(), DatasetError> {
        match a.data_type() {
            DataType::Utf8 => match a.as_string_opt::<i32>() {
                Some(s) => out.extend(s.iter().map(|v| v.unwrap_or_default().to_string())),
                None => return Err(self.type_error(name, a.data_type(), "utf8")),
            },
            DataType::LargeUtf8 => match a.as_string_opt::<i64>() {
                Some(s) => out.extend(s.iter().map(|v| v.unwrap_or_default().to_string())),
                None => return Err(self.type_error(name, a.data_type(), "utf8")),
            },
            DataType::Utf8View => match a.as_string_view_opt() {
                Some(s) => out.extend(s.iter().map(|v| v.unwrap_or_default().to_string())),
                None => return Err(self.type_error(name, a.data_type(), "utf8")),
            },
            DataType::Dictionary(_, _) => {
                let Some(d) = a.as_any_dictionary_opt() else {
                    return Err(self.type_error(name, a.data_type(), "dictionary"));
                };
                let mut values = Vec::new();
                self.extend_strings(name, d.values().as_ref(), &mut values)?;
                for k in d.normalized_keys() {
                    let v = values.get(k).ok_or_else(|| {
                        DatasetError::malformed(&self.path, format!("column `{name}`: dictionary key {k} out of range"))
                    })?;
                    out.push(v.clone());
                }
            }
            other => return Err(self.type_error(name, other, "a string")),
        }
        Ok(())
    }
}

/// Largest row count or buffer size accepted in a Feather file (2^31).
const MAX_IPC_LEN: i64 = 1 << 31;

/// Checks an Arrow IPC file's footer blocks, record-batch buffers and LZ4 length prefixes against the file
/// before the arrow decoder sees it: every block inside the file, every buffer inside its block's body, every
/// row count and uncompressed length within [`MAX_IPC_LEN`] and (for LZ4) at most 255 times the compressed size.
fn check_ipc_layout(bytes: &[u8]) -> Result<(), String> {
    const MAGIC: &[u8] = b"ARROW1";
    let n = bytes.len();
    if n < 18 || bytes.get(..6) != Some(MAGIC) || bytes.get(n - 6..) != Some(MAGIC) {
        return Err("missing ARROW1 magic at start or end (truncated?)".into());
    }
    let flen = bytes.get(n - 10..n - 6).ok_or("truncated footer")?;
    let flen = i32::from_le_bytes([flen[0], flen[1], flen[2], flen[3]]);
    let flen = usize::try_from(flen).map_err(|_| format!("negative footer length {flen}"))?;
    let footer_start = (n - 10).checked_sub(flen).filter(|s| *s >= 8).ok_or("footer length exceeds the file")?;
    let footer = arrow_ipc::root_as_footer(bytes.get(footer_start..n - 10).ok_or("bad footer")?)
        .map_err(|e| format!("bad footer: {e}"))?;
    let blocks = footer.recordBatches().into_iter().flatten().chain(footer.dictionaries().into_iter().flatten());
    for b in blocks {
        let size = |v: i64, what: &str| usize::try_from(v).map_err(|_| format!("negative block {what} {v}"));
        let off = size(b.offset(), "offset")?;
        let meta = size(i64::from(b.metaDataLength()), "metadata length")?;
        let body = size(b.bodyLength(), "body length")?;
        let body_start = off.checked_add(meta).ok_or("block overflows")?;
        let end = body_start.checked_add(body).ok_or("block overflows")?;
        if end > footer_start || meta < 8 {
            return Err(format!("block at {off} (metadata {meta}, body {body} bytes) lies outside the data"));
        }
        let msg = bytes.get(off..body_start).ok_or("bad block")?;
        let skip = if msg.get(..4) == Some(&[0xff; 4]) { 8 } else { 4 };
        let msg = arrow_ipc::root_as_message(msg.get(skip..).ok_or("bad block")?)
            .map_err(|e| format!("bad message at {off}: {e}"))?;
        if usize::try_from(msg.bodyLength()).ok() != Some(body) {
            return Err(format!("message at {off}: body length {} disagrees with the footer", msg.bodyLength()));
        }
        let Some(rb) = msg.header_as_record_batch().or_else(|| msg.header_as_dictionary_batch().and_then(|d| d.data()))
        else {
            continue;
        };
        let in_range = |v: i64| (0..=MAX_IPC_LEN).contains(&v);
        if !in_range(rb.length())
            || rb.nodes().into_iter().flatten().any(|f| !in_range(f.length()) || !in_range(f.null_count()))
        {
            return Err(format!("message at {off}: row or null count out of range"));
        }
        let compressed = rb.compression().is_some();
        for buf in rb.buffers().into_iter().flatten() {
            let (o, l) = (buf.offset(), buf.length());
            let (Ok(o), Ok(l)) = (usize::try_from(o), usize::try_from(l)) else {
                return Err(format!("message at {off}: negative buffer offset or length"));
            };
            if o.checked_add(l).is_none_or(|e| e > body) {
                return Err(format!("message at {off}: buffer {o}+{l} outside the {body}-byte body"));
            }
            if compressed && l > 0 {
                let at = body_start + o;
                let prefix =
                    bytes.get(at..at + 8).filter(|_| l >= 8).ok_or("compressed buffer shorter than 8 bytes")?;
                let raw = i64::from_le_bytes([
                    prefix[0], prefix[1], prefix[2], prefix[3], prefix[4], prefix[5], prefix[6], prefix[7],
                ]);
                let limit =
                    i64::try_from(l).unwrap_or(i64::MAX).saturating_mul(255).saturating_add(64).min(MAX_IPC_LEN);
                if raw != -1 && !(0..=limit).contains(&raw) {
                    return Err(format!("message at {off}: uncompressed length {raw} implausible for {l} bytes"));
                }
            }
        }
    }
    Ok(())
}

// -------------------------------------------------------------------------------------------------------------
// Sweeps, poses, calibration
// -------------------------------------------------------------------------------------------------------------

/// A LiDAR sweep in AV2's ego frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// Sweep timestamp (file name), nanoseconds.
    pub timestamp_ns: i64,
    /// Points `x, y, z` in the ego frame (float16 in the file), metres.
    pub points_in_ego: Vec<[f32; 3]>,
    /// Laser number of each point (0..31 up LiDAR, 32..63 down LiDAR).
    pub laser_number: Vec<u8>,
}

/// Reads `sensors/lidar/<timestamp_ns>.feather`.
///
/// # Errors
/// A file name that is not a timestamp, a malformed Feather file, missing or mistyped columns.
pub fn read_sweep(path: &Path) -> Result<Sweep, DatasetError> {
    let timestamp_ns = path
        .file_stem()
        .and_then(|s| s.to_str())
        .and_then(|s| s.parse::<i64>().ok())
        .ok_or_else(|| DatasetError::malformed(path, "sweep file name is not a nanosecond timestamp"))?;
    let t = FeatherTable::read(path)?;
    let (x, y, z) = (t.f32_column("x")?, t.f32_column("y")?, t.f32_column("z")?);
    let lasers = t.i64_column("laser_number")?;
    let points_in_ego = x.iter().zip(&y).zip(&z).map(|((x, y), z)| [*x, *y, *z]).collect();
    let laser_number = lasers.iter().map(|v| u8::try_from(*v).unwrap_or(u8::MAX)).collect();
    Ok(Sweep { timestamp_ns, points_in_ego, laser_number })
}

/// Ego poses `city_SE3_egovehicle`, sorted by time.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseTrack {
    /// Timestamps, nanoseconds, strictly increasing.
    pub timestamps_ns: Vec<i64>,
    /// `city_from_ego` at each timestamp.
    pub city_from_ego: Vec<Rigid3>,
}

impl PoseTrack {
    /// Reads `city_SE3_egovehicle.feather`.
    ///
    /// # Errors
    /// Malformed file, missing columns, non-unit quaternions, repeated timestamps, no rows.
    pub fn read(path: &Path) -> Result<Self, DatasetError> {
        let t = FeatherTable::read(path)?;
        let poses = read_se3_rows(&t, path)?;
        let ts = t.i64_column("timestamp_ns")?;
        let mut rows: Vec<(i64, Rigid3)> = ts.into_iter().zip(poses).collect();
        rows.sort_by_key(|r| r.0);
        if rows.is_empty() {
            return Err(DatasetError::malformed(path, "no poses"));
        }
        if rows.windows(2).any(|w| w.first().map(|a| a.0) == w.get(1).map(|b| b.0)) {
            return Err(DatasetError::malformed(path, "repeated timestamp"));
        }
        Ok(Self {
            timestamps_ns: rows.iter().map(|r| r.0).collect(),
            city_from_ego: rows.iter().map(|r| r.1).collect(),
        })
    }

    /// The pose nearest in time to `t_ns` and its time offset (nanoseconds, absolute).
    #[must_use]
    pub fn nearest(&self, t_ns: i64) -> Option<(Rigid3, i64)> {
        let i = self.timestamps_ns.partition_point(|t| *t < t_ns);
        let mut best: Option<(usize, i64)> = None;
        for j in [i.checked_sub(1), Some(i)].into_iter().flatten() {
            if let Some(t) = self.timestamps_ns.get(j) {
                let d = t.abs_diff(t_ns);
                let d = i64::try_from(d).unwrap_or(i64::MAX);
                if best.is_none_or(|(_, bd)| d < bd) {
                    best = Some((j, d));
                }
            }
        }
        let (j, d) = best?;
        Some((*self.city_from_ego.get(j)?, d))
    }
}

fn read_se3_rows(t: &FeatherTable, path: &Path) -> Result<Vec<Rigid3>, DatasetError> {
    let cols = ["qw", "qx", "qy", "qz", "tx_m", "ty_m", "tz_m"].map(|c| t.f64_column(c));
    let [qw, qx, qy, qz, tx, ty, tz] = cols;
    let (qw, qx, qy, qz, tx, ty, tz) = (qw?, qx?, qy?, qz?, tx?, ty?, tz?);
    let mut out = Vec::with_capacity(qw.len());
    for i in 0..qw.len() {
        let g = |v: &Vec<f64>| v.get(i).copied().unwrap_or(f64::NAN);
        let r = Rigid3::from_quat_translation([g(&qw), g(&qx), g(&qy), g(&qz)], [g(&tx), g(&ty), g(&tz)])
            .ok_or_else(|| DatasetError::malformed(path, format!("row {i}: not a unit quaternion or not finite")))?;
        out.push(r);
    }
    Ok(out)
}

/// Reads `calibration/egovehicle_SE3_sensor.feather`: sensor name -> `ego_from_sensor`.
///
/// # Errors
/// Malformed file, missing columns, non-unit quaternions.
pub fn read_extrinsics(path: &Path) -> Result<BTreeMap<String, Rigid3>, DatasetError> {
    let t = FeatherTable::read(path)?;
    let names = t.string_column("sensor_name")?;
    let poses = read_se3_rows(&t, path)?;
    Ok(names.into_iter().zip(poses).collect())
}

// -------------------------------------------------------------------------------------------------------------
// Ground raster
// -------------------------------------------------------------------------------------------------------------

/// A 2D similarity `p_img = scale * (R * p_city + t)` (AV2 `Sim2` JSON: `{"R": [4], "t": [2], "s": scale}`).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub struct Sim2 {
    /// Row-major 2x2 rotation.
    #[serde(rename = "R")]
    pub rotation: [f64; 4],
    /// Translation (city units).
    #[serde(rename = "t")]
    pub translation: [f64; 2],
    /// Scale, cells per metre.
    #[serde(rename = "s")]
    pub scale: f64,
}

impl Sim2 {
    /// Applies the similarity.
    #[must_use]
    pub fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        let [a, b, c, d] = self.rotation;
        let [tx, ty] = self.translation;
        (self.scale * (a * x + b * y + tx), self.scale * (c * x + d * y + ty))
    }
}

/// A float array read from a `.npy` file (C order, little-endian float16/32/64), as f32.
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    /// Shape.
    pub shape: Vec<usize>,
    /// Values, C (row-major) order.
    pub data: Vec<f32>,
}

/// Parses a `.npy` file holding a little-endian float array in C order.
///
/// # Errors
/// Bad magic, truncated header or data, unsupported dtype or Fortran order.
pub fn parse_npy(bytes: &[u8]) -> Result<NpyArray, String> {
    let magic = bytes.get(..6).ok_or("truncated: no .npy magic")?;
    if magic != b"\x93NUMPY" {
        return Err("not a .npy file (bad magic)".into());
    }
    let major = *bytes.get(6).ok_or("truncated header")?;
    let (hlen, start) = match major {
        1 => {
            let b = bytes.get(8..10).ok_or("truncated header")?;
            (usize::from(u16::from_le_bytes([b[0], b[1]])), 10usize)
        }
        2 | 3 => {
            let b = bytes.get(8..12).ok_or("truncated header")?;
            let n = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            (usize::try_from(n).map_err(|_| "header too long")?, 12usize)
        }
        v => return Err(format!("unsupported .npy version {v}")),
    };
    let end = start.checked_add(hlen).ok_or("header length overflows")?;
    let header = bytes.get(start..end).ok_or("truncated header")?;
    let header = std::str::from_utf8(header).map_err(|_| "header is not text")?;
    let field = |key: &str| -> Result<&str, String> {
        let at = header.find(&format!("'{key}'")).ok_or(format!("header has no '{key}'"))?;
        let rest = header.get(at + key.len() + 2..).unwrap_or_default();
        let rest = rest.trim_start().strip_prefix(':').ok_or(format!("header: no ':' after '{key}'"))?;
        Ok(rest.trim_start())
    };
    let descr = field("descr")?;
    let descr = descr.strip_prefix('\'').and_then(|r| r.split('\'').next()).ok_or("header: bad 'descr'")?;
    let size = match descr {
        "<f2" => 2,
        "<f4" => 4,
        "<f8" => 8,
        other => return Err(format!("unsupported dtype `{other}` (little-endian float16/32/64 only)")),
    };
    if field("fortran_order")?.starts_with("True") {
        return Err("Fortran-order arrays are not supported".into());
    }
    let shape = field("shape")?;
    let shape = shape.strip_prefix('(').and_then(|r| r.split(')').next()).ok_or("header: bad 'shape'")?;
    let shape: Vec<usize> = shape
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>().map_err(|_| format!("header: bad shape entry `{s}`")))
        .collect::<Result<_, _>>()?;
    let count = shape.iter().try_fold(1usize, |a, b| a.checked_mul(*b)).ok_or("shape overflows")?;
    let nbytes = count.checked_mul(size).ok_or("shape overflows")?;
    let data = bytes.get(end..).unwrap_or_default();
    if data.len() != nbytes {
        return Err(format!("data has {} bytes, shape {shape:?} of {descr} needs {nbytes}: truncated?", data.len()));
    }
    let values = match size {
        2 => data.chunks_exact(2).map(|c| half::f16::from_le_bytes([c[0], c[1]]).to_f32()).collect(),
        4 => data.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect(),
        _ => data
            .chunks_exact(8)
            .map(|c| f32_of(f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]])))
            .collect(),
    };
    Ok(NpyArray { shape, data: values })
}

/// AV2 ground-height raster: heights (city frame z, metres) on a grid addressed by `img_from_city`
/// (column = image x, row = image y), NaN where unknown.
#[derive(Clone, Debug, PartialEq)]
pub struct GroundRaster {
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// Row-major heights, metres (NaN unknown).
    pub heights_m: Vec<f32>,
    /// City to image similarity.
    pub img_from_city: Sim2,
}

impl GroundRaster {
    /// Reads the raster of a log's `map/` folder: `*_ground_height_surface____*.npy` and
    /// `*___img_Sim2_city.json`.
    ///
    /// # Errors
    /// Missing or several candidate files, malformed files.
    pub fn open(map_dir: &Path) -> Result<Self, DatasetError> {
        let one = |suffix_test: &dyn Fn(&str) -> bool, what: &str| -> Result<PathBuf, DatasetError> {
            let files = list_dir(map_dir, suffix_test)?;
            match files.as_slice() {
                [f] => Ok(f.clone()),
                [] => Err(DatasetError::malformed(map_dir, format!("no {what}"))),
                _ => Err(DatasetError::malformed(map_dir, format!("several {what} files"))),
            }
        };
        let npy =
            one(&|n: &str| n.contains("_ground_height_surface____") && n.ends_with(".npy"), "ground height .npy")?;
        let json = one(&|n: &str| n.ends_with("___img_Sim2_city.json"), "img_Sim2_city .json")?;
        Self::from_files(&npy, &json)
    }

    /// Reads a raster from its two files.
    ///
    /// # Errors
    /// Malformed files, a raster that is not 2D, a non-positive scale.
    pub fn from_files(npy: &Path, sim2_json: &Path) -> Result<Self, DatasetError> {
        let arr = parse_npy(&read_bytes(npy)?).map_err(|m| DatasetError::malformed(npy, m))?;
        let [rows, cols] = arr.shape.as_slice() else {
            return Err(DatasetError::malformed(npy, format!("raster shape {:?} is not 2D", arr.shape)));
        };
        let sim: Sim2 = serde_json::from_str(&read_text(sim2_json)?)
            .map_err(|e| DatasetError::malformed(sim2_json, e.to_string()))?;
        let finite = sim.rotation.iter().chain(sim.translation.iter()).all(|v| v.is_finite());
        if !(finite && sim.scale.is_finite() && sim.scale > 0.0) {
            return Err(DatasetError::malformed(sim2_json, "non-finite values or non-positive scale"));
        }
        Ok(Self { rows: *rows, cols: *cols, heights_m: arr.data, img_from_city: sim })
    }

    /// Cell size, metres.
    #[must_use]
    pub fn resolution_m(&self) -> f64 {
        1.0 / self.img_from_city.scale
    }

    /// Ground height (city z, metres) at city `(x, y)`; `None` outside the raster or where unknown. The cell is
    /// the integer part of the image coordinates, as the AV2 API does.
    #[must_use]
    pub fn height_at_city(&self, x_m: f64, y_m: f64) -> Option<f32> {
        let (c, r) = self.img_from_city.apply(x_m, y_m);
        if !(c >= 0.0 && r >= 0.0) {
            return None;
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // non-negative, bounds-checked below
        let (c, r) = (c.floor() as usize, r.floor() as usize);
        if c >= self.cols || r >= self.rows {
            return None;
        }
        let h = *self.heights_m.get(r.checked_mul(self.cols)?.checked_add(c)?)?;
        h.is_finite().then_some(h)
    }
}

// -------------------------------------------------------------------------------------------------------------
// Annotations and the log reader
// -------------------------------------------------------------------------------------------------------------

/// The monitor's class for an AV2 category.
#[must_use]
pub fn class_of(category: &str) -> ObjectClass {
    match category {
        "REGULAR_VEHICLE" => ObjectClass::Car,
        "LARGE_VEHICLE"
        | "BUS"
        | "BOX_TRUCK"
        | "TRUCK"
        | "TRUCK_CAB"
        | "VEHICULAR_TRAILER"
        | "SCHOOL_BUS"
        | "ARTICULATED_BUS"
        | "RAILED_VEHICLE"
        | "MESSAGE_BOARD_TRAILER"
        | "TRAFFIC_LIGHT_TRAILER" => ObjectClass::Truck,
        "PEDESTRIAN" | "OFFICIAL_SIGNALER" => ObjectClass::Pedestrian,
        "BICYCLIST" | "WHEELED_RIDER" => ObjectClass::Cyclist,
        "MOTORCYCLIST" => ObjectClass::Motorcyclist,
        "BICYCLE"
        | "MOTORCYCLE"
        | "WHEELED_DEVICE"
        | "STROLLER"
        | "WHEELCHAIR"
        | "BOLLARD"
        | "CONSTRUCTION_CONE"
        | "CONSTRUCTION_BARREL"
        | "SIGN"
        | "STOP_SIGN"
        | "MOBILE_PEDESTRIAN_CROSSING_SIGN"
        | "DOG"
        | "ANIMAL" => ObjectClass::Other,
        _ => ObjectClass::Unknown,
    }
}

/// One annotation row.
#[derive(Clone, Debug, PartialEq)]
pub struct Cuboid {
    /// Timestamp, nanoseconds.
    pub timestamp_ns: i64,
    /// Track uuid.
    pub track_uuid: String,
    /// Category.
    pub category: String,
    /// Length, width, height, metres.
    pub size_m: [f64; 3],
    /// `ego_from_cuboid` (rotation from the quaternion, translation = geometric centre).
    pub ego_from_cuboid: Rigid3,
    /// Points inside, per the dataset.
    pub num_interior_pts: i64,
}

/// Reads `annotations.feather` (or `annotations_with_ego.feather`).
///
/// # Errors
/// Malformed file, missing columns, non-unit quaternions, non-positive sizes.
pub fn read_annotations(path: &Path) -> Result<Vec<Cuboid>, DatasetError> {
    let t = FeatherTable::read(path)?;
    let ts = t.i64_column("timestamp_ns")?;
    let uuid = t.string_column("track_uuid")?;
    let cat = t.string_column("category")?;
    let (l, w, h) = (t.f64_column("length_m")?, t.f64_column("width_m")?, t.f64_column("height_m")?);
    let n = t.i64_column("num_interior_pts")?;
    let poses = read_se3_rows(&t, path)?;
    let mut out = Vec::with_capacity(ts.len());
    for (i, (((((ts, uuid), cat), pose), n), ((l, w), h))) in
        ts.into_iter().zip(uuid).zip(cat).zip(poses).zip(n).zip(l.into_iter().zip(w).zip(h)).enumerate()
    {
        if !(l > 0.0 && w > 0.0 && h > 0.0) {
            return Err(DatasetError::malformed(path, format!("row {i}: non-positive size {l} x {w} x {h}")));
        }
        out.push(Cuboid {
            timestamp_ns: ts,
            track_uuid: uuid,
            category: cat,
            size_m: [l, w, h],
            ego_from_cuboid: pose,
            num_interior_pts: n,
        });
    }
    Ok(out)
}

#[allow(clippy::cast_precision_loss)] // nanosecond timestamps: f64 keeps ~60 ns at 3e17 ns, plenty for 10 Hz
fn seconds_of_ns(ns: i64) -> f64 {
    ns as f64 * 1e-9
}

/// Reads an AV2 sensor log directory: one frame per annotation timestamp (10 Hz), with the sweep of the
/// same timestamp when `sensors/lidar/<ts>.feather` exists, the ego pose nearest in time from
/// `city_SE3_egovehicle.feather`, and the cuboids in the ego frame (the synthetic `EGO_VEHICLE` track dropped).
/// Speeds are central differences of each track's city-frame positions over neighbouring annotation frames
/// (at most 0.5 s apart): speed over ground. Headings are the cuboid quaternions' yaw.
///
/// # Errors
/// Missing required files (`annotations*.feather`, `city_SE3_egovehicle.feather`, and the extrinsics when a sweep
/// is read), malformed files, repeated track in one frame.
pub fn open_log(dir: &Path, opts: &ReadOptions) -> Result<Dataset, DatasetError> {
    open_log_with(dir, opts, false).map(|(ds, _)| ds)
}

/// The sweeps of an Argoverse 2 log opened by [`open_log_deferred`]: one frame's cloud read (and levelled) when
/// asked, never held.
#[derive(Clone, Debug)]
pub struct Av2Sweeps {
    /// The up-LiDAR's extrinsic (`None`: no sweep is read).
    up_lidar: Option<Rigid3>,
    /// Per frame: its sweep file, if one matched its timestamp.
    files: Vec<Option<PathBuf>>,
    /// Per frame: the ego pose (city frame).
    poses: Vec<Rigid3>,
    raster: Option<GroundRaster>,
    ground_z_m: f32,
    ground: GroundMode,
    /// Level each sweep by the local estimate as it is read (what [`crate::open_with`] does after the reader with
    /// [`GroundMode::Local`]).
    level_local: bool,
}

impl Av2Sweeps {
    /// True when frame `index` has a sweep.
    #[must_use]
    pub fn has_sweep(&self, index: usize) -> bool {
        self.up_lidar.is_some() && self.files.get(index).is_some_and(Option::is_some)
    }

    /// Reads frame `index`'s sweep, levelled as [`open_log`] levels it (the ground raster per return with
    /// [`GroundMode::Auto`], the local estimate with [`GroundMode::Local`]); `None` when the frame has none.
    ///
    /// # Errors
    /// A missing or malformed sweep file.
    pub fn cloud(&self, index: usize) -> Result<Option<OwnedCloud>, DatasetError> {
        Ok(self.cloud_and_stats(index)?.map(|(c, _)| c))
    }

    fn cloud_and_stats(&self, index: usize) -> Result<Option<(OwnedCloud, Option<LevelStats>)>, DatasetError> {
        let (Some(up), Some(Some(path)), Some(pose)) = (self.up_lidar, self.files.get(index), self.poses.get(index))
        else {
            return Ok(None);
        };
        let pose = *pose;
        let sweep = read_sweep(path)?;
        let o = up.translation_m;
        let (ox, oy, oz) = (f32_of(o[0]), f32_of(o[1]), f32_of(o[2]));
        let mut cloud = OwnedCloud {
            points_in_sensor: sweep.points_in_ego.iter().map(|p| [p[0] - ox, p[1] - oy, p[2] - oz]).collect(),
            ego_from_sensor: Isometry3::from_translation(ox, oy, oz),
        };
        let ego = DatasetFormat::Argoverse2.ego_footprint_m();
        // The ground raster per return (the height of each return over the city-frame ground under it), the
        // local estimate where the raster has no value.
        let stats = match (&self.raster, self.ground) {
            (Some(r), GroundMode::Auto) => {
                let known = |q: [f32; 3]| {
                    let c = pose.apply([f64::from(q[0]), f64::from(q[1]), f64::from(q[2])]);
                    let h = r.height_at_city(c[0], c[1])?;
                    Some(q[2] - f32_of(c[2] - f64::from(h)))
                };
                Some(level_cloud(&mut cloud, self.ground_z_m, ego, Default::default(), &known))
            }
            _ => None,
        };
        if self.level_local {
            level_cloud(&mut cloud, self.ground_z_m, ego, Default::default(), &|_| None);
        }
        Ok(Some((cloud, stats)))
    }
}

/// [`open_log`] without reading the sweeps: the frames (objects, poses, ROI) with `cloud: None`, and the
/// [`Av2Sweeps`] that reads one frame's sweep when asked, levelled as [`open_log`] would have (so that a log
/// can be streamed a frame at a time). The region of interest and the checks of [`crate::open_with`] are
/// applied; with [`GroundMode::Local`] each sweep is levelled by the local estimate as it is read. The notes
/// say how many sweeps matched; the share of returns levelled by the raster is not known before they are read.
///
/// # Errors
/// As [`open_log`], except for the sweep files, whose errors come when they are read.
pub fn open_log_deferred(dir: &Path, opts: &ReadOptions) -> Result<(Dataset, Av2Sweeps), DatasetError> {
    let (mut ds, mut sweeps) = open_log_with(dir, opts, true)?;
    crate::roi::finish(&mut ds, &opts.roi);
    if crate::ground::levels_locally(&ds, opts.ground) {
        let n = (0..ds.frames.len()).filter(|&i| sweeps.has_sweep(i)).count();
        crate::ground::push_local_note(&mut ds, n);
        sweeps.level_local = true;
    }
    crate::check_finite(&ds)?;
    Ok((ds, sweeps))
}

fn open_log_with(dir: &Path, opts: &ReadOptions, defer: bool) -> Result<(Dataset, Av2Sweeps), DatasetError> {
    let ann_path = ["annotations.feather", "annotations_with_ego.feather"]
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.exists())
        .unwrap_or_else(|| dir.join("annotations.feather"));
    let cuboids = read_annotations(&ann_path)?;
    let poses_path = dir.join("city_SE3_egovehicle.feather");
    let poses = PoseTrack::read(&poses_path)?;
    // The ground raster is optional: some published logs ship only the vector map (the nominal ground height
    // is used then, as without a map folder).
    let map_dir = dir.join("map");
    let has_raster = map_dir.is_dir()
        && !list_dir(&map_dir, |n| n.contains("_ground_height_surface____") && n.ends_with(".npy"))?.is_empty();
    let raster = if has_raster { Some(GroundRaster::open(&map_dir)?) } else { None };
    // The vector map becomes each frame's region of interest (unless another ROI was asked for).
    let vector_map = match opts.roi.mode {
        RoiMode::Auto => find_vector_map(&map_dir)?.map(|p| VectorMap::read(&p)).transpose()?,
        RoiMode::WholeGrid | RoiMode::Corridor { .. } => None,
    };
    let map_opts =
        MapRoiOptions { sidewalk_width_m: opts.roi.sidewalk_width_m, clip_half_extent_m: opts.roi.grid_half_extent_m };
    let mut roi_polygons = 0usize;
    let lidar_dir = dir.join("sensors").join("lidar");
    let sweep_files: BTreeMap<i64, PathBuf> = if lidar_dir.is_dir() {
        list_dir(&lidar_dir, |n| n.ends_with(".feather"))?
            .into_iter()
            .filter_map(|p| {
                let ts = p.file_stem()?.to_str()?.parse::<i64>().ok()?;
                Some((ts, p))
            })
            .collect()
    } else {
        BTreeMap::new()
    };
    let extr_path = dir.join("calibration").join("egovehicle_SE3_sensor.feather");
    let mut calibration_warning = None;
    let up_lidar: Option<Rigid3> = if opts.load_clouds && !sweep_files.is_empty() {
        if extr_path.exists() {
            let extr = read_extrinsics(&extr_path)?;
            Some(*extr.get("up_lidar").ok_or_else(|| DatasetError::malformed(&extr_path, "no `up_lidar` row"))?)
        } else {
            calibration_warning = Some(format!(
                "{WARNING_PREFIX}{} is missing: the up-LiDAR origin is the documented nominal one, \
                 ({}, {}, {}) m in the ego frame (docs/datasets.md); occlusion reasoning may be off by a few cm",
                extr_path.display(),
                NOMINAL_UP_LIDAR_ORIGIN_M[0],
                NOMINAL_UP_LIDAR_ORIGIN_M[1],
                NOMINAL_UP_LIDAR_ORIGIN_M[2]
            ));
            Some(Rigid3 { translation_m: NOMINAL_UP_LIDAR_ORIGIN_M, ..Rigid3::IDENTITY })
        }
    } else {
        None
    };

    // group by timestamp, drop the ego track
    let mut by_time: BTreeMap<i64, Vec<&Cuboid>> = BTreeMap::new();
    let mut ego_rows = 0usize;
    for c in &cuboids {
        if c.category == EGO_CATEGORY {
            ego_rows += 1;
            continue;
        }
        by_time.entry(c.timestamp_ns).or_default().push(c);
    }
    for list in by_time.values_mut() {
        list.sort_by(|a, b| a.track_uuid.cmp(&b.track_uuid));
        if let Some(w) = list.windows(2).find(|w| w.first().map(|a| &a.track_uuid) == w.get(1).map(|b| &b.track_uuid)) {
            let uuid = w.first().map(|c| c.track_uuid.clone()).unwrap_or_default();
            return Err(DatasetError::malformed(&ann_path, format!("track {uuid} appears twice at one timestamp")));
        }
    }
    // the ego pose per frame
    let mut frame_pose: BTreeMap<i64, Rigid3> = BTreeMap::new();
    let mut worst_pose_gap_ns = 0i64;
    for ts in by_time.keys() {
        let (pose, gap) = poses.nearest(*ts).ok_or_else(|| DatasetError::malformed(&poses_path, "no poses"))?;
        worst_pose_gap_ns = worst_pose_gap_ns.max(gap);
        frame_pose.insert(*ts, pose);
    }
    // ids by first appearance, city-frame tracks, speeds
    let mut ids: BTreeMap<&str, u64> = BTreeMap::new();
    let mut tracks: BTreeMap<&str, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for (ts, list) in &by_time {
        let pose = frame_pose.get(ts).copied().unwrap_or_default();
        for c in list {
            let next = u64::try_from(ids.len() + 1).unwrap_or(u64::MAX);
            ids.entry(c.track_uuid.as_str()).or_insert(next);
            let p = pose.apply(c.ego_from_cuboid.translation_m);
            tracks.entry(c.track_uuid.as_str()).or_default().push((seconds_of_ns(*ts), p[0], p[1]));
        }
    }
    let speeds: BTreeMap<&str, Vec<Option<f64>>> =
        tracks.iter().map(|(k, obs)| (*k, finite_difference_speeds(obs, MAX_GAP_S))).collect();
    let mut cursor: BTreeMap<&str, usize> = BTreeMap::new();

    // ground height under the ego origin, in the ego frame
    let mut ground: Vec<f64> = Vec::new();
    if let Some(r) = &raster {
        for pose in frame_pose.values() {
            let [x, y, _] = pose.translation_m;
            if let Some(h) = r.height_at_city(x, y) {
                let p = pose.inverse().apply([x, y, f64::from(h)]);
                ground.push(p[2]);
            }
        }
    }
    ground.sort_by(f64::total_cmp);
    let ground_z_m = ground.get(ground.len() / 2).map_or(NOMINAL_GROUND_Z_M, |g| f32_of(*g));

    let mut sweeps = Av2Sweeps {
        up_lidar,
        files: Vec::new(),
        poses: Vec::new(),
        raster,
        ground_z_m,
        ground: opts.ground,
        level_local: false,
    };
    let mut frames = Vec::new();
    let mut levelled = (0usize, 0usize, 0usize);
    let mut no_speed = 0usize;
    let mut sweeps_used = 0usize;
    for (ts, list) in &by_time {
        let pose = frame_pose.get(ts).copied().unwrap_or_default();
        let index = u64::try_from(frames.len()).unwrap_or(u64::MAX);
        let mut frame = RecordedFrame::empty(index, seconds_of_ns(*ts), pose.to_pose2());
        if let Some(m) = &vector_map {
            frame.roi_in_ego = m.roi_in_ego(&pose.inverse(), &map_opts);
            roi_polygons += frame.roi_in_ego.len();
        }
        let mut extras = Vec::with_capacity(list.len());
        for c in list {
            let k = cursor.entry(c.track_uuid.as_str()).or_insert(0);
            let speed = speeds.get(c.track_uuid.as_str()).and_then(|v| v.get(*k)).copied().flatten();
            *k += 1;
            if speed.is_none() {
                no_speed += 1;
            }
            let [l, w, h] = c.size_m;
            let t = c.ego_from_cuboid.translation_m;
            frame.objects.push(ObjectState {
                id: ids.get(c.track_uuid.as_str()).copied().unwrap_or(0),
                class: class_of(&c.category),
                x_m: f32_of(t[0]),
                y_m: f32_of(t[1]),
                heading_rad: f32_of(wrap_angle(c.ego_from_cuboid.yaw_rad())),
                speed_mps: f32_of(speed.unwrap_or(0.0)),
                length_m: f32_of(l),
                width_m: f32_of(w),
                uncertainty: None,
            });
            extras.push(ObjectExtra {
                track_key: c.track_uuid.clone(),
                category: c.category.clone(),
                height_m: Some(f32_of(h)),
                z_center_m: Some(f32_of(t[2])),
                num_points: u32::try_from(c.num_interior_pts).ok(),
                accel_mps2: None,
            });
        }
        let index = frames.len();
        sweeps.files.push(if up_lidar.is_some() { sweep_files.get(ts).cloned() } else { None });
        sweeps.poses.push(pose);
        if sweeps.has_sweep(index) {
            sweeps_used += 1;
            if !defer {
                if let Some((cloud, stats)) = sweeps.cloud_and_stats(index)? {
                    frame.cloud = Some(cloud);
                    if let Some(s) = stats {
                        levelled = (levelled.0 + s.from_dataset, levelled.1 + s.from_estimate, levelled.2 + 1);
                    }
                }
            } else if sweeps.raster.is_some() && opts.ground == GroundMode::Auto {
                levelled.2 += 1;
            }
        }
        frames.push(DatasetFrame { frame, extras });
    }
    let mut notes = vec![
        format!(
            "ego frame = AV2 ego-vehicle frame (rear axle, above the ground): ground_z_m = {ground_z_m:.3} m {}",
            if ground.is_empty() {
                "(nominal: no ground raster)".to_string()
            } else {
                format!("(median over {} frames of the ground raster under the ego origin)", ground.len())
            }
        ),
        "points in a sensor-centred, ego-aligned frame: p_sensor = p_ego - up_lidar origin, ego_from_sensor = \
         translation(up_lidar origin); down-LiDAR returns get the up-LiDAR origin too"
            .to_string(),
        "speed = central difference of city-frame track positions over annotation frames <= 0.5 s apart (over \
         ground); heading = cuboid quaternion yaw; ego pose = nearest city_SE3_egovehicle row"
            .to_string(),
        format!("worst ego-pose time offset {:.1} ms", seconds_of_ns(worst_pose_gap_ns) * 1e3),
        format!("{sweeps_used} of {} sweep files matched an annotation timestamp", sweep_files.len()),
    ];
    if let Some(m) = &vector_map {
        notes.push(format!(
            "{ROI_NOTE_PREFIX}the log's vector map {}: {} drivable areas and {} pedestrian crossings, {}, clipped to \
             the {} m grid square ({:.0} polygons per frame on average){}",
            m.path.file_name().and_then(|n| n.to_str()).unwrap_or("?"),
            m.drivable_areas.len(),
            m.crossings.len(),
            if map_opts.sidewalk_width_m > 0.0 {
                format!("a {} m sidewalk band along the drivable areas' boundary", map_opts.sidewalk_width_m)
            } else {
                "no sidewalk band (--sidewalk-m 0)".to_string()
            },
            2.0 * map_opts.clip_half_extent_m,
            roi_polygons as f64 / frames.len().max(1) as f64,
            if m.skipped_areas + m.skipped_crossings > 0 {
                format!(
                    "; skipped {} drivable areas with fewer than 3 points and {} crossings without two 2-point edges",
                    m.skipped_areas, m.skipped_crossings
                )
            } else {
                String::new()
            }
        ));
    }
    if levelled.2 > 0 && defer {
        notes.push(format!(
            "{GROUND_NOTE_PREFIX}{} sweeps levelled to the log's ground raster per return as they are read (the local \
             estimate where the raster has no value)",
            levelled.2
        ));
    } else if levelled.2 > 0 {
        notes.push(format!(
            "{GROUND_NOTE_PREFIX}{} sweeps levelled to the log's ground raster per return ({:.1} % of the returns; \
             the local estimate for the rest, where the raster has no value)",
            levelled.2,
            100.0 * levelled.0 as f64 / (levelled.0 + levelled.1).max(1) as f64
        ));
    }
    if ego_rows > 0 {
        notes.push(format!("{ego_rows} rows of the synthetic {EGO_CATEGORY} track dropped"));
    }
    notes.extend(calibration_warning);
    if no_speed > 0 {
        notes.push(format!("{no_speed} cuboids of tracks seen once (or isolated) get speed 0"));
    }
    let ds = Dataset {
        info: DatasetInfo {
            name: dir.file_name().and_then(|s| s.to_str()).unwrap_or("av2").to_string(),
            format: DatasetFormat::Argoverse2,
            source: dir.to_path_buf(),
            ground_z_m,
            ego_pose_known: true,
            speed_source: SpeedSource::FiniteDifferenceWorld,
            frame_period_s: Some(0.1),
            notes,
        },
        frames,
    };
    Ok((ds, sweeps))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn npy(header: &str, data: &[u8]) -> Vec<u8> {
        let mut h = header.to_string();
        while !(10 + h.len() + 1).is_multiple_of(64) {
            h.push(' ');
        }
        h.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&u16::try_from(h.len()).unwrap().to_le_bytes());
        out.extend_from_slice(h.as_bytes());
        out.extend_from_slice(data);
        out
    }

    #[test]
    fn npy_float16_and_errors() {
        let mut data = Vec::new();
        for v in [1.0f32, 2.5, f32::NAN, -0.25, 3.0, 4.0] {
            data.extend_from_slice(&half::f16::from_f32(v).to_le_bytes());
        }
        let bytes = npy("{'descr': '<f2', 'fortran_order': False, 'shape': (2, 3), }", &data);
        let a = parse_npy(&bytes).unwrap();
        assert_eq!(a.shape, vec![2, 3]);
        assert!((a.data[1] - 2.5).abs() < 1e-6 && a.data[2].is_nan());
        assert!(parse_npy(&bytes[..bytes.len() - 1]).unwrap_err().contains("truncated"));
        let bad = npy("{'descr': '>f8', 'fortran_order': False, 'shape': (2, 3), }", &data);
        assert!(parse_npy(&bad).is_err());
        let fortran = npy("{'descr': '<f2', 'fortran_order': True, 'shape': (2, 3), }", &data);
        assert!(parse_npy(&fortran).is_err());
    }

    #[test]
    fn raster_lookup() {
        let r = GroundRaster {
            rows: 2,
            cols: 3,
            heights_m: vec![1.0, 2.0, f32::NAN, 4.0, 5.0, 6.0],
            img_from_city: Sim2 { rotation: [1.0, 0.0, 0.0, 1.0], translation: [-100.0, -200.0], scale: 2.0 },
        };
        assert_eq!(r.height_at_city(100.2, 200.2), Some(1.0));
        assert_eq!(r.height_at_city(100.6, 200.2), Some(2.0));
        assert_eq!(r.height_at_city(101.1, 200.2), None); // NaN
        assert_eq!(r.height_at_city(100.6, 200.6), Some(5.0));
        assert_eq!(r.height_at_city(99.0, 200.0), None);
        assert_eq!(r.height_at_city(102.0, 200.0), None);
        assert!((r.resolution_m() - 0.5).abs() < 1e-12);
    }
}
