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

/// The speed of the positions from `a` to `b`, when `b` follows `a` within `max_gap` seconds.
fn step_speed(a: &Obs, b: &Obs, max_gap: f64) -> Option<f64> {
    let dt = b.t - a.t;
    (dt > 0.0 && dt <= max_gap).then(|| (b.x - a.x).hypot(b.y - a.y) / dt)
}

/// One observation of a track and where it stands: its frame's index and its index in that frame's objects.
struct Observed {
    frame: usize,
    object: usize,
    class: ObjectClass,
    obs: Obs,
}

/// The frames' objects grouped into tracks by id, each in frame order, in the world frame (`world_from_ego`
/// applied to positions and headings).
fn tracks_of(frames: &[crate::DatasetFrame]) -> BTreeMap<u64, Vec<Observed>> {
    let mut tracks: BTreeMap<u64, Vec<Observed>> = BTreeMap::new();
    for (frame, f) in frames.iter().enumerate() {
        let pose = f.frame.world_from_ego;
        for (object, o) in f.frame.objects.iter().enumerate() {
            let (x, y) = pose.transform_point(f64::from(o.x_m), f64::from(o.y_m));
            let obs = Obs {
                t: f.frame.timestamp_s,
                x,
                y,
                heading: f64::from(o.heading_rad) + pose.yaw_rad,
                speed: f64::from(o.speed_mps),
            };
            tracks.entry(o.id).or_default().push(Observed { frame, object, class: o.class, obs });
        }
    }
    tracks
}

/// The dataset's frame period: `DatasetInfo::frame_period_s`, or the median gap between its frames (0.1 s
/// without two frames).
#[must_use]
pub fn frame_period(ds: &Dataset) -> f64 {
    let mut gaps: Vec<f64> =
        ds.frames.windows(2).filter_map(|w| Some(w.get(1)?.frame.timestamp_s - w.first()?.frame.timestamp_s)).collect();
    gaps.sort_by(f64::total_cmp);
    ds.info.frame_period_s.or_else(|| gaps.get(gaps.len() / 2).copied()).unwrap_or(0.1)
}

/// Per-class extremes of finite-difference motion over the dataset's tracks (object ids), with counts above
/// `accel_limit_mps2` and above `heading_limit_rad` per 0.2 s. A track's class is that of its first
/// observation. Needs a frame period (`DatasetInfo::frame_period_s`, or the median frame gap).
#[must_use]
pub fn motion_extremes(ds: &Dataset, accel_limit_mps2: f64, heading_limit_rad: f64) -> Vec<MotionExtremes> {
    let period = frame_period(ds);
    let max_gap = 1.5 * period;
    // steps for 0.2 s
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // small positive ratio
    let steps = ((0.2 / period).round() as usize).max(1);

    let mut out: BTreeMap<ObjectClass, MotionExtremes> = BTreeMap::new();
    for (id, track) in &tracks_of(&ds.frames) {
        let Some(class) = track.first().map(|o| o.class) else { continue };
        let obs: Vec<&Obs> = track.iter().map(|o| &o.obs).collect();
        let m = out.entry(class).or_insert_with(|| MotionExtremes::new(class));
        m.tracks += 1;
        m.observations += obs.len();
        // forward-difference speeds between consecutive observations
        let mut v: Vec<Option<(f64, f64)>> = Vec::with_capacity(obs.len());
        for w in obs.windows(2) {
            let (Some(a), Some(b)) = (w.first(), w.get(1)) else { continue };
            let dt = b.t - a.t;
            v.push(step_speed(a, b, max_gap).map(|speed| (speed, (a.t + b.t) / 2.0)));
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

/// Which labelled states sit on a *speed glitch of the labels themselves*: for object `i` of frame `f`,
/// `out[f][i]` is true when, at this state or at one of the track's states in the `window_s` before it, the
/// recorded `speed_mps` differs by more than `threshold_mps` from the speed of the recorded positions (the mean of
/// the one-step position differences to the previous and the next observation, each within 1.5 frame periods).
///
/// Such a state is not a clean state: the labels contradict themselves (NGSIM's differentiated video tracks
/// record speed steps of up to 2.7 m/s in 0.1 s that their positions do not show, docs/plausibility.md), and an
/// alarm there reports a real error of the data. The same rule as `python/examples/ngsim_speed_glitches.py`
/// (which reads the CommonRoad XML itself), so the two can be compared.
#[must_use]
pub fn speed_label_glitches(
    frames: &[crate::DatasetFrame],
    frame_period_s: f64,
    threshold_mps: f64,
    window_s: f64,
) -> Vec<Vec<bool>> {
    let max_gap = 1.5 * frame_period_s;
    let mut out: Vec<Vec<bool>> = frames.iter().map(|f| vec![false; f.frame.objects.len()]).collect();
    for obs in tracks_of(frames).values() {
        // The gap of each state: |recorded speed - speed of its positions|, when it has a neighbour in time.
        let gaps: Vec<Option<f64>> = (0..obs.len())
            .map(|i| {
                let here = &obs.get(i)?.obs;
                let before = i.checked_sub(1).and_then(|j| obs.get(j)).and_then(|p| step_speed(&p.obs, here, max_gap));
                let after = obs.get(i + 1).and_then(|n| step_speed(here, &n.obs, max_gap));
                let w: Vec<f64> = [before, after].into_iter().flatten().collect();
                #[allow(clippy::cast_precision_loss)] // one or two
                let mean = (!w.is_empty()).then(|| w.iter().sum::<f64>() / w.len() as f64)?;
                Some((here.speed - mean).abs())
            })
            .collect();
        for (i, o) in obs.iter().enumerate() {
            let glitched = (0..=i)
                .rev()
                .take_while(|&j| obs.get(j).is_some_and(|p| o.obs.t - p.obs.t <= window_s + 0.5 * frame_period_s))
                .any(|j| gaps.get(j).copied().flatten().is_some_and(|g| g > threshold_mps));
            if let Some(slot) = out.get_mut(o.frame).and_then(|f| f.get_mut(o.object)) {
                *slot = glitched;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use pmon_monitor::{ObjectState, Pose2};
    use pmon_recording::RecordedFrame;

    use super::*;
    use crate::DatasetFrame;

    /// A car driving at 10 m/s along x at 10 Hz, its recorded speed `speed(k)` at frame k.
    fn track(frames: usize, speed: impl Fn(usize) -> f32) -> Vec<DatasetFrame> {
        (0..frames)
            .map(|k| {
                #[allow(clippy::cast_precision_loss)]
                let t = k as f64 * 0.1;
                let mut frame = RecordedFrame::empty(k as u64, t, Pose2::default());
                #[allow(clippy::cast_possible_truncation)]
                frame.objects.push(ObjectState {
                    id: 7,
                    class: ObjectClass::Car,
                    x_m: (10.0 * t) as f32,
                    y_m: 0.0,
                    heading_rad: 0.0,
                    speed_mps: speed(k),
                    length_m: 4.5,
                    width_m: 1.8,
                    uncertainty: None,
                });
                DatasetFrame { frame, extras: vec![Default::default()] }
            })
            .collect()
    }

    #[test]
    fn a_recorded_speed_step_marks_its_state_and_the_next_half_second() {
        // Self-consistent: nothing marked.
        let clean = speed_label_glitches(&track(20, |_| 10.0), 0.1, 2.0, 0.5);
        assert!(clean.iter().flatten().all(|g| !g));
        // Frame 8 records 12.5 m/s while the box moves at 10: frames 8 to 13 (0.5 s) are marked, no other.
        let glitch = speed_label_glitches(&track(20, |k| if k == 8 { 12.5 } else { 10.0 }), 0.1, 2.0, 0.5);
        let marked: Vec<usize> = glitch.iter().enumerate().filter(|(_, g)| g[0]).map(|(k, _)| k).collect();
        assert_eq!(marked, (8..=13).collect::<Vec<_>>());
        // A step below the threshold marks nothing.
        let small = speed_label_glitches(&track(20, |k| if k == 8 { 11.5 } else { 10.0 }), 0.1, 2.0, 0.5);
        assert!(small.iter().flatten().all(|g| !g));
    }
}
