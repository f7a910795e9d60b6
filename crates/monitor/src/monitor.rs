//! [`Monitor`]: owns every buffer, runs both checks on a frame, and returns one verdict per object.

use alloc::vec::Vec;

use crate::frame::{Frame, ObjectState, Uncertainty};
use crate::grid::{GridGeometry, OccupancyGrid, FLAG_EXPLAINED, FLAG_ROI_CONFLICT, FLAG_STATIC, FLAG_VISITED};
use crate::params::{MonitorParams, ParamError};
use crate::plausibility::TrackTable;
use crate::region::Region;
use crate::verdict::{
    ClusterReport, FrameError, FrameReport, GridStats, MotionOutcome, NotMonitoredReason, ObjectReport, SensorOutcome,
    SensorVerdict, Verdict,
};
use crate::visibility::{Sight, VisibilityMap, NO_CELL};

/// The stages of [`Monitor::check`], in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Reset of the touched cells, points into the ego frame, height band, hits, visibility map.
    Rasterize,
    /// Object regions `A_o` and consistency `eta(o)`.
    Regions,
    /// Conflict cells, their clusters, and their attribution to objects.
    Conflicts,
    /// Track bookkeeping and the plausibility conditions.
    Plausibility,
    /// Occlusion test of evidence-free objects and the combined verdicts.
    Verdicts,
}

impl Stage {
    /// All stages in order.
    pub const ALL: [Self; 5] = [Self::Rasterize, Self::Regions, Self::Conflicts, Self::Plausibility, Self::Verdicts];

    /// Name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Rasterize => "rasterize",
            Self::Regions => "regions",
            Self::Conflicts => "conflicts",
            Self::Plausibility => "plausibility",
            Self::Verdicts => "verdicts",
        }
    }
}

/// Per-object state of the sensor checks within one frame.
#[derive(Clone, Copy, Debug)]
struct ObjectScratch {
    region: Option<Region>,
    /// Attributed cluster and its size.
    cluster: Option<(u16, u32)>,
}

/// The perception monitor. Construct once with [`Monitor::new`]; call [`Monitor::check`] every frame.
///
/// Memory is allocated in `new` only: the grid (`cells^2` x 3 bytes), the point and cluster buffers
/// (`max_points` x 4 bytes x 2), and the per-object and track buffers. `check` allocates nothing.
// Not `Clone`: a cloned `Vec` loses its spare capacity, and the per-frame buffers rely on it (no
// allocation per frame, pushes bounded by capacity). Build another with `new` instead.
#[derive(Debug)]
pub struct Monitor {
    params: MonitorParams,
    grid: OccupancyGrid,
    visibility: VisibilityMap,
    scratch: Vec<ObjectScratch>,
    valid: Vec<bool>,
    motion: Vec<MotionOutcome>,
    reports: Vec<ObjectReport>,
    clusters: Vec<ClusterReport>,
    cluster_spans: Vec<(u32, u32)>,
    queue: Vec<u32>,
    tracks: TrackTable,
    stats: GridStats,
    sensor_status: Option<NotMonitoredReason>,
    rasterizer: crate::rasterize::Rasterizer,
}

/// Checks an object's state: finite values, sizes in `(0, max]`, speed `>= 0`, valid uncertainties.
#[must_use]
pub fn object_is_valid(o: &ObjectState, p: &MonitorParams) -> bool {
    let finite = [o.x_m, o.y_m, o.heading_rad, o.speed_mps, o.length_m, o.width_m].iter().all(|v| v.is_finite());
    finite
        && o.length_m > 0.0
        && o.width_m > 0.0
        && o.length_m <= p.max_object_size_m
        && o.width_m <= p.max_object_size_m
        && o.speed_mps >= 0.0
        && o.uncertainty.is_none_or(|u| u.is_valid())
}

const fn sensor_outcome(verdict: SensorVerdict) -> SensorOutcome {
    SensorOutcome {
        verdict,
        eta: 0.0,
        margin_length_m: 0.0,
        margin_width_m: 0.0,
        visible_fraction: 0.0,
        cluster: None,
        offset_m: [0.0, 0.0],
    }
}

impl Monitor {
    /// Validates the parameters and allocates every buffer.
    ///
    /// # Errors
    /// The first parameter out of range.
    pub fn new(params: MonitorParams) -> Result<Self, ParamError> {
        params.validate()?;
        let geometry = GridGeometry::new(params.grid_cells_per_side(), params.cell_size_m);
        let max_points = params.max_points as usize;
        let max_objects = params.max_objects as usize;
        let max_clusters = params.max_clusters as usize;
        let cells = geometry.cell_count();
        Ok(Self {
            grid: OccupancyGrid::new(geometry, params.hit_probability, max_points),
            visibility: VisibilityMap::new(params.visibility_bins),
            scratch: Vec::with_capacity(max_objects),
            valid: Vec::with_capacity(max_objects),
            motion: Vec::with_capacity(max_objects),
            reports: Vec::with_capacity(max_objects),
            clusters: Vec::with_capacity(max_clusters),
            cluster_spans: Vec::with_capacity(max_clusters),
            queue: Vec::with_capacity(max_points.min(cells)),
            tracks: TrackTable::new(max_objects),
            stats: GridStats::default(),
            sensor_status: None,
            rasterizer: crate::rasterize::Rasterizer::default(),
            params,
        })
    }

    /// The validated parameters.
    #[must_use]
    pub fn params(&self) -> &MonitorParams {
        &self.params
    }

    /// The occupancy grid of the last frame (for display and inspection).
    #[must_use]
    pub fn grid(&self) -> &OccupancyGrid {
        &self.grid
    }

    /// The last frame's visibility map (empty when that frame had no usable sweep): which ego-frame positions
    /// the sensor saw (for pictures of free and unknown space).
    #[must_use]
    pub fn visibility(&self) -> &VisibilityMap {
        &self.visibility
    }

    /// The region `A_o` the sensor checks use for an object, `None` for an invalid state.
    #[must_use]
    pub fn region_of(&self, o: &ObjectState) -> Option<Region> {
        object_is_valid(o, &self.params).then(|| Region::of(o, &self.uncertainty_of(o), &self.params))
    }

    fn uncertainty_of(&self, o: &ObjectState) -> Uncertainty {
        o.uncertainty.unwrap_or(self.params.default_uncertainty)
    }

    /// Forgets all track histories (for example after a jump in the recording).
    pub fn reset_tracks(&mut self) {
        self.tracks.clear();
    }

    /// Runs the sensor and plausibility checks on one frame.
    ///
    /// Every object of `frame.objects` gets exactly one [`ObjectReport`], in input order. Allocates nothing;
    /// never panics; loops are bounded by the capacities in [`MonitorParams`] and by the grid size.
    ///
    /// # Errors
    /// [`FrameError::TooManyObjects`] when the list exceeds `max_objects` (no object is judged then; the
    /// tracks are left unchanged).
    pub fn check(&mut self, frame: &Frame<'_>) -> Result<FrameReport<'_>, FrameError> {
        self.check_with_stages(frame, &mut |_| {})
    }

    /// [`Monitor::check`], calling `on_stage` as each [`Stage`] ends (for profiling: the caller reads its
    /// own clock; the core has none).
    ///
    /// # Errors
    /// As [`Monitor::check`].
    pub fn check_with_stages(
        &mut self,
        frame: &Frame<'_>,
        on_stage: &mut dyn FnMut(Stage),
    ) -> Result<FrameReport<'_>, FrameError> {
        let n = frame.objects.len();
        if n > self.params.max_objects as usize {
            return Err(FrameError::TooManyObjects { got: n, max: self.params.max_objects });
        }
        self.begin_frame(frame);
        self.rasterize(frame);
        self.mark_scenery(frame);
        on_stage(Stage::Rasterize);
        self.object_regions(frame);
        on_stage(Stage::Regions);
        if self.sensor_status.is_none() {
            self.cluster_conflicts(frame);
            self.attribute_clusters();
        }
        on_stage(Stage::Conflicts);
        self.tracks.check_frame(
            frame.timestamp_s,
            &frame.world_from_ego,
            frame.objects,
            &self.valid,
            &mut self.motion,
            &self.params,
        );
        on_stage(Stage::Plausibility);
        self.finish_reports(frame);
        on_stage(Stage::Verdicts);
        Ok(FrameReport {
            objects: &self.reports,
            clusters: &self.clusters,
            grid: self.stats,
            sensor_status: self.sensor_status,
        })
    }

    fn begin_frame(&mut self, frame: &Frame<'_>) {
        self.grid.reset();
        self.clusters.clear();
        self.cluster_spans.clear();
        self.queue.clear();
        self.stats = GridStats::default();
        self.valid.clear();
        self.scratch.clear();
        self.motion.clear();
        self.reports.clear();
        for o in frame.objects {
            self.valid.push(object_is_valid(o, &self.params));
            self.scratch.push(ObjectScratch { region: None, cluster: None });
            self.motion.push(MotionOutcome::not_monitored(NotMonitoredReason::InvalidState));
        }
        self.sensor_status = match &frame.cloud {
            None => Some(NotMonitoredReason::NoLidarData),
            Some(c) if !c.ego_from_sensor.is_finite() => Some(NotMonitoredReason::InvalidCloud),
            Some(c) if c.points_in_sensor.is_empty() => Some(NotMonitoredReason::EmptyCloud),
            Some(c) if c.points_in_sensor.len() > self.params.max_points as usize => {
                Some(NotMonitoredReason::TooManyPoints)
            }
            Some(_) => None,
        };
    }

    /// Selects the implementation of the rasterize stage, for verification and benchmarking: the blocked
    /// two-pass loop ([`crate::Rasterizer::Blocked`], the default) or the reference per-point loop
    /// ([`crate::Rasterizer::Scalar`]). Both give bit-identical grids, visibility maps, statistics and verdicts.
    pub fn set_rasterizer(&mut self, rasterizer: crate::Rasterizer) {
        self.rasterizer = rasterizer;
    }

    /// Points -> grid: transform into the ego frame, keep the height band, count hits, fill the visibility map
    /// (the loops are in `crate::rasterize`).
    fn rasterize(&mut self, frame: &Frame<'_>) {
        use crate::rasterize::{rasterize_blocked, rasterize_scalar, Band, Rasterizer};
        let Some(cloud) = frame.cloud.filter(|_| self.sensor_status.is_none()) else { return };
        let t = cloud.ego_from_sensor;
        self.visibility.reset([t.translation_m[0], t.translation_m[1]]);
        let (lo_m, hi_m) = self.params.obstacle_band_m();
        let band = Band {
            lo_m,
            hi_m,
            ego_m: if self.params.ego_footprint_m.iter().all(|v| *v == 0.0) {
                Band::NO_EGO
            } else {
                self.params.ego_footprint_m
            },
        };
        let (points, grid, visibility) = (cloud.points_in_sensor, &mut self.grid, &mut self.visibility);
        let in_band = match self.rasterizer {
            Rasterizer::Blocked => rasterize_blocked(points, &t, band, grid, visibility, true),
            Rasterizer::BlockedBaseline => rasterize_blocked(points, &t, band, grid, visibility, false),
            Rasterizer::Scalar => rasterize_scalar(points, &t, band, grid, visibility),
        };
        self.stats.points_total = u32::try_from(cloud.points_in_sensor.len()).unwrap_or(u32::MAX);
        self.stats.points_in_band = in_band;
        self.stats.cells_hit = u32::try_from(self.grid.touched().len()).unwrap_or(u32::MAX);
    }

    /// Hit cells that touch known static scenery (centre within half a cell diagonal of a polygon, so that
    /// points on a facade's edge count): explained by the map, and no evidence for objects. Visits each
    /// polygon's bounding box once (bounded by the grid).
    fn mark_scenery(&mut self, frame: &Frame<'_>) {
        if self.sensor_status.is_some() {
            return;
        }
        let geometry = self.grid.geometry;
        let reach = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        for poly in frame.static_in_ego {
            let mut b = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
            for p in poly.iter() {
                b = [b[0].min(p[0] - reach), b[1].min(p[1] - reach), b[2].max(p[0] + reach), b[3].max(p[1] + reach)];
            }
            let Some((ix0, iy0, ix1, iy1)) = geometry.cell_range_clipped(b) else { continue };
            for iy in iy0..=iy1 {
                let cy = geometry.cell_center_axis(iy);
                for ix in ix0..=ix1 {
                    let idx = iy * geometry.cells_per_side + ix;
                    if self.grid.hits(idx) > 0
                        && crate::geometry::polygon_distance(poly, geometry.cell_center_axis(ix), cy) <= reach
                    {
                        self.grid.set_flags(idx, FLAG_STATIC | FLAG_EXPLAINED);
                    }
                }
            }
        }
    }

    /// Regions `A_o`, consistency `eta(o)` (eq. consistency), and the cells they explain.
    fn object_regions(&mut self, frame: &Frame<'_>) {
        let geometry = self.grid.geometry;
        for (i, o) in frame.objects.iter().enumerate() {
            let report = if !self.valid.get(i).copied().unwrap_or(false) {
                sensor_outcome(SensorVerdict::NotMonitored(NotMonitoredReason::InvalidState))
            } else {
                let region = Region::of(o, &self.uncertainty_of(o), &self.params);
                let mut out = sensor_outcome(SensorVerdict::Consistent);
                out.margin_length_m = region.margin_length_m;
                out.margin_width_m = region.margin_width_m;
                let bounds = region.grown.aabb();
                match geometry.cell_range(bounds).filter(|_| geometry.contains_box(bounds)) {
                    None => {
                        out.verdict = SensorVerdict::NotMonitored(NotMonitoredReason::OutsideGrid);
                        // Not judged, but its evidence inside the grid is explained: no conflict at the edge.
                        if self.sensor_status.is_none() {
                            self.explain_cells(&region, geometry.cell_range_clipped(bounds));
                        }
                    }
                    Some(_) if self.sensor_status.is_some() => {
                        out.verdict =
                            SensorVerdict::NotMonitored(self.sensor_status.unwrap_or(NotMonitoredReason::NoLidarData));
                    }
                    Some(range) => {
                        let mut eta = self.grid.probability_of_hits(0);
                        self.grid.for_each_hit_cell_overlapping(&region.grown, range, |grid, idx| {
                            if grid.flags(idx) & FLAG_STATIC == 0 {
                                eta = eta.max(grid.probability(idx));
                                grid.set_flags(idx, FLAG_EXPLAINED);
                            }
                        });
                        out.eta = eta;
                        if let Some(s) = self.scratch.get_mut(i) {
                            s.region = Some(region);
                        }
                    }
                }
                out
            };
            self.reports.push(ObjectReport {
                id: o.id,
                verdict: Verdict::NotMonitored(NotMonitoredReason::InvalidState),
                sensor: report,
                motion: MotionOutcome::not_monitored(NotMonitoredReason::InvalidState),
            });
        }
    }

    /// Marks the hit cells of a cell range that overlap a region as explained.
    fn explain_cells(&mut self, region: &Region, range: Option<(u32, u32, u32, u32)>) {
        let Some(range) = range else { return };
        self.grid.for_each_hit_cell_overlapping(&region.grown, range, |grid, idx| grid.set_flags(idx, FLAG_EXPLAINED));
    }

    /// Conflict cells (`kappa > tau_fn`, eq. conflict) grouped into 8-connected clusters.
    fn cluster_conflicts(&mut self, frame: &Frame<'_>) {
        let geometry = self.grid.geometry;
        let n = geometry.cells_per_side;
        let tau = self.params.tau_fn;
        let mut k = 0usize;
        while let Some(&idx) = self.grid.touched().get(k) {
            k += 1;
            if self.grid.probability(idx) <= tau {
                continue;
            }
            self.stats.cells_occupied += 1;
            let flags = self.grid.flags(idx);
            if flags & FLAG_EXPLAINED != 0 {
                continue;
            }
            self.stats.cells_conflict += 1;
            if flags & FLAG_VISITED != 0 {
                continue;
            }
            // Flood fill; the queue keeps every cluster's cells contiguous (bounded: each cell enters once).
            let start = self.queue.len();
            self.grid.set_flags(idx, FLAG_VISITED);
            self.queue.push(idx);
            let mut head = start;
            while let Some(&c) = self.queue.get(head) {
                head += 1;
                let (cx, cy) = (c % n, c / n);
                for dy in -1i32..=1 {
                    for dx in -1i32..=1 {
                        if dx == 0 && dy == 0 {
                            continue;
                        }
                        let (nx, ny) = (cx as i64 + i64::from(dx), cy as i64 + i64::from(dy));
                        if nx < 0 || ny < 0 || nx >= i64::from(n) || ny >= i64::from(n) {
                            continue;
                        }
                        let nb = ny as u32 * n + nx as u32;
                        if self.grid.hits(nb) == 0
                            || self.grid.probability(nb) <= tau
                            || self.grid.flags(nb) & (FLAG_EXPLAINED | FLAG_VISITED) != 0
                            || self.queue.len() >= self.queue.capacity()
                        {
                            continue;
                        }
                        self.grid.set_flags(nb, FLAG_VISITED);
                        self.queue.push(nb);
                    }
                }
            }
            let end = self.queue.len();
            let cells = (end - start) as u32;
            if cells < self.params.min_cluster_cells {
                continue;
            }
            self.stats.clusters_total += 1;
            if self.clusters.len() >= self.clusters.capacity() {
                continue;
            }
            let (mut sx, mut sy) = (0.0f32, 0.0f32);
            let mut b = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
            // In the region of interest: some cell inside the ROI, or no ROI. (Cells of known scenery are
            // explained by the map and never part of a cluster.)
            let mut in_roi = frame.roi_in_ego.is_empty();
            for &c in self.queue.get(start..end).unwrap_or(&[]) {
                let (x, y) = geometry.cell_center(c);
                sx += x;
                sy += y;
                b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
                if !in_roi {
                    in_roi = frame.roi_in_ego.iter().any(|p| crate::geometry::polygon_contains(p, x, y));
                }
            }
            if in_roi {
                for k in start..end {
                    if let Some(&c) = self.queue.get(k) {
                        self.grid.set_flags(c, FLAG_ROI_CONFLICT);
                    }
                }
            }
            let inv = 1.0 / cells as f32;
            self.clusters.push(ClusterReport {
                cells,
                centroid_m: [sx * inv, sy * inv],
                bounds_m: b,
                in_roi,
                object: None,
            });
            self.cluster_spans.push((start as u32, end as u32));
        }
    }

    /// Attributes each cluster in the region of interest to the nearest object region within
    /// `conflict_association_m`: for an inconsistent object its evidence moved out, for a consistent one its
    /// evidence spills over the region's edge. Evidence outside the ROI or in known scenery is nobody's.
    fn attribute_clusters(&mut self) {
        let geometry = self.grid.geometry;
        let reach = self.params.conflict_association_m;
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        let tau_tp = self.params.tau_tp;
        // A cluster "touches" a region when a cell of it is adjacent to the region.
        let spill = 0.5 * geometry.cell_size_m;
        for (k, cluster) in self.clusters.iter_mut().enumerate() {
            let Some(&(start, end)) = self.cluster_spans.get(k) else { continue };
            let cells = self.queue.get(start as usize..end as usize).unwrap_or(&[]);
            // Prefer an object without evidence of its own (its evidence moved out) within reach; a consistent
            // object only when the cluster touches its region (its evidence spills over the edge).
            let mut best: Option<(usize, f32, bool)> = None;
            for (j, s) in self.scratch.iter().enumerate() {
                let Some(region) = &s.region else { continue };
                // Evidence outside the region of interest (or in known scenery) is nobody's.
                if !cluster.in_roi {
                    continue;
                }
                let rb = region.grown.aabb();
                let cb = cluster.bounds_m;
                let gap_x = (cb[0] - rb[2]).max(rb[0] - cb[2]).max(0.0);
                let gap_y = (cb[1] - rb[3]).max(rb[1] - cb[3]).max(0.0);
                // Bounds are of cell centres: allow half a diagonal, as the exact test below does. First without
                // the square root: `hypot(gx, gy) >= max(gx, gy)` also after rounding, so this skips only pairs
                // the test with `hypotf` skips (most pairs are far apart).
                if gap_x.max(gap_y) - half_diagonal > reach || libm::hypotf(gap_x, gap_y) - half_diagonal > reach {
                    continue;
                }
                // Distance from the cell (not its centre) to the region: centre distance less half a diagonal
                // (no cell can come nearer than touching).
                let mut d = f32::INFINITY;
                for &c in cells {
                    let (x, y) = geometry.cell_center(c);
                    d = d.min((region.grown.distance(x, y) - half_diagonal).max(0.0));
                    if d <= 0.0 {
                        break;
                    }
                }
                let inconsistent = self.reports.get(j).is_some_and(|r| r.sensor.eta < tau_tp);
                let within = if inconsistent { reach } else { spill };
                let better = match best {
                    None => true,
                    Some((_, bd, b_inc)) => (inconsistent && !b_inc) || (inconsistent == b_inc && d < bd),
                };
                if d <= within && better {
                    best = Some((j, d, inconsistent));
                }
            }
            if let Some((j, _, _)) = best {
                cluster.object = u32::try_from(j).ok();
                if let Some(s) = self.scratch.get_mut(j) {
                    if s.cluster.is_none_or(|(_, size)| cluster.cells > size) {
                        s.cluster = u16::try_from(k).ok().map(|k16| (k16, cluster.cells));
                    }
                }
            }
        }
    }

    /// Index of the reported cluster that contains a cell (linear in the conflict cells; only called for
    /// evidence-free objects).
    fn cluster_of(spans: &[(u32, u32)], queue: &[u32], cell: u32) -> Option<usize> {
        if cell == NO_CELL {
            return None;
        }
        spans.iter().position(|&(a, b)| queue.get(a as usize..b as usize).is_some_and(|cells| cells.contains(&cell)))
    }

    /// Sensor verdicts (f(o) with the cluster attribution and the occlusion test) and the combined verdicts.
    fn finish_reports(&mut self, frame: &Frame<'_>) {
        let geometry = self.grid.geometry;
        let tau_tp = self.params.tau_tp;
        for (j, report) in self.reports.iter_mut().enumerate() {
            let scratch = self.scratch.get(j).copied();
            if let Some(ObjectScratch { region: Some(region), cluster }) = scratch {
                let s = &mut report.sensor;
                if let Some((k, _)) = cluster {
                    s.verdict = SensorVerdict::PositionError;
                    s.cluster = Some(k);
                    if let Some(c) = self.clusters.get(k as usize) {
                        let (nx, ny) = region.footprint.nearest_point(c.centroid_m[0], c.centroid_m[1]);
                        s.offset_m = [nx - c.centroid_m[0], ny - c.centroid_m[1]];
                    }
                } else if s.eta < tau_tp {
                    // Was the place the object claims to occupy (its footprint, not the margin around it)
                    // visible to the sensor? A footprint hidden behind evidence that no object explains is not
                    // excused: that evidence is likely the object itself, displaced.
                    let (mut visible, mut unexplained_shadow, mut total) = (0u32, 0u32, 0u32);
                    let mut occluder = NO_CELL;
                    if let Some(range) = geometry.cell_range(region.footprint.aabb()) {
                        let (visibility, grid) = (&self.visibility, &self.grid);
                        geometry.for_each_cell_overlapping(&region.footprint, range, |_, cx, cy| {
                            total += 1;
                            match visibility.sight(cx, cy) {
                                Sight::Visible => visible += 1,
                                Sight::Shadowed(c) if c != NO_CELL => {
                                    // Behind evidence nobody explains, in the region of interest.
                                    if grid.flags(c) & FLAG_ROI_CONFLICT != 0 {
                                        unexplained_shadow += 1;
                                        occluder = c;
                                    }
                                }
                                Sight::Shadowed(_) | Sight::Unreached => {}
                            }
                        });
                    }
                    let frac = |k: u32| if total > 0 { k as f32 / total as f32 } else { 0.0 };
                    s.visible_fraction = frac(visible);
                    s.verdict = if frac(visible + unexplained_shadow) < self.params.ghost_visible_fraction {
                        SensorVerdict::NotMonitored(NotMonitoredReason::Occluded)
                    } else if let Some(k) = Self::cluster_of(&self.cluster_spans, &self.queue, occluder)
                        .filter(|&k| self.clusters.get(k).is_some_and(|c| c.in_roi))
                    {
                        // Hidden behind evidence no object explains: that evidence is the object, displaced.
                        s.cluster = u16::try_from(k).ok();
                        if let Some(c) = self.clusters.get_mut(k) {
                            let (nx, ny) = region.footprint.nearest_point(c.centroid_m[0], c.centroid_m[1]);
                            s.offset_m = [nx - c.centroid_m[0], ny - c.centroid_m[1]];
                            if c.object.is_none() {
                                c.object = u32::try_from(j).ok();
                            }
                        }
                        SensorVerdict::PositionError
                    } else {
                        SensorVerdict::Ghost
                    };
                }
            }
            if let Some(m) = self.motion.get(j) {
                report.motion = *m;
            }
            report.verdict = Verdict::combine(report.sensor.verdict, report.motion.verdict);
        }
        let _ = frame;
    }
}
