//! `Monitor`: one [`Session`] per Python monitor; `check` lends the numpy arrays to it without copying the
//! points (a C-contiguous `(N, 3)` float32 array is read in place, `(N, 4)` is copied into a buffer made once,
//! as in the C API) and returns the report as a dict of numpy arrays.

use std::time::Instant;

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pmon_monitor::{FrameReport, Isometry3, ObjectClass, ObjectReport, ObjectState, Pose2, Uncertainty, Verdict};
use pmon_session::{CheckError, FlatCloud, Session};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};

use crate::params::params_from_json;

/// The object list of one frame as columns: ids, class codes (`ObjectClass` in declaration order), the
/// state `(N, 6)` = x, y, heading, speed, length, width (ego frame, metres, radians, m/s), and optionally the
/// one-sigma uncertainties `(N, 6)` in the same order with a flag per row.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct ObjectColumns<'py> {
    ids: PyReadonlyArray1<'py, u64>,
    classes: PyReadonlyArray1<'py, u8>,
    state: PyReadonlyArray2<'py, f32>,
    uncertainty: Option<PyReadonlyArray2<'py, f32>>,
    has_uncertainty: Option<PyReadonlyArray1<'py, bool>>,
}

fn invalid(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// A C-contiguous slice of an array, or a `ValueError` naming it.
fn slice<'a, T: numpy::Element, D: numpy::ndarray::Dimension>(
    a: &'a numpy::PyReadonlyArray<'_, T, D>,
    what: &str,
) -> PyResult<&'a [T]> {
    a.as_slice().map_err(|_| invalid(format!("{what} must be a C-contiguous array")))
}

/// Fills `out` with the object list; errors name the column and row.
pub fn objects_into(cols: &ObjectColumns<'_>, out: &mut Vec<ObjectState>) -> PyResult<()> {
    let ids = slice(&cols.ids, "objects['id']")?;
    let classes = slice(&cols.classes, "objects['class']")?;
    let n = ids.len();
    if cols.state.shape() != [n, 6] {
        return Err(invalid(format!("object state must have shape ({n}, 6), got {:?}", cols.state.shape())));
    }
    let state = slice(&cols.state, "object state")?;
    if classes.len() != n {
        return Err(invalid(format!("objects['class'] has {} entries, objects['id'] {n}", classes.len())));
    }
    let unc = match (&cols.uncertainty, &cols.has_uncertainty) {
        (Some(u), Some(h)) => {
            if u.shape() != [n, 6] || h.len() != n {
                return Err(invalid(format!(
                    "objects['uncertainty'] must have shape ({n}, 6), got {:?} (and {} flags)",
                    u.shape(),
                    h.len()
                )));
            }
            Some((slice(u, "objects['uncertainty']")?, slice(h, "uncertainty flags")?))
        }
        (None, None) => None,
        _ => return Err(invalid("uncertainty and its flags go together")),
    };
    out.clear();
    for (i, (&id, &class)) in ids.iter().zip(classes).enumerate() {
        let class = ObjectClass::ALL
            .get(usize::from(class))
            .copied()
            .ok_or_else(|| invalid(format!("objects['class'][{i}]: class code {class} is unknown")))?;
        let s = state.get(6 * i..6 * i + 6).ok_or_else(|| invalid("object state is too short"))?;
        let uncertainty = match unc {
            Some((u, h)) if h.get(i).copied().unwrap_or(false) => {
                let u = u.get(6 * i..6 * i + 6).ok_or_else(|| invalid("uncertainty is too short"))?;
                Some(Uncertainty {
                    x_m: u[0],
                    y_m: u[1],
                    heading_rad: u[2],
                    speed_mps: u[3],
                    length_m: u[4],
                    width_m: u[5],
                })
            }
            _ => None,
        };
        // Non-finite or out-of-range values are the monitor's to judge: `not monitored: invalid_state`.
        out.push(ObjectState {
            id,
            class,
            x_m: s[0],
            y_m: s[1],
            heading_rad: s[2],
            speed_mps: s[3],
            length_m: s[4],
            width_m: s[5],
            uncertainty,
        });
    }
    Ok(())
}

/// `ego_from_sensor` from a `(3, 4)` float32 matrix `[R | t]`.
pub fn isometry(m: Option<&PyReadonlyArray2<'_, f32>>) -> PyResult<Isometry3> {
    let Some(m) = m else { return Ok(Isometry3::IDENTITY) };
    if m.shape() != [3, 4] {
        return Err(invalid(format!("ego_from_sensor must have shape (3, 4) or (4, 4), got {:?}", m.shape())));
    }
    let v = slice(m, "ego_from_sensor")?;
    let row = |r: usize| -> [f32; 4] { [v[4 * r], v[4 * r + 1], v[4 * r + 2], v[4 * r + 3]] };
    let (a, b, c) = (row(0), row(1), row(2));
    Ok(Isometry3 {
        rotation: [[a[0], a[1], a[2]], [b[0], b[1], b[2]], [c[0], c[1], c[2]]],
        translation_m: [a[3], b[3], c[3]],
    })
}

/// Polygons `(K, 2)` float32 as vertex slices.
pub fn polygons<'a>(list: &'a [PyReadonlyArray2<'_, f32>], what: &str) -> PyResult<Vec<&'a [[f32; 2]]>> {
    list.iter()
        .enumerate()
        .map(|(i, p)| {
            if p.shape().get(1) != Some(&2) {
                return Err(invalid(format!("{what}[{i}] must have shape (K, 2), got {:?}", p.shape())));
            }
            let flat = slice(p, &format!("{what}[{i}]"))?;
            Ok(flat.as_chunks::<2>().0)
        })
        .collect()
}

/// A flat point buffer from an `(N, 3|4)` float32 array, read in place.
fn cloud<'a>(points: &'a PyReadonlyArray2<'_, f32>, ego_from_sensor: Isometry3) -> PyResult<FlatCloud<'a>> {
    let stride = points.shape().get(1).copied().unwrap_or(0);
    if stride != 3 && stride != 4 {
        return Err(invalid(format!("points must have shape (N, 3) or (N, 4), got {:?}", points.shape())));
    }
    Ok(FlatCloud { points: slice(points, "points")?, stride, ego_from_sensor })
}

/// The pmon monitor (private API: use `pmon.Monitor`).
#[pyclass(module = "pmon._pmon")]
pub struct Monitor {
    session: Session,
}

#[pymethods]
impl Monitor {
    /// A monitor with a full set of parameters as JSON (from `pmon.Params`).
    #[new]
    fn new(params_json: &str) -> PyResult<Self> {
        let params = params_from_json(params_json)?;
        let session = Session::new(params).map_err(|e| invalid(format!("parameters: {e}")))?;
        Ok(Self { session })
    }

    /// Checks one frame; see `pmon.Monitor.check`. Returns `(objects, clusters, summary)` dicts.
    #[allow(clippy::too_many_arguments)] // One argument per part of the core's `Frame`, as the C API's `PmonFrame`.
    #[pyo3(signature = (timestamp_s, world_from_ego, points, ego_from_sensor, objects, roi, scenery, core_time=false))]
    fn check<'py>(
        &mut self,
        py: Python<'py>,
        timestamp_s: f64,
        world_from_ego: (f64, f64, f64),
        points: Option<PyReadonlyArray2<'py, f32>>,
        ego_from_sensor: Option<PyReadonlyArray2<'py, f32>>,
        objects: ObjectColumns<'py>,
        roi: Vec<PyReadonlyArray2<'py, f32>>,
        scenery: Vec<PyReadonlyArray2<'py, f32>>,
        core_time: bool,
    ) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>, Bound<'py, PyDict>)> {
        let n = objects.ids.len();
        if n > self.session.max_objects() {
            let max = u32::try_from(self.session.max_objects()).unwrap_or(u32::MAX);
            return Err(invalid(pmon_monitor::FrameError::TooManyObjects { got: n, max }.to_string()));
        }
        objects_into(&objects, self.session.objects_mut())?;
        let extrinsic = isometry(ego_from_sensor.as_ref())?;
        let flat = points.as_ref().map(|p| cloud(p, extrinsic)).transpose()?;
        let roi = polygons(&roi, "roi")?;
        let scenery = polygons(&scenery, "static")?;
        let (x_m, y_m, yaw_rad) = world_from_ego;
        let pose = Pose2 { x_m, y_m, yaw_rad };
        let session = &mut self.session;
        // The GIL is released while the monitor runs: other Python threads (and other monitors) go on.
        let (result, core_s) = py.detach(|| {
            let t0 = Instant::now();
            let r = session.check(timestamp_s, pose, flat, roi.into_iter(), scenery.into_iter());
            let dt = t0.elapsed().as_secs_f64();
            (r.map(|rep| report_columns(&rep)), dt)
        });
        let cols = result.map_err(|e| match e {
            CheckError::InvalidArgument(m) => invalid(m),
            CheckError::Frame(e) => invalid(e.to_string()),
        })?;
        let (objects, clusters, summary) = cols.into_py(py)?;
        if core_time {
            summary.set_item("core_time_s", core_s)?;
        }
        Ok((objects, clusters, summary))
    }
}

/// Distinct texts of a column and each row's index into them: a frame has a handful of distinct verdicts, so
/// each distinct value is formatted once (compared by value, not by text) and becomes one Python str, which
/// every row with that value shares.
struct TextColumn<K> {
    keys: Vec<K>,
    table: Vec<String>,
    index: Vec<u16>,
}

impl<K: PartialEq + Copy> TextColumn<K> {
    fn with_capacity(n: usize) -> Self {
        Self { keys: Vec::new(), table: Vec::new(), index: Vec::with_capacity(n) }
    }

    /// Adds a row; `render` makes the text of a value not seen before (empty: does not apply).
    fn push(&mut self, key: K, render: impl FnOnce(K) -> String) {
        let i = match self.keys.iter().position(|k| *k == key) {
            Some(i) => i,
            None => {
                self.keys.push(key);
                self.table.push(render(key));
                self.keys.len() - 1
            }
        };
        self.index.push(u16::try_from(i).unwrap_or(u16::MAX));
    }

    fn into_parts(self) -> (Vec<String>, Vec<u16>) {
        (self.table, self.index)
    }
}

/// The report as owned columns (made while the GIL is released).
#[derive(Default)]
struct ReportColumns {
    id: Vec<u64>,
    /// (name, distinct texts, index per row).
    texts: Vec<(&'static str, Vec<String>, Vec<u16>)>,
    is_alarm: Vec<bool>,
    f32s: Vec<(&'static str, Vec<f32>)>,
    f64s: Vec<(&'static str, Vec<f64>)>,
    cluster: Vec<i32>,
    // clusters
    c_cells: Vec<u32>,
    c_missed: Vec<bool>,
    c_object: Vec<i32>,
    c_in_roi: Vec<bool>,
    c_outside_roi: Vec<bool>,
    /// `RoiStatus::name` per cluster: no_roi, inside, no_return_in_roi, grazing.
    c_roi: Vec<&'static str>,
    c_f32s: Vec<(&'static str, Vec<f32>)>,
    // summary
    sensor_status: Option<String>,
    points_total: u32,
    points_in_band: u32,
    object_alarms: usize,
    missed_objects: usize,
}

/// Text columns whose empty value means "does not apply" (`None` in Python).
const OPTIONAL_TEXTS: [&str; 5] = ["reason", "conditions", "position_cause", "kind", "error_unit"];

/// A named float column of the report and how to read it.
type Field<T> = (&'static str, fn(&ObjectReport) -> T);

/// The float fields of an object's report, by the names of `pmon check --format jsonl` (arrays split into
/// `_x` / `_y`); the one mapping from the core's report to Python: a field added to `ObjectReport` goes here.
const OBJECT_F32: [Field<f32>; 16] = [
    ("eta", |r| r.sensor.eta),
    ("margin_length_m", |r| r.sensor.margin_length_m),
    ("margin_width_m", |r| r.sensor.margin_width_m),
    ("visible_fraction", |r| r.sensor.visible_fraction),
    ("offset_x_m", |r| r.sensor.offset_m[0]),
    ("offset_y_m", |r| r.sensor.offset_m[1]),
    ("accel_mps2", |r| r.motion.accel_mps2),
    ("accel_margin_mps2", |r| r.motion.accel_margin_mps2),
    ("turn_rate_radps", |r| r.motion.turn_rate_radps),
    ("turn_rate_margin_radps", |r| r.motion.turn_rate_margin_radps),
    ("predicted_margin_x_m", |r| r.motion.predicted_margin_m[0]),
    ("predicted_margin_y_m", |r| r.motion.predicted_margin_m[1]),
    ("position_residual_m", |r| r.motion.position_residual_m),
    ("position_allowance_m", |r| r.motion.position_allowance_m),
    ("error_size", |r| if r.motion.kind.is_some() { r.motion.error_size } else { f32::NAN }),
    ("severity", |r| if r.motion.kind.is_some() { r.motion.severity } else { f32::NAN }),
];

const OBJECT_F64: [Field<f64>; 3] = [
    ("dt_s", |r| r.motion.dt_s),
    ("predicted_world_x_m", |r| r.motion.predicted_world_m[0]),
    ("predicted_world_y_m", |r| r.motion.predicted_world_m[1]),
];

fn report_columns(rep: &FrameReport<'_>) -> ReportColumns {
    let n = rep.objects.len();
    let mut c = ReportColumns {
        f32s: OBJECT_F32.iter().map(|(k, _)| (*k, Vec::with_capacity(n))).collect(),
        f64s: OBJECT_F64.iter().map(|(k, _)| (*k, Vec::with_capacity(n))).collect(),
        ..ReportColumns::default()
    };
    let mut verdict = TextColumn::with_capacity(n);
    let mut reason = TextColumn::with_capacity(n);
    let mut conditions = TextColumn::with_capacity(n);
    let mut cause = TextColumn::with_capacity(n);
    let mut sensor = TextColumn::with_capacity(n);
    let mut motion = TextColumn::with_capacity(n);
    let mut kind = TextColumn::with_capacity(n);
    let mut unit = TextColumn::with_capacity(n);
    for r in rep.objects {
        c.id.push(r.id);
        verdict.push(r.verdict, |v| v.name().to_string());
        reason.push(r.verdict, |v| v.not_monitored_reason().map_or_else(String::new, |r| r.name().to_string()));
        conditions.push(r.verdict, |v| match v {
            Verdict::ImplausibleMotion(cond) => cond.to_string(),
            _ => String::new(),
        });
        cause.push(r.sensor.position_cause, |c| c.map_or_else(String::new, |c| c.name().to_string()));
        sensor.push(r.sensor.verdict, |v| v.to_string());
        motion.push(r.motion.verdict, |v| v.to_string());
        kind.push(r.motion.kind, |k| k.map_or_else(String::new, |k| k.name().to_string()));
        unit.push(r.motion.kind, |k| k.map_or_else(String::new, |k| k.unit().to_string()));
        c.is_alarm.push(r.verdict.is_alarm());
        for ((_, col), (_, get)) in c.f32s.iter_mut().zip(OBJECT_F32.iter()) {
            col.push(get(r));
        }
        for ((_, col), (_, get)) in c.f64s.iter_mut().zip(OBJECT_F64.iter()) {
            col.push(get(r));
        }
        c.cluster.push(r.sensor.cluster.map_or(-1, i32::from));
    }
    for (name, (table, index)) in [
        ("verdict", verdict.into_parts()),
        ("reason", reason.into_parts()),
        ("conditions", conditions.into_parts()),
        ("position_cause", cause.into_parts()),
        ("sensor", sensor.into_parts()),
        ("motion", motion.into_parts()),
        ("kind", kind.into_parts()),
        ("error_unit", unit.into_parts()),
    ] {
        c.texts.push((name, table, index));
    }
    let names = ["centroid_x_m", "centroid_y_m", "min_x_m", "min_y_m", "max_x_m", "max_y_m"];
    c.c_f32s = names.iter().map(|k| (*k, Vec::with_capacity(rep.clusters.len()))).collect();
    for cl in rep.clusters {
        c.c_cells.push(cl.cells);
        c.c_missed.push(cl.is_missed_object());
        c.c_object.push(cl.object.and_then(|o| i32::try_from(o).ok()).unwrap_or(-1));
        c.c_in_roi.push(cl.in_roi);
        c.c_outside_roi.push(cl.is_outside_roi());
        c.c_roi.push(cl.roi.name());
        let vals = [cl.centroid_m[0], cl.centroid_m[1], cl.bounds_m[0], cl.bounds_m[1], cl.bounds_m[2], cl.bounds_m[3]];
        for ((_, col), v) in c.c_f32s.iter_mut().zip(vals) {
            col.push(v);
        }
    }
    c.sensor_status = rep.sensor_status.map(|s| s.name().to_string());
    c.points_total = rep.grid.points_total;
    c.points_in_band = rep.grid.points_in_band;
    c.object_alarms = rep.object_alarms();
    c.missed_objects = rep.missed_objects();
    c
}

impl ReportColumns {
    fn into_py(self, py: Python<'_>) -> PyResult<(Bound<'_, PyDict>, Bound<'_, PyDict>, Bound<'_, PyDict>)> {
        let objects = PyDict::new(py);
        objects.set_item("id", self.id.into_pyarray(py))?;
        for (name, table, index) in self.texts {
            // An object array of str (None where a text does not apply), one str object per distinct text.
            let optional = OPTIONAL_TEXTS.contains(&name);
            let distinct: Vec<Py<PyAny>> = table
                .iter()
                .map(|t| if optional && t.is_empty() { py.None() } else { PyString::new(py, t).into_any().unbind() })
                .collect();
            let column: Vec<Py<PyAny>> = index
                .iter()
                .map(|&i| distinct.get(usize::from(i)).map_or_else(|| py.None(), |o| o.clone_ref(py)))
                .collect();
            objects.set_item(name, PyArray1::from_vec(py, column))?;
        }
        objects.set_item("is_alarm", self.is_alarm.into_pyarray(py))?;
        for (name, col) in self.f32s {
            objects.set_item(name, col.into_pyarray(py))?;
        }
        for (name, col) in self.f64s {
            objects.set_item(name, col.into_pyarray(py))?;
        }
        objects.set_item("cluster", self.cluster.into_pyarray(py))?;
        let clusters = PyDict::new(py);
        clusters.set_item("cells", self.c_cells.into_pyarray(py))?;
        clusters.set_item("is_missed_object", self.c_missed.into_pyarray(py))?;
        clusters.set_item("object", self.c_object.into_pyarray(py))?;
        clusters.set_item("in_roi", self.c_in_roi.into_pyarray(py))?;
        clusters.set_item("is_outside_roi", self.c_outside_roi.into_pyarray(py))?;
        // An object array of str, one str object per status.
        let names: Vec<Py<PyAny>> = self.c_roi.iter().map(|t| PyString::new(py, t).into_any().unbind()).collect();
        clusters.set_item("roi", PyArray1::from_vec(py, names))?;
        for (name, col) in self.c_f32s {
            clusters.set_item(name, col.into_pyarray(py))?;
        }
        let summary = PyDict::new(py);
        summary.set_item("sensor_status", self.sensor_status)?;
        summary.set_item("points_total", self.points_total)?;
        summary.set_item("points_in_band", self.points_in_band)?;
        summary.set_item("object_alarms", self.object_alarms)?;
        summary.set_item("missed_objects", self.missed_objects)?;
        Ok((objects, clusters, summary))
    }
}

/// The synthetic benchmark frames of `pmon bench` (`crates/bench/src/frames.rs`): `"64-beam"` (120,000
/// points, 100 objects) or `"32-beam"`, as a list of frame dicts, for the overhead measurement.
#[pyfunction]
pub fn synthetic_frames<'py>(py: Python<'py>, which: &str) -> PyResult<Bound<'py, PyList>> {
    use pmon_bench::{Sequence, SyntheticSpec};
    let spec = match which {
        "64-beam" => SyntheticSpec::BEAMS_64,
        "32-beam" => SyntheticSpec::BEAMS_32,
        other => return Err(invalid(format!("unknown synthetic sequence `{other}` (known: 64-beam, 32-beam)"))),
    };
    let seq = Sequence::synthetic(&spec);
    let list = PyList::empty(py);
    for k in 0..seq.frames.len() {
        let f = seq.frame(k, Sequence::timestamp_s(k)).ok_or_else(|| invalid("internal: synthetic frame missing"))?;
        let owned = pmon_recording::RecordedFrame {
            index: k as u64,
            timestamp_s: f.timestamp_s,
            world_from_ego: f.world_from_ego,
            objects: f.objects.to_vec(),
            cloud: f.cloud.map(|c| pmon_recording::OwnedCloud {
                points_in_sensor: c.points_in_sensor.to_vec(),
                ego_from_sensor: c.ego_from_sensor,
            }),
            roi_in_ego: f.roi_in_ego.iter().map(|p| p.to_vec()).collect(),
            static_in_ego: f.static_in_ego.iter().map(|p| p.to_vec()).collect(),
        };
        list.append(crate::frames::frame_dict(py, owned)?)?;
    }
    Ok(list)
}
