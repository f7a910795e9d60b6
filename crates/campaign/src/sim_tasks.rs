//! The simulated experiments of `pmon reproduce` (the paper's plan, [`crate::experiments::plan`]) as
//! independent tasks, for `pmon reproduce --scheduler dask://... | ray://...` (docs/campaigns.md).
//!
//! - A [`SimTask`] is one run of the plan: one built-in scene ([`SceneSpec`]: which variant, its seed and
//!   length) x one parameter set x one fault setting (with its noise) x the run's injection seed, which
//!   [`crate::experiments::plan`] derives from the campaign seed and the run's identity, never from its
//!   position. Its id is the scene's name and a hash of all of that, so it is also a file name.
//! - [`run_task`] runs it on its scene with [`crate::run_one`], the code of the single-process `pmon
//!   reproduce`, and returns counts ([`crate::Metrics`], integers only) and the example frames, no timing.
//!   A worker simulates a scene from its [`SceneSpec`] ([`simulate`]) and may keep it for the next task.
//! - [`tasks`] turns a plan into tasks (runs with the same identity share one task) and tells which task
//!   feeds each planned run, so that the driver rebuilds the run results in plan order and
//!   [`crate::experiments::assemble`] gives the figures of the single-process run, byte for byte.

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};

use pmon_monitor::MonitorParams;
use pmon_scenario::{LidarPreset, ScenarioConfig, Simulator};
use serde::{Deserialize, Serialize};

use crate::experiments::{run_identity, PlannedRun};
use crate::inject::InjectionConfig;
use crate::metrics::{Metrics, TrackTally};
use crate::run::{run_one, Example, RunResult, RunSpec, Scene};

/// `format` of a task description.
pub const TASK_FORMAT: &str = "pmon-reproduce-task/1";
/// `format` of a task result.
pub const RESULT_FORMAT: &str = "pmon-reproduce-result/1";

/// The built-in scenes of `pmon reproduce`, in the order of its scene list (`SceneIds` 0 to 3).
pub const SCENES: [&str; 4] = ["pedestrians", "intersection", "pedestrians_20hz", "pedestrians_paper"];

/// A built-in scene of `pmon reproduce`: enough to simulate it again anywhere.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// One of [`SCENES`].
    pub name: String,
    /// The simulation's seed.
    pub seed: u64,
    /// Length, seconds.
    pub duration_s: f64,
}

/// The simulator's configuration of a scene of `pmon reproduce`. The two scenes of the paper, the residential
/// street once more as a 20 Hz, 32-beam sensor sees it (the paper's update rates span dt = 0.05 to 0.1 s), for
/// the speed errors; and the residential street under the paper's conditions (docs/evaluation.md, "Paper
/// conditions"): the ground truth carries no position uncertainty (CARLA's has none: the region grows by
/// delta_safe only), parked cars are static geometry of the map rather than objects (CARLA lists its actors
/// only), and the street holds half as many pedestrians (the paper spawns "multiple" pedestrians; the built-in
/// street's 120 put about 33 in every frame, nearest neighbours a median 2.7 m apart).
///
/// `duration_s`: the length (`None`: the scenario's own).
///
/// # Errors
/// An unknown scene name, a length that is not positive.
pub fn scenario_config(name: &str, seed: u64, duration_s: Option<f64>) -> Result<ScenarioConfig, String> {
    let builtin = match name {
        "pedestrians" | "pedestrians_20hz" | "pedestrians_paper" => "pedestrians",
        "intersection" => "intersection",
        _ => return Err(format!("no scene `{name}` in pmon reproduce (known: {})", SCENES.join(", "))),
    };
    let mut cfg = ScenarioConfig::builtin(builtin).ok_or_else(|| format!("no built-in scenario `{builtin}`"))?;
    cfg.seed = seed;
    if name == "pedestrians_20hz" {
        cfg.name = name.into();
        cfg.dt_s = 0.05;
        cfg.lidar.preset = LidarPreset::Vlp32;
    }
    if name == "pedestrians_paper" {
        cfg.name = name.into();
        cfg.noise.position_sigma_m = 0.0;
        cfg.noise.size_sigma_m = 0.0;
        cfg.noise.report_sigma = true;
        cfg.agents.parked_as_scenery = true;
        cfg.agents.pedestrians /= 2;
    }
    if let Some(d) = duration_s {
        if !(d.is_finite() && d > 0.0) {
            return Err(format!("scene `{name}`: the length must be positive, got {d} s"));
        }
        cfg.duration_s = d;
    }
    Ok(cfg)
}

/// The scenes of `pmon reproduce`, in the order of [`SCENES`]: `duration_s` when given, else the scenario's
/// own length (at most 15 s with `quick`).
///
/// # Errors
/// A length that is not positive.
pub fn scene_specs(quick: bool, seed: u64, duration_s: Option<f64>) -> Result<Vec<SceneSpec>, String> {
    SCENES
        .iter()
        .map(|&name| {
            let own = scenario_config(name, seed, duration_s)?.duration_s;
            let duration_s = if duration_s.is_none() && quick { own.min(15.0) } else { own };
            Ok(SceneSpec { name: name.into(), seed, duration_s })
        })
        .collect()
}

/// Simulates a scene; `on_frame(done, total)` after every frame (for a progress bar).
///
/// # Errors
/// As [`scenario_config`], or the simulator refuses the configuration.
pub fn simulate(spec: &SceneSpec, on_frame: &dyn Fn(u64, u64)) -> Result<Scene, String> {
    let cfg = scenario_config(&spec.name, spec.seed, Some(spec.duration_s))?;
    let mut sim = Simulator::new(&cfg).map_err(|e| format!("scenario `{}`: {e}", spec.name))?;
    let total = sim.frame_count();
    let mut frames = Vec::new();
    while let Some(f) = sim.step() {
        frames.push(f.frame);
        on_frame(frames.len() as u64, total);
    }
    let builtin = if spec.name == "intersection" { "intersection" } else { "pedestrians" };
    let source = format!(
        "built-in scenario `{builtin}`, seed {}, {} s, dt {} s, {:?} LiDAR",
        spec.seed, cfg.duration_s, cfg.dt_s, cfg.lidar.preset
    );
    Ok(Scene { name: spec.name.clone(), source, frames })
}

/// One task: one run of the plan on one scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimTask {
    /// Always [`TASK_FORMAT`].
    pub format: String,
    /// `<scene>-<16 hex digits>`: the scene's name and a hash (FNV-1a) of the scene and the run.
    pub id: String,
    /// The scene to simulate.
    pub scene: SceneSpec,
    /// Monitor parameters.
    pub params: MonitorParams,
    /// What to inject, with the run's seed.
    pub injection: InjectionConfig,
    /// Plausibility detection window, frames.
    pub window: u64,
}

impl SimTask {
    /// The run as [`run_one`] takes it (its scene is index 0 of a one-scene list).
    #[must_use]
    pub fn spec(&self) -> RunSpec {
        RunSpec { scene: 0, params: self.params, injection: self.injection, window: self.window }
    }
}

/// The tasks of a plan.
#[derive(Clone, Debug)]
pub struct TaskPlan {
    /// The tasks, sorted by id, each once.
    pub tasks: Vec<SimTask>,
    /// For each planned run (in plan order), the index in `tasks` of the task that runs it.
    pub task_of_run: Vec<usize>,
}

/// The tasks of a plan over the scenes `scenes` (indexed as the runs' `scene`): runs with the same identity
/// (scene, parameters, injection and seed, window) share a task.
///
/// # Errors
/// A run refers to a scene that is not in `scenes`; two different runs hash to the same id.
pub fn tasks(planned: &[PlannedRun], scenes: &[SceneSpec]) -> Result<TaskPlan, String> {
    let mut by_id: BTreeMap<String, SimTask> = BTreeMap::new();
    let mut ids = Vec::with_capacity(planned.len());
    for (k, run) in planned.iter().enumerate() {
        let scene = scenes.get(run.spec.scene).ok_or_else(|| format!("run {k}: no scene {}", run.spec.scene))?;
        let identity = format!(
            "{}\n{}\n{}",
            serde_json::to_string(scene).map_err(|e| format!("internal: {e}"))?,
            run_identity(&scene.name, &run.spec),
            run.spec.injection.seed
        );
        let id = format!("{}-{:016x}", scene.name, crate::real_data::evaluate::fnv1a(&identity));
        let task = SimTask {
            format: TASK_FORMAT.into(),
            id: id.clone(),
            scene: scene.clone(),
            params: run.spec.params,
            injection: run.spec.injection,
            window: run.spec.window,
        };
        match by_id.get(&id) {
            Some(old) if *old != task => return Err(format!("two different runs hash to the task id `{id}`")),
            Some(_) => {}
            None => {
                by_id.insert(id.clone(), task);
            }
        }
        ids.push(id);
    }
    let index: BTreeMap<&str, usize> = by_id.keys().enumerate().map(|(i, id)| (id.as_str(), i)).collect();
    let task_of_run = ids.iter().map(|id| index.get(id.as_str()).copied().unwrap_or(0)).collect();
    Ok(TaskPlan { tasks: by_id.into_values().collect(), task_of_run })
}

/// What a task found: the run's counts and example frames. No timing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TaskOutput {
    /// Counts (integers only).
    pub metrics: Metrics,
    /// The sensor checks' counts per track, sorted by id (empty in results written before they were kept).
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
}

impl TaskOutput {
    /// The run result (its timing field, the median check time, is NaN: tasks carry no timing).
    #[must_use]
    pub fn to_run_result(&self) -> RunResult {
        RunResult {
            metrics: self.metrics,
            tracks: self.tracks.clone(),
            detected_example: self.detected_example,
            missed_example: self.missed_example,
            false_alarm_example: self.false_alarm_example,
            occluded_example: self.occluded_example,
            check_median_us: f64::NAN,
        }
    }
}

/// The outcome of a task.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// The run's counts.
    Ok(Box<TaskOutput>),
    /// The run failed (a scene that cannot be simulated, parameters the monitor refuses, a panic).
    Error(String),
}

/// A task's result: its id and outcome, the same bytes wherever it ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskResult {
    /// Always [`RESULT_FORMAT`].
    pub format: String,
    /// The task's id.
    pub id: String,
    /// What happened.
    pub outcome: Outcome,
}

/// Runs a task on its scene (simulated from `task.scene` by the caller, who may keep it for other tasks).
/// Never fails: an error or a panic becomes an [`Outcome::Error`] naming the task.
#[must_use]
pub fn run_task(task: &SimTask, scene: &Scene) -> TaskResult {
    let outcome = match catch_unwind(AssertUnwindSafe(|| {
        if task.format != TASK_FORMAT {
            return Err(format!("task format `{}`, expected `{TASK_FORMAT}`", task.format));
        }
        run_one(scene, &task.spec())
    })) {
        Ok(Ok(r)) => Outcome::Ok(Box::new(TaskOutput {
            metrics: r.metrics,
            tracks: r.tracks,
            detected_example: r.detected_example,
            missed_example: r.missed_example,
            false_alarm_example: r.false_alarm_example,
            occluded_example: r.occluded_example,
        })),
        Ok(Err(e)) => Outcome::Error(format!("{}: {e}", task.id)),
        Err(_) => Outcome::Error(format!("{}: internal error (panic)", task.id)),
    };
    TaskResult { format: RESULT_FORMAT.into(), id: task.id.clone(), outcome }
}

/// Runs a task given as JSON and returns its result as the text of its file (pretty JSON, a final newline).
/// `scene_of` gives the task's scene (a worker's cache, or [`simulate`]); a scene that cannot be made is an
/// error result, not an `Err`.
///
/// # Errors
/// The JSON is not a [`SimTask`].
pub fn run_task_json(
    task_json: &str,
    scene_of: &dyn Fn(&SceneSpec) -> Result<std::sync::Arc<Scene>, String>,
) -> Result<String, String> {
    let task: SimTask = serde_json::from_str(task_json).map_err(|e| format!("task: {e}"))?;
    let result = match catch_unwind(AssertUnwindSafe(|| scene_of(&task.scene))) {
        Ok(Ok(scene)) => run_task(&task, &scene),
        Ok(Err(e)) => TaskResult {
            format: RESULT_FORMAT.into(),
            id: task.id.clone(),
            outcome: Outcome::Error(format!("{}: {e}", task.id)),
        },
        Err(_) => TaskResult {
            format: RESULT_FORMAT.into(),
            id: task.id.clone(),
            outcome: Outcome::Error(format!("{}: internal error (panic while simulating the scene)", task.id)),
        },
    };
    result_json(&result)
}

/// A result as the text of its file: pretty JSON with a final newline.
///
/// # Errors
/// Serialisation (not expected).
pub fn result_json(r: &TaskResult) -> Result<String, String> {
    serde_json::to_string_pretty(r).map(|s| s + "\n").map_err(|e| format!("internal: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::{plan, Scale, SceneIds};

    const IDS: SceneIds =
        SceneIds { pedestrians: 0, intersection: 1, pedestrians_20hz: Some(2), pedestrians_paper: Some(3) };

    #[test]
    fn seeds_come_from_the_identity_not_the_position() {
        let params = MonitorParams::default();
        let a = plan(Scale::Smoke, IDS, &params, 7);
        // The same run, found in another plan (another scale) at another position, has the same seed.
        let b = plan(Scale::Quick, IDS, &params, 7);
        let key = |r: &PlannedRun| (r.spec.scene, run_identity("", &r.spec));
        let (mut common, mut moved) = (0, 0);
        for (i, r) in a.iter().enumerate() {
            if let Some(j) = b.iter().position(|q| key(q) == key(r)) {
                common += 1;
                moved += usize::from(i != j);
                assert_eq!(r.spec.injection.seed, b[j].spec.injection.seed, "{}", key(r).1);
            }
        }
        assert!(common >= 10 && moved > 0, "{common} common runs, {moved} at another position");
        // Another campaign seed, other run seeds.
        let c = plan(Scale::Smoke, IDS, &params, 8);
        assert!(a.iter().zip(&c).all(|(x, y)| x.spec.injection.seed != y.spec.injection.seed));
    }

    /// Adding a params key must not redraw every run: a key added later (`spill_over_fit`, `seen_over`,
    /// `face_in_front`, `roi_graze_fraction`, `roi_graze_height_m`, `seen_body`, `follow_gate`) stays out of the
    /// identity at its default, and the seeds of the paper's default plan stay those of before (pinned: the first
    /// run of the smoke plan at campaign seed 7, the same bytes `pmon reproduce` wrote before the key). The key's
    /// default moved from `occupied` to `every_return` (issue #10): still left out at the default, so the seeds did
    /// not move with it; the other value is in the identity. The same for `roi_graze_fraction`, whose default moved
    /// from 0 to 0.5 (issue #10), and for `seen_body` and `follow_gate`, on by default since issue #10's round
    /// "Rays on the body with step 8 gated".
    #[test]
    fn a_params_key_added_at_its_default_keeps_the_identities() {
        let params = MonitorParams::default();
        let a = plan(Scale::Smoke, IDS, &params, 7);
        let id = run_identity("pedestrians", &a[0].spec);
        assert!(!id.contains("spill_over_fit") && !id.contains("seen_over") && !id.contains("face_in_front"), "{id}");
        assert!(!id.contains("roi_graze") && !id.contains("seen_body") && !id.contains("returns_beyond"), "{id}");
        assert_eq!(a[0].spec.injection.seed, 5_901_858_983_376_117_566, "{id}");
        // `seen_body` and `follow_gate` are on by default since issue #10's round of rays on the body: off, they
        // are in the identity.
        assert!(!id.contains("follow_gate"), "{id}");
        let body = MonitorParams { seen_body: false, follow_gate: false, ..params };
        let d = plan(Scale::Smoke, IDS, &body, 7);
        let id_off = run_identity("pedestrians", &d[0].spec);
        assert!(id_off.contains("\"seen_body\":false") && id_off.contains("\"follow_gate\":false"), "{id_off}");
        assert_ne!(a[0].spec.injection.seed, d[0].spec.injection.seed);
        let over = MonitorParams { seen_over: true, ..params };
        let c = plan(Scale::Smoke, IDS, &over, 7);
        assert!(run_identity("pedestrians", &c[0].spec).contains("\"seen_over\":true"));
        assert_ne!(a[0].spec.injection.seed, c[0].spec.injection.seed);
        let occupied = MonitorParams { spill_over_fit: pmon_monitor::SpillOverFit::Occupied, ..params };
        let b = plan(Scale::Smoke, IDS, &occupied, 7);
        assert!(run_identity("pedestrians", &b[0].spec).contains("\"spill_over_fit\":\"occupied\""));
        assert_ne!(a[0].spec.injection.seed, b[0].spec.injection.seed);
        // The grazing rule's default moved from 0 (off) to 0.5 (issue #10): the default (0.5) is left out, so the
        // default plan's seeds (pinned above) did not move with it; the rule off (0) is now in the identity.
        assert!((params.roi_graze_fraction - 0.5).abs() < f32::EPSILON);
        let off = MonitorParams { roi_graze_fraction: 0.0, ..params };
        let d = plan(Scale::Smoke, IDS, &off, 7);
        assert!(run_identity("pedestrians", &d[0].spec).contains("\"roi_graze_fraction\":0.0"));
        assert_ne!(a[0].spec.injection.seed, d[0].spec.injection.seed);
        // `spill_gap_m` (issue #10's round "Spill-over across a gap") is an `f32` whose default, 0.4, is written
        // `0.4` but reads back as the `f64` 0.4000000059604645: it is left out as written (the pinned seed above),
        // and the key off (0) is in the identity.
        assert!(!id.contains("spill_gap"), "{id}");
        let no_gap = MonitorParams { spill_gap_m: 0.0, ..params };
        let e = plan(Scale::Smoke, IDS, &no_gap, 7);
        let id_no_gap = run_identity("pedestrians", &e[0].spec);
        assert!(id_no_gap.contains("\"spill_gap_m\":0.0"), "{id_no_gap}");
        assert_eq!(id_no_gap.replacen(",\"spill_gap_m\":0.0", "", 1), id);
        assert_ne!(a[0].spec.injection.seed, e[0].spec.injection.seed);
    }

    #[test]
    fn tasks_cover_every_run_and_share_identical_ones() {
        let params = MonitorParams::default();
        let planned = plan(Scale::Smoke, IDS, &params, 7);
        let scenes = scene_specs(false, 7, Some(1.0)).unwrap();
        let tp = tasks(&planned, &scenes).unwrap();
        assert_eq!(tp.task_of_run.len(), planned.len());
        assert!(tp.tasks.windows(2).all(|w| w[0].id < w[1].id));
        for (run, &t) in planned.iter().zip(&tp.task_of_run) {
            let task = &tp.tasks[t];
            assert_eq!(task.injection, run.spec.injection);
            assert_eq!(task.scene, scenes[run.spec.scene]);
            assert!(task.id.starts_with(&task.scene.name));
        }
        // A task's JSON goes through a worker unchanged.
        let text = serde_json::to_string(&tp.tasks[0]).unwrap();
        assert_eq!(serde_json::from_str::<SimTask>(&text).unwrap(), tp.tasks[0]);
        assert!(tasks(&planned, &scenes[..2]).is_err());
    }

    #[test]
    fn a_task_gives_the_counts_of_the_single_process_run() {
        let params = MonitorParams::default();
        let planned = plan(Scale::Smoke, IDS, &params, 7);
        let specs = scene_specs(false, 7, Some(0.6)).unwrap();
        let tp = tasks(&planned, &specs).unwrap();
        let k = planned.iter().position(|r| r.spec.scene == 1 && r.spec.injection.fault != crate::Fault::None).unwrap();
        let scene = simulate(&specs[1], &|_, _| {}).unwrap();
        let direct = run_one(&scene, &RunSpec { scene: 0, ..planned[k].spec.clone() }).unwrap();
        let task = &tp.tasks[tp.task_of_run[k]];
        let text =
            run_task_json(&serde_json::to_string(task).unwrap(), &|s| simulate(s, &|_, _| {}).map(std::sync::Arc::new))
                .unwrap();
        let r: TaskResult = serde_json::from_str(&text).unwrap();
        let Outcome::Ok(out) = r.outcome else { panic!("{text}") };
        assert_eq!(out.metrics, direct.metrics);
        assert!(out.metrics.sensor.injected > 0);
        // The per-track counts travel too, sorted by id, and add up to the run's totals.
        assert_eq!(out.tracks, direct.tracks);
        assert!(out.tracks.windows(2).all(|w| w[0].id < w[1].id) && !out.tracks.is_empty());
        let sum = |f: fn(&TrackTally) -> u64| out.tracks.iter().map(f).sum::<u64>();
        let (m, v) = (out.metrics.sensor, out.metrics.sensor_verifiable);
        assert_eq!(
            (sum(|t| t.verifiable), sum(|t| t.detected), sum(|t| t.alarms), sum(|t| t.true_alarms)),
            (v.injected, v.detected, m.alarms, m.true_alarms)
        );
        // A result written before the per-track counts were kept still reads (with none).
        let mut old: serde_json::Value = serde_json::from_str(&text).unwrap();
        old["outcome"]["ok"].as_object_mut().unwrap().remove("tracks").unwrap();
        let old: TaskResult = serde_json::from_value(old).unwrap();
        let Outcome::Ok(old) = old.outcome else { panic!("{text}") };
        assert!(old.tracks.is_empty() && old.metrics == direct.metrics);
        // A scene that cannot be made is an error result naming the task, not a failure of the call.
        let mut bad = task.clone();
        bad.scene.name = "moon".into();
        let text =
            run_task_json(&serde_json::to_string(&bad).unwrap(), &|s| simulate(s, &|_, _| {}).map(std::sync::Arc::new))
                .unwrap();
        assert!(text.contains("error") && text.contains("moon"), "{text}");
        assert!(run_task_json("{", &|s| simulate(s, &|_, _| {}).map(std::sync::Arc::new)).is_err());
    }
}
