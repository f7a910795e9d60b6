//! Evidence only in the margin that runs on beyond it (params key `evidence_runs_on`, on by default;
//! docs/attribution.md, "Evidence in the margin that runs on"): a box confirmed by evidence of its own, none of which
//! overlaps its footprint, whose evidence continues beyond its grown region into a conflict cluster another box took
//! as its displaced evidence, is displaced. Part of [`Monitor`]; the verdict is given in `verdicts.rs`.

use super::*;

impl Monitor {
    /// With `evidence_runs_on`: true when no occupied cell object `j` owns overlaps its footprint (the box is
    /// confirmed only by cells in its margin, the band `delta_safe + gamma_sens (Delta + Delta size)` wide that
    /// its grown region adds) and one of those owned cells is 8-adjacent to an occupied cell beyond the grown region
    /// that belongs to a conflict cluster another object took (no object's region explains it; the assignment
    /// gave it away as displaced evidence). A displaced box's margin holds the near end of a body whose rest a
    /// neighbour claimed; a clean box that its noise moved keeps its evidence within the region, and evidence that
    /// runs on into a cluster nobody takes is scenery or a missed object beside it (a small labelled object with no
    /// returns of its own beside a fence, on nuScenes and Argoverse 2: docs/attribution.md). Bounded: nothing for a
    /// box one of whose owned occupied cells overlaps its footprint (noted in `own_evidence`'s pass over the touched
    /// cells); otherwise one walk over the grown region's cells and the 3 x 3 block of each owned occupied cell in
    /// the margin until the answer is known.
    pub(super) fn evidence_runs_on(&self, j: usize, region: &Region) -> bool {
        let geometry = self.grid.geometry;
        let half = 0.5 * geometry.cell_size_m;
        let tau = self.params.tau_fn;
        let grid = &self.grid;
        // The occupied cells it owns were walked once this frame (`own_evidence`), which noted whether one of them
        // overlaps the footprint: most confirmed boxes' do, and the answer is then known without a walk.
        if self.scratch.get(j).is_none_or(|s| s.own_on_footprint) {
            return false;
        }
        // Every occupied cell it owns lies in its margin: does one of them touch a taken cell beyond the region?
        let Some(range) = geometry.cell_range(region.grown.aabb()) else { return false };
        let mut runs_on = false;
        geometry.for_each_cell_overlapping(&region.grown, range, |idx, _, _| {
            if runs_on || grid.probability(idx) <= tau || !self.owns(j, idx) {
                return;
            }
            runs_on = geometry.block3x3(idx).any(|c| {
                let (cx, cy) = geometry.cell_center(c);
                grid.probability(c) > tau
                    && grid.flags(c) & (FLAG_EXPLAINED | FLAG_ATTRIBUTED) == FLAG_ATTRIBUTED
                    && !region.grown.overlaps_square(cx, cy, half)
            });
        });
        runs_on
    }
}
