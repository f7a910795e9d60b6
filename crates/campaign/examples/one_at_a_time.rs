//! How close the "one object at a time" runs of `pmon reproduce` (figure `permanent_position_one`: the faulty
//! tracks of a run chosen so that no two ever come within `experiments::ISOLATION_M` of each other) come to
//! running each faulty track alone (docs/evaluation.md, "One object at a time"):
//!
//! `cargo run --release -p pmon-campaign --example one_at_a_time -- SEED [MAGNITUDE ...]`
//!
//! For each magnitude (default 1.0 and 2.0 m) and both cell sizes it takes the plan's run (`--quick` plan, or with
//! `FULL=1` the full plan; the
//! same scene, injection seed and faulty tracks as `pmon reproduce --quick --seed SEED`), prints how many tracks
//! carry the error and how many the scene has, then runs the scene once per faulty track with that track alone
//! displaced, and once with none (the clean baseline). It prints the isolated run's verifiable detections and
//! alarms beside the sums over the single-track runs (the false alarms of the single runs less the baseline's,
//! each counted once, plus the baseline's): equal counts mean the isolated run *is* the one-at-a-time run.
use std::collections::BTreeSet;

use pmon_campaign::experiments::{self, Scale, SceneIds};
use pmon_campaign::inject::isolated_tracks;
use pmon_campaign::run::{each_track_alone, run_one};
use pmon_campaign::Scene;
use pmon_monitor::MonitorParams;
use pmon_scenario::Simulator;

fn pedestrians(seed: u64, full: bool) -> Result<Scene, Box<dyn std::error::Error>> {
    for spec in pmon_campaign::sim_tasks::scene_specs(!full, seed, None)? {
        if spec.name == "pedestrians" {
            let cfg = pmon_campaign::sim_tasks::scenario_config(&spec.name, spec.seed, Some(spec.duration_s))?;
            let mut sim = Simulator::new(&cfg).map_err(|e| format!("{}: {e}", spec.name))?;
            let mut frames = Vec::new();
            while let Some(f) = sim.step() {
                frames.push(f.frame);
            }
            return Ok(Scene { name: spec.name.clone(), source: String::new(), frames });
        }
    }
    Err("no pedestrians scene in the quick plan".into())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map_or(Ok(7), |s| s.parse())?;
    let mags: Vec<f64> =
        if args.len() > 2 { args.iter().skip(2).map(|s| s.parse()).collect::<Result<_, _>>()? } else { vec![1.0, 2.0] };
    // `FULL=1`: the full plan's scene and runs (`pmon reproduce` without `--quick`).
    let full = std::env::var_os("FULL").is_some();
    let scene = pedestrians(seed, full)?;
    // The pedestrians scene is index 0 here: the plan's runs name it by `ids.pedestrians`.
    let ids = SceneIds { pedestrians: 0, intersection: 1, pedestrians_20hz: None, pedestrians_paper: None };
    let scale = if full { Scale::Full } else { Scale::Quick };
    let plan = experiments::plan(scale, ids, &MonitorParams::default(), seed);
    let tracks: BTreeSet<u64> = scene.frames.iter().flat_map(|f| f.objects.iter().map(|o| o.id)).collect();
    let per_frame =
        scene.frames.iter().map(|f| f.objects.len()).sum::<usize>() as f64 / scene.frames.len().max(1) as f64;
    println!(
        "seed {seed}: pedestrians scene, {} frames, {} tracks, {per_frame:.1} objects per frame; isolation {} m",
        scene.frames.len(),
        tracks.len(),
        experiments::ISOLATION_M
    );
    for &m in &mags {
        for run in plan
            .iter()
            .filter(|r| r.probes.iter().any(|p| p.figure == "permanent_position_one" && (p.x - m).abs() < 1e-9))
        {
            let mut spec = run.spec.clone();
            // `ISOLATION=M`: another radius (the plan's run otherwise).
            if let Some(r) = std::env::var("ISOLATION").ok().and_then(|v| v.parse::<f32>().ok()) {
                spec.injection.isolation_m = r;
            }
            let spec = &spec;
            let cells = spec.params.cell_size_m;
            let faulty =
                isolated_tracks(spec.injection.isolation_m, spec.injection.isolation_set, scene.object_lists());
            let isolated = run_one(&scene, spec)?.metrics;
            let alone = each_track_alone(&scene, spec, &faulty)?;
            let (det, inj, true_alarms, fa, fa0) = (
                alone.verifiable_detected,
                alone.verifiable_injected,
                alone.true_alarms,
                alone.false_alarms,
                alone.baseline_false_alarms,
            );
            let pct = |a: u64, b: u64| if b == 0 { f64::NAN } else { 100.0 * a as f64 / b as f64 };
            println!(
                "{m:.1} m, {cells} m cells, set {}: {} faulty tracks | isolated run: verifiable {}/{} ({:.1} %), alarms {} true {} false ({:.1} % precision) | each alone: verifiable {det}/{inj} ({:.1} %), alarms {true_alarms} true {fa} false ({:.1} %); clean baseline {fa0} false alarms",
                spec.injection.isolation_set,
                faulty.len(),
                isolated.sensor_verifiable.detected,
                isolated.sensor_verifiable.injected,
                pct(isolated.sensor_verifiable.detected, isolated.sensor_verifiable.injected),
                isolated.sensor.true_alarms,
                isolated.sensor.false_alarms(),
                pct(isolated.sensor.true_alarms, isolated.sensor.alarms),
                pct(det, inj),
                pct(true_alarms, true_alarms + fa),
            );
        }
    }
    Ok(())
}
