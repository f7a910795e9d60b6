//! One faulty object at a time (`InjectionConfig::isolation_m`, figure `permanent_position_one` of `pmon
//! reproduce`): a run whose faulty tracks never come within `ISOLATION_M` of each other scores what running each
//! of them alone scores, summed. Checked on a short stretch of the built-in crowded street.

use std::collections::BTreeSet;

use pmon_campaign::experiments::{ISOLATION_M, ISOLATION_SETS};
use pmon_campaign::inject::isolated_tracks;
use pmon_campaign::run::{run_one, run_one_with, RunSpec};
use pmon_campaign::{Direction, Fault, InjectionConfig, Injector, Scene};
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
        let tracks = isolated_tracks(ISOLATION_M, set, scene.frames.iter().map(|f| f.objects.as_slice()));
        assert!(!tracks.is_empty(), "set {set} is empty");
        faulty_total += tracks.len();
        let isolated = run_one(&scene, &spec).unwrap().metrics;
        let alone = |set: BTreeSet<u64>| {
            run_one_with(&scene, &spec, Injector::with_faulty_tracks(injection, set)).unwrap().metrics
        };
        let clean = alone(BTreeSet::new());
        let singles: Vec<_> = tracks.iter().map(|&id| alone(BTreeSet::from([id]))).collect();
        let sum = |f: &dyn Fn(&pmon_campaign::metrics::Metrics) -> u64| singles.iter().map(f).sum::<u64>();
        // Every error of the isolated run is an error of one single-track run, judged the same way.
        assert_eq!(isolated.sensor_verifiable.injected, sum(&|m| m.sensor_verifiable.injected), "set {set}");
        assert_eq!(isolated.sensor_verifiable.detected, sum(&|m| m.sensor_verifiable.detected), "set {set}");
        assert_eq!(isolated.sensor.true_alarms, sum(&|m| m.sensor.true_alarms), "set {set}");
        // The false alarms each faulty track causes, plus those of the clean run (counted once).
        let fa0 = clean.sensor.false_alarms();
        assert_eq!(
            isolated.sensor.false_alarms(),
            sum(&|m| m.sensor.false_alarms() - fa0) + fa0,
            "set {set}: false alarms"
        );
    }
    // The check is about something: errors were injected and seen.
    assert!(faulty_total >= 3, "{faulty_total} faulty tracks");
}
