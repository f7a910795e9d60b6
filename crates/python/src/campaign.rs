//! One campaign task in Rust, for `pmon.campaign` (docs/campaigns.md, "Sharded campaigns"): a built-in scene
//! simulated, a fault injected, the monitor run over every frame and the run scored by
//! [`pmon_campaign::run_one`], the same code as `pmon reproduce`. The task comes in as JSON and its counts go
//! out as JSON, so a task is a plain string a Dask or Ray worker can ship, and its result merges by adding
//! integers (exact, associative). The randomness is seeded by the task's fields (the scene seed and the
//! injection seed it carries), never by the order in which a worker happens to run it.
//!
//! `run_reproduce_task` runs one task of `pmon reproduce --scheduler ...` (`pmon_campaign::sim_tasks`) and
//! `run_evaluation_task` one of `pmon evaluate`.
//!
//! Scenes are simulated once per process and kept (keyed by scenario, seed and duration): a worker that runs
//! many tasks on the same scene pays for the simulation once. At most [`SCENES_KEPT`] scenes are kept, the ones
//! used last, so a long campaign over many scenes does not grow a worker's memory without bound.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

use pmon_campaign::{run_one, Fault, InjectionConfig, RunSpec, Scene};
use pmon_scenario::{ScenarioConfig, Simulator};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde::{Deserialize, Serialize};

/// One task: what to simulate, what to inject, with which parameters.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Task {
    /// A built-in scenario (`pedestrians`, `intersection`).
    scenario: String,
    /// The simulation's seed.
    scene_seed: u64,
    /// Length of the scene, seconds (the scenario's own when absent).
    #[serde(default)]
    duration_s: Option<f64>,
    /// Monitor parameters over the defaults (any subset, as `pmon.Params`), already validated by Python and
    /// validated again here.
    #[serde(default)]
    params: Option<serde_json::Value>,
    /// The fault (`{"kind": "permanent_position", "magnitude_m": 1.0, "direction": "random"}`, ...).
    fault: Fault,
    /// The injection's seed.
    injection_seed: u64,
    /// Gaussian position noise on every object, metres.
    #[serde(default)]
    position_noise_m: f32,
    /// Fraction of tracks with a permanent fault.
    #[serde(default = "half")]
    permanent_track_fraction: f64,
    /// Plausibility window, frames.
    #[serde(default = "two")]
    window: u64,
}

const fn half() -> f64 {
    0.5
}

const fn two() -> u64 {
    2
}

/// What a task returns: counts only (no rates, no timings), so results merge by addition.
#[derive(Serialize)]
struct TaskResult {
    metrics: pmon_campaign::Metrics,
}

type SceneKey = (String, u64, Option<u64>);

/// The most scenes a worker process keeps (a 15 s built-in scene with its LiDAR sweeps is tens of MB).
const SCENES_KEPT: usize = 8;

/// The scenes kept, each with the tick of its last use.
#[derive(Default)]
struct SceneCache {
    tick: u64,
    scenes: BTreeMap<SceneKey, (u64, Arc<Scene>)>,
}

impl SceneCache {
    fn get(&mut self, key: &SceneKey) -> Option<Arc<Scene>> {
        self.tick += 1;
        let tick = self.tick;
        self.scenes.get_mut(key).map(|(used, s)| {
            *used = tick;
            Arc::clone(s)
        })
    }

    /// Keeps `scene` (or the one another thread kept first) and drops the least recently used beyond the cap.
    fn keep(&mut self, key: SceneKey, scene: Arc<Scene>) -> Arc<Scene> {
        self.tick += 1;
        let tick = self.tick;
        let kept = Arc::clone(&self.scenes.entry(key).or_insert((tick, scene)).1);
        while self.scenes.len() > SCENES_KEPT {
            let Some(oldest) = self.scenes.iter().min_by_key(|(_, (used, _))| *used).map(|(k, _)| k.clone()) else {
                break;
            };
            self.scenes.remove(&oldest);
        }
        kept
    }
}

fn scene_cache() -> &'static Mutex<SceneCache> {
    static CACHE: OnceLock<Mutex<SceneCache>> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(SceneCache::default()))
}

fn scene_for(task: &Task) -> Result<Arc<Scene>, String> {
    let key = (task.scenario.clone(), task.scene_seed, task.duration_s.map(f64::to_bits));
    if let Some(s) = scene_cache().lock().unwrap_or_else(PoisonError::into_inner).get(&key) {
        return Ok(s);
    }
    let mut cfg = ScenarioConfig::builtin(&task.scenario)
        .ok_or_else(|| format!("no built-in scenario `{}` (pedestrians, intersection)", task.scenario))?;
    cfg.seed = task.scene_seed;
    if let Some(d) = task.duration_s {
        if !(d.is_finite() && d > 0.0) {
            return Err(format!("duration_s must be positive, got {d}"));
        }
        cfg.duration_s = d;
    }
    let mut sim = Simulator::new(&cfg).map_err(|e| format!("scenario `{}`: {e}", task.scenario))?;
    let mut frames = Vec::new();
    while let Some(f) = sim.step() {
        frames.push(f.frame);
    }
    let source = format!("built-in scenario `{}`, seed {}, {} s", task.scenario, task.scene_seed, cfg.duration_s);
    let scene = Arc::new(Scene { name: task.scenario.clone(), source, frames });
    // Two threads may simulate the same scene at once; both give the same frames, the first one stays.
    Ok(scene_cache().lock().unwrap_or_else(PoisonError::into_inner).keep(key, scene))
}

fn run_task_json(task_json: &str) -> Result<String, String> {
    let task: Task = serde_json::from_str(task_json).map_err(|e| format!("task: {e}"))?;
    let params = match &task.params {
        None => pmon_monitor::MonitorParams::default(),
        Some(over) => {
            let text = crate::params::validate_params_json(&over.to_string(), None).map_err(|e| e.to_string())?;
            serde_json::from_str(&text).map_err(|e| format!("parameters: {e}"))?
        }
    };
    if !(0.0..=1.0).contains(&task.permanent_track_fraction) {
        return Err(format!("permanent_track_fraction must be in [0, 1], got {}", task.permanent_track_fraction));
    }
    if !(task.position_noise_m.is_finite() && task.position_noise_m >= 0.0) {
        return Err(format!("position_noise_m must be finite and >= 0, got {}", task.position_noise_m));
    }
    let scene = scene_for(&task)?;
    let mut injection = InjectionConfig::new(task.fault, task.injection_seed);
    injection.position_noise_m = task.position_noise_m;
    injection.permanent_track_fraction = task.permanent_track_fraction;
    let spec = RunSpec { scene: 0, params, injection, window: task.window };
    let result = run_one(&scene, &spec)?;
    serde_json::to_string(&TaskResult { metrics: result.metrics }).map_err(|e| format!("internal: {e}"))
}

/// Runs one campaign task (JSON, see [`Task`]) and returns its counts as JSON. The GIL is released while it
/// runs. A bad task (unknown key, unknown scenario, parameters out of range) raises `ValueError`.
#[pyfunction]
pub fn run_campaign_task(py: Python<'_>, task_json: &str) -> PyResult<String> {
    let task_json = task_json.to_owned();
    py.detach(move || run_task_json(&task_json)).map_err(PyValueError::new_err)
}

/// The scenes this process keeps for `run_campaign_task` (scenario, seed, duration in seconds or `None`), least
/// recently used first. For tests and diagnostics.
#[pyfunction]
pub fn _cached_scenes() -> Vec<(String, u64, Option<f64>)> {
    let cache = scene_cache().lock().unwrap_or_else(PoisonError::into_inner);
    let mut kept: Vec<(&SceneKey, u64)> = cache.scenes.iter().map(|(k, (used, _))| (k, *used)).collect();
    kept.sort_by_key(|(_, used)| *used);
    kept.into_iter().map(|((name, seed, d), _)| (name.clone(), *seed, d.map(f64::from_bits))).collect()
}

/// Runs one task of `pmon evaluate` (JSON, `pmon_campaign::real_data::evaluate::LogTask`) and returns its
/// result file's text (JSON). The GIL is released while it runs. A log that fails on its data gives a result
/// holding the error; only a task that is not valid JSON raises `ValueError`.
#[pyfunction]
pub fn run_evaluation_task(py: Python<'_>, task_json: &str) -> PyResult<String> {
    let task_json = task_json.to_owned();
    py.detach(move || pmon_campaign::real_data::evaluate::run_task_json(&task_json)).map_err(PyValueError::new_err)
}

type ReproduceSceneKey = String;

/// The scenes of `pmon reproduce` this process has simulated (at most the four of one campaign's scale and
/// seed are kept: the cache is emptied when a fifth distinct scene comes), keyed by their JSON description.
fn reproduce_scene_cache() -> &'static Mutex<BTreeMap<ReproduceSceneKey, Arc<Scene>>> {
    static CACHE: OnceLock<Mutex<BTreeMap<ReproduceSceneKey, Arc<Scene>>>> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(BTreeMap::new()))
}

fn reproduce_scene(spec: &pmon_campaign::sim_tasks::SceneSpec) -> Result<Arc<Scene>, String> {
    let key = serde_json::to_string(spec).map_err(|e| format!("internal: {e}"))?;
    if let Some(s) = reproduce_scene_cache().lock().unwrap_or_else(PoisonError::into_inner).get(&key) {
        return Ok(Arc::clone(s));
    }
    let scene = Arc::new(pmon_campaign::sim_tasks::simulate(spec, &|_, _| {})?);
    let mut cache = reproduce_scene_cache().lock().unwrap_or_else(PoisonError::into_inner);
    if cache.len() >= pmon_campaign::sim_tasks::SCENES.len() && !cache.contains_key(&key) {
        cache.clear();
    }
    Ok(Arc::clone(cache.entry(key).or_insert(scene)))
}

/// Runs one task of `pmon reproduce --scheduler ...` (JSON, `pmon_campaign::sim_tasks::SimTask`: one run of the
/// paper's plan on a built-in scene, simulated here once per process and kept) and returns its result file's
/// text (JSON: counts and example frames, no timing). The GIL is released while it runs. A run that fails gives
/// a result holding the error; only a task that is not valid JSON raises `ValueError`.
#[pyfunction]
pub fn run_reproduce_task(py: Python<'_>, task_json: &str) -> PyResult<String> {
    let task_json = task_json.to_owned();
    py.detach(move || pmon_campaign::sim_tasks::run_task_json(&task_json, &reproduce_scene))
        .map_err(PyValueError::new_err)
}
