//! Experiments on real driving data (Section IV, "Position error of a real sensor", and beyond it).
//!
//! 1. **The paper's real-sensor experiment**: permanent position errors away from the ego are injected into the
//!    human-labelled boxes of real LiDAR frames (nuScenes keyframe, KITTI object frames, the two Argoverse 2
//!    sweeps) and the **sensor checks** are scored (single frames: no motion, so the plausibility checks do not
//!    apply). Objects without LiDAR evidence (the monitor says *not monitored*, or the dataset counts no point
//!    in the box) are *not verifiable* and shown separately, which is why recall over all boxes saturates.
//! 2. **False alarms on clean real frames**: the sensor checks on the unmodified labels, with every flagged box
//!    and the likely reason.
//! 3. **Plausibility on real human-labelled motion**: Argoverse 2 tracks and CommonRoad (NGSIM) trajectories,
//!    clean (false alarms per class and condition) and with injected speed and position errors.
//!
//! Every dataset that is absent is skipped with a note; malformed data is an error. The data are read from the
//! shared data folder and never copied. Results are deterministic for a seed (rayon only maps independent runs
//! and keeps their order; no timing enters the results).

use std::borrow::Cow;
use std::path::Path;

use pmon_datasets::ground::GroundMode;
use pmon_datasets::roi::RoiOptions;
use pmon_datasets::{open_with, Dataset, DatasetFrame, ReadOptions};
use pmon_monitor::{
    ClusterReport, Monitor, MonitorParams, MotionVerdict, ObjectClass, ObjectReport, ObjectState, SensorVerdict,
};
use serde::{Deserialize, Serialize};

use crate::experiments::{Claim, Curve, Figure, FigureSpec};
use crate::inject::{InjectionConfig, Injector};
use crate::metrics::{score, Metrics, Outcome, Rate, Score};

mod clean;
pub mod evaluate;
mod one_box;
mod plausibility;
mod sensor;

use plausibility::{plausibility_experiments, TrackScene};
use sensor::{sensor_experiments, FrameStream, OpenFrames, SensorSet};

/// nuScenes keyframe folder, relative to the data folder.
pub const NUSCENES_DIR: &str = "nuscenes";
/// KITTI 3D object training folder, relative to the data folder.
pub const KITTI_OBJECT_DIR: &str = "kitti/object/training";
/// The Argoverse 2 log with LiDAR sweeps, relative to the data folder.
pub const AV2_SWEEP_LOG: &str = "av2/sensor/val/7fab2350-7eaf-3b7e-a39d-6937a4c1bede";
/// The Argoverse 2 log with annotations and poses only, relative to the data folder.
pub const AV2_TRACK_LOG: &str = "av2/sensor/val/3b3570b4-7b0b-3268-a571-b0889dbf40b6";
/// The CommonRoad (NGSIM) scenarios, relative to the data folder.
pub const COMMONROAD_FILES: [&str; 2] = ["commonroad/USA_US101-4_1_T-1.xml", "commonroad/USA_Lanker-1_1_T-1.xml"];

/// Rate of the transient speed errors (the paper: 10 %).
const TRANSIENT_SPEED_RATE: f64 = 0.1;
/// Rate of the random position errors (the paper's lowest rate: 20 %).
const RANDOM_POSITION_RATE: f64 = 0.2;
/// Quantile of the monitor's own motion estimates used for the per-class limits configuration.
const LIMIT_QUANTILE: f64 = 0.999;
/// Magnitudes from which the real-sensor recall counts as saturated, metres.
const SATURATION_FROM_M: f64 = 1.5;

/// How much to run. [`RealDataOptions::full`] is the experiment; [`RealDataOptions::smoke`] is for tests.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RealDataOptions {
    /// Magnitudes of the permanent position errors (sensor experiment) and of the random position errors
    /// (plausibility experiment), metres.
    pub position_magnitudes_m: Vec<f64>,
    /// Magnitudes of the speed errors, m/s.
    pub speed_magnitudes_mps: Vec<f64>,
    /// Seeds per magnitude of the runs that displace half the boxes (precision needs clean boxes beside the
    /// displaced ones; one keyframe is small, so the runs are repeated with other halves and pooled).
    pub precision_repeats: u32,
}

impl RealDataOptions {
    /// The paper's sweeps: position 0.1 to 2.0 m in 0.1 m steps, speed 0.5 to 10 m/s in 0.5 m/s steps, and ten
    /// seeds of the half-the-boxes runs.
    #[must_use]
    pub fn full() -> Self {
        Self {
            position_magnitudes_m: steps(0.1, 2.0, 0.1),
            speed_magnitudes_mps: steps(0.5, 10.0, 0.5),
            precision_repeats: 10,
        }
    }

    /// Three position and two speed magnitudes, two seeds: exercises everything quickly, not for conclusions.
    #[must_use]
    pub fn smoke() -> Self {
        Self { position_magnitudes_m: vec![0.1, 1.0, 2.0], speed_magnitudes_mps: vec![2.0, 8.0], precision_repeats: 2 }
    }
}

impl Default for RealDataOptions {
    fn default() -> Self {
        Self::full()
    }
}

/// A table: title, column headers, rows.
pub type Table = (String, Vec<String>, Vec<Vec<String>>);

/// Everything the real-data experiments produce.
#[derive(Clone, Debug, Serialize)]
pub struct RealDataResults {
    /// Curves with 95 % Wilson intervals (ids `real_position_<dataset>`, `real_speed_errors_<family>`,
    /// `real_random_position_<family>`).
    pub figures: Vec<Figure>,
    /// The paper's statements about real data next to pmon's measurements.
    pub claims: Vec<Claim>,
    /// What was skipped, how things were counted, what surprised, and the data attributions.
    pub notes: Vec<String>,
    /// Tables `(title, headers, rows)`.
    pub tables: Vec<Table>,
}

/// [`real_data_experiments_with`] with [`RealDataOptions::full`].
///
/// # Errors
/// Malformed data (a reader error naming the file), or a monitor error. Absent datasets are not errors.
pub fn real_data_experiments(data_dir: &Path, base: &MonitorParams, seed: u64) -> Result<RealDataResults, String> {
    real_data_experiments_with(data_dir, base, seed, &RealDataOptions::full())
}

/// Runs every real-data experiment on the datasets found under `data_dir` (the shared data folder's layout),
/// with `base` as the monitor parameters (its `ground_z_m` replaced by each dataset's own).
///
/// # Errors
/// Malformed data (a reader error naming the file), or a monitor error. Absent datasets are not errors.
pub fn real_data_experiments_with(
    data_dir: &Path,
    base: &MonitorParams,
    seed: u64,
    opts: &RealDataOptions,
) -> Result<RealDataResults, String> {
    let mut out = RealDataResults { figures: Vec::new(), claims: Vec::new(), notes: Vec::new(), tables: Vec::new() };
    if !data_dir.exists() {
        out.notes.push(format!("real-data experiments skipped: data folder {} not found", data_dir.display()));
        return Ok(out);
    }
    let notes = &mut out.notes;
    let nuscenes = load(data_dir, NUSCENES_DIR, "nuscenes", "nuScenes keyframe", true, base.grid_size_m, notes)?;
    let kitti = load(data_dir, KITTI_OBJECT_DIR, "kitti", "KITTI object frames", true, base.grid_size_m, notes)?;
    let av2_sweeps = load(data_dir, AV2_SWEEP_LOG, "av2", "Argoverse 2 log 7fab2350", true, base.grid_size_m, notes)?;
    let av2_tracks = load(data_dir, AV2_TRACK_LOG, "av2", "Argoverse 2 log 3b3570b4", false, base.grid_size_m, notes)?;
    let mut commonroad = Vec::new();
    for rel in COMMONROAD_FILES {
        let what = format!("CommonRoad {}", rel.trim_start_matches("commonroad/"));
        commonroad.extend(load(data_dir, rel, "commonroad", &what, false, base.grid_size_m, notes)?);
    }

    // ---- 1 and 2: sensor checks on real LiDAR ----
    let mut sets = Vec::new();
    for (key, label, paper_ref, ds) in [
        ("nuscenes", "nuScenes keyframe", "Fig. positionNuScenes", &nuscenes),
        ("kitti", "KITTI object frames", "beyond the paper (Fig. positionNuScenes, other data)", &kitti),
        (
            "av2",
            "Argoverse 2 sweeps (log 7fab2350)",
            "beyond the paper (Fig. positionNuScenes, other data)",
            &av2_sweeps,
        ),
    ] {
        let Some(ds) = ds else { continue };
        if !ds.frames.iter().any(|f| f.frame.cloud.is_some()) {
            out.notes.push(format!("{label}: no frame with a LiDAR sweep, sensor experiments skipped"));
            continue;
        }
        // The dataset is in memory already (`reproduce` reads the extracts whole); the frames are lent one by one.
        let frames: OpenFrames<'_> = Box::new(move || {
            let stream: FrameStream<'_> =
                Box::new(ds.frames.iter().filter(|f| f.frame.cloud.is_some()).map(|f| Ok(Cow::Borrowed(f))));
            Ok(stream)
        });
        sets.push(SensorSet {
            key,
            name: label.to_string(),
            paper_ref,
            params: MonitorParams {
                ground_z_m: ds.info.ground_z_m,
                ego_footprint_m: ds.info.format.ego_footprint_m(),
                ..*base
            },
            frames,
            roi: ds.roi_note().map_or_else(|| "none".to_string(), roi_label),
        });
    }
    sensor_experiments(&mut sets, seed, opts, &mut out)?;
    drop(sets);

    // ---- 3: plausibility on real tracks ----
    let mut scenes = Vec::new();
    for ds in [&av2_sweeps, &av2_tracks].into_iter().flatten() {
        scenes.push(TrackScene::new("av2", "Argoverse 2", ds, base));
    }
    for ds in &commonroad {
        scenes.push(TrackScene::new("commonroad", "CommonRoad (NGSIM)", ds, base));
    }
    plausibility_experiments(&scenes, seed, opts, &mut out)?;

    out.notes.push(
        "Data: nuScenes (Caesar et al., CVPR 2020; nuScenes terms, CC BY-NC-SA 4.0); KITTI (Geiger, Lenz, Urtasun, \
         CVPR 2012; CC BY-NC-SA 3.0); Argoverse 2 (c) 2022 Argo AI, LLC, CC BY-NC-SA 4.0; CommonRoad scenarios \
         (commonroad-io, BSD-3-Clause) built from NGSIM recordings. Non-commercial use only for the first three."
            .into(),
    );
    Ok(out)
}

/// A short label of a dataset's ROI note.
fn roi_label(note: &str) -> String {
    if note.starts_with("none") {
        "none".into()
    } else if note.contains("vector map") {
        "vector map".into()
    } else if note.starts_with("the labelled field of view") {
        "the labelled camera's field of view".into()
    } else {
        note.split(" (").next().unwrap_or(note).to_string()
    }
}

fn steps(from: f64, to: f64, step: f64) -> Vec<f64> {
    let n = ((to - from) / step).round() as i64;
    (0..=n).map(|i| ((from + i as f64 * step) * 1000.0).round() / 1000.0).collect()
}

/// Reads a dataset, or notes that it is absent.
fn load(
    data_dir: &Path,
    rel: &str,
    scheme: &str,
    what: &str,
    load_clouds: bool,
    grid_size_m: f32,
    notes: &mut Vec<String>,
) -> Result<Option<Dataset>, String> {
    let path = data_dir.join(rel);
    if !path.exists() {
        notes.push(format!("{what}: skipped, not found at {}", path.display()));
        return Ok(None);
    }
    let spec = format!("{scheme}:{}", path.display());
    // The dataset's own map, where it has one, is the frames' ROI, clipped to the monitor's grid.
    let roi = RoiOptions { grid_half_extent_m: 0.5 * f64::from(grid_size_m), ..RoiOptions::default() };
    let ds = open_with(&spec, &ReadOptions { load_clouds, roi, ground: GroundMode::Auto })
        .map_err(|e| format!("{what}: {e}"))?;
    if load_clouds {
        notes.push(format!("{what}: region of interest: {}", ds.roi_note().unwrap_or("none")));
    }
    Ok(Some(ds))
}

/// SplitMix64 of a seed and a tag: independent, reproducible seeds per run.
pub(crate) fn mix(seed: u64, tag: u64) -> u64 {
    let mut z = seed ^ tag.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(0x632B_E59B_D9B4_E019);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// One object state of a run, kept for the tables.
#[derive(Clone, Copy, Debug)]
struct StateRecord {
    frame: usize,
    index: usize,
    injected: bool,
    in_scope: bool,
    /// The object as the monitor saw it (with the injected error).
    object: ObjectState,
    report: ObjectReport,
}

/// A run over dataset frames: the campaign's scores plus what the real-data tables need.
#[derive(Default)]
struct FrameRun {
    metrics: Metrics,
    /// Injected states in scope that the monitor could not judge (occluded, ...).
    nv_monitor: u64,
    /// Injected states in scope the monitor judged although the dataset counts no LiDAR point in the box.
    nv_no_points: u64,
    /// Every object state (only when asked for details).
    records: Vec<StateRecord>,
    /// Conflict clusters per frame (only when asked for details).
    clusters: Vec<Vec<ClusterReport>>,
}

/// One run's monitor and injector, advanced one frame at a time (the frames of a log are streamed through every
/// run of an experiment at once, so a run keeps its state between frames instead of holding the frames).
struct RunState {
    monitor: Monitor,
    injector: Injector,
    objects: Vec<ObjectState>,
}

/// What one frame of a run gives.
#[derive(Default)]
struct FrameStep {
    /// One per object of the frame.
    outcomes: Vec<Outcome>,
    /// Missed-object alarms of the frame.
    missed: u64,
    /// Injected states in scope that the monitor could not judge (occluded, ...).
    nv_monitor: u64,
    /// Injected states in scope the monitor judged although the dataset counts no LiDAR point in the box.
    nv_no_points: u64,
    /// Every object state (only when asked for details).
    records: Vec<StateRecord>,
    /// The frame's conflict clusters (only when asked for details).
    clusters: Vec<ClusterReport>,
}

impl RunState {
    fn new(params: &MonitorParams, injection: InjectionConfig) -> Result<Self, String> {
        Ok(Self {
            monitor: Monitor::new(*params).map_err(|e| e.to_string())?,
            injector: Injector::new(injection),
            objects: Vec::new(),
        })
    }

    /// Checks frame `k` (frames must come in order, each once) with the run's injection, with the real-data
    /// notion of verifiability: a state is *judged* by the sensor checks when the monitor judged it AND the
    /// dataset does not count zero LiDAR points in its box.
    fn step(&mut self, k: usize, df: &DatasetFrame, details: bool) -> Result<FrameStep, String> {
        let clean = &df.frame;
        let objects = &mut self.objects;
        objects.clone_from(&clean.objects);
        // Per object: the position offset injected into it (`None`: nothing injected).
        let mut injected: Vec<Option<[f32; 2]>> = vec![None; objects.len()];
        for i in self.injector.apply(k as u64, objects) {
            if let Some(x) = injected.get_mut(i.index as usize) {
                *x = Some(i.offset_m);
            }
        }
        let mut polygons = Vec::new();
        let mut view = clean.as_frame(&mut polygons);
        view.objects = objects;
        let report = self.monitor.check(&view).map_err(|e| format!("frame {k}: {e}"))?;
        let mut step = FrameStep { missed: report.missed_objects() as u64, ..FrameStep::default() };
        step.outcomes.reserve(report.objects.len());
        for (i, r) in report.objects.iter().enumerate() {
            let in_scope = crate::run::in_scope(r.sensor.verdict);
            let monitor_judged = !matches!(r.sensor.verdict, SensorVerdict::NotMonitored(_));
            let no_points = df.extras.get(i).and_then(|e| e.num_points) == Some(0);
            let offset = injected.get(i).copied().flatten();
            let inj = offset.is_some();
            if in_scope && inj {
                if !monitor_judged {
                    step.nv_monitor += 1;
                } else if no_points {
                    step.nv_no_points += 1;
                }
            }
            step.outcomes.push(Outcome {
                frame: k as u64,
                id: r.id,
                in_scope,
                injected: inj,
                sensor_alarm: matches!(r.sensor.verdict, SensorVerdict::Ghost | SensorVerdict::PositionError),
                sensor_judged: monitor_judged && !no_points,
                plausibility_alarm: matches!(r.motion.verdict, MotionVerdict::Implausible(_)),
                sensor_offset_agrees: crate::metrics::offset_outcome(
                    &r.sensor,
                    report.clusters,
                    clean.objects.get(i),
                    offset,
                ),
                sensor_cause: crate::metrics::cause_index(&r.sensor),
            });
            if details {
                let object = objects.get(i).copied().unwrap_or_else(|| clean.objects.get(i).copied().unwrap_or(OBJ0));
                step.records.push(StateRecord { frame: k, index: i, injected: inj, in_scope, object, report: *r });
            }
        }
        if details {
            step.clusters = report.clusters.to_vec();
        }
        Ok(step)
    }
}

/// Runs the monitor over dataset frames with an injection, as [`crate::run_one`] does, but with the real-data
/// notion of verifiability (see [`RunState::step`]). Scores with a window (the plausibility experiments need 2
/// frames); the sensor experiments stream their frames through [`RunState`] instead.
fn run_frames(
    frames: &[DatasetFrame],
    params: &MonitorParams,
    injection: InjectionConfig,
    window: u64,
    details: bool,
) -> Result<FrameRun, String> {
    let mut state = RunState::new(params, injection)?;
    let mut run = FrameRun::default();
    let mut outcomes = Vec::new();
    let mut missed = 0u64;
    for (k, df) in frames.iter().enumerate() {
        let step = state.step(k, df, details)?;
        outcomes.extend(step.outcomes);
        missed += step.missed;
        run.nv_monitor += step.nv_monitor;
        run.nv_no_points += step.nv_no_points;
        run.records.extend(step.records);
        if details {
            run.clusters.push(step.clusters);
        }
    }
    run.metrics = score(&outcomes, window, frames.len() as u64, missed);
    Ok(run)
}

/// Placeholder object (never used: reports and objects are parallel).
const OBJ0: ObjectState = ObjectState {
    id: 0,
    class: ObjectClass::Unknown,
    x_m: 0.0,
    y_m: 0.0,
    heading_rad: 0.0,
    speed_mps: 0.0,
    length_m: 1.0,
    width_m: 1.0,
    uncertainty: None,
};

fn add_score(a: &mut Score, b: &Score) {
    let Score { injected, detected, alarms, true_alarms } = b;
    a.injected += injected;
    a.detected += detected;
    a.alarms += alarms;
    a.true_alarms += true_alarms;
}

/// Sums the counts of two runs (pooling repeats or scenes). Destructures exhaustively, so a new field of
/// [`Metrics`] cannot be forgotten here.
fn add_metrics(a: &mut Metrics, b: &Metrics) {
    let Metrics {
        frames,
        states_in_scope,
        clean_states_in_scope,
        sensor,
        plausibility,
        combined,
        not_verifiable,
        sensor_verifiable,
        missed_object_alarms,
        sensor_offset,
        sensor_causes,
    } = b;
    a.frames += frames;
    a.states_in_scope += states_in_scope;
    a.clean_states_in_scope += clean_states_in_scope;
    add_score(&mut a.sensor, sensor);
    add_score(&mut a.plausibility, plausibility);
    add_score(&mut a.combined, combined);
    a.not_verifiable += not_verifiable;
    add_score(&mut a.sensor_verifiable, sensor_verifiable);
    a.missed_object_alarms += missed_object_alarms;
    a.sensor_offset.flagged += sensor_offset.flagged;
    a.sensor_offset.agrees += sensor_offset.agrees;
    a.sensor_causes.add(sensor_causes);
}

fn fmt_rate(r: &Rate) -> String {
    if r.n == 0 {
        "n/a".into()
    } else {
        format!("{:.1} % [{:.1}, {:.1}] (n = {})", 100.0 * r.value, 100.0 * r.lo, 100.0 * r.hi, r.n)
    }
}

fn fmt_per_mille(r: &Rate) -> String {
    if r.n == 0 {
        "n/a".into()
    } else {
        format!("{:.2} per mille [{:.2}, {:.2}] ({} of {})", 1000.0 * r.value, 1000.0 * r.lo, 1000.0 * r.hi, r.k, r.n)
    }
}

fn fig_spec(id: String, title: String, paper_ref: &str, x_label: &str, refs: Vec<(bool, f64, String)>) -> FigureSpec {
    FigureSpec {
        id,
        title,
        paper_ref: paper_ref.into(),
        x_label: x_label.into(),
        y_label: "rate".into(),
        refs,
        y_range: (0.0, 1.02),
    }
}

fn rate_at(c: &Curve, x: f64) -> Option<Rate> {
    c.points.iter().find(|p| (p.x - x).abs() < 1e-9).map(|p| p.rate)
}

fn short_rate(r: Option<Rate>) -> String {
    match r {
        Some(r) if r.n > 0 => format!("{:.0} % ({}/{})", 100.0 * r.value, r.k, r.n),
        _ => "n/a".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_cover_the_paper_sweeps() {
        let p = RealDataOptions::full();
        assert_eq!(p.position_magnitudes_m.len(), 20);
        assert_eq!(p.speed_magnitudes_mps.len(), 20);
        assert!((p.position_magnitudes_m.last().copied().unwrap_or(0.0) - 2.0).abs() < 1e-9);
    }

    #[test]
    fn absent_folder_is_a_note_not_an_error() {
        let r = real_data_experiments_with(
            Path::new("/nonexistent/pmon-data"),
            &MonitorParams::PAPER,
            1,
            &RealDataOptions::smoke(),
        );
        let r = r.unwrap();
        assert!(r.figures.is_empty() && r.claims.is_empty());
        assert!(r.notes.iter().any(|n| n.contains("not found")));
    }

    #[test]
    fn pooled_metrics_add_counts() {
        let mut a = Metrics::default();
        let mut b = Metrics::default();
        b.sensor.injected = 3;
        b.sensor.detected = 2;
        b.states_in_scope = 5;
        add_metrics(&mut a, &b);
        add_metrics(&mut a, &b);
        assert_eq!((a.sensor.injected, a.sensor.detected, a.states_in_scope), (6, 4, 10));
    }
}
