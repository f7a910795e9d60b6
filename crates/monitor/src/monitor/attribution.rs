//! The evidence attribution of the sensor checks (docs/attribution.md): which object each explained cell
//! belongs to (`eta_own`), what the sensor saw of a footprint, the gated one-to-one assignment of conflict
//! clusters to objects, the evidence memory's part in it, spill-over, and the free-space test towards the
//! sensor. Part of [`Monitor`]; `monitor.rs` keeps the stages and the verdicts.

/// How far below the top of an object's own evidence the lowest ray that reached it must have crossed a sample
/// point of the box for [`Monitor::seen_over`] to count the point as seen (metres): rays that only graze the top of
/// the evidence may have passed over a shorter body standing at the box (a neighbour's head seen over a parked car,
/// above a shorter pedestrian). 0.1 m raised the sensor false alarms up to 0.3 m noise on two of three seeds; 0.2 m
/// left them unchanged (docs/attribution.md, "Seen over the occluder").
pub(super) const SEEN_OVER_BELOW_TOP_M: f32 = 0.2;

use super::*;

/// What the sensor saw of an object's footprint (the cells overlapping it), for objects without evidence of
/// their own: was the place visibly empty, hidden, or taken by another object's evidence?
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct FootprintSight {
    /// Footprint cells.
    pub(super) total: u32,
    /// Seen empty: rays passed over them and returned from beyond.
    pub(super) visible: u32,
    /// Shadowed by evidence no object explains, in the region of interest (likely this object, displaced).
    pub(super) unexplained_shadow: u32,
    /// With `shadow_gate`: shadowed by unexplained evidence beyond the gate (hidden; counted in no other field).
    pub(super) far_shadow: u32,
    /// Occupied by evidence that another object owns, with the cell's centre inside that object's footprint:
    /// two objects cannot stand in one place.
    pub(super) foreign: u32,
    /// A cell of the unexplained evidence that shadows the footprint (`NO_CELL`: none).
    pub(super) occluder: u32,
    /// The first few distinct cells that stood for the unexplained evidence, with the shadowed cells each
    /// accounts for, so that the test can be brought up to date once evidence is attributed without a second
    /// walk over the footprint (`occluders_len > OCCLUDERS`: too many to keep; walk again).
    pub(super) occluders: [(u32, u32); OCCLUDERS],
    pub(super) occluders_len: usize,
}

impl FootprintSight {
    pub(super) fn fraction(&self, k: u32) -> f32 {
        if self.total > 0 {
            k as f32 / self.total as f32
        } else {
            0.0
        }
    }

    /// Share of the footprint the sensor contradicts: seen empty, behind unexplained evidence, or taken.
    pub(super) fn contradicted(&self) -> f32 {
        self.fraction(self.visible + self.unexplained_shadow + self.foreign)
    }
}

impl Monitor {
    /// `eta_own` of every object: the highest occupancy probability among the cells it owns (one pass over the
    /// touched cells).
    pub(super) fn own_evidence(&mut self) {
        let floor = self.grid.probability_of_hits(0);
        for s in &mut self.scratch {
            s.eta_own = floor;
        }
        let tau = self.params.tau_fn;
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
                }
            }
        }
    }

    /// What the sensor saw of object `j`'s footprint (see [`FootprintSight`]).
    ///
    /// Each footprint cell is looked at in the point of the footprint nearest to its centre (a cell centre can lie
    /// up to half a cell diagonal outside the box, in space that says nothing about the object), and that point
    /// counts as *seen empty* only when it lies in front of the nearest obstacle of its direction by more than the
    /// region's margin: the object's own surface can stand anywhere within its margin, so space just in front of
    /// a return may be the object itself (the same rule as [`Monitor::seen_through`]).
    pub(super) fn footprint_sight(&self, j: usize, region: &Region) -> FootprintSight {
        self.sight_at(j, &region.footprint, region.margin_length_m.max(region.margin_width_m))
    }

    /// [`Monitor::footprint_sight`] of a footprint placed anywhere (for the ghost test's shifted boxes).
    pub(super) fn sight_at(&self, j: usize, footprint: &crate::geometry::OrientedRect, margin: f32) -> FootprintSight {
        let geometry = self.grid.geometry;
        let mut sight = FootprintSight { occluder: NO_CELL, ..FootprintSight::default() };
        let Some(range) = geometry.cell_range(footprint.aabb()) else { return sight };
        // At most `SIGHT_SAMPLES` cells along each axis of the range are looked at (every `stride`-th row and
        // column): the fractions need no more, and a car at 0.1 m cells would otherwise cost 900 look-ups.
        let span = (range.2 - range.0).max(range.3 - range.1) + 1;
        let stride = span.div_ceil(SIGHT_SAMPLES).max(1);
        // Only the sampled rows and columns are walked (the same cells, in the same order, as filtering the walk
        // of every overlapping cell).
        geometry.for_each_cell_overlapping_every(footprint, range, stride, |idx, cx, cy| {
            self.sight_cell(&mut sight, j, footprint, margin, idx, cx, cy);
        });
        sight
    }

    /// One cell of [`Monitor::sight_at`]'s walk, counted into `sight`: in `total`, and in at most one of
    /// `foreign`, `visible` and `unexplained_shadow`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn sight_cell(
        &self,
        sight: &mut FootprintSight,
        j: usize,
        footprint: &crate::geometry::OrientedRect,
        margin: f32,
        idx: u32,
        cx: f32,
        cy: f32,
    ) {
        let (grid, visibility, tau) = (&self.grid, &self.visibility, self.params.tau_fn);
        sight.total += 1;
        if grid.probability(idx) > tau && grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) == FLAG_EXPLAINED {
            let other = self.owner.get(idx as usize).map_or(j, |&o| o as usize);
            let taken = other != j
                && self.scratch.get(other).and_then(|s| s.region).is_some_and(|r| r.footprint.contains(cx, cy));
            if taken {
                sight.foreign += 1;
                return;
            }
        }
        let (px, py) = footprint.nearest_point(cx, cy);
        // One look at the bin for the sight and the clearance (`VisibilityMap::sight_with_clearance`).
        match visibility.sight_with_clearance(px, py) {
            (Sight::Visible, clearance) => {
                if clearance.is_none_or(|clearance| clearance > margin) {
                    sight.visible += 1;
                }
            }
            // Behind evidence nobody explains, in the region of interest (with `shadow_gate`, only evidence
            // within reach of the point: farther evidence cannot be this object displaced; the cell is hidden).
            (Sight::Shadowed(c), _) => {
                let Some(k) = self.unexplained_at(c) else { return };
                if !self.shadow_within_gate(k, margin, px, py) {
                    sight.far_shadow += 1;
                } else {
                    sight.unexplained_shadow += 1;
                    sight.occluder = k;
                    let n = sight.occluders_len.min(OCCLUDERS);
                    if let Some(o) = sight.occluders.get_mut(..n).and_then(|l| l.iter_mut().find(|o| o.0 == k)) {
                        o.1 += 1;
                    } else {
                        if let Some(o) = sight.occluders.get_mut(n) {
                            *o = (k, 1);
                        }
                        sight.occluders_len += 1;
                    }
                }
            }
            (Sight::Unreached, _) => {}
        }
    }

    /// With `shadow_gate`: whether conflict cell `k`, which shadows footprint point `(px, py)`, has its centre within
    /// `conflict_association_m` + `margin` (the region's larger margin) + one cell diagonal of the point, so that
    /// it may be the object's own displaced evidence. Always true without the key.
    #[inline(always)]
    fn shadow_within_gate(&self, k: u32, margin: f32, px: f32, py: f32) -> bool {
        if !self.params.shadow_gate {
            return true;
        }
        let geometry = self.grid.geometry;
        let reach = self.params.conflict_association_m + margin + core::f32::consts::SQRT_2 * geometry.cell_size_m;
        let (x, y) = geometry.cell_center(k);
        let (dx, dy) = (x - px, y - py);
        dx * dx + dy * dy <= reach * reach
    }

    /// With `shadow_gate`, for a box without evidence of its own that is hidden: when the shadows the gate set
    /// aside (evidence beyond it) would have contradicted the box without the key, the free cluster in the region
    /// of interest nearest to the grown region within `conflict_association_m` (lowest index on ties), if any. Without
    /// the key such a box takes the far cluster that shadows it (a clean box hidden behind a displaced neighbour's
    /// evidence, most often); with it, only free evidence within the gate, which may be its own, displaced.
    pub(super) fn near_cluster_for_far_shadow(&self, sight: &FootprintSight, region: &Region) -> Option<usize> {
        if !self.params.shadow_gate || sight.far_shadow == 0 {
            return None;
        }
        let fraction = self.params.ghost_visible_fraction;
        let contradicted = sight.fraction(sight.visible + sight.unexplained_shadow + sight.foreign + sight.far_shadow);
        let open = sight.fraction(sight.visible + sight.unexplained_shadow + sight.far_shadow);
        if contradicted < fraction || open < fraction {
            return None;
        }
        let gate = self.params.conflict_association_m;
        // On the box's line of sight, beyond it: a cluster centre farther from the sensor than the box's centre, in
        // front of the sensor, and within the box's half diagonal + half a cell of the ray through the box's centre
        // (|cross| / rf is that distance). Squares only: no root per cluster.
        let footprint = &region.footprint;
        let o = self.visibility.origin();
        let (fx, fy) = (footprint.cx - o[0], footprint.cy - o[1]);
        let rf2 = fx * fx + fy * fy;
        let reach = libm::hypotf(footprint.half_length, footprint.half_width) + 0.5 * self.grid.geometry.cell_size_m;
        let grown = region.grown.aabb();
        let mut best: Option<(f32, usize)> = None;
        for (k, c) in self.clusters.iter().enumerate() {
            if !c.in_roi || c.object.is_some() || self.far_apart(c.bounds_m, grown, gate) {
                continue;
            }
            let (px, py) = (c.centroid_m[0] - o[0], c.centroid_m[1] - o[1]);
            let (cross, dot) = (fx * py - fy * px, fx * px + fy * py);
            let beyond = px * px + py * py > rf2 && dot > 0.0 && cross * cross <= reach * reach * rf2;
            if !beyond {
                continue;
            }
            if let Some(d) = self.cluster_distance(k, &region.grown, gate) {
                if best.is_none_or(|(b, _)| d < b) {
                    best = Some((d, k));
                }
            }
        }
        best.map(|(_, k)| k)
    }

    /// [`Monitor::hidden_within_margin`]'s test of one placement `moved`: the footprint's sight there, brought up
    /// to date for evidence attributed since ([`Monitor::without_attributed`]), has cells and less than
    /// `ghost_visible_fraction` of them visible or behind unexplained evidence. The same answer as computing the
    /// whole sight ([`Monitor::placement_hidden_by_full_sight`], the reference kept for the tests), decided as
    /// soon as the rows left cannot change it: the sampled rows (at most [`SIGHT_SAMPLES`]) are found first,
    /// which gives the final `total` before any cell is looked at; after each row, with `v` visible cells, `s`
    /// cells behind unexplained evidence and `r` cells left, the test's final count `k` lies between `v` and
    /// `v + s + r` (each cell adds at most one to `visible + unexplained_shadow`, and the update for attributed
    /// evidence only lowers `unexplained_shadow`), and the test's quotient `k as f32 / total as f32` (its own
    /// rounding, monotonic in `k`) at `v` already at least the fraction means not hidden, at `v + s + r` below
    /// it means hidden. (A NaN fraction, which validated parameters exclude, is never reached and never missed.)
    pub(super) fn placement_hidden(&self, j: usize, moved: &crate::geometry::OrientedRect, margin: f32) -> bool {
        self.placement_test(j, moved, margin).0
    }

    /// [`Monitor::placement_hidden`], and the number of cells it looked at.
    #[inline(always)]
    pub(super) fn placement_test(&self, j: usize, moved: &crate::geometry::OrientedRect, margin: f32) -> (bool, u32) {
        let geometry = self.grid.geometry;
        let Some(range) = geometry.cell_range(moved.aabb()) else { return (false, 0) };
        let span = (range.2 - range.0).max(range.3 - range.1) + 1;
        let stride = span.div_ceil(SIGHT_SAMPLES).max(1);
        let mut rows = [(0u32, 0u32, 0u32, 0.0f32); SIGHT_SAMPLES as usize];
        let (mut len, mut total) = (0usize, 0u32);
        geometry.for_each_sampled_run(moved, range, stride, |iy, first, last, cy| {
            if let Some(row) = rows.get_mut(len) {
                *row = (iy, first, last, cy);
                total += if first <= last { (last - first) / stride + 1 } else { 0 };
            }
            len += 1;
        });
        let fraction = self.params.ghost_visible_fraction;
        if len > rows.len() {
            // Not for a range sampled as `sight_at` samples it (at most `SIGHT_SAMPLES` rows); kept exact anyway.
            let sight = self.sight_at(j, moved, margin);
            return (self.hidden_by_sight(sight), sight.total);
        }
        let mut sight = FootprintSight { occluder: NO_CELL, ..FootprintSight::default() };
        for &(iy, first, last, cy) in rows.get(..len).unwrap_or(&[]) {
            let mut ix = first;
            while ix <= last {
                let idx = iy * geometry.cells_per_side + ix;
                self.sight_cell(&mut sight, j, moved, margin, idx, geometry.cell_center_axis(ix), cy);
                let Some(next) = ix.checked_add(stride) else { break };
                ix = next;
            }
            // Decided: the final count, at least `visible`, already reaches the fraction, or, at most `visible +
            // shadow + cells left`, cannot. (Tested per row: per cell cost more than it saved.)
            if total > 0 {
                let t = total as f32;
                if sight.visible as f32 / t >= fraction {
                    return (false, sight.total);
                }
                let most = sight.visible + sight.unexplained_shadow + total.saturating_sub(sight.total);
                if (most as f32) / t < fraction {
                    return (true, sight.total);
                }
            }
        }
        (self.hidden_by_sight(sight), sight.total)
    }

    /// The reference of [`Monitor::placement_hidden`]: the whole sight of the placement, then the test.
    #[cfg(test)]
    pub(super) fn placement_hidden_by_full_sight(
        &self,
        j: usize,
        moved: &crate::geometry::OrientedRect,
        margin: f32,
    ) -> bool {
        self.hidden_by_sight(self.sight_at(j, moved, margin))
    }

    /// The test of [`Monitor::hidden_within_margin`] on a placement's whole sight.
    fn hidden_by_sight(&self, sight: FootprintSight) -> bool {
        let sight = if sight.unexplained_shadow > 0 && sight.occluders_len <= OCCLUDERS {
            self.without_attributed(sight)
        } else {
            sight
        };
        // Seen empty or behind evidence nobody took: not there. Hidden, or on evidence another object
        // owns (two objects the sensor cannot tell apart, as in the verdicts' shared case): maybe there.
        sight.total > 0 && sight.fraction(sight.visible + sight.unexplained_shadow) < self.params.ghost_visible_fraction
    }

    /// The conflict cell (of a cluster in the region of interest) that stands for the nearest return `c` of a
    /// visibility bin: `c` itself, or, when `c` is unexplained but holds too few hits to be occupied (the first
    /// return of an object is often alone in its cell), an 8-neighbour of it. `None` when `c` is explained,
    /// scenery, or not next to unexplained evidence in the region of interest.
    pub(super) fn unexplained_at(&self, c: u32) -> Option<u32> {
        if c == NO_CELL || self.grid.hits(c) == 0 {
            return None;
        }
        let flags = self.grid.flags(c);
        if flags & FLAG_ATTRIBUTED != 0 {
            // Another object's displaced evidence: it hides what lies behind it, like any object.
            return None;
        }
        if flags & FLAG_ROI_CONFLICT != 0 {
            return Some(c);
        }
        if flags & (FLAG_EXPLAINED | FLAG_STATIC) != 0 {
            return None;
        }
        self.grid
            .geometry
            .block3x3(c)
            .find(|&idx| self.grid.flags(idx) & (FLAG_ROI_CONFLICT | FLAG_ATTRIBUTED) == FLAG_ROI_CONFLICT)
    }

    /// Distance from a cluster's cells (not their centres: no cell comes nearer than touching) to a region,
    /// metres, or `None` when it exceeds `reach` (decided first on bounding boxes, which skips most pairs).
    pub(super) fn cluster_distance(&self, k: usize, region: &crate::geometry::OrientedRect, reach: f32) -> Option<f32> {
        let geometry = self.grid.geometry;
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        let cluster = self.clusters.get(k)?;
        let rb = region.aabb();
        let cb = cluster.bounds_m;
        let gap_x = (cb[0] - rb[2]).max(rb[0] - cb[2]).max(0.0);
        let gap_y = (cb[1] - rb[3]).max(rb[1] - cb[3]).max(0.0);
        // Bounds are of cell centres: allow half a diagonal, as the exact test below does. First without the
        // square root: `hypot(gx, gy) >= max(gx, gy)` also after rounding, so this skips only pairs the test
        // with `hypotf` skips (most pairs are far apart).
        if gap_x.max(gap_y) - half_diagonal > reach || libm::hypotf(gap_x, gap_y) - half_diagonal > reach {
            return None;
        }
        let d = self.nearest_cell_distance(k, |x, y| region.outside_offsets(x, y));
        (d <= reach).then_some(d)
    }

    /// The smallest `distance(cell centre) - half a cell diagonal` (at least 0) over cluster `k`'s cells: how near
    /// its cells (not their centres) come to something. Stops at 0.
    ///
    /// `offsets(x, y)` gives the two legs whose `hypotf` is the distance from a cell centre (see
    /// [`nearest_distance`]).
    fn nearest_cell_distance(&self, k: usize, offsets: impl Fn(f32, f32) -> (f32, f32)) -> f32 {
        let geometry = self.grid.geometry;
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        nearest_distance(self.cluster_cells(k).iter().map(|&c| geometry.cell_center(c)), half_diagonal, offsets)
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
    ///    and fits its box, is that object's evidence reaching over its edge (the nearest such object).
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
        self.own_spans.clear();
        self.own_spans.resize(self.scratch.len().min(self.own_spans.capacity()), None);
        for k in 0..self.clusters.len() {
            let Some(cb) = self.clusters.get(k).filter(|c| c.in_roi && c.object.is_none()).map(|c| c.bounds_m) else {
                continue;
            };
            let mut best: Option<(f32, usize)> = None;
            let (lo, hi) = self.x_window(cb, adjacent);
            for m in lo..hi {
                let Some(j) = self.by_x.get(m).map(|&(_, j)| j as usize) else { continue };
                let Some(&(rb, bits)) = self.candidates.get(j) else { continue };
                // A confirmed object's own evidence continues into the cluster (8-adjacent cells), and both
                // together fit its box: the box is displaced (or too small). Evidence merely near a confirmed box
                // is not its. An unconfirmed object takes a cluster that touches its region and fits its box.
                let confirmed = bits & CANDIDATE_CONFIRMED != 0;
                // A cell next to an owned cell (which overlaps the region) is at most a cell diagonal from it.
                let reach = if confirmed { adjacent } else { touch };
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
                    self.cluster_touches_own_evidence(j, k) && {
                        let own = self.own_spans(j, &region);
                        match self.spill_over_fit {
                            SpillOverFit::Occupied => self.fits_with_own(&region, k, own[0]),
                            SpillOverFit::EveryReturn => self.spill_fits_with(&region, k, own),
                        }
                    }
                } else {
                    self.evidence_fits(&region, k)
                };
                // Nearest; ties to the lower index (deterministic whatever the loop order).
                if ok && best.is_none_or(|(bd, bj)| d.total_cmp(&bd).then(j.cmp(&bj)).is_lt()) {
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
        let (grid, owner) = (&self.grid, &self.owner);
        let cb = self.clusters.get(k).map_or([0.0; 4], |c| c.bounds_m);
        let in_k = |idx: u32, x: f32, y: f32| {
            x >= cb[0] && x <= cb[2] && y >= cb[1] && y <= cb[3] && self.cluster_cells(k).contains(&idx)
        };
        let Some(range) = geometry.cell_range(region.grown.aabb()) else { return false };
        let mut runs_on = false;
        geometry.for_each_cell_overlapping(&region.grown, range, |idx, _, _| {
            if runs_on
                || grid.hits(idx) == 0
                || grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) != FLAG_EXPLAINED
                || owner.get(idx as usize).is_none_or(|&o| o as usize != j)
            {
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

    /// True when the rays pass through most of object `j`'s footprint and end on its own evidence behind it:
    /// of 3 x 3 points spread over the box (at -0.6, 0 and 0.6 of its half length and half width), at least
    /// `ghost_visible_fraction` lie in front of the nearest obstacle of their direction by more than the
    /// region's margin (an object displaced by its stated uncertainty is not caught), and that obstacle is
    /// evidence the object owns (rays that pass beside a box's body, or end on something else, prove
    /// nothing). Points, not cells: the visibility map keeps the ranges of the returns themselves. With the
    /// params key `seen_over`, a point shadowed by another obstacle may count too ([`Monitor::seen_over`]).
    /// With the params key `seen_body`, a ray that ends on own evidence counts only when it ends on the object's
    /// *body*: no farther than the box's depth along the ray (plus the safety margin) beyond the nearest return,
    /// inside the grown region, of the object's own evidence (the visibility map's bins across the region). The
    /// grown region also owns returns behind the body (a neighbour's edge, a post); a box moved sideways within its
    /// stated uncertainty lets the rays pass beside the body and end there (docs/attribution.md, "Rays that end
    /// on the body"). Looked at only for a box the test would flag: one walk over the region's bins.
    pub(super) fn seen_through(&self, j: usize, region: &Region) -> bool {
        let fp = &region.footprint;
        let margin = region.margin_length_m.max(region.margin_width_m);
        let tau = self.params.tau_fn;
        let own = |c: u32| {
            self.grid.probability(c) > tau
                && self.grid.flags(c) & (FLAG_EXPLAINED | FLAG_STATIC) == FLAG_EXPLAINED
                && self.owner.get(c as usize).is_some_and(|&o| o as usize == j)
        };
        // The first return of a face is often alone in its cell: its occupied neighbour stands for it.
        let near_own = |c: u32| own(c) || self.grid.geometry.neighbours4(c).any(own);
        let o = self.visibility.origin();
        let mut free = 0u32;
        // With `seen_body`: for each free point whose ray ends on the own evidence, the range where it ends less
        // the box's depth along the ray (points freed by `seen_over` are not kept: `NEG_INFINITY`).
        let mut ends = [f32::NEG_INFINITY; 9];
        for u in [-0.6f32, 0.0, 0.6] {
            for v in [-0.6f32, 0.0, 0.6] {
                let (lu, lv) = (u * fp.half_length, v * fp.half_width);
                let (x, y) = (fp.cx + lu * fp.cos - lv * fp.sin, fp.cy + lu * fp.sin + lv * fp.cos);
                let Some((clearance, cell)) = self.visibility.clearance(x, y) else {
                    let behind_other = |c: u32| c != crate::visibility::NO_CELL && !near_own(c);
                    if self.params.seen_over {
                        if let crate::visibility::Sight::Shadowed(occluder) = self.visibility.sight(x, y) {
                            if behind_other(occluder) && self.seen_over(x, y, margin, fp, occluder, &near_own) {
                                free += 1;
                            }
                        }
                    }
                    continue;
                };
                if clearance > margin && near_own(cell) {
                    if self.params.seen_body {
                        let (dx, dy) = (x - o[0], y - o[1]);
                        let r = libm::sqrtf(dx * dx + dy * dy);
                        // The box's extent along the ray: the ranges of a body inside it differ by no more.
                        let (along, across) = if r > 0.0 {
                            ((dx * fp.cos + dy * fp.sin) / r, (dy * fp.cos - dx * fp.sin) / r)
                        } else {
                            (1.0, 1.0)
                        };
                        let depth = 2.0 * (fp.half_length * along.abs() + fp.half_width * across.abs());
                        if let Some(end) = ends.get_mut(free as usize) {
                            *end = r + clearance - depth;
                        }
                    }
                    free += 1;
                }
            }
        }
        let needed = self.params.ghost_visible_fraction * 9.0;
        if (free as f32) < needed || !self.params.seen_body {
            return free as f32 >= needed;
        }
        // `seen_body`: a ray counts only when it ends on the object's body, within the box's depth (and the
        // safety margin) of the nearest return of the object's own evidence in the directions the grown region
        // spans. A ray that passes beside the body and ends on a post or a neighbour's edge behind it, which the
        // grown region also owns, proves nothing about a box moved sideways within its stated uncertainty.
        let mut front = f32::INFINITY;
        if !self.visibility.nearest_obstacles_across(&region.grown.corners(), |r, c, p| {
            if r < front && own(c) && region.grown.contains(p[0], p[1]) {
                front = r;
            }
        }) {
            return true;
        }
        let reach = front + self.params.safety_margin_m;
        let on_body = ends.iter().filter(|&&end| end != f32::NEG_INFINITY && end <= reach).count();
        let freed_over = free as usize - ends.iter().filter(|&&end| end != f32::NEG_INFINITY).count();
        (on_body + freed_over) as f32 >= needed
    }

    /// With `seen_over` (off by default): a sample point of a box that the 2-D visibility map calls shadowed by a
    /// nearer obstacle that is not the object's own evidence (a parked car in front of a pedestrian), seen over that
    /// obstacle. The 2-D map keeps only the nearest obstacle of each direction, so a box behind a parked car reads
    /// as hidden although the LiDAR saw its object over the car's roof. The point counts as seen empty when (1)
    /// its cell has no return; (2) walking from it towards the sensor over the box's reach, no cell with returns
    /// is (or borders) the object's own evidence: no face of the object stands in front of the point; (3) walking
    /// away from the sensor, the first cell with returns is (or borders) the object's own evidence, and that
    /// cell's nearest return lies more than the margin behind the point; and (4) the lowest ray that reached that
    /// cell (through its lowest return; taken no lower than the cell's returns allow) crossed the point above the
    /// obstacle band's floor and at least [`SEEN_OVER_BELOW_TOP_M`] below the top of that cell's returns: where a
    /// body as tall as the evidence would have stopped it. (5) A ray along the point's direction that reached
    /// the point passed over the `occluder` (the 2-D map's nearest obstacle of that direction), so it crossed the
    /// point no lower than the occluder's shadow line (the line from the sensor over the top of the occluder's
    /// returns, taken no lower than the occluder cell's ranges allow): (4) is asked of the higher of the two
    /// heights, and some return of the evidence cell must lie above that line where it stands. The lowest return
    /// of a cell a cell wide may have come beside the occluder, along another direction, and says nothing
    /// about the point (the sensor false alarms it raised: docs/attribution.md, "Seen over the occluder").
    /// Bounded: two walks of at most `4 (half length + half width + margin) / cell` steps.
    fn seen_over(
        &self,
        x: f32,
        y: f32,
        margin: f32,
        fp: &crate::geometry::OrientedRect,
        occluder: u32,
        near_own: &dyn Fn(u32) -> bool,
    ) -> bool {
        let o = self.visibility.origin();
        let (dx, dy) = (x - o[0], y - o[1]);
        let r = libm::sqrtf(dx * dx + dy * dy);
        if r.is_nan() || r <= 1e-3 {
            return false;
        }
        let (ux, uy) = (dx / r, dy / r);
        let geometry = self.grid.geometry;
        let Some(c0) = geometry.point_to_cell(x, y) else { return false };
        if self.grid.hits(c0) > 0 {
            return false;
        }
        let step = 0.5 * geometry.cell_size_m;
        let reach = 2.0 * (fp.half_length + fp.half_width + margin);
        // Towards the sensor: no return of the object's own evidence in front of the point (its face is there).
        let mut t = step;
        while t <= reach {
            let Some(c) = geometry.point_to_cell(x - ux * t, y - uy * t) else { break };
            t += step;
            if c != c0 && self.grid.hits(c) > 0 && near_own(c) {
                return false;
            }
        }
        let mut t = step;
        while t <= reach {
            let Some(c) = geometry.point_to_cell(x + ux * t, y + uy * t) else { return false };
            t += step;
            if c == c0 || self.grid.hits(c) == 0 {
                continue;
            }
            if !near_own(c) {
                return false;
            }
            let Some([r2min, zlow, ztop]) = self.grid.returns(c) else { return false };
            let rmin = libm::sqrtf(r2min);
            let clearance = rmin - r;
            if clearance.is_nan() || clearance <= margin {
                return false;
            }
            // The lowest ray that reached the cell, from its lowest return and a range that bounds that return's
            // from the side that lowers the ray least: the cell's returns lie within a cell diagonal of its nearest.
            let diagonal = core::f32::consts::SQRT_2 * geometry.cell_size_m;
            // The slope of a ray from the sensor through a return at height `z`, nearest range `range` of its cell:
            // the return lies within a cell diagonal beyond it, taken where the ray is highest.
            let slope_through = |z: f32, range: f32| {
                let dz = z - self.sensor_z;
                if dz < 0.0 {
                    dz / (range + diagonal)
                } else {
                    dz / range
                }
            };
            let h = self.sensor_z + slope_through(zlow, rmin) * r;
            // The occluder's shadow line: no ray along this direction passed over it lower.
            let Some([o2min, _, otop]) = self.grid.returns(occluder) else { return false };
            let shadow = slope_through(otop, libm::sqrtf(o2min));
            let h = h.max(self.sensor_z + shadow * r);
            let (lo, _) = self.params.obstacle_band_m();
            return h <= ztop - SEEN_OVER_BELOW_TOP_M && h >= lo && self.sensor_z + shadow * rmin <= ztop;
        }
        false
    }

    /// True when object `j`'s footprint, moved anywhere within its region `A_o` ([`placements`]: by its margins
    /// along and across the box, in steps of half a margin), is mostly hidden from the sensor or on another
    /// object's evidence in one of them: the object may stand there, so the sensor cannot call it a ghost. (A
    /// noisy object list puts a hidden pedestrian's box half out of the shadow it stands in; its stated
    /// uncertainty allows the place in the shadow.) The places in between matter: a shadow narrower than the
    /// margin (a pedestrian far behind a post or another pedestrian) can lie between the box and its eight
    /// extreme places, all of them half in view (3 of the 13 sensor false alarms up to 0.3 m noise of
    /// `reproduce --quick`, seeds 7 and 11, were such ghosts while the eight extreme places alone were tried).
    pub(super) fn hidden_within_margin(&self, j: usize, region: &Region) -> bool {
        let margin = region.margin_length_m.max(region.margin_width_m);
        // A region in open view is hidden nowhere: no placement needs its walk (`open_view`, exact).
        if self.open_view(region, margin) {
            return false;
        }
        // Each placement decided as soon as its rows left cannot change the answer (`placement_hidden`).
        placements(region).any(|moved| self.placement_hidden(j, &moved, margin))
    }

    /// True only when no placement of [`Monitor::hidden_within_margin`] can be hidden, told from the grown region
    /// as a whole: every place the placements' walks look at lies in the grown region (each placement is the
    /// footprint shifted by at most its margins, and each look-up takes the placement's point nearest a cell
    /// centre), so when no cell of the region's range (a millimetre or so wider) holds occupied evidence (no cell is
    /// `foreign`) and the visibility map sees every point of the region's bounding box empty with more than
    /// `margin` to spare ([`crate::visibility::VisibilityMap::box_seen_empty`]), every cell of every placement's
    /// walk is visible: the visible fraction is 1, and `ghost_visible_fraction` is at most 1. False when it cannot
    /// tell; then the placements are walked as before. Tested against the walks
    /// (`a_placement_decided_early_equals_its_whole_sight`) and, in the visibility map, point by point
    /// (`a_box_seen_empty_is_seen_empty_at_every_point`).
    pub(super) fn open_view(&self, region: &Region, margin: f32) -> bool {
        let geometry = self.grid.geometry;
        let g = region.grown.aabb();
        // A little wider: the placements' boxes are within the grown one up to their rounding (the slack the
        // visibility test allows too).
        let c = crate::visibility::open_view_slack_m(g);
        let Some((ix0, iy0, ix1, iy1)) = geometry.cell_range_clipped([g[0] - c, g[1] - c, g[2] + c, g[3] + c]) else {
            return false;
        };
        let (tau, n) = (self.params.tau_fn, geometry.cells_per_side);
        for iy in iy0..=iy1 {
            for ix in ix0..=ix1 {
                if self.grid.probability(iy * n + ix) > tau {
                    return false;
                }
            }
        }
        self.visibility.box_seen_empty(g, margin)
    }

    /// For a track whose evidence stood apart from it last frame (remembered as displaced), or that keeps an offset
    /// alarms found over a gap (`memory_hold_s`; only where it puts the evidence in front of the box): the centre of
    /// the occupied cells outside its region, within `conflict_association_m / 2` of where its offset puts that
    /// evidence now, that another object explains only through its margin (cell centre outside that object's box),
    /// if any. Such evidence is no conflict, so no cluster carries it, but no other object stands on it. Bounded: the
    /// cells of a square of side `conflict_association_m` around the expected place.
    pub(super) fn followed_evidence(&self, j: usize, region: &Region) -> Option<[f32; 2]> {
        let s = self.scratch.get(j)?;
        // The offset of the previous frame's alarm, or one held since (`memory_hold_s`): a held one only where it
        // puts the evidence in front of the box on its line of sight (the box stands behind its own evidence).
        let (r, held) = match s.recalled {
            Some((EvidenceKind::Displaced, r)) => (r, false),
            _ => (s.hold?.offset_m, true),
        };
        let expected = [region.footprint.cx + r[0], region.footprint.cy + r[1]];
        if held && !self.behind(&region.footprint, expected) {
            return None;
        }
        let reach = 0.5 * self.params.conflict_association_m;
        let geometry = self.grid.geometry;
        let (ix0, iy0, ix1, iy1) = geometry.cell_range_clipped([
            expected[0] - reach,
            expected[1] - reach,
            expected[0] + reach,
            expected[1] + reach,
        ])?;
        let (tau, n) = (self.params.tau_fn, geometry.cells_per_side);
        // With `follow_gate` (the default) or `memory_gate`: only cells within the gate of the box count (step 4's
        // bound; without it a track could stay flagged by cells many metres away, where an offset taken once put its
        // evidence).
        let gate = self.params.conflict_association_m + core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        let beyond_gate = |region: &Region, x: f32, y: f32| {
            (self.params.memory_gate || self.params.follow_gate) && region.grown.distance(x, y) > gate
        };
        let mut sum = [0.0f32; 3];
        for iy in iy0..=iy1 {
            for ix in ix0..=ix1 {
                let idx = iy * n + ix;
                if self.grid.hits(idx) == 0
                    || self.grid.probability(idx) <= tau
                    || self.grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC | FLAG_ATTRIBUTED) != FLAG_EXPLAINED
                {
                    continue;
                }
                let (x, y) = geometry.cell_center(idx);
                // Displaced evidence lies outside the object's own region (inside it, it would confirm the object
                // or lie where its stated uncertainty allows).
                if libm::hypotf(x - expected[0], y - expected[1]) > reach || region.grown.contains(x, y) {
                    continue;
                }
                let owner = self.owner.get(idx as usize).map_or(j, |&o| o as usize);
                let in_box = self.scratch.get(owner).and_then(|o| o.region).is_some_and(|o| o.footprint.contains(x, y));
                if owner == j || in_box || beyond_gate(region, x, y) {
                    continue;
                }
                sum = [sum[0] + x, sum[1] + y, sum[2] + 1.0];
            }
        }
        (sum[2] >= 1.0).then(|| [sum[0] / sum[2], sum[1] / sum[2]])
    }

    /// With `memory_gate`: whether cluster `k`, which shadows an unconfirmed box's footprint, stands within the
    /// gate of its region (`conflict_association_m`), as every cluster offered in step 3 does. Without the key
    /// any such cluster is taken, however far in front of the box it stands (seen: a pedestrian 32 m out taking
    /// evidence 26 m in front of it, then held displaced by step 8 for 80 frames). Always true without the key.
    pub(super) fn occluder_within_gate(&self, k: usize, region: &Region) -> bool {
        !self.params.memory_gate
            || self.cluster_distance(k, &region.grown, self.params.conflict_association_m).is_some()
    }

    /// The evidence follows its object, also when the box keeps evidence in its region (issue #10): for a track
    /// confirmed by its own evidence in the previous frame, the centre that frame's object list predicts for now
    /// (its centre then plus its stated velocity times the time step) and where the box is reported now differ by
    /// more than the box's uncertainty allows over two frames, along or across the box; the occupied cells within
    /// the grown region placed at the predicted centre (not standing in another object's box) hold at least half as
    /// many cells as its own evidence held then; and their centre stands where the previous offset from box to
    /// evidence, applied at the predicted centre, puts it, not where the same offset puts it from the reported box.
    /// Then the object jumped away from its evidence, which stayed where a body moving as stated would be: a
    /// position error: returns that evidence's centre and where it puts the box's centre (the remembered offset
    /// back from it). The allowance along each axis is
    /// `2 (margin - delta_safe) + delta_safe + cell size`: the stated uncertainty in each of the two frames, the
    /// safety margin, and half a cell of rounding of each frame's evidence centre. Bounded: one walk over the cells
    /// of one region, for objects whose reported centre jumped only.
    ///
    /// With the params key `jump_from_returns` (and the previous frame's returns recorded), the same tests are also
    /// made with both evidence centres taken as the mean of the returns in the same cells instead of the mean of the
    /// cells' centres, and an allowance whose rounding term (a cell) gives way to twice the safety margin:
    /// `2 (margin - delta_safe) + 3 delta_safe` (docs/attribution.md, "Step 9 from the returns"); the box jumped
    /// when either centre says so. The returns' test also flags a box whose jump and whose distance from where the
    /// returns put it both reach beyond the *ellipse* with those semi-axes (a jump diagonal to the box, under the
    /// allowance along each axis), when the returns stand within `3 delta_safe` (as a distance, not per axis) of
    /// where the prediction puts them: that quantity holds no box noise, so a tight bound on its length shows the
    /// object moved as stated, and what is left of the jump is the two frames' position noise, whose stated
    /// covariance bounds it by an ellipse rather than a rectangle (docs/attribution.md, "The diagonal test"). The
    /// centre returned (what the memory keeps) stays the cells' mean; where the evidence puts the box is the mean
    /// the test that fired used, less its remembered offset.
    pub(super) fn moved_from_evidence(&self, j: usize, region: &Region) -> Option<([f32; 2], [f32; 2])> {
        let s = self.scratch.get(j)?;
        let (p, before, returns_offset) = s.predicted?;
        let Some((EvidenceKind::Own, cell_offset)) = s.recalled else { return None };
        let returns_offset = returns_offset.filter(|_| self.grid.has_sums());
        let fp = &region.footprint;
        let geometry = self.grid.geometry;
        let (cells_allow, returns_allow) = self.jump_allowances(region);
        let beyond = |d: [f32; 2], allow: [f32; 2]| beyond_allowance(fp, d, allow);
        // The box jumped: its centre beyond an allowance from the prediction (each test with its own; the returns'
        // beyond its ellipse, which every jump beyond the rectangle also is).
        let jump = [fp.cx - p[0], fp.cy - p[1]];
        let returns_offset = returns_offset.filter(|_| beyond_ellipse(fp, jump, returns_allow));
        let by_cells = beyond(jump, cells_allow);
        if returns_offset.is_none() && !by_cells {
            return None;
        }
        let moved = crate::geometry::OrientedRect { cx: p[0], cy: p[1], ..region.grown };
        let range = geometry.cell_range(moved.aabb())?;
        let tau = self.params.tau_fn;
        // A box reported where the predicted box stands is the same place, not a neighbour that moved onto it
        // (params key `jump_coincident_boxes`): its cells count. So do a box reported where this box stands (a
        // second label on the same object that jumped with it: where it claims to be is where this box claims).
        let predicted_box = crate::geometry::OrientedRect { cx: p[0], cy: p[1], ..*fp };
        let same_place = self.params.jump_coincident_boxes;
        let half_cell = 0.5 * geometry.cell_size_m;
        // A neighbour whose own box jumped from its prediction, beyond the ellipse this box's jump is tested against
        // (params key `jump_jumped_boxes`), claims nothing by standing there.
        let jumped_nb = |os: &super::ObjectScratch, o: &Region| {
            self.params.jump_jumped_boxes
                && os.predicted.is_some_and(|(q, _, _)| {
                    let jump = [o.footprint.cx - q[0], o.footprint.cy - q[1]];
                    beyond_ellipse(&o.footprint, jump, self.jump_allowances(o).1)
                })
        };
        let mut sum = [0.0f32; 3];
        let mut ret = [0.0f32; 3];
        geometry.for_each_cell_overlapping(&moved, range, |idx, x, y| {
            if self.grid.hits(idx) == 0 || self.grid.probability(idx) <= tau || self.grid.flags(idx) & FLAG_STATIC != 0
            {
                return;
            }
            if self.grid.flags(idx) & FLAG_EXPLAINED != 0 {
                let owner = self.owner.get(idx as usize).map_or(j, |&o| o as usize);
                if owner != j
                    && self.scratch.get(owner).is_some_and(|os| {
                        os.region.is_some_and(|o| {
                            o.footprint.contains(x, y)
                                && !(same_place
                                    && (in_one_place(&o.footprint, &predicted_box, half_cell)
                                        || in_one_place(&o.footprint, fp, half_cell)))
                                && !jumped_nb(os, &o)
                        })
                    })
                {
                    return;
                }
            }
            sum = [sum[0] + x, sum[1] + y, sum[2] + 1.0];
            if let (Some(e), true) = (self.grid.sums(idx), returns_offset.is_some()) {
                if e[2] > 0.0 {
                    ret = [ret[0] + e[0], ret[1] + e[1], ret[2] + e[2]];
                }
            }
        });
        if sum[2] < (0.5 * before).max(1.0) {
            return None;
        }
        let cells = [sum[0] / sum[2], sum[1] / sum[2]];
        // The evidence moved as the object said (within the allowance of where the remembered offset puts it from
        // the prediction) and the box did not (beyond it from where the offset puts it from the box).
        let jumped = |c: [f32; 2], r: [f32; 2], allow: [f32; 2]| {
            let from_prediction = [c[0] - (p[0] + r[0]), c[1] - (p[1] + r[1])];
            let from_box = [c[0] - (fp.cx + r[0]), c[1] - (fp.cy + r[1])];
            (!beyond(from_prediction, allow) && beyond(from_box, allow)).then_some([c[0] - r[0], c[1] - r[1]])
        };
        // The diagonal test (returns only): the returns within `3 delta_safe` of the prediction as a distance, and
        // the box beyond the allowance's ellipse both from the prediction (above) and from where they put it.
        let evidence_allow = 3.0 * self.params.safety_margin_m;
        let diagonal = |c: [f32; 2], r: [f32; 2]| {
            let from_prediction = [c[0] - (p[0] + r[0]), c[1] - (p[1] + r[1])];
            let from_box = [c[0] - (fp.cx + r[0]), c[1] - (fp.cy + r[1])];
            // The box is beyond the ellipse from the prediction (tested above); without the params key
            // `jump_evidence_at_prediction` also from where the returns put it (their scatter counted twice).
            (from_prediction[0] * from_prediction[0] + from_prediction[1] * from_prediction[1]
                <= evidence_allow * evidence_allow
                && (self.params.jump_evidence_at_prediction || beyond_ellipse(fp, from_box, returns_allow)))
            .then_some([c[0] - r[0], c[1] - r[1]])
        };
        let by_returns = returns_offset.filter(|_| ret[2] >= 1.0).and_then(|r| {
            let c = [ret[0] / ret[2], ret[1] / ret[2]];
            jumped(c, r, returns_allow).filter(|_| beyond(jump, returns_allow)).or_else(|| diagonal(c, r))
        });
        by_returns.or_else(|| jumped(cells, cell_offset, cells_allow).filter(|_| by_cells)).map(|at| (cells, at))
    }

    /// Step 9's allowances along and across the box, `(cells' mean, returns' mean)`: the stated uncertainty in
    /// each of the two frames and the safety margin, plus the scatter of each frame's evidence centre (half a cell
    /// of rounding of the cells' mean in each frame, or one safety margin of the returns' mean in each).
    pub(super) fn jump_allowances(&self, region: &Region) -> ([f32; 2], [f32; 2]) {
        let delta = self.params.safety_margin_m;
        let base_u = 2.0 * (region.margin_length_m - delta) + delta;
        let base_v = 2.0 * (region.margin_width_m - delta) + delta;
        let cell = self.grid.geometry.cell_size_m;
        ([base_u + cell, base_v + cell], [base_u + 2.0 * delta, base_v + 2.0 * delta])
    }

    /// A sight brought up to date after the attribution: shadows cast by evidence now attributed to an object
    /// hide rather than contradict.
    pub(super) fn without_attributed(&self, mut sight: FootprintSight) -> FootprintSight {
        sight.occluder = NO_CELL;
        for &(cell, count) in sight.occluders.get(..sight.occluders_len).unwrap_or(&[]) {
            if self.grid.flags(cell) & FLAG_ATTRIBUTED != 0 {
                sight.unexplained_shadow = sight.unexplained_shadow.saturating_sub(count);
            } else {
                sight.occluder = cell;
            }
        }
        sight
    }

    /// What the sensor saw of object `j`'s footprint, computed once per frame (see [`FootprintSight`]).
    pub(super) fn sight_of(&mut self, j: usize, region: &Region) -> FootprintSight {
        if let Some(sight) = self.scratch.get(j).and_then(|s| s.sight) {
            return sight;
        }
        let sight = self.footprint_sight(j, region);
        if let Some(s) = self.scratch.get_mut(j) {
            s.sight = Some(sight);
        }
        sight
    }

    /// True when a cluster's bounds (of cell centres) and a region's bounding box are more than `reach` apart,
    /// cells included (a lower bound of [`Monitor::cluster_distance`]: skips most pairs cheaply).
    pub(super) fn far_apart(&self, cluster_bounds: [f32; 4], region_aabb: [f32; 4], reach: f32) -> bool {
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * self.grid.geometry.cell_size_m;
        let gap_x = (cluster_bounds[0] - region_aabb[2]).max(region_aabb[0] - cluster_bounds[2]);
        let gap_y = (cluster_bounds[1] - region_aabb[3]).max(region_aabb[1] - cluster_bounds[3]);
        gap_x.max(gap_y) - half_diagonal > reach
    }

    /// Index of the reported cluster that contains a cell (linear in the conflict cells; only called for
    /// objects without evidence of their own).
    pub(super) fn cluster_of(spans: &[(u32, u32)], queue: &[u32], cell: u32) -> Option<usize> {
        if cell == NO_CELL {
            return None;
        }
        spans.iter().position(|&(a, b)| queue.get(a as usize..b as usize).is_some_and(|cells| cells.contains(&cell)))
    }

    /// True when a footprint lies behind a point as the sensor sees them: the point's bearing within the
    /// footprint's angular extent (plus half a cell), and the point nearer than the footprint's centre.
    pub(super) fn behind(&self, footprint: &crate::geometry::OrientedRect, point: [f32; 2]) -> bool {
        let o = self.visibility.origin();
        let (fx, fy) = (footprint.cx - o[0], footprint.cy - o[1]);
        let (px, py) = (point[0] - o[0], point[1] - o[1]);
        let (rf, rp) = (libm::hypotf(fx, fy), libm::hypotf(px, py));
        // Also false for NaN distances.
        if rp.partial_cmp(&rf) != Some(core::cmp::Ordering::Less) || rf <= 0.0 {
            return false;
        }
        let reach = libm::hypotf(footprint.half_length, footprint.half_width) + 0.5 * self.grid.geometry.cell_size_m;
        // The angle between the two directions is at most `asin(reach / rf)`: in front (positive dot product),
        // and `sin(angle) = |cross| / (rf rp) <= reach / rf` (any angle up to 90 degrees once `reach >= rf`).
        let (cross, dot) = ((fx * py - fy * px).abs(), fx * px + fy * py);
        dot > 0.0 && (reach >= rf || cross <= reach * rp)
    }

    /// Distance from a cluster's cells to a point, metres (no cell comes nearer than touching), or `None` beyond
    /// `reach`.
    pub(super) fn cluster_point_distance(&self, k: usize, p: [f32; 2], reach: f32) -> Option<f32> {
        let cb = self.clusters.get(k)?.bounds_m;
        if self.point_far(cb, p, reach) {
            return None;
        }
        let d = self.nearest_cell_distance(k, |x, y| (x - p[0], y - p[1]));
        (d <= reach).then_some(d)
    }

    /// True when a cluster's bounds (of cell centres) and a point are more than `reach` apart, cells included (the
    /// lower bound [`Monitor::cluster_point_distance`] tests first).
    #[inline]
    pub(super) fn point_far(&self, cluster_bounds: [f32; 4], p: [f32; 2], reach: f32) -> bool {
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * self.grid.geometry.cell_size_m;
        let cb = cluster_bounds;
        let gap_x = (cb[0] - p[0]).max(p[0] - cb[2]).max(0.0);
        let gap_y = (cb[1] - p[1]).max(p[1] - cb[3]).max(0.0);
        gap_x.max(gap_y) - half_diagonal > reach
    }

    /// Cells of cluster `k`.
    pub(super) fn cluster_cells(&self, k: usize) -> &[u32] {
        self.cluster_spans.get(k).and_then(|&(a, b)| self.queue.get(a as usize..b as usize)).unwrap_or(&[])
    }

    /// True when a cell of cluster `k` is 8-adjacent to an occupied cell that object `j` owns.
    pub(super) fn cluster_touches_own_evidence(&self, j: usize, k: usize) -> bool {
        let tau = self.params.tau_fn;
        self.cluster_cells(k).iter().any(|&c| {
            self.grid.geometry.block3x3(c).any(|idx| {
                self.grid.probability(idx) > tau
                    && self.grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) == FLAG_EXPLAINED
                    && self.owner.get(idx as usize).is_some_and(|&o| o as usize == j)
            })
        })
    }

    /// The slack of the fit tests ([`Monitor::fits_with_own`], [`Monitor::spill_fits_with`]) beyond a box's length and
    /// width: one cell diagonal (a cell centre is within half a diagonal of every point of its cell) and twice the
    /// safety margin (LiDAR noise).
    #[inline]
    fn fit_slack(&self) -> f32 {
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
        let mut add = |x: f32, y: f32| {
            let (u, v) = fp.local(x, y);
            span = [span[0].min(u), span[1].max(u), span[2].min(v), span[3].max(v)];
        };
        for &c in self.cluster_cells(k) {
            let (x, y) = geometry.cell_center(c);
            add(x, y);
        }
        let tau = self.params.tau_fn;
        if let Some(range) = geometry.cell_range(region.grown.aabb()) {
            let (grid, owner) = (&self.grid, &self.owner);
            geometry.for_each_cell_overlapping(&region.grown, range, |idx, x, y| {
                if grid.probability(idx) > tau
                    && grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) == FLAG_EXPLAINED
                    && owner.get(idx as usize).is_some_and(|&o| o as usize == j)
                {
                    add(x, y);
                }
            });
        }
        span[1] - span[0] <= 2.0 * fp.half_length + slack && span[3] - span[2] <= 2.0 * fp.half_width + slack
    }

    /// The fit test of spill-over to a confirmed object `j` (step 5) with [`SpillOverFit::EveryReturn`]:
    /// [`Monitor::evidence_fits_walking_own`], then the same with its own evidence counting every return rather than
    /// the occupied cells only. The box's own returns are the hit cells
    /// it owns in its region, however few their hits, and the cluster's are its cells and the hit cells 8-adjacent
    /// to them that no object explains (returns too sparse to be occupied that continue the cluster). A box whose
    /// evidence moved with it leaves no return of its own where the displaced box no longer reaches, and its
    /// displaced evidence ends within its extent: a box that keeps a return at its far end, or a cluster whose
    /// returns run on beyond the box's extent, is a clean box next to unlabelled returns (docs/attribution.md,
    /// "spill-over counts every return"). Bounded: one walk over the region's cells and the 3 x 3 neighbourhood of
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
        let mut span = [f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY];
        let mut add = |x: f32, y: f32| {
            let (u, v) = fp.local(x, y);
            span = [span[0].min(u), span[1].max(u), span[2].min(v), span[3].max(v)];
        };
        let (grid, owner) = (&self.grid, &self.owner);
        let own = |idx: u32| {
            grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) == FLAG_EXPLAINED
                && owner.get(idx as usize).is_some_and(|&o| o as usize == j)
        };
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
                if grid.hits(idx) > 0 && own(idx) {
                    add(x, y);
                }
            });
        }
        span[1] - span[0] <= 2.0 * fp.half_length + slack && span[3] - span[2] <= 2.0 * fp.half_width + slack
    }

    /// Object `j`'s own spans in its box's axes (see the field `own_spans`): the occupied cells and the hit cells
    /// it owns in its grown region, each as `[u min, u max, v min, v max]` (infinite bounds when there are none).
    /// One walk over the region's cells the first time spill-over asks in a frame, the stored answer after.
    pub(super) fn own_spans(&mut self, j: usize, region: &Region) -> [[f32; 4]; 2] {
        if let Some(Some(spans)) = self.own_spans.get(j) {
            return *spans;
        }
        let mut spans = [NO_SPAN; 2];
        let geometry = self.grid.geometry;
        let fp = &region.footprint;
        let tau = self.params.tau_fn;
        // Own cells have hits: the walk over the region's hit cells (empty cells skipped 64 at a time) finds them
        // all. Every one of them is a hit cell its owner owns (the second span); the occupied ones, the first.
        if let Some(range) = geometry.cell_range(region.grown.aabb()) {
            let (grid, owner) = (&self.grid, &self.owner);
            grid.for_each_hit_cell(&region.grown, range, |idx| {
                let own = grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) == FLAG_EXPLAINED
                    && owner.get(idx as usize).is_some_and(|&o| o as usize == j);
                if !own {
                    return;
                }
                let (x, y) = geometry.cell_center(idx);
                let (u, v) = fp.local(x, y);
                let grow = |span: &mut [f32; 4]| {
                    *span = [span[0].min(u), span[1].max(u), span[2].min(v), span[3].max(v)];
                };
                if grid.probability(idx) > tau {
                    grow(&mut spans[0]);
                }
                grow(&mut spans[1]);
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
        let geometry = self.grid.geometry;
        let fp = &region.footprint;
        let slack = self.fit_slack();
        let mut span = own;
        for &c in self.cluster_cells(k) {
            let (x, y) = geometry.cell_center(c);
            let (u, v) = fp.local(x, y);
            span = [span[0].min(u), span[1].max(u), span[2].min(v), span[3].max(v)];
        }
        span[1] - span[0] <= 2.0 * fp.half_length + slack && span[3] - span[2] <= 2.0 * fp.half_width + slack
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
                    let (u, v) = fp.local(x, y);
                    span = [span[0].min(u), span[1].max(u), span[2].min(v), span[3].max(v)];
                }
            }
        }
        span[1] - span[0] <= 2.0 * fp.half_length + slack && span[3] - span[2] <= 2.0 * fp.half_width + slack
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

/// The smallest `hypotf(offsets(x, y)) - half_diagonal` (at least 0) over the cell centres `(x, y)`, stopping at 0:
/// the straightforward minimum, except that `hypotf` is called only for a centre whose legs' squared sum (in `f64`:
/// each square of an `f32` is exact there, the sum rounds once) is strictly below the smallest sum so far. The
/// others cannot lower the minimum: in each of its branches `hypotf` (libm) is a function of that sum that does
/// not decrease as it grows (`sqrtf` of it rounded to `f32`; scaled by exact powers of two 2^90 for huge or tiny
/// legs; the longer leg for legs 2^25 apart and more, which is what `sqrtf` gives there too), and
/// `(h - half_diagonal).max(0.0)` does not decrease as `h` grows. Same bits as the straightforward loop (tested
/// against it, also on huge and tiny coordinates). Legs whose sum is NaN take the straightforward path, which the
/// bound used until round branches could skip; no caller passes NaN legs (`outside_offsets` clamps with
/// `max(0.0)`; a NaN point makes every centre's leg NaN, from the first centre on, as before).
pub(super) fn nearest_distance(
    centres: impl Iterator<Item = (f32, f32)>,
    half_diagonal: f32,
    offsets: impl Fn(f32, f32) -> (f32, f32),
) -> f32 {
    let mut d = f32::INFINITY;
    let mut smallest = f64::INFINITY;
    for (x, y) in centres {
        let (a, b) = offsets(x, y);
        let (a64, b64) = (f64::from(a), f64::from(b));
        let sum = a64 * a64 + b64 * b64;
        if sum >= smallest {
            continue;
        }
        if sum < smallest {
            smallest = sum;
        }
        d = d.min((libm::hypotf(a, b) - half_diagonal).max(0.0));
        if d <= 0.0 {
            break;
        }
    }
    d
}

/// Fractions of its margins by which [`placements`] moves a footprint along and across its axes.
const PLACEMENT_STEPS: [f32; 5] = [-1.0, -0.5, 0.0, 0.5, 1.0];

/// The places within an object's region `A_o` where its footprint may stand by its stated uncertainty: the
/// footprint moved by `-1, -1/2, 0, 1/2, 1` times its margin along and across its axes (24 places; the unmoved
/// one left out). The region is the footprint grown by these margins, so each place lies wholly inside it.
pub(super) fn placements(region: &Region) -> impl Iterator<Item = crate::geometry::OrientedRect> + '_ {
    let fp = region.footprint;
    let (ml, mw) = (region.margin_length_m, region.margin_width_m);
    PLACEMENT_STEPS.into_iter().flat_map(move |a| {
        PLACEMENT_STEPS.into_iter().filter_map(move |b| {
            let (du, dv) = (a * ml, b * mw);
            (a != 0.0 || b != 0.0).then_some(crate::geometry::OrientedRect {
                cx: fp.cx + du * fp.cos - dv * fp.sin,
                cy: fp.cy + du * fp.sin + dv * fp.cos,
                ..fp
            })
        })
    })
}

/// The paper's consistency `eta` of report `j`.
pub(super) fn s_eta(reports: &[ObjectReport], j: usize) -> f32 {
    reports.get(j).map_or(0.0, |r| r.sensor.eta)
}

/// Distinct occluding cells a [`FootprintSight`] keeps count of.
pub(super) const OCCLUDERS: usize = 4;

/// Most cells looked at along each axis of a footprint's cell range by the sight test.
pub(super) const SIGHT_SAMPLES: u32 = 8;

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

/// Step 3c: for a track confirmed by its own evidence in the previous frame whose box jumped (it stands farther
/// from where its reported motion puts it than the region's margins allow, along or across it), where that
/// evidence should stand now if the object moved as the object list said (the predicted centre plus the
/// evidence's offset from the centre then), when that place lies outside the track's grown region this frame: the
/// box left its own evidence behind. `None` otherwise (no memory of it, its evidence was displaced then, no jump,
/// or the place is inside the region: the box is where its evidence is).
pub(super) fn stayed_evidence(s: &super::ObjectScratch, region: &Region) -> Option<[f32; 2]> {
    let (Some((EvidenceKind::Own, off)), Some((centre, _, _))) = (s.recalled, s.predicted) else { return None };
    let fp = &region.footprint;
    // The box jumped: it stands farther from its prediction than its stated uncertainty allows (the region's
    // margins), along or across it. A box that drifts with its error, or jitters within its uncertainty, is left
    // to the other steps.
    let jump = [fp.cx - centre[0], fp.cy - centre[1]];
    if !beyond_allowance(fp, jump, [region.margin_length_m, region.margin_width_m]) {
        return None;
    }
    let expected = [centre[0] + off[0], centre[1] + off[1]];
    (expected.iter().all(|v| v.is_finite()) && !region.grown.contains(expected[0], expected[1])).then_some(expected)
}

/// The span of no cells in a box's axes, `[u min, u max, v min, v max]`: any cell's coordinates replace it.
pub(super) const NO_SPAN: [f32; 4] = [f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY];

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

/// `true` when a vector (ego axes) reaches beyond an allowance along or across a box (step 9).
pub(super) fn beyond_allowance(fp: &crate::geometry::OrientedRect, d: [f32; 2], allow: [f32; 2]) -> bool {
    let (u, v) = (d[0] * fp.cos + d[1] * fp.sin, -d[0] * fp.sin + d[1] * fp.cos);
    !(u.abs() <= allow[0] && v.abs() <= allow[1])
}

/// `true` when a vector (ego axes) reaches beyond the ellipse whose semi-axes along and across a box are the
/// allowance, `(u / a_u)^2 + (v / a_v)^2 > 1` (step 9's diagonal test), written without a division. Every vector
/// beyond the allowance along or across the box ([`beyond_allowance`]) is beyond the ellipse, also when a
/// semi-axis is zero (then only the other axis's segment is inside).
pub(super) fn beyond_ellipse(fp: &crate::geometry::OrientedRect, d: [f32; 2], allow: [f32; 2]) -> bool {
    let (u, v) = (d[0] * fp.cos + d[1] * fp.sin, -d[0] * fp.sin + d[1] * fp.cos);
    let (a2, b2) = (allow[0] * allow[0], allow[1] * allow[1]);
    u * u * b2 + v * v * a2 > a2 * b2 || !(u.abs() <= allow[0] && v.abs() <= allow[1])
}

/// `true` when two boxes stand in one place: centres and half extents within `tol` of each other and axes within
/// 10 degrees (a box turned by half a turn is the same box; so is a square one at any heading).
pub(super) fn in_one_place(a: &crate::geometry::OrientedRect, b: &crate::geometry::OrientedRect, tol: f32) -> bool {
    // |cos| of the angle between the two length axes, against cos(10 degrees).
    const COS_10_DEG: f32 = 0.984_807_8;
    let square = (a.half_length - a.half_width).abs() <= tol;
    (a.cx - b.cx).abs() <= tol
        && (a.cy - b.cy).abs() <= tol
        && (a.half_length - b.half_length).abs() <= tol
        && (a.half_width - b.half_width).abs() <= tol
        && (square || (a.cos * b.cos + a.sin * b.sin).abs() >= COS_10_DEG)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::OrientedRect;
    use crate::test_support::unit_draws;

    /// Boxes in one place (params key `jump_coincident_boxes`): within half a cell in centre and extents and 10
    /// degrees in heading (or half a turn apart, or square), not beyond any of them.
    #[test]
    fn boxes_in_one_place_are_within_the_tolerance_of_each_other() {
        let car = OrientedRect::new(10.0, 5.0, 0.3, 2.2, 0.9);
        let tol = 0.25;
        for same in [
            car,
            OrientedRect::new(10.2, 4.8, 0.3, 2.2, 0.9),
            OrientedRect::new(10.0, 5.0, 0.3 + core::f32::consts::PI, 2.2, 0.9),
            OrientedRect::new(10.0, 5.0, 0.3 + 0.17, 2.4, 0.7),
        ] {
            assert!(in_one_place(&same, &car, tol) && in_one_place(&car, &same, tol), "{same:?}");
        }
        for apart in [
            OrientedRect::new(10.3, 5.0, 0.3, 2.2, 0.9),
            OrientedRect::new(10.0, 4.7, 0.3, 2.2, 0.9),
            OrientedRect::new(10.0, 5.0, 0.3 + 0.18, 2.2, 0.9),
            OrientedRect::new(10.0, 5.0, 0.3, 2.5, 0.9),
            OrientedRect::new(10.0, 5.0, 0.3, 2.2, 0.6),
            OrientedRect::new(10.0, 5.0, 0.3 + core::f32::consts::FRAC_PI_2, 2.2, 0.9),
        ] {
            assert!(!in_one_place(&apart, &car, tol) && !in_one_place(&car, &apart, tol), "{apart:?}");
        }
        // A square box (a pedestrian) is in one place at any heading.
        let ped = OrientedRect::new(3.0, 1.0, 0.0, 0.3, 0.3);
        assert!(in_one_place(&OrientedRect::new(3.0, 1.0, 0.7, 0.3, 0.3), &ped, tol));
        assert!(!in_one_place(&OrientedRect::new(f32::NAN, 1.0, 0.0, 0.3, 0.3), &ped, tol), "NaN is nowhere");
    }

    /// The straightforward minimum `nearest_distance` skips `hypotf` in.
    fn nearest_distance_reference(
        centres: &[(f32, f32)],
        half_diagonal: f32,
        distance: impl Fn(f32, f32) -> f32,
    ) -> f32 {
        let mut d = f32::INFINITY;
        for &(x, y) in centres {
            d = d.min((distance(x, y) - half_diagonal).max(0.0));
            if d <= 0.0 {
                break;
            }
        }
        d
    }

    /// What `nearest_distance` rests on: `hypotf` does not decrease as its legs' `f64` squared sum grows. Pairs of
    /// legs drawn near each other (sums close or equal), with ratios up to and beyond 2^25 (where `hypotf` returns
    /// the longer leg), with legs whose square is a tie of `f32` rounding (`4097 * 2^e`: 25 significant bits),
    /// and over scales from 1e-6 to 1e6.
    #[test]
    fn hypotf_does_not_decrease_as_the_squared_sum_grows() {
        let mut unit = unit_draws(0x2545_F491_4F6C_DD1D);
        let sum = |a: f32, b: f32| f64::from(a) * f64::from(a) + f64::from(b) * f64::from(b);
        let mut compared = 0u32;
        for case in 0..400_000u32 {
            // Scales reach the branches that scale by 2^90 (legs beyond 2^60 or below 2^-60), subnormal squares
            // and sums beyond `f32::MAX`.
            let scale = [1e-6f32, 1e-3, 1.0, 30.0, 1e3, 1e6, 1e-40, 1e-25, 1e19, 1e25, 1e30, 1.2e18, 8.7e-19]
                [(case % 13) as usize];
            let a = match case / 6 % 3 {
                0 => unit() * scale,
                1 => 4097.0 * scale.log2().round().exp2() * [1.0f32, 0.5, 2.0][(case % 3) as usize],
                _ => (1.0 + unit() * 1e-6) * scale,
            };
            let b = match case / 18 % 4 {
                0 => unit() * scale,
                1 => a * (unit() * 2f32.powi(-24)),
                2 => a * 2f32.powi(-25 - (case % 4) as i32),
                _ => 0.0,
            };
            // A neighbour: one or two units in the last place away in either leg, or the legs swapped.
            let step = |v: f32, k: u32| f32::from_bits(v.to_bits().saturating_add(k % 3).saturating_sub(k / 3 % 2));
            let (c, d) = if case % 5 == 0 { (b, a) } else { (step(a, case / 7), step(b, case / 11)) };
            let (s0, s1) = (sum(a, b), sum(c, d));
            let (h0, h1) = (libm::hypotf(a, b), libm::hypotf(c, d));
            if s0 < s1 {
                assert!(h0 <= h1, "legs {a:e} {b:e} (sum {s0:e}, hypotf {h0:e}) vs {c:e} {d:e} ({s1:e}, {h1:e})");
                compared += 1;
            } else if s1 < s0 {
                assert!(h1 <= h0, "legs {c:e} {d:e} (sum {s1:e}, hypotf {h1:e}) vs {a:e} {b:e} ({s0:e}, {h0:e})");
                compared += 1;
            } else {
                assert_eq!(h0.to_bits(), h1.to_bits(), "equal sums, legs {a:e} {b:e} and {c:e} {d:e}");
            }
        }
        assert!(compared > 100_000);
    }

    /// `nearest_distance` equals the straightforward loop bit for bit, to rectangles and to points, on random
    /// clusters of cell centres (near, touching and far, cells of 0.1 to 1 m, also huge and tiny coordinates).
    #[test]
    fn nearest_distance_skips_only_centres_that_cannot_lower_it() {
        let mut unit = unit_draws(0x9E37_79B9_7F4A_7C15);
        let mut skipped_some = false;
        for case in 0..4000 {
            let cell = [0.1f32, 0.2, 0.5, 1.0][case % 4];
            let hd = core::f32::consts::FRAC_1_SQRT_2 * cell;
            let scale = [1.0f32, 30.0, 1e-3, 5e4][case / 4 % 4];
            let (ox, oy) = ((unit() - 0.5) * 60.0 * scale, (unit() - 0.5) * 60.0 * scale);
            let count = 1 + (unit() * 40.0) as usize;
            let centres: Vec<(f32, f32)> = (0..count)
                .map(|_| {
                    let (i, j) = ((unit() * 12.0) as i32, (unit() * 12.0) as i32);
                    (ox + (i as f32 + 0.5) * cell, oy + (j as f32 + 0.5) * cell)
                })
                .collect();
            let rect = OrientedRect::new(
                (unit() - 0.5) * 60.0 * scale,
                (unit() - 0.5) * 60.0 * scale,
                (unit() - 0.5) * 7.0,
                unit() * 3.0 * scale,
                unit() * 1.5 * scale,
            );
            let got = nearest_distance(centres.iter().copied(), hd, |x, y| rect.outside_offsets(x, y));
            let want = nearest_distance_reference(&centres, hd, |x, y| rect.distance(x, y));
            assert_eq!(got.to_bits(), want.to_bits(), "case {case}: rectangle {rect:?}");
            let p = [(unit() - 0.5) * 60.0 * scale, (unit() - 0.5) * 60.0 * scale];
            let got = nearest_distance(centres.iter().copied(), hd, |x, y| (x - p[0], y - p[1]));
            let want = nearest_distance_reference(&centres, hd, |x, y| libm::hypotf(x - p[0], y - p[1]));
            assert_eq!(got.to_bits(), want.to_bits(), "case {case}: point {p:?}");
            // The test does skip: some centre's squared sum is not below the smallest of those before it.
            let mut smallest = f64::INFINITY;
            for &(x, y) in &centres {
                let (a, b) = (f64::from(x - p[0]), f64::from(y - p[1]));
                let sum = a * a + b * b;
                skipped_some |= sum >= smallest;
                smallest = smallest.min(sum);
            }
        }
        assert!(skipped_some);
    }
}
