//! The paper's analytic bounds as functions, for the evaluation to draw and to test against.

use crate::motion::{check_motion, MeasuredState};
use crate::params::{MonitorParams, MotionLimits};
use crate::verdict::Conditions;

/// Eq. (gridCapabilities): the smallest position error the sensor checks are guaranteed to detect,
/// `dx_min = sqrt(2) (c_grid + delta_safe) + gamma_sens Delta B(Sigma(o))`, metres.
#[must_use]
pub fn dx_min_m(cell_size_m: f32, safety_margin_m: f32, gamma_sens: f32, delta_b_m: f32) -> f32 {
    core::f32::consts::SQRT_2 * (cell_size_m + safety_margin_m) + gamma_sens * delta_b_m
}

/// The acceleration-only bound for transient speed errors (Section III-C-2):
/// `dv_min = min(a_acc, -a_br) dt + sqrt(2) Delta v`, m/s.
#[must_use]
pub fn dv_min_transient_accel_only_mps(limits: &MotionLimits, dt_s: f64, speed_margin_mps: f64) -> f64 {
    f64::from(limits.accel_max_mps2.min(-limits.brake_max_mps2)) * dt_s + core::f64::consts::SQRT_2 * speed_margin_mps
}

/// Measurement margins of the theoretical setup (the paper's Fig. dv_theo uses 0.1 m, 1 m/s, 10 degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Margins {
    /// Position margin `Delta x = Delta y`, metres.
    pub position_m: f64,
    /// Speed margin `Delta v`, m/s.
    pub speed_mps: f64,
    /// Heading margin `Delta theta`, radians.
    pub heading_rad: f64,
}

impl Margins {
    /// The values of Fig. dv_theo: 0.1 m, 1 m/s, and Table I's 10 degrees.
    pub const PAPER: Self = Self { position_m: 0.1, speed_mps: 1.0, heading_rad: 10.0 * core::f64::consts::PI / 180.0 };
}

/// Kind of speed error in the theoretical setup of Section III-C-2.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpeedError {
    /// `v0 = v1 = v + dv`: both measurements carry the error.
    Permanent,
    /// `v0 = v`, `v1 = v + dv`: only the second does.
    Transient,
}

/// Conditions fired in the theoretical two-step setup: an object moving straight (heading 0) at true speed
/// `v`, measured positions exact (`x1 = v dt`), speed error `dv` of the given kind. A measured speed is a
/// magnitude: `|v + dv|`.
#[must_use]
pub fn fired_for_speed_error(
    kind: SpeedError,
    dt_s: f64,
    v_mps: f64,
    dv_mps: f64,
    p: &MonitorParams,
    m: &Margins,
) -> Conditions {
    let err = libm::fabs(v_mps + dv_mps);
    let (v0, v1) = match kind {
        SpeedError::Permanent => (err, err),
        SpeedError::Transient => (v_mps, err),
    };
    let base = MeasuredState {
        t_s: 0.0,
        x_m: 0.0,
        y_m: 0.0,
        v_mps: v0,
        heading_rad: 0.0,
        dx_m: m.position_m,
        dy_m: m.position_m,
        dv_mps: m.speed_mps,
        dheading_rad: m.heading_rad,
    };
    let next = MeasuredState { t_s: dt_s, x_m: v_mps * dt_s, v_mps: v1, ..base };
    check_motion(&base, &next, &p.motion_limits, f64::from(p.gamma_plaus)).fired
}

/// The minimal detectable speed error `dv_min` (Fig. dv_theo): of the errors, positive or negative, that the
/// plausibility checks flag in the setup of [`fired_for_speed_error`], the one with the smallest `|dv|`,
/// returned with its sign. Scans `|dv|` upward in steps of `step_mps` up to `max_mps` (bounded loop), then
/// refines by bisection to `1e-4` m/s. `None` if nothing up to `max_mps` is detected.
#[must_use]
pub fn dv_min_mps(
    kind: SpeedError,
    dt_s: f64,
    v_mps: f64,
    p: &MonitorParams,
    m: &Margins,
    step_mps: f64,
    max_mps: f64,
) -> Option<f64> {
    if !(step_mps > 0.0 && max_mps > 0.0 && dt_s > 0.0) {
        return None;
    }
    let steps = libm::ceil(max_mps / step_mps).min(1.0e6) as u32;
    let mut best: Option<f64> = None;
    for sign in [1.0, -1.0] {
        let detected = |mag: f64| !fired_for_speed_error(kind, dt_s, v_mps, sign * mag, p, m).is_empty();
        let mut lo = 0.0;
        for i in 1..=steps {
            let hi = f64::from(i) * step_mps;
            if best.is_some_and(|b| hi > b.abs()) {
                break;
            }
            if detected(hi) {
                let mut hi = hi;
                for _ in 0..40 {
                    let mid = 0.5 * (lo + hi);
                    if detected(mid) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                    if hi - lo < 1e-4 {
                        break;
                    }
                }
                let signed = sign * hi;
                best = Some(best.map_or(signed, |b: f64| if hi < b.abs() { signed } else { b }));
                break;
            }
            lo = hi;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dx_min_table_one() {
        // sqrt(2) (0.5 + 0.1) + 3 * ||0.1, 0.1|| = 0.8485 + 0.4243.
        let d = dx_min_m(0.5, 0.1, 3.0, libm::hypotf(0.1, 0.1));
        assert!((d - 1.272_792).abs() < 1e-4, "{d}");
    }

    #[test]
    fn transient_bound_is_acceleration_condition_for_small_dt() {
        let p = MonitorParams::default();
        let dt = 0.05;
        let bound = dv_min_transient_accel_only_mps(&p.motion_limits, dt, 1.0);
        assert!((bound - (0.35 + 2f64.sqrt())).abs() < 1e-12);
        let found = dv_min_mps(SpeedError::Transient, dt, 5.0, &p, &Margins::PAPER, 0.05, 30.0).unwrap().abs();
        assert!(found <= bound + 1e-3, "found {found}, bound {bound}");
    }

    #[test]
    fn permanent_errors_need_larger_magnitudes_and_grow_with_speed() {
        let p = MonitorParams::default();
        let m = Margins::PAPER;
        let slow = dv_min_mps(SpeedError::Permanent, 0.1, 2.0, &p, &m, 0.05, 60.0).unwrap().abs();
        let fast = dv_min_mps(SpeedError::Permanent, 0.1, 15.0, &p, &m, 0.05, 60.0).unwrap().abs();
        let transient = dv_min_mps(SpeedError::Transient, 0.1, 15.0, &p, &m, 0.05, 60.0).unwrap().abs();
        assert!(fast > slow, "permanent dv_min grows with speed: {slow} -> {fast}");
        assert!(transient < fast, "transient errors are easier: {transient} vs {fast}");
        // Longer intervals help against permanent errors (the paper's observation).
        let longer = dv_min_mps(SpeedError::Permanent, 0.2, 15.0, &p, &m, 0.05, 60.0).unwrap().abs();
        assert!(longer < fast, "{longer} vs {fast}");
    }
}
