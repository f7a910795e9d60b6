//! Issue #11: plausibility checks on what real trackers do (calibrated mode), and the friction it reported.
#![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]

mod common;

use common::object;
use pmon_monitor::{
    Frame, ImplausibilityKind, Monitor, MonitorParams, MotionOutcome, MotionVerdict, ObjectState, PlausibilityMode,
    Pose2, Verdict,
};

fn calibrated() -> MonitorParams {
    MonitorParams { plausibility_mode: PlausibilityMode::Calibrated, ..MonitorParams::default() }
}

fn step(m: &mut Monitor, t: f64, objects: &[ObjectState]) -> Vec<(Verdict, MotionOutcome)> {
    let f = Frame {
        timestamp_s: t,
        world_from_ego: Pose2::default(),
        objects,
        cloud: None,
        roi_in_ego: &[],
        static_in_ego: &[],
    };
    m.check(&f).unwrap().objects.iter().map(|r| (r.verdict, r.motion)).collect()
}

#[test]
fn issue_11_standing_object_with_noise_heading_raises_no_alarm() {
    // 13-31 rad/s of heading "turn rate" at 0.05 m/s: the heading is undefined there.
    let mut m = Monitor::new(calibrated()).unwrap();
    let headings = [0.0, 2.5, -1.0, 3.0, 0.3, -2.8, 1.7, -0.4];
    for (k, h) in headings.iter().enumerate() {
        let o = ObjectState { speed_mps: 0.05, ..object(1, 10.0 + 0.005 * k as f32, 0.0, *h, 0.6, 0.6) };
        let r = step(&mut m, k as f64 * 0.1, &[o]);
        assert!(!r[0].0.is_alarm(), "frame {k}: {:?}", r[0]);
    }
}

#[test]
fn issue_11_warmup_never_hides_a_car_moving_27_mps() {
    // Reported 0 m/s (velocity not initialised) while the box moved 2.7 m in 0.1 s: a real speed error.
    let mut m = Monitor::new(calibrated()).unwrap();
    step(&mut m, 0.0, &[object(1, 10.0, 0.0, 0.0, 4.5, 1.8)]);
    let r = step(&mut m, 0.1, &[object(1, 12.7, 0.0, 0.0, 4.5, 1.8)]);
    assert!(matches!(r[0].1.verdict, MotionVerdict::Implausible(_)), "{:?}", r[0]);
    assert_eq!(r[0].1.kind, Some(ImplausibilityKind::SpeedInconsistent));
    assert!(r[0].1.error_size < -20.0 && r[0].1.severity > 5.0, "{:?}", r[0].1);
    // A pedestrian's warm-up (1.4 m/s reported as 0) is tolerated.
    let mut m = Monitor::new(calibrated()).unwrap();
    step(&mut m, 0.0, &[object(2, 10.0, 0.0, 0.0, 0.6, 0.6)]);
    let r = step(&mut m, 0.1, &[object(2, 10.14, 0.0, 0.0, 0.6, 0.6)]);
    assert_eq!(r[0].1.verdict, MotionVerdict::Plausible);
}

#[test]
fn issue_11_alarms_name_their_kind_and_size() {
    let mut m = Monitor::new(calibrated()).unwrap();
    let car = |x: f32, y: f32, h: f32, v: f32| ObjectState { speed_mps: v, ..object(3, x, y, h, 4.5, 1.8) };
    for k in 0..6 {
        let r = step(&mut m, k as f64 * 0.1, &[car(k as f32, 0.0, 0.0, 10.0)]);
        assert!(!r[0].0.is_alarm(), "{k}");
    }
    // The box jumps 3 m sideways.
    let r = step(&mut m, 0.6, &[car(6.0, 3.0, 0.0, 10.0)]);
    assert_eq!(r[0].1.kind, Some(ImplausibilityKind::PositionJump), "{:?}", r[0].1);
    assert!((r[0].1.error_size - 3.0).abs() < 0.5 && r[0].1.severity >= 1.0);
    // A heading flip while moving.
    let r = step(&mut m, 0.7, &[car(7.0, 0.0, core::f32::consts::PI, 10.0)]);
    assert_eq!(r[0].1.kind, Some(ImplausibilityKind::HeadingFlip), "{:?}", r[0].1);
    // The paper's mode names kinds too, its verdicts are the paper's.
    let mut m = Monitor::new(MonitorParams::default()).unwrap();
    for k in 0..4 {
        step(&mut m, k as f64 * 0.1, &[car(k as f32, 0.0, 0.0, 10.0)]);
    }
    let r = step(&mut m, 0.4, &[car(4.0, 3.0, 0.0, 10.0)]);
    assert!(r[0].1.kind.is_some(), "{:?}", r[0].1);
}

#[test]
fn issue_11_first_frame_without_lidar_is_not_monitored_for_the_missing_sensor_data() {
    // A world-frame object list without LiDAR: the objects lie far outside the grid around the origin. The
    // sensor checks judge nothing for want of data, not because of the grid: the first frame is
    // `not_monitored(first_frame_of_track)`, later frames `motion_only_consistent(no_lidar_data)`.
    use pmon_monitor::{NotMonitoredReason, SensorVerdict};
    for params in [MonitorParams::default(), calibrated()] {
        let mut m = Monitor::new(params).unwrap();
        let far = |x: f32| ObjectState { speed_mps: 10.0, ..object(1, x, 300.0, 0.0, 4.5, 1.8) };
        let near = |x: f32| ObjectState { speed_mps: 10.0, ..object(2, x, 5.0, 0.0, 4.5, 1.8) };
        let f = Frame {
            timestamp_s: 0.0,
            world_from_ego: Pose2::default(),
            objects: &[far(500.0), near(10.0)],
            cloud: None,
            roi_in_ego: &[],
            static_in_ego: &[],
        };
        let rep = m.check(&f).unwrap();
        for r in rep.objects {
            assert_eq!(r.sensor.verdict, SensorVerdict::NotMonitored(NotMonitoredReason::NoLidarData), "{r:?}");
            assert_eq!(r.verdict, Verdict::NotMonitored(NotMonitoredReason::FirstFrameOfTrack), "{r:?}");
            assert_eq!(r.verdict.to_string(), "not_monitored(first_frame_of_track)");
        }
        let r = step(&mut m, 0.1, &[far(501.0), near(11.0)]);
        for (v, _) in r {
            assert_eq!(v, Verdict::MotionOnlyConsistent(NotMonitoredReason::NoLidarData));
        }
    }
}
