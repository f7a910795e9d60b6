//! Own returns beyond the grown region (params key `returns_beyond_cells`, off by default; docs/attribution.md,
//! "Own returns beyond the grown region"). Part of [`Monitor`]; the verdicts (`verdicts.rs`) ask it.
//!
//! The grown region `A_o` explains the cells it overlaps, so a 0.5 m cell on its edge may hold returns up to a cell
//! diagonal beyond it: that is the paper's `dx_min` (1.27 m at 0.5 m cells and 0.1 m uncertainty). The grid keeps
//! each hit cell's first return (`jump_first_return`, the default since issue #10), which says where in the cell
//! the evidence stands. A box confirmed by its own evidence is a `position_error` when at least
//! `returns_beyond_cells` of its own hit cells have their first return more than `delta_safe` beyond its grown
//! region, and its own evidence still fits its size:
//!
//! - a return inside another object's grown region, or near an object without evidence of its own and without a
//!   cluster (whose evidence may be lying there), is not counted, and does not widen the span;
//! - the span of its own first returns along and across the box is at most its length and width plus
//!   `2 delta_safe`: evidence wider than the box holds something else beside it (a neighbour, a post), and says
//!   nothing about where the box stands.
//!
//! Why it is sound in the simulator and not on real boxes: an object within its stated uncertainty has every return
//! inside its grown region (the footprint plus `3 sigma` plus `delta_safe`), so a return beyond it is someone
//! else's or proves the box displaced. Real boxes stand beside unlabelled things (bushes, posts, bicycles) whose
//! returns fall in the box's edge cells; with one cell that flags 5 of the 80 clean Argoverse 2 boxes in scope
//! (docs/attribution.md). Bounded: one walk over the grown region's hit cells per confirmed box that no other rule
//! flags, and for each counted return the look at the nearby regions of `face.rs`.

use super::fit::{grown, span_fits, NO_SPAN};
use super::*;

impl Monitor {
    /// For a box confirmed by its own evidence (no cluster, not seen through, no face in front), with
    /// `returns_beyond_cells` = K > 0: the mean of the first returns of its own hit cells that lie more than
    /// `delta_safe` beyond its grown region, when there are at least K such cells and its own first returns fit its
    /// size (see the module documentation); `None` otherwise.
    pub(super) fn returns_beyond(&self, j: usize, region: &Region) -> Option<[f32; 2]> {
        let k_min = self.params.returns_beyond_cells;
        if k_min == 0 || !self.grid.has_sums() {
            return None;
        }
        let geometry = self.grid.geometry;
        let range = geometry.cell_range(region.grown.aabb())?;
        let tolerance = self.params.safety_margin_m;
        let fp = &region.footprint;
        let slack = 2.0 * self.params.safety_margin_m;
        // Each own hit cell's first return (with `jump_first_return`; else the mean of its returns).
        let first_return = |idx: u32| {
            self.grid.sums(idx).filter(|s| s[2] >= 1.0 && self.owns(j, idx)).map(|[sx, sy, n]| (sx / n, sy / n))
        };
        // First, without the look at the other objects (which only leaves returns beyond out): the returns beyond
        // and the span of the others in the box's axes. Most boxes have fewer than K beyond, or evidence wider than
        // the box already, and stop here.
        let mut candidates = 0u32;
        let mut span = NO_SPAN;
        self.grid.for_each_hit_cell(&region.grown, range, |idx| {
            if let Some((x, y)) = first_return(idx) {
                if region.grown.distance(x, y) > tolerance {
                    candidates += 1;
                } else {
                    span = grown(span, fp.local(x, y));
                }
            }
        });
        if candidates < k_min || !span_fits(span, fp, slack) {
            return None;
        }
        // Then the returns beyond, each unless it may be another object's.
        let mut beyond = 0u32;
        let mut sum = [0.0f32; 2];
        self.grid.for_each_hit_cell(&region.grown, range, |idx| {
            let Some((x, y)) = first_return(idx) else { return };
            if region.grown.distance(x, y) <= tolerance || self.in_other_region(j, x, y) || self.sought_nearby(j, x, y)
            {
                return;
            }
            span = grown(span, fp.local(x, y));
            beyond += 1;
            sum[0] += x;
            sum[1] += y;
        });
        (beyond >= k_min && span_fits(span, fp, slack)).then(|| [sum[0] / beyond as f32, sum[1] / beyond as f32])
    }
}
