//! [`Simulator`]: steps the world frame by frame and produces [`SimFrame`]s; [`simulate_to_dir`] writes them.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use pmon_monitor::{Isometry3, ObjectClass, ObjectState, Pose2, Uncertainty};
use pmon_recording::{OwnedCloud, RecordedFrame, RecordingMeta, RecordingWriter};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::Serialize;

use crate::config::{RoiMode, ScenarioConfig};
use crate::error::ScenarioError;
use crate::geom::{wrap_angle, Box3};
use crate::lidar::{Lidar, GROUND};
use crate::traffic::{Behaviour, Traffic};
use crate::world::{SceneryKind, World};
use pmon_datasets::geometry::clip_to_square;

/// Ground truth of one road user (or parked car) in one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TruthObject {
    /// Id, as in the object list; a vehicle that leaves the world and comes back gets a new id.
    pub id: u64,
    /// Class.
    pub class: ObjectClass,
    /// True for parked cars (never move).
    pub parked: bool,
    /// Footprint centre, world frame, metres.
    pub x_m: f64,
    /// Footprint centre, world frame, metres.
    pub y_m: f64,
    /// Heading (direction of motion and box yaw), world frame, radians.
    pub heading_rad: f64,
    /// Footprint centre, ego frame, metres.
    pub x_ego_m: f64,
    /// Footprint centre, ego frame, metres.
    pub y_ego_m: f64,
    /// Heading, ego frame, radians.
    pub heading_ego_rad: f64,
    /// Ground speed, m/s, `>= 0`.
    pub speed_mps: f64,
    /// Longitudinal acceleration over the last step, m/s^2.
    pub accel_mps2: f64,
    /// Turn rate over the last step, rad/s.
    pub turn_rate_radps: f64,
    /// Box length, metres.
    pub length_m: f64,
    /// Box width, metres.
    pub width_m: f64,
    /// Box height, metres.
    pub height_m: f64,
    /// LiDAR points that hit the box this frame (0 without a cloud).
    pub lidar_points: u32,
    /// True when the centre is inside the ego-centred grid square (the object is in the object list).
    pub in_grid: bool,
}

/// The ego vehicle's ground truth.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EgoTruth {
    /// Reference point (footprint centre), world frame, metres.
    pub x_m: f64,
    /// Reference point, world frame, metres.
    pub y_m: f64,
    /// Yaw, world frame, radians.
    pub yaw_rad: f64,
    /// Speed, m/s.
    pub speed_mps: f64,
    /// Acceleration over the last step, m/s^2.
    pub accel_mps2: f64,
    /// Yaw rate over the last step, rad/s.
    pub yaw_rate_radps: f64,
}

/// One simulated frame: what the monitor gets, and the ground truth.
#[derive(Clone, Debug, PartialEq)]
pub struct SimFrame {
    /// Object list (agents and parked cars in the grid, ego frame), LiDAR sweep, ego pose, ROI.
    pub frame: RecordedFrame,
    /// Every agent within the grid square grown by [`TRUTH_MARGIN_M`], sorted by id.
    pub truth: Vec<TruthObject>,
    /// The ego vehicle.
    pub ego: EgoTruth,
}

/// Ground truth covers the grid square grown by this margin on each side, metres.
pub const TRUTH_MARGIN_M: f64 = 10.0;

/// The simulator: a world, its agents, the ego and its LiDAR.
pub struct Simulator {
    cfg: ScenarioConfig,
    world: World,
    traffic: Traffic,
    lidar: Option<Lidar>,
    frame: u64,
    frames: u64,
    last_sweep: Option<i64>,
    noise_rng: ChaCha8Rng,
    lidar_seed: u64,
    boxes: Vec<Box3>,
    box_agent: Vec<usize>,
}

fn sub_seed(seed: u64, stream: u64) -> u64 {
    let mut z = seed ^ stream.wrapping_mul(0xD6E8_FEB8_6659_FD93);
    z = (z ^ (z >> 32)).wrapping_mul(0xD6E8_FEB8_6659_FD93);
    z = (z ^ (z >> 32)).wrapping_mul(0xD6E8_FEB8_6659_FD93);
    z ^ (z >> 32)
}

impl Simulator {
    /// Builds the world, spawns the agents and runs the warm-up.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] if the configuration does not validate.
    pub fn new(cfg: &ScenarioConfig) -> Result<Self, ScenarioError> {
        cfg.validate()?;
        let seed = cfg.seed;
        let world = World::build(cfg, &mut ChaCha8Rng::seed_from_u64(sub_seed(seed, 1)));
        let mut traffic = Traffic::new(cfg, &world, ChaCha8Rng::seed_from_u64(sub_seed(seed, 2)));
        let warm = (cfg.warmup_s / cfg.dt_s).round() as u64;
        for k in 0..warm {
            traffic.step(&world, (k as f64 + 1.0) * cfg.dt_s - cfg.warmup_s, cfg.dt_s);
        }
        traffic.release_ego(cfg.ego.mode);
        let lidar = cfg.lidar.is_enabled().then(|| Lidar::new(cfg.lidar.resolve()));
        Ok(Self {
            cfg: cfg.clone(),
            world,
            traffic,
            lidar,
            frame: 0,
            frames: cfg.frame_count(),
            last_sweep: None,
            noise_rng: ChaCha8Rng::seed_from_u64(sub_seed(seed, 3)),
            lidar_seed: sub_seed(seed, 4),
            boxes: Vec::new(),
            box_agent: Vec::new(),
        })
    }

    /// The scenario.
    #[must_use]
    pub fn config(&self) -> &ScenarioConfig {
        &self.cfg
    }

    /// Number of frames the scenario yields.
    #[must_use]
    pub fn frame_count(&self) -> u64 {
        self.frames
    }

    /// The extrinsic `ego_from_sensor` of the LiDAR (identity rotation), if the LiDAR is enabled.
    #[must_use]
    pub fn ego_from_sensor(&self) -> Option<Isometry3> {
        self.lidar.as_ref().map(|l| {
            let m = l.model();
            Isometry3::from_translation(m.forward_offset_m as f32, 0.0, m.mount_height_m as f32)
        })
    }

    /// Simulates the next frame; `None` once the scenario's duration is over.
    pub fn step(&mut self) -> Option<SimFrame> {
        if self.frame >= self.frames {
            return None;
        }
        let dt = self.cfg.dt_s;
        let t = self.frame as f64 * dt;
        if self.frame > 0 {
            self.traffic.step(&self.world, t, dt);
        }
        let ego = &self.traffic.ego;
        let pose = Pose2 { x_m: ego.x, y_m: ego.y, yaw_rad: ego.heading };
        let (sy, cy) = ego.heading.sin_cos();
        let to_ego = |x: f64, y: f64| {
            let (dx, dy) = (x - ego.x, y - ego.y);
            (cy * dx + sy * dy, -sy * dx + cy * dy)
        };
        let ego_truth = EgoTruth {
            x_m: ego.x,
            y_m: ego.y,
            yaw_rad: ego.heading,
            speed_mps: ego.speed,
            accel_mps2: ego.accel,
            yaw_rate_radps: ego.turn_rate,
        };

        // LiDAR.
        let mut hits = vec![0u32; self.traffic.agents.len()];
        let mut cloud = None;
        if let Some(lidar) = self.lidar.as_mut() {
            let m = lidar.model();
            let sweep_index = (t * m.rate_hz + 1e-6).floor() as i64;
            if self.last_sweep != Some(sweep_index) {
                self.last_sweep = Some(sweep_index);
                let (off, h) = (m.forward_offset_m, m.mount_height_m);
                self.boxes.clear();
                self.box_agent.clear();
                let n_scenery = self.world.scenery.len();
                self.boxes.extend(self.world.scenery.iter().map(|s| s.b));
                for (i, a) in self.traffic.agents.iter().enumerate() {
                    if a.active {
                        self.boxes.push(a.box3());
                        self.box_agent.push(i);
                    }
                }
                let (sx, sy_) = (ego.x + cy * off, ego.y + sy * off);
                let sweep = lidar.cast(sx, sy_, ego.heading, &self.boxes, sub_seed(self.lidar_seed, self.frame));
                for &tg in &sweep.targets {
                    if tg != GROUND && (tg as usize) >= n_scenery {
                        if let Some(&ai) = self.box_agent.get(tg as usize - n_scenery) {
                            if let Some(c) = hits.get_mut(ai) {
                                *c += 1;
                            }
                        }
                    }
                }
                cloud = Some(OwnedCloud {
                    points_in_sensor: sweep.points,
                    ego_from_sensor: Isometry3::from_translation(off as f32, 0.0, h as f32),
                });
            }
        }

        // Ground truth and object list.
        let half = self.cfg.grid_size_m / 2.0;
        let n = &self.cfg.noise;
        let sigma = n.report_sigma.then(|| Uncertainty {
            x_m: n.position_sigma_m as f32,
            y_m: n.position_sigma_m as f32,
            heading_rad: n.heading_sigma_deg.to_radians() as f32,
            speed_mps: n.speed_sigma_mps as f32,
            length_m: n.size_sigma_m as f32,
            width_m: n.size_sigma_m as f32,
        });
        let mut truth = Vec::new();
        let mut objects = Vec::new();
        for (i, a) in self.traffic.agents.iter().enumerate() {
            if !a.active {
                continue;
            }
            let (ex, ey) = to_ego(a.x, a.y);
            if ex.abs() > half + TRUTH_MARGIN_M || ey.abs() > half + TRUTH_MARGIN_M {
                continue;
            }
            let in_grid = ex.abs() <= half && ey.abs() <= half;
            let heading_ego = wrap_angle(a.heading - ego.heading);
            truth.push(TruthObject {
                id: a.id,
                class: a.class,
                parked: matches!(a.behaviour, Behaviour::Parked),
                x_m: a.x,
                y_m: a.y,
                heading_rad: a.heading,
                x_ego_m: ex,
                y_ego_m: ey,
                heading_ego_rad: heading_ego,
                speed_mps: a.speed,
                accel_mps2: a.accel,
                turn_rate_radps: a.turn_rate,
                length_m: a.size[0],
                width_m: a.size[1],
                height_m: a.size[2],
                lidar_points: hits.get(i).copied().unwrap_or(0),
                in_grid,
            });
            // List every object whose footprint can reach into the grid, so that its evidence at the grid's
            // edge is explained (the monitor judges only those wholly inside; see NotMonitoredReason::OutsideGrid).
            let reach = 0.5 * a.size[0].hypot(a.size[1]) + 1.0;
            let listed = !(self.cfg.agents.parked_as_scenery && matches!(a.behaviour, Behaviour::Parked));
            if listed && ex.abs() <= half + reach && ey.abs() <= half + reach {
                let mut o = ObjectState {
                    id: a.id,
                    class: a.class,
                    x_m: ex as f32,
                    y_m: ey as f32,
                    heading_rad: heading_ego as f32,
                    speed_mps: a.speed as f32,
                    length_m: a.size[0] as f32,
                    width_m: a.size[1] as f32,
                    uncertainty: sigma,
                };
                if n.add_noise {
                    let mut g = || -> f64 { rand::RngExt::sample(&mut self.noise_rng, StandardNormal) };
                    o.x_m = (ex + n.position_sigma_m * g()) as f32;
                    o.y_m = (ey + n.position_sigma_m * g()) as f32;
                    o.heading_rad = wrap_angle(heading_ego + n.heading_sigma_deg.to_radians() * g()) as f32;
                    o.speed_mps = (a.speed + n.speed_sigma_mps * g()).max(0.0) as f32;
                    o.length_m = (a.size[0] + n.size_sigma_m * g()).max(0.1) as f32;
                    o.width_m = (a.size[1] + n.size_sigma_m * g()).max(0.1) as f32;
                }
                objects.push(o);
            }
        }
        truth.sort_by_key(|o| o.id);
        objects.sort_by_key(|o| o.id);

        // Region of interest (carriageway and crosswalks, optionally sidewalks) and known static scenery (footprints
        // of what reaches into the height band: buildings, walls, poles, trunks), ego frame, clipped to the grid.
        let to_grid = |poly: &[[f64; 2]]| -> Option<Vec<[f32; 2]>> {
            let local: Vec<[f64; 2]> = poly
                .iter()
                .map(|p| {
                    let (x, y) = to_ego(p[0], p[1]);
                    [x, y]
                })
                .collect();
            let clipped = clip_to_square(&local, half);
            (clipped.len() >= 3).then(|| clipped.iter().map(|p| [p[0] as f32, p[1] as f32]).collect())
        };
        let sidewalks: &[Vec<[f64; 2]>] = if self.cfg.roi == RoiMode::Walkable { &self.world.sidewalks } else { &[] };
        let roi_in_ego = self.world.roi.iter().chain(sidewalks).filter_map(|p| to_grid(p)).collect();
        let mut static_in_ego = Vec::new();
        if self.cfg.agents.parked_as_scenery {
            for a in self.traffic.agents.iter().filter(|a| a.active && matches!(a.behaviour, Behaviour::Parked)) {
                let (ex, ey) = to_ego(a.x, a.y);
                let (s, c) = (a.heading - ego.heading).sin_cos();
                let (hl, hw) = (0.5 * a.size[0], 0.5 * a.size[1]);
                let corners: Vec<[f64; 2]> = [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)]
                    .iter()
                    .map(|&(u, v)| [ex + u * c - v * s, ey + u * s + v * c])
                    .collect();
                let clipped = clip_to_square(&corners, half);
                if clipped.len() >= 3 {
                    static_in_ego.push(clipped.iter().map(|p| [p[0] as f32, p[1] as f32]).collect());
                }
            }
        }
        if self.cfg.static_scenery {
            let reach = half * std::f64::consts::SQRT_2;
            for s in &self.world.scenery {
                let b = &s.b;
                if s.kind == SceneryKind::TreeCanopy || (b.cx - ego.x).hypot(b.cy - ego.y) > reach + b.half_l + b.half_w
                {
                    continue;
                }
                if let Some(p) = to_grid(&b.corners()) {
                    static_in_ego.push(p);
                }
            }
        }

        let frame = RecordedFrame {
            index: self.frame,
            timestamp_s: t,
            world_from_ego: pose,
            objects,
            cloud,
            roi_in_ego,
            static_in_ego,
        };
        self.frame += 1;
        Some(SimFrame { frame, truth, ego: ego_truth })
    }
}

/// What [`simulate_to_dir`] wrote.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// The recording directory.
    pub out_dir: PathBuf,
    /// Frames written.
    pub frames: u64,
    /// Frames that carry a LiDAR sweep.
    pub clouds: u64,
    /// LiDAR points written, all frames.
    pub points: u64,
    /// Object states in the object lists (agents and parked cars in the grid), all frames.
    pub object_states: u64,
    /// Of those, states of moving road users (not parked cars).
    pub moving_object_states: u64,
}

#[derive(Serialize)]
struct TruthLine<'a> {
    frame: u64,
    timestamp_s: f64,
    ego: &'a EgoTruth,
    objects: &'a [TruthObject],
}

/// Simulates a whole scenario into `out_dir`: a pmon recording (`recording.json`, `frames.jsonl`, `clouds/`) plus
/// `truth.jsonl` (one line per frame: `frame`, `timestamp_s`, `ego`, `objects` as [`TruthObject`]s).
/// `progress(done, total)` is called after each frame.
///
/// # Errors
/// An invalid scenario, or I/O errors naming the file.
pub fn simulate_to_dir(
    config: &ScenarioConfig,
    out_dir: &Path,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Summary, ScenarioError> {
    let mut sim = Simulator::new(config)?;
    let meta = RecordingMeta::new(
        config.name.clone(),
        format!("pmon-scenario {} (layout {:?}, seed {})", config.name, config.layout, config.seed),
    );
    let mut writer = RecordingWriter::create(out_dir, meta)?;
    let truth_path = out_dir.join("truth.jsonl");
    let io_err = |source| ScenarioError::Io { path: truth_path.clone(), source };
    let mut truth = BufWriter::new(File::create(&truth_path).map_err(io_err)?);
    let total = sim.frame_count();
    let mut summary = Summary {
        out_dir: out_dir.to_path_buf(),
        frames: 0,
        clouds: 0,
        points: 0,
        object_states: 0,
        moving_object_states: 0,
    };
    while let Some(f) = sim.step() {
        writer.write_frame(&f.frame)?;
        let line = TruthLine { frame: f.frame.index, timestamp_s: f.frame.timestamp_s, ego: &f.ego, objects: &f.truth };
        let text = serde_json::to_string(&line).map_err(|e| io_err(std::io::Error::other(e)))?;
        writeln!(truth, "{text}").map_err(io_err)?;
        summary.frames += 1;
        if let Some(c) = &f.frame.cloud {
            summary.clouds += 1;
            summary.points += c.points_in_sensor.len() as u64;
        }
        summary.object_states += f.frame.objects.len() as u64;
        summary.moving_object_states += f.truth.iter().filter(|o| o.in_grid && !o.parked).count() as u64;
        progress(summary.frames, total);
    }
    truth.flush().map_err(io_err)?;
    writer.finish()?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inside_convex(poly: &[[f64; 2]], p: [f64; 2]) -> bool {
        let n = poly.len();
        let sign = |i: usize| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
        };
        (0..n).all(|i| sign(i) >= 0.0) || (0..n).all(|i| sign(i) <= 0.0)
    }

    #[test]
    fn canopy_points_are_above_the_height_band() {
        let cfg = ScenarioConfig::builtin("pedestrians").unwrap();
        let sim = Simulator::new(&cfg).unwrap();
        let boxes: Vec<Box3> = sim.world.scenery.iter().map(|s| s.b).collect();
        let model = cfg.lidar.resolve();
        let h = model.mount_height_m as f32;
        let mut lidar = Lidar::new(model);
        let mut canopy_points = 0;
        for k in 0..12 {
            let x = -150.0 + 20.0 * f64::from(k);
            let sweep = lidar.cast(x, -1.75, 0.0, &boxes, k as u64);
            for (p, &t) in sweep.points.iter().zip(&sweep.targets) {
                if t == GROUND {
                    continue;
                }
                if sim.world.scenery[t as usize].kind == SceneryKind::TreeCanopy {
                    canopy_points += 1;
                    // Ego frame height (ground at 0): above the monitor's default band (0.3 .. 2.5 m).
                    assert!(p[2] + h > 2.5, "canopy point at {} m", p[2] + h);
                }
            }
        }
        assert!(canopy_points > 1000, "{canopy_points}");
    }

    #[test]
    fn roi_covers_carriageway_not_scenery() {
        for name in crate::BUILTIN_NAMES {
            let cfg = ScenarioConfig::builtin(name).unwrap();
            let sim = Simulator::new(&cfg).unwrap();
            let in_roi = |p: [f64; 2]| sim.world.roi.iter().any(|poly| inside_convex(poly, p));
            for s in &sim.world.scenery {
                if s.kind != SceneryKind::TreeCanopy {
                    assert!(!in_roi([s.b.cx, s.b.cy]), "{name}: {:?} at {} {} in the ROI", s.kind, s.b.cx, s.b.cy);
                }
            }
            for b in &sim.world.parked {
                assert!(in_roi([b.cx, b.cy]), "{name}: parked car outside the ROI");
            }
            // The ego lane is in the ROI.
            assert!(in_roi([sim.traffic.ego.x, sim.traffic.ego.y]));
        }
    }

    #[test]
    fn vehicles_do_not_collide() {
        for name in crate::BUILTIN_NAMES {
            let mut cfg = ScenarioConfig::builtin(name).unwrap();
            cfg.lidar.enabled = Some(false);
            let mut sim = Simulator::new(&cfg).unwrap();
            let (mut veh_veh, mut veh_ped, mut states) = (0, 0, 0);
            while sim.step().is_some() {
                let all: Vec<&crate::traffic::Agent> =
                    std::iter::once(&sim.traffic.ego).chain(sim.traffic.agents.iter()).filter(|a| a.active).collect();
                let is_veh = |a: &crate::traffic::Agent| matches!(a.behaviour, Behaviour::Vehicle(_));
                for (i, a) in all.iter().enumerate() {
                    if !is_veh(a) {
                        continue;
                    }
                    states += 1;
                    for b in all.iter().skip(i + 1) {
                        if (a.x - b.x).hypot(a.y - b.y) > 15.0 || !a.box3().overlaps_xy(&b.box3(), -0.05) {
                            continue;
                        }
                        match b.behaviour {
                            Behaviour::Vehicle(_) | Behaviour::Parked => veh_veh += 1,
                            Behaviour::Pedestrian(_) => veh_ped += 1,
                        }
                    }
                }
            }
            // Rare contacts are tolerated (no collision avoidance is perfect), not more.
            assert!(veh_veh * 1000 <= states, "{name}: {veh_veh} vehicle overlaps in {states} vehicle states");
            assert!(
                veh_ped * 1000 <= states,
                "{name}: {veh_ped} vehicle-pedestrian overlaps in {states} vehicle states"
            );
            eprintln!("{name}: {veh_veh} vehicle and {veh_ped} pedestrian overlaps in {states} vehicle states");
        }
    }

    #[test]
    fn object_noise_is_seeded_and_reported() {
        let mut cfg = ScenarioConfig::builtin("intersection").unwrap();
        cfg.lidar.enabled = Some(false);
        cfg.duration_s = 0.5;
        cfg.noise.add_noise = true;
        cfg.noise.position_sigma_m = 0.3;
        let frames = |cfg: &ScenarioConfig| {
            let mut sim = Simulator::new(cfg).unwrap();
            std::iter::from_fn(move || sim.step()).collect::<Vec<_>>()
        };
        let a = frames(&cfg);
        assert_eq!(a, frames(&cfg));
        let mut dev = 0.0;
        let mut n = 0.0;
        for f in &a {
            for o in &f.frame.objects {
                let t = f.truth.iter().find(|t| t.id == o.id).unwrap();
                dev += (f64::from(o.x_m) - t.x_ego_m).powi(2);
                n += 1.0;
                assert!((o.uncertainty.unwrap().x_m - 0.3).abs() < 1e-6);
            }
        }
        let sd = (dev / n).sqrt();
        assert!((sd - 0.3).abs() < 0.05, "{sd}");
    }
}
