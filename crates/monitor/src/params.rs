//! [`MonitorParams`]: every tunable of the monitor, with the paper's Table I as `Default`.
//!
//! A unit in every name (`_m`, `_s`, `_mps`, `_mps2`, `_rad`, `_radps`); dimensionless fields say so.
//! Parameters are validated once, by [`MonitorParams::validate`] (called by [`crate::Monitor::new`]): the core
//! trusts a validated set and never re-checks it per frame.

use core::fmt;

use crate::frame::{ObjectClass, Uncertainty};

/// Physical motion limits of a road user (eqs. condition_w and condition_a).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(deny_unknown_fields))]
pub struct MotionLimits {
    /// Largest plausible forward acceleration `a_acc`, m/s^2, `> 0`. Table I: 7.
    pub accel_max_mps2: f32,
    /// Strongest plausible braking `a_br`, m/s^2, `< 0`. Table I: -7.
    pub brake_max_mps2: f32,
    /// Largest plausible turn rate `|omega_max|`, rad/s, `> 0`. Table I: 90 degrees per 0.2 s.
    pub turn_rate_max_radps: f32,
}

impl Default for MotionLimits {
    fn default() -> Self {
        Self { accel_max_mps2: 7.0, brake_max_mps2: -7.0, turn_rate_max_radps: core::f32::consts::FRAC_PI_2 / 0.2 }
    }
}

/// Per-class overrides of [`MonitorParams::motion_limits`]; `None` uses the common limits.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
pub struct ClassMotionLimits {
    /// Cars.
    pub car: Option<MotionLimits>,
    /// Trucks, vans, buses.
    pub truck: Option<MotionLimits>,
    /// Pedestrians.
    pub pedestrian: Option<MotionLimits>,
    /// Cyclists.
    pub cyclist: Option<MotionLimits>,
    /// Motorcyclists.
    pub motorcyclist: Option<MotionLimits>,
    /// Other objects.
    pub other: Option<MotionLimits>,
    /// Objects of unknown class.
    pub unknown: Option<MotionLimits>,
}

impl ClassMotionLimits {
    fn get(&self, class: ObjectClass) -> Option<MotionLimits> {
        match class {
            ObjectClass::Car => self.car,
            ObjectClass::Truck => self.truck,
            ObjectClass::Pedestrian => self.pedestrian,
            ObjectClass::Cyclist => self.cyclist,
            ObjectClass::Motorcyclist => self.motorcyclist,
            ObjectClass::Other => self.other,
            ObjectClass::Unknown => self.unknown,
        }
    }

    fn iter(&self) -> impl Iterator<Item = (&'static str, &MotionLimits)> {
        [
            ("per_class_limits.car", &self.car),
            ("per_class_limits.truck", &self.truck),
            ("per_class_limits.pedestrian", &self.pedestrian),
            ("per_class_limits.cyclist", &self.cyclist),
            ("per_class_limits.motorcyclist", &self.motorcyclist),
            ("per_class_limits.other", &self.other),
            ("per_class_limits.unknown", &self.unknown),
        ]
        .into_iter()
        .filter_map(|(n, l)| l.as_ref().map(|l| (n, l)))
    }
}

/// Which rule the plausibility checks apply (docs/plausibility.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum PlausibilityMode {
    /// The paper's rule: two frames, eqs. (condition_w), (condition_a), (condition_xy) with `gamma_plaus` and
    /// the sum of the margins' norms. The default, and the rule of the paper's rows in `pmon reproduce`.
    #[default]
    Paper,
    /// The tracker-aware, calibrated rule: Mahalanobis / chi-square gates at `false_alarm_probability` on the
    /// propagated covariance, the position checked over a baseline of up to `baseline_s` (a ring buffer per
    /// track), heading and turn rate judged only where the heading is defined, box re-fits allowed for, the
    /// speed warm-up of new tracks tolerated up to the safety-critical size, per-class noise for objects
    /// without uncertainty.
    Calibrated,
}

/// How spill-over (attribution step 5, docs/attribution.md) decides whether a cluster left over and a confirmed
/// object's own evidence together fit the object's box ([`MonitorParams::spill_over_fit`], [`crate::Monitor::set_spill_over_fit`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum SpillOverFit {
    /// Over the occupied cells: the box's own occupied cells and the cluster's cells. The default until issue
    /// #10's clean-box round; kept for comparison (`spill_over_fit = "occupied"`).
    Occupied,
    /// Over every return: also the hit cells the box owns that hold too few hits to be occupied, and the hit cells
    /// next to the cluster that no object explains. The default: on the clean nuScenes and KITTI frames it
    /// removes two of the four clean boxes flagged (nuScenes pedestrian 28, KITTI car 6), at a small cost in
    /// simulated and real recall measured in docs/attribution.md ("Spill-over over every return").
    #[default]
    EveryReturn,
}

/// A tracker's noise (one sigma) for objects that report no uncertainty, in the calibrated mode.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(deny_unknown_fields))]
pub struct TrackerNoise {
    /// Position noise of a moving object, each axis, metres.
    pub position_m: f32,
    /// Position noise of a standing object (centre jitter), each axis, metres; blended with `position_m` as
    /// `exp(-v / 1 m/s)` of the reported speed.
    pub standstill_position_m: f32,
    /// Speed noise, m/s.
    pub speed_mps: f32,
    /// Heading noise of a moving object, radians (it grows as `speed_mps / v` towards standstill).
    pub heading_rad: f32,
}

impl TrackerNoise {
    /// The common default: a typical tracker without covariances (docs/plausibility.md).
    pub const DEFAULT: Self = Self { position_m: 0.15, standstill_position_m: 0.3, speed_mps: 0.5, heading_rad: 0.1 };

    fn is_valid(&self) -> bool {
        [self.position_m, self.standstill_position_m, self.speed_mps, self.heading_rad]
            .iter()
            .all(|v| v.is_finite() && *v > 0.0)
    }

    /// Position sigma at reported speed `v_mps`, metres.
    #[must_use]
    pub fn position_at(&self, v_mps: f64) -> f64 {
        // (A standing object, `v <= 0`, or NaN, which `max` takes to 0: `exp(-0) = 1` exactly, without the call.)
        let w = if v_mps > 0.0 { libm::exp(-v_mps) } else { 1.0 };
        f64::from(self.position_m) + (f64::from(self.standstill_position_m) - f64::from(self.position_m)) * w
    }
}

impl Default for TrackerNoise {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Per-class overrides of [`MonitorParams::tracker_noise`]; `None` uses the common values.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
pub struct ClassTrackerNoise {
    /// Cars.
    pub car: Option<TrackerNoise>,
    /// Trucks, vans, buses.
    pub truck: Option<TrackerNoise>,
    /// Pedestrians.
    pub pedestrian: Option<TrackerNoise>,
    /// Cyclists.
    pub cyclist: Option<TrackerNoise>,
    /// Motorcyclists.
    pub motorcyclist: Option<TrackerNoise>,
    /// Other objects.
    pub other: Option<TrackerNoise>,
    /// Objects of unknown class.
    pub unknown: Option<TrackerNoise>,
}

impl ClassTrackerNoise {
    /// The entry of a class.
    #[must_use]
    pub fn get(&self, class: ObjectClass) -> Option<TrackerNoise> {
        match class {
            ObjectClass::Car => self.car,
            ObjectClass::Truck => self.truck,
            ObjectClass::Pedestrian => self.pedestrian,
            ObjectClass::Cyclist => self.cyclist,
            ObjectClass::Motorcyclist => self.motorcyclist,
            ObjectClass::Other => self.other,
            ObjectClass::Unknown => self.unknown,
        }
    }

    /// The entry of a class, to set it.
    pub fn get_mut(&mut self, class: ObjectClass) -> &mut Option<TrackerNoise> {
        match class {
            ObjectClass::Car => &mut self.car,
            ObjectClass::Truck => &mut self.truck,
            ObjectClass::Pedestrian => &mut self.pedestrian,
            ObjectClass::Cyclist => &mut self.cyclist,
            ObjectClass::Motorcyclist => &mut self.motorcyclist,
            ObjectClass::Other => &mut self.other,
            ObjectClass::Unknown => &mut self.unknown,
        }
    }
}

/// All parameters of the monitor. `Default` is the paper's Table I plus documented choices for what the paper
/// leaves open (height band, inverse sensor model, clustering, capacities).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
pub struct MonitorParams {
    // ---- grid (Table I: 100 m x 100 m, c_grid = 0.5 m) ----
    /// Side length of the square, ego-centred occupancy grid, metres. Table I: 100.
    pub grid_size_m: f32,
    /// Cell side `c_grid`, metres. Table I: 0.5.
    pub cell_size_m: f32,

    // ---- height band (which LiDAR points are obstacles) ----
    /// Height of the flat ground plane in the ego frame, metres (the ego frame's origin is on the ground: 0).
    pub ground_z_m: f32,
    /// Points lower than this above the ground are ground returns, metres.
    pub min_obstacle_height_m: f32,
    /// Points higher than this above the ground can be driven under (canopies, signs, bridges), metres.
    pub max_obstacle_height_m: f32,

    /// The ego vehicle's footprint in the ego frame, `[min_x, min_y, max_x, max_y]`, metres: returns inside it
    /// are the vehicle itself (mirrors, roof rack) and are ignored. All zeros: no mask.
    pub ego_footprint_m: [f32; 4],

    // ---- occupancy (inverse sensor model, log-odds) ----
    /// Occupancy probability that one LiDAR hit in a cell stands for (inverse sensor model), dimensionless in
    /// (0.5, 1). Each hit adds `ln(p / (1 - p))` to the cell's log-odds, starting from the prior 0.5. With 0.7
    /// and tau 0.8, two hits make a cell occupied.
    pub hit_probability: f32,

    // ---- sensor checks (Table I) ----
    /// Safety margin `delta_safe` added around every object footprint, metres. Table I: 0.1.
    pub safety_margin_m: f32,
    /// Consistency threshold `tau_tp`, dimensionless. Table I: 0.8.
    pub tau_tp: f32,
    /// Conflict threshold `tau_fn`, dimensionless. Table I: 0.8.
    pub tau_fn: f32,
    /// Sensitivity `gamma_sens` of the covariance margin, dimensionless. Table I: 3.
    pub gamma_sens: f32,
    /// Smallest conflict cluster reported as a missed object or attributed to an object, cells.
    pub min_cluster_cells: u32,
    /// A conflict cluster closer than this to an object's region `A_o` is attributed to that object (its
    /// evidence lies outside its region: a position error), metres.
    pub conflict_association_m: f32,
    /// Fraction of an evidence-free object's footprint that must be visible to the sensor (not shadowed by
    /// nearer obstacles, crossed by rays that returned from beyond it) for the object to be called a ghost;
    /// below it, the object is *not monitored: occluded*. Dimensionless in [0, 1].
    pub ghost_visible_fraction: f32,
    /// Azimuth bins of the visibility map used for the occlusion test.
    pub visibility_bins: u32,
    /// How spill-over (attribution step 5) decides whether a left-over cluster and a confirmed object's own
    /// evidence fit the object's box: `every_return` (the default: also the sparse hit cells; fewer clean real
    /// boxes flagged, some real recall lost: docs/attribution.md) or `occupied` (occupied cells only, the
    /// default before issue #10's clean-box round).
    pub spill_over_fit: SpillOverFit,
    /// Off by default. The free-space test towards the sensor also looks over nearer obstacles: a sample point of
    /// a confirmed box hidden behind something in front of it (a pedestrian behind a parked car) counts as seen
    /// empty when the rays that reached the object's own evidence behind the point crossed it at a body's height
    /// (docs/attribution.md, "Seen over the occluder"). Before the verdicts it gathers the nearest range and the lowest
    /// and highest z of the returns of the cells it will read (the cells the rasterizer records per point): 1.08-1.27x
    /// the sensor checks' time, +11 to +24 % of their instructions (docs/performance.md). Not the default: that cost. (Its first version also raised the sensor false alarms on the full plan of
    /// `pmon reproduce`, 8 -> 14 on seed 23; since its rays must clear the occluder's shadow line, none on the
    /// plans measured.)
    pub seen_over: bool,
    /// Off by default. A box confirmed by its own evidence whose rays end on that evidence in front of its grown
    /// region is a `position_error` (displaced away from the sensor): the visibility map keeps each direction's
    /// nearest return range itself, so this catches displacements the cells of the grown region still cover
    /// (below the paper's `dx_min`; docs/attribution.md, "The face in front"). Not the default: on the quick plan
    /// it adds 0-4 sensor false alarms up to 0.3 m noise (draws beyond the margin that the cells hid) and costs
    /// up to 0.9 points of precision under the paper's conditions, for recall below `dx_min` and on real sweeps.
    pub face_in_front: bool,
    /// Off by default (0). With N > 0, a box confirmed by its own evidence is a `position_error` when at least N of
    /// its own hit cells stand wholly beyond its grown region (their first return and every other return more than
    /// `safety_margin_m` beyond it) and its own first returns still fit its length and width (plus
    /// `2 safety_margin_m`); returns in another object's region or near an object whose evidence is sought are left
    /// out. It catches displacements the cells of the grown region still cover (below `dx_min`; docs/attribution.md,
    /// "Own returns beyond the grown region", "The whole cell, not its first return"). Not the default for its cost:
    /// with N = 1, 13-26 % more instructions per check (a scan of the candidate cells' returns each frame); it
    /// flags 2 of the 80 clean Argoverse 2 boxes in scope and adds sensor false alarms up to 0.3 m noise, boxes
    /// beyond their stated margin (full plans: 9 / 7 / 3 -> 12 / 14 / 5 on seeds 7 / 11 / 23). Needs the grid's
    /// first returns (`jump_first_return`) or sums (`jump_from_returns`); without either it does nothing.
    pub returns_beyond_cells: u32,
    /// On by default (issue #10; off before it). Step 9 of the attribution (a box that jumps away from evidence
    /// that stayed) is also made with each frame's evidence centre taken as the mean of the returns in the
    /// evidence's cells instead of the mean of the cells' centres, with an allowance along each axis that drops the
    /// cell size (half a cell of rounding in each frame) for twice the safety margin:
    /// `2 (margin - delta_safe) + 3 delta_safe`, 0.9 m instead of 1.2 m with the default uncertainty, 0.5 m cells
    /// and `delta_safe` 0.1 m, or beyond the ellipse with those semi-axes (a jump diagonal to the box) when the
    /// returns stand within `3 delta_safe` of where the prediction puts them; the box jumped when either test says
    /// so (docs/attribution.md, "Step 9 from the returns", "The diagonal test"). Keeps per grid cell either the
    /// sums of its returns (16 bytes) or, with `jump_first_return` (the default), its first return, allocated in
    /// `Monitor::new`, and a pass over the hit cells for the objects' own sums. Changes nothing without a previous
    /// frame (single keyframes). Cost with `jump_first_return`: +3-9 % of the checks' instructions, 1.04-1.07x
    /// their time (docs/performance.md); gain: Argoverse 2, one box displaced 1 m after a clean sweep, 19 -> 32 of
    /// 38 caught, and up to 14 points of recall on the simulated transient errors from 1 m, for at most 1.5 points
    /// of their combined precision. `false` gives the paper's step 9 on the cells' centres only.
    pub jump_from_returns: bool,
    /// On by default (issue #10; off before it). Has an effect only with `jump_from_returns`. Step 9's returns'
    /// mean is the mean over the cells of each cell's **first return** of the frame (the first obstacle-band
    /// return in point order that lands in it) instead of the mean of all the cells' returns: the grid keeps one
    /// return per cell, set when the cell is first touched (`OccupancyGrid::with_first_returns`), with no
    /// per-return addition and no x and y from pass 1 (docs/attribution.md, "Step 9 from each cell's first
    /// return"). `false` sums every return (+9-18 % of the checks' instructions instead of +3-9 %).
    pub jump_first_return: bool,
    /// On by default (issue #10; off before it). Has an effect only with `jump_from_returns`. Step 9's diagonal
    /// test takes returns that stand where the prediction puts them (within `3 delta_safe`) as the evidence that
    /// stayed, and the box's jump beyond the allowance's ellipse *from the prediction* as the displacement. `false`
    /// also requires the box beyond the ellipse from where those returns put it: the returns' scatter (the `2
    /// delta_safe` the allowance already holds for it) then counts twice, and a 1 m jump whose returns came 0.25 m
    /// its way in the new sweep is left to the one-frame rules (docs/attribution.md, "Step 9: the evidence at the
    /// prediction, boxes in one place"). Costs nothing (one test fewer).
    pub jump_evidence_at_prediction: bool,
    /// On by default (issue #10; off before it). Step 9 counts the occupied cells inside the grown region placed
    /// at the track's predicted centre, leaving out cells that stand in another object's box: a neighbour that
    /// moved onto the place is no evidence that the track's evidence stayed. A box reported where the track's
    /// predicted box stands (centre and half extents within half a cell, axes within 10 degrees) is the same
    /// place, not a neighbour: with this key its cells count (two labels on one car, one of them jumping away:
    /// the evidence stayed with the other label). So do the cells of a box reported where the jumping box itself
    /// stands (two labels on one car that jumped together: the other label claims the place this box claims).
    /// Step 3b's rule for boxes reported in one place, applied to step 9. Costs two comparisons per such cell,
    /// only for a box that jumped.
    pub jump_coincident_boxes: bool,
    /// On by default (issue #10; off before it). Step 9 leaves out cells inside another object's box (a neighbour
    /// that moved onto the place is no evidence that the track's evidence stayed), except, with this key, the box
    /// of a track that itself jumped: its centre beyond step 9's ellipse from its own prediction. Such a box stands
    /// where its own evidence is not, as far as step 9 can tell, so it is no claim on the returns it now covers
    /// (every box of a frame displaced at once: each neighbour's box moved over the others' evidence). A neighbour
    /// that moved as it said (its box at its prediction) still claims its cells. Costs a test per such cell, only
    /// for a box that jumped (docs/attribution.md, "Neighbours whose boxes jumped too").
    pub jump_jumped_boxes: bool,
    /// On by default since issue #10's round "Rays on the body with step 8 gated" (with `follow_gate`; off before it,
    /// docs/attribution.md). The free-space test towards the sensor (a confirmed box whose rays pass through most of
    /// its footprint and end on its own evidence behind it) counts a ray only when it ends on the object's
    /// *body*: within the box's depth along the ray (plus `safety_margin_m`) of the nearest return of the
    /// object's own evidence within the directions its grown region spans. Returns a neighbour's edge or a post
    /// left in the grown region behind the body (0.6-1.1 m behind a pedestrian) no longer prove that a box
    /// moved sideways within its stated uncertainty stands in empty space (docs/attribution.md, "Rays that end
    /// on the body"). Alone it set off an evidence-memory cascade (seed 11, towards the ego at 1.8 m: precision down
    /// by 5.7 points) that `follow_gate` stops. Costs a look at the visibility map's bins across the region, only
    /// for a box the test would flag.
    pub seen_body: bool,
    /// Off by default. Evidence farther than `conflict_association_m` from a box is never its evidence, in the
    /// two places where the sensor checks lacked that bound: (1) step 8 of docs/attribution.md (a hidden track
    /// remembered as displaced stays flagged while occupied cells lie in a neighbour's margin where its
    /// remembered offset puts its evidence) counts only cells within the gate of its grown region, as step 4 does
    /// for clusters; (2) an unconfirmed box hidden behind evidence nobody explains takes that cluster only when it
    /// stands within the gate; beyond it the cluster is an occluder and the box is `not_monitored(occluded)`
    /// instead of taking it or being called a ghost. Without it a hidden clean pedestrian 32 m out took a cluster
    /// 26 m in front of it once and was held displaced for 80 frames (docs/attribution.md, "Evidence beyond the
    /// gate"). Costs a distance per cell looked at by step 8 and one cluster distance per such box. Its first half
    /// alone is `follow_gate`, on by default since issue #10's round "Rays on the body with step 8 gated"; the second
    /// half breaks the object-level guarantee for displacements beyond the gate, so this key stays off by default.
    pub memory_gate: bool,
    /// On by default since issue #10's round "Rays on the body with step 8 gated" (with `seen_body`). The first half
    /// of `memory_gate` alone: step 8 of docs/attribution.md counts only occupied cells within
    /// `conflict_association_m` of the track's grown region (as step 4 does for clusters); an unconfirmed box hidden
    /// behind free evidence beyond the gate still takes it (the half of `memory_gate` that breaks the object-level
    /// guarantee is left out). `memory_gate` implies it (docs/attribution.md, "Evidence beyond the gate" and "Rays
    /// on the body with step 8 gated"). Costs a distance per cell looked at by step 8.
    pub follow_gate: bool,
    /// On by default since issue #10's round "Two rules together" (off before it; docs/attribution.md). A single-frame
    /// rule for a box displaced away from its returns and confirmed by scenery (docs/attribution.md, "One box displaced
    /// 2 m in a single sweep"): a free conflict cluster left after spill-over (in the region of interest or not) goes
    /// to a *confirmed* box without a cluster when (1) it stands on the box's line of sight, in front of it, within
    /// `conflict_association_m` of its grown region, (2) it fits the box (as step 3's fit test) and holds at least as
    /// many cells as the occupied cells the box owns, and (3) the evidence that confirms the box runs on beyond it: a
    /// hit cell it owns in its grown region is 8-adjacent to a hit cell outside the region that no object explains or
    /// that is known scenery (the cluster's own cells left out), so the region's edge cuts through something that
    /// continues past where the box could stand. The box is then a `position_error` with that cluster. Alone it cost
    /// 0.9 points of precision under the paper's conditions (quick plan of seed 7, 0.5 m cells, 1.6 m), against the
    /// rule fixed before it was measured (at most 0.5), and stayed off until the round of two rules; Argoverse 2, one
    /// box displaced in a single sweep: 21 / 32 -> 25 / 40 of 77 at 1 / 2 m. Costs one sight test per confirmed box
    /// near a free cluster, and one walk over the region's cells (and their 3 x 3 blocks) for a box the first two tests
    /// pass.
    pub front_cluster: bool,
    /// On by default since issue #10's round "Spill-over in front of the box" (off, the rule before it, when false;
    /// docs/attribution.md). Spill-over (step 5) gives a free cluster to a confirmed box whose own evidence it
    /// continues (8-adjacent cells); with this key it also gives it one it does not touch, within
    /// `conflict_association_m` of its grown region, when the cluster stands in front of the box on the sensor's line
    /// of sight (its centroid's bearing within the bearings of the box's corners, nearer than its centre), holds at
    /// least as many cells as the occupied cells the box owns, and touches no evidence another object owns; the fit
    /// tests of spill-over still apply (the cluster and the box's own evidence within the box). That is the near face a
    /// box displaced away from the sensor leaves behind when the returns along its side are too sparse to join it to
    /// what its displaced region still holds (a car 46 m out seen along its length: one return every metre). Full plans
    /// of seeds 7, 11 and 23: hard-conditions recall up by up to 4.5 points, paper conditions up to 1.5, precision down
    /// by at most 0.4 points but at one (towards the ego, 2 m, seed 7: -0.6), sensor false alarms up to 0.3 m noise
    /// unchanged, no clean real box flagged. Costs a cluster distance per confirmed box within the gate of a free
    /// cluster, and for those in front of it four bearings and a walk over the cluster's 3 x 3 blocks.
    pub spill_in_front: bool,
    /// On by default since issue #10's round "The near side of the box" (off, the rule before it, when false;
    /// docs/attribution.md). With `spill_in_front`: the cell count and the fit test of spill-over in front of a
    /// confirmed box leave out the occupied cells the box owns beyond its **near side** (whose centres are farther from
    /// the sensor than the box's centre plus half a cell diagonal); sparse returns (hit cells not occupied) still count
    /// wherever they are. A box displaced away from the sensor leaves its near face in front of it and holds, at its
    /// far side, whatever stands behind it: counted miss by miss (full plan of seed 11, hard conditions, 0.2 m cells,
    /// 1.8 m), most of the free clusters at a missed box's true place that spill-over refused failed the fit because
    /// the displaced box owned a displaced neighbour's face at its far end. Full plans of seeds 7, 11 and 23:
    /// hard-conditions recall up by up to 2.8 points (sums over a row's 15 points +3.1 to +11.2), paper conditions up to
    /// 0.1, precision down by at most 0.8 points (towards the ego, seed 11, 1.9 m), sensor false alarms up to 0.3 m
    /// noise unchanged, real data byte-identical. Costs one squared range per hit cell in the walk over a confirmed
    /// box's region that spill-over already makes.
    pub spill_near_side: bool,
    /// Off by default (issue #10's round "The box a cluster stretches least", docs/attribution.md under that name).
    /// Spill-over gives a cluster that continues the own evidence of several confirmed boxes, and fits each, to the
    /// nearest of them; with this key, when that one is vehicle-sized (at least 3 m long), to the one the cluster
    /// stretches least instead (how far the cluster and the box's own occupied cells together reach beyond its
    /// length or width). A displaced neighbour's corner by a clean parked car's near end fits the car within the
    /// fit's slack (a cell diagonal and twice the safety margin) and was its alarm. Full plans of seeds 7, 11 and 23:
    /// hard-conditions recall -0.3 to +0.7 points, precision -0.1 to +1.1, paper conditions and the sensor false
    /// alarms up to 0.3 m noise unchanged, `pmon check` on real sweeps byte-identical; but the real-sensor
    /// experiment (Argoverse 2, every box displaced in one sweep) finds 2 of 80 boxes fewer at 1.8 and 1.9 m, so it
    /// is not the default.
    pub spill_least_stretch: bool,
    /// Metres; 0.4 by default since issue #10's round "Spill-over across a gap" (docs/attribution.md, under that
    /// name; 0 gives the verdicts before it). Spill-over gives a confirmed box a cluster that, with its own evidence,
    /// fits its box when a cell of the cluster is 8-adjacent to an occupied cell the box owns. With this key the
    /// cluster may also stand across a gap of empty cells up to this wide (rounded down to whole cells, so a gap
    /// narrower than a cell changes nothing), beside a box at least 2 m long: a vehicle's side seen at a grazing
    /// angle is sampled sparsely, and at 0.2 m cells the returns of a displaced car's end often form one-cell
    /// clusters two cells from the rest of its side. 0.4 m bridges two 0.2 m cells and none of 0.5 m, which already
    /// span such gaps: the verdicts at 0.5 m cells are those without the key. Pedestrian-sized boxes never bridge a
    /// gap (their returns are one compact blob; a cell across a gap from them is someone else's). Must be in [0, 1]
    /// m. Costs a walk over the `(2 g + 3)^2` block of each cell of a cluster spill-over looks at beside such a box
    /// (`g` the gap in cells) instead of its 3 x 3.
    pub spill_gap_m: f32,
    /// Seconds; 1 by default since issue #10's round "Two rules together" (0, off, before it; docs/attribution.md).
    /// Step 8 over a gap (docs/attribution.md, "Step 8 held over a gap"): a track that alarms found displaced in at
    /// least two consecutive frames keeps the offset from its box to that evidence for this long after its last alarm,
    /// through frames in which it is not flagged, beside whatever evidence the memory records for it then; whenever its
    /// box is hidden and the offset puts the evidence in front of it on its line of sight, step 8 looks for its
    /// evidence there (occupied cells outside its region that a neighbour explains only through its margin keep it a
    /// `position_error`). Without it the offset lives one frame: a displaced box called occluded or consistent once (it
    /// stepped onto another body's evidence) loses it for good. Only step 8 uses a held offset (not step 4's priority,
    /// not the claim penalty). Alone, on the quick plans of seeds 7, 11 and 23, it raises the hard-conditions recall by
    /// up to 4 points (0.5 m cells) with the sensor false alarms up to 0.3 m noise unchanged, but lowers precision by
    /// up to 0.9 points at some points and the transient errors' combined precision by up to 0.9 (the rule fixed before
    /// measuring allowed 0.5). Must be in [0, 10] s. Costs nothing per frame beyond step 8's walk for such a hidden
    /// track.
    pub memory_hold_s: f64,
    /// Seconds; 0 (off) by default. A hold for parked vehicles (docs/attribution.md, "Parked cars in a row"): a box
    /// reported at least [`PARKED_MIN_LENGTH_M`] long and slower than [`PARKED_MAX_SPEED_MPS`] that alarms found
    /// displaced in at least two consecutive frames stays a `position_error` (the cause `held_while_parked`, the
    /// offset the last of those alarms found) for this long after that alarm, while it is still reported so, stands
    /// within half that offset of where the alarm found it (world frame: an error that ended moves the box back to
    /// its evidence) and the held offset still puts its evidence in front of it on its line of sight, within
    /// `conflict_association_m` of it. A parked car in a row, displaced along the row, is what a correct box would
    /// give whenever the car in front hides its near end; the ego's moving view opens and closes on it. Held verdicts are not evidence: they
    /// start no run and the memory records nothing of them. Must be in [0, 10] s. Costs a look-up in the evidence
    /// memory for each such box that no test flagged.
    pub parked_hold_s: f64,
    /// Off by default. Bounds "behind evidence nobody explains" by the gate (docs/attribution.md, "The shadow of far
    /// evidence"): a footprint cell shadowed by unexplained evidence counts as contradicted (`unexplained_shadow`:
    /// the object's own displaced evidence may stand in front of it) only when the conflict cell that shadows it has
    /// its centre within `conflict_association_m` + the region's larger margin + one cell diagonal of the
    /// footprint point looked at; farther evidence cannot be this object's, so the cell is merely hidden. Without
    /// it a clean box 15-35 m behind another faulty track's unexplained evidence on its bearing counts as
    /// contradicted, is offered every cluster within the full gate and may take a neighbour's. A box without
    /// evidence of its own that the cells set aside would have contradicted (it is hidden only by evidence beyond
    /// the gate) takes the nearest free cluster in the region of interest that stands beyond it on its line of
    /// sight, within `conflict_association_m` of its grown region (a box displaced towards the sensor into the
    /// shadow, its own returns seen over the occluder), and is occluded when there is none. Costs one distance per
    /// shadowed footprint cell, and one pass over the clusters for such a hidden box.
    pub shadow_gate: bool,
    /// Off by default (issue #10; docs/attribution.md, "Step 8 judged by the evidence it follows", variant "fits the
    /// owner"). Step 8 (a track flagged displaced last frame finds its evidence where its remembered offset puts it,
    /// in a neighbour's margin) does not follow cells that all lie in one neighbour's margin when their first
    /// returns, together with the first returns of the hit cells that neighbour owns, fit the neighbour's box
    /// (along and across no longer than its length and width plus `2 safety_margin_m`): they can be that
    /// neighbour's own body, spilling out of its box within its stated uncertainty, and then they prove nothing
    /// about the track. Needs the grid's first returns (`jump_from_returns` with `jump_first_return`, the
    /// defaults); without them the key does nothing. Measured (full plan of seed 7): step 8's false alarms on the
    /// report's occlusion figure 3,021 -> 254 and its precision 98.0 -> 99.2 % at 1 m, for 0.1-0.7 points of its
    /// recall; but up to 2.4 points of verifiable recall lost on the transient errors at 50-80 % error rates (4.5
    /// on the quick plan), where a
    /// displaced pedestrian's own returns often stand within a neighbour's extent, so off by default. Costs one
    /// walk over the neighbour's grown region, only when step 8 finds cells.
    pub follow_owner_fit: bool,
    /// On by default since issue #10's round "Claims a flagged neighbour releases" (docs/attribution.md, under that
    /// name; `false` gives the verdicts before it). A neighbour that
    /// holds a conflict cluster of its own (its evidence lies there) releases the occupied cells it owns only by its
    /// reported region when that cluster does not continue them: a hidden box without evidence of its own takes
    /// such cells when they stand in front of it on its line of sight, within `conflict_association_m` of its grown
    /// region and outside it, in no other object's region, fitting its box: a `position_error` with the cause
    /// `evidence_released`. Measured (full plans of seeds 7, 11, 23): docs/attribution.md. Costs one walk over the
    /// cells within the gate of a hidden box, only for hidden boxes without evidence.
    pub release_flagged_claims: bool,
    /// Off by default (issue #10; docs/attribution.md, "Released claims for a confirmed box"). With
    /// `release_flagged_claims`: a box confirmed by evidence of its own takes the released cells in front of it too,
    /// when they are at least as many as the occupied cells it owns on its near side and fit its box with them.
    pub release_to_confirmed: bool,
    /// On by default since issue #10's round "Evidence in the margin that runs on" (docs/attribution.md, under that
    /// name; `false` gives the verdicts before it). A box confirmed by evidence of its own, none of which overlaps
    /// its footprint (only cells in its margin), one of them 8-adjacent to an occupied cell beyond its grown region
    /// in a conflict cluster another box took as its displaced evidence, is displaced: a `position_error` with the
    /// cause `evidence_runs_on`. The evidence memory keeps that evidence as the track's own (no displaced offset is
    /// held for step 8). Costs a walk over the footprint's cells for each box confirmed by its own evidence that no
    /// other test flagged, and over its grown region for one that owns none of them.
    pub evidence_runs_on: bool,
    /// On by default since issue #10's round "The near side seen through" (docs/attribution.md, under that name;
    /// `false` gives the verdicts before it). The free-space test towards the sensor (`seen_through`) also flags a box
    /// confirmed by its own evidence when the whole side of it that faces the sensor is seen empty: the three sample
    /// points of that side each lie in front of the object's own evidence by more than the box may move along the
    /// line of sight within its margins (`margin_length |cos a| + margin_width |sin a|`, `a` the angle between the
    /// box and the ray). A car displaced along the line of sight towards the sensor by less than its length keeps its
    /// face inside the box, so most of its sample points lie behind that face and the majority of
    /// `ghost_visible_fraction` is never reached; a box that stands where its object is has no such side. The
    /// cause is `seen_through`. Costs a few operations per box the free-space test looks at.
    pub seen_through_near_side: bool,
    /// 0.5 by default (0 turns the rule off). Kerb-side scenery that only grazes the region of interest
    /// (docs/datasets.md, "The grazing rule"): a conflict cluster with obstacle-band returns inside the ROI, but fewer than this fraction of
    /// all its band returns, and a return over its cells higher than `roi_graze_height_m` over the ground, is
    /// outside the ROI (reported as unexplained evidence outside it, not as a missed object). Dimensionless in
    /// [0, 1]; 0 keeps the rule before it (one band return inside suffices). Measured with 0.5 (a tall structure
    /// whose band returns lie mostly outside the area): Argoverse 2 log 7fab2350 goes from 6 and 3 missed-object
    /// alarms per sweep to 2 and 1, no clean box flagged, but the one-box recall at 2 m from 33 to 32 of 77 (a car
    /// parked on the verge under a tree, its left-over returns mostly outside the area). The default since issue
    /// #10's measurement (docs/datasets.md, "Made the default"): that loss is its stated cost. Without an ROI it
    /// changes nothing.
    pub roi_graze_fraction: f32,
    /// The height over the ground (`ground_z_m`) above which a return over a cluster's cells says the cluster is no
    /// road user, for `roi_graze_fraction`, metres. Default 4.5 m: above the tallest road vehicles (4-4.3 m) with a
    /// margin. At least `max_obstacle_height_m` when the rule is on.
    pub roi_graze_height_m: f32,

    // ---- plausibility checks (Table I) ----
    /// Common motion limits `a_acc`, `a_br`, `omega_max`. Table I: +7, -7 m/s^2, 90 degrees per 0.2 s.
    pub motion_limits: MotionLimits,
    /// Optional per-class overrides of `motion_limits`.
    pub per_class_limits: ClassMotionLimits,
    /// Sensitivity `gamma_plaus` of the position condition, dimensionless. Table I: 1.
    pub gamma_plaus: f32,
    /// Uncertainties used for objects that carry none. The heading value is Table I's `Delta theta` = 10
    /// degrees; position 0.1 m and speed 1 m/s are the values of the paper's Fig. dv_theo.
    pub default_uncertainty: Uncertainty,
    /// Longest time step the small-dt motion model is trusted for, seconds; a longer gap restarts the track.
    pub max_time_step_s: f64,

    // ---- calibrated plausibility (beyond the paper; docs/plausibility.md) ----
    /// Which rule the plausibility checks apply. Default: the paper's.
    pub plausibility_mode: PlausibilityMode,
    /// Calibrated mode: the false-alarm probability of each gate per object state (chi-square with 2 degrees
    /// of freedom for the position, two-sided normal for speed change and heading), in (0, 0.5).
    pub false_alarm_probability: f64,
    /// Calibrated mode: the longest position baseline, seconds (at most [`crate::plausibility::HISTORY`] - 1
    /// frames back): a permanent speed error shows as a displacement growing with the baseline.
    pub baseline_s: f64,
    /// Calibrated mode: frames at a track's start in which a reported speed of exactly 0 counts as not yet
    /// initialised (judged against the motion with `warmup_speed_sigma_mps`, no acceleration check).
    pub warmup_frames: u32,
    /// Calibrated mode: the speed sigma of a not yet initialised speed, m/s.
    pub warmup_speed_sigma_mps: f32,
    /// Calibrated mode: the heading (flips, turn rate) is judged only when both reported speeds reach this, m/s.
    pub heading_min_speed_mps: f32,
    /// Calibrated mode: noise of objects without uncertainty.
    pub tracker_noise: TrackerNoise,
    /// Calibrated mode: per-class overrides of `tracker_noise`.
    pub per_class_noise: ClassTrackerNoise,

    // ---- capacities (fixed at construction: no allocation per frame) ----
    /// Most LiDAR points accepted per frame; a larger cloud leaves the sensor checks *not monitored*.
    pub max_points: u32,
    /// Most objects accepted per frame; a larger list is rejected as a whole with an error.
    pub max_objects: u32,
    /// Most conflict clusters reported per frame; further clusters are counted but not described.
    pub max_clusters: u32,
    /// Longest object side accepted, metres; a longer box is *not monitored: invalid state*.
    pub max_object_size_m: f32,
}

impl Default for MonitorParams {
    fn default() -> Self {
        Self::PAPER
    }
}

impl MonitorParams {
    /// The paper's Table I.
    pub const PAPER: Self = Self {
        grid_size_m: 100.0,
        cell_size_m: 0.5,
        ground_z_m: 0.0,
        min_obstacle_height_m: 0.3,
        max_obstacle_height_m: 2.5,
        ego_footprint_m: [0.0; 4],
        hit_probability: 0.7,
        safety_margin_m: 0.1,
        tau_tp: 0.8,
        tau_fn: 0.8,
        gamma_sens: 3.0,
        min_cluster_cells: 1,
        conflict_association_m: 2.0,
        ghost_visible_fraction: 0.5,
        visibility_bins: 720,
        spill_over_fit: SpillOverFit::EveryReturn,
        seen_over: false,
        face_in_front: false,
        returns_beyond_cells: 0,
        jump_from_returns: true,
        jump_first_return: true,
        jump_evidence_at_prediction: true,
        jump_coincident_boxes: true,
        jump_jumped_boxes: true,
        seen_body: true,
        memory_gate: false,
        follow_gate: true,
        front_cluster: true,
        spill_in_front: true,
        spill_near_side: true,
        spill_least_stretch: false,
        spill_gap_m: 0.4,
        memory_hold_s: 1.0,
        parked_hold_s: 0.0,
        shadow_gate: false,
        follow_owner_fit: false,
        release_flagged_claims: true,
        release_to_confirmed: false,
        evidence_runs_on: true,
        seen_through_near_side: true,
        roi_graze_fraction: 0.5,
        roi_graze_height_m: 4.5,
        motion_limits: MotionLimits {
            accel_max_mps2: 7.0,
            brake_max_mps2: -7.0,
            turn_rate_max_radps: core::f32::consts::FRAC_PI_2 / 0.2,
        },
        per_class_limits: ClassMotionLimits {
            car: None,
            truck: None,
            pedestrian: None,
            cyclist: None,
            motorcyclist: None,
            other: None,
            unknown: None,
        },
        gamma_plaus: 1.0,
        default_uncertainty: Uncertainty {
            x_m: 0.1,
            y_m: 0.1,
            heading_rad: 10.0 * core::f32::consts::PI / 180.0,
            speed_mps: 1.0,
            length_m: 0.0,
            width_m: 0.0,
        },
        max_time_step_s: 0.5,
        plausibility_mode: PlausibilityMode::Paper,
        false_alarm_probability: 1.0e-4,
        baseline_s: 0.5,
        warmup_frames: 2,
        warmup_speed_sigma_mps: 0.7,
        heading_min_speed_mps: 1.0,
        tracker_noise: TrackerNoise::DEFAULT,
        per_class_noise: ClassTrackerNoise {
            car: None,
            truck: None,
            pedestrian: None,
            cyclist: None,
            motorcyclist: None,
            other: None,
            unknown: None,
        },
        max_points: 400_000,
        max_objects: 1024,
        max_clusters: 512,
        max_object_size_m: 30.0,
    };

    /// Motion limits for a class: the per-class override if set, else the common limits.
    #[must_use]
    pub fn limits_for(&self, class: ObjectClass) -> MotionLimits {
        self.per_class_limits.get(class).unwrap_or(self.motion_limits)
    }

    /// Tracker noise for a class: the per-class override if set, else the common values.
    #[must_use]
    pub fn noise_for(&self, class: ObjectClass) -> TrackerNoise {
        self.per_class_noise.get(class).unwrap_or(self.tracker_noise)
    }

    /// The obstacle height band in the ego frame, `(lowest, highest)` z, metres: points between them (inclusive)
    /// are obstacle evidence; lower ones are ground, higher ones can be driven under.
    #[must_use]
    pub fn obstacle_band_m(&self) -> (f32, f32) {
        (self.ground_z_m + self.min_obstacle_height_m, self.ground_z_m + self.max_obstacle_height_m)
    }

    /// Number of cells along one side of the grid.
    #[must_use]
    pub fn grid_cells_per_side(&self) -> u32 {
        // Validated: grid_size_m / cell_size_m is in [1, MAX_CELLS_PER_SIDE].
        let n = libm::ceilf(self.grid_size_m / self.cell_size_m);
        if n.is_finite() && n >= 1.0 && n <= MAX_CELLS_PER_SIDE as f32 {
            n as u32
        } else {
            1
        }
    }

    /// Checks every field against its range. Called once by [`crate::Monitor::new`].
    ///
    /// # Errors
    /// The first field out of range, with the reason.
    pub fn validate(&self) -> Result<(), ParamError> {
        fn pos(field: &'static str, v: f32) -> Result<(), ParamError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ParamError { field, reason: "must be finite and > 0" })
            }
        }
        fn non_neg(field: &'static str, v: f32) -> Result<(), ParamError> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(ParamError { field, reason: "must be finite and >= 0" })
            }
        }
        fn unit(field: &'static str, v: f32) -> Result<(), ParamError> {
            if (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(ParamError { field, reason: "must be in [0, 1]" })
            }
        }
        /// Physical upper bounds: a larger value would switch a check off without a word (issue 15: found by
        /// fuzzing, e.g. `safety_margin_m = 1e30` made every object consistent).
        fn at_most(field: &'static str, v: f32, max: f32, reason: &'static str) -> Result<(), ParamError> {
            if v <= max {
                Ok(())
            } else {
                Err(ParamError { field, reason })
            }
        }
        fn threshold(field: &'static str, v: f32) -> Result<(), ParamError> {
            // 0.5 is an unobserved cell's probability and no cell's probability exceeds 1: a threshold outside
            // (0.5, 1) makes every cell pass or none.
            if v > 0.5 && v < 1.0 {
                Ok(())
            } else {
                Err(ParamError {
                    field,
                    reason:
                        "must be in (0.5, 1): 0.5 is an unobserved cell, and no cell exceeds 1 (the check would be off)",
                })
            }
        }
        fn limits(prefix: &'static str, l: &MotionLimits) -> Result<(), ParamError> {
            pos(prefix, l.accel_max_mps2)?;
            pos(prefix, l.turn_rate_max_radps)?;
            if !(l.brake_max_mps2.is_finite() && l.brake_max_mps2 < 0.0) {
                return Err(ParamError { field: prefix, reason: "brake_max_mps2 must be finite and < 0" });
            }
            let why = "accel_max_mps2 and -brake_max_mps2 must be <= 100 m/s^2, turn_rate_max_radps <= 100 rad/s";
            at_most(prefix, l.accel_max_mps2, 100.0, why)?;
            at_most(prefix, -l.brake_max_mps2, 100.0, why)?;
            at_most(prefix, l.turn_rate_max_radps, 100.0, why)?;
            Ok(())
        }
        pos("grid_size_m", self.grid_size_m)?;
        pos("cell_size_m", self.cell_size_m)?;
        let cells = self.grid_size_m / self.cell_size_m;
        if !(cells.is_finite() && cells <= MAX_CELLS_PER_SIDE as f32) {
            return Err(ParamError { field: "cell_size_m", reason: "grid_size_m / cell_size_m must be <= 4096" });
        }
        if !self.ground_z_m.is_finite() {
            return Err(ParamError { field: "ground_z_m", reason: "must be finite" });
        }
        non_neg("min_obstacle_height_m", self.min_obstacle_height_m)?;
        pos("max_obstacle_height_m", self.max_obstacle_height_m)?;
        if self.max_obstacle_height_m <= self.min_obstacle_height_m {
            return Err(ParamError {
                field: "max_obstacle_height_m",
                reason: "must be greater than min_obstacle_height_m",
            });
        }
        let e = self.ego_footprint_m;
        let none = e.iter().all(|v| *v == 0.0);
        if !(e.iter().all(|v| v.is_finite()) && (none || (e[0] < e[2] && e[1] < e[3]))) {
            return Err(ParamError {
                field: "ego_footprint_m",
                reason: "must be finite [min_x, min_y, max_x, max_y] with min < max, or all zeros",
            });
        }
        if !(self.hit_probability > 0.5 && self.hit_probability < 1.0) {
            return Err(ParamError { field: "hit_probability", reason: "must be in (0.5, 1)" });
        }
        non_neg("safety_margin_m", self.safety_margin_m)?;
        at_most("safety_margin_m", self.safety_margin_m, 5.0, "must be <= 5 m")?;
        threshold("tau_tp", self.tau_tp)?;
        threshold("tau_fn", self.tau_fn)?;
        non_neg("gamma_sens", self.gamma_sens)?;
        at_most("gamma_sens", self.gamma_sens, 10.0, "must be <= 10")?;
        if !(1..=10_000).contains(&self.min_cluster_cells) {
            return Err(ParamError { field: "min_cluster_cells", reason: "must be in [1, 10000]" });
        }
        non_neg("conflict_association_m", self.conflict_association_m)?;
        at_most("conflict_association_m", self.conflict_association_m, 20.0, "must be <= 20 m")?;
        unit("ghost_visible_fraction", self.ghost_visible_fraction)?;
        unit("roi_graze_fraction", self.roi_graze_fraction)?;
        pos("roi_graze_height_m", self.roi_graze_height_m)?;
        at_most("roi_graze_height_m", self.roi_graze_height_m, 100.0, "must be <= 100 m")?;
        if self.roi_graze_fraction > 0.0 && self.roi_graze_height_m < self.max_obstacle_height_m {
            return Err(ParamError {
                field: "roi_graze_height_m",
                reason:
                    "must be >= max_obstacle_height_m while roi_graze_fraction > 0 (the grazing rule, on by default; \
                         a band return would count as tall): raise roi_graze_height_m with max_obstacle_height_m, or \
                         set roi_graze_fraction = 0 to turn the rule off",
            });
        }
        if !(8..=65_536).contains(&self.visibility_bins) {
            return Err(ParamError { field: "visibility_bins", reason: "must be in [8, 65536]" });
        }
        limits("motion_limits", &self.motion_limits)?;
        for (name, l) in self.per_class_limits.iter() {
            limits(name, l)?;
        }
        non_neg("gamma_plaus", self.gamma_plaus)?;
        at_most("gamma_plaus", self.gamma_plaus, 10.0, "must be <= 10")?;
        if !self.default_uncertainty.is_valid() {
            return Err(ParamError { field: "default_uncertainty", reason: "every value must be finite and >= 0" });
        }
        let u = self.default_uncertainty;
        let why = "x_m, y_m, length_m, width_m must be <= 10 m, speed_mps <= 50 m/s, heading_rad <= pi";
        for v in [u.x_m, u.y_m, u.length_m, u.width_m] {
            at_most("default_uncertainty", v, 10.0, why)?;
        }
        at_most("default_uncertainty", u.speed_mps, 50.0, why)?;
        at_most("default_uncertainty", u.heading_rad, core::f32::consts::PI, why)?;
        if !(self.max_time_step_s >= 1e-3 && self.max_time_step_s <= 60.0) {
            return Err(ParamError { field: "max_time_step_s", reason: "must be in [0.001, 60] s" });
        }
        if !(self.false_alarm_probability > 0.0 && self.false_alarm_probability < 0.5) {
            return Err(ParamError { field: "false_alarm_probability", reason: "must be in (0, 0.5)" });
        }
        if !(self.baseline_s.is_finite() && self.baseline_s >= 0.0) {
            return Err(ParamError { field: "baseline_s", reason: "must be finite and >= 0" });
        }
        if !(self.spill_gap_m >= 0.0 && self.spill_gap_m <= 1.0) {
            return Err(ParamError { field: "spill_gap_m", reason: "must be in [0, 1] m" });
        }
        if !(self.memory_hold_s >= 0.0 && self.memory_hold_s <= 10.0) {
            return Err(ParamError { field: "memory_hold_s", reason: "must be in [0, 10] s" });
        }
        if !(self.parked_hold_s >= 0.0 && self.parked_hold_s <= 10.0) {
            return Err(ParamError { field: "parked_hold_s", reason: "must be in [0, 10] s" });
        }
        if self.warmup_frames > 100 {
            return Err(ParamError { field: "warmup_frames", reason: "must be <= 100" });
        }
        pos("warmup_speed_sigma_mps", self.warmup_speed_sigma_mps)?;
        non_neg("heading_min_speed_mps", self.heading_min_speed_mps)?;
        if !self.tracker_noise.is_valid() {
            return Err(ParamError { field: "tracker_noise", reason: "every value must be finite and > 0" });
        }
        for c in ObjectClass::ALL {
            if self.per_class_noise.get(c).is_some_and(|n| !n.is_valid()) {
                return Err(ParamError { field: "per_class_noise", reason: "every value must be finite and > 0" });
            }
        }
        if !(1..=MAX_POINTS).contains(&self.max_points) {
            return Err(ParamError { field: "max_points", reason: "must be in [1, 4194304]" });
        }
        if !(1..=MAX_OBJECTS).contains(&self.max_objects) {
            return Err(ParamError { field: "max_objects", reason: "must be in [1, 65536]" });
        }
        if !(1..=65_536).contains(&self.max_clusters) {
            return Err(ParamError { field: "max_clusters", reason: "must be in [1, 65536]" });
        }
        pos("max_object_size_m", self.max_object_size_m)?;
        if self.max_object_size_m > 200.0 {
            return Err(ParamError { field: "max_object_size_m", reason: "must be <= 200" });
        }
        Ok(())
    }
}

/// Largest grid side in cells (4096 x 4096 = 16.7 M cells, 33 MiB).
pub const MAX_CELLS_PER_SIDE: u32 = 4096;
/// Largest accepted `max_points`.
pub const MAX_POINTS: u32 = 4_194_304;
/// Largest accepted `max_objects`.
pub const MAX_OBJECTS: u32 = 65_536;
/// The shortest box `parked_hold_s` holds, metres: a vehicle (the simulator's and the datasets' cars are 3.8-5 m,
/// a pedestrian or a cyclist below 2 m).
pub const PARKED_MIN_LENGTH_M: f32 = 3.0;
/// The fastest box `parked_hold_s` holds, m/s: standing still, up to a tracker's speed noise.
pub const PARKED_MAX_SPEED_MPS: f32 = 0.5;

/// A parameter out of its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamError {
    /// The field's name as in the TOML file.
    pub field: &'static str,
    /// What is wrong.
    pub reason: &'static str,
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "parameter `{}` {}", self.field, self.reason)
    }
}

impl core::error::Error for ParamError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn position_at_skips_exp_only_where_it_is_1() {
        // The blend as written before the standing object's shortcut, bit for bit.
        let n = TrackerNoise::DEFAULT;
        let blend = |v: f64| {
            let w = libm::exp(-v.max(0.0));
            f64::from(n.position_m) + (f64::from(n.standstill_position_m) - f64::from(n.position_m)) * w
        };
        for v in [0.0, -0.0, -1.0, -1e-300, f64::NAN, f64::NEG_INFINITY, f64::INFINITY, 1e-300, 0.3, 1.0, 30.0, 800.0] {
            assert_eq!(n.position_at(v).to_bits(), blend(v).to_bits(), "{v}");
        }
    }

    /// Issue 15 (found by fuzzing): values that passed validation and turned a recording with alarms into 100 %
    /// "not monitored" or "consistent" with exit 0.
    #[test]
    fn issue_15_parameters_that_switch_checks_off_are_rejected() {
        let d = MonitorParams::default();
        let cases = [
            (MonitorParams { safety_margin_m: 1e30, ..d }, "safety_margin_m"),
            (MonitorParams { tau_fn: 1.0, ..d }, "tau_fn"),
            (MonitorParams { tau_tp: 0.5, ..d }, "tau_tp"),
            (MonitorParams { max_time_step_s: 1e-300, ..d }, "max_time_step_s"),
            (MonitorParams { gamma_plaus: 1e30, ..d }, "gamma_plaus"),
            (MonitorParams { gamma_sens: 1e30, ..d }, "gamma_sens"),
            (MonitorParams { min_cluster_cells: u32::MAX, ..d }, "min_cluster_cells"),
            (
                MonitorParams { motion_limits: MotionLimits { accel_max_mps2: 1e30, ..d.motion_limits }, ..d },
                "motion_limits",
            ),
            (
                MonitorParams { default_uncertainty: Uncertainty { x_m: 1e30, ..d.default_uncertainty }, ..d },
                "default_uncertainty",
            ),
        ];
        for (p, field) in cases {
            let e = p.validate().unwrap_err();
            assert_eq!(e.field, field, "{e}");
        }
        assert!(d.validate().is_ok());
    }

    /// Step 9 from each cell's first return is the default since issue #10; `jump_first_return` only chooses what
    /// `jump_from_returns` keeps per cell, so turning `jump_from_returns` off alone is a valid set of params (the
    /// first-return key then has no effect: tests/evidence_attribution.rs checks the verdicts).
    #[test]
    fn step_9_from_first_returns_is_the_default_and_one_key_turns_it_off() {
        let d = MonitorParams::default();
        assert!(d.jump_from_returns && d.jump_first_return);
        assert!(d.jump_evidence_at_prediction && d.jump_coincident_boxes && d.jump_jumped_boxes);
        assert!(MonitorParams { jump_from_returns: false, ..d }.validate().is_ok());
        assert!(MonitorParams {
            jump_evidence_at_prediction: false,
            jump_coincident_boxes: false,
            jump_jumped_boxes: false,
            ..d
        }
        .validate()
        .is_ok());
        assert!(MonitorParams { jump_first_return: false, ..d }.validate().is_ok());
    }

    /// `memory_hold_s`: 1 s by default (issue #10's round "Two rules together"), with `front_cluster` on; any time
    /// in [0, 10] s is accepted (0 turns it off), NaN, negative and longer times are not.
    #[test]
    fn memory_hold_is_one_second_by_default_and_bounded() {
        let d = MonitorParams::default();
        assert_eq!(d.memory_hold_s.to_bits(), 1.0f64.to_bits());
        assert!(d.front_cluster && d.spill_in_front);
        assert!(MonitorParams { spill_in_front: false, ..d }.validate().is_ok());
        assert!(d.spill_near_side && MonitorParams { spill_near_side: false, ..d }.validate().is_ok());
        assert!(!d.spill_least_stretch && MonitorParams { spill_least_stretch: true, ..d }.validate().is_ok());
        assert_eq!(d.spill_gap_m.to_bits(), 0.4f32.to_bits(), "0.4 m by default since issue #10's round of the gap");
        for ok in [0.0, 0.4, 1.0] {
            assert!(MonitorParams { spill_gap_m: ok, ..d }.validate().is_ok(), "{ok}");
        }
        for bad in [-0.1, 1.5, f32::NAN, f32::INFINITY] {
            let e = MonitorParams { spill_gap_m: bad, ..d }.validate().unwrap_err();
            assert_eq!(e.field, "spill_gap_m", "{bad}: {e}");
        }
        assert!(!d.seen_over && !d.face_in_front && !d.memory_gate && !d.shadow_gate && !d.follow_owner_fit);
        assert!(d.release_flagged_claims, "on by default since issue #10's round of released claims");
        assert!(MonitorParams { release_flagged_claims: false, ..d }.validate().is_ok());
        assert!(!d.release_to_confirmed);
        assert!(d.evidence_runs_on, "on by default since issue #10's round of evidence that runs on");
        assert!(MonitorParams { evidence_runs_on: false, ..d }.validate().is_ok());
        assert!(d.seen_through_near_side, "on by default since issue #10's round of the near side seen through");
        assert!(MonitorParams { seen_through_near_side: false, ..d }.validate().is_ok());
        assert_eq!(d.returns_beyond_cells, 0);
        assert!(d.seen_body && d.follow_gate, "on by default since issue #10's round of rays on the body");
        for ok in [0.0, 0.5, 10.0] {
            assert!(MonitorParams { memory_hold_s: ok, ..d }.validate().is_ok(), "{ok}");
        }
        for bad in [f64::NAN, -0.1, 10.5, f64::INFINITY] {
            let e = MonitorParams { memory_hold_s: bad, ..d }.validate().unwrap_err();
            assert_eq!(e.field, "memory_hold_s", "{bad}: {e}");
        }
        assert_eq!(d.parked_hold_s.to_bits(), 0.0f64.to_bits());
        for ok in [0.0, 3.0, 10.0] {
            assert!(MonitorParams { parked_hold_s: ok, ..d }.validate().is_ok(), "{ok}");
        }
        for bad in [f64::NAN, -0.1, 10.5, f64::INFINITY] {
            let e = MonitorParams { parked_hold_s: bad, ..d }.validate().unwrap_err();
            assert_eq!(e.field, "parked_hold_s", "{bad}: {e}");
        }
    }

    #[test]
    fn paper_defaults_are_table_one() {
        let p = MonitorParams::default();
        assert!((p.grid_size_m - 100.0).abs() < 1e-6);
        assert!((p.cell_size_m - 0.5).abs() < 1e-6);
        assert!((p.safety_margin_m - 0.1).abs() < 1e-6);
        assert!((p.tau_tp - 0.8).abs() < 1e-6 && (p.tau_fn - 0.8).abs() < 1e-6);
        assert!((p.motion_limits.brake_max_mps2 + 7.0).abs() < 1e-6);
        assert!((p.motion_limits.accel_max_mps2 - 7.0).abs() < 1e-6);
        assert!((p.default_uncertainty.heading_rad.to_degrees() - 10.0).abs() < 1e-4);
        // 90 degrees per 0.2 s = 450 degrees per second.
        assert!((p.motion_limits.turn_rate_max_radps.to_degrees() - 450.0).abs() < 1e-3);
        assert!((p.gamma_sens - 3.0).abs() < 1e-6 && (p.gamma_plaus - 1.0).abs() < 1e-6);
        assert_eq!(p.validate(), Ok(()));
        assert_eq!(p.grid_cells_per_side(), 200);
    }

    #[test]
    fn out_of_range_values_are_named() {
        let mut p = MonitorParams::default();
        p.cell_size_m = -0.5;
        assert_eq!(p.validate().map_err(|e| e.field), Err("cell_size_m"));
        let mut p = MonitorParams::default();
        p.tau_tp = f32::NAN;
        assert_eq!(p.validate().map_err(|e| e.field), Err("tau_tp"));
        let mut p = MonitorParams::default();
        p.motion_limits.brake_max_mps2 = 3.0;
        assert_eq!(p.validate().map_err(|e| e.field), Err("motion_limits"));
        let mut p = MonitorParams::default();
        p.cell_size_m = 0.001;
        assert_eq!(p.validate().map_err(|e| e.field), Err("cell_size_m"));
        let mut p = MonitorParams::default();
        p.per_class_limits.pedestrian = Some(MotionLimits { turn_rate_max_radps: 0.0, ..MotionLimits::default() });
        assert_eq!(p.validate().map_err(|e| e.field), Err("per_class_limits.pedestrian"));
    }

    /// With the grazing rule on by default, a params file that only raises `max_obstacle_height_m` above the
    /// rule's 4.5 m is refused, and the message says both ways out.
    #[test]
    fn a_band_above_the_grazing_height_is_refused_with_both_ways_out() {
        let p = MonitorParams { max_obstacle_height_m: 5.0, ..MonitorParams::default() };
        let e = p.validate().unwrap_err();
        assert_eq!(e.field, "roi_graze_height_m");
        assert!(e.reason.contains("raise roi_graze_height_m") && e.reason.contains("roi_graze_fraction = 0"), "{e:?}");
        let raised = MonitorParams { roi_graze_height_m: 5.0, ..p };
        assert_eq!(raised.validate(), Ok(()));
        let off = MonitorParams { roi_graze_fraction: 0.0, ..p };
        assert_eq!(off.validate(), Ok(()));
    }

    #[test]
    fn per_class_limits_override() {
        let mut p = MonitorParams::default();
        let ped = MotionLimits { accel_max_mps2: 3.0, brake_max_mps2: -4.0, turn_rate_max_radps: 20.0 };
        p.per_class_limits.pedestrian = Some(ped);
        assert_eq!(p.limits_for(ObjectClass::Pedestrian), ped);
        assert_eq!(p.limits_for(ObjectClass::Car), p.motion_limits);
    }
}
