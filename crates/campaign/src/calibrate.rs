//! Data-driven tuning (issue #11, item 5; `pmon calibrate`, docs/plausibility.md): a tracker's per-class noise
//! estimated from its own output, for the calibrated plausibility rule.
//!
//! The tracker's output is cut into tracks (one id, steps of at most `max_time_step_s`, one class). From each
//! class's states, robust to the tracker's glitches (jumps, flips, warm-ups, drop-outs: each value is fitted at
//! the samples' [`QUANTILE`], 95 %, which glitches in a few per cent of the states move little, while a tail
//! heavier than Gaussian up to there widens the gates as it should):
//!
//! - **speed** `speed_mps`: the scatter of the speed change between consecutive states of moving objects
//!   (both speeds `>= MOVING_MPS`), over `sqrt 2` (the acceleration gate's statistic; real accelerations only
//!   make it larger);
//! - **heading** `heading_rad`: the same for the heading change of fast objects (both `>= FAST_MPS`, where the
//!   heading is the direction of motion and its speed-dependent part `speed_mps / v` is small);
//! - **position** `position_m` (reported speed `>= FAST_MPS`) and `standstill_position_m` (below
//!   `STANDING_MPS`): the value for which the monitor's own position statistic (`r^T S^-1 r` over the baseline,
//!   box re-fits allowed for, [`pmon_monitor::calibrated::check_calibrated`]) has the chi-square's (2 degrees
//!   of freedom) 95th percentile, found by bisection. This calibrates the gate the monitor applies, so
//!   correlated jitter (which a frame-to-frame difference underestimates) is measured over the same baseline.
//!
//! Speed dependence: the same estimates per band of reported speed ([`SpeedBand`]) are reported beside the
//! model's two-level position noise (blended as `exp(-v / 1 m/s)`) and `heading_rad + speed_mps / v`.
//!
//! A class with fewer than [`MIN_SAMPLES`] samples for a value takes the value of all classes together; when
//! those are too few too, the base parameters' value (the documented default). Every fallback is listed.
//!
//! The fit fixes the noise up to its 95th percentile; the gates sit further out (`false_alarm_probability`,
//! default 1e-4 per gate). Tails heavier than Gaussian beyond it give more alarms than the nominal rate, which is
//! why [`alarm_rate`] measures the written parameters on the same input.

use std::collections::{BTreeMap, HashMap};

use pmon_monitor::calibrated::{check_calibrated, Entry, Gates, History, HISTORY};
use pmon_monitor::plausibility::to_world;
use pmon_monitor::{
    object_is_valid, Frame, Monitor, MonitorParams, MotionVerdict, ObjectClass, ObjectState, PlausibilityMode, Pose2,
    TrackerNoise,
};
use serde::Serialize;

/// Fewest samples for a value of a class (else the value of all classes).
pub const MIN_SAMPLES: usize = 100;
/// Both speeds at least this: a moving object (speed estimate), m/s.
pub const MOVING_MPS: f32 = 1.0;
/// Reported speed at least this: a fast object (heading and moving-position estimates), m/s.
pub const FAST_MPS: f32 = 3.0;
/// Reported speed below this: a standing object (standstill position estimate), m/s.
pub const STANDING_MPS: f32 = 0.2;
/// The quantile at which the noise is fitted: the samples' 95th percentile is made the Gaussian one (not the
/// median: real tracks have tails heavier than Gaussian, and the gates sit in the tail; not higher: the
/// tracker's own glitches, about 1-3 % of the states, must not widen the gates).
pub const QUANTILE: f64 = 0.95;
/// The two-sided normal quantile of [`QUANTILE`].
const Z_QUANTILE: f64 = 1.959_964;
/// The [`QUANTILE`] of a chi-square with 2 degrees of freedom, `-2 ln (1 - q)`.
const CHI2_2_QUANTILE: f64 = 5.991_465;
/// Smallest values written (the parameters must be `> 0`).
const FLOOR: f32 = 0.002;

#[derive(Clone, Copy, Debug)]
struct Sample {
    t_s: f64,
    x_m: f64,
    y_m: f64,
    v_mps: f32,
    heading_rad: f64,
    length_m: f32,
    width_m: f32,
    warmup: bool,
}

#[derive(Debug)]
struct Segment {
    class: ObjectClass,
    states: Vec<Sample>,
}

/// Collects a tracker's output, frame by frame, into tracks.
#[derive(Debug)]
pub struct Collector {
    params: MonitorParams,
    open: HashMap<u64, Segment>,
    done: Vec<Segment>,
    /// Object states read.
    pub states: u64,
    /// Object states left out: invalid (NaN, non-positive size), duplicate ids in a frame, or in a frame with a
    /// non-finite timestamp or pose.
    pub skipped: u64,
    last_t: Option<f64>,
}

impl Collector {
    /// A collector for the given base parameters (`max_time_step_s`, `warmup_frames` and the validity rules).
    #[must_use]
    pub fn new(params: &MonitorParams) -> Self {
        Self { params: *params, open: HashMap::new(), done: Vec::new(), states: 0, skipped: 0, last_t: None }
    }

    /// Adds one frame's object list (ego frame) with its ego pose.
    pub fn add_frame(&mut self, timestamp_s: f64, world_from_ego: &Pose2, objects: &[ObjectState]) {
        self.states += objects.len() as u64;
        if !timestamp_s.is_finite() || !world_from_ego.is_finite() || self.last_t.is_some_and(|t| timestamp_s <= t) {
            self.skipped += objects.len() as u64;
            return;
        }
        self.last_t = Some(timestamp_s);
        let mut count: HashMap<u64, u32> = HashMap::new();
        for o in objects {
            *count.entry(o.id).or_default() += 1;
        }
        let p = self.params;
        for o in objects {
            if count.get(&o.id).copied().unwrap_or(0) > 1 || !object_is_valid(o, &p) {
                self.skipped += 1;
                continue;
            }
            let s = to_world(o, &p.default_uncertainty, world_from_ego, timestamp_s);
            let continues = self.open.get(&o.id).is_some_and(|seg| {
                seg.class == o.class && seg.states.last().is_some_and(|l| timestamp_s - l.t_s <= p.max_time_step_s)
            });
            if !continues {
                if let Some(old) = self.open.remove(&o.id) {
                    self.done.push(old);
                }
            }
            let seg = self.open.entry(o.id).or_insert_with(|| Segment { class: o.class, states: Vec::new() });
            let age = u32::try_from(seg.states.len()).unwrap_or(u32::MAX);
            seg.states.push(Sample {
                t_s: timestamp_s,
                x_m: s.x_m,
                y_m: s.y_m,
                v_mps: o.speed_mps,
                heading_rad: s.heading_rad,
                length_m: o.length_m,
                width_m: o.width_m,
                warmup: age < p.warmup_frames && o.speed_mps <= 0.0,
            });
        }
    }

    /// Estimates the noise of every class.
    #[must_use]
    pub fn finish(mut self) -> Calibration {
        let mut open: Vec<(u64, Segment)> = self.open.drain().collect();
        open.sort_by_key(|(id, _)| *id);
        self.done.extend(open.into_iter().map(|(_, s)| s));
        estimate(&self.done, &self.params, self.states, self.skipped)
    }
}

/// One estimated value and where it came from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Value {
    /// The value (metres, m/s or radians).
    pub value: f32,
    /// Samples it was estimated from (0: taken from `source`).
    pub samples: usize,
    /// `estimated`, `all classes` or `default`.
    pub source: &'static str,
}

/// The estimate of one class (or of all classes together).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClassEstimate {
    /// Class name, or `all`.
    pub class: String,
    /// Tracks (segments) of the class.
    pub tracks: usize,
    /// States of the class.
    pub states: usize,
    /// Position noise of a moving object, m.
    pub position_m: Value,
    /// Position noise of a standing object, m.
    pub standstill_position_m: Value,
    /// Speed noise, m/s.
    pub speed_mps: Value,
    /// Heading noise of a moving object, rad.
    pub heading_rad: Value,
    /// The same quantities per band of reported speed.
    pub bands: Vec<SpeedBand>,
}

impl ClassEstimate {
    /// As the monitor's [`TrackerNoise`].
    #[must_use]
    pub fn noise(&self) -> TrackerNoise {
        TrackerNoise {
            position_m: self.position_m.value,
            standstill_position_m: self.standstill_position_m.value,
            speed_mps: self.speed_mps.value,
            heading_rad: self.heading_rad.value,
        }
    }
}

/// Estimates within one band of reported speed (`None`: fewer than 30 samples).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SpeedBand {
    /// Lower bound, m/s.
    pub from_mps: f32,
    /// Upper bound (exclusive), m/s.
    pub to_mps: f32,
    /// States in the band (judged by the position statistic).
    pub states: usize,
    /// One position sigma for the band (fitted at the chi-square's 95th percentile), m.
    pub position_m: Option<f32>,
    /// Speed scatter of pairs starting in the band, m/s.
    pub speed_mps: Option<f32>,
    /// Heading scatter of pairs starting in the band (both speeds `>= MOVING_MPS`), rad.
    pub heading_rad: Option<f32>,
}

/// The result of a calibration.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Calibration {
    /// All classes together (the written `tracker_noise`).
    pub all: ClassEstimate,
    /// Each class with states in the input (the written `per_class_noise`).
    pub per_class: Vec<ClassEstimate>,
    /// Object states read.
    pub states_read: u64,
    /// Object states left out (invalid, duplicate ids, bad timestamps).
    pub states_skipped: u64,
    /// The base parameters the estimate was made with.
    #[serde(skip)]
    pub base: MonitorParams,
}

impl Calibration {
    /// The base parameters in the calibrated mode with the estimated noise (all classes as `tracker_noise`,
    /// each class with states as `per_class_noise`).
    #[must_use]
    pub fn params(&self) -> MonitorParams {
        let mut p = MonitorParams { plausibility_mode: PlausibilityMode::Calibrated, ..self.base };
        p.tracker_noise = self.all.noise();
        for c in &self.per_class {
            if let Some(class) = ObjectClass::ALL.iter().find(|k| k.name() == c.class) {
                *p.per_class_noise.get_mut(*class) = Some(c.noise());
            }
        }
        p
    }
}

/// The sigma of a normal distribution whose [`QUANTILE`] of `|x - median|` is the sample's: `q / z`, with `z`
/// the two-sided normal quantile. Robust to glitches in up to a few per cent of the samples; a tail heavier
/// than Gaussian up to that quantile makes it larger (what the gates need).
fn robust_sigma(xs: &mut [f64]) -> Option<f64> {
    let med = median(xs)?;
    for x in xs.iter_mut() {
        *x = (*x - med).abs();
    }
    quantile(xs, QUANTILE).map(|q| q / Z_QUANTILE)
}

fn median(xs: &mut [f64]) -> Option<f64> {
    quantile(xs, 0.5)
}

fn quantile(xs: &mut [f64], q: f64) -> Option<f64> {
    if xs.is_empty() {
        return None;
    }
    let k = ((xs.len() as f64 * q) as usize).min(xs.len() - 1);
    let (_, m, _) = xs.select_nth_unstable_by(k, f64::total_cmp);
    Some(*m)
}

fn entry(s: &Sample, n: &TrackerNoise, p: &MonitorParams) -> Entry {
    let sp = n.position_at(f64::from(s.v_mps)) as f32;
    Entry {
        t_s: s.t_s,
        x_m: s.x_m,
        y_m: s.y_m,
        v_mps: s.v_mps,
        heading_rad: s.heading_rad as f32,
        sx_m: sp,
        sy_m: sp,
        sv_mps: if s.warmup { n.speed_mps.max(p.warmup_speed_sigma_mps) } else { n.speed_mps },
        sh_rad: n.heading_rad,
        length_m: s.length_m,
        width_m: s.width_m,
        warmup: s.warmup,
        suspect: false,
        flipped: false,
        unit: [0.0; 2], // set by History::push
    }
}

/// The monitor's position statistic `r^T S^-1 r` for every state `k >= 1` of the segments whose reported speed
/// passes `keep` (states in or right after a warm-up left out).
fn position_statistics(segs: &[&Segment], n: &TrackerNoise, p: &MonitorParams, keep: &dyn Fn(f32) -> bool) -> Vec<f64> {
    let gates = Gates::new(p.false_alarm_probability);
    let mut out = Vec::new();
    for seg in segs {
        let limits = p.limits_for(seg.class);
        for k in 1..seg.states.len() {
            let Some(s1) = seg.states.get(k) else { continue };
            if s1.warmup || !keep(s1.v_mps) || seg.states.get(k - 1).is_some_and(|s| s.warmup) {
                continue;
            }
            let mut h = History::default();
            for s in seg.states.get(k.saturating_sub(HISTORY)..k).unwrap_or(&[]) {
                h.push(entry(s, n, p));
            }
            let c = check_calibrated(
                &h,
                &entry(s1, n, p),
                &limits,
                &gates,
                f64::from(p.heading_min_speed_mps),
                p.baseline_s,
            );
            // allowance = residual * sqrt(chi2 / d2)  =>  d2 = chi2 (residual / allowance)^2.
            let d2 = if c.allowance.is_finite() && c.allowance > 0.0 {
                gates.chi2_2 * (c.residual / c.allowance).powi(2)
            } else if c.residual > 0.0 {
                f64::INFINITY
            } else {
                0.0
            };
            out.push(d2);
        }
    }
    out
}

/// The position sigma (set through `set`) at which the statistic's [`QUANTILE`] is the chi-square's, by bisection in log
/// space over [0.005, 20] m; `None` with fewer than `min` samples.
fn fit_position(
    segs: &[&Segment],
    base: TrackerNoise,
    p: &MonitorParams,
    keep: &dyn Fn(f32) -> bool,
    set: &dyn Fn(TrackerNoise, f32) -> TrackerNoise,
    min: usize,
) -> Option<(f32, usize)> {
    let count = position_statistics(segs, &set(base, 1.0), p, keep).len();
    if count < min {
        return None;
    }
    let q = |s: f32| quantile(&mut position_statistics(segs, &set(base, s), p, keep), QUANTILE).unwrap_or(0.0);
    let (mut lo, mut hi) = (0.005f64.ln(), 20.0f64.ln());
    for _ in 0..30 {
        let mid = 0.5 * (lo + hi);
        if q(mid.exp() as f32) > CHI2_2_QUANTILE {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(((0.5 * (lo + hi)).exp() as f32, count))
}

/// Speed-change and heading-change samples of consecutive states (neither in its warm-up).
fn pair_samples(segs: &[&Segment], keep: &dyn Fn(&Sample, &Sample) -> bool) -> (Vec<f64>, Vec<f64>) {
    let (mut dv, mut dh) = (Vec::new(), Vec::new());
    for seg in segs {
        for w in seg.states.windows(2) {
            let [a, b] = w else { continue };
            if a.warmup || b.warmup || !keep(a, b) {
                continue;
            }
            dv.push(f64::from(b.v_mps - a.v_mps) / core::f64::consts::SQRT_2);
            dh.push(pmon_monitor::geometry::wrap_angle(b.heading_rad - a.heading_rad) / core::f64::consts::SQRT_2);
        }
    }
    (dv, dh)
}

const BANDS: [(f32, f32); 6] = [(0.0, 0.2), (0.2, 1.0), (1.0, 3.0), (3.0, 8.0), (8.0, 15.0), (15.0, f32::INFINITY)];

fn value(est: Option<(f32, usize)>, fallback: Value, fallback_source: &'static str) -> Value {
    match est {
        Some((v, n)) => Value { value: v.max(FLOOR), samples: n, source: "estimated" },
        None => Value { value: fallback.value, samples: 0, source: fallback_source },
    }
}

fn estimate_class(name: &str, segs: &[&Segment], p: &MonitorParams, fallback: &ClassEstimate) -> ClassEstimate {
    let fb = if name == "all" { "default" } else { "all classes" };
    let sigma = |mut xs: Vec<f64>| -> Option<(f32, usize)> {
        let n = xs.len();
        if n < MIN_SAMPLES {
            return None;
        }
        robust_sigma(&mut xs).map(|s| (s as f32, n))
    };
    let (dv, _) = pair_samples(segs, &|a, b| a.v_mps.min(b.v_mps) >= MOVING_MPS);
    let (_, dh) = pair_samples(segs, &|a, b| a.v_mps.min(b.v_mps) >= FAST_MPS);
    let speed_mps = value(sigma(dv), fallback.speed_mps, fb);
    let heading_rad = value(sigma(dh), fallback.heading_rad, fb);
    let mut noise = TrackerNoise {
        position_m: fallback.position_m.value,
        standstill_position_m: fallback.standstill_position_m.value,
        speed_mps: speed_mps.value,
        heading_rad: heading_rad.value,
    };
    // Moving, then standing (their blend overlaps little), then moving again with the standing value.
    let moving = |v: f32| v >= FAST_MPS;
    let standing = |v: f32| v < STANDING_MPS;
    let set_moving = |n: TrackerNoise, s: f32| TrackerNoise { position_m: s, ..n };
    let set_standing = |n: TrackerNoise, s: f32| TrackerNoise { standstill_position_m: s, ..n };
    let mut pos_moving = None;
    let mut pos_standing = None;
    for _ in 0..2 {
        pos_moving = fit_position(segs, noise, p, &moving, &set_moving, MIN_SAMPLES);
        if let Some((v, _)) = pos_moving {
            noise.position_m = v.max(FLOOR);
        }
        pos_standing = fit_position(segs, noise, p, &standing, &set_standing, MIN_SAMPLES);
        if let Some((v, _)) = pos_standing {
            noise.standstill_position_m = v.max(FLOOR);
        }
        if pos_moving.is_none() || pos_standing.is_none() {
            break;
        }
    }
    let position_m = value(pos_moving, fallback.position_m, fb);
    let standstill_position_m = value(pos_standing, fallback.standstill_position_m, fb);
    let mut bands = Vec::new();
    for (lo, hi) in BANDS {
        let in_band = move |v: f32| v >= lo && v < hi;
        let both = |n: TrackerNoise, s: f32| TrackerNoise { position_m: s, standstill_position_m: s, ..n };
        let pos = fit_position(segs, noise, p, &in_band, &both, 30);
        let states = position_statistics(segs, &noise, p, &in_band).len();
        let band_sigma = |mut xs: Vec<f64>| if xs.len() < 30 { None } else { robust_sigma(&mut xs).map(|s| s as f32) };
        let (dv, _) = pair_samples(segs, &|a, _| in_band(a.v_mps));
        let (_, dh) = pair_samples(segs, &|a, b| in_band(a.v_mps) && a.v_mps.min(b.v_mps) >= MOVING_MPS);
        bands.push(SpeedBand {
            from_mps: lo,
            to_mps: hi,
            states,
            position_m: pos.map(|(v, _)| v),
            speed_mps: band_sigma(dv),
            heading_rad: band_sigma(dh),
        });
    }
    ClassEstimate {
        class: name.to_string(),
        tracks: segs.len(),
        states: segs.iter().map(|s| s.states.len()).sum(),
        position_m,
        standstill_position_m,
        speed_mps,
        heading_rad,
        bands,
    }
}

fn estimate(segs: &[Segment], p: &MonitorParams, states_read: u64, states_skipped: u64) -> Calibration {
    let d = p.tracker_noise;
    let default = |v: f32| Value { value: v, samples: 0, source: "default" };
    let defaults = ClassEstimate {
        class: "default".into(),
        tracks: 0,
        states: 0,
        position_m: default(d.position_m),
        standstill_position_m: default(d.standstill_position_m),
        speed_mps: default(d.speed_mps),
        heading_rad: default(d.heading_rad),
        bands: Vec::new(),
    };
    let all_segs: Vec<&Segment> = segs.iter().collect();
    let all = estimate_class("all", &all_segs, p, &defaults);
    let mut by_class: BTreeMap<&'static str, Vec<&Segment>> = BTreeMap::new();
    for s in segs {
        by_class.entry(s.class.name()).or_default().push(s);
    }
    let per_class = by_class.iter().map(|(name, segs)| estimate_class(name, segs, p, &all)).collect();
    Calibration { all, per_class, states_read, states_skipped, base: *p }
}

/// Alarms of the plausibility checks (no LiDAR) per class: `(judged states, implausible)`, and in total.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct AlarmRate {
    /// Per class name: judged states and alarms.
    pub per_class: BTreeMap<String, (u64, u64)>,
    /// All classes: judged states and alarms.
    pub all: (u64, u64),
}

impl AlarmRate {
    /// Alarms per mille of judged states.
    #[must_use]
    pub fn per_mille(c: (u64, u64)) -> f64 {
        1000.0 * c.1 as f64 / c.0.max(1) as f64
    }
}

/// Runs the plausibility checks with `params` over object lists and counts alarms per judged state.
///
/// # Errors
/// Invalid parameters, or a frame the monitor refuses (too many objects).
pub fn alarm_rate<'a>(
    params: &MonitorParams,
    frames: impl IntoIterator<Item = (f64, Pose2, &'a [ObjectState])>,
) -> Result<AlarmRate, String> {
    // Plausibility only: a coarse grid (no LiDAR is given).
    let params = MonitorParams { grid_size_m: 1000.0, cell_size_m: 2.0, ..*params };
    let mut monitor = Monitor::new(params).map_err(|e| e.to_string())?;
    let mut rate = AlarmRate::default();
    for (k, (t, pose, objects)) in frames.into_iter().enumerate() {
        let f =
            Frame { timestamp_s: t, world_from_ego: pose, objects, cloud: None, roi_in_ego: &[], static_in_ego: &[] };
        let rep = monitor.check(&f).map_err(|e| format!("frame {k}: {e}"))?;
        for (o, r) in objects.iter().zip(rep.objects) {
            let (judged, alarm) = match r.motion.verdict {
                MotionVerdict::Plausible => (1, 0),
                MotionVerdict::Implausible(_) => (1, 1),
                MotionVerdict::NotMonitored(_) => (0, 0),
            };
            let e = rate.per_class.entry(o.class.name().to_string()).or_default();
            e.0 += judged;
            e.1 += alarm;
            rate.all.0 += judged;
            rate.all.1 += alarm;
        }
    }
    Ok(rate)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robust_sigma_is_bounded_by_glitches_and_exact_without() {
        // A deterministic normal sample (sigma 0.3, quantiles on a grid) plus 2 % gross outliers on both sides:
        // the 95th percentile moves to the clean sample's 96.9th, 1.10 sigma (at most 1.2 asserted); without
        // outliers the estimate is the sigma.
        let n = 2000;
        let clean = || (0..n).map(|i| 0.3 * normal_quantile((i as f64 + 0.5) / n as f64));
        let mut xs: Vec<f64> = clean().collect();
        xs.extend((0..n / 50).map(|i| if i % 2 == 0 { 50.0 + i as f64 } else { -50.0 - i as f64 }));
        let s = robust_sigma(&mut xs).unwrap();
        assert!(s > 0.3 && s < 0.3 * 1.2, "{s}");
        let s = robust_sigma(&mut clean().collect::<Vec<_>>()).unwrap();
        assert!((s - 0.3).abs() < 0.01, "{s}");
    }

    /// Normal quantile by bisection on `erf` (test helper).
    pub(super) fn normal_quantile(u: f64) -> f64 {
        let cdf = |x: f64| 0.5 * (1.0 + libm_erf(x / core::f64::consts::SQRT_2));
        let (mut lo, mut hi) = (-10.0, 10.0);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if cdf(mid) < u {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// `erf` (Abramowitz and Stegun 7.1.26, error below 1.5e-7).
    fn libm_erf(x: f64) -> f64 {
        let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
        let y = 1.0
            - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t + 0.254_829_592)
                * t
                * (-x * x).exp();
        if x >= 0.0 {
            y
        } else {
            -y
        }
    }
}
