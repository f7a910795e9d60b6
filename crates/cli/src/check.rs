//! `pmon check`: run the monitor over a recording and report.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use pmon_datasets::roi::{RoiMode, RoiOptions};
use pmon_datasets::ReadOptions;
use pmon_monitor::{
    ClusterReport, FrameReport, Monitor, MonitorParams, MotionOutcome, MotionVerdict, NotMonitoredReason, ObjectReport,
    ObjectState, PositionCause, SensorVerdict, Verdict,
};
use pmon_recording::{RecordedFrame, RecordingReader};
use serde::Serialize;

use crate::config::load_params_over;
use crate::output::OutputFile;

/// Output format of `pmon check`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// A readable per-frame alarm summary and totals.
    Text,
    /// One JSON record per object and frame, one per missed object, and one per cluster the region of interest
    /// excused (`outside_roi`, with its reason).
    Jsonl,
}

/// A family of checks (`pmon check --checks`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CheckKind {
    /// The sensor checks (LiDAR evidence in the occupancy grid).
    Sensor,
    /// The plausibility checks (motion).
    Motion,
}

/// An object's report with the switched-off checks' verdicts replaced by `not_monitored(check_disabled)`, and
/// the combined verdict recomputed (a reason of the check that ran is kept over `check_disabled`).
fn with_checks(mut r: ObjectReport, sensor: bool, motion: bool) -> ObjectReport {
    let off = NotMonitoredReason::CheckDisabled;
    if !sensor {
        r.sensor.verdict = SensorVerdict::NotMonitored(off);
    }
    if !motion {
        r.motion = MotionOutcome::not_monitored(off);
    }
    r.verdict = match (Verdict::combine(r.sensor.verdict, r.motion.verdict), r.sensor.verdict, r.motion.verdict) {
        (Verdict::NotMonitored(_), SensorVerdict::NotMonitored(s), _) if s != off => Verdict::NotMonitored(s),
        (Verdict::NotMonitored(_), _, MotionVerdict::NotMonitored(m)) if m != off => Verdict::NotMonitored(m),
        (v, _, _) => v,
    };
    r
}

/// Arguments of `pmon check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// A pmon recording directory, a `.jsonl` file of object lists (plausibility checks only), or a dataset
    /// as `kitti:DIR`, `kitti-tracking:FILE`, `nuscenes:DIR`, `nuscenes-v1:DIR[#scene]`, `av2:LOG_DIR` or
    /// `commonroad:FILE.xml` (see docs/datasets.md).
    pub recording: PathBuf,
    /// Monitor parameters (TOML), or a profile pmon ships (`profile:recall`: three opt-in rules that find more
    /// small displacements, at a measured price; README); defaults to the paper's Table I. See `pmon params`.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    /// Write the output to this file instead of standard output.
    #[arg(long, short)]
    pub out: Option<PathBuf>,
    /// In text format, also list frames without alarms.
    #[arg(long)]
    pub all_frames: bool,
    /// Replace `--out` even when it is a file pmon did not write.
    #[arg(long)]
    pub force: bool,
    /// Which checks run, comma-separated: `sensor`, `motion` (default: both). A check switched off gives
    /// `not_monitored(check_disabled)` for every object.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [CheckKind::Sensor, CheckKind::Motion])]
    pub checks: Vec<CheckKind>,
    /// Region of interest for a dataset spec: `auto` (the dataset's map where it has one, the Argoverse 2 vector
    /// map; else the whole grid), `none` (the whole grid) or `corridor:<width_m>` (a band of that width around
    /// the ego's path over the log). See docs/datasets.md.
    #[arg(long, default_value = "auto", value_parser = parse_roi)]
    pub roi: RoiMode,
    /// Width of the sidewalk band added along a map's drivable areas, metres.
    #[arg(long, default_value_t = pmon_datasets::av2_map::DEFAULT_SIDEWALK_WIDTH_M, value_parser = parse_width)]
    pub sidewalk_m: f64,
    /// Options for a rosbag2 `.mcap` input (docs/ros2.md).
    #[command(flatten)]
    pub bag: crate::bag::BagArgs,
}

/// `--roi` values.
pub fn parse_roi(s: &str) -> Result<RoiMode, String> {
    s.parse()
}

/// `--sidewalk-m` values: finite, in `[0, 50]` m.
pub fn parse_width(s: &str) -> Result<f64, String> {
    let w: f64 = s.parse().map_err(|_| format!("`{s}` is not a number of metres"))?;
    if w.is_finite() && (0.0..=50.0).contains(&w) {
        Ok(w)
    } else {
        Err(format!("`{s}`: the sidewalk width must be in [0, 50] m"))
    }
}

/// Reader options for a dataset spec: the ROI mode and sidewalk width, clipped to the monitor's grid.
#[must_use]
pub fn read_options(roi: RoiMode, sidewalk_m: f64, grid_size_m: f32) -> ReadOptions {
    ReadOptions {
        roi: RoiOptions { mode: roi, sidewalk_width_m: sidewalk_m, grid_half_extent_m: 0.5 * f64::from(grid_size_m) },
        ground: pmon_datasets::ground::GroundMode::Auto,
        ..ReadOptions::default()
    }
}

#[derive(Serialize)]
struct ObjectRecord<'a> {
    frame: u64,
    timestamp_s: f64,
    id: u64,
    class: &'a str,
    verdict: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    conditions: Option<String>,
    /// For a position error, which test found it (`displaced_evidence`, `seen_through`, ...).
    #[serde(skip_serializing_if = "Option::is_none")]
    position_cause: Option<&'static str>,
    sensor: String,
    motion: String,
    eta: f32,
    margin_length_m: f32,
    margin_width_m: f32,
    visible_fraction: f32,
    offset_m: [f32; 2],
    dt_s: f64,
    accel_mps2: f32,
    accel_margin_mps2: f32,
    turn_rate_radps: f32,
    turn_rate_margin_radps: f32,
    predicted_world_m: [f64; 2],
    predicted_margin_m: [f32; 2],
    position_residual_m: f32,
    position_allowance_m: f32,
    /// What is wrong (implausible motion only): speed_inconsistent, heading_flip, position_jump, acceleration,
    /// turn_rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    kind: Option<&'static str>,
    /// Estimated error size in the kind's unit (`error_unit`).
    #[serde(skip_serializing_if = "Option::is_none")]
    error_size: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    error_unit: Option<&'static str>,
    /// Error size over the safety-critical size (1 m, 3 m/s): >= 1 is safety-critical.
    #[serde(skip_serializing_if = "Option::is_none")]
    severity: Option<f32>,
}

/// The last JSONL record: the run's totals (`"record": "totals"`; object and missed-object records have no
/// `record` key).
#[derive(Serialize)]
struct TotalsRecord<'a> {
    record: &'static str,
    name: &'a str,
    frames: u64,
    object_states: u64,
    frames_with_alarms: u64,
    missed_objects: u64,
    verdicts: &'a BTreeMap<String, u64>,
    /// The position errors by the test that found them (`position_cause`).
    position_causes: &'a BTreeMap<&'static str, u64>,
    written_by: &'static str,
}

/// A cluster record: a missed object (`verdict: "missed_object"`, no `reason`) or a cluster the region of
/// interest excused (`verdict: "outside_roi"`, `reason`: `no_return_in_roi` or `grazing`; not an alarm).
#[derive(Serialize)]
struct ClusterRecord {
    frame: u64,
    timestamp_s: f64,
    verdict: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<&'static str>,
    centroid_m: [f32; 2],
    bounds_m: [f32; 4],
    cells: u32,
}

fn cluster_record(f: &RecordedFrame, c: &ClusterReport) -> ClusterRecord {
    let missed = c.is_missed_object();
    ClusterRecord {
        frame: f.index,
        timestamp_s: f.timestamp_s,
        verdict: if missed { "missed_object" } else { "outside_roi" },
        reason: (!missed).then(|| c.roi.name()),
        centroid_m: c.centroid_m,
        bounds_m: c.bounds_m,
        cells: c.cells,
    }
}

fn object_record<'a>(f: &RecordedFrame, o: &'a ObjectState, r: &ObjectReport) -> ObjectRecord<'a> {
    ObjectRecord {
        frame: f.index,
        timestamp_s: f.timestamp_s,
        id: r.id,
        class: o.class.name(),
        verdict: r.verdict.name(),
        reason: r.verdict.not_monitored_reason().map(NotMonitoredReason::name),
        conditions: match r.verdict {
            Verdict::ImplausibleMotion(c) => Some(c.to_string()),
            _ => None,
        },
        position_cause: r.sensor.position_cause.map(PositionCause::name),
        sensor: r.sensor.verdict.to_string(),
        motion: r.motion.verdict.to_string(),
        eta: r.sensor.eta,
        margin_length_m: r.sensor.margin_length_m,
        margin_width_m: r.sensor.margin_width_m,
        visible_fraction: r.sensor.visible_fraction,
        offset_m: r.sensor.offset_m,
        dt_s: r.motion.dt_s,
        accel_mps2: r.motion.accel_mps2,
        accel_margin_mps2: r.motion.accel_margin_mps2,
        turn_rate_radps: r.motion.turn_rate_radps,
        turn_rate_margin_radps: r.motion.turn_rate_margin_radps,
        predicted_world_m: r.motion.predicted_world_m,
        predicted_margin_m: r.motion.predicted_margin_m,
        position_residual_m: r.motion.position_residual_m,
        position_allowance_m: r.motion.position_allowance_m,
        kind: r.motion.kind.map(|k| k.name()),
        error_size: r.motion.kind.map(|_| r.motion.error_size),
        error_unit: r.motion.kind.map(|k| k.unit()),
        severity: r.motion.kind.map(|_| r.motion.severity),
    }
}

/// Totals over a run.
#[derive(Default)]
struct Totals {
    frames: u64,
    objects: u64,
    verdicts: BTreeMap<String, u64>,
    /// Position errors by the test that found them.
    position_causes: BTreeMap<&'static str, u64>,
    /// Implausible motion by kind: (alarms, of those safety-critical).
    kinds: BTreeMap<&'static str, (u64, u64)>,
    missed_objects: u64,
    /// Clusters the region of interest excused (outside it, attributed to no object): no return in it, grazing.
    outside_roi: [u64; 2],
    /// Frames whose sensor checks ran with a region of interest.
    roi_frames: u64,
    frames_with_alarms: u64,
    /// Frames whose sensor checks ran (with a cloud).
    sensor_frames: u64,
}

fn describe_alarm(o: &ObjectState, r: &ObjectReport) -> String {
    let what = match r.verdict {
        Verdict::Ghost => format!("ghost (eta {:.2}, footprint {:.0} % visible)", r.sensor.eta, 100.0 * r.sensor.visible_fraction),
        Verdict::PositionError => format!(
            "position error (eta {:.2}, evidence {:.2} m away{})",
            r.sensor.eta,
            r.sensor.offset_m[0].hypot(r.sensor.offset_m[1]),
            r.sensor.position_cause.map_or(String::new(), |c| format!(": {}", c.description()))
        ),
        Verdict::ImplausibleMotion(_) if r.motion.kind.is_some() => {
            let k = r.motion.kind.map_or("", |k| k.name());
            let unit = r.motion.kind.map_or("", |k| k.unit());
            format!(
                "implausible motion: {k} {:+.2} {unit} ({}, {:.1}x the safety-critical size); position off by {:.2} m (allowed {:.2}), a {:+.1} m/s²",
                r.motion.error_size,
                if r.motion.severity >= 1.0 { "critical" } else { "below critical" },
                r.motion.severity,
                r.motion.position_residual_m,
                r.motion.position_allowance_m,
                r.motion.accel_mps2,
            )
        }
        Verdict::ImplausibleMotion(c) => format!(
            "implausible motion [{c}]: a {:+.1}±{:.1} m/s², ω {:+.2}±{:.2} rad/s, position off by {:.2} m (allowed {:.2})",
            r.motion.accel_mps2,
            r.motion.accel_margin_mps2,
            r.motion.turn_rate_radps,
            r.motion.turn_rate_margin_radps,
            r.motion.position_residual_m,
            r.motion.position_allowance_m
        ),
        other => other.to_string(),
    };
    format!("{} {} at ({:.1}, {:.1}) m: {what}", o.class.name(), r.id, o.x_m, o.y_m)
}

fn write_text_frame(out: &mut dyn Write, f: &RecordedFrame, rep: &FrameReport<'_>, all: bool) -> io::Result<()> {
    let alarms: Vec<_> = f.objects.iter().zip(rep.objects).filter(|(_, r)| r.verdict.is_alarm()).collect();
    let missed: Vec<_> = rep.clusters.iter().filter(|c| c.is_missed_object()).collect();
    if alarms.is_empty() && missed.is_empty() && !all {
        return Ok(());
    }
    let sensor = rep.sensor_status.map_or_else(
        || format!("{} points, {} in band", rep.grid.points_total, rep.grid.points_in_band),
        |r| format!("sensor checks not run: {r}"),
    );
    writeln!(
        out,
        "frame {:>5}  t={:>9.3} s  {} objects, {} alarms, {} missed  ({sensor})",
        f.index,
        f.timestamp_s,
        f.objects.len(),
        alarms.len(),
        missed.len()
    )?;
    for (o, r) in alarms {
        writeln!(out, "    ALARM  {}", describe_alarm(o, r))?;
    }
    for c in missed {
        writeln!(
            out,
            "    ALARM  missed object: {} unexplained cells around ({:.1}, {:.1}) m",
            c.cells, c.centroid_m[0], c.centroid_m[1]
        )?;
    }
    Ok(())
}

/// The verdict counted in the text summary. Without LiDAR the sensor checks judge nothing, so an object outside
/// their grid is not monitored for the plausibility checks' reason (issue #11: a track's first frame without
/// LiDAR read `outside_grid`, which says nothing about a frame that has no sensor data at all).
fn summary_verdict(sensor_status: Option<pmon_monitor::NotMonitoredReason>, r: &ObjectReport) -> Verdict {
    use pmon_monitor::{MotionVerdict, NotMonitoredReason};
    match (sensor_status, r.verdict, r.motion.verdict) {
        (
            Some(NotMonitoredReason::NoLidarData),
            Verdict::NotMonitored(NotMonitoredReason::OutsideGrid),
            MotionVerdict::NotMonitored(m),
        ) => Verdict::NotMonitored(m),
        (_, v, _) => v,
    }
}

/// Frames from a recording or a dataset, and the parameters the input itself needs.
pub struct Input {
    /// The frames, in order.
    pub iter: Box<dyn Iterator<Item = Result<RecordedFrame>>>,
    /// The defaults with what this input needs on top: a dataset's ground height and ego footprint, or a
    /// converted recording's `params.toml`. A `--params` file goes over these (see [`Input::params`]).
    pub base_params: MonitorParams,
    /// Where a dataset's region of interest comes from (`None` for pmon recordings, whose frames carry theirs).
    pub roi_note: Option<String>,
}

impl Input {
    /// The parameters to check this input with: `--params` (any subset of keys) over [`Input::base_params`].
    pub fn params(&self, file: Option<&Path>) -> Result<MonitorParams> {
        load_params_over(self.base_params, file)
    }
}

/// Name of the parameter file a recording may carry (written by `pmon convert`): the settings its source needs.
pub const RECORDING_PARAMS: &str = "params.toml";

/// The `params.toml` `pmon convert` writes into a recording: what `check` applies for that dataset.
pub fn recording_params_toml(ground_z_m: f32, ego_footprint_m: [f32; 4]) -> String {
    let [a, b, c, d] = ego_footprint_m;
    format!(
        "# Written by pmon convert: the settings pmon check applies for this recording's source dataset.\n\
         # pmon check and pmon view load this file; a --params file goes over it.\n\
         ground_z_m = {ground_z_m:?}\nego_footprint_m = [{a:?}, {b:?}, {c:?}, {d:?}]\n"
    )
}

/// Says on stderr what a dataset reader substituted (a nominal calibration, ...).
pub fn print_warnings(ds: &pmon_datasets::Dataset) {
    for n in ds.info.notes.iter().filter(|n| n.starts_with(pmon_datasets::WARNING_PREFIX)) {
        eprintln!("pmon: {n}");
    }
}

/// Opens a pmon recording (directory or `.jsonl`) or a dataset spec `scheme:path`.
pub fn open_input(arg: &Path, opts: &ReadOptions) -> Result<(String, Input)> {
    let text = arg.to_string_lossy();
    if let Some((scheme, _)) = text.split_once(':') {
        if pmon_datasets::SCHEMES.contains(&scheme) {
            let ds = pmon_datasets::open_with(&text, opts).map_err(|e| anyhow::anyhow!("{e}"))?;
            let roi_note = ds.roi_note().map(str::to_string);
            print_warnings(&ds);
            let base_params = MonitorParams {
                ground_z_m: ds.info.ground_z_m,
                ego_footprint_m: ds.info.format.ego_footprint_m(),
                ..MonitorParams::default()
            };
            let name = ds.info.name.clone();
            let iter = ds.frames.into_iter().map(|f| Ok(f.frame));
            return Ok((name, Input { iter: Box::new(iter), base_params, roi_note }));
        }
        // `C:\...` on Windows and a plain path with a colon that exists are paths, not schemes.
        if !arg.exists() && scheme.len() > 1 && scheme.chars().all(|c| c.is_ascii_alphanumeric() || c == '-') {
            anyhow::bail!(
                "{text}: unknown dataset prefix `{scheme}:` (known: {}), and no such file or folder",
                pmon_datasets::SCHEMES.join(", ")
            );
        }
    }
    if arg == Path::new("-") {
        let reader = RecordingReader::from_reader(Box::new(io::stdin().lock()), Path::new("<stdin>"))?;
        let name = reader.meta.name.clone();
        let iter = Box::new(reader.map(|f| f.map_err(anyhow::Error::from)));
        return Ok((name, Input { iter, base_params: MonitorParams::default(), roi_note: None }));
    }
    let reader = RecordingReader::open(arg)?;
    let name = reader.meta.name.clone();
    let mut base_params = MonitorParams::default();
    let sidecar = arg.join(RECORDING_PARAMS);
    if arg.is_dir() && sidecar.is_file() {
        base_params = load_params_over(base_params, Some(&sidecar))?;
        eprintln!("pmon: using {} (the settings the recording's source needs)", sidecar.display());
    }
    Ok((name, Input { iter: Box::new(reader.map(|f| f.map_err(anyhow::Error::from))), base_params, roi_note: None }))
}

/// `pmon check`.
pub fn run(args: &CheckArgs) -> Result<ExitCode> {
    if crate::bag::is_mcap(&args.recording) {
        return crate::bag::run_check(args);
    }
    // The ROI of a dataset is clipped to the grid: its size comes from --params (any subset of keys).
    let grid_size_m = crate::config::load_params_over(MonitorParams::default(), args.params.as_deref())?.grid_size_m;
    let opts = read_options(args.roi, args.sidewalk_m, grid_size_m);
    let (name, frames) = open_input(&args.recording, &opts)?;
    if let (Some(note), Format::Jsonl) = (&frames.roi_note, args.format) {
        eprintln!("region of interest: {note}");
    }
    let params = frames.params(args.params.as_deref())?;
    let mut monitor = Monitor::new(params).map_err(|e| anyhow::anyhow!("{e}"))?;
    let out_file = match &args.out {
        Some(p) => Some(OutputFile::prepare(p, "check", args.force)?),
        None => None,
    };
    let mut out: Box<dyn Write> = match &out_file {
        Some(f) => Box::new(BufWriter::new(
            File::create(f.path()).with_context(|| format!("cannot create {}", f.path().display()))?,
        )),
        None => Box::new(BufWriter::new(io::stdout().lock())),
    };
    let mut totals = Totals::default();
    let frames_roi_note = frames.roi_note;
    let sensor_on = args.checks.contains(&CheckKind::Sensor);
    let motion_on = args.checks.contains(&CheckKind::Motion);
    let mut adjusted: Vec<ObjectReport> = Vec::new();
    for frame in frames.iter {
        let mut frame = frame?;
        if !sensor_on {
            frame.cloud = None;
        }
        let mut polygons = Vec::new();
        let view = frame.as_frame(&mut polygons);
        let mut rep = monitor.check(&view).map_err(|e| anyhow::anyhow!("frame {}: {e}", frame.index))?;
        if !(sensor_on && motion_on) {
            adjusted.clear();
            adjusted.extend(rep.objects.iter().map(|r| with_checks(*r, sensor_on, motion_on)));
            rep.objects = &adjusted;
            if !sensor_on {
                rep.sensor_status = Some(NotMonitoredReason::CheckDisabled);
            }
        }
        totals.frames += 1;
        if rep.sensor_status.is_none() {
            totals.sensor_frames += 1;
        }
        totals.objects += rep.objects.len() as u64;
        if rep.sensor_status.is_none() && !frame.roi_in_ego.is_empty() {
            totals.roi_frames += 1;
        }
        for (total, n) in totals.outside_roi.iter_mut().zip(rep.outside_roi_counts()) {
            *total += n as u64;
        }
        let missed = rep.missed_objects() as u64;
        totals.missed_objects += missed;
        if rep.object_alarms() > 0 || missed > 0 {
            totals.frames_with_alarms += 1;
        }
        for r in rep.objects {
            *totals.verdicts.entry(summary_verdict(rep.sensor_status, r).to_string()).or_default() += 1;
            if let (Verdict::PositionError, Some(c)) = (r.verdict, r.sensor.position_cause) {
                *totals.position_causes.entry(c.name()).or_default() += 1;
            }
            if let (Verdict::ImplausibleMotion(_), Some(k)) = (r.verdict, r.motion.kind) {
                let e = totals.kinds.entry(k.name()).or_default();
                e.0 += 1;
                e.1 += u64::from(r.motion.severity >= 1.0);
            }
        }
        match args.format {
            Format::Text => write_text_frame(&mut *out, &frame, &rep, args.all_frames)?,
            Format::Jsonl => {
                for (o, r) in frame.objects.iter().zip(rep.objects) {
                    serde_json::to_writer(&mut *out, &object_record(&frame, o, r))?;
                    writeln!(out)?;
                }
                // The missed objects, then the clusters the region of interest excused, each with its reason.
                let missed = rep.clusters.iter().filter(|c| c.is_missed_object());
                for c in missed.chain(rep.clusters.iter().filter(|c| c.is_outside_roi())) {
                    serde_json::to_writer(&mut *out, &cluster_record(&frame, c))?;
                    writeln!(out)?;
                }
            }
        }
    }
    if totals.frames == 0 {
        anyhow::bail!("{}: no frames: an empty input cannot be checked", args.recording.display());
    }
    if args.format == Format::Text {
        write!(
            out,
            "\n{name}: {} frames, {} object states, {} frames with alarms, {} missed-object alarms",
            totals.frames, totals.objects, totals.frames_with_alarms, totals.missed_objects
        )?;
        if totals.roi_frames > 0 {
            let [none, grazing] = totals.outside_roi;
            write!(
                out,
                "; {} clusters outside the region of interest (not alarms): {none} without a return in it, {grazing} grazing",
                none + grazing
            )?;
        }
        writeln!(out)?;
        if let Some(note) = &frames_roi_note {
            writeln!(out, "  region of interest: {note}")?;
        }
        if totals.sensor_frames > 0 {
            writeln!(
                out,
                "  missed-object alarms per frame with a LiDAR sweep: {:.1} ({} frames)",
                totals.missed_objects as f64 / totals.sensor_frames as f64,
                totals.sensor_frames
            )?;
        }
        for (k, v) in &totals.verdicts {
            let share = 100.0 * *v as f64 / totals.objects.max(1) as f64;
            writeln!(out, "  {k:<45} {v:>8}  {share:>5.1} %")?;
        }
        if !totals.position_causes.is_empty() {
            writeln!(out, "position errors by the test that found them (docs/cli.md):")?;
            for (k, n) in &totals.position_causes {
                writeln!(out, "  {k:<45} {n:>8}")?;
            }
        }
        if !totals.kinds.is_empty() {
            writeln!(out, "implausible motion by kind (alarms, of those safety-critical):")?;
            for (k, (n, crit)) in &totals.kinds {
                writeln!(out, "  {k:<45} {n:>8}  {crit:>8}")?;
            }
        }
    }
    if args.format == Format::Jsonl {
        let rec = TotalsRecord {
            record: "totals",
            name: &name,
            frames: totals.frames,
            object_states: totals.objects,
            frames_with_alarms: totals.frames_with_alarms,
            missed_objects: totals.missed_objects,
            verdicts: &totals.verdicts,
            position_causes: &totals.position_causes,
            written_by: "pmon check (pmon-output)",
        };
        serde_json::to_writer(&mut *out, &rec)?;
        writeln!(out)?;
    } else if out_file.is_some() {
        writeln!(out, "(written by pmon check; {})", crate::output::FILE_TAG)?;
    }
    out.flush()?;
    drop(out);
    if let Some(f) = out_file {
        f.commit()?;
    }
    Ok(if totals.frames_with_alarms > 0 { ExitCode::from(1) } else { ExitCode::SUCCESS })
}

#[cfg(test)]
mod tests {
    use pmon_monitor::{Frame, Monitor, MonitorParams, NotMonitoredReason, ObjectClass, ObjectState, Pose2, Verdict};

    #[test]
    fn issue_11_first_frame_without_lidar_is_summarised_as_first_frame_of_track() {
        // A world-frame object list without LiDAR: the object lies far outside the grid around the origin.
        let mut m = Monitor::new(MonitorParams::default()).unwrap();
        let o = ObjectState {
            id: 1,
            class: ObjectClass::Car,
            x_m: 500.0,
            y_m: 300.0,
            heading_rad: 0.0,
            speed_mps: 0.0,
            length_m: 4.5,
            width_m: 1.8,
            uncertainty: None,
        };
        let objects = [o];
        let f = Frame {
            timestamp_s: 0.0,
            world_from_ego: Pose2::default(),
            objects: &objects,
            cloud: None,
            roi_in_ego: &[],
            static_in_ego: &[],
        };
        let rep = m.check(&f).unwrap();
        let v = super::summary_verdict(rep.sensor_status, &rep.objects[0]);
        assert_eq!(v, Verdict::NotMonitored(NotMonitoredReason::FirstFrameOfTrack));
        assert_eq!(v.to_string(), "not_monitored(first_frame_of_track)");
    }
}
