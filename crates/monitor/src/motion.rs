//! The small-dt CTRA motion model and its error propagation (Section III-C).
//!
//! ## Model (eq. mot_mod)
//! Over a short interval `dt` a constant-turn-rate-and-acceleration motion moves an object by
//! `dx = v dt cos(th) + dt^2/2 (a cos(th) - v w sin(th))`,
//! `dy = v dt sin(th) + dt^2/2 (a sin(th) + v w cos(th))`.
//!
//! ## Estimates (eqs. pred1, pred2)
//! From two measured states `(x0, y0, v0, th0)` and `(x1, y1, v1, th1)`, `dt` apart:
//! `w = wrap(th1 - th0) / dt`, `a = (v1 - v0) / dt`, `x_hat = x0 + dx(dt, v0, th0, a, w)`, likewise `y_hat`.
//!
//! ## Error propagation
//! The measured quantities `x0, y0, v0, th0, v1, th1` are independent with margins `Delta q`; `dt` is exact.
//! First-order propagation gives `Delta f = sqrt(sum_q (df/dq Delta q)^2)`:
//! - `Delta w = sqrt(Delta th0^2 + Delta th1^2) / dt`, `Delta a = sqrt(Delta v0^2 + Delta v1^2) / dt`.
//! - Substituting the estimates into the model, with `D = wrap(th1 - th0)`:
//!   `x_hat = x0 + dt/2 (v0 + v1) cos(th0) - dt/2 v0 D sin(th0)`,
//!   `y_hat = y0 + dt/2 (v0 + v1) sin(th0) + dt/2 v0 D cos(th0)`, so
//!   - `dx_hat/dx0 = 1`, `dx_hat/dv0 = dt/2 (cos th0 - D sin th0)`, `dx_hat/dv1 = dt/2 cos th0`,
//!     `dx_hat/dth0 = -dt/2 (v1 sin th0 + v0 D cos th0)`, `dx_hat/dth1 = -dt/2 v0 sin th0`;
//!   - `dy_hat/dy0 = 1`, `dy_hat/dv0 = dt/2 (sin th0 + D cos th0)`, `dy_hat/dv1 = dt/2 sin th0`,
//!     `dy_hat/dth0 = dt/2 (v1 cos th0 - v0 D sin th0)`, `dy_hat/dth1 = dt/2 v0 cos th0`.
//!
//! ## Conditions (eqs. condition_w, condition_a, condition_xy)
//! Implausible if `w - Delta w > |w_max|` or `w + Delta w < -|w_max|`; if `a - Delta a > a_acc` or
//! `a + Delta a < a_br`; or if `||x_hat - x1|| - gamma_plaus (||Delta x_hat|| + ||Delta x1||) > 0`.

use crate::geometry::wrap_angle;
use crate::params::MotionLimits;
use crate::verdict::Conditions;

/// A measured state in the world frame, with its one-sigma margins.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredState {
    /// Timestamp, seconds.
    pub t_s: f64,
    /// Position, world frame, metres.
    pub x_m: f64,
    /// Position, world frame, metres.
    pub y_m: f64,
    /// Speed over ground, m/s.
    pub v_mps: f64,
    /// Heading, world frame, radians.
    pub heading_rad: f64,
    /// Margin of x, metres.
    pub dx_m: f64,
    /// Margin of y, metres.
    pub dy_m: f64,
    /// Margin of speed, m/s.
    pub dv_mps: f64,
    /// Margin of heading, radians.
    pub dheading_rad: f64,
}

/// Displacement `(dx, dy)` of eq. (mot_mod), metres.
#[must_use]
pub fn ctra_displacement(dt: f64, v: f64, heading: f64, a: f64, w: f64) -> (f64, f64) {
    ctra_displacement_sc(dt, v, libm::sincos(heading), a, w)
}

/// [`ctra_displacement`] with the heading's `(sin, cos)` given (computed once per check).
fn ctra_displacement_sc(dt: f64, v: f64, (s, c): (f64, f64), a: f64, w: f64) -> (f64, f64) {
    let h = 0.5 * dt * dt;
    (v * dt * c + h * (a * c - v * w * s), v * dt * s + h * (a * s + v * w * c))
}

/// Everything eqs. (pred1) to (condition_xy) compute for one pair of states.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionCheck {
    /// `dt`, seconds.
    pub dt_s: f64,
    /// `a_hat`, m/s^2.
    pub accel: f64,
    /// `Delta a_hat`, m/s^2.
    pub accel_margin: f64,
    /// `omega_hat`, rad/s.
    pub turn_rate: f64,
    /// `Delta omega_hat`, rad/s.
    pub turn_rate_margin: f64,
    /// `(x_hat, y_hat)`, metres.
    pub predicted: [f64; 2],
    /// `(Delta x_hat, Delta y_hat)`, metres.
    pub predicted_margin: [f64; 2],
    /// `||x_hat - x1||`, metres.
    pub residual: f64,
    /// `gamma_plaus (||Delta x_hat|| + ||Delta x1||)`, metres.
    pub allowance: f64,
    /// Conditions that fired.
    pub fired: Conditions,
}

/// `sqrt(a^2 + b^2)` without `libm::hypot`'s care for overflow (metres, m/s and radians are far from it), several
/// times faster.
fn norm(a: f64, b: f64) -> f64 {
    libm::sqrt(a * a + b * b)
}

/// Evaluates the plausibility of the motion from `s0` to `s1` (`s1.t_s - s0.t_s` must be > 0; the caller
/// checks). Implements eqs. (pred1), (pred2), the error propagation above, and the three conditions.
#[must_use]
pub fn check_motion(s0: &MeasuredState, s1: &MeasuredState, limits: &MotionLimits, gamma_plaus: f64) -> MotionCheck {
    let dt = s1.t_s - s0.t_s;
    let d_heading = wrap_angle(s1.heading_rad - s0.heading_rad);
    let turn_rate = d_heading / dt;
    let turn_rate_margin = norm(s0.dheading_rad, s1.dheading_rad) / dt;
    let accel = (s1.v_mps - s0.v_mps) / dt;
    let accel_margin = norm(s0.dv_mps, s1.dv_mps) / dt;

    let (s, c) = libm::sincos(s0.heading_rad);
    let (ddx, ddy) = ctra_displacement_sc(dt, s0.v_mps, (s, c), accel, turn_rate);
    let predicted = [s0.x_m + ddx, s0.y_m + ddy];

    let h = 0.5 * dt;
    let (v0, v1) = (s0.v_mps, s1.v_mps);
    let (dv0, dv1, dth0, dth1) = (s0.dv_mps, s1.dv_mps, s0.dheading_rad, s1.dheading_rad);
    let sq = |a: f64| a * a;
    let var_x = sq(s0.dx_m)
        + sq(h * (c - d_heading * s) * dv0)
        + sq(h * c * dv1)
        + sq(h * (v1 * s + v0 * d_heading * c) * dth0)
        + sq(h * v0 * s * dth1);
    let var_y = sq(s0.dy_m)
        + sq(h * (s + d_heading * c) * dv0)
        + sq(h * s * dv1)
        + sq(h * (v1 * c - v0 * d_heading * s) * dth0)
        + sq(h * v0 * c * dth1);
    let predicted_margin = [libm::sqrt(var_x), libm::sqrt(var_y)];

    let residual = norm(predicted[0] - s1.x_m, predicted[1] - s1.y_m);
    let allowance = gamma_plaus * (norm(predicted_margin[0], predicted_margin[1]) + norm(s1.dx_m, s1.dy_m));

    let w_max = f64::from(limits.turn_rate_max_radps).abs();
    let mut fired = Conditions::default();
    // Eq. (condition_w).
    if turn_rate - turn_rate_margin > w_max || turn_rate + turn_rate_margin < -w_max {
        fired = fired.union(Conditions::TURN_RATE);
    }
    // Eq. (condition_a).
    if accel - accel_margin > f64::from(limits.accel_max_mps2)
        || accel + accel_margin < f64::from(limits.brake_max_mps2)
    {
        fired = fired.union(Conditions::ACCELERATION);
    }
    // Eq. (condition_xy).
    if residual - allowance > 0.0 {
        fired = fired.union(Conditions::POSITION);
    }
    MotionCheck {
        dt_s: dt,
        accel,
        accel_margin,
        turn_rate,
        turn_rate_margin,
        predicted,
        predicted_margin,
        residual,
        allowance,
        fired,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(t: f64, x: f64, y: f64, v: f64, th: f64) -> MeasuredState {
        MeasuredState {
            t_s: t,
            x_m: x,
            y_m: y,
            v_mps: v,
            heading_rad: th,
            dx_m: 0.1,
            dy_m: 0.1,
            dv_mps: 1.0,
            dheading_rad: 10f64.to_radians(),
        }
    }

    #[test]
    fn ctra_displacement_by_hand() {
        // v = 10, a = 2, w = 0.5, heading 0, dt = 0.1: dx = 1 + 0.005 * 2 = 1.01, dy = 0.005 * 10 * 0.5 = 0.025.
        let (dx, dy) = ctra_displacement(0.1, 10.0, 0.0, 2.0, 0.5);
        assert!((dx - 1.01).abs() < 1e-12 && (dy - 0.025).abs() < 1e-12);
    }

    #[test]
    fn straight_constant_motion_is_plausible_and_margins_match_hand_values() {
        let s0 = state(0.0, 0.0, 0.0, 10.0, 0.0);
        let s1 = state(0.1, 1.0, 0.0, 10.0, 0.0);
        let m = check_motion(&s0, &s1, &MotionLimits::default(), 1.0);
        assert!(m.fired.is_empty());
        assert!(m.residual < 1e-12);
        // Delta a = sqrt(2) * 1 / 0.1.
        assert!((m.accel_margin - 2f64.sqrt() * 10.0).abs() < 1e-9);
        // Delta x_hat^2 = 0.1^2 + (0.05 dv0)^2 + (0.05 dv1)^2 = 0.01 + 0.0025 + 0.0025.
        assert!((m.predicted_margin[0] - 0.015f64.sqrt()).abs() < 1e-12);
        // Delta y_hat^2 = 0.1^2 + (0.05 * 10 * dth)^2 (th0 term, v1 = 10) + (0.05 * 10 * dth)^2 (th1 term).
        let dth = 10f64.to_radians();
        let want = (0.01 + 2.0 * (0.5 * dth).powi(2)).sqrt();
        assert!((m.predicted_margin[1] - want).abs() < 1e-12);
    }

    #[test]
    fn each_condition_fires_alone() {
        let lim = MotionLimits::default();
        // Acceleration: speed jumps by 5 m/s in 0.1 s (a = 50, margin 14.1): beyond 7.
        let m = check_motion(&state(0.0, 0.0, 0.0, 5.0, 0.0), &state(0.1, 0.5, 0.0, 10.0, 0.0), &lim, 1.0);
        assert!(m.fired.contains(Conditions::ACCELERATION));
        // Turn rate: heading jumps by 2 rad in 0.1 s: 20 rad/s - 2.47 > 7.85.
        let m = check_motion(&state(0.0, 0.0, 0.0, 0.0, 0.0), &state(0.1, 0.0, 0.0, 0.0, 2.0), &lim, 1.0);
        assert!(m.fired.contains(Conditions::TURN_RATE) && !m.fired.contains(Conditions::ACCELERATION));
        // Position: a 1 m jump sideways at standstill.
        let m = check_motion(&state(0.0, 0.0, 0.0, 0.0, 0.0), &state(0.1, 0.0, 1.0, 0.0, 0.0), &lim, 1.0);
        assert_eq!(m.fired, Conditions::POSITION);
    }

    #[test]
    fn heading_wraps_across_pi() {
        let s0 = state(0.0, 0.0, 0.0, 1.0, 3.1);
        let s1 = MeasuredState { t_s: 0.1, heading_rad: -3.1, x_m: -0.1, ..s0 };
        let m = check_motion(&s0, &s1, &MotionLimits::default(), 1.0);
        assert!((m.turn_rate - (2.0 * core::f64::consts::PI - 6.2) / 0.1).abs() < 1e-9);
        assert!(!m.fired.contains(Conditions::TURN_RATE));
    }
}
