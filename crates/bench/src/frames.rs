//! Deterministic frames for the latency benchmarks: a synthetic LiDAR scene, the real sweeps of the shared data,
//! and the floor (the time to read every point once).
//!
//! This file is compiled twice: as `pmon_bench::frames`, and through `#[path]` into the divan benchmarks of
//! `pmon-monitor` (`crates/monitor/benches/monitor.rs`), which may depend on nothing but `pmon-monitor` and
//! `divan`. Hence it uses only `core`, `std` and `pmon_monitor`, draws its random numbers from a local SplitMix64
//! instead of `rand_chacha`, and follows the monitor crate's strict lints (no indexing, no unwrap, no panics).
//!
//! # The synthetic scene
//! A sensor [`SENSOR_HEIGHT_M`] above the ego origin casts `beams x azimuth_steps` rays, one per beam and
//! azimuth step. Beam `k` points down so that it meets the flat ground on a ring of radius `r_k` (radii spaced
//! geometrically from [`MIN_RING_RANGE_M`] to [`MAX_RING_RANGE_M`]); every ray returns exactly one point, so a
//! frame has exactly `beams * azimuth_steps` points (64 x 1875 = 120,000 like a 64-beam sweep, 32 x 1085 = 34,720
//! like the 32-beam nuScenes sweep). A ray that meets a box before the ground returns from the box's visible
//! face (or roof): boxes cast shadows. Points are stored beam by beam (ring after ring), like a KITTI sweep.
//!
//! The world holds the listed objects (cars, trucks, pedestrians) moving at constant speed and heading, plus
//! unlisted clutter boxes (evidence no object explains). The object list is the truth except that every 20th
//! object is a ghost (listed, absent from the world) and every 20th is reported displaced by
//! [`DISPLACEMENT_M`] sideways: all verdicts and every stage of the monitor get work.

use core::f32::consts::TAU;
use std::path::{Path, PathBuf};

use pmon_monitor::{Frame, Isometry3, ObjectClass, ObjectState, PointCloud, Pose2};

/// Height of the synthetic sensor above the ground, metres.
pub const SENSOR_HEIGHT_M: f32 = 1.8;
/// Height of the KITTI Velodyne above the ground (ground near z = -1.73 m in its frame), metres.
pub const KITTI_SENSOR_HEIGHT_M: f32 = 1.73;
/// Height of the nuScenes LIDAR_TOP above the ground (ground near z = -1.8 m in its frame), metres.
pub const NUSCENES_SENSOR_HEIGHT_M: f32 = 1.8;
/// Ground range of the steepest beam, metres.
pub const MIN_RING_RANGE_M: f32 = 3.5;
/// Ground range of the flattest beam, metres.
pub const MAX_RING_RANGE_M: f32 = 70.0;
/// Objects are placed with their centre at this distance or more from the ego origin, metres.
pub const MIN_OBJECT_RANGE_M: f32 = 5.0;
/// Objects are placed with their centre at this distance or less (at 10 m/s for 0.5 s they stay inside the
/// paper's 100 m x 100 m grid), metres.
pub const MAX_OBJECT_RANGE_M: f32 = 36.0;
/// Sideways offset of the displaced objects in the object list, metres.
pub const DISPLACEMENT_M: f32 = 1.5;
/// Time between consecutive frames of a sequence, seconds.
pub const FRAME_PERIOD_S: f64 = 0.1;

/// Size of a synthetic sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyntheticSpec {
    /// LiDAR beams (rings); 0 for frames without a cloud.
    pub beams: u32,
    /// Rays per beam and sweep.
    pub azimuth_steps: u32,
    /// Objects in the object list.
    pub objects: u32,
    /// Frames in the sequence (objects move from frame to frame; the benchmarks cycle through them).
    pub frames: u32,
    /// Seed of the scene.
    pub seed: u64,
}

impl SyntheticSpec {
    /// A 64-beam sweep (120,000 points) with 100 objects.
    pub const BEAMS_64: Self = Self { beams: 64, azimuth_steps: 1875, objects: 100, frames: 6, seed: 64 };
    /// A 32-beam sweep (34,720 points) with 30 objects.
    pub const BEAMS_32: Self = Self { beams: 32, azimuth_steps: 1085, objects: 30, frames: 6, seed: 32 };
    /// The largest frame the paper parameters accept: 400,000 points (`max_points`) and 1,024 objects
    /// (`max_objects`).
    pub const WORST_CASE: Self = Self { beams: 128, azimuth_steps: 3125, objects: 1024, frames: 2, seed: 400 };

    /// Object lists only (no cloud): the plausibility checks alone.
    #[must_use]
    pub const fn objects_only(objects: u32) -> Self {
        Self { beams: 0, azimuth_steps: 0, objects, frames: 6, seed: 7 }
    }

    /// Points per frame.
    #[must_use]
    pub const fn points(&self) -> u64 {
        self.beams as u64 * self.azimuth_steps as u64
    }
}

/// A sweep: points in the sensor frame and the extrinsic.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// Where it came from (`synthetic`, or the file name).
    pub label: String,
    /// Points `[x, y, z]` in the sensor frame, metres.
    pub points_in_sensor: Vec<[f32; 3]>,
    /// Extrinsic `ego_from_sensor`.
    pub ego_from_sensor: Isometry3,
    /// The frame's region of interest, ego frame (empty: the whole grid). The Argoverse 2 sweeps carry their log's
    /// vector map; see [`Sequence::frame_with_roi`].
    pub roi_in_ego: Vec<Vec<[f32; 2]>>,
}

/// One frame of a sequence: an object list and the index of its sweep (if any).
#[derive(Clone, Debug, PartialEq)]
pub struct SequenceFrame {
    /// The object list, ego frame.
    pub objects: Vec<ObjectState>,
    /// Index into [`Sequence::sweeps`], `None` for a frame without a cloud.
    pub sweep: Option<usize>,
    /// The ego pose (`Pose2::default()`, the identity, except in [`Sequence::steady_traffic`], whose ego drives).
    pub world_from_ego: Pose2,
}

/// Frames the benchmarks cycle through, with their sweeps stored once.
#[derive(Clone, Debug, PartialEq)]
pub struct Sequence {
    /// Name, for reports.
    pub name: String,
    /// The sweeps.
    pub sweeps: Vec<Sweep>,
    /// The frames, in time order; frame `k` is at `k * FRAME_PERIOD_S`.
    pub frames: Vec<SequenceFrame>,
}

impl Sequence {
    /// The monitor's view of frame `k % frames.len()` at `timestamp_s` (the caller keeps timestamps increasing
    /// when it cycles; after a wrap the objects jump back, which the plausibility checks flag for one frame).
    /// `None` for an empty sequence.
    #[must_use]
    pub fn frame(&self, k: usize, timestamp_s: f64) -> Option<Frame<'_>> {
        let n = self.frames.len();
        if n == 0 {
            return None;
        }
        let f = self.frames.get(k % n)?;
        let cloud = f
            .sweep
            .and_then(|s| self.sweeps.get(s))
            .map(|s| PointCloud { points_in_sensor: &s.points_in_sensor, ego_from_sensor: s.ego_from_sensor });
        Some(Frame {
            timestamp_s,
            world_from_ego: f.world_from_ego,
            objects: &f.objects,
            cloud,
            roi_in_ego: &[],
            static_in_ego: &[],
        })
    }

    /// [`Sequence::frame`] with its sweep's region of interest, lent through `roi` (scratch space, filled here).
    #[must_use]
    pub fn frame_with_roi<'a>(
        &'a self,
        k: usize,
        timestamp_s: f64,
        roi: &'a mut Vec<&'a [[f32; 2]]>,
    ) -> Option<Frame<'a>> {
        let f = self.frame(k, timestamp_s)?;
        let sweep = self.frames.get(k % self.frames.len())?.sweep.and_then(|s| self.sweeps.get(s));
        roi.clear();
        roi.extend(sweep.iter().flat_map(|s| s.roi_in_ego.iter().map(Vec::as_slice)));
        Some(Frame { roi_in_ego: roi.as_slice(), ..f })
    }

    /// The same frame without its cloud (plausibility checks only).
    #[must_use]
    pub fn frame_without_cloud(&self, k: usize, timestamp_s: f64) -> Option<Frame<'_>> {
        self.frame(k, timestamp_s).map(|f| Frame { cloud: None, ..f })
    }

    /// Timestamp of iteration `i` when cycling: `i * FRAME_PERIOD_S`.
    #[must_use]
    pub fn timestamp_s(i: usize) -> f64 {
        i as f64 * FRAME_PERIOD_S
    }

    /// Each sweep's points as three columns `[x, y, z]` (for [`pmon_monitor::PointColumns`]), in sweep order.
    #[must_use]
    pub fn sweep_columns(&self) -> Vec<[Vec<f32>; 3]> {
        self.sweeps
            .iter()
            .map(|s| {
                let p = &s.points_in_sensor;
                [p.iter().map(|p| p[0]).collect(), p.iter().map(|p| p[1]).collect(), p.iter().map(|p| p[2]).collect()]
            })
            .collect()
    }

    /// Largest number of points of a sweep.
    #[must_use]
    pub fn max_points(&self) -> usize {
        self.sweeps.iter().map(|s| s.points_in_sensor.len()).max().unwrap_or(0)
    }

    /// Largest number of objects of a frame.
    #[must_use]
    pub fn max_objects(&self) -> usize {
        self.frames.iter().map(|f| f.objects.len()).max().unwrap_or(0)
    }

    /// A synthetic sequence (see the module documentation).
    #[must_use]
    pub fn synthetic(spec: &SyntheticSpec) -> Self {
        let world = World::new(spec);
        let mut sweeps = Vec::new();
        let mut frames = Vec::new();
        for k in 0..spec.frames {
            let t = (f64::from(k) * FRAME_PERIOD_S) as f32;
            let sweep = if spec.points() > 0 {
                sweeps.push(Sweep {
                    label: "synthetic".to_string(),
                    points_in_sensor: world.cast(spec, t),
                    ego_from_sensor: Isometry3::from_translation(0.0, 0.0, SENSOR_HEIGHT_M),
                    roi_in_ego: Vec::new(),
                });
                Some(sweeps.len() - 1)
            } else {
                None
            };
            frames.push(SequenceFrame { objects: world.object_list(t), sweep, world_from_ego: Pose2::default() });
        }
        let name = if spec.points() > 0 {
            format!("synthetic {}-beam, {} objects", spec.beams, spec.objects)
        } else {
            format!("object list only, {} objects", spec.objects)
        };
        Self { name, sweeps, frames }
    }

    /// Real sweeps with the object lists of a synthetic spec (`objects.beams` is ignored): frame `k` has sweep
    /// `k % sweeps` and the synthetic objects at time `k * FRAME_PERIOD_S`. The objects do not match the scene:
    /// most are evidence-free, so the occlusion test runs for nearly all of them (a heavy case for the verdict
    /// stage). `None` when `sweeps` is empty.
    #[must_use]
    pub fn real(name: &str, sweeps: Vec<Sweep>, objects: &SyntheticSpec) -> Option<Self> {
        if sweeps.is_empty() {
            return None;
        }
        let spec = SyntheticSpec { beams: 0, azimuth_steps: 0, ..*objects };
        let world = World::new(&spec);
        let n = spec.frames.max(u32::try_from(sweeps.len()).unwrap_or(u32::MAX));
        let frames = (0..n)
            .map(|k| SequenceFrame {
                objects: world.object_list((f64::from(k) * FRAME_PERIOD_S) as f32),
                sweep: Some(k as usize % sweeps.len()),
                world_from_ego: Pose2::default(),
            })
            .collect();
        Some(Self { name: name.to_string(), sweeps, frames })
    }
}

/// Frames of one period of [`Sequence::steady_traffic`] (30 s at [`FRAME_PERIOD_S`]): every object and the ego
/// are back where they started after it, so the sequence cycles without a jump.
pub const STEADY_PERIOD_FRAMES: u32 = 300;
/// Radius of the ego's circle in [`Sequence::steady_traffic`], metres.
pub const STEADY_EGO_RADIUS_M: f64 = 5.0;
/// Objects of [`Sequence::steady_traffic`] stay within this distance of the world origin (the centre of the ego's
/// circle), metres: their centres stay within 41 m of the ego, inside the paper's 100 m grid.
pub const STEADY_RANGE_M: f64 = 36.0;

impl Sequence {
    /// Steady traffic, object lists only (no cloud): `objects` road users (cars, trucks, pedestrians as in the
    /// synthetic scene) each drive on a circle of their own (radius 2.4-30 m) at a speed that varies smoothly about
    /// its mean (`v(t) = v_mean + A sin(2 pi m t / T + phi)`, `|dv/dt| < 1 m/s^2`, lateral acceleration at most
    /// about 6 m/s^2), seen from an ego that drives on a circle of [`STEADY_EGO_RADIUS_M`] (one lap per period).
    /// Every object's heading changes from frame to frame, and so do its speed (but for the odd frame at the top or
    /// bottom of its cycle, where two speeds may round to one `f32`) and the ego's pose: the arguments of the
    /// monitor's `sincos` and `exp` do not repeat as in the 6-frame cycle. One period of [`STEADY_PERIOD_FRAMES`] frames (`T` = 30 s) holds
    /// whole laps and whole speed cycles, so frame `T` is frame 0 again (up to rounding) and cycling the frames with
    /// increasing timestamps shows the monitor continuous motion with no jump, also at the wrap: an alarm-free
    /// case, unlike the 6-frame cycle of [`SyntheticSpec::objects_only`], whose objects jump back every 6th frame.
    #[must_use]
    pub fn steady_traffic(objects: u32, seed: u64) -> Self {
        use core::f64::consts::{FRAC_PI_2, PI, TAU as TAU64};
        let period_s = f64::from(STEADY_PERIOD_FRAMES) * FRAME_PERIOD_S;
        let mut rng = SplitMix64(seed);
        struct Mover {
            id: u64,
            class: ObjectClass,
            length_m: f32,
            width_m: f32,
            centre: (f64, f64),
            radius_m: f64,
            /// +1 counter-clockwise, -1 clockwise.
            dir: f64,
            theta0: f64,
            v_mean: f64,
            amp: f64,
            cycles: f64,
            phase: f64,
        }
        impl Mover {
            /// Position and heading in the world, and speed, at `t`.
            fn at(&self, t: f64, period_s: f64) -> (f64, f64, f64, f64) {
                let w = TAU64 * self.cycles / period_s;
                let v = self.v_mean + self.amp * (w * t + self.phase).sin();
                let s = self.v_mean * t - self.amp / w * ((w * t + self.phase).cos() - self.phase.cos());
                let theta = self.theta0 + self.dir * s / self.radius_m;
                let (st, ct) = theta.sin_cos();
                (
                    self.centre.0 + self.radius_m * ct,
                    self.centre.1 + self.radius_m * st,
                    theta + self.dir * FRAC_PI_2,
                    v,
                )
            }
        }
        let movers: Vec<Mover> = (0..objects)
            .map(|i| {
                let r = |rng: &mut SplitMix64, lo: f32, hi: f32| f64::from(rng.range(lo, hi));
                let (class, length_m, width_m, v_mean, r_target) = match i % 10 {
                    6 => (ObjectClass::Truck, rng.range(6.0, 9.0), rng.range(2.3, 2.6), r(&mut rng, 2.0, 8.0), 20.0),
                    7..=9 => {
                        (ObjectClass::Pedestrian, rng.range(0.5, 0.8), rng.range(0.5, 0.8), r(&mut rng, 0.5, 1.5), 6.0)
                    }
                    _ => (ObjectClass::Car, rng.range(4.2, 4.8), rng.range(1.8, 2.0), r(&mut rng, 3.0, 10.0), 25.0),
                };
                // Whole laps per period: the radius nearest `r_target` (at most 30 m) with `2 pi radius laps =
                // v_mean T`.
                let per_lap = v_mean * period_s / TAU64;
                let laps = (per_lap / r_target).round().max((per_lap / 30.0).ceil()).max(1.0);
                let radius_m = per_lap / laps;
                // The centre: the whole circle within STEADY_RANGE_M of the origin.
                let room = (STEADY_RANGE_M - radius_m).max(0.0);
                let (sa, ca) = r(&mut rng, -PI as f32, PI as f32).sin_cos();
                let d = room * r(&mut rng, 0.0, 1.0).sqrt();
                let amp = (0.3 * v_mean).min(1.5);
                let cycles = f64::from(1 + (i % 3));
                let dir = if rng.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
                Mover {
                    id: u64::from(i) + 1,
                    class,
                    length_m,
                    width_m,
                    centre: (d * ca, d * sa),
                    radius_m,
                    dir,
                    theta0: r(&mut rng, -PI as f32, PI as f32),
                    v_mean,
                    amp,
                    cycles,
                    phase: r(&mut rng, -PI as f32, PI as f32),
                }
            })
            .collect();
        let ego = Mover {
            id: 0,
            class: ObjectClass::Car,
            length_m: 0.0,
            width_m: 0.0,
            centre: (0.0, 0.0),
            radius_m: STEADY_EGO_RADIUS_M,
            dir: 1.0,
            theta0: 0.0,
            v_mean: TAU64 * STEADY_EGO_RADIUS_M / period_s,
            amp: 0.0,
            cycles: 1.0,
            phase: 0.0,
        };
        let frames = (0..STEADY_PERIOD_FRAMES)
            .map(|k| {
                let t = f64::from(k) * FRAME_PERIOD_S;
                let (ex, ey, eyaw, _) = ego.at(t, period_s);
                let (s, c) = eyaw.sin_cos();
                let objects = movers
                    .iter()
                    .map(|m| {
                        let (x, y, h, v) = m.at(t, period_s);
                        let (dx, dy) = (x - ex, y - ey);
                        // World -> ego: the inverse rotation; the heading relative to the ego's, in (-pi, pi].
                        let rel = (h - eyaw).rem_euclid(TAU64);
                        ObjectState {
                            id: m.id,
                            class: m.class,
                            x_m: (c * dx + s * dy) as f32,
                            y_m: (-s * dx + c * dy) as f32,
                            heading_rad: (if rel > PI { rel - TAU64 } else { rel }) as f32,
                            speed_mps: v as f32,
                            length_m: m.length_m,
                            width_m: m.width_m,
                            uncertainty: None,
                        }
                    })
                    .collect();
                SequenceFrame {
                    objects,
                    sweep: None,
                    world_from_ego: Pose2 { x_m: ex, y_m: ey, yaw_rad: (eyaw + PI).rem_euclid(TAU64) - PI },
                }
            })
            .collect();
        Self {
            name: format!(
                "steady traffic, object list only, {objects} objects on circles, moving ego, {STEADY_PERIOD_FRAMES} \
                 frames cycled without a jump"
            ),
            sweeps: Vec::new(),
            frames,
        }
    }
}

/// SplitMix64 (Steele, Lea, Flood 2014): a tiny, well-mixed, seeded generator.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        let unit = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        lo + (hi - lo) * unit
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    /// Listed and present.
    Listed,
    /// Listed, absent from the world.
    Ghost,
    /// Listed displaced sideways.
    Displaced,
    /// Present, not listed.
    Clutter,
}

#[derive(Clone, Copy, Debug)]
struct Body {
    role: Role,
    id: u64,
    class: ObjectClass,
    x0_m: f32,
    y0_m: f32,
    heading_rad: f32,
    speed_mps: f32,
    length_m: f32,
    width_m: f32,
    height_m: f32,
}

impl Body {
    fn center_at(&self, t_s: f32) -> (f32, f32) {
        let (s, c) = self.heading_rad.sin_cos();
        (self.x0_m + c * self.speed_mps * t_s, self.y0_m + s * self.speed_mps * t_s)
    }

    /// Horizontal distances at which a ray from the origin along `(dx, dy)` enters and leaves the box.
    fn ray_interval(&self, t_s: f32, dx: f32, dy: f32) -> Option<(f32, f32)> {
        let (cx, cy) = self.center_at(t_s);
        let (s, c) = self.heading_rad.sin_cos();
        // Origin and direction in box coordinates.
        let (px, py) = (-cx * c - cy * s, cx * s - cy * c);
        let (ux, uy) = (dx * c + dy * s, -dx * s + dy * c);
        let mut lo = f32::NEG_INFINITY;
        let mut hi = f32::INFINITY;
        for (p, u, h) in [(px, ux, 0.5 * self.length_m), (py, uy, 0.5 * self.width_m)] {
            if u.abs() < 1e-9 {
                if p.abs() > h {
                    return None;
                }
            } else {
                let (a, b) = ((-h - p) / u, (h - p) / u);
                lo = lo.max(a.min(b));
                hi = hi.min(a.max(b));
            }
        }
        (lo > 0.0 && hi >= lo).then_some((lo, hi))
    }
}

struct World {
    bodies: Vec<Body>,
}

impl World {
    fn new(spec: &SyntheticSpec) -> Self {
        let mut rng = SplitMix64(spec.seed);
        let clutter = if spec.beams > 0 { (spec.objects / 10).max(1) } else { 0 };
        let mut bodies: Vec<Body> = Vec::new();
        for i in 0..spec.objects + clutter {
            let (role, class, length_m, width_m, height_m, speed_mps) = if i >= spec.objects {
                (Role::Clutter, ObjectClass::Other, rng.range(2.0, 6.0), rng.range(0.5, 2.0), 1.2, 0.0)
            } else {
                let role = match i % 20 {
                    7 => Role::Ghost,
                    13 => Role::Displaced,
                    _ => Role::Listed,
                };
                match i % 10 {
                    6 => (role, ObjectClass::Truck, rng.range(6.0, 9.0), rng.range(2.3, 2.6), 3.0, rng.range(0.0, 8.0)),
                    7..=9 => (
                        role,
                        ObjectClass::Pedestrian,
                        rng.range(0.5, 0.8),
                        rng.range(0.5, 0.8),
                        1.7,
                        rng.range(0.0, 1.5),
                    ),
                    _ => (role, ObjectClass::Car, rng.range(4.2, 4.8), rng.range(1.8, 2.0), 1.5, rng.range(0.0, 10.0)),
                }
            };
            let radius = 0.5 * length_m.hypot(width_m);
            // Uniform in the annulus' area; a few attempts to avoid overlapping an earlier body, then accept.
            let mut place = (0.0, 0.0);
            for _ in 0..64 {
                let r2 = rng.range(MIN_OBJECT_RANGE_M * MIN_OBJECT_RANGE_M, MAX_OBJECT_RANGE_M * MAX_OBJECT_RANGE_M);
                let a = rng.range(0.0, TAU);
                let (s, c) = a.sin_cos();
                place = (r2.sqrt() * c, r2.sqrt() * s);
                let free = bodies.iter().all(|b| {
                    let other = 0.5 * b.length_m.hypot(b.width_m);
                    (b.x0_m - place.0).hypot(b.y0_m - place.1) > radius + other + 0.3
                });
                if free {
                    break;
                }
            }
            bodies.push(Body {
                role,
                id: u64::from(i) + 1,
                class,
                x0_m: place.0,
                y0_m: place.1,
                heading_rad: rng.range(-core::f32::consts::PI, core::f32::consts::PI),
                speed_mps,
                length_m,
                width_m,
                height_m,
            });
        }
        Self { bodies }
    }

    fn object_list(&self, t_s: f32) -> Vec<ObjectState> {
        self.bodies
            .iter()
            .filter(|b| b.role != Role::Clutter)
            .map(|b| {
                let (mut x, mut y) = b.center_at(t_s);
                if b.role == Role::Displaced {
                    let (s, c) = b.heading_rad.sin_cos();
                    x -= s * DISPLACEMENT_M;
                    y += c * DISPLACEMENT_M;
                }
                ObjectState {
                    id: b.id,
                    class: b.class,
                    x_m: x,
                    y_m: y,
                    heading_rad: b.heading_rad,
                    speed_mps: b.speed_mps,
                    length_m: b.length_m,
                    width_m: b.width_m,
                    uncertainty: None,
                }
            })
            .collect()
    }

    /// Casts the sweep at time `t_s`; points in the sensor frame, beam by beam.
    fn cast(&self, spec: &SyntheticSpec, t_s: f32) -> Vec<[f32; 3]> {
        let beams = spec.beams as usize;
        let steps = spec.azimuth_steps as usize;
        let h = SENSOR_HEIGHT_M;
        // Beam k meets the ground at range r_k; its slope (metres down per metre out) is h / r_k.
        let ratio = MAX_RING_RANGE_M / MIN_RING_RANGE_M;
        let ranges: Vec<f32> = (0..beams)
            .map(|k| {
                let f = if beams > 1 { k as f32 / (beams - 1) as f32 } else { 0.0 };
                MIN_RING_RANGE_M * ratio.powf(f)
            })
            .collect();
        let present: Vec<&Body> = self.bodies.iter().filter(|b| b.role != Role::Ghost).collect();
        let mut points = vec![[0.0f32; 3]; beams * steps];
        let mut hits: Vec<(f32, f32, f32)> = Vec::new();
        for a in 0..steps {
            let az = a as f32 * TAU / steps as f32;
            let (dy, dx) = az.sin_cos();
            hits.clear();
            hits.extend(
                present.iter().filter_map(|b| b.ray_interval(t_s, dx, dy).map(|(lo, hi)| (lo, hi, b.height_m))),
            );
            hits.sort_by(|p, q| p.0.total_cmp(&q.0));
            for (k, &r_ground) in ranges.iter().enumerate() {
                let slope = h / r_ground;
                let mut range = r_ground;
                let mut z = 0.0;
                for &(lo, hi, top) in &hits {
                    if lo >= range {
                        break;
                    }
                    let z_face = h - slope * lo;
                    if z_face <= top {
                        (range, z) = (lo, z_face);
                        break;
                    }
                    // Passes above the near face: it may come down on the roof.
                    let t_roof = (h - top) / slope;
                    if t_roof <= hi && t_roof < range {
                        (range, z) = (t_roof, top);
                        break;
                    }
                }
                if let Some(p) = points.get_mut(k * steps + a) {
                    *p = [range * dx, range * dy, z - h];
                }
            }
        }
        points
    }
}

/// The folder of the shared real data: `PMON_DATA_DIR`, else `<workspace>/../shared/data`.
#[must_use]
pub fn data_dir() -> PathBuf {
    std::env::var_os("PMON_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"))
}

/// Reads a sweep of little-endian f32 records of `stride` values, keeping the first three (`x, y, z`).
///
/// # Errors
/// I/O errors and a size that is not a whole number of records, as a message naming the file.
pub fn read_sweep(path: &Path, stride: usize) -> Result<Vec<[f32; 3]>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let record = 4 * stride.max(3);
    if bytes.is_empty() || bytes.len() % record != 0 {
        return Err(format!(
            "{}: {} bytes is not a whole number of {record}-byte points ({} f32 each)",
            path.display(),
            bytes.len(),
            stride.max(3)
        ));
    }
    let f =
        |c: &[u8], i: usize| c.get(4 * i..4 * i + 4).and_then(|b| b.try_into().ok()).map_or(0.0, f32::from_le_bytes);
    Ok(bytes.chunks_exact(record).map(|c| [f(c, 0), f(c, 1), f(c, 2)]).collect())
}

/// Files in `dir` whose names end with `suffix`, sorted by name; empty when the folder is absent.
#[must_use]
pub fn files_ending(dir: &Path, suffix: &str) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut files: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.ends_with(suffix)))
        .collect();
    files.sort();
    files
}

/// The KITTI sweeps `kitti/object/training/velodyne/*.bin` (N x 4 f32), sensor 1.73 m above the ground.
///
/// # Errors
/// A present but malformed file.
pub fn kitti_sweeps(data: &Path) -> Result<Vec<Sweep>, String> {
    sweeps(&data.join("kitti/object/training/velodyne"), ".bin", 4, KITTI_SENSOR_HEIGHT_M)
}

/// The nuScenes sweeps `nuscenes/*.pcd.bin` (N x 5 f32), sensor 1.8 m above the ground.
///
/// # Errors
/// A present but malformed file.
pub fn nuscenes_sweeps(data: &Path) -> Result<Vec<Sweep>, String> {
    sweeps(&data.join("nuscenes"), ".pcd.bin", 5, NUSCENES_SENSOR_HEIGHT_M)
}

fn sweeps(dir: &Path, suffix: &str, stride: usize, height_m: f32) -> Result<Vec<Sweep>, String> {
    files_ending(dir, suffix)
        .into_iter()
        .map(|path| {
            Ok(Sweep {
                label: path.file_name().and_then(|n| n.to_str()).unwrap_or("?").to_string(),
                points_in_sensor: read_sweep(&path, stride)?,
                ego_from_sensor: Isometry3::from_translation(0.0, 0.0, height_m),
                roi_in_ego: Vec::new(),
            })
        })
        .collect()
}

/// The floor: the sum of every coordinate of every point, in eight independent accumulators so that the loop
/// is bound by reading the points, not by the latency of one chain of additions.
#[must_use]
pub fn coordinate_sum(points: &[[f32; 3]]) -> f32 {
    let mut acc = [[0.0f32; 3]; 8];
    let chunks = points.chunks_exact(8);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (a, p) in acc.iter_mut().zip(chunk) {
            a[0] += p[0];
            a[1] += p[1];
            a[2] += p[2];
        }
    }
    let mut sum: f32 = acc.iter().flatten().sum();
    for p in rest {
        sum += p[0] + p[1] + p[2];
    }
    sum
}
