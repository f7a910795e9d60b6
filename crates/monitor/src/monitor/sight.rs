//! What the sensor saw of an object's footprint, and the free-space tests of the evidence attribution
//! (docs/attribution.md, "The rule, step by step"): [`FootprintSight`] and the walk that fills it (step 2: cells seen
//! empty, behind evidence nobody explains, or taken by another object's evidence; brought up to date once displaced
//! evidence has its objects, step 6), the free cluster a box hidden by far evidence may take (`shadow_gate`), the
//! ghost test's places within the region (step 7: `hidden_within_margin`, each placement decided as soon as it can
//! be, and `open_view`), the free-space test towards the sensor (`seen_through`, with `seen_over` and `seen_body`),
//! and whether a box stands behind a point on the sensor's line of sight (`behind`). Part of [`Monitor`]; the
//! assignment that asks them is in `attribution.rs`.

use super::*;

/// The four sides of the 3 x 3 sample points of [`super::over::sample_points`], as masks of their indices
/// (`k = 3 iu + iv`): `u` at -0.6 and 0.6 of the half length, `v` at -0.6 and 0.6 of the half width.
const SIDE_ROWS: [u32; 4] = [0b000_000_111, 0b111_000_000, 0b001_001_001, 0b100_100_100];

/// How far below the top of an object's own evidence the lowest ray that reached it must have crossed a sample
/// point of the box for [`Monitor::seen_over`] to count the point as seen (metres): rays that only graze the top of
/// the evidence may have passed over a shorter body standing at the box (a neighbour's head seen over a parked car,
/// above a shorter pedestrian). 0.1 m raised the sensor false alarms up to 0.3 m noise on two of three seeds; 0.2 m
/// left them unchanged (docs/attribution.md, "Seen over the occluder").
pub(super) const SEEN_OVER_BELOW_TOP_M: f32 = 0.2;

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

/// How [`Monitor::seen_through`] found a box's footprint seen empty, in front of its own evidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Through {
    /// Most of its sample points (`ghost_visible_fraction` of them).
    Majority,
    /// The side that faces the sensor (`seen_through_near_side`): the box stands about `depth_m` in front of its
    /// evidence along the line of sight (the least clearance of the side's points, plus the side's inset from the
    /// box's edge).
    NearSide { depth_m: f32 },
}

/// The side of a box that faces the sensor at `o`, as a mask of [`SIDE_ROWS`] (the side whose outward normal points
/// most towards the sensor, weighed by its length: the side the sensor sees widest), how far the box may move along
/// the line of sight within its region's margins (`margin_length |cos a| + margin_width |sin a|`, `a` the angle
/// between the box's length and the line of sight), and how far the side's sample points lie inside the box's edge
/// (0.4 of the half length or half width).
fn near_side(region: &Region, o: [f32; 2]) -> (u32, f32, f32) {
    let fp = &region.footprint;
    let (dx, dy) = (o[0] - fp.cx, o[1] - fp.cy);
    let (du, dv) = (dx * fp.cos + dy * fp.sin, dy * fp.cos - dx * fp.sin);
    let [back, front, right, left] = SIDE_ROWS;
    let (side, half) = if (du * fp.half_width).abs() >= (dv * fp.half_length).abs() {
        (if du < 0.0 { back } else { front }, fp.half_length)
    } else {
        (if dv < 0.0 { right } else { left }, fp.half_width)
    };
    let d = libm::sqrtf(dx * dx + dy * dy).max(1e-3);
    (
        side,
        (region.margin_length_m * du.abs() + region.margin_width_m * dv.abs()) / d,
        (1.0 - super::over::SAMPLE_AT) * half,
    )
}

impl Monitor {
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
    ///
    /// With the params key `seen_through_near_side` (the default), the side of the box that faces the sensor
    /// (its three sample points) seen empty suffices, when each of its points lies in front of the object's own
    /// evidence by more than the box may move along the line of sight within its margins, and (with `seen_body`)
    /// each of their rays ends on the object's body (docs/attribution.md, "The near side seen through"): a box that
    /// stands where its object is has no such side, whatever the majority says.
    pub(super) fn seen_through(&self, j: usize, region: &Region) -> Option<Through> {
        let fp = &region.footprint;
        let margin = region.margin_length_m.max(region.margin_width_m);
        let tau = self.params.tau_fn;
        let own = |c: u32| self.grid.probability(c) > tau && self.owns(j, c);
        // The first return of a face is often alone in its cell: its occupied neighbour stands for it.
        let near_own = |c: u32| own(c) || self.grid.geometry.neighbours4(c).any(own);
        let o = self.visibility.origin();
        let mut free = 0u32;
        let mut clear = [f32::NEG_INFINITY; 9];
        // With `seen_body`: for each free point whose ray ends on the own evidence, the range where it ends less
        // the box's depth along the ray (points freed by `seen_over` are not kept: `NEG_INFINITY`).
        let mut ends = [f32::NEG_INFINITY; 9];
        for (k, [x, y]) in super::over::sample_points(fp).into_iter().enumerate() {
            let Some((clearance, cell)) = self.visibility.clearance(x, y) else {
                // With `seen_over`: shadowed by an obstacle that is not the object's own evidence, and seen over it
                // (`over.rs` walked its ray before the verdicts and kept the point's cells when it may be).
                if self.params.seen_over && self.seen_over(j, k, x, y, margin) {
                    free += 1;
                }
                continue;
            };
            if clearance > margin && near_own(cell) {
                if let Some(c) = clear.get_mut(k) {
                    *c = clearance;
                }
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
                    if let Some(end) = ends.get_mut(k) {
                        *end = r + clearance - depth;
                    }
                }
                free += 1;
            }
        }
        // With `seen_through_near_side`: the side facing the sensor, if each of its points is free by more than the
        // box may move along the line of sight.
        let on_side = |side: u32| clear.iter().enumerate().filter(move |&(k, _)| side & (1 << k) != 0);
        let side = (self.params.seen_through_near_side && free >= 3)
            .then(|| near_side(region, o))
            .filter(|&(side, allowance, _)| on_side(side).all(|(_, &c)| c > allowance))
            .map(|(side, _, inset)| (side, on_side(side).fold(f32::INFINITY, |m, (_, &c)| m.min(c)) + inset));
        let needed = self.params.ghost_visible_fraction * 9.0;
        let majority = free as f32 >= needed;
        let by_side = side.map(|(_, depth_m)| Through::NearSide { depth_m });
        // The answer when the body test is not asked (or cannot be: the walk below declines).
        let without_body = if majority { Some(Through::Majority) } else { by_side };
        if !self.params.seen_body || without_body.is_none() {
            return without_body;
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
            return without_body;
        }
        let reach = front + self.params.safety_margin_m;
        let on_body = |end: f32| end != f32::NEG_INFINITY && end <= reach;
        let freed_over = free as usize - ends.iter().filter(|&&end| end != f32::NEG_INFINITY).count();
        if majority && (ends.iter().filter(|&&end| on_body(end)).count() + freed_over) as f32 >= needed {
            return Some(Through::Majority);
        }
        side.filter(|&(side, _)| ends.iter().enumerate().all(|(k, &end)| side & (1 << k) == 0 || on_body(end)))
            .map(|(_, depth_m)| Through::NearSide { depth_m })
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
    /// The walks of (1)-(3) were done before the verdicts (`over.rs`, which keeps the cell of (3) for sample point
    /// `k` of object `j`, and gathers its returns and the occluder's); here only the heights.
    fn seen_over(&self, j: usize, k: usize, x: f32, y: f32, margin: f32) -> bool {
        // Its preconditions (`over.rs`): the point shadowed by an occluder that is not the object's own evidence, seen
        // empty in its cell, no face of the object in front of it, and the first cell with returns behind it the
        // object's own evidence.
        let Some((r, c, occluder)) = self.over_evidence_kept(j, k, x, y) else { return false };
        let geometry = self.grid.geometry;
        let Some([r2min, zlow, ztop]) = self.over_returns(c) else { return false };
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
        let Some([o2min, _, otop]) = self.over_returns(occluder) else { return false };
        let shadow = slope_through(otop, libm::sqrtf(o2min));
        let h = h.max(self.sensor_z + shadow * r);
        let (lo, _) = self.params.obstacle_band_m();
        h <= ztop - SEEN_OVER_BELOW_TOP_M && h >= lo && self.sensor_z + shadow * rmin <= ztop
    }

    /// The footprint's centre and the point relative to the sensor, with their ranges, when the point is nearer
    /// than the centre (and the centre not at the sensor); `None` otherwise, also for NaN ranges. The common start
    /// of [`Monitor::behind`] and [`Monitor::behind_exactly`].
    #[inline]
    fn nearer_than_centre(
        &self,
        footprint: &crate::geometry::OrientedRect,
        point: [f32; 2],
    ) -> Option<([f32; 2], [f32; 2], f32, f32)> {
        let o = self.visibility.origin();
        let (fx, fy) = (footprint.cx - o[0], footprint.cy - o[1]);
        let (px, py) = (point[0] - o[0], point[1] - o[1]);
        let (rf, rp) = (libm::hypotf(fx, fy), libm::hypotf(px, py));
        (rp.partial_cmp(&rf) == Some(core::cmp::Ordering::Less) && rf > 0.0).then_some(([fx, fy], [px, py], rf, rp))
    }

    /// True when a footprint lies behind a point as the sensor sees them, exactly: the point's bearing within the
    /// bearings of the footprint's corners (plus half a cell at the point's range) and the point nearer than the
    /// footprint's centre. [`Monitor::behind`] takes the footprint's circumscribed circle instead; this test leaves
    /// out a point beside the box's near end that the circle holds. Bearings are measured from the direction of the
    /// footprint's centre, so they do not wrap for a footprint that does not hold the sensor.
    pub(super) fn behind_exactly(&self, footprint: &crate::geometry::OrientedRect, point: [f32; 2]) -> bool {
        let Some(([fx, fy], [px, py], _, rp)) = self.nearer_than_centre(footprint, point) else { return false };
        let o = self.visibility.origin();
        let bearing = |x: f32, y: f32| libm::atan2f(fx * y - fy * x, fx * x + fy * y);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for c in footprint.corners() {
            let a = bearing(c[0] - o[0], c[1] - o[1]);
            lo = lo.min(a);
            hi = hi.max(a);
        }
        let half_cell = 0.5 * self.grid.geometry.cell_size_m / rp.max(1e-3);
        let a = bearing(px, py);
        a >= lo - half_cell && a <= hi + half_cell
    }

    /// True when a footprint lies behind a point as the sensor sees them: the point's bearing within the
    /// footprint's angular extent (plus half a cell), and the point nearer than the footprint's centre.
    pub(super) fn behind(&self, footprint: &crate::geometry::OrientedRect, point: [f32; 2]) -> bool {
        let Some(([fx, fy], [px, py], rf, rp)) = self.nearer_than_centre(footprint, point) else { return false };
        let reach = libm::hypotf(footprint.half_length, footprint.half_width) + 0.5 * self.grid.geometry.cell_size_m;
        // The angle between the two directions is at most `asin(reach / rf)`: in front (positive dot product),
        // and `sin(angle) = |cross| / (rf rp) <= reach / rf` (any angle up to 90 degrees once `reach >= rf`).
        let (cross, dot) = ((fx * py - fy * px).abs(), fx * px + fy * py);
        dot > 0.0 && (reach >= rf || cross <= reach * rp)
    }
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

/// Distinct occluding cells a [`FootprintSight`] keeps count of.
pub(super) const OCCLUDERS: usize = 4;

/// Most cells looked at along each axis of a footprint's cell range by the sight test.
pub(super) const SIGHT_SAMPLES: u32 = 8;
