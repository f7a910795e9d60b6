//! Frames for Python: the dataset readers and the recording reader as iterators of frame dicts, and the
//! recording writer. A frame dict holds numpy arrays (points `(N, 3)` float32 in the sensor frame, the
//! object columns as `Monitor.check` takes them) and plain values; `pmon/_frames.py` wraps it in a `Frame`.

use std::path::{Path, PathBuf};

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pmon_datasets::roi::{RoiMode, RoiOptions};
use pmon_datasets::{DatasetFrame, ReadOptions};
use pmon_monitor::{MonitorParams, ObjectClass, Pose2};
use pmon_recording::{OwnedCloud, RecordedFrame, RecordingMeta, RecordingReader};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::monitor::{isometry, objects_into, polygons, ObjectColumns};

fn invalid(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// The class names in code order (`ObjectClass` in declaration order).
#[pyfunction]
pub fn class_names() -> Vec<&'static str> {
    ObjectClass::ALL.iter().map(|c| c.name()).collect()
}

/// The dataset prefixes `pmon check` knows (`kitti`, `nuscenes`, ...).
#[pyfunction]
pub fn dataset_schemes() -> Vec<&'static str> {
    pmon_datasets::SCHEMES.to_vec()
}

/// One frame as a dict of numpy arrays and plain values.
pub fn frame_dict(py: Python<'_>, f: RecordedFrame) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("index", f.index)?;
    d.set_item("timestamp_s", f.timestamp_s)?;
    d.set_item("world_from_ego", (f.world_from_ego.x_m, f.world_from_ego.y_m, f.world_from_ego.yaw_rad))?;
    match f.cloud {
        Some(c) => {
            let n = c.points_in_sensor.len();
            let points = c.points_in_sensor.into_flattened().into_pyarray(py).reshape([n, 3])?;
            let r = c.ego_from_sensor.rotation;
            let t = c.ego_from_sensor.translation_m;
            let m =
                vec![r[0][0], r[0][1], r[0][2], t[0], r[1][0], r[1][1], r[1][2], t[1], r[2][0], r[2][1], r[2][2], t[2]];
            d.set_item("points", points)?;
            d.set_item("ego_from_sensor", m.into_pyarray(py).reshape([3, 4])?)?;
        }
        None => {
            d.set_item("points", py.None())?;
            d.set_item("ego_from_sensor", py.None())?;
        }
    }
    let n = f.objects.len();
    let mut ids = Vec::with_capacity(n);
    let mut classes = Vec::with_capacity(n);
    let mut state = Vec::with_capacity(6 * n);
    let mut unc = Vec::with_capacity(6 * n);
    let mut has_unc = Vec::with_capacity(n);
    for o in &f.objects {
        ids.push(o.id);
        classes.push(u8::try_from(o.class.index()).unwrap_or(0));
        state.extend([o.x_m, o.y_m, o.heading_rad, o.speed_mps, o.length_m, o.width_m]);
        match o.uncertainty {
            Some(u) => {
                unc.extend([u.x_m, u.y_m, u.heading_rad, u.speed_mps, u.length_m, u.width_m]);
                has_unc.push(true);
            }
            None => {
                unc.extend([f32::NAN; 6]);
                has_unc.push(false);
            }
        }
    }
    let objects = PyDict::new(py);
    objects.set_item("ids", ids.into_pyarray(py))?;
    objects.set_item("classes", classes.into_pyarray(py))?;
    objects.set_item("state", state.into_pyarray(py).reshape([n, 6])?)?;
    objects.set_item("uncertainty", unc.into_pyarray(py).reshape([n, 6])?)?;
    objects.set_item("has_uncertainty", has_unc.into_pyarray(py))?;
    d.set_item("objects", objects)?;
    d.set_item("roi", polygon_list(py, f.roi_in_ego)?)?;
    d.set_item("static", polygon_list(py, f.static_in_ego)?)?;
    Ok(d)
}

fn polygon_list(py: Python<'_>, polys: Vec<Vec<[f32; 2]>>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for p in polys {
        let k = p.len();
        list.append(p.into_flattened().into_pyarray(py).reshape([k, 2])?)?;
    }
    Ok(list)
}

/// A dataset in its native layout, frame by frame (private API: use `pmon.datasets`).
#[pyclass(module = "pmon._pmon")]
pub struct DatasetFrames {
    frames: std::vec::IntoIter<DatasetFrame>,
    #[pyo3(get)]
    name: String,
    #[pyo3(get)]
    len: usize,
    /// The defaults with the dataset's ground height and ego footprint, as `pmon check` applies them (JSON).
    #[pyo3(get)]
    params_json: String,
    /// What the reader substituted or assumed (`warning: ...` first), and where the ROI comes from.
    #[pyo3(get)]
    notes: Vec<String>,
}

#[pymethods]
impl DatasetFrames {
    /// Opens `spec` (`kitti:DIR`, `nuscenes:DIR`, ...) with the ROI mode (`auto`, `none`, `corridor:W`) and
    /// sidewalk width of `pmon check`; the ROI is clipped to the grid of `grid_size_m`.
    #[new]
    #[pyo3(signature = (spec, roi="auto", sidewalk_m=pmon_datasets::av2_map::DEFAULT_SIDEWALK_WIDTH_M, grid_size_m=None))]
    fn new(py: Python<'_>, spec: &str, roi: &str, sidewalk_m: f64, grid_size_m: Option<f32>) -> PyResult<Self> {
        let mode: RoiMode = roi.parse().map_err(|e: String| invalid(format!("roi: {e}")))?;
        if !(sidewalk_m.is_finite() && (0.0..=50.0).contains(&sidewalk_m)) {
            return Err(invalid(format!("sidewalk_m: the sidewalk width must be in [0, 50] m, got {sidewalk_m}")));
        }
        let grid = grid_size_m.unwrap_or(MonitorParams::default().grid_size_m);
        if !(grid.is_finite() && grid > 0.0) {
            return Err(invalid(format!("grid_size_m must be finite and > 0, got {grid}")));
        }
        let opts = ReadOptions {
            roi: RoiOptions { mode, sidewalk_width_m: sidewalk_m, grid_half_extent_m: 0.5 * f64::from(grid) },
            // The ground `pmon check` uses: each return levelled to the dataset's ground (docs/datasets.md).
            ground: pmon_datasets::ground::GroundMode::Auto,
            ..ReadOptions::default()
        };
        let spec_owned = spec.to_string();
        let ds = py.detach(move || pmon_datasets::open_with(&spec_owned, &opts)).map_err(|e| invalid(e.to_string()))?;
        let params = MonitorParams {
            ground_z_m: ds.info.ground_z_m,
            ego_footprint_m: ds.info.format.ego_footprint_m(),
            ..MonitorParams::default()
        };
        let params_json = serde_json::to_string(&params).map_err(|e| invalid(e.to_string()))?;
        Ok(Self {
            len: ds.frames.len(),
            name: ds.info.name.clone(),
            notes: ds.info.notes.clone(),
            params_json,
            frames: ds.frames.into_iter(),
        })
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.frames.next().map(|f| frame_dict(py, f.frame)).transpose()
    }

    fn __len__(&self) -> usize {
        self.frames.len()
    }
}

/// A pmon recording (a directory, or a `.jsonl` object list), frame by frame (private API: use
/// `pmon.read_recording`). Read lazily: an error in line 500 comes as a `ValueError` naming the file and line
/// when frame 500 is reached. Used on the thread that opened it.
#[pyclass(module = "pmon._pmon", unsendable)]
pub struct RecordingFrames {
    reader: RecordingReader,
    #[pyo3(get)]
    name: String,
    #[pyo3(get)]
    source: String,
    /// Frames announced by `recording.json` (`None` for a bare `.jsonl`).
    #[pyo3(get)]
    frames: Option<u64>,
    /// The defaults, or the recording's `params.toml` over them (as `pmon check` applies it), JSON.
    #[pyo3(get)]
    params_json: String,
    /// The `params.toml` that was applied, if any.
    #[pyo3(get)]
    params_file: Option<PathBuf>,
}

#[pymethods]
impl RecordingFrames {
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        let reader = RecordingReader::open(&path).map_err(|e| invalid(e.to_string()))?;
        let sidecar = path.join("params.toml");
        let (params_json, params_file) = if path.is_dir() && sidecar.is_file() {
            (crate::params::params_json_from_toml_file(sidecar.clone(), None)?, Some(sidecar))
        } else {
            (crate::params::default_params_json()?, None)
        };
        let frames = path.is_dir().then_some(reader.meta.frames);
        Ok(Self {
            name: reader.meta.name.clone(),
            source: reader.meta.source.clone(),
            frames,
            reader,
            params_json,
            params_file,
        })
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        match self.reader.next() {
            None => Ok(None),
            Some(Ok(f)) => frame_dict(py, f).map(Some),
            Some(Err(e)) => Err(invalid(e.to_string())),
        }
    }
}

/// Writes a pmon recording frame by frame (private API: use `pmon.write_recording`). Refuses a path that
/// exists and is not an empty directory: existing data is never overwritten.
#[pyclass(module = "pmon._pmon")]
pub struct RecordingWriter {
    writer: Option<pmon_recording::RecordingWriter>,
    path: PathBuf,
    written: u64,
    last_timestamp_s: Option<f64>,
}

fn refuse_existing(path: &Path) -> PyResult<()> {
    if path.is_dir() {
        let mut entries = std::fs::read_dir(path).map_err(|e| invalid(format!("{}: {e}", path.display())))?;
        if entries.next().is_some() {
            return Err(invalid(format!(
                "{}: the folder exists and is not empty; pmon does not write over existing data",
                path.display()
            )));
        }
    } else if path.exists() {
        return Err(invalid(format!("{}: exists and is not a folder", path.display())));
    }
    Ok(())
}

#[pymethods]
impl RecordingWriter {
    #[new]
    fn new(path: PathBuf, name: &str, source: &str) -> PyResult<Self> {
        refuse_existing(&path)?;
        let writer = pmon_recording::RecordingWriter::create(&path, RecordingMeta::new(name, source))
            .map_err(|e| invalid(e.to_string()))?;
        Ok(Self { writer: Some(writer), path, written: 0, last_timestamp_s: None })
    }

    /// Appends a frame (numbered by its position); timestamps must be finite and strictly increasing, as the
    /// reader requires.
    #[allow(clippy::too_many_arguments)] // One argument per part of a frame, as `Monitor.check`.
    fn write(
        &mut self,
        timestamp_s: f64,
        world_from_ego: (f64, f64, f64),
        points: Option<PyReadonlyArray2<'_, f32>>,
        ego_from_sensor: Option<PyReadonlyArray2<'_, f32>>,
        objects: ObjectColumns<'_>,
        roi: Vec<PyReadonlyArray2<'_, f32>>,
        scenery: Vec<PyReadonlyArray2<'_, f32>>,
    ) -> PyResult<()> {
        let index = self.written;
        let here = |m: String| invalid(format!("{}: frame {index}: {m}", self.path.display()));
        if !timestamp_s.is_finite() {
            return Err(here(format!("timestamp_s must be finite, got {timestamp_s}")));
        }
        if let Some(last) = self.last_timestamp_s {
            if timestamp_s <= last {
                return Err(here(format!("timestamps must increase strictly: {timestamp_s} s after {last} s")));
            }
        }
        let (x_m, y_m, yaw_rad) = world_from_ego;
        let pose = Pose2 { x_m, y_m, yaw_rad };
        if !pose.is_finite() {
            return Err(here("world_from_ego must be finite".into()));
        }
        let mut objs = Vec::new();
        objects_into(&objects, &mut objs).map_err(|e| here(e.to_string()))?;
        let cloud = match points {
            None => None,
            Some(p) => {
                if p.shape().get(1) != Some(&3) {
                    return Err(here(format!("points must have shape (N, 3), got {:?}", p.shape())));
                }
                let flat = p.as_slice().map_err(|_| here("points must be C-contiguous".into()))?;
                Some(OwnedCloud {
                    points_in_sensor: flat.as_chunks::<3>().0.to_vec(),
                    ego_from_sensor: isometry(ego_from_sensor.as_ref())?,
                })
            }
        };
        let roi = polygons(&roi, "roi")?.into_iter().map(<[_]>::to_vec).collect();
        let scenery = polygons(&scenery, "static")?.into_iter().map(<[_]>::to_vec).collect();
        let frame = RecordedFrame {
            index,
            timestamp_s,
            world_from_ego: pose,
            objects: objs,
            cloud,
            roi_in_ego: roi,
            static_in_ego: scenery,
        };
        let w = self.writer.as_mut().ok_or_else(|| here("the recording is already finished".into()))?;
        w.write_frame(&frame).map_err(|e| invalid(e.to_string()))?;
        self.written += 1;
        self.last_timestamp_s = Some(timestamp_s);
        Ok(())
    }

    /// Writes `recording.json`; returns the number of frames.
    fn finish(&mut self) -> PyResult<u64> {
        let w = self.writer.take().ok_or_else(|| invalid("the recording is already finished"))?;
        let meta = w.finish().map_err(|e| invalid(e.to_string()))?;
        Ok(meta.frames)
    }
}
