//! # pmon-bench: how fast is the monitor on this machine?
//!
//! [`run_bench`] builds deterministic frames (a synthetic 64-beam and 32-beam LiDAR scene, object lists without a
//! cloud, the largest frame the paper parameters accept, and the real KITTI, nuScenes and Argoverse 2 sweeps of
//! the shared data when present), runs [`Monitor::check_with_stages`] on them many times on one thread, reads
//! [`Instant`] at every stage boundary, and reports per stage the median and the spread (10th and 90th
//! percentiles) in microseconds, beside the frame sizes, the machine, the paper's figures and a floor: the time
//! to read every point of the sweep once ([`frames::coordinate_sum`]).
//!
//! The `pmon bench [--json] [--iterations N]` command prints [`BenchReport::to_table`] (or the report as JSON).
//! How the figures were measured and what they mean is in `docs/performance.md`.
//!
//! Each case reuses one [`Monitor`] across its iterations, cycling through the case's frames with timestamps
//! `i * 0.1 s`; after each cycle the objects jump back to their first positions, which the plausibility checks
//! flag for that frame: in the 6-frame object-list cases `objects-N/no-cloud` on about 16 % (paper rule) and 46 %
//! (calibrated rule) of the states, the alarm-heavy worst case. The steady-traffic case [`STEADY_CASE`]
//! ([`Sequence::steady_traffic`]) cycles without a jump (0 alarms); the 5 us goal of the plausibility checks is
//! judged on it, with the worst case printed beside it.

pub mod av2;
pub mod cpu;
pub mod frames;
mod goals;
pub mod jitter;
mod machine;
pub mod native;
pub mod peers;
mod report;
mod rules;
mod table;

use std::path::{Path, PathBuf};
use std::time::Instant;

use pmon_monitor::{
    ColumnCloud, FrameError, Join, Monitor, MonitorParams, MotionVerdict, ParamError, PointColumns, Rasterizer, Stage,
};

pub use report::{
    alarm_rate, paper_figures, BenchReport, CaseReport, FrameTiming, GoalResult, PaperComparison, PaperFigure,
    StageTiming, Timing,
};
pub use rules::RuleSwitches;

pub use frames::{Sequence, SyntheticSpec};
pub use machine::{cpu_model_of, Machine};

/// One [`Monitor::check`] with the wall time of each [`Stage`] (in [`Stage::ALL`] order), microseconds. The first
/// stage includes the call's set-up, so the stages add up to the whole call.
///
/// # Errors
/// As [`Monitor::check`].
pub fn timed_check<'m>(
    monitor: &'m mut Monitor,
    frame: &pmon_monitor::Frame<'_>,
) -> Result<(pmon_monitor::FrameReport<'m>, [f64; 5]), FrameError> {
    timed_check_with(monitor, frame, None)
}

/// [`Join`] on rayon's global pool (`rayon::join`): the two halves of [`Monitor::check_split`]'s rasterize stage
/// on two threads.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayonJoin;

impl Join for RayonJoin {
    fn join(&self, a: &mut (dyn FnMut() + Send), b: &mut (dyn FnMut() + Send)) {
        rayon::join(a, b);
    }
}

/// [`timed_check`], through [`Monitor::check_split`] with `join` when given.
///
/// # Errors
/// As [`Monitor::check`].
pub fn timed_check_with<'m>(
    monitor: &'m mut Monitor,
    frame: &pmon_monitor::Frame<'_>,
    join: Option<&dyn Join>,
) -> Result<(pmon_monitor::FrameReport<'m>, [f64; 5]), FrameError> {
    timed_check_of(monitor, frame, None, join)
}

/// [`timed_check_with`] with the sweep handed over as columns ([`Monitor::check_columns`]; `frame.cloud` is
/// set to `None` for the call, as the monitor asks).
///
/// # Errors
/// As [`Monitor::check`].
pub fn timed_check_columns<'m>(
    monitor: &'m mut Monitor,
    frame: &pmon_monitor::Frame<'_>,
    cloud: &ColumnCloud<'_>,
    join: Option<&dyn Join>,
) -> Result<(pmon_monitor::FrameReport<'m>, [f64; 5]), FrameError> {
    timed_check_of(monitor, &pmon_monitor::Frame { cloud: None, ..*frame }, Some(cloud), join)
}

fn timed_check_of<'m>(
    monitor: &'m mut Monitor,
    frame: &pmon_monitor::Frame<'_>,
    columns: Option<&ColumnCloud<'_>>,
    join: Option<&dyn Join>,
) -> Result<(pmon_monitor::FrameReport<'m>, [f64; 5]), FrameError> {
    let mut marks: [Option<Instant>; 5] = [None; 5];
    let t0 = Instant::now();
    let mut on_stage = |s| {
        let now = Instant::now();
        if let Some(m) = Stage::ALL.iter().position(|x| *x == s).and_then(|k| marks.get_mut(k)) {
            *m = Some(now);
        }
    };
    let report = match (join, columns) {
        (Some(join), None) => monitor.check_split_with_stages(frame, join, &mut on_stage)?,
        (None, None) => monitor.check_with_stages(frame, &mut on_stage)?,
        (Some(join), Some(cloud)) => monitor.check_columns_split_with_stages(frame, cloud, join, &mut on_stage)?,
        (None, Some(cloud)) => monitor.check_columns_with_stages(frame, cloud, &mut on_stage)?,
    };
    let mut row = [0.0; 5];
    let mut prev = t0;
    for (slot, mark) in row.iter_mut().zip(marks) {
        let mark = mark.unwrap_or(prev);
        *slot = us(mark.saturating_duration_since(prev));
        prev = mark;
    }
    Ok((report, row))
}

/// What to measure.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// Timed checks per case, after a warm-up of one cycle through the case's frames; `>= 1`.
    pub iterations: usize,
    /// A case stops early once its timed checks have taken this long (at least 10 run), seconds.
    pub max_seconds_per_case: f64,
    /// Folder of the shared real data; `None`: `PMON_DATA_DIR`, else `<workspace>/../shared/data`.
    pub data_dir: Option<PathBuf>,
    /// Measure the real sweeps (KITTI, nuScenes, Argoverse 2) when they are present.
    pub real_data: bool,
    /// Measure the largest accepted frame (400,000 points, 1,024 objects).
    pub worst_case: bool,
    /// The rasterize loop to measure (`Blocked`, the monitor's default, picks AVX2 where the processor has it).
    pub rasterizer: Rasterizer,
    /// Measure only the cases whose name contains one of these (all cases when empty).
    pub only: Vec<String>,
    /// Rasterize sweeps of at least `pmon_monitor::split::SPLIT_MIN_POINTS` points in two halves on two
    /// threads ([`Monitor::check_split`] with [`RayonJoin`]; the same verdicts). Off: one thread.
    pub split: bool,
    /// Hand every sweep to the monitor as three columns (`x`, `y`, `z` slices, [`Monitor::check_columns`]; the
    /// same verdicts) instead of `[x, y, z]` records. The columns are made once per sweep before the timing.
    pub columns: bool,
    /// Rule keys switched on or off for the whole run (`pmon bench --seen-over`, ...; [`RuleSwitches`]), over
    /// [`Self::params`].
    pub rules: RuleSwitches,
    /// The parameters every case starts from instead of Table I (`pmon bench --params FILE|profile:NAME`), with
    /// what they are, for the report's notes; each case keeps its own `cell_size_m` and `grid_size_m`. `None`:
    /// Table I.
    pub params: Option<(MonitorParams, String)>,
    /// Check the KITTI sweeps over the whole grid instead of camera 2's field of view (the region KITTI labels and
    /// `pmon check kitti:`'s default region of interest; docs/datasets.md, "KITTI's labelled field of view").
    pub kitti_whole_grid: bool,
    /// Skip the machine's own jitter reference ([`jitter::reference`], timed after each case with a cloud, about as
    /// long as the case itself): the `machine` column shows `-` and `jitter_reference` is `None`. Off: measured.
    pub no_machine_reference: bool,
    /// Do not read this thread's CPU clock around each check ([`cpu`]; two system calls per check, outside the
    /// wall-clock marks): `check_cpu` and `jitter_reference_cpu` are `None`. Off: read (except with
    /// [`Self::split`], whose second thread this thread's clock does not see).
    pub no_cpu_time: bool,
}

impl Default for BenchOptions {
    /// 300 iterations per case, at most 2 s per case, real data and worst case included: about 10 s in a
    /// release build on a 2-core machine.
    fn default() -> Self {
        Self {
            iterations: 300,
            max_seconds_per_case: 2.0,
            data_dir: None,
            real_data: true,
            worst_case: true,
            rasterizer: Rasterizer::Blocked,
            only: Vec::new(),
            split: false,
            columns: false,
            rules: RuleSwitches::default(),
            params: None,
            kitti_whole_grid: false,
            no_machine_reference: false,
            no_cpu_time: false,
        }
    }
}

/// Why a benchmark run failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// An option out of range.
    #[error("invalid benchmark option: {0}")]
    Options(String),
    /// The monitor rejected a case's parameters (a bug in this crate).
    #[error("case `{case}`: monitor parameters rejected: {source}")]
    Params {
        /// The case.
        case: String,
        /// The monitor's reason.
        source: ParamError,
    },
    /// The monitor rejected a case's frame (a bug in this crate).
    #[error("case `{case}`: frame rejected: {source}")]
    Frame {
        /// The case.
        case: String,
        /// The monitor's reason.
        source: FrameError,
    },
    /// A real sweep is present but cannot be read.
    #[error("real data: {0}")]
    Data(String),
}

/// The grid's side for the real sweeps' cases, metres (0.5 m cells).
const REAL_GRID_SIZE_M: f32 = 100.0;

/// The steady-traffic case of the plausibility checks (30 objects, [`Sequence::steady_traffic`]); with
/// `/calibrated` appended, the calibrated rule on the same frames.
pub const STEADY_CASE: &str = "objects-30/steady";
/// Seed of the steady-traffic case's scene.
pub const STEADY_SEED: u64 = 7;

struct CaseDef<'a> {
    name: String,
    sequence: &'a Sequence,
    cell_size_m: f32,
    grid_size_m: f32,
    /// The paper's plausibility rule, or the calibrated one (docs/plausibility.md).
    calibrated: bool,
    /// Copy each frame's object list into a buffer of the bench before the timed check (as a tracker would have
    /// just written it): the long steady sequences would otherwise be read from wherever they sit in the caches.
    copy_objects: bool,
}

fn params(cell_size_m: f32, grid_size_m: f32) -> MonitorParams {
    MonitorParams { cell_size_m, grid_size_m, ..MonitorParams::PAPER }
}

/// The parameters a case starts from: [`BenchOptions::params`] (Table I when `None`) with the case's cell and grid
/// size.
fn start_params(opts: &BenchOptions, cell_size_m: f32, grid_size_m: f32) -> MonitorParams {
    let base = opts.params.as_ref().map_or(MonitorParams::PAPER, |(p, _)| *p);
    MonitorParams { cell_size_m, grid_size_m, ..base }
}

/// A case's parameters: [`start_params`] with the rule switches over them.
fn case_params(opts: &BenchOptions, cell_size_m: f32, grid_size_m: f32) -> MonitorParams {
    let mut p = start_params(opts, cell_size_m, grid_size_m);
    opts.rules.apply(&mut p);
    p
}

/// Runs the benchmarks (see the crate documentation).
///
/// # Errors
/// [`BenchError::Options`] for zero iterations or a non-positive time limit; [`BenchError::Data`] when a real
/// sweep is present but malformed; the others only on a bug.
pub fn run_bench(opts: &BenchOptions) -> Result<BenchReport, BenchError> {
    if opts.iterations == 0 {
        return Err(BenchError::Options("iterations must be at least 1".to_string()));
    }
    if !(opts.max_seconds_per_case.is_finite() && opts.max_seconds_per_case > 0.0) {
        return Err(BenchError::Options("max_seconds_per_case must be finite and > 0".to_string()));
    }
    let machine = Machine::current(opts.rasterizer);
    let mut notes = Vec::new();
    if !machine.optimized_build {
        notes.push("DEBUG BUILD: figures are not representative; build with --release".to_string());
    }
    if opts.split {
        notes.push(format!(
            "--split: sweeps of at least {} points are rasterized in two halves on two threads (Monitor::check_split, \
             rayon); the figures are wall time on two cores, not the one-core figures of the goals",
            pmon_monitor::split::SPLIT_MIN_POINTS
        ));
    }

    if opts.columns {
        notes.push(
            "--columns: every sweep is handed over as three columns (x, y, z slices; Monitor::check_columns), made \
             once per sweep before the timing"
                .to_string(),
        );
    }

    if let Some((_, source)) = &opts.params {
        notes.push(format!("parameters: {source}; each case keeps its own cell_size_m and grid_size_m"));
    }
    let changed = changed_keys(opts);
    if !changed.is_empty() {
        let over = if opts.params.is_some() { "over those parameters" } else { "from the defaults" };
        notes.push(format!("params keys changed {over} in every case: {}", changed.join(", ")));
    }

    // Real data first: a malformed file fails the run before anything slow happens.
    let real = if opts.real_data { real_sequences(opts, &mut notes)? } else { RealSequences::default() };
    let syn64 = Sequence::synthetic(&SyntheticSpec::BEAMS_64);
    let syn32 = Sequence::synthetic(&SyntheticSpec::BEAMS_32);
    let lists: Vec<Sequence> =
        [30, 100, 300, 1000].iter().map(|&n| Sequence::synthetic(&SyntheticSpec::objects_only(n))).collect();
    let steady = Sequence::steady_traffic(30, STEADY_SEED);
    let worst = opts.worst_case.then(|| Sequence::synthetic(&SyntheticSpec::WORST_CASE));
    if !opts.real_data {
        notes.push("real sweeps not measured (disabled)".to_string());
    }

    let mut defs = vec![
        CaseDef {
            name: "synthetic-64/0.5m".into(),
            sequence: &syn64,
            cell_size_m: 0.5,
            grid_size_m: 100.0,
            calibrated: false,
            copy_objects: false,
        },
        CaseDef {
            name: "synthetic-64/0.2m".into(),
            sequence: &syn64,
            cell_size_m: 0.2,
            grid_size_m: 100.0,
            calibrated: false,
            copy_objects: false,
        },
        CaseDef {
            name: "synthetic-64/0.1m".into(),
            sequence: &syn64,
            cell_size_m: 0.1,
            grid_size_m: 100.0,
            calibrated: false,
            copy_objects: false,
        },
        CaseDef {
            name: "synthetic-64/0.2m/200m".into(),
            sequence: &syn64,
            cell_size_m: 0.2,
            grid_size_m: 200.0,
            calibrated: false,
            copy_objects: false,
        },
        CaseDef {
            name: "synthetic-32/0.5m".into(),
            sequence: &syn32,
            cell_size_m: 0.5,
            grid_size_m: 100.0,
            calibrated: false,
            copy_objects: false,
        },
    ];
    for seq in &lists {
        let name = format!("objects-{}/no-cloud", seq.max_objects());
        defs.push(CaseDef {
            name,
            sequence: seq,
            cell_size_m: 0.5,
            grid_size_m: 100.0,
            calibrated: false,
            copy_objects: false,
        });
    }
    // The calibrated plausibility rule on the same 30-object lists, in the same run as the paper's rule.
    if let Some(seq) = lists.first() {
        let name = format!("objects-{}/no-cloud/calibrated", seq.max_objects());
        defs.push(CaseDef {
            name,
            sequence: seq,
            cell_size_m: 0.5,
            grid_size_m: 100.0,
            calibrated: true,
            copy_objects: false,
        });
    }
    // Steady traffic (no jump: the realistic case the 5 us goal is judged on), both rules.
    for calibrated in [false, true] {
        let name = format!("{STEADY_CASE}{}", if calibrated { "/calibrated" } else { "" });
        defs.push(CaseDef {
            name,
            sequence: &steady,
            cell_size_m: 0.5,
            grid_size_m: 100.0,
            calibrated,
            copy_objects: true,
        });
    }
    for (name, seq) in [("kitti/0.5m", &real.kitti), ("nuscenes/0.5m", &real.nuscenes), ("av2/0.5m", &real.av2)] {
        if let Some(seq) = seq {
            defs.push(CaseDef {
                name: name.into(),
                sequence: seq,
                cell_size_m: 0.5,
                grid_size_m: REAL_GRID_SIZE_M,
                calibrated: false,
                copy_objects: false,
            });
        }
    }
    if let Some(seq) = &worst {
        defs.push(CaseDef {
            name: "worst-case/0.5m".into(),
            sequence: seq,
            cell_size_m: 0.5,
            grid_size_m: 100.0,
            calibrated: false,
            copy_objects: false,
        });
    }

    if !opts.only.is_empty() {
        defs.retain(|d| opts.only.iter().any(|o| d.name.contains(o.as_str())));
        notes.push(format!("only the cases matching {:?}", opts.only));
    }
    if defs.iter().any(|d| d.name.starts_with("objects-")) {
        notes.push(format!(
            "object lists: {STEADY_CASE} is steady traffic (30 objects moving continuously, {} frames cycled without a \
             jump: no alarm expected) and carries the 5 us goal of the plausibility checks; objects-N/no-cloud cycle 6 \
             frames whose objects jump back every 6th frame (the alarm-heavy worst case, printed beside the goal; the \
             goal was judged on it before round plat3); column alarms o/oo: implausible states per mille of those judged",
            frames::STEADY_PERIOD_FRAMES
        ));
    }
    let mut cases = Vec::with_capacity(defs.len());
    for def in &defs {
        cases.push(measure_case(def, opts)?);
    }
    let paper = goals::compare_with_paper(&cases);
    let goals = goals::goals(&cases);
    Ok(BenchReport {
        version: env!("CARGO_PKG_VERSION").to_string(),
        machine,
        iterations: opts.iterations,
        cases,
        paper,
        goals,
        notes,
    })
}

/// Gives each KITTI sweep camera 2's field of view (the wedge KITTI labels, from the frame's `calib/NNNNNN.txt`, the
/// nominal calibration without one) as its region of interest, as the KITTI object reader does with `--roi auto`. A
/// sweep whose calibration leaves no field of view in the grid keeps an empty region (the whole grid), as in the
/// reader; `run_bench` counts such sweeps in its notes.
///
/// # Errors
/// A calibration file that is present but unreadable or malformed, named in the message.
pub fn kitti_fields_of_view(dir: &Path, sweeps: &mut [frames::Sweep]) -> Result<(), String> {
    use pmon_datasets::kitti;
    let calib_dir = dir.join("kitti/object/training/calib");
    for s in sweeps {
        let path = calib_dir.join(format!("{}.txt", s.label.trim_end_matches(".bin")));
        let calib = match std::fs::read_to_string(&path) {
            Ok(text) => kitti::parse_calib(&text).map_err(|e| format!("{}: {e}", path.display()))?,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => kitti::KittiCalib::nominal(),
            Err(e) => return Err(format!("{}: {e}", path.display())),
        };
        s.roi_in_ego = kitti::field_of_view_polygon(&calib, 0.5 * f64::from(REAL_GRID_SIZE_M)).into_iter().collect();
    }
    Ok(())
}

/// The real sequences found (each `None` when its sweeps are absent).
#[derive(Default)]
struct RealSequences {
    kitti: Option<Sequence>,
    nuscenes: Option<Sequence>,
    av2: Option<Sequence>,
}

fn real_sequences(opts: &BenchOptions, notes: &mut Vec<String>) -> Result<RealSequences, BenchError> {
    let dir = opts.data_dir.clone().unwrap_or_else(frames::data_dir);
    let dir = dir.canonicalize().unwrap_or(dir);
    if !dir.is_dir() {
        notes.push(format!("real sweeps skipped: no data folder at {} (set PMON_DATA_DIR)", dir.display()));
        return Ok(RealSequences::default());
    }
    let mut kitti = frames::kitti_sweeps(&dir).map_err(BenchError::Data)?;
    if !opts.kitti_whole_grid {
        kitti_fields_of_view(&dir, &mut kitti).map_err(BenchError::Data)?;
    }
    let nuscenes = frames::nuscenes_sweeps(&dir).map_err(BenchError::Data)?;
    let av2_logs = av2::logs(&dir).map_err(BenchError::Data)?;
    let describe = |what: &str, sweeps: &[frames::Sweep]| {
        let names: Vec<&str> = sweeps.iter().map(|s| s.label.as_str()).collect();
        format!("{what}: {} sweep(s) from {} ({})", sweeps.len(), dir.display(), names.join(", "))
    };
    if kitti.is_empty() {
        notes
            .push(format!("KITTI sweeps skipped: none under {}", dir.join("kitti/object/training/velodyne").display()));
    } else {
        notes.push(describe("KITTI", &kitti));
        let no_view = kitti.iter().filter(|s| s.roi_in_ego.is_empty()).count();
        notes.push(if opts.kitti_whole_grid {
            "KITTI sweeps checked over the whole grid (--kitti-whole-grid; `pmon check kitti:` checks camera 2's field \
             of view)"
                .to_string()
        } else if no_view > 0 {
            format!(
                "KITTI sweeps checked in camera 2's field of view, the labelled region (as `pmon check kitti:` does \
                 by default; docs/datasets.md), but {no_view} of {} sweeps have none in the grid (their calibration \
                 turns the camera off the ground) and are checked over the whole grid",
                kitti.len()
            )
        } else {
            "KITTI sweeps checked in camera 2's field of view, the labelled region (as `pmon check kitti:` does by \
             default; docs/datasets.md): the cluster stage tests its clusters against it; --kitti-whole-grid for the \
             whole grid"
                .to_string()
        });
    }
    if nuscenes.is_empty() {
        notes.push(format!("nuScenes sweeps skipped: none under {}", dir.join("nuscenes").display()));
    } else {
        notes.push(describe("nuScenes", &nuscenes));
    }
    if av2_logs.is_empty() {
        notes.push(format!(
            "Argoverse 2 sweeps skipped: no log with sensors/lidar/*.feather under {}",
            dir.join("av2/sensor").display()
        ));
    }
    for log in &av2_logs {
        notes.push(describe(&format!("Argoverse 2 log {}", log.name()), &log.sweeps));
        let polygons: usize = log.sweeps.iter().map(|s| s.roi_in_ego.len()).sum();
        notes.push(format!(
            "Argoverse 2 log {}: {} ROI polygons per sweep on average from the log's vector map (drivable areas and \
             crossings, docs/datasets.md); the cluster stage tests its clusters against them",
            log.name(),
            polygons / log.sweeps.len().max(1)
        ));
        let [x, y, z] = log.up_lidar_m;
        let height = z - log.ground_z_m;
        notes.push(format!(
            "Argoverse 2: points as read by pmon-datasets (both VLP-32C lidars merged, centred on the up_lidar \
             origin ({x:.3}, {y:.3}, {z:.3}) m of AV2's rear-axle ego frame); extrinsic = that origin raised by \
             the ground depth under the ego origin ({:.3} m, ground raster), i.e. translation ({x:.3}, {y:.3}, \
             {height:.3}) m, so the ground is at z = 0 as in the other cases; no ego-footprint mask",
            -log.ground_z_m
        ));
        if log.sweeps.len() < log.sweep_files {
            notes.push(format!(
                "Argoverse 2 log {}: {} of {} sweep files match an annotation timestamp (the others are not read)",
                log.name(),
                log.sweeps.len(),
                log.sweep_files
            ));
        }
    }
    notes.push(
        "real sweeps carry synthetic object lists of the goal sizes (KITTI 100, nuScenes 30, Argoverse 2 100: \
         two stacked 32-beam lidars give about as many points as KITTI's 64-beam one) that do not match the \
         scene: most objects are evidence-free, so the occlusion test runs for nearly all"
            .to_string(),
    );
    let av2 = av2::sequence(av2_logs.into_iter().flat_map(|log| log.sweeps).collect());
    let kitti = Sequence::real("KITTI HDL-64E sweeps, 100 synthetic objects", kitti, &SyntheticSpec::BEAMS_64);
    let nuscenes = Sequence::real("nuScenes 32-beam sweep, 30 synthetic objects", nuscenes, &SyntheticSpec::BEAMS_32);
    Ok(RealSequences { kitti, nuscenes, av2 })
}

fn us(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

/// The values of the iterations that checked frame `k` of the cycle (`frame_of`: each iteration's frame).
fn of_frame<T: Copy>(values: &[T], frame_of: &[usize], k: usize) -> Vec<T> {
    values.iter().zip(frame_of).filter(|(_, f)| **f == k).map(|(x, _)| *x).collect()
}

fn median_u32(v: &mut [u32]) -> u32 {
    v.sort_unstable();
    v.get(v.len() / 2).copied().unwrap_or(0)
}

/// The params keys the rule switches change from the parameters the cases start from (Table I, or
/// [`BenchOptions::params`]), as `key = value` (empty when none does), so that a report says what it measured.
fn changed_keys(opts: &BenchOptions) -> Vec<String> {
    let (cell, grid) = (MonitorParams::PAPER.cell_size_m, MonitorParams::PAPER.grid_size_m);
    let d = start_params(opts, cell, grid);
    let p = case_params(opts, cell, grid);
    let mut out = Vec::new();
    for (key, default, value) in [
        ("seen_over", d.seen_over, p.seen_over),
        ("face_in_front", d.face_in_front, p.face_in_front),
        ("jump_from_returns", d.jump_from_returns, p.jump_from_returns),
        ("jump_first_return", d.jump_first_return, p.jump_first_return),
        ("seen_body", d.seen_body, p.seen_body),
        ("memory_gate", d.memory_gate, p.memory_gate),
        ("follow_gate", d.follow_gate, p.follow_gate),
        ("shadow_gate", d.shadow_gate, p.shadow_gate),
        ("follow_owner_fit", d.follow_owner_fit, p.follow_owner_fit),
        ("release_flagged_claims", d.release_flagged_claims, p.release_flagged_claims),
        ("release_to_confirmed", d.release_to_confirmed, p.release_to_confirmed),
        ("evidence_runs_on", d.evidence_runs_on, p.evidence_runs_on),
        ("seen_through_near_side", d.seen_through_near_side, p.seen_through_near_side),
        ("front_cluster", d.front_cluster, p.front_cluster),
        ("spill_in_front", d.spill_in_front, p.spill_in_front),
        ("spill_near_side", d.spill_near_side, p.spill_near_side),
        ("spill_least_stretch", d.spill_least_stretch, p.spill_least_stretch),
        ("jump_evidence_at_prediction", d.jump_evidence_at_prediction, p.jump_evidence_at_prediction),
        ("jump_coincident_boxes", d.jump_coincident_boxes, p.jump_coincident_boxes),
        ("jump_jumped_boxes", d.jump_jumped_boxes, p.jump_jumped_boxes),
    ] {
        if default != value {
            out.push(format!("{key} = {value}"));
        }
    }
    if d.returns_beyond_cells != p.returns_beyond_cells {
        out.push(format!("returns_beyond_cells = {}", p.returns_beyond_cells));
    }
    if d.spill_gap_m.to_bits() != p.spill_gap_m.to_bits() {
        out.push(format!("spill_gap_m = {}", p.spill_gap_m));
    }
    if d.memory_hold_s.to_bits() != p.memory_hold_s.to_bits() {
        out.push(format!("memory_hold_s = {}", p.memory_hold_s));
    }
    if d.parked_hold_s.to_bits() != p.parked_hold_s.to_bits() {
        out.push(format!("parked_hold_s = {}", p.parked_hold_s));
    }
    if d.roi_graze_fraction.to_bits() != p.roi_graze_fraction.to_bits() {
        out.push(format!("roi_graze_fraction = {}", p.roi_graze_fraction));
    }
    out
}

fn measure_case(def: &CaseDef<'_>, opts: &BenchOptions) -> Result<CaseReport, BenchError> {
    let mut p = case_params(opts, def.cell_size_m, def.grid_size_m);
    if def.calibrated {
        p.plausibility_mode = pmon_monitor::PlausibilityMode::Calibrated;
    }
    let mut monitor = Monitor::new(p).map_err(|source| BenchError::Params { case: def.name.clone(), source })?;
    monitor.set_rasterizer(opts.rasterizer);
    if opts.split {
        monitor.enable_split();
    }
    let join: Option<&dyn Join> = if opts.split { Some(&RayonJoin) } else { None };
    let seq = def.sequence;
    let n = seq.frames.len().max(1);
    let frame_err = |source| BenchError::Frame { case: def.name.clone(), source };
    // With `columns`, each sweep's points as three columns, made here (outside the timing).
    let columns: Vec<[Vec<f32>; 3]> = if opts.columns { seq.sweep_columns() } else { Vec::new() };
    // Frame `i`'s sweep as a `ColumnCloud` when measuring columns and the frame has a sweep.
    let column_cloud = |i: usize| -> Option<ColumnCloud<'_>> {
        let sweep = seq.frames.get(i % n)?.sweep?;
        let [x, y, z] = columns.get(sweep)?;
        let points_in_sensor = PointColumns::new(x, y, z).ok()?;
        Some(ColumnCloud { points_in_sensor, ego_from_sensor: seq.sweeps.get(sweep)?.ego_from_sensor })
    };

    // Warm-up: one cycle (fills the tracks, touches the buffers).
    for i in 0..n {
        let mut roi = Vec::new();
        if let Some(f) = seq.frame_with_roi(i, Sequence::timestamp_s(i), &mut roi) {
            match column_cloud(i) {
                Some(cloud) => monitor.check_columns(&pmon_monitor::Frame { cloud: None, ..f }, &cloud).map(|_| ()),
                None => monitor.check(&f).map(|_| ()),
            }
            .map_err(frame_err)?;
        }
    }

    let mut stage_us: Vec<[f64; 5]> = Vec::with_capacity(opts.iterations);
    let mut total_us = Vec::with_capacity(opts.iterations);
    let (mut points, mut in_band, mut cells_hit, mut clusters) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // The frame of the cycle each timed iteration checked.
    let mut frame_of: Vec<usize> = Vec::with_capacity(opts.iterations);
    // This thread's CPU time of each whole check, read outside the wall-clock marks (`cpu`).
    let read_cpu = !opts.split && !opts.no_cpu_time;
    let mut check_cpu_us: Vec<f64> = Vec::with_capacity(if read_cpu { opts.iterations } else { 0 });
    let started = Instant::now();
    let (mut motion_states, mut motion_alarms) = (0u64, 0u64);
    let mut objects_copy: Vec<pmon_monitor::ObjectState> = Vec::with_capacity(seq.max_objects());
    for i in n..n + opts.iterations {
        let mut roi = Vec::new();
        let Some(frame) = seq.frame_with_roi(i, Sequence::timestamp_s(i), &mut roi) else { break };
        let frame = if def.copy_objects {
            objects_copy.clear();
            objects_copy.extend_from_slice(frame.objects);
            pmon_monitor::Frame { objects: &objects_copy, ..frame }
        } else {
            frame
        };
        let (timed, cpu_us) = cpu::around(read_cpu, || match column_cloud(i) {
            Some(cloud) => timed_check_columns(&mut monitor, &frame, &cloud, join),
            None => timed_check_with(&mut monitor, &frame, join),
        });
        let (report, row) = timed.map_err(frame_err)?;
        if let Some(c) = cpu_us {
            check_cpu_us.push(c);
        }
        points.push(report.grid.points_total);
        in_band.push(report.grid.points_in_band);
        cells_hit.push(report.grid.cells_hit);
        clusters.push(report.grid.clusters_total);
        for o in report.objects {
            match o.motion.verdict {
                MotionVerdict::Plausible => motion_states += 1,
                MotionVerdict::Implausible(_) => {
                    (motion_states, motion_alarms) = (motion_states + 1, motion_alarms + 1)
                }
                MotionVerdict::NotMonitored(_) => {}
            }
        }
        stage_us.push(row);
        total_us.push(row.iter().sum());
        frame_of.push(i % n);
        if i >= n + 10 && started.elapsed().as_secs_f64() > opts.max_seconds_per_case {
            break;
        }
    }
    let samples = stage_us.len();
    // Every check or none: a clock that failed once leaves the figure out rather than a part of it.
    let cpu_complete = samples > 0 && check_cpu_us.len() == samples;

    // The floors, cycling through the same sweeps in the same order (same cache behaviour), alternating.
    let (mut floor_us, mut native_us) = (Vec::new(), Vec::new());
    if seq.max_points() > 0 {
        for i in n..n + samples {
            let Some(cloud) = seq.frame(i, 0.0).and_then(|f| f.cloud) else { continue };
            let t0 = Instant::now();
            std::hint::black_box(frames::coordinate_sum(std::hint::black_box(cloud.points_in_sensor)));
            floor_us.push(us(t0.elapsed()));
            let t0 = Instant::now();
            std::hint::black_box(native::native_sum(std::hint::black_box(cloud.points_in_sensor)));
            native_us.push(us(t0.elapsed()));
        }
    }

    let column = |k: usize| -> Vec<f64> { stage_us.iter().map(|r| r.get(k).copied().unwrap_or(0.0)).collect() };
    let stages = Stage::ALL
        .iter()
        .enumerate()
        .map(|(k, s)| StageTiming { stage: s.name().to_string(), timing: Timing::of(&column(k)) })
        .collect();
    let plausibility_k = Stage::ALL.iter().position(|s| *s == Stage::Plausibility).unwrap_or(3);
    let sensor: Vec<f64> = stage_us
        .iter()
        .map(|r| r.iter().enumerate().filter(|(k, _)| *k != plausibility_k).map(|(_, v)| v).sum())
        .collect();
    let sensor_checks = Timing::of(&sensor);
    let per_frame: Vec<FrameTiming> = if n > 1 {
        (0..n)
            .map(|k| {
                let mut c = of_frame(&clusters, &frame_of, k);
                let own = of_frame(&sensor, &frame_of, k);
                FrameTiming {
                    frame: k,
                    clusters: median_u32(&mut c),
                    samples: own.len(),
                    sensor_checks: Timing::of(&own),
                    check_cpu: cpu_complete.then(|| Timing::of(&of_frame(&check_cpu_us, &frame_of, k))),
                }
            })
            .filter(|f| f.samples > 0)
            .collect()
    } else {
        Vec::new()
    };
    let floor = (!floor_us.is_empty()).then(|| Timing::of(&floor_us));
    let sensor_over_floor = floor.filter(|f| f.median_us > 0.0).map(|f| sensor_checks.median_us / f.median_us);
    let native_floor = (!native_us.is_empty()).then(|| Timing::of(&native_us));
    let sensor_over_native_floor =
        native_floor.filter(|f| f.median_us > 0.0).map(|f| sensor_checks.median_us / f.median_us);
    let geometry_cells = u64::from(p.grid_cells_per_side()) * u64::from(p.grid_cells_per_side());
    let reference = if seq.max_points() > 0 && !opts.no_machine_reference {
        jitter::reference(sensor_checks.median_us, samples, read_cpu)
    } else {
        None
    };
    Ok(CaseReport {
        name: def.name.clone(),
        description: seq.name.clone(),
        frames: seq.frames.len(),
        points: median_u32(&mut points),
        points_in_band: median_u32(&mut in_band),
        objects: seq.max_objects(),
        cell_size_m: def.cell_size_m,
        grid_size_m: def.grid_size_m,
        grid_cells: geometry_cells,
        cells_hit: median_u32(&mut cells_hit),
        clusters: median_u32(&mut clusters),
        samples,
        stages,
        sensor_checks,
        plausibility: Timing::of(&column(plausibility_k)),
        motion_states,
        motion_alarms,
        total: Timing::of(&total_us),
        floor,
        sensor_over_floor,
        native_floor,
        sensor_over_native_floor,
        per_frame,
        jitter_reference: reference.map(|r| r.wall),
        check_cpu: cpu_complete.then(|| Timing::of(&check_cpu_us)),
        jitter_reference_cpu: reference.and_then(|r| r.cpu),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmon_monitor::geometry::polygon_contains;

    fn sweep(label: &str) -> frames::Sweep {
        frames::Sweep {
            label: label.into(),
            points_in_sensor: Vec::new(),
            ego_from_sensor: pmon_monitor::Isometry3::from_translation(0.0, 0.0, 1.73),
            roi_in_ego: Vec::new(),
        }
    }

    /// Each KITTI sweep gets its frame's field of view: ahead of the car, not behind or beside it.
    #[test]
    #[cfg_attr(pmon_no_data, ignore = "needs the real data extracts: ../shared/data or PMON_DATA_DIR not found")]
    fn the_kitti_sweeps_take_camera_2s_field_of_view() {
        let dir = frames::data_dir();
        let mut sweeps = frames::kitti_sweeps(&dir).unwrap();
        assert!(!sweeps.is_empty());
        kitti_fields_of_view(&dir, &mut sweeps).unwrap();
        for s in &sweeps {
            assert_eq!(s.roi_in_ego.len(), 1, "{}", s.label);
            let inside = |x: f32, y: f32| polygon_contains(&s.roi_in_ego[0], x, y);
            assert!(inside(20.0, 0.0) && inside(30.0, 20.0), "{}: ahead", s.label);
            assert!(!inside(-20.0, 0.0) && !inside(0.0, 20.0) && !inside(10.0, -20.0), "{}: behind, beside", s.label);
        }
    }

    /// A sweep without a calibration file takes the nominal one; a malformed file is an error naming it; one whose
    /// calibration leaves no field of view keeps the whole grid.
    #[test]
    fn a_missing_kitti_calibration_is_nominal_and_a_malformed_one_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let calib = dir.path().join("kitti/object/training/calib");
        std::fs::create_dir_all(&calib).unwrap();
        let mut sweeps = vec![sweep("000000.bin"), sweep("000001.bin")];
        kitti_fields_of_view(dir.path(), &mut sweeps).unwrap();
        assert!(sweeps.iter().all(|s| s.roi_in_ego.len() == 1 && polygon_contains(&s.roi_in_ego[0], 20.0, 0.0)));
        std::fs::write(calib.join("000001.txt"), "P0: 1 2 3\nTr_velo_to_cam: 1 2\n").unwrap();
        let err = kitti_fields_of_view(dir.path(), &mut sweeps).unwrap_err();
        assert!(err.contains("000001.txt"), "{err}");
        // A calibration that turns the camera off the ground (its axis straight up) leaves no field of view.
        std::fs::write(
            calib.join("000001.txt"),
            "R0_rect: 1 0 0 0 1 0 0 0 1\nTr_velo_to_cam: 1 0 0 0 0 1 0 0 0 0 1 0\n",
        )
        .unwrap();
        kitti_fields_of_view(dir.path(), &mut sweeps).unwrap();
        assert_eq!(sweeps.iter().map(|s| s.roi_in_ego.len()).collect::<Vec<_>>(), [1, 0]);
        // The run says so in its notes.
        let velodyne = dir.path().join("kitti/object/training/velodyne");
        std::fs::create_dir_all(&velodyne).unwrap();
        let points: Vec<u8> = [[10.0f32, 0.0, -1.0, 0.0], [20.0, 1.0, -0.5, 0.0]]
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        for name in ["000000.bin", "000001.bin"] {
            std::fs::write(velodyne.join(name), &points).unwrap();
        }
        let opts = BenchOptions {
            iterations: 2,
            data_dir: Some(dir.path().to_path_buf()),
            worst_case: false,
            only: vec!["kitti".into()],
            no_machine_reference: true,
            ..BenchOptions::default()
        };
        let report = run_bench(&opts).unwrap();
        assert!(report.notes.iter().any(|n| n.contains("1 of 2 sweeps have none in the grid")), "{:?}", report.notes);
    }
}
