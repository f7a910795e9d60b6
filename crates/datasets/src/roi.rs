//! Where the frames' region of interest (`RecordedFrame::roi_in_ego`) comes from: a dataset's map, a corridor
//! around the ego vehicle's own path, or nothing (the whole grid).
//!
//! The monitor treats conflict clusters outside the ROI as nobody's evidence: they raise no missed-object alarm
//! and are credited to no object. Without any ROI, every building, wall and tree in the grid is a missed object.
//!
//! - [`RoiMode::Auto`] (the default): the dataset's map where it has one (Argoverse 2 `map/log_map_archive_*.json`,
//!   see [`crate::av2_map`]); for KITTI's object frames, whose labels cover only camera 2's image, that camera's
//!   field of view ([`crate::kitti::field_of_view_polygon`]); otherwise no ROI, and the dataset's notes say so.
//! - [`RoiMode::Corridor`]: a band of the given width centred on the ego vehicle's path over the whole log (from
//!   its poses), continued straight ahead of the last pose and behind the first one to the grid's edge. This is
//!   where the vehicle drove: its own carriageway and, with a width of 15-20 m, the kerbs beside it, without the
//!   buildings set back from the road. Where the ego poses are unknown (KITTI object frames, CommonRoad) every
//!   frame's path is its own position, so the corridor is the straight band along the ego's x axis.
//! - [`RoiMode::WholeGrid`]: no ROI, even where there is a map.

use std::str::FromStr;

use pmon_monitor::Pose2;

use crate::av2_map::DEFAULT_SIDEWALK_WIDTH_M;
use crate::geometry::{clip_to_square, polygon_area};
use crate::{Dataset, DatasetFrame};

/// The start of the dataset note that says where the ROI comes from (see [`Dataset::roi_note`]).
pub const ROI_NOTE_PREFIX: &str = "region of interest: ";

/// Path points closer than this to the last kept one are skipped: bounds the corridor's polygon count, metres.
const CORRIDOR_SPACING_M: f64 = 5.0;

/// Which region of interest the frames get.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RoiMode {
    /// The dataset's map where it has one, else none.
    Auto,
    /// No region of interest: the whole grid.
    WholeGrid,
    /// A corridor of this full width, metres, around the ego vehicle's path over the log (maps are ignored).
    Corridor {
        /// Full width, metres (finite, > 0).
        width_m: f64,
    },
}

impl FromStr for RoiMode {
    type Err = String;

    /// `auto`, `none` or `corridor:<width_m>`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" | "map" => Ok(Self::Auto),
            "none" => Ok(Self::WholeGrid),
            _ => {
                let w = s
                    .strip_prefix("corridor:")
                    .ok_or_else(|| format!("`{s}`: expected `auto`, `none` or `corridor:<width_m>`"))?;
                let width_m: f64 = w.parse().map_err(|_| format!("`{s}`: `{w}` is not a number of metres"))?;
                if width_m.is_finite() && width_m > 0.0 && width_m <= 1000.0 {
                    Ok(Self::Corridor { width_m })
                } else {
                    Err(format!("`{s}`: the corridor width must be in (0, 1000] m"))
                }
            }
        }
    }
}

/// Region-of-interest options of the readers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoiOptions {
    /// Map, corridor or nothing.
    pub mode: RoiMode,
    /// Width of the sidewalk band along a map's drivable areas, metres (see [`crate::av2_map`]).
    pub sidewalk_width_m: f64,
    /// Half the side of the monitor's grid square, metres (`grid_size_m / 2`): polygons are clipped to it.
    pub grid_half_extent_m: f64,
}

impl Default for RoiOptions {
    fn default() -> Self {
        Self { mode: RoiMode::Auto, sidewalk_width_m: DEFAULT_SIDEWALK_WIDTH_M, grid_half_extent_m: 50.0 }
    }
}

impl Dataset {
    /// The note that says where the frames' ROI comes from (set by [`crate::open_with`]).
    #[must_use]
    pub fn roi_note(&self) -> Option<&str> {
        self.info.notes.iter().find_map(|n| n.strip_prefix(ROI_NOTE_PREFIX))
    }
}

/// Applies the ROI mode after a reader ran: the corridor, or nothing; and writes the note.
pub(crate) fn finish(ds: &mut Dataset, opts: &RoiOptions) {
    let note = match opts.mode {
        RoiMode::WholeGrid => {
            for f in &mut ds.frames {
                f.frame.roi_in_ego.clear();
            }
            "none (--roi none): the whole grid; every unlabelled structure in it is a missed-object alarm".to_string()
        }
        RoiMode::Corridor { width_m } => {
            apply_corridor(&mut ds.frames, width_m, opts.grid_half_extent_m);
            format!(
                "a {width_m} m corridor around the ego's path over the log{} (--roi corridor:{width_m})",
                if ds.info.ego_pose_known { "" } else { " (ego poses unknown: the band along the ego's x axis)" }
            )
        }
        RoiMode::Auto => {
            if ds.info.notes.iter().any(|n| n.starts_with(ROI_NOTE_PREFIX)) {
                return; // the reader used the dataset's map and said so
            }
            if ds.info.format.is_object_list_only() {
                return; // object lists only (CommonRoad, KITTI tracking labels): no sensor check, nothing to scope
            }
            "none: this dataset has no map, so the whole grid is the ROI and every building, wall and tree in it is \
             a missed-object alarm; use --roi corridor:<width_m> (e.g. corridor:20) to keep to the ego's path"
                .to_string()
        }
    };
    ds.info.notes.retain(|n| !n.starts_with(ROI_NOTE_PREFIX));
    ds.info.notes.push(format!("{ROI_NOTE_PREFIX}{note}"));
}

/// The ego's path in the world frame: positions at least [`CORRIDOR_SPACING_M`] apart (the last one always
/// kept), continued along the first pose's heading behind it and the last pose's heading ahead of it by `reach`.
fn ego_path(poses: &[Pose2], reach: f64) -> Vec<[f64; 2]> {
    let mut path: Vec<[f64; 2]> = Vec::new();
    for p in poses {
        let q = [p.x_m, p.y_m];
        if path.last().is_none_or(|l| (l[0] - q[0]).hypot(l[1] - q[1]) >= CORRIDOR_SPACING_M) {
            path.push(q);
        }
    }
    if let (Some(last_pose), Some(last)) = (poses.last(), path.last_mut()) {
        *last = [last_pose.x_m, last_pose.y_m];
    }
    if let (Some(first), Some(last)) = (poses.first(), poses.last()) {
        let (s0, c0) = first.yaw_rad.sin_cos();
        let (s1, c1) = last.yaw_rad.sin_cos();
        path.insert(0, [first.x_m - c0 * reach, first.y_m - s0 * reach]);
        path.push([last.x_m + c1 * reach, last.y_m + s1 * reach]);
    }
    path
}

/// One rectangle per path segment, `width_m` wide, lengthened by half the width at both ends (closes the gaps
/// at bends), in the world frame.
#[must_use]
pub fn corridor_polygons(path: &[[f64; 2]], width_m: f64) -> Vec<[[f64; 2]; 4]> {
    let h = 0.5 * width_m;
    path.windows(2)
        .filter_map(|w| {
            let (a, b) = (w.first()?, w.get(1)?);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len = dx.hypot(dy);
            if len < 1e-9 {
                return None;
            }
            let (ux, uy) = (dx / len * h, dy / len * h);
            let (a, b) = ([a[0] - ux, a[1] - uy], [b[0] + ux, b[1] + uy]);
            Some([[a[0] + uy, a[1] - ux], [b[0] + uy, b[1] - ux], [b[0] - uy, b[1] + ux], [a[0] - uy, a[1] + ux]])
        })
        .collect()
}

/// Replaces every frame's ROI by the corridor around the ego path, in that frame's ego frame, clipped to the grid.
#[allow(clippy::cast_possible_truncation)] // ego-frame metres inside the grid: f32 is the monitor's precision
fn apply_corridor(frames: &mut [DatasetFrame], width_m: f64, half: f64) {
    let poses: Vec<Pose2> = frames.iter().map(|f| f.frame.world_from_ego).collect();
    let path = ego_path(&poses, half * std::f64::consts::SQRT_2 + width_m);
    let rects = corridor_polygons(&path, width_m);
    for f in frames {
        let p = f.frame.world_from_ego;
        let (s, c) = p.yaw_rad.sin_cos();
        let to_ego = |q: &[f64; 2]| {
            let (dx, dy) = (q[0] - p.x_m, q[1] - p.y_m);
            [c * dx + s * dy, -s * dx + c * dy]
        };
        f.frame.roi_in_ego = rects
            .iter()
            .filter_map(|r| {
                let ego: Vec<[f64; 2]> = r.iter().map(to_ego).collect();
                let clipped = clip_to_square(&ego, half);
                (clipped.len() >= 3 && polygon_area(&clipped).abs() > 1e-6)
                    .then(|| clipped.iter().map(|q| [q[0] as f32, q[1] as f32]).collect())
            })
            .collect();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_parse_and_bad_widths_are_errors() {
        assert_eq!("auto".parse::<RoiMode>(), Ok(RoiMode::Auto));
        assert_eq!("none".parse::<RoiMode>(), Ok(RoiMode::WholeGrid));
        assert_eq!("corridor:12.5".parse::<RoiMode>(), Ok(RoiMode::Corridor { width_m: 12.5 }));
        for bad in ["corridor:", "corridor:-3", "corridor:NaN", "corridor:inf", "corridor:0", "lanes", ""] {
            assert!(bad.parse::<RoiMode>().is_err(), "{bad}");
        }
    }

    #[test]
    fn straight_path_corridor_is_a_band_through_the_grid() {
        // Ego standing still at the origin heading along +x: a band |y| <= 5 across the whole 100 m grid.
        let poses = [Pose2 { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }; 3];
        let path = ego_path(&poses, 50.0 * std::f64::consts::SQRT_2 + 10.0);
        let rects = corridor_polygons(&path, 10.0);
        let inside = |x: f64, y: f64| {
            rects.iter().any(|r| {
                let v: Vec<[f32; 2]> = r.iter().map(|p| [p[0] as f32, p[1] as f32]).collect();
                pmon_monitor::geometry::polygon_contains(&v, x as f32, y as f32)
            })
        };
        for x in [-49.0, -20.0, 0.5, 30.0, 49.0] {
            assert!(inside(x, 4.9) && inside(x, -4.9), "{x}");
            assert!(!inside(x, 5.1) && !inside(x, -5.1), "{x}");
        }
    }
}
