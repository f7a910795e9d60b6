//! The rasterize stage's inner loop: points of the sensor frame into the occupancy grid and the visibility map.
//!
//! Two implementations with bit-identical results (the same hit counts, the same order of first touch, the same
//! visibility arrays, the same number of points in the band), selected by [`Rasterizer`]:
//!
//! - [`rasterize_scalar`], the reference: one point at a time, as the stage was first written.
//! - [`rasterize_blocked`]: blocks of [`BLOCK`] points in two passes. Pass 1 has no branches and writes only to
//!   small stack arrays, so the compiler vectorises it (4 points per SSE2 instruction, 8 per AVX2 instruction in
//!   the version chosen at run time, see [`Rasterizer::Blocked`]): it transforms the points into the ego frame,
//!   classifies them by the height band, and computes the grid cell (or [`NO_CELL`]), the squared range and the
//!   azimuth bin of each. Pass 2 applies the updates in point order, which is what keeps the results identical
//!   (ties in the nearest obstacle keep the first point; the touched-cell list is in the order of first touch):
//!   to the visibility map without branches on the data (whether a return is the nearest or farthest so far is
//!   not predictable; the nearest obstacle is the first return with the smallest `r^2` bits, compared strictly
//!   in point order), and to the grid one run of consecutive hits of a cell at a time (see `OccupancyGrid::add_hits`).
//!
//! Pass 1 computes the reference's floating-point operations in the reference's order (Rust neither contracts
//! `a * b + c` into a fused multiply-add nor reassociates, whatever the instruction set), so each lane has the
//! reference's bits. Three things are written differently, each exact and argued where it is done: the diamond
//! angle without branches ([`crate::geometry::diamond_angle_select`]), float-to-integer truncation by float
//! operations ([`floor_small`], as SSE2 has no vector form of Rust's saturating `as`), and, for an upright sensor
//! (identity rotation, the usual extrinsic), the transform as a translation. The division of the diamond angle
//! stays: no multiplication by a reciprocal rounds like it.
//!
//! With the params keys `jump_from_returns` and `roi_graze_fraction` the grid also keeps each hit cell's sums of its
//! returns' x and y (`OccupancyGrid::with_sums`) and a bit per cell for the returns above the grazing height
//! (`OccupancyGrid::with_tall`): separate instantiations of the blocked loop (`SUMS`, `TALL`) fill them, so that the
//! default loop is the one without; the reference loop fills them return by return (docs/performance.md, "The two
//! opt-in rules' per-cell data in the rasterize loop").

use alloc::vec::Vec;

use crate::frame::{Isometry3, PointColumns};
use crate::geometry::diamond_angle_select;
use crate::grid::{bits_below, GridGeometry, OccupancyGrid};
use crate::params::MAX_CELLS_PER_SIDE;
use crate::visibility::{BinParams, VisibilityMap, NO_CELL};

/// Which implementation runs the rasterize stage ([`crate::Monitor::set_rasterizer`]). Both give bit-identical
/// results; the choice exists for verification and benchmarking.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Rasterizer {
    /// Blocks of points in two passes: a branch-free pass the compiler vectorises, then the updates of the grid
    /// and the visibility map in point order; compiled for the widest vector unit the processor offers (with the
    /// `std` feature on x86-64: AVX2 when the processor has it, detected at run time; otherwise as
    /// [`Rasterizer::BlockedBaseline`]). The default.
    #[default]
    Blocked,
    /// The blocked loop compiled for the target's baseline only (SSE2 on x86-64), whatever the processor.
    BlockedBaseline,
    /// The reference: one point at a time.
    Scalar,
}

impl Rasterizer {
    /// The instruction set the blocked loop runs with on this processor: `"avx2"`, `"baseline"` or `"scalar"`.
    #[must_use]
    pub fn instruction_set(self) -> &'static str {
        match self {
            Self::Blocked if wide::available() => "avx2",
            Self::Blocked | Self::BlockedBaseline => "baseline",
            Self::Scalar => "scalar",
        }
    }
}

/// The obstacle height band in the ego frame: `lo_m <= z <= hi_m` is an obstacle, `z < lo_m` a ground return,
/// `z > hi_m` (or NaN) neither. Metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Band {
    /// Lowest obstacle height, metres.
    pub lo_m: f32,
    /// Highest obstacle height, metres.
    pub hi_m: f32,
    /// The ego footprint `[min_x, min_y, max_x, max_y]`: returns inside it are skipped like NaN points. An
    /// empty box (`min > max`) masks nothing.
    pub ego_m: [f32; 4],
}

impl Band {
    /// No ego mask.
    pub(crate) const NO_EGO: [f32; 4] = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];

    /// True when `(x, y)` lies in the ego footprint (never for NaN).
    #[inline(always)]
    pub(crate) fn in_ego(&self, x: f32, y: f32) -> bool {
        let e = self.ego_m;
        (x >= e[0]) & (x <= e[2]) & (y >= e[1]) & (y <= e[3])
    }
}

/// The reference loop. Returns the number of points that fell in the band and in the grid.
pub(crate) fn rasterize_scalar<S: Source>(
    points: S,
    t: &Isometry3,
    band: Band,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
) -> u32 {
    scalar(points, t, band, grid, visibility, None)
}

/// [`rasterize_scalar`], and each point's grid cell in `cells` (see [`rasterize_blocked_recording`]).
pub(crate) fn rasterize_scalar_recording<S: Source>(
    points: S,
    t: &Isometry3,
    band: Band,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
    cells: &mut Vec<u32>,
) -> u32 {
    cells.clear();
    let record = (cells.capacity() >= points.len()).then_some(cells);
    scalar(points, t, band, grid, visibility, record)
}

/// The reference loop, recording each point's cell (or [`NO_CELL`]) in `cells` when given (room for every point
/// is the caller's).
fn scalar<S: Source>(
    points: S,
    t: &Isometry3,
    band: Band,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
    mut cells: Option<&mut Vec<u32>>,
) -> u32 {
    let (lo, hi) = (band.lo_m, band.hi_m);
    let geometry = grid.geometry;
    let tall = grid.tall_above_m();
    let mut in_band = 0u32;
    for p in points.iter() {
        let q = t.transform(p);
        // With the grazing rule: a return higher than the threshold marks its cell (any return, in the band or
        // not, ego footprint or not; NaN never).
        if let Some(top) = tall {
            if q[2] > top {
                if let Some(cell) = geometry.point_to_cell(q[0], q[1]) {
                    grid.add_tall(cell);
                }
            }
        }
        // Above the band (overhangs) or NaN: not an obstacle, and not a return that shows free space.
        let skipped = q[2].partial_cmp(&hi).is_none_or(|o| o == core::cmp::Ordering::Greater)
            || !(q[0].is_finite() && q[1].is_finite())
            || band.in_ego(q[0], q[1]);
        let obstacle = q[2] >= lo;
        let cell = if obstacle && !skipped { geometry.point_to_cell(q[0], q[1]) } else { None };
        if let Some(cells) = cells.as_deref_mut() {
            cells.push(cell.unwrap_or(NO_CELL));
        }
        if skipped {
            continue;
        }
        visibility.add_return(q[0], q[1], obstacle, cell.unwrap_or(NO_CELL));
        if let Some(cell) = cell {
            // `VisibilityMap::add_return`'s squared range, the same operations.
            let o = visibility.origin();
            let (dx, dy) = (q[0] - o[0], q[1] - o[1]);
            // Cannot fail: the touched list has room for max_points >= points cells.
            let _ = grid.add_hit_return(cell, dx * dx + dy * dy, q);
            in_band += 1;
        }
    }
    in_band
}

/// Points per block of [`rasterize_blocked`].
pub(crate) const BLOCK: usize = 64;

/// Everything pass 1 needs, computed once per frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pass1 {
    rotation: [[f32; 3]; 3],
    translation: [f32; 3],
    band: Band,
    grid_origin_m: f32,
    inv_cell: f32,
    cells_per_side: u32,
    cells_per_side_f: f32,
    bins: BinParams,
    last_bin_f: f32,
    /// The height above which a return marks its cell tall ([`OccupancyGrid::tall_above_m`]; infinite: none).
    tall_m: f32,
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
            tall_m: f32::INFINITY,
        })
    }

    /// A point's x and y in the ego frame, by `Isometry3::transform` itself (the reference loop's computation):
    /// the first return of a new cell with `OccupancyGrid::with_first_returns`, computed once per new cell.
    #[inline(always)]
    fn xy(&self, p: [f32; 3]) -> (f32, f32) {
        let [x, y, _] = Isometry3 { rotation: self.rotation, translation_m: self.translation }.transform(p);
        (x, y)
    }

    /// True when the rotation is the identity (entries exactly 1 and 0, of either sign): the common upright
    /// sensor, for which [`Pass1::point`] has a cheaper exact transform.
    #[allow(clippy::float_cmp)] // Exact ones and zeros are the condition (either zero: `-0.0 == 0.0`).
    fn translation_only(&self) -> bool {
        let [r0, r1, r2] = self.rotation;
        r0 == [1.0, 0.0, 0.0] && r1 == [0.0, 1.0, 0.0] && r2 == [0.0, 0.0, 1.0]
    }

    /// One point: `(bin, farthest-return candidate r^2, nearest-obstacle candidate r^2 as bits, cell, z, x, y,
    /// tall cell)` (`x`, `y`, `z` in the ego frame). A point the reference skips gets `0.0` and `u32::MAX` (they
    /// never win) and `NO_CELL`; so does an obstacle whose `r^2` is infinite (the reference's `r2 < INFINITY`
    /// fails for it). The tall cell: the grid cell of a return higher than `tall_m`, else `NO_CELL`.
    /// `TRANSLATION_ONLY` requires [`Pass1::translation_only`].
    #[inline(always)]
    fn point<const TRANSLATION_ONLY: bool, const EGO_MASK: bool, const ROUND: bool>(
        &self,
        x: f32,
        y: f32,
        z: f32,
    ) -> (u32, f32, u32, u32, f32, f32, f32, u32) {
        let [t0, t1, t2] = self.translation;
        // `&` rather than `&&`: no branches. A sum of `zero_if_finite` terms is 0 exactly when all are finite.
        let (q0, q1, q2, finite) = if TRANSLATION_ONLY {
            // `Isometry3::transform` computes `q0 = 1 x + 0 y + 0 z + t0`. For finite x, y, z that is `x + t0`
            // but for the sign of a zero when `x` and `t0` are zeros, which nothing downstream can tell (a zero
            // `q0` only enters `q0 - origin` and `|dx|`, `dx < 0`, `dx * dx`). A non-finite x, y or z makes the
            // reference's `q0` and `q1` NaN (`0 * inf`), a skipped point: hence the test of `z` here (`x` and
            // `y` are tested through `q0 = x + t0` and `q1 = y + t1`, not finite when they are not).
            let (q0, q1, q2) = (x + t0, y + t1, z + t2);
            (q0, q1, q2, zero_if_finite(q0) + zero_if_finite(q1) + zero_if_finite(z) == 0.0)
        } else {
            // Exactly `Isometry3::transform`.
            let [r0, r1, r2] = self.rotation;
            let q0 = r0[0] * x + r0[1] * y + r0[2] * z + t0;
            let q1 = r1[0] * x + r1[1] * y + r1[2] * z + t1;
            let q2 = r2[0] * x + r2[1] * y + r2[2] * z + t2;
            (q0, q1, q2, zero_if_finite(q0) + zero_if_finite(q1) == 0.0)
        };
        // The ego mask is a separate instantiation: testing it in every frame costs half the loop's speed.
        let ret = (q2 <= self.band.hi_m) & finite & !(EGO_MASK && self.band.in_ego(q0, q1));
        let obstacle = ret & (q2 >= self.band.lo_m);
        // Exactly `GridGeometry::point_to_cell`: the same `f`, the same range test, and `f as u32` (truncation
        // of `f` in `[0, cells_per_side)`) by `floor_small`, which is exact there.
        let fx = (q0 - self.grid_origin_m) * self.inv_cell;
        let fy = (q1 - self.grid_origin_m) * self.inv_cell;
        let n = self.cells_per_side_f;
        let inside = (fx >= 0.0) & (fx < n) & (fy >= 0.0) & (fy < n);
        let index = floor_of::<ROUND>(fy).wrapping_mul(self.cells_per_side).wrapping_add(floor_of::<ROUND>(fx));
        let cell = if obstacle & inside { index } else { NO_CELL };
        // Exactly `VisibilityMap::add_return`'s range and bin: `(angle * bins_per_unit) as usize`, at most the
        // last bin. The product lies in `[0, 4 bins_per_unit]`, where `floor_small` is exact; clamping before
        // or after the truncation is the same, as the last bin is a whole number.
        let dx = q0 - self.bins.origin[0];
        let dy = q1 - self.bins.origin[1];
        let r2 = dx * dx + dy * dy;
        let v = diamond_angle_select(dx, dy) * self.bins.bins_per_unit;
        let bin = floor_of::<ROUND>(if v < self.last_bin_f { v } else { self.last_bin_f });
        let far = if ret { r2 } else { 0.0 };
        // `r2` is never NaN here (finite coordinates), and never `-0.0`: the bits of the non-negative floats
        // order as their values, which `VisibilityMap::add_binned` relies on.
        let near = if obstacle & (r2 < f32::INFINITY) { r2.to_bits() } else { u32::MAX };
        // The reference's `q2 > top` and `point_to_cell(q0, q1)`, for every return: `finite` as above (a non-finite
        // z makes the reference's `q0` NaN, so no cell, also where this transform is a translation).
        let tall = if finite & (q2 > self.tall_m) & inside { index } else { NO_CELL };
        (bin, far, near, cell, q2, q0, q1, tall)
    }
}

/// 0 for a finite `v`, NaN for an infinite or NaN `v`: one subtraction (`is_finite` is three SSE2 operations).
#[inline(always)]
#[allow(clippy::eq_op)] // `v - v` is the point.
fn zero_if_finite(v: f32) -> f32 {
    v - v
}

/// `f as u32` for `f` in `[0, 2^23)`, with float operations only (SSE2 converts floats to integers with sign
/// and saturation fix-ups the vectoriser will not emit; these it will). Any value (no panic) elsewhere.
///
/// `(f + 2^23) - 2^23` is `f` rounded to the nearest whole number (in `[2^23, 2^24)` the float spacing is 1);
/// that, less one where it rounded up, is `floor(f)`; and a whole number `w < 2^23` plus `2^23` has the bits
/// `0x4B00_0000 + w`.
#[inline(always)]
fn floor_small(f: f32) -> u32 {
    const TWO_23: f32 = 8_388_608.0;
    let rounded = (f + TWO_23) - TWO_23;
    let floor = rounded - if rounded > f { 1.0 } else { 0.0 };
    (floor + TWO_23).to_bits().wrapping_sub(TWO_23.to_bits())
}

/// [`floor_small`], with the processor's rounding instruction when the loop is compiled for one (`ROUND`: the AVX2
/// build, and AVX2 implies SSE4.1's `roundps`): for `f` in `[0, 2^23)`, `f.trunc()` is `floor(f)`, and the whole
/// number plus `2^23` has the bits `0x4B00_0000 + w` as in [`floor_small`]; three operations instead of seven.
/// Outside that range the two may differ (pass 1 discards those values: a cell outside the grid, a bin clamped
/// first). Only with `std`: `core` has no `trunc` (and the AVX2 build exists only with `std`).
#[inline(always)]
fn floor_of<const ROUND: bool>(f: f32) -> u32 {
    #[cfg(feature = "std")]
    if ROUND {
        const TWO_23: f32 = 8_388_608.0;
        return (f.trunc() + TWO_23).to_bits().wrapping_sub(TWO_23.to_bits());
    }
    floor_small(f)
}

/// Pass 1's output for one block.
#[derive(Clone, Copy, Debug)]
struct Block {
    bins: [u32; BLOCK],
    far_r2: [f32; BLOCK],
    /// Each point's candidate nearest obstacle as the two 32-bit halves of a visibility-map key
    /// (`crate::visibility::key`), lower half first: `[squared range's bits, cell]`. Pass 1 writes them, its 32-bit
    /// lanes interleaved (two unpacks and two lane permutes per 8 points); `VisibilityMap::add_binned` compares the
    /// bits and moves the pair as one 64-bit key. (Until round viscopy the keys were `u64`s built in a loop of their
    /// own after pass 1, 1.28 instructions per point; built as `u64`s in pass 1 their 64-bit lanes halved its vector
    /// width.)
    near_keys: [[u32; 2]; BLOCK],
    cells: [u32; BLOCK],
    /// Each point's z in the ego frame (read for the points with a cell: obstacle returns in the grid).
    z: [f32; BLOCK],
    /// With `SUMS` (the grid keeps sums): each point's x and y in the ego frame (read for the points with a cell);
    /// with `TALL` (the grid keeps tall bits), its tall cell (see [`Pass1::point`]). Not written otherwise.
    x: [f32; BLOCK],
    y: [f32; BLOCK],
    tall: [u32; BLOCK],
}

impl Block {
    const EMPTY: Self = Self {
        bins: [0; BLOCK],
        far_r2: [0.0; BLOCK],
        near_keys: [[0; 2]; BLOCK],
        cells: [0; BLOCK],
        z: [0.0; BLOCK],
        x: [0.0; BLOCK],
        y: [0.0; BLOCK],
        tall: [NO_CELL; BLOCK],
    };

    /// Pass 1 over a block of [`BLOCK`] points, read as [`Lanes`] gives them (records or columns: one body, the
    /// same instructions per lane), and the points' visibility-map keys from its outputs. With `SUMS`, also each
    /// point's x and y, with `TALL` its tall cell.
    #[inline(always)]
    fn fill<
        const TRANSLATION_ONLY: bool,
        const EGO_MASK: bool,
        const ROUND: bool,
        const SUMS: bool,
        const TALL: bool,
    >(
        &mut self,
        k: &Pass1,
        points: impl Lanes,
    ) {
        let outputs = self.bins.iter_mut().zip(self.far_r2.iter_mut()).zip(self.near_keys.iter_mut());
        let cells = self.cells.iter_mut().zip(self.z.iter_mut());
        if SUMS || TALL {
            let extra = self.x.iter_mut().zip(self.y.iter_mut()).zip(self.tall.iter_mut());
            for ((([x, y, z], ((bin, far), near)), (cell, height)), ((qx, qy), tall)) in
                points.points().zip(outputs).zip(cells).zip(extra)
            {
                let (q0, q1, t);
                let (r2, c);
                (*bin, *far, r2, c, *height, q0, q1, t) = k.point::<TRANSLATION_ONLY, EGO_MASK, ROUND>(x, y, z);
                (*near, *cell) = ([r2, c], c);
                if SUMS {
                    (*qx, *qy) = (q0, q1);
                }
                if TALL {
                    *tall = t;
                }
            }
        } else {
            for (([x, y, z], ((bin, far), near)), (cell, height)) in points.points().zip(outputs).zip(cells) {
                let (r2, c);
                (*bin, *far, r2, c, *height, _, _, _) = k.point::<TRANSLATION_ONLY, EGO_MASK, ROUND>(x, y, z);
                (*near, *cell) = ([r2, c], c);
            }
        }
    }

    /// Pass 2: the updates, in point order (with `SUMS` and `TALL`, also the grid's sums and tall bits; with the
    /// grid's first returns, those of the cells new in the block, from `points`). Returns the number of the block's
    /// points that fall in the band and in the grid.
    #[inline(always)]
    fn apply<const SUMS: bool, const TALL: bool>(
        &self,
        k: &Pass1,
        points: impl Lanes,
        grid: &mut OccupancyGrid,
        visibility: &mut VisibilityMap,
    ) -> u32 {
        let from = grid.touched_len();
        visibility.add_binned(&self.bins, &self.far_r2, &self.near_keys);
        // A point with a cell is an obstacle return in the grid: its key pair's first half is its squared range's bits.
        let xy = if SUMS { Some((&self.x, &self.y)) } else { None };
        // The points with a cell (pass 1 gives a cell in the grid or `NO_CELL`): the block's points in the band and
        // in the grid, counted from the grid's mask of them.
        let in_band = grid.add_hits_with_returns(&self.cells, Some((&self.near_keys, &self.z)), xy);
        // First returns come with the loop without `SUMS` (`blocks_for`): the loops with it do not look.
        if !SUMS {
            grid.set_first_returns(from, |j| k.xy(points.point(j)));
        }
        // Most blocks hold no tall return (`NO_CELL` has every bit set: the `and` of the block's entries is `NO_CELL`
        // exactly when none is a cell); in the others, the tall points as a mask, then those alone.
        if TALL && self.tall.iter().fold(NO_CELL, |a, &c| a & c) != NO_CELL {
            // `c != NO_CELL` is `c < NO_CELL` (`u32::MAX`).
            let mut mask = bits_below(&self.tall, NO_CELL);
            while mask != 0 {
                let j = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if let Some(&c) = self.tall.get(j) {
                    grid.add_tall(c);
                }
            }
        }
        in_band
    }
}

/// The blocked two-pass loop: the same results as [`rasterize_scalar`] (which it falls back to for a grid or a
/// map it cannot reproduce exactly). `wide`: use the wider vector unit when the processor has one (see
/// [`Rasterizer::Blocked`]). Returns the number of points that fell in the band and in the grid.
pub(crate) fn rasterize_blocked<S: Source>(
    points: S,
    t: &Isometry3,
    band: Band,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
    wide: bool,
) -> u32 {
    let Some(k) = Pass1::new(t, band, &grid.geometry, visibility.bin_params()) else {
        return rasterize_scalar(points, t, band, grid, visibility);
    };
    blocks_for::<S, false>(&k, band, points, grid, visibility, wide, &mut Vec::new())
}

/// [`rasterize_blocked`], or with `record` [`rasterize_blocked_recording`] into `cells`: the blocked loop as the
/// monitor runs it (and each half of `crate::split` does).
#[allow(clippy::too_many_arguments)]
pub(crate) fn rasterize_blocked_into<S: Source>(
    points: S,
    t: &Isometry3,
    band: Band,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
    wide: bool,
    record: bool,
    cells: &mut Vec<u32>,
) -> u32 {
    if record {
        rasterize_blocked_recording(points, t, band, grid, visibility, wide, cells)
    } else {
        rasterize_blocked(points, t, band, grid, visibility, wide)
    }
}

/// [`blocks_on`] instantiated for the frame: a pure translation or not, with an ego footprint or not, with the
/// grid's sums or tall bits (the params keys `jump_from_returns`, `roi_graze_fraction`: a separate instantiation,
/// so that the default loop is the one without them) or not.
fn blocks_for<S: Source, const RECORD: bool>(
    k: &Pass1,
    band: Band,
    points: S,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
    wide: bool,
    cells: &mut Vec<u32>,
) -> u32 {
    macro_rules! on {
        ($k:expr, $sums:literal, $tall:literal) => {{
            let k = $k;
            match (k.translation_only(), band.ego_m != Band::NO_EGO) {
                (true, false) => {
                    blocks_on::<S, true, false, RECORD, $sums, $tall>(k, points, grid, visibility, wide, cells)
                }
                (false, false) => {
                    blocks_on::<S, false, false, RECORD, $sums, $tall>(k, points, grid, visibility, wide, cells)
                }
                (true, true) => {
                    blocks_on::<S, true, true, RECORD, $sums, $tall>(k, points, grid, visibility, wide, cells)
                }
                (false, true) => {
                    blocks_on::<S, false, true, RECORD, $sums, $tall>(k, points, grid, visibility, wide, cells)
                }
            }
        }};
    }
    let tall = grid.tall_above_m();
    let with_tall = &Pass1 { tall_m: tall.unwrap_or(f32::INFINITY), ..*k };
    // First returns alone (`OccupancyGrid::with_first_returns`): the loop without the sums (pass 2 sets each new
    // cell's first return).
    match (grid.has_sums() && !grid.has_first_returns(), tall.is_some()) {
        (false, false) => on!(k, false, false),
        (true, false) => on!(k, true, false),
        (false, true) => on!(with_tall, false, true),
        (true, true) => on!(with_tall, true, true),
    }
}

/// [`rasterize_blocked`], and in `cells` each point's grid cell as the rasterizer found it: the cell of an
/// obstacle-band return in the grid (outside the ego footprint), [`NO_CELL`] for every other point, one entry per
/// point in order (the same entries as [`rasterize_scalar_recording`]). For the frames with a region of interest
/// (the cluster stage decides cells on its edge by their returns without a second transform of the sweep): a
/// separate instantiation of the loop, so that frames without one do not pay for it. `cells` is left empty when
/// it has no room for every point (it is never grown here).
pub(crate) fn rasterize_blocked_recording<S: Source>(
    points: S,
    t: &Isometry3,
    band: Band,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
    wide: bool,
    cells: &mut Vec<u32>,
) -> u32 {
    cells.clear();
    if cells.capacity() < points.len() {
        return rasterize_blocked(points, t, band, grid, visibility, wide);
    }
    let Some(k) = Pass1::new(t, band, &grid.geometry, visibility.bin_params()) else {
        return rasterize_scalar_recording(points, t, band, grid, visibility, cells);
    };
    blocks_for::<S, true>(&k, band, points, grid, visibility, wide, cells)
}

/// [`blocks`] with the wider vector unit when `wide` and the processor has one, else on the baseline.
fn blocks_on<
    S: Source,
    const TRANSLATION_ONLY: bool,
    const EGO_MASK: bool,
    const RECORD: bool,
    const SUMS: bool,
    const TALL: bool,
>(
    k: &Pass1,
    points: S,
    grid: &mut OccupancyGrid,
    visibility: &mut VisibilityMap,
    wide: bool,
    cells: &mut Vec<u32>,
) -> u32 {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if wide {
        return wide::blocks::<S, TRANSLATION_ONLY, EGO_MASK, RECORD, SUMS, TALL>(k, points, grid, visibility, cells);
    }
    // Without run-time detection (`wide::available` is false) the flag has nothing to choose.
    let _ = wide;
    points.blocks::<TRANSLATION_ONLY, EGO_MASK, false, RECORD, SUMS, TALL>(k, grid, visibility, cells)
}

/// The block loop compiled for a wider vector unit, chosen at run time.
///
/// The only `unsafe` of the crate: calling a function compiled with `#[target_feature(enable = "avx2")]` (and four
/// integer bit-manipulation extensions, see [`available`]), which is sound exactly when the processor has them, and
/// that is checked first (`is_x86_feature_detected!`, which caches its answer). The loop is the same Rust code as the baseline one, inlined: with the same IEEE-754
/// operations in the same order (Rust does not contract `a * b + c` into a fused multiply-add, even where the
/// processor has one) each lane computes the same bits in 8-wide registers as in 4-wide ones.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[allow(unsafe_code)]
mod wide {
    use super::{OccupancyGrid, Pass1, Source, Vec, VisibilityMap};

    /// True when the processor has AVX2 and the bit-manipulation extensions the wide loop is compiled with
    /// (`bmi1`, `bmi2`, `lzcnt`, `popcnt`: every processor with AVX2 from Intel since Haswell and from AMD since
    /// Excavator has them; they shorten the scans of pass 2's 64-bit masks: `tzcnt`, `blsr`, `bzhi`, `lzcnt`,
    /// `popcnt` for sequences of 3 to 12 instructions; integer instructions only, so no floating-point bit changes).
    pub(super) fn available() -> bool {
        std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
            && std::arch::is_x86_feature_detected!("lzcnt")
            && std::arch::is_x86_feature_detected!("popcnt")
    }

    /// [`super::blocks`] with AVX2, or with the baseline when the processor lacks it.
    pub(super) fn blocks<
        S: Source,
        const TRANSLATION_ONLY: bool,
        const EGO_MASK: bool,
        const RECORD: bool,
        const SUMS: bool,
        const TALL: bool,
    >(
        k: &Pass1,
        points: S,
        grid: &mut OccupancyGrid,
        visibility: &mut VisibilityMap,
        cells: &mut Vec<u32>,
    ) -> u32 {
        if available() {
            // SAFETY: the processor has AVX2, BMI1, BMI2, LZCNT and POPCNT (checked on the line above), the one
            // requirement of a function compiled with `target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")`.
            unsafe {
                blocks_avx2::<S, TRANSLATION_ONLY, EGO_MASK, RECORD, SUMS, TALL>(k, points, grid, visibility, cells)
            }
        } else {
            points.blocks::<TRANSLATION_ONLY, EGO_MASK, false, RECORD, SUMS, TALL>(k, grid, visibility, cells)
        }
    }

    #[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
    fn blocks_avx2<
        S: Source,
        const TRANSLATION_ONLY: bool,
        const EGO_MASK: bool,
        const RECORD: bool,
        const SUMS: bool,
        const TALL: bool,
    >(
        k: &Pass1,
        points: S,
        grid: &mut OccupancyGrid,
        visibility: &mut VisibilityMap,
        cells: &mut Vec<u32>,
    ) -> u32 {
        // AVX2 implies SSE4.1's `roundps`: the cheaper floor of `floor_of`.
        points.blocks::<TRANSLATION_ONLY, EGO_MASK, true, RECORD, SUMS, TALL>(k, grid, visibility, cells)
    }
}

/// Without `std` or off x86-64 there is no run-time choice: the baseline loop (compile with
/// `-C target-feature=+avx2` or a `target-cpu` to widen it).
#[cfg(not(all(feature = "std", target_arch = "x86_64")))]
mod wide {
    /// Never: no run-time detection here.
    pub(super) fn available() -> bool {
        false
    }
}

/// Where pass 1 reads a sweep's points from: interleaved `[x, y, z]` records (`&[[f32; 3]]`) or three columns
/// ([`Columns`]). The two give the same blocks, so the same results.
pub(crate) trait Source: Copy + Send + Sync {
    /// The number of points.
    fn len(self) -> usize;

    /// The points in order (for the reference loop).
    fn iter(self) -> impl Iterator<Item = [f32; 3]>;

    /// The first `mid` points and the rest (`mid` at most [`Source::len`]).
    fn split_at(self, mid: usize) -> (Self, Self);

    /// The block loop of [`rasterize_blocked`] (inlined into each instruction set's version); with `RECORD`, each
    /// point's cell appended to `cells`, which the caller made room for.
    fn blocks<
        const TRANSLATION_ONLY: bool,
        const EGO_MASK: bool,
        const ROUND: bool,
        const RECORD: bool,
        const SUMS: bool,
        const TALL: bool,
    >(
        self,
        k: &Pass1,
        grid: &mut OccupancyGrid,
        visibility: &mut VisibilityMap,
        cells: &mut Vec<u32>,
    ) -> u32;
}

/// One block's points as pass 1 reads them: `[x, y, z]` records or three columns. [`Block::fill`] is the one body
/// for both; the accessor is inlined, so each layout's instantiation reads its points the way a loop written for it
/// would (the records' loop and the columns' loop vectorise as before: docs/performance.md, "The rasterize loop").
trait Lanes: Copy {
    /// The block's [`BLOCK`] points in order.
    fn points(self) -> impl Iterator<Item = [f32; 3]>;

    /// The block's point `j` (NaN beyond the block).
    fn point(self, j: usize) -> [f32; 3];
}

impl Lanes for &[[f32; 3]; BLOCK] {
    #[inline(always)]
    fn points(self) -> impl Iterator<Item = [f32; 3]> {
        // Each coordinate read on its own (`copied()`, a 12-byte copy per point, keeps the loop from vectorising:
        // 3x the instructions).
        self.iter().map(|&[x, y, z]| [x, y, z])
    }

    #[inline(always)]
    fn point(self, j: usize) -> [f32; 3] {
        self.get(j).copied().unwrap_or([f32::NAN; 3])
    }
}

impl Lanes for [&[f32; BLOCK]; 3] {
    #[inline(always)]
    fn points(self) -> impl Iterator<Item = [f32; 3]> {
        let [xs, ys, zs] = self;
        xs.iter().zip(ys).zip(zs).map(|((&x, &y), &z)| [x, y, z])
    }

    #[inline(always)]
    fn point(self, j: usize) -> [f32; 3] {
        let [xs, ys, zs] = self;
        [xs, ys, zs].map(|c| c.get(j).copied().unwrap_or(f32::NAN))
    }
}

impl Block {
    /// Pass 2 and the recorded cells of the block's first `len` points.
    #[inline(always)]
    fn finish<const RECORD: bool, const SUMS: bool, const TALL: bool>(
        &self,
        k: &Pass1,
        points: impl Lanes,
        grid: &mut OccupancyGrid,
        visibility: &mut VisibilityMap,
        cells: &mut Vec<u32>,
        len: usize,
    ) -> u32 {
        let in_band = self.apply::<SUMS, TALL>(k, points, grid, visibility);
        if RECORD {
            cells.extend_from_slice(self.cells.get(..len).unwrap_or(&[]));
        }
        in_band
    }
}

impl Source for &[[f32; 3]] {
    #[inline]
    fn len(self) -> usize {
        <[[f32; 3]]>::len(self)
    }

    #[inline]
    fn iter(self) -> impl Iterator<Item = [f32; 3]> {
        <[[f32; 3]]>::iter(self).copied()
    }

    #[inline]
    fn split_at(self, mid: usize) -> (Self, Self) {
        self.split_at_checked(mid).unwrap_or((self, &[]))
    }

    #[inline(always)]
    fn blocks<
        const TRANSLATION_ONLY: bool,
        const EGO_MASK: bool,
        const ROUND: bool,
        const RECORD: bool,
        const SUMS: bool,
        const TALL: bool,
    >(
        self,
        k: &Pass1,
        grid: &mut OccupancyGrid,
        visibility: &mut VisibilityMap,
        cells: &mut Vec<u32>,
    ) -> u32 {
        let mut block = Block::EMPTY;
        let mut in_band = 0u32;
        let (chunks, rest) = self.as_chunks::<BLOCK>();
        for chunk in chunks {
            block.fill::<TRANSLATION_ONLY, EGO_MASK, ROUND, SUMS, TALL>(k, chunk);
            in_band += block.finish::<RECORD, SUMS, TALL>(k, chunk, grid, visibility, cells, BLOCK);
        }
        if !rest.is_empty() {
            // NaN padding: the reference skips such points, and so do both passes (no bin, range or cell wins).
            let mut padded = [[f32::NAN; 3]; BLOCK];
            for (d, s) in padded.iter_mut().zip(rest) {
                *d = *s;
            }
            block.fill::<TRANSLATION_ONLY, EGO_MASK, ROUND, SUMS, TALL>(k, &padded);
            in_band += block.finish::<RECORD, SUMS, TALL>(k, &padded, grid, visibility, cells, rest.len());
        }
        in_band
    }
}

impl Source for PointColumns<'_> {
    #[inline]
    fn len(self) -> usize {
        PointColumns::len(&self)
    }

    #[inline]
    fn iter(self) -> impl Iterator<Item = [f32; 3]> {
        self.x().iter().zip(self.y()).zip(self.z()).map(|((&x, &y), &z)| [x, y, z])
    }

    #[inline]
    fn split_at(self, mid: usize) -> (Self, Self) {
        fn cut(c: &[f32], mid: usize) -> (&[f32], &[f32]) {
            c.split_at_checked(mid).unwrap_or((c, &[]))
        }
        let ((x0, x1), (y0, y1), (z0, z1)) = (cut(self.x(), mid), cut(self.y(), mid), cut(self.z(), mid));
        // Cut at the same index, the halves' columns keep equal lengths.
        match (PointColumns::new(x0, y0, z0), PointColumns::new(x1, y1, z1)) {
            (Ok(a), Ok(b)) => (a, b),
            _ => (self, PointColumns::EMPTY),
        }
    }

    #[inline(always)]
    fn blocks<
        const TRANSLATION_ONLY: bool,
        const EGO_MASK: bool,
        const ROUND: bool,
        const RECORD: bool,
        const SUMS: bool,
        const TALL: bool,
    >(
        self,
        k: &Pass1,
        grid: &mut OccupancyGrid,
        visibility: &mut VisibilityMap,
        cells: &mut Vec<u32>,
    ) -> u32 {
        let mut block = Block::EMPTY;
        let mut in_band = 0u32;
        // Columns of equal length (`PointColumns::new`): the same chunks and the same rest in each.
        let (xs, x_rest) = self.x().as_chunks::<BLOCK>();
        let (ys, y_rest) = self.y().as_chunks::<BLOCK>();
        let (zs, z_rest) = self.z().as_chunks::<BLOCK>();
        for ((x, y), z) in xs.iter().zip(ys).zip(zs) {
            block.fill::<TRANSLATION_ONLY, EGO_MASK, ROUND, SUMS, TALL>(k, [x, y, z]);
            in_band += block.finish::<RECORD, SUMS, TALL>(k, [x, y, z], grid, visibility, cells, BLOCK);
        }
        if !x_rest.is_empty() {
            let mut padded = [[f32::NAN; BLOCK]; 3];
            for (d, s) in padded.iter_mut().zip([x_rest, y_rest, z_rest]) {
                for (d, s) in d.iter_mut().zip(s) {
                    *d = *s;
                }
            }
            let [x, y, z] = &padded;
            block.fill::<TRANSLATION_ONLY, EGO_MASK, ROUND, SUMS, TALL>(k, [x, y, z]);
            in_band += block.finish::<RECORD, SUMS, TALL>(k, [x, y, z], grid, visibility, cells, x_rest.len());
        }
        in_band
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)]
mod tests {
    use alloc::vec;
    use alloc::vec::Vec;

    use super::*;
    use crate::geometry::diamond_angle;

    /// A tiny xorshift generator (the crate has no RNG dependency).
    struct Xorshift(u64);

    impl Xorshift {
        fn next_u32(&mut self) -> u32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 32) as u32
        }

        fn unit(&mut self) -> f32 {
            (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
        }

        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.unit()
        }
    }

    /// Runs both loops on fresh grids and maps; asserts bit-identical results; returns the points in band. Three
    /// times: on grids without and with the sums and tall bits of the params keys `jump_from_returns` and
    /// `roi_graze_fraction` (the loops' `SUMS` and `TALL` instantiation), and with each cell's first return instead
    /// of the sums (`jump_first_return`: the loop without `SUMS`) and the tall bits, checked against their
    /// definitions.
    fn assert_same(points: &[[f32; 3]], t: &Isometry3, band: Band, cells: u32, cell_m: f32, bins: u32) -> u32 {
        // Tall: 0.5 m above the band (the params refuse a threshold below its top).
        let n = assert_same_with(points, t, band, cells, cell_m, bins, None);
        for first in [false, true] {
            assert_eq!(n, assert_same_with(points, t, band, cells, cell_m, bins, Some((band.hi_m + 0.5, first))));
        }
        n
    }

    fn assert_same_with(
        points: &[[f32; 3]],
        t: &Isometry3,
        band: Band,
        cells: u32,
        cell_m: f32,
        bins: u32,
        extra: Option<(f32, bool)>,
    ) -> u32 {
        let geometry = GridGeometry::new(cells, cell_m);
        // 0: the reference, 1: the blocked loop on the baseline, 2: with the widest vector unit available.
        // Modes 3, 4, 5: the same three, recording each point's cell. Modes 6 to 11: modes 0 to 5 with the points
        // given as columns.
        let [x, y, z]: [Vec<f32>; 3] = core::array::from_fn(|k| points.iter().map(|p| p[k]).collect());
        let columns = PointColumns::new(&x, &y, &z).unwrap();
        let run = |mode: u8| {
            let mut grid = OccupancyGrid::new(geometry, 0.7, points.len()).with_returns();
            match extra {
                Some((top, false)) => grid = grid.with_sums().with_tall(top),
                Some((top, true)) => grid = grid.with_first_returns().with_tall(top),
                None => {}
            }
            let mut vis = VisibilityMap::new(bins);
            vis.reset([t.translation_m[0], t.translation_m[1]]);
            let mut cells = Vec::with_capacity(points.len());
            let (g, v, c) = (&mut grid, &mut vis, &mut cells);
            let n = match mode {
                0 => rasterize_scalar(points, t, band, g, v),
                1 | 2 => rasterize_blocked(points, t, band, g, v, mode == 2),
                3 => rasterize_scalar_recording(points, t, band, g, v, c),
                4 | 5 => rasterize_blocked_recording(points, t, band, g, v, mode == 5, c),
                6 => rasterize_scalar(columns, t, band, g, v),
                7 | 8 => rasterize_blocked(columns, t, band, g, v, mode == 8),
                9 => rasterize_scalar_recording(columns, t, band, g, v, c),
                m => rasterize_blocked_recording(columns, t, band, g, v, m == 11, c),
            };
            let touched = grid.touched().to_vec();
            let hits: Vec<u16> = touched.iter().map(|&c| grid.hits(c)).collect();
            let (near, near_cell, far) = vis.arrays();
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
            let returns: Vec<[u32; 3]> =
                touched.iter().map(|&c| grid.returns(c).map_or([0; 3], |r| r.map(f32::to_bits))).collect();
            let sums: Vec<Option<[u32; 3]>> =
                touched.iter().map(|&c| grid.sums(c).map(|r| r.map(f32::to_bits))).collect();
            let tall: Vec<u32> = (0..geometry.cell_count() as u32).filter(|&c| grid.tall(c)).collect();
            // The grid comes back clear: no tall bit survives the reset.
            grid.reset();
            assert!((0..geometry.cell_count() as u32).all(|c| !grid.tall(c)), "tall bits after the reset");
            ((n, touched, hits, bits(&near), near_cell, bits(&far), returns, sums, tall), cells)
        };
        let (scalar, _) = run(0);
        // Each hit cell's returns, by their definition: the smallest squared range from the sensor's ground point
        // and the lowest and highest z of the obstacle returns in the cell.
        for (&c, r) in scalar.1.iter().zip(&scalar.6) {
            let mut want = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY];
            for p in points {
                let q = t.transform(*p);
                let obstacle = q[2] >= band.lo_m && q[2] <= band.hi_m && !band.in_ego(q[0], q[1]);
                if obstacle && geometry.point_to_cell(q[0], q[1]) == Some(c) {
                    let (dx, dy) = (q[0] - t.translation_m[0], q[1] - t.translation_m[1]);
                    want = [want[0].min(dx * dx + dy * dy), want[1].min(q[2]), want[2].max(q[2])];
                }
            }
            assert_eq!(*r, want.map(f32::to_bits), "returns of cell {c}");
        }
        // The sums and tall bits, by their definitions: each hit cell's obstacle returns' x and y added in point
        // order from zero, and their number (with first returns: only the first return in point order, added to
        // zero, and the count 1); the cells of the returns above the threshold, any return.
        let mut want_tall = Vec::new();
        let first_only = extra.is_some_and(|(_, first)| first);
        for (&c, sums) in scalar.1.iter().zip(&scalar.7) {
            let mut want = [0.0f32; 3];
            for p in points {
                let q = t.transform(*p);
                let obstacle = q[2] >= band.lo_m && q[2] <= band.hi_m && !band.in_ego(q[0], q[1]);
                if obstacle && geometry.point_to_cell(q[0], q[1]) == Some(c) && !(first_only && want[2] > 0.0) {
                    want = [want[0] + q[0], want[1] + q[1], want[2] + 1.0];
                }
            }
            assert!(want[2] >= 1.0, "a hit cell has a return");
            assert_eq!(*sums, extra.map(|_| want.map(f32::to_bits)), "sums of cell {c}");
        }
        if let Some((top, _)) = extra {
            for p in points {
                let q = t.transform(*p);
                if let Some(c) = geometry.point_to_cell(q[0], q[1]).filter(|_| q[2] > top) {
                    want_tall.push(c);
                }
            }
            want_tall.sort_unstable();
            want_tall.dedup();
        }
        assert_eq!(scalar.8, want_tall, "tall cells");
        // The recorded cells: one per point, the reference's definition (an obstacle-band return in the grid,
        // outside the ego footprint), the same for the three loops; recording changes nothing else.
        let expected: Vec<u32> = points
            .iter()
            .map(|p| {
                let q = t.transform(*p);
                let obstacle = q[2] >= band.lo_m && q[2] <= band.hi_m && !band.in_ego(q[0], q[1]);
                obstacle.then(|| geometry.point_to_cell(q[0], q[1])).flatten().unwrap_or(NO_CELL)
            })
            .collect();
        let mut outputs = vec![run(1).0, run(2).0, run(6).0, run(7).0, run(8).0];
        for mode in [3, 4, 5, 9, 10, 11] {
            let (out, cells) = run(mode);
            assert_eq!(cells, expected, "recorded cells, mode {mode}");
            outputs.push(out);
        }
        for blocked in outputs {
            assert_eq!(scalar.0, blocked.0, "points in band");
            assert_eq!(scalar.1, blocked.1, "touched cells in order");
            assert_eq!(scalar.2, blocked.2, "hits");
            assert_eq!(scalar.3, blocked.3, "nearest obstacle r2 bits");
            assert_eq!(scalar.4, blocked.4, "nearest obstacle cells");
            assert_eq!(scalar.5, blocked.5, "farthest return r2 bits");
            assert_eq!(scalar.6, blocked.6, "each hit cell's nearest r2, lowest and highest z");
            assert_eq!(scalar.7, blocked.7, "each hit cell's sums of x and y and count");
            assert_eq!(scalar.8, blocked.8, "tall cells");
        }
        scalar.0
    }

    const BAND: Band = Band { lo_m: 0.3, hi_m: 2.5, ego_m: Band::NO_EGO };

    #[test]
    fn blocked_equals_scalar_on_special_points() {
        let t = Isometry3::from_translation(0.0, 0.0, 1.8);
        let specials =
            [0.0, -0.0, 0.5, -0.5, 1e-30, -1e-30, 3e38, -3e38, f32::MAX, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        let mut points = Vec::new();
        for &a in &specials {
            for &b in &specials {
                for z in [-1.8, -1.5, 0.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30] {
                    points.push([a, b, z]);
                    points.push([b, 10.0, z]);
                    points.push([-7.25, a, z]);
                }
            }
        }
        // Cell borders of a 0.5 m grid of 200 cells (-50 m .. 50 m), including both outer edges, just inside and
        // just outside, at the exact band limits (z = 0.3 and 2.5 in the ego frame, sensor 1.8 m up).
        for k in -2..=202 {
            let v = -50.0 + 0.5 * k as f32;
            for w in [v, v.next_up(), v.next_down()] {
                for z in [0.3 - 1.8, 2.5 - 1.8, (0.3f32 - 1.8).next_down(), (2.5f32 - 1.8).next_up(), -1.0] {
                    points.push([w, 3.25, z]);
                    points.push([-11.0, w, z]);
                    points.push([w, w, z]);
                }
            }
        }
        // The sensor's own position (dx = dy = 0) and the axes (quadrant edges of the diamond angle).
        for r in [0.0, 1.0, 5.0, 49.9] {
            for (x, y) in [(r, 0.0), (-r, 0.0), (0.0, r), (0.0, -r), (r, -0.0), (-0.0, -r)] {
                points.push([x, y, -1.0]);
                points.push([x, y, 0.0]);
            }
        }
        let in_band = assert_same(&points, &t, BAND, 200, 0.5, 720);
        assert!(in_band > 100, "the cases reach the grid: {in_band}");
        // The translation-only fast path: a sensor off the ego origin, and an identity written with negative zeros
        // and zero translations of either sign (zeros of either sign in x and y above).
        for t in [
            Isometry3::from_translation(1.25, -0.75, 1.8),
            Isometry3 {
                rotation: [[1.0, -0.0, 0.0], [-0.0, 1.0, -0.0], [0.0, -0.0, 1.0]],
                translation_m: [-0.0, 0.0, 1.8],
            },
        ] {
            assert!(Pass1::new(&t, BAND, &GridGeometry::new(200, 0.5), VisibilityMap::new(720).bin_params())
                .is_some_and(|k| k.translation_only()));
            assert_same(&points, &t, BAND, 200, 0.5, 720);
        }
        // The same points through rotated extrinsics, and bins that put the last bin at the limit.
        for (yaw, bins) in [(0.3, 8), (-2.0, 65_536), (core::f32::consts::PI, 720)] {
            let t = Isometry3::from_yaw_translation(yaw, [0.7, -0.4, 1.8]);
            assert_same(&points, &t, BAND, 200, 0.5, bins);
        }
    }

    #[test]
    fn blocked_equals_scalar_for_every_remainder() {
        let mut rng = Xorshift(0x9e37_79b9_7f4a_7c15);
        let t = Isometry3::from_yaw_translation(0.1, [0.5, 0.2, 1.8]);
        for len in 0..=200 {
            let points: Vec<[f32; 3]> =
                (0..len).map(|_| [rng.range(-60.0, 60.0), rng.range(-60.0, 60.0), rng.range(-2.5, 1.5)]).collect();
            assert_same(&points, &t, BAND, 200, 0.5, 720);
        }
    }

    #[test]
    fn blocked_equals_scalar_on_random_clouds_grids_and_extrinsics() {
        let mut rng = Xorshift(42);
        for case in 0..60 {
            let cells = [1, 2, 7, 200, 333, 1000][case % 6];
            let cell_m = [0.1, 0.2, 0.5, 0.37, 1.0, 3.0][(case / 6) % 6];
            let bins = [8, 9, 720, 1000, 4096, 65_536][(case / 3) % 6];
            let (yaw, roll) = (rng.range(-4.0, 4.0), rng.range(-0.2, 0.2));
            let (s, c) = (libm::sinf(yaw), libm::cosf(yaw));
            let (sr, cr) = (libm::sinf(roll), libm::cosf(roll));
            // A yaw and a roll: every entry of the rotation is used.
            let t = Isometry3 {
                rotation: [[c, -s * cr, s * sr], [s, c * cr, -c * sr], [0.0, sr, cr]],
                translation_m: [rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(0.0, 3.0)],
            };
            let half = 0.6 * cells as f32 * cell_m;
            let points: Vec<[f32; 3]> = (0..1000)
                .map(|i| {
                    let mut p = [rng.range(-half, half), rng.range(-half, half), rng.range(-3.0, 2.0)];
                    if i % 97 == 0 {
                        p[i % 3] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][i % 3];
                    }
                    if i % 13 == 0 {
                        // On a cell border.
                        p[0] = -0.5 * cells as f32 * cell_m + cell_m * (i % 50) as f32 - t.translation_m[0];
                    }
                    p
                })
                .collect();
            let band = Band {
                lo_m: rng.range(-0.5, 0.5),
                hi_m: rng.range(0.6, 3.0),
                ego_m: [rng.range(-3.0, -0.5), rng.range(-2.0, -0.5), rng.range(0.5, 3.0), rng.range(0.5, 2.0)],
            };
            assert_same(&points, &t, band, cells, cell_m, bins);
        }
    }

    /// The grid's sums (`jump_from_returns`) take one of two paths per block of 64 points: every point at once where
    /// most are obstacle returns in the grid (those outside added to a spare entry nobody reads), one bit at a
    /// time elsewhere. Clouds with blocks of each kind, short and long runs of one cell, and points outside the
    /// grid, below or above the band and not finite among them: the same sums as the reference's additions.
    #[test]
    fn blocked_equals_scalar_where_most_points_are_in_the_grid() {
        let mut rng = Xorshift(7);
        let t = Isometry3::from_yaw_translation(0.3, [1.0, -0.5, 1.8]);
        for case in 0..12 {
            // Out of every 64 points, `outside` are not obstacle returns in the grid: 0 to 40, so that blocks with
            // 24 to 64 points in the grid come on both sides of the dense path's threshold.
            let outside = [0, 1, 3, 6, 12, 19, 20, 21, 25, 32, 40, 2][case];
            let run = 1 + case % 5;
            let mut points = Vec::new();
            let mut p = [0.0f32; 3];
            for i in 0..(64 * 9 + case * 5) {
                if i % run == 0 {
                    p = [rng.range(-40.0, 40.0), rng.range(-40.0, 40.0), rng.range(-1.0, 0.5)];
                }
                let mut q = [p[0] + rng.range(-0.05, 0.05), p[1] + rng.range(-0.05, 0.05), p[2]];
                if (i * 37) % 64 < outside {
                    match i % 5 {
                        0 => q[0] = 80.0,
                        1 => q[2] = -3.0,
                        2 => q[2] = 5.0,
                        3 => q[1] = f32::NAN,
                        _ => q[0] = f32::INFINITY,
                    }
                }
                points.push(q);
            }
            assert_same(&points, &t, BAND, 200, 0.5, 720);
        }
    }

    #[test]
    fn falls_back_to_the_reference_for_a_modified_geometry() {
        // A geometry whose private inverse cell size no longer matches: pass 1 cannot reproduce it.
        let grid = || {
            let mut g = OccupancyGrid::new(GridGeometry::new(10, 1.0), 0.7, 16);
            g.geometry.cell_size_m = 2.0;
            g
        };
        let (mut grid_blocked, mut grid_scalar) = (grid(), grid());
        let (mut vis_blocked, mut vis_scalar) = (VisibilityMap::new(8), VisibilityMap::new(8));
        let t = Isometry3::IDENTITY;
        assert!(Pass1::new(&t, BAND, &grid_blocked.geometry, vis_blocked.bin_params()).is_none());
        let points = [[1.0, 1.0, 1.0], [-3.0, 2.0, 1.0], [4.5, -4.5, 1.0]];
        let a = rasterize_blocked(points.as_slice(), &t, BAND, &mut grid_blocked, &mut vis_blocked, true);
        let b = rasterize_scalar(points.as_slice(), &t, BAND, &mut grid_scalar, &mut vis_scalar);
        assert_eq!((a, grid_blocked.touched()), (b, grid_scalar.touched()));
        assert_eq!(grid_scalar.touched(), [66, 72, 9]);
        assert_eq!(vis_blocked.arrays(), vis_scalar.arrays());
    }

    #[test]
    fn floor_small_is_truncation_below_two_to_the_23() {
        let mut values = vec![0.0f32, -0.0, 0.5, 0.499_999_97, 1.0, 1.5, 2.5, 4_095.999_8, 8_388_607.0, 8_388_607.5];
        for k in 0..5000u32 {
            let v = k as f32 * 0.25;
            values.extend([v, v.next_up(), v.next_down().max(0.0)]);
        }
        let mut rng = Xorshift(7);
        for _ in 0..100_000 {
            values.push(rng.unit() * [1.0, 200.0, 4096.0, 65_536.0, 8_388_607.0][rng.next_u32() as usize % 5]);
        }
        for v in values {
            assert_eq!(floor_small(v), v as u32, "{v:e}");
            assert_eq!(floor_of::<true>(v), v as u32, "{v:e}");
            assert_eq!(floor_of::<false>(v), v as u32, "{v:e}");
        }
    }

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
        let mut draws = crate::test_support::xorshift_draws(0x2545_f491_4f6c_dd1d);
        let mut next = || f32::from_bits((draws() >> 32) as u32);
        for _ in 0..200_000 {
            let (dx, dy) = (next(), next());
            let (a, b) = (diamond_angle(dx, dy), diamond_angle_select(dx, dy));
            assert!(a == b || (a.is_nan() && b.is_nan()), "diamond_angle({dx:e}, {dy:e}) = {a}, select {b}");
        }
    }
}
