//! One faulty object at a time (`InjectionConfig::isolation_m`, figure `permanent_position_one` of `pmon
//! reproduce`): a run whose faulty tracks never come within `ISOLATION_M` of each other scores what running each
//! of them alone scores, summed. Checked on a short stretch of the built-in crowded street.

use pmon_campaign::experiments::{ISOLATION_M, ISOLATION_SETS};
use pmon_campaign::inject::isolated_tracks;
use std::collections::BTreeSet;

use pmon_campaign::run::{each_track_alone, run_one, run_one_split, RunSpec};
use pmon_campaign::{Direction, Fault, InjectionConfig, Scene};
use pmon_monitor::MonitorParams;
use pmon_scenario::Simulator;

fn street(seconds: f64) -> Scene {
    let cfg = pmon_campaign::sim_tasks::scenario_config("pedestrians", 7, Some(seconds)).unwrap();
    let mut sim = Simulator::new(&cfg).unwrap();
    let mut frames = Vec::new();
    while let Some(f) = sim.step() {
        frames.push(f.frame);
    }
    Scene { name: "pedestrians".into(), source: String::new(), frames }
}

#[test]
fn an_isolated_run_scores_what_each_faulty_track_alone_scores() {
    let scene = street(2.0);
    let fault = Fault::PermanentPosition { magnitude_m: 1.5, direction: Direction::Away };
    let mut faulty_total = 0;
    for set in 0..ISOLATION_SETS {
        let injection =
            InjectionConfig { isolation_m: ISOLATION_M, isolation_set: set, ..InjectionConfig::new(fault, 3) };
        let spec = RunSpec { scene: 0, params: MonitorParams::default(), injection, window: 2 };
        let tracks = isolated_tracks(ISOLATION_M, set, scene.object_lists());
        assert!(!tracks.is_empty(), "set {set} is empty");
        faulty_total += tracks.len();
        let isolated = run_one(&scene, &spec).unwrap().metrics;
        let alone = each_track_alone(&scene, &spec, &tracks).unwrap();
        // Every error of the isolated run is an error of one single-track run, judged the same way.
        assert_eq!(isolated.sensor_verifiable.injected, alone.verifiable_injected, "set {set}");
        assert_eq!(isolated.sensor_verifiable.detected, alone.verifiable_detected, "set {set}");
        assert_eq!(isolated.sensor.true_alarms, alone.true_alarms, "set {set}");
        // The false alarms each faulty track causes, plus those of the clean run (counted once).
        assert_eq!(alone.below_baseline, 0, "set {set}: a single-track run below the clean run");
        assert_eq!(isolated.sensor.false_alarms(), alone.false_alarms, "set {set}: false alarms");
        // No single run changes an alarm on another track of the set (such alarms are scored in that track's own
        // run, not as false alarms: on this stretch there are none beyond the clean run's).
        assert_eq!(alone.alarms_on_the_set, alone.baseline_alarms_on_the_set, "set {set}: alarms on the set");
    }
    // The check is about something: errors were injected and seen.
    assert!(faulty_total >= 3, "{faulty_total} faulty tracks");
}

/// `run_one_split` scores every object state once: the tracks set apart and the others add up to the whole run.
#[test]
fn a_run_split_by_track_adds_up_to_the_whole_run() {
    let scene = street(1.0);
    let fault = Fault::PermanentPosition { magnitude_m: 1.5, direction: Direction::Away };
    let spec =
        RunSpec { scene: 0, params: MonitorParams::default(), injection: InjectionConfig::new(fault, 3), window: 2 };
    let whole = run_one(&scene, &spec).unwrap().metrics;
    let tracks: BTreeSet<u64> = scene.object_lists().flat_map(|l| l.iter().map(|o| o.id)).collect();
    // Every other track apart (faulty and clean ones alike, by the injection's draw).
    let apart: BTreeSet<u64> = tracks.iter().copied().step_by(2).collect();
    let (rest, on_apart) = run_one_split(&scene, &spec, scene.injector(&spec), &apart).unwrap();
    let rest = rest.metrics;
    assert!(on_apart.states_in_scope > 0 && rest.states_in_scope > 0);
    assert_eq!(rest.states_in_scope + on_apart.states_in_scope, whole.states_in_scope);
    for (a, b, w) in [
        (rest.sensor, on_apart.sensor, whole.sensor),
        (rest.sensor_verifiable, on_apart.sensor_verifiable, whole.sensor_verifiable),
        (rest.plausibility, on_apart.plausibility, whole.plausibility),
    ] {
        assert_eq!(
            (a.injected + b.injected, a.detected + b.detected, a.alarms + b.alarms, a.true_alarms + b.true_alarms),
            (w.injected, w.detected, w.alarms, w.true_alarms)
        );
    }
    assert!(whole.sensor.injected > 0 && whole.sensor.alarms > 0, "{whole:?}");
    // Every sensor alarm names the test that raised it: the alarms by cause add up to the errors found and the
    // false alarms, here and in the two parts; the displaced evidence finds some of these 1.5 m errors.
    let mut parts = rest.sensor_causes;
    parts.add(&on_apart.sensor_causes);
    assert_eq!(parts, whole.sensor_causes);
    let c = whole.sensor_causes;
    assert_eq!(c.found.total(), whole.sensor_verifiable.detected);
    assert_eq!(c.false_alarms.total(), whole.sensor.false_alarms());
    assert!(c.found.displaced_evidence > 0, "{c:?}");
    // Nothing apart: the first part is the whole run.
    let (all, none) = run_one_split(&scene, &spec, scene.injector(&spec), &BTreeSet::new()).unwrap();
    assert_eq!(all.metrics, whole);
    assert_eq!(none.states_in_scope, 0);
}
