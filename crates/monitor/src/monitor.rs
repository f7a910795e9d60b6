//! [`Monitor`]: owns every buffer, runs both checks on a frame, and returns one verdict per object.

use alloc::vec::Vec;

use crate::evidence_memory::{EvidenceKind, EvidenceMemory};
use crate::frame::{Frame, ObjectState, Uncertainty};
use crate::grid::{
    GridGeometry, OccupancyGrid, FLAG_ATTRIBUTED, FLAG_EXPLAINED, FLAG_ROI_CONFLICT, FLAG_STATIC, FLAG_VISITED,
};
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
    /// `eta_own`: the highest occupancy probability among the cells this object owns (see [`SensorOutcome`]).
    eta_own: f32,
    /// What the sensor saw of the footprint; computed for objects without evidence of their own only.
    sight: Option<FootprintSight>,
    /// The track's evidence in the previous frame: kind and offset from the centre (ego frame, metres).
    recalled: Option<(EvidenceKind, [f32; 2])>,
    /// Sum of the centres of the occupied cells the object owns, and their number.
    own_sum: [f32; 3],
}

/// What the sensor saw of an object's footprint (the cells overlapping it), for objects without evidence of
/// their own: was the place visibly empty, hidden, or taken by another object's evidence?
#[derive(Clone, Copy, Debug, Default)]
struct FootprintSight {
    /// Footprint cells.
    total: u32,
    /// Seen empty: rays passed over them and returned from beyond.
    visible: u32,
    /// Shadowed by evidence no object explains, in the region of interest (likely this object, displaced).
    unexplained_shadow: u32,
    /// Occupied by evidence that another object owns, with the cell's centre inside that object's footprint:
    /// two objects cannot stand in one place.
    foreign: u32,
    /// A cell of the unexplained evidence that shadows the footprint (`NO_CELL`: none).
    occluder: u32,
    /// The first few distinct cells that stood for the unexplained evidence, with the shadowed cells each
    /// accounts for, so that the test can be brought up to date once evidence is attributed without a second
    /// walk over the footprint (`occluders_len > OCCLUDERS`: too many to keep; walk again).
    occluders: [(u32, u32); OCCLUDERS],
    occluders_len: usize,
}

impl FootprintSight {
    fn fraction(&self, k: u32) -> f32 {
        if self.total > 0 {
            k as f32 / self.total as f32
        } else {
            0.0
        }
    }

    /// Share of the footprint the sensor contradicts: seen empty, behind unexplained evidence, or taken.
    fn contradicted(&self) -> f32 {
        self.fraction(self.visible + self.unexplained_shadow + self.foreign)
    }
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
    /// Per cell, valid where the cell is flagged `FLAG_EXPLAINED` this frame: the object in whose region it
    /// lies deepest among those whose regions cover it (ties to the lower index), and that depth (see `claim`).
    owner: Vec<u32>,
    owner_depth: Vec<f32>,
    /// Per object, compact for the loops over cluster-object pairs: the grown region's bounding box (empty
    /// when the object has no region) and the `CANDIDATE_*` bits.
    candidates: Vec<([f32; 4], u8)>,
    /// Objects with a region as `(left edge of the region's bounding box, index)`, sorted: the pair loops look
    /// only at the objects whose boxes can reach a cluster along x. And the tracks whose evidence stood apart
    /// last frame (looked at for every cluster).
    by_x: Vec<(f32, u32)>,
    displaced: Vec<u32>,
    /// Widest region bounding box of the frame, metres.
    widest_m: f32,
    /// Candidate (distance, cluster, object) pairs of the evidence assignment.
    pairs: Vec<(f32, u32, u32)>,
    valid: Vec<bool>,
    motion: Vec<MotionOutcome>,
    reports: Vec<ObjectReport>,
    clusters: Vec<ClusterReport>,
    cluster_spans: Vec<(u32, u32)>,
    queue: Vec<u32>,
    tracks: TrackTable,
    memory: EvidenceMemory,
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
        eta_own: 0.0,
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
            owner: alloc::vec![0; cells],
            owner_depth: alloc::vec![0.0; cells],
            pairs: Vec::with_capacity(max_clusters.saturating_mul(ASSOCIATION_CANDIDATES)),
            valid: Vec::with_capacity(max_objects),
            candidates: Vec::with_capacity(max_objects),
            by_x: Vec::with_capacity(max_objects),
            displaced: Vec::with_capacity(max_objects),
            widest_m: 0.0,
            motion: Vec::with_capacity(max_objects),
            reports: Vec::with_capacity(max_objects),
            clusters: Vec::with_capacity(max_clusters),
            cluster_spans: Vec::with_capacity(max_clusters),
            queue: Vec::with_capacity(max_points.min(cells)),
            tracks: TrackTable::new(max_objects),
            memory: EvidenceMemory::new(max_objects),
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
        self.memory.clear();
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
        self.pairs.clear();
        self.stats = GridStats::default();
        self.valid.clear();
        self.candidates.clear();
        self.by_x.clear();
        self.displaced.clear();
        self.widest_m = 0.0;
        self.scratch.clear();
        self.motion.clear();
        self.reports.clear();
        for o in frame.objects {
            self.valid.push(object_is_valid(o, &self.params));
            let recalled =
                self.memory.recall(o.id, frame.timestamp_s, frame.world_from_ego.yaw_rad, self.params.max_time_step_s);
            self.scratch.push(ObjectScratch {
                region: None,
                cluster: None,
                eta_own: 0.0,
                sight: None,
                recalled,
                own_sum: [0.0; 3],
            });
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
                            self.explain_cells(i, &region, geometry.cell_range_clipped(bounds));
                        }
                    }
                    Some(_) if self.sensor_status.is_some() => {
                        out.verdict =
                            SensorVerdict::NotMonitored(self.sensor_status.unwrap_or(NotMonitoredReason::NoLidarData));
                    }
                    Some(range) => {
                        let mut eta = self.grid.probability_of_hits(0);
                        let (owner, owner_depth) = (&mut self.owner, &mut self.owner_depth);
                        // A track whose evidence stood apart from it last frame claims cells only where no
                        // other object does: what lies under a displaced box is probably someone else's.
                        let penalty = match self.scratch.get(i).and_then(|s| s.recalled) {
                            Some((EvidenceKind::Displaced, _)) => 1.0,
                            _ => 0.0,
                        };
                        self.grid.for_each_hit_cell_overlapping(&region.grown, range, |grid, idx| {
                            if grid.flags(idx) & FLAG_STATIC == 0 {
                                eta = eta.max(grid.probability(idx));
                                claim(grid, owner, owner_depth, &region, i, idx, penalty);
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

    /// Marks the hit cells of a cell range that overlap object `i`'s region as explained (and claims them).
    fn explain_cells(&mut self, i: usize, region: &Region, range: Option<(u32, u32, u32, u32)>) {
        let Some(range) = range else { return };
        let (owner, owner_depth) = (&mut self.owner, &mut self.owner_depth);
        self.grid.for_each_hit_cell_overlapping(&region.grown, range, |grid, idx| {
            claim(grid, owner, owner_depth, region, i, idx, 0.0);
        });
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

    /// `eta_own` of every object: the highest occupancy probability among the cells it owns (one pass over the
    /// touched cells).
    fn own_evidence(&mut self) {
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
    fn footprint_sight(&self, j: usize, footprint: &crate::geometry::OrientedRect) -> FootprintSight {
        let geometry = self.grid.geometry;
        let mut sight = FootprintSight { occluder: NO_CELL, ..FootprintSight::default() };
        let Some(range) = geometry.cell_range(footprint.aabb()) else { return sight };
        let (grid, visibility, tau) = (&self.grid, &self.visibility, self.params.tau_fn);
        // At most `SIGHT_SAMPLES` cells along each axis of the range are looked at (every `stride`-th row and
        // column): the fractions need no more, and a car at 0.1 m cells would otherwise cost 900 look-ups.
        let span = (range.2 - range.0).max(range.3 - range.1) + 1;
        let stride = span.div_ceil(SIGHT_SAMPLES).max(1);
        let n = geometry.cells_per_side;
        geometry.for_each_cell_overlapping(footprint, range, |idx, cx, cy| {
            if stride > 1 && !((idx % n - range.0).is_multiple_of(stride) && (idx / n - range.1).is_multiple_of(stride))
            {
                return;
            }
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
            match visibility.sight(cx, cy) {
                Sight::Visible => sight.visible += 1,
                // Behind evidence nobody explains, in the region of interest.
                Sight::Shadowed(c) => {
                    if let Some(k) = self.unexplained_at(c) {
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
                Sight::Unreached => {}
            }
        });
        sight
    }

    /// The conflict cell (of a cluster in the region of interest) that stands for the nearest return `c` of a
    /// visibility bin: `c` itself, or, when `c` is unexplained but holds too few hits to be occupied (the first
    /// return of an object is often alone in its cell), an 8-neighbour of it. `None` when `c` is explained,
    /// scenery, or not next to unexplained evidence in the region of interest.
    fn unexplained_at(&self, c: u32) -> Option<u32> {
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
        let n = self.grid.geometry.cells_per_side;
        let (cx, cy) = (c % n, c / n);
        for y in cy.saturating_sub(1)..=(cy + 1).min(n - 1) {
            for x in cx.saturating_sub(1)..=(cx + 1).min(n - 1) {
                let idx = y * n + x;
                if self.grid.flags(idx) & (FLAG_ROI_CONFLICT | FLAG_ATTRIBUTED) == FLAG_ROI_CONFLICT {
                    return Some(idx);
                }
            }
        }
        None
    }

    /// Distance from a cluster's cells (not their centres: no cell comes nearer than touching) to a region,
    /// metres, or `None` when it exceeds `reach` (decided first on bounding boxes, which skips most pairs).
    fn cluster_distance(&self, k: usize, region: &crate::geometry::OrientedRect, reach: f32) -> Option<f32> {
        let geometry = self.grid.geometry;
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        let cluster = self.clusters.get(k)?;
        let &(start, end) = self.cluster_spans.get(k)?;
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
        let mut d = f32::INFINITY;
        for &c in self.queue.get(start as usize..end as usize).unwrap_or(&[]) {
            let (x, y) = geometry.cell_center(c);
            d = d.min((region.distance(x, y) - half_diagonal).max(0.0));
            if d <= 0.0 {
                break;
            }
        }
        (d <= reach).then_some(d)
    }

    /// Gives the evidence no object explains to the objects it belongs to.
    ///
    /// 1. Ownership: each explained cell belongs to the object whose footprint is nearest (`eta_own`). An object
    ///    whose own evidence is below `tau_tp` is *unconfirmed*: occluded, a ghost, or displaced.
    /// 2. Assignment: clusters in the region of interest go to unconfirmed objects by a gated, one-to-one,
    ///    deterministic assignment on the displacement it implies (the distance from the cluster to the
    ///    region `A_o`), nearest pairs first. The gate is `conflict_association_m` for an object whose
    ///    footprint the sensor contradicts (seen empty, behind unexplained evidence, or taken by another
    ///    object's evidence: it is not where it claims) and touching only for one hidden from the sensor (an
    ///    occluded object has no reason to be displaced). A confirmed object takes no displaced evidence.
    /// 3. Spill-over: a cluster left over that continues a confirmed object's own evidence (8-adjacent cells) and
    ///    fits its box together with it, or that touches an unconfirmed object's region (within half a cell)
    ///    and fits its box, is that object's evidence reaching over its edge (the nearest such object).
    ///
    /// Everything else is a missed object. Bounded: pairs are kept up to a fixed capacity
    /// (`ASSOCIATION_CANDIDATES` per cluster on average), sorted in place.
    fn attribute_clusters(&mut self) {
        self.own_evidence();
        let tau_tp = self.params.tau_tp;
        let touch = 0.5 * self.grid.geometry.cell_size_m;
        let gate = self.params.conflict_association_m;
        let follow = 0.5 * gate;
        for s in &self.scratch {
            let entry = match s.region {
                None => ([f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY], 0),
                Some(r) => {
                    let mut bits = CANDIDATE_REGION;
                    if s.eta_own >= tau_tp {
                        bits |= CANDIDATE_CONFIRMED;
                    }
                    if matches!(s.recalled, Some((EvidenceKind::Displaced, _))) {
                        bits |= CANDIDATE_DISPLACED;
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
                if entry.1 & CANDIDATE_DISPLACED != 0 && self.displaced.len() < self.displaced.capacity() {
                    self.displaced.push(index);
                }
            }
        }
        self.by_x.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // Candidate pairs.
        for k in 0..self.clusters.len() {
            let Some(cb) = self.clusters.get(k).filter(|c| c.in_roi).map(|c| c.bounds_m) else { continue };
            // A track whose evidence stood apart from it last frame: its evidence is expected where the offset puts
            // it now (the cost is how far the cluster is from there).
            for m in 0..self.displaced.len() {
                let Some(j) = self.displaced.get(m).map(|&j| j as usize) else { continue };
                let Some(s) = self.scratch.get(j) else { continue };
                let (Some(region), Some((_, r))) = (s.region, s.recalled) else { continue };
                let expected = [region.footprint.cx + r[0], region.footprint.cy + r[1]];
                if let Some(d) = self.cluster_point_distance(k, expected, follow) {
                    if self.evidence_fits(j, &region, k, false) && self.pairs.len() < self.pairs.capacity() {
                        self.pairs.push((d, k as u32, j as u32));
                    }
                }
            }
            // Objects without evidence of their own (a followed track's pair above stands for it).
            let (lo, hi) = self.x_window(cb, gate);
            for m in lo..hi {
                let Some(j) = self.by_x.get(m).map(|&(_, j)| j as usize) else { continue };
                let Some(&(rb, bits)) = self.candidates.get(j) else { continue };
                if bits & CANDIDATE_CONFIRMED != 0 || self.far_apart(cb, rb, gate) {
                    continue;
                }
                let Some(s) = self.scratch.get(j) else { continue };
                let Some(region) = s.region else { continue };
                if let (true, Some((_, r))) = (bits & CANDIDATE_DISPLACED != 0, s.recalled) {
                    let expected = [region.footprint.cx + r[0], region.footprint.cy + r[1]];
                    if self.cluster_point_distance(k, expected, follow).is_some() {
                        continue;
                    }
                }
                let Some(d) = self.cluster_distance(k, &region.grown, gate) else { continue };
                // The whole gate for an object the sensor contradicts, or one that claims to stand behind the
                // evidence on its own line of sight (displaced away from it; its place is then hidden, often also
                // behind a low obstacle the rays passed over); touching only for one merely hidden.
                let reachable = d <= touch
                    || self.clusters.get(k).is_some_and(|c| self.behind(&region.footprint, c.centroid_m))
                    || self.sight_of(j, &region).contradicted() >= self.params.ghost_visible_fraction;
                if reachable && self.evidence_fits(j, &region, k, false) && self.pairs.len() < self.pairs.capacity() {
                    self.pairs.push((d, k as u32, j as u32));
                }
            }
        }
        // Nearest first; ties by cluster, then object: deterministic.
        self.pairs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        for p in 0..self.pairs.len() {
            let Some(&(_, k, j)) = self.pairs.get(p) else { continue };
            let free = self.clusters.get(k as usize).is_some_and(|c| c.object.is_none());
            if free && self.scratch.get(j as usize).is_some_and(|s| s.cluster.is_none()) {
                self.give(k as usize, j as usize);
            }
        }
        // Spill-over of the clusters left.
        let adjacent = core::f32::consts::SQRT_2 * self.grid.geometry.cell_size_m + 1e-3;
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
                let Some(d) = self.cluster_distance(k, &region.grown, reach) else { continue };
                let ok = if confirmed {
                    self.cluster_touches_own_evidence(j, k) && self.evidence_fits(j, &region, k, true)
                } else {
                    self.evidence_fits(j, &region, k, false)
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
    }

    /// The range of `by_x` whose regions' bounding boxes can come within `reach` of a cluster's bounds along x.
    fn x_window(&self, cluster_bounds: [f32; 4], reach: f32) -> (usize, usize) {
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
    /// nothing). Points, not cells: the visibility map keeps the ranges of the returns themselves.
    fn seen_through(&self, j: usize, region: &Region) -> bool {
        let fp = &region.footprint;
        let margin = region.margin_length_m.max(region.margin_width_m);
        let tau = self.params.tau_fn;
        let mut free = 0u32;
        for u in [-0.6f32, 0.0, 0.6] {
            for v in [-0.6f32, 0.0, 0.6] {
                let (lu, lv) = (u * fp.half_length, v * fp.half_width);
                let (x, y) = (fp.cx + lu * fp.cos - lv * fp.sin, fp.cy + lu * fp.sin + lv * fp.cos);
                let Some((clearance, cell)) = self.visibility.clearance(x, y) else { continue };
                let own = |c: u32| {
                    self.grid.probability(c) > tau
                        && self.grid.flags(c) & (FLAG_EXPLAINED | FLAG_STATIC) == FLAG_EXPLAINED
                        && self.owner.get(c as usize).is_some_and(|&o| o as usize == j)
                };
                // The first return of a face is often alone in its cell: its occupied neighbour stands for it.
                let n = self.grid.geometry.cells_per_side;
                let near_own = own(cell)
                    || [cell.wrapping_sub(1), cell + 1, cell.wrapping_sub(n), cell + n]
                        .into_iter()
                        .any(|c| c < n * n && own(c));
                if clearance > margin && near_own {
                    free += 1;
                }
            }
        }
        free as f32 >= self.params.ghost_visible_fraction * 9.0
    }

    /// A sight brought up to date after the attribution: shadows cast by evidence now attributed to an object
    /// hide rather than contradict.
    fn without_attributed(&self, mut sight: FootprintSight) -> FootprintSight {
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
    fn sight_of(&mut self, j: usize, region: &Region) -> FootprintSight {
        if let Some(sight) = self.scratch.get(j).and_then(|s| s.sight) {
            return sight;
        }
        let sight = self.footprint_sight(j, &region.footprint);
        if let Some(s) = self.scratch.get_mut(j) {
            s.sight = Some(sight);
        }
        sight
    }

    /// True when a cluster's bounds (of cell centres) and a region's bounding box are more than `reach` apart,
    /// cells included (a lower bound of [`Monitor::cluster_distance`]: skips most pairs cheaply).
    fn far_apart(&self, cluster_bounds: [f32; 4], region_aabb: [f32; 4], reach: f32) -> bool {
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * self.grid.geometry.cell_size_m;
        let gap_x = (cluster_bounds[0] - region_aabb[2]).max(region_aabb[0] - cluster_bounds[2]);
        let gap_y = (cluster_bounds[1] - region_aabb[3]).max(region_aabb[1] - cluster_bounds[3]);
        gap_x.max(gap_y) - half_diagonal > reach
    }

    /// Index of the reported cluster that contains a cell (linear in the conflict cells; only called for
    /// objects without evidence of their own).
    fn cluster_of(spans: &[(u32, u32)], queue: &[u32], cell: u32) -> Option<usize> {
        if cell == NO_CELL {
            return None;
        }
        spans.iter().position(|&(a, b)| queue.get(a as usize..b as usize).is_some_and(|cells| cells.contains(&cell)))
    }

    /// True when a footprint lies behind a point as the sensor sees them: the point's bearing within the
    /// footprint's angular extent (plus half a cell), and the point nearer than the footprint's centre.
    fn behind(&self, footprint: &crate::geometry::OrientedRect, point: [f32; 2]) -> bool {
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
    fn cluster_point_distance(&self, k: usize, p: [f32; 2], reach: f32) -> Option<f32> {
        let geometry = self.grid.geometry;
        let half_diagonal = core::f32::consts::FRAC_1_SQRT_2 * geometry.cell_size_m;
        let cb = self.clusters.get(k)?.bounds_m;
        let gap_x = (cb[0] - p[0]).max(p[0] - cb[2]).max(0.0);
        let gap_y = (cb[1] - p[1]).max(p[1] - cb[3]).max(0.0);
        if gap_x.max(gap_y) - half_diagonal > reach {
            return None;
        }
        let mut d = f32::INFINITY;
        for &c in self.cluster_cells(k) {
            let (x, y) = geometry.cell_center(c);
            d = d.min((libm::hypotf(x - p[0], y - p[1]) - half_diagonal).max(0.0));
        }
        (d <= reach).then_some(d)
    }

    /// Cells of cluster `k`.
    fn cluster_cells(&self, k: usize) -> &[u32] {
        self.cluster_spans.get(k).and_then(|&(a, b)| self.queue.get(a as usize..b as usize)).unwrap_or(&[])
    }

    /// True when a cell of cluster `k` is 8-adjacent to an occupied cell that object `j` owns.
    fn cluster_touches_own_evidence(&self, j: usize, k: usize) -> bool {
        let n = self.grid.geometry.cells_per_side;
        let tau = self.params.tau_fn;
        self.cluster_cells(k).iter().any(|&c| {
            let (cx, cy) = (c % n, c / n);
            (cy.saturating_sub(1)..=(cy + 1).min(n - 1)).any(|y| {
                (cx.saturating_sub(1)..=(cx + 1).min(n - 1)).any(|x| {
                    let idx = y * n + x;
                    self.grid.probability(idx) > tau
                        && self.grid.flags(idx) & (FLAG_EXPLAINED | FLAG_STATIC) == FLAG_EXPLAINED
                        && self.owner.get(idx as usize).is_some_and(|&o| o as usize == j)
                })
            })
        })
    }

    /// Could cluster `k` (with object `j`'s own occupied evidence, when `with_own`) be the evidence of `j`'s box
    /// moved somewhere? True when its extent along and across the box, over cell centres, is at most the box's
    /// length and width plus one cell diagonal (a cell centre is within half a diagonal of every point of the
    /// cell) and twice the safety margin (LiDAR noise). A wall, a hedge or two objects side by side do not fit
    /// a pedestrian.
    fn evidence_fits(&self, j: usize, region: &Region, k: usize, with_own: bool) -> bool {
        let geometry = self.grid.geometry;
        let fp = &region.footprint;
        let slack = core::f32::consts::SQRT_2 * geometry.cell_size_m + 2.0 * self.params.safety_margin_m;
        // First on the cluster's bounds: two of its cells as far apart as its bounding box is wide cannot both lie
        // in a box whose diagonal is shorter (this skips walls and hedges without a look at their cells).
        if let Some(b) = self.clusters.get(k).map(|c| c.bounds_m) {
            let diagonal = libm::hypotf(2.0 * fp.half_length + slack, 2.0 * fp.half_width + slack);
            if (b[2] - b[0]).max(b[3] - b[1]) > diagonal {
                return false;
            }
        }
        let mut span = [f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY];
        let mut add = |x: f32, y: f32| {
            let (u, v) = fp.local(x, y);
            span = [span[0].min(u), span[1].max(u), span[2].min(v), span[3].max(v)];
        };
        for &c in self.cluster_cells(k) {
            let (x, y) = geometry.cell_center(c);
            add(x, y);
        }
        if with_own {
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
        }
        span[1] - span[0] <= 2.0 * fp.half_length + slack && span[3] - span[2] <= 2.0 * fp.half_width + slack
    }

    /// Attributes cluster `k` to object `j` (an object keeps its largest cluster as the one it reports).
    fn give(&mut self, k: usize, j: usize) {
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

    /// Sensor verdicts (f(o) with the evidence attribution and the occlusion test) and the combined verdicts.
    fn finish_reports(&mut self, frame: &Frame<'_>) {
        let tau_tp = self.params.tau_tp;
        self.memory.begin();
        for j in 0..self.reports.len() {
            let Some(scratch) = self.scratch.get(j).copied() else { continue };
            if let ObjectScratch { region: Some(region), cluster, eta_own, sight, own_sum, .. } = scratch {
                // Hidden behind evidence that no object explains and nobody took: that evidence is likely the
                // object itself, displaced (a ghost otherwise).
                let mut cluster = cluster.map(|(k, _)| usize::from(k));
                let mut occluded = false;
                let mut shared = false;
                let mut sight = sight;
                if cluster.is_none() && eta_own < tau_tp {
                    // Seen again now that the displaced evidence has its objects, if unexplained evidence shadowed
                    // it: evidence attributed to another object hides this one; it does not contradict it.
                    let seen = match sight {
                        Some(s) if s.unexplained_shadow == 0 => s,
                        Some(s) if s.occluders_len <= OCCLUDERS => self.without_attributed(s),
                        _ => self.footprint_sight(j, &region.footprint),
                    };
                    sight = Some(seen);
                    let sight = seen;
                    let open = sight.fraction(sight.visible + sight.unexplained_shadow);
                    if sight.contradicted() < self.params.ghost_visible_fraction {
                        occluded = true;
                    } else if open < self.params.ghost_visible_fraction && s_eta(&self.reports, j) >= tau_tp {
                        // Its place is taken by evidence another object owns and no displaced evidence came its
                        // way: the two cannot be told apart (objects standing in one place, or one box on its
                        // neighbour's evidence). The paper's f(o) stands: the region holds evidence.
                        shared = true;
                    } else if let Some(k) = Self::cluster_of(&self.cluster_spans, &self.queue, sight.occluder)
                        .filter(|&k| self.clusters.get(k).is_some_and(|c| c.in_roi && c.object.is_none()))
                    {
                        self.give(k, j);
                        cluster = Some(k);
                    }
                }
                let seen_through =
                    cluster.is_none() && eta_own >= tau_tp && own_sum[2] >= 1.0 && self.seen_through(j, &region);
                let Some(report) = self.reports.get_mut(j) else { continue };
                let s = &mut report.sensor;
                s.eta_own = eta_own;
                if let Some(sight) = sight {
                    s.visible_fraction = sight.fraction(sight.visible);
                }
                s.verdict = if let Some(k) = cluster {
                    s.cluster = u16::try_from(k).ok();
                    if let Some(c) = self.clusters.get(k) {
                        let (nx, ny) = region.footprint.nearest_point(c.centroid_m[0], c.centroid_m[1]);
                        s.offset_m = [nx - c.centroid_m[0], ny - c.centroid_m[1]];
                    }
                    SensorVerdict::PositionError
                } else if seen_through {
                    // Confirmed by evidence in its margin, but the rays prove its footprint empty: the object
                    // stands in front of its evidence, displaced towards the sensor (beyond the paper, whose
                    // checks cannot see this direction).
                    let c = [own_sum[0] / own_sum[2], own_sum[1] / own_sum[2]];
                    let (nx, ny) = region.footprint.nearest_point(c[0], c[1]);
                    s.offset_m = [nx - c[0], ny - c[1]];
                    SensorVerdict::PositionError
                } else if eta_own >= tau_tp || shared {
                    SensorVerdict::Consistent
                } else if occluded {
                    SensorVerdict::NotMonitored(NotMonitoredReason::Occluded)
                } else {
                    SensorVerdict::Ghost
                };
                // What the next frame recalls of this track's evidence.
                let centre = [region.footprint.cx, region.footprint.cy];
                let evidence = match s.verdict {
                    SensorVerdict::PositionError => match s.cluster.and_then(|k| self.clusters.get(usize::from(k))) {
                        Some(c) => Some((EvidenceKind::Displaced, c.centroid_m)),
                        // Seen through: its own evidence, behind it, is where it stands apart.
                        None if own_sum[2] >= 1.0 => {
                            Some((EvidenceKind::Displaced, [own_sum[0] / own_sum[2], own_sum[1] / own_sum[2]]))
                        }
                        None => None,
                    },
                    SensorVerdict::Consistent if own_sum[2] >= 1.0 => {
                        Some((EvidenceKind::Own, [own_sum[0] / own_sum[2], own_sum[1] / own_sum[2]]))
                    }
                    _ => None,
                };
                if let Some((kind, at)) = evidence {
                    let id = report.id;
                    let offset = [at[0] - centre[0], at[1] - centre[1]];
                    self.memory.record(id, j, frame.timestamp_s, frame.world_from_ego.yaw_rad, offset, kind);
                }
            }
            let Some(report) = self.reports.get_mut(j) else { continue };
            if let Some(m) = self.motion.get(j) {
                report.motion = *m;
            }
            report.verdict = Verdict::combine(report.sensor.verdict, report.motion.verdict);
        }
        self.memory.commit();
    }
}

/// The paper's consistency `eta` of report `j`.
fn s_eta(reports: &[ObjectReport], j: usize) -> f32 {
    reports.get(j).map_or(0.0, |r| r.sensor.eta)
}

/// Distinct occluding cells a [`FootprintSight`] keeps count of.
const OCCLUDERS: usize = 4;

/// Most cells looked at along each axis of a footprint's cell range by the sight test.
const SIGHT_SAMPLES: u32 = 8;

/// Candidate bit: the object has a region in the grid.
const CANDIDATE_REGION: u8 = 1;
/// Candidate bit: the object is confirmed by its own evidence (`eta_own >= tau_tp`).
const CANDIDATE_CONFIRMED: u8 = 2;
/// Candidate bit: the track's evidence stood apart from it in the previous frame.
const CANDIDATE_DISPLACED: u8 = 4;

/// Average number of candidate objects per conflict cluster the evidence assignment keeps room for.
const ASSOCIATION_CANDIDATES: usize = 8;

/// Marks a hit cell as explained by object `i`'s region and makes `i` its owner when the cell lies deepest in
/// `i`'s region so far (strictly: ties stay with the lower index).
///
/// Depth is measured relative to the region's size, `max(|u| / half length, |v| / half width)` in the region's
/// axes (1 on its edge): evidence on an object's face lies well inside its own region, while a neighbour whose
/// region only reaches it with its margin sees it near its edge, whatever the two objects' sizes.
#[inline]
fn claim(
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
