//! Claims a flagged neighbour releases (params key `release_flagged_claims`, on by default; docs/attribution.md,
//! "Claims a flagged neighbour releases"). Ownership (step 1) gives an occupied cell to the object in whose grown
//! region it lies deepest, wherever that object really stands. A neighbour that holds a conflict cluster of its own
//! has its evidence there: the cells it owns only by its reported region are not its evidence unless the cluster
//! continues them (spill-over's first path, its body reaching over its edge). A hidden box without evidence of its
//! own that stands behind such cells takes them: displaced away from the sensor, behind its own returns, which a
//! displaced neighbour's region covered. With `release_to_confirmed` (off by default; docs/attribution.md, "Released
//! claims for a confirmed box") a box confirmed by evidence of its own takes them too, when they outweigh what it
//! owns on its near side and fit its box with it. Part of [`Monitor`]; the verdict is in `verdicts.rs`.

use super::fit::{grown, span_fits, NO_SPAN};
use super::*;

impl Monitor {
    /// With `release_flagged_claims`: the centre of the occupied cells that stand in front of object `j`'s box on
    /// its line of sight, within `conflict_association_m` of its grown region and outside it, owned (step 1) by
    /// another object that holds a conflict cluster not 8-adjacent to the cells it owns, and in no third object's
    /// grown region (released, they would be that object's), when they fit `j`'s box (along and across no longer
    /// than its length and width plus a cell diagonal and twice the safety margin). `None` otherwise. Bounded: one
    /// walk over the cells within the gate of the grown region, and per counted cell one pass over the objects.
    pub(super) fn released_evidence(&self, j: usize, region: &Region) -> Option<[f32; 2]> {
        let clip = self.release_window(j, region)?;
        self.released_cells(j, region, clip, NO_SPAN).map(|(at, _)| at)
    }

    /// With `release_to_confirmed`: [`Monitor::released_evidence`] for a box confirmed by evidence of its own, when
    /// the released cells are at least as many as the occupied cells it owns on its near side and fit its box
    /// together with them (what a box displaced away from the sensor keeps in its region is the far end of its own
    /// body; spill-over in front of the box weighs a cluster the same way).
    pub(super) fn released_to_confirmed(&mut self, j: usize, region: &Region) -> Option<[f32; 2]> {
        let clip = self.release_window(j, region)?;
        let spans = self.own_spans(j, region);
        let (at, cells) = self.released_cells(j, region, clip, spans.near[0])?;
        (cells >= spans.near_cells).then_some(at)
    }

    /// Where released cells can stand for object `j`: its gate window (its grown region's bounding box widened by
    /// `conflict_association_m`) clipped to the bounding boxes of the grown regions of the objects that hold a cluster
    /// and reach into it (`[x min, y min, x max, y max]`); `None` when no such object does.
    fn release_window(&self, j: usize, region: &Region) -> Option<[f32; 4]> {
        let gate = self.params.conflict_association_m;
        let b = region.grown.aabb();
        let window = [b[0] - gate, b[1] - gate, b[2] + gate, b[3] + gate];
        // Only cells of an object that holds a cluster can be released, and they lie in its grown region: walk the
        // window where it meets such regions (none: nothing to release).
        let mut reach = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
        for (m, s) in self.scratch.iter().enumerate() {
            let Some(r) = s.region.filter(|_| m != j && s.cluster.is_some()) else { continue };
            let a = r.grown.aabb();
            if a[0] <= window[2] && a[2] >= window[0] && a[1] <= window[3] && a[3] >= window[1] {
                reach = [reach[0].min(a[0]), reach[1].min(a[1]), reach[2].max(a[2]), reach[3].max(a[3])];
            }
        }
        if reach[0] > reach[2] {
            return None;
        }
        Some([window[0].max(reach[0]), window[1].max(reach[1]), window[2].min(reach[2]), window[3].min(reach[3])])
    }

    /// The released cells in front of object `j` (see [`Monitor::released_evidence`]) within `clip`
    /// ([`Monitor::release_window`]): their centre and number, when they fit its box together with the span `own` (in
    /// its axes; [`NO_SPAN`] for none).
    fn released_cells(&self, j: usize, region: &Region, clip: [f32; 4], own: [f32; 4]) -> Option<([f32; 2], f32)> {
        let gate = self.params.conflict_association_m;
        let geometry = self.grid.geometry;
        let (ix0, iy0, ix1, iy1) = geometry.cell_range_clipped(clip)?;
        let (tau, n) = (self.params.tau_fn, geometry.cells_per_side);
        let mut sum = [0.0f32; 3];
        let mut span = own;
        // The last owner asked whether its cluster continues its cells, and the answer (cells of one owner come
        // together).
        let mut continues: Option<(usize, bool)> = None;
        for iy in iy0..=iy1 {
            for ix in ix0..=ix1 {
                let idx = iy * n + ix;
                if !self.explained_evidence(idx, tau) {
                    continue;
                }
                let Some(owner) = self.owner.get(idx as usize).map(|&o| o as usize).filter(|&o| o != j) else {
                    continue;
                };
                let Some((k, _)) = self.scratch.get(owner).and_then(|o| o.cluster) else { continue };
                let (x, y) = geometry.cell_center(idx);
                if region.grown.contains(x, y)
                    || region.grown.distance(x, y) > gate
                    || !self.behind(&region.footprint, [x, y])
                {
                    continue;
                }
                let touches = match continues {
                    Some((o, t)) if o == owner => t,
                    _ => self.cluster_touches_owned_by(usize::from(k), |o| o == owner),
                };
                continues = Some((owner, touches));
                if touches {
                    continue;
                }
                let elsewhere = self
                    .scratch
                    .iter()
                    .enumerate()
                    .any(|(m, o)| m != j && m != owner && o.region.is_some_and(|r| r.grown.contains(x, y)));
                if elsewhere {
                    continue;
                }
                sum = [sum[0] + x, sum[1] + y, sum[2] + 1.0];
                span = grown(span, region.footprint.local(x, y));
            }
        }
        if sum[2] < 1.0 {
            return None;
        }
        span_fits(span, &region.footprint, self.fit_slack()).then(|| ([sum[0] / sum[2], sum[1] / sum[2]], sum[2]))
    }
}
