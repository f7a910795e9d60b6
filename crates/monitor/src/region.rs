//! The object region `A_o`: the footprint grown by the safety margin and the covariance margin.

use crate::frame::{ObjectState, Uncertainty};
use crate::geometry::OrientedRect;
use crate::params::MonitorParams;

/// An object's region and the margins that made it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Region {
    /// The footprint as given (ungrown).
    pub footprint: OrientedRect,
    /// The grown region `A_o`.
    pub grown: OrientedRect,
    /// Growth along the length, metres.
    pub margin_length_m: f32,
    /// Growth across the width, metres.
    pub margin_width_m: f32,
    /// `Delta B(Sigma(o))`, metres.
    pub delta_b_m: f32,
}

/// Position uncertainty projected on the object's axes: `(Delta lon, Delta lat)`, metres.
///
/// The covariance is taken as diagonal in the ego frame, `Sigma = diag(sx^2, sy^2)`; its standard deviation
/// along the unit heading `u` is `sqrt(u^T Sigma u)`.
#[must_use]
pub fn axis_sigmas(u: &Uncertainty, heading_rad: f32) -> (f32, f32) {
    axis_sigmas_sc(u, libm::sincosf(heading_rad))
}

/// [`axis_sigmas`] with `(s, c) = libm::sincosf(heading_rad)` given (computed once per object: the footprint
/// takes the same pair).
fn axis_sigmas_sc(u: &Uncertainty, (s, c): (f32, f32)) -> (f32, f32) {
    let (vx, vy) = (u.x_m * u.x_m, u.y_m * u.y_m);
    (libm::sqrtf(vx * c * c + vy * s * s), libm::sqrtf(vx * s * s + vy * c * c))
}

/// `Delta B(Sigma(o)) = ||Delta lon + Delta L, Delta lat + Delta W||` (the paper's
/// `||Delta x + Delta L, Delta y + Delta W||` with the position margins taken along the object's axes).
#[must_use]
pub fn delta_b(u: &Uncertainty, heading_rad: f32) -> f32 {
    let (lon, lat) = axis_sigmas(u, heading_rad);
    libm::hypotf(lon + u.length_m, lat + u.width_m)
}

impl Region {
    /// The region of an object (its state assumed valid).
    ///
    /// Along the length the footprint grows by `delta_safe + gamma_sens (Delta lon + Delta L)`, across by
    /// `delta_safe + gamma_sens (Delta lat + Delta W)`. A point at distance `d` from the footprint can lie in the
    /// grown region only if `d <= ||(growth_l, growth_w)|| <= sqrt(2) delta_safe + gamma_sens Delta B`, which is
    /// what makes eq. (gridCapabilities)'s `dx_min` a guarantee (see [`crate::theory::dx_min_m`]).
    #[must_use]
    pub fn of(o: &ObjectState, u: &Uncertainty, p: &MonitorParams) -> Self {
        // (One `sincosf` of the heading for both: the same call `OrientedRect::new` makes.)
        let (sin, cos) = libm::sincosf(o.heading_rad);
        let (lon, lat) = axis_sigmas_sc(u, (sin, cos));
        let margin_length_m = p.safety_margin_m + p.gamma_sens * (lon + u.length_m);
        let margin_width_m = p.safety_margin_m + p.gamma_sens * (lat + u.width_m);
        let footprint =
            OrientedRect { cx: o.x_m, cy: o.y_m, cos, sin, half_length: 0.5 * o.length_m, half_width: 0.5 * o.width_m };
        let grown = OrientedRect {
            half_length: footprint.half_length + margin_length_m,
            half_width: footprint.half_width + margin_width_m,
            ..footprint
        };
        Self {
            footprint,
            grown,
            margin_length_m,
            margin_width_m,
            delta_b_m: libm::hypotf(lon + u.length_m, lat + u.width_m),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::ObjectClass;

    #[test]
    fn growth_matches_hand_computation() {
        let p = MonitorParams::default();
        let u = Uncertainty { x_m: 0.1, y_m: 0.1, heading_rad: 0.0, speed_mps: 0.0, length_m: 0.2, width_m: 0.0 };
        let o = ObjectState {
            id: 1,
            class: ObjectClass::Car,
            x_m: 10.0,
            y_m: 0.0,
            heading_rad: 0.3,
            speed_mps: 0.0,
            length_m: 4.0,
            width_m: 2.0,
            uncertainty: Some(u),
        };
        let r = Region::of(&o, &u, &p);
        // Isotropic position sigma 0.1: lon = lat = 0.1. Growth: 0.1 + 3 (0.1 + 0.2) = 1.0 and 0.1 + 3 * 0.1 = 0.4.
        assert!((r.margin_length_m - 1.0).abs() < 1e-5);
        assert!((r.margin_width_m - 0.4).abs() < 1e-5);
        assert!((r.grown.half_length - 3.0).abs() < 1e-5 && (r.grown.half_width - 1.4).abs() < 1e-5);
        // Delta B = ||0.1 + 0.2, 0.1 + 0|| = sqrt(0.09 + 0.01).
        assert!((r.delta_b_m - 0.1_f32.sqrt()).abs() < 1e-5);
    }

    #[test]
    fn anisotropic_sigma_projects_on_axes() {
        let u = Uncertainty { x_m: 0.3, y_m: 0.1, heading_rad: 0.0, speed_mps: 0.0, length_m: 0.0, width_m: 0.0 };
        let (lon, lat) = axis_sigmas(&u, core::f32::consts::FRAC_PI_2);
        assert!((lon - 0.1).abs() < 1e-5 && (lat - 0.3).abs() < 1e-5);
    }

    #[test]
    fn one_sincos_gives_the_footprint_and_margins_of_two() {
        // `Region::of` takes one `sincosf` for the margins and the footprint: the same bits as `axis_sigmas` and
        // `OrientedRect::new`, which take one each.
        let p = MonitorParams::default();
        for k in -700i32..700 {
            let heading_rad = k as f32 * 0.01 + 0.003;
            let u = Uncertainty {
                x_m: 0.1 + (k.rem_euclid(7)) as f32 * 0.11,
                y_m: 0.3,
                heading_rad: 0.0,
                speed_mps: 0.0,
                length_m: 0.2,
                width_m: 0.1,
            };
            let o = ObjectState {
                id: 1,
                class: ObjectClass::Car,
                x_m: 10.0,
                y_m: -3.0,
                heading_rad,
                speed_mps: 1.0,
                length_m: 4.0,
                width_m: 2.0,
                uncertainty: Some(u),
            };
            let r = Region::of(&o, &u, &p);
            let (lon, lat) = axis_sigmas(&u, heading_rad);
            let f = OrientedRect::new(o.x_m, o.y_m, heading_rad, 0.5 * o.length_m, 0.5 * o.width_m);
            assert_eq!(r.footprint, f);
            assert_eq!(r.margin_length_m.to_bits(), (p.safety_margin_m + p.gamma_sens * (lon + u.length_m)).to_bits());
            assert_eq!(r.margin_width_m.to_bits(), (p.safety_margin_m + p.gamma_sens * (lat + u.width_m)).to_bits());
            assert_eq!(r.delta_b_m.to_bits(), delta_b(&u, heading_rad).to_bits());
        }
    }
}
