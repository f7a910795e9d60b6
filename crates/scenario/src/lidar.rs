//! The ray-cast LiDAR: beams at fixed elevations, swept in azimuth columns, against the ground plane and upright
//! boxes (scenery and agents).
//!
//! All beams of one azimuth column share the same horizontal ray. So each column intersects that 2D ray with the
//! footprints of the boxes near its azimuth once (slab test, giving the horizontal entry and exit distances), sorts
//! the hits by entry distance, and then each beam only checks at which horizontal distance its height lies within
//! a box's height range: the nearest such distance over all boxes and the ground is the return. Occlusion follows
//! from the geometry. Boxes are found through an angular index (720 bins of 0.5 degrees).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::config::LidarModel;
use crate::geom::Box3;

/// Target id of a ground return.
pub(crate) const GROUND: u32 = u32::MAX;

const BINS: usize = 720;
/// Columns per work chunk (also the unit of parallel work).
const CHUNK: usize = 64;

#[derive(Clone, Copy, Debug)]
struct Beam {
    cos_e: f32,
    sin_e: f32,
    /// 1 / tan(elevation); infinite for a horizontal beam.
    inv_tan: f32,
    /// Horizontal distance where the beam meets the ground, or infinity.
    ground_rho: f32,
    /// Horizontal distances of the range limits.
    rho_min: f32,
    rho_max: f32,
}

/// A box in the sensor frame, prepared for slab tests.
#[derive(Clone, Copy, Debug)]
struct SensorBox {
    /// Sensor origin in the box frame.
    ox: f32,
    oy: f32,
    /// Box yaw in the sensor frame (cos, sin).
    c: f32,
    s: f32,
    hl: f32,
    hw: f32,
    /// Heights relative to the sensor, metres.
    zlo: f32,
    zhi: f32,
    target: u32,
}

#[derive(Clone, Copy, Debug)]
struct Cand {
    tin: f32,
    tout: f32,
    zlo: f32,
    zhi: f32,
    target: u32,
}

/// One sweep: points in the sensor frame and, per point, the index of the box it hit (or [`GROUND`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Sweep {
    pub points: Vec<[f32; 3]>,
    pub targets: Vec<u32>,
}

/// The LiDAR with its precomputed beams, columns and scratch index.
pub(crate) struct Lidar {
    model: LidarModel,
    beams: Vec<Beam>,
    /// (cos, sin) of each column's azimuth in the sensor frame.
    columns: Vec<(f32, f32)>,
    boxes: Vec<SensorBox>,
    bins: Vec<Vec<u32>>,
}

fn mix64(mut z: u64) -> u64 {
    // SplitMix64 finaliser.
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Lidar {
    pub(crate) fn new(model: LidarModel) -> Self {
        let h = model.mount_height_m as f32;
        let beams = model
            .elevations_rad
            .iter()
            .map(|&e| {
                let (sin_e, cos_e) = (e.sin() as f32, e.cos() as f32);
                let tan_e = sin_e / cos_e;
                Beam {
                    cos_e,
                    sin_e,
                    inv_tan: if tan_e.abs() > 1e-7 { 1.0 / tan_e } else { f32::INFINITY },
                    ground_rho: if tan_e < -1e-7 { h / -tan_e } else { f32::INFINITY },
                    rho_min: model.min_range_m as f32 * cos_e,
                    rho_max: model.max_range_m as f32 * cos_e,
                }
            })
            .collect();
        let n = model.columns();
        let columns = (0..n)
            .map(|j| {
                let a = j as f64 * std::f64::consts::TAU / n as f64;
                (a.cos() as f32, a.sin() as f32)
            })
            .collect();
        Self { model, beams, columns, boxes: Vec::new(), bins: vec![Vec::new(); BINS] }
    }

    pub(crate) fn model(&self) -> &LidarModel {
        &self.model
    }

    /// Casts one sweep from a sensor at world `(x, y)` with `yaw`, against `boxes` (world frame; the returned
    /// targets index this slice). `seed` seeds the noise and dropout of this sweep.
    pub(crate) fn cast(&mut self, x: f64, y: f64, yaw: f64, boxes: &[Box3], seed: u64) -> Sweep {
        self.index(x, y, yaw, boxes);
        let n = self.columns.len();
        let chunks: Vec<usize> = (0..n.div_ceil(CHUNK)).collect();
        let this = &*self;
        #[cfg(feature = "parallel")]
        let parts: Vec<Sweep> = {
            use rayon::prelude::*;
            chunks.par_iter().map(|&c| this.cast_chunk(c, seed)).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let parts: Vec<Sweep> = chunks.iter().map(|&c| this.cast_chunk(c, seed)).collect();
        let total = parts.iter().map(|p| p.points.len()).sum();
        let mut out = Sweep { points: Vec::with_capacity(total), targets: Vec::with_capacity(total) };
        for p in parts {
            out.points.extend_from_slice(&p.points);
            out.targets.extend_from_slice(&p.targets);
        }
        out
    }

    /// Transforms the boxes into the sensor frame and fills the angular bins.
    fn index(&mut self, x: f64, y: f64, yaw: f64, boxes: &[Box3]) {
        let h = self.model.mount_height_m;
        let (sy, cy) = yaw.sin_cos();
        self.boxes.clear();
        for bin in &mut self.bins {
            bin.clear();
        }
        let bin_w = std::f64::consts::TAU / BINS as f64;
        for (i, b) in boxes.iter().enumerate() {
            // Centre and yaw in the sensor frame.
            let (dx, dy) = (b.cx - x, b.cy - y);
            let (px, py) = (cy * dx + sy * dy, -sy * dx + cy * dy);
            let r = px.hypot(py);
            if r - (b.half_l + b.half_w) > self.model.max_range_m || b.z1 <= 0.0 {
                continue;
            }
            let byaw = b.yaw - yaw;
            let (s, c) = byaw.sin_cos();
            let sb = SensorBox {
                ox: (-(c * px + s * py)) as f32,
                oy: (-(-s * px + c * py)) as f32,
                c: c as f32,
                s: s as f32,
                hl: b.half_l as f32,
                hw: b.half_w as f32,
                zlo: (b.z0 - h) as f32,
                zhi: (b.z1 - h) as f32,
                target: i as u32,
            };
            let k = self.boxes.len() as u32;
            self.boxes.push(sb);
            let inside = sb.ox.abs() <= sb.hl + 0.05 && sb.oy.abs() <= sb.hw + 0.05;
            if inside {
                for bin in &mut self.bins {
                    bin.push(k);
                }
                continue;
            }
            let centre = py.atan2(px);
            let (mut lo, mut hi) = (0.0f64, 0.0f64);
            let (sl, cl) = byaw.sin_cos();
            for (a, bb) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)] {
                let qx = px + cl * a * b.half_l - sl * bb * b.half_w;
                let qy = py + sl * a * b.half_l + cl * bb * b.half_w;
                let d = crate::geom::wrap_angle(qy.atan2(qx) - centre);
                lo = lo.min(d);
                hi = hi.max(d);
            }
            let start = (centre + lo).rem_euclid(std::f64::consts::TAU);
            let first = (start / bin_w).floor() as usize;
            let count = (((hi - lo) / bin_w).floor() as usize + 2).min(BINS);
            for j in 0..count {
                if let Some(bin) = self.bins.get_mut((first + j) % BINS) {
                    bin.push(k);
                }
            }
        }
    }

    fn cast_chunk(&self, chunk: usize, seed: u64) -> Sweep {
        let n = self.columns.len();
        let c0 = chunk * CHUNK;
        let c1 = (c0 + CHUNK).min(n);
        let mut out = Sweep {
            points: Vec::with_capacity((c1 - c0) * self.beams.len()),
            targets: Vec::with_capacity((c1 - c0) * self.beams.len()),
        };
        let noisy = self.model.range_noise_m > 0.0 || self.model.dropout > 0.0;
        let sigma = self.model.range_noise_m as f32;
        let dropout = self.model.dropout;
        let mut cands: Vec<Cand> = Vec::with_capacity(64);
        for col in c0..c1 {
            let Some(&(dc, ds)) = self.columns.get(col) else { break };
            let bin = col * BINS / n;
            cands.clear();
            for &k in self.bins.get(bin).map(Vec::as_slice).unwrap_or(&[]) {
                let Some(b) = self.boxes.get(k as usize) else { continue };
                // Ray direction in the box frame.
                let dx = b.c * dc + b.s * ds;
                let dy = -b.s * dc + b.c * ds;
                let Some((tin, tout)) = slab(b.ox, dx, b.hl).and_then(|(a0, a1)| {
                    let (b0, b1) = slab(b.oy, dy, b.hw)?;
                    let (tin, tout) = (a0.max(b0).max(0.0), a1.min(b1));
                    (tin <= tout).then_some((tin, tout))
                }) else {
                    continue;
                };
                cands.push(Cand { tin, tout, zlo: b.zlo, zhi: b.zhi, target: b.target });
            }
            cands.sort_unstable_by(|a, b| a.tin.total_cmp(&b.tin).then(a.target.cmp(&b.target)));
            let mut rng = noisy.then(|| ChaCha8Rng::seed_from_u64(mix64(seed ^ mix64(col as u64))));
            for beam in &self.beams {
                let mut best = beam.ground_rho;
                let mut target = GROUND;
                for c in &cands {
                    if c.tin >= best {
                        break;
                    }
                    let (lo, hi) = if beam.inv_tan.is_finite() {
                        let (a, b) = (c.zlo * beam.inv_tan, c.zhi * beam.inv_tan);
                        if beam.inv_tan > 0.0 {
                            (a, b)
                        } else {
                            (b, a)
                        }
                    } else if c.zlo <= 0.0 && c.zhi >= 0.0 {
                        (0.0, f32::INFINITY)
                    } else {
                        continue;
                    };
                    let hit = c.tin.max(lo);
                    if hit <= c.tout.min(hi) && hit < best {
                        best = hit;
                        target = c.target;
                    }
                }
                if !(best.is_finite() && best >= beam.rho_min && best <= beam.rho_max) {
                    continue;
                }
                let mut range = best / beam.cos_e;
                if let Some(rng) = rng.as_mut() {
                    if dropout > 0.0 && rng.random_bool(dropout) {
                        continue;
                    }
                    if sigma > 0.0 {
                        let n: f32 = rng.sample(StandardNormal);
                        range = (range + sigma * n).max(0.0);
                    }
                }
                let rho = range * beam.cos_e;
                out.points.push([rho * dc, rho * ds, range * beam.sin_e]);
                out.targets.push(target);
            }
        }
        out
    }
}

/// Slab of one axis: the ray `o + t d` is within `[-h, h]` for `t` in the returned interval.
#[inline]
fn slab(o: f32, d: f32, h: f32) -> Option<(f32, f32)> {
    if d.abs() < 1e-9 {
        return (o.abs() <= h).then_some((f32::NEG_INFINITY, f32::INFINITY));
    }
    let inv = 1.0 / d;
    let (t0, t1) = ((-h - o) * inv, (h - o) * inv);
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{LidarModel, LidarPreset};

    fn ideal(preset: LidarPreset) -> LidarModel {
        let mut m = LidarModel::preset(preset);
        m.range_noise_m = 0.0;
        m.dropout = 0.0;
        m
    }

    /// A single beam, single column LiDAR looking along +x.
    fn one_beam(elev_deg: f64, h: f64) -> Lidar {
        let mut m = ideal(LidarPreset::Hdl64);
        m.elevations_rad = vec![elev_deg.to_radians()];
        m.mount_height_m = h;
        m.azimuth_step_rad = std::f64::consts::TAU;
        Lidar::new(m)
    }

    #[test]
    fn ground_hit_at_known_range() {
        let mut l = one_beam(-10.0, 1.8);
        let s = l.cast(0.0, 0.0, 0.0, &[], 1);
        assert_eq!(s.points.len(), 1);
        let p = s.points[0];
        let rho = 1.8 / 10f64.to_radians().tan();
        assert!((f64::from(p[0]) - rho).abs() < 1e-3, "{p:?}");
        assert!((f64::from(p[2]) + 1.8).abs() < 1e-4);
        assert_eq!(s.targets[0], GROUND);
    }

    #[test]
    fn box_face_hit_at_known_range_and_blocks_the_ground() {
        let mut l = one_beam(-2.0, 1.8);
        // Box face at x = 20, 0..2 m high: the beam is at 1.8 - 20 tan 2deg = 1.10 m there.
        let b = Box3::aabb(20.0, 24.0, -1.0, 1.0, 0.0, 2.0);
        let s = l.cast(0.0, 0.0, 0.0, &[b], 1);
        assert_eq!(s.targets, vec![0]);
        let r = (s.points[0][0].powi(2) + s.points[0][2].powi(2)).sqrt();
        assert!((f64::from(r) - 20.0 / 2f64.to_radians().cos()).abs() < 1e-3);
        // Beam passes over a lower box: ground beyond it (ground at 1.8 / tan 2deg = 51.5 m).
        let low = Box3::aabb(20.0, 24.0, -1.0, 1.0, 0.0, 0.5);
        let s = l.cast(0.0, 0.0, 0.0, &[low], 1);
        assert_eq!(s.targets, vec![GROUND]);
        assert!((f64::from(s.points[0][0]) - 1.8 / 2f64.to_radians().tan()).abs() < 1e-2);
    }

    #[test]
    fn roof_hit_from_above() {
        // Steep beam lands on the top face.
        // Sensor 3 m up: the beam clears the front face (2.27 m high there) and lands on the 1.5 m roof.
        let mut l = one_beam(-20.0, 3.0);
        let b = Box3::aabb(2.0, 8.0, -1.0, 1.0, 0.0, 1.5);
        let s = l.cast(0.0, 0.0, 0.0, &[b], 1);
        assert_eq!(s.targets, vec![0]);
        assert!((s.points[0][2] + 1.5).abs() < 1e-4, "{:?}", s.points[0]);
        assert!((f64::from(s.points[0][0]) - 1.5 / 20f64.to_radians().tan()).abs() < 1e-3);
    }

    #[test]
    fn rotated_box_and_sensor_yaw() {
        let mut l = one_beam(0.0, 1.0);
        // Sensor yawed to +y; a box rotated 45 degrees straight ahead at 10 m.
        let b = Box3 { cx: 0.0, cy: 10.0, yaw: 0.785, half_l: 1.0, half_w: 1.0, z0: 0.0, z1: 2.0 };
        let s = l.cast(0.0, 0.0, std::f64::consts::FRAC_PI_2, &[b], 1);
        assert_eq!(s.targets, vec![0]);
        assert!((f64::from(s.points[0][0]) - (10.0 - 2f64.sqrt())).abs() < 1e-2, "{:?}", s.points[0]);
    }

    #[test]
    fn box_fully_behind_another_gets_no_points() {
        let mut l = Lidar::new(ideal(LidarPreset::Hdl64));
        let truck = Box3 { cx: 10.0, cy: 0.0, yaw: 0.0, half_l: 1.25, half_w: 5.0, z0: 0.0, z1: 3.8 };
        let car = Box3 { cx: 20.0, cy: 0.0, yaw: 0.0, half_l: 2.2, half_w: 0.9, z0: 0.0, z1: 1.5 };
        let s = l.cast(0.0, 0.0, 0.0, &[truck, car], 7);
        let hits = |t: u32| s.targets.iter().filter(|&&x| x == t).count();
        assert!(hits(0) > 1000, "truck {}", hits(0));
        assert_eq!(hits(1), 0);
        // Without the truck the car is seen.
        let s = l.cast(0.0, 0.0, 0.0, &[car], 7);
        assert!(s.targets.iter().filter(|&&x| x == 0).count() > 100);
    }

    #[test]
    fn canopy_above_sensor_is_hit_only_from_below() {
        let mut l = Lidar::new(ideal(LidarPreset::Vlp32));
        let canopy = Box3::aabb(-10.0, 10.0, -10.0, 10.0, 3.0, 6.0);
        let s = l.cast(0.0, 0.0, 0.0, &[canopy], 3);
        let h = l.model().mount_height_m as f32;
        let canopy_pts: Vec<_> = s.points.iter().zip(&s.targets).filter(|(_, &t)| t == 0).collect();
        assert!(!canopy_pts.is_empty());
        assert!(canopy_pts.iter().all(|(p, _)| p[2] + h >= 3.0 - 1e-3));
    }

    #[test]
    fn point_count_is_near_the_ray_count_with_ground() {
        let mut l = Lidar::new(ideal(LidarPreset::Hdl64));
        let s = l.cast(0.0, 0.0, 0.0, &[], 1);
        // Downward beams all hit the ground within 120 m: 2083 columns x (beams below -0.83 deg).
        let down = l.beams.iter().filter(|b| b.ground_rho <= b.rho_max).count();
        assert_eq!(s.points.len(), 2083 * down);
    }
}
