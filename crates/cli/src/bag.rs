//! `pmon check bag.mcap` (a rosbag2 MCAP) and `pmon convert ... --format mcap`: the CLI side of `pmon-ros`.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use pmon_ros::bag::{check_bag, check_mcap, read_file, BagConfig, BagSummary};
use pmon_ros::msg::Time;

use crate::check::{CheckArgs, Format};
use crate::config::load_params;

/// Options of `pmon check` for rosbag2 MCAP input (defaults: Autoware's topic names).
#[derive(Args, Debug, Clone)]
pub struct BagArgs {
    /// Bag input: the `sensor_msgs/PointCloud2` topic.
    #[arg(long, default_value = "/sensing/lidar/concatenated/pointcloud")]
    pub cloud_topic: String,
    /// Bag input: the `autoware_perception_msgs/TrackedObjects` (or `DetectedObjects`) topic.
    #[arg(long, default_value = "/perception/object_recognition/tracking/objects")]
    pub objects_topic: String,
    /// Bag input: the ego `nav_msgs/Odometry` topic (`/tf` map -> base_link is used when it has none).
    #[arg(long, default_value = "/localization/kinematic_state")]
    pub odometry_topic: String,
    /// Bag input: the ego frame.
    #[arg(long, default_value = "base_link")]
    pub ego_frame: String,
    /// Bag input: the world frame of the ego pose.
    #[arg(long, default_value = "map")]
    pub world_frame: String,
    /// Bag input: largest |object stamp - cloud stamp| for a pairing, seconds.
    #[arg(long, default_value_t = 0.05)]
    pub pairing_tolerance_s: f64,
    /// Bag input: also draw a top view of this frame (object list number, from 0) into `--view-out`.
    #[arg(long, requires = "view_out")]
    pub view_frame: Option<u64>,
    /// Bag input: the top view image (`.png` or `.svg`).
    #[arg(long)]
    pub view_out: Option<std::path::PathBuf>,
}

impl BagArgs {
    /// The library's configuration.
    #[must_use]
    pub fn config(&self) -> BagConfig {
        BagConfig {
            cloud_topic: self.cloud_topic.clone(),
            objects_topic: self.objects_topic.clone(),
            odometry_topic: self.odometry_topic.clone(),
            ego_frame: self.ego_frame.clone(),
            world_frame: self.world_frame.clone(),
            pairing_tolerance_s: self.pairing_tolerance_s,
            ..BagConfig::default()
        }
    }
}

/// True for a path that names an MCAP file.
#[must_use]
pub fn is_mcap(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

fn stamps(v: &[Time]) -> String {
    let shown: Vec<String> = v.iter().take(10).map(|t| format!("{:.3}", t.as_secs_f64())).collect();
    let more = if v.len() > 10 { format!(", ... ({} more)", v.len() - 10) } else { String::new() };
    format!("{}{more}", shown.join(", "))
}

pub fn write_summary(out: &mut dyn Write, name: &str, s: &BagSummary) -> io::Result<()> {
    writeln!(
        out,
        "\n{name}: {} frames (object lists), {} clouds, {} object states, {} frames with alarms, {} missed-object alarms",
        s.frames, s.clouds, s.objects, s.frames_with_alarms, s.missed_objects
    )?;
    for (k, v) in &s.verdicts {
        let share = 100.0 * *v as f64 / s.objects.max(1) as f64;
        writeln!(out, "  {k:<45} {v:>8}  {share:>5.1} %")?;
    }
    writeln!(out, "object lists without a cloud (plausibility only): {}", s.unpaired_object_lists.len())?;
    if !s.unpaired_object_lists.is_empty() {
        writeln!(out, "  at t = {} s", stamps(&s.unpaired_object_lists))?;
    }
    writeln!(out, "clouds without an object list: {}", s.unpaired_clouds.len())?;
    if !s.unpaired_clouds.is_empty() {
        writeln!(out, "  at t = {} s", stamps(&s.unpaired_clouds))?;
    }
    writeln!(out, "problems: {} ({} undecodable messages)", s.problems.len(), s.undecodable)?;
    for p in &s.problems {
        writeln!(out, "  {} @ {:.3} s: {}", p.topic, p.log_time_ns as f64 * 1e-9, p.message)?;
    }
    Ok(())
}

/// `pmon check bag.mcap`: text or JSON lines (one `pmon_msgs/FrameVerdicts` per line), or an MCAP of results
/// when `--out` ends in `.mcap`.
pub fn run_check(args: &CheckArgs) -> Result<ExitCode> {
    let params = load_params(args.params.as_deref())?;
    let cfg = args.bag.config();
    let path = args.recording.as_path();
    let bytes = read_file(path)?;
    // Before any output is created: every length in the bag fits its record (issue 15).
    check_mcap(path, &bytes)?;
    let mut text: Box<dyn Write> = match &args.out {
        Some(p) if !is_mcap(p) => {
            Box::new(BufWriter::new(File::create(p).with_context(|| format!("cannot create {}", p.display()))?))
        }
        _ => Box::new(BufWriter::new(io::stdout().lock())),
    };
    let mut mcap_out = match &args.out {
        Some(p) if is_mcap(p) => {
            let mut w = pmon_ros::output::ResultWriter::create(p, &bytes, &params)?;
            w.set_ego_frame(&cfg.ego_frame);
            Some(w)
        }
        _ => None,
    };
    let format = args.format;
    let all = args.all_frames;
    let view = args.bag.view_frame.zip(args.bag.view_out.clone());
    let mut sink = |f: &pmon_ros::bag::CheckedFrame<'_>| -> std::result::Result<(), String> {
        if let Some((n, img)) = &view {
            if f.frame.index == *n {
                let checked = crate::view::Checked {
                    frame: f.frame,
                    objects: f.report.objects,
                    clusters: f.report.clusters,
                    injections: &[],
                };
                let title = format!("{} object list {n} (t = {:.2} s)", path.display(), f.frame.timestamp_s);
                let picture = crate::view::top_view(&title, f.monitor, &checked, (0.0, 0.0), 30.0);
                crate::view::write_view(&picture, img).map_err(|e| format!("{e:#}"))?;
            }
        }
        if let Some(w) = mcap_out.as_mut() {
            w.frame(f).map_err(|e| e.to_string())?;
        }
        let v = f.verdicts;
        let io = |e: io::Error| e.to_string();
        match format {
            Format::Jsonl => {
                serde_json::to_writer(&mut text, v).map_err(|e| e.to_string())?;
                writeln!(text).map_err(io)?;
            }
            Format::Text => {
                let alarms: Vec<_> = v.objects.iter().filter(|o| matches!(o.verdict, 1..=3)).collect();
                if alarms.is_empty() && v.missed.is_empty() && !all {
                    return Ok(());
                }
                let sensor = if v.sensor_status.is_empty() {
                    format!("{} points, {} in band", v.points_total, v.points_in_band)
                } else {
                    format!("sensor checks not run: {}", v.sensor_status)
                };
                writeln!(
                    text,
                    "t={:>14.3} s  {} objects, {} alarms, {} missed  ({sensor})",
                    v.header.stamp.as_secs_f64(),
                    v.objects.len(),
                    alarms.len(),
                    v.missed.len()
                )
                .map_err(io)?;
                for o in alarms {
                    writeln!(
                        text,
                        "    ALARM  object {} at ({:.1}, {:.1}) m: {} {}",
                        o.id, o.x_m, o.y_m, o.verdict_name, o.reason
                    )
                    .map_err(io)?;
                }
                for m in &v.missed {
                    writeln!(
                        text,
                        "    ALARM  missed object: {} cells around ({:.1}, {:.1}) m",
                        m.cells, m.centroid_m[0], m.centroid_m[1]
                    )
                    .map_err(io)?;
                }
            }
        }
        Ok(())
    };
    let summary = check_bag(path, &bytes, &cfg, &params, &mut sink)?;
    if format == Format::Text {
        write_summary(&mut *text, &path.display().to_string(), &summary)?;
    } else {
        // The pairing report still goes somewhere a person sees it.
        write_summary(&mut io::stderr().lock(), &path.display().to_string(), &summary)?;
    }
    text.flush()?;
    if let Some(w) = mcap_out {
        let p = args.out.as_deref().unwrap_or(path);
        w.finish().with_context(|| format!("cannot finish {}", p.display()))?;
    }
    Ok(if summary.undecodable > 0 {
        ExitCode::from(2)
    } else if summary.frames_with_alarms > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// `pmon convert --format`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ConvertFormat {
    /// A pmon recording directory.
    Recording,
    /// A rosbag2-style MCAP with Autoware's topics (CDR).
    Mcap,
}

/// `pmon convert SPEC --out x.mcap --format mcap`: any dataset or recording as MCAP.
pub fn convert_mcap(spec: &str, out: &Path) -> Result<ExitCode> {
    let (name, input) = crate::check::open_input(Path::new(spec), &pmon_datasets::ReadOptions::default())?;
    let default = pmon_monitor::MonitorParams::default().default_uncertainty;
    let frames = input.iter.map(|f| f.map_err(|e| format!("{e:#}")));
    let n =
        pmon_ros::write_dataset::write_frames(out, frames, &default).with_context(|| format!("converting {spec}"))?;
    eprintln!("wrote {}: {n} frames from {name} ({spec})", out.display());
    Ok(ExitCode::SUCCESS)
}
