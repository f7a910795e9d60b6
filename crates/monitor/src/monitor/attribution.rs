//! The evidence attribution of the sensor checks (docs/attribution.md, "The rule, step by step"): which object each
//! explained cell belongs to (step 1, `eta_own`, [`claim`]), the gated one-to-one assignment of conflict clusters to
//! objects (steps 3, 3b and 4, with step 3c's candidates), spill-over (step 5) and `front_cluster`. Part of
//! [`Monitor`]; `monitor.rs` keeps the stages, `clusters.rs` the clusters and `verdicts.rs` the verdicts. The rest
//! of the attribution is beside this file: what the sensor saw of a footprint and the free-space tests in `sight.rs`
//! (steps 2 and 7), the distances from a cluster in `distance.rs`, spill-over's fit tests in `fit.rs`, the evidence
//! memory's steps (3c's place, 8 and 9) in `memory_steps.rs`, and the solver of the assignment in `assignment.rs`.

use super::fit::STRETCH_MIN_LENGTH_M;
use super::memory_steps::stayed_evidence;
use super::*;

impl Monitor {
    /// `eta_own` of every object: the highest occupancy probability among the cells it owns (one pass over the
    /// touched cells).
    pub(super) fn own_evidence(&mut self) {
        let floor = self.grid.probability_of_hits(0);
        for s in &mut self.scratch {
            s.eta_own = floor;
        }
        let tau = self.params.tau_fn;
        let half = 0.5 * self.grid.geometry.cell_size_m;
        let on_footprint = self.params.evidence_runs_on;
        for &idx in self.grid.touched() {
            if self.grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) != FLAG_EXPLAINED {
                continue;
            }
            let Some(&o) = self.owner.get(idx as usize) else { continue };
            if let Some(s) = self.scratch.get_mut(o as usize) {
                let p = self.grid.probability(idx);
                s.eta_own = s.eta_own.max(p);
                if p > tau {
                    let (x, y) = self.grid.geometry.cell_center(idx);
                    s.own_sum = [s.own_sum[0] + x, s.own_sum[1] + y, s.own_sum[2] + 1.0];
                    // With `evidence_runs_on`: whether any of them overlaps the footprint (`margin.rs`).
                    if on_footprint && !s.own_on_footprint {
                        s.own_on_footprint = s.region.is_some_and(|r| r.footprint.overlaps_square(x, y, half));
                    }
                }
            }
        }
    }

    /// Whether object `j` owns cell `c` (step 1): the cell is explained, not known scenery, and `j` is the object in
    /// whose region it lies deepest. Whether the cell is occupied is the caller's question.
    #[inline]
    pub(super) fn owns(&self, j: usize, c: u32) -> bool {
        self.owner_of(c) == Some(j)
    }

    /// The object that owns cell `c` (step 1), if any: the cell is explained and not known scenery.
    #[inline]
    pub(super) fn owner_of(&self, c: u32) -> Option<usize> {
        if self.grid.flags(c) & (FLAG_EXPLAINED | FLAG_STATIC) != FLAG_EXPLAINED {
            return None;
        }
        self.owner.get(c as usize).map(|&o| o as usize)
    }

    /// Gives the evidence no object explains to the objects it belongs to.
    ///
    /// 1. Ownership: each explained cell belongs to the object in whose region it lies deepest (`eta_own`, see
    ///    [`claim`]). An object whose own evidence is below `tau_tp` is *unconfirmed*: occluded, a ghost, or
    ///    displaced.
    /// 2. Assignment: clusters in the region of interest go to unconfirmed objects by a gated, one-to-one,
    ///    deterministic assignment on the displacement it implies (the distance from the cluster to the
    ///    region `A_o`), nearest pairs first. The gate is `conflict_association_m` for an object whose
    ///    footprint the sensor contradicts (seen empty, behind unexplained evidence, or taken by another
    ///    object's evidence: it is not where it claims) or that stands behind the cluster on its line of sight,
    ///    and touching only for one merely hidden. A track whose evidence stood apart from it last frame is
    ///    offered the clusters near where that offset puts its evidence now, at the cost of that distance.
    /// 3. Spill-over: a cluster left over that continues a confirmed object's own evidence (8-adjacent cells) and
    ///    fits its box together with it, or that touches an unconfirmed object's region (within half a cell)
    ///    and fits its box, is that object's evidence reaching over its edge (the nearest such object; when the
    ///    nearest confirmed box whose evidence it continues is vehicle-sized, the confirmed box it stretches least
    ///    stands for them: a neighbour's corner by a car's near end fits the car within the fit's slack). With
    ///    `spill_in_front`, a cluster within `conflict_association_m` of a confirmed box's region that stands in
    ///    front of it on the sensor's line of sight, holds at least as many cells as the box owns and touches no
    ///    other object's evidence need not touch the box's own evidence ([`Monitor::spills_in_front`]).
    ///
    /// Everything else is a missed object. Bounded: pairs are kept up to a fixed capacity
    /// (`ASSOCIATION_CANDIDATES` per cluster on average), sorted in place.
    pub(super) fn attribute_clusters(&mut self) {
        self.own_evidence();
        let tau_tp = self.params.tau_tp;
        let touch = 0.5 * self.grid.geometry.cell_size_m;
        let gate = self.params.conflict_association_m;
        let follow = 0.5 * gate;
        for s in &self.scratch {
            // Step 3c: where its own evidence of the last frame should stand now, when that left its region (never
            // for a track whose evidence was displaced then: `stayed_evidence` asks for its own).
            let stayed = s.region.and_then(|r| stayed_evidence(s, &r));
            let entry = match s.region {
                None => ([f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY], 0),
                Some(r) => {
                    let mut bits = CANDIDATE_REGION;
                    if s.eta_own >= tau_tp {
                        bits |= CANDIDATE_CONFIRMED;
                    }
                    if matches!(s.recalled, Some((EvidenceKind::Displaced, _))) {
                        bits |= CANDIDATE_DISPLACED;
                    } else if stayed.is_some() {
                        bits |= CANDIDATE_STAYED;
                    }
                    (r.grown.aabb(), bits)
                }
            };
            let j = self.candidates.len();
            if j < self.candidates.capacity() {
                self.candidates.push(entry);
                let index = u32::try_from(j).unwrap_or(u32::MAX);
                if entry.1 & CANDIDATE_REGION != 0 && self.by_x.len() < self.by_x.capacity() {
                    self.by_x.push((entry.0[0], index));
                    self.widest_m = self.widest_m.max(entry.0[2] - entry.0[0]);
                }
                // With where its offset puts its evidence now (the clusters below are tested against it first).
                if entry.1 & CANDIDATE_DISPLACED != 0 && self.displaced.len() < self.displaced.capacity() {
                    if let (Some(region), Some((_, r))) = (s.region, s.recalled) {
                        self.displaced.push((index, [region.footprint.cx + r[0], region.footprint.cy + r[1]]));
                    }
                }
                // Step 3c: its own evidence of the last frame, where the track's motion puts it, left its region.
                if let Some(expected) = stayed.filter(|_| self.displaced.len() < self.displaced.capacity()) {
                    self.displaced.push((index, expected));
                }
            }
        }
        self.by_x.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // Candidate pairs.
        for k in 0..self.clusters.len() {
            // Clusters outside the region of interest too: the ROI decides where evidence nobody owns is a missed
            // object, not whose evidence it is. An object without evidence of its own (unconfirmed: only those are
            // offered clusters here) standing beside a cluster that fits it, off the drivable area, is a parked car
            // displaced from its own returns as much as one on the road.
            let Some(cb) = self.clusters.get(k).map(|c| c.bounds_m) else { continue };
            // A track whose evidence stood apart from it last frame: its evidence is expected where the offset puts
            // it now (the cost is how far the cluster is from there).
            // Step 3c: a cluster where a track's own evidence of the last frame should stand is that track's; no
            // neighbour claims it by geometry.
            let mut stayed_here = false;
            for m in 0..self.displaced.len() {
                let Some((j, expected)) = self.displaced.get(m).map(|&(j, e)| (j as usize, e)) else { continue };
                // Most clusters are far from where a track's evidence is expected: the bounds test of
                // `cluster_point_distance` first, before the track's region is looked at (the same pairs).
                if self.point_far(cb, expected, follow) {
                    continue;
                }
                let Some(region) = self.scratch.get(j).and_then(|s| s.region) else { continue };
                // Followed only while the evidence stays within the gate of the box: a remembered offset is updated
                // every frame, and without this bound a track could follow a neighbour's evidence walking away.
                let within_gate = |m: &Self| m.cluster_distance(k, &region.grown, gate).is_some();
                if let Some(d) = self.cluster_point_distance(k, expected, follow).filter(|_| within_gate(self)) {
                    // Remembered for the loop below, which then skips this pair (one follow test per pair).
                    if let Some(s) = self.scratch.get_mut(j) {
                        s.followed = k as u32;
                    }
                    if self.evidence_fits(&region, k) && self.pairs.len() < self.pairs.capacity() {
                        self.pairs.push((d, k as u32, j as u32, 0));
                        stayed_here |= self.candidates.get(j).is_some_and(|c| c.1 & CANDIDATE_STAYED != 0);
                    }
                }
            }
            if stayed_here {
                continue;
            }
            // Objects without evidence of their own (a followed track's pair above stands for it).
            let (lo, hi) = self.x_window(cb, gate);
            for m in lo..hi {
                let Some(j) = self.by_x.get(m).map(|&(_, j)| j as usize) else { continue };
                let Some(&(rb, bits)) = self.candidates.get(j) else { continue };
                // `|`: both tests are cheap and pure, and one branch is easier to predict than two.
                if (bits & CANDIDATE_CONFIRMED != 0) | self.far_apart(cb, rb, gate) {
                    continue;
                }
                let Some(s) = self.scratch.get(j) else { continue };
                let Some(region) = s.region else { continue };
                if bits & (CANDIDATE_DISPLACED | CANDIDATE_STAYED) != 0 && s.followed == k as u32 {
                    continue;
                }
                // A cluster that cannot fit the box gives no pair. Its distance is still needed while the object's
                // sight is not yet computed (whether this pair computes it, once per frame, depends on it); once
                // it is, the pair has no effect at all and is skipped before the distance (the same pairs and
                // sights as testing every pair in full).
                if s.sight.is_some() && !self.bounds_may_fit(&region, k) {
                    continue;
                }
                let Some(d) = self.cluster_distance(k, &region.grown, gate) else { continue };
                // The whole gate for an object the sensor contradicts, or one that claims to stand behind the
                // evidence on its own line of sight (displaced away from it; its place is then hidden, often also
                // behind a low obstacle the rays passed over); touching only for one merely hidden.
                let reachable = d <= touch
                    || self.clusters.get(k).is_some_and(|c| self.behind(&region.footprint, c.centroid_m))
                    || self.sight_of(j, &region).contradicted() >= self.params.ghost_visible_fraction;
                if reachable && self.evidence_fits(&region, k) && self.pairs.len() < self.pairs.capacity() {
                    self.pairs.push((d, k as u32, j as u32, 0));
                }
            }
        }
        self.assign_pairs();
        self.share_between_coincident_boxes();
        // Spill-over of the clusters left.
        let adjacent = core::f32::consts::SQRT_2 * self.grid.geometry.cell_size_m + 1e-3;
        // With `spill_gap_m`, the evidence a cluster continues may stand across `gap` empty cells (boxes of a
        // vehicle's length): its cells are then within `gap + 1` cell diagonals of the region (an owned cell overlaps
        // it).
        let continues = adjacent * (self.spill_gap_cells() + 1) as f32;
        // How far from a confirmed box's grown region a cluster may stand: a cell diagonal for one that continues the
        // box's own evidence (8-adjacent cells; more across a gap), the gate for one in front of it
        // (`spill_in_front`).
        let far =
            if self.params.spill_in_front { self.params.conflict_association_m.max(continues) } else { continues };
        self.own_spans.clear();
        self.own_spans.resize(self.scratch.len().min(self.own_spans.capacity()), None);
        for k in 0..self.clusters.len() {
            let Some(cb) = self.clusters.get(k).filter(|c| c.in_roi && c.object.is_none()).map(|c| c.bounds_m) else {
                continue;
            };
            let mut best: Option<(f32, usize)> = None;
            // The confirmed boxes whose evidence the cluster continues: the nearest (its distance, index, and
            // whether it is vehicle-sized), and the one it stretches least (stretch, distance, index).
            let mut nearest_continued: Option<(f32, usize, bool)> = None;
            let mut least_stretched: Option<(f32, f32, usize)> = None;
            let (lo, hi) = self.x_window(cb, far);
            for m in lo..hi {
                let Some(j) = self.by_x.get(m).map(|&(_, j)| j as usize) else { continue };
                let Some(&(rb, bits)) = self.candidates.get(j) else { continue };
                // A confirmed object's own evidence continues into the cluster (8-adjacent cells, or with
                // `spill_gap_m` across a gap of empty cells beside a vehicle-sized box), and both
                // together fit its box: the box is displaced (or too small). Evidence merely near a confirmed box
                // is not its. An unconfirmed object takes a cluster that touches its region and fits its box.
                let confirmed = bits & CANDIDATE_CONFIRMED != 0;
                // A cell next to an owned cell (which overlaps the region) is at most a cell diagonal from it.
                let reach = if confirmed { far } else { touch };
                if bits & CANDIDATE_REGION == 0 || self.far_apart(cb, rb, reach) {
                    continue;
                }
                let Some(region) = self.scratch.get(j).and_then(|s| s.region) else { continue };
                // Both fit tests below start with the bounds test: a cluster wider than the box never spills over.
                if !self.bounds_may_fit(&region, k) {
                    continue;
                }
                let Some(d) = self.cluster_distance(k, &region.grown, reach) else { continue };
                let ok = if confirmed {
                    let gap = self.spill_gap_for(&region);
                    if d <= adjacent * (gap + 1) as f32 && self.cluster_near_own_evidence(j, k, gap) {
                        let own = self.own_spans(j, &region).all;
                        if self.spill_fit(&region, k, own) {
                            let fp = &region.footprint;
                            let vehicle = 2.0 * fp.half_length.max(fp.half_width) >= STRETCH_MIN_LENGTH_M;
                            if nearest_continued.is_none_or(|(bd, bj, _)| d.total_cmp(&bd).then(j.cmp(&bj)).is_lt()) {
                                nearest_continued = Some((d, j, vehicle));
                            }
                            if self.params.spill_least_stretch {
                                let e = self.stretch(&region, k, own[0]);
                                let less = |(be, bd, bj): (f32, f32, usize)| {
                                    e.total_cmp(&be).then(d.total_cmp(&bd)).then(j.cmp(&bj)).is_lt()
                                };
                                if least_stretched.is_none_or(less) {
                                    least_stretched = Some((e, d, j));
                                }
                            }
                        }
                        // Weighed against the other candidates below, once the loop has seen them all.
                        false
                    } else {
                        self.params.spill_in_front && self.spills_in_front(j, &region, k)
                    }
                } else {
                    self.evidence_fits(&region, k)
                };
                // Nearest; ties to the lower index (deterministic whatever the loop order).
                if ok && best.is_none_or(|(bd, bj)| d.total_cmp(&bd).then(j.cmp(&bj)).is_lt()) {
                    best = Some((d, j));
                }
            }
            // The confirmed box that stands for those whose evidence the cluster continues: the nearest, or, when
            // that is vehicle-sized and `spill_least_stretch` is on, the one the cluster stretches least
            // ([`Monitor::stretch`]); then the nearest of it and the other candidates, as before.
            let continued = match nearest_continued {
                Some((d, j, vehicle)) if !vehicle || !self.params.spill_least_stretch => Some((d, j)),
                Some(_) => least_stretched.map(|(_, d, j)| (d, j)),
                None => None,
            };
            if let Some((d, j)) = continued {
                if best.is_none_or(|(bd, bj)| d.total_cmp(&bd).then(j.cmp(&bj)).is_lt()) {
                    best = Some((d, j));
                }
            }
            if let Some((_, j)) = best {
                self.give(k, j);
            }
        }
        if self.params.front_cluster {
            self.front_clusters();
        }
    }

    /// With `front_cluster`: a free cluster left after spill-over goes to the nearest confirmed box without a
    /// cluster that stands behind it on the sensor's line of sight, within the gate, that it fits, that holds at
    /// least as many cells as the occupied cells the box owns, and whose confirming evidence is a piece of
    /// something larger than the box ([`Monitor::own_evidence_runs_on`]): the box
    /// claims to stand behind evidence of its own size and is confirmed only by scenery (docs/attribution.md, "One
    /// box displaced 2 m in a single sweep"). Bounded: the clusters times the boxes within the gate of each.
    fn front_clusters(&mut self) {
        let gate = self.params.conflict_association_m;
        for k in 0..self.clusters.len() {
            let Some((cb, centroid, cells)) =
                self.clusters.get(k).filter(|c| c.object.is_none()).map(|c| (c.bounds_m, c.centroid_m, c.cells))
            else {
                continue;
            };
            let mut best: Option<(f32, usize)> = None;
            let (lo, hi) = self.x_window(cb, gate);
            for m in lo..hi {
                let Some(j) = self.by_x.get(m).map(|&(_, j)| j as usize) else { continue };
                let Some(&(rb, bits)) = self.candidates.get(j) else { continue };
                let wanted = CANDIDATE_REGION | CANDIDATE_CONFIRMED;
                if bits & wanted != wanted || self.far_apart(cb, rb, gate) {
                    continue;
                }
                let Some(s) = self.scratch.get(j).filter(|s| s.cluster.is_none()) else { continue };
                let Some(region) = s.region else { continue };
                if !self.behind(&region.footprint, centroid) {
                    continue;
                }
                let Some(d) = self.cluster_distance(k, &region.grown, gate) else { continue };
                // At least as many cells as the occupied cells the box owns (its shape's evidence in front of it
                // outweighs what its region holds), fitting it, and the evidence that confirms it runs on beyond it.
                if (cells as f32) < s.own_sum[2]
                    || !self.evidence_fits(&region, k)
                    || !self.own_evidence_runs_on(j, &region, k)
                {
                    continue;
                }
                if best.is_none_or(|(bd, bj)| d.total_cmp(&bd).then(j.cmp(&bj)).is_lt()) {
                    best = Some((d, j));
                }
            }
            if let Some((_, j)) = best {
                self.give(k, j);
            }
        }
    }

    /// With `front_cluster`: true when the evidence that confirms object `j` runs on beyond its region: a hit cell it
    /// owns in its grown region is 8-adjacent to a hit cell outside the region that no object explains or that is
    /// known scenery (cluster `k`'s cells left out): the region's edge cuts through it, so it is a piece of
    /// something that continues past where the box could stand. Bounded: one walk over the region's cells and the
    /// 3 x 3 block of each owned one.
    fn own_evidence_runs_on(&self, j: usize, region: &Region, k: usize) -> bool {
        let geometry = self.grid.geometry;
        let half = 0.5 * geometry.cell_size_m;
        let grid = &self.grid;
        let cb = self.clusters.get(k).map_or([0.0; 4], |c| c.bounds_m);
        let in_k = |idx: u32, x: f32, y: f32| {
            x >= cb[0] && x <= cb[2] && y >= cb[1] && y <= cb[3] && self.cluster_cells(k).contains(&idx)
        };
        let Some(range) = geometry.cell_range(region.grown.aabb()) else { return false };
        let mut runs_on = false;
        geometry.for_each_cell_overlapping(&region.grown, range, |idx, _, _| {
            if runs_on || grid.hits(idx) == 0 || !self.owns(j, idx) {
                return;
            }
            runs_on = geometry.block3x3(idx).any(|c| {
                let flags = grid.flags(c);
                let (x, y) = geometry.cell_center(c);
                grid.hits(c) > 0
                    && (flags & FLAG_EXPLAINED == 0 || flags & FLAG_STATIC != 0)
                    && !region.grown.overlaps_square(x, y, half)
                    && !in_k(c, x, y)
            });
        });
        runs_on
    }

    /// The one-to-one assignment of step 3: the candidate pairs fall into groups (connected components of the
    /// graph of clusters and objects they join); in each group as many objects as possible get a cluster, with
    /// the smallest total displacement among those assignments ([`assignment::assign`]). A group with more than
    /// `MAX_SIDE` objects or clusters is assigned nearest pair first. Deterministic: groups and pairs are sorted.
    pub(super) fn assign_pairs(&mut self) {
        let base = self.params.max_clusters;
        let node = |k: u32, j: u32, object: bool| if object { base.saturating_add(j) } else { k };
        for &(_, k, j, _) in &self.pairs {
            for x in [node(k, j, false), node(k, j, true)] {
                if let Some(g) = self.groups.get_mut(x as usize) {
                    *g = x;
                }
            }
        }
        for p in 0..self.pairs.len() {
            let Some(&(_, k, j, _)) = self.pairs.get(p) else { continue };
            let (a, b) = (self.group_root(node(k, j, false)), self.group_root(node(k, j, true)));
            // The lower node is the root: the groups do not depend on the order of the pairs.
            let (lo, hi) = (a.min(b), a.max(b));
            if let Some(g) = self.groups.get_mut(hi as usize) {
                *g = lo;
            }
        }
        for p in 0..self.pairs.len() {
            let Some(&(_, k, _, _)) = self.pairs.get(p) else { continue };
            let root = self.group_root(k);
            if let Some(pair) = self.pairs.get_mut(p) {
                pair.3 = root;
            }
        }
        // By group; within it nearest first, ties by cluster, then object.
        self.pairs
            .sort_unstable_by(|a, b| a.3.cmp(&b.3).then(a.0.total_cmp(&b.0)).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut start = 0;
        while start < self.pairs.len() {
            let root = self.pairs.get(start).map_or(0, |p| p.3);
            let end = start + self.pairs.get(start..).map_or(0, |r| r.iter().take_while(|p| p.3 == root).count());
            let (mut objects, mut clusters) = ([0u32; assignment::MAX_SIDE], [0u32; assignment::MAX_SIDE]);
            let (mut no, mut nc, mut small) = (0usize, 0usize, true);
            let mut costs = [[f32::INFINITY; assignment::MAX_SIDE]; assignment::MAX_SIDE];
            for &(d, k, j, _) in self.pairs.get(start..end).unwrap_or(&[]) {
                let row = objects.get(..no).and_then(|l| l.iter().position(|&x| x == j)).or_else(|| {
                    let r = (no < assignment::MAX_SIDE).then_some(no);
                    if let Some(slot) = r.and_then(|r| objects.get_mut(r)) {
                        *slot = j;
                        no += 1;
                    }
                    r
                });
                let col = clusters.get(..nc).and_then(|l| l.iter().position(|&x| x == k)).or_else(|| {
                    let c = (nc < assignment::MAX_SIDE).then_some(nc);
                    if let Some(slot) = c.and_then(|c| clusters.get_mut(c)) {
                        *slot = k;
                        nc += 1;
                    }
                    c
                });
                match (row, col) {
                    (Some(r), Some(c)) => {
                        if let Some(x) = costs.get_mut(r).and_then(|row| row.get_mut(c)) {
                            *x = x.min(d);
                        }
                    }
                    _ => small = false,
                }
            }
            if small {
                let chosen = assignment::assign(no, nc, &costs);
                for (r, c) in chosen.iter().enumerate().take(no) {
                    let (Some(&j), Some(&k)) = (objects.get(r), c.and_then(|c| clusters.get(usize::from(c)))) else {
                        continue;
                    };
                    self.give(k as usize, j as usize);
                }
            } else {
                for p in start..end {
                    let Some(&(_, k, j, _)) = self.pairs.get(p) else { continue };
                    let free = self.clusters.get(k as usize).is_some_and(|c| c.object.is_none());
                    if free && self.scratch.get(j as usize).is_some_and(|s| s.cluster.is_none()) {
                        self.give(k as usize, j as usize);
                    }
                }
            }
            start = end.max(start + 1);
        }
    }

    /// Evidence of two boxes reported in one place: an unconfirmed object left without a cluster whose box
    /// overlaps (within a cell) the box of an object that was just given a cluster shares that cluster, if it
    /// could have taken it itself (within the gate, fitting its box, and it stands behind the cluster or the
    /// sensor contradicts its footprint). Two boxes in one place leave one blob of evidence; when both stand
    /// apart from it, the sensor cannot say whose it is, and both are displaced from it.
    pub(super) fn share_between_coincident_boxes(&mut self) {
        let tau_tp = self.params.tau_tp;
        let gate = self.params.conflict_association_m;
        let tol = self.grid.geometry.cell_size_m;
        for j in 0..self.scratch.len() {
            let Some(s) = self.scratch.get(j).copied() else { continue };
            let Some(region) = s.region.filter(|_| s.cluster.is_none() && s.eta_own < tau_tp) else { continue };
            // The tests below are pure: the cheap one on the bounds first (it rejects almost every pair), then the
            // other object's region, then the rest in their order.
            let aabb = region.grown.aabb();
            for k in 0..self.clusters.len() {
                let Some((m, centroid, bounds)) =
                    self.clusters.get(k).and_then(|c| c.object.map(|m| (m as usize, c.centroid_m, c.bounds_m)))
                else {
                    continue;
                };
                if self.far_apart(bounds, aabb, gate) {
                    continue;
                }
                let Some(other) = self.scratch.get(m).and_then(|o| o.region).filter(|_| m != j) else { continue };
                if !footprints_touch(&region.footprint, &other.footprint, tol)
                    || self.cluster_distance(k, &region.grown, gate).is_none()
                    || !self.evidence_fits(&region, k)
                {
                    continue;
                }
                let reachable = self.behind(&region.footprint, centroid)
                    || self.sight_of(j, &region).contradicted() >= self.params.ghost_visible_fraction;
                if reachable {
                    let cells = self.clusters.get(k).map_or(0, |c| c.cells);
                    if let Some(s) = self.scratch.get_mut(j) {
                        s.cluster = u16::try_from(k).ok().map(|k16| (k16, cells));
                    }
                    break;
                }
            }
        }
    }

    /// The root of a node of the pair graph (bounded: at most as many steps as there are nodes).
    fn group_root(&self, mut x: u32) -> u32 {
        for _ in 0..self.groups.len() {
            match self.groups.get(x as usize) {
                Some(&parent) if parent != x => x = parent,
                _ => break,
            }
        }
        x
    }

    /// The range of `by_x` whose regions' bounding boxes can come within `reach` of a cluster's bounds along x.
    pub(super) fn x_window(&self, cluster_bounds: [f32; 4], reach: f32) -> (usize, usize) {
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * self.grid.geometry.cell_size_m;
        let lo = cluster_bounds[0] - reach - half_diagonal - self.widest_m;
        let hi = cluster_bounds[2] + reach + half_diagonal;
        let start = self.by_x.partition_point(|&(x, _)| x < lo);
        let end = self.by_x.partition_point(|&(x, _)| x <= hi);
        (start, end.max(start))
    }

    /// Index of the reported cluster that contains a cell (linear in the conflict cells; only called for
    /// objects without evidence of their own).
    pub(super) fn cluster_of(spans: &[(u32, u32)], queue: &[u32], cell: u32) -> Option<usize> {
        if cell == NO_CELL {
            return None;
        }
        spans.iter().position(|&(a, b)| queue.get(a as usize..b as usize).is_some_and(|cells| cells.contains(&cell)))
    }

    /// Cells of cluster `k`.
    pub(super) fn cluster_cells(&self, k: usize) -> &[u32] {
        self.cluster_spans.get(k).and_then(|&(a, b)| self.queue.get(a as usize..b as usize)).unwrap_or(&[])
    }

    /// Attributes cluster `k` to object `j` (an object keeps its largest cluster as the one it reports).
    pub(super) fn give(&mut self, k: usize, j: usize) {
        let Some(cluster) = self.clusters.get_mut(k) else { return };
        cluster.object = u32::try_from(j).ok();
        let cells = cluster.cells;
        if let Some(&(a, b)) = self.cluster_spans.get(k) {
            for &c in self.queue.get(a as usize..b as usize).unwrap_or(&[]) {
                self.grid.set_flags(c, FLAG_ATTRIBUTED);
            }
        }
        if let Some(s) = self.scratch.get_mut(j) {
            if s.cluster.is_none_or(|(_, size)| cells > size) {
                s.cluster = u16::try_from(k).ok().map(|k16| (k16, cells));
            }
        }
    }
}

/// True when two boxes overlap or come within `tol` of each other (corner-to-box distances; a box inside the
/// other is caught by its centre).
fn footprints_touch(a: &crate::geometry::OrientedRect, b: &crate::geometry::OrientedRect, tol: f32) -> bool {
    let corners = |r: &crate::geometry::OrientedRect| {
        [(1.0f32, 1.0f32), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)].map(|(su, sv)| {
            let (u, v) = (su * r.half_length, sv * r.half_width);
            (r.cx + u * r.cos - v * r.sin, r.cy + u * r.sin + v * r.cos)
        })
    };
    a.contains(b.cx, b.cy)
        || b.contains(a.cx, a.cy)
        || corners(a).iter().any(|&(x, y)| b.distance(x, y) <= tol)
        || corners(b).iter().any(|&(x, y)| a.distance(x, y) <= tol)
}

/// The paper's consistency `eta` of report `j`.
pub(super) fn s_eta(reports: &[ObjectReport], j: usize) -> f32 {
    reports.get(j).map_or(0.0, |r| r.sensor.eta)
}

/// Candidate bit: the object has a region in the grid.
pub(super) const CANDIDATE_REGION: u8 = 1;
/// Candidate bit: the object is confirmed by its own evidence (`eta_own >= tau_tp`).
pub(super) const CANDIDATE_CONFIRMED: u8 = 2;
/// Candidate bit: the track's evidence stood apart from it in the previous frame.
pub(super) const CANDIDATE_DISPLACED: u8 = 4;
/// Candidate bit: the track was confirmed by its own evidence in the previous frame, is not now, and where that
/// evidence should stand now (its predicted centre plus the evidence's offset then) lies outside its region
/// ([`stayed_evidence`], step 3c).
pub(super) const CANDIDATE_STAYED: u8 = 8;

/// Average number of candidate objects per conflict cluster the evidence assignment keeps room for.
pub(super) const ASSOCIATION_CANDIDATES: usize = 8;

/// Marks a hit cell as explained by object `i`'s region and makes `i` its owner when the cell lies deepest in
/// `i`'s region so far (strictly: ties stay with the lower index).
///
/// Depth is measured relative to the region's size, `max(|u| / half length, |v| / half width)` in the region's
/// axes (1 on its edge): evidence on an object's face lies well inside its own region, while a neighbour whose
/// region only reaches it with its margin sees it near its edge, whatever the two objects' sizes.
#[inline]
pub(super) fn claim(
    grid: &mut OccupancyGrid,
    owner: &mut [u32],
    owner_depth: &mut [f32],
    region: &Region,
    i: usize,
    idx: u32,
    penalty: f32,
) {
    let (x, y) = grid.geometry.cell_center(idx);
    let (u, v) = region.grown.local(x, y);
    let d = (u.abs() / region.grown.half_length).max(v.abs() / region.grown.half_width) + penalty;
    let first = grid.flags(idx) & FLAG_EXPLAINED == 0;
    if let (Some(o), Some(od)) = (owner.get_mut(idx as usize), owner_depth.get_mut(idx as usize)) {
        if first || d < *od {
            *o = u32::try_from(i).unwrap_or(u32::MAX);
            *od = d;
        }
    }
    grid.set_flags(idx, FLAG_EXPLAINED);
}
