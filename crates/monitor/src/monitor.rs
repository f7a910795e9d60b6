//! [`Monitor`]: owns every buffer, runs both checks on a frame, and returns one verdict per object.
//!
//! This file keeps the types, construction, the public API, the sequence of the stages ([`Stage`], `check_inner`),
//! the stages up to the regions (rasterize, scenery, regions and `eta`, cell ownership) and each object's own
//! returns summed after the attribution (`sum_cell_returns`). The rest of the stages is in the files beside it: the
//! conflict clusters and the region of interest decided by returns in `clusters.rs` (the polygons in `roi.rs`, the
//! grazing rule in `graze.rs`), their attribution in `attribution.rs` and the files it names, the sensor verdicts
//! and the combined verdicts in `verdicts.rs`.

use alloc::vec::Vec;

use crate::evidence_memory::{EvidenceKind, EvidenceMemory, Hold};
use crate::frame::{ColumnCloud, Frame, Isometry3, ObjectState, PointCloud, PointColumns, Uncertainty};
use crate::grid::{
    GridGeometry, OccupancyGrid, FLAG_ATTRIBUTED, FLAG_EXPLAINED, FLAG_ROI_CONFLICT, FLAG_ROI_EDGE, FLAG_STATIC,
};
use crate::params::{MonitorParams, ParamError, SpillOverFit};
use crate::plausibility::TrackTable;
use crate::region::Region;
use crate::verdict::{
    ClusterReport, FrameError, FrameReport, GridStats, MotionOutcome, NotMonitoredReason, ObjectReport, RoiStatus,
    SensorOutcome, SensorVerdict, Verdict,
};
use crate::visibility::{Sight, VisibilityMap, NO_CELL};

mod assignment;
mod attribution;
mod beyond;
mod clusters;
mod distance;
mod face;
mod fit;
mod graze;
mod margin;
mod memory_steps;
mod over;
mod released;
mod roi;
mod sight;
mod verdicts;
use attribution::{claim, ASSOCIATION_CANDIDATES};
use clusters::EDGE_MAP;
use fit::OwnSpans;
use graze::RoiAmount;
#[doc(hidden)]
pub use roi::roi_index_mismatch;
use roi::{polygon_box, RoiIndex};
use sight::FootprintSight;

/// The sweep of the frame being checked, as the caller gave it: `[x, y, z]` records ([`Monitor::check`]) or
/// columns ([`Monitor::check_columns`]). Every stage reads the points through it.
#[derive(Clone, Copy, Debug)]
enum Points<'a> {
    Rows(&'a [[f32; 3]]),
    Columns(PointColumns<'a>),
}

impl Points<'_> {
    fn len(self) -> usize {
        match self {
            Self::Rows(p) => p.len(),
            Self::Columns(c) => c.len(),
        }
    }

    /// Point `i`, `None` past the end.
    #[inline]
    fn get(self, i: usize) -> Option<[f32; 3]> {
        match self {
            Self::Rows(p) => p.get(i).copied(),
            Self::Columns(c) => c.get(i),
        }
    }
}

/// A sweep and its extrinsic, from a [`PointCloud`] or a [`ColumnCloud`].
#[derive(Clone, Copy, Debug)]
struct Cloud<'a> {
    points: Points<'a>,
    ego_from_sensor: Isometry3,
}

impl<'a> From<PointCloud<'a>> for Cloud<'a> {
    fn from(c: PointCloud<'a>) -> Self {
        Self { points: Points::Rows(c.points_in_sensor), ego_from_sensor: c.ego_from_sensor }
    }
}

impl<'a> From<ColumnCloud<'a>> for Cloud<'a> {
    fn from(c: ColumnCloud<'a>) -> Self {
        Self { points: Points::Columns(c.points_in_sensor), ego_from_sensor: c.ego_from_sensor }
    }
}

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
    /// The displaced offset the track keeps: found by an alarm in the previous frame, or held since
    /// (`memory_hold_s`; ego frame).
    hold: Option<Hold>,
    /// With `parked_hold_s`: the displaced offset a parked vehicle's track keeps (ego frame).
    parked: Option<Hold>,
    /// Sum of the centres of the occupied cells the object owns, and their number.
    own_sum: [f32; 3],
    /// With `evidence_runs_on`: one of those cells overlaps the object's footprint (not only its margin).
    own_on_footprint: bool,
    /// With `jump_from_returns`: the sum of the returns in those cells, and their number.
    own_returns: [f32; 3],
    /// The last cluster found where the track's remembered offset puts its evidence (`u32::MAX`: none yet).
    followed: u32,
    /// Where the track's centre should stand now if it moved as the previous frame's object list said, and how
    /// many occupied cells its own evidence held then (tracks confirmed by their own evidence last frame only).
    /// With `jump_from_returns`, also the offset from its centre to its returns' mean then (current ego axes).
    predicted: Option<([f32; 2], f32, Option<[f32; 2]>)>,
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
    /// last frame (looked at for every cluster), with where their offset puts that evidence now.
    by_x: Vec<(f32, u32)>,
    displaced: Vec<(u32, [f32; 2])>,
    /// Per object, during spill-over (step 5): the spans, in its box's axes, of the occupied cells it owns in its
    /// grown region and of the hit cells it owns there, all of them and those on its near side ([`OwnSpans`]),
    /// computed the first time spill-over asks (`Monitor::own_spans`); `None` until then. Ownership does not change
    /// during spill-over.
    own_spans: Vec<Option<OwnSpans>>,
    /// Widest region bounding box of the frame, metres.
    widest_m: f32,
    /// Candidate (distance, cluster, object, group) pairs of the evidence assignment; the group is the connected
    /// component of the pair graph the pair belongs to (a node of `groups`).
    pairs: Vec<(f32, u32, u32, u32)>,
    /// Union-find parents over the pair graph's nodes: clusters `0..max_clusters`, then objects.
    groups: Vec<u32>,
    valid: Vec<bool>,
    motion: Vec<MotionOutcome>,
    reports: Vec<ObjectReport>,
    /// The frame's objects in the order they are judged in, when the list came in another order (`check_inner`):
    /// by id, duplicate ids in input order. Empty otherwise.
    ordered: Vec<ObjectState>,
    /// With `ordered`: `order[r]` is the input index of the object judged `r`-th; empty when the list came in that
    /// order. The reports and the clusters' objects are given back in input order.
    order: Vec<u32>,
    /// With `ordered`: a copy of the reports in the order judged, to put them back in input order.
    ordered_reports: Vec<ObjectReport>,
    clusters: Vec<ClusterReport>,
    cluster_spans: Vec<(u32, u32)>,
    queue: Vec<u32>,
    tracks: TrackTable,
    memory: EvidenceMemory,
    stats: GridStats,
    sensor_status: Option<NotMonitoredReason>,
    rasterizer: crate::rasterize::Rasterizer,
    spill_over_fit: SpillOverFit,
    /// This frame's region-of-interest polygons, indexed by grid row (`roi.rs`).
    roi: RoiIndex,
    /// In frames with a region of interest, and in every frame with `seen_over` or `returns_beyond_cells`: each
    /// point's grid cell as the rasterizer found it (`NO_CELL` for points not in the obstacle band or not in the
    /// grid), for the returns of the ROI's edge cells, of the cells `seen_over` reads and of the candidate cells of
    /// `returns_beyond_cells` (`beyond.rs`).
    point_cells: Vec<u32>,
    /// The prefilter of the scan of the recorded cells (`roi_by_returns`): byte `c & 0xFFFF` is 1 when a cell `c`
    /// marked `FLAG_ROI_EDGE` this frame maps to it ([`EDGE_MAP`] bytes; all 0 between frames). Exact for grids of
    /// at most 65,535 cells (`NO_CELL` maps to byte 0xFFFF, which no cell then sets); for larger grids cells may
    /// share a byte, and each candidate is checked against the cell's flags.
    edge_map: Vec<u8>,
    /// With the grazing rule (`roi_graze_fraction > 0`): per reported cluster, its obstacle-band returns in
    /// cells wholly inside the ROI, all its band returns, and whether the amount still decides it (`graze.rs`).
    roi_amounts: Vec<RoiAmount>,
    /// With the grazing rule: per cell, the band returns of a `FLAG_ROI_EDGE` cell found inside the ROI
    /// (saturating; 0 between frames; the returns above `roi_graze_height_m` are the grid's tall bits). Empty with
    /// the rule off.
    roi_cell_counts: Vec<u8>,
    /// The second half's buffers of the rasterize stage on two threads ([`Monitor::enable_split`]).
    split: Option<crate::split::SecondHalf>,
    /// The sensor origin's height in the ego frame this frame, m (for `seen_over`).
    sensor_z: f32,
    /// With `seen_over`: the cells it may read this frame, sorted (`over.rs`; at most
    /// [`over::OVER_CELLS_PER_POINT`] per sample point of each object, the capacity made in `new`), and each one's
    /// nearest squared range and lowest and highest z of its returns. Empty without the key.
    over_cells: Vec<u32>,
    over_entries: Vec<[f32; 3]>,
    /// With `seen_over`: per object of the frame, per sample point of the free-space test, the evidence cell behind
    /// it that `seen_over`'s walks found and the point's occluder (`NO_CELL`: the point is not looked over).
    over_points: Vec<[[u32; 2]; 9]>,
    /// With `seen_over`: the prefilter of its scan of the recorded cells ([`EDGE_MAP`] bytes, as `edge_map`; all 0
    /// between frames). Empty without the key.
    over_map: Vec<u8>,
    /// With `returns_beyond_cells`: the candidate cells of each confirmed box (its own hit cells whose first return
    /// stands beyond its grown region), sorted by cell and box, with the distance beyond that region of each cell's
    /// nearest return (`beyond.rs`). Empty without the key.
    beyond_entries: Vec<beyond::BeyondEntry>,
    /// With `returns_beyond_cells`: the prefilter of its scan of the recorded cells ([`EDGE_MAP`] bytes, as
    /// `edge_map`; all 0 between frames). Empty without the key.
    beyond_map: Vec<u8>,
    /// With `returns_beyond_cells`: whether this frame's candidate cells were gathered and scanned.
    beyond_gathered: bool,
}

/// The occupancy grid the parameters ask for (touched cells bounded by `max_points`; each hit cell's sums of its
/// returns' x and y with `jump_from_returns`; a bit per cell for the returns above the grazing rule's height with
/// `roi_graze_fraction > 0`): the monitor's and the second half's of the rasterize stage on two threads.
fn grid_for(params: &MonitorParams, geometry: GridGeometry) -> OccupancyGrid {
    let mut grid = OccupancyGrid::new(geometry, params.hit_probability, params.max_points as usize);
    if params.jump_from_returns {
        grid = if params.jump_first_return { grid.with_first_returns() } else { grid.with_sums() };
    }
    if params.roi_graze_fraction > 0.0 {
        grid = grid.with_tall(params.ground_z_m + params.roi_graze_height_m);
    }
    grid
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
        position_cause: None,
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
        // With `seen_over`: the cells it may read per frame (two per sample point of each object; `over.rs`).
        let over_cells = if params.seen_over { 9 * over::OVER_CELLS_PER_POINT * max_objects } else { 0 };
        let beyond = params.returns_beyond_cells > 0;
        let mut tracks = TrackTable::new(max_objects);
        // The calibrated rule's gates now, not in the first frame (bounded time per frame).
        let _ = tracks.prepare_gates(params.false_alarm_probability);
        Ok(Self {
            grid: grid_for(&params, geometry),
            visibility: VisibilityMap::new(params.visibility_bins),
            scratch: Vec::with_capacity(max_objects),
            owner: alloc::vec![0; cells],
            owner_depth: alloc::vec![0.0; cells],
            pairs: Vec::with_capacity(max_clusters.saturating_mul(ASSOCIATION_CANDIDATES)),
            groups: alloc::vec![0; max_clusters.saturating_add(max_objects)],
            valid: Vec::with_capacity(max_objects),
            candidates: Vec::with_capacity(max_objects),
            by_x: Vec::with_capacity(max_objects),
            displaced: Vec::with_capacity(max_objects),
            own_spans: Vec::with_capacity(max_objects),
            widest_m: 0.0,
            motion: Vec::with_capacity(max_objects),
            reports: Vec::with_capacity(max_objects),
            ordered: Vec::with_capacity(max_objects),
            order: Vec::with_capacity(max_objects),
            ordered_reports: Vec::with_capacity(max_objects),
            clusters: Vec::with_capacity(max_clusters),
            cluster_spans: Vec::with_capacity(max_clusters),
            queue: Vec::with_capacity(max_points.min(cells)),
            tracks,
            memory: EvidenceMemory::new(max_objects),
            stats: GridStats::default(),
            sensor_status: None,
            rasterizer: crate::rasterize::Rasterizer::default(),
            spill_over_fit: params.spill_over_fit,
            roi: RoiIndex::new(geometry),
            point_cells: Vec::with_capacity(max_points),
            edge_map: alloc::vec![0; EDGE_MAP],
            roi_amounts: Vec::with_capacity(if params.roi_graze_fraction > 0.0 { max_clusters } else { 0 }),
            roi_cell_counts: if params.roi_graze_fraction > 0.0 { alloc::vec![0; cells] } else { Vec::new() },
            split: None,
            sensor_z: 0.0,
            over_cells: Vec::with_capacity(over_cells),
            over_entries: Vec::with_capacity(over_cells),
            over_points: Vec::with_capacity(if params.seen_over { max_objects } else { 0 }),
            over_map: if params.seen_over { alloc::vec![0; EDGE_MAP] } else { Vec::new() },
            beyond_entries: Vec::with_capacity(if beyond { beyond::BEYOND_CELLS_PER_OBJECT * max_objects } else { 0 }),
            beyond_map: if beyond { alloc::vec![0; EDGE_MAP] } else { Vec::new() },
            beyond_gathered: false,
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

    /// Diagnostics (`attribution_diag`, `IDENT=1`): the cells of the last frame's conflict cluster `k` (its index
    /// in the report's clusters); empty for an unknown index.
    #[doc(hidden)]
    #[must_use]
    pub fn last_cluster_cells(&self, k: usize) -> &[u32] {
        self.cluster_cells(k)
    }

    /// Diagnostics (`attribution_diag`, `IDENT=1`): the object (index in the last frame's object list) an occupied
    /// cell's evidence went to in the last frame: the object that took the conflict cluster holding it, else the
    /// object owning it (in whose region it lies deepest); `None` for a free cell, a cell of known scenery, or a
    /// cell that is not occupied.
    #[doc(hidden)]
    #[must_use]
    pub fn cell_attributed_to(&self, cell: u32) -> Option<u32> {
        if self.grid.probability(cell) <= self.params.tau_fn {
            return None;
        }
        let flags = self.grid.flags(cell);
        if flags & FLAG_STATIC != 0 {
            return None;
        }
        if flags & FLAG_EXPLAINED != 0 {
            return self.owner.get(cell as usize).map(|&r| self.input_index(r));
        }
        Self::cluster_of(&self.cluster_spans, &self.queue, cell).and_then(|k| self.clusters.get(k)?.object)
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
    /// Every object of `frame.objects` gets exactly one [`ObjectReport`], in input order. The verdicts do not
    /// depend on that order: the objects are judged in the order of their ids (duplicate ids in input order), and
    /// [`ClusterReport::object`] indexes the list as given. Allocates nothing;
    /// never panics; loops are bounded by the capacities in [`MonitorParams`] and by the grid size.
    ///
    /// # Errors
    /// [`FrameError::TooManyObjects`] when the list exceeds `max_objects` (no object is judged then; the
    /// tracks are left unchanged).
    pub fn check(&mut self, frame: &Frame<'_>) -> Result<FrameReport<'_>, FrameError> {
        self.check_with_stages(frame, &mut |_| {})
    }

    /// Allocates a second grid, visibility map and point buffer, so that [`Monitor::check_split`] can rasterize
    /// a sweep on two threads (about `cells^2 x 3 + max_points x 4` bytes more). Call it once, after
    /// [`Monitor::new`]; again, it does nothing. [`Monitor::check`] is unaffected.
    pub fn enable_split(&mut self) {
        if self.split.is_none() {
            let max_points = self.params.max_points as usize;
            self.split = Some(crate::split::SecondHalf {
                grid: grid_for(&self.params, self.grid.geometry),
                visibility: VisibilityMap::new(self.params.visibility_bins),
                cells: Vec::with_capacity(max_points),
            });
        }
    }

    /// [`Monitor::check`], with the rasterize stage of a large sweep (at least
    /// [`crate::split::SPLIT_MIN_POINTS`] points, 65,536) cut in two halves that `join` runs, on two threads if it
    /// likes: the same reports, bit for bit, as [`Monitor::check`] (the argument is in `crate::split`). Runs
    /// on the calling thread alone when [`Monitor::enable_split`] was not called, for smaller sweeps, and with
    /// the scalar rasterizer. Allocates nothing.
    ///
    /// # Errors
    /// As [`Monitor::check`].
    pub fn check_split(
        &mut self,
        frame: &Frame<'_>,
        join: &dyn crate::split::Join,
    ) -> Result<FrameReport<'_>, FrameError> {
        self.check_inner(frame, frame.cloud.map(Cloud::from), &mut |_| {}, Some(join))
    }

    /// [`Monitor::check_split`], calling `on_stage` as each [`Stage`] ends (see [`Monitor::check_with_stages`]).
    ///
    /// # Errors
    /// As [`Monitor::check`].
    pub fn check_split_with_stages(
        &mut self,
        frame: &Frame<'_>,
        join: &dyn crate::split::Join,
        on_stage: &mut dyn FnMut(Stage),
    ) -> Result<FrameReport<'_>, FrameError> {
        self.check_inner(frame, frame.cloud.map(Cloud::from), on_stage, Some(join))
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
        self.check_inner(frame, frame.cloud.map(Cloud::from), on_stage, None)
    }

    /// [`Monitor::check`] with the sweep given as columns ([`PointColumns`]: separate `x`, `y`, `z` slices, read
    /// in place, no copy into `[x, y, z]` records). `cloud` is the frame's sweep; `frame.cloud` must be `None`. The reports are those [`Monitor::check`] gives for a [`PointCloud`] of the same points,
    /// bit for bit (`tests/rasterize_equivalence.rs`).
    ///
    /// # Errors
    /// As [`Monitor::check`], and [`FrameError::CloudGivenTwice`] when `frame.cloud` is `Some` too (nothing is
    /// checked then).
    pub fn check_columns(&mut self, frame: &Frame<'_>, cloud: &ColumnCloud<'_>) -> Result<FrameReport<'_>, FrameError> {
        self.check_columns_inner(frame, cloud, &mut |_| {}, None)
    }

    /// [`Monitor::check_columns`], calling `on_stage` as each [`Stage`] ends (see [`Monitor::check_with_stages`]).
    ///
    /// # Errors
    /// As [`Monitor::check_columns`].
    pub fn check_columns_with_stages(
        &mut self,
        frame: &Frame<'_>,
        cloud: &ColumnCloud<'_>,
        on_stage: &mut dyn FnMut(Stage),
    ) -> Result<FrameReport<'_>, FrameError> {
        self.check_columns_inner(frame, cloud, on_stage, None)
    }

    /// [`Monitor::check_columns_with_stages`] with the rasterize stage split as in [`Monitor::check_split`].
    ///
    /// # Errors
    /// As [`Monitor::check_columns`].
    pub fn check_columns_split_with_stages(
        &mut self,
        frame: &Frame<'_>,
        cloud: &ColumnCloud<'_>,
        join: &dyn crate::split::Join,
        on_stage: &mut dyn FnMut(Stage),
    ) -> Result<FrameReport<'_>, FrameError> {
        self.check_columns_inner(frame, cloud, on_stage, Some(join))
    }

    /// The entry points with a column sweep: a frame that carries a sweep of its own too is refused.
    fn check_columns_inner(
        &mut self,
        frame: &Frame<'_>,
        cloud: &ColumnCloud<'_>,
        on_stage: &mut dyn FnMut(Stage),
        join: Option<&dyn crate::split::Join>,
    ) -> Result<FrameReport<'_>, FrameError> {
        if frame.cloud.is_some() {
            return Err(FrameError::CloudGivenTwice);
        }
        self.check_inner(frame, Some(Cloud::from(*cloud)), on_stage, join)
    }

    /// The checks of one frame; `cloud` is its sweep (`frame.cloud` is not read past this point).
    fn check_inner(
        &mut self,
        frame: &Frame<'_>,
        cloud: Option<Cloud<'_>>,
        on_stage: &mut dyn FnMut(Stage),
        join: Option<&dyn crate::split::Join>,
    ) -> Result<FrameReport<'_>, FrameError> {
        let n = frame.objects.len();
        if n > self.params.max_objects as usize {
            return Err(FrameError::TooManyObjects { got: n, max: self.params.max_objects });
        }
        // The verdicts must not depend on the order of the list (a tracker may list the same objects in any order,
        // and in another order every frame): the objects are judged in the order of their ids, duplicate ids in
        // input order, and the reports given back in input order. A list already in that order, as trackers and the
        // simulator usually give, is judged as it is (docs/attribution.md, "The order of the object list").
        self.order.clear();
        if frame.objects.iter().zip(frame.objects.iter().skip(1)).all(|(a, b)| a.id <= b.id) {
            self.check_in_order(frame, cloud, on_stage, join);
        } else {
            let objects = frame.objects;
            self.order.extend((0..n).filter_map(|i| u32::try_from(i).ok()));
            self.order.sort_unstable_by_key(|&i| (objects.get(i as usize).map_or(u64::MAX, |o| o.id), i));
            // Taken out of the monitor for the check (no allocation: an empty `Vec` takes its place).
            let mut ordered = core::mem::take(&mut self.ordered);
            ordered.clear();
            ordered.extend(self.order.iter().filter_map(|&i| objects.get(i as usize).copied()));
            self.check_in_order(&Frame { objects: &ordered, ..*frame }, cloud, on_stage, join);
            self.ordered = ordered;
            self.restore_input_order();
        }
        // The verdicts stage ends once the reports stand in input order (the stage marks time the whole check).
        on_stage(Stage::Verdicts);
        Ok(FrameReport {
            objects: &self.reports,
            clusters: &self.clusters,
            grid: self.stats,
            sensor_status: self.sensor_status,
        })
    }

    /// Puts the reports of a frame judged in id order back in input order, and names the objects the clusters went
    /// to by their input index.
    fn restore_input_order(&mut self) {
        self.ordered_reports.clear();
        self.ordered_reports.extend_from_slice(&self.reports);
        for (r, &i) in self.order.iter().enumerate() {
            if let (Some(to), Some(from)) = (self.reports.get_mut(i as usize), self.ordered_reports.get(r)) {
                *to = *from;
            }
        }
        for c in &mut self.clusters {
            c.object = c.object.and_then(|r| self.order.get(r as usize).copied());
        }
    }

    /// The input index of the object judged `r`-th this frame.
    fn input_index(&self, r: u32) -> u32 {
        if self.order.is_empty() {
            r
        } else {
            self.order.get(r as usize).copied().unwrap_or(r)
        }
    }

    /// [`Monitor::check_inner`] for an object list in the order it is judged in: every stage, and every stage's
    /// mark but the verdicts', which `check_inner` gives once the reports stand in input order.
    fn check_in_order(
        &mut self,
        frame: &Frame<'_>,
        cloud: Option<Cloud<'_>>,
        on_stage: &mut dyn FnMut(Stage),
        join: Option<&dyn crate::split::Join>,
    ) {
        self.begin_frame(frame, cloud);
        self.rasterize(frame, cloud, join);
        self.mark_scenery(frame);
        on_stage(Stage::Rasterize);
        self.object_regions(frame);
        on_stage(Stage::Regions);
        if self.sensor_status.is_none() {
            self.cluster_conflicts(frame, cloud);
            self.attribute_clusters();
            self.sum_cell_returns();
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
        // `returns_beyond_cells`: its scan runs when a box first needs it (`beyond.rs`), or with `seen_over` in
        // the same scan as the latter's (`over.rs`).
        self.beyond_gathered = false;
        if self.params.seen_over {
            let status = self.sensor_status;
            self.gather_over_returns(cloud.filter(|_| status.is_none()));
        }
        let status = self.sensor_status;
        self.finish_reports(frame, cloud.filter(|_| status.is_none()));
    }

    fn begin_frame(&mut self, frame: &Frame<'_>, cloud: Option<Cloud<'_>>) {
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
            let (recalled, [hold, parked]) = self.memory.recall_with_hold(
                o.id,
                frame.timestamp_s,
                frame.world_from_ego.yaw_rad,
                self.params.max_time_step_s,
            );
            self.scratch.push(ObjectScratch {
                region: None,
                cluster: None,
                eta_own: 0.0,
                sight: None,
                recalled,
                hold,
                parked,
                own_sum: [0.0; 3],
                own_on_footprint: false,
                own_returns: [0.0; 3],
                followed: u32::MAX,
                predicted: self.memory.predicted_centre(
                    o.id,
                    frame.timestamp_s,
                    &frame.world_from_ego,
                    self.params.max_time_step_s,
                ),
            });
            self.motion.push(MotionOutcome::not_monitored(NotMonitoredReason::InvalidState));
        }
        self.sensor_status = match cloud {
            None => Some(NotMonitoredReason::NoLidarData),
            Some(c) if !c.ego_from_sensor.is_finite() => Some(NotMonitoredReason::InvalidCloud),
            Some(c) if c.points.len() == 0 => Some(NotMonitoredReason::EmptyCloud),
            Some(c) if c.points.len() > self.params.max_points as usize => Some(NotMonitoredReason::TooManyPoints),
            Some(_) => None,
        };
    }

    /// Selects the implementation of the rasterize stage, for verification and benchmarking: the blocked
    /// two-pass loop ([`crate::Rasterizer::Blocked`], the default) or the reference per-point loop
    /// ([`crate::Rasterizer::Scalar`]). Both give bit-identical grids, visibility maps, statistics and verdicts.
    pub fn set_rasterizer(&mut self, rasterizer: crate::Rasterizer) {
        self.rasterizer = rasterizer;
    }

    /// Selects how spill-over decides the fit of a left-over cluster with a confirmed object's own evidence
    /// ([`SpillOverFit`]; the default counts occupied cells only), as the params key `spill_over_fit` does.
    /// Takes effect from the next frame; [`Monitor::params`] reports it.
    pub fn set_spill_over_fit(&mut self, fit: SpillOverFit) {
        self.spill_over_fit = fit;
        self.params.spill_over_fit = fit;
    }

    /// Points -> grid: transform into the ego frame, keep the height band, count hits, fill the visibility map
    /// (the loops are in `crate::rasterize`).
    /// The obstacle band and the ego footprint, as the rasterizer applies them.
    fn band(&self) -> crate::rasterize::Band {
        use crate::rasterize::Band;
        let (lo_m, hi_m) = self.params.obstacle_band_m();
        Band {
            lo_m,
            hi_m,
            ego_m: if self.params.ego_footprint_m.iter().all(|v| *v == 0.0) {
                Band::NO_EGO
            } else {
                self.params.ego_footprint_m
            },
        }
    }

    fn rasterize(&mut self, frame: &Frame<'_>, cloud: Option<Cloud<'_>>, join: Option<&dyn crate::split::Join>) {
        use crate::rasterize::{rasterize_blocked_into, rasterize_scalar, rasterize_scalar_recording, Rasterizer};
        use crate::split::{rasterize_split, Half, SPLIT_MIN_POINTS};
        self.point_cells.clear();
        let Some(cloud) = cloud.filter(|_| self.sensor_status.is_none()) else { return };
        let t = cloud.ego_from_sensor;
        self.visibility.reset([t.translation_m[0], t.translation_m[1]]);
        self.sensor_z = t.translation_m[2];
        let band = self.band();
        // The tall bits only where the grazing rule may read them (frames with a region of interest).
        let tall = !frame.roi_in_ego.is_empty();
        self.grid.set_tall_this_frame(tall);
        if let Some(second) = self.split.as_mut() {
            second.grid.set_tall_this_frame(tall);
        }
        let (grid, visibility) = (&mut self.grid, &mut self.visibility);
        // With a region of interest the loop also records each point's cell (`roi_by_returns` reads them), and with
        // `seen_over` (`over.rs` reads them) or `returns_beyond_cells` (`beyond.rs`).
        let cells = &mut self.point_cells;
        let record = !frame.roi_in_ego.is_empty() || self.params.seen_over || self.params.returns_beyond_cells > 0;
        // The blocked loop with the wider vector unit or on the baseline; `None`: the scalar reference.
        let wide = match self.rasterizer {
            Rasterizer::Blocked => Some(true),
            Rasterizer::BlockedBaseline => Some(false),
            Rasterizer::Scalar => None,
        };
        let split = self.split.as_mut().filter(|_| cloud.points.len() >= SPLIT_MIN_POINTS);
        // The same loops for records and columns (`crate::rasterize::Source`), instantiated for each.
        macro_rules! run {
            ($points:expr) => {{
                let points = $points;
                match (join, split, wide) {
                    (Some(join), Some(second), Some(wide)) => {
                        let first = Half { grid, visibility, cells };
                        let second = Half {
                            grid: &mut second.grid,
                            visibility: &mut second.visibility,
                            cells: &mut second.cells,
                        };
                        rasterize_split(points, &t, band, first, second, wide, record, join)
                    }
                    (_, _, Some(wide)) => {
                        rasterize_blocked_into(points, &t, band, grid, visibility, wide, record, cells)
                    }
                    (_, _, None) if record => rasterize_scalar_recording(points, &t, band, grid, visibility, cells),
                    (_, _, None) => rasterize_scalar(points, &t, band, grid, visibility),
                }
            }};
        }
        let in_band = match cloud.points {
            Points::Rows(points) => run!(points),
            Points::Columns(points) => run!(points),
        };
        self.stats.points_total = u32::try_from(cloud.points.len()).unwrap_or(u32::MAX);
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
            let [x0, y0, x1, y1] = polygon_box(poly);
            let b = [x0 - reach, y0 - reach, x1 + reach, y1 + reach];
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
                    // No sensor data: nothing is judged, wherever the object lies (issue #11: a first frame
                    // without LiDAR read `outside_grid` for a world-frame object list).
                    _ if self.sensor_status.is_some() => {
                        out.verdict =
                            SensorVerdict::NotMonitored(self.sensor_status.unwrap_or(NotMonitoredReason::NoLidarData));
                    }
                    None => {
                        out.verdict = SensorVerdict::NotMonitored(NotMonitoredReason::OutsideGrid);
                        // Not judged, but its evidence inside the grid is explained: no conflict at the edge.
                        self.explain_cells(i, &region, geometry.cell_range_clipped(bounds));
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

    /// With `jump_from_returns`, after the attribution: each object's own returns summed (`own_returns`: x, y and
    /// their number over the occupied cells it owns, in the order of first touch), from the sums of each hit cell's
    /// obstacle-band returns that the rasterizer kept (`OccupancyGrid::sums`; step 9 also reads them for the cells
    /// of a moved region). Nothing without the key.
    fn sum_cell_returns(&mut self) {
        if !self.grid.has_sums() || self.sensor_status.is_some() {
            return;
        }
        let tau = self.params.tau_fn;
        for &c in self.grid.touched() {
            if (self.grid.flags(c) & (FLAG_EXPLAINED | FLAG_STATIC) != FLAG_EXPLAINED)
                | (self.grid.probability(c) <= tau)
            {
                continue;
            }
            let (Some(&o), Some(e)) = (self.owner.get(c as usize), self.grid.sums(c)) else { continue };
            if let Some(s) = self.scratch.get_mut(o as usize) {
                let r = s.own_returns;
                s.own_returns = [r[0] + e[0], r[1] + e[1], r[2] + e[2]];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Isometry3, ObjectClass, PointCloud, Pose2};
    use crate::geometry::OrientedRect;

    use super::roi::tests::Rng;

    /// Thirty boxes (a third pedestrians) at random places and headings, with returns under some, beside others
    /// (displaced) or none (ghosts), forty clumps of walls and clutter, and ground all around: the scenes of the
    /// tests that compare an early-decided or cached path with its reference.
    fn clumps_scene(rng: &mut Rng) -> (Vec<ObjectState>, Vec<[f32; 3]>) {
        let mut objects = Vec::new();
        let mut points = Vec::new();
        for id in 0..30u64 {
            let (x, y) = (rng.range(-35.0, 35.0), rng.range(-35.0, 35.0));
            let (length_m, width_m) = if id % 3 == 0 { (0.6, 0.6) } else { (rng.range(3.5, 5.0), rng.range(1.6, 2.1)) };
            objects.push(ObjectState {
                id,
                class: if id % 3 == 0 { ObjectClass::Pedestrian } else { ObjectClass::Car },
                x_m: x,
                y_m: y,
                heading_rad: rng.range(-3.2, 3.2),
                speed_mps: 0.0,
                length_m,
                width_m,
                uncertainty: None,
            });
            // Evidence under the box, beside it (displaced), or none (a ghost, visible or hidden).
            let kind = id % 4;
            if kind < 3 {
                let (ox, oy) = if kind == 0 { (0.0, 0.0) } else { (rng.range(-3.0, 3.0), rng.range(-3.0, 3.0)) };
                for _ in 0..60 {
                    let z = rng.range(0.3, 1.6);
                    points.push([x + ox + rng.range(-1.0, 1.0), y + oy + rng.range(-1.0, 1.0), z - 1.8]);
                }
            }
        }
        // Walls and clutter that hide some boxes, and ground that shows others empty.
        for _ in 0..40 {
            let (cx, cy) = (rng.range(-40.0, 40.0), rng.range(-40.0, 40.0));
            for _ in 0..30 {
                let z = if rng.range(0.0, 1.0) < 0.3 { rng.range(-0.2, 0.1) } else { rng.range(0.3, 1.8) };
                points.push([cx + rng.range(-1.5, 1.5), cy + rng.range(-1.5, 1.5), z - 1.8]);
            }
        }
        for _ in 0..20_000 {
            let (r, a) = (rng.range(3.0, 49.0), rng.range(0.0, core::f32::consts::TAU));
            points.push([r * libm::cosf(a), r * libm::sinf(a), -1.8 + rng.range(-0.05, 0.05)]);
        }
        (objects, points)
    }

    /// Checks one frame of [`clumps_scene`] (sensor 1.8 m above the ground, no ROI, 10 Hz).
    fn check_clumps(monitor: &mut Monitor, objects: &[ObjectState], points: &[[f32; 3]], frame_no: u32) {
        let frame = Frame {
            timestamp_s: f64::from(frame_no) * 0.1,
            world_from_ego: Pose2::default(),
            objects,
            cloud: Some(PointCloud {
                points_in_sensor: points,
                ego_from_sensor: Isometry3::from_translation(0.0, 0.0, 1.8),
            }),
            roi_in_ego: &[],
            static_in_ego: &[],
        };
        monitor.check(&frame).unwrap();
    }

    /// A placement of the ghost test decided early (`placement_hidden`: after each sampled row, when the rows left
    /// cannot change the answer) gives the answer of its whole sight (`placement_hidden_by_full_sight`), for the
    /// eight placements of every object and for random shifts and turns of each footprint, on random clumps of
    /// returns (some under the objects, some beside them, some far) at three ghost fractions; both answers and both
    /// early exits occur. Where `open_view` holds, every cell of every placement's whole sight is visible (so no
    /// placement is hidden, whatever the fraction).
    #[test]
    fn a_placement_decided_early_equals_its_whole_sight() {
        let mut rng = Rng(0x2545_F491_4F6C_DD1D);
        let (mut hidden, mut seen, mut early, mut opened) = (0usize, 0usize, 0usize, 0usize);
        for cell_size_m in [0.5f32, 0.2] {
            let mut monitor = Monitor::new(MonitorParams { cell_size_m, ..MonitorParams::default() }).unwrap();
            for frame_no in 0..12 {
                let (objects, points) = clumps_scene(&mut rng);
                check_clumps(&mut monitor, &objects, &points, frame_no);
                for fraction in [0.2f32, 0.5, 0.8] {
                    monitor.params.ghost_visible_fraction = fraction;
                    for j in 0..objects.len() {
                        let Some(region) = monitor.scratch.get(j).and_then(|s| s.region) else { continue };
                        let margin = region.margin_length_m.max(region.margin_width_m);
                        let mut moves: Vec<_> = sight::placements(&region).collect();
                        for _ in 0..8 {
                            let fp = region.footprint;
                            let heading = libm::atan2f(fp.sin, fp.cos) + rng.range(-0.5, 0.5);
                            moves.push(OrientedRect::new(
                                fp.cx + rng.range(-3.0, 3.0),
                                fp.cy + rng.range(-3.0, 3.0),
                                heading,
                                fp.half_length,
                                fp.half_width,
                            ));
                        }
                        // The open-view bound: where it holds, every cell of every placement's walk is visible.
                        if monitor.open_view(&region, margin) {
                            opened += 1;
                            for moved in sight::placements(&region) {
                                let sight = monitor.sight_at(j, &moved, margin);
                                assert_eq!(sight.visible, sight.total, "frame {frame_no}, object {j}, {moved:?}");
                                assert!(!monitor.placement_hidden_by_full_sight(j, &moved, margin));
                            }
                        }
                        for moved in &moves {
                            let fast = monitor.placement_hidden(j, moved, margin);
                            let full = monitor.placement_hidden_by_full_sight(j, moved, margin);
                            assert_eq!(fast, full, "cell {cell_size_m}, frame {frame_no}, object {j}, {moved:?}");
                            let total = monitor.sight_at(j, moved, margin).total;
                            if fast {
                                hidden += 1
                            } else {
                                seen += 1
                            }
                            if total > 0 && monitor.placement_test(j, moved, margin).1 < total {
                                early += 1;
                            }
                        }
                    }
                }
                monitor.params.ghost_visible_fraction = MonitorParams::default().ghost_visible_fraction;
            }
        }
        assert!(
            hidden > 100 && seen > 100 && early > 100 && opened > 20,
            "hidden {hidden}, seen {seen}, decided early {early}, open view {opened}"
        );
    }

    /// Spill-over's fit tests with the object's own spans walked once per frame (`own_spans`, `fits_with_own`,
    /// `spill_fits_with`) answer as the references that walk the object's region for every pair
    /// (`evidence_fits_walking_own`, `spill_fits`), for every object with a region and every cluster of the frame, at
    /// two cell sizes; both answers occur, and the cache is filled by the checks themselves.
    #[test]
    fn spill_over_with_the_own_spans_once_equals_the_walk_per_pair() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let (mut fit, mut unfit, mut cached) = (0usize, 0usize, 0usize);
        for cell_size_m in [0.5f32, 0.2] {
            let mut monitor = Monitor::new(MonitorParams { cell_size_m, ..MonitorParams::default() }).unwrap();
            for frame_no in 0..12 {
                let (objects, points) = clumps_scene(&mut rng);
                check_clumps(&mut monitor, &objects, &points, frame_no);
                cached += monitor.own_spans.iter().flatten().count();
                // What the frame's spill-over stored must be what a fresh walk gives.
                let stored: Vec<_> = monitor.own_spans.clone();
                monitor.own_spans.iter_mut().for_each(|s| *s = None);
                for j in 0..objects.len() {
                    let Some(region) = monitor.scratch.get(j).and_then(|s| s.region) else { continue };
                    let spans = monitor.own_spans(j, &region);
                    if let Some(Some(before)) = stored.get(j) {
                        assert_eq!(before, &spans);
                    }
                    let own = spans.all;
                    for k in 0..monitor.clusters.len() {
                        let reference = monitor.evidence_fits_walking_own(j, &region, k);
                        assert_eq!(monitor.fits_with_own(&region, k, own[0]), reference, "frame {frame_no}, {j}, {k}");
                        let spill = monitor.spill_fits(j, &region, k);
                        assert_eq!(monitor.spill_fits_with(&region, k, own), spill, "frame {frame_no}, {j}, {k}");
                        if spill {
                            fit += 1;
                        } else {
                            unfit += 1;
                        }
                    }
                }
            }
        }
        assert!(fit > 20 && unfit > 1000 && cached > 0, "fit {fit}, unfit {unfit}, stored by the checks {cached}");
    }
}
