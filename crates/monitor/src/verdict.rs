//! What the monitor says about each object and each frame, and why.

use core::fmt;

/// Why a check could not judge an object. Every object that is not judged gets one of these, never silence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum NotMonitoredReason {
    /// The object's state is invalid: NaN or infinite values, a size not > 0 or above the maximum, a
    /// negative speed, or invalid uncertainties.
    InvalidState,
    /// The object's footprint is not entirely inside the occupancy grid.
    OutsideGrid,
    /// No LiDAR sweep came with this frame.
    NoLidarData,
    /// The LiDAR sweep had no point at all (a sensor fault, not an empty world: the ground returns).
    EmptyCloud,
    /// The LiDAR sweep was invalid: its extrinsic is not finite.
    InvalidCloud,
    /// The sweep had more points than the monitor's capacity (`max_points`).
    TooManyPoints,
    /// No LiDAR evidence in the object's region, and the region is hidden from the sensor (behind nearer
    /// obstacles or beyond the sweep's reach): the sensor cannot say whether the object is there.
    Occluded,
    /// First frame of this track: there is no history to check the motion against.
    FirstFrameOfTrack,
    /// The frame's timestamp is not finite.
    InvalidTimestamp,
    /// The time since the track's previous state is zero or negative.
    TimeStepNotPositive,
    /// The time since the track's previous state exceeds `max_time_step_s`; the track restarts.
    TimeStepTooLong,
    /// Two or more objects of this frame share this id.
    DuplicateId,
    /// An intermediate result of the motion check was not finite (NaN or infinite: for example a time step so
    /// small that the estimated acceleration overflows); no verdict is computed from it.
    NonFiniteEstimate,
    /// The user switched this check off (`pmon check --checks`); the monitor itself never gives it.
    CheckDisabled,
}

impl NotMonitoredReason {
    /// Short snake_case name, as in JSON output.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::InvalidState => "invalid_state",
            Self::OutsideGrid => "outside_grid",
            Self::NoLidarData => "no_lidar_data",
            Self::EmptyCloud => "empty_cloud",
            Self::InvalidCloud => "invalid_cloud",
            Self::TooManyPoints => "too_many_points",
            Self::Occluded => "occluded",
            Self::FirstFrameOfTrack => "first_frame_of_track",
            Self::InvalidTimestamp => "invalid_timestamp",
            Self::TimeStepNotPositive => "time_step_not_positive",
            Self::TimeStepTooLong => "time_step_too_long",
            Self::DuplicateId => "duplicate_id",
            Self::NonFiniteEstimate => "non_finite_estimate",
            Self::CheckDisabled => "check_disabled",
        }
    }
}

impl fmt::Display for NotMonitoredReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which test of the sensor checks found a position error: the evidence that shows the object is not where the
/// object list says (docs/attribution.md, "The rule, step by step"). A user sees why an alarm fired, and which
/// alarms a rule that is off by default would add.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum PositionCause {
    /// A conflict cluster (evidence no object explains) was attributed to the object: its evidence lies outside
    /// its grown region (the paper's test, with pmon's gated assignment; steps 2-7).
    DisplacedEvidence,
    /// The object's evidence of the frames before, followed to where its offset from the box puts it now, lies in
    /// a neighbour's margin (step 8).
    EvidenceFollowed,
    /// The box jumped away from its evidence, which stayed where the object's stated motion predicts it (step 9).
    JumpedFromEvidence,
    /// The LiDAR rays pass through the box's footprint to its own evidence behind it: the object stands behind
    /// where it is reported (displaced towards the sensor; the free-space test).
    SeenThrough,
    /// Its evidence's face stands in front of the box along the rays (params key `face_in_front`).
    FaceInFront,
    /// Its own returns stand beyond its grown region (params key `returns_beyond_cells`).
    ReturnsBeyond,
    /// Hidden, it stands behind evidence that a neighbour held only by its reported region while that neighbour's
    /// own evidence lies elsewhere (params key `release_flagged_claims`).
    EvidenceReleased,
    /// Confirmed only by evidence in its margin that runs on beyond its grown region (params key
    /// `evidence_runs_on`).
    EvidenceRunsOn,
    /// A parked vehicle that alarms found displaced in the frames before, held while it stays parked (params key
    /// `parked_hold_s`).
    HeldWhileParked,
}

impl PositionCause {
    /// Every cause, in the order of their codes (`pmon.h`'s `PMON_POSITION_CAUSE_*` are 1 + the index).
    pub const ALL: [Self; 9] = [
        Self::DisplacedEvidence,
        Self::EvidenceFollowed,
        Self::JumpedFromEvidence,
        Self::SeenThrough,
        Self::FaceInFront,
        Self::ReturnsBeyond,
        Self::EvidenceReleased,
        Self::EvidenceRunsOn,
        Self::HeldWhileParked,
    ];

    /// Short snake_case name, as in JSON output.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::DisplacedEvidence => "displaced_evidence",
            Self::EvidenceFollowed => "evidence_followed",
            Self::JumpedFromEvidence => "jumped_from_evidence",
            Self::SeenThrough => "seen_through",
            Self::FaceInFront => "face_in_front",
            Self::ReturnsBeyond => "returns_beyond",
            Self::EvidenceReleased => "evidence_released",
            Self::EvidenceRunsOn => "evidence_runs_on",
            Self::HeldWhileParked => "held_while_parked",
        }
    }

    /// A sentence for a person reading an alarm.
    #[must_use]
    pub const fn description(self) -> &'static str {
        match self {
            Self::DisplacedEvidence => "its evidence lies outside its region",
            Self::EvidenceFollowed => "its evidence, followed from the frames before, lies apart from it",
            Self::JumpedFromEvidence => "the box jumped away from its evidence, which stayed",
            Self::SeenThrough => "the rays pass through the box to its evidence behind it",
            Self::FaceInFront => "its evidence's face stands in front of the box along the rays",
            Self::ReturnsBeyond => "its own returns stand beyond its region",
            Self::EvidenceReleased => "it stands behind evidence a neighbour held only by its wrong place",
            Self::EvidenceRunsOn => "its evidence lies only in its margin and runs on beyond its region",
            Self::HeldWhileParked => "parked, it was found displaced from its evidence in the frames before",
        }
    }
}

impl fmt::Display for PositionCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which implausibility conditions fired (bit set).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Conditions(pub u8);

impl Conditions {
    /// Eq. (condition_w): turn rate beyond `omega_max`.
    pub const TURN_RATE: Self = Self(1);
    /// Eq. (condition_a): acceleration beyond `a_acc` or braking beyond `a_br`.
    pub const ACCELERATION: Self = Self(2);
    /// Eq. (condition_xy): position off the CTRA prediction.
    pub const POSITION: Self = Self(4);

    /// True when no condition fired.
    #[must_use]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// True when every condition of `other` fired.
    #[must_use]
    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    /// Union.
    #[must_use]
    pub const fn union(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }
}

impl fmt::Display for Conditions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut first = true;
        for (bit, name) in
            [(Self::TURN_RATE, "turn_rate"), (Self::ACCELERATION, "acceleration"), (Self::POSITION, "position")]
        {
            if self.contains(bit) {
                if !first {
                    f.write_str("+")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        if first {
            f.write_str("none")?;
        }
        Ok(())
    }
}

/// Result of the sensor checks for one object (Section III-B).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum SensorVerdict {
    /// `eta(o) >= tau_tp` and no unexplained evidence next to the object.
    Consistent,
    /// `eta(o) < tau_tp`, no unexplained evidence nearby, and the region was visible: a false positive.
    Ghost,
    /// The object's LiDAR evidence lies outside its region: `eta(o) < tau_tp` with an unexplained conflict
    /// cluster nearby, or a conflict cluster touching the region.
    PositionError,
    /// The sensor checks could not judge this object.
    NotMonitored(NotMonitoredReason),
}

impl fmt::Display for SensorVerdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Consistent => f.write_str("consistent"),
            Self::Ghost => f.write_str("ghost"),
            Self::PositionError => f.write_str("position_error"),
            Self::NotMonitored(r) => write!(f, "not_monitored({r})"),
        }
    }
}

/// Details of the sensor checks for one object.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SensorOutcome {
    /// The verdict.
    pub verdict: SensorVerdict,
    /// Consistency `eta(o)` (eq. consistency), the highest occupancy probability in `A_o`; 0 when not computed.
    pub eta: f32,
    /// The object's *own* consistency: the highest occupancy probability over the cells of `A_o` whose nearest
    /// footprint (among all objects whose regions cover the cell) is this object's. Below `tau_tp` while `eta`
    /// is above it, the object only borrows a neighbour's evidence. 0 when not computed.
    pub eta_own: f32,
    /// Growth of the footprint along its length, `delta_safe + gamma_sens (Delta lon + Delta L)`, metres.
    pub margin_length_m: f32,
    /// Growth of the footprint across its width, `delta_safe + gamma_sens (Delta lat + Delta W)`, metres.
    pub margin_width_m: f32,
    /// Fraction of the footprint's cells visible to the sensor, in [0, 1]; computed only for objects without
    /// evidence of their own (`eta_own < tau_tp`) that the evidence attribution needed to look at or that got
    /// no cluster (0 otherwise).
    pub visible_fraction: f32,
    /// Index into [`FrameReport::clusters`] of the conflict cluster attributed to this object, if any.
    pub cluster: Option<u16>,
    /// For a position error: vector from the attributed cluster's centroid to the nearest point of the
    /// object's (ungrown) box, ego frame, metres: how far the object sits from its evidence.
    pub offset_m: [f32; 2],
    /// For a position error: which test found it (`None` for every other verdict).
    pub position_cause: Option<PositionCause>,
}

/// Result of the plausibility checks for one object (Section III-C).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum MotionVerdict {
    /// No condition fired.
    Plausible,
    /// At least one of eqs. (condition_w), (condition_a), (condition_xy) fired.
    Implausible(Conditions),
    /// The plausibility checks could not judge this object.
    NotMonitored(NotMonitoredReason),
}

impl fmt::Display for MotionVerdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Plausible => f.write_str("plausible"),
            Self::Implausible(c) => write!(f, "implausible({c})"),
            Self::NotMonitored(r) => write!(f, "not_monitored({r})"),
        }
    }
}

/// What an implausible motion verdict says is wrong (the tracker-aware modes name it; the paper's mode does
/// not). The error size is in [`MotionOutcome::error_size`], in the kind's unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum ImplausibilityKind {
    /// The reported speed disagrees with the observed motion of the box (m/s: reported minus observed).
    SpeedInconsistent,
    /// The heading turned by more than 90 degrees in one step while the object moves (rad).
    HeadingFlip,
    /// The box moved where neither its reported motion nor its own position history puts it (m).
    PositionJump,
    /// The reported speeds change faster than the class can accelerate or brake, consistently with the
    /// observed motion (m/s^2 beyond the limit).
    Acceleration,
    /// The heading turns faster than the class can turn (rad/s beyond the limit).
    TurnRate,
}

impl ImplausibilityKind {
    /// Short snake_case name, as in JSON output.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::SpeedInconsistent => "speed_inconsistent",
            Self::HeadingFlip => "heading_flip",
            Self::PositionJump => "position_jump",
            Self::Acceleration => "acceleration",
            Self::TurnRate => "turn_rate",
        }
    }

    /// Unit of [`MotionOutcome::error_size`] for this kind.
    #[must_use]
    pub const fn unit(self) -> &'static str {
        match self {
            Self::SpeedInconsistent => "m/s",
            Self::HeadingFlip => "rad",
            Self::PositionJump => "m",
            Self::Acceleration => "m/s^2",
            Self::TurnRate => "rad/s",
        }
    }
}

impl fmt::Display for ImplausibilityKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Details of the plausibility checks for one object: the estimates and margins of eqs. (pred1)-(condition_xy).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MotionOutcome {
    /// The verdict.
    pub verdict: MotionVerdict,
    /// Time step `dt` since the track's previous state, seconds (0 when not computed).
    pub dt_s: f64,
    /// Estimated acceleration `a_hat` (eq. pred1), m/s^2.
    pub accel_mps2: f32,
    /// Its margin of error `Delta a_hat`, m/s^2.
    pub accel_margin_mps2: f32,
    /// Estimated turn rate `omega_hat` (eq. pred1), rad/s.
    pub turn_rate_radps: f32,
    /// Its margin of error `Delta omega_hat`, rad/s.
    pub turn_rate_margin_radps: f32,
    /// Predicted position `x_hat, y_hat` (eq. pred2), world frame, metres.
    pub predicted_world_m: [f64; 2],
    /// Margin of error of the prediction `(Delta x_hat, Delta y_hat)`, metres.
    pub predicted_margin_m: [f32; 2],
    /// Distance between prediction and measurement `||x_hat - x_tilde||`, metres.
    pub position_residual_m: f32,
    /// Allowed distance `gamma_plaus (||Delta x_hat|| + ||Delta x_tilde||)`, metres (tracker mode: the gate's
    /// distance along the residual).
    pub position_allowance_m: f32,
    /// What is wrong, for an implausible verdict in the tracker-aware mode (`None` otherwise).
    pub kind: Option<ImplausibilityKind>,
    /// Estimated size of the error in the kind's unit ([`ImplausibilityKind::unit`]); 0 without a kind.
    pub error_size: f32,
    /// `|error_size|` over the safety-critical size of its kind (1 m, 3 m/s; a flip: the velocity error `2 v`
    /// over 3 m/s; limits: the excess over the limit relative to the limit): `>= 1` is safety-critical.
    pub severity: f32,
}

impl MotionOutcome {
    /// An outcome with no estimates.
    #[must_use]
    pub const fn not_monitored(reason: NotMonitoredReason) -> Self {
        Self {
            verdict: MotionVerdict::NotMonitored(reason),
            dt_s: 0.0,
            accel_mps2: 0.0,
            accel_margin_mps2: 0.0,
            turn_rate_radps: 0.0,
            turn_rate_margin_radps: 0.0,
            predicted_world_m: [0.0, 0.0],
            predicted_margin_m: [0.0, 0.0],
            position_residual_m: 0.0,
            position_allowance_m: 0.0,
            kind: None,
            error_size: 0.0,
            severity: 0.0,
        }
    }
}

/// The one verdict every object gets each frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(rename_all = "snake_case"))]
pub enum Verdict {
    /// The LiDAR confirmed the object (the sensor checks found it consistent) and the plausibility checks raised
    /// no alarm (they may not have run, e.g. on a track's first frame). Only the sensor checks can say this.
    Consistent,
    /// Only the plausibility checks judged the object, and found its motion plausible; the sensor checks could
    /// not judge it, for the reason given (occluded, no LiDAR data, outside the grid, ...). Not an alarm, and
    /// not a confirmation that the object is there.
    MotionOnlyConsistent(NotMonitoredReason),
    /// Sensor checks: no evidence in a visible region (false positive).
    Ghost,
    /// Sensor checks: the evidence lies outside the object's region.
    PositionError,
    /// Plausibility checks: the motion violates the named conditions.
    ImplausibleMotion(Conditions),
    /// Neither check could judge the object; the reason of the sensor checks is given unless it is only
    /// that no LiDAR came, in which case the plausibility reason is given.
    NotMonitored(NotMonitoredReason),
}

impl Verdict {
    /// True for the alarms (ghost, position error, implausible motion).
    #[must_use]
    pub const fn is_alarm(self) -> bool {
        matches!(self, Self::Ghost | Self::PositionError | Self::ImplausibleMotion(_))
    }

    /// Combines the two checks: sensor alarms first, then motion alarms, then consistent if the sensor checks
    /// confirmed the object, motion-only consistent if only the plausibility checks judged it, else not
    /// monitored.
    #[must_use]
    pub fn combine(sensor: SensorVerdict, motion: MotionVerdict) -> Self {
        match (sensor, motion) {
            (SensorVerdict::Ghost, _) => Self::Ghost,
            (SensorVerdict::PositionError, _) => Self::PositionError,
            (_, MotionVerdict::Implausible(c)) => Self::ImplausibleMotion(c),
            (SensorVerdict::Consistent, _) => Self::Consistent,
            (SensorVerdict::NotMonitored(s), MotionVerdict::Plausible) => Self::MotionOnlyConsistent(s),
            (SensorVerdict::NotMonitored(s), MotionVerdict::NotMonitored(m)) => {
                if matches!(s, NotMonitoredReason::NoLidarData) {
                    Self::NotMonitored(m)
                } else {
                    Self::NotMonitored(s)
                }
            }
        }
    }

    /// Why the sensor checks could not judge the object, for the two verdicts that carry a reason
    /// (`not_monitored`, `motion_only_consistent`); `None` for the others. Every front end reports it beside the
    /// verdict (an object nobody confirmed, and why).
    #[must_use]
    pub const fn not_monitored_reason(self) -> Option<NotMonitoredReason> {
        match self {
            Self::NotMonitored(r) | Self::MotionOnlyConsistent(r) => Some(r),
            _ => None,
        }
    }

    /// Short snake_case name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Consistent => "consistent",
            Self::MotionOnlyConsistent(_) => "motion_only_consistent",
            Self::Ghost => "ghost",
            Self::PositionError => "position_error",
            Self::ImplausibleMotion(_) => "implausible_motion",
            Self::NotMonitored(_) => "not_monitored",
        }
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::ImplausibleMotion(c) => write!(f, "implausible_motion({c})"),
            Self::NotMonitored(r) => write!(f, "not_monitored({r})"),
            Self::MotionOnlyConsistent(r) => write!(f, "motion_only_consistent({r})"),
            other => f.write_str(other.name()),
        }
    }
}

/// Everything the monitor says about one object in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ObjectReport {
    /// The object's id.
    pub id: u64,
    /// The combined verdict.
    pub verdict: Verdict,
    /// Sensor checks.
    pub sensor: SensorOutcome,
    /// Plausibility checks.
    pub motion: MotionOutcome,
}

/// A connected group of conflict cells (`kappa > tau_fn`): LiDAR evidence that no object explains.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ClusterReport {
    /// Number of cells.
    pub cells: u32,
    /// Centroid of the cell centres, ego frame, metres.
    pub centroid_m: [f32; 2],
    /// Axis-aligned bounds `[min_x, min_y, max_x, max_y]`, ego frame, metres.
    pub bounds_m: [f32; 4],
    /// True when the frame has no region of interest, or when one of the cluster's obstacle-band returns lies
    /// inside it (with `roi_graze_fraction > 0`: and at least that fraction of them does, or no return over its
    /// cells is higher than `roi_graze_height_m` over the ground). Always `roi.in_roi()`.
    pub in_roi: bool,
    /// Why the cluster is in the region of interest or outside it: the reason a cluster no object explains is
    /// excused (not a missed object) is kept, not only the outcome.
    pub roi: RoiStatus,
    /// Index into [`FrameReport::objects`] of the object it is attributed to (a position error), if any.
    pub object: Option<u32>,
}

impl ClusterReport {
    /// True for an alarm: large enough, in the region of interest, and not attributed to any object.
    #[must_use]
    pub const fn is_missed_object(&self) -> bool {
        self.in_roi && self.object.is_none()
    }

    /// True when the map excused it: outside the region of interest ([`RoiStatus::Outside`] or
    /// [`RoiStatus::Grazing`]) and attributed to no object. Not an alarm; its reason is `roi`.
    #[must_use]
    pub const fn is_outside_roi(&self) -> bool {
        !self.in_roi && self.object.is_none()
    }
}

/// Where a conflict cluster lies with respect to the frame's region of interest, and why
/// ([`ClusterReport::roi`]; docs/datasets.md, "The grazing rule").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum RoiStatus {
    /// The frame has no region of interest: the whole grid is (in the ROI).
    NoRoi,
    /// In the region of interest: one of its obstacle-band returns lies inside it (with the grazing rule: and
    /// at least `roi_graze_fraction` of them do, or nothing over its cells is taller than `roi_graze_height_m`).
    Inside,
    /// Outside: none of its obstacle-band returns lies inside the region of interest.
    Outside,
    /// Outside by the grazing rule: some of its band returns lie inside, fewer than `roi_graze_fraction` of
    /// them, and a return over its cells stands higher than `roi_graze_height_m` over the ground (a tree canopy
    /// over the kerb).
    Grazing,
}

impl RoiStatus {
    /// True for [`RoiStatus::NoRoi`] and [`RoiStatus::Inside`] (the value of [`ClusterReport::in_roi`]).
    #[must_use]
    pub const fn in_roi(self) -> bool {
        matches!(self, Self::NoRoi | Self::Inside)
    }

    /// Snake-case name: `no_roi`, `inside`, `no_return_in_roi`, `grazing` (the `reason` of
    /// `pmon check --format jsonl`'s `outside_roi` records for the last two).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::NoRoi => "no_roi",
            Self::Inside => "inside",
            Self::Outside => "no_return_in_roi",
            Self::Grazing => "grazing",
        }
    }

    /// Code for the C API and Python: 0 no ROI, 1 inside, 2 outside (no return in it), 3 grazing.
    #[must_use]
    pub const fn code(self) -> u32 {
        match self {
            Self::NoRoi => 0,
            Self::Inside => 1,
            Self::Outside => 2,
            Self::Grazing => 3,
        }
    }
}

impl core::fmt::Display for RoiStatus {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// Frame-level summary of the sensor checks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GridStats {
    /// Points in the sweep.
    pub points_total: u32,
    /// Points inside the height band and the grid (obstacle evidence).
    pub points_in_band: u32,
    /// Cells with at least one obstacle hit.
    pub cells_hit: u32,
    /// Cells with occupancy above `tau_fn`.
    pub cells_occupied: u32,
    /// Occupied cells no object explains (`kappa > tau_fn`).
    pub cells_conflict: u32,
    /// Conflict clusters of at least `min_cluster_cells`, including those beyond `max_clusters`.
    pub clusters_total: u32,
}

/// What [`crate::Monitor::check`] returns: borrowed from the monitor's buffers until the next call.
#[derive(Clone, Copy, Debug)]
pub struct FrameReport<'a> {
    /// One report per input object, in input order.
    pub objects: &'a [ObjectReport],
    /// Conflict clusters (at most `max_clusters`).
    pub clusters: &'a [ClusterReport],
    /// Grid statistics; all zero when the sensor checks did not run.
    pub grid: GridStats,
    /// Why the sensor checks did not run this frame, if they did not.
    pub sensor_status: Option<NotMonitoredReason>,
}

impl FrameReport<'_> {
    /// Number of object alarms.
    #[must_use]
    pub fn object_alarms(&self) -> usize {
        self.objects.iter().filter(|o| o.verdict.is_alarm()).count()
    }

    /// Number of missed-object alarms (unattributed conflict clusters in the region of interest).
    #[must_use]
    pub fn missed_objects(&self) -> usize {
        self.clusters.iter().filter(|c| c.is_missed_object()).count()
    }

    /// The clusters the region of interest excused (outside it, attributed to no object; not alarms), by reason:
    /// `[no band return in the ROI, the grazing rule]` (the `outside_roi` records of `pmon check --format jsonl`).
    #[must_use]
    pub fn outside_roi_counts(&self) -> [usize; 2] {
        let mut n = [0, 0];
        for c in self.clusters.iter().filter(|c| c.is_outside_roi()) {
            if let Some(k) = n.get_mut(usize::from(c.roi == RoiStatus::Grazing)) {
                *k += 1;
            }
        }
        n
    }
}

/// A frame the monitor refuses as a whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// More objects than `max_objects`.
    TooManyObjects {
        /// Objects in the frame.
        got: usize,
        /// Capacity.
        max: u32,
    },
    /// [`crate::Monitor::check_columns`] (and its variants) was given a frame that carries a sweep of its own in
    /// `frame.cloud` besides the column sweep: which one to check would be a guess, so the frame is refused.
    CloudGivenTwice,
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooManyObjects { got, max } => {
                write!(f, "frame has {got} objects, more than the monitor's capacity of {max} (max_objects)")
            }
            Self::CloudGivenTwice => write!(
                f,
                "frame carries a point cloud and a column cloud was passed too: set the frame's cloud to None when \
                 handing the sweep over as columns"
            ),
        }
    }
}

impl core::error::Error for FrameError {}

#[cfg(test)]
mod tests {
    use super::*;

    /// The position causes' names are distinct snake_case words (JSON, Python, C and ROS 2 carry them), `ALL`
    /// lists each once in code order, and `Display` is the name.
    #[test]
    fn position_causes_have_distinct_snake_case_names() {
        extern crate alloc;
        use alloc::string::ToString;
        for (i, a) in PositionCause::ALL.iter().enumerate() {
            assert!(a.name().bytes().all(|b| b.is_ascii_lowercase() || b == b'_'), "{}", a.name());
            assert_eq!(a.to_string(), a.name());
            assert!(!a.description().is_empty());
            for b in PositionCause::ALL.iter().skip(i + 1) {
                assert_ne!(a.name(), b.name());
                assert!(a < b, "ALL is in code order");
            }
        }
    }

    /// Issue 15: `consistent` means the LiDAR confirmed the object. An object the sensor could not judge
    /// (occluded, no LiDAR, ...) whose motion is plausible is `motion_only_consistent(reason)`, never
    /// `consistent`.
    #[test]
    fn issue_15_consistent_only_when_the_lidar_confirmed_the_object() {
        use NotMonitoredReason as R;
        for reason in [R::Occluded, R::NoLidarData, R::EmptyCloud, R::OutsideGrid, R::TooManyPoints, R::InvalidCloud] {
            let v = Verdict::combine(SensorVerdict::NotMonitored(reason), MotionVerdict::Plausible);
            assert_eq!(v, Verdict::MotionOnlyConsistent(reason));
            assert_eq!(v.not_monitored_reason(), Some(reason));
            assert!(!v.is_alarm());
            assert_ne!(v.name(), "consistent");
        }
        for motion in [MotionVerdict::Plausible, MotionVerdict::NotMonitored(R::FirstFrameOfTrack)] {
            assert_eq!(Verdict::combine(SensorVerdict::Consistent, motion), Verdict::Consistent);
        }
        let v = Verdict::combine(
            SensorVerdict::NotMonitored(R::Occluded),
            MotionVerdict::NotMonitored(R::FirstFrameOfTrack),
        );
        assert_eq!(v, Verdict::NotMonitored(R::Occluded));
        assert_eq!(v.not_monitored_reason(), Some(R::Occluded));
        for v in [Verdict::Consistent, Verdict::Ghost, Verdict::PositionError] {
            assert_eq!(v.not_monitored_reason(), None);
        }
    }
}
