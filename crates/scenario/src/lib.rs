//! # pmon-scenario: the built-in driving simulator
//!
//! A small, fast, deterministic world simulator after the paper's evaluation setup (Section IV-A: a residential
//! street with pedestrians crossing at random, and an urban intersection with pedestrians, cars, trucks and
//! cyclists), with a ray-cast LiDAR. It produces [`pmon_recording::RecordedFrame`]s for the monitor (object list =
//! ground truth in the ego frame, optionally noisy; LiDAR sweep in the sensor frame; region of interest) plus the
//! ground truth of every agent for evaluation campaigns.
//!
//! ```no_run
//! use pmon_scenario::{ScenarioConfig, Simulator};
//! let cfg = ScenarioConfig::builtin("intersection").unwrap();
//! let mut sim = Simulator::new(&cfg).unwrap();
//! while let Some(f) = sim.step() {
//!     println!("{} objects, {} truth", f.frame.objects.len(), f.truth.len());
//! }
//! ```
//!
//! Same scenario and seed give byte-identical output, whatever the number of threads (feature `parallel`).
//! See `docs/simulator.md` for the world, the agents' behaviour, the LiDAR model and every scenario key.

mod config;
mod error;
mod geom;
mod lidar;
mod path;
mod sim;
mod traffic;
mod world;

pub use config::{
    AgentsConfig, EgoConfig, EgoMode, Layout, LidarConfig, LidarModel, LidarPreset, NoiseConfig, RoadConfig, RoiMode,
    ScenarioConfig, SignalConfig, Turn, BUILTIN_NAMES,
};
pub use error::ScenarioError;
pub use sim::{simulate_to_dir, EgoTruth, SimFrame, Simulator, Summary, TruthObject, TRUTH_MARGIN_M};
