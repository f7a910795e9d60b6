//! The rasterize stage's inner loop: points of the sensor frame into the occupancy grid and the visibility map.
//!
//! Two implementations with bit-identical results (the same hit counts, the same order of first touch, the same
//! visibility arrays, the same number of points in the band), selected by [`Rasterizer`]:
//!
//! - [`rasterize_scalar`], the reference: one point at a time, as the stage was first written.
//! - [`rasterize_blocked`]: blocks of [`BLOCK`] points in two passes. Pass 1 has no branches and no memory
//!   writes but to small stack arrays, so the compiler vectorises it: it transforms the points into the ego
//!   frame, classifies them by the height band, and computes the grid cell (or [`NO_CELL`]), the squared range
//!   and the azimuth bin of each. Pass 2 applies the updates to the visibility map and to the grid in point
//!   order, which is what keeps the results identical (ties in the nearest obstacle keep the first point; the
//!   touched-cell list is in the order of first touch).
//!
//! Every floating-point operation of pass 1 is the reference's, in the same order (Rust does not contract
//! `a * b + c` into a fused multiply-add, and the compiler may not reassociate), so each lane computes the same
//! bits; see [`crate::geometry::diamond_angle_select`] for the one rewritten function.

use crate::frame::Isometry3;
use crate::geometry::diamond_angle_select;
use crate::grid::{GridGeometry, OccupancyGrid};
use crate::params::MAX_CELLS_PER_SIDE;
use crate::visibility::{BinParams, VisibilityMap, NO_CELL};

/// Which implementation runs the rasterize stage ([`crate::Monitor::set_rasterizer`]). Both give bit-identical
/// results; the choice exists for verification and benchmarking.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Rasterizer {
    /// Blocks of points in two passes: a branch-free pass the compiler vectorises, then the updates of the grid
    /// and the visibility map in point order. The default.
    #[default]
    Blocked,
    /// The reference: one point at a time.
    Scalar,
}

/// The obstacle height band in the ego frame: `lo_m <= z <= hi_m` is an obstacle, `z < lo_m` a ground return,
/// `z > hi_m` (or NaN) neither. Metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Band {
    /// Lowest obstacle height, metres.
    pub lo_m: f32,
    /// Highest obstacle height, metres.
    pub hi_m: f32,
}

/// The reference loop. Returns the number of points that fell in the band and in the grid.
pub(crate) fn rasterize_scalar(
    points: &[[f32; 3]],
    t: &Isometry3,
    band: Band,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
) -> u32 {
    let (lo, hi) = (band.lo_m, band.hi_m);
    let geometry = grid.geometry;
    let mut in_band = 0u32;
    for p in points {
        let q = t.transform(*p);
        // Above the band (overhangs) or NaN: not an obstacle, and not a return that shows free space.
        if q[2].partial_cmp(&hi).is_none_or(|o| o == core::cmp::Ordering::Greater) {
            continue;
        }
        let obstacle = q[2] >= lo;
        if !(q[0].is_finite() && q[1].is_finite()) {
            continue;
        }
        let cell = if obstacle { geometry.point_to_cell(q[0], q[1]) } else { None };
        visibility.add_return(q[0], q[1], obstacle, cell.unwrap_or(NO_CELL));
        if let Some(cell) = cell {
            // Cannot fail: the touched list has room for max_points >= points cells.
            let _ = grid.add_hit(cell);
            in_band += 1;
        }
    }
    in_band
}

/// Points per block of [`rasterize_blocked`].
pub(crate) const BLOCK: usize = 64;

/// Everything pass 1 needs, computed once per frame.
#[derive(Clone, Copy, Debug)]
struct Pass1 {
    rotation: [[f32; 3]; 3],
    translation: [f32; 3],
    band: Band,
    grid_origin_m: f32,
    inv_cell: f32,
    cells_per_side: u32,
    cells_per_side_f: f32,
    bins: BinParams,
    last_bin_f: f32,
}

impl Pass1 {
    /// `None` when the grid or the map lies outside what pass 1 reproduces exactly (never for a grid and a map
    /// built from validated [`crate::MonitorParams`]): the caller then runs the reference loop.
    fn new(t: &Isometry3, band: Band, geometry: &GridGeometry, bins: BinParams) -> Option<Self> {
        // `GridGeometry` keeps `1 / cell_size_m` private; a geometry equal to a fresh one has exactly this one.
        if *geometry != GridGeometry::new(geometry.cells_per_side, geometry.cell_size_m)
            || geometry.cells_per_side > MAX_CELLS_PER_SIDE
        {
            return None;
        }
        // `floor_small` is exact below 2^23; angles are below 4 (params: at most 65,536 bins).
        let last_bin = u32::try_from(bins.last_bin).ok().filter(|&b| b < 1 << 20)?;
        if !(bins.bins_per_unit >= 0.0 && bins.bins_per_unit <= (1 << 20) as f32) {
            return None;
        }
        Some(Self {
            rotation: t.rotation,
            translation: t.translation_m,
            band,
            grid_origin_m: geometry.origin_m,
            inv_cell: 1.0 / geometry.cell_size_m,
            cells_per_side: geometry.cells_per_side,
            cells_per_side_f: geometry.cells_per_side as f32,
            bins,
            last_bin_f: last_bin as f32,
        })
    }

    /// One point: `(bin, farthest-return candidate r^2, nearest-obstacle candidate r^2, cell)`. A point the
    /// reference skips gets `0.0` and `INFINITY` (they never win) and `NO_CELL`.
    #[inline(always)]
    fn point(&self, p: &[f32; 3]) -> (u32, f32, f32, u32) {
        let [x, y, z] = *p;
        let [r0, r1, r2] = self.rotation;
        let [t0, t1, t2] = self.translation;
        // Exactly `Isometry3::transform`.
        let q0 = r0[0] * x + r0[1] * y + r0[2] * z + t0;
        let q1 = r1[0] * x + r1[1] * y + r1[2] * z + t1;
        let q2 = r2[0] * x + r2[1] * y + r2[2] * z + t2;
        // `&` rather than `&&`: no branches. `v - v` is 0 for finite `v`, NaN for infinite or NaN `v`, so the
        // sum is 0 exactly when both are finite (cheaper than two `is_finite` on SSE2).
        let finite = (q0 - q0) + (q1 - q1) == 0.0;
        let ret = (q2 <= self.band.hi_m) & finite;
        let obstacle = ret & (q2 >= self.band.lo_m);
        // Exactly `GridGeometry::point_to_cell`: the same `f`, the same range test, and `f as u32` (truncation
        // of `f` in `[0, cells_per_side)`) by `floor_small`, which is exact there.
        let fx = (q0 - self.grid_origin_m) * self.inv_cell;
        let fy = (q1 - self.grid_origin_m) * self.inv_cell;
        let n = self.cells_per_side_f;
        let inside = (fx >= 0.0) & (fx < n) & (fy >= 0.0) & (fy < n);
        let index = floor_small(fy).wrapping_mul(self.cells_per_side).wrapping_add(floor_small(fx));
        let cell = if obstacle & inside { index } else { NO_CELL };
        // Exactly `VisibilityMap::add_return`'s range and bin: `(angle * bins_per_unit) as usize`, at most the
        // last bin. The product lies in `[0, 4 bins_per_unit]`, where `floor_small` is exact; clamping before
        // or after the truncation is the same, as the last bin is a whole number.
        let dx = q0 - self.bins.origin[0];
        let dy = q1 - self.bins.origin[1];
        let r2 = dx * dx + dy * dy;
        let v = diamond_angle_select(dx, dy) * self.bins.bins_per_unit;
        let bin = floor_small(if v < self.last_bin_f { v } else { self.last_bin_f });
        let far = if ret { r2 } else { 0.0 };
        let near = if obstacle { r2 } else { f32::INFINITY };
        (bin, far, near, cell)
    }
}

/// `f as u32` for `f` in `[0, 2^23)`, with float operations only (SSE2 converts floats to integers with sign
/// and saturation fix-ups the vectoriser will not emit; these it will). Any value (no panic) elsewhere.
///
/// `(f + 2^23) - 2^23` is `f` rounded to the nearest whole number (in `[2^23, 2^24)` the float spacing is 1),
/// one less if that rounded up is `floor(f)`, and a whole number `w < 2^23` plus `2^23` has the bits
/// `0x4B00_0000 + w`.
#[inline(always)]
fn floor_small(f: f32) -> u32 {
    const TWO_23: f32 = 8_388_608.0;
    let rounded = (f + TWO_23) - TWO_23;
    let floor = rounded - if rounded > f { 1.0 } else { 0.0 };
    (floor + TWO_23).to_bits().wrapping_sub(TWO_23.to_bits())
}

/// Pass 1's output for one block.
#[derive(Clone, Copy, Debug)]
struct Block {
    bins: [u32; BLOCK],
    far_r2: [f32; BLOCK],
    near_r2: [f32; BLOCK],
    cells: [u32; BLOCK],
}

impl Block {
    const EMPTY: Self = Self { bins: [0; BLOCK], far_r2: [0.0; BLOCK], near_r2: [0.0; BLOCK], cells: [0; BLOCK] };

    /// Pass 1 over a block; returns the number of points that fall in the band and in the grid.
    #[inline(always)]
    fn fill(&mut self, k: &Pass1, points: &[[f32; 3]; BLOCK]) -> u32 {
        let outputs = self.bins.iter_mut().zip(self.far_r2.iter_mut()).zip(self.near_r2.iter_mut());
        for ((p, ((bin, far), near)), cell) in points.iter().zip(outputs).zip(self.cells.iter_mut()) {
            (*bin, *far, *near, *cell) = k.point(p);
        }
        self.cells.iter().map(|&c| u32::from(c != NO_CELL)).sum()
    }

    /// Pass 2: the updates, in point order.
    #[inline(always)]
    fn apply(&self, grid: &mut OccupancyGrid, visibility: &mut VisibilityMap) {
        visibility.add_binned(&self.bins, &self.far_r2, &self.near_r2, &self.cells);
        for &c in &self.cells {
            if c != NO_CELL {
                // Cannot fail: the touched list has room for max_points >= points cells.
                let _ = grid.add_hit(c);
            }
        }
    }
}

/// The blocked two-pass loop: the same results as [`rasterize_scalar`] (which it falls back to for a grid or a
/// map it cannot reproduce exactly). Returns the number of points that fell in the band and in the grid.
pub(crate) fn rasterize_blocked(
    points: &[[f32; 3]],
    t: &Isometry3,
    band: Band,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
) -> u32 {
    let Some(k) = Pass1::new(t, band, &grid.geometry, visibility.bin_params()) else {
        return rasterize_scalar(points, t, band, grid, visibility);
    };
    let mut block = Block::EMPTY;
    let mut in_band = 0u32;
    let chunks = points.chunks_exact(BLOCK);
    let rest = chunks.remainder();
    for chunk in chunks {
        let Ok(chunk) = <&[[f32; 3]; BLOCK]>::try_from(chunk) else { continue };
        in_band += block.fill(&k, chunk);
        block.apply(grid, visibility);
    }
    if !rest.is_empty() {
        // NaN padding: the reference skips such points, and so do both passes (no bin, range or cell wins).
        let mut padded = [[f32::NAN; 3]; BLOCK];
        for (d, s) in padded.iter_mut().zip(rest) {
            *d = *s;
        }
        in_band += block.fill(&k, &padded);
        block.apply(grid, visibility);
    }
    in_band
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;
    use crate::geometry::diamond_angle;

    #[test]
    fn diamond_angle_select_equals_diamond_angle() {
        let specials = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.25,
            1e-30,
            -1e-30,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            3e38,
            -3e38,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        for &dx in &specials {
            for &dy in &specials {
                let (a, b) = (diamond_angle(dx, dy), diamond_angle_select(dx, dy));
                assert!(a == b, "diamond_angle({dx}, {dy}) = {a}, select variant {b}");
            }
        }
        // A dense sweep of directions and scales.
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            f32::from_bits((state >> 32) as u32)
        };
        for _ in 0..200_000 {
            let (dx, dy) = (next(), next());
            let (a, b) = (diamond_angle(dx, dy), diamond_angle_select(dx, dy));
            assert!(a == b || (a.is_nan() && b.is_nan()), "diamond_angle({dx:e}, {dy:e}) = {a}, select {b}");
        }
    }
}
