//! Claims a flagged neighbour releases (params key `release_flagged_claims`, on by default; docs/attribution.md,
//! "Claims a flagged neighbour releases"). Ownership (step 1) gives an occupied cell to the object in whose grown
//! region it lies deepest, wherever that object really stands. A neighbour that holds a conflict cluster of its own
//! has its evidence there: the cells it owns only by its reported region are not its evidence unless the cluster
//! continues them (spill-over's first path, its body reaching over its edge). A hidden box without evidence of its
//! own that stands behind such cells takes them: displaced away from the sensor, behind its own returns, which a
//! displaced neighbour's region covered. Part of [`Monitor`]; the verdict is in `verdicts.rs`.

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
        let clip = [window[0].max(reach[0]), window[1].max(reach[1]), window[2].min(reach[2]), window[3].min(reach[3])];
        let geometry = self.grid.geometry;
        let (ix0, iy0, ix1, iy1) = geometry.cell_range_clipped(clip)?;
        let (tau, n) = (self.params.tau_fn, geometry.cells_per_side);
        let mut sum = [0.0f32; 3];
        let mut span = NO_SPAN;
        // The last owner asked whether its cluster continues its cells, and the answer (cells of one owner come
        // together).
        let mut continues: Option<(usize, bool)> = None;
        for iy in iy0..=iy1 {
            for ix in ix0..=ix1 {
                let idx = iy * n + ix;
                if self.grid.hits(idx) == 0
                    || self.grid.probability(idx) <= tau
                    || self.grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC | FLAG_ATTRIBUTED) != FLAG_EXPLAINED
                {
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
        span_fits(span, &region.footprint, self.fit_slack()).then(|| [sum[0] / sum[2], sum[1] / sum[2]])
    }
}
