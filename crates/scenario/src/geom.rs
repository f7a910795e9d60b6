//! Small 2D/3D geometry: angles, oriented boxes, polygon clipping.

use std::f64::consts::{PI, TAU};

/// Wraps an angle to (-pi, pi], radians.
#[must_use]
pub(crate) fn wrap_angle(a: f64) -> f64 {
    let mut r = a.rem_euclid(TAU);
    if r > PI {
        r -= TAU;
    }
    r
}

/// An upright box: an oriented rectangle footprint (centre, yaw, half extents) between two heights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Box3 {
    /// Footprint centre, metres.
    pub cx: f64,
    /// Footprint centre, metres.
    pub cy: f64,
    /// Yaw of the length axis, radians.
    pub yaw: f64,
    /// Half length (along yaw), metres.
    pub half_l: f64,
    /// Half width, metres.
    pub half_w: f64,
    /// Bottom height above the ground, metres.
    pub z0: f64,
    /// Top height above the ground, metres.
    pub z1: f64,
}

impl Box3 {
    /// An axis-aligned box from its x and y ranges.
    pub(crate) fn aabb(x0: f64, x1: f64, y0: f64, y1: f64, z0: f64, z1: f64) -> Self {
        Self {
            cx: 0.5 * (x0 + x1),
            cy: 0.5 * (y0 + y1),
            yaw: 0.0,
            half_l: 0.5 * (x1 - x0).abs(),
            half_w: 0.5 * (y1 - y0).abs(),
            z0,
            z1,
        }
    }

    /// True when the footprint grown by `margin` contains `(x, y)`.
    #[cfg(test)]
    pub(crate) fn contains_xy(&self, x: f64, y: f64, margin: f64) -> bool {
        let (s, c) = self.yaw.sin_cos();
        let (dx, dy) = (x - self.cx, y - self.cy);
        let u = c * dx + s * dy;
        let v = -s * dx + c * dy;
        u.abs() <= self.half_l + margin && v.abs() <= self.half_w + margin
    }

    /// The footprint's corners, counter-clockwise.
    pub(crate) fn corners(&self) -> [[f64; 2]; 4] {
        let (s, c) = self.yaw.sin_cos();
        let (l, w) = (self.half_l, self.half_w);
        let p = |a: f64, b: f64| [self.cx + c * a - s * b, self.cy + s * a + c * b];
        [p(l, w), p(-l, w), p(-l, -w), p(l, -w)]
    }

    /// True when the footprints (grown by `margin`) overlap (separating axis test).
    #[cfg(test)]
    pub(crate) fn overlaps_xy(&self, other: &Self, margin: f64) -> bool {
        let axes = [self.yaw, self.yaw + PI / 2.0, other.yaw, other.yaw + PI / 2.0];
        let (ca, cb) = (self.corners(), other.corners());
        axes.iter().all(|&a| {
            let (s, c) = a.sin_cos();
            let proj = |pts: &[[f64; 2]; 4]| {
                pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    let d = c * p[0] + s * p[1];
                    (lo.min(d), hi.max(d))
                })
            };
            let (a0, a1) = proj(&ca);
            let (b0, b1) = proj(&cb);
            a0 <= b1 + margin && b0 <= a1 + margin
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI / 2.0 - TAU) + PI / 2.0).abs() < 1e-12);
    }

    #[test]
    fn box_tests() {
        let b = Box3 { cx: 1.0, cy: 2.0, yaw: PI / 2.0, half_l: 2.0, half_w: 1.0, z0: 0.0, z1: 1.0 };
        assert!(b.contains_xy(1.0, 3.9, 0.0));
        assert!(!b.contains_xy(2.5, 2.0, 0.0));
        assert!(b.contains_xy(2.5, 2.0, 0.6));
        let c = Box3 { cx: 3.5, cy: 2.0, ..b };
        assert!(!b.overlaps_xy(&c, 0.0));
        assert!(b.overlaps_xy(&c, 0.6));
    }
}
