//! The `extern "C"` functions and `#[repr(C)]` types of the C API (the only module with `unsafe`).
//!
//! Every function returns a status (`PMON_OK` = 0, else an error code; the message is in `pmon_last_error`),
//! checks every pointer for null (and alignment where it reads arrays), and runs its body under
//! `catch_unwind`, so that a bug becomes `PMON_ERR_PANIC`, never an unwind into C.

use core::ffi::c_char;
use std::cell::RefCell;
use std::ffi::CStr;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use pmon_monitor::{
    ClusterReport, Isometry3, MonitorParams, NotMonitoredReason, ObjectClass, ObjectReport, ObjectState, Pose2,
    PositionCause, Uncertainty, Verdict,
};
use pmon_recording::{RecordedFrame, RecordingReader};

use crate::session::{self, CheckError, FlatCloud, Session};
use crate::text::write_display;

/// Success.
pub const PMON_OK: i32 = 0;
/// A required pointer was null.
pub const PMON_ERR_NULL: i32 = 1;
/// An argument is out of range or malformed (the message says which).
pub const PMON_ERR_INVALID_ARGUMENT: i32 = 2;
/// The parameters are invalid (unknown key, value out of range).
pub const PMON_ERR_PARAMS: i32 = 3;
/// The monitor refused the frame as a whole (more objects than `max_objects`).
pub const PMON_ERR_FRAME: i32 = 4;
/// A caller's output buffer is too small (the message gives the size needed; nothing was checked).
pub const PMON_ERR_BUFFER_TOO_SMALL: i32 = 5;
/// A file could not be read, or is malformed (the message names file and line).
pub const PMON_ERR_IO: i32 = 6;
/// An internal error was caught at the boundary (a bug in pmon: please report it).
pub const PMON_ERR_PANIC: i32 = 7;
/// `pmon_recording_next`: no more frames (not an error).
pub const PMON_END: i32 = 8;

/// Verdict codes (`PmonObjectResult::verdict`). Texts are authoritative: a verdict the core adds later reads
/// `PMON_VERDICT_OTHER` here with its name in `verdict_name`.
pub const PMON_VERDICT_CONSISTENT: u32 = 0;
/// Ghost (false positive).
pub const PMON_VERDICT_GHOST: u32 = 1;
/// Position error.
pub const PMON_VERDICT_POSITION_ERROR: u32 = 2;
/// Implausible motion (`conditions` says which).
pub const PMON_VERDICT_IMPLAUSIBLE_MOTION: u32 = 3;
/// Not monitored (`reason` says why).
pub const PMON_VERDICT_NOT_MONITORED: u32 = 4;
/// A verdict this header does not know yet: read `verdict_name`.
pub const PMON_VERDICT_OTHER: u32 = 255;

/// `PmonObjectResult::position_cause`: not a position error.
pub const PMON_POSITION_CAUSE_NONE: u32 = 0;
/// A conflict cluster (evidence no object explains) was attributed to the object: its evidence lies outside its
/// grown region.
pub const PMON_POSITION_CAUSE_DISPLACED_EVIDENCE: u32 = 1;
/// Its evidence of the frames before, followed to where its offset puts it, lies apart from it.
pub const PMON_POSITION_CAUSE_EVIDENCE_FOLLOWED: u32 = 2;
/// The box jumped away from its evidence, which stayed where the object's motion predicts it.
pub const PMON_POSITION_CAUSE_JUMPED_FROM_EVIDENCE: u32 = 3;
/// The rays pass through the box to its own evidence behind it (displaced towards the sensor).
pub const PMON_POSITION_CAUSE_SEEN_THROUGH: u32 = 4;
/// Its evidence's face stands in front of the box along the rays (params key `face_in_front`).
pub const PMON_POSITION_CAUSE_FACE_IN_FRONT: u32 = 5;
/// Its own returns stand beyond its grown region (params key `returns_beyond_cells`).
pub const PMON_POSITION_CAUSE_RETURNS_BEYOND: u32 = 6;
/// Hidden, it stands behind evidence a neighbour held only by its wrong place (params key `release_flagged_claims`).
pub const PMON_POSITION_CAUSE_EVIDENCE_RELEASED: u32 = 7;
/// Confirmed only by evidence in its margin that runs on beyond its region (params key `evidence_runs_on`).
pub const PMON_POSITION_CAUSE_EVIDENCE_RUNS_ON: u32 = 8;
/// A parked vehicle found displaced in the frames before, held while it stays parked (params key `parked_hold_s`).
pub const PMON_POSITION_CAUSE_HELD_WHILE_PARKED: u32 = 9;
/// A cause the core added after this header: its name is in `position_cause_name`.
pub const PMON_POSITION_CAUSE_OTHER: u32 = 255;

/// `PmonCluster::roi_status`: the frame has no region of interest (the whole grid is in it).
pub const PMON_ROI_NONE: u32 = 0;
/// In the region of interest: one of its obstacle-band returns lies inside it (and the grazing rule kept it).
pub const PMON_ROI_INSIDE: u32 = 1;
/// Outside the region of interest: none of its obstacle-band returns lies inside it (`roi_name`
/// `no_return_in_roi`).
pub const PMON_ROI_OUTSIDE: u32 = 2;
/// Outside by the grazing rule: fewer than `roi_graze_fraction` of its band returns inside, and a return over its
/// cells higher than `roi_graze_height_m` (`roi_name` `grazing`).
pub const PMON_ROI_GRAZING: u32 = 3;

/// Bits of `PmonObjectResult::conditions` (eqs. condition_w, condition_a, condition_xy).
pub const PMON_CONDITION_TURN_RATE: u32 = 1;
/// Acceleration or braking beyond the limits.
pub const PMON_CONDITION_ACCELERATION: u32 = 2;
/// Position off the prediction.
pub const PMON_CONDITION_POSITION: u32 = 4;

/// Object classes (`PmonObject::class_`): the core's `ObjectClass` in declaration order.
pub const PMON_CLASS_UNKNOWN: u32 = 0;
/// Car.
pub const PMON_CLASS_CAR: u32 = 1;
/// Truck, van, bus.
pub const PMON_CLASS_TRUCK: u32 = 2;
/// Pedestrian.
pub const PMON_CLASS_PEDESTRIAN: u32 = 3;
/// Cyclist.
pub const PMON_CLASS_CYCLIST: u32 = 4;
/// Motorcyclist.
pub const PMON_CLASS_MOTORCYCLIST: u32 = 5;
/// Other.
pub const PMON_CLASS_OTHER: u32 = 6;

/// One-sigma uncertainties of an object (the paper's margins).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct PmonUncertainty {
    /// Position along ego x, metres.
    pub x_m: f32,
    /// Position along ego y, metres.
    pub y_m: f32,
    /// Heading, radians.
    pub heading_rad: f32,
    /// Speed, m/s.
    pub speed_mps: f32,
    /// Length, metres.
    pub length_m: f32,
    /// Width, metres.
    pub width_m: f32,
}

/// One object of the object list, ego frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct PmonObject {
    /// Track id, stable across frames.
    pub id: u64,
    /// `PMON_CLASS_*`.
    pub class_: u32,
    /// 1 when `uncertainty` is given, 0 to use the parameters' `default_uncertainty`.
    pub has_uncertainty: u32,
    /// Centre, metres.
    pub x_m: f32,
    /// Centre, metres.
    pub y_m: f32,
    /// Heading, radians.
    pub heading_rad: f32,
    /// Speed over ground, m/s.
    pub speed_mps: f32,
    /// Length, metres.
    pub length_m: f32,
    /// Width, metres.
    pub width_m: f32,
    /// Uncertainties (read when `has_uncertainty` is 1).
    pub uncertainty: PmonUncertainty,
}

/// A polygon in the ego frame: `vertex_count` pairs `x, y` (metres).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct PmonPolygon {
    /// `2 * vertex_count` floats.
    pub xy: *const f32,
    /// Number of vertices.
    pub vertex_count: usize,
}

/// Everything the monitor looks at in one frame. All pointers are borrowed for the call only.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct PmonFrame {
    /// Timestamp, seconds, strictly increasing.
    pub timestamp_s: f64,
    /// Ego pose in the world frame: x, metres.
    pub world_x_m: f64,
    /// Ego pose in the world frame: y, metres.
    pub world_y_m: f64,
    /// Ego pose in the world frame: yaw, radians.
    pub world_yaw_rad: f64,
    /// `object_count` objects (may be null when 0).
    pub objects: *const PmonObject,
    /// Number of objects.
    pub object_count: usize,
    /// 1 when a LiDAR sweep comes with this frame (then `points` may still be empty), else 0.
    pub has_cloud: u32,
    /// Floats per point: 3 (`x, y, z`, read in place) or 4 (`x, y, z, intensity`, copied).
    pub point_stride: u32,
    /// `point_count * point_stride` floats, sensor frame, metres (4-byte aligned; null when 0 points).
    pub points: *const f32,
    /// Number of points.
    pub point_count: usize,
    /// `ego_from_sensor`: row-major 3x3 rotation.
    pub ego_from_sensor_rotation: [f32; 9],
    /// `ego_from_sensor`: translation, metres.
    pub ego_from_sensor_translation_m: [f32; 3],
    /// Region of interest polygons (may be null when 0).
    pub roi: *const PmonPolygon,
    /// Number of ROI polygons.
    pub roi_count: usize,
    /// Known static scenery polygons (may be null when 0).
    pub scenery: *const PmonPolygon,
    /// Number of scenery polygons.
    pub scenery_count: usize,
}

/// Everything the monitor says about one object (the fields of `pmon check --format jsonl`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct PmonObjectResult {
    /// The object's id.
    pub id: u64,
    /// `PMON_VERDICT_*`.
    pub verdict: u32,
    /// `PMON_CONDITION_*` bits for an implausible motion, else 0.
    pub conditions: u32,
    /// Index into the frame's clusters attributed to this object, -1 for none.
    pub cluster: i32,
    /// Consistency `eta(o)`.
    pub eta: f32,
    /// Footprint growth along the length, metres.
    pub margin_length_m: f32,
    /// Footprint growth across the width, metres.
    pub margin_width_m: f32,
    /// Visible fraction of the footprint.
    pub visible_fraction: f32,
    /// Offset from the attributed evidence to the box, metres.
    pub offset_m: [f32; 2],
    /// Time step, seconds.
    pub dt_s: f64,
    /// Estimated acceleration, m/s^2.
    pub accel_mps2: f32,
    /// Its margin, m/s^2.
    pub accel_margin_mps2: f32,
    /// Estimated turn rate, rad/s.
    pub turn_rate_radps: f32,
    /// Its margin, rad/s.
    pub turn_rate_margin_radps: f32,
    /// Predicted position, world frame, metres.
    pub predicted_world_m: [f64; 2],
    /// Margin of the prediction, metres.
    pub predicted_margin_m: [f32; 2],
    /// Distance prediction to measurement, metres.
    pub position_residual_m: f32,
    /// Allowed distance, metres.
    pub position_allowance_m: f32,
    /// Verdict name (`consistent`, `ghost`, ...), NUL-terminated.
    pub verdict_name: [u8; 32],
    /// Reason name for a not-monitored verdict, else empty.
    pub reason_name: [u8; 32],
    /// Conditions for an implausible motion (`turn_rate+position`), else empty.
    pub conditions_text: [u8; 48],
    /// The sensor checks' verdict as text (`not_monitored(occluded)`).
    pub sensor_text: [u8; 64],
    /// The plausibility checks' verdict as text (`implausible(position)`).
    pub motion_text: [u8; 64],
    /// Kind of an implausible motion (`speed_inconsistent`, `position_jump`, ...), else empty.
    pub kind_name: [u8; 32],
    /// Unit of `error_size` (`m`, `m/s`, `rad`, ...), else empty.
    pub error_unit: [u8; 8],
    /// Estimated size of the motion error in `error_unit` (0 without a kind).
    pub error_size: f32,
    /// `error_size` over the safety-critical size (>= 1: safety-critical; 0 without a kind).
    pub severity: f32,
    /// For a position error, which test found it (`PMON_POSITION_CAUSE_*`); else `PMON_POSITION_CAUSE_NONE`.
    pub position_cause: u32,
    /// Its name (`displaced_evidence`, `seen_through`, ...), else empty.
    pub position_cause_name: [u8; 32],
}

/// A conflict cluster: LiDAR evidence no object explains.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct PmonCluster {
    /// Number of cells.
    pub cells: u32,
    /// 1 when it is a missed-object alarm (in the ROI and attributed to no object).
    pub is_missed_object: u32,
    /// Index of the object it is attributed to, -1 for none.
    pub object: i32,
    /// 1 when in the region of interest.
    pub in_roi: u32,
    /// Centroid, ego frame, metres.
    pub centroid_m: [f32; 2],
    /// `min_x, min_y, max_x, max_y`, ego frame, metres.
    pub bounds_m: [f32; 4],
    /// Why it is in the region of interest or outside it: `PMON_ROI_NONE`, `PMON_ROI_INSIDE`,
    /// `PMON_ROI_OUTSIDE`, `PMON_ROI_GRAZING`.
    pub roi_status: u32,
    /// 1 when the region of interest excused it: outside it and attributed to no object (not an alarm; the
    /// `outside_roi` records of `pmon check --format jsonl`).
    pub is_outside_roi: u32,
    /// The status's name, NUL-terminated: `no_roi`, `inside`, `no_return_in_roi`, `grazing` (the `reason` of an
    /// `outside_roi` record).
    pub roi_name: [u8; 24],
}

/// Frame-level results.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub struct PmonFrameSummary {
    /// Object results written (= the frame's object count).
    pub object_count: usize,
    /// Clusters written to the caller's buffer.
    pub cluster_count: usize,
    /// Clusters the monitor described (more than `cluster_count` when the caller's buffer was smaller).
    pub clusters_available: usize,
    /// Object alarms.
    pub object_alarms: usize,
    /// Missed-object alarms (among all described clusters).
    pub missed_objects: usize,
    /// 1 when the sensor checks did not run this frame (`sensor_status` says why).
    pub sensor_not_run: u32,
    /// Points in the sweep.
    pub points_total: u32,
    /// Points in the height band.
    pub points_in_band: u32,
    /// Why the sensor checks did not run, NUL-terminated, else empty.
    pub sensor_status: [u8; 32],
}

/// A monitor with its scratch buffers. Opaque.
pub struct PmonMonitor {
    session: Session,
}

/// A recording being read frame by frame. Opaque.
pub struct PmonRecording {
    reader: RecordingReader,
    current: Option<RecordedFrame>,
    objects: Vec<PmonObject>,
    roi: Vec<PmonPolygon>,
    scenery: Vec<PmonPolygon>,
}

thread_local! {
    static LAST_ERROR: RefCell<String> = const { RefCell::new(String::new()) };
}

fn set_error(message: impl Into<String>) {
    let message = message.into();
    LAST_ERROR.with(|e| *e.borrow_mut() = message);
}

/// Runs `f`, turning a panic into `PMON_ERR_PANIC` with a message.
fn guard(f: impl FnOnce() -> Result<(), (i32, String)>) -> i32 {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => PMON_OK,
        Ok(Err((code, message))) => {
            set_error(message);
            code
        }
        Err(_) => {
            set_error("internal error in pmon (a panic was caught at the C boundary): please report it");
            PMON_ERR_PANIC
        }
    }
}

fn invalid(message: impl Into<String>) -> (i32, String) {
    (PMON_ERR_INVALID_ARGUMENT, message.into())
}

/// A slice from a C array: null is allowed only for an empty array; the pointer must be aligned.
///
/// # Safety
/// `ptr` must point to `len` valid `T` for the duration of the borrow (the caller's contract).
unsafe fn c_slice<'a, T>(ptr: *const T, len: usize, what: &str) -> Result<&'a [T], (i32, String)> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err((PMON_ERR_NULL, format!("{what} is null but its count is {len}")));
    }
    if !(ptr as usize).is_multiple_of(core::mem::align_of::<T>()) {
        return Err(invalid(format!("{what} is not aligned to {} bytes", core::mem::align_of::<T>())));
    }
    if len.checked_mul(core::mem::size_of::<T>()).is_none_or(|b| b > isize::MAX as usize) {
        return Err(invalid(format!("{what}: count {len} is too large")));
    }
    // SAFETY: non-null, aligned, size checked; validity of the memory is the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts(ptr, len) })
}

/// # Safety
/// `ptr` must be null or a NUL-terminated string.
unsafe fn c_str<'a>(ptr: *const c_char, what: &str) -> Result<&'a str, (i32, String)> {
    if ptr.is_null() {
        return Err((PMON_ERR_NULL, format!("{what} is null")));
    }
    // SAFETY: non-null and NUL-terminated by contract.
    unsafe { CStr::from_ptr(ptr) }.to_str().map_err(|_| invalid(format!("{what} is not UTF-8")))
}

/// Copies the last error message of this thread into `buf` (NUL-terminated, truncated to `capacity`).
/// Returns the message's full length in bytes (without the NUL), so a caller can retry with a larger buffer.
///
/// # Safety
/// `buf` must be null or point to `capacity` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn pmon_last_error(buf: *mut c_char, capacity: usize) -> usize {
    catch_unwind(|| {
        LAST_ERROR.with(|e| {
            let e = e.borrow();
            if !buf.is_null() && capacity > 0 {
                let n = e.len().min(capacity - 1);
                // SAFETY: `buf` has `capacity` bytes by contract; we write `n + 1 <= capacity`.
                unsafe {
                    core::ptr::copy_nonoverlapping(e.as_ptr(), buf.cast::<u8>(), n);
                    *buf.add(n) = 0;
                }
            }
            e.len()
        })
    })
    .unwrap_or(0)
}

/// The lower-case name of a `PMON_CLASS_*` code (`"car"`), or null for an unknown code. Static storage.
#[no_mangle]
pub extern "C" fn pmon_class_name(class_: u32) -> *const c_char {
    const NAMES: [&CStr; 7] = [c"unknown", c"car", c"truck", c"pedestrian", c"cyclist", c"motorcyclist", c"other"];
    let class = usize::try_from(class_).ok().and_then(|i| ObjectClass::ALL.get(i));
    match class.and_then(|c| NAMES.iter().find(|n| n.to_bytes() == c.name().as_bytes())) {
        Some(n) => n.as_ptr(),
        None => core::ptr::null(),
    }
}

fn new_monitor(params: Result<MonitorParams, String>, out: *mut *mut PmonMonitor) -> Result<(), (i32, String)> {
    let params = params.map_err(|m| (PMON_ERR_PARAMS, m))?;
    let session = Session::new(params).map_err(|e| (PMON_ERR_PARAMS, e.to_string()))?;
    let handle = Box::into_raw(Box::new(PmonMonitor { session }));
    // SAFETY: `out` was checked non-null by the callers.
    unsafe { *out = handle };
    Ok(())
}

/// Creates a monitor. `params_toml` is TOML text as printed by `pmon params` (keys left out keep Table I), or
/// null for Table I. On success `*out` is a handle to free with `pmon_monitor_free`.
///
/// # Safety
/// `params_toml` null or NUL-terminated; `out` a valid pointer.
#[no_mangle]
pub unsafe extern "C" fn pmon_monitor_new(params_toml: *const c_char, out: *mut *mut PmonMonitor) -> i32 {
    guard(|| {
        if out.is_null() {
            return Err((PMON_ERR_NULL, "out is null".into()));
        }
        let params = if params_toml.is_null() {
            Ok(MonitorParams::default())
        } else {
            // SAFETY: non-null, NUL-terminated by contract.
            session::params_from_toml(unsafe { c_str(params_toml, "params_toml") }?)
        };
        new_monitor(params, out)
    })
}

/// Creates a monitor with the parameters of a TOML file (as `pmon --params FILE`; keys left out keep Table I).
/// `profile:NAME` is one of the parameter profiles pmon ships, as `--params profile:NAME` (`profile:recall`:
/// README, "The recall profile"; a file of that name is `./profile:NAME`).
///
/// # Safety
/// `path` NUL-terminated; `out` a valid pointer.
#[no_mangle]
pub unsafe extern "C" fn pmon_monitor_new_from_file(path: *const c_char, out: *mut *mut PmonMonitor) -> i32 {
    guard(|| {
        if out.is_null() {
            return Err((PMON_ERR_NULL, "out is null".into()));
        }
        // SAFETY: NUL-terminated by contract.
        let path = unsafe { c_str(path, "path") }?;
        new_monitor(session::params_from_file(Path::new(path)), out)
    })
}

/// Frees a monitor (null is allowed and does nothing).
///
/// # Safety
/// `monitor` null or a handle from `pmon_monitor_new*`, not used afterwards.
#[no_mangle]
pub unsafe extern "C" fn pmon_monitor_free(monitor: *mut PmonMonitor) {
    if !monitor.is_null() {
        // SAFETY: created by Box::into_raw in `new_monitor`; freed once by contract.
        let _ = catch_unwind(AssertUnwindSafe(|| drop(unsafe { Box::from_raw(monitor) })));
    }
}

fn object_state(o: &PmonObject, i: usize) -> Result<ObjectState, (i32, String)> {
    let class = usize::try_from(o.class_)
        .ok()
        .and_then(|c| ObjectClass::ALL.get(c).copied())
        .ok_or_else(|| invalid(format!("objects[{i}]: class code {} is unknown", o.class_)))?;
    let uncertainty = match o.has_uncertainty {
        0 => None,
        1 => {
            let u = o.uncertainty;
            Some(Uncertainty {
                x_m: u.x_m,
                y_m: u.y_m,
                heading_rad: u.heading_rad,
                speed_mps: u.speed_mps,
                length_m: u.length_m,
                width_m: u.width_m,
            })
        }
        other => return Err(invalid(format!("objects[{i}]: has_uncertainty must be 0 or 1, got {other}"))),
    };
    // Non-finite or out-of-range values are the monitor's to judge: `not monitored: invalid state`.
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

/// The verdict code; by name, so that a verdict the core adds later maps to `PMON_VERDICT_OTHER`.
fn verdict_code(v: Verdict) -> u32 {
    match v.name() {
        "consistent" => PMON_VERDICT_CONSISTENT,
        "ghost" => PMON_VERDICT_GHOST,
        "position_error" => PMON_VERDICT_POSITION_ERROR,
        "implausible_motion" => PMON_VERDICT_IMPLAUSIBLE_MOTION,
        "not_monitored" => PMON_VERDICT_NOT_MONITORED,
        _ => PMON_VERDICT_OTHER,
    }
}

/// The position cause's code; by name, so that a cause the core adds later maps to `PMON_POSITION_CAUSE_OTHER`.
fn position_cause_code(c: PositionCause) -> u32 {
    match c.name() {
        "displaced_evidence" => PMON_POSITION_CAUSE_DISPLACED_EVIDENCE,
        "evidence_followed" => PMON_POSITION_CAUSE_EVIDENCE_FOLLOWED,
        "jumped_from_evidence" => PMON_POSITION_CAUSE_JUMPED_FROM_EVIDENCE,
        "seen_through" => PMON_POSITION_CAUSE_SEEN_THROUGH,
        "face_in_front" => PMON_POSITION_CAUSE_FACE_IN_FRONT,
        "returns_beyond" => PMON_POSITION_CAUSE_RETURNS_BEYOND,
        "evidence_released" => PMON_POSITION_CAUSE_EVIDENCE_RELEASED,
        "evidence_runs_on" => PMON_POSITION_CAUSE_EVIDENCE_RUNS_ON,
        "held_while_parked" => PMON_POSITION_CAUSE_HELD_WHILE_PARKED,
        _ => PMON_POSITION_CAUSE_OTHER,
    }
}

/// The one mapping from the core's report to the C record: a field added to `ObjectReport` goes here.
fn object_result(r: &ObjectReport) -> PmonObjectResult {
    let mut out = PmonObjectResult {
        id: r.id,
        verdict: verdict_code(r.verdict),
        conditions: match r.verdict {
            Verdict::ImplausibleMotion(c) => u32::from(c.0),
            _ => 0,
        },
        cluster: r.sensor.cluster.map_or(-1, i32::from),
        eta: r.sensor.eta,
        margin_length_m: r.sensor.margin_length_m,
        margin_width_m: r.sensor.margin_width_m,
        visible_fraction: r.sensor.visible_fraction,
        offset_m: r.sensor.offset_m,
        dt_s: r.motion.dt_s,
        accel_mps2: r.motion.accel_mps2,
        accel_margin_mps2: r.motion.accel_margin_mps2,
        turn_rate_radps: r.motion.turn_rate_radps,
        turn_rate_margin_radps: r.motion.turn_rate_margin_radps,
        predicted_world_m: r.motion.predicted_world_m,
        predicted_margin_m: r.motion.predicted_margin_m,
        position_residual_m: r.motion.position_residual_m,
        position_allowance_m: r.motion.position_allowance_m,
        verdict_name: [0; 32],
        reason_name: [0; 32],
        conditions_text: [0; 48],
        sensor_text: [0; 64],
        motion_text: [0; 64],
        kind_name: [0; 32],
        error_unit: [0; 8],
        error_size: 0.0,
        severity: 0.0,
        position_cause: r.sensor.position_cause.map_or(PMON_POSITION_CAUSE_NONE, position_cause_code),
        position_cause_name: [0; 32],
    };
    if let Some(cause) = r.sensor.position_cause {
        write_display(&mut out.position_cause_name, &cause.name());
    }
    write_display(&mut out.verdict_name, &r.verdict.name());
    if let Some(reason) = r.verdict.not_monitored_reason() {
        write_display(&mut out.reason_name, &reason);
    }
    if let Verdict::ImplausibleMotion(c) = r.verdict {
        write_display(&mut out.conditions_text, &c);
    }
    if let Some(kind) = r.motion.kind {
        write_display(&mut out.kind_name, &kind.name());
        write_display(&mut out.error_unit, &kind.unit());
        out.error_size = r.motion.error_size;
        out.severity = r.motion.severity;
    }
    write_display(&mut out.sensor_text, &r.sensor.verdict);
    write_display(&mut out.motion_text, &r.motion.verdict);
    out
}

fn cluster_result(c: &ClusterReport) -> PmonCluster {
    PmonCluster {
        cells: c.cells,
        is_missed_object: u32::from(c.is_missed_object()),
        object: c.object.and_then(|o| i32::try_from(o).ok()).unwrap_or(-1),
        in_roi: u32::from(c.in_roi),
        centroid_m: c.centroid_m,
        bounds_m: c.bounds_m,
        roi_status: c.roi.code(),
        is_outside_roi: u32::from(c.is_outside_roi()),
        roi_name: {
            let mut name = [0u8; 24];
            write_display(&mut name, &c.roi);
            name
        },
    }
}

/// # Safety
/// The polygons' `xy` arrays must be valid for the call.
unsafe fn polygons<'a>(list: &'a [PmonPolygon], what: &str) -> Result<Vec<&'a [[f32; 2]]>, (i32, String)> {
    list.iter()
        .enumerate()
        .map(|(i, p)| {
            // SAFETY: caller's contract.
            unsafe { c_slice(p.xy.cast::<[f32; 2]>(), p.vertex_count, &format!("{what}[{i}].xy")) }
        })
        .collect()
}

/// Checks one frame. Writes one `PmonObjectResult` per object into `results` (capacity `result_capacity`, at
/// least `frame->object_count`, else `PMON_ERR_BUFFER_TOO_SMALL` before anything is checked), up to
/// `cluster_capacity` clusters into `clusters` (null when 0), and the summary. Objects with bad values get the
/// verdict *not monitored: invalid_state*; bad arguments (null arrays, unknown class codes, a stride other
/// than 3 or 4) are errors and leave the monitor's state as it was.
///
/// ROI and scenery polygons cost one small allocation per frame that has any (the list of polygon slices).
///
/// # Safety
/// Every pointer valid for its stated count; `monitor` a live handle, not used concurrently.
#[no_mangle]
pub unsafe extern "C" fn pmon_monitor_check(
    monitor: *mut PmonMonitor,
    frame: *const PmonFrame,
    results: *mut PmonObjectResult,
    result_capacity: usize,
    clusters: *mut PmonCluster,
    cluster_capacity: usize,
    summary: *mut PmonFrameSummary,
) -> i32 {
    guard(|| {
        if monitor.is_null() || frame.is_null() || summary.is_null() {
            return Err((PMON_ERR_NULL, "monitor, frame and summary must not be null".into()));
        }
        // SAFETY: non-null; valid by contract.
        let (m, f) = unsafe { (&mut *monitor, &*frame) };
        if f.object_count > result_capacity {
            return Err((
                PMON_ERR_BUFFER_TOO_SMALL,
                format!("results has room for {result_capacity} objects, the frame has {}", f.object_count),
            ));
        }
        if f.object_count > 0 && results.is_null() {
            return Err((PMON_ERR_NULL, "results is null".into()));
        }
        if cluster_capacity > 0 && clusters.is_null() {
            return Err((PMON_ERR_NULL, "clusters is null but cluster_capacity > 0".into()));
        }
        // SAFETY: the arrays are valid for their counts by contract (checked for null and alignment).
        let objects = unsafe { c_slice(f.objects, f.object_count, "objects") }?;
        if objects.len() > m.session.max_objects() {
            let max = u32::try_from(m.session.max_objects()).unwrap_or(u32::MAX);
            let e = pmon_monitor::FrameError::TooManyObjects { got: objects.len(), max };
            return Err((PMON_ERR_FRAME, e.to_string()));
        }
        let buffer = m.session.objects_mut();
        for (i, o) in objects.iter().enumerate() {
            buffer.push(object_state(o, i)?);
        }
        let cloud = match f.has_cloud {
            0 => None,
            1 => {
                let stride = usize::try_from(f.point_stride).unwrap_or(0);
                if stride != 3 && stride != 4 {
                    return Err(invalid(format!("point_stride must be 3 or 4, got {}", f.point_stride)));
                }
                let floats = f.point_count.checked_mul(stride).ok_or_else(|| invalid("point_count is too large"))?;
                // SAFETY: as above.
                let points = unsafe { c_slice(f.points, floats, "points") }?;
                let r = &f.ego_from_sensor_rotation;
                let rotation = [[r[0], r[1], r[2]], [r[3], r[4], r[5]], [r[6], r[7], r[8]]];
                let ego_from_sensor = Isometry3 { rotation, translation_m: f.ego_from_sensor_translation_m };
                Some(FlatCloud { points, stride, ego_from_sensor })
            }
            other => return Err(invalid(format!("has_cloud must be 0 or 1, got {other}"))),
        };
        // SAFETY: as above.
        let (roi, scenery) =
            unsafe { (c_slice(f.roi, f.roi_count, "roi")?, c_slice(f.scenery, f.scenery_count, "scenery")?) };
        // SAFETY: as above.
        let (roi, scenery) = unsafe { (polygons(roi, "roi")?, polygons(scenery, "scenery")?) };
        let pose = Pose2 { x_m: f.world_x_m, y_m: f.world_y_m, yaw_rad: f.world_yaw_rad };
        let report =
            m.session.check(f.timestamp_s, pose, cloud, roi.into_iter(), scenery.into_iter()).map_err(|e| match e {
                CheckError::InvalidArgument(m) => invalid(m),
                CheckError::Frame(e) => (PMON_ERR_FRAME, e.to_string()),
            })?;
        for (i, r) in report.objects.iter().enumerate() {
            // SAFETY: `results` has `result_capacity >= object_count` slots; the report has one per object.
            unsafe { results.add(i).write(object_result(r)) };
        }
        let written = report.clusters.len().min(cluster_capacity);
        for (i, c) in report.clusters.iter().take(written).enumerate() {
            // SAFETY: `clusters` has `cluster_capacity` slots.
            unsafe { clusters.add(i).write(cluster_result(c)) };
        }
        let mut s = PmonFrameSummary {
            object_count: report.objects.len(),
            cluster_count: written,
            clusters_available: report.clusters.len(),
            object_alarms: report.object_alarms(),
            missed_objects: report.missed_objects(),
            sensor_not_run: u32::from(report.sensor_status.is_some()),
            points_total: report.grid.points_total,
            points_in_band: report.grid.points_in_band,
            sensor_status: [0; 32],
        };
        if let Some(reason) = report.sensor_status {
            write_display::<32>(&mut s.sensor_status, &reason as &NotMonitoredReason);
        }
        // SAFETY: non-null by the check above.
        unsafe { summary.write(s) };
        Ok(())
    })
}

/// Opens a pmon recording (a directory, or a `.jsonl` file of object lists; docs/recording-format.md).
///
/// # Safety
/// `path` NUL-terminated; `out` a valid pointer.
#[no_mangle]
pub unsafe extern "C" fn pmon_recording_open(path: *const c_char, out: *mut *mut PmonRecording) -> i32 {
    guard(|| {
        if out.is_null() {
            return Err((PMON_ERR_NULL, "out is null".into()));
        }
        // SAFETY: NUL-terminated by contract.
        let path = unsafe { c_str(path, "path") }?;
        let reader = RecordingReader::open(Path::new(path)).map_err(|e| (PMON_ERR_IO, e.to_string()))?;
        let rec = PmonRecording { reader, current: None, objects: Vec::new(), roi: Vec::new(), scenery: Vec::new() };
        // SAFETY: non-null.
        unsafe { *out = Box::into_raw(Box::new(rec)) };
        Ok(())
    })
}

/// Reads the next frame into `*frame` (and its number into `*index`, if not null). The frame's arrays belong
/// to the recording and stay valid until the next call or `pmon_recording_free`. Returns `PMON_END` after the
/// last frame, `PMON_ERR_IO` for a malformed or truncated recording (the message names file and line).
///
/// # Safety
/// `recording` a live handle; `frame` valid; `index` null or valid.
#[no_mangle]
pub unsafe extern "C" fn pmon_recording_next(
    recording: *mut PmonRecording,
    frame: *mut PmonFrame,
    index: *mut u64,
) -> i32 {
    let mut end = false;
    let status = guard(|| {
        if recording.is_null() || frame.is_null() {
            return Err((PMON_ERR_NULL, "recording and frame must not be null".into()));
        }
        // SAFETY: live handle by contract.
        let rec = unsafe { &mut *recording };
        rec.current = None;
        let Some(next) = rec.reader.next() else {
            end = true;
            return Ok(());
        };
        let f = next.map_err(|e| (PMON_ERR_IO, e.to_string()))?;
        rec.objects.clear();
        rec.objects.extend(f.objects.iter().map(|o| PmonObject {
            id: o.id,
            class_: u32::try_from(o.class.index()).unwrap_or(0),
            has_uncertainty: u32::from(o.uncertainty.is_some()),
            x_m: o.x_m,
            y_m: o.y_m,
            heading_rad: o.heading_rad,
            speed_mps: o.speed_mps,
            length_m: o.length_m,
            width_m: o.width_m,
            uncertainty: o.uncertainty.map_or_else(PmonUncertainty::default, |u| PmonUncertainty {
                x_m: u.x_m,
                y_m: u.y_m,
                heading_rad: u.heading_rad,
                speed_mps: u.speed_mps,
                length_m: u.length_m,
                width_m: u.width_m,
            }),
        }));
        let polygon = |p: &Vec<[f32; 2]>| PmonPolygon { xy: p.as_ptr().cast::<f32>(), vertex_count: p.len() };
        rec.roi.clear();
        rec.roi.extend(f.roi_in_ego.iter().map(polygon));
        rec.scenery.clear();
        rec.scenery.extend(f.static_in_ego.iter().map(polygon));
        let (has_cloud, points, point_count, iso) = match &f.cloud {
            Some(c) => (1, c.points_in_sensor.as_ptr().cast::<f32>(), c.points_in_sensor.len(), c.ego_from_sensor),
            None => (0, core::ptr::null(), 0, Isometry3::IDENTITY),
        };
        let r = iso.rotation;
        let view = PmonFrame {
            timestamp_s: f.timestamp_s,
            world_x_m: f.world_from_ego.x_m,
            world_y_m: f.world_from_ego.y_m,
            world_yaw_rad: f.world_from_ego.yaw_rad,
            objects: rec.objects.as_ptr(),
            object_count: rec.objects.len(),
            has_cloud,
            point_stride: 3,
            points,
            point_count,
            ego_from_sensor_rotation: [r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2]],
            ego_from_sensor_translation_m: iso.translation_m,
            roi: rec.roi.as_ptr(),
            roi_count: rec.roi.len(),
            scenery: rec.scenery.as_ptr(),
            scenery_count: rec.scenery.len(),
        };
        // SAFETY: valid by contract; the arrays point into `rec`, which keeps `f` alive until the next call.
        unsafe {
            frame.write(view);
            if !index.is_null() {
                index.write(f.index);
            }
        }
        rec.current = Some(f);
        Ok(())
    });
    if status == PMON_OK && end {
        PMON_END
    } else {
        status
    }
}

/// Frees a recording (null is allowed).
///
/// # Safety
/// `recording` null or a handle from `pmon_recording_open`, not used afterwards.
#[no_mangle]
pub unsafe extern "C" fn pmon_recording_free(recording: *mut PmonRecording) {
    if !recording.is_null() {
        // SAFETY: created by Box::into_raw; freed once by contract.
        let _ = catch_unwind(AssertUnwindSafe(|| drop(unsafe { Box::from_raw(recording) })));
    }
}
