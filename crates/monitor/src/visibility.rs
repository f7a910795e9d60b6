//! A polar visibility map, to tell an empty region (ghost) from a hidden one (occluded).
//!
//! The hit-only occupancy grid cannot say whether a cell without hits is free or merely unseen. Per azimuth
//! bin around the sensor this map keeps the squared range of the nearest obstacle return (points in the
//! height band) and of the farthest return below the band's top (ground or obstacle). A ground position is
//! *visible* when it lies before the nearest obstacle of its bin (not in a shadow) and before the farthest
//! return (some ray reached past it). Cost: one pass over the points, no trigonometry (bins are spaced in
//! [`crate::geometry::diamond_angle`], which is monotonic in the true angle but not uniform: bins are at most
//! about 1.4 times wider than `360 / bins` degrees).

use alloc::vec;
use alloc::vec::Vec;

use crate::geometry::diamond_angle;

/// Cell index meaning "no cell" (outside the grid or no obstacle).
pub const NO_CELL: u32 = u32::MAX;

/// The binning of a [`VisibilityMap`], copied out so that a loop can bin many returns without borrowing the map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BinParams {
    /// Sensor origin, ego frame, metres.
    pub origin: [f32; 2],
    /// Bins per unit of diamond angle.
    pub bins_per_unit: f32,
    /// Index of the last bin.
    pub last_bin: usize,
}

/// What the sensor saw of a position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sight {
    /// Rays passed over it and returned from beyond: it is seen (to be empty, if it has no hits).
    Visible,
    /// It lies behind the nearest obstacle of its direction, whose grid cell is given.
    Shadowed(u32),
    /// No ray of its direction returned from as far: out of the sensor's reach.
    Unreached,
}

/// One azimuth bin: the nearest obstacle return (squared range and grid cell) and the farthest return.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bin {
    /// The nearest obstacle return as one [`key`]: the bits of its squared range (m^2; `INFINITY`: none) in the
    /// lower 32 bits, its grid cell (`NO_CELL`: none, or outside the grid) in the upper 32. One load, one compare of
    /// the lower half with the candidate's bits in memory, one conditional move and one store per update in the
    /// rasterize loop (docs/performance.md, "Issue #16, round rast16" and "round viscopy").
    ///
    /// (Round rast16 had the range in the upper half, compared as `key < old & !0xFFFF_FFFF`: a copy and an `and`
    /// per update more; round viscopy put it in the lower half, which x86 compares as the 32-bit register of the
    /// loaded key with no instruction of its own.)
    nearest_obstacle: u64,
    /// Squared range of the farthest return below the band's top, m^2 (0: none).
    farthest_return_r2: f32,
}

impl Bin {
    const EMPTY: Self = Self { nearest_obstacle: key(f32::INFINITY.to_bits(), NO_CELL), farthest_return_r2: 0.0 };

    /// Squared range of the nearest obstacle return, m^2 (`INFINITY`: none).
    #[inline(always)]
    fn nearest_obstacle_r2(&self) -> f32 {
        f32::from_bits(self.nearest_r2_bits())
    }

    /// The bits of [`Bin::nearest_obstacle_r2`].
    #[inline(always)]
    fn nearest_r2_bits(&self) -> u32 {
        // The lower half: the truncation is the point.
        #[allow(clippy::cast_possible_truncation)]
        let bits = self.nearest_obstacle as u32;
        bits
    }

    /// Grid cell of the nearest obstacle return (`NO_CELL`: none, or outside the grid).
    #[inline(always)]
    fn nearest_obstacle_cell(&self) -> u32 {
        (self.nearest_obstacle >> 32) as u32
    }
}

/// A nearest-obstacle key of [`Bin`]: a squared range's bits (lower half) and a cell (upper half). It is not
/// compared as a whole: the range's bits alone decide ([`VisibilityMap::add_binned`]). The rasterize loop's pass 1
/// writes its two halves as `[bits, cell]`, which is the key's little-endian memory.
#[inline(always)]
pub(crate) const fn key(r2_bits: u32, cell: u32) -> u64 {
    ((cell as u64) << 32) | r2_bits as u64
}

/// Most bins [`VisibilityMap::box_seen_empty`] looks at per quadrant (beyond them it answers false): 128 of the
/// default 720, a box about 60 degrees wide.
pub const OPEN_VIEW_MAX_BINS: usize = 128;

/// The slack [`VisibilityMap::box_seen_empty`] (and the ghost test's cell range around it) allows around a box for
/// the rounding of the positions looked up in it: 1 mm plus 1e-5 of the box's largest coordinate (the nearest
/// points of shifted boxes stray by a few f32 ulps of their coordinates: under 1e-5 m at 50 m, about 2 mm at 5 km).
#[must_use]
pub fn open_view_slack_m(b: [f32; 4]) -> f32 {
    1e-3 + 1e-5 * b.iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

/// The unit direction of a diamond angle (the inverse of [`diamond_angle`], normalised), for `a` in `[0, 4)`.
fn diamond_direction(a: f32) -> [f32; 2] {
    let (dx, dy) = if a < 1.0 {
        (1.0 - a, a)
    } else if a < 2.0 {
        (1.0 - a, 2.0 - a)
    } else if a < 3.0 {
        (a - 3.0, 2.0 - a)
    } else {
        (a - 3.0, a - 4.0)
    };
    let norm = libm::sqrtf(dx * dx + dy * dy);
    [dx / norm, dy / norm]
}

/// The capacity of [`VisibilityMap`]'s fixed-size arrays: a map of at most this many bins (the default
/// `visibility_bins` is 720) holds its bins in two arrays of exactly this length, which the rasterize loop indexes
/// by the bin masked with `FAST_BINS - 1`, with no bounds test. A power of two.
const FAST_BINS: usize = 1 << 10;

/// Nearest-obstacle and farthest-return ranges per azimuth bin.
///
/// The bins are two arrays, the nearest obstacle's `key`s and the farthest returns. A map of at most
/// `FAST_BINS` bins holds `FAST_BINS` entries in each (12 KiB; the first `len` are the map, the rest is never
/// read or written), which the rasterize loop indexes by the bin masked, with no bounds test and with the
/// addressing mode's scale of 8 and 4 (one array of 16-byte records needed a shift and a bounds test per update:
/// docs/performance.md, "Round perf17"). A map of more bins holds `len` entries in each (12 bytes per bin) and
/// takes the same updates with the bounds tested.
#[derive(Clone)]
pub struct VisibilityMap {
    /// Each bin's nearest obstacle as a [`key`] (`Bin::nearest_obstacle`).
    near: Vec<u64>,
    /// Each bin's farthest return, `r^2` (`Bin::farthest_return_r2`).
    far: Vec<f32>,
    /// The number of bins (at least 1).
    len: usize,
    origin: [f32; 2],
    bins_per_unit: f32,
}

impl core::fmt::Debug for VisibilityMap {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let (near, far) = self.bins();
        let bins: Vec<Bin> = Self::records(near, far).collect();
        f.debug_struct("VisibilityMap")
            .field("bins", &bins)
            .field("origin", &self.origin)
            .field("bins_per_unit", &self.bins_per_unit)
            .finish()
    }
}

impl VisibilityMap {
    /// A map with `bins` azimuth bins (at least 1).
    #[must_use]
    pub fn new(bins: u32) -> Self {
        let n = bins.max(1) as usize;
        // The used bins are emptied now and per frame; the entries beyond them (maps of fewer bins than
        // `FAST_BINS`) are never read.
        let (near, far) = (vec![0u64; n.max(FAST_BINS)], vec![0.0f32; n.max(FAST_BINS)]);
        let mut map = Self { near, far, len: n, origin: [0.0, 0.0], bins_per_unit: n as f32 / 4.0 };
        map.reset([0.0, 0.0]);
        map
    }

    /// Clears the map and sets the sensor origin (ego frame, metres).
    pub fn reset(&mut self, origin: [f32; 2]) {
        if let Some(near) = self.near.get_mut(..self.len) {
            near.fill(Bin::EMPTY.nearest_obstacle);
        }
        if let Some(far) = self.far.get_mut(..self.len) {
            far.fill(Bin::EMPTY.farthest_return_r2);
        }
        self.origin = origin;
    }

    /// The map's bins: their nearest obstacles' keys and farthest returns (`len` each).
    #[inline(always)]
    fn bins(&self) -> (&[u64], &[f32]) {
        (self.near.get(..self.len).unwrap_or_default(), self.far.get(..self.len).unwrap_or_default())
    }

    /// The bins of the two arrays `near` and `far` (one range of the map's), as records.
    fn records<'a>(near: &'a [u64], far: &'a [f32]) -> impl Iterator<Item = Bin> + 'a {
        near.iter().zip(far).map(|(&n, &r)| Bin { nearest_obstacle: n, farthest_return_r2: r })
    }

    /// Bin `b`, `None` beyond the map.
    #[inline(always)]
    fn get(&self, b: usize) -> Option<Bin> {
        let (near, far) = self.bins();
        Some(Bin { nearest_obstacle: *near.get(b)?, farthest_return_r2: *far.get(b)? })
    }

    /// What the blocked rasteriser needs to bin returns itself (see `crate::rasterize`).
    #[must_use]
    pub(crate) fn bin_params(&self) -> BinParams {
        BinParams { origin: self.origin, bins_per_unit: self.bins_per_unit, last_bin: self.len.saturating_sub(1) }
    }

    /// Records a block of returns already binned (see [`BinParams`]), in point order: the same map as
    /// [`VisibilityMap::add_return`] on each return in turn. Per return: its bin, its squared range as a candidate
    /// farthest return (`0.0` for a point that is no return: it never wins), and its candidate nearest obstacle as
    /// the halves `[bits, cell]` of a [`key`]: the bits of its squared range and its grid cell (`u32::MAX` as the
    /// bits for a point that is no obstacle or has an infinite range: it never wins; otherwise a finite non-negative
    /// float, whose bits order as its value).
    ///
    /// The nearest obstacle is compared by its range's bits, strictly, in point order: the first of equal ranges
    /// stays, as in [`VisibilityMap::add_return`] (the definition is unchanged since before issue #16; the updates
    /// run in point order, one bin at a time). The candidate's bits are compared with the lower half of the bin's
    /// key (on x86-64: a 32-bit compare of the candidate in memory with the loaded key's register), and the winner's
    /// whole key is moved in (a 64-bit load of the `[bits, cell]` pair). (Round rast16: the range in the upper half
    /// and one 64-bit comparison with the cell half cleared, 14 instructions per update; round viscopy: 11. Until
    /// round rast16 the range's bits and the cell were two fields and two conditional moves; before issue #16's
    /// first round, a 64-bit key `(r^2 bits << 32) | point index` in a second array of bins, copied into this one
    /// per frame.)
    ///
    /// The bins are at most the last bin of [`VisibilityMap::bin_params`] (pass 1 clamps them), so below
    /// [`FAST_BINS`] in a map of at most [`FAST_BINS`] bins: there each update indexes the fixed-size arrays by the
    /// bin masked with `FAST_BINS - 1` (the bin itself), with no bounds test (round perf17). A map of more bins
    /// takes the same updates with the bounds tested.
    #[inline(always)]
    pub(crate) fn add_binned(&mut self, bins: &[u32; 64], far_r2: &[f32; 64], near_keys: &[[u32; 2]; 64]) {
        debug_assert!(bins.iter().all(|&b| (b as usize) < self.len));
        // Eight returns per turn of the loop: one loop test for eight updates.
        let (bins, _) = bins.as_chunks::<8>();
        let (far_r2, _) = far_r2.as_chunks::<8>();
        let (near_keys, _) = near_keys.as_chunks::<8>();
        let fast: (Result<&mut [u64; FAST_BINS], _>, Result<&mut [f32; FAST_BINS], _>) =
            (self.near.as_mut_slice().try_into(), self.far.as_mut_slice().try_into());
        if let (Ok(near_of), Ok(far_of)) = fast {
            for ((b, far), near) in bins.iter().zip(far_r2).zip(near_keys) {
                for ((&b, &far), &[bits, cell]) in b.iter().zip(far).zip(near) {
                    // Exact: `b < len <= FAST_BINS`, so the mask keeps the bin.
                    let b = b as usize & (FAST_BINS - 1);
                    // An index below the arrays' length: no test is compiled for these `get_mut`s. On a
                    // little-endian processor the key is one 64-bit load: the pair lies in memory as its bytes.
                    if let (Some(n), Some(f)) = (near_of.get_mut(b), far_of.get_mut(b)) {
                        Self::update(n, f, far, key(bits, cell), bits);
                    }
                }
            }
        } else {
            let len = self.len;
            let (near_of, far_of) = (&mut self.near, &mut self.far);
            for ((b, far), near) in bins.iter().zip(far_r2).zip(near_keys) {
                for ((&b, &far), &[bits, cell]) in b.iter().zip(far).zip(near) {
                    let b = b as usize;
                    if let (true, Some(n), Some(f)) = (b < len, near_of.get_mut(b), far_of.get_mut(b)) {
                        Self::update(n, f, far, key(bits, cell), bits);
                    }
                }
            }
        }
    }

    /// One return of [`VisibilityMap::add_binned`] into its bin's nearest obstacle `n` and farthest return `f`.
    #[inline(always)]
    fn update(n: &mut u64, f: &mut f32, far: f32, near: u64, bits: u32) {
        // The farthest return: a `maxss` (neither range is NaN).
        *f = if far > *f { far } else { *f };
        // The nearest obstacle. An empty bin holds `INFINITY`, whose bits are below `u32::MAX`, so a point that is
        // no obstacle never wins. Whether a return is the nearest so far is not predictable in real sweeps: no
        // branch.
        let old = *n;
        // The lower half: the truncation is the point.
        #[allow(clippy::cast_possible_truncation)]
        let old_bits = old as u32;
        *n = core::hint::select_unpredictable(bits < old_bits, near, old);
    }

    /// Folds in a map of the returns that came after this map's (same bins and origin): per bin the farthest of
    /// both, and `other`'s nearest obstacle only where it is strictly nearer by its bits (a tie keeps this map's,
    /// which came first): the map one pass over both sets of returns in order gives. For the rasterize stage on
    /// two threads (`crate::split`).
    pub(crate) fn absorb(&mut self, other: &VisibilityMap) {
        let (o_near, o_far) = other.bins();
        let len = self.len;
        let near = self.near.get_mut(..len).unwrap_or_default();
        for (n, &o) in near.iter_mut().zip(o_near) {
            #[allow(clippy::cast_possible_truncation)]
            if (o as u32) < (*n as u32) {
                *n = o;
            }
        }
        let far = self.far.get_mut(..len).unwrap_or_default();
        for (f, &o) in far.iter_mut().zip(o_far) {
            *f = if o > *f { o } else { *f };
        }
    }

    /// The three arrays (nearest obstacle r^2, its cell, farthest return r^2), for bit-exact comparisons.
    #[cfg(test)]
    pub(crate) fn arrays(&self) -> (Vec<f32>, Vec<u32>, Vec<f32>) {
        let (near, far) = self.bins();
        let bins: Vec<Bin> = Self::records(near, far).collect();
        (
            bins.iter().map(|b| b.nearest_obstacle_r2()).collect(),
            bins.iter().map(|b| b.nearest_obstacle_cell()).collect(),
            bins.iter().map(|b| b.farthest_return_r2).collect(),
        )
    }

    #[inline]
    fn bin(&self, dx: f32, dy: f32) -> usize {
        let b = (diamond_angle(dx, dy) * self.bins_per_unit) as usize;
        b.min(self.len.saturating_sub(1))
    }

    /// Records a return at an ego-frame position; `obstacle` for points in the height band, with the grid
    /// cell it fell in (`NO_CELL` outside the grid).
    #[inline]
    pub fn add_return(&mut self, x: f32, y: f32, obstacle: bool, cell: u32) {
        let dx = x - self.origin[0];
        let dy = y - self.origin[1];
        let r2 = dx * dx + dy * dy;
        let b = self.bin(dx, dy);
        let len = self.len;
        if let (true, Some(near), Some(far)) = (b < len, self.near.get_mut(b), self.far.get_mut(b)) {
            if r2 > *far {
                *far = r2;
            }
            if obstacle && r2 < f32::from_bits(*near as u32) {
                *near = key(r2.to_bits(), cell);
            }
        }
    }

    /// The sensor origin of the current frame, ego frame, metres.
    #[must_use]
    pub fn origin(&self) -> [f32; 2] {
        self.origin
    }

    /// What the sensor saw of an ego-frame position.
    #[must_use]
    #[inline]
    pub fn sight(&self, x: f32, y: f32) -> Sight {
        self.look(x, y).0
    }

    /// [`VisibilityMap::sight`] and, for a visible position, [`VisibilityMap::clearance`]'s distance, from one look
    /// at the bin (the same operations on the same values: the same bits as the two calls).
    #[must_use]
    #[inline]
    pub fn sight_with_clearance(&self, x: f32, y: f32) -> (Sight, Option<f32>) {
        let (sight, r2, bin) = self.look(x, y);
        // Visible means `r2 < near` and `r2 <= far`: `clearance` answers exactly when the bin has an obstacle cell.
        let clearance = (sight == Sight::Visible)
            .then_some(bin)
            .flatten()
            .filter(|b| b.nearest_obstacle_cell() != NO_CELL)
            .map(|b| libm::sqrtf(b.nearest_obstacle_r2()) - libm::sqrtf(r2));
        (sight, clearance)
    }

    /// True only when every position of the axis-aligned box `[x0, y0, x1, y1]` (ego frame) is seen empty with
    /// room to spare: [`VisibilityMap::sight_with_clearance`] of any point in it (or within a millimetre of it),
    /// whatever that look-up's own rounding, is `Visible` with no obstacle in its bin or one more than `margin`
    /// beyond it. A conservative bound for the ghost test ([`crate::Monitor`]'s `hidden_within_margin`): false
    /// whenever it cannot be told cheaply, i.e. when the box holds the sensor, spans more than
    /// [`OPEN_VIEW_MAX_BINS`] bins in a quadrant, or a bin its directions cross (one more on each side, for
    /// rounding) holds no return beyond the box or an obstacle within `margin` (and 0.1 mm) of its far corner.
    #[must_use]
    pub fn box_seen_empty(&self, b: [f32; 4], margin: f32) -> bool {
        if self.len == 0 || !(b.iter().all(|v| v.is_finite()) && margin.is_finite()) {
            return false;
        }
        // Slack for the rounding of the positions the look-ups are given (nearest points of shifted boxes): a
        // millimetre, and more for boxes kilometres out, where an f32 ulp is a millimetre (`open_view_slack_m`).
        let slack = f64::from(open_view_slack_m(b));
        let (ox, oy) = (f64::from(self.origin[0]), f64::from(self.origin[1]));
        let (x0, x1) = (f64::from(b[0]) - ox - slack, f64::from(b[2]) - ox + slack);
        let (y0, y1) = (f64::from(b[1]) - oy - slack, f64::from(b[3]) - oy + slack);
        let straddles = |a0: f64, a1: f64| a0 <= 0.0 && a1 >= 0.0;
        if straddles(x0, x1) && straddles(y0, y1) {
            return false;
        }
        // The farthest squared range in the box, with room for the look-ups' rounding of `dx^2 + dy^2`.
        let (fx, fy) = (x0.abs().max(x1.abs()), y0.abs().max(y1.abs()));
        let r2_up = (fx * fx + fy * fy) * (1.0 + 1e-5);
        // The diamond angle is monotonic within a closed quadrant (the look-ups' `dy >= 0` and `dx >= 0` decide
        // it): the box is cut at the axes it crosses, each part's edge on an axis taken a hair inside the part's
        // quadrant (the angle's limit there: 0 or 4 on the positive x axis, 1, 2 or 3 on the others).
        const HAIR: f64 = 1e-20;
        let xs: &[(f64, f64)] = if straddles(x0, x1) { &[(x0, -HAIR), (0.0, x1)] } else { &[(x0, x1)] };
        let ys: &[(f64, f64)] = if straddles(y0, y1) { &[(y0, -HAIR), (0.0, y1)] } else { &[(y0, y1)] };
        xs.iter()
            .all(|&(a0, a1)| ys.iter().all(|&(c0, c1)| self.quadrant_box_seen_empty([a0, c0, a1, c1], r2_up, margin)))
    }

    /// [`VisibilityMap::box_seen_empty`] of a box (relative to the origin, already widened) within one closed
    /// quadrant, with the squared range bound `r2_up` of the whole box.
    fn quadrant_box_seen_empty(&self, q: [f64; 4], r2_up: f64, margin: f32) -> bool {
        let n = self.len;
        // Within one quadrant the extremes of the angle are at corners; a bin more on each side covers the
        // look-ups' rounding (a few ulps against a bin of 4 / n).
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        #[allow(clippy::cast_possible_truncation)]
        for (x, y) in [(q[0], q[1]), (q[0], q[3]), (q[2], q[1]), (q[2], q[3])] {
            let d = diamond_angle(x as f32, y as f32);
            lo = lo.min(d);
            hi = hi.max(d);
        }
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (b_lo, b_hi) = (
            ((lo * self.bins_per_unit) as usize).saturating_sub(1),
            ((hi * self.bins_per_unit) as usize).saturating_add(1).min(n.saturating_sub(1)),
        );
        if b_hi.saturating_sub(b_lo) > OPEN_VIEW_MAX_BINS {
            return false;
        }
        let r_up = libm::sqrt(r2_up);
        let (near, far) = self.bins();
        let (Some(near), Some(far)) = (near.get(b_lo..=b_hi), far.get(b_lo..=b_hi)) else { return false };
        Self::records(near, far).all(|bin| {
            let near = f64::from(bin.nearest_obstacle_r2());
            f64::from(bin.farthest_return_r2) >= r2_up
                && if bin.nearest_obstacle_cell() == NO_CELL {
                    near > r2_up
                } else {
                    libm::sqrt(near) - r_up > f64::from(margin) + 1e-4
                }
        })
    }

    /// What the sensor saw of a position, its squared range from the sensor and its bin (`None` outside the map).
    #[inline(always)]
    fn look(&self, x: f32, y: f32) -> (Sight, f32, Option<Bin>) {
        let dx = x - self.origin[0];
        let dy = y - self.origin[1];
        let r2 = dx * dx + dy * dy;
        let bin = self.get(self.bin(dx, dy));
        let near = bin.map_or(0.0, |b| b.nearest_obstacle_r2());
        let far = bin.map_or(0.0, |b| b.farthest_return_r2);
        let sight = if r2 >= near {
            Sight::Shadowed(bin.map_or(NO_CELL, |b| b.nearest_obstacle_cell()))
        } else if r2 <= far {
            Sight::Visible
        } else {
            Sight::Unreached
        };
        (sight, r2, bin)
    }

    /// For a visible position, how far in front of the nearest obstacle of its bin it lies, metres, and that
    /// obstacle's grid cell; `None` when the position is not visible or its bin has no obstacle.
    #[must_use]
    pub fn clearance(&self, x: f32, y: f32) -> Option<(f32, u32)> {
        let dx = x - self.origin[0];
        let dy = y - self.origin[1];
        let r2 = dx * dx + dy * dy;
        let bin = self.get(self.bin(dx, dy))?;
        (r2 < bin.nearest_obstacle_r2() && r2 <= bin.farthest_return_r2 && bin.nearest_obstacle_cell() != NO_CELL)
            .then(|| (libm::sqrtf(bin.nearest_obstacle_r2()) - libm::sqrtf(r2), bin.nearest_obstacle_cell()))
    }

    /// The range of the nearest obstacle return in the bin of an ego-frame position, metres, and its grid cell;
    /// `None` when the bin holds no obstacle inside the grid. Exact (the return's own range), not a cell's.
    #[must_use]
    pub fn nearest_obstacle(&self, x: f32, y: f32) -> Option<(f32, u32)> {
        let bin = self.get(self.bin(x - self.origin[0], y - self.origin[1]))?;
        (bin.nearest_obstacle_cell() != NO_CELL)
            .then(|| (libm::sqrtf(bin.nearest_obstacle_r2()), bin.nearest_obstacle_cell()))
    }

    /// Visits the nearest obstacle return (its range, metres, its grid cell, and where it lies, ego frame, taken
    /// along the middle direction of its bin: within half a bin's angle of the return) of every bin whose
    /// directions the corners of a convex polygon span (ego frame), bins without an obstacle inside the grid
    /// left out. Returns
    /// false, visiting nothing, when the corners span half a turn or more (the polygon holds the sensor or
    /// reaches round it). Bounded: at most half the bins, plus one.
    pub fn nearest_obstacles_across(&self, corners: &[[f32; 2]], mut visit: impl FnMut(f32, u32, [f32; 2])) -> bool {
        let angle = |p: &[f32; 2]| diamond_angle(p[0] - self.origin[0], p[1] - self.origin[1]);
        let span = |shift: bool| {
            corners
                .iter()
                .map(angle)
                .map(|a| if shift && a < 2.0 { a + 4.0 } else { a })
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), a| (lo.min(a), hi.max(a)))
        };
        let (mut lo, mut hi) = span(false);
        if hi - lo >= 2.0 {
            (lo, hi) = span(true);
        }
        // No corners leave `lo > hi`. (A corner without a finite direction has the angle 0.)
        if !(lo <= hi && hi - lo < 2.0) {
            return false;
        }
        let n = self.len;
        let (first, last) = ((lo * self.bins_per_unit) as usize, (hi * self.bins_per_unit) as usize);
        for b in first..=last.min(first.saturating_add(n / 2)) {
            if let Some(bin) = self.get(b % n) {
                if bin.nearest_obstacle_cell() != NO_CELL {
                    let r = libm::sqrtf(bin.nearest_obstacle_r2());
                    let d = diamond_direction(((b % n) as f32 + 0.5) / self.bins_per_unit);
                    visit(r, bin.nearest_obstacle_cell(), [self.origin[0] + r * d[0], self.origin[1] + r * d[1]]);
                }
            }
        }
        true
    }

    /// True when the ego-frame position is visible: before the nearest obstacle and the farthest return of
    /// its bin.
    #[must_use]
    #[inline]
    pub fn is_visible(&self, x: f32, y: f32) -> bool {
        self.sight(x, y) == Sight::Visible
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::unit_draws;

    /// `add_binned` keeps the nearest obstacle by the strict comparison of the ranges' bits, whatever the cells:
    /// equal ranges keep the bin's obstacle, and `u32::MAX` (no obstacle) never wins, not even over an empty bin;
    /// a winner's key is its range's bits and its cell, as `key` builds it.
    #[test]
    fn keys_compare_as_their_ranges() {
        let ranges =
            [0u32, 1, 2, 0x3F80_0000, f32::INFINITY.to_bits() - 1, f32::INFINITY.to_bits(), u32::MAX - 1, u32::MAX];
        let cells = [0u32, 1, 77, NO_CELL - 1, NO_CELL];
        for &r_new in &ranges {
            for &r_old in &ranges {
                for &c_new in &cells {
                    for &c_old in &cells {
                        let mut map = VisibilityMap::new(1);
                        if let Some(n) = map.near.get_mut(0) {
                            *n = key(r_old, c_old);
                        }
                        map.add_binned(&[0; 64], &[0.0; 64], &[[r_new, c_new]; 64]);
                        let want = if r_new < r_old { (r_new, c_new) } else { (r_old, c_old) };
                        let bin = map.get(0).unwrap();
                        assert_eq!((bin.nearest_r2_bits(), bin.nearest_obstacle_cell()), want);
                    }
                }
            }
        }
        let mut map = VisibilityMap::new(1);
        map.add_binned(&[0; 64], &[0.0; 64], &[[u32::MAX, 5]; 64]);
        assert_eq!(map.get(0), Some(Bin::EMPTY), "no obstacle never wins");
    }

    /// `add_binned` on the fixed-size arrays (maps of up to `FAST_BINS` bins, bins masked with `FAST_BINS - 1`)
    /// and on a larger map (bounds tested) is the straightforward update of one record per bin, return by return:
    /// random blocks with many ties, bins up to the last, the first and the last bin of each map. Fails when the
    /// fast path reads a bin by other bits than its own (e.g. `b & 511`), when a map of more than `FAST_BINS` bins
    /// takes the fast path, or when a tie goes to the later return.
    #[test]
    fn updates_by_masked_bins_are_the_updates_of_records() {
        let mut draws = unit_draws(17);
        let mut draw = |n: usize| {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let v = ((f64::from(draws()) * n as f64) as usize).min(n - 1);
            v
        };
        for bins in [1u32, 2, 720, 1023, 1024, 1025, 2048, 4096, 65_535, 65_536, 70_000] {
            let n = bins as usize;
            let mut map = VisibilityMap::new(bins);
            // Memory proportional to the map: the fixed capacity up to it, one entry per bin beyond.
            assert_eq!((map.near.len(), map.far.len()), (n.max(FAST_BINS), n.max(FAST_BINS)), "{bins} bins");
            let mut want = vec![Bin::EMPTY; n];
            for block in 0..40 {
                let mut b = [0u32; 64];
                let mut far = [0.0f32; 64];
                let mut near = [[0u32; 2]; 64];
                for i in 0..64 {
                    // A few bins per block (ties and repeats), the first and the last among them.
                    let pick = [0, n - 1, draw(n), draw(n)];
                    b[i] = pick[draw(4)] as u32;
                    far[i] = if draw(3) == 0 { 0.0 } else { draw(50) as f32 * 0.5 };
                    let bits = if draw(4) == 0 { u32::MAX } else { (draw(20) as f32 * 0.25).to_bits() };
                    near[i] = [bits, (block * 64 + i) as u32];
                }
                map.add_binned(&b, &far, &near);
                for i in 0..64 {
                    let w = &mut want[b[i] as usize];
                    if far[i] > w.farthest_return_r2 {
                        w.farthest_return_r2 = far[i];
                    }
                    if near[i][0] < w.nearest_r2_bits() {
                        w.nearest_obstacle = key(near[i][0], near[i][1]);
                    }
                }
            }
            let got: Vec<Bin> = (0..n).map(|b| map.get(b).unwrap()).collect();
            assert_eq!(got, want, "{bins} bins");
            assert_eq!(map.get(n), None);
            map.reset([0.0, 0.0]);
            assert!((0..n).all(|b| map.get(b) == Some(Bin::EMPTY)), "{bins} bins after a reset");
        }
    }

    /// `box_seen_empty` is sound: wherever it answers true, every point of the box and of a half-millimetre rim
    /// around it (its corners, its edges, points on the axes through the origin, random points) is `Visible` with
    /// no obstacle in its bin or one more than the margin beyond it. On random maps of walls and open ground, with
    /// boxes near and far, across the axes and holding the origin; both answers occur, and boxes that straddle an
    /// axis are answered true too (the cut at the axes, not a refusal).
    #[test]
    fn a_box_seen_empty_is_seen_empty_at_every_point() {
        let mut next = unit_draws(0x9E37_79B9_7F4A_7C15);
        let (mut yes, mut no, mut yes_straddling) = (0usize, 0usize, 0usize);
        for round in 0..300 {
            let bins = [720u32, 360, 64, 4096][round % 4];
            let mut v = VisibilityMap::new(bins);
            let origin = if round % 3 == 0 { [0.0, 0.0] } else { [next() * 4.0 - 2.0, next() * 4.0 - 2.0] };
            v.reset(origin);
            // Open ground out to 30-60 m all round, and a few walls (obstacles) at random places.
            let reach = 30.0 + next() * 30.0;
            for k in 0..4000 {
                let a = k as f32 / 4000.0 * core::f32::consts::TAU;
                let r = reach * (0.9 + 0.1 * next());
                v.add_return(origin[0] + r * libm::cosf(a), origin[1] + r * libm::sinf(a), false, NO_CELL);
            }
            for _ in 0..(round % 7) {
                let (cx, cy) = (next() * 60.0 - 30.0, next() * 60.0 - 30.0);
                for _ in 0..40 {
                    v.add_return(cx + next() * 2.0 - 1.0, cy + next() * 2.0 - 1.0, true, 7);
                }
            }
            for _ in 0..40 {
                let (w, h) = (0.2 + next() * 6.0, 0.2 + next() * 6.0);
                let (x, y) = if next() < 0.3 {
                    // Across an axis through the origin (or round the origin itself).
                    (origin[0] - next() * w, origin[1] + next() * 30.0 - 15.0)
                } else {
                    (next() * 60.0 - 30.0, next() * 60.0 - 30.0)
                };
                let (x, y) = if next() < 0.5 { (x, y) } else { (y, x) };
                let b = [x, y, x + w, y + h];
                let margin = next() * 1.2;
                if !v.box_seen_empty(b, margin) {
                    no += 1;
                    continue;
                }
                yes += 1;
                let straddles = |lo: f32, hi: f32, o: f32| lo <= o && hi >= o;
                if straddles(b[0], b[2], origin[0]) || straddles(b[1], b[3], origin[1]) {
                    yes_straddling += 1;
                }
                let rim = 5e-4;
                let (x0, y0, x1, y1) = (b[0] - rim, b[1] - rim, b[2] + rim, b[3] + rim);
                let mut points = vec![(x0, y0), (x0, y1), (x1, y0), (x1, y1), (origin[0], y0), (origin[0], y1)];
                points.extend([(x0, origin[1]), (x1, origin[1]), (origin[0], origin[1])]);
                for _ in 0..200 {
                    points.push((x0 + next() * (x1 - x0), y0 + next() * (y1 - y0)));
                }
                for (px, py) in points {
                    if !(x0 <= px && px <= x1 && y0 <= py && py <= y1) {
                        continue;
                    }
                    let (sight, clearance) = v.sight_with_clearance(px, py);
                    assert_eq!(sight, Sight::Visible, "round {round}, box {b:?}, point ({px}, {py})");
                    assert!(
                        clearance.is_none_or(|c| c > margin),
                        "round {round}, box {b:?}, ({px}, {py}): {clearance:?}"
                    );
                }
            }
        }
        assert!(
            yes > 500 && no > 500 && yes_straddling > 20,
            "true {yes}, false {no}, true across an axis {yes_straddling}"
        );
    }

    /// `sight_with_clearance` gives `sight` and `clearance`'s distance, bit for bit, at random positions of random
    /// maps (also empty bins, obstacle-free bins and positions at the origin).
    #[test]
    fn sight_with_clearance_equals_sight_and_clearance() {
        let mut next = unit_draws(0x2545_F491_4F6C_DD1D);
        for round in 0..50 {
            let mut v = VisibilityMap::new(16 + round * 13);
            v.reset([next() * 4.0 - 2.0, next() * 4.0 - 2.0]);
            for _ in 0..(round * 7) {
                let (x, y) = (next() * 80.0 - 40.0, next() * 80.0 - 40.0);
                let obstacle = next() < 0.5;
                let cell = if next() < 0.2 { NO_CELL } else { (next() * 1000.0) as u32 };
                v.add_return(x, y, obstacle, cell);
            }
            for k in 0..400 {
                let (x, y) =
                    if k == 0 { (v.origin[0], v.origin[1]) } else { (next() * 90.0 - 45.0, next() * 90.0 - 45.0) };
                let (sight, clearance) = v.sight_with_clearance(x, y);
                assert_eq!(sight, v.sight(x, y));
                let want = if sight == Sight::Visible { v.clearance(x, y).map(|(c, _)| c.to_bits()) } else { None };
                assert_eq!(clearance.map(f32::to_bits), want, "round {round}, ({x}, {y})");
            }
        }
    }

    /// `nearest_obstacles_across` visits exactly the bins whose directions a polygon spans, across the wrap of the
    /// angle at +x too, each with its return's range and a position within half a bin's angle of the return; and
    /// visits nothing for a polygon round the sensor.
    #[test]
    fn nearest_obstacles_across_visits_the_bins_a_polygon_spans() {
        let mut v = VisibilityMap::new(720);
        v.reset([1.0, -2.0]);
        // One obstacle every degree, 20 m out, cell = degree.
        for deg in 0..360u32 {
            let a = (deg as f32 + 0.25).to_radians();
            v.add_return(1.0 + 20.0 * a.cos(), -2.0 + 20.0 * a.sin(), true, deg);
        }
        let square =
            |cx: f32, cy: f32, h: f32| [[cx - h, cy - h], [cx + h, cy - h], [cx + h, cy + h], [cx - h, cy + h]];
        for (centre, wrap) in [([11.0f32, 8.0f32], false), ([11.0, -2.0], true), ([-9.0, -2.0], false)] {
            let mut seen = Vec::new();
            assert!(v.nearest_obstacles_across(&square(centre[0], centre[1], 1.0), |r, cell, p| {
                assert!((r - 20.0).abs() < 1e-3, "{r}");
                let a = (cell as f32 + 0.25).to_radians();
                let d = ((p[0] - 1.0 - 20.0 * a.cos()).powi(2) + (p[1] + 2.0 - 20.0 * a.sin()).powi(2)).sqrt();
                assert!(d < 20.0 * 0.5f32.to_radians(), "cell {cell}: {p:?} is {d} m from its return");
                seen.push(cell);
            }));
            // The square 10 m out, 2 m wide, spans about 11.4 degrees: the degrees whose returns fall in its span.
            let bearing = (centre[1] + 2.0).atan2(centre[0] - 1.0).to_degrees();
            assert!((10..=13).contains(&seen.len()), "{centre:?}: {seen:?}");
            for cell in &seen {
                let off = (*cell as f32 + 0.25 - bearing + 540.0).rem_euclid(360.0) - 180.0;
                assert!(off.abs() < 7.0, "{centre:?}: cell {cell} is {off} degrees off the bearing {bearing}");
            }
            assert_eq!(seen.iter().any(|&c| c > 300) && seen.iter().any(|&c| c < 60), wrap, "{seen:?}");
        }
        assert!(!v.nearest_obstacles_across(&square(1.0, -2.0, 1.0), |_, _, _| panic!("round the sensor")));
        assert!(!v.nearest_obstacles_across(&[], |_, _, _| panic!("no corners")));
    }

    #[test]
    fn shadow_behind_obstacle_and_reach_of_ground() {
        let mut v = VisibilityMap::new(1024);
        v.reset([0.0, 0.0]);
        v.add_return(10.0, 0.0, true, 42); // obstacle at 10 m straight ahead
        v.add_return(30.0, 0.0, false, NO_CELL); // ground return at 30 m behind it (other beam)
        v.add_return(0.0, 20.0, false, NO_CELL); // ground at 20 m to the left
        assert!(v.is_visible(5.0, 0.0));
        assert_eq!(v.sight(15.0, 0.0), Sight::Shadowed(42), "in the obstacle's shadow");
        assert!(v.is_visible(0.0, 15.0));
        assert_eq!(v.sight(0.0, 25.0), Sight::Unreached, "beyond the farthest return");
        assert!(!v.is_visible(-10.0, 0.0), "no return in that direction");
    }
}
