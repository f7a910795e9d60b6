//! # pmon-monitor: the safety channel
//!
//! A lightweight perception monitor after Buerkle et al., *Fault-Tolerant Perception for Automated Driving: A
//! Lightweight Monitoring Approach*. Two checks run on every frame of the primary channel's object list:
//!
//! - **Sensor checks** (Section III-B): LiDAR points inside a height band go into an ego-centred occupancy grid;
//!   each object's footprint `A_o`, grown by a safety margin and its covariance, must contain occupied cells
//!   (consistency `eta(o)`, eq. consistency), and occupied cells that no footprint covers are conflicts
//!   (`kappa`, eq. conflict), clustered into missed-object candidates or attributed to a displaced object.
//! - **Plausibility checks** (Section III-C): each track's motion between frames must fit the small-dt CTRA
//!   model within physical limits and propagated uncertainty (eqs. pred1, pred2, condition_w/a/xy).
//!
//! One call per frame, [`Monitor::check`], returns exactly one [`Verdict`] per object, never panics, and
//! allocates nothing after [`Monitor::new`]. The crate is `no_std` (it needs `alloc` only at construction).
#![cfg_attr(not(feature = "std"), no_std)]
// Unit tests may panic: a failed assertion is how a test fails.
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic,
        clippy::field_reassign_with_default
    )
)]

extern crate alloc;

pub mod frame;
pub mod params;
pub mod verdict;

pub use frame::{
    ColumnCloud, ColumnLengthError, Frame, Isometry3, ObjectClass, ObjectState, PointCloud, PointColumns, Pose2,
    Uncertainty,
};
pub use params::{
    ClassMotionLimits, ClassTrackerNoise, MonitorParams, MotionLimits, ParamError, PlausibilityMode, SpillOverFit,
    TrackerNoise,
};
pub use verdict::{
    ClusterReport, Conditions, FrameError, FrameReport, GridStats, ImplausibilityKind, MotionOutcome, MotionVerdict,
    NotMonitoredReason, ObjectReport, PositionCause, RoiStatus, SensorOutcome, SensorVerdict, Verdict,
};

pub mod calibrated;
mod evidence_memory;
pub mod geometry;
pub mod grid;
pub mod monitor;
pub mod motion;
pub mod plausibility;
mod rasterize;
pub mod region;
pub mod split;
#[cfg(test)]
mod test_support;
pub mod theory;
pub mod visibility;

pub use grid::{CellState, GridGeometry, OccupancyGrid};
pub use monitor::{object_is_valid, Monitor, Stage};
pub use rasterize::Rasterizer;
pub use region::Region;
pub use split::{Join, Sequential};
