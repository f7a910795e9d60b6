//! Finite-difference motion statistics of a dataset's tracks: how hard do real (annotated) objects seem to
//! accelerate and turn between frames? Used to judge the monitor's plausibility limits on real data.
//!
//! Everything is computed in the world frame (`world_from_ego` applied), over consecutive observations of a
//! track whose time gap is at most 1.5 frame periods.

use std::collections::BTreeMap;

use pmon_monitor::ObjectClass;

use crate::geometry::wrap_angle;
use crate::Dataset;

/// Extremes of one class.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionExtremes {
    /// The class.
    pub class: ObjectClass,
    /// Tracks of this class.
    pub tracks: usize,
    /// Observations of this class.
    pub observations: usize,
    /// Largest |acceleration| from second differences of positions (forward-difference speeds), m/s^2.
    pub max_abs_accel_positions_mps2: f64,
    /// Where it happened: `(object id, timestamp_s)`.
    pub at_accel_positions: Option<(u64, f64)>,
    /// Largest |acceleration| from differences of the dataset's `speed_mps` field between frames, m/s^2.
    pub max_abs_accel_speed_field_mps2: f64,
    /// Where it happened: `(object id, timestamp_s)`.
    pub at_accel_speed_field: Option<(u64, f64)>,
    /// Largest |heading change| over 0.2 s (or the nearest whole number of frames), radians.
    pub max_heading_change_rad: f64,
    /// Where it happened: `(object id, timestamp_s)`.
    pub at_heading_change: Option<(u64, f64)>,
    /// Position-difference accelerations above the limit given to [`motion_extremes`].
    pub accel_positions_over_limit: usize,
    /// Speed-field accelerations above the limit.
    pub accel_speed_field_over_limit: usize,
    /// Heading changes over 0.2 s above the limit.
    pub heading_over_limit: usize,
    /// Number of acceleration samples (position differences).
    pub accel_samples: usize,
    /// Number of heading-change samples.
    pub heading_samples: usize,
}

impl MotionExtremes {
    fn new(class: ObjectClass) -> Self {
        Self {
            class,
            tracks: 0,
            observations: 0,
            max_abs_accel_positions_mps2: 0.0,
            at_accel_positions: None,
            max_abs_accel_speed_field_mps2: 0.0,
            at_accel_speed_field: None,
            max_heading_change_rad: 0.0,
            at_heading_change: None,
            accel_positions_over_limit: 0,
            accel_speed_field_over_limit: 0,
            heading_over_limit: 0,
            accel_samples: 0,
            heading_samples: 0,
        }
    }
}

struct Obs {
    t: f64,
    x: f64,
    y: f64,
    heading: f64,
    speed: f64,
}

/// Per-class extremes of finite-difference motion over the dataset's tracks (object ids), with counts above
/// `accel_limit_mps2` and above `heading_limit_rad` per 0.2 s. A track's class is that of its first
/// observation. Needs a frame period (`DatasetInfo::frame_period_s`, or the median frame gap).
#[must_use]
pub fn motion_extremes(ds: &Dataset, accel_limit_mps2: f64, heading_limit_rad: f64) -> Vec<MotionExtremes> {
    let mut gaps: Vec<f64> =
        ds.frames.windows(2).filter_map(|w| Some(w.get(1)?.frame.timestamp_s - w.first()?.frame.timestamp_s)).collect();
    gaps.sort_by(f64::total_cmp);
    let period = ds.info.frame_period_s.or_else(|| gaps.get(gaps.len() / 2).copied()).unwrap_or(0.1);
    let max_gap = 1.5 * period;
    // steps for 0.2 s
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // small positive ratio
    let steps = ((0.2 / period).round() as usize).max(1);

    let mut tracks: BTreeMap<u64, (ObjectClass, Vec<Obs>)> = BTreeMap::new();
    for f in &ds.frames {
        let pose = f.frame.world_from_ego;
        for o in &f.frame.objects {
            let (x, y) = pose.transform_point(f64::from(o.x_m), f64::from(o.y_m));
            let e = tracks.entry(o.id).or_insert_with(|| (o.class, Vec::new()));
            e.1.push(Obs {
                t: f.frame.timestamp_s,
                x,
                y,
                heading: f64::from(o.heading_rad) + pose.yaw_rad,
                speed: f64::from(o.speed_mps),
            });
        }
    }
    let mut out: BTreeMap<ObjectClass, MotionExtremes> = BTreeMap::new();
    for (id, (class, obs)) in &tracks {
        let m = out.entry(*class).or_insert_with(|| MotionExtremes::new(*class));
        m.tracks += 1;
        m.observations += obs.len();
        // forward-difference speeds between consecutive observations
        let mut v: Vec<Option<(f64, f64)>> = Vec::with_capacity(obs.len());
        for w in obs.windows(2) {
            let (Some(a), Some(b)) = (w.first(), w.get(1)) else { continue };
            let dt = b.t - a.t;
            v.push((dt > 0.0 && dt <= max_gap).then(|| ((b.x - a.x).hypot(b.y - a.y) / dt, (a.t + b.t) / 2.0)));
            if dt > 0.0 && dt <= max_gap {
                let acc = (b.speed - a.speed) / dt;
                if acc.abs() > m.max_abs_accel_speed_field_mps2 {
                    m.max_abs_accel_speed_field_mps2 = acc.abs();
                    m.at_accel_speed_field = Some((*id, a.t));
                }
                if acc.abs() > accel_limit_mps2 {
                    m.accel_speed_field_over_limit += 1;
                }
            }
        }
        for w in v.windows(2) {
            let (Some(Some((v0, t0))), Some(Some((v1, t1)))) = (w.first(), w.get(1)) else { continue };
            let acc = (v1 - v0) / (t1 - t0);
            m.accel_samples += 1;
            if acc.abs() > m.max_abs_accel_positions_mps2 {
                m.max_abs_accel_positions_mps2 = acc.abs();
                m.at_accel_positions = Some((*id, *t0));
            }
            if acc.abs() > accel_limit_mps2 {
                m.accel_positions_over_limit += 1;
            }
        }
        for (i, a) in obs.iter().enumerate() {
            let Some(b) = obs.get(i + steps) else { break };
            let span = b.t - a.t;
            #[allow(clippy::cast_precision_loss)]
            let want = steps as f64 * period;
            if (span - want).abs() > 0.5 * period {
                continue;
            }
            let dh = wrap_angle(b.heading - a.heading).abs();
            m.heading_samples += 1;
            if dh > m.max_heading_change_rad {
                m.max_heading_change_rad = dh;
                m.at_heading_change = Some((*id, a.t));
            }
            if dh > heading_limit_rad {
                m.heading_over_limit += 1;
            }
        }
    }
    out.into_values().collect()
}
