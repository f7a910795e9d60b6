//! Lists the transient speed errors of `pmon reproduce --quick` (Fig. velocityError, 10 % per object and frame)
//! that the plausibility checks miss, by cause (a development aid for issue #11, docs/plausibility.md):
//!
//! `cargo run --release -p pmon-campaign --example transient_speed_diag -- [--full] [SEED] [MAX_DV] [FILTER]`
//!
//! Runs the quick plan's transient speed runs (both rules, every scene) with the same seeds as
//! `pmon reproduce --quick --seed SEED` (default 7; `--full`: the full plan and scenes of `pmon reproduce --seed
//! SEED`, 0.5 m/s steps), up to the error `MAX_DV` m/s (default 5), and scores them
//! the way the campaign does (an error at frame `k` is detected by an alarm at `k` or `k + 1`). Each missed
//! error gets the first cause that applies:
//!
//! - `not judged`: neither frame `k` nor `k + 1` has a motion verdict (a track's first frame, and no next one);
//! - `first frame`: frame `k` is the track's first (only the step back at `k + 1` can tell);
//! - `after an error`: frame `k - 1` carried an error too (the step into `k` is from one wrong speed to another);
//! - `own scatter, inflated`: an error of the last 12 frames of this track went undetected (its speed steps
//!   count as the track's noise: the margin is the declared one or an inflated own scatter);
//! - `declared margin`: the acceleration margin at `k` is the declared sigmas' `z hypot(sigma_v0, sigma_v1)`
//!   (the paper's rule: its fixed margin; the calibrated rule: the track's own scatter not in force, fewer
//!   than 5 clean steps among the last 12 states);
//! - `own scatter`: the own scatter narrowed the margin, from clean steps, and the step is still within it.
//!
//! For each miss the margin at `k` in m/s (`accel_margin dt`) is kept; the table prints its median, the median
//! implied factor `margin / hypot(sigma_v0, sigma_v1)` (`z` = 3.89 at `p = 1e-4` when the declared sigma sets
//! it) and the true speed. `FILTER` keeps the runs whose curve label contains it (e.g. `20 Hz`).
use std::collections::{BTreeMap, HashMap};

use pmon_campaign::experiments::{self, Measure, PlannedRun, Scale, SceneIds};
use pmon_campaign::{sim_tasks, Injector, Scene};
use pmon_monitor::{Monitor, MotionVerdict, NotMonitoredReason, PlausibilityMode};
use rayon::prelude::*;

/// One object state of a run, as the diagnosis needs it.
#[derive(Clone, Copy, Debug, Default)]
struct State {
    in_scope: bool,
    injected: bool,
    judged: bool,
    alarm: bool,
    /// The acceleration margin (m/s^2) and the time step (s).
    margin: f64,
    dt: f64,
    /// Declared speed sigma of this state and the reported and true speed, m/s.
    sigma_v: f64,
    v_true: f64,
    first_of_track: bool,
}

const CAUSES: [&str; 6] =
    ["not judged", "first frame", "after an error", "declared margin", "inflated by a missed error", "own scatter"];

/// Misses of one cause: their number, and per miss the margin (m/s), the implied factor and the true speed.
type Misses = (u64, Vec<f64>, Vec<f64>, Vec<f64>);

#[derive(Default)]
struct Tally {
    injected: u64,
    detected: u64,
    /// Per cause: misses, margins (m/s), implied factors, true speeds.
    misses: BTreeMap<&'static str, Misses>,
    /// Misses with the declared margin: the track's age at `k` (states before it) and its alarms among the
    /// 11 states before `k`.
    declared_age: Vec<f64>,
    declared_alarms: Vec<f64>,
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn wanted(run: &PlannedRun, max_dv: f64, filter: &str) -> Option<String> {
    let p = run.probes.iter().find(|p| {
        (p.figure == "speed_errors" || p.figure == "speed_errors_calibrated")
            && p.curve.starts_with("transient 10 %")
            && p.measure == Measure::PlausibilityRecall
    })?;
    let mode = if run.spec.params.plausibility_mode == PlausibilityMode::Calibrated { "calibrated" } else { "paper" };
    let label = format!("{mode:10} {:32} {:4.1}", p.curve, p.x);
    (p.x <= max_dv + 1e-9 && label.contains(filter)).then_some(label)
}

fn diagnose(scene: &Scene, run: &PlannedRun) -> Result<Tally, String> {
    let spec = &run.spec;
    let mut monitor = Monitor::new(spec.params).map_err(|e| e.to_string())?;
    let mut injector = Injector::new(spec.injection);
    // Per object id: its states by frame.
    let mut states: HashMap<u64, BTreeMap<u64, State>> = HashMap::new();
    let mut objects = Vec::new();
    for (k, clean) in scene.frames.iter().enumerate() {
        objects.clone_from(&clean.objects);
        let injections = injector.apply_at(k as u64, clean.timestamp_s, &mut objects);
        let mut roi = Vec::new();
        let mut view = clean.as_frame(&mut roi);
        view.objects = &objects;
        let report = monitor.check(&view).map_err(|e| format!("frame {k}: {e}"))?;
        for (i, r) in report.objects.iter().enumerate() {
            let m = r.motion;
            let o = objects.get(i).copied();
            let st = State {
                in_scope: pmon_campaign::in_scope(r.sensor.verdict),
                injected: injections.iter().any(|j| j.index as usize == i),
                judged: !matches!(m.verdict, MotionVerdict::NotMonitored(_)),
                alarm: matches!(m.verdict, MotionVerdict::Implausible(_)),
                margin: f64::from(m.accel_margin_mps2),
                dt: m.dt_s,
                sigma_v: o.and_then(|o| o.uncertainty).map_or(f64::NAN, |u| f64::from(u.speed_mps)),
                v_true: clean.objects.get(i).map_or(f64::NAN, |o| f64::from(o.speed_mps)),
                first_of_track: m.verdict == MotionVerdict::NotMonitored(NotMonitoredReason::FirstFrameOfTrack),
            };
            states.entry(r.id).or_default().insert(k as u64, st);
        }
    }
    let z = pmon_monitor::calibrated::Gates::new(spec.params.false_alarm_probability).z;
    let mut tally = Tally::default();
    for track in states.values() {
        let detected_at = |k: u64| -> bool { (k..=k + 1).any(|f| track.get(&f).is_some_and(|s| s.alarm)) };
        for (&k, s) in track.iter().filter(|(_, s)| s.in_scope && s.injected) {
            tally.injected += 1;
            if detected_at(k) {
                tally.detected += 1;
                continue;
            }
            let next_judged = track.get(&(k + 1)).is_some_and(|n| n.judged);
            let prev = k.checked_sub(1).and_then(|p| track.get(&p));
            let declared = z * f64::hypot(prev.map_or(s.sigma_v, |p| p.sigma_v), s.sigma_v);
            let margin_mps = s.margin * s.dt;
            let inflated =
                (k.saturating_sub(12)..k).any(|f| track.get(&f).is_some_and(|e| e.injected && !detected_at(f)));
            let cause = if !s.judged && !next_judged {
                CAUSES[0]
            } else if s.first_of_track {
                CAUSES[1]
            } else if prev.is_some_and(|p| p.injected) {
                CAUSES[2]
            } else if spec.params.plausibility_mode == PlausibilityMode::Paper {
                CAUSES[3]
            } else if inflated {
                CAUSES[4]
            } else if margin_mps >= declared * (1.0 - 1e-3) {
                CAUSES[3]
            } else {
                CAUSES[5]
            };
            if cause == CAUSES[3] {
                tally.declared_age.push(track.range(..k).count() as f64);
                tally
                    .declared_alarms
                    .push(track.range(k.saturating_sub(11)..k).filter(|(_, e)| e.alarm).count() as f64);
            }
            let e = tally.misses.entry(cause).or_default();
            e.0 += 1;
            if s.judged {
                e.1.push(margin_mps);
                e.2.push(margin_mps / f64::hypot(prev.map_or(s.sigma_v, |p| p.sigma_v), s.sigma_v));
            }
            e.3.push(s.v_true);
        }
    }
    Ok(tally)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let full = args.first().is_some_and(|a| a == "--full");
    if full {
        args.remove(0);
    }
    let seed: u64 = args.first().map_or(Ok(7), |s| s.parse())?;
    let max_dv: f64 = args.get(1).map_or(Ok(5.0), |s| s.parse())?;
    let filter = args.get(2).cloned().unwrap_or_default();
    let specs = sim_tasks::scene_specs(!full, seed, None)?;
    let ids = SceneIds { pedestrians: 0, intersection: 1, pedestrians_20hz: Some(2), pedestrians_paper: Some(3) };
    let scale = if full { Scale::Full } else { Scale::Quick };
    let planned = experiments::plan(scale, ids, &pmon_monitor::MonitorParams::default(), seed);
    let runs: Vec<(String, &PlannedRun)> =
        planned.iter().filter_map(|r| wanted(r, max_dv, &filter).map(|l| (l, r))).collect();
    let scenes: Vec<Scene> = specs
        .par_iter()
        .map(|s| {
            if runs.iter().any(|(_, r)| ids.role(r.spec.scene) == s.name) {
                sim_tasks::simulate(s, &|_, _| {})
            } else {
                Ok(Scene { name: s.name.clone(), source: String::new(), frames: Vec::new() })
            }
        })
        .collect::<Result<_, String>>()?;
    let tallies: Vec<Tally> = runs
        .par_iter()
        .map(|(_, r)| scenes.get(r.spec.scene).ok_or_else(|| "no scene".to_string()).and_then(|s| diagnose(s, r)))
        .collect::<Result<_, String>>()?;
    let mut rows: Vec<(&String, &Tally)> = runs.iter().map(|(l, _)| l).zip(&tallies).collect();
    rows.sort_by(|a, b| a.0.cmp(b.0));
    println!("rule       curve                            dv   recall (det/inj)   misses by cause: n [median margin m/s, factor, true speed m/s]");
    for (label, t) in rows {
        let recall = t.detected as f64 / t.injected.max(1) as f64;
        let mut parts = Vec::new();
        for c in CAUSES {
            if let Some((n, m, f, v)) = t.misses.get(c) {
                let (mut m, mut f, mut v) = (m.clone(), f.clone(), v.clone());
                parts.push(format!("{c}: {n} [{:.2}, {:.2}, {:.2}]", median(&mut m), median(&mut f), median(&mut v)));
            }
        }
        if !t.declared_age.is_empty() {
            let young = t.declared_age.iter().filter(|&&a| a < 7.0).count();
            let (mut a, mut b) = (t.declared_age.clone(), t.declared_alarms.clone());
            parts.push(format!(
                "(declared margin: {young} in a track's first 7 states; median age {:.0}, median alarms in the 11 states before {:.0})",
                median(&mut a),
                median(&mut b)
            ));
        }
        println!("{label} {:5.1} % ({}/{})   {}", 100.0 * recall, t.detected, t.injected, parts.join("; "));
    }
    Ok(())
}
