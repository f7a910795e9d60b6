//! Per-track history and the plausibility checks of each frame (Section III-C).
//!
//! Tracks live in a vector sorted by id, rebuilt each frame by merging it with the frame's objects sorted by
//! id (an in-place `sort_unstable`, no allocation): no hashing, deterministic, `O(n log n)` per frame with a
//! bound of `2 * max_objects` tracks. A track that misses frames keeps its last state for up to
//! `max_time_step_s`, so a single dropped detection does not restart it.

use alloc::vec::Vec;

use crate::frame::{ObjectState, Pose2, Uncertainty};
use crate::geometry::wrap_angle;
use crate::motion::{check_motion, MeasuredState};
use crate::params::MonitorParams;
use crate::verdict::{MotionOutcome, MotionVerdict, NotMonitoredReason};

#[derive(Clone, Copy, Debug)]
struct Track {
    id: u64,
    state: MeasuredState,
}

/// The tracks' last states.
// Not `Clone`: a cloned `Vec` loses its spare capacity, and the per-frame buffers rely on it (no
// allocation per frame, pushes bounded by capacity). Build another with `new` instead.
#[derive(Debug)]
pub struct TrackTable {
    tracks: Vec<Track>,
    next: Vec<Track>,
    order: Vec<u32>,
}

/// An object's state in the world frame with its margins.
#[must_use]
pub fn to_world(o: &ObjectState, u: &Uncertainty, pose: &Pose2, t_s: f64) -> MeasuredState {
    let (x_m, y_m) = pose.transform_point(f64::from(o.x_m), f64::from(o.y_m));
    let (s, c) = libm::sincos(pose.yaw_rad);
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
        Self {
            tracks: Vec::with_capacity(2 * max_objects),
            next: Vec::with_capacity(2 * max_objects),
            order: Vec::with_capacity(max_objects),
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
        self.order.clear();
        self.order.extend(0..n as u32);
        self.order.sort_unstable_by_key(|&i| (objects.get(i as usize).map_or(u64::MAX, |o| o.id), i));

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
            while let Some(tr) = self.tracks.get(prev_i).copied() {
                if tr.id >= id {
                    break;
                }
                if t_s - tr.state.t_s <= p.max_time_step_s && self.next.len() + remaining_current + 1 < cap {
                    self.next.push(tr);
                }
                prev_i += 1;
            }
            let prev = match self.tracks.get(prev_i).copied() {
                Some(tr) if tr.id == id => {
                    prev_i += 1;
                    Some(tr)
                }
                _ => None,
            };
            let keep_prev = |next: &mut Vec<Track>| {
                if let Some(tr) = prev {
                    if next.len() < cap {
                        next.push(tr);
                    }
                }
            };
            if end - k > 1 {
                for j in k..end {
                    if let Some(o) = self.order.get(j).and_then(|&i| out.get_mut(i as usize)) {
                        *o = MotionOutcome::not_monitored(NotMonitoredReason::DuplicateId);
                    }
                }
                keep_prev(&mut self.next);
                k = end;
                continue;
            }
            let i = first as usize;
            let outcome = if !valid.get(i).copied().unwrap_or(false) {
                keep_prev(&mut self.next);
                MotionOutcome::not_monitored(NotMonitoredReason::InvalidState)
            } else {
                let u = obj.uncertainty.unwrap_or(p.default_uncertainty);
                let s1 = to_world(obj, &u, pose, t_s);
                let new_track = Track { id, state: s1 };
                match prev {
                    None => {
                        if self.next.len() < cap {
                            self.next.push(new_track);
                        }
                        MotionOutcome::not_monitored(NotMonitoredReason::FirstFrameOfTrack)
                    }
                    Some(tr) => {
                        let dt = t_s - tr.state.t_s;
                        if dt.is_nan() || dt <= 0.0 {
                            keep_prev(&mut self.next);
                            MotionOutcome::not_monitored(NotMonitoredReason::TimeStepNotPositive)
                        } else if dt > p.max_time_step_s {
                            if self.next.len() < cap {
                                self.next.push(new_track);
                            }
                            MotionOutcome::not_monitored(NotMonitoredReason::TimeStepTooLong)
                        } else {
                            if self.next.len() < cap {
                                self.next.push(new_track);
                            }
                            let m = check_motion(&tr.state, &s1, &p.limits_for(obj.class), f64::from(p.gamma_plaus));
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
                                predicted_margin_m: [m.predicted_margin[0] as f32, m.predicted_margin[1] as f32],
                                position_residual_m: m.residual as f32,
                                position_allowance_m: m.allowance as f32,
                                kind: None,
                                error_size: 0.0,
                                severity: 0.0,
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
        while let Some(tr) = self.tracks.get(prev_i).copied() {
            if t_s - tr.state.t_s <= p.max_time_step_s && self.next.len() < cap {
                self.next.push(tr);
            }
            prev_i += 1;
        }
        core::mem::swap(&mut self.tracks, &mut self.next);
    }
}
