//! The rasterize stage on two threads, with the single thread's bits (issue #16's "optional multi-threaded path
//! for large clouds").
//!
//! The core starts no threads (it is `no_std`): the caller hands [`crate::Monitor::check_split`] a [`Join`], which
//! runs two pieces of work at once however it likes (`rayon::join`, `std::thread::scope`, an RTOS task pair) or
//! one after the other ([`Sequential`]). The sweep is cut in two at a block boundary; the first half goes into the
//! monitor's own grid and visibility map, the second into a second grid and map allocated by
//! [`crate::Monitor::enable_split`] (never per frame); then the second is folded into the first. The fold gives
//! exactly what one pass over the whole sweep in point order gives:
//!
//! - **Hit counts** add, saturating at the grid's maximum: `min(a + b, MAX)` whether the second half's hits came
//!   one at a time or as one count already capped at `MAX` (`min(a + min(b, MAX), MAX) = min(a + b, MAX)`).
//! - **The touched-cell list** (the order of first touch, which later stages iterate in) is the first half's list
//!   followed by the second half's cells the first half did not touch, in the second half's order: the order of
//!   first touch over the whole sweep.
//! - **The nearest obstacle of a bin** is the first return with the smallest `r^2` bits in point order: the
//!   second half's nearest replaces the first half's only when strictly nearer (a tie keeps the first half's,
//!   which came first). **The farthest return** is a maximum.
//! - **The recorded cells** of each point (frames with a region of interest): the second half's after the first's.
//! - **Tall bits** (the grazing rule): or-ed.
//! - **Each cell's sums of its returns' x and y** (`jump_from_returns`): a cell the first half did not touch takes
//!   the second half's sums (the same additions from zero in the same order); a cell both touched gets the second
//!   half's returns added one at a time, in point order, to the first half's sums (a sum of the two sums would
//!   round differently). The second half records its points' cells for this (whether the frame asks for them or
//!   not), and those returns alone are transformed again, with `Isometry3::transform`: the same x and y as pass 1
//!   (up to the sign of a zero, which cannot change a sum that starts at +0).
//!
//! Tests: `split_rasterize_equals_one_pass` (random sweeps, both halves' contents and the fold against one pass)
//! and the whole-check test in `tests/split.rs` (every report field, sequential and on two threads).

use alloc::vec::Vec;

use crate::frame::Isometry3;
use crate::grid::OccupancyGrid;
#[cfg(test)]
use crate::rasterize::{rasterize_blocked, rasterize_blocked_recording};
use crate::rasterize::{rasterize_blocked_into, Band, Source, BLOCK};
use crate::visibility::VisibilityMap;

/// Runs two pieces of work, at the same time or one after the other; [`crate::Monitor::check_split`] gives it
/// the two halves of the rasterize stage. Both must have run when `join` returns.
///
/// With rayon: `impl Join for MyPool { fn join(&self, a, b) { rayon::join(a, b); } }`.
pub trait Join {
    /// Runs `a` and `b`, each once, and returns when both have returned.
    fn join(&self, a: &mut (dyn FnMut() + Send), b: &mut (dyn FnMut() + Send));
}

/// [`Join`] on the calling thread: `a`, then `b` (the split's arithmetic without threads, for tests and for
/// targets without them).
#[derive(Clone, Copy, Debug, Default)]
pub struct Sequential;

impl Join for Sequential {
    fn join(&self, a: &mut (dyn FnMut() + Send), b: &mut (dyn FnMut() + Send)) {
        a();
        b();
    }
}

/// Sweeps with fewer points than this are rasterized on the calling thread whatever the [`Join`]: below it the
/// fold and the hand-over (waking a pool's sleeping thread) cost about what the second thread saves. Measured
/// (docs/performance.md): a 120,000-point sweep gains, a 34,688-point nuScenes sweep lost (rasterize 1.26x).
pub const SPLIT_MIN_POINTS: usize = 65_536;

/// The second half's grid, visibility map and recorded cells ([`crate::Monitor::enable_split`]).
#[derive(Debug)]
pub(crate) struct SecondHalf {
    pub grid: OccupancyGrid,
    pub visibility: VisibilityMap,
    pub cells: Vec<u32>,
}

/// The monitor's buffers one half of the sweep goes into.
pub(crate) struct Half<'a> {
    pub grid: &'a mut OccupancyGrid,
    pub visibility: &'a mut VisibilityMap,
    pub cells: &'a mut Vec<u32>,
}

/// The blocked rasterizer over `points[..mid]` into `first` and `points[mid..]` into `second`, run by `join`, then
/// the fold (module docs). `second.grid` must be clear (it is left clear) and its map is reset here. `record`:
/// each point's cell into `first.cells` (which must have room for every point, as for
/// `rasterize_blocked_recording`), as one pass would. Returns the number of points in the band and in the grid.
#[allow(clippy::too_many_arguments)]
pub(crate) fn rasterize_split<S: Source>(
    points: S,
    t: &Isometry3,
    band: Band,
    first: Half<'_>,
    second: Half<'_>,
    wide: bool,
    record: bool,
    join: &dyn Join,
) -> u32 {
    // A block boundary near the middle: each half's blocks are those of one pass.
    let mid = (points.len() / 2).next_multiple_of(BLOCK).min(points.len());
    let (a_points, b_points) = points.split_at(mid);
    second.visibility.reset(first.visibility.origin());
    let (mut in_a, mut in_b) = (0u32, 0u32);
    {
        let Half { grid: ga, visibility: va, cells: ca } = first;
        let Half { grid: gb, visibility: vb, cells: cb } = second;
        // The second half's cells also for the fold of the sums (not of first returns: a cell both halves touched
        // keeps the first half's, `OccupancyGrid::absorb`).
        let record_b = record || (gb.has_sums() && !gb.has_first_returns());
        let mut a = || in_a = rasterize_blocked_into(a_points, t, band, ga, va, wide, record, ca);
        let mut b = || in_b = rasterize_blocked_into(b_points, t, band, gb, vb, wide, record_b, cb);
        join.join(&mut a, &mut b);
        if ga.absorb(gb) {
            // The second half's returns of the cells both halves touched, in point order.
            if cb.len() == b_points.len() {
                for (p, &c) in b_points.iter().zip(cb.iter()) {
                    if gb.shared_sum(c) {
                        let q = t.transform(p);
                        ga.add_return_sum(c, q[0], q[1]);
                    }
                }
            } else {
                // Not recorded (never with the capacities of `Monitor::enable_split`): the same returns, by the
                // reference's definition.
                let geometry = gb.geometry;
                for p in b_points.iter() {
                    let q = t.transform(p);
                    if !(q[2] >= band.lo_m && q[2] <= band.hi_m) || band.in_ego(q[0], q[1]) {
                        continue;
                    }
                    if let Some(c) = geometry.point_to_cell(q[0], q[1]).filter(|&c| gb.shared_sum(c)) {
                        ga.add_return_sum(c, q[0], q[1]);
                    }
                }
            }
        }
        gb.reset();
        va.absorb(vb);
        if record {
            // Both halves recorded (or, without room, neither: `rasterize_blocked_recording` then leaves its
            // list empty, and so the whole frame's list stays empty as one pass would leave it).
            if ca.len() == a_points.len() && cb.len() == b_points.len() && ca.capacity() >= points.len() {
                ca.extend_from_slice(cb);
            } else {
                ca.clear();
            }
        }
        cb.clear();
    }
    in_a + in_b
}

#[cfg(test)]
mod tests {
    use alloc::vec;
    use alloc::vec::Vec;

    use super::*;
    use crate::frame::PointColumns;
    use crate::grid::GridGeometry;
    use crate::visibility::{Sight, NO_CELL};

    struct Lcg(u64);

    impl Lcg {
        fn unit(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            ((self.0 >> 40) as f32) / (1u64 << 24) as f32
        }
    }

    /// A sweep with rings (runs of one cell), exact ties of range across the halves, NaNs, points outside the
    /// grid and above and below the band.
    fn sweep(seed: u64, n: usize) -> Vec<[f32; 3]> {
        let mut r = Lcg(seed);
        let mut pts: Vec<[f32; 3]> = (0..n)
            .map(|i| {
                let u = r.unit();
                match i % 97 {
                    0 => [f32::NAN, 1.0, 0.5],
                    1 => [200.0 * u - 100.0, 90.0, 0.5],
                    _ => {
                        let a = core::f32::consts::TAU * (i as f32 / 512.0).fract();
                        let range = 2.0 + 60.0 * u * u;
                        [range * libm::cosf(a), range * libm::sinf(a), 3.0 * r.unit() - 1.5]
                    }
                }
            })
            .collect();
        // The second half repeats some of the first half's points exactly: equal ranges in one bin.
        for i in 0..n / 8 {
            let j = n / 2 + 3 * i;
            if j < n {
                pts[j] = pts[i * 2];
            }
        }
        pts
    }

    fn grid(max_touched: usize) -> OccupancyGrid {
        OccupancyGrid::new(GridGeometry::new(160, 0.5), 0.7, max_touched).with_returns()
    }

    /// [`grid`] with the sums and tall bits of `jump_from_returns` and the grazing rule.
    fn grid_extra(max_touched: usize) -> OccupancyGrid {
        grid(max_touched).with_sums().with_tall(1.2)
    }

    /// [`grid`] with each cell's first return (`jump_first_return`) and the tall bits.
    fn grid_first(max_touched: usize) -> OccupancyGrid {
        grid(max_touched).with_first_returns().with_tall(1.2)
    }

    #[test]
    fn split_rasterize_equals_one_pass() {
        let band = Band { lo_m: -0.2, hi_m: 1.0, ego_m: [-1.0, -1.0, 2.0, 1.0] };
        let t = Isometry3::from_yaw_translation(0.3, [1.0, 0.2, 1.7]);
        let upright = Isometry3::from_translation(0.5, 0.0, 1.8);
        for (seed, n) in [(1u64, 0usize), (2, 1), (3, 63), (4, 64), (5, 130), (6, 5_000), (7, 40_001)] {
            for t in [t, upright] {
                for (record, kind) in [(false, 0), (true, 0), (false, 1), (true, 1), (false, 2), (true, 2)] {
                    let extra = kind > 0;
                    let grid = [grid, grid_extra, grid_first][kind];
                    for wide in [false, true] {
                        let pts = sweep(seed, n);
                        let (mut g1, mut v1, mut c1) = (grid(n), VisibilityMap::new(720), Vec::with_capacity(n));
                        v1.reset([t.translation_m[0], t.translation_m[1]]);
                        let in1 = if record {
                            rasterize_blocked_recording(pts.as_slice(), &t, band, &mut g1, &mut v1, wide, &mut c1)
                        } else {
                            rasterize_blocked(pts.as_slice(), &t, band, &mut g1, &mut v1, wide)
                        };
                        // The same sweep as columns, split at the same point.
                        let [x, y, z]: [Vec<f32>; 3] = core::array::from_fn(|k| pts.iter().map(|p| p[k]).collect());
                        let columns = PointColumns::new(&x, &y, &z).unwrap();
                        let (mut g2, mut v2, mut c2) = (grid(n), VisibilityMap::new(720), Vec::with_capacity(n));
                        let (mut gb, mut vb, mut cb) = (grid(n), VisibilityMap::new(720), Vec::with_capacity(n));
                        v2.reset([t.translation_m[0], t.translation_m[1]]);
                        // Twice for each layout: the second grid must come back clear after the first frame.
                        for pass in 0..4 {
                            g2.reset();
                            v2.reset([t.translation_m[0], t.translation_m[1]]);
                            c2.clear();
                            let first = Half { grid: &mut g2, visibility: &mut v2, cells: &mut c2 };
                            let second = Half { grid: &mut gb, visibility: &mut vb, cells: &mut cb };
                            let in2 = if pass < 2 {
                                rasterize_split(pts.as_slice(), &t, band, first, second, wide, record, &Sequential)
                            } else {
                                rasterize_split(columns, &t, band, first, second, wide, record, &Sequential)
                            };
                            let what = alloc::format!(
                                "seed {seed}, n {n}, record {record}, extra {kind}, wide {wide}, pass {pass}"
                            );
                            assert_eq!(in1, in2, "{what}");
                            assert_eq!(g1.touched(), g2.touched(), "{what}");
                            for &c in g1.touched() {
                                assert_eq!(g1.hits(c), g2.hits(c), "{what}, cell {c}");
                                let bits = |r: Option<[f32; 3]>| r.map(|r| r.map(f32::to_bits));
                                assert_eq!(bits(g1.returns(c)), bits(g2.returns(c)), "{what}, returns of cell {c}");
                                assert_eq!(bits(g1.sums(c)), bits(g2.sums(c)), "{what}, sums of cell {c}");
                                assert_eq!(g1.sums(c).is_some(), extra, "{what}");
                            }
                            for c in 0..160 * 160 {
                                assert_eq!(g1.tall(c), g2.tall(c), "{what}, tall cell {c}");
                                assert!(!gb.tall(c), "{what}: the second grid's tall bits are left clear");
                            }
                            if extra && n > 1000 {
                                assert!((0..160 * 160).any(|c| g1.tall(c)), "{what}: tall returns");
                            }
                            assert_eq!(v1.arrays(), v2.arrays(), "{what}");
                            assert_eq!(c1, c2, "{what}");
                            assert!(gb.touched().is_empty(), "{what}: the second grid is left clear");
                        }
                    }
                }
            }
        }
    }

    /// `pts` (sensor at the origin, identity extrinsic, band -1..1 m, no ego mask, `bins` bins) rasterized in one
    /// pass and in two halves folded together: each run's grid and visibility map.
    fn one_pass_and_split(
        pts: &[[f32; 3]],
        bins: u32,
    ) -> ((OccupancyGrid, VisibilityMap), (OccupancyGrid, VisibilityMap)) {
        let band = Band { lo_m: -1.0, hi_m: 1.0, ego_m: Band::NO_EGO };
        let t = Isometry3::IDENTITY;
        let n = pts.len();
        let (mut g1, mut v1) = (grid(n), VisibilityMap::new(bins));
        v1.reset([0.0, 0.0]);
        rasterize_blocked(pts, &t, band, &mut g1, &mut v1, false);
        let (mut g2, mut v2, mut c2) = (grid(n), VisibilityMap::new(bins), Vec::new());
        let (mut gb, mut vb, mut cb) = (grid(n), VisibilityMap::new(bins), Vec::new());
        v2.reset([0.0, 0.0]);
        let first = Half { grid: &mut g2, visibility: &mut v2, cells: &mut c2 };
        let second = Half { grid: &mut gb, visibility: &mut vb, cells: &mut cb };
        rasterize_split(pts, &t, band, first, second, false, false, &Sequential);
        ((g1, v1), (g2, v2))
    }

    #[test]
    fn a_tie_across_the_halves_keeps_the_first_halfs_obstacle() {
        // (10.2, 10.9) and (10.9, 10.2) have the same r^2 bits, lie in one of 60 bins (45 degrees is mid-bin 7)
        // and in different cells: the nearest obstacle of that bin is the first half's return, as in one pass.
        let mut pts = vec![[-20.0_f32, 3.0, 0.0]; 200];
        pts[5] = [10.2, 10.9, 0.0];
        pts[150] = [10.9, 10.2, 0.0];
        let ((_, v1), (_, v2)) = one_pass_and_split(&pts, 60);
        let geometry = GridGeometry::new(160, 0.5);
        let (first_cell, second_cell) = (geometry.point_to_cell(10.2, 10.9), geometry.point_to_cell(10.9, 10.2));
        assert_ne!(first_cell, second_cell);
        assert_eq!(v1.sight(12.0, 12.0), Sight::Shadowed(first_cell.unwrap_or(NO_CELL)));
        assert_eq!(v1.arrays(), v2.arrays());
    }

    #[test]
    fn saturated_counts_fold_like_one_pass() {
        // 600 returns in one cell, half in each half: the count saturates the same way.
        let pts = vec![[5.1_f32, 5.1, 0.0]; 600];
        let ((g1, _), (g2, _)) = one_pass_and_split(&pts, 64);
        let c = g1.touched()[0];
        assert_eq!(g1.hits(c), g2.hits(c));
        assert!(g2.hits(c) > 0 && g2.touched() == g1.touched());
    }
}
