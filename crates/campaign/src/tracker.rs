//! A tracker-behaviour model: what a real multi-object tracker does to a ground-truth object list, seeded and
//! documented, with every injected behaviour recorded as benign or as an error with its size.
//!
//! Real trackers (issue #11) report speed 0 in a track's first frames (velocity not initialised), re-fit boxes
//! (the centre moves by half the size change while the object does not), jitter on standing objects, give
//! headings that are noise at standstill, switch ids, and now and then flip the heading by pi, jump the box or
//! drop the speed. [`TrackerModel`] applies these to clean frames; [`TrackerLabel`] says for each object state
//! what was done and whether it is *benign* (the paper's safety-critical sizes are not reached), *critical*
//! (a position error of at least [`CRITICAL_POSITION_M`], a speed error of at least [`CRITICAL_SPEED_MPS`], a
//! heading flip while the object moves fast enough that the velocity is off by that much) or in between.
//!
//! The model works in each frame's ego frame (rigid offsets are the same in the world frame up to a rotation).
//! Randomness: one ChaCha8 stream per run seeded by [`TrackerModelConfig::seed`], drawn in object order; the
//! result depends only on the seed and the frames.

use std::collections::HashMap;

use pmon_monitor::{ObjectClass, ObjectState};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// Position error from which an error is safety-critical (the paper's Sec. III-A: half a lane), metres.
pub const CRITICAL_POSITION_M: f64 = 1.0;
/// Speed error from which an error is safety-critical (the paper's Sec. III-A), m/s.
pub const CRITICAL_SPEED_MPS: f64 = 3.0;
/// Below this error size an injected error counts as benign (position m, speed m/s).
pub const BENIGN_SPEED_MPS: f64 = 1.0;

/// The parameters of the tracker model (rates per object and frame unless said otherwise).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackerModelConfig {
    /// Seed.
    pub seed: u64,
    /// Frames at a track's start with speed reported as 0 (velocity not initialised): 1 or 2, drawn per track
    /// with equal probability; 0 disables.
    pub warmup_frames_max: u32,
    /// Centre jitter (1-sigma, each axis) of a moving object, metres.
    pub jitter_moving_m: f64,
    /// Centre jitter (1-sigma, each axis) of a standing object, metres; blended as `exp(-v / 0.5 m/s)`.
    pub jitter_standstill_m: f64,
    /// Frame-to-frame correlation of the jitter (first-order Gauss-Markov), in [0, 1).
    pub jitter_correlation: f64,
    /// Heading noise (1-sigma) of a moving object, radians.
    pub heading_noise_rad: f64,
    /// Below this speed the heading is noise: `N(0, heading_standstill_rad)` around the truth, white, m/s.
    pub heading_defined_speed_mps: f64,
    /// Heading noise (1-sigma) at standstill, radians.
    pub heading_standstill_rad: f64,
    /// Speed noise (1-sigma, correlated like the jitter), m/s.
    pub speed_noise_mps: f64,
    /// Probability of a box re-fit starting (length changes, the centre moves by half the change along the
    /// heading; lasts a geometric number of frames, mean 5).
    pub refit_rate: f64,
    /// Largest length change of a re-fit as a fraction of the length.
    pub refit_fraction: f64,
    /// Probability of an id switch (the track continues under a new id, with a new warm-up).
    pub id_switch_rate: f64,
    /// Probability of a heading flip by pi (lasting 1 to 3 frames).
    pub flip_rate: f64,
    /// Probability of a position jump (one frame, random direction).
    pub jump_rate: f64,
    /// Size range of the jumps, metres.
    pub jump_m: (f64, f64),
    /// Probability of a speed drop-out (speed 0 for 1 or 2 frames).
    pub dropout_rate: f64,
}

impl TrackerModelConfig {
    /// The documented defaults (docs/plausibility.md): sizes seen on production tracker output.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self {
            seed,
            warmup_frames_max: 2,
            jitter_moving_m: 0.08,
            jitter_standstill_m: 0.25,
            jitter_correlation: 0.8,
            heading_noise_rad: 0.03,
            heading_defined_speed_mps: 0.3,
            heading_standstill_rad: 1.0,
            speed_noise_mps: 0.2,
            refit_rate: 0.02,
            refit_fraction: 0.3,
            id_switch_rate: 0.002,
            flip_rate: 0.003,
            jump_rate: 0.003,
            jump_m: (1.5, 6.0),
            dropout_rate: 0.003,
        }
    }
}

/// What kind of error an injected behaviour is, as the monitor should name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorKind {
    /// The reported speed disagrees with the motion (warm-up, drop-out).
    Speed,
    /// The heading is flipped by pi.
    HeadingFlip,
    /// The box jumped.
    PositionJump,
}

impl ErrorKind {
    /// Name for reports.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Speed => "speed",
            Self::HeadingFlip => "heading_flip",
            Self::PositionJump => "position_jump",
        }
    }
}

/// How bad an object state is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    /// Only benign tracker behaviour (jitter, re-fits, heading noise at standstill, id switches, warm-ups and
    /// drop-outs of slow objects).
    #[default]
    Benign,
    /// An error below the safety-critical size but not negligible.
    Intermediate,
    /// A safety-critical error.
    Critical,
}

/// What the model did to one object state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackerLabel {
    /// Severity of the state.
    pub severity: Severity,
    /// The error kind, if an error was injected.
    pub kind: Option<ErrorKind>,
    /// Error size (metres for jumps, m/s for speed errors and flips: the velocity error `2 v`).
    pub size: f64,
    /// The box was re-fitted in this state.
    pub refit: bool,
    /// The track is in its warm-up (speed reported 0).
    pub warmup: bool,
}

#[derive(Clone, Copy, Debug, Default)]
struct TrackState {
    /// Id reported for this truth id.
    out_id: u64,
    /// Frames reported under `out_id`.
    age: u32,
    warmup: u32,
    jitter: [f64; 2],
    speed_noise: f64,
    refit_frames: u32,
    refit_dl: f64,
    refit_sign: f64,
    flip_frames: u32,
    dropout_frames: u32,
}

/// Applies the tracker model frame by frame.
pub struct TrackerModel {
    config: TrackerModelConfig,
    rng: ChaCha8Rng,
    tracks: HashMap<u64, TrackState>,
    next_id: u64,
}

fn severity_of_speed_error(e: f64) -> Severity {
    if e >= CRITICAL_SPEED_MPS {
        Severity::Critical
    } else if e >= BENIGN_SPEED_MPS {
        Severity::Intermediate
    } else {
        Severity::Benign
    }
}

impl TrackerModel {
    /// A new model.
    #[must_use]
    pub fn new(config: TrackerModelConfig) -> Self {
        Self { config, rng: ChaCha8Rng::seed_from_u64(config.seed), tracks: HashMap::new(), next_id: 1 << 40 }
    }

    fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.rng)
    }

    /// Applies the model to one frame's clean object list in place (ids may change: id switches) and returns one
    /// label per object. The objects' uncertainty is removed (a tracker that exports none).
    pub fn apply(&mut self, objects: &mut [ObjectState]) -> Vec<TrackerLabel> {
        let c = self.config;
        let mut labels = Vec::with_capacity(objects.len());
        for o in objects.iter_mut() {
            let truth_id = o.id;
            let v = f64::from(o.speed_mps);
            let mut t = match self.tracks.get(&truth_id) {
                Some(t) => *t,
                None => {
                    let w =
                        if c.warmup_frames_max == 0 { 0 } else { 1 + self.rng.random_range(0..c.warmup_frames_max) };
                    TrackState { out_id: truth_id, warmup: w, ..TrackState::default() }
                }
            };
            let mut label = TrackerLabel::default();
            // Id switch: a new track from here on.
            if t.age > 0 && self.rng.random_bool(c.id_switch_rate) {
                t.out_id = self.next_id;
                self.next_id += 1;
                t.age = 0;
                t.warmup = if c.warmup_frames_max == 0 { 0 } else { 1 + self.rng.random_range(0..c.warmup_frames_max) };
            }
            // Jitter (Gauss-Markov), growing at standstill.
            let still = (-v / 0.5).exp();
            let sigma = c.jitter_moving_m + (c.jitter_standstill_m - c.jitter_moving_m) * still;
            let rho = c.jitter_correlation;
            let k = (1.0 - rho * rho).max(0.0).sqrt();
            let (g0, g1, g2) = (self.normal(), self.normal(), self.normal());
            t.jitter = [rho * t.jitter[0] + k * g0, rho * t.jitter[1] + k * g1];
            t.speed_noise = rho * t.speed_noise + k * g2;
            let (s, co) = f64::from(o.heading_rad).sin_cos();
            let mut x = f64::from(o.x_m) + sigma * t.jitter[0];
            let mut y = f64::from(o.y_m) + sigma * t.jitter[1];
            let mut speed = (v + c.speed_noise_mps * t.speed_noise).max(0.0);
            let gh = self.normal();
            let mut heading = f64::from(o.heading_rad)
                + if v < c.heading_defined_speed_mps {
                    c.heading_standstill_rad * gh
                } else {
                    c.heading_noise_rad * gh
                };
            // Box re-fit: the length changes by dl, one end stays, the centre moves by dl / 2.
            if t.refit_frames == 0 && self.rng.random_bool(c.refit_rate) {
                t.refit_frames = 1 + (self.rng.random::<f64>().ln() / 0.8f64.ln()) as u32;
                t.refit_dl = self.rng.random_range(-c.refit_fraction..c.refit_fraction) * f64::from(o.length_m);
                t.refit_sign = if self.rng.random_bool(0.5) { 1.0 } else { -1.0 };
            }
            let mut length = f64::from(o.length_m);
            if t.refit_frames > 0 {
                t.refit_frames -= 1;
                length = (length + t.refit_dl).max(0.2);
                let shift = 0.5 * (length - f64::from(o.length_m)) * t.refit_sign;
                x += shift * co;
                y += shift * s;
                label.refit = true;
            }
            // Errors: warm-up, drop-out, flip, jump (at most one per state, in that order).
            if t.age < t.warmup {
                speed = 0.0;
                label.warmup = true;
                label.kind = Some(ErrorKind::Speed);
                label.size = v;
                label.severity = severity_of_speed_error(v);
            } else {
                if t.dropout_frames == 0 && t.flip_frames == 0 && self.rng.random_bool(c.dropout_rate) {
                    t.dropout_frames = 1 + self.rng.random_range(0..2u32);
                } else if t.flip_frames == 0 && t.dropout_frames == 0 && self.rng.random_bool(c.flip_rate) {
                    t.flip_frames = 1 + self.rng.random_range(0..3u32);
                }
                if t.dropout_frames > 0 {
                    t.dropout_frames -= 1;
                    speed = 0.0;
                    label.kind = Some(ErrorKind::Speed);
                    label.size = v;
                    label.severity = severity_of_speed_error(v);
                } else if t.flip_frames > 0 {
                    t.flip_frames -= 1;
                    heading += std::f64::consts::PI;
                    label.kind = Some(ErrorKind::HeadingFlip);
                    label.size = 2.0 * v;
                    label.severity = severity_of_speed_error(2.0 * v);
                } else if self.rng.random_bool(c.jump_rate) {
                    let m = self.rng.random_range(c.jump_m.0..c.jump_m.1);
                    let a = self.rng.random_range(0.0..std::f64::consts::TAU);
                    x += m * a.cos();
                    y += m * a.sin();
                    label.kind = Some(ErrorKind::PositionJump);
                    label.size = m;
                    label.severity = if m >= CRITICAL_POSITION_M { Severity::Critical } else { Severity::Intermediate };
                }
            }
            t.age += 1;
            self.tracks.insert(truth_id, t);
            o.id = t.out_id;
            o.x_m = x as f32;
            o.y_m = y as f32;
            o.speed_mps = speed as f32;
            o.heading_rad = pmon_monitor::geometry::wrap_angle(heading) as f32;
            o.length_m = length as f32;
            o.uncertainty = None;
            labels.push(label);
        }
        labels
    }
}

/// Classes in the report, in order.
pub const REPORT_CLASSES: [ObjectClass; 4] =
    [ObjectClass::Car, ObjectClass::Truck, ObjectClass::Pedestrian, ObjectClass::Cyclist];

#[cfg(test)]
mod tests {
    use super::*;

    fn obj(id: u64, x: f32, v: f32) -> ObjectState {
        ObjectState {
            id,
            class: ObjectClass::Car,
            x_m: x,
            y_m: 0.0,
            heading_rad: 0.0,
            speed_mps: v,
            length_m: 4.5,
            width_m: 1.8,
            uncertainty: None,
        }
    }

    #[test]
    fn warmup_reports_zero_speed_and_labels_by_size() {
        let mut m = TrackerModel::new(TrackerModelConfig::new(1));
        let mut objs = vec![obj(1, 0.0, 10.0), obj(2, 5.0, 0.5)];
        let l = m.apply(&mut objs);
        assert_eq!(objs[0].speed_mps, 0.0);
        assert!(l[0].warmup && l[0].severity == Severity::Critical && l[0].kind == Some(ErrorKind::Speed));
        assert!(l[1].warmup && l[1].severity == Severity::Benign);
    }

    #[test]
    fn rates_and_determinism() {
        let mut c = TrackerModelConfig::new(3);
        c.jump_rate = 0.1;
        let run = || {
            let mut m = TrackerModel::new(c);
            let mut all = Vec::new();
            for k in 0..200 {
                let mut objs: Vec<_> = (0..50).map(|i| obj(i, k as f32, 10.0)).collect();
                all.extend(m.apply(&mut objs));
            }
            all
        };
        let a = run();
        assert_eq!(a, run());
        let jumps = a.iter().filter(|l| l.kind == Some(ErrorKind::PositionJump)).count() as f64 / a.len() as f64;
        assert!((jumps - 0.1).abs() < 0.02, "{jumps}");
        assert!(a.iter().filter(|l| l.kind == Some(ErrorKind::PositionJump)).all(|l| l.size >= 1.5 && l.size < 6.0));
    }

    #[test]
    fn refit_moves_the_centre_by_half_the_length_change() {
        let mut c = TrackerModelConfig::new(5);
        c.refit_rate = 1.0;
        c.jitter_moving_m = 0.0;
        c.jitter_standstill_m = 0.0;
        c.warmup_frames_max = 0;
        c.flip_rate = 0.0;
        c.jump_rate = 0.0;
        c.dropout_rate = 0.0;
        let mut m = TrackerModel::new(c);
        let mut objs = vec![obj(1, 10.0, 5.0)];
        let l = m.apply(&mut objs);
        assert!(l[0].refit);
        let dl = f64::from(objs[0].length_m) - 4.5;
        let dx = f64::from(objs[0].x_m) - 10.0;
        assert!((dx.abs() - 0.5 * dl.abs()).abs() < 1e-4, "{dx} {dl}");
    }
}
