//! The returns `seen_over` reads, gathered only for the cells it will read (the params key `seen_over`;
//! docs/attribution.md, "Seen over the occluder"; docs/performance.md, "The seen-over pass").
//!
//! `Monitor::seen_over` asks, for a few cells per frame, the nearest squared range of their obstacle-band returns
//! and their lowest and highest `z`: the first cell with returns behind a shadowed sample point of a confirmed box,
//! and the point's occluder. The grid can keep these for every hit cell as it is filled
//! ([`crate::grid::OccupancyGrid::with_returns`]), but that fold cost 27-48 % more instructions per check. Here,
//! before the verdicts, [`Monitor::gather_over_returns`] makes `seen_over`'s walks once for every sample point
//! `seen_through` would hand to it (none of what they ask changes during the verdicts) and keeps, per point, the
//! evidence cell behind it and its occluder ([`Monitor::over_evidence_kept`]: `seen_over` walks no more); then it
//! folds the returns of the kept cells alone, found through the cells the rasterizer recorded per point and a
//! byte-map prefilter (the scan of `roi_by_returns`). `min` and `max` do not depend on the order, so each kept
//! entry has the bits of the grid's fold (tested: `over_returns_equal_the_grids_fold`; the verdicts: the same
//! `attribution_diag` curves and `pmon check` lines as with the grid's fold). With `returns_beyond_cells` on as
//! well, the same scan folds that rule's candidate cells (`beyond.rs`), gathered here for every box: one scan of
//! the recorded cells instead of two (docs/performance.md, "One scan for two opt-in rules").

use super::beyond::{fold_beyond_return, mark_beyond_cells};
use super::clusters::{edge_slot, for_each_marked_return};
use super::*;

/// A cell's returns before any: nothing is nearer, lower or higher (as the grid's).
const NO_RETURNS: [f32; 3] = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY];

/// Cells `seen_over` may read per sample point: the first cell with returns behind it and its occluder.
pub(super) const OVER_CELLS_PER_POINT: usize = 2;

/// Where the outer sample points of the free-space test stand, as a fraction of the half length and half width.
pub(super) const SAMPLE_AT: f32 = 0.6;

/// The 3 x 3 sample points of the free-space test over a footprint (at -0.6, 0 and 0.6 of its half length and
/// half width), in the order `seen_through` visits them.
pub(super) fn sample_points(fp: &crate::geometry::OrientedRect) -> [[f32; 2]; 9] {
    let mut out = [[0.0; 2]; 9];
    let mut k = 0;
    for u in [-SAMPLE_AT, 0.0, SAMPLE_AT] {
        for v in [-SAMPLE_AT, 0.0, SAMPLE_AT] {
            let (lu, lv) = (u * fp.half_length, v * fp.half_width);
            if let Some(p) = out.get_mut(k) {
                *p = [fp.cx + lu * fp.cos - lv * fp.sin, fp.cy + lu * fp.sin + lv * fp.cos];
            }
            k += 1;
        }
    }
    out
}

/// The ray of `seen_over` from the sensor through a sample point: its direction, the point's cell and the walk's
/// step and reach.
pub(super) struct OverRay {
    pub(super) u: [f32; 2],
    pub(super) c0: u32,
    pub(super) step: f32,
    pub(super) reach: f32,
}

impl Monitor {
    /// The ray of `seen_over` through the sample point `(x, y)` of footprint `fp` with margin `margin`; `None` when
    /// the point is at the sensor, off the grid, or in a cell with returns (the point is not seen empty).
    pub(super) fn over_ray(&self, x: f32, y: f32, margin: f32, fp: &crate::geometry::OrientedRect) -> Option<OverRay> {
        let o = self.visibility.origin();
        let (dx, dy) = (x - o[0], y - o[1]);
        let r = libm::sqrtf(dx * dx + dy * dy);
        if r.is_nan() || r <= 1e-3 {
            return None;
        }
        let geometry = self.grid.geometry;
        let c0 = geometry.point_to_cell(x, y)?;
        if self.grid.hits(c0) > 0 {
            return None;
        }
        Some(OverRay {
            u: [dx / r, dy / r],
            c0,
            step: 0.5 * geometry.cell_size_m,
            reach: 2.0 * (fp.half_length + fp.half_width + margin),
        })
    }

    /// Walking away from the sensor from the point of `ray`, the first cell with returns other than the point's
    /// own, within the walk's reach; `None` when the walk leaves the grid or reaches its end first.
    pub(super) fn first_hit_beyond(&self, x: f32, y: f32, ray: &OverRay) -> Option<u32> {
        let geometry = self.grid.geometry;
        let mut t = ray.step;
        while t <= ray.reach {
            let c = geometry.point_to_cell(x + ray.u[0] * t, y + ray.u[1] * t)?;
            t += ray.step;
            if c != ray.c0 && self.grid.hits(c) > 0 {
                return Some(c);
            }
        }
        None
    }

    /// The preconditions of `seen_over` for the sample point `(x, y)` of footprint `fp` (margin `margin`), which
    /// need no returns: the point's cell has none ([`Monitor::over_ray`]); walking from it towards the sensor over
    /// the walk's reach, no cell with returns is (or borders, `near_own`) the object's own evidence; and walking
    /// away, the first cell with returns ([`Monitor::first_hit_beyond`]) is. The ray and that cell, whose returns
    /// `seen_over` then reads (and, when they clear the margin, the occluder's).
    pub(super) fn over_evidence_cell(
        &self,
        x: f32,
        y: f32,
        margin: f32,
        fp: &crate::geometry::OrientedRect,
        near_own: &dyn Fn(u32) -> bool,
    ) -> Option<(OverRay, u32)> {
        let ray = self.over_ray(x, y, margin, fp)?;
        // Away from the sensor first (the walk that ends soonest): the first cell with returns is own evidence.
        let c = self.first_hit_beyond(x, y, &ray).filter(|&c| near_own(c))?;
        let geometry = self.grid.geometry;
        // Towards the sensor: no return of the object's own evidence in front of the point (its face is there).
        let mut t = ray.step;
        while t <= ray.reach {
            let Some(f) = geometry.point_to_cell(x - ray.u[0] * t, y - ray.u[1] * t) else { break };
            t += ray.step;
            if f != ray.c0 && self.grid.hits(f) > 0 && near_own(f) {
                return None;
            }
        }
        Some((ray, c))
    }

    /// For sample point `k` of object `j` (at `(x, y)`), when [`Monitor::gather_over_returns`] kept it this frame
    /// (shadowed by an occluder that is not the object's own evidence, [`Monitor::over_evidence_cell`] met): its
    /// range from the sensor, the evidence cell behind it and its occluder.
    pub(super) fn over_evidence_kept(&self, j: usize, k: usize, x: f32, y: f32) -> Option<(f32, u32, u32)> {
        let [c, occluder] = self.over_points.get(j).and_then(|p| p.get(k)).copied().filter(|&[c, _]| c != NO_CELL)?;
        // The range as `over_ray` computes it (which kept the point: not NaN, beyond 1 mm).
        let o = self.visibility.origin();
        let (dx, dy) = (x - o[0], y - o[1]);
        Some((libm::sqrtf(dx * dx + dy * dy), c, occluder))
    }

    /// With `seen_over`: the nearest squared range of a hit cell's obstacle-band returns from the sensor (m^2),
    /// their lowest and their highest z (m), for a cell [`Monitor::gather_over_returns`] kept this frame; `None`
    /// for a cell without hits (or one not kept, which `seen_over` never asks).
    pub(super) fn over_returns(&self, cell: u32) -> Option<[f32; 3]> {
        if self.grid.hits(cell) == 0 {
            return None;
        }
        let i = self.over_cells.binary_search(&cell).ok();
        debug_assert!(i.is_some(), "seen_over read cell {cell}, which was not gathered");
        self.over_entries.get(i?).copied()
    }

    /// With `seen_over`, before the verdicts: the cells `seen_over` may read this frame and their returns. For
    /// every box the free-space test may look over (confirmed by its own evidence, with no cluster), each sample
    /// point that `seen_through` would hand to `seen_over` (shadowed, by an occluder that is not the object's own
    /// evidence) and that meets `seen_over`'s preconditions ([`Monitor::over_evidence_cell`]) keeps the evidence
    /// cell behind it and its occluder. The verdicts change none of what this asks (the confirmed boxes' clusters,
    /// their own evidence, `owner_of`: `give` only marks cells attributed), so `seen_over` reads only kept cells.
    /// Then one scan of the recorded cells folds the returns of the kept cells. Bounded: 9 points per object, two
    /// walks of at most `4 (half length + half width + margin) / cell` steps each, and a pass over the sweep's
    /// recorded cells.
    pub(super) fn gather_over_returns(&mut self, cloud: Option<Cloud<'_>>) {
        self.over_cells.clear();
        self.over_entries.clear();
        self.over_points.clear();
        let Some(cloud) = cloud else { return };
        let tau_tp = self.params.tau_tp;
        for j in 0..self.scratch.len() {
            if self.over_points.len() < self.over_points.capacity() {
                self.over_points.push([[NO_CELL; 2]; 9]);
            }
            let Some(s) = self.scratch.get(j) else { continue };
            let Some(region) = s.region.as_ref() else { continue };
            if s.cluster.is_some() || s.eta_own < tau_tp || s.own_sum[2] < 1.0 {
                continue;
            }
            let fp = region.footprint;
            let margin = region.margin_length_m.max(region.margin_width_m);
            // The closures of `seen_through`.
            let tau = self.params.tau_fn;
            let own = |c: u32| self.grid.probability(c) > tau && self.owns(j, c);
            let near_own = |c: u32| own(c) || self.grid.geometry.neighbours4(c).any(own);
            let mut evidence = [[NO_CELL; 2]; 9];
            for (k, [x, y]) in sample_points(&fp).into_iter().enumerate() {
                if self.visibility.clearance(x, y).is_some() {
                    continue;
                }
                let Sight::Shadowed(occluder) = self.visibility.sight(x, y) else { continue };
                if occluder == NO_CELL || near_own(occluder) {
                    continue;
                }
                if let Some((_, c)) = self.over_evidence_cell(x, y, margin, &fp, &near_own) {
                    if let Some(e) = evidence.get_mut(k) {
                        *e = [c, occluder];
                    }
                }
            }
            if let Some(p) = self.over_points.get_mut(j) {
                *p = evidence;
            }
            // Both cells of each kept point (at most `OVER_CELLS_PER_POINT` per point: the capacity made in `new`).
            for &c in evidence.iter().filter(|&&[c, _]| c != NO_CELL).flatten() {
                if self.over_cells.len() < self.over_cells.capacity() {
                    self.over_cells.push(c);
                }
            }
        }
        self.over_cells.sort_unstable();
        self.over_cells.dedup();
        // With `returns_beyond_cells` too, its candidate cells are gathered here for every box, and one scan folds
        // the returns of both kinds of cells (`beyond.rs` then finds them gathered): one scan instead of two.
        let beyond = self.params.returns_beyond_cells > 0 && {
            self.beyond_gathered = true;
            self.beyond_entries_from(0)
        };
        self.fold_over_returns(cloud, beyond);
    }

    /// The returns of the cells in `over_cells` (sorted, no repeats): one scan of the cells the rasterizer recorded
    /// per point (or, when they were not recorded, a pass over the sweep), the points of the kept cells transformed
    /// and folded as the grid's reference loop folds them. With `beyond`, the same scan also folds the returns of
    /// `returns_beyond_cells`' candidate cells (`beyond_entries`) into their nearest return: each fold reads only
    /// the points of its own cells, and neither depends on the order of the points (minima and maxima), so both
    /// get the bits of a scan of their own.
    fn fold_over_returns(&mut self, cloud: Cloud<'_>, beyond: bool) {
        self.over_entries.clear();
        if self.over_cells.is_empty() && !beyond {
            return;
        }
        for &c in &self.over_cells {
            self.over_entries.push(NO_RETURNS);
            if let Some(b) = self.over_map.get_mut(edge_slot(c)) {
                *b = 1;
            }
        }
        if beyond {
            mark_beyond_cells(&mut self.over_map, &self.beyond_entries, 1);
        }
        let t = cloud.ego_from_sensor;
        let o = self.visibility.origin();
        let (band, geometry) = (self.band(), self.grid.geometry);
        let (grid, cells, entries) = (&self.grid, &self.over_cells, &mut self.over_entries);
        let (scratch, beyond_entries) = (&self.scratch, &mut self.beyond_entries);
        // A ring puts several points of a run in one cell: one search per run.
        let mut last = (NO_CELL, None);
        let mut last_beyond = (NO_CELL, 0usize, 0usize);
        for_each_marked_return(&self.over_map, &self.point_cells, cloud, band, geometry, |cell, p| {
            if beyond {
                fold_beyond_return(beyond_entries, scratch, &mut last_beyond, cell, || t.transform(p));
            }
            if cell != last.0 {
                last = (cell, cells.binary_search(&cell).ok().filter(|_| grid.hits(cell) > 0));
            }
            let Some(i) = last.1 else { return };
            let q = t.transform(p);
            let (dx, dy) = (q[0] - o[0], q[1] - o[1]);
            let r2 = dx * dx + dy * dy;
            if let Some(v) = entries.get_mut(i) {
                *v = [v[0].min(r2), v[1].min(q[2]), v[2].max(q[2])];
            }
        });
        // The prefilter is empty again for the next frame.
        for &c in &self.over_cells {
            if let Some(b) = self.over_map.get_mut(edge_slot(c)) {
                *b = 0;
            }
        }
        if beyond {
            mark_beyond_cells(&mut self.over_map, &self.beyond_entries, 0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Isometry3, PointCloud, Pose2};
    use crate::grid::OccupancyGrid;

    use super::super::roi::tests::Rng;

    /// The returns `fold_over_returns` folds for a cell are the grid's own fold of that cell
    /// (`OccupancyGrid::with_returns`, filled by the reference loop), bit for bit: every hit cell of random sweeps
    /// (points off the grid, NaN, under the band, in the ego footprint, a tilted sensor; cells repeated), through the
    /// recorded cells of the blocked loop and through the pass over the sweep when none were recorded.
    #[test]
    fn over_returns_equal_the_grids_fold() {
        let mut rng = Rng(0x0BAD_5EED_1234_5678);
        for case in 0..12 {
            let n = [0usize, 1, 63, 64, 65, 1000, 4097, 20_000][case % 8];
            let mut points = alloc::vec::Vec::with_capacity(n);
            for i in 0..n {
                let p = match i % 97 {
                    0 => [f32::NAN, 1.0, 0.0],
                    1 => [500.0, 0.0, 0.5],
                    2 => [0.3, 0.2, -0.5],
                    _ => [rng.range(-45.0, 45.0), rng.range(-45.0, 45.0), rng.range(-1.7, 1.3)],
                };
                // Runs of one cell, as rings put them.
                points.push(p);
                if i % 5 == 0 {
                    points.push([p[0] + 0.01, p[1], p[2] + 0.2]);
                }
            }
            let params = MonitorParams {
                seen_over: true,
                ego_footprint_m: if case % 2 == 0 { [-1.0, -1.0, 1.0, 1.0] } else { [0.0; 4] },
                ..MonitorParams::default()
            };
            let mut t = Isometry3::from_yaw_translation(if case % 3 == 0 { 0.3 } else { 0.0 }, [1.0, 0.5, 1.8]);
            if case % 4 == 1 {
                // A slightly tilted sensor: z depends on x and y.
                t.rotation[2] = [0.02, -0.01, 1.0];
            }
            let mut m = Monitor::new(params).unwrap();
            let cloud = PointCloud { points_in_sensor: &points, ego_from_sensor: t };
            let frame = Frame {
                timestamp_s: 0.1,
                world_from_ego: Pose2::default(),
                objects: &[],
                cloud: Some(cloud),
                roi_in_ego: &[],
                static_in_ego: &[],
            };
            m.check(&frame).unwrap();
            assert_eq!(m.point_cells.len(), points.len(), "case {case}: the cells are recorded with the key");
            // The reference: a grid with the eager fold, filled by the scalar loop.
            let mut grid =
                OccupancyGrid::new(m.grid.geometry, params.hit_probability, params.max_points as usize).with_returns();
            let mut visibility = VisibilityMap::new(params.visibility_bins);
            visibility.reset([t.translation_m[0], t.translation_m[1]]);
            let _ = crate::rasterize::rasterize_scalar(&points[..], &t, m.band(), &mut grid, &mut visibility);
            assert_eq!(grid.touched(), m.grid.touched(), "case {case}");
            for recorded in [true, false] {
                if !recorded {
                    m.point_cells.clear();
                }
                m.over_cells.clear();
                m.over_cells.extend_from_slice(m.grid.touched());
                m.over_cells.sort_unstable();
                m.fold_over_returns(Cloud::from(cloud), false);
                assert_eq!(m.over_entries.len(), m.over_cells.len());
                for &c in &m.over_cells {
                    let want = grid.returns(c).map(|v| v.map(f32::to_bits));
                    let got = m.over_returns(c).map(|v| v.map(f32::to_bits));
                    assert_eq!(got, want, "case {case}, recorded {recorded}, cell {c}");
                }
                assert!(m.over_map.iter().all(|&b| b == 0), "case {case}: the prefilter is empty again");
            }
        }
    }

    /// With `returns_beyond_cells` too, the one scan that folds both kinds of cells (`fold_over_returns` with
    /// `beyond`) gives each candidate entry the bits `gather_beyond_returns`' own scan gives it and each seen-over
    /// cell the bits of the scan without the candidates, and leaves the prefilter empty: random sweeps with boxes
    /// on them, every hit cell a candidate of every box (so the two kinds of cells overlap and interleave), with
    /// and without the recorded cells.
    #[test]
    fn one_scan_for_seen_over_and_the_returns_beyond_equals_two() {
        let mut rng = Rng(0x5CA1_AB1E_0DD5_EED5);
        let mut compared = 0usize;
        for case in 0..8 {
            let n = [100usize, 1000, 4097, 20_000][case % 4];
            let mut points = alloc::vec::Vec::with_capacity(n);
            for i in 0..n {
                let p = [rng.range(-30.0, 30.0), rng.range(-30.0, 30.0), rng.range(-1.7, 1.3)];
                points.push(p);
                if i % 3 == 0 {
                    points.push([p[0] + 0.02, p[1] - 0.01, p[2] + 0.3]);
                }
            }
            let objects: alloc::vec::Vec<ObjectState> = (0..6)
                .map(|k| ObjectState {
                    id: k,
                    class: crate::frame::ObjectClass::Car,
                    x_m: rng.range(-25.0, 25.0),
                    y_m: rng.range(-25.0, 25.0),
                    heading_rad: rng.range(-3.0, 3.0),
                    speed_mps: 0.0,
                    length_m: 4.5,
                    width_m: 1.8,
                    uncertainty: None,
                })
                .collect();
            let params = MonitorParams { seen_over: true, returns_beyond_cells: 1, ..MonitorParams::default() };
            let t = Isometry3::from_yaw_translation(0.2, [0.5, -0.3, 1.8]);
            let mut m = crate::test_support::monitor_after_one_check(params, t, &points, &objects);
            let cloud = PointCloud { points_in_sensor: &points, ego_from_sensor: t };
            let boxes = (0..m.scratch.len()).filter(|&j| m.scratch[j].region.is_some()).count();
            assert!(boxes > 0, "case {case}: boxes with a region");
            for recorded in [true, false] {
                if !recorded {
                    m.point_cells.clear();
                }
                let candidates = |m: &mut Monitor| {
                    m.beyond_entries.clear();
                    let mut cells = m.grid.touched().to_vec();
                    cells.sort_unstable();
                    for &cell in &cells {
                        for object in 0..m.scratch.len() as u32 {
                            if m.beyond_entries.len() < m.beyond_entries.capacity() {
                                m.beyond_entries.push(beyond::BeyondEntry { cell, object, nearest: f32::INFINITY });
                            }
                        }
                    }
                };
                // Every other hit cell is read by seen-over.
                m.over_cells.clear();
                let over: alloc::vec::Vec<u32> = m.grid.touched().iter().copied().step_by(2).collect();
                m.over_cells.extend_from_slice(&over);
                m.over_cells.sort_unstable();
                // Two scans: seen-over's alone, then the candidates' own (as `gather_beyond_returns` makes it).
                m.fold_over_returns(Cloud::from(cloud), false);
                let over_alone: alloc::vec::Vec<[u32; 3]> =
                    m.over_entries.iter().map(|v| v.map(f32::to_bits)).collect();
                candidates(&mut m);
                m.fold_beyond_returns(Cloud::from(cloud));
                assert!(m.beyond_map.iter().all(|&b| b == 0), "case {case}: its own prefilter is empty again");
                let beyond_alone: alloc::vec::Vec<(u32, u32, u32)> =
                    m.beyond_entries.iter().map(|e| (e.cell, e.object, e.nearest.to_bits())).collect();
                assert!(m.beyond_entries.iter().any(|e| e.nearest.is_finite()), "case {case}: returns folded");
                // One scan for both.
                candidates(&mut m);
                m.fold_over_returns(Cloud::from(cloud), true);
                let over_both: alloc::vec::Vec<[u32; 3]> = m.over_entries.iter().map(|v| v.map(f32::to_bits)).collect();
                let beyond_both: alloc::vec::Vec<(u32, u32, u32)> =
                    m.beyond_entries.iter().map(|e| (e.cell, e.object, e.nearest.to_bits())).collect();
                assert_eq!(over_both, over_alone, "case {case}, recorded {recorded}: seen-over's cells");
                assert_eq!(beyond_both, beyond_alone, "case {case}, recorded {recorded}: the candidates");
                assert!(m.over_map.iter().all(|&b| b == 0), "case {case}: the prefilter is empty again");
                compared += beyond_both.len();
            }
        }
        assert!(compared > 1000, "{compared} candidate entries compared");
    }
}
