//! `pmon`: the command line tool of the pmon perception monitor.

mod check;
mod config;
mod reproduce;
mod simulate;
mod tracker_bed;
mod view;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

/// pmon: a lightweight perception monitor for automated driving.
///
/// Checks an object list (position, heading, speed, size, uncertainty) against LiDAR evidence in an
/// occupancy grid (sensor checks) and against a physical motion model (plausibility checks), after Buerkle
/// et al., "Fault-Tolerant Perception for Automated Driving: A Lightweight Monitoring Approach".
#[derive(Parser, Debug)]
#[command(name = "pmon", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// `pmon bench --rasterizer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum RasterizerArg {
    /// The blocked loop, AVX2 where the processor has it (the monitor's default).
    Blocked,
    /// The blocked loop on the target's baseline instruction set.
    Baseline,
    /// The reference per-point loop.
    Scalar,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run every experiment of the paper on the built-in scenarios and write a report (the main job).
    Reproduce(reproduce::ReproduceArgs),
    /// Simulate a built-in (or your own) scenario with a ray-cast LiDAR and write a pmon recording.
    Simulate(simulate::SimulateArgs),
    /// Check a recording: one verdict per object and frame, and missed objects.
    ///
    /// Exit status: 0 when no alarm was raised, 1 when at least one was, 2 on bad input or usage.
    Check(check::CheckArgs),
    /// Draw a top view of one frame: grid cells, LiDAR points, footprints coloured by verdict, clusters.
    View(view::ViewArgs),
    /// Measure the monitor's latency per stage on synthetic and real frames, beside the paper's figures.
    Bench {
        /// Print JSON instead of the table.
        #[arg(long)]
        json: bool,
        /// Timed checks per case.
        #[arg(long, default_value_t = 300)]
        iterations: usize,
        /// At most this many seconds per case.
        #[arg(long, default_value_t = 2.0)]
        max_seconds_per_case: f64,
        /// Also measure the largest accepted frame (400,000 points, 1,024 objects).
        #[arg(long)]
        worst_case: bool,
        /// Skip the real sweeps (KITTI, nuScenes, Argoverse 2) even when ../shared/data (or PMON_DATA_DIR) has
        /// them.
        #[arg(long)]
        no_real_data: bool,
        /// The rasterize loop: `blocked` (the monitor's default: AVX2 where the processor has it), `baseline` (the
        /// same loop on the target's baseline, SSE2 on x86-64) or `scalar` (the reference loop).
        #[arg(long, value_enum, default_value_t = RasterizerArg::Blocked)]
        rasterizer: RasterizerArg,
    },
    /// Convert a dataset (`kitti:DIR`, `nuscenes:DIR`, `av2:LOG_DIR`, `commonroad:FILE.xml`, ...) into a pmon
    /// recording.
    Convert {
        /// The dataset spec (see docs/datasets.md).
        spec: String,
        /// Output recording directory.
        #[arg(long, short)]
        out: std::path::PathBuf,
    },
    /// Score the plausibility checks on simulated tracker-like output (warm-up, re-fits, jitter, flips, jumps,
    /// drop-outs): false alarms on benign states, recall on safety-critical errors, kind correctness.
    TrackerBed(tracker_bed::TrackerBedArgs),
    /// Print the monitor parameters as TOML (the paper's Table I, or a file's values merged over it).
    Params {
        /// A TOML file of parameters to validate and print merged over the defaults.
        #[arg(long)]
        params: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Reproduce(args) => reproduce::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Check(args) => check::run(&args),
        Command::View(args) => view::run(&args),
        Command::Bench { json, iterations, max_seconds_per_case, worst_case, no_real_data, rasterizer } => {
            let opts = pmon_bench::BenchOptions {
                iterations,
                max_seconds_per_case,
                data_dir: None,
                real_data: !no_real_data,
                worst_case,
                rasterizer: match rasterizer {
                    RasterizerArg::Blocked => pmon_monitor::Rasterizer::Blocked,
                    RasterizerArg::Baseline => pmon_monitor::Rasterizer::BlockedBaseline,
                    RasterizerArg::Scalar => pmon_monitor::Rasterizer::Scalar,
                },
            };
            pmon_bench::run_bench(&opts).map_err(anyhow::Error::from).and_then(|r| {
                if json {
                    println!("{}", serde_json::to_string_pretty(&r)?);
                } else {
                    print!("{}", r.to_table());
                }
                Ok(ExitCode::SUCCESS)
            })
        }
        Command::Convert { spec, out } => {
            pmon_datasets::open(&spec).map_err(|e| anyhow::anyhow!("{e}")).and_then(|ds| {
                let meta = ds.write_recording(&out)?;
                eprintln!(
                    "wrote {}: {} frames from {spec}{}",
                    out.display(),
                    meta.frames,
                    if ds.info.ground_z_m.abs() > 1e-3 {
                        format!(
                            " (ground at z = {:.2} m: check it with --params holding ground_z_m = {:.2})",
                            ds.info.ground_z_m, ds.info.ground_z_m
                        )
                    } else {
                        String::new()
                    }
                );
                Ok(ExitCode::SUCCESS)
            })
        }
        Command::TrackerBed(args) => tracker_bed::run(&args),
        Command::Params { params } => config::print_params(params.as_deref()).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("pmon: error: {e:#}");
            ExitCode::from(2)
        }
    }
}
