//! Small 2D geometry: angle wrapping, oriented rectangles, cell-rectangle overlap, polygons.

use core::f64::consts::PI;

/// Wraps an angle difference into `(-pi, pi]`, radians. Non-finite input returns NaN.
#[must_use]
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * PI;
    let x = a + PI;
    // `fmod(x, 2 pi)` without its division where it is `x` itself (`|x| < 2 pi`) or one subtraction of `2 pi`
    // (`2 pi <= |x| < 4 pi`: exact by Sterbenz's lemma, as `fmod` is): bit for bit the same result (test
    // `wrap_angle_fast_path_is_bit_identical`). Angle differences of two wrapped angles always take it.
    let mut r = if x > -two_pi && x < two_pi {
        x
    } else if x >= two_pi && x < 2.0 * two_pi {
        x - two_pi
    } else if x <= -two_pi && x > -2.0 * two_pi {
        x + two_pi
    } else if a.is_finite() {
        libm::fmod(x, two_pi)
    } else {
        return f64::NAN;
    };
    if r <= 0.0 {
        r += two_pi;
    }
    r - PI
}

/// An oriented rectangle in the ego frame: centre, unit axes, half extents (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientedRect {
    /// Centre x, metres.
    pub cx: f32,
    /// Centre y, metres.
    pub cy: f32,
    /// cos(heading).
    pub cos: f32,
    /// sin(heading).
    pub sin: f32,
    /// Half extent along the heading, metres.
    pub half_length: f32,
    /// Half extent across the heading, metres.
    pub half_width: f32,
}

impl OrientedRect {
    /// A rectangle from centre, heading and half extents.
    #[must_use]
    pub fn new(cx: f32, cy: f32, heading_rad: f32, half_length: f32, half_width: f32) -> Self {
        let (sin, cos) = libm::sincosf(heading_rad);
        Self { cx, cy, cos, sin, half_length, half_width }
    }

    /// The four corners, in turn round the rectangle.
    #[must_use]
    pub fn corners(&self) -> [[f32; 2]; 4] {
        let (lx, ly) = (self.half_length * self.cos, self.half_length * self.sin);
        let (wx, wy) = (-self.half_width * self.sin, self.half_width * self.cos);
        let (cx, cy) = (self.cx, self.cy);
        [
            [cx + lx + wx, cy + ly + wy],
            [cx - lx + wx, cy - ly + wy],
            [cx - lx - wx, cy - ly - wy],
            [cx + lx - wx, cy + ly - wy],
        ]
    }

    /// Axis-aligned bounds `[min_x, min_y, max_x, max_y]`.
    #[must_use]
    pub fn aabb(&self) -> [f32; 4] {
        let ex = self.half_length * self.cos.abs() + self.half_width * self.sin.abs();
        let ey = self.half_length * self.sin.abs() + self.half_width * self.cos.abs();
        [self.cx - ex, self.cy - ey, self.cx + ex, self.cy + ey]
    }

    /// True when the axis-aligned square of centre `(x, y)` and half side `h` overlaps the rectangle with
    /// positive area (separating-axis test on the square's two axes and the rectangle's two axes). Touching
    /// edges do not count.
    #[must_use]
    #[inline]
    pub fn overlaps_square(&self, x: f32, y: f32, h: f32) -> bool {
        let dx = x - self.cx;
        let dy = y - self.cy;
        let (c, s) = (self.cos.abs(), self.sin.abs());
        // Square's axes (x, y).
        if dx.abs() >= h + self.half_length * c + self.half_width * s {
            return false;
        }
        if !self.row_may_overlap(y, h) {
            return false;
        }
        // Rectangle's axes (u along heading, v across).
        let du = dx * self.cos + dy * self.sin;
        let dv = -dx * self.sin + dy * self.cos;
        let hs = h * (c + s);
        // `&`, not `&&`: the two tests are cheap, and which of them fails is hard to predict along a row.
        (du.abs() < self.half_length + hs) & (dv.abs() < self.half_width + hs)
    }

    /// The test of [`OrientedRect::overlaps_square`] on the square's y axis alone: false when no square of half
    /// side `h` centred at height `y` overlaps the rectangle, whatever its `x`.
    #[must_use]
    #[inline]
    pub fn row_may_overlap(&self, y: f32, h: f32) -> bool {
        let dy = y - self.cy;
        dy.abs() < h + self.half_length * self.sin.abs() + self.half_width * self.cos.abs()
    }

    /// An interval of `x` that contains every `x` for which [`OrientedRect::overlaps_square`]`(x, y, h)` holds,
    /// from the test's three conditions on `x` solved in real numbers (each is an interval), or `None` when that
    /// cannot be trusted (non-finite values). The bounds carry rounding errors of about `1e-7` times the
    /// coordinates' magnitude divided by `MIN_AXIS_COMPONENT`: callers widen it before relying on it.
    #[must_use]
    #[inline]
    pub fn row_bounds(&self, y: f32, h: f32) -> Option<(f32, f32)> {
        /// Below this a rectangle axis' component gives no bound (its division would amplify rounding).
        const MIN_AXIS_COMPONENT: f32 = 0.01;
        let dy = y - self.cy;
        let (c, s) = (self.cos.abs(), self.sin.abs());
        let hs = h * (c + s);
        // |dx| < h + L c + W s.
        let a = h + self.half_length * c + self.half_width * s;
        let (mut lo, mut hi) = (-a, a);
        // |dx cos + dy sin| < L + hs.
        if c >= MIN_AXIS_COMPONENT {
            let b = self.half_length + hs;
            let (p, q) = ((-b - dy * self.sin) / self.cos, (b - dy * self.sin) / self.cos);
            lo = lo.max(p.min(q));
            hi = hi.min(p.max(q));
        }
        // |-dx sin + dy cos| < W + hs.
        if s >= MIN_AXIS_COMPONENT {
            let b = self.half_width + hs;
            let (p, q) = ((dy * self.cos - b) / self.sin, (dy * self.cos + b) / self.sin);
            lo = lo.max(p.min(q));
            hi = hi.min(p.max(q));
        }
        (lo.is_finite() && hi.is_finite()).then_some((self.cx + lo, self.cx + hi))
    }

    /// True when the point lies inside or on the rectangle.
    #[must_use]
    pub fn contains(&self, x: f32, y: f32) -> bool {
        let (du, dv) = self.local(x, y);
        du.abs() <= self.half_length && dv.abs() <= self.half_width
    }

    /// The point in the rectangle's frame (along, across), metres.
    #[must_use]
    pub fn local(&self, x: f32, y: f32) -> (f32, f32) {
        let dx = x - self.cx;
        let dy = y - self.cy;
        (dx * self.cos + dy * self.sin, -dx * self.sin + dy * self.cos)
    }

    /// Euclidean distance from the point to the rectangle (0 inside), metres.
    #[must_use]
    pub fn distance(&self, x: f32, y: f32) -> f32 {
        let (ou, ov) = self.outside_offsets(x, y);
        libm::hypotf(ou, ov)
    }

    /// How far the point lies beyond the rectangle along and across it (0 within its extent), metres: the legs
    /// of [`OrientedRect::distance`].
    #[must_use]
    #[inline]
    pub fn outside_offsets(&self, x: f32, y: f32) -> (f32, f32) {
        let (du, dv) = self.local(x, y);
        ((du.abs() - self.half_length).max(0.0), (dv.abs() - self.half_width).max(0.0))
    }

    /// The point of the rectangle nearest to `(x, y)`. (The clamps written out: `f32::clamp`'s values, without its
    /// check that the bounds are ordered, which a called function paid for at every cell of the ghost test.)
    #[must_use]
    #[inline]
    pub fn nearest_point(&self, x: f32, y: f32) -> (f32, f32) {
        let (du, dv) = self.local(x, y);
        let u = clamp_unchecked(du, -self.half_length, self.half_length);
        let v = clamp_unchecked(dv, -self.half_width, self.half_width);
        (self.cx + u * self.cos - v * self.sin, self.cy + u * self.sin + v * self.cos)
    }
}

/// `v.clamp(lo, hi)` for `lo <= hi`: the same value (NaN stays NaN), without `f32::clamp`'s panic on unordered bounds
/// (for which it gives `hi` when `v > hi`, else `lo` when `v < lo`).
#[inline(always)]
fn clamp_unchecked(v: f32, lo: f32, hi: f32) -> f32 {
    let mut v = v;
    if v < lo {
        v = lo;
    }
    if v > hi {
        v = hi;
    }
    v
}

/// The even-odd rule's step: whether the edge from `prev` to `p` crosses the ray from `(x, y)` towards +x.
#[inline(always)]
pub(crate) fn edge_crosses_ray(prev: [f32; 2], p: [f32; 2], x: f32, y: f32) -> bool {
    let ([xi, yi], [xj, yj]) = (p, prev);
    (yi > y) != (yj > y) && x < xi + (y - yi) / (yj - yi) * (xj - xi)
}

/// The offset of `(x, y)` from the nearest point of the segment from `prev` to `p`.
#[inline(always)]
pub(crate) fn offset_from_segment(prev: [f32; 2], p: [f32; 2], x: f32, y: f32) -> (f32, f32) {
    let (ex, ey) = (p[0] - prev[0], p[1] - prev[1]);
    let len2 = ex * ex + ey * ey;
    let t = if len2 > 0.0 { (((x - prev[0]) * ex + (y - prev[1]) * ey) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (x - prev[0] - t * ex, y - prev[1] - t * ey)
}

/// The polygon's edges as `(previous vertex, vertex)`, the closing edge first; none for fewer than 3 vertices.
pub(crate) fn polygon_edges(polygon: &[[f32; 2]]) -> impl Iterator<Item = ([f32; 2], [f32; 2])> + '_ {
    let last = if polygon.len() < 3 { None } else { polygon.last().copied() };
    polygon.iter().scan(last, |prev, &p| prev.replace(p).map(|q| (q, p)))
}

/// Even-odd point-in-polygon test. A polygon with fewer than 3 vertices contains nothing.
#[must_use]
pub fn polygon_contains(polygon: &[[f32; 2]], x: f32, y: f32) -> bool {
    polygon_edges(polygon).fold(false, |inside, (prev, p)| inside != edge_crosses_ray(prev, p, x, y))
}

/// Distance from a point to a polygon: 0 inside (even-odd rule), else the distance to its nearest edge.
/// A polygon with fewer than 3 vertices is infinitely far.
#[must_use]
pub fn polygon_distance(polygon: &[[f32; 2]], x: f32, y: f32) -> f32 {
    if polygon_contains(polygon, x, y) {
        return 0.0;
    }
    polygon_edges(polygon).fold(f32::INFINITY, |best, (prev, p)| {
        let (dx, dy) = offset_from_segment(prev, p, x, y);
        best.min(libm::hypotf(dx, dy))
    })
}

/// Where a point lies against a polygon, in one pass over its edges: `(inside (even-odd), squared distance to
/// the nearest edge)`. A polygon with fewer than 3 vertices: `(false, infinity)`.
#[must_use]
pub fn polygon_side_and_edge_distance2(polygon: &[[f32; 2]], x: f32, y: f32) -> (bool, f32) {
    polygon_edges(polygon).fold((false, f32::INFINITY), |(inside, best), (prev, p)| {
        let (dx, dy) = offset_from_segment(prev, p, x, y);
        (inside != edge_crosses_ray(prev, p, x, y), best.min(dx * dx + dy * dy))
    })
}

/// A monotonic pseudo-angle in `[0, 4)` of the direction `(dx, dy)` (the "diamond angle"): cheaper than
/// `atan2`, no trigonometry, same ordering. `(0, 0)` maps to 0.
#[must_use]
#[inline]
pub fn diamond_angle(dx: f32, dy: f32) -> f32 {
    let s = dx.abs() + dy.abs();
    if s <= 0.0 || !s.is_finite() {
        return 0.0;
    }
    if dy >= 0.0 {
        if dx >= 0.0 {
            dy / s
        } else {
            1.0 - dx / s
        }
    } else if dx < 0.0 {
        2.0 - dy / s
    } else {
        3.0 + dx / s
    }
}

/// [`diamond_angle`] without branches, for loops the compiler should vectorise: the same value for every input
/// (as `==`; a `-0.0` of the original may come out `+0.0`), including 0 for `(0, 0)`, for non-finite input
/// and for `|dx| + |dy|` overflowing to infinity (which finite `dx`, `dy` can do, so the test is not redundant).
///
/// Why the same bits: per quadrant the original computes `dy / s`, `1 - dx / s`, `2 - dy / s` or `3 + dx / s`;
/// with `num = |dx|` or `|dy|` these are `base + num / s` exactly, since IEEE division and subtraction are
/// symmetric in the sign (`-(a / s) == (-a) / s`, `b - a == b + (-a)`), and `0 + x == x` as a value.
#[must_use]
#[inline(always)]
pub(crate) fn diamond_angle_select(dx: f32, dy: f32) -> f32 {
    let (ax, ay) = (dx.abs(), dy.abs());
    let s = ax + ay;
    let upper = dy >= 0.0;
    let left = dx < 0.0;
    let base = match (upper, left) {
        (true, false) => 0.0,
        (true, true) => 1.0,
        (false, true) => 2.0,
        (false, false) => 3.0,
    };
    let num = if upper == left { ax } else { ay };
    let d = base + num / s;
    // NaN fails both comparisons; (0, 0) the first; an infinite s the second. (`s < INFINITY` would be the
    // same, but the compiler turns it into integer operations on the bits.)
    if (s > 0.0) & (s <= f32::MAX) {
        d
    } else {
        0.0
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_fast_path_is_bit_identical() {
        // The definition: fmod for every input.
        let reference = |a: f64| {
            if !a.is_finite() {
                return f64::NAN;
            }
            let mut r = libm::fmod(a + PI, 2.0 * PI);
            if r <= 0.0 {
                r += 2.0 * PI;
            }
            r - PI
        };
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut values = alloc::vec![0.0, -0.0, PI, -PI, 2.0 * PI, -2.0 * PI, 3.0 * PI, -3.0 * PI, 5.0 * PI, 1e300];
        for k in -2000..=2000 {
            values.push(f64::from(k) * 0.007_853_981_633_974_483);
        }
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            values.push(((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 30.0);
        }
        for &b in &[PI, 2.0 * PI, 3.0 * PI, 4.0 * PI] {
            for s in [-1.0, 1.0] {
                let c = s * b;
                values.extend([c, c.next_up(), c.next_down()]);
                let m = c - PI;
                values.extend([m, m.next_up(), m.next_down()]);
            }
        }
        for a in values {
            assert_eq!(wrap_angle(a).to_bits(), reference(a).to_bits(), "{a:e}");
        }
        assert!(wrap_angle(f64::INFINITY).is_nan() && wrap_angle(f64::NEG_INFINITY).is_nan());
    }

    #[test]
    fn wrap_angle_into_half_open_interval() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(0.1 - 2.0 * PI) - 0.1).abs() < 1e-12);
        assert!(wrap_angle(f64::NAN).is_nan());
    }

    #[test]
    fn square_overlap_and_touching() {
        let r = OrientedRect::new(0.0, 0.0, 0.0, 1.0, 0.5);
        assert!(r.overlaps_square(1.2, 0.0, 0.25));
        assert!(!r.overlaps_square(1.25, 0.0, 0.25), "touching edges do not overlap");
        assert!(!r.overlaps_square(0.0, 0.8, 0.25));
        // Rotated 45 degrees: the corner region between the rectangle's corner and the square.
        let r = OrientedRect::new(0.0, 0.0, core::f32::consts::FRAC_PI_4, 1.0, 1.0);
        assert!(r.overlaps_square(1.5, 0.0, 0.25)); // tip at sqrt(2) = 1.414 > 1.25
        assert!(!r.overlaps_square(1.2, 1.2, 0.25));
    }

    #[test]
    fn distance_and_nearest_point() {
        let r = OrientedRect::new(1.0, 1.0, core::f32::consts::FRAC_PI_2, 2.0, 1.0);
        assert!(r.distance(1.0, 1.0) < 1e-6);
        assert!((r.distance(3.0, 1.0) - 1.0).abs() < 1e-5);
        let (x, y) = r.nearest_point(3.0, 1.0);
        assert!((x - 2.0).abs() < 1e-5 && (y - 1.0).abs() < 1e-5);
    }

    #[test]
    fn polygon() {
        let sq = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert!(polygon_contains(&sq, 1.0, 1.0));
        assert!(!polygon_contains(&sq, 3.0, 1.0));
        assert!(!polygon_contains(&sq[..2], 1.0, 0.0));
    }

    #[test]
    fn polygon_distance_inside_and_outside() {
        let sq = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert!(polygon_distance(&sq, 1.0, 1.0).abs() < 1e-6);
        assert!((polygon_distance(&sq, 3.0, 1.0) - 1.0).abs() < 1e-6);
        assert!((polygon_distance(&sq, 3.0, 3.0) - 2f32.sqrt()).abs() < 1e-6);
        assert!(polygon_distance(&sq[..2], 0.0, 0.0).is_infinite());
    }

    #[test]
    fn diamond_angle_is_monotonic() {
        let mut last = -1.0;
        for i in 0..720 {
            let a = (i as f32) * core::f32::consts::PI / 360.0;
            let d = diamond_angle(libm::cosf(a), libm::sinf(a));
            assert!(d >= last, "{i}");
            assert!((0.0..4.0).contains(&d));
            last = d;
        }
    }
}
