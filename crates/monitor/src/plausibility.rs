//! Per-track history and the plausibility checks of each frame (Section III-C).
//!
//! Tracks live in a vector sorted by id, rebuilt each frame by merging it with the frame's objects sorted by
//! id (an in-place `sort_unstable`, no allocation): no hashing, deterministic, `O(n log n)` per frame with a
//! bound of `2 * max_objects` tracks. A track that misses frames keeps its last state for up to
//! `max_time_step_s`, so a single dropped detection does not restart it.

use alloc::vec::Vec;

pub use crate::calibrated::HISTORY;
use crate::calibrated::{check_calibrated_sc, CalibratedCheck, Entry, Gates, History};
use crate::frame::{ObjectState, Pose2, Uncertainty};
use crate::geometry::wrap_angle;
use crate::motion::{check_motion, MeasuredState};
use crate::params::{MonitorParams, PlausibilityMode};
use crate::verdict::{Conditions, ImplausibilityKind, MotionOutcome, MotionVerdict, NotMonitoredReason};

#[derive(Clone, Copy, Debug)]
struct Track {
    id: u64,
    /// The last state with the paper's margins (the paper's rule).
    state: MeasuredState,
    /// Slot of its last [`HISTORY`] states (with the calibrated rule's sigmas) in the table's pool of histories:
    /// the track itself stays small, so the per-frame merge copies no history.
    hist: u32,
    /// States seen since the track started.
    age: u32,
}

/// The calibrated rule's view of an object: its own uncertainty when given, else the class's tracker noise;
/// with `libm::sincos` of its (`f32`) heading, also set as its [`Entry::unit`] (computed once per state).
fn entry_of(o: &ObjectState, s: &MeasuredState, p: &MonitorParams, age: u32) -> (Entry, (f64, f64)) {
    let v = f64::from(o.speed_mps);
    let warmup = age < p.warmup_frames && o.speed_mps <= 0.0;
    let (sx, sy, sv, sh) = match o.uncertainty {
        Some(_) => (s.dx_m as f32, s.dy_m as f32, s.dv_mps as f32, s.dheading_rad as f32),
        None => {
            let n = p.noise_for(o.class);
            let sp = n.position_at(v) as f32;
            (sp, sp, n.speed_mps, n.heading_rad)
        }
    };
    let heading_rad = s.heading_rad as f32;
    let sc = libm::sincos(f64::from(heading_rad));
    let e = Entry {
        t_s: s.t_s,
        x_m: s.x_m,
        y_m: s.y_m,
        v_mps: o.speed_mps,
        heading_rad,
        sx_m: sx,
        sy_m: sy,
        sv_mps: if warmup { sv.max(p.warmup_speed_sigma_mps) } else { sv },
        sh_rad: sh,
        length_m: o.length_m,
        width_m: o.width_m,
        warmup,
        suspect: false,
        flipped: false,
        unit: [sc.1 as f32, sc.0 as f32],
    };
    (e, sc)
}

/// Kind and size of a paper-mode alarm the calibrated rule did not name: read off the conditions.
fn kind_from_conditions(c: Conditions, m: &crate::motion::MotionCheck) -> (ImplausibilityKind, f64, f64) {
    use crate::calibrated::{CRITICAL_POSITION_M, CRITICAL_SPEED_MPS};
    if c.contains(Conditions::TURN_RATE) && libm::fabs(m.turn_rate * m.dt_s) > core::f64::consts::FRAC_PI_2 {
        let d = libm::fabs(m.turn_rate * m.dt_s);
        (ImplausibilityKind::HeadingFlip, d, 0.0)
    } else if c.contains(Conditions::POSITION) {
        let e = m.residual - m.allowance;
        (ImplausibilityKind::PositionJump, e, e / CRITICAL_POSITION_M)
    } else if c.contains(Conditions::ACCELERATION) {
        let e = libm::fabs(m.accel) - m.accel_margin;
        (ImplausibilityKind::Acceleration, e, e * m.dt_s / CRITICAL_SPEED_MPS)
    } else {
        let e = libm::fabs(m.turn_rate) - m.turn_rate_margin;
        (ImplausibilityKind::TurnRate, e, 0.0)
    }
}

/// The tracks' last states.
// Not `Clone`: a cloned `Vec` loses its spare capacity, and the per-frame buffers rely on it (no
// allocation per frame, pushes bounded by capacity). Build another with `new` instead.
#[derive(Debug)]
pub struct TrackTable {
    tracks: Vec<Track>,
    next: Vec<Track>,
    order: Vec<u32>,
    /// The tracks' histories, allocated at construction: one per remembered track and one per object of a frame
    /// (a new track takes a slot before the old tracks after it in id order have given theirs back).
    pool: Vec<History>,
    /// Slots of `pool` not in use.
    free: Vec<u32>,
    /// The calibrated rule's gates and the false-alarm probability they are for (computed once: the Student-t
    /// quantiles take a bisection each).
    gates: Option<(f64, Gates)>,
}

/// An object's state in the world frame with its margins.
#[must_use]
pub fn to_world(o: &ObjectState, u: &Uncertainty, pose: &Pose2, t_s: f64) -> MeasuredState {
    to_world_sc(o, u, pose, libm::sincos(pose.yaw_rad), t_s)
}

/// [`to_world`] with `(s, c) = libm::sincos(pose.yaw_rad)` given (computed once per frame; the same arithmetic
/// as [`Pose2::transform_point`]).
fn to_world_sc(o: &ObjectState, u: &Uncertainty, pose: &Pose2, (s, c): (f64, f64), t_s: f64) -> MeasuredState {
    let (x, y) = (f64::from(o.x_m), f64::from(o.y_m));
    let (x_m, y_m) = (pose.x_m + c * x - s * y, pose.y_m + s * x + c * y);
    let (sx, sy) = (f64::from(u.x_m), f64::from(u.y_m));
    let (vx, vy) = (sx * sx, sy * sy);
    MeasuredState {
        t_s,
        x_m,
        y_m,
        v_mps: f64::from(o.speed_mps),
        heading_rad: wrap_angle(f64::from(o.heading_rad) + pose.yaw_rad),
        dx_m: libm::sqrt(c * c * vx + s * s * vy),
        dy_m: libm::sqrt(s * s * vx + c * c * vy),
        dv_mps: f64::from(u.speed_mps),
        dheading_rad: f64::from(u.heading_rad),
    }
}

impl TrackTable {
    /// Room for `max_objects` objects per frame and as many remembered tracks.
    #[must_use]
    pub fn new(max_objects: usize) -> Self {
        let slots = 3 * max_objects;
        let mut pool = Vec::with_capacity(slots);
        pool.resize(slots, History::default());
        Self {
            tracks: Vec::with_capacity(2 * max_objects),
            next: Vec::with_capacity(2 * max_objects),
            order: Vec::with_capacity(max_objects),
            pool,
            free: (0..slots as u32).rev().collect(),
            gates: None,
        }
    }

    /// Computes the calibrated rule's gates for false-alarm probability `p` now (about 7 M instructions, 2-3 ms:
    /// the quantiles of the robust speed scatter are integrals solved by bisection), so that the first checked
    /// frame does not pay for them; returns them. [`crate::Monitor::new`] calls it, and `check_frame` on every frame
    /// (computing them only when its parameters ask for another `p`).
    pub fn prepare_gates(&mut self, p: f64) -> Gates {
        match self.gates {
            Some((q, g)) if q.to_bits() == p.to_bits() => g,
            _ => {
                let g = Gates::new(p);
                self.gates = Some((p, g));
                g
            }
        }
    }

    /// Number of remembered tracks.
    #[must_use]
    pub fn len(&self) -> usize {
        self.tracks.len()
    }

    /// True when no track is remembered.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.tracks.is_empty()
    }

    /// Forgets every track.
    pub fn clear(&mut self) {
        for tr in &self.tracks {
            self.free.push(tr.hist);
        }
        self.tracks.clear();
    }

    /// Runs the plausibility checks for one frame. `valid[i]` says whether object `i` has a valid state;
    /// `out[i]` receives its outcome. `objects`, `valid` and `out` have the same length, at most the
    /// capacity given to [`TrackTable::new`] (the caller checks).
    pub fn check_frame(
        &mut self,
        t_s: f64,
        pose: &Pose2,
        objects: &[ObjectState],
        valid: &[bool],
        out: &mut [MotionOutcome],
        p: &MonitorParams,
    ) {
        let n = objects.len().min(valid.len()).min(out.len()).min(self.order.capacity());
        if !t_s.is_finite() || !pose.is_finite() {
            let reason =
                if t_s.is_finite() { NotMonitoredReason::InvalidState } else { NotMonitoredReason::InvalidTimestamp };
            for o in out.iter_mut() {
                *o = MotionOutcome::not_monitored(reason);
            }
            return;
        }
        let gates = self.prepare_gates(p.false_alarm_probability);
        let pose_sc = libm::sincos(pose.yaw_rad);
        self.order.clear();
        self.order.extend(0..n as u32);
        // (Objects already in strictly increasing id order, as trackers usually list them, are in the order the
        // sort would give: the keys `(id, i)` ascend already, so the sort is skipped.)
        let ascending = objects.get(..n).is_some_and(|o| o.windows(2).all(|w| matches!(w, [a, b] if a.id < b.id)));
        if !ascending {
            self.order.sort_unstable_by_key(|&i| (objects.get(i as usize).map_or(u64::MAX, |o| o.id), i));
        }

        self.next.clear();
        let cap = self.next.capacity();
        let mut prev_i = 0usize;
        let mut k = 0usize;
        while k < n {
            let Some(&first) = self.order.get(k) else { break };
            let Some(obj) = objects.get(first as usize) else { break };
            let id = obj.id;
            // The run of objects with this id.
            let mut end = k + 1;
            while self.order.get(end).and_then(|&j| objects.get(j as usize)).is_some_and(|o| o.id == id) {
                end += 1;
            }
            let remaining_current = n - end;
            // Remembered tracks with smaller ids: keep the recent ones while room remains for the current objects.
            // (Tracks are looked at by reference and copied only when kept: a track carries its history.)
            while let Some(tr) = self.tracks.get(prev_i) {
                if tr.id >= id {
                    break;
                }
                if t_s - tr.state.t_s <= p.max_time_step_s && self.next.len() + remaining_current + 1 < cap {
                    self.next.push(*tr);
                } else {
                    self.free.push(tr.hist);
                }
                prev_i += 1;
            }
            let prev = match self.tracks.get(prev_i) {
                Some(tr) if tr.id == id => {
                    prev_i += 1;
                    Some(*tr)
                }
                _ => None,
            };
            let keep_prev = |next: &mut Vec<Track>, free: &mut Vec<u32>| {
                if let Some(tr) = prev {
                    if next.len() < cap {
                        next.push(tr);
                    } else {
                        free.push(tr.hist);
                    }
                }
            };
            if end - k > 1 {
                for j in k..end {
                    if let Some(o) = self.order.get(j).and_then(|&i| out.get_mut(i as usize)) {
                        *o = MotionOutcome::not_monitored(NotMonitoredReason::DuplicateId);
                    }
                }
                keep_prev(&mut self.next, &mut self.free);
                k = end;
                continue;
            }
            let i = first as usize;
            let outcome = if !valid.get(i).copied().unwrap_or(false) {
                keep_prev(&mut self.next, &mut self.free);
                MotionOutcome::not_monitored(NotMonitoredReason::InvalidState)
            } else {
                let u = obj.uncertainty.unwrap_or(p.default_uncertainty);
                let s1 = to_world_sc(obj, &u, pose, pose_sc, t_s);
                // A new track in `slot` (the old track's, or a free one), remembered while there is room.
                let fresh = |slot: Option<u32>, next: &mut Vec<Track>, free: &mut Vec<u32>, pool: &mut [History]| {
                    let Some(slot) = slot.or_else(|| free.pop()) else { return };
                    match pool.get_mut(slot as usize) {
                        Some(h) if next.len() < cap => {
                            *h = History::with(entry_of(obj, &s1, p, 0).0);
                            next.push(Track { id, state: s1, hist: slot, age: 1 });
                        }
                        _ => free.push(slot),
                    }
                };
                match prev {
                    None => {
                        fresh(None, &mut self.next, &mut self.free, &mut self.pool);
                        MotionOutcome::not_monitored(NotMonitoredReason::FirstFrameOfTrack)
                    }
                    Some(tr) => {
                        let dt = t_s - tr.state.t_s;
                        if dt.is_nan() || dt <= 0.0 {
                            keep_prev(&mut self.next, &mut self.free);
                            MotionOutcome::not_monitored(NotMonitoredReason::TimeStepNotPositive)
                        } else if dt > p.max_time_step_s {
                            fresh(Some(tr.hist), &mut self.next, &mut self.free, &mut self.pool);
                            MotionOutcome::not_monitored(NotMonitoredReason::TimeStepTooLong)
                        } else {
                            let (mut e1, u1) = entry_of(obj, &s1, p, tr.age);
                            let limits = p.limits_for(obj.class);
                            let hist = self.pool.get(tr.hist as usize).unwrap_or(&History::EMPTY);
                            let cal = || -> CalibratedCheck {
                                check_calibrated_sc(
                                    hist,
                                    &e1,
                                    u1,
                                    &limits,
                                    &gates,
                                    f64::from(p.heading_min_speed_mps),
                                    p.baseline_s,
                                    // (The histories here hold finite, strictly increasing times: a state is
                                    // pushed only after `dt > 0` from the newest, and `t_s` is finite.)
                                    true,
                                )
                            };
                            // The calibrated check, whose steps of the new state are kept with it (computed once).
                            let mut checked = None;
                            let outcome = match p.plausibility_mode {
                                PlausibilityMode::Paper => {
                                    let m = check_motion(&tr.state, &s1, &limits, f64::from(p.gamma_plaus));
                                    let (kind, size, severity) = if m.fired.is_empty() {
                                        (None, 0.0, 0.0)
                                    } else if let Some(c) = Some(cal()).filter(|c| c.kind.is_some()) {
                                        (c.kind, c.error_size, c.severity)
                                    } else {
                                        let (k, e, s) = kind_from_conditions(m.fired, &m);
                                        (Some(k), e, s)
                                    };
                                    MotionOutcome {
                                        verdict: if m.fired.is_empty() {
                                            MotionVerdict::Plausible
                                        } else {
                                            MotionVerdict::Implausible(m.fired)
                                        },
                                        dt_s: m.dt_s,
                                        accel_mps2: m.accel as f32,
                                        accel_margin_mps2: m.accel_margin as f32,
                                        turn_rate_radps: m.turn_rate as f32,
                                        turn_rate_margin_radps: m.turn_rate_margin as f32,
                                        predicted_world_m: m.predicted,
                                        predicted_margin_m: [
                                            m.predicted_margin[0] as f32,
                                            m.predicted_margin[1] as f32,
                                        ],
                                        position_residual_m: m.residual as f32,
                                        position_allowance_m: m.allowance as f32,
                                        kind,
                                        error_size: size as f32,
                                        severity: severity as f32,
                                    }
                                }
                                PlausibilityMode::Calibrated => {
                                    let cal = cal();
                                    checked = Some(cal);
                                    MotionOutcome {
                                        verdict: if cal.fired.is_empty() {
                                            MotionVerdict::Plausible
                                        } else {
                                            MotionVerdict::Implausible(cal.fired)
                                        },
                                        dt_s: dt,
                                        accel_mps2: cal.accel.0 as f32,
                                        accel_margin_mps2: cal.accel.1 as f32,
                                        turn_rate_radps: cal.turn_rate.0 as f32,
                                        turn_rate_margin_radps: cal.turn_rate.1 as f32,
                                        predicted_world_m: cal.predicted,
                                        predicted_margin_m: [
                                            cal.predicted_margin[0] as f32,
                                            cal.predicted_margin[1] as f32,
                                        ],
                                        // (The one-frame residual when only the own-scatter test fired.)
                                        position_residual_m: cal.own_position.map_or(cal.residual, |o| o.0) as f32,
                                        position_allowance_m: cal.own_position.map_or(cal.allowance, |o| o.1) as f32,
                                        kind: cal.kind,
                                        error_size: cal.error_size as f32,
                                        severity: cal.severity as f32,
                                    }
                                }
                            };
                            e1.suspect = matches!(outcome.verdict, MotionVerdict::Implausible(_));
                            e1.flipped = e1.suspect && outcome.kind == Some(ImplausibilityKind::HeadingFlip);
                            // The track moves to its new place; its history is updated in its slot.
                            if self.next.len() < cap {
                                if let Some(h) = self.pool.get_mut(tr.hist as usize) {
                                    match checked {
                                        // (The steps computed by the check; a state that raised an alarm keeps
                                        // no position step and no clean steps.)
                                        Some(c) => h.push_checked(e1, &c),
                                        None => h.push_with_unit(e1),
                                    }
                                }
                                self.next.push(Track { state: s1, age: tr.age.saturating_add(1), ..tr });
                            } else {
                                self.free.push(tr.hist);
                            }
                            // No verdict from a NaN: every comparison with NaN is false, so no condition would fire (issue 15: a
                            // tiny dt made the acceleration infinite and the residual NaN, and a 573 m jump was called plausible).
                            if outcome_is_finite(&outcome) {
                                outcome
                            } else {
                                MotionOutcome::not_monitored(NotMonitoredReason::NonFiniteEstimate)
                            }
                        }
                    }
                }
            };
            if let Some(o) = out.get_mut(i) {
                *o = outcome;
            }
            k = end;
        }
        while let Some(tr) = self.tracks.get(prev_i) {
            if t_s - tr.state.t_s <= p.max_time_step_s && self.next.len() < cap {
                self.next.push(*tr);
            } else {
                self.free.push(tr.hist);
            }
            prev_i += 1;
        }
        core::mem::swap(&mut self.tracks, &mut self.next);
    }
}

/// True when every estimate and margin of a motion check is finite (also after narrowing to `f32`).
fn outcome_is_finite(o: &MotionOutcome) -> bool {
    o.accel_mps2.is_finite()
        && o.accel_margin_mps2.is_finite()
        && o.turn_rate_radps.is_finite()
        && o.turn_rate_margin_radps.is_finite()
        && o.predicted_margin_m[0].is_finite()
        && o.predicted_margin_m[1].is_finite()
        && o.position_residual_m.is_finite()
        && o.position_allowance_m.is_finite()
        && o.dt_s.is_finite()
        && o.predicted_world_m[0].is_finite()
        && o.predicted_world_m[1].is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::ObjectClass;
    use alloc::format;

    #[test]
    fn objects_in_id_order_and_shuffled_give_the_same_outcomes() {
        // The sort by id is skipped when the ids ascend already (its result): the same frames with their objects
        // listed in ascending id order and in a shuffled order give the same outcome per object, to the last
        // bit, in both modes (duplicates, which always take the sort, included in some frames).
        for mode in [PlausibilityMode::Paper, PlausibilityMode::Calibrated] {
            let p = MonitorParams { plausibility_mode: mode, ..MonitorParams::PAPER };
            let (mut sorted_table, mut shuffled_table) = (TrackTable::new(40), TrackTable::new(40));
            for k in 0..60u32 {
                let t = f64::from(k) * 0.1;
                let mut objects: Vec<ObjectState> = (0..30u64)
                    .map(|id| ObjectState {
                        id: 3 * id + 1,
                        class: if id % 3 == 0 { ObjectClass::Pedestrian } else { ObjectClass::Car },
                        x_m: (id as f32) * 2.0 + 0.8 * k as f32 * (1.0 + (id % 5) as f32),
                        y_m: (id as f32) - 0.01 * (k * k) as f32,
                        heading_rad: 0.05 * (id % 7) as f32 - 0.002 * k as f32,
                        speed_mps: 8.0 * (1.0 + (id % 5) as f32)
                            + if (k + id as u32).is_multiple_of(17) { 4.0 } else { 0.0 },
                        length_m: 4.0,
                        width_m: 1.8,
                        uncertainty: None,
                    })
                    .collect();
                if k % 11 == 5 {
                    if let Some(o) = objects.get_mut(7) {
                        o.id = 19; // the id of object 6: a duplicate
                    }
                }
                let pose = Pose2 { x_m: 0.3 * t, y_m: 0.0, yaw_rad: 0.01 * t };
                let valid = alloc::vec![true; objects.len()];
                let none = MotionOutcome::not_monitored(NotMonitoredReason::InvalidState);
                let mut out_sorted = alloc::vec![none; objects.len()];
                sorted_table.check_frame(t, &pose, &objects, &valid, &mut out_sorted, &p);
                // A fixed shuffle of the same objects.
                let order: Vec<usize> = (0..objects.len()).map(|i| (i * 7 + k as usize) % objects.len()).collect();
                let shuffled: Vec<ObjectState> = order.iter().filter_map(|&i| objects.get(i).copied()).collect();
                let mut out_shuffled = alloc::vec![none; objects.len()];
                shuffled_table.check_frame(t, &pose, &shuffled, &valid, &mut out_shuffled, &p);
                for (j, &i) in order.iter().enumerate() {
                    let (a, b) = (out_sorted.get(i), out_shuffled.get(j));
                    assert_eq!(format!("{a:?}"), format!("{b:?}"), "frame {k}, object {i}");
                }
            }
        }
    }
}
