//! `pmon simulate`: write a built-in or user scenario as a pmon recording.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use pmon_scenario::{ScenarioConfig, BUILTIN_NAMES};

use crate::output::OutputDir;

/// Arguments of `pmon simulate`.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// A built-in scenario (`pedestrians`, `intersection`) or a scenario TOML file.
    #[arg(long, default_value = "pedestrians")]
    pub scenario: String,
    /// Seed (overrides the file's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Length, seconds (overrides the file's).
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Output recording directory.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Print the scenario's TOML (to edit and pass back with --scenario FILE) and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Replace `--out` even when it holds files pmon simulate did not write.
    #[arg(long)]
    pub force: bool,
}

/// Loads a scenario by built-in name or file path.
pub fn load_scenario(name_or_path: &str) -> Result<ScenarioConfig> {
    if let Some(cfg) = ScenarioConfig::builtin(name_or_path) {
        return Ok(cfg);
    }
    let path = std::path::Path::new(name_or_path);
    if path.exists() {
        return ScenarioConfig::from_path(path).map_err(|e| anyhow::anyhow!("{e}"));
    }
    anyhow::bail!("`{name_or_path}` is neither a built-in scenario ({}) nor a file", BUILTIN_NAMES.join(", "))
}

/// `pmon simulate`.
pub fn run(args: &SimulateArgs) -> Result<ExitCode> {
    let mut cfg = load_scenario(&args.scenario)?;
    if let Some(s) = args.seed {
        cfg.seed = s;
    }
    if let Some(d) = args.duration_s {
        cfg.duration_s = d;
    }
    if args.print_config {
        print!("{}", cfg.to_toml_string().map_err(|e| anyhow::anyhow!("{e}"))?);
        return Ok(ExitCode::SUCCESS);
    }
    let pb = ProgressBar::new(cfg.frame_count());
    if let Ok(style) = ProgressStyle::with_template("{prefix:>12} [{bar:40}] {pos}/{len} frames ({eta} left)") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_prefix(cfg.name.clone());
    let out = OutputDir::prepare(&args.out, "simulate", args.force)?;
    let summary = pmon_scenario::simulate_to_dir(&cfg, out.path(), &mut |done, _total| pb.set_position(done))
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("simulating `{}`", args.scenario))?;
    out.commit()?;
    pb.finish_and_clear();
    eprintln!(
        "wrote {}: {} frames, {} object states ({} moving), {:.0} points per frame",
        args.out.display(),
        summary.frames,
        summary.object_states,
        summary.moving_object_states,
        summary.points as f64 / summary.clouds.max(1) as f64
    );
    Ok(ExitCode::SUCCESS)
}
