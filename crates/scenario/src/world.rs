//! The static world: road layout, sidewalks, crosswalks, scenery, parking spots, lane routes and traffic lights.
//!
//! World frame: x east, y north, z up, metres; the street centre (residential) or the intersection centre is the
//! origin, the ground is the plane z = 0 (kerbs are not modelled). Traffic drives on the right.

use std::f64::consts::{FRAC_PI_2, PI};

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use crate::config::{Layout, ScenarioConfig, Turn};
use crate::geom::Box3;
use crate::path::{Path, PathBuilder};

/// What a piece of scenery is (for reports and tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SceneryKind {
    Building,
    Wall,
    Pole,
    TreeTrunk,
    TreeCanopy,
}

/// A static scenery box.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Scenery {
    pub kind: SceneryKind,
    pub b: Box3,
}

/// A sidewalk strip along one kerb: kerb line `origin + dir * u`, the sidewalk on the `out` side.
#[derive(Clone, Debug)]
pub(crate) struct Strip {
    pub origin: [f64; 2],
    pub dir: [f64; 2],
    pub out: [f64; 2],
    pub length: f64,
    /// The strip across the road (same `u` straight across).
    pub opposite: usize,
    /// The strip around the corner (intersection), sharing `corner`.
    pub partner: Option<usize>,
    /// The sidewalk corner point both partners pass through.
    pub corner: [f64; 2],
    /// Crosswalk centres along this strip, `u`, metres.
    pub crosswalks_u: Vec<f64>,
    /// Intervals of `u` where a pedestrian cannot step off the kerb (parked cars, trees, poles), sorted.
    pub blocked: Vec<(f64, f64)>,
}

impl Strip {
    /// World point at `u` along the kerb and `v` metres into the sidewalk (negative: into the road).
    pub(crate) fn point(&self, u: f64, v: f64) -> [f64; 2] {
        [self.origin[0] + self.dir[0] * u + self.out[0] * v, self.origin[1] + self.dir[1] * u + self.out[1] * v]
    }

    /// `(u, v)` of a world point.
    pub(crate) fn coords(&self, p: [f64; 2]) -> (f64, f64) {
        let (dx, dy) = (p[0] - self.origin[0], p[1] - self.origin[1]);
        (dx * self.dir[0] + dy * self.dir[1], dx * self.out[0] + dy * self.out[1])
    }

    /// True when a pedestrian can step off the kerb at `u` (a 1.2 m wide path is clear).
    pub(crate) fn crossing_free(&self, u: f64) -> bool {
        u > 0.5 && u < self.length - 0.5 && !self.blocked.iter().any(|&(a, b)| u > a - 0.6 && u < b + 0.6)
    }
}

/// A vehicle route: its path plus what the intersection logic needs.
#[derive(Clone, Debug)]
pub(crate) struct Route {
    pub path: Path,
    /// Approach arm (0 west, 1 south, 2 east, 3 north); residential: 0 eastbound, 2 westbound.
    pub entry: usize,
    pub turn: Turn,
    /// Arc length of the stop line (front bumper stops here), if the route crosses the intersection.
    pub stop_s: Option<f64>,
    /// Arc length where the path leaves the intersection box.
    pub box_exit_s: f64,
    /// Left turns: where to wait for oncoming traffic.
    pub gate_s: Option<f64>,
}

impl Route {
    /// Signal phase of the route: 0 east-west, 1 north-south.
    pub(crate) fn phase(&self) -> usize {
        self.entry % 2
    }
}

/// The static world.
#[derive(Clone, Debug)]
pub(crate) struct World {
    pub layout: Layout,
    pub half_length: f64,
    pub lane_w: f64,
    /// Half-width of the carriageway (lanes + parking), metres.
    pub hw: f64,
    pub sidewalk_w: f64,
    pub scenery: Vec<Scenery>,
    pub strips: Vec<Strip>,
    /// Parked cars (boxes).
    pub parked: Vec<Box3>,
    /// Region of interest (carriageway and crosswalks), convex polygons, world frame.
    pub roi: Vec<Vec<[f64; 2]>>,
    /// Sidewalks, convex polygons, world frame.
    pub sidewalks: Vec<Vec<[f64; 2]>>,
    pub green_s: f64,
    /// Pedestrians start crossing only in the first `walk_s` of their parallel green.
    pub walk_s: f64,
    pub clearance_s: f64,
    pub signal_offset_s: f64,
}

/// Radius of right turns (cars, cyclists) and left turns, metres.
const RIGHT_TURN_R: f64 = 6.0;
const RIGHT_TURN_R_BIKE: f64 = 5.0;
const LEFT_TURN_R: f64 = 9.0;
/// Comfortable lateral acceleration in curves and braking ahead of them, m/s^2.
pub(crate) const LATERAL_ACCEL: f64 = 2.0;
pub(crate) const PROFILE_BRAKE: f64 = 1.5;

fn rot(p: [f64; 2], a: f64) -> [f64; 2] {
    let (s, c) = a.sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1]]
}

fn rot_box(b: Box3, a: f64) -> Box3 {
    let p = rot([b.cx, b.cy], a);
    Box3 { cx: p[0], cy: p[1], yaw: b.yaw + a, ..b }
}

impl World {
    /// Builds the world of a validated scenario; `rng` draws the scenery.
    pub(crate) fn build(cfg: &ScenarioConfig, rng: &mut ChaCha8Rng) -> Self {
        let lane_w = cfg.road.lane_width_m;
        let hw = lane_w + cfg.road.parking_width_m;
        let mut w = World {
            layout: cfg.layout,
            half_length: cfg.half_length_m(),
            lane_w,
            hw,
            sidewalk_w: cfg.road.sidewalk_width_m,
            scenery: Vec::new(),
            strips: Vec::new(),
            parked: Vec::new(),
            roi: Vec::new(),
            sidewalks: Vec::new(),
            green_s: cfg.signals.green_s,
            walk_s: cfg.signals.walk_s,
            clearance_s: cfg.signals.clearance_s,
            signal_offset_s: cfg.signals.offset_s,
        };
        match cfg.layout {
            Layout::Residential => w.build_residential(cfg, rng),
            Layout::Intersection => w.build_intersection(cfg, rng),
        }
        w.compute_blocked();
        w
    }

    fn build_residential(&mut self, cfg: &ScenarioConfig, rng: &mut ChaCha8Rng) {
        let (l, hw, sw) = (self.half_length, self.hw, self.sidewalk_w);
        let cw: Vec<f64> = cfg.road.crosswalks_x_m.clone();
        // Strips: 0 south kerb, 1 north kerb; u = x + L.
        for (i, side) in [-1.0f64, 1.0].into_iter().enumerate() {
            self.strips.push(Strip {
                origin: [-l, side * hw],
                dir: [1.0, 0.0],
                out: [0.0, side],
                length: 2.0 * l,
                opposite: 1 - i,
                partner: None,
                corner: [0.0, 0.0],
                crosswalks_u: cw.iter().map(|x| x + l).collect(),
                blocked: Vec::new(),
            });
        }
        self.roi.push(vec![[-l, -hw], [l, -hw], [l, hw], [-l, hw]]);
        for side in [-1.0f64, 1.0] {
            let (y0, y1) = (side * hw, side * (hw + sw));
            self.sidewalks.push(vec![[-l, y0.min(y1)], [l, y0.min(y1)], [l, y0.max(y1)], [-l, y0.max(y1)]]);
        }
        for x in &cw {
            self.roi.push(vec![[x - 1.5, -hw], [x + 1.5, -hw], [x + 1.5, hw], [x - 1.5, hw]]);
        }
        let near_cw = |x: f64, m: f64| cw.iter().any(|c| (x - c).abs() < m);
        for side in [-1.0f64, 1.0] {
            // Houses with front yards, garden walls and hedges along the property line.
            let mut x = -l + rng.random_range(0.0..6.0);
            while x < l - 8.0 {
                let front = rng.random_range(9.0..16.0);
                let setback = rng.random_range(3.0..7.0);
                let depth = rng.random_range(8.0..12.0);
                let y0 = hw + sw + setback;
                let b = Box3::aabb(x, x + front, side * y0, side * (y0 + depth), 0.0, rng.random_range(6.0..10.0));
                self.scenery.push(Scenery { kind: SceneryKind::Building, b });
                let gap = rng.random_range(3.0..9.0);
                if rng.random_bool(0.6) {
                    let y = hw + sw + 0.3;
                    let b = Box3::aabb(
                        x - gap * 0.3,
                        x + front + gap * 0.3,
                        side * y,
                        side * (y + 0.3),
                        0.0,
                        rng.random_range(0.8..1.8),
                    );
                    self.scenery.push(Scenery { kind: SceneryKind::Wall, b });
                }
                x += front + gap;
            }
            // Street trees (canopy over the parking lane) and street lights in the furniture zone.
            let mut x = -l + rng.random_range(2.0..10.0);
            while x < l - 2.0 {
                if !near_cw(x, 4.0) && rng.random_bool(0.75) {
                    self.push_tree(x, side * (hw + 0.6), rng);
                }
                x += rng.random_range(12.0..20.0);
            }
            let mut x = -l + 15.0;
            while x < l - 2.0 {
                let clear = !self
                    .scenery
                    .iter()
                    .any(|s| s.kind == SceneryKind::TreeTrunk && (s.b.cx - x).abs() < 2.0 && s.b.cy * side > 0.0);
                if clear && !near_cw(x, 3.0) {
                    self.push_pole(x, side * (hw + 0.4), 7.0);
                }
                x += 32.0;
            }
            // Parked cars, heading with the traffic on their side.
            let heading = if side < 0.0 { 0.0 } else { PI };
            let y = side * (hw - cfg.road.parking_width_m / 2.0);
            self.push_parked_row(-l + 5.0, l - 5.0, y, heading, cfg.agents.parked_fill, &|x| near_cw(x, 7.0), rng);
        }
    }

    fn build_intersection(&mut self, cfg: &ScenarioConfig, rng: &mut ChaCha8Rng) {
        let (l, hw, sw) = (self.half_length, self.hw, self.sidewalk_w);
        self.roi.push(vec![[-l, -hw], [l, -hw], [l, hw], [-l, hw]]);
        self.roi.push(vec![[-hw, -l], [hw, -l], [hw, l], [-hw, l]]);
        for k in 0..4 {
            let a = f64::from(k) * FRAC_PI_2;
            // Canonical east arm, rotated by k quarter turns. Strip 2k: south side, 2k+1: north side.
            for (j, side) in [-1.0f64, 1.0].into_iter().enumerate() {
                let partner = if j == 1 { 2 * ((k as usize + 1) % 4) } else { 2 * ((k as usize + 3) % 4) + 1 };
                self.strips.push(Strip {
                    origin: rot([hw, side * hw], a),
                    dir: rot([1.0, 0.0], a),
                    out: rot([0.0, side], a),
                    length: l - hw,
                    opposite: 2 * k as usize + 1 - j,
                    partner: Some(partner),
                    corner: rot([hw + sw / 2.0, side * (hw + sw / 2.0)], a),
                    crosswalks_u: vec![1.5],
                    blocked: Vec::new(),
                });
            }
            for side in [-1.0f64, 1.0] {
                let (y0, y1) = ((side * hw).min(side * (hw + sw)), (side * hw).max(side * (hw + sw)));
                let poly = [[hw, y0], [l, y0], [l, y1], [hw, y1]];
                self.sidewalks.push(poly.iter().map(|p| rot(*p, a)).collect());
            }
            let cw = [[hw, -hw], [hw + 3.0, -hw], [hw + 3.0, hw], [hw, hw]];
            self.roi.push(cw.iter().map(|p| rot(*p, a)).collect());

            let mut boxes: Vec<Scenery> = Vec::new();
            // Corner building (north-east corner of the canonical arm) and a signal pole at the corner.
            let c0 = hw + sw + rng.random_range(0.5..2.0);
            let c1 = hw + sw + rng.random_range(14.0..18.0);
            boxes.push(Scenery {
                kind: SceneryKind::Building,
                b: Box3::aabb(c0, c1, c0, c1, 0.0, rng.random_range(12.0..24.0)),
            });
            for side in [-1.0f64, 1.0] {
                boxes.push(Scenery {
                    kind: SceneryKind::Pole,
                    b: Box3::aabb(hw + 3.6, hw + 3.85, side * (hw + 0.4), side * (hw + 0.65), 0.0, 4.5),
                });
                // Urban blocks beyond the corner building.
                let mut x = hw + sw + rng.random_range(19.0..22.0);
                while x < l - 8.0 {
                    let front = rng.random_range(12.0..30.0);
                    let setback = rng.random_range(0.5..2.0);
                    let depth = rng.random_range(12.0..20.0);
                    let y0 = hw + sw + setback;
                    let b = Box3::aabb(x, x + front, side * y0, side * (y0 + depth), 0.0, rng.random_range(9.0..24.0));
                    boxes.push(Scenery { kind: SceneryKind::Building, b });
                    let gap = rng.random_range(0.0..5.0);
                    if gap > 2.0 && rng.random_bool(0.4) {
                        let y = hw + sw + 0.3;
                        let b = Box3::aabb(
                            x + front,
                            x + front + gap,
                            side * y,
                            side * (y + 0.3),
                            0.0,
                            rng.random_range(1.5..2.5),
                        );
                        boxes.push(Scenery { kind: SceneryKind::Wall, b });
                    }
                    x += front + gap;
                }
            }
            for s in boxes {
                self.scenery.push(Scenery { kind: s.kind, b: rot_box(s.b, a) });
            }
            for side in [-1.0f64, 1.0] {
                let mut x = hw + sw + 10.0 + rng.random_range(0.0..8.0);
                while x < l - 2.0 {
                    if rng.random_bool(0.6) {
                        let p = rot([x, side * (hw + 0.6)], a);
                        self.push_tree_at(p, rng);
                    } else {
                        let p = rot([x, side * (hw + 0.4)], a);
                        self.push_pole(p[0], p[1], 7.0);
                    }
                    x += rng.random_range(14.0..24.0);
                }
                // Parked cars beyond the approach zone, heading with the traffic on that side.
                let heading = if side < 0.0 { 0.0 } else { PI };
                let y = side * (hw - cfg.road.parking_width_m / 2.0);
                let start = self.parked.len();
                self.push_parked_row(hw + 26.0, l - 5.0, y, heading, cfg.agents.parked_fill, &|_| false, rng);
                for b in self.parked.iter_mut().skip(start) {
                    *b = rot_box(*b, a);
                }
            }
        }
    }

    fn push_tree(&mut self, x: f64, y: f64, rng: &mut ChaCha8Rng) {
        self.push_tree_at([x, y], rng);
    }

    fn push_tree_at(&mut self, p: [f64; 2], rng: &mut ChaCha8Rng) {
        let t = 0.175;
        let base = rng.random_range(3.0..3.6);
        self.scenery.push(Scenery {
            kind: SceneryKind::TreeTrunk,
            b: Box3::aabb(p[0] - t, p[0] + t, p[1] - t, p[1] + t, 0.0, base + 0.2),
        });
        let c = rng.random_range(3.5..5.0) / 2.0;
        self.scenery.push(Scenery {
            kind: SceneryKind::TreeCanopy,
            b: Box3::aabb(p[0] - c, p[0] + c, p[1] - c, p[1] + c, base, rng.random_range(5.5..7.0)),
        });
    }

    fn push_pole(&mut self, x: f64, y: f64, h: f64) {
        self.scenery
            .push(Scenery { kind: SceneryKind::Pole, b: Box3::aabb(x - 0.1, x + 0.1, y - 0.1, y + 0.1, 0.0, h) });
    }

    /// Parks cars along `x in [x0, x1]` at lateral `y` (canonical row), filling about `fill` of the length.
    #[allow(clippy::too_many_arguments)]
    fn push_parked_row(
        &mut self,
        x0: f64,
        x1: f64,
        y: f64,
        heading: f64,
        fill: f64,
        excluded: &dyn Fn(f64) -> bool,
        rng: &mut ChaCha8Rng,
    ) {
        let mut x = x0 + rng.random_range(0.0..4.0);
        while x < x1 {
            let len = rng.random_range(3.8..5.0);
            if rng.random_bool(fill.clamp(0.0, 1.0)) && x + len < x1 && !excluded(x) && !excluded(x + len) {
                let width = rng.random_range(1.7..1.95);
                let b = Box3 {
                    cx: x + len / 2.0,
                    cy: y + rng.random_range(-0.1..0.1),
                    yaw: heading + rng.random_range(-0.03..0.03),
                    half_l: len / 2.0,
                    half_w: width / 2.0,
                    z0: 0.0,
                    z1: rng.random_range(1.4..1.7),
                };
                self.parked.push(b);
                x += len + rng.random_range(0.8..2.5);
            } else {
                x += rng.random_range(3.0..8.0);
            }
        }
    }

    /// Marks where pedestrians cannot step off each kerb: parked cars, trees and poles near the kerb.
    fn compute_blocked(&mut self) {
        let obstacles: Vec<Box3> = self
            .parked
            .iter()
            .copied()
            .chain(
                self.scenery
                    .iter()
                    .filter(|s| matches!(s.kind, SceneryKind::Pole | SceneryKind::TreeTrunk))
                    .map(|s| s.b),
            )
            .collect();
        let (hw, lane_w) = (self.hw, self.lane_w);
        for strip in &mut self.strips {
            let mut blocked: Vec<(f64, f64)> = Vec::new();
            for b in &obstacles {
                let mut lo = f64::INFINITY;
                let mut hi = f64::NEG_INFINITY;
                let mut vmin = f64::INFINITY;
                for c in b.corners() {
                    let (u, v) = strip.coords(c);
                    lo = lo.min(u);
                    hi = hi.max(u);
                    vmin = vmin.min(v);
                }
                // Near this kerb: in the parking lane or the furniture zone.
                let v_mid = strip.coords([b.cx, b.cy]).1;
                if v_mid > -(hw - lane_w) - 0.5 && vmin < 1.2 && hi > 0.0 && lo < strip.length {
                    blocked.push((lo, hi));
                }
            }
            blocked.sort_by(|a, b| a.0.total_cmp(&b.0));
            strip.blocked = blocked;
        }
    }

    /// Which phase (0 east-west, 1 north-south) has green at `t_s`, and for how much longer, seconds.
    pub(crate) fn signal(&self, t_s: f64) -> (Option<usize>, f64) {
        if self.layout != Layout::Intersection {
            return (None, 0.0);
        }
        let (g, c) = (self.green_s, self.clearance_s);
        let cycle = 2.0 * (g + c);
        let tau = (t_s + self.signal_offset_s).rem_euclid(cycle);
        if tau < g {
            (Some(0), g - tau)
        } else if tau < g + c {
            (None, 0.0)
        } else if tau < 2.0 * g + c {
            (Some(1), 2.0 * g + c - tau)
        } else {
            (None, 0.0)
        }
    }

    /// Number of distinct entries for vehicle routes (residential: 2 directions; intersection: 4 arms).
    pub(crate) fn entries(&self) -> &'static [usize] {
        match self.layout {
            Layout::Residential => &[0, 2],
            Layout::Intersection => &[0, 1, 2, 3],
        }
    }

    /// The route entering at `entry` with `turn`; `bike` keeps near the right edge of the lane.
    pub(crate) fn route(&self, entry: usize, turn: Turn, bike: bool) -> Route {
        let l = self.half_length;
        let lat = if bike { self.lane_w - 0.75 } else { self.lane_w / 2.0 };
        let a = entry as f64 * FRAC_PI_2;
        let start = rot([-l, -lat], a);
        let b = PathBuilder::new(start[0], start[1], a);
        let (turn, b) = match (self.layout, turn) {
            (Layout::Residential, _) | (_, Turn::Straight) => (Turn::Straight, b.line(2.0 * l)),
            (_, Turn::Right) => {
                let r = if bike { RIGHT_TURN_R_BIKE } else { RIGHT_TURN_R };
                (Turn::Right, b.line(l - lat - r).arc(r, -FRAC_PI_2).line(l - lat - r))
            }
            (_, Turn::Left) => {
                let r = LEFT_TURN_R;
                (Turn::Left, b.line(l + lat - r).arc(r, FRAC_PI_2).line(l - r + lat))
            }
        };
        let path = b.build(LATERAL_ACCEL, PROFILE_BRAKE);
        let (stop_s, box_exit_s, gate_s) = match self.layout {
            Layout::Residential => (None, 0.0, None),
            Layout::Intersection => {
                let stop = l - (self.hw + 4.0);
                let mut exit = stop;
                let mut s = stop;
                while s < path.length {
                    let (x, y, _, _) = path.pose(s);
                    if x.abs() <= self.hw + 0.5 && y.abs() <= self.hw + 0.5 {
                        exit = s;
                    }
                    s += 0.25;
                }
                let gate = (turn == Turn::Left).then(|| l + lat - LEFT_TURN_R + LEFT_TURN_R * 20f64.to_radians());
                (Some(stop), exit, gate)
            }
        };
        Route { path, entry, turn, stop_s, box_exit_s, gate_s }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn world(name: &str) -> World {
        let cfg = ScenarioConfig::builtin(name).unwrap();
        World::build(&cfg, &mut ChaCha8Rng::seed_from_u64(1))
    }

    #[test]
    fn scenery_stays_off_the_carriageway() {
        for name in ["pedestrians", "intersection"] {
            let w = world(name);
            assert!(w.scenery.len() > 50, "{name}: {}", w.scenery.len());
            for s in &w.scenery {
                if s.kind == SceneryKind::TreeCanopy {
                    assert!(s.b.z0 >= 3.0);
                    continue;
                }
                for c in s.b.corners() {
                    let on_x_road = c[1].abs() < w.hw && c[0].abs() < w.half_length;
                    let on_y_road = w.layout == Layout::Intersection && c[0].abs() < w.hw;
                    assert!(!on_x_road && !on_y_road, "{name}: {:?} {c:?} on the road", s.kind);
                }
            }
            assert!(!w.parked.is_empty());
        }
    }

    #[test]
    fn routes_end_where_expected() {
        let w = world("intersection");
        let r = w.route(0, Turn::Left, false);
        let (x, y, h, _) = r.path.pose(r.path.length);
        assert!((x - 1.75).abs() < 1e-6 && (y - w.half_length).abs() < 1e-6 && (h - FRAC_PI_2).abs() < 1e-9);
        let r = w.route(1, Turn::Right, false);
        let (x, y, _, _) = r.path.pose(r.path.length);
        assert!((x - w.half_length).abs() < 1e-6 && (y + 1.75).abs() < 1e-6, "{x} {y}");
        let stop = r.stop_s.unwrap();
        assert!(r.box_exit_s > stop + 5.0);
        assert_eq!(w.signal(1.0).0, Some(0));
        assert_eq!(w.signal(w.green_s + 1.0).0, None);
        assert_eq!(w.signal(w.green_s + w.clearance_s + 1.0).0, Some(1));
    }
}
