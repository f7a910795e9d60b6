//! `pmon tracker-bed`: the plausibility checks on simulated tracker-like output (issue #11, docs/plausibility.md).

use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use pmon_campaign::run::Scene;
use pmon_campaign::tracker::TrackerModelConfig;
use pmon_campaign::tracker_eval::{bed_table, run_bed};
use pmon_scenario::{ScenarioConfig, Simulator};

use crate::config::load_params;

/// Arguments of `pmon tracker-bed`.
#[derive(Args, Debug)]
pub struct TrackerBedArgs {
    /// Monitor parameters (TOML); defaults to the paper's Table I.
    #[arg(long)]
    pub params: Option<std::path::PathBuf>,
    /// Seed of the scenes and of the tracker model.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Seconds simulated per scene.
    #[arg(long, default_value_t = 120.0)]
    pub duration_s: f64,
    /// Print JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// The built-in scenes without LiDAR (object lists and ground truth only), at 10 Hz and the street at 20 Hz.
pub fn object_scenes(seed: u64, duration_s: f64) -> Result<Vec<Scene>> {
    let mut scenes = Vec::new();
    for (name, builtin, dt) in [
        ("pedestrians", "pedestrians", 0.1),
        ("intersection", "intersection", 0.1),
        ("pedestrians_20hz", "pedestrians", 0.05),
    ] {
        let mut cfg = ScenarioConfig::builtin(builtin).with_context(|| format!("no built-in scenario `{builtin}`"))?;
        cfg.seed = seed;
        cfg.name = name.into();
        cfg.dt_s = dt;
        cfg.duration_s = duration_s;
        cfg.lidar.enabled = Some(false);
        let mut sim = Simulator::new(&cfg).map_err(|e| anyhow::anyhow!("scenario `{name}`: {e}"))?;
        let mut frames = Vec::new();
        while let Some(f) = sim.step() {
            frames.push(f.frame);
        }
        scenes.push(Scene { name: name.into(), source: format!("built-in `{builtin}`, seed {seed}"), frames });
    }
    Ok(scenes)
}

/// `pmon tracker-bed`.
pub fn run(args: &TrackerBedArgs) -> Result<ExitCode> {
    let params = load_params(args.params.as_deref())?;
    let scenes = object_scenes(args.seed, args.duration_s)?;
    let mut results = Vec::new();
    for (i, s) in scenes.iter().enumerate() {
        let cfg = TrackerModelConfig::new(args.seed.wrapping_mul(7919).wrapping_add(i as u64));
        results.push(run_bed(s, &params, cfg).map_err(|e| anyhow::anyhow!(e))?);
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&results)?);
    } else {
        print!("{}", bed_table(&results));
    }
    Ok(ExitCode::SUCCESS)
}
