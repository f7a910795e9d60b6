//! Own returns beyond the grown region (params key `returns_beyond_cells`, off by default; docs/attribution.md,
//! "Own returns beyond the grown region"). Part of [`Monitor`]; the verdicts (`verdicts.rs`) ask it.
//!
//! The grown region `A_o` explains the cells it overlaps, so a 0.5 m cell on its edge may hold returns up to a cell
//! diagonal beyond it: that is the paper's `dx_min` (1.27 m at 0.5 m cells and 0.1 m uncertainty). The grid keeps
//! each hit cell's first return (`jump_first_return`, the default since issue #10), which says where in the cell
//! the evidence stands. A box confirmed by its own evidence is a `position_error` when at least
//! `returns_beyond_cells` of its own hit cells stand *wholly* beyond its grown region (every return of the cell
//! more than `delta_safe` beyond it), and its own evidence still fits its size:
//!
//! - a cell whose first return stands beyond is a candidate; the first time in a frame a box passes the other
//!   tests, [`Monitor::gather_beyond_returns`] folds every return of the frame's candidate cells (one scan of the
//!   cells the rasterizer recorded per point, as `over.rs` does; with `seen_over` on, the candidates of every box
//!   are gathered before the verdicts and folded in seen-over's own scan) into the distance beyond the region of the cell's
//!   nearest return. A cell that also holds a return within `delta_safe` of the region is not counted: the box's own edge
//!   with something beside it (a mirror, a post, a bush) in the same cell;
//! - a return inside another object's grown region, or near an object without evidence of its own and without a
//!   cluster (whose evidence may be lying there), is not counted, and does not widen the span;
//! - the span of its own first returns along and across the box is at most its length and width plus
//!   `2 delta_safe`: evidence wider than the box holds something else beside it (a neighbour, a post), and says
//!   nothing about where the box stands.
//!
//! Why it is sound in the simulator and not always on real boxes: an object within its stated uncertainty has
//! every return inside its grown region (the footprint plus `3 sigma` plus `delta_safe`), so a return beyond it is
//! someone else's or proves the box displaced. Real boxes stand beside unlabelled things (bushes, posts, bicycles)
//! whose returns may fill a cell beyond the box's edge (docs/attribution.md). Bounded: one walk over the grown
//! region's hit cells per confirmed box, at most [`BEYOND_CELLS_PER_OBJECT`] candidate cells per box, one scan of
//! the recorded cells per frame when there is a candidate, and for each counted return the look at the nearby
//! regions of `face.rs`.

use super::clusters::{edge_slot, for_each_marked_return};
use super::fit::{grown, span_fits, NO_SPAN};
use super::*;

/// The candidate cells kept per box (its cells whose first return stands beyond its grown region); a box with more
/// keeps its first ones in the grid's order, and the others are not counted.
pub(super) const BEYOND_CELLS_PER_OBJECT: usize = 16;

/// A candidate cell of a box: the cell, the box, and how far beyond the box's grown region the cell's nearest
/// return stands (metres; the scan lowers it from infinity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct BeyondEntry {
    pub(super) cell: u32,
    pub(super) object: u32,
    pub(super) nearest: f32,
}

/// Sets the prefilter byte of every candidate cell in `entries` to `value` (1 before a scan, 0 after it, so that
/// the prefilter is empty again for the next frame).
pub(super) fn mark_beyond_cells(map: &mut [u8], entries: &[BeyondEntry], value: u8) {
    for e in entries {
        if let Some(b) = map.get_mut(edge_slot(e.cell)) {
            *b = value;
        }
    }
}

/// Folds a return of `cell` (`point`: its ego-frame position, computed only when the cell has entries) into the
/// nearest return of each candidate entry of that cell. `last` caches the cell's range of `entries` over a run of
/// returns in one cell (a ring puts several in a row: one search per run).
#[inline]
pub(super) fn fold_beyond_return(
    entries: &mut [BeyondEntry],
    scratch: &[ObjectScratch],
    last: &mut (u32, usize, usize),
    cell: u32,
    point: impl FnOnce() -> [f32; 3],
) {
    if cell != last.0 {
        let from = entries.partition_point(|e| e.cell < cell);
        let to = from + entries.get(from..).map_or(0, |rest| rest.partition_point(|e| e.cell == cell));
        *last = (cell, from, to);
    }
    if last.1 == last.2 {
        return;
    }
    let q = point();
    for e in entries.get_mut(last.1..last.2).into_iter().flatten() {
        let Some(region) = scratch.get(e.object as usize).and_then(|s| s.region.as_ref()) else { continue };
        e.nearest = e.nearest.min(region.grown.distance(q[0], q[1]));
    }
}

impl Monitor {
    /// Each own hit cell's first return (with `jump_first_return`; else the mean of its returns).
    pub(super) fn own_first_return(&self, j: usize, idx: u32) -> Option<(f32, f32)> {
        self.grid.sums(idx).filter(|s| s[2] >= 1.0 && self.owns(j, idx)).map(|[sx, sy, n]| (sx / n, sy / n))
    }

    /// The first walk, without the look at the other objects (which only leaves returns beyond out): `visit` gets
    /// each own hit cell whose first return stands more than `delta_safe` beyond the grown region; true when there
    /// are at least `returns_beyond_cells` of them and the span of the others fits the box. Most boxes have fewer,
    /// or evidence wider than the box already, and stop here.
    fn beyond_candidates(&self, j: usize, region: &Region, mut visit: impl FnMut(u32)) -> bool {
        let k_min = self.params.returns_beyond_cells;
        let Some(range) = self.grid.geometry.cell_range(region.grown.aabb()) else { return false };
        let tolerance = self.params.safety_margin_m;
        let mut candidates = 0u32;
        let mut span = NO_SPAN;
        self.grid.for_each_hit_cell(&region.grown, range, |idx| {
            if let Some((x, y)) = self.own_first_return(j, idx) {
                if region.grown.distance(x, y) > tolerance {
                    candidates += 1;
                    visit(idx);
                } else {
                    span = grown(span, region.footprint.local(x, y));
                }
            }
        });
        k_min > 0 && candidates >= k_min && span_fits(span, &region.footprint, 2.0 * self.params.safety_margin_m)
    }

    /// With `returns_beyond_cells` > 0, the first time in a frame a box needs it (`returns_beyond`): the candidate
    /// cells of box `from` and of every later box confirmed by its own evidence (`beyond_candidates`; the cells a box
    /// owns do not change during the verdicts), and for each the distance beyond the box's grown region of the cell's
    /// nearest return, from one scan of the cells the rasterizer recorded per point (the prefilter of `over.rs`).
    /// `returns_beyond` counts a candidate only when that distance exceeds `delta_safe`.
    pub(super) fn gather_beyond_returns(&mut self, from: usize, cloud: Option<Cloud<'_>>) {
        self.beyond_gathered = true;
        let Some(cloud) = cloud else {
            self.beyond_entries.clear();
            return;
        };
        if self.beyond_entries_from(from) {
            self.fold_beyond_returns(cloud);
        }
    }

    /// The returns of the candidate cells in `beyond_entries` folded into each entry's nearest return, by one scan
    /// of the cells the rasterizer recorded per point through this rule's own prefilter (emptied again after).
    pub(super) fn fold_beyond_returns(&mut self, cloud: Cloud<'_>) {
        mark_beyond_cells(&mut self.beyond_map, &self.beyond_entries, 1);
        let t = cloud.ego_from_sensor;
        let (band, geometry) = (self.band(), self.grid.geometry);
        let (scratch, entries) = (&self.scratch, &mut self.beyond_entries);
        let mut last = (NO_CELL, 0usize, 0usize);
        for_each_marked_return(&self.beyond_map, &self.point_cells, cloud, band, geometry, |cell, p| {
            fold_beyond_return(entries, scratch, &mut last, cell, || t.transform(p));
        });
        mark_beyond_cells(&mut self.beyond_map, &self.beyond_entries, 0);
    }

    /// The candidate cells of box `from` and of every later box confirmed by its own evidence, each with its
    /// nearest return at infinity, sorted by cell and box (`beyond_entries`); false when there are none. Each
    /// entry depends on its cell and box only, so entries of boxes that never ask change nothing for the others.
    pub(super) fn beyond_entries_from(&mut self, from: usize) -> bool {
        self.beyond_entries.clear();
        let tau_tp = self.params.tau_tp;
        for j in from..self.scratch.len() {
            let Some(s) = self.scratch.get(j) else { continue };
            let Some(region) = s.region.as_ref() else { continue };
            if s.eta_own < tau_tp || s.own_sum[2] < 1.0 {
                continue;
            }
            let mut cells = [NO_CELL; BEYOND_CELLS_PER_OBJECT];
            let mut n = 0usize;
            let fits = self.beyond_candidates(j, region, |idx| {
                if let Some(c) = cells.get_mut(n) {
                    *c = idx;
                    n += 1;
                }
            });
            if !fits {
                continue;
            }
            for &cell in cells.iter().take(n) {
                if self.beyond_entries.len() < self.beyond_entries.capacity() {
                    self.beyond_entries.push(BeyondEntry { cell, object: j as u32, nearest: f32::INFINITY });
                }
            }
        }
        self.beyond_entries.sort_unstable_by_key(|e| (e.cell, e.object));
        !self.beyond_entries.is_empty()
    }

    /// Whether candidate cell `idx` of box `j` stands wholly beyond its grown region: every return of it more than
    /// `delta_safe` beyond (`gather_beyond_returns`).
    fn wholly_beyond(&self, j: usize, idx: u32) -> bool {
        let key = (idx, j as u32);
        self.beyond_entries
            .binary_search_by_key(&key, |e| (e.cell, e.object))
            .ok()
            .and_then(|i| self.beyond_entries.get(i))
            .is_some_and(|e| e.nearest > self.params.safety_margin_m)
    }

    /// The second walk: the span of the box's own first returns (within the region's margin, and beyond it unless
    /// they may be another object's), how many of the latter there are, and the first
    /// [`BEYOND_CELLS_PER_OBJECT`] of them (cell and return; a later one has no candidate entry either, since
    /// `gather_beyond_returns` keeps the first candidates in the same order).
    fn beyond_walk(&self, j: usize, region: &Region) -> ([f32; 4], u32, [(u32, f32, f32); BEYOND_CELLS_PER_OBJECT]) {
        let tolerance = self.params.safety_margin_m;
        let fp = &region.footprint;
        let (mut span, mut beyond, mut kept) = (NO_SPAN, 0u32, [(NO_CELL, 0.0, 0.0); BEYOND_CELLS_PER_OBJECT]);
        let Some(range) = self.grid.geometry.cell_range(region.grown.aabb()) else { return (span, 0, kept) };
        self.grid.for_each_hit_cell(&region.grown, range, |idx| {
            let Some((x, y)) = self.own_first_return(j, idx) else { return };
            if region.grown.distance(x, y) <= tolerance {
                span = grown(span, fp.local(x, y));
                return;
            }
            if self.in_other_region(j, x, y) || self.sought_nearby(j, x, y) {
                return;
            }
            span = grown(span, fp.local(x, y));
            if let Some(k) = kept.get_mut(beyond as usize) {
                *k = (idx, x, y);
            }
            beyond += 1;
        });
        (span, beyond, kept)
    }

    /// For a box confirmed by its own evidence (no cluster, not seen through, no face in front), with
    /// `returns_beyond_cells` = K > 0: the mean of the first returns of its own hit cells that stand wholly more than
    /// `delta_safe` beyond its grown region, when there are at least K such cells and its own first returns fit its
    /// size (see the module documentation); `None` otherwise. The scan of the candidate cells' returns runs only
    /// when a box gets this far, once per frame.
    pub(super) fn returns_beyond(&mut self, j: usize, region: &Region, cloud: Option<Cloud<'_>>) -> Option<[f32; 2]> {
        let k_min = self.params.returns_beyond_cells;
        if k_min == 0 || !self.grid.has_sums() || !self.beyond_candidates(j, region, |_| {}) {
            return None;
        }
        let slack = 2.0 * self.params.safety_margin_m;
        let (span, beyond, kept) = self.beyond_walk(j, region);
        if beyond < k_min || !span_fits(span, &region.footprint, slack) {
            return None;
        }
        if !self.beyond_gathered {
            self.gather_beyond_returns(j, cloud);
        }
        let (mut counted, mut sum) = (0u32, [0.0f32; 2]);
        for &(idx, x, y) in kept.iter().take(beyond as usize) {
            if self.wholly_beyond(j, idx) {
                counted += 1;
                sum[0] += x;
                sum[1] += y;
            }
        }
        (counted >= k_min).then(|| [sum[0] / counted as f32, sum[1] / counted as f32])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::ObjectClass;

    use super::super::roi::tests::Rng;

    /// Each candidate cell's nearest return that `gather_beyond_returns` keeps is the nearest, to its box's grown
    /// region, of every obstacle-band return in that cell, bit for bit: through the cells the rasterizer recorded
    /// and through the pass over the sweep. Random boxes with returns on their footprints and some 0.3-0.9 m beyond
    /// an end (candidates, some with a neighbour return within the margin in the same cell).
    #[test]
    fn beyond_entries_hold_each_cells_nearest_return() {
        let mut rng = Rng(0x5EED_BE40_0D00_0001);
        let (mut whole, mut mixed) = (0usize, 0usize);
        for case in 0..8 {
            let mut objects = Vec::new();
            let mut points = Vec::new();
            for id in 0..20u64 {
                let (x, y, heading) = (rng.range(-30.0, 30.0), rng.range(-30.0, 30.0), rng.range(-3.2, 3.2));
                let (l, w) = if id % 3 == 0 { (0.6, 0.6) } else { (rng.range(3.5, 5.0), rng.range(1.6, 2.1)) };
                objects.push(ObjectState {
                    id,
                    class: if id % 3 == 0 { ObjectClass::Pedestrian } else { ObjectClass::Car },
                    x_m: x,
                    y_m: y,
                    heading_rad: heading,
                    speed_mps: 0.0,
                    length_m: l,
                    width_m: w,
                    uncertainty: None,
                });
                let (c, s) = (libm::cosf(heading), libm::sinf(heading));
                for k in 0..60 {
                    let (u, v) = if k % 6 == 0 {
                        (0.5 * l + rng.range(if id % 2 == 0 { 0.55 } else { 0.3 }, 0.9), rng.range(-0.5 * w, 0.5 * w))
                    } else {
                        (rng.range(-0.5 * l, 0.5 * l), rng.range(-0.5 * w, 0.5 * w))
                    };
                    points.push([x + u * c - v * s, y + u * s + v * c, rng.range(0.3, 1.6) - 1.8]);
                }
            }
            let params = MonitorParams {
                returns_beyond_cells: 1 + case % 2,
                ego_footprint_m: if case % 2 == 0 { [-1.0, -1.0, 1.0, 1.0] } else { [0.0; 4] },
                ..MonitorParams::default()
            };
            let t = Isometry3::from_yaw_translation(if case % 3 == 0 { 0.3 } else { 0.0 }, [1.0, 0.5, 1.8]);
            let mut m = crate::test_support::monitor_after_one_check(params, t, &points, &objects);
            let cloud = PointCloud { points_in_sensor: &points, ego_from_sensor: t };
            assert_eq!(m.point_cells.len(), points.len(), "case {case}: the cells are recorded with the key");
            for recorded in [true, false] {
                if !recorded {
                    m.point_cells.clear();
                }
                m.gather_beyond_returns(0, Some(Cloud::from(cloud)));
                let band = m.band();
                for e in &m.beyond_entries {
                    let region = m.scratch[e.object as usize].region.unwrap();
                    let mut want = f32::INFINITY;
                    for p in &points {
                        let q = t.transform(*p);
                        let in_band = q[2] >= band.lo_m && q[2] <= band.hi_m && !band.in_ego(q[0], q[1]);
                        if in_band && m.grid.geometry.point_to_cell(q[0], q[1]) == Some(e.cell) {
                            want = want.min(region.grown.distance(q[0], q[1]));
                        }
                    }
                    assert_eq!(e.nearest.to_bits(), want.to_bits(), "case {case}, recorded {recorded}, {e:?}");
                    if e.nearest > params.safety_margin_m {
                        whole += 1;
                    } else {
                        mixed += 1;
                    }
                }
                assert!(m.beyond_map.iter().all(|&b| b == 0), "case {case}: the prefilter is empty again");
            }
        }
        // Both kinds of candidate cells: wholly beyond, and with a return within the margin.
        assert!(whole > 20 && mixed > 20, "the scenes' candidate cells: {whole} wholly beyond, {mixed} not");
    }
}
