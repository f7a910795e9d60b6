//! Runs the monitor over a scene with a fault injected, and scores it.

use std::collections::BTreeSet;
use std::time::Instant;

use pmon_monitor::{
    ClusterReport, Monitor, MonitorParams, NotMonitoredReason, ObjectReport, ObjectState, SensorVerdict,
};
use pmon_recording::RecordedFrame;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::inject::{Injection, InjectionConfig, Injector};
use crate::metrics::{offset_outcome, score, score_by_track, Metrics, Outcome, TrackTally};

/// Frames to evaluate on: clean object lists (ground truth with their nominal uncertainty), clouds and ROI.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Name, e.g. "pedestrians".
    pub name: String,
    /// Where it came from (scenario, seed, dataset).
    pub source: String,
    /// The frames, in time order.
    pub frames: Vec<RecordedFrame>,
}

impl Scene {
    /// The frames' object lists, in order (what [`Injector::for_scene`] and
    /// [`crate::inject::isolated_tracks`] read).
    pub fn object_lists(&self) -> impl Iterator<Item = &[ObjectState]> {
        self.frames.iter().map(|f| f.objects.as_slice())
    }

    /// The injector of a run of `spec` over this scene.
    #[must_use]
    pub fn injector(&self, spec: &RunSpec) -> Injector {
        Injector::for_scene(spec.injection, self.object_lists())
    }
}

/// One run: a scene, monitor parameters and an injection.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunSpec {
    /// Index of the scene in the list given to [`run_all`].
    pub scene: usize,
    /// Monitor parameters.
    pub params: MonitorParams,
    /// What to inject.
    pub injection: InjectionConfig,
    /// Plausibility detection window, frames (the paper: 2).
    pub window: u64,
}

/// An object state worth a picture: the first detected and the first missed injection of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Example {
    /// Frame index.
    pub frame: u64,
    /// Object id.
    pub id: u64,
}

/// The result of one run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RunResult {
    /// Scores.
    pub metrics: Metrics,
    /// The sensor checks' counts per track, sorted by id ([`crate::metrics::score_by_track`]): the clusters of the
    /// intervals by track. Empty in results written before they were kept.
    #[serde(default)]
    pub tracks: Vec<TrackTally>,
    /// First injected error the sensor checks detected.
    pub detected_example: Option<Example>,
    /// First injected error the sensor checks judged and missed.
    pub missed_example: Option<Example>,
    /// First clean object state the sensor checks flagged.
    pub false_alarm_example: Option<Example>,
    /// First injected error on an object the sensor checks called occluded.
    pub occluded_example: Option<Example>,
    /// Median wall time of `Monitor::check` per frame, microseconds (informative only; see the benchmarks).
    pub check_median_us: f64,
}

/// In the scoring's scope (docs/evaluation.md, "Scoring"): every sensor verdict but *not monitored* because the
/// footprint lies outside the grid or the state is invalid.
#[must_use]
pub fn in_scope(verdict: SensorVerdict) -> bool {
    !matches!(verdict, SensorVerdict::NotMonitored(NotMonitoredReason::OutsideGrid | NotMonitoredReason::InvalidState))
}

/// Confirmed by evidence of its own (`eta_own >= tau_tp`) and monitored: on the clean frame, what makes an injected
/// error *verifiable* by the LiDAR (docs/evaluation.md, "Scoring").
#[must_use]
pub fn confirmed_by_own_evidence(report: &ObjectReport, tau_tp: f32) -> bool {
    !matches!(report.sensor.verdict, SensorVerdict::NotMonitored(_)) && report.sensor.eta_own >= tau_tp
}

/// One frame of a paired run ([`paired_frames`]): the clean object list and the faulted one, checked side by side.
pub struct PairedFrame<'a> {
    /// Frame index.
    pub k: usize,
    /// The clean frame: ground-truth object list, cloud, ROI.
    pub clean: &'a RecordedFrame,
    /// The object list with the errors injected (what the faulted monitor checked).
    pub objects: &'a [ObjectState],
    /// What was injected in this frame.
    pub injections: &'a [Injection],
    /// Per object: confirmed by its own evidence in the clean frame ([`confirmed_by_own_evidence`]): an error
    /// on it is *verifiable*.
    pub confirmed: &'a [bool],
    /// The faulted monitor's reports, one per object.
    pub reports: &'a [ObjectReport],
    /// The faulted monitor's conflict clusters.
    pub clusters: &'a [ClusterReport],
    /// The faulted monitor after the frame (its grid holds this frame).
    pub monitor: &'a Monitor,
    /// The monitor of the clean frames after the frame (for `region_of`).
    pub clean_monitor: &'a Monitor,
    /// Time of the faulted check alone, microseconds.
    pub check_us: f64,
}

/// The loop of a paired run, shared by [`run_one`] and the diagnostics: per frame, the errors of `spec` are
/// injected into a copy of the object list; a monitor on the clean frames says which objects their own evidence
/// confirms; a second monitor checks the faulted frame; `f` sees both.
///
/// # Errors
/// Invalid parameters, a frame the monitor refuses (named by scene and frame), or `f`'s error.
pub fn paired_frames(
    scene: &Scene,
    spec: &RunSpec,
    f: impl FnMut(&PairedFrame<'_>) -> Result<(), String>,
) -> Result<(), String> {
    paired_frames_with(scene, spec, scene.injector(spec), f)
}

/// [`paired_frames`] with a given injector (for example one that displaces a single track,
/// [`Injector::with_faulty_tracks`]).
///
/// # Errors
/// As [`paired_frames`].
pub fn paired_frames_with(
    scene: &Scene,
    spec: &RunSpec,
    mut injector: Injector,
    mut f: impl FnMut(&PairedFrame<'_>) -> Result<(), String>,
) -> Result<(), String> {
    let mut monitor = Monitor::new(spec.params).map_err(|e| e.to_string())?;
    // The same monitor on the clean frames tells which objects the sensor can verify at all.
    let mut clean_monitor = Monitor::new(spec.params).map_err(|e| e.to_string())?;
    let (mut objects, mut confirmed, mut reports, mut clusters) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, clean) in scene.frames.iter().enumerate() {
        // Only the object list changes: copy it, lend the clean cloud.
        objects.clone_from(&clean.objects);
        let injections = injector.apply_at(k as u64, clean.timestamp_s, &mut objects);
        let mut roi = Vec::new();
        let mut view = clean.as_frame(&mut roi);
        {
            let clean_report = clean_monitor.check(&view).map_err(|e| format!("{}: frame {k}: {e}", scene.name))?;
            confirmed.clear();
            confirmed.extend(clean_report.objects.iter().map(|r| confirmed_by_own_evidence(r, spec.params.tau_tp)));
        }
        view.objects = &objects;
        let t0 = Instant::now();
        let report = monitor.check(&view).map_err(|e| format!("{}: frame {k}: {e}", scene.name))?;
        let check_us = t0.elapsed().as_secs_f64() * 1e6;
        reports.clear();
        reports.extend_from_slice(report.objects);
        clusters.clear();
        clusters.extend_from_slice(report.clusters);
        f(&PairedFrame {
            k,
            clean,
            objects: &objects,
            injections: &injections,
            confirmed: &confirmed,
            reports: &reports,
            clusters: &clusters,
            monitor: &monitor,
            clean_monitor: &clean_monitor,
            check_us,
        })?;
    }
    Ok(())
}

/// Runs one spec on a scene.
///
/// # Errors
/// Invalid parameters, or a frame the monitor refuses.
pub fn run_one(scene: &Scene, spec: &RunSpec) -> Result<RunResult, String> {
    run_one_with(scene, spec, scene.injector(spec))
}

/// [`run_one`] with a given injector (see [`paired_frames_with`]).
///
/// # Errors
/// As [`run_one`].
pub fn run_one_with(scene: &Scene, spec: &RunSpec, injector: Injector) -> Result<RunResult, String> {
    run_one_split(scene, spec, injector, &BTreeSet::new()).map(|(r, _)| r)
}

/// [`run_one_with`], its object states split by track: the result over the tracks not in `apart`, and the
/// [`Metrics`] of the states of the tracks in `apart` scored on their own (with the same window; they count in
/// neither the examples nor the timings, and every missed-object alarm goes to the first). With `apart` empty, the
/// first is [`run_one_with`]'s result.
///
/// # Errors
/// As [`run_one`].
pub fn run_one_split(
    scene: &Scene,
    spec: &RunSpec,
    injector: Injector,
    apart: &BTreeSet<u64>,
) -> Result<(RunResult, Metrics), String> {
    let mut outcomes = Vec::new();
    let mut apart_outcomes = Vec::new();
    let mut missed = 0u64;
    let mut times = Vec::with_capacity(scene.frames.len());
    let (mut detected_example, mut missed_example, mut false_alarm_example, mut occluded_example) =
        (None, None, None, None);
    // Per object of the frame: the position offset injected into it (`None`: nothing injected).
    let mut injected: Vec<Option<[f32; 2]>> = Vec::new();
    paired_frames_with(scene, spec, injector, |p| {
        let k = p.k;
        injected.clear();
        injected.resize(p.objects.len(), None);
        for i in p.injections {
            if let Some(x) = injected.get_mut(i.index as usize) {
                *x = Some(i.offset_m);
            }
        }
        times.push(p.check_us);
        missed += p.clusters.iter().filter(|c| c.is_missed_object()).count() as u64;
        for (i, r) in p.reports.iter().enumerate() {
            let in_scope = in_scope(r.sensor.verdict);
            let set_apart = apart.contains(&r.id);
            let sensor_alarm = matches!(r.sensor.verdict, SensorVerdict::Ghost | SensorVerdict::PositionError);
            let offset = injected.get(i).copied().flatten();
            let inj = offset.is_some();
            let o = Outcome {
                frame: k as u64,
                id: r.id,
                in_scope,
                injected: inj,
                sensor_alarm,
                sensor_judged: p.confirmed.get(i).copied().unwrap_or(false),
                plausibility_alarm: matches!(r.motion.verdict, pmon_monitor::MotionVerdict::Implausible(_)),
                // A position error flagged: does the verdict report its displacement?
                sensor_offset_agrees: offset_outcome(&r.sensor, p.clusters, p.clean.objects.get(i), offset),
                sensor_cause: crate::metrics::cause_index(&r.sensor),
            };
            if set_apart {
                apart_outcomes.push(o);
                continue;
            }
            if in_scope {
                let ex = Some(Example { frame: k as u64, id: r.id });
                if inj && sensor_alarm && detected_example.is_none() {
                    detected_example = ex;
                }
                if inj && o.sensor_judged && !sensor_alarm && missed_example.is_none() {
                    missed_example = ex;
                }
                if !inj && sensor_alarm && false_alarm_example.is_none() {
                    false_alarm_example = ex;
                }
                if inj
                    && r.sensor.verdict == SensorVerdict::NotMonitored(NotMonitoredReason::Occluded)
                    && occluded_example.is_none()
                {
                    occluded_example = ex;
                }
            }
            outcomes.push(o);
        }
        Ok(())
    })?;
    times.sort_by(f64::total_cmp);
    let check_median_us = times.get(times.len() / 2).copied().unwrap_or(f64::NAN);
    let frames = scene.frames.len() as u64;
    let (metrics, tracks) = score_by_track(&outcomes, spec.window, frames, missed);
    Ok((
        RunResult {
            metrics,
            tracks,
            detected_example,
            missed_example,
            false_alarm_example,
            occluded_example,
            check_median_us,
        },
        score(&apart_outcomes, spec.window, frames, 0),
    ))
}

/// What running each of `tracks` alone (the only faulty track of the run, [`Injector::with_faulty_tracks`])
/// scores, summed: the check that a run of one object at a time ([`InjectionConfig::isolation_m`]) is that.
///
/// Like is compared with like: every object state of the set's run is scored in the single run that stands for it.
/// A state of a track of the set is an error there, so it is scored in that track's own run (its detections and
/// true alarms); a state of any other track is clean in every run, so it is scored in the clean run, plus what
/// each single run changes there (the false alarms). An alarm that track A's run raises on another track B of the
/// set (clean in A's run) is therefore not one of A's false alarms: in the set's run that state is B's error,
/// judged in B's own run. Such alarms are counted apart (`alarms_on_the_set`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AloneSums {
    /// Verifiable errors, summed over the runs.
    pub verifiable_injected: u64,
    /// Of those, detected.
    pub verifiable_detected: u64,
    /// Alarms explained by an injection, summed.
    pub true_alarms: u64,
    /// False alarms on the tracks not in the set: each run's less the clean run's, summed, plus the clean run's
    /// once.
    pub false_alarms: u64,
    /// The false alarms of the run with no faulty track on the tracks not in the set.
    pub baseline_false_alarms: u64,
    /// Runs with fewer such false alarms than the clean run (a faulty track that silenced a clean run's alarm;
    /// counted as 0 in `false_alarms`).
    pub below_baseline: u64,
    /// Alarms each single run raises on the other tracks of the set (clean in that run), summed over the runs:
    /// left out of `false_alarms` (see above). Beyond the clean run's alarms on them, they are effects of one
    /// faulty track on another one of the set.
    pub alarms_on_the_set: u64,
    /// The clean run's alarms on the tracks of the set, times the number of single runs less one (what
    /// `alarms_on_the_set` holds when no single run changes another track of the set).
    pub baseline_alarms_on_the_set: u64,
}

/// Runs `spec` on `scene` once per track of `tracks` with that track alone faulty, and once with none (in parallel;
/// the sums do not depend on the order), and sums their scores, like with like ([`AloneSums`]).
///
/// # Errors
/// As [`run_one`].
pub fn each_track_alone(scene: &Scene, spec: &RunSpec, tracks: &BTreeSet<u64>) -> Result<AloneSums, String> {
    let sets: Vec<BTreeSet<u64>> =
        tracks.iter().map(|&id| BTreeSet::from([id])).chain(std::iter::once(BTreeSet::new())).collect();
    let metrics = sets
        .into_par_iter()
        .map(|set| {
            // The other tracks of the set are scored apart.
            let apart: BTreeSet<u64> = tracks.difference(&set).copied().collect();
            run_one_split(scene, spec, Injector::with_faulty_tracks(spec.injection, set), &apart)
                .map(|(r, on_set)| (r.metrics, on_set))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (singles, baseline) = metrics.split_at(metrics.len().saturating_sub(1));
    let fa0 = baseline.first().map_or(0, |b| b.0.sensor.false_alarms());
    let on_set0 = baseline.first().map_or(0, |b| b.1.sensor.alarms);
    let sum = |f: &dyn Fn(&(Metrics, Metrics)) -> u64| singles.iter().map(f).sum::<u64>();
    Ok(AloneSums {
        verifiable_injected: sum(&|m| m.0.sensor_verifiable.injected),
        verifiable_detected: sum(&|m| m.0.sensor_verifiable.detected),
        true_alarms: sum(&|m| m.0.sensor.true_alarms),
        false_alarms: sum(&|m| m.0.sensor.false_alarms().saturating_sub(fa0)) + fa0,
        baseline_false_alarms: fa0,
        below_baseline: sum(&|m| u64::from(m.0.sensor.false_alarms() < fa0)),
        alarms_on_the_set: sum(&|m| m.1.sensor.alarms),
        baseline_alarms_on_the_set: on_set0 * (singles.len() as u64).saturating_sub(1),
    })
}

/// Runs every spec in parallel (rayon); results come back in spec order, identical whatever the number of
/// threads (timings aside). `progress` is called once per finished run.
///
/// # Errors
/// The first failing run's error.
pub fn run_all(scenes: &[Scene], specs: &[RunSpec], progress: &(dyn Fn() + Sync)) -> Result<Vec<RunResult>, String> {
    specs
        .par_iter()
        .map(|spec| {
            let scene = scenes.get(spec.scene).ok_or_else(|| format!("no scene {}", spec.scene))?;
            let r = run_one(scene, spec);
            progress();
            r
        })
        .collect()
}

/// The monitor's view of one frame of a run, for pictures: the injected object list, what was injected,
/// the reports, and the monitor (whose grid holds that frame).
pub struct Replay {
    /// The monitor after the frame.
    pub monitor: Monitor,
    /// The frame as the monitor saw it (object list with the errors).
    pub frame: RecordedFrame,
    /// What was injected in that frame.
    pub injections: Vec<crate::inject::Injection>,
    /// Reports, one per object.
    pub objects: Vec<pmon_monitor::ObjectReport>,
    /// Conflict clusters.
    pub clusters: Vec<pmon_monitor::ClusterReport>,
}

/// Runs a spec up to and including frame `k` and returns the monitor's view of that frame.
///
/// # Errors
/// As [`run_one`], or `k` beyond the scene.
pub fn replay_to(scene: &Scene, spec: &RunSpec, k: usize) -> Result<Replay, String> {
    if k >= scene.frames.len() {
        return Err(format!("{} has {} frames, no frame {k}", scene.name, scene.frames.len()));
    }
    let mut monitor = Monitor::new(spec.params).map_err(|e| e.to_string())?;
    let mut injector = scene.injector(spec);
    for (i, clean) in scene.frames.iter().enumerate().take(k + 1) {
        let mut frame = clean.clone();
        let injections = injector.apply_at(i as u64, clean.timestamp_s, &mut frame.objects);
        let (objects, clusters) = {
            let mut roi = Vec::new();
            let view = frame.as_frame(&mut roi);
            let report = monitor.check(&view).map_err(|e| format!("{}: frame {i}: {e}", scene.name))?;
            (report.objects.to_vec(), report.clusters.to_vec())
        };
        if i == k {
            return Ok(Replay { monitor, frame, injections, objects, clusters });
        }
    }
    Err(format!("{}: frame {k} not reached", scene.name))
}
