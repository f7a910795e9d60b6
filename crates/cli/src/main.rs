//! `pmon`: the command line tool of the pmon perception monitor.

mod bag;
mod calibrate;
mod causes;
mod check;
mod config;
mod evaluate;
mod output;
mod readme_table;
mod reproduce;
mod ros2;
mod run_dir;
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
    /// Run the real-data experiments of `reproduce` over every log of a dataset (Argoverse 2, nuScenes, a folder
    /// of recordings), one task per log, here or on a Dask or Ray cluster; resumable.
    ///
    /// Exit status: 0 when every task ran, 1 when some failed on their data (the report lists them), 2 on bad
    /// input or usage.
    Evaluate(evaluate::EvaluateArgs),
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
        /// Measure only the cases whose name contains this text (repeatable), e.g. `--only kitti`.
        #[arg(long)]
        only: Vec<String>,
        /// Instead of measuring, write the frames of the 0.5 m cases with a cloud and pmon's per-box maxima into
        /// this folder, for the numpy and PCL peers (crates/bench/peers, docs/performance.md).
        #[arg(long)]
        export_peers: Option<std::path::PathBuf>,
        /// Rasterize each sweep of at least 65,536 points in two halves on two threads (`Monitor::check_split`:
        /// bit-identical verdicts; docs/performance.md). Without it every case runs on one thread.
        #[arg(long)]
        split: bool,
        /// Hand every sweep to the monitor as three columns (`x`, `y`, `z` slices: `Monitor::check_columns`, the
        /// same verdicts) instead of `[x, y, z]` records (docs/performance.md).
        #[arg(long, alias = "soa")]
        columns: bool,
        #[command(flatten)]
        rules: pmon_bench::RuleSwitches,
        /// Parameters every case starts from instead of the defaults: a TOML file over them, or a profile pmon
        /// ships (`profile:recall`; README, "The recall profile"), to measure what they cost. Each case keeps its
        /// own cell and grid size; the rule switches above apply over these.
        #[arg(long)]
        params: Option<std::path::PathBuf>,
        /// Check the KITTI sweeps over the whole grid instead of camera 2's field of view (the labelled region,
        /// `pmon check kitti:`'s default; docs/datasets.md).
        #[arg(long)]
        kitti_whole_grid: bool,
        /// Skip the machine's jitter reference (a fixed work of each case's median, timed after every case with a
        /// cloud, about as long as the case): the run takes about half the time; the `machine` column shows `-`.
        #[arg(long)]
        no_machine_reference: bool,
        /// Do not read the thread's CPU clock around each check (two system calls per check, outside the timed
        /// region): the `cpu` columns show `-` and the CPU-time worst-case lines are left out (docs/performance.md,
        /// "Worst case in CPU time").
        #[arg(long)]
        no_cpu_time: bool,
    },
    /// Convert a dataset (`kitti:DIR`, `nuscenes:DIR`, `av2:LOG_DIR`, `commonroad:FILE.xml`, ...) into a pmon
    /// recording.
    Convert {
        /// The dataset spec (see docs/datasets.md).
        spec: String,
        /// Output recording directory (or `.mcap` file with `--format mcap`).
        #[arg(long, short)]
        out: std::path::PathBuf,
        /// Region of interest the recording carries: `auto` (the dataset's map, where it has one), `none` or
        /// `corridor:<width_m>` (see docs/datasets.md).
        #[arg(long, default_value = "auto", value_parser = check::parse_roi)]
        roi: pmon_datasets::roi::RoiMode,
        /// Width of the sidewalk band added along a map's drivable areas, metres.
        #[arg(long, default_value_t = pmon_datasets::av2_map::DEFAULT_SIDEWALK_WIDTH_M, value_parser = check::parse_width)]
        sidewalk_m: f64,
        /// The monitor's grid size the ROI is clipped to, metres (Table I: 100).
        #[arg(long, default_value_t = pmon_monitor::MonitorParams::PAPER.grid_size_m)]
        grid_size_m: f32,
        /// Replace `--out` even when it holds files pmon convert did not write.
        #[arg(long)]
        force: bool,
        /// `recording` (a pmon recording directory) or `mcap` (Autoware topics, CDR; docs/ros2.md).
        #[arg(long, value_enum, default_value_t = bag::ConvertFormat::Recording)]
        format: bag::ConvertFormat,
    },
    /// Score the plausibility checks on simulated tracker-like output (warm-up, re-fits, jitter, flips, jumps,
    /// drop-outs): false alarms on benign states, recall on safety-critical errors, kind correctness.
    TrackerBed(tracker_bed::TrackerBedArgs),
    /// Run as a live ROS 2 node (DDS, no ROS installation): subscribe to a point cloud and an Autoware object
    /// list, publish verdicts (`pmon_msgs/FrameVerdicts`) and `/diagnostics` until Ctrl-C (docs/ros2.md).
    Ros2(Box<ros2::Ros2Args>),
    /// Estimate a tracker's per-class noise (position, speed, heading, vs. speed) from its own output and write a
    /// parameter file for the calibrated plausibility rule, with the expected false-alarm rate.
    Calibrate(calibrate::CalibrateArgs),
    /// Print the monitor parameters as TOML (the paper's Table I, or a file's values merged over it).
    Params {
        /// A TOML file of parameters to validate and print merged over the defaults, or a profile pmon ships
        /// (`profile:recall`; README, "The recall profile").
        #[arg(long)]
        params: Option<PathBuf>,
    },
}

/// `pmon convert`: the dataset as a recording, with the parameters `check` applies for it (ground height, ego
/// footprint) in the recording's `params.toml`, so that checking the recording gives what checking the dataset
/// gives.
fn convert(
    spec: &str,
    out: &std::path::Path,
    force: bool,
    opts: &pmon_datasets::ReadOptions,
) -> anyhow::Result<ExitCode> {
    use anyhow::Context;
    let (scheme, _) = spec.split_once(':').unwrap_or((spec, ""));
    if !pmon_datasets::SCHEMES.contains(&scheme) {
        anyhow::bail!("{spec}: unknown dataset prefix `{scheme}:` (known: {})", pmon_datasets::SCHEMES.join(", "));
    }
    let ds = pmon_datasets::open_with(spec, opts).map_err(|e| anyhow::anyhow!("{e}"))?;
    check::print_warnings(&ds);
    if let Some(note) = ds.roi_note() {
        eprintln!("region of interest: {note}");
    }
    if ds.frames.is_empty() {
        anyhow::bail!("{spec}: no frames: nothing to convert");
    }
    let dir = output::OutputDir::prepare(out, "convert", force)?;
    let meta = ds.write_recording(dir.path())?;
    let needs = check::recording_params_toml(ds.info.ground_z_m, ds.info.format.ego_footprint_m());
    let params_path = dir.path().join(check::RECORDING_PARAMS);
    std::fs::write(&params_path, needs).with_context(|| format!("cannot write {}", params_path.display()))?;
    dir.commit()?;
    eprintln!(
        "wrote {}: {} frames from {spec} (ground at z = {:.2} m and the ego footprint in {}/{}, applied by check and view)",
        out.display(),
        meta.frames,
        ds.info.ground_z_m,
        out.display(),
        check::RECORDING_PARAMS
    );
    Ok(ExitCode::SUCCESS)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Reproduce(args) => reproduce::run(&args),
        Command::Evaluate(args) => evaluate::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Check(args) => check::run(&args),
        Command::View(args) => view::run(&args),
        Command::Bench {
            json,
            iterations,
            max_seconds_per_case,
            worst_case,
            no_real_data,
            rasterizer,
            only,
            export_peers,
            split,
            columns,
            rules,
            params,
            kitti_whole_grid,
            no_machine_reference,
            no_cpu_time,
        } => {
            let params = match params.as_deref().map(|p| config::described_params(Some(p))).transpose() {
                Ok(p) => p,
                Err(e) => {
                    eprintln!("pmon: error: {}", error_chain(&e));
                    return ExitCode::from(2);
                }
            };
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
                only,
                split,
                columns,
                rules,
                params,
                kitti_whole_grid,
                no_machine_reference,
                no_cpu_time,
            };
            if let Some(dir) = export_peers {
                return match pmon_bench::peers::export_peers(&dir, &opts) {
                    Ok(cases) => {
                        for c in cases {
                            println!("{}\t{}\t{} frames\t{} boxes", c.name, c.dir.display(), c.frames, c.boxes);
                        }
                        ExitCode::SUCCESS
                    }
                    Err(e) => {
                        eprintln!("error: {e}");
                        ExitCode::from(2)
                    }
                };
            }
            pmon_bench::run_bench(&opts).map_err(anyhow::Error::from).and_then(|r| {
                if json {
                    println!("{}", serde_json::to_string_pretty(&r)?);
                } else {
                    print!("{}", r.to_table());
                }
                Ok(ExitCode::SUCCESS)
            })
        }
        Command::Convert { spec, out, format: bag::ConvertFormat::Mcap, .. } => bag::convert_mcap(&spec, &out),
        Command::Convert { spec, out, force, roi, sidewalk_m, grid_size_m, .. } => {
            convert(&spec, &out, force, &check::read_options(roi, sidewalk_m, grid_size_m))
        }
        Command::TrackerBed(args) => tracker_bed::run(&args),
        Command::Ros2(args) => ros2::run(&args),
        Command::Calibrate(args) => calibrate::run(&args),
        Command::Params { params } => config::print_params(params.as_deref()).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(e) if is_broken_pipe(&e) => ExitCode::from(EXIT_BROKEN_PIPE),
        Err(e) => {
            eprintln!("pmon: error: {}", error_chain(&e));
            ExitCode::from(2)
        }
    }
}

/// Exit status when the reader of standard output went away (`pmon check | head`): quiet, as a program ended by
/// SIGPIPE reports it in the shell.
const EXIT_BROKEN_PIPE: u8 = 141;

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    let pipe = Some(std::io::ErrorKind::BrokenPipe);
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>().map(std::io::Error::kind) == pipe
            || c.downcast_ref::<serde_json::Error>().and_then(serde_json::Error::io_error_kind) == pipe
    })
}

/// The error and its causes, each said once: a cause whose text the message already holds (an OS error that a
/// reader's error repeats) is not printed again.
fn error_chain(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !msg.contains(&c) {
            msg.push_str(": ");
            msg.push_str(&c);
        }
    }
    msg
}
