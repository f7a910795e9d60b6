//! The frame's region of interest (map polygons) for the conflict clusters: where a cell's square lies against it
//! ([`RoiSide`]) and whether a return lies inside it, each the same answer as the test against every polygon
//! ([`roi_cell_side`], [`roi_contains`], kept as the reference and the fallback), at the cost of the few polygon
//! edges near the cell's row. Part of [`super::Monitor`]; `clusters.rs` keeps the cluster stage that asks.
//!
//! [`RoiIndex::build`] puts each polygon edge, once per frame, into the grid rows whose band (widened by half a
//! cell diagonal less half a cell, and a rounding margin) its `y` extent meets: a counting sort into one buffer
//! reserved at construction ([`ROI_EDGES`] entries, [`ROI_BOXES`] polygons). A frame with more, or with a
//! coordinate that is not finite or beyond [`MAX_COORDINATE_M`], is answered by the reference functions instead:
//! the same answers, slower.
//!
//! Why a row's edges give the reference's answer bit for bit (the edges are tested by the same functions,
//! `edge_crosses_ray` and `offset_from_segment`, with the same arguments in the same orientation; the results are
//! combined by exclusive or, which does not depend on the order, and by comparisons of the minimum with `r^2`):
//! - a return that `GridGeometry::point_to_cell` put in row `r` has its `y` in the row's band up to rounding far
//!   below `margin`; an edge left out of the row lies entirely above or entirely below that `y`, so it does not
//!   cross the ray from the return (`(yi > y) != (yj > y)` is false for it): the even-odd parity of the row's
//!   edges is the polygon's;
//! - a cell centre lies half a cell from its row's borders; an edge left out of the row lies more than half a
//!   cell diagonal plus `margin` above or below it: it does not cross the centre's ray either, and its computed
//!   offset has `|dy| > half_diagonal` (the rounding error of the offset, a few units in the last place of
//!   coordinates below `MAX_COORDINATE_M`, stays below `margin`), so its squared distance is at least
//!   `half_diagonal^2` after rounding (rounding is monotonic): it never makes a cell [`RoiSide::Edge`], and the
//!   minimum over the row's edges compares with `half_diagonal^2` as the minimum over all edges does.
//!
//! The polygons' bounding boxes skip polygons exactly where the reference skips them.
//!
//! Within a row, [`RoiIndex::cell_side`] tests an edge in full only when its `x` extent comes within half a cell
//! diagonal plus `margin` of the cell centre. An edge whose `x` extent ends more
//! than that to the left of the point does not cross the ray towards `+x` (the computed crossing,
//! `xi + t (xj - xi)` with `0 <= t <= 1` after rounding, stays within the edge's `x` extent up to a few units in
//! the last place of `MAX_COORDINATE_M`-bounded coordinates, below `margin`), and its computed offset has
//! `|dx| > half_diagonal` (as for `dy` above), so its squared distance changes no comparison with
//! `half_diagonal^2`. An edge that begins more than that to the right of the point crosses the ray exactly when
//! its ends lie on either side of the point's `y` (the computed crossing lies to the right of the point), which
//! is the first half of `edge_crosses_ray`; its distance again changes no comparison. So these edges need no
//! division. (An entry keeps its edge's `x` extent and that first half at its row's centres, computed once as the
//! index is built: the same values, not recomputed for every cell of the row.) Tested with the rest: every cell of random grids and polygons, and edges placed at half a cell
//! diagonal (and a few units in the last place beside it) from cell centres. ([`RoiIndex::contains`] tests every
//! edge of the row: its calls are few, and the same skip made it no cheaper.)

use alloc::vec::Vec;

use crate::geometry::{edge_crosses_ray, offset_from_segment, polygon_edges};
use crate::grid::GridGeometry;

/// Where a cell's square lies against the region of interest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum RoiSide {
    /// Its centre lies inside a polygon, at least half a cell diagonal from every edge: the whole square is.
    Inside,
    /// Its centre lies within half a cell diagonal of some polygon's edge: its returns decide.
    Edge,
    /// No part of the square reaches a polygon.
    Outside,
}

/// How many region-of-interest polygons have their bounding box kept per frame (memory reserved at
/// construction); a frame with more tests the others without the box first, with the same result, and is not
/// indexed by rows.
pub(super) const ROI_BOXES: usize = 512;

/// How many (edge, row) entries the row index of a frame holds (memory reserved at construction: 32 bytes each).
/// Argoverse 2 frames need a few thousand; a frame that needs more is answered by the reference functions.
pub(super) const ROI_EDGES: usize = 1 << 15;

/// Polygons with a coordinate beyond this (metres, ego frame) are not indexed (the rounding argument of the
/// module documentation is made for coordinates below it).
pub(super) const MAX_COORDINATE_M: f32 = 1.0e6;

/// The bounding box `[min x, min y, max x, max y]` of a polygon.
pub(super) fn polygon_box(poly: &[[f32; 2]]) -> [f32; 4] {
    let mut b = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
    for p in poly {
        b = [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])];
    }
    b
}

/// True when `(x, y)` lies within `margin` of the box (false for NaN).
#[inline]
fn near_box(b: &[f32; 4], x: f32, y: f32, margin: f32) -> bool {
    // `&`: four cheap comparisons, one branch on their outcome.
    (x >= b[0] - margin) & (x <= b[2] + margin) & (y >= b[1] - margin) & (y <= b[3] + margin)
}

/// [`RoiSide`] of the cell centred at `(x, y)`, against every polygon; each polygon's bounding box first (most
/// are far away). `boxes` holds the bounding boxes of the first polygons (see [`ROI_BOXES`]). The reference of
/// [`RoiIndex::cell_side`].
pub(super) fn roi_cell_side(roi: &[&[[f32; 2]]], boxes: &[[f32; 4]], x: f32, y: f32, half_diagonal: f32) -> RoiSide {
    let mut side = RoiSide::Outside;
    let r2 = half_diagonal * half_diagonal;
    for (k, poly) in roi.iter().enumerate() {
        let b = boxes.get(k).copied().unwrap_or_else(|| polygon_box(poly));
        if !near_box(&b, x, y, half_diagonal) {
            continue;
        }
        let (inside, d2) = crate::geometry::polygon_side_and_edge_distance2(poly, x, y);
        if inside && d2 >= r2 {
            return RoiSide::Inside;
        }
        if d2 < r2 {
            side = RoiSide::Edge;
        }
    }
    side
}

/// True when `(x, y)` lies inside one of the polygons (even-odd rule each), the bounding boxes first. The
/// reference of [`RoiIndex::contains`].
pub(super) fn roi_contains(roi: &[&[[f32; 2]]], boxes: &[[f32; 4]], x: f32, y: f32) -> bool {
    roi.iter().enumerate().any(|(k, poly)| {
        boxes.get(k).is_none_or(|b| near_box(b, x, y, 0.0)) && crate::geometry::polygon_contains(poly, x, y)
    })
}

/// One polygon edge in one row: the edge from `from` to `to` as `polygon_edges` gives it, and its polygon; with
/// what [`RoiIndex::cell_side`] reads of it for every cell of the row, computed once as the entry is made: its `x`
/// extent `[min, max]` and whether its ends lie on either side of the row's cell centres (`(to.y > y) != (from.y >
/// y)` at the centres' `y`, `GridGeometry::cell_center_axis(row)`, the test `edge_crosses_ray` begins with).
#[derive(Clone, Copy, Debug)]
struct Entry {
    from: [f32; 2],
    to: [f32; 2],
    x_extent: [f32; 2],
    polygon: u32,
    straddles_centres: bool,
}

const NO_ENTRY: Entry =
    Entry { from: [0.0; 2], to: [0.0; 2], x_extent: [0.0; 2], polygon: 0, straddles_centres: false };

/// The frame's region-of-interest polygons, their bounding boxes and their edges by grid row (see the module
/// documentation). Built once per frame by [`RoiIndex::build`]; no allocation after [`RoiIndex::new`].
#[derive(Debug)]
pub(super) struct RoiIndex {
    geometry: GridGeometry,
    half_diagonal: f32,
    /// The bounding boxes of the frame's polygons (the first [`ROI_BOXES`]).
    boxes: Vec<[f32; 4]>,
    /// Row `r`'s entries are `entries[row_start[r]..row_start[r + 1]]`, in polygon order.
    row_start: Vec<u32>,
    entries: Vec<Entry>,
    /// The frame's polygons are in `entries` (else the reference functions answer).
    indexed: bool,
    /// The rounding margin of the frame (see the module documentation).
    margin: f32,
}

impl RoiIndex {
    /// Reserves the buffers for a grid.
    pub(super) fn new(geometry: GridGeometry) -> Self {
        Self {
            geometry,
            half_diagonal: core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m,
            boxes: Vec::with_capacity(ROI_BOXES),
            row_start: alloc::vec![0; geometry.cells_per_side as usize + 1],
            entries: Vec::with_capacity(ROI_EDGES),
            indexed: false,
            margin: 0.0,
        }
    }

    /// The rows `(first, last)` whose band, widened by `reach`, meets the edge's `y` extent; `None` when none.
    fn rows(&self, from: [f32; 2], to: [f32; 2], reach: f32) -> Option<(usize, usize)> {
        let g = &self.geometry;
        let n = g.cells_per_side as f32;
        let lo = (from[1].min(to[1]) - reach - g.origin_m) / g.cell_size_m;
        let hi = (from[1].max(to[1]) + reach - g.origin_m) / g.cell_size_m;
        if !(hi >= 0.0 && lo < n) {
            return None;
        }
        // Saturating casts of values in [0, n).
        Some((lo.max(0.0) as usize, hi.min(n - 1.0) as usize))
    }

    /// Indexes a frame's polygons (bounded by [`ROI_BOXES`] polygons and [`ROI_EDGES`] entries; beyond, or with a
    /// coordinate that is not finite or beyond [`MAX_COORDINATE_M`], the frame is left to the reference functions).
    pub(super) fn build(&mut self, roi: &[&[[f32; 2]]]) {
        self.boxes.clear();
        self.entries.clear();
        self.indexed = false;
        for poly in roi.iter().take(ROI_BOXES) {
            self.boxes.push(polygon_box(poly));
        }
        if roi.is_empty() || roi.len() > ROI_BOXES {
            return;
        }
        let finite = roi.iter().flat_map(|p| p.iter()).all(|v| {
            v[0].is_finite() && v[1].is_finite() && v[0].abs() <= MAX_COORDINATE_M && v[1].abs() <= MAX_COORDINATE_M
        });
        if !finite {
            return;
        }
        // The largest magnitude a tested point or a vertex can have (returns lie in the grid).
        let mut max_abs = 0.5 * self.geometry.size_m() + self.geometry.cell_size_m;
        for b in &self.boxes {
            max_abs = b.iter().fold(max_abs, |m, v| m.max(v.abs()));
        }
        // Rounding margin (see the module documentation): far above a few units in the last place of `max_abs`
        // (2^-14 against 2^-24 relative), and a 64th of a cell for the row of a return.
        let margin = self.geometry.cell_size_m / 64.0 + max_abs * (1.0 / 16384.0);
        self.margin = margin;
        // A cell centre lies half a cell inside its row: edges within half a diagonal of it reach the row's band
        // widened by half a diagonal less half a cell.
        let reach = (self.half_diagonal - 0.5 * self.geometry.cell_size_m).max(0.0) + 2.0 * margin;
        let rows = self.geometry.cells_per_side as usize;
        // Counting sort: entries per row, then the starts, then the entries in polygon order.
        self.row_start.iter_mut().for_each(|s| *s = 0);
        let mut total = 0usize;
        for poly in roi {
            for (from, to) in polygon_edges(poly) {
                let Some((r0, r1)) = self.rows(from, to, reach) else { continue };
                total += r1 + 1 - r0;
                if total > ROI_EDGES {
                    return;
                }
                for r in r0..=r1 {
                    if let Some(c) = self.row_start.get_mut(r + 1) {
                        *c += 1;
                    }
                }
            }
        }
        for r in 0..rows {
            let before = self.row_start.get(r).copied().unwrap_or(0);
            if let Some(c) = self.row_start.get_mut(r + 1) {
                *c += before;
            }
        }
        // `row_start[r]` serves as row r's cursor; afterwards it holds row r's end, which is row r + 1's start.
        self.entries.resize(total, NO_ENTRY);
        for (k, poly) in roi.iter().enumerate() {
            for (from, to) in polygon_edges(poly) {
                let Some((r0, r1)) = self.rows(from, to, reach) else { continue };
                let x_extent = [from[0].min(to[0]), from[0].max(to[0])];
                for r in r0..=r1 {
                    // `r` is below `cells_per_side` (`rows`): the cast is exact.
                    #[allow(clippy::cast_possible_truncation)]
                    let y = self.geometry.cell_center_axis(r as u32);
                    let straddles_centres = (to[1] > y) != (from[1] > y);
                    let Some(cursor) = self.row_start.get_mut(r) else { continue };
                    if let Some(e) = self.entries.get_mut(*cursor as usize) {
                        *e = Entry { from, to, x_extent, polygon: k as u32, straddles_centres };
                    }
                    *cursor += 1;
                }
            }
        }
        for r in (0..rows).rev() {
            let start = if r == 0 { 0 } else { self.row_start.get(r - 1).copied().unwrap_or(0) };
            if let Some(s) = self.row_start.get_mut(r) {
                *s = start;
            }
        }
        if let Some(end) = self.row_start.get_mut(rows) {
            *end = total as u32;
        }
        self.indexed = true;
    }

    /// The entries of the row of cell `cell`.
    fn row_entries(&self, cell: u32) -> &[Entry] {
        let row = (cell / self.geometry.cells_per_side.max(1)) as usize;
        let (Some(&a), Some(&b)) = (self.row_start.get(row), self.row_start.get(row + 1)) else { return &[] };
        self.entries.get(a as usize..b as usize).unwrap_or(&[])
    }

    /// The indexed edges of `cell`'s row, one run per polygon: `(polygon, its edges)`.
    fn polygon_groups(&self, cell: u32) -> impl Iterator<Item = (u32, &[Entry])> {
        self.row_entries(cell).chunk_by(|a, b| a.polygon == b.polygon).map(|g| (g.first().map_or(0, |e| e.polygon), g))
    }

    /// [`roi_cell_side`] of cell `cell` at its centre (`GridGeometry::cell_center`, whose `y` the entries of its
    /// row were made for).
    pub(super) fn cell_side(&self, roi: &[&[[f32; 2]]], cell: u32) -> RoiSide {
        let (x, y) = self.geometry.cell_center(cell);
        if !self.indexed {
            return roi_cell_side(roi, &self.boxes, x, y, self.half_diagonal);
        }
        let hd = self.half_diagonal;
        let r2 = hd * hd;
        // Edges whose `x` extent ends left of `lo` or begins right of `hi` need no division (module documentation).
        let (lo, hi) = (x - hd - self.margin, x + hd + self.margin);
        let mut side = RoiSide::Outside;
        for (k, group) in self.polygon_groups(cell) {
            if !self.boxes.get(k as usize).is_some_and(|b| near_box(b, x, y, hd)) {
                continue;
            }
            let (inside, d2) = group.iter().fold((false, f32::INFINITY), |(inside, best), e| {
                let [x0, x1] = e.x_extent;
                if (x1 < lo) | (x0 > hi) {
                    let crosses = (x0 > hi) & e.straddles_centres;
                    return (inside != crosses, best);
                }
                let (dx, dy) = offset_from_segment(e.from, e.to, x, y);
                (inside != edge_crosses_ray(e.from, e.to, x, y), best.min(dx * dx + dy * dy))
            });
            if inside && d2 >= r2 {
                return RoiSide::Inside;
            }
            if d2 < r2 {
                side = RoiSide::Edge;
            }
        }
        side
    }

    /// [`roi_contains`] for a return at `(x, y)` that `GridGeometry::point_to_cell` puts in cell `cell`.
    pub(super) fn contains(&self, roi: &[&[[f32; 2]]], cell: u32, x: f32, y: f32) -> bool {
        if !self.indexed {
            return roi_contains(roi, &self.boxes, x, y);
        }
        for (k, group) in self.polygon_groups(cell) {
            if self.boxes.get(k as usize).is_some_and(|b| near_box(b, x, y, 0.0))
                && group.iter().fold(false, |inside, e| inside != edge_crosses_ray(e.from, e.to, x, y))
            {
                return true;
            }
        }
        false
    }
}

/// For tests, here and in other crates (`pmon-bench` runs it on the Argoverse 2 map frames): indexes `roi` for a
/// grid of `geometry` and compares [`RoiIndex::cell_side`] with [`roi_cell_side`] on every cell of the grid, and
/// [`RoiIndex::contains`] with [`roi_contains`] at every point of `points` that lies in the grid (ego frame,
/// metres). Returns whether the polygons were indexed and the first disagreement, if any, as text.
#[doc(hidden)]
#[must_use]
pub fn roi_index_mismatch(
    roi: &[&[[f32; 2]]],
    geometry: GridGeometry,
    points: &[[f32; 2]],
) -> (bool, Option<alloc::string::String>) {
    let mut index = RoiIndex::new(geometry);
    index.build(roi);
    let hd = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
    for cell in 0..u32::try_from(geometry.cell_count()).unwrap_or(u32::MAX) {
        let (x, y) = geometry.cell_center(cell);
        let (got, want) = (index.cell_side(roi, cell), roi_cell_side(roi, &index.boxes, x, y, hd));
        if got != want {
            return (index.indexed, Some(alloc::format!("cell {cell} at ({x}, {y}): {got:?}, reference {want:?}")));
        }
    }
    for &[x, y] in points {
        let Some(cell) = geometry.point_to_cell(x, y) else { continue };
        let (got, want) = (index.contains(roi, cell, x, y), roi_contains(roi, &index.boxes, x, y));
        if got != want {
            return (index.indexed, Some(alloc::format!("point ({x}, {y}) in cell {cell}: {got}, reference {want}")));
        }
    }
    (index.indexed, None)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use alloc::vec;

    /// A small deterministic generator (xorshift64*); the monitor's own tests use it too.
    pub(in crate::monitor) struct Rng(pub(in crate::monitor) u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }
        /// Uniform in `[lo, hi)`.
        pub(in crate::monitor) fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * ((self.next() >> 40) as f32 / (1u64 << 24) as f32)
        }
        pub(in crate::monitor) fn below(&mut self, n: u64) -> u64 {
            self.next() % n.max(1)
        }
    }

    /// A random polygon within `extent` of the origin: a star around a random centre (simple), or random points
    /// (self-intersecting), with its vertices snapped to a lattice of a quarter cell half of the time (vertices on
    /// cell centres, corners and borders; edges along cell rows and columns).
    fn polygon(rng: &mut Rng, extent: f32, cell: f32) -> Vec<[f32; 2]> {
        let n = 3 + rng.below(40) as usize;
        let snap = rng.below(2) == 0;
        let (cx, cy) = (rng.range(-extent, extent), rng.range(-extent, extent));
        let star = rng.below(3) != 0;
        let mut v: Vec<[f32; 2]> = (0..n)
            .map(|i| {
                if star {
                    let a = core::f32::consts::TAU * (i as f32 + rng.range(0.0, 0.9)) / n as f32;
                    let r = rng.range(0.2, extent);
                    [cx + r * libm::cosf(a), cy + r * libm::sinf(a)]
                } else {
                    [rng.range(-extent, extent), rng.range(-extent, extent)]
                }
            })
            .collect();
        if snap {
            let q = 0.25 * cell;
            for p in &mut v {
                *p = [libm::roundf(p[0] / q) * q, libm::roundf(p[1] / q) * q];
            }
        }
        if rng.below(4) == 0 {
            // Repeated vertices: zero-length edges.
            let p = v[0];
            v.insert(1, p);
        }
        v
    }

    /// Points that stress the tests: random ones, cell centres and corners, every vertex, edge midpoints and
    /// points a few units in the last place beside them.
    fn points(rng: &mut Rng, polys: &[Vec<[f32; 2]>], geometry: GridGeometry) -> Vec<[f32; 2]> {
        let half = 0.5 * geometry.size_m();
        let mut pts = Vec::new();
        for _ in 0..2000 {
            pts.push([rng.range(-half, half), rng.range(-half, half)]);
        }
        let n = geometry.cells_per_side;
        for _ in 0..500 {
            let (ix, iy) = (rng.below(u64::from(n)) as u32, rng.below(u64::from(n)) as u32);
            let (x, y) = (geometry.cell_center_axis(ix), geometry.cell_center_axis(iy));
            let h = 0.5 * geometry.cell_size_m;
            pts.extend([[x, y], [x - h, y - h], [x - h, y], [x, y - h]]);
        }
        for poly in polys {
            for (a, b) in polygon_edges(poly) {
                let m = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
                for p in [a, m] {
                    pts.push(p);
                    pts.push([f32::from_bits(p[0].to_bits() + 1), p[1]]);
                    pts.push([p[0], f32::from_bits(p[1].to_bits().wrapping_sub(1))]);
                }
            }
        }
        pts
    }

    fn check(polys: &[Vec<[f32; 2]>], geometry: GridGeometry, pts: &[[f32; 2]]) -> bool {
        let roi: Vec<&[[f32; 2]]> = polys.iter().map(Vec::as_slice).collect();
        let (indexed, mismatch) = roi_index_mismatch(&roi, geometry, pts);
        assert_eq!(mismatch, None, "polygons {polys:?}");
        indexed
    }

    #[test]
    fn the_row_index_answers_as_the_test_against_every_polygon() {
        let mut rng = Rng(0x5EED_0001);
        let mut indexed = 0;
        for case in 0..120 {
            let (cell, n) = [(0.5, 40), (0.2, 60), (0.1, 50), (0.5, 200)][case % 4];
            let geometry = GridGeometry::new(n, cell);
            let extent = 0.6 * geometry.size_m();
            let polys: Vec<Vec<[f32; 2]>> = (0..1 + rng.below(6)).map(|_| polygon(&mut rng, extent, cell)).collect();
            let pts = points(&mut rng, &polys, geometry);
            indexed += usize::from(check(&polys, geometry, &pts));
        }
        // The index itself is what is compared (not the fallback).
        assert!(indexed >= 115, "only {indexed} of 120 frames indexed");
    }

    #[test]
    fn edges_along_cell_rows_columns_and_through_centres_agree() {
        // Axis-aligned rectangles on cell borders, on cell centres, and a quarter cell off; a diamond through
        // cell corners; a diagonal edge through cell centres.
        let geometry = GridGeometry::new(40, 0.5);
        let mut polys = Vec::new();
        for off in [0.0f32, 0.25, 0.125, 0.0625] {
            polys.push(vec![
                [-5.0 + off, -4.0 + off],
                [5.0 + off, -4.0 + off],
                [5.0 + off, 4.0 + off],
                [-5.0 + off, 4.0 + off],
            ]);
        }
        polys.push(vec![[0.0, -6.0], [6.0, 0.0], [0.0, 6.0], [-6.0, 0.0]]);
        polys.push(vec![[-9.75, -9.75], [9.75, 9.75], [9.75, -9.75]]);
        let mut rng = Rng(7);
        for poly in &polys {
            let one = [poly.clone()];
            let pts = points(&mut rng, &one, geometry);
            assert!(check(&one, geometry, &pts));
        }
        let pts = points(&mut rng, &polys, geometry);
        assert!(check(&polys, geometry, &pts));
    }

    #[test]
    fn edges_that_end_half_a_diagonal_from_cell_centres_agree() {
        // The edges skipped by their `x` extent: vertical edges and edge ends at half a cell diagonal from a cell
        // centre, at that plus the index's rounding margin, and a few units in the last place on either side of
        // both, left and right of the centre, in straight and slanted polygons.
        let up = |v: f32, k: i32| f32::from_bits((v.to_bits() as i32 + k) as u32);
        for (n, cell) in [(40u32, 0.5f32), (60, 0.2), (50, 0.1)] {
            let geometry = GridGeometry::new(n, cell);
            let hd = core::f32::consts::FRAC_1_SQRT_2 * cell;
            let (cx, cy) = (geometry.cell_center_axis(n / 2 + 1), geometry.cell_center_axis(n / 2 - 2));
            let mut index = RoiIndex::new(geometry);
            index.build(&[&[[cx - 1.0, cy - 1.0], [cx + 1.0, cy - 1.0], [cx, cy + 1.0]]]);
            let margin = index.margin;
            let mut rng = Rng(u64::from(n));
            for base in [hd, hd + margin, 0.5 * cell, margin] {
                for k in [-3, -1, 0, 1, 3] {
                    let d = up(base, k);
                    for sx in [-1.0f32, 1.0] {
                        let x = cx + sx * d;
                        let polys = vec![
                            // A vertical edge at `x`.
                            vec![[x, cy - 2.0], [x, cy + 2.0], [x + sx * 3.0, cy + 2.0], [x + sx * 3.0, cy - 2.0]],
                            // A horizontal edge and a slanted one ending at `x`.
                            vec![[x, cy], [x + sx * 2.0, cy], [x + sx * 2.0, cy + 2.0]],
                            vec![[x, cy + 0.5 * cell], [x + sx * 1.5, cy - 1.0], [x + sx * 1.5, cy + 1.5]],
                        ];
                        let pts = points(&mut rng, &polys, geometry);
                        assert!(check(&polys, geometry, &pts));
                        for poly in &polys {
                            let one = [poly.clone()];
                            assert!(check(&one, geometry, &pts));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn frames_the_index_cannot_hold_fall_back_to_the_same_answers() {
        let geometry = GridGeometry::new(40, 0.5);
        let mut rng = Rng(11);
        // A coordinate that is not finite.
        let polys = vec![vec![[0.0, 0.0], [5.0, f32::NAN], [5.0, 5.0]], vec![[-5.0, -5.0], [-1.0, -5.0], [-1.0, -1.0]]];
        let pts = points(&mut rng, &polys[1..], geometry);
        assert!(!check(&polys, geometry, &pts));
        // More polygons than boxes.
        let many: Vec<Vec<[f32; 2]>> = (0..ROI_BOXES + 3)
            .map(|i| {
                let x = -9.0 + (i % 37) as f32 * 0.5;
                vec![[x, -9.0], [x + 0.3, -9.0 + (i % 29) as f32 * 0.6], [x - 0.2, 9.0]]
            })
            .collect();
        let pts = points(&mut rng, &many[..5], geometry);
        assert!(!check(&many, geometry, &pts));
        // More entries than the buffer: vertical zig-zags across every row.
        let zig: Vec<Vec<[f32; 2]>> = (0..100)
            .map(|i| {
                let x = -9.9 + i as f32 * 0.19;
                (0..100).flat_map(|k| [[x, -9.9], [x + 0.05 + k as f32 * 1e-3, 9.9]]).collect()
            })
            .collect();
        let pts = points(&mut rng, &zig[..2], geometry);
        assert!(!check(&zig, geometry, &pts));
        // Polygons with fewer than 3 vertices, and none at all.
        let few = vec![vec![[0.0, 0.0], [3.0, 3.0]], vec![[1.0, 1.0]], vec![]];
        let pts = points(&mut rng, &few, geometry);
        check(&few, geometry, &pts);
        check(&[], geometry, &pts);
    }
}
