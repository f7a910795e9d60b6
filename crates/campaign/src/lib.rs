//! # pmon-campaign: evaluating the monitor by fault injection
//!
//! Section IV of the paper: inject position and speed errors into a ground-truth object list, run the
//! monitor, and score what it detects. [`inject`] makes the errors and records them, [`run`] runs the monitor
//! over a [`run::Scene`] for each [`run::RunSpec`] in parallel, [`metrics`] scores precision, recall and
//! false-alarm rates with 95 % confidence intervals.

pub mod calibrate;
pub mod experiments;
pub mod inject;
pub mod metrics;
pub mod real_data;
pub mod run;
pub mod sim_tasks;
pub mod tracker;
pub mod tracker_eval;

pub use inject::{Direction, Fault, Injection, InjectionConfig, Injector};
pub use metrics::{
    cause_index, cause_name, clustered_wilson, distance_to_box, offset_agrees, offset_outcome,
    reported_displacement_agrees, score, score_by_track, CauseCounts, CauseTally, ClusteredRate, Metrics, OffsetTally,
    Outcome, Rate, Score, TrackTally, CAUSES, OWN_EVIDENCE_TOLERANCE_M,
};
pub use run::{
    confirmed_by_own_evidence, in_scope, paired_frames, replay_to, run_all, run_one, Example, PairedFrame, Replay,
    RunResult, RunSpec, Scene,
};
