//! One faulty object at a time (`InjectionConfig::isolation_m`, figure `permanent_position_one` of `pmon
//! reproduce`): a run whose faulty tracks never come within `ISOLATION_M` of each other scores what running each
//! of them alone scores, summed. Checked on a short stretch of the built-in crowded street.

use pmon_campaign::experiments::{ISOLATION_M, ISOLATION_SETS};
use pmon_campaign::inject::isolated_tracks;
use pmon_campaign::run::{each_track_alone, run_one, RunSpec};
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
    }
    // The check is about something: errors were injected and seen.
    assert!(faulty_total >= 3, "{faulty_total} faulty tracks");
}
