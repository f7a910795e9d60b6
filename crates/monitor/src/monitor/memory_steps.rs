//! The evidence memory's steps of the attribution (docs/attribution.md, "The rule, step by step"): step 8, evidence
//! in a neighbour's margin still follows its track (`followed_evidence`, also over a gap with `memory_hold_s`); step
//! 9, a box that jumps away from evidence that stayed (`moved_from_evidence`: its allowances, the rectangle's and the
//! ellipse's tests, boxes in one place); step 3c, where the evidence a jump left behind should stand
//! (`stayed_evidence`); and with `memory_gate`, the gate on free evidence that hides a box (`occluder_within_gate`).
//! Part of [`Monitor`]; the memory itself is `crate::evidence_memory`, and the verdicts that ask these are in
//! `verdicts.rs` (`finish_reports`).

use super::fit::{grown, span_fits, NO_SPAN};
use super::*;

impl Monitor {
    /// An occupied cell (hit, probability above `tau`) that some object's region explains, that is not known
    /// scenery and that no cluster taken as displaced evidence holds: evidence a region holds and nothing else
    /// claims, which step 8 follows and a flagged neighbour releases (`released.rs`).
    #[inline]
    pub(super) fn explained_evidence(&self, idx: u32, tau: f32) -> bool {
        self.grid.hits(idx) > 0
            && self.grid.probability(idx) > tau
            && self.grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC | FLAG_ATTRIBUTED) == FLAG_EXPLAINED
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
        // With `follow_owner_fit`: the neighbour whose margin holds the cells counted (`None` once a second one
        // does), and the span of their first returns in that neighbour's box axes.
        let mut owner_fit: Option<Option<usize>> = None;
        let mut followed_span = NO_SPAN;
        for iy in iy0..=iy1 {
            for ix in ix0..=ix1 {
                let idx = iy * n + ix;
                if !self.explained_evidence(idx, tau) {
                    continue;
                }
                let (x, y) = geometry.cell_center(idx);
                // Displaced evidence lies outside the object's own region (inside it, it would confirm the object
                // or lie where its stated uncertainty allows).
                if libm::hypotf(x - expected[0], y - expected[1]) > reach || region.grown.contains(x, y) {
                    continue;
                }
                let owner = self.owner.get(idx as usize).map_or(j, |&o| o as usize);
                let owner_region = self.scratch.get(owner).and_then(|o| o.region);
                let in_box = owner_region.is_some_and(|o| o.footprint.contains(x, y));
                if owner == j || in_box || beyond_gate(region, x, y) {
                    continue;
                }
                sum = [sum[0] + x, sum[1] + y, sum[2] + 1.0];
                if self.params.follow_owner_fit {
                    owner_fit = match owner_fit {
                        None => Some(Some(owner)),
                        Some(o) => Some(o.filter(|&o| o == owner)),
                    };
                    if let (Some(Some(_)), Some(o)) = (owner_fit, owner_region) {
                        if let Some(at) = self.own_first_return(owner, idx) {
                            followed_span = grown(followed_span, o.footprint.local(at.0, at.1));
                        }
                    }
                }
            }
        }
        if let Some(Some(o)) = owner_fit {
            if self.fits_owner_with(o, followed_span) {
                return None;
            }
        }
        (sum[2] >= 1.0).then(|| [sum[0] / sum[2], sum[1] / sum[2]])
    }

    /// With `follow_owner_fit`: whether the first returns of the hit cells object `o` owns in its grown region,
    /// together with `span` (first returns in `o`'s box axes), fit `o`'s box: along and across no longer than its
    /// length and width plus twice the safety margin (the LiDAR's noise on both ends). Then the cells step 8 would
    /// follow can be `o`'s own body. False without the grid's first returns, or with no return in `span`. Bounded: one
    /// walk over `o`'s grown region.
    fn fits_owner_with(&self, o: usize, span: [f32; 4]) -> bool {
        let Some(region) = self.scratch.get(o).and_then(|s| s.region) else { return false };
        if !self.grid.has_first_returns() || span[0].is_nan() || span[0] > span[1] {
            return false;
        }
        let geometry = self.grid.geometry;
        let Some(range) = geometry.cell_range(region.grown.aabb()) else { return false };
        let mut span = span;
        self.grid.for_each_hit_cell(&region.grown, range, |idx| {
            if let Some((x, y)) = self.own_first_return(o, idx) {
                span = grown(span, region.footprint.local(x, y));
            }
        });
        span_fits(span, &region.footprint, 2.0 * self.params.safety_margin_m)
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
}

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
}
