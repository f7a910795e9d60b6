//! KITTI (Geiger, Lenz, Urtasun, CVPR 2012): the 3D object benchmark and the tracking benchmark's labels.
//!
//! Frames: labels are in the rectified camera-0 frame (x right, y down, z forward, box `(x, y, z)` = bottom
//! centre). They are converted to the Velodyne frame with `p_velo = inv(R0_rect * Tr_velo_to_cam) * p_rect`,
//! yaw `-rotation_y - pi/2`. The Velodyne frame (x forward, y left, z up) has its origin 1.73 m above the
//! ground, so this crate's ego frame is the Velodyne frame moved down to the ground: `ego_from_sensor` is a
//! pure translation by [`VELODYNE_HEIGHT_M`] and objects' z is Velodyne z + 1.73 m. Ground is near z = 0.

use std::collections::BTreeMap;
use std::f64::consts::FRAC_PI_2;
use std::path::{Path, PathBuf};

use pmon_monitor::{Isometry3, ObjectClass, ObjectState, Pose2};
use pmon_recording::RecordedFrame;

use crate::geometry::{clip_to_square, inverse, mat_vec, polygon_area, wrap_angle, Box3, Mat3};
use crate::roi::{RoiMode, ROI_NOTE_PREFIX};
use crate::sweeps::{SweepFile, SweepFormat};
use crate::util::{f32_of, finite_difference_speeds, list_dir, parse_f64, read_bytes, read_text};
use crate::{Dataset, DatasetError, DatasetFormat, DatasetFrame, DatasetInfo, ObjectExtra, ReadOptions, SpeedSource};

/// Mounting height of the Velodyne HDL-64E above the ground, metres (KITTI setup: ground near z = -1.73 m).
pub const VELODYNE_HEIGHT_M: f32 = 1.73;

/// Tracking benchmark frame period, seconds (10 Hz).
pub const TRACKING_PERIOD_S: f64 = 0.1;

/// Largest gap between two observations of a track used for a finite difference, seconds.
const MAX_GAP_S: f64 = 0.5;

/// The camera-from-Velodyne part of a KITTI calibration file: `p_rect = a * p_velo + b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KittiCalib {
    /// `R0_rect * R_velo_to_cam` (3x3).
    pub rect_from_velo_rot: Mat3,
    /// `R0_rect * t_velo_to_cam`, metres.
    pub rect_from_velo_t: [f64; 3],
    /// Inverse of `rect_from_velo_rot`.
    velo_from_rect_rot: Mat3,
}

impl KittiCalib {
    /// Builds the calibration from `R0_rect` and `Tr_velo_to_cam` (row-major 3x4).
    ///
    /// # Errors
    /// A singular or non-finite matrix.
    pub fn new(r0_rect: &Mat3, tr_velo_to_cam: &[[f64; 4]; 3]) -> Result<Self, String> {
        let r = [
            [tr_velo_to_cam[0][0], tr_velo_to_cam[0][1], tr_velo_to_cam[0][2]],
            [tr_velo_to_cam[1][0], tr_velo_to_cam[1][1], tr_velo_to_cam[1][2]],
            [tr_velo_to_cam[2][0], tr_velo_to_cam[2][1], tr_velo_to_cam[2][2]],
        ];
        let t = [tr_velo_to_cam[0][3], tr_velo_to_cam[1][3], tr_velo_to_cam[2][3]];
        let a = crate::geometry::mat_mul(r0_rect, &r);
        let b = mat_vec(r0_rect, t);
        let inv = inverse(&a).ok_or("R0_rect * Tr_velo_to_cam is singular or not finite")?;
        Ok(Self { rect_from_velo_rot: a, rect_from_velo_t: b, velo_from_rect_rot: inv })
    }

    /// A nominal calibration (axis permutation, Velodyne 0.27 m behind and 0.08 m above camera 0, the KITTI
    /// setup drawing), for label files shipped without their calibration. Positions are good to a few
    /// centimetres near the car and about 1 % of range far away (the real rotation differs by ~0.5 degrees).
    #[must_use]
    pub fn nominal() -> Self {
        let a = [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]];
        let inv = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
        Self { rect_from_velo_rot: a, rect_from_velo_t: [0.0, -0.08, -0.27], velo_from_rect_rot: inv }
    }

    /// A point of the rectified camera frame in the Velodyne frame.
    #[must_use]
    pub fn velo_from_rect(&self, p: [f64; 3]) -> [f64; 3] {
        let b = self.rect_from_velo_t;
        mat_vec(&self.velo_from_rect_rot, [p[0] - b[0], p[1] - b[1], p[2] - b[2]])
    }
}

/// Parses a KITTI calibration file (object: `R0_rect:`, `Tr_velo_to_cam:`; tracking: `R_rect`, `Tr_velo_cam`).
///
/// # Errors
/// Missing keys, wrong number of values, values that are not numbers.
pub fn parse_calib(text: &str) -> Result<KittiCalib, String> {
    let mut r0: Option<Vec<f64>> = None;
    let mut tr: Option<Vec<f64>> = None;
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let mut tokens = line.split_whitespace();
        let Some(key) = tokens.next() else { continue };
        let key = key.trim_end_matches(':');
        let slot = match key {
            "R0_rect" | "R_rect" => &mut r0,
            "Tr_velo_to_cam" | "Tr_velo_cam" => &mut tr,
            _ => continue,
        };
        let values = tokens.map(|t| parse_f64(t, &format!("line {}: {key}", n + 1))).collect::<Result<Vec<_>, _>>()?;
        *slot = Some(values);
    }
    let r0 = r0.ok_or("no `R0_rect` (or `R_rect`) line")?;
    let tr = tr.ok_or("no `Tr_velo_to_cam` (or `Tr_velo_cam`) line")?;
    let [a, b, c, d, e, f, g, h, i] = r0.as_slice() else {
        return Err(format!("R0_rect has {} values, expected 9", r0.len()));
    };
    let [t0, t1, t2, t3, t4, t5, t6, t7, t8, t9, t10, t11] = tr.as_slice() else {
        return Err(format!("Tr_velo_to_cam has {} values, expected 12", tr.len()));
    };
    KittiCalib::new(
        &[[*a, *b, *c], [*d, *e, *f], [*g, *h, *i]],
        &[[*t0, *t1, *t2, *t3], [*t4, *t5, *t6, *t7], [*t8, *t9, *t10, *t11]],
    )
}

/// One label line.
#[derive(Clone, Debug, PartialEq)]
pub struct KittiLabel {
    /// Frame number (tracking labels only).
    pub frame: Option<u64>,
    /// Track id (tracking labels only; -1 for `DontCare`).
    pub track_id: Option<i64>,
    /// `type` column (`Car`, `Van`, `Pedestrian`, ..., `DontCare`).
    pub kind: String,
    /// Box height, width, length, metres.
    pub hwl_m: [f64; 3],
    /// Bottom centre in the rectified camera frame, metres.
    pub bottom_center_rect_m: [f64; 3],
    /// Rotation about the camera's y axis, radians.
    pub rotation_y_rad: f64,
}

/// Parses one label line: 15 (object, optionally 16 with a score) or 17 (tracking, optionally 18) columns.
///
/// # Errors
/// A wrong column count or a value that is not a number.
pub fn parse_label_line(line: &str, tracking: bool) -> Result<KittiLabel, String> {
    let cols: Vec<&str> = line.split_whitespace().collect();
    let (base, ok) = if tracking { (2, matches!(cols.len(), 17 | 18)) } else { (0, matches!(cols.len(), 15 | 16)) };
    if !ok {
        return Err(format!(
            "{} columns, expected {} (KITTI {} label)",
            cols.len(),
            if tracking { "17" } else { "15" },
            if tracking { "tracking" } else { "object" }
        ));
    }
    let col = |i: usize| cols.get(i).copied().unwrap_or("");
    let num = |i: usize, what: &str| parse_f64(col(i), what);
    let (frame, track_id) = if tracking {
        let frame = col(0).parse::<u64>().map_err(|_| format!("frame `{}` is not a frame number", col(0)))?;
        let track = col(1).parse::<i64>().map_err(|_| format!("track id `{}` is not an integer", col(1)))?;
        (Some(frame), Some(track))
    } else {
        (None, None)
    };
    let kind = col(base).to_string();
    let hwl_m = [num(base + 8, "h")?, num(base + 9, "w")?, num(base + 10, "l")?];
    let bottom_center_rect_m = [num(base + 11, "x")?, num(base + 12, "y")?, num(base + 13, "z")?];
    let rotation_y_rad = num(base + 14, "rotation_y")?;
    // truncated, occluded, alpha, bbox: validated as numbers, not used
    for (i, what) in
        [(1, "truncated"), (2, "occluded"), (3, "alpha"), (4, "bbox"), (5, "bbox"), (6, "bbox"), (7, "bbox")]
    {
        num(base + i, what)?;
    }
    Ok(KittiLabel { frame, track_id, kind, hwl_m, bottom_center_rect_m, rotation_y_rad })
}

/// The monitor's class for a KITTI `type`.
#[must_use]
pub fn class_of(kind: &str) -> ObjectClass {
    match kind {
        "Car" => ObjectClass::Car,
        "Van" | "Truck" | "Tram" => ObjectClass::Truck,
        "Pedestrian" | "Person_sitting" | "Person" => ObjectClass::Pedestrian,
        "Cyclist" => ObjectClass::Cyclist,
        "Misc" => ObjectClass::Other,
        _ => ObjectClass::Unknown,
    }
}

/// A label's box in the Velodyne frame (geometric centre), per the KITTI devkit conversion.
///
/// # Errors
/// Non-positive dimensions.
pub fn box_in_velodyne(label: &KittiLabel, calib: &KittiCalib) -> Result<Box3, String> {
    let [h, w, l] = label.hwl_m;
    if !(h > 0.0 && w > 0.0 && l > 0.0) {
        return Err(format!("box dimensions h={h} w={w} l={l} must be positive"));
    }
    let [x, y, z] = label.bottom_center_rect_m;
    let c = calib.velo_from_rect([x, y - h / 2.0, z]);
    let yaw = wrap_angle(-label.rotation_y_rad - FRAC_PI_2);
    Ok(Box3 {
        center_m: [f32_of(c[0]), f32_of(c[1]), f32_of(c[2])],
        length_m: f32_of(l),
        width_m: f32_of(w),
        height_m: f32_of(h),
        yaw_rad: f32_of(yaw),
    })
}

/// Reads a Velodyne `.bin` sweep (N x 4 little-endian f32 `x, y, z, reflectance`), Velodyne frame.
///
/// # Errors
/// I/O errors, a size that is not a whole number of 16-byte points.
pub fn read_velodyne(path: &Path) -> Result<Vec<[f32; 3]>, DatasetError> {
    let bytes = read_bytes(path)?;
    pmon_recording::points_from_le_bytes(&bytes, 4).map_err(|m| DatasetError::malformed(path, m))
}

/// The extrinsic from the Velodyne frame to this crate's KITTI ego frame (ground below the Velodyne).
#[must_use]
pub fn ego_from_velodyne() -> Isometry3 {
    Isometry3::from_translation(0.0, 0.0, VELODYNE_HEIGHT_M)
}

/// Camera 2's focal length in pixels, its principal point's column and its image width: the values of the KITTI
/// object benchmark's `P2` and images (1242 x 375; the calibration files' `P2` differs from them by a few pixels
/// between drives, which moves the field of view's edges by a fraction of a degree).
const CAMERA2_FX_PX: f64 = 721.5377;
const CAMERA2_CX_PX: f64 = 609.5593;
const CAMERA2_WIDTH_PX: f64 = 1242.0;

/// Degrees added to each side of camera 2's field of view in the default region of interest: a labelled object cut
/// by the image's edge keeps the returns beside it.
pub const FIELD_OF_VIEW_MARGIN_DEG: f64 = 5.0;

/// The angles of the rays through camera 2's image's left and right edges off its axis, radians.
fn camera2_half_angles() -> (f64, f64) {
    ((CAMERA2_CX_PX / CAMERA2_FX_PX).atan(), ((CAMERA2_WIDTH_PX - CAMERA2_CX_PX) / CAMERA2_FX_PX).atan())
}

/// The labelled field of view in the ego frame (KITTI labels only the objects in camera 2's image): the wedge from
/// the camera's centre between the rays through the image's left and right edges, each widened by
/// [`FIELD_OF_VIEW_MARGIN_DEG`], clipped to the grid's square of half side `half` (metres). `None` when the clip
/// leaves nothing (also when the calibration turns the camera's view off the ground: a degenerate or undefined
/// wedge has no area).
#[must_use]
#[allow(clippy::cast_possible_truncation)] // ego-frame metres inside the grid: f32 is the monitor's precision
pub fn field_of_view_polygon(calib: &KittiCalib, half: f64) -> Option<Vec<[f32; 2]>> {
    let margin = FIELD_OF_VIEW_MARGIN_DEG.to_radians();
    let (left, right) = camera2_half_angles();
    let (left, right) = (left + margin, right + margin);
    let apex = calib.velo_from_rect([0.0, 0.0, 0.0]);
    // A direction of the rectified camera frame (x right, z forward) on the Velodyne frame's ground plane.
    let dir = |x: f64| {
        let q = calib.velo_from_rect([x, 0.0, 1.0]);
        let (dx, dy) = (q[0] - apex[0], q[1] - apex[1]);
        let n = dx.hypot(dy);
        [dx / n, dy / n]
    };
    // Far enough that the wedge's far edge lies outside the grid's square (the half-angles stay below 60 degrees
    // with the margin: the edge is at least half this far).
    let reach = 8.0 * half + apex[0].abs() + apex[1].abs();
    let (l, r) = (dir(-left.tan()), dir(right.tan()));
    let wedge = [
        [apex[0], apex[1]],
        [apex[0] + reach * r[0], apex[1] + reach * r[1]],
        [apex[0] + reach * l[0], apex[1] + reach * l[1]],
    ];
    let clipped = clip_to_square(&wedge, half);
    (clipped.len() >= 3 && polygon_area(&clipped).abs() > 1e-6)
        .then(|| clipped.iter().map(|q| [q[0] as f32, q[1] as f32]).collect())
}

fn object_of(id: u64, label: &KittiLabel, b: &Box3, speed_mps: f32, track_key: String) -> (ObjectState, ObjectExtra) {
    let o = ObjectState {
        id,
        class: class_of(&label.kind),
        x_m: b.center_m[0],
        y_m: b.center_m[1],
        heading_rad: b.yaw_rad,
        speed_mps,
        length_m: b.length_m,
        width_m: b.width_m,
        uncertainty: None,
    };
    let e = ObjectExtra {
        track_key,
        category: label.kind.clone(),
        height_m: Some(b.height_m),
        z_center_m: Some(b.center_m[2] + VELODYNE_HEIGHT_M),
        num_points: None,
        accel_mps2: None,
    };
    (o, e)
}

/// Reads a KITTI 3D object directory (`DIR/velodyne/NNNNNN.bin`, `DIR/label_2/NNNNNN.txt`,
/// `DIR/calib/NNNNNN.txt`). Frames are unrelated snapshots: frame `NNNNNN` gets timestamp `NNNNNN` seconds
/// (so nothing links them in time), ids are unique over the whole set, speeds are 0 (unknown).
///
/// # Errors
/// Missing directories, a label without its calibration, malformed or truncated files.
pub fn open_object(dir: &Path, opts: &ReadOptions) -> Result<Dataset, DatasetError> {
    open_object_with(dir, opts, false).map(|(ds, _)| ds)
}

/// [`open_object`]; with `defer` the sweeps are not read but returned per frame (the frames' clouds `None`), for
/// [`crate::sweeps::open_deferred`]. Without `defer` each sweep is read where it always was (so the errors come
/// in the same order).
pub(crate) fn open_object_with(
    dir: &Path,
    opts: &ReadOptions,
    defer: bool,
) -> Result<(Dataset, Vec<Option<SweepFile>>), DatasetError> {
    let velo_dir = dir.join("velodyne");
    let label_dir = dir.join("label_2");
    let calib_dir = dir.join("calib");
    let velo_files = list_dir(&velo_dir, |n| n.ends_with(".bin"))?;
    if velo_files.is_empty() {
        return Err(DatasetError::malformed(&velo_dir, "no `.bin` sweeps"));
    }
    let mut frames = Vec::new();
    let mut files = Vec::new();
    let mut notes = vec![
        format!(
            "ego frame = Velodyne frame moved down by {VELODYNE_HEIGHT_M} m to the ground (ego_from_sensor = \
             translation(0, 0, {VELODYNE_HEIGHT_M})); ground_z_m = 0"
        ),
        "frames are unrelated snapshots: timestamp_s = file number, object ids unique over the set, speed 0 \
         (unknown), ego pose identity"
            .to_string(),
        "DontCare labels skipped; labels converted camera -> Velodyne with inv(R0_rect * Tr_velo_to_cam), yaw = \
         -rotation_y - pi/2"
            .to_string(),
    ];
    let mut dontcare = 0usize;
    let mut missing_labels = 0usize;
    let mut next_id = 1u64;
    // The default region of interest of KITTI's object frames: the labelled field of view (other modes are applied
    // after the reader, `roi::finish`).
    let field_of_view = opts.roi.mode == RoiMode::Auto;
    let mut no_view = 0usize;
    for velo in &velo_files {
        let stem = velo.file_stem().and_then(|s| s.to_str()).unwrap_or_default().to_string();
        let number: u64 = stem
            .parse()
            .map_err(|_| DatasetError::malformed(velo, "sweep file name is not a frame number (NNNNNN.bin)"))?;
        let label_path = label_dir.join(format!("{stem}.txt"));
        let mut objects = Vec::new();
        let mut extras = Vec::new();
        let mut frame_calib = None;
        if label_path.exists() {
            let text = read_text(&label_path)?;
            let calib_path = calib_dir.join(format!("{stem}.txt"));
            let calib = parse_calib(&read_text(&calib_path)?).map_err(|m| DatasetError::malformed(&calib_path, m))?;
            frame_calib = Some(calib);
            for (n, line) in text.lines().enumerate() {
                if line.trim().is_empty() {
                    continue;
                }
                let here = |m: String| DatasetError::malformed(&label_path, format!("line {}: {m}", n + 1));
                let label = parse_label_line(line, false).map_err(here)?;
                if label.kind == "DontCare" {
                    dontcare += 1;
                    continue;
                }
                let b = box_in_velodyne(&label, &calib).map_err(here)?;
                let (o, e) = object_of(next_id, &label, &b, 0.0, format!("{stem}:{}", n + 1));
                next_id += 1;
                objects.push(o);
                extras.push(e);
            }
        } else {
            missing_labels += 1;
        }
        let file = opts.load_clouds.then(|| SweepFile {
            path: velo.clone(),
            format: SweepFormat::KittiVelodyne,
            ego_from_sensor: ego_from_velodyne(),
        });
        let cloud = match &file {
            Some(f) if !defer => Some(f.read()?),
            _ => None,
        };
        files.push(if defer { file } else { None });
        #[allow(clippy::cast_precision_loss)] // frame numbers < 2^53
        let mut frame = RecordedFrame::empty(frames.len() as u64, number as f64, Pose2::default());
        frame.objects = objects;
        frame.cloud = cloud;
        if field_of_view {
            // A sweep without a label file has no calibration of its own: the nominal one.
            let calib = frame_calib.unwrap_or_else(KittiCalib::nominal);
            frame.roi_in_ego = field_of_view_polygon(&calib, opts.roi.grid_half_extent_m).into_iter().collect();
            no_view += usize::from(frame.roi_in_ego.is_empty());
        }
        frames.push(DatasetFrame { frame, extras });
    }
    if field_of_view {
        notes.push(format!(
            "{ROI_NOTE_PREFIX}the labelled field of view: KITTI labels only the objects in camera 2's image, so \
             returns outside it are no missed object of the label list; the wedge from the camera between the \
             image's edges ({:.1} deg left, {:.1} deg right of its axis) widened by {FIELD_OF_VIEW_MARGIN_DEG} deg \
             on each side (--roi none: the whole grid, where every unlabelled structure is a missed-object alarm; \
             --roi corridor:<width_m>: a band along the ego's x axis)",
            camera2_half_angles().0.to_degrees(),
            camera2_half_angles().1.to_degrees(),
        ));
        if no_view > 0 {
            notes.push(format!(
                "{no_view} frames have no field of view in the grid (their calibration turns the camera's view off \
                 the ground): no region of interest there, the whole grid"
            ));
        }
    }
    notes.push(format!("{dontcare} DontCare labels skipped"));
    if missing_labels > 0 {
        notes.push(format!("{missing_labels} sweeps have no label file (no objects)"));
    }
    let ds = Dataset {
        info: DatasetInfo {
            name: dir.file_name().and_then(|s| s.to_str()).unwrap_or("kitti").to_string(),
            format: DatasetFormat::KittiObject,
            source: dir.to_path_buf(),
            ground_z_m: 0.0,
            ego_pose_known: false,
            speed_source: SpeedSource::Unknown,
            frame_period_s: None,
            notes,
        },
        frames,
    };
    Ok((ds, files))
}

/// Reads a KITTI tracking label file `.../label_02/SSSS.txt` (17 columns with frame and track id) into
/// one frame per frame number from 0 to the last labelled one, 10 Hz, no clouds, ego pose identity.
///
/// The calibration `.../calib/SSSS.txt` beside `label_02` is used when present, otherwise
/// [`KittiCalib::nominal`]. Speeds are central finite differences of the track's positions in the moving ego
/// frame, so they include the ego vehicle's own motion (ego-relative; noted in the metadata).
///
/// # Errors
/// I/O errors, malformed lines, frames out of order in a way that repeats a track within a frame.
pub fn open_tracking(label_path: &Path) -> Result<Dataset, DatasetError> {
    let text = read_text(label_path)?;
    let stem = label_path.file_stem().and_then(|s| s.to_str()).unwrap_or_default().to_string();
    let calib_path: Option<PathBuf> = label_path
        .parent()
        .and_then(Path::parent)
        .map(|root| root.join("calib").join(format!("{stem}.txt")))
        .filter(|p| p.exists());
    let mut notes = Vec::new();
    let calib = match &calib_path {
        Some(p) => {
            notes.push(format!("calibration from {}", p.display()));
            parse_calib(&read_text(p)?).map_err(|m| DatasetError::malformed(p, m))?
        }
        None => {
            notes.push(
                "no calib/SSSS.txt beside label_02: nominal camera->Velodyne calibration used (axis permutation, \
                 Velodyne 0.27 m behind, 0.08 m above camera 0); positions good to a few cm near the car"
                    .to_string(),
            );
            KittiCalib::nominal()
        }
    };
    // (frame, track) -> object, kept sorted by frame then line
    let mut per_frame: BTreeMap<u64, Vec<(i64, KittiLabel, Box3)>> = BTreeMap::new();
    let mut dontcare = 0usize;
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let here = |m: String| DatasetError::malformed(label_path, format!("line {}: {m}", n + 1));
        let label = parse_label_line(line, true).map_err(here)?;
        let (Some(frame), Some(track)) = (label.frame, label.track_id) else { continue };
        if label.kind == "DontCare" || track < 0 {
            dontcare += 1;
            continue;
        }
        if frame > 1_000_000 {
            return Err(here(format!("frame number {frame} is implausibly large")));
        }
        let b = box_in_velodyne(&label, &calib).map_err(here)?;
        let list = per_frame.entry(frame).or_default();
        if list.iter().any(|(t, _, _)| *t == track) {
            return Err(here(format!("track {track} appears twice in frame {frame}")));
        }
        list.push((track, label, b));
    }
    // finite-difference speeds per track (ego-relative)
    let mut tracks: BTreeMap<i64, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for (frame, list) in &per_frame {
        for (track, _, b) in list {
            #[allow(clippy::cast_precision_loss)]
            let t = *frame as f64 * TRACKING_PERIOD_S;
            tracks.entry(*track).or_default().push((t, f64::from(b.center_m[0]), f64::from(b.center_m[1])));
        }
    }
    let speeds: BTreeMap<i64, Vec<Option<f64>>> =
        tracks.iter().map(|(k, obs)| (*k, finite_difference_speeds(obs, MAX_GAP_S))).collect();
    let mut cursor: BTreeMap<i64, usize> = BTreeMap::new();
    let mut no_speed = 0usize;
    let last = per_frame.keys().next_back().copied().unwrap_or(0);
    let mut frames = Vec::new();
    for f in 0..=last {
        #[allow(clippy::cast_precision_loss)]
        let mut frame = RecordedFrame::empty(f, f as f64 * TRACKING_PERIOD_S, Pose2::default());
        let mut extras = Vec::new();
        if let Some(list) = per_frame.get(&f) {
            for (track, label, b) in list {
                let k = cursor.entry(*track).or_insert(0);
                let speed = speeds.get(track).and_then(|v| v.get(*k)).copied().flatten();
                *k += 1;
                if speed.is_none() {
                    no_speed += 1;
                }
                let id = u64::try_from(*track).unwrap_or(0);
                let (o, e) = object_of(id, label, b, f32_of(speed.unwrap_or(0.0)), track.to_string());
                frame.objects.push(o);
                extras.push(e);
            }
        }
        frames.push(DatasetFrame { frame, extras });
    }
    notes.push(
        "speeds are central finite differences in the moving ego (camera) frame: they INCLUDE the ego vehicle's \
         motion (ego-relative, not speed over ground); no ego motion (oxts) is read, ego pose is identity"
            .to_string(),
    );
    notes.push(format!("{no_speed} observations without a neighbour within {MAX_GAP_S} s get speed 0"));
    notes.push(format!("{dontcare} DontCare lines skipped"));
    notes.push(format!(
        "ego frame = Velodyne frame moved down {VELODYNE_HEIGHT_M} m (ground_z_m = 0); no clouds in this benchmark"
    ));
    Ok(Dataset {
        info: DatasetInfo {
            name: format!("kitti-tracking-{stem}"),
            format: DatasetFormat::KittiTracking,
            source: label_path.to_path_buf(),
            ground_z_m: 0.0,
            ego_pose_known: false,
            speed_source: SpeedSource::FiniteDifferenceEgoRelative,
            frame_period_s: Some(TRACKING_PERIOD_S),
            notes,
        },
        frames,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const CALIB: &str = "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nR0_rect: 1 0 0 0 1 0 0 0 1\n\
        Tr_velo_to_cam: 0 -1 0 0 0 0 -1 0 1 0 0 -0.3\nTr_imu_to_velo: 1 0 0 0 0 1 0 0 0 0 1 0\n";

    #[test]
    fn camera_box_to_velodyne() {
        let calib = parse_calib(CALIB).unwrap();
        let label = parse_label_line("Car 0.00 0 -1.5 0 0 10 10 1.5 1.6 4.0 2.0 1.7 10.0 0.0", false).unwrap();
        let b = box_in_velodyne(&label, &calib).unwrap();
        // camera z=10 forward -> velo x = 10 + 0.3; camera x=2 right -> velo y = -2; centre 0.75 above bottom
        assert!((b.center_m[0] - 10.3).abs() < 1e-5 && (b.center_m[1] + 2.0).abs() < 1e-5, "{b:?}");
        assert!((b.center_m[2] - (-1.7 + 0.75)).abs() < 1e-5, "{b:?}");
        assert!((b.yaw_rad + std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    }

    #[test]
    fn bad_lines_are_errors() {
        assert!(parse_label_line("Car 0 0 0", false).is_err());
        assert!(parse_label_line("Car 0.00 0 -1.5 0 0 10 10 1.5 1.6 x 2.0 1.7 10.0 0.0", false).is_err());
        assert!(parse_label_line("Car 0.00 0 -1.5 0 0 10 10 1.5 1.6 4 2.0 1.7 10.0 NaN", false).is_err());
        assert!(parse_calib("R0_rect: 1 0 0\n").is_err());
        assert!(parse_calib("R0_rect: 0 0 0 0 0 0 0 0 0\nTr_velo_to_cam: 0 0 0 0 0 0 0 0 0 0 0 0\n").is_err());
    }

    /// Even-odd test of a point against a polygon (the test's own, independent of the monitor's ROI index).
    fn inside(poly: &[[f32; 2]], x: f32, y: f32) -> bool {
        let mut c = false;
        for (i, a) in poly.iter().enumerate() {
            let b = poly[(i + 1) % poly.len()];
            if (a[1] > y) != (b[1] > y) && x < a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]) {
                c = !c;
            }
        }
        c
    }

    #[test]
    fn the_field_of_view_is_the_cameras_wedge_widened_by_the_margin() {
        for calib in [KittiCalib::nominal(), parse_calib(CALIB).unwrap()] {
            let poly = field_of_view_polygon(&calib, 50.0).unwrap();
            // Every vertex inside the grid's square.
            assert!(poly.iter().all(|q| q[0].abs() <= 50.0 + 1e-3 && q[1].abs() <= 50.0 + 1e-3), "{poly:?}");
            // Ahead, inside; behind and beside, outside.
            assert!(inside(&poly, 20.0, 0.0));
            assert!(!inside(&poly, -10.0, 0.0) && !inside(&poly, 5.0, 20.0) && !inside(&poly, 5.0, -20.0));
            // The edges: 40.2 deg to the left (+y) and 41.2 deg to the right, each plus 5 deg, from the camera
            // 0.27 m ahead of the Velodyne. 44 deg is inside on both sides, 47.5 deg outside on both.
            for (deg, expect) in [(44.0f32, true), (47.5, false)] {
                let t = deg.to_radians();
                for side in [1.0f32, -1.0] {
                    let (x, y) = (0.27 + 30.0 * t.cos(), side * 30.0 * t.sin());
                    assert_eq!(inside(&poly, x, y), expect, "{deg} deg, side {side}: {poly:?}");
                }
            }
        }
        // A calibration that turns the camera's axis straight up (the rectified z along the Velodyne's z) leaves
        // no wedge on the ground: no field of view, not a polygon of NaNs.
        let up = parse_calib(
            "R0_rect: 1 0 0 0 1 0 0 0 1\nTr_velo_to_cam: 1 0 0 0 0 1 0 0 0 0 1 0\nTr_imu_to_velo: 1 0 0 0 0 1 0 0 0 0 1 0\n",
        )
        .unwrap();
        assert_eq!(field_of_view_polygon(&up, 50.0), None);
        // A grid too small to hold more than the wedge's tip still gives a polygon, inside the square.
        let tiny = field_of_view_polygon(&KittiCalib::nominal(), 1.0).unwrap();
        assert!(tiny.iter().all(|q| q[0].abs() <= 1.0 + 1e-6 && q[1].abs() <= 1.0 + 1e-6), "{tiny:?}");
    }
}
