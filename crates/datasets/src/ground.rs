//! The ground under each LiDAR return, so that the monitor's height band ("0.3 m above the ground") follows the
//! terrain instead of one flat plane per log.
//!
//! The monitor compares every return with one ground height (`MonitorParams::ground_z_m`). On a hill the road
//! 40 m behind the vehicle lies 0.3-0.5 m above the ground under it (Argoverse 2 log 7fab2350), and its returns
//! enter the obstacle band as "missed objects". This module *levels* a sweep before the monitor sees it: each
//! return's height above the local ground replaces its height above the flat plane
//! (`z' = ground_z_m + (z - ground(x, y))`, moved along the ego frame's vertical), so the monitor itself stays as
//! the paper describes it.
//!
//! Where the ground comes from ([`GroundMode`]):
//! - the dataset's own ground surface where it has one (Argoverse 2 `*_ground_height_surface____*.npy`, applied
//!   per return by the AV2 reader; the default), and
//! - on request (or where the raster has no value) a **local estimate**: [`SectorGround`], the slope-limited lowest-return ground of Himmelsbach,
//!   Hundelshausen and Wuensche, *Fast segmentation of 3D point clouds for ground vehicles* (IEEE IV 2010), in the
//!   simplified form of Autoware's `ray_ground_filter`: the sweep is cut into azimuth sectors and range bins
//!   around the sensor; each bin's lowest return is its ground candidate; walking outwards along each sector, a
//!   candidate is ground when it rises above the last accepted ground by at most `step_m + max_slope * distance`
//!   (the rise capped at `max_rise_m`) and is rejected otherwise (the bottom of a car, a wall behind a gap); the
//!   ground then follows it, but climbs no faster than `max_slope` (so `step_m` tolerates a kerb or noise without
//!   letting the ground climb a hedge bin by bin); bins without an accepted candidate keep the last ground of
//!   their sector. Lower candidates are always accepted (a return below the ground can only be the ground, where
//!   the road falls away). A bin whose returns span more than `vertical_m` in height (the max-min height
//!   difference of Thrun et al., *Stanley*, J. Field Robotics 2006) holds something standing up: its lowest return
//!   may rise above the last ground by no more than the slope allows (at most `step_m`), so that sparse rings at
//!   range (2 m apart at 30 m for a 32-beam sensor) do not lift the ground onto the foot of a barrier or a car.
//!
//! Limits: under an object that hides every ground return of its bins the ground is carried from in front of it
//! (right for an object on the road); a structure seen only from a height beyond a long shadow may be taken for
//! rising ground up to `max_rise_m` (its lower part then leaves the band). Sectors and bins are fixed, so the
//! cost is linear in the points plus a fixed array per frame.

use pmon_monitor::Isometry3;
use pmon_recording::OwnedCloud;

/// The start of the dataset note that says how the sweeps' ground was found.
pub const GROUND_NOTE_PREFIX: &str = "ground: ";

/// Where the ground under each return comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroundMode {
    /// Points as recorded: the monitor compares them with one flat ground height per log (`ground_z_m`).
    AsRecorded,
    /// The dataset's ground surface where it has one (the Argoverse 2 ground raster per return, the local estimate
    /// where the raster has no value); sweeps of datasets without one stay as recorded. What `pmon check`,
    /// `convert`, `view`, `bench` and `reproduce` use.
    Auto,
    /// The local estimate ([`SectorGround`]) for every return, even where the dataset has a ground surface. Not the
    /// default for datasets without a raster: on the flat nuScenes keyframe it turns four barriers at 30-35 m,
    /// hit by one or two rings each, into ghosts (docs/datasets.md).
    Local,
}

impl GroundMode {
    /// Parses `recorded`, `auto` or `local`.
    ///
    /// # Errors
    /// Any other word.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "recorded" | "flat" => Ok(Self::AsRecorded),
            "auto" => Ok(Self::Auto),
            "local" => Ok(Self::Local),
            _ => Err(format!("`{s}`: expected `auto`, `local` or `recorded`")),
        }
    }
}

/// Parameters of the local ground estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectorGroundOptions {
    /// Azimuth sectors around the sensor.
    pub sectors: usize,
    /// Radial bin length, metres.
    pub bin_m: f32,
    /// Range covered, metres (beyond it, the last ground of the sector).
    pub max_range_m: f32,
    /// Largest ground slope followed, rise over run (0.15: 8.5 degrees, steeper than most streets).
    pub max_slope: f32,
    /// Rise allowed at any distance (kerbs, noise), metres.
    pub step_m: f32,
    /// Largest rise accepted after a gap, metres.
    pub max_rise_m: f32,
    /// A bin whose returns span more than this in height holds something standing up, metres.
    pub vertical_m: f32,
}

impl Default for SectorGroundOptions {
    fn default() -> Self {
        Self {
            sectors: 360,
            bin_m: 0.5,
            max_range_m: 80.0,
            max_slope: 0.15,
            step_m: 0.15,
            max_rise_m: 1.0,
            vertical_m: 0.3,
        }
    }
}

/// The local ground estimate of one sweep: a ground height per (sector, bin) in the ego frame.
#[derive(Clone, Debug, PartialEq)]
pub struct SectorGround {
    origin: [f32; 2],
    opts: SectorGroundOptions,
    bins: usize,
    /// Row-major `[sector][bin]`, metres (ego frame z).
    height_m: Vec<f32>,
}

impl SectorGround {
    /// Estimates the ground from points in the ego frame seen from `origin` (the sensor's x, y), starting at
    /// `ground_z_m` under the vehicle. Points inside `ego_footprint_m` (`[min_x, min_y, max_x, max_y]`, the
    /// vehicle itself) and non-finite points are ignored.
    #[must_use]
    pub fn estimate(
        points_in_ego: &[[f32; 3]],
        origin: [f32; 2],
        ground_z_m: f32,
        ego_footprint_m: [f32; 4],
        opts: SectorGroundOptions,
    ) -> Self {
        let opts = SectorGroundOptions {
            sectors: opts.sectors.max(1),
            bin_m: if opts.bin_m > 0.0 { opts.bin_m } else { 0.5 },
            ..opts
        };
        let bins = ((opts.max_range_m / opts.bin_m).ceil().max(1.0)) as usize;
        let mut lowest = vec![f32::INFINITY; opts.sectors * bins];
        let mut highest = vec![f32::NEG_INFINITY; opts.sectors * bins];
        let mut me = Self { origin, opts, bins, height_m: Vec::new() };
        let e = ego_footprint_m;
        for p in points_in_ego {
            if !p.iter().all(|v| v.is_finite()) || (p[0] >= e[0] && p[0] <= e[2] && p[1] >= e[1] && p[1] <= e[3]) {
                continue;
            }
            if let Some(i) = me.index(p[0], p[1]) {
                if let (Some(l), Some(h)) = (lowest.get_mut(i), highest.get_mut(i)) {
                    *l = l.min(p[2]);
                    *h = h.max(p[2]);
                }
            }
        }
        let o = me.opts;
        for s in 0..o.sectors {
            let (mut ground, mut at_m) = (ground_z_m, 0.0f32);
            for b in 0..bins {
                let i = s * bins + b;
                let r = (b as f32 + 0.5) * o.bin_m;
                let candidate = lowest.get(i).copied().unwrap_or(f32::INFINITY);
                let spread = highest.get(i).copied().unwrap_or(f32::NEG_INFINITY) - candidate;
                let rise = (o.max_slope * (r - at_m)).min(o.max_rise_m);
                // A bin whose returns stand up (a car's side, a barrier, a wall) offers its lowest return as ground
                // only near the ground expected there; a flat bin may rise with the slope.
                let tolerance = if spread > o.vertical_m { o.step_m.min(rise) } else { o.step_m + rise };
                if candidate.is_finite() && candidate <= ground + tolerance {
                    // The ground climbs no faster than the slope allows (`step_m` is a tolerance, not a climb: a
                    // staircase of steps would let it climb a hedge seen at a grazing angle).
                    ground = candidate.min(ground + rise);
                    at_m = r;
                }
                if let Some(l) = lowest.get_mut(i) {
                    *l = ground;
                }
            }
        }
        me.height_m = lowest;
        me
    }

    fn index(&self, x: f32, y: f32) -> Option<usize> {
        let (dx, dy) = (x - self.origin[0], y - self.origin[1]);
        let r = dx.hypot(dy);
        if !r.is_finite() {
            return None;
        }
        let a = dy.atan2(dx).rem_euclid(std::f32::consts::TAU);
        let s = ((a / std::f32::consts::TAU * self.opts.sectors as f32) as usize).min(self.opts.sectors - 1);
        let b = ((r / self.opts.bin_m) as usize).min(self.bins - 1);
        Some(s * self.bins + b)
    }

    /// The estimated ground height (ego frame z, metres) under `(x, y)`.
    #[must_use]
    pub fn height_at(&self, x: f32, y: f32) -> Option<f32> {
        self.index(x, y).and_then(|i| self.height_m.get(i).copied())
    }
}

/// What levelling did to one sweep.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelStats {
    /// Returns whose ground came from the dataset's surface.
    pub from_dataset: usize,
    /// Returns whose ground came from the local estimate.
    pub from_estimate: usize,
}

/// Levels a sweep in place: each return moves along the ego frame's vertical by `ground_z_m - ground`, where
/// `ground` is `known(point_in_ego)` (the dataset's ground height in the ego frame there, when it has one) or the
/// local estimate. Afterwards the flat plane `ground_z_m` is the local ground under every return.
pub fn level_cloud(
    cloud: &mut OwnedCloud,
    ground_z_m: f32,
    ego_footprint_m: [f32; 4],
    opts: SectorGroundOptions,
    known: &dyn Fn([f32; 3]) -> Option<f32>,
) -> LevelStats {
    let t: Isometry3 = cloud.ego_from_sensor;
    let in_ego: Vec<[f32; 3]> = cloud.points_in_sensor.iter().map(|p| t.transform(*p)).collect();
    let origin = [t.translation_m[0], t.translation_m[1]];
    let estimate = SectorGround::estimate(&in_ego, origin, ground_z_m, ego_footprint_m, opts);
    // The ego frame's vertical in the sensor frame: the third row of `ego_from_sensor`'s rotation.
    let up = t.rotation[2];
    let mut stats = LevelStats::default();
    for (p, q) in cloud.points_in_sensor.iter_mut().zip(&in_ego) {
        let ground = match known(*q) {
            Some(g) => {
                stats.from_dataset += 1;
                Some(g)
            }
            None => {
                stats.from_estimate += 1;
                estimate.height_at(q[0], q[1])
            }
        };
        let Some(g) = ground.filter(|g| g.is_finite()) else { continue };
        let dz = ground_z_m - g;
        *p = [p[0] + dz * up[0], p[1] + dz * up[1], p[2] + dz * up[2]];
    }
    stats
}

/// Levels the sweeps of a dataset with the local estimate for [`GroundMode::Local`] (the readers apply a dataset's
/// own ground surface for [`GroundMode::Auto`] and say so in a note starting with [`GROUND_NOTE_PREFIX`]); adds
/// a note saying what was done.
pub fn finish(ds: &mut crate::Dataset, mode: GroundMode) {
    if !levels_locally(ds, mode) {
        return;
    }
    let (ground_z_m, ego) = (ds.info.ground_z_m, ds.info.format.ego_footprint_m());
    let mut sweeps = 0usize;
    for f in &mut ds.frames {
        if let Some(cloud) = f.frame.cloud.as_mut() {
            level_cloud(cloud, ground_z_m, ego, SectorGroundOptions::default(), &|_| None);
            sweeps += 1;
        }
    }
    push_local_note(ds, sweeps);
}

/// True when [`finish`] levels the dataset's sweeps with the local estimate: [`GroundMode::Local`], and no reader
/// applied a ground surface of its own (its note). Also asked by readers that level each sweep as it is read.
pub(crate) fn levels_locally(ds: &crate::Dataset, mode: GroundMode) -> bool {
    mode == GroundMode::Local && !ds.info.notes.iter().any(|n| n.starts_with(GROUND_NOTE_PREFIX))
}

/// Adds the note of [`local_note`] for `sweeps` levelled sweeps (none for zero).
pub(crate) fn push_local_note(ds: &mut crate::Dataset, sweeps: usize) {
    if sweeps > 0 {
        ds.info.notes.push(format!("{GROUND_NOTE_PREFIX}{}", local_note(sweeps)));
    }
}

/// The note for sweeps levelled with the local estimate.
#[must_use]
pub fn local_note(sweeps: usize) -> String {
    let o = SectorGroundOptions::default();
    format!(
        "{sweeps} sweeps levelled to a local ground estimate (lowest return per {}-degree sector and {} m range bin, \
         slope up to {}, Himmelsbach et al. 2010; docs/datasets.md)",
        360.0 / o.sectors as f32,
        o.bin_m,
        o.max_slope
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic sweep: ground (60 m wide) rising at `slope` behind the sensor (x < 0), flat ahead, and the
    /// face of a car from 0.25 m to 1.5 m above the slope 20 m behind.
    fn sloped_sweep(slope: f32) -> Vec<[f32; 3]> {
        let mut pts = Vec::new();
        let ground = |x: f32| if x < 0.0 { -slope * x } else { 0.0 };
        // As a spinning LiDAR samples it: every 0.2 degrees, every 0.25 m of range from 2 m to 45 m.
        for k in 0..1800 {
            let a = (k as f32 * 0.2).to_radians();
            let mut r = 2.0f32;
            while r < 45.0 {
                let (x, y) = (r * a.cos(), r * a.sin());
                pts.push([x, y, ground(x)]);
                r += 0.25;
            }
        }
        // The car: its faces from 0.25 m to 1.5 m above the slope, at x -22..-20, y -1..1.
        let mut z = 0.25f32;
        while z <= 1.5 {
            let mut y = -1.0f32;
            while y <= 1.0 {
                pts.push([-20.0, y, ground(-20.0) + z]);
                y += 0.1;
            }
            z += 0.1;
        }
        pts
    }

    #[test]
    fn follows_a_slope_and_keeps_the_car_standing_on_it() {
        let pts = sloped_sweep(0.08);
        let g = SectorGround::estimate(&pts, [0.0, 0.0], 0.0, [-1.0, -1.0, 1.0, 1.0], SectorGroundOptions::default());
        for x in [-40.0f32, -30.0, -10.0, 10.0, 30.0] {
            let want = if x < 0.0 { -0.08 * x } else { 0.0 };
            let got = g.height_at(x, 3.0).unwrap();
            assert!((got - want).abs() < 0.1, "x {x}: ground {got} want {want}");
        }
        // Under the car the ground is carried from in front of it, not raised to its bottom.
        let under = g.height_at(-20.0, 0.0).unwrap();
        assert!((under - 1.6).abs() < 0.1, "under the car: {under}");
    }

    #[test]
    fn levelling_puts_the_slope_on_the_flat_plane_and_keeps_the_car_in_the_band() {
        let pts = sloped_sweep(0.08);
        // A sensor 1.7 m up, upright.
        let t = Isometry3::from_translation(0.0, 0.0, 1.7);
        let mut cloud =
            OwnedCloud { points_in_sensor: pts.iter().map(|p| [p[0], p[1], p[2] - 1.7]).collect(), ego_from_sensor: t };
        let stats = level_cloud(&mut cloud, 0.0, [-1.0, -1.0, 1.0, 1.0], SectorGroundOptions::default(), &|_| None);
        assert_eq!(stats.from_dataset, 0);
        let (mut ground_in_band, mut car_in_band, mut car) = (0, 0, 0);
        for (p, q) in pts.iter().zip(&cloud.points_in_sensor) {
            let z = t.transform(*q)[2];
            let is_car = (p[0] + 20.0).abs() < 1e-3 && p[2] > 0.08 * 20.0 + 0.2;
            if is_car {
                car += 1;
                car_in_band += usize::from(z >= 0.3);
            } else if z >= 0.3 {
                ground_in_band += 1;
            }
        }
        assert_eq!(ground_in_band, 0, "no ground return in the obstacle band after levelling");
        assert!(car_in_band * 10 >= car * 8, "{car_in_band} of {car} car returns stay in the band");
        // Without levelling the slope beyond 4 m behind is in the band.
        let flat = pts.iter().filter(|p| p[2] >= 0.3 && p[0] < -4.0 && (p[0] + 20.0).abs() > 1e-3).count();
        assert!(flat > 1000, "{flat}");
    }

    #[test]
    fn a_rotated_extrinsic_moves_points_along_the_ego_vertical() {
        // nuScenes-like: the sensor yawed by 90 degrees.
        let t = Isometry3::from_yaw_translation(std::f32::consts::FRAC_PI_2, [0.9, 0.0, 1.8]);
        let ego = [[-10.0f32, 2.0, 0.5], [-10.5, 2.0, 0.5], [-10.0, 2.5, 0.5]];
        // sensor = R^T (ego - t)
        let sensor: Vec<[f32; 3]> = ego
            .iter()
            .map(|p| {
                let d = [p[0] - 0.9, p[1], p[2] - 1.8];
                [d[1], -d[0], d[2]]
            })
            .collect();
        let mut cloud = OwnedCloud { points_in_sensor: sensor, ego_from_sensor: t };
        level_cloud(&mut cloud, 0.0, [0.0; 4], SectorGroundOptions::default(), &|q| Some(q[2] - 0.1));
        for (p, q) in ego.iter().zip(&cloud.points_in_sensor) {
            let e = t.transform(*q);
            assert!((e[0] - p[0]).abs() < 1e-4 && (e[1] - p[1]).abs() < 1e-4, "{e:?}");
            assert!((e[2] - 0.1).abs() < 1e-4, "height above the given ground: {e:?}");
        }
    }
}
