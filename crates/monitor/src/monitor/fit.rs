//! Spill-over's fit tests (docs/attribution.md, "The rule, step by step", step 5; step 3's fit too): could a
//! cluster, alone or together with a confirmed object's own evidence, be that object's evidence, its box moved? Its
//! extent along and across the box, over occupied cells (`evidence_fits`, `fits_with_own`) or over every return
//! (`spill_fits_with`, [`SpillOverFit::EveryReturn`]), with the object's own spans walked once per frame
//! (`own_spans`); the walks per pair they replace are kept as the tests' references (`evidence_fits_walking_own`,
//! `spill_fits`). Part of [`Monitor`]; spill-over itself is in `attribution.rs` (`attribute_clusters`).

use super::*;

/// The least length (its longer side) of a box whose evidence spill-over follows across a gap (`spill_gap_m`): a
/// car's or a truck's (4-12 m), not a pedestrian's (0.5-1 m); a bicycle's (about 1.8 m) stays below it.
pub(super) const SPILL_GAP_MIN_LENGTH_M: f32 = 2.0;

/// The least length (its longer side) of a confirmed box that spill-over does not give a cluster merely for being
/// the nearest of the confirmed boxes whose evidence the cluster continues: it goes to the one it stretches least
/// ([`Monitor::stretch`]; docs/attribution.md, "The box a cluster stretches least"). A parked car's (about 4 m); a
/// pedestrian's box is below it, whose stretch at 0.5 m cells is mostly the cells' rounding.
pub(super) const STRETCH_MIN_LENGTH_M: f32 = 3.0;

impl Monitor {
    /// True when a cell of cluster `k` is within `gap + 1` cells (along each grid axis) of an occupied cell that
    /// object `j` owns: the two stand across at most `gap` empty cells (`spill_gap_m`); `gap` 0 is 8-adjacency.
    /// Bounded: the cluster's cells and the `(2 gap + 3)^2` block of each.
    pub(super) fn cluster_near_own_evidence(&self, j: usize, k: usize, gap: u32) -> bool {
        let tau = self.params.tau_fn;
        self.cluster_cells(k).iter().any(|&c| {
            self.grid.geometry.block(c, gap + 1).any(|idx| self.grid.probability(idx) > tau && self.owns(j, idx))
        })
    }

    /// `spill_gap_m` in whole cells (rounded down; a thousandth of a cell's tolerance for 0.4 m / 0.2 m in floats).
    pub(super) fn spill_gap_cells(&self) -> u32 {
        // `as` truncates towards zero (and saturates): a gap narrower than a cell is no cell.
        (self.params.spill_gap_m / self.grid.geometry.cell_size_m + 1e-3) as u32
    }

    /// The gap spill-over bridges for a box (`spill_gap_cells`): only for one at least [`SPILL_GAP_MIN_LENGTH_M`]
    /// long. A vehicle's side is a surface that a ray at a grazing angle samples sparsely; a pedestrian-sized box's
    /// returns are one compact blob, and a cluster across a gap from it is someone else's (or its own limb beyond a
    /// tight margin, which the paper's conditions give: measured in docs/attribution.md, "Spill-over across a gap").
    pub(super) fn spill_gap_for(&self, region: &Region) -> u32 {
        let long = 2.0 * region.footprint.half_length.max(region.footprint.half_width) >= SPILL_GAP_MIN_LENGTH_M;
        if long {
            self.spill_gap_cells()
        } else {
            0
        }
    }

    /// With `spill_in_front`: cluster `k`, which does not touch object `j`'s own evidence, may still be the rest of
    /// it when it stands where a box displaced away from the sensor leaves its near face: in front of the box on the
    /// sensor's line of sight (its centroid's bearing within the footprint's, nearer than its centre:
    /// [`Monitor::behind_exactly`]), with no cell 8-adjacent to a hit cell another object owns (a fragment of a
    /// neighbour's evidence is the neighbour's), with at least as many cells as the occupied cells the box owns (the
    /// evidence of its shape in front of it outweighs what its region holds), and the cluster with the box's own
    /// evidence fitting the box (spill-over's fit test). With `spill_near_side` the last two leave out the occupied
    /// cells the box owns beyond its near side ([`OwnSpans`]): what a box displaced away from the sensor holds at its
    /// far side is whatever stands behind it (docs/attribution.md, "The near side of the box"). Spill-over offers such a cluster
    /// to a box within `conflict_association_m` of its grown region (docs/attribution.md, "Spill-over in front of the
    /// box"). Bounded: the cluster's cells and their 3 x 3 blocks, and the walk of [`Monitor::own_spans`] once per
    /// frame.
    pub(super) fn spills_in_front(&mut self, j: usize, region: &Region, k: usize) -> bool {
        let Some((cells, centroid)) = self.clusters.get(k).map(|c| (c.cells as f32, c.centroid_m)) else {
            return false;
        };
        if !self.behind_exactly(&region.footprint, centroid) || self.cluster_touches_others(j, k) {
            return false;
        }
        let spans = self.own_spans(j, region);
        let (owned, own) = if self.params.spill_near_side {
            (spans.near_cells, spans.near)
        } else {
            (self.scratch.get(j).map_or(0.0, |s| s.own_sum[2]), spans.all)
        };
        cells >= owned && self.spill_fit(region, k, own)
    }

    /// Spill-over's fit test of cluster `k` with a confirmed object's own spans `own` ([`SpillOverFit`]: over the
    /// occupied cells, or over every return).
    pub(super) fn spill_fit(&self, region: &Region, k: usize, own: [[f32; 4]; 2]) -> bool {
        match self.spill_over_fit {
            SpillOverFit::Occupied => self.fits_with_own(region, k, own[0]),
            SpillOverFit::EveryReturn => self.spill_fits_with(region, k, own),
        }
    }

    /// True when a cell of cluster `k` is 8-adjacent to a hit cell that an object other than `j` owns.
    fn cluster_touches_others(&self, j: usize, k: usize) -> bool {
        self.cluster_touches_owned_by(k, |o| o != j)
    }

    /// True when a cell of cluster `k` is 8-adjacent to a hit cell owned (step 1) by an object `owner` accepts.
    pub(super) fn cluster_touches_owned_by(&self, k: usize, owner: impl Fn(usize) -> bool) -> bool {
        let grid = &self.grid;
        self.cluster_cells(k)
            .iter()
            .any(|&c| grid.geometry.block3x3(c).any(|idx| grid.hits(idx) > 0 && self.owner_of(idx).is_some_and(&owner)))
    }

    /// The slack of the fit tests ([`Monitor::fits_with_own`], [`Monitor::spill_fits_with`]) beyond a box's length and
    /// width: one cell diagonal (a cell centre is within half a diagonal of every point of its cell) and twice the
    /// safety margin (LiDAR noise).
    #[inline]
    pub(super) fn fit_slack(&self) -> f32 {
        core::f32::consts::SQRT_2 * self.grid.geometry.cell_size_m + 2.0 * self.params.safety_margin_m
    }

    /// [`Monitor::evidence_fits`]' first test, on cluster `k`'s bounds alone: two of its cells as far apart as its
    /// bounding box is wide cannot both lie in a box whose diagonal is shorter (walls and hedges fail it without
    /// a look at their cells). False means `fits_with_own` is false, whatever the object's own evidence.
    #[inline]
    pub(super) fn bounds_may_fit(&self, region: &Region, k: usize) -> bool {
        let fp = &region.footprint;
        let slack = self.fit_slack();
        self.clusters.get(k).map(|c| c.bounds_m).is_none_or(|b| {
            let diagonal = libm::hypotf(2.0 * fp.half_length + slack, 2.0 * fp.half_width + slack);
            (b[2] - b[0]).max(b[3] - b[1]) <= diagonal
        })
    }

    /// Could cluster `k` be the evidence of object `j`'s box (`region`) moved somewhere? True when its extent
    /// along and across the box, over cell centres, is at most the box's length and width plus one cell diagonal
    /// (a cell centre is within half a diagonal of every point of the cell) and twice the safety margin (LiDAR
    /// noise). A wall, a hedge or two objects side by side do not fit a pedestrian. [`Monitor::fits_with_own`]
    /// with no evidence of the box's own.
    #[inline]
    pub(super) fn evidence_fits(&self, region: &Region, k: usize) -> bool {
        self.fits_with_own(region, k, NO_SPAN)
    }

    /// The reference of [`Monitor::fits_with_own`] with object `j`'s own occupied evidence: the cluster's cells and
    /// the occupied cells `j` owns, found by a walk over every cell of its grown region, must fit its box. Kept for
    /// the tests.
    #[cfg(test)]
    pub(super) fn evidence_fits_walking_own(&self, j: usize, region: &Region, k: usize) -> bool {
        if !self.bounds_may_fit(region, k) {
            return false;
        }
        let geometry = self.grid.geometry;
        let fp = &region.footprint;
        let slack = self.fit_slack();
        let mut span = NO_SPAN;
        let mut add = |x: f32, y: f32| span = grown(span, fp.local(x, y));
        for &c in self.cluster_cells(k) {
            let (x, y) = geometry.cell_center(c);
            add(x, y);
        }
        let tau = self.params.tau_fn;
        if let Some(range) = geometry.cell_range(region.grown.aabb()) {
            geometry.for_each_cell_overlapping(&region.grown, range, |idx, x, y| {
                if self.grid.probability(idx) > tau && self.owns(j, idx) {
                    add(x, y);
                }
            });
        }
        span_fits(span, fp, slack)
    }

    /// The fit test of spill-over to a confirmed object `j` (step 5) with [`SpillOverFit::EveryReturn`]:
    /// [`Monitor::evidence_fits_walking_own`], then the same with its own evidence counting every return rather than
    /// the occupied cells only. The box's own returns are the hit cells
    /// it owns in its region, however few their hits, and the cluster's are its cells and the hit cells 8-adjacent
    /// to them that no object explains (returns too sparse to be occupied that continue the cluster). A box whose
    /// evidence moved with it leaves no return of its own where the displaced box no longer reaches, and its
    /// displaced evidence ends within its extent: a box that keeps a return at its far end, or a cluster whose
    /// returns run on beyond the box's extent, is a clean box next to unlabelled returns (docs/attribution.md,
    /// "Every return made the default"). Bounded: one walk over the region's cells and the 3 x 3 neighbourhood of
    /// each cluster cell. The reference of [`Monitor::spill_fits_with`], which spill-over runs (the object's own
    /// spans walked once per frame), kept for the tests.
    #[cfg(test)]
    pub(super) fn spill_fits(&self, j: usize, region: &Region, k: usize) -> bool {
        if !self.evidence_fits_walking_own(j, region, k) {
            return false;
        }
        let geometry = self.grid.geometry;
        let fp = &region.footprint;
        let slack = self.fit_slack();
        let mut span = NO_SPAN;
        let mut add = |x: f32, y: f32| span = grown(span, fp.local(x, y));
        let grid = &self.grid;
        for &c in self.cluster_cells(k) {
            for idx in geometry.block3x3(c) {
                if grid.hits(idx) > 0 && grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) == 0 {
                    let (x, y) = geometry.cell_center(idx);
                    add(x, y);
                }
            }
        }
        if let Some(range) = geometry.cell_range(region.grown.aabb()) {
            geometry.for_each_cell_overlapping(&region.grown, range, |idx, x, y| {
                if grid.hits(idx) > 0 && self.owns(j, idx) {
                    add(x, y);
                }
            });
        }
        span_fits(span, fp, slack)
    }

    /// Object `j`'s own spans in its box's axes (see the field `own_spans` and [`OwnSpans`]): the occupied cells and
    /// the hit cells it owns in its grown region, each as `[u min, u max, v min, v max]` (infinite bounds when there
    /// are none), all of them and those on its near side. One walk over the region's cells the first time spill-over
    /// asks in a frame, the stored answer after.
    pub(super) fn own_spans(&mut self, j: usize, region: &Region) -> OwnSpans {
        if let Some(Some(spans)) = self.own_spans.get(j) {
            return *spans;
        }
        let mut spans = OwnSpans { all: [NO_SPAN; 2], near: [NO_SPAN; 2], near_cells: 0.0 };
        let geometry = self.grid.geometry;
        let fp = &region.footprint;
        let tau = self.params.tau_fn;
        // The near side: cell centres no farther from the sensor than the box's centre plus half a cell diagonal
        // (a cell whose centre lies beyond may still hold a return nearer than the centre). Only occupied cells are
        // left out beyond it (`OwnSpans`).
        let o = self.visibility.origin();
        let reach = libm::hypotf(fp.cx - o[0], fp.cy - o[1]) + core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        let near_sq = reach * reach;
        // Own cells have hits: the walk over the region's hit cells (empty cells skipped 64 at a time) finds them
        // all. Every one of them is a hit cell its owner owns (the second span); the occupied ones, the first.
        if let Some(range) = geometry.cell_range(region.grown.aabb()) {
            let grid = &self.grid;
            grid.for_each_hit_cell(&region.grown, range, |idx| {
                if !self.owns(j, idx) {
                    return;
                }
                let (x, y) = geometry.cell_center(idx);
                let uv = fp.local(x, y);
                let near = (x - o[0]) * (x - o[0]) + (y - o[1]) * (y - o[1]) <= near_sq;
                let occupied = grid.probability(idx) > tau;
                if occupied {
                    spans.all[0] = grown(spans.all[0], uv);
                    if near {
                        spans.near[0] = grown(spans.near[0], uv);
                        spans.near_cells += 1.0;
                    }
                }
                spans.all[1] = grown(spans.all[1], uv);
                if near || !occupied {
                    spans.near[1] = grown(spans.near[1], uv);
                }
            });
        }
        if let Some(slot) = self.own_spans.get_mut(j) {
            *slot = Some(spans);
        }
        spans
    }

    /// Cluster `k` together with evidence of the box's own whose span in its axes is `own` (its occupied cells,
    /// [`Monitor::own_spans`]; [`NO_SPAN`] for none) fits the box (see [`Monitor::evidence_fits`]). The same answer
    /// as walking the box's cells with the cluster's (`evidence_fits_walking_own`, kept for the tests): the spans'
    /// minima and maxima do not depend on the order in which the cells come.
    pub(super) fn fits_with_own(&self, region: &Region, k: usize, own: [f32; 4]) -> bool {
        if !self.bounds_may_fit(region, k) {
            return false;
        }
        let fp = &region.footprint;
        span_fits(self.span_with_cluster(fp, k, own), fp, self.fit_slack())
    }

    /// The span `own` (box `fp`'s axes, `[u min, u max, v min, v max]`) grown by the centres of cluster `k`'s cells.
    fn span_with_cluster(&self, fp: &crate::geometry::OrientedRect, k: usize, own: [f32; 4]) -> [f32; 4] {
        let geometry = self.grid.geometry;
        let mut span = own;
        for &c in self.cluster_cells(k) {
            let (x, y) = geometry.cell_center(c);
            span = grown(span, fp.local(x, y));
        }
        span
    }

    /// How far cluster `k`'s cells and a confirmed object's own occupied span `own` (its box's axes) together reach
    /// beyond the box's length or across its width, metres over cell centres (0 when they lie within both): how much
    /// the box must stretch for the cluster to be its evidence. Spill-over's choice between the confirmed boxes
    /// whose evidence a cluster continues when the nearest is vehicle-sized ([`STRETCH_MIN_LENGTH_M`]).
    pub(super) fn stretch(&self, region: &Region, k: usize, own: [f32; 4]) -> f32 {
        let fp = &region.footprint;
        let span = self.span_with_cluster(fp, k, own);
        (span[1] - span[0] - 2.0 * fp.half_length).max(span[3] - span[2] - 2.0 * fp.half_width).max(0.0)
    }

    /// [`Monitor::spill_fits`] with the object's own spans given ([`Monitor::own_spans`]): the same answer.
    pub(super) fn spill_fits_with(&self, region: &Region, k: usize, own: [[f32; 4]; 2]) -> bool {
        if !self.fits_with_own(region, k, own[0]) {
            return false;
        }
        let geometry = self.grid.geometry;
        let fp = &region.footprint;
        let slack = self.fit_slack();
        let grid = &self.grid;
        let mut span = own[1];
        for &c in self.cluster_cells(k) {
            for idx in geometry.block3x3(c) {
                if grid.hits(idx) > 0 && grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) == 0 {
                    let (x, y) = geometry.cell_center(idx);
                    span = grown(span, fp.local(x, y));
                }
            }
        }
        span_fits(span, fp, slack)
    }
}

/// A confirmed object's own evidence in its grown region, in its box's axes, for spill-over (step 5;
/// [`Monitor::own_spans`]): the spans (`[u min, u max, v min, v max]`) of the occupied cells it owns and of every hit
/// cell it owns (`[occupied, every return]`), all of them (`all`) and without the occupied cells beyond its **near
/// side** (`near`: occupied cells whose centres are no farther from the sensor than the box's centre plus half a
/// cell diagonal, and every hit cell that is not occupied), and how many occupied cells it owns on its near side. A
/// face dense enough to be occupied at the box's far side is something standing behind it; sparse returns along a box
/// (its side at a grazing angle, its roof) are its own and still bound where its evidence ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct OwnSpans {
    pub(super) all: [[f32; 4]; 2],
    pub(super) near: [[f32; 4]; 2],
    pub(super) near_cells: f32,
}

/// `span` (`[u min, u max, v min, v max]` in a box's axes) grown to take the point `(u, v)`.
#[inline]
pub(super) fn grown(span: [f32; 4], (u, v): (f32, f32)) -> [f32; 4] {
    [span[0].min(u), span[1].max(u), span[2].min(v), span[3].max(v)]
}

/// A span in the axes of box `fp` no longer along and across than the box's length and width plus `slack`.
#[inline]
pub(super) fn span_fits(span: [f32; 4], fp: &crate::geometry::OrientedRect, slack: f32) -> bool {
    span[1] - span[0] <= 2.0 * fp.half_length + slack && span[3] - span[2] <= 2.0 * fp.half_width + slack
}

/// The span of no cells in a box's axes, `[u min, u max, v min, v max]`: any cell's coordinates replace it.
pub(super) const NO_SPAN: [f32; 4] = [f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY];
