//! Argoverse 2 vector maps (`map/log_map_archive_*.json`) as the frames' region of interest.
//!
//! The map is in the city frame, metres. What the monitor gets per frame (`RecordedFrame::roi_in_ego`, ego
//! frame, clipped to the grid square) is where road users can be:
//!
//! - every **drivable area** polygon (`drivable_areas[*].area_boundary`), as it is (possibly non-convex: the
//!   monitor's ROI test is even-odd);
//! - every **pedestrian crossing**, the convex hull of its two edges' four points;
//! - a **sidewalk band**: each drivable-area boundary edge extruded outwards by [`MapRoiOptions::sidewalk_width_m`]
//!   (and lengthened by the same width at both ends, which fills the gap at convex corners). AV2 maps carry no
//!   sidewalks; pedestrians, cyclists on the kerb and cars entering from driveways are next to the drivable area.
//!
//! Lane segments are read and checked (they lie inside the drivable areas, so they add nothing to the ROI).
//! Only polygons that reach the grid square are kept, so the count per frame is bounded by what is near the ego.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::geometry::{clip_to_square, polygon_area, Rigid3};
use crate::DatasetError;

/// Default width of the sidewalk band along the drivable area's boundary, metres: none. Measured on log 7fab2350
/// (docs/datasets.md): in this narrow Pittsburgh street a band of 1-3 m already reaches building fronts, fences,
/// poles and hedges, which the map does not list as scenery. A 3 m band raises the missed-object alarms from 15 to
/// 66 per sweep and the clean labelled boxes flagged as position errors from 0 to 10 (those walls' clusters are
/// blamed on boxes beside them); 1 m gives 45 per sweep and 9. What the band would buy is missed-object alarms
/// for unlabelled road users on the sidewalk, which the monitor cannot tell from a wall without a scenery map. A
/// labelled pedestrian on the sidewalk is checked against its own evidence with or without the band. Set
/// `--sidewalk-m 3` (a US urban sidewalk with its kerb strip) to monitor sidewalks at that cost.
pub const DEFAULT_SIDEWALK_WIDTH_M: f64 = 0.0;

/// How the vector map becomes a region of interest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapRoiOptions {
    /// Width of the band along the drivable areas' boundary, metres (`0` for none). Must be finite and `>= 0`.
    pub sidewalk_width_m: f64,
    /// Half the side of the grid square polygons are clipped to, metres (the monitor's `grid_size_m / 2`).
    pub clip_half_extent_m: f64,
}

impl Default for MapRoiOptions {
    fn default() -> Self {
        // Table I: a 100 m grid.
        Self { sidewalk_width_m: DEFAULT_SIDEWALK_WIDTH_M, clip_half_extent_m: 50.0 }
    }
}

#[derive(Deserialize)]
struct JsonPoint {
    x: f64,
    y: f64,
    #[serde(default)]
    z: Option<f64>,
}

#[derive(Deserialize)]
struct JsonDrivableArea {
    area_boundary: Vec<JsonPoint>,
}

#[derive(Deserialize)]
struct JsonCrossing {
    edge1: Vec<JsonPoint>,
    edge2: Vec<JsonPoint>,
}

#[derive(Deserialize)]
struct JsonLaneSegment {
    left_lane_boundary: Vec<JsonPoint>,
    right_lane_boundary: Vec<JsonPoint>,
    lane_type: String,
    is_intersection: bool,
}

#[derive(Deserialize)]
struct JsonMap {
    drivable_areas: BTreeMap<String, JsonDrivableArea>,
    lane_segments: BTreeMap<String, JsonLaneSegment>,
    pedestrian_crossings: BTreeMap<String, JsonCrossing>,
}

/// One lane segment (city frame, metres).
#[derive(Clone, Debug, PartialEq)]
pub struct LaneSegment {
    /// The map's id.
    pub id: String,
    /// `VEHICLE`, `BIKE`, `BUS`.
    pub lane_type: String,
    /// Inside an intersection.
    pub is_intersection: bool,
    /// Left boundary polyline, city frame `(x, y, z)`.
    pub left_m: Vec<[f64; 3]>,
    /// Right boundary polyline, city frame `(x, y, z)`.
    pub right_m: Vec<[f64; 3]>,
}

/// An Argoverse 2 log's vector map, city frame, metres (`z` is the map's height, used only to transform).
#[derive(Clone, Debug, PartialEq)]
pub struct VectorMap {
    /// The file read.
    pub path: PathBuf,
    /// Drivable-area boundaries (at least 3 points each), by map id order.
    pub drivable_areas: Vec<Vec<[f64; 3]>>,
    /// Pedestrian crossings: the four points of their two edges.
    pub crossings: Vec<[[f64; 3]; 4]>,
    /// Lane segments.
    pub lane_segments: Vec<LaneSegment>,
    /// Drivable areas skipped because their boundary has fewer than 3 distinct points.
    pub skipped_areas: usize,
    /// Crossings skipped because an edge does not have exactly 2 points.
    pub skipped_crossings: usize,
}

/// The log's vector map file in `map_dir` (`log_map_archive_*.json`), if there is exactly one.
///
/// # Errors
/// The folder cannot be listed, or holds more than one map file.
pub fn find_vector_map(map_dir: &Path) -> Result<Option<PathBuf>, DatasetError> {
    if !map_dir.is_dir() {
        return Ok(None);
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(map_dir)
        .map_err(|e| DatasetError::io(map_dir, e))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("log_map_archive_") && n.ends_with(".json"))
        })
        .collect();
    found.sort();
    match found.len() {
        0 => Ok(None),
        1 => Ok(found.pop()),
        n => Err(DatasetError::malformed(map_dir, format!("{n} log_map_archive_*.json files: expected one"))),
    }
}

fn point(p: &JsonPoint, path: &Path, what: &str) -> Result<[f64; 3], DatasetError> {
    let z = p.z.unwrap_or(0.0);
    if p.x.is_finite() && p.y.is_finite() && z.is_finite() {
        Ok([p.x, p.y, z])
    } else {
        Err(DatasetError::malformed(path, format!("{what}: coordinate not finite ({}, {}, {z})", p.x, p.y)))
    }
}

fn points(ps: &[JsonPoint], path: &Path, what: &str) -> Result<Vec<[f64; 3]>, DatasetError> {
    ps.iter().map(|p| point(p, path, what)).collect()
}

/// Removes consecutive repeated points and a closing point equal to the first.
fn dedup_ring(mut ring: Vec<[f64; 3]>) -> Vec<[f64; 3]> {
    ring.dedup_by(|a, b| a[0] == b[0] && a[1] == b[1]);
    while ring.len() > 1 && ring.first().map(|p| [p[0], p[1]]) == ring.last().map(|p| [p[0], p[1]]) {
        ring.pop();
    }
    ring
}

impl VectorMap {
    /// Reads and checks a `log_map_archive_*.json` file.
    ///
    /// # Errors
    /// The file cannot be read, is not valid JSON of this layout (the message names the line and column), or a
    /// coordinate is not finite. Drivable areas with fewer than 3 distinct points and crossings whose edges do
    /// not have 2 points each are skipped and counted.
    pub fn read(path: &Path) -> Result<Self, DatasetError> {
        let text = std::fs::read_to_string(path).map_err(|e| DatasetError::io(path, e))?;
        Self::parse(path, &text)
    }

    /// [`VectorMap::read`] from text already in memory (`path` names it in errors).
    ///
    /// # Errors
    /// As [`VectorMap::read`].
    pub fn parse(path: &Path, text: &str) -> Result<Self, DatasetError> {
        let json: JsonMap = serde_json::from_str(text).map_err(|e| DatasetError::malformed(path, format!("{e}")))?;
        let mut map = Self {
            path: path.to_path_buf(),
            drivable_areas: Vec::new(),
            crossings: Vec::new(),
            lane_segments: Vec::new(),
            skipped_areas: 0,
            skipped_crossings: 0,
        };
        for (id, a) in &json.drivable_areas {
            let ring = dedup_ring(points(&a.area_boundary, path, &format!("drivable area {id}"))?);
            if ring.len() < 3 {
                map.skipped_areas += 1;
            } else {
                map.drivable_areas.push(ring);
            }
        }
        for (id, c) in &json.pedestrian_crossings {
            let what = format!("pedestrian crossing {id}");
            let (e1, e2) = (points(&c.edge1, path, &what)?, points(&c.edge2, path, &what)?);
            match (e1.as_slice(), e2.as_slice()) {
                ([a, b], [c, d]) => map.crossings.push([*a, *b, *c, *d]),
                _ => map.skipped_crossings += 1,
            }
        }
        for (id, l) in json.lane_segments {
            let what = format!("lane segment {id}");
            let left_m = points(&l.left_lane_boundary, path, &what)?;
            let right_m = points(&l.right_lane_boundary, path, &what)?;
            map.lane_segments.push(LaneSegment {
                id,
                lane_type: l.lane_type,
                is_intersection: l.is_intersection,
                left_m,
                right_m,
            });
        }
        Ok(map)
    }

    /// The region of interest in the ego frame of a pose (`ego_from_city` = inverse of `city_SE3_egovehicle`):
    /// drivable areas, crossings and the sidewalk band, each clipped to the grid square; polygons that do not
    /// reach it are left out.
    #[must_use]
    pub fn roi_in_ego(&self, ego_from_city: &Rigid3, opts: &MapRoiOptions) -> Vec<Vec<[f32; 2]>> {
        let half = opts.clip_half_extent_m;
        let to_ego = |p: &[f64; 3]| {
            let q = ego_from_city.apply(*p);
            [q[0], q[1]]
        };
        let mut out = Vec::new();
        let mut keep = |poly: &[[f64; 2]]| {
            if let Some(p) = clip_polygon(poly, half) {
                out.push(p);
            }
        };
        for ring in &self.drivable_areas {
            let ego: Vec<[f64; 2]> = ring.iter().map(to_ego).collect();
            keep(&ego);
            if opts.sidewalk_width_m > 0.0 {
                for quad in sidewalk_band(&ego, opts.sidewalk_width_m) {
                    keep(&quad);
                }
            }
        }
        for c in &self.crossings {
            let pts: Vec<[f64; 2]> = c.iter().map(to_ego).collect();
            keep(&convex_hull(&pts));
        }
        out
    }
}

/// Clips to the square; `None` when nothing with area is left. Cheap bounding-box rejection first.
#[allow(clippy::cast_possible_truncation)] // ego-frame metres inside the grid: f32 is the monitor's precision
fn clip_polygon(poly: &[[f64; 2]], half: f64) -> Option<Vec<[f32; 2]>> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in poly {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    if lo[0] > half || lo[1] > half || hi[0] < -half || hi[1] < -half {
        return None;
    }
    let c = clip_to_square(poly, half);
    (c.len() >= 3 && polygon_area(&c).abs() > 1e-6).then(|| c.iter().map(|p| [p[0] as f32, p[1] as f32]).collect())
}

/// One quadrilateral per boundary edge of a ring: the edge extruded by `width` away from the ring's inside,
/// lengthened by `width` at both ends.
#[must_use]
pub fn sidewalk_band(ring: &[[f64; 2]], width: f64) -> Vec<[[f64; 2]; 4]> {
    let sign = if polygon_area(ring) >= 0.0 { 1.0 } else { -1.0 };
    let Some(&last) = ring.last() else { return Vec::new() };
    let mut prev = last;
    let mut out = Vec::with_capacity(ring.len());
    for &p in ring {
        let (dx, dy) = (p[0] - prev[0], p[1] - prev[1]);
        let len = dx.hypot(dy);
        if len > 1e-9 {
            let (ux, uy) = (dx / len, dy / len);
            // Outward normal: right of the edge for a counter-clockwise ring.
            let (nx, ny) = (sign * uy * width, -sign * ux * width);
            let a = [prev[0] - ux * width, prev[1] - uy * width];
            let b = [p[0] + ux * width, p[1] + uy * width];
            out.push([a, b, [b[0] + nx, b[1] + ny], [a[0] + nx, a[1] + ny]]);
        }
        prev = p;
    }
    out
}

/// Convex hull (Andrew's monotone chain), counter-clockwise.
#[must_use]
pub fn convex_hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut pts = points.to_vec();
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> =
            if pass == 0 { Box::new(pts.iter()) } else { Box::new(pts.iter().rev()) };
        for &p in iter {
            while hull.len() >= start + 2 {
                let n = hull.len();
                let (Some(&o), Some(&a)) = (hull.get(n - 2), hull.get(n - 1)) else { break };
                if cross(o, a, p) <= 0.0 {
                    hull.pop();
                } else {
                    break;
                }
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_crossing_is_its_quadrilateral_whatever_the_edge_order() {
        // Two edges pointing opposite ways: the naive a, b, c, d order would cross itself.
        let pts = [[0.0, 0.0], [10.0, 0.0], [10.0, 3.0], [0.0, 3.0]];
        let h = convex_hull(&[pts[0], pts[1], pts[3], pts[2]]);
        assert_eq!(h.len(), 4);
        assert!((polygon_area(&h) - 30.0).abs() < 1e-9);
    }

    #[test]
    fn band_lies_outside_the_ring_for_both_orientations() {
        let ccw = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let cw: Vec<[f64; 2]> = ccw.iter().rev().copied().collect();
        for ring in [ccw.to_vec(), cw] {
            let band = sidewalk_band(&ring, 2.0);
            assert_eq!(band.len(), 4);
            for q in &band {
                // Every band quad's far side is outside the ring.
                let mid = [0.25 * q.iter().map(|p| p[0]).sum::<f64>(), 0.25 * q.iter().map(|p| p[1]).sum::<f64>()];
                let inside = mid[0] > 0.0 && mid[0] < 10.0 && mid[1] > 0.0 && mid[1] < 10.0;
                assert!(!inside, "{mid:?}");
                assert!((polygon_area(q).abs() - 14.0 * 2.0).abs() < 1e-9);
            }
        }
    }
}
