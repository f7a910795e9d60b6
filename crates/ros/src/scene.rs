//! `foxglove.SceneUpdate` and `foxglove.Grid` as JSON messages (MCAP `json` encoding, `jsonschema` schemas),
//! what Foxglove opens by schema name. JSON instead of the `foxglove` crate: the crate costs a 70 s cold
//! build (ECOSYSTEM.md) for two message shapes that serde writes in a few lines.

use base64::Engine;
use pmon_monitor::{CellState, ObjectState, OccupancyGrid};
use serde_json::{json, Value};

use crate::msg::{FrameVerdicts, Time};

/// Schema name Foxglove knows.
pub const SCENE_UPDATE: &str = "foxglove.SceneUpdate";
/// Schema name Foxglove knows.
pub const GRID: &str = "foxglove.Grid";

/// A minimal JSON Schema naming the type (Foxglove picks its panels by the schema name).
#[must_use]
pub fn json_schema(title: &str) -> Vec<u8> {
    json!({"title": title, "type": "object"}).to_string().into_bytes()
}

/// RGBA colour of a verdict code (`pmon_msgs/ObjectVerdict`): consistent green, ghost red, position error
/// orange, implausible motion magenta, not monitored grey.
#[must_use]
pub fn colour(verdict: u8) -> [f64; 4] {
    match verdict {
        0 => [0.2, 0.8, 0.2, 0.6],
        1 => [0.9, 0.1, 0.1, 0.8],
        2 => [1.0, 0.55, 0.0, 0.8],
        3 => [0.85, 0.2, 0.85, 0.8],
        _ => [0.6, 0.6, 0.6, 0.5],
    }
}

fn ts(t: Time) -> Value {
    json!({"sec": t.sec.max(0), "nsec": t.nanosec})
}

fn pose(x: f64, y: f64, z: f64, yaw: f64) -> Value {
    json!({"position": {"x": x, "y": y, "z": z},
           "orientation": {"x": 0.0, "y": 0.0, "z": (yaw / 2.0).sin(), "w": (yaw / 2.0).cos()}})
}

fn rgba(c: [f64; 4]) -> Value {
    json!({"r": c[0], "g": c[1], "b": c[2], "a": c[3]})
}

/// One scene entity in the ego frame: a box per object coloured by verdict with a label, and a box per missed
/// object (conflict cluster no object explains) with its cell count.
#[must_use]
pub fn scene_update(v: &FrameVerdicts, objects: &[ObjectState], ego_frame: &str) -> Value {
    let mut cubes = Vec::new();
    let mut texts = Vec::new();
    for (o, r) in objects.iter().zip(&v.objects) {
        let (x, y) = (f64::from(o.x_m), f64::from(o.y_m));
        let finite = x.is_finite() && y.is_finite();
        let (x, y) = if finite { (x, y) } else { (0.0, 0.0) };
        cubes.push(json!({"pose": pose(x, y, 0.75, f64::from(o.heading_rad)),
            "size": {"x": o.length_m.max(0.1), "y": o.width_m.max(0.1), "z": 1.5}, "color": rgba(colour(r.verdict))}));
        let label = if r.reason.is_empty() {
            format!("{} {}: {}", o.class.name(), r.id, r.verdict_name)
        } else {
            format!("{} {}: {} ({})", o.class.name(), r.id, r.verdict_name, r.reason)
        };
        texts.push(json!({"pose": pose(x, y, 2.0, 0.0), "billboard": true, "font_size": 14.0,
            "scale_invariant": true, "color": rgba([1.0, 1.0, 1.0, 1.0]), "text": label}));
    }
    for m in &v.missed {
        let b = m.bounds_m.map(f64::from);
        cubes.push(json!({"pose": pose(0.5 * (b[0] + b[2]), 0.5 * (b[1] + b[3]), 0.5, 0.0),
            "size": {"x": (b[2] - b[0]).max(0.1), "y": (b[3] - b[1]).max(0.1), "z": 1.0},
            "color": rgba([0.1, 0.4, 1.0, 0.6])}));
        texts.push(json!({"pose": pose(f64::from(m.centroid_m[0]), f64::from(m.centroid_m[1]), 1.5, 0.0),
            "billboard": true, "font_size": 14.0, "scale_invariant": true, "color": rgba([0.6, 0.8, 1.0, 1.0]),
            "text": format!("missed object: {} cells", m.cells)}));
    }
    json!({"deletions": [], "entities": [{
        "timestamp": ts(v.header.stamp), "frame_id": ego_frame, "id": "pmon", "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": false, "metadata": [], "arrows": [], "cubes": cubes, "spheres": [], "cylinders": [],
        "lines": [], "triangles": [], "texts": texts, "models": []}]})
}

/// Cell values of the grid message: 0 unknown (no hit), 1 weak, 2 occupied and explained, 3 conflict.
#[must_use]
pub const fn cell_value(s: CellState) -> u8 {
    match s {
        CellState::Unknown => 0,
        CellState::Weak => 1,
        CellState::Occupied => 2,
        CellState::Conflict => 3,
    }
}

/// The occupancy grid of the frame as a `foxglove.Grid` of one `uint8` field `state` ([`cell_value`]), in the
/// ego frame, row by row from the lower-left corner.
#[must_use]
pub fn grid(stamp: Time, grid: &OccupancyGrid, tau_fn: f32, ego_frame: &str) -> Value {
    let g = &grid.geometry;
    let mut data = vec![0u8; g.cell_count()];
    for &i in grid.touched() {
        if let Some(d) = data.get_mut(i as usize) {
            *d = cell_value(grid.state(i, tau_fn));
        }
    }
    let o = f64::from(g.origin_m);
    json!({"timestamp": ts(stamp), "frame_id": ego_frame, "pose": pose(o, o, 0.0, 0.0),
        "column_count": g.cells_per_side, "cell_size": {"x": g.cell_size_m, "y": g.cell_size_m},
        "row_stride": g.cells_per_side, "cell_stride": 1,
        "fields": [{"name": "state", "offset": 0, "type": 1}],
        "data": base64::engine::general_purpose::STANDARD.encode(&data)})
}
