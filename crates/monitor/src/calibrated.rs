//! The calibrated, tracker-aware plausibility rule (beyond the paper; docs/plausibility.md).
//!
//! Per track a fixed-capacity ring buffer ([`History`]) keeps the last [`HISTORY`] states. For a new state
//! `s1` the rule computes, with the previous state `s0`:
//!
//! 1. **Heading** (only where defined: both reported speeds `>= heading_min_speed_mps`, neither speed in its
//!    warm-up). The heading sigma grows towards standstill as `sigma_th + sigma_v / v`. A change
//!    `|D| - z sigma_D > pi / 2` is a *heading flip*; otherwise `|D| / dt - z sigma_D / dt > omega_max` is a
//!    *turn rate* beyond the limit (`z`: the two-sided normal quantile of `false_alarm_probability`). After a
//!    state called flipped, the new heading is also compared with the newest not-flipped state within
//!    `baseline_s`: a heading that stays flipped is a flip in each frame, as long as the box's motion since the
//!    first flipped state agrees with the old heading at least as well as with the new one (an object that
//!    really turned around moves along its new heading).
//! 2. **Acceleration** `(v1 - v0) / dt` against `a_acc`, `a_br` with margin `z hypot(sigma_v0, sigma_v1) / dt`
//!    (skipped while the new speed is in its warm-up; at the first initialised speed after a warm-up the
//!    warm-up's 0 carries the warm-up sigma, and an alarm names the warm-up's speed error).
//! 3. **Motion** over a baseline: the start `b` is the oldest state within `baseline_s` that raised no alarm
//!    and whose speed is initialised (else the oldest initialised one in the window, else the previous state). The displacement predicted by the reported
//!    velocities, `sum_i dt_i / 2 (v_i u_i + v_(i+1) u_(i+1))` (trapezoid, `u` the heading's unit vector), is
//!    compared with the observed `p1 - p_b`. Box re-fits: the residual shrinks by half the length change along
//!    the box and half the width change across it (the reference point moved, the object did not). The
//!    covariance `S` is the two positions' plus each velocity's (`sigma_v` along the heading,
//!    `v sigma_th + sigma_v` across, weighted by its share of the baseline; speed errors independent from frame
//!    to frame, as in the paper's propagation). Implausible if `r^T S^-1 r > -2 ln p` (chi-square, 2 degrees of
//!    freedom).
//!
//! Kinds: a flip first; then for the motion, a *position jump* if the box also leaves the straight-line
//! extrapolation of its own last two alarm-free positions (positions only, `a_acc dt^2` allowed; or that
//! distance is at least 0.7 of the motion residual), else a
//! *speed inconsistent with motion*; an acceleration alarm alone is a *speed* error when the new speed is far
//! from the speed observed over the baseline, else *acceleration*.
//!
//! Each gate fires with probability at most `p` on honest Gaussian input, so a state raises a false alarm
//! with probability at most about `4 p`. Every loop is bounded by [`HISTORY`].

use crate::geometry::wrap_angle;
use crate::params::MotionLimits;
use crate::verdict::{Conditions, ImplausibilityKind};

mod history;
mod stats;

use history::{clean_unless_alarm, one_frame_residual, ring_index};
pub use history::{one_frame_d2, Entry, History};
pub use stats::{own_dof, robust_rank, Gates};

/// States kept per track (the current one included once pushed).
pub const HISTORY: usize = 12;

/// Speed steps kept per track for the robust own scatter ([`History::robust_speed_scale`]).
pub const SPEED_STEPS: usize = 24;

/// Fewest clean increments in a track's history before its own scatter may narrow a margin.
pub const OWN_SCATTER_MIN_INCREMENTS: u8 = 5;
/// Smallest own scatter used, as a fraction of the declared sigma (a track whose speeds never change is not
/// taken to be noise-free: the margin stays at least `t` times this fraction of the declared one).
pub const OWN_SCATTER_FLOOR: f64 = 0.05;
/// Both speeds at least this for a heading change to count as a sample of the heading's own scatter, m/s.
pub const OWN_HEADING_MIN_SPEED_MPS: f32 = 1.0;
/// Smallest own position scatter used, as a fraction of the declared sigma of a one-frame residual (a track
/// whose box never moves is not taken to be noise-free).
pub const OWN_POSITION_FLOOR: f64 = 0.35;

/// Safety-critical position error (the paper's Sec. III-A), metres.
pub const CRITICAL_POSITION_M: f64 = 1.0;
/// Safety-critical speed error (the paper's Sec. III-A), m/s.
pub const CRITICAL_SPEED_MPS: f64 = 3.0;

/// What the calibrated rule found for one state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibratedCheck {
    /// Conditions that fired (flip and turn rate as `TURN_RATE`, motion as `POSITION`).
    pub fired: Conditions,
    /// What is wrong, when something fired.
    pub kind: Option<ImplausibilityKind>,
    /// Its size in the kind's unit.
    pub error_size: f64,
    /// Size over the safety-critical size.
    pub severity: f64,
    /// Acceleration estimate and margin, m/s^2.
    pub accel: (f64, f64),
    /// Turn-rate estimate and margin, rad/s (0, 0 when the heading is not defined).
    pub turn_rate: (f64, f64),
    /// Predicted position `p_b + sum`, world frame, metres.
    pub predicted: [f64; 2],
    /// Sigma of the residual per axis, metres.
    pub predicted_margin: [f64; 2],
    /// `|r|` after the re-fit allowance, metres.
    pub residual: f64,
    /// Distance along `r` at which the gate fires, metres.
    pub allowance: f64,
    /// When the one-frame residual failed the track's own position scatter (and the baseline test did not
    /// fire): that residual and the distance along it at which the own-scatter gate fires, metres.
    pub own_position: Option<(f64, f64)>,
    /// Half the Mahalanobis distance squared of the one-frame residual from the newest state (as
    /// [`one_frame_d2`]) when both states are clean (the new one taken to be alarm-free) and it is finite, else
    /// negative: the position step [`History::push`] keeps for a new state that raised no alarm.
    pub position_step: f32,
    /// The speed step [`History::push`] keeps in the robust scatter's ring for the new state (`speed_step_any`
    /// of the newest state and the new one: computed here from the same variance and change the acceleration
    /// test takes), and the clean steps it keeps for the new state when it raises no alarm (`steps_from_any`
    /// with the new state taken to be alarm-free): the same numbers, computed once.
    pub speed_step: f32,
    /// See [`CalibratedCheck::speed_step`].
    pub steps_if_no_alarm: (f32, f32),
}

/// `sqrt(a^2 + b^2)` without `hypot`'s care for overflow (the values here are metres, m/s and radians: far from
/// it), several times faster.
fn norm(a: f64, b: f64) -> f64 {
    libm::sqrt(a * a + b * b)
}

/// [`wrap_angle`] of a difference of two wrapped angles (within `[-2 pi, 2 pi]`) without `fmod`.
fn wrap_difference(a: f64) -> f64 {
    use core::f64::consts::{PI, TAU};
    if a > PI && a <= 3.0 * PI {
        a - TAU
    } else if a <= -PI && a > -3.0 * PI {
        a + TAU
    } else if a > -PI && a <= PI {
        a
    } else {
        wrap_angle(a)
    }
}

fn shrink(r: f64, by: f64) -> f64 {
    if r > by {
        r - by
    } else if r < -by {
        r + by
    } else {
        0.0
    }
}

/// Residual after the re-fit allowance: `r` in the frame of the heading `(s, c)` = (sin, cos), each axis shrunk.
fn refit_allowance(r: [f64; 2], (s, c): (f64, f64), dl: f64, dw: f64) -> [f64; 2] {
    let lon = shrink(c * r[0] + s * r[1], 0.5 * dl.abs());
    let lat = shrink(-s * r[0] + c * r[1], 0.5 * dw.abs());
    [c * lon - s * lat, s * lon + c * lat]
}

/// Mahalanobis distance squared of `r` under the symmetric `[sxx, sxy, syy]`.
fn mahalanobis2(r: [f64; 2], s: [f64; 3]) -> f64 {
    let det = s[0] * s[2] - s[1] * s[1];
    if det.is_nan() || det <= 0.0 {
        return f64::INFINITY;
    }
    (s[2] * r[0] * r[0] - 2.0 * s[1] * r[0] * r[1] + s[0] * r[1] * r[1]) / det
}

/// Adds a velocity's covariance (`sv` along the heading `(c, s)` = (cos, sin), `sc` across), weighted by `w`
/// seconds.
fn add_velocity_cov(cov: &mut [f64; 3], w: f64, (s, c): (f64, f64), sv: f64, sc: f64) {
    let (a, b) = ((w * sv) * (w * sv), (w * sc) * (w * sc));
    cov[0] += a * c * c + b * s * s;
    cov[1] += (a - b) * s * c;
    cov[2] += a * s * s + b * c * c;
}

/// The displacement the reported velocities predict from the history's state `from` to `last` (the new state,
/// with its [`Entry::unit`]), by the trapezoid over `from`, the states after it and `last` (each velocity weighs
/// half of its two adjacent intervals), and its covariance: both positions' and every velocity's. With
/// `skip_flipped`, a state after `from` whose heading was called flipped lends no velocity.
fn trapezoid(h: &History, from: &Entry, b: usize, last: &Entry, skip_flipped: bool) -> ([f64; 2], [f64; 3]) {
    let n = h.len();
    let sq = |x: f32| f64::from(x) * f64::from(x);
    let mut pred = [0.0f64; 2];
    let mut cov = [sq(from.sx_m) + sq(last.sx_m), 0.0, sq(from.sy_m) + sq(last.sy_m)];
    if b > n {
        return (pred, cov);
    }
    let add = |e: &Entry, w: f64, pred: &mut [f64; 2], cov: &mut [f64; 3]| {
        let v = f64::from(e.v_mps);
        let (s, c) = (f64::from(e.unit[1]), f64::from(e.unit[0]));
        pred[0] += w * v * c;
        pred[1] += w * v * s;
        let sv = f64::from(e.sv_mps);
        add_velocity_cov(cov, w, (s, c), sv, v * f64::from(e.sh_rad) + sv);
    };
    // The states b..n in the ring's slots (b itself never skipped), then `last`: the sequence
    // [`trapezoid_reference`] walks, with the same weights added in the same order.
    let mut prev: &Entry = if b < n { h.get(b).unwrap_or(last) } else { last };
    let mut prev_w = 0.0f64;
    if b < n {
        let mut slot = ring_index(usize::from(h.start) + b, HISTORY);
        for _ in b + 1..n {
            slot += 1;
            if slot >= HISTORY {
                slot -= HISTORY;
            }
            let e = h.items.get(slot).unwrap_or(last);
            if skip_flipped && e.flipped {
                continue;
            }
            let half = 0.5 * (e.t_s - prev.t_s);
            add(prev, prev_w + half, &mut pred, &mut cov);
            prev_w = half;
            prev = e;
        }
        let half = 0.5 * (last.t_s - prev.t_s);
        add(prev, prev_w + half, &mut pred, &mut cov);
        prev_w = half;
        prev = last;
    }
    add(prev, prev_w, &mut pred, &mut cov);
    (pred, cov)
}

/// [`trapezoid`] as it was written first (state by state through [`History::get`]): the reference the tests hold
/// it to.
#[cfg(test)]
fn trapezoid_reference(h: &History, from: &Entry, b: usize, last: &Entry, skip_flipped: bool) -> ([f64; 2], [f64; 3]) {
    let n = h.len();
    let sq = |x: f32| f64::from(x) * f64::from(x);
    let mut pred = [0.0f64; 2];
    let mut cov = [sq(from.sx_m) + sq(last.sx_m), 0.0, sq(from.sy_m) + sq(last.sy_m)];
    let mut prev: Option<&Entry> = None;
    let mut prev_w = 0.0f64;
    let add = |e: &Entry, w: f64, pred: &mut [f64; 2], cov: &mut [f64; 3]| {
        let v = f64::from(e.v_mps);
        let (s, c) = (f64::from(e.unit[1]), f64::from(e.unit[0]));
        pred[0] += w * v * c;
        pred[1] += w * v * s;
        let sv = f64::from(e.sv_mps);
        add_velocity_cov(cov, w, (s, c), sv, v * f64::from(e.sh_rad) + sv);
    };
    for j in b..=n {
        let e = if j < n { h.get(j).unwrap_or(last) } else { last };
        if skip_flipped && j != b && j < n && e.flipped {
            continue;
        }
        if let Some(p) = prev {
            let half = 0.5 * (e.t_s - p.t_s);
            add(p, prev_w + half, &mut pred, &mut cov);
            prev_w = half;
        }
        prev = Some(e);
    }
    if let Some(p) = prev {
        add(p, prev_w, &mut pred, &mut cov);
    }
    (pred, cov)
}

/// For a heading that may stay flipped: does the box's motion from the history's state `f` (the first state
/// called flipped) to `s1` (with its [`Entry::unit`]) agree better with the reported headings than with the
/// headings turned by pi? The two hypotheses predict opposite displacements, `a` (the trapezoid of the reported
/// velocities from `f` to `s1`) and `-a`, with the same covariance `S` (both positions and every velocity: a
/// velocity's covariance is the same along `u` and along `-u`), so the new headings fit better, `(d - a)^T S^-1
/// (d - a) < (d + a)^T S^-1 (d + a)`, exactly when `a^T S^-1 d > 0`, `d` the observed displacement. Before the
/// test each component of `d` along and across `s1`'s box is shrunk towards 0 by half the change of the box's
/// length and width since `f` (a re-fit moves the reference point without the object moving, which is no
/// evidence of a turn). A tie (no motion, or no usable covariance) is not a turn: the flip stays reported.
fn turn_explains_motion(h: &History, f: usize, s1: &Entry) -> bool {
    let Some(sf) = h.get(f) else { return false };
    let (a, cov) = trapezoid(h, sf, f, s1, false);
    let (s, c) = (f64::from(s1.unit[1]), f64::from(s1.unit[0]));
    let d = refit_allowance(
        [s1.x_m - sf.x_m, s1.y_m - sf.y_m],
        (s, c),
        f64::from(s1.length_m - sf.length_m),
        f64::from(s1.width_m - sf.width_m),
    );
    let det = cov[0] * cov[2] - cov[1] * cov[1];
    if det.is_nan() || det <= 0.0 {
        return false;
    }
    let agreement = (cov[2] * a[0] * d[0] - cov[1] * (a[0] * d[1] + a[1] * d[0]) + cov[0] * a[1] * d[1]) / det;
    agreement > 0.0
}

/// Runs the calibrated rule for the new state `s1` against the track's history (newest last; must not be
/// empty, and `s1.t_s` must be later than the newest state: the caller checks).
#[must_use]
pub fn check_calibrated(
    h: &History,
    s1: &Entry,
    limits: &MotionLimits,
    gates: &Gates,
    heading_min_speed_mps: f64,
    baseline_s: f64,
) -> CalibratedCheck {
    let u1 = libm::sincos(f64::from(s1.heading_rad));
    check_calibrated_sc(
        h,
        &Entry { unit: [u1.1 as f32, u1.0 as f32], ..*s1 },
        u1,
        limits,
        gates,
        heading_min_speed_mps,
        baseline_s,
        false,
    )
}

/// [`check_calibrated`] with `u1 = libm::sincos(f64::from(s1.heading_rad))` given (computed once per state) and
/// `s1`'s [`Entry::unit`] set from it (`[u1.1 as f32, u1.0 as f32]`, as [`History::push`] sets it).
/// `times_in_order` says that the history's times are finite and strictly increasing (the track table's
/// histories are: it pushes a state only after its time, finite, passed `t - t_prev > 0`): the states before
/// the baseline's window are then skipped by a binary search instead of a scan (the same state is found; test
/// `ordered_baseline_search_finds_the_scan_s_state`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn check_calibrated_sc(
    h: &History,
    s1: &Entry,
    u1: (f64, f64),
    limits: &MotionLimits,
    gates: &Gates,
    heading_min_speed_mps: f64,
    baseline_s: f64,
    times_in_order: bool,
) -> CalibratedCheck {
    let n = h.len();
    let s0 = h.last().unwrap_or(s1);
    let dt = (s1.t_s - s0.t_s).max(1e-9);
    let (v0, v1) = (f64::from(s0.v_mps), f64::from(s1.v_mps));
    let mut fired = Conditions::default();
    let mut kind = None;
    let mut error_size = 0.0;
    let mut severity = 0.0;

    // 1. Heading.
    let mut turn = (0.0, 0.0);
    let heading_defined = !s0.warmup && !s1.warmup && v0.min(v1) >= heading_min_speed_mps;
    let d_heading = wrap_difference(f64::from(s1.heading_rad) - f64::from(s0.heading_rad));
    // `a^2 + b^2` of the two heading sigmas, as `norm` and `steps_from_any` compute it (computed once).
    let heading_var = || {
        let (a, b) = (s0.heading_sigma(), s1.heading_sigma());
        a * a + b * b
    };
    let mut var_h = None;
    if heading_defined {
        let vh = heading_var();
        var_h = Some(vh);
        let m = gates.factor(h.own_heading_scatter()) * libm::sqrt(vh);
        turn = (d_heading / dt, m / dt);
        let w_max = f64::from(limits.turn_rate_max_radps).abs();
        if libm::fabs(d_heading) - m > core::f64::consts::FRAC_PI_2 {
            fired = fired.union(Conditions::TURN_RATE);
            kind = Some(ImplausibilityKind::HeadingFlip);
            error_size = libm::fabs(d_heading);
            severity = 2.0 * 0.5 * (v0 + v1) * libm::sin(0.5 * libm::fabs(d_heading)) / CRITICAL_SPEED_MPS;
        } else if libm::fabs(turn.0) - turn.1 > w_max {
            fired = fired.union(Conditions::TURN_RATE);
            kind = Some(ImplausibilityKind::TurnRate);
            error_size = libm::fabs(turn.0) - w_max;
            severity = 0.5 * (v0 + v1) * error_size * dt / CRITICAL_SPEED_MPS;
        }
    }

    // 1b. A heading that stays flipped: after a state called flipped, the new heading is compared with the
    // newest state before it that was not flipped (within the baseline, heading defined there): a tracker that
    // keeps the flipped heading for several frames reports a flipped heading in each of them, although the
    // heading is steady from one flipped frame to the next. It is called flipped again only when the box's
    // motion since the first flipped state agrees with the old heading at least as well as with the new one
    // (see [`turn_explains_motion`]): an object that really turned around moves along its new heading.
    if kind.is_none() && s0.flipped && !s1.warmup && v1 >= heading_min_speed_mps {
        let mut reference = None;
        for i in (0..n).rev() {
            let Some(e) = h.get(i) else { break };
            if s1.t_s - e.t_s > baseline_s + 1e-9 {
                break;
            }
            if !e.flipped && !e.warmup {
                reference = Some((i, e));
                break;
            }
        }
        if let Some((ri, r)) = reference.filter(|(_, r)| f64::from(r.v_mps) >= heading_min_speed_mps) {
            let d = wrap_difference(f64::from(s1.heading_rad) - f64::from(r.heading_rad));
            let m = gates.factor(h.own_heading_scatter()) * norm(r.heading_sigma(), s1.heading_sigma());
            if libm::fabs(d) - m > core::f64::consts::FRAC_PI_2 && !turn_explains_motion(h, ri + 1, s1) {
                fired = fired.union(Conditions::TURN_RATE);
                kind = Some(ImplausibilityKind::HeadingFlip);
                error_size = libm::fabs(d);
                severity = (f64::from(r.v_mps) + v1) * libm::sin(0.5 * libm::fabs(d)) / CRITICAL_SPEED_MPS;
            }
        }
    }

    // 2. Acceleration.
    let accel = (v1 - v0) / dt;
    // (The own scatter narrows the margin only between initialised speeds: at the end of a warm-up the step
    // is the warm-up's error, judged with the warm-up sigma.)
    // Two estimates of the track's own speed scatter narrow it, each a test at `p`: the mean of squares of the clean
    // steps (Student's t) and the robust order statistic of every step (which the track's errors do not move).
    let speed_factor = if s0.warmup || s1.warmup {
        gates.z
    } else {
        gates.speed_factor(h.own_speed_scatter(), h.robust_speed_scale())
    };
    // The first initialised speed after a warm-up is checked too. The warm-up's 0 is no measurement (the tracker
    // did not know the speed), so the step from it carries only the new speed's sigma: a step beyond
    // `a_acc dt + z sigma_v` says that the object moved at that speed while the tracker reported 0 (a speed error
    // of the warm-up, named below). (The warm-up sigma stays in the motion test over the baseline.)
    let warmup_end = s0.warmup && !s1.warmup;
    // (`norm`'s sum of squares, also the speed step's variance below.)
    let (sv0, sv1) = (f64::from(s0.sv_mps), f64::from(s1.sv_mps));
    let var_v = sv0 * sv0 + sv1 * sv1;
    let accel_margin =
        if warmup_end { speed_factor * f64::from(s1.sv_mps) / dt } else { speed_factor * libm::sqrt(var_v) / dt };
    let accel_fired = (warmup_end || (!s0.warmup && !s1.warmup))
        && (accel - accel_margin > f64::from(limits.accel_max_mps2)
            || accel + accel_margin < f64::from(limits.brake_max_mps2));

    // 3. Motion over the baseline: the oldest alarm-free, initialised state within baseline_s, else s0.
    // When every state in the window raised an alarm (a permanent error), the oldest in the window: the error
    // keeps showing over the whole baseline.
    let within = |e: &Entry| s1.t_s - e.t_s <= baseline_s + 1e-9;
    // A young track whose only initialised states raised alarms (a jump in its second frame) is measured
    // from its alarm-free warm-up state (whose speed sigma covers the unknown speed) rather than from the
    // alarmed state, which every later state would echo. (One scan for the three candidates.)
    let (mut oldest_clean, mut oldest_alarm_free, mut oldest_any) = (None, None, None);
    // (The states in the ring's slots, oldest first: the states `h.get(first..n)`. With the times in order the
    // test `within` is false for the states before the first one within the window and true from it on, so
    // those states, which the scan would skip, are skipped by a binary search.)
    let mut first = 0;
    if times_in_order {
        let mut len = n;
        while len > 0 {
            let half = len / 2;
            let slot = usize::from(h.start) + first + half;
            let slot = if slot >= HISTORY { slot - HISTORY } else { slot };
            if h.items.get(slot).is_some_and(|e| !within(e)) {
                first += half + 1;
                len -= half + 1;
            } else {
                len = half;
            }
        }
    }
    let slot = usize::from(h.start) + first;
    let mut slot = if slot >= HISTORY { slot - HISTORY } else { slot };
    for i in first..n {
        let Some(e) = h.items.get(slot) else { break };
        slot = if slot + 1 >= HISTORY { slot + 1 - HISTORY } else { slot + 1 };
        if !within(e) {
            continue;
        }
        if !e.suspect {
            if oldest_clean.is_none() && !e.warmup {
                oldest_clean = Some(i);
            }
            if oldest_alarm_free.is_none() {
                oldest_alarm_free = Some(i);
            }
        }
        if oldest_any.is_none() && !e.warmup {
            oldest_any = Some(i);
        }
        if oldest_clean.is_some() {
            // The first choice is found; the others are used only without it.
            break;
        }
    }
    let b = oldest_clean.or(oldest_alarm_free).or(oldest_any).unwrap_or(n.saturating_sub(1));
    let sb = h.get(b).unwrap_or(s0);
    // Trapezoid over b, the states after it, and s1 (a state whose heading was called flipped lends no velocity).
    let (pred, cov) = trapezoid(h, sb, b, s1, true);
    let raw = [s1.x_m - sb.x_m - pred[0], s1.y_m - sb.y_m - pred[1]];
    let r = refit_allowance(raw, u1, f64::from(s1.length_m - sb.length_m), f64::from(s1.width_m - sb.width_m));
    let d2 = mahalanobis2(r, cov);
    let residual = norm(r[0], r[1]);
    // (A residual of exactly 0, noise-free input, has no direction: the allowance along the wider axis.)
    // (`0 < d2 < inf`: positive and finite, as one pair of comparisons.)
    let allowance = if d2 > 0.0 && d2 < f64::INFINITY {
        residual * libm::sqrt(gates.chi2_2 / d2)
    } else if d2 <= 0.0 {
        libm::sqrt(gates.chi2_2 * cov[0].max(cov[2]))
    } else {
        f64::INFINITY
    };
    // 3b. The one-frame residual against the track's own position scatter (an F test: the declared sigmas are an
    // upper bound; a standing object's jitter from its own history tells a 1.5 m jump from its noise).
    // (Computed once: the same step is kept in the history when the new state raises no alarm.)
    let mut own_position = None;
    let mut position_step = -1.0f32;
    if n > 0 && clean_unless_alarm(s0, s1) {
        let (r1, d1) = one_frame_residual(s0, s1);
        let q = 0.5 * d1;
        if q.is_finite() {
            position_step = q as f32;
        }
        let gate = gates.position_gate(h.own_position_scatter());
        if gate.is_finite() && 0.5 * d1 > gate {
            let res1 = norm(r1[0], r1[1]);
            own_position = Some((res1, res1 * libm::sqrt(2.0 * gate / d1)));
        }
    }
    // The steps the push keeps for the new state: `speed_step_any(Some(s0), s1)` and `steps_from_any(Some(s0),
    // s1, speed_step)` with `s1` taken to be alarm-free, from the variances and changes computed above (the same
    // expressions; test `checked_steps_match_the_push_s_own`).
    let speed_step = if n > 0 && !s0.warmup && !s1.warmup {
        let dv = v1 - v0;
        let q = dv * dv / var_v;
        if var_v > 0.0 && q.is_finite() {
            q as f32
        } else {
            -1.0
        }
    } else {
        -1.0
    };
    let steps_if_no_alarm = if n > 0 && clean_unless_alarm(s0, s1) {
        let heading = if s0.v_mps.min(s1.v_mps) >= OWN_HEADING_MIN_SPEED_MPS {
            let vh = var_h.unwrap_or_else(heading_var);
            if vh > 0.0 {
                (d_heading * d_heading / vh) as f32
            } else {
                -1.0
            }
        } else {
            -1.0
        };
        let speed = if speed_step >= 0.0 { speed_step } else { -1.0 };
        (if speed.is_finite() { speed } else { -1.0 }, if heading.is_finite() { heading } else { -1.0 })
    } else {
        (-1.0, -1.0)
    };
    let motion_fired = d2 > gates.chi2_2 || own_position.is_some();
    // The speeds over the baseline name an alarm's kind; computed only for an alarm.
    let span = || (s1.t_s - sb.t_s).max(1e-9);
    let observed_speed = || norm(s1.x_m - sb.x_m, s1.y_m - sb.y_m) / span();
    let reported_speed = || norm(pred[0], pred[1]) / span();

    if motion_fired {
        fired = fired.union(Conditions::POSITION);
        if kind.is_none() {
            let (observed_speed, reported_speed) = (observed_speed(), reported_speed());
            // Positions only: the straight-line extrapolation of the two newest alarm-free states.
            let mut a = None;
            let mut c2 = None;
            for i in (0..n).rev() {
                if let Some(e) = h.get(i).filter(|e| !e.suspect) {
                    if a.is_none() {
                        a = Some(*e);
                    } else if e.t_s < a.map_or(0.0, |x: Entry| x.t_s) {
                        c2 = Some(*e);
                        break;
                    }
                }
            }
            let jump = match (a, c2) {
                (Some(a), Some(c2)) => {
                    let k = (s1.t_s - a.t_s) / (a.t_s - c2.t_s).max(1e-9);
                    let q = [a.x_m + k * (a.x_m - c2.x_m), a.y_m + k * (a.y_m - c2.y_m)];
                    let rj = refit_allowance(
                        [s1.x_m - q[0], s1.y_m - q[1]],
                        u1,
                        f64::from(s1.length_m - a.length_m),
                        f64::from(s1.width_m - a.width_m),
                    );
                    let sq = |x: f32| f64::from(x) * f64::from(x);
                    let acc = f64::from(limits.accel_max_mps2.max(-limits.brake_max_mps2))
                        * (s1.t_s - a.t_s)
                        * (s1.t_s - c2.t_s)
                        * 0.5;
                    let var = 0.5 * (sq(s1.sx_m) + sq(s1.sy_m))
                        + (1.0 + k) * (1.0 + k) * 0.5 * (sq(a.sx_m) + sq(a.sy_m))
                        + k * k * 0.5 * (sq(c2.sx_m) + sq(c2.sy_m))
                        + acc * acc;
                    let dj = norm(rj[0], rj[1]);
                    // A jump if the positions alone are off, or if they explain most of the residual (a speed
                    // error leaves the positions on their straight line).
                    // (Fired by the one-frame own-scatter test: a jump when that frame's residual is most of the
                    // baseline's; a speed error builds up over the baseline instead.)
                    let own_jump = own_position.is_some_and(|(r1, _)| r1 >= 0.7 * residual);
                    let size = own_position.map_or(dj, |(r1, _)| dj.max(r1));
                    Some((size, dj * dj / var > gates.chi2_2 || dj >= 0.7 * residual || own_jump))
                }
                _ => None,
            };
            match jump {
                Some((dj, true)) => {
                    kind = Some(ImplausibilityKind::PositionJump);
                    error_size = dj;
                    severity = dj / CRITICAL_POSITION_M;
                }
                Some((_, false)) => {
                    kind = Some(ImplausibilityKind::SpeedInconsistent);
                    error_size = reported_speed - observed_speed;
                    severity = libm::fabs(error_size) / CRITICAL_SPEED_MPS;
                }
                None => {
                    // A young track: the speed is the suspect when the new one is 0 or not yet initialised, or
                    // when the old one was and the new one agrees with the observed motion (the end of a
                    // warm-up); else the box (a 0.2 m/s car whose box moved 3 m jumped).
                    let new_speed_agrees = libm::fabs(v1 - observed_speed) <= 0.5 * observed_speed;
                    if s1.warmup || v1 < 1e-3 || ((s0.warmup || v0 < 1e-3) && new_speed_agrees) {
                        kind = Some(ImplausibilityKind::SpeedInconsistent);
                        error_size = reported_speed - observed_speed;
                        severity = libm::fabs(error_size) / CRITICAL_SPEED_MPS;
                    } else {
                        kind = Some(ImplausibilityKind::PositionJump);
                        error_size = residual;
                        severity = residual / CRITICAL_POSITION_M;
                    }
                }
            }
        }
    }
    if accel_fired {
        fired = fired.union(Conditions::ACCELERATION);
        if kind.is_none() {
            let observed_speed = observed_speed();
            // Which speed agrees with the motion observed over the baseline? At the end of a warm-up, the
            // warm-up's 0 was the error when the new speed agrees with the motion.
            if warmup_end && libm::fabs(v1 - observed_speed) <= libm::fabs(v0 - observed_speed) {
                kind = Some(ImplausibilityKind::SpeedInconsistent);
                error_size = v0 - observed_speed;
                severity = libm::fabs(error_size) / CRITICAL_SPEED_MPS;
            } else if libm::fabs(v1 - observed_speed) > libm::fabs(v0 - observed_speed) {
                kind = Some(ImplausibilityKind::SpeedInconsistent);
                error_size = v1 - observed_speed;
                severity = libm::fabs(error_size) / CRITICAL_SPEED_MPS;
            } else {
                let lim = if accel > 0.0 { f64::from(limits.accel_max_mps2) } else { f64::from(limits.brake_max_mps2) };
                kind = Some(ImplausibilityKind::Acceleration);
                error_size = accel - lim;
                severity = libm::fabs(error_size) * dt / CRITICAL_SPEED_MPS;
            }
        }
    }
    CalibratedCheck {
        fired,
        kind,
        error_size,
        severity,
        accel: (accel, accel_margin),
        turn_rate: turn,
        predicted: [sb.x_m + pred[0], sb.y_m + pred[1]],
        predicted_margin: [libm::sqrt(cov[0].max(0.0)), libm::sqrt(cov[2].max(0.0))],
        residual,
        allowance,
        own_position: if d2 > gates.chi2_2 { None } else { own_position },
        position_step,
        speed_step,
        steps_if_no_alarm,
    }
}

#[cfg(test)]
mod tests;
