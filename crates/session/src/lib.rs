//! # pmon-session: the monitor for foreign callers
//!
//! A monitor with the scratch buffers a foreign caller needs: safe Rust, shared by the C API (`crates/capi`,
//! re-exported there as `pmon_capi::session`) and the Python package (`crates/python`).
//!
//! Foreign callers hand over flat `f32` point buffers (stride 3 or 4), their own object records and polygons
//! as (pointer, length) pairs. [`Session`] turns these into the monitor's borrowed [`Frame`] without allocating
//! per frame: the object list goes into a buffer of capacity `max_objects` made at construction; a stride-3
//! cloud is reinterpreted in place (no copy); a stride-4 cloud is copied into a buffer made on its first use;
//! the list of polygon slices reuses one buffer that only grows when a frame has more polygons than any before.

pub mod profiles;

use pmon_monitor::{
    Frame, FrameError, FrameReport, Isometry3, Monitor, MonitorParams, ObjectState, ParamError, PointCloud, Pose2,
};

/// A LiDAR sweep as a flat buffer: `points.len() / stride` points `x, y, z[, intensity]` in the sensor frame.
#[derive(Clone, Copy, Debug)]
pub struct FlatCloud<'a> {
    /// `x, y, z` (stride 3) or `x, y, z, w` (stride 4, `w` ignored) per point, metres, sensor frame.
    pub points: &'a [f32],
    /// Floats per point: 3 or 4.
    pub stride: usize,
    /// Extrinsic `ego_from_sensor`.
    pub ego_from_sensor: Isometry3,
}

/// Why a frame was refused as a whole.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CheckError {
    /// Bad input from the caller (what is wrong, in words).
    InvalidArgument(String),
    /// The monitor refused the frame (more objects than `max_objects`).
    Frame(FrameError),
}

impl core::fmt::Display for CheckError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::InvalidArgument(m) => f.write_str(m),
            Self::Frame(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for CheckError {}

/// A [`Monitor`] plus the scratch space to call it from foreign code without allocating per frame.
pub struct Session {
    monitor: Monitor,
    max_objects: usize,
    max_points: usize,
    objects: Vec<ObjectState>,
    xyz: Vec<[f32; 3]>,
    polygons: Vec<&'static [[f32; 2]]>,
}

impl Session {
    /// A monitor with these parameters (validated: the first field out of range is the error).
    ///
    /// # Errors
    /// [`ParamError`] from [`MonitorParams::validate`].
    pub fn new(params: MonitorParams) -> Result<Self, ParamError> {
        let monitor = Monitor::new(params)?;
        let max_objects = usize::try_from(params.max_objects).unwrap_or(usize::MAX);
        let max_points = usize::try_from(params.max_points).unwrap_or(usize::MAX);
        Ok(Self {
            monitor,
            max_objects,
            max_points,
            objects: Vec::with_capacity(max_objects),
            xyz: Vec::new(),
            polygons: Vec::new(),
        })
    }

    /// The capacity for objects per frame (`max_objects`).
    #[must_use]
    pub fn max_objects(&self) -> usize {
        self.max_objects
    }

    /// Empties the object buffer and returns it, for the caller to fill with at most [`Session::max_objects`]
    /// objects before [`Session::check`] (more are refused by `check` with the monitor's own error).
    pub fn objects_mut(&mut self) -> &mut Vec<ObjectState> {
        self.objects.clear();
        &mut self.objects
    }

    /// Checks a frame made of the objects put in [`Session::objects_mut`], the optional cloud and the
    /// polygons (region of interest and static scenery, ego frame).
    ///
    /// # Errors
    /// [`CheckError::InvalidArgument`] for a cloud whose length is not a multiple of its stride or a stride
    /// other than 3 and 4; [`CheckError::Frame`] for more objects than `max_objects`.
    pub fn check<'a>(
        &mut self,
        timestamp_s: f64,
        world_from_ego: Pose2,
        cloud: Option<FlatCloud<'a>>,
        roi: impl Iterator<Item = &'a [[f32; 2]]>,
        scenery: impl Iterator<Item = &'a [[f32; 2]]>,
    ) -> Result<FrameReport<'_>, CheckError> {
        if self.objects.len() > self.max_objects {
            let max = u32::try_from(self.max_objects).unwrap_or(u32::MAX);
            return Err(CheckError::Frame(FrameError::TooManyObjects { got: self.objects.len(), max }));
        }
        let cloud = match cloud {
            None => None,
            Some(c) => Some(PointCloud {
                points_in_sensor: points_view(c.points, c.stride, self.max_points, &mut self.xyz)?,
                ego_from_sensor: c.ego_from_sensor,
            }),
        };
        // Reuse the polygon buffer: `&'static` slices coerce to the frame's shorter lifetime (Vec is covariant).
        let mut polygons: Vec<&'a [[f32; 2]]> = core::mem::take(&mut self.polygons);
        polygons.clear();
        polygons.extend(roi);
        let roi_count = polygons.len();
        polygons.extend(scenery);
        let (roi_in_ego, static_in_ego) = polygons.split_at(roi_count);
        let frame = Frame { timestamp_s, world_from_ego, objects: &self.objects, cloud, roi_in_ego, static_in_ego };
        let report = self.monitor.check(&frame).map_err(CheckError::Frame);
        self.polygons = recycle(polygons);
        report
    }
}

/// Gives the emptied buffer back its `'static` element type. The collect of an empty `vec::IntoIter` into a
/// `Vec` of a type with the same layout reuses the allocation (std's in-place collection; the test
/// `polygon_buffer_is_reused` checks it), so nothing is allocated.
fn recycle(mut v: Vec<&[[f32; 2]]>) -> Vec<&'static [[f32; 2]]> {
    v.clear();
    v.into_iter().map(|_| -> &'static [[f32; 2]] { &[] }).collect()
}

/// The points as `[x, y, z]` triples: the buffer itself for stride 3, a copy into `scratch` for stride 4
/// (at most `max_points + 1` points are copied: a larger cloud is *too many points* for the monitor whatever
/// its content, and the copy must not allocate more than that).
fn points_view<'a>(
    flat: &'a [f32],
    stride: usize,
    max_points: usize,
    scratch: &'a mut Vec<[f32; 3]>,
) -> Result<&'a [[f32; 3]], CheckError> {
    if !flat.len().is_multiple_of(stride.max(1)) {
        return Err(CheckError::InvalidArgument(format!(
            "the cloud has {} floats, not a multiple of its stride {stride}",
            flat.len()
        )));
    }
    match stride {
        3 => bytemuck::try_cast_slice(flat)
            .map_err(|e| CheckError::InvalidArgument(format!("the cloud cannot be read as x, y, z triples: {e}"))),
        4 => {
            let keep = (flat.len() / 4).min(max_points.saturating_add(1));
            scratch.clear();
            scratch.reserve(keep);
            scratch.extend(flat.chunks_exact(4).take(keep).map(|p| match p {
                [x, y, z, _] => [*x, *y, *z],
                _ => [f32::NAN; 3],
            }));
            Ok(scratch.as_slice())
        }
        other => Err(CheckError::InvalidArgument(format!("point stride must be 3 or 4 floats, got {other}"))),
    }
}

/// Parameters from a JSON object (the keys of `pmon params`, nested tables as objects); keys left out keep
/// Table I; unknown keys and out-of-range values are errors.
///
/// # Errors
/// A message naming the key or field.
pub fn params_from_json(text: &str) -> Result<MonitorParams, String> {
    let p: MonitorParams = serde_json::from_str(text).map_err(|e| format!("parameters: {e}"))?;
    p.validate().map_err(|e| e.to_string())?;
    Ok(p)
}

/// Parameters from TOML text (as written by `pmon params`); same rules as [`params_from_json`].
///
/// # Errors
/// A message naming the key or field.
pub fn params_from_toml(text: &str) -> Result<MonitorParams, String> {
    let p: MonitorParams = toml::from_str(text).map_err(|e| format!("parameters: {}", e.to_string().trim_end()))?;
    p.validate().map_err(|e| e.to_string())?;
    Ok(p)
}

/// Parameters from a TOML file (as `--params FILE` of the `pmon` command); errors name the file. `profile:NAME`
/// loads one of the [`profiles::PROFILES`] over the defaults instead (a file of that name: `./profile:NAME`).
///
/// # Errors
/// An unreadable file, an unknown profile, unknown keys, values out of range.
pub fn params_from_file(path: &std::path::Path) -> Result<MonitorParams, String> {
    if let Some(name) = path.to_str().and_then(profiles::profile_name) {
        let text = profiles::profile_toml(name)?;
        return params_from_toml(text).map_err(|e| format!("profile:{name}: {e}"));
    }
    let text =
        std::fs::read_to_string(path).map_err(|e| format!("cannot read parameter file {}: {e}", path.display()))?;
    params_from_toml(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The parameters (Table I by default) as JSON, for foreign callers that want to show or edit them.
#[must_use]
pub fn params_to_json(params: &MonitorParams) -> String {
    serde_json::to_string(params).unwrap_or_default()
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn polygon_buffer_is_reused() {
        let mut v: Vec<&[[f32; 2]]> = Vec::with_capacity(16);
        let square = [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0]];
        v.push(&square);
        let ptr = v.as_ptr() as usize;
        let back = recycle(v);
        assert_eq!(back.capacity(), 16);
        assert_eq!(back.as_ptr() as usize, ptr);
        assert!(back.is_empty());
    }

    #[test]
    fn stride_three_is_not_copied_and_stride_four_drops_the_fourth_value() {
        let flat = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0];
        let mut scratch = Vec::new();
        let v = points_view(&flat, 3, 10, &mut scratch).unwrap();
        assert_eq!(v.as_ptr() as usize, flat.as_ptr() as usize);
        assert_eq!(v, &[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        let flat4 = [1.0f32, 2.0, 3.0, 9.0, 4.0, 5.0, 6.0, 9.0];
        let v = points_view(&flat4, 4, 10, &mut scratch).unwrap();
        assert_eq!(v, &[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert!(points_view(&flat4[..7], 4, 10, &mut scratch).is_err());
        assert!(points_view(&flat, 2, 10, &mut scratch).is_err());
    }

    #[test]
    fn a_copied_cloud_beyond_capacity_stays_too_large() {
        let flat = [0.0f32; 4 * 10];
        let mut scratch = Vec::new();
        let v = points_view(&flat, 4, 3, &mut scratch).unwrap();
        assert_eq!(v.len(), 4);
    }

    #[test]
    fn unknown_keys_and_bad_values_are_refused() {
        assert!(params_from_json("{}").is_ok());
        assert!(params_from_json(r#"{"cell_size_m": 0.2}"#).is_ok());
        let e = params_from_json(r#"{"cell_sise_m": 0.2}"#).unwrap_err();
        assert!(e.contains("cell_sise_m"), "{e}");
        let e = params_from_json(r#"{"cell_size_m": -1}"#).unwrap_err();
        assert!(e.contains("cell_size_m"), "{e}");
        let e = params_from_toml("tau_tp = 2.0").unwrap_err();
        assert!(e.contains("tau_tp"), "{e}");
    }

    #[test]
    fn a_profile_loads_by_name_where_a_file_would() {
        let p = params_from_file(std::path::Path::new("profile:recall")).unwrap();
        let d = MonitorParams::default();
        assert_ne!(p, d);
        assert_eq!(p, MonitorParams { returns_beyond_cells: 1, face_in_front: true, seen_over: true, ..d });
        let e = params_from_file(std::path::Path::new("profile:fast")).unwrap_err();
        assert!(e.contains("unknown parameter profile `fast`"), "{e}");
        let e = params_from_file(std::path::Path::new("./profile:recall")).unwrap_err();
        assert!(e.contains("cannot read parameter file ./profile:recall"), "{e}");
    }
}
