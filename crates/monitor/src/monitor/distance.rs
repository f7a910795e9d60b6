//! How near a conflict cluster comes to a region or a point: the cost and the gates of the evidence assignment
//! (docs/attribution.md, "The rule, step by step", steps 3 and 4), from the cluster's cells, not their centres,
//! with the cheap tests on bounding boxes first (`far_apart`, `point_far`) and the exact minimum that calls
//! `hypotf` only where it can lower the result ([`nearest_distance`], tested bit for bit against the
//! straightforward loop). Part of [`Monitor`].

use super::*;

impl Monitor {
    /// Distance from a cluster's cells (not their centres: no cell comes nearer than touching) to a region,
    /// metres, or `None` when it exceeds `reach` (decided first on bounding boxes, which skips most pairs).
    pub(super) fn cluster_distance(&self, k: usize, region: &crate::geometry::OrientedRect, reach: f32) -> Option<f32> {
        let geometry = self.grid.geometry;
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        let cluster = self.clusters.get(k)?;
        let rb = region.aabb();
        let cb = cluster.bounds_m;
        let gap_x = (cb[0] - rb[2]).max(rb[0] - cb[2]).max(0.0);
        let gap_y = (cb[1] - rb[3]).max(rb[1] - cb[3]).max(0.0);
        // Bounds are of cell centres: allow half a diagonal, as the exact test below does. First without the
        // square root: `hypot(gx, gy) >= max(gx, gy)` also after rounding, so this skips only pairs the test
        // with `hypotf` skips (most pairs are far apart).
        if gap_x.max(gap_y) - half_diagonal > reach || libm::hypotf(gap_x, gap_y) - half_diagonal > reach {
            return None;
        }
        let d = self.nearest_cell_distance(k, |x, y| region.outside_offsets(x, y));
        (d <= reach).then_some(d)
    }

    /// The smallest `distance(cell centre) - half a cell diagonal` (at least 0) over cluster `k`'s cells: how near
    /// its cells (not their centres) come to something. Stops at 0.
    ///
    /// `offsets(x, y)` gives the two legs whose `hypotf` is the distance from a cell centre (see
    /// [`nearest_distance`]).
    fn nearest_cell_distance(&self, k: usize, offsets: impl Fn(f32, f32) -> (f32, f32)) -> f32 {
        let geometry = self.grid.geometry;
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        nearest_distance(self.cluster_cells(k).iter().map(|&c| geometry.cell_center(c)), half_diagonal, offsets)
    }

    /// True when a cluster's bounds (of cell centres) and a region's bounding box are more than `reach` apart,
    /// cells included (a lower bound of [`Monitor::cluster_distance`]: skips most pairs cheaply).
    pub(super) fn far_apart(&self, cluster_bounds: [f32; 4], region_aabb: [f32; 4], reach: f32) -> bool {
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * self.grid.geometry.cell_size_m;
        let gap_x = (cluster_bounds[0] - region_aabb[2]).max(region_aabb[0] - cluster_bounds[2]);
        let gap_y = (cluster_bounds[1] - region_aabb[3]).max(region_aabb[1] - cluster_bounds[3]);
        gap_x.max(gap_y) - half_diagonal > reach
    }

    /// Distance from a cluster's cells to a point, metres (no cell comes nearer than touching), or `None` beyond
    /// `reach`.
    pub(super) fn cluster_point_distance(&self, k: usize, p: [f32; 2], reach: f32) -> Option<f32> {
        let cb = self.clusters.get(k)?.bounds_m;
        if self.point_far(cb, p, reach) {
            return None;
        }
        let d = self.nearest_cell_distance(k, |x, y| (x - p[0], y - p[1]));
        (d <= reach).then_some(d)
    }

    /// True when a cluster's bounds (of cell centres) and a point are more than `reach` apart, cells included (the
    /// lower bound [`Monitor::cluster_point_distance`] tests first).
    #[inline]
    pub(super) fn point_far(&self, cluster_bounds: [f32; 4], p: [f32; 2], reach: f32) -> bool {
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * self.grid.geometry.cell_size_m;
        let cb = cluster_bounds;
        let gap_x = (cb[0] - p[0]).max(p[0] - cb[2]).max(0.0);
        let gap_y = (cb[1] - p[1]).max(p[1] - cb[3]).max(0.0);
        gap_x.max(gap_y) - half_diagonal > reach
    }
}

/// The smallest `hypotf(offsets(x, y)) - half_diagonal` (at least 0) over the cell centres `(x, y)`, stopping at 0:
/// the straightforward minimum, except that `hypotf` is called only for a centre whose legs' squared sum (in `f64`:
/// each square of an `f32` is exact there, the sum rounds once) is strictly below the smallest sum so far. The
/// others cannot lower the minimum: in each of its branches `hypotf` (libm) is a function of that sum that does
/// not decrease as it grows (`sqrtf` of it rounded to `f32`; scaled by exact powers of two 2^90 for huge or tiny
/// legs; the longer leg for legs 2^25 apart and more, which is what `sqrtf` gives there too), and
/// `(h - half_diagonal).max(0.0)` does not decrease as `h` grows. Same bits as the straightforward loop (tested
/// against it, also on huge and tiny coordinates). Legs whose sum is NaN take the straightforward path, which the
/// bound used until round branches could skip; no caller passes NaN legs (`outside_offsets` clamps with
/// `max(0.0)`; a NaN point makes every centre's leg NaN, from the first centre on, as before).
pub(super) fn nearest_distance(
    centres: impl Iterator<Item = (f32, f32)>,
    half_diagonal: f32,
    offsets: impl Fn(f32, f32) -> (f32, f32),
) -> f32 {
    let mut d = f32::INFINITY;
    let mut smallest = f64::INFINITY;
    for (x, y) in centres {
        let (a, b) = offsets(x, y);
        let (a64, b64) = (f64::from(a), f64::from(b));
        let sum = a64 * a64 + b64 * b64;
        if sum >= smallest {
            continue;
        }
        if sum < smallest {
            smallest = sum;
        }
        d = d.min((libm::hypotf(a, b) - half_diagonal).max(0.0));
        if d <= 0.0 {
            break;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::OrientedRect;
    use crate::test_support::unit_draws;

    /// The straightforward minimum `nearest_distance` skips `hypotf` in.
    fn nearest_distance_reference(
        centres: &[(f32, f32)],
        half_diagonal: f32,
        distance: impl Fn(f32, f32) -> f32,
    ) -> f32 {
        let mut d = f32::INFINITY;
        for &(x, y) in centres {
            d = d.min((distance(x, y) - half_diagonal).max(0.0));
            if d <= 0.0 {
                break;
            }
        }
        d
    }

    /// What `nearest_distance` rests on: `hypotf` does not decrease as its legs' `f64` squared sum grows. Pairs of
    /// legs drawn near each other (sums close or equal), with ratios up to and beyond 2^25 (where `hypotf` returns
    /// the longer leg), with legs whose square is a tie of `f32` rounding (`4097 * 2^e`: 25 significant bits),
    /// and over scales from 1e-6 to 1e6.
    #[test]
    fn hypotf_does_not_decrease_as_the_squared_sum_grows() {
        let mut unit = unit_draws(0x2545_F491_4F6C_DD1D);
        let sum = |a: f32, b: f32| f64::from(a) * f64::from(a) + f64::from(b) * f64::from(b);
        let mut compared = 0u32;
        for case in 0..400_000u32 {
            // Scales reach the branches that scale by 2^90 (legs beyond 2^60 or below 2^-60), subnormal squares
            // and sums beyond `f32::MAX`.
            let scale = [1e-6f32, 1e-3, 1.0, 30.0, 1e3, 1e6, 1e-40, 1e-25, 1e19, 1e25, 1e30, 1.2e18, 8.7e-19]
                [(case % 13) as usize];
            let a = match case / 6 % 3 {
                0 => unit() * scale,
                1 => 4097.0 * scale.log2().round().exp2() * [1.0f32, 0.5, 2.0][(case % 3) as usize],
                _ => (1.0 + unit() * 1e-6) * scale,
            };
            let b = match case / 18 % 4 {
                0 => unit() * scale,
                1 => a * (unit() * 2f32.powi(-24)),
                2 => a * 2f32.powi(-25 - (case % 4) as i32),
                _ => 0.0,
            };
            // A neighbour: one or two units in the last place away in either leg, or the legs swapped.
            let step = |v: f32, k: u32| f32::from_bits(v.to_bits().saturating_add(k % 3).saturating_sub(k / 3 % 2));
            let (c, d) = if case % 5 == 0 { (b, a) } else { (step(a, case / 7), step(b, case / 11)) };
            let (s0, s1) = (sum(a, b), sum(c, d));
            let (h0, h1) = (libm::hypotf(a, b), libm::hypotf(c, d));
            if s0 < s1 {
                assert!(h0 <= h1, "legs {a:e} {b:e} (sum {s0:e}, hypotf {h0:e}) vs {c:e} {d:e} ({s1:e}, {h1:e})");
                compared += 1;
            } else if s1 < s0 {
                assert!(h1 <= h0, "legs {c:e} {d:e} (sum {s1:e}, hypotf {h1:e}) vs {a:e} {b:e} ({s0:e}, {h0:e})");
                compared += 1;
            } else {
                assert_eq!(h0.to_bits(), h1.to_bits(), "equal sums, legs {a:e} {b:e} and {c:e} {d:e}");
            }
        }
        assert!(compared > 100_000);
    }

    /// `nearest_distance` equals the straightforward loop bit for bit, to rectangles and to points, on random
    /// clusters of cell centres (near, touching and far, cells of 0.1 to 1 m, also huge and tiny coordinates).
    #[test]
    fn nearest_distance_skips_only_centres_that_cannot_lower_it() {
        let mut unit = unit_draws(0x9E37_79B9_7F4A_7C15);
        let mut skipped_some = false;
        for case in 0..4000 {
            let cell = [0.1f32, 0.2, 0.5, 1.0][case % 4];
            let hd = core::f32::consts::FRAC_1_SQRT_2 * cell;
            let scale = [1.0f32, 30.0, 1e-3, 5e4][case / 4 % 4];
            let (ox, oy) = ((unit() - 0.5) * 60.0 * scale, (unit() - 0.5) * 60.0 * scale);
            let count = 1 + (unit() * 40.0) as usize;
            let centres: Vec<(f32, f32)> = (0..count)
                .map(|_| {
                    let (i, j) = ((unit() * 12.0) as i32, (unit() * 12.0) as i32);
                    (ox + (i as f32 + 0.5) * cell, oy + (j as f32 + 0.5) * cell)
                })
                .collect();
            let rect = OrientedRect::new(
                (unit() - 0.5) * 60.0 * scale,
                (unit() - 0.5) * 60.0 * scale,
                (unit() - 0.5) * 7.0,
                unit() * 3.0 * scale,
                unit() * 1.5 * scale,
            );
            let got = nearest_distance(centres.iter().copied(), hd, |x, y| rect.outside_offsets(x, y));
            let want = nearest_distance_reference(&centres, hd, |x, y| rect.distance(x, y));
            assert_eq!(got.to_bits(), want.to_bits(), "case {case}: rectangle {rect:?}");
            let p = [(unit() - 0.5) * 60.0 * scale, (unit() - 0.5) * 60.0 * scale];
            let got = nearest_distance(centres.iter().copied(), hd, |x, y| (x - p[0], y - p[1]));
            let want = nearest_distance_reference(&centres, hd, |x, y| libm::hypotf(x - p[0], y - p[1]));
            assert_eq!(got.to_bits(), want.to_bits(), "case {case}: point {p:?}");
            // The test does skip: some centre's squared sum is not below the smallest of those before it.
            let mut smallest = f64::INFINITY;
            for &(x, y) in &centres {
                let (a, b) = (f64::from(x - p[0]), f64::from(y - p[1]));
                let sum = a * a + b * b;
                skipped_some |= sum >= smallest;
                smallest = smallest.min(sum);
            }
        }
        assert!(skipped_some);
    }
}
