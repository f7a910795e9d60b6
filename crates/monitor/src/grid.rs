//! Grid geometry and the occupancy grid.
//!
//! Cells and metres are kept apart: `GridGeometry` converts; cell indices are `u32` row-major
//! (`iy * cells_per_side + ix`), `ix` along ego x. The grid is centred on the ego origin.
//!
//! Each cell holds the number of obstacle hits of this frame. Its occupancy probability follows the classic
//! log-odds inverse sensor model (Thrun, Burgard, Fox, *Probabilistic Robotics*, ch. 9): starting from the prior
//! 0.5 (log-odds 0), every hit adds `l_hit = ln(p_hit / (1 - p_hit))`, so `P(n) = 1 - 1 / (1 + exp(n l_hit))`.
//! A cell without a hit is **unknown** (`P = 0.5`), a state of its own, not "free": the hit-only grid cannot
//! see free space (see [`crate::visibility`] for that).
//!
//! Only cells touched this frame are reset at the start of the next frame: the per-frame cost grows with the
//! number of points, not with the grid's area.

use alloc::vec;
use alloc::vec::Vec;

use crate::geometry::OrientedRect;

/// Hits beyond this are not counted further (the probability has long saturated).
pub const MAX_HITS: u16 = 255;
// `OccupancyGrid::add_run` saturates a byte's addition: at `MAX_HITS` only when it is the byte's maximum.
const _: () = assert!(MAX_HITS == u8::MAX as u16);

/// For a block of 64 cells (`NO_CELL` or any index at or above `cell_count`: outside the grid): bit j of the first
/// mask is set when cell j ends a run of equal cells (cell j + 1 differs, or j is 63), bit j of the second when cell
/// j is in the grid. Written as two halves of 32 bits, each bit a comparison of 32-bit lanes: so the compiler
/// builds each half from vector compares (8 lanes per AVX2 instruction) and a few `or`s, where one 64-bit
/// accumulator made it widen every lane to 64 bits (212 instructions per block in the AVX2 loop against about 110).
#[inline(always)]
fn run_masks(cells: &[u32; 64], cell_count: usize) -> (u64, u64) {
    // Cells are u32; a count beyond `u32::MAX` (never for a grid of validated params: at most 4,096^2 cells) holds
    // every cell, see the end.
    let count = u32::try_from(cell_count).unwrap_or(u32::MAX);
    // Each cell's successor; the last one's is a value unequal to it, so the block's last cell ends a run.
    let mut next = [0u32; 64];
    for (d, &s) in next.iter_mut().zip(cells.iter().skip(1)) {
        *d = s;
    }
    let [.., last] = *cells;
    let [.., next_last] = &mut next;
    *next_last = !last;
    let half = |c: &[u32], n: &[u32]| -> (u64, u64) {
        let (mut e, mut g) = (0u32, 0u32);
        for (j, (&c, &n)) in c.iter().zip(n).enumerate().take(32) {
            e |= u32::from(c != n) << j;
            g |= u32::from(c < count) << j;
        }
        (u64::from(e), u64::from(g))
    };
    let (lo, hi) = cells.split_at(32);
    let (next_lo, next_hi) = next.split_at(32);
    let (e0, g0) = half(lo, next_lo);
    let (e1, g1) = half(hi, next_hi);
    // All ones when the count exceeds every u32 (a compare and a negation, no branch per block).
    let all = u64::from(u32::try_from(cell_count).is_err()).wrapping_neg();
    (e0 | e1 << 32, g0 | g1 << 32 | all)
}

/// Bit j set when `test(cells[j])`, built as [`run_masks`] builds its masks: two halves of 32 bits, each bit a
/// comparison of 32-bit lanes (vector compares and a few `or`s once the test is inlined).
#[inline(always)]
fn bits_where(cells: &[u32; 64], test: impl Fn(u32) -> bool) -> u64 {
    let half = |c: &[u32]| -> u64 {
        let mut g = 0u32;
        for (j, &c) in c.iter().enumerate().take(32) {
            g |= u32::from(test(c)) << j;
        }
        u64::from(g)
    };
    let (lo, hi) = cells.split_at(32);
    half(lo) | half(hi) << 32
}

/// Bit j set when `cells[j] < bound`: [`run_masks`]' second mask for any bound.
#[inline(always)]
pub(crate) fn bits_below(cells: &[u32; 64], bound: u32) -> u64 {
    bits_where(cells, |c| c < bound)
}

/// Bit j set when `cells[j] == cell` (the first points of new cells before round branches; the tests' reference).
#[cfg(test)]
fn bits_equal(cells: &[u32; 64], cell: u32) -> u64 {
    bits_where(cells, |c| c == cell)
}

/// Cell flag: the cell intersects at least one object region `A_o`.
pub const FLAG_EXPLAINED: u8 = 1;
/// Cell flag: visited by the conflict clustering.
pub const FLAG_VISITED: u8 = 2;
/// Cell flag: part of a reported conflict cluster in the region of interest (not scenery).
pub const FLAG_ROI_CONFLICT: u8 = 4;
/// Cell flag: inside known static scenery; its evidence is explained by the map and confirms no object.
pub const FLAG_STATIC: u8 = 8;
/// Cell flag: part of a conflict cluster attributed to an object (that object's evidence, displaced).
pub const FLAG_ATTRIBUTED: u8 = 16;
/// Cell flag: a conflict cell whose square straddles the edge of the region of interest (its centre within half
/// a cell diagonal of a polygon's edge): whether its returns lie inside is decided return by return.
pub const FLAG_ROI_EDGE: u8 = 32;
/// Cell flag: a [`FLAG_ROI_EDGE`] cell holding an obstacle-band return inside the region of interest.
pub const FLAG_RETURN_IN_ROI: u8 = 64;

/// The 64-bit words of the hit bit set that hold the cells `first..=last` (`first <= last`), each with the mask of
/// the bits of those cells.
#[inline]
fn run_words(first: u32, last: u32) -> impl Iterator<Item = (u32, u64)> {
    (first / 64..=last / 64).map(move |word| {
        let base = word * 64;
        let mut mask = u64::MAX;
        if first > base {
            mask &= u64::MAX << (first - base);
        }
        if last < base + 63 {
            mask &= u64::MAX >> (base + 63 - last);
        }
        (word, mask)
    })
}

/// The state of one cell, for display and inspection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellState {
    /// No evidence this frame.
    Unknown,
    /// Some hits, occupancy probability at or below the threshold.
    Weak,
    /// Occupied (`P > tau_fn`) and inside some object region.
    Occupied,
    /// Occupied and inside no object region: a conflict (`kappa > tau_fn`).
    Conflict,
}

/// Geometry of the square, ego-centred grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridGeometry {
    /// Cells along one side.
    pub cells_per_side: u32,
    /// Cell side, metres.
    pub cell_size_m: f32,
    /// Ego-frame coordinate of the grid's lower-left corner (both axes), metres.
    pub origin_m: f32,
    inv_cell: f32,
}

impl GridGeometry {
    /// A grid of `cells_per_side` cells of `cell_size_m`, centred on the ego origin.
    #[must_use]
    pub fn new(cells_per_side: u32, cell_size_m: f32) -> Self {
        let origin_m = -(cells_per_side as f32) * cell_size_m * 0.5;
        Self { cells_per_side, cell_size_m, origin_m, inv_cell: 1.0 / cell_size_m }
    }

    /// Side length, metres.
    #[must_use]
    pub fn size_m(&self) -> f32 {
        self.cells_per_side as f32 * self.cell_size_m
    }

    /// Total number of cells.
    #[must_use]
    pub fn cell_count(&self) -> usize {
        self.cells_per_side as usize * self.cells_per_side as usize
    }

    /// Column or row of an ego-frame coordinate, or `None` outside the grid (or not finite).
    #[must_use]
    #[inline]
    pub fn axis_to_cell(&self, v_m: f32) -> Option<u32> {
        let f = (v_m - self.origin_m) * self.inv_cell;
        // NaN fails both comparisons.
        if f >= 0.0 && f < self.cells_per_side as f32 {
            Some(f as u32)
        } else {
            None
        }
    }

    /// Cell index of an ego-frame point, or `None` outside the grid.
    #[must_use]
    #[inline]
    pub fn point_to_cell(&self, x_m: f32, y_m: f32) -> Option<u32> {
        let ix = self.axis_to_cell(x_m)?;
        let iy = self.axis_to_cell(y_m)?;
        Some(iy * self.cells_per_side + ix)
    }

    /// Centre of column/row `i`, ego frame, metres.
    #[must_use]
    #[inline]
    pub fn cell_center_axis(&self, i: u32) -> f32 {
        self.origin_m + (i as f32 + 0.5) * self.cell_size_m
    }

    /// A cell and its 8 neighbours inside the grid, row by row (at most 9 cells): [`GridGeometry::block`] of radius 1.
    pub fn block3x3(self, index: u32) -> impl Iterator<Item = u32> {
        self.block(index, 1)
    }

    /// The cells within `radius` cells of a cell along each grid axis, inside the grid, row by row (at most
    /// `(2 radius + 1)^2` cells).
    pub fn block(self, index: u32, radius: u32) -> impl Iterator<Item = u32> {
        let n = self.cells_per_side.max(1);
        let (cx, cy) = (index % n, index / n);
        (cy.saturating_sub(radius)..=(cy + radius).min(n - 1))
            .flat_map(move |y| (cx.saturating_sub(radius)..=(cx + radius).min(n - 1)).map(move |x| y * n + x))
    }

    /// The 4-neighbours of a cell inside the grid (left, right, below, above; at most 4 cells). A neighbour
    /// across the grid's edge does not exist: `index +- 1` would wrap to the other end of the neighbouring row.
    pub fn neighbours4(self, index: u32) -> impl Iterator<Item = u32> {
        let n = self.cells_per_side.max(1);
        let (cx, cy) = (index % n, index / n);
        let inside = index < n.saturating_mul(n);
        [
            (cx > 0).then(|| index - 1),
            (cx + 1 < n).then(|| index + 1),
            (cy > 0).then(|| index - n),
            (cy + 1 < n).then(|| index + n),
        ]
        .into_iter()
        .flatten()
        .filter(move |_| inside)
    }

    /// Centre of a cell, ego frame, metres.
    #[must_use]
    pub fn cell_center(&self, index: u32) -> (f32, f32) {
        let n = self.cells_per_side.max(1);
        (self.cell_center_axis(index % n), self.cell_center_axis(index / n))
    }

    /// True when the axis-aligned box `[min_x, min_y, max_x, max_y]` lies entirely inside the grid.
    #[must_use]
    pub fn contains_box(&self, b: [f32; 4]) -> bool {
        let hi = self.origin_m + self.size_m();
        b[0] >= self.origin_m && b[1] >= self.origin_m && b[2] < hi && b[3] < hi
    }

    /// Inclusive cell range covering the part of a box that lies inside the grid, `None` if none does.
    #[must_use]
    pub fn cell_range_clipped(&self, b: [f32; 4]) -> Option<(u32, u32, u32, u32)> {
        let hi = self.origin_m + self.size_m();
        if !(b[0] < hi && b[1] < hi && b[2] >= self.origin_m && b[3] >= self.origin_m) {
            return None;
        }
        let clamp = |v: f32| v.clamp(self.origin_m, hi - 0.5 * self.cell_size_m);
        self.cell_range([clamp(b[0]), clamp(b[1]), clamp(b[2]), clamp(b[3])])
    }

    /// Calls `f(index, centre_x, centre_y)` for each cell of an inclusive cell range that overlaps a rectangle
    /// with positive area ([`OrientedRect::overlaps_square`]), row by row, in increasing index order. Bounded by
    /// the range (at most the whole grid). (A closure rather than an iterator: a `flat_map` iterator here cost
    /// the regions stage 45 % in `pmon bench`.)
    ///
    /// The same cells as testing every cell of the range (the tests compare the two), with
    /// a few tests per row instead of one per cell: in a row, the cells that pass form one run. (Each of the
    /// test's conditions compares the absolute value of a quantity computed from the cell centre `x` by
    /// operations that are monotonic in `x` in floating point too (a subtraction, a multiplication by a constant,
    /// an addition of a constant), and centres grow with the column; so each condition holds on a run of
    /// columns, and so does their conjunction.) The run is found from [`OrientedRect::row_bounds`], widened by
    /// two cells, by testing inwards from both ends until a cell passes.
    #[inline]
    pub fn for_each_cell_overlapping(
        self,
        rect: &OrientedRect,
        range: (u32, u32, u32, u32),
        mut f: impl FnMut(u32, f32, f32),
    ) {
        self.for_each_row_run(rect, range, |iy, a, b, cy| {
            for ix in a..=b {
                f(iy * self.cells_per_side + ix, self.cell_center_axis(ix), cy);
            }
        });
    }

    /// The runs of [`GridGeometry::for_each_cell_overlapping`]: `f(row, first column, last column, row centre)`
    /// for each row of the range with at least one overlapping cell, in increasing row order.
    #[inline]
    pub fn for_each_row_run(
        self,
        rect: &OrientedRect,
        range: (u32, u32, u32, u32),
        mut f: impl FnMut(u32, u32, u32, f32),
    ) {
        let (ix0, iy0, ix1, iy1) = range;
        for iy in iy0..=iy1 {
            if let Some((a, b, cy)) = self.row_run(rect, ix0, ix1, iy) {
                f(iy, a, b, cy);
            }
        }
    }

    /// The cells of [`GridGeometry::for_each_cell_overlapping`] in every `step`-th row and column of the range
    /// (counted from its first row and column: `(ix - ix0)` and `(iy - iy0)` multiples of `step`), in the same
    /// order: the same cells as filtering that walk by row and column, without walking the cells left out.
    #[inline]
    pub fn for_each_cell_overlapping_every(
        self,
        rect: &OrientedRect,
        range: (u32, u32, u32, u32),
        step: u32,
        mut f: impl FnMut(u32, f32, f32),
    ) {
        let step = step.max(1);
        self.for_each_sampled_run(rect, range, step, |iy, first, last, cy| {
            let mut ix = first;
            while ix <= last {
                f(iy * self.cells_per_side + ix, self.cell_center_axis(ix), cy);
                let Some(next) = ix.checked_add(step) else { break };
                ix = next;
            }
        });
    }

    /// The rows of [`GridGeometry::for_each_cell_overlapping_every`]: for every `step`-th row of the range with a
    /// sampled cell that overlaps `rect`, `f(iy, first, last, cy)` with the row's first and last sampled
    /// overlapping columns and the row centre `cy`; the row's cells are the columns `first, first + step, ...,
    /// last`. In the walk's order. `step` at least 1. (Rows whose run holds no sampled column are left out: they
    /// hold no cell of the walk.)
    #[inline(always)]
    pub fn for_each_sampled_run(
        self,
        rect: &OrientedRect,
        range: (u32, u32, u32, u32),
        step: u32,
        mut f: impl FnMut(u32, u32, u32, f32),
    ) {
        let (ix0, iy0, ix1, iy1) = range;
        let step = step.max(1);
        let mut iy = iy0;
        while iy <= iy1 {
            if let Some((first, last, cy)) = self.sampled_row_run(rect, ix0, ix1, iy, step) {
                f(iy, first, last, cy);
            }
            let Some(next) = iy.checked_add(step) else { break };
            iy = next;
        }
    }

    /// The run of row `iy` (first column, last column, row centre) within columns `ix0..=ix1`, `None` when no cell
    /// of the row overlaps: the body of [`GridGeometry::for_each_row_run`] (and of the sampled walk). Inlined
    /// always: as a call per row it cost the regions stage about 47 k instructions per AV2 check.
    #[inline(always)]
    fn row_run(self, rect: &OrientedRect, ix0: u32, ix1: u32, iy: u32) -> Option<(u32, u32, f32)> {
        let half = 0.5 * self.cell_size_m;
        let cy = self.cell_center_axis(iy);
        if ix0 > ix1 || !rect.row_may_overlap(cy, half) {
            return None;
        }
        let (mut a, mut b) = (ix0, ix1);
        if let Some((lo, hi)) = rect.row_bounds(cy, half) {
            // Columns whose centre lies within two cells of the bounds; `as` saturates (and NaN cannot occur:
            // the bounds are finite).
            let column = |x: f32| (x - self.origin_m) * self.inv_cell - 0.5;
            a = a.max((column(lo) - 2.0).max(0.0) as u32);
            b = b.min((column(hi) + 2.0).max(0.0) as u32);
        }
        let overlaps = |ix: u32| rect.overlaps_square(self.cell_center_axis(ix), cy, half);
        while a <= b && !overlaps(a) {
            a += 1;
        }
        if a > b {
            return None;
        }
        while b > a && !overlaps(b) {
            b -= 1;
        }
        Some((a, b, cy))
    }

    /// The first and last sampled columns (`ix0 + k step`) of row `iy`'s run within `ix0..=ix1` and the row centre;
    /// `None` when no sampled column of the row overlaps. The columns [`GridGeometry::row_run`] would give,
    /// filtered to the sampled ones, but found by testing only sampled columns: the search starts from the same
    /// widened bounds as `row_run`'s (which contain the run; the whole range when it is narrow) and steps by `step` inwards from both ends; the
    /// overlapping columns within the bounds form one run (see [`GridGeometry::for_each_cell_overlapping`]), so
    /// the first sampled column that overlaps from the left and the last from the right bound its sampled
    /// columns, all of which overlap. With `step` 1, `row_run` itself.
    #[inline(always)]
    fn sampled_row_run(self, rect: &OrientedRect, ix0: u32, ix1: u32, iy: u32, step: u32) -> Option<(u32, u32, f32)> {
        let half = 0.5 * self.cell_size_m;
        let cy = self.cell_center_axis(iy);
        if ix0 > ix1 || !rect.row_may_overlap(cy, half) {
            return None;
        }
        let (mut a, mut b) = (ix0, ix1);
        // As in `row_run`, for ranges of more than 5 columns: on narrower ones (the ghost test's pedestrians), bounds
        // widened by two cells on each side seldom leave out a column, and cost two divisions.
        if ix1 - ix0 >= 5 {
            if let Some((lo, hi)) = rect.row_bounds(cy, half) {
                let column = |x: f32| (x - self.origin_m) * self.inv_cell - 0.5;
                a = a.max((column(lo) - 2.0).max(0.0) as u32);
                b = b.min((column(hi) + 2.0).max(0.0) as u32);
            }
        }
        if a > b {
            return None;
        }
        let step = step.max(1);
        // The sampled columns at or after `a` and at or before `b` (`a, b >= ix0`).
        let mut first = ix0 + (a - ix0).div_ceil(step) * step;
        let mut last = ix0 + (b - ix0) / step * step;
        let overlaps = |ix: u32| rect.overlaps_square(self.cell_center_axis(ix), cy, half);
        while first <= last && !overlaps(first) {
            first = first.saturating_add(step);
        }
        if first > last {
            return None;
        }
        while last > first && !overlaps(last) {
            last -= step;
        }
        Some((first, last, cy))
    }

    /// [`GridGeometry::for_each_cell_overlapping`] by testing every cell of the range: the reference the tests
    /// compare the walk with.
    #[cfg(test)]
    pub(crate) fn for_each_cell_overlapping_scan(
        self,
        rect: &OrientedRect,
        range: (u32, u32, u32, u32),
        mut f: impl FnMut(u32, f32, f32),
    ) {
        let (ix0, iy0, ix1, iy1) = range;
        let half = 0.5 * self.cell_size_m;
        for iy in iy0..=iy1 {
            let cy = self.cell_center_axis(iy);
            for ix in ix0..=ix1 {
                let cx = self.cell_center_axis(ix);
                if rect.overlaps_square(cx, cy, half) {
                    f(iy * self.cells_per_side + ix, cx, cy);
                }
            }
        }
    }

    /// Inclusive cell range `(ix0, iy0, ix1, iy1)` covering a box that lies inside the grid.
    #[must_use]
    pub fn cell_range(&self, b: [f32; 4]) -> Option<(u32, u32, u32, u32)> {
        Some((self.axis_to_cell(b[0])?, self.axis_to_cell(b[1])?, self.axis_to_cell(b[2])?, self.axis_to_cell(b[3])?))
    }
}

/// The occupancy grid: hit counts, flags and the list of cells touched this frame.
#[derive(Clone, Debug)]
pub struct OccupancyGrid {
    /// Geometry.
    pub geometry: GridGeometry,
    /// Hits per cell, at most [`MAX_HITS`] (a byte: half the cache footprint of the grid's hottest array).
    hits: Vec<u8>,
    flags: Vec<u8>,
    /// The touched cells are `touched[..touched_len]`; the buffer has its full length from construction and
    /// never grows (no allocation per frame; a full list records no new cell).
    touched: Vec<u32>,
    touched_len: usize,
    /// One bit per cell: set when the cell has hits. Lets the region loops visit only the hit cells of a row.
    hit_bits: Vec<u64>,
    /// `P(n)` for `n = 0..=MAX_HITS`.
    probability: [f32; MAX_HITS as usize + 1],
    /// Empty unless [`OccupancyGrid::with_returns`]: per cell with hits, the smallest squared range of its returns
    /// from the sensor (m^2), their lowest and their highest z (m); set at the cell's first hit of the frame.
    returns: Vec<[f32; 3]>,
    /// Empty unless [`OccupancyGrid::with_sums`]: per cell with hits, the sum of its obstacle returns' x and y (ego
    /// frame, metres, added one return at a time in point order), their number and a zero (the params key
    /// `jump_from_returns`); set to zero at the cell's first hit of the frame. Four lanes so that a return is
    /// added as one 4-wide addition of `[x, y, 1, 0]`, whose lanes are the three scalar additions (and `0 + 0`).
    sums: Vec<[f32; 4]>,
    /// [`OccupancyGrid::with_first_returns`]: each entry of `sums` holds the cell's first return alone (`[0 + x,
    /// 0 + y, 1, 0]`, the sums of that one return), not the sum of all its returns (the params key
    /// `jump_first_return`).
    first_only: bool,
    /// Per block of the rasterize loop ([`OccupancyGrid::add_runs`]): entry `t` is the first point (in the block)
    /// of the `t`-th cell new in the block, which [`OccupancyGrid::set_first_returns`] reads.
    block_first: [u8; 64],
    /// The length of the touched list when the block's runs began ([`OccupancyGrid::add_runs`]).
    block_from: usize,
    /// Empty unless [`OccupancyGrid::with_tall`]: one bit per cell, set when a return of the frame in the cell
    /// stands higher than `tall_above_m` (any return of the sweep, in the band or not, ego footprint or not; the
    /// grazing rule's `ground_z_m + roi_graze_height_m`). The reset clears the words when `tall_any` (a bit was set
    /// since the last reset): one word per 64 cells (625 for the default 200 x 200 cells), not a pass per cell.
    tall_bits: Vec<u64>,
    tall_above_m: f32,
    tall_any: bool,
    /// Whether the rasterizer sets the tall bits this frame ([`OccupancyGrid::set_tall_this_frame`]).
    tall_on: bool,
}

/// A cell's returns before any: nothing is nearer, lower or higher.
const NO_RETURNS: [f32; 3] = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY];

/// At least this many of a block's 64 points in the grid: [`OccupancyGrid::add_sums`] adds all 64 (those outside
/// the grid to a spare entry) rather than finding those in the grid one bit at a time.
const DENSE_SUMS: u32 = 44;

/// Adds a return at `(x, y)` to a cell's sums `[sum x, sum y, count, 0]`: the lanes of one 4-wide addition of
/// `[x, y, 1, 0]` (the compiler's vector add), each lane the scalar addition it replaces, so the sums are those of
/// `e[0] + x`, `e[1] + y`, `e[2] + 1` in turn, bit for bit.
#[inline(always)]
fn add_return(e: &mut [f32; 4], x: f32, y: f32) {
    let v = [x, y, 1.0, 0.0];
    *e = [e[0] + v[0], e[1] + v[1], e[2] + v[2], e[3] + v[3]];
}

impl OccupancyGrid {
    /// Allocates a grid; `max_touched` bounds the cells touched per frame (at most one per point).
    #[must_use]
    pub fn new(geometry: GridGeometry, hit_probability: f32, max_touched: usize) -> Self {
        let l_hit = libm::logf(hit_probability / (1.0 - hit_probability));
        let mut probability = [0.5_f32; MAX_HITS as usize + 1];
        for (n, p) in probability.iter_mut().enumerate() {
            *p = 1.0 - 1.0 / (1.0 + libm::expf(n as f32 * l_hit));
        }
        let cells = geometry.cell_count();
        Self {
            geometry,
            hits: vec![0; cells],
            flags: vec![0; cells],
            touched: vec![0; max_touched.min(cells)],
            touched_len: 0,
            hit_bits: vec![0; cells.div_ceil(64)],
            probability,
            returns: Vec::new(),
            sums: Vec::new(),
            first_only: false,
            block_first: [0; 64],
            block_from: 0,
            tall_bits: Vec::new(),
            tall_above_m: f32::INFINITY,
            tall_any: false,
            tall_on: true,
        }
    }

    /// The grid also keeps, per cell with hits, the sum of its obstacle returns' x and y and their number
    /// ([`OccupancyGrid::sums`]; the params key `jump_from_returns`). Allocates one entry per cell.
    #[must_use]
    pub fn with_sums(mut self) -> Self {
        // One entry per cell and a spare one after them (see `add_sums`).
        self.sums = vec![[0.0; 4]; self.hits.len() + 1];
        self
    }

    /// [`OccupancyGrid::with_sums`], but each cell's entry is its **first return** of the frame alone (the first
    /// obstacle-band return in point order that lands in it): [`OccupancyGrid::sums`] gives its x, its y and the
    /// count 1 (the params keys `jump_from_returns` and `jump_first_return`). Set when the cell is first touched
    /// (the rasterizer computes that one point's x and y there): no per-return addition, and pass 1 writes no x and
    /// y. Allocates one entry per cell.
    #[must_use]
    pub fn with_first_returns(mut self) -> Self {
        self = self.with_sums();
        self.first_only = true;
        self
    }

    /// True when [`OccupancyGrid::sums`] holds each cell's first return alone
    /// ([`OccupancyGrid::with_first_returns`]).
    #[must_use]
    #[inline]
    pub fn has_first_returns(&self) -> bool {
        self.first_only
    }

    /// The grid also keeps a bit per cell: a return higher than `above_m` in the cell this frame
    /// ([`OccupancyGrid::tall`]; the grazing rule). Allocates one bit per cell.
    #[must_use]
    pub fn with_tall(mut self, above_m: f32) -> Self {
        self.tall_bits = vec![0; self.hits.len().div_ceil(64)];
        self.tall_above_m = above_m;
        self
    }

    /// With [`OccupancyGrid::with_sums`], for a cell with hits this frame: the sum of its obstacle returns' x, the
    /// sum of their y (ego frame, metres, in point order: `((0 + x1) + x2) + ...`) and their number. `None`
    /// otherwise.
    #[must_use]
    #[inline]
    pub fn sums(&self, index: u32) -> Option<[f32; 3]> {
        if self.hits(index) == 0 {
            return None;
        }
        self.sums.get(index as usize).map(|&[x, y, n, _]| [x, y, n])
    }

    /// True when the grid keeps [`OccupancyGrid::sums`].
    #[must_use]
    #[inline]
    pub fn has_sums(&self) -> bool {
        !self.sums.is_empty()
    }

    /// With [`OccupancyGrid::with_tall`], unless switched off for the frame: the height above which a return marks
    /// its cell tall.
    #[must_use]
    #[inline]
    pub fn tall_above_m(&self) -> Option<f32> {
        (self.tall_on && !self.tall_bits.is_empty()).then_some(self.tall_above_m)
    }

    /// Whether the next rasterize sets the tall bits (with [`OccupancyGrid::with_tall`]; on until switched off):
    /// the monitor switches them off in frames without a region of interest, where the grazing rule reads none.
    pub(crate) fn set_tall_this_frame(&mut self, on: bool) {
        self.tall_on = on;
    }

    /// With [`OccupancyGrid::with_tall`]: some return of this frame in the cell stood higher than
    /// [`OccupancyGrid::tall_above_m`]. False otherwise (and outside the grid).
    #[must_use]
    #[inline]
    pub fn tall(&self, index: u32) -> bool {
        self.tall_bits.get(index as usize / 64).is_some_and(|w| w & (1 << (index % 64)) != 0)
    }

    /// Marks a cell tall (nothing without [`OccupancyGrid::with_tall`], or outside the grid).
    #[inline(always)]
    pub(crate) fn add_tall(&mut self, index: u32) {
        if let Some(w) = self.tall_bits.get_mut(index as usize / 64) {
            *w |= 1 << (index % 64);
            self.tall_any = true;
        }
    }

    /// Adds a return's x and y to a cell's sums (nothing without [`OccupancyGrid::with_sums`], or outside the
    /// grid); with [`OccupancyGrid::with_first_returns`] only the cell's first (an entry still zero).
    #[inline(always)]
    fn add_sum(&mut self, index: u32, x: f32, y: f32) {
        let first_only = self.first_only;
        if let Some(e) = self.sums.get_mut(index as usize) {
            if !first_only || e[2] == 0.0 {
                add_return(e, x, y);
            }
        }
    }

    /// With [`OccupancyGrid::with_first_returns`], right after the hits of a block of 64 points joined the touched
    /// list ([`OccupancyGrid::add_hits_with_returns`], from position `from` on, which is `block_from`: the caller
    /// passes what it read before the block, which the compiler keeps in a register; reading the field measured
    /// 50 k more instructions per AV2 check): each cell new
    /// in the block gets its first return, the x and y `xy(j)` of its first point `j` in the block (a cell new in
    /// the block had no hit before it, so its first point in the block is its first of the frame). Nothing
    /// otherwise. The first point of each new cell is the one [`OccupancyGrid::add_runs`] kept as the cell joined
    /// the touched list (until round branches: a vector compare of the block's cells per new cell, the mask of
    /// its points, the first set bit its first point; tested against that in `first_points_kept_by_the_runs`).
    /// Not inlined into the loops (`#[inline]` only): the default loop's instructions were lowest this way
    /// (inlined, or its work out of line behind an inlined test, the loop without the key took up to 1.0 or
    /// 1.4 % more; docs/performance.md).
    #[inline]
    pub(crate) fn set_first_returns(&mut self, from: usize, mut xy: impl FnMut(usize) -> (f32, f32)) {
        debug_assert_eq!(from, self.block_from);
        if !self.first_only || from >= self.touched_len {
            return;
        }
        for k in from..self.touched_len {
            let Some(&c) = self.touched.get(k) else { break };
            let Some(&first) = self.block_first.get(k - from) else { break };
            let (x, y) = xy(usize::from(first));
            if let Some(e) = self.sums.get_mut(c as usize) {
                *e = [0.0; 4];
                add_return(e, x, y);
            }
        }
    }

    /// The number of cells touched so far this frame.
    #[inline(always)]
    pub(crate) fn touched_len(&self) -> usize {
        self.touched_len
    }

    /// The grid also keeps, per cell with hits, the nearest squared range and the lowest and highest z of its
    /// returns ([`OccupancyGrid::returns`]), folded as the rasterizer fills it. Allocates one entry per cell. The
    /// monitor no longer asks for it: with the params key `seen_over` it gathers these values for the few cells it
    /// reads (`monitor/over.rs`, at a fraction of this fold's cost), and its test checks them against this fold.
    #[must_use]
    pub fn with_returns(mut self) -> Self {
        self.returns = vec![NO_RETURNS; self.hits.len()];
        self
    }

    /// With [`OccupancyGrid::with_returns`], for a cell with hits this frame: the smallest squared range of its
    /// returns from the sensor (m^2), their lowest and their highest z (m). `None` otherwise.
    #[must_use]
    #[inline]
    pub fn returns(&self, index: u32) -> Option<[f32; 3]> {
        if self.hits(index) == 0 {
            return None;
        }
        self.returns.get(index as usize).copied()
    }

    /// Folds returns (squared range, z) into a cell's entry (nothing without [`OccupancyGrid::with_returns`], or
    /// outside the grid). `min` and `max` do not depend on the order: any split of the returns gives the same entry.
    #[inline(always)]
    fn fold_returns(&mut self, index: u32, r2: f32, z_low: f32, z_high: f32) {
        if let Some(v) = self.returns.get_mut(index as usize) {
            *v = [v[0].min(r2), v[1].min(z_low), v[2].max(z_high)];
        }
    }

    /// [`OccupancyGrid::add_hit`] of an obstacle return at `q` (ego frame) with its squared range from the sensor
    /// (the reference loop's way of [`OccupancyGrid::add_hits_with_returns`]).
    #[inline]
    pub(crate) fn add_hit_return(&mut self, index: u32, r2: f32, q: [f32; 3]) -> bool {
        let added = self.add_run(index, 1);
        if added {
            self.fold_returns(index, r2, q[2], q[2]);
            self.add_sum(index, q[0], q[1]);
        }
        added
    }

    /// Clears every cell touched since the last reset.
    pub fn reset(&mut self) {
        for &i in self.touched.get(..self.touched_len).unwrap_or(&[]) {
            if let Some(w) = self.hit_bits.get_mut(i as usize / 64) {
                *w = 0;
            }
            if let Some(h) = self.hits.get_mut(i as usize) {
                *h = 0;
            }
            if let Some(f) = self.flags.get_mut(i as usize) {
                *f = 0;
            }
        }
        self.touched_len = 0;
        if core::mem::take(&mut self.tall_any) {
            self.tall_bits.fill(0);
        }
    }

    /// Adds one hit to a cell. Returns false when the touched list is full (the hit is then not recorded).
    #[inline]
    pub fn add_hit(&mut self, index: u32) -> bool {
        self.add_run(index, 1)
    }

    /// [`OccupancyGrid::add_hit`] on each of 64 cells in turn, skipping cells outside the grid (such as
    /// [`crate::visibility::NO_CELL`]). Consecutive hits of one cell (a sweep puts several points of a ring in
    /// one cell) are added at once, and the runs are found without a branch per point: one hit at a time, each
    /// increment would wait for the previous one's store, and a test per point of whether the cell changed is
    /// mispredicted at every run's end.
    #[cfg(test)]
    pub(crate) fn add_hits(&mut self, cells: &[u32; 64]) {
        let _ = self.add_hits_with_returns(cells, None, None);
    }

    /// [`OccupancyGrid::add_hits`], and with [`OccupancyGrid::with_returns`] each run's returns folded into its
    /// cell at once: `returns` gives each point's squared range from the sensor (as the bits in the first half of
    /// a visibility-map key's `[bits, cell]` pair, `crate::visibility::key`: non-negative floats order as their
    /// bits) and its z; and with
    /// [`OccupancyGrid::with_sums`] each point's x and y from `xy` added to its cell's sums, one at a time in point
    /// order (the reference's additions). Returns the number of the 64 cells that are in the grid.
    #[inline(always)]
    pub(crate) fn add_hits_with_returns(
        &mut self,
        cells: &[u32; 64],
        returns: Option<(&[[u32; 2]; 64], &[f32; 64])>,
        xy: Option<(&[f32; 64], &[f32; 64])>,
    ) -> u32 {
        let returns = returns.filter(|_| !self.returns.is_empty());
        let xy = xy.filter(|_| !self.sums.is_empty());
        // Bit j of `ends`: point j ends a run (the next point's cell differs, or j is the last point); of
        // `in_grid`: its cell is in the grid.
        let (ends, in_grid) = run_masks(cells, self.hits.len());
        let runs = ends & in_grid;
        // Two loops, with and without the returns, so that the default one does not test for them per run.
        match returns {
            None => self.add_runs(cells, ends, runs, |_, _, _, _| {}),
            Some((r2_keys, z)) => self.add_runs(cells, ends, runs, |grid, c, start, j| {
                let run = start as usize..=j as usize;
                // The lower halves of the keys (`[bits, cell]`): the squared ranges' bits.
                let r2 = r2_keys
                    .get(run.clone())
                    .map_or(u32::MAX, |r| r.iter().map(|&[bits, _]| bits).min().unwrap_or(u32::MAX));
                let (lo, hi) = z.get(run).map_or((f32::INFINITY, f32::NEG_INFINITY), |z| {
                    z.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
                });
                grid.fold_returns(c, f32::from_bits(r2), lo, hi);
            }),
        }
        // The sums: each point in the grid in turn, in point order (the cells new this block were set to zero above,
        // before any of their returns is added). A return whose cell could not join a full touched list is added to
        // an entry nobody reads (`sums` needs hits) and set to zero when the cell is first touched.
        if let Some((x, y)) = xy {
            self.add_sums(cells, in_grid, x, y);
        }
        in_grid.count_ones()
    }

    /// The sums of [`OccupancyGrid::add_hits_with_returns`]: adds each point `j` whose bit is set in `in_grid` (its
    /// cell `cells[j]` is in the grid) to its cell's sums, in point order. A point's cell is clamped to the spare
    /// entry after the last cell (`with_sums` allocates it; nobody reads it), which no cell in the grid reaches, so
    /// there is no test per point: where most of a block's points are in the grid every point of the block is
    /// added, those outside to the spare entry (no bit loop); elsewhere only the points in the grid.
    #[inline(always)]
    fn add_sums(&mut self, cells: &[u32; 64], in_grid: u64, x: &[f32; 64], y: &[f32; 64]) {
        let Some(spare) = self.sums.len().checked_sub(1) else { return };
        if in_grid.count_ones() >= DENSE_SUMS {
            for ((&c, &x), &y) in cells.iter().zip(x).zip(y) {
                if let Some(e) = self.sums.get_mut((c as usize).min(spare)) {
                    add_return(e, x, y);
                }
            }
        } else {
            let mut points = in_grid;
            while points != 0 {
                let j = (points.trailing_zeros() & 63) as usize;
                points &= points - 1;
                let (Some(&c), Some(&x), Some(&y)) = (cells.get(j), x.get(j), y.get(j)) else { continue };
                if let Some(e) = self.sums.get_mut((c as usize).min(spare)) {
                    add_return(e, x, y);
                }
            }
        }
    }

    /// Adds `other`'s hits to this grid, cell by cell in `other`'s order of first touch: the grid one pass over
    /// this grid's points and then `other`'s would give (counts saturate at the same maximum; cells new to this
    /// grid join its touched list in `other`'s order). Flags are not copied. For the rasterize stage on two
    /// threads (`crate::split`); `other` must have the same geometry.
    ///
    /// Tall bits are or-ed. Sums: a cell new to this grid takes `other`'s (one pass adds the same returns from
    /// zero in the same order); a cell this grid had too cannot take them (a sum of sums is not the one pass's sum
    /// of returns in turn): its entry in `other` gets the count -1, and the caller adds `other`'s returns of those
    /// cells in point order ([`OccupancyGrid::shared_sum`], [`OccupancyGrid::add_return_sum`]). Returns true when
    /// there are such cells.
    pub(crate) fn absorb(&mut self, other: &mut OccupancyGrid) -> bool {
        let mut shared = false;
        for k in 0..other.touched_len {
            let Some(&c) = other.touched.get(k) else { break };
            let new = self.hits(c) == 0;
            if self.add_run(c, u8::try_from(other.hits(c)).unwrap_or(u8::MAX)) {
                if let Some(&[r2, lo, hi]) = other.returns.get(c as usize) {
                    self.fold_returns(c, r2, lo, hi);
                }
                if let (Some(mine), Some(theirs)) = (self.sums.get_mut(c as usize), other.sums.get_mut(c as usize)) {
                    if new {
                        *mine = *theirs;
                    } else if self.first_only {
                        // First returns: the cell's first return is this grid's (its points come first).
                    } else {
                        theirs[2] = -1.0;
                        shared = true;
                    }
                }
            }
        }
        if other.tall_any {
            for (w, &o) in self.tall_bits.iter_mut().zip(&other.tall_bits) {
                *w |= o;
            }
            self.tall_any = true;
        }
        shared
    }

    /// After [`OccupancyGrid::absorb`] of this grid into another: true for a cell whose returns the other grid
    /// must add one at a time.
    #[inline]
    pub(crate) fn shared_sum(&self, index: u32) -> bool {
        self.hits(index) > 0 && self.sums.get(index as usize).is_some_and(|e| e[2] < 0.0)
    }

    /// Adds one obstacle return's x and y to a cell with hits (the fold of the rasterize stage on two threads).
    #[inline]
    pub(crate) fn add_return_sum(&mut self, index: u32, x: f32, y: f32) {
        if self.hits(index) > 0 {
            self.add_sum(index, x, y);
        }
    }

    /// The runs of a block in order (`runs`: the bits of `ends`, see [`run_masks`], of the runs to add), each with
    /// [`OccupancyGrid::add_run`] and, when that recorded it, `then(grid, cell, first point, last point)`.
    #[inline(always)]
    fn add_runs(
        &mut self,
        cells: &[u32; 64],
        ends: u64,
        mut runs: u64,
        mut then: impl FnMut(&mut Self, u32, u32, u32),
    ) {
        self.block_from = self.touched_len;
        while runs != 0 {
            let j = runs.trailing_zeros();
            runs &= runs - 1;
            // The run starts after the previous end (of any run, in the grid or not); `leading_zeros` of 0 is 64,
            // so a run that starts the block needs no test.
            let before = ends & ((1u64 << j) - 1);
            let start = 64 - before.leading_zeros();
            if let Some(&c) = cells.get(j as usize) {
                // At most 64 points: the truncation is exact.
                #[allow(clippy::cast_possible_truncation)]
                if self.add_run_from::<true>(c, (j + 1 - start) as u8, start as u8) {
                    then(self, c, start, j);
                }
            }
        }
    }

    /// `n` hits on one cell: the same as `n` calls of [`OccupancyGrid::add_hit`]. False when no hit was recorded
    /// (outside the grid, or a new cell while the touched list is full).
    #[inline(always)]
    fn add_run(&mut self, index: u32, n: u8) -> bool {
        self.add_run_from::<false>(index, n, 0)
    }

    /// [`OccupancyGrid::add_run`]; with `KEEP`, for a run of a block of the rasterize loop
    /// ([`OccupancyGrid::add_runs`]) that starts at point `start` of the block: a cell new in the block keeps
    /// `start`, its first point in the block (the runs come in point order), in `block_first` at its place among
    /// the block's new cells.
    #[inline(always)]
    fn add_run_from<const KEEP: bool>(&mut self, index: u32, n: u8, start: u8) -> bool {
        let Some(h) = self.hits.get_mut(index as usize) else { return false };
        if *h == 0 {
            let Some(slot) = self.touched.get_mut(self.touched_len) else { return false };
            *slot = index;
            if KEEP {
                if let Some(first) = self.block_first.get_mut(self.touched_len.wrapping_sub(self.block_from) & 63) {
                    *first = start;
                }
            }
            self.touched_len += 1;
            if let Some(v) = self.returns.get_mut(index as usize) {
                *v = NO_RETURNS;
            }
            if let Some(e) = self.sums.get_mut(index as usize) {
                *e = [0.0; 4];
            }
            if let Some(w) = self.hit_bits.get_mut(index as usize / 64) {
                *w |= 1 << (index % 64);
            }
        }
        // `MAX_HITS` is `u8::MAX` (asserted below): the byte's saturating addition is the saturation at `MAX_HITS`.
        *h = h.saturating_add(n);
        true
    }

    /// Calls `f(grid, index)` for each cell with hits among the cells of a range that overlap a rectangle (those
    /// of [`GridGeometry::for_each_cell_overlapping`], in the same order, less the cells without hits). Costs a
    /// few tests per row of the range and one step per hit cell, not one per cell: the cells without hits are
    /// skipped 64 at a time. `f` may change the grid's flags (not its hits).
    #[inline]
    pub fn for_each_hit_cell_overlapping(
        &mut self,
        rect: &OrientedRect,
        range: (u32, u32, u32, u32),
        mut f: impl FnMut(&mut Self, u32),
    ) {
        let geometry = self.geometry;
        geometry.for_each_row_run(rect, range, |iy, a, b, _| {
            let (first, last) = (iy * geometry.cells_per_side + a, iy * geometry.cells_per_side + b);
            for (word, mask) in run_words(first, last) {
                let mut bits = self.hit_bits.get(word as usize).copied().unwrap_or(0) & mask;
                while bits != 0 {
                    let index = word * 64 + bits.trailing_zeros();
                    bits &= bits - 1;
                    f(self, index);
                }
            }
        });
    }

    /// [`OccupancyGrid::for_each_hit_cell_overlapping`] for a look that changes nothing: `f(index)` for each cell
    /// with hits among the cells of a range that overlap a rectangle, in the same order.
    #[inline]
    pub fn for_each_hit_cell(&self, rect: &OrientedRect, range: (u32, u32, u32, u32), mut f: impl FnMut(u32)) {
        let geometry = self.geometry;
        geometry.for_each_row_run(rect, range, |iy, a, b, _| {
            let (first, last) = (iy * geometry.cells_per_side + a, iy * geometry.cells_per_side + b);
            for (word, mask) in run_words(first, last) {
                let mut bits = self.hit_bits.get(word as usize).copied().unwrap_or(0) & mask;
                while bits != 0 {
                    f(word * 64 + bits.trailing_zeros());
                    bits &= bits - 1;
                }
            }
        });
    }

    /// Hits of a cell this frame (0 outside the grid).
    #[must_use]
    #[inline]
    pub fn hits(&self, index: u32) -> u16 {
        self.hits.get(index as usize).copied().map_or(0, u16::from)
    }

    /// Occupancy probability `P(zeta)` of a cell (0.5, unknown, for a cell without hits).
    #[must_use]
    #[inline]
    pub fn probability(&self, index: u32) -> f32 {
        self.probability_of_hits(self.hits(index))
    }

    /// `P(n)` for a hit count.
    #[must_use]
    #[inline]
    pub fn probability_of_hits(&self, hits: u16) -> f32 {
        self.probability.get(hits as usize).copied().unwrap_or(1.0)
    }

    /// Flags of a cell.
    #[must_use]
    #[inline]
    pub fn flags(&self, index: u32) -> u8 {
        self.flags.get(index as usize).copied().unwrap_or(0)
    }

    /// Sets flags on a cell that has hits (flags are only ever set on touched cells, so that
    /// [`OccupancyGrid::reset`] clears them).
    #[inline]
    pub fn set_flags(&mut self, index: u32, flags: u8) {
        if self.hits(index) == 0 {
            return;
        }
        if let Some(f) = self.flags.get_mut(index as usize) {
            *f |= flags;
        }
    }

    /// Clears flags of a cell.
    #[inline]
    pub fn clear_flags(&mut self, index: u32, flags: u8) {
        if let Some(f) = self.flags.get_mut(index as usize) {
            *f &= !flags;
        }
    }

    /// Cells touched this frame, in the order of first touch.
    #[must_use]
    pub fn touched(&self) -> &[u32] {
        self.touched.get(..self.touched_len).unwrap_or(&[])
    }

    /// State of a cell given the conflict threshold.
    #[must_use]
    pub fn state(&self, index: u32, tau_fn: f32) -> CellState {
        let n = self.hits(index);
        if n == 0 {
            CellState::Unknown
        } else if self.probability_of_hits(n) <= tau_fn {
            CellState::Weak
        } else if self.flags(index) & FLAG_EXPLAINED != 0 {
            CellState::Occupied
        } else {
            CellState::Conflict
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{unit_draws, xorshift_draws};

    proptest::proptest! {
        /// `run_masks` (two 32-bit halves) against its definition bit by bit, on blocks of few distinct cells (long
        /// runs), with `NO_CELL`, cells at and above the count and the count 0 and beyond `u32::MAX`.
        #[test]
        fn run_masks_are_their_definition(
            seed in proptest::prelude::any::<u64>(),
            count in proptest::prop_oneof![0usize..10, 5usize..7, proptest::strategy::Just(u32::MAX as usize + 3)],
        ) {
            let mut next = xorshift_draws(seed | 1);
            let cells: [u32; 64] = core::array::from_fn(|_| {
                let state = next();
                match state % 5 {
                    0 => crate::visibility::NO_CELL,
                    1 => u32::MAX - 1,
                    k => (state >> 32) as u32 % 8 + k as u32,
                }
            });
            let (ends, in_grid) = run_masks(&cells, count);
            for j in 0..64 {
                let end = j == 63 || cells[j] != cells[j + 1];
                proptest::prop_assert_eq!(ends >> j & 1 == 1, end, "end bit {}", j);
                proptest::prop_assert_eq!(in_grid >> j & 1 == 1, (cells[j] as usize) < count, "grid bit {}", j);
            }
        }

        /// The first points `add_runs` keeps for the cells new in a block are their first points in it (the first
        /// set bit of `bits_equal`, the computation they replace): blocks of few distinct cells (runs, a cell
        /// coming back after others), `NO_CELL` and cells beyond the grid, cells already touched in earlier
        /// blocks, and a touched list that fills up (a new cell that cannot join gets no first return).
        #[test]
        fn first_points_kept_by_the_runs(
            seed in proptest::prelude::any::<u64>(),
            room in proptest::prop_oneof![1usize..40, proptest::strategy::Just(400usize)],
        ) {
            let mut next = xorshift_draws(seed | 1);
            let geometry = GridGeometry::new(20, 0.5);
            let mut grid = OccupancyGrid::new(geometry, 0.7, room).with_first_returns();
            for _block in 0..6 {
                let spread = 1 + next() % 60;
                let cells: [u32; 64] = core::array::from_fn(|_| match next() % 9 {
                    0 => crate::visibility::NO_CELL,
                    1 => 400 + (next() % 5) as u32,
                    _ => (next() % spread) as u32 * 7 % 400,
                });
                let from = grid.touched_len();
                let was: Vec<bool> = cells.iter().map(|&c| grid.hits(c) > 0).collect();
                grid.add_hits_with_returns(&cells, None, None);
                grid.set_first_returns(grid.block_from, |j| (j as f32, 100.0 + j as f32));
                for k in from..grid.touched_len() {
                    let c = grid.touched[k];
                    let first = bits_equal(&cells, c).trailing_zeros() as usize;
                    proptest::prop_assert!(first < 64 && !was[first]);
                    let want = [first as f32, 100.0 + first as f32, 1.0, 0.0];
                    proptest::prop_assert_eq!(grid.sums[c as usize].map(f32::to_bits), want.map(f32::to_bits));
                }
            }
        }

        /// `neighbours4` gives exactly the cells one row or one column away inside the grid: at an edge, no
        /// neighbour wraps to the other end of the neighbouring row (the earlier `index +- 1` did).
        #[test]
        fn neighbours4_never_wrap(n in 1u32..300, at in 0.0f64..1.0) {
            let g = GridGeometry::new(n, 0.5);
            let index = ((f64::from(n * n) * at) as u32).min(n * n - 1);
            let (cx, cy) = (index % n, index / n);
            let got: Vec<u32> = g.neighbours4(index).collect();
            let mut want = Vec::new();
            for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (x, y) = (i64::from(cx) + dx, i64::from(cy) + dy);
                if (0..i64::from(n)).contains(&x) && (0..i64::from(n)).contains(&y) {
                    want.push((y * i64::from(n) + x) as u32);
                }
            }
            proptest::prop_assert_eq!(got, want);
        }
    }

    #[test]
    fn neighbours4_at_the_row_ends() {
        let g = GridGeometry::new(4, 0.5);
        // Cell 3 ends row 0: its right neighbour does not exist (3 + 1 = 4 starts row 1).
        assert_eq!(g.neighbours4(3).collect::<Vec<_>>(), vec![2, 7]);
        assert_eq!(g.neighbours4(4).collect::<Vec<_>>(), vec![5, 0, 8]);
        assert_eq!(g.neighbours4(16).count(), 0, "outside the grid");
    }

    #[test]
    fn world_to_cell_and_back() {
        let g = GridGeometry::new(200, 0.5);
        assert_eq!(g.point_to_cell(0.1, 0.1), Some(100 * 200 + 100));
        assert_eq!(g.point_to_cell(-50.0, -50.0), Some(0));
        assert_eq!(g.point_to_cell(50.0, 0.0), None);
        assert_eq!(g.point_to_cell(f32::NAN, 0.0), None);
        let (x, y) = g.cell_center(100 * 200 + 100);
        assert!((x - 0.25).abs() < 1e-6 && (y - 0.25).abs() < 1e-6);
    }

    #[test]
    fn log_odds_probabilities() {
        let g = OccupancyGrid::new(GridGeometry::new(4, 1.0), 0.7, 16);
        assert!((g.probability_of_hits(0) - 0.5).abs() < 1e-6);
        assert!((g.probability_of_hits(1) - 0.7).abs() < 1e-5);
        // Two hits: odds (7/3)^2 = 5.444, P = 0.8448.
        assert!((g.probability_of_hits(2) - 0.844_827_6).abs() < 1e-5);
        assert!(g.probability_of_hits(255) <= 1.0);
    }

    #[test]
    fn reset_clears_only_touched_and_capacity_is_respected() {
        let mut g = OccupancyGrid::new(GridGeometry::new(4, 1.0), 0.7, 2);
        assert!(g.add_hit(3));
        assert!(g.add_hit(3));
        assert!(g.add_hit(5));
        assert!(!g.add_hit(7), "third distinct cell exceeds capacity");
        g.set_flags(3, FLAG_EXPLAINED);
        g.set_flags(9, FLAG_EXPLAINED); // no hits: ignored
        assert_eq!(g.flags(9), 0);
        assert_eq!(g.state(3, 0.8), CellState::Occupied);
        assert_eq!(g.state(5, 0.8), CellState::Weak);
        g.reset();
        assert_eq!(g.hits(3), 0);
        assert_eq!(g.flags(3), 0);
        assert!(g.touched().is_empty());
    }

    #[test]
    fn cell_walk_by_runs_equals_the_scan_of_every_cell() {
        let mut unit = unit_draws(0x853c_49e6_748f_ea9b);
        let headings =
            [0.0, 1e-7, -1e-7, 0.009, 0.0101, 0.3, core::f32::consts::FRAC_PI_2, 1.5706, 1.5808, 3.1414, -2.2];
        let mut cells_seen = 0usize;
        for case in 0..3000 {
            let (cells, cell_m) = [(200, 0.5), (500, 0.2), (1000, 0.1), (37, 0.37), (8, 3.0)][case % 5];
            let g = GridGeometry::new(cells, cell_m);
            let half_size = 0.5 * cells as f32 * cell_m;
            let heading = if case % 3 == 0 { headings[case / 3 % headings.len()] } else { (unit() - 0.5) * 7.0 };
            let rect = OrientedRect::new(
                (unit() - 0.5) * 2.4 * half_size,
                (unit() - 0.5) * 2.4 * half_size,
                heading,
                [0.0f32, 1e-4, 0.3, 2.5, 9.0][case / 25 % 5].max(unit() * 4.0 * (case % 2) as f32),
                [0.0f32, 1e-4, 0.2, 1.1, 4.0][case / 5 % 5].max(unit() * 2.0 * (case % 2) as f32),
            );
            let Some(range) = g.cell_range_clipped(rect.aabb()) else { continue };
            // Also ranges narrower than the rectangle's (clipped by the caller).
            let range =
                if case % 7 == 0 { (range.0 + (range.2 - range.0) / 3, range.1, range.2, range.3) } else { range };
            let (mut walk, mut scan) = (Vec::new(), Vec::new());
            g.for_each_cell_overlapping(&rect, range, |i, x, y| walk.push((i, x.to_bits(), y.to_bits())));
            g.for_each_cell_overlapping_scan(&rect, range, |i, x, y| scan.push((i, x.to_bits(), y.to_bits())));
            assert_eq!(walk, scan, "case {case}: {rect:?} {range:?} cell {cell_m}");
            cells_seen += scan.len();
            // Every `step`-th row and column: the scan filtered by row and column.
            for step in [1u32, 2, 3, 5] {
                let mut every = Vec::new();
                g.for_each_cell_overlapping_every(&rect, range, step, |i, x, y| {
                    every.push((i, x.to_bits(), y.to_bits()));
                });
                let n = g.cells_per_side;
                let filtered: Vec<_> = scan
                    .iter()
                    .copied()
                    .filter(|&(i, _, _)| {
                        (i % n - range.0).is_multiple_of(step) && (i / n - range.1).is_multiple_of(step)
                    })
                    .collect();
                assert_eq!(every, filtered, "case {case}, step {step}: {rect:?} {range:?} cell {cell_m}");
            }
        }
        assert!(cells_seen > 100_000, "the cases cover cells: {cells_seen}");
    }

    #[test]
    fn hit_cells_of_a_region_are_the_scanned_cells_with_hits() {
        let mut next = xorshift_draws(0x2545_f491_4f6c_dd1d);
        for case in 0..400 {
            let (cells, cell_m) = [(200, 0.5), (333, 0.2), (64, 1.0), (65, 1.0), (7, 3.0)][case % 5];
            let g = GridGeometry::new(cells, cell_m);
            let mut grid = OccupancyGrid::new(g, 0.7, 100_000);
            // Hits in about one cell in 4 (every cell in some cases), through both ways of adding them.
            let density = [4, 1, 50][case % 3];
            for c in 0..g.cell_count() as u32 {
                if next().is_multiple_of(density) {
                    if c % 2 == 0 {
                        let _ = grid.add_hit(c);
                    } else {
                        let mut block = [u32::MAX; 64];
                        block[0] = c;
                        grid.add_hits(&block);
                    }
                }
            }
            let unit = |v: u64| (v >> 40) as f32 / (1u64 << 24) as f32;
            let half_size = 0.5 * g.size_m();
            let rect = OrientedRect::new(
                (unit(next()) - 0.5) * 2.2 * half_size,
                (unit(next()) - 0.5) * 2.2 * half_size,
                (unit(next()) - 0.5) * 7.0,
                unit(next()) * 0.3 * half_size,
                unit(next()) * 0.2 * half_size,
            );
            let Some(range) = g.cell_range_clipped(rect.aabb()) else { continue };
            let mut scanned = Vec::new();
            g.for_each_cell_overlapping_scan(&rect, range, |i, _, _| {
                if grid.hits(i) > 0 {
                    scanned.push(i);
                }
            });
            let mut visited = Vec::new();
            grid.for_each_hit_cell_overlapping(&rect, range, |_, i| visited.push(i));
            assert_eq!(visited, scanned, "case {case}");
            // The reset clears the bits with the hits.
            grid.reset();
            let mut after = 0;
            grid.for_each_hit_cell_overlapping(&rect, range, |_, _| after += 1);
            assert_eq!(after, 0);
        }
    }

    /// `add_hits` over blocks of 64 cells, the last one padded with a cell outside the grid.
    fn add_hits_in_blocks(g: &mut OccupancyGrid, cells: &[u32]) {
        for chunk in cells.chunks(64) {
            let mut block = [u32::MAX; 64];
            block[..chunk.len()].copy_from_slice(chunk);
            g.add_hits(&block);
        }
    }

    #[test]
    fn add_hits_equals_add_hit_in_turn_including_a_full_list_and_saturation() {
        let cells: Vec<u32> = [3, 3, 5, u32::MAX, 7, 16, 5, 9, 3, 7]
            .into_iter()
            .chain(core::iter::repeat_n(9, 300))
            .chain(core::iter::repeat_n(11, 300))
            .collect();
        for capacity in [0, 1, 2, 3, 16] {
            let (mut one, mut block) = (
                OccupancyGrid::new(GridGeometry::new(4, 1.0), 0.7, capacity),
                OccupancyGrid::new(GridGeometry::new(4, 1.0), 0.7, capacity),
            );
            for &c in &cells {
                let _ = one.add_hit(c);
            }
            add_hits_in_blocks(&mut block, &cells);
            assert_eq!(one.touched(), block.touched(), "capacity {capacity}");
            for c in 0..16 {
                assert_eq!(one.hits(c), block.hits(c), "capacity {capacity}, cell {c}");
            }
        }
        let mut g = OccupancyGrid::new(GridGeometry::new(4, 1.0), 0.7, 16);
        add_hits_in_blocks(&mut g, &cells);
        assert_eq!((g.hits(9), g.hits(11), g.hits(3)), (MAX_HITS, MAX_HITS, 3));
        assert_eq!(g.touched(), [3, 5, 7, 9, 11]);
    }
}
