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
//! alarms beside the sums over the single-track runs, like with like (`run::each_track_alone`: a state of a track of
//! the set is scored in that track's own run; the false alarms are those on the other tracks, each single run's less
//! the baseline's, plus the baseline's): equal counts mean the isolated run *is* the one-at-a-time run. It also
//! prints the alarms the single runs raise on the set's other tracks (left out of those sums) beside what the clean
//! run alone would put there.
//!
//! With `TRACE=1` it also prints every object state whose sensor verdict in the isolated run differs from the
//! one-at-a-time runs' (a faulty track's from its own single run, a clean track's from the clean run's, or a clean
//! track's that some single run changed): frame, id, whether the track is faulty in the set, both verdicts (with
//! `eta_own`, cluster offset, box and cluster centroid), the nearest other faulty track of the set in that frame
//! (its id, distance centre to centre between the reported boxes, verdict and true place) and whose true place the
//! cluster taken lies nearest. Then which faulty tracks the difference needs (the set's run repeated without one
//! track at a time: the state returns to its one-at-a-time verdict without the errors listed), and, per single run,
//! the states whose verdict it changes against the clean run. `MEMGATE=1` sets the params key `memory_gate`, `SHADOWGATE=1` the key
//! `shadow_gate`.
use std::collections::{BTreeMap, BTreeSet};

use pmon_campaign::experiments::{self, Scale, SceneIds};
use pmon_campaign::inject::isolated_tracks;
use pmon_campaign::inject::Injector;
use pmon_campaign::run::{each_track_alone, paired_frames_with, run_one, RunSpec};
use pmon_campaign::Scene;
use pmon_monitor::{MonitorParams, SensorVerdict};
use pmon_scenario::Simulator;
use rayon::prelude::*;

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
        std::env::var("ISOLATION").ok().and_then(|v| v.parse::<f32>().ok()).unwrap_or(experiments::ISOLATION_M)
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
            // `MEMGATE=1`: with the params key `memory_gate` (docs/attribution.md, "Evidence beyond the gate").
            if std::env::var_os("MEMGATE").is_some() {
                spec.params.memory_gate = true;
            }
            // `SHADOWGATE=1`: with the params key `shadow_gate` (docs/attribution.md, "The shadow of far evidence").
            if std::env::var_os("SHADOWGATE").is_some() {
                spec.params.shadow_gate = true;
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
                "{m:.1} m, {cells} m cells, set {}: {} faulty tracks | isolated run: verifiable {}/{} ({:.1} %), alarms {} true {} false ({:.1} % precision) | each alone: verifiable {det}/{inj} ({:.1} %), alarms {true_alarms} true {fa} false ({:.1} %); clean baseline {fa0} false alarms; alarms of the single runs on the set's other tracks {} (clean run's: {})",
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
                alone.alarms_on_the_set,
                alone.baseline_alarms_on_the_set,
            );
            if std::env::var_os("TRACE").is_some() {
                trace(&scene, spec, &faulty)?;
            }
        }
    }
    Ok(())
}

/// One object state of a run, as `TRACE=1` prints it.
#[derive(Clone, Copy, Debug)]
struct State {
    verdict: SensorVerdict,
    eta_own: f32,
    offset_m: [f32; 2],
    xy: [f32; 2],
    /// The clean frame's position (where its evidence is).
    clean_xy: [f32; 2],
    /// The centroid of the cluster attributed to it.
    cluster_m: Option<[f32; 2]>,
    injected: bool,
    in_scope: bool,
}

impl State {
    fn alarm(&self) -> bool {
        self.in_scope && matches!(self.verdict, SensorVerdict::Ghost | SensorVerdict::PositionError)
    }

    fn describe(&self) -> String {
        format!(
            "{}{} (eta_own {:.2}, offset [{:.2}, {:.2}], box at [{:.1}, {:.1}]{})",
            self.verdict,
            if self.injected { " injected" } else { "" },
            self.eta_own,
            self.offset_m[0],
            self.offset_m[1],
            self.xy[0],
            self.xy[1],
            self.cluster_m.map_or(String::new(), |c| format!(", cluster at [{:.1}, {:.1}]", c[0], c[1]))
        )
    }
}

type States = BTreeMap<(usize, u64), State>;

/// Every object state of a run of `spec` whose faulty tracks are `tracks`.
fn states(scene: &Scene, spec: &RunSpec, tracks: BTreeSet<u64>) -> Result<States, String> {
    let mut out = States::new();
    paired_frames_with(scene, spec, Injector::with_faulty_tracks(spec.injection, tracks), |p| {
        for (i, r) in p.reports.iter().enumerate() {
            let o = &p.objects[i];
            out.insert(
                (p.k, r.id),
                State {
                    verdict: r.sensor.verdict,
                    eta_own: r.sensor.eta_own,
                    offset_m: r.sensor.offset_m,
                    xy: [o.x_m, o.y_m],
                    clean_xy: p.clean.objects.get(i).map_or([f32::NAN; 2], |c| [c.x_m, c.y_m]),
                    cluster_m: r.sensor.cluster.and_then(|c| p.clusters.get(usize::from(c))).map(|c| c.centroid_m),
                    injected: p.injections.iter().any(|j| j.index as usize == i),
                    in_scope: pmon_campaign::run::in_scope(r.sensor.verdict),
                },
            );
        }
        Ok(())
    })?;
    Ok(out)
}

/// `TRACE=1`: the states of the isolated run that differ from the single runs, and what each single run changes.
fn trace(scene: &Scene, spec: &RunSpec, faulty: &BTreeSet<u64>) -> Result<(), String> {
    let sets: Vec<BTreeSet<u64>> = std::iter::once(faulty.clone())
        .chain(std::iter::once(BTreeSet::new()))
        .chain(faulty.iter().map(|&id| BTreeSet::from([id])))
        .collect();
    let runs = sets.into_par_iter().map(|set| states(scene, spec, set)).collect::<Result<Vec<_>, _>>()?;
    let (set_run, clean, singles) = (&runs[0], &runs[1], &runs[2..]);
    let single: BTreeMap<u64, &States> = faulty.iter().copied().zip(singles.iter()).collect();
    // The nearest other faulty track of the set in frame k (reported boxes of the isolated run).
    let nearest = |k: usize, id: u64, xy: [f32; 2]| {
        faulty
            .iter()
            .filter(|&&t| t != id)
            .filter_map(|&t| set_run.get(&(k, t)).map(|s| (t, (s.xy[0] - xy[0]).hypot(s.xy[1] - xy[1]))))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    };
    let mut differing = 0;
    let mut diffs: Vec<((usize, u64), SensorVerdict)> = Vec::new();
    let mut alarm_differing = 0;
    for (&(k, id), s) in set_run {
        // What one object at a time says of this state: its own single run if faulty, else the clean run, or the
        // single runs that changed it.
        let mut expected: Vec<(String, State)> = Vec::new();
        if let Some(own) = single.get(&id) {
            expected.extend(own.get(&(k, id)).map(|e| (format!("alone({id})"), *e)));
        } else {
            let base = clean.get(&(k, id));
            let changed: Vec<(String, State)> = single
                .iter()
                .filter_map(|(&t, run)| {
                    run.get(&(k, id))
                        .filter(|e| Some(e.verdict) != base.map(|b| b.verdict))
                        .map(|e| (format!("alone({t})"), *e))
                })
                .collect();
            if changed.is_empty() {
                expected.extend(base.map(|b| ("clean".to_string(), *b)));
            } else {
                expected = changed;
            }
        }
        if expected.iter().all(|(_, e)| e.verdict == s.verdict) && !expected.is_empty() {
            continue;
        }
        differing += 1;
        diffs.push(((k, id), s.verdict));
        let alarm_changed = expected.iter().any(|(_, e)| e.alarm() != s.alarm());
        alarm_differing += usize::from(alarm_changed);
        let near = nearest(k, id, s.xy).map_or("none".to_string(), |(t, d)| {
            let other = set_run.get(&(k, t));
            format!(
                "{t} at {d:.1} m ({}, true place [{:.1}, {:.1}])",
                other.map_or(String::new(), |o| o.describe()),
                other.map_or(f32::NAN, |o| o.clean_xy[0]),
                other.map_or(f32::NAN, |o| o.clean_xy[1])
            )
        });
        // Whose evidence the cluster is: the object whose true (clean) centre is nearest to it, and its verdict.
        let owner = s.cluster_m.and_then(|c| {
            set_run
                .range((k, 0)..=(k, u64::MAX))
                .map(|(&(_, t), o)| (t, o, (o.clean_xy[0] - c[0]).hypot(o.clean_xy[1] - c[1])))
                .min_by(|a, b| a.2.total_cmp(&b.2))
        });
        let near = match owner {
            Some((t, o, d)) => format!(
                "{near}; cluster {d:.1} m from the true place of {t}{} ({})",
                if faulty.contains(&t) { " (faulty)" } else { "" },
                o.verdict
            ),
            None => near,
        };
        let exp: Vec<String> = expected.iter().map(|(w, e)| format!("{w}: {}", e.describe())).collect();
        println!(
            "  TRACE frame {k} id {id}{}{}: set {} | {} | nearest faulty {near}",
            if faulty.contains(&id) { " (faulty)" } else { "" },
            if alarm_changed { " ALARM" } else { "" },
            s.describe(),
            exp.join("; ")
        );
    }
    println!("  TRACE {differing} states differ from one at a time, {alarm_differing} of them in the alarm");
    // Which faulty track's error makes them differ: the set run less one track at a time; a differing state whose
    // verdict returns to the one-at-a-time verdict without track t needs t's error.
    if !diffs.is_empty() {
        let without: Vec<(u64, States)> = faulty
            .par_iter()
            .map(|&t| {
                let rest: BTreeSet<u64> = faulty.iter().copied().filter(|&x| x != t).collect();
                states(scene, spec, rest).map(|r| (t, r))
            })
            .collect::<Result<Vec<_>, _>>()?;
        for ((k, id), verdict) in &diffs {
            let needed: Vec<String> = without
                .iter()
                .filter(|(t, run)| t != id && run.get(&(*k, *id)).is_some_and(|e| e.verdict != *verdict))
                .map(|(t, run)| {
                    let d = match (run.get(&(*k, *t)).or_else(|| set_run.get(&(*k, *t))), set_run.get(&(*k, *id))) {
                        (Some(a), Some(b)) => (a.xy[0] - b.xy[0]).hypot(a.xy[1] - b.xy[1]),
                        _ => f32::NAN,
                    };
                    format!("{t} ({d:.1} m)")
                })
                .collect();
            println!("  TRACE frame {k} id {id}: differs only with the errors of [{}]", needed.join(", "));
        }
    }
    // What each single run changes against the clean run (the sums' false alarms).
    for (&t, run) in &single {
        let mut lines = Vec::new();
        for (&(k, id), e) in run.iter().filter(|(&(_, id), _)| id != t) {
            let b = clean.get(&(k, id));
            if b.map(|b| b.verdict) != Some(e.verdict) {
                let d = run.get(&(k, t)).map_or(f32::NAN, |a| (a.xy[0] - e.xy[0]).hypot(a.xy[1] - e.xy[1]));
                lines.push(format!(
                    "    frame {k} id {id}{}: {} | clean {} | {d:.1} m from {t}",
                    if faulty.contains(&id) { " (faulty in the set)" } else { "" },
                    e.describe(),
                    b.map_or("absent".to_string(), State::describe)
                ));
            }
        }
        if !lines.is_empty() {
            println!("  TRACE alone({t}) changes {} other states:", lines.len());
            for l in lines {
                println!("{l}");
            }
        }
    }
    Ok(())
}
