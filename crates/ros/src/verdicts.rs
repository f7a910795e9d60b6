//! The monitor's report -> `pmon_msgs/FrameVerdicts` and `diagnostic_msgs/DiagnosticArray`.

use pmon_monitor::{FrameReport, ObjectState, Verdict};

use crate::msg::{
    DiagnosticArray, DiagnosticStatus, FrameVerdicts, Header, KeyValue, MissedObject, ObjectVerdict, Time, Uuid,
};

/// `diagnostic_msgs/DiagnosticStatus` levels.
pub mod level {
    /// OK.
    pub const OK: u8 = 0;
    /// WARN.
    pub const WARN: u8 = 1;
    /// ERROR.
    pub const ERROR: u8 = 2;
    /// STALE (no recent information).
    pub const STALE: u8 = 3;
}

/// Name of pmon's diagnostic status.
pub const DIAGNOSTIC_NAME: &str = "pmon: perception monitor";

/// Names of the per-check statuses ([`check_statuses`]).
pub mod check_names {
    /// Ghosts and position errors (the sensor consistency check).
    pub const CONSISTENCY: &str = "pmon: object consistency";
    /// Evidence no object explains.
    pub const MISSED: &str = "pmon: missed objects";
    /// The motion plausibility checks.
    pub const MOTION: &str = "pmon: motion plausibility";
    /// Whether the sensor checks had a usable cloud.
    pub const INPUT: &str = "pmon: sensor input";
}

/// `pmon_msgs/ObjectVerdict` constant of a verdict.
#[must_use]
pub const fn verdict_code(v: Verdict) -> u8 {
    match v {
        Verdict::Consistent => 0,
        Verdict::Ghost => 1,
        Verdict::PositionError => 2,
        Verdict::ImplausibleMotion(_) => 3,
        Verdict::NotMonitored(_) => 4,
        Verdict::MotionOnlyConsistent(_) => 5,
    }
}

/// Everything about a frame that is not in the monitor's report.
pub struct FrameContext<'a> {
    /// The object list's header.
    pub header: &'a Header,
    /// The paired cloud's stamp, if one was paired.
    pub cloud_stamp: Option<Time>,
    /// Why the sensor checks could not use the cloud (malformed, missing transform), overriding the
    /// monitor's own status.
    pub cloud_problem: Option<String>,
    /// Track UUIDs, one per object (zero for detections).
    pub uuids: &'a [Uuid],
    /// Wall time of the check, seconds.
    pub processing_time_s: f64,
}

/// Builds the verdict message of one checked frame.
#[must_use]
pub fn frame_verdicts(ctx: &FrameContext<'_>, objects: &[ObjectState], rep: &FrameReport<'_>) -> FrameVerdicts {
    let sensor_status = match (&ctx.cloud_problem, rep.sensor_status) {
        (Some(p), _) => p.clone(),
        (None, Some(r)) => r.name().to_string(),
        (None, None) => String::new(),
    };
    FrameVerdicts {
        header: ctx.header.clone(),
        cloud_stamp: ctx.cloud_stamp.unwrap_or_default(),
        cloud_paired: ctx.cloud_stamp.is_some(),
        sensor_status,
        points_total: rep.grid.points_total,
        points_in_band: rep.grid.points_in_band,
        processing_time_s: ctx.processing_time_s,
        objects: objects
            .iter()
            .zip(rep.objects)
            .enumerate()
            .map(|(i, (o, r))| ObjectVerdict {
                object_id: ctx.uuids.get(i).copied().unwrap_or_default(),
                id: r.id,
                verdict: verdict_code(r.verdict),
                verdict_name: r.verdict.name().into(),
                reason: match (r.verdict.not_monitored_reason(), r.verdict) {
                    (Some(reason), _) => reason.name().into(),
                    (None, Verdict::ImplausibleMotion(c)) => c.to_string(),
                    (None, Verdict::PositionError) => {
                        r.sensor.position_cause.map_or_else(String::new, |c| c.name().into())
                    }
                    (None, _) => String::new(),
                },
                x_m: o.x_m,
                y_m: o.y_m,
                eta: r.sensor.eta,
                visible_fraction: r.sensor.visible_fraction,
                offset_m: r.sensor.offset_m,
            })
            .collect(),
        missed: rep
            .clusters
            .iter()
            .filter(|c| c.is_missed_object())
            .map(|c| MissedObject { centroid_m: c.centroid_m, bounds_m: c.bounds_m, cells: c.cells })
            .collect(),
    }
}

/// Builds `/diagnostics` from a verdict message: ERROR with one key-value per alarm when any alarm was raised,
/// WARN when the sensor checks did not run (no cloud paired, empty or malformed cloud, missing transform),
/// OK otherwise. Counts are always given.
#[must_use]
pub fn diagnostics(v: &FrameVerdicts) -> DiagnosticArray {
    let alarms: Vec<&ObjectVerdict> = v.objects.iter().filter(|o| matches!(o.verdict, 1..=3)).collect();
    let not_monitored = v.objects.iter().filter(|o| o.verdict == 4).count();
    let kv = |k: &str, val: String| KeyValue { key: k.into(), value: val };
    let mut values = vec![
        kv("objects", v.objects.len().to_string()),
        kv("alarms", alarms.len().to_string()),
        kv("missed_objects", v.missed.len().to_string()),
        kv("not_monitored", not_monitored.to_string()),
        kv("cloud_paired", v.cloud_paired.to_string()),
        kv("sensor_status", if v.sensor_status.is_empty() { "ran".into() } else { v.sensor_status.clone() }),
        kv("processing_time_ms", format!("{:.3}", v.processing_time_s * 1e3)),
    ];
    for o in &alarms {
        let what =
            if o.reason.is_empty() { o.verdict_name.clone() } else { format!("{} ({})", o.verdict_name, o.reason) };
        values.push(kv(
            &format!("object {}", o.id),
            format!("{what} at ({:.1}, {:.1}) m, eta {:.2}", o.x_m, o.y_m, o.eta),
        ));
    }
    for m in &v.missed {
        values.push(kv(
            "missed object",
            format!("{} cells around ({:.1}, {:.1}) m", m.cells, m.centroid_m[0], m.centroid_m[1]),
        ));
    }
    let (lvl, message) = if !alarms.is_empty() || !v.missed.is_empty() {
        (level::ERROR, format!("{} object alarms, {} missed objects", alarms.len(), v.missed.len()))
    } else if !v.sensor_status.is_empty() {
        (level::WARN, format!("sensor checks not run: {}", v.sensor_status))
    } else {
        (level::OK, "no alarm".into())
    };
    DiagnosticArray {
        header: Header { stamp: v.header.stamp, frame_id: String::new() },
        status: vec![DiagnosticStatus {
            level: lvl,
            name: DIAGNOSTIC_NAME.into(),
            message,
            hardware_id: "pmon".into(),
            values,
        }],
    }
}

/// One `diagnostic_msgs/DiagnosticStatus` per check, each with a level a system can act on (docs/ros2.md):
/// - object consistency: ERROR on a ghost or position error, WARN when the sensor checks did not run, else OK;
///   beside the counts of alarms, the objects the sensor checks could not judge (`not_monitored` and
///   `motion_only_consistent`), in total and by reason;
/// - missed objects: ERROR when evidence no object explains was found, WARN when the sensor checks did not
///   run, else OK;
/// - motion plausibility: ERROR on implausible motion, else OK (it runs without a cloud);
/// - sensor input: WARN when no cloud was paired or it could not be used (`sensor_status`), else OK.
#[must_use]
pub fn check_statuses(v: &FrameVerdicts) -> Vec<DiagnosticStatus> {
    let kv = |k: &str, val: String| KeyValue { key: k.into(), value: val };
    let count = |code: u8| v.objects.iter().filter(|o| o.verdict == code).count();
    let sensor_ran = v.sensor_status.is_empty();
    let alarm_values = |codes: &[u8]| -> Vec<KeyValue> {
        v.objects
            .iter()
            .filter(|o| codes.contains(&o.verdict))
            .map(|o| {
                let what = if o.reason.is_empty() {
                    o.verdict_name.clone()
                } else {
                    format!("{} ({})", o.verdict_name, o.reason)
                };
                kv(&format!("object {}", o.id), format!("{what} at ({:.1}, {:.1}) m", o.x_m, o.y_m))
            })
            .collect()
    };
    let status = |name: &str, (level, message): (u8, String), values: Vec<KeyValue>| DiagnosticStatus {
        level,
        name: name.into(),
        message,
        hardware_id: "pmon".into(),
        values,
    };
    let not_run = || (level::WARN, format!("not run: {}", v.sensor_status));
    let (ghosts, position) = (count(1), count(2));
    let mut consistency = vec![kv("ghosts", ghosts.to_string()), kv("position_errors", position.to_string())];
    // The objects the sensor checks could not judge, counted by reason (not alarms, changing no level): a
    // planner should know which of its objects nobody confirmed (occluded, outside the grid, ...).
    let mut unjudged = std::collections::BTreeMap::<&str, usize>::new();
    for o in v.objects.iter().filter(|o| o.verdict == 4 || o.verdict == 5) {
        *unjudged.entry(if o.reason.is_empty() { "unknown" } else { o.reason.as_str() }).or_default() += 1;
    }
    consistency.push(kv("not_judged_by_sensor", unjudged.values().sum::<usize>().to_string()));
    consistency.extend(unjudged.iter().map(|(r, n)| kv(&format!("not_judged_by_sensor: {r}"), n.to_string())));
    consistency.extend(alarm_values(&[1, 2]));
    let consistency_level = if ghosts + position > 0 {
        (level::ERROR, format!("{ghosts} ghosts, {position} position errors"))
    } else if !sensor_ran {
        not_run()
    } else {
        (level::OK, "consistent".into())
    };
    let mut missed = vec![kv("missed_objects", v.missed.len().to_string())];
    missed.extend(v.missed.iter().map(|m| {
        kv("missed object", format!("{} cells around ({:.1}, {:.1}) m", m.cells, m.centroid_m[0], m.centroid_m[1]))
    }));
    let missed_level = if !v.missed.is_empty() {
        (level::ERROR, format!("{} missed objects", v.missed.len()))
    } else if !sensor_ran {
        not_run()
    } else {
        (level::OK, "none".into())
    };
    let implausible = count(3);
    let mut motion = vec![kv("implausible", implausible.to_string())];
    motion.extend(alarm_values(&[3]));
    let motion_level = if implausible > 0 {
        (level::ERROR, format!("{implausible} implausible motions"))
    } else {
        (level::OK, "plausible".into())
    };
    let input = vec![
        kv("cloud_paired", v.cloud_paired.to_string()),
        kv("sensor_status", if sensor_ran { "ran".into() } else { v.sensor_status.clone() }),
        kv("points_total", v.points_total.to_string()),
    ];
    let input_level = if sensor_ran { (level::OK, "cloud used".into()) } else { not_run() };
    vec![
        status(check_names::CONSISTENCY, consistency_level, consistency),
        status(check_names::MISSED, missed_level, missed),
        status(check_names::MOTION, motion_level, motion),
        status(check_names::INPUT, input_level, input),
    ]
}

/// Adds the counts of [`FrameReport::outside_roi_counts`] to the missed-objects status of [`check_statuses`] (the
/// live node's per-check statuses) as the key-values `outside_roi_no_return` and `outside_roi_grazing`: what the
/// map excused is counted beside the alarms, and changes no level. (`pmon_msgs/FrameVerdicts` and the frame status of
/// [`diagnostics`] are unchanged.)
pub fn add_outside_roi(statuses: &mut [DiagnosticStatus], counts: [usize; 2]) {
    if let Some(s) = statuses.iter_mut().find(|s| s.name == check_names::MISSED) {
        let kv = |k: &str, n: usize| KeyValue { key: k.into(), value: n.to_string() };
        // After the count of missed objects, before the missed objects one by one.
        let at = 1.min(s.values.len());
        s.values.insert(at, kv("outside_roi_grazing", counts[1]));
        s.values.insert(at, kv("outside_roi_no_return", counts[0]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn verdict(id: u64, code: u8, name: &str, reason: &str) -> ObjectVerdict {
        ObjectVerdict { id, verdict: code, verdict_name: name.into(), reason: reason.into(), ..Default::default() }
    }

    /// A position error carries the test that found it in `reason`, and `/diagnostics` names it beside the alarm.
    #[test]
    fn a_position_error_says_which_test_found_it() {
        use pmon_monitor::{Frame, Isometry3, Monitor, MonitorParams, ObjectClass, PointCloud, Pose2};
        // A 0.6 m post 14 m ahead (returns 0.3-1.3 m high; the sensor 1.8 m up), its box reported 1.5 m further.
        let mut pts = Vec::new();
        for i in 0..6 {
            for j in 0..6 {
                for k in 0..6 {
                    pts.push([13.75 + 0.1 * i as f32, -0.25 + 0.1 * j as f32, 0.3 + 0.2 * k as f32 - 1.8]);
                }
            }
        }
        let o = ObjectState {
            id: 1,
            class: ObjectClass::Pedestrian,
            x_m: 15.5,
            y_m: 0.0,
            heading_rad: 0.0,
            speed_mps: 0.0,
            length_m: 0.6,
            width_m: 0.6,
            uncertainty: None,
        };
        let cloud = PointCloud {
            points_in_sensor: &pts,
            ego_from_sensor: Isometry3::from_yaw_translation(0.0, [0.0, 0.0, 1.8]),
        };
        let frame = Frame {
            timestamp_s: 0.1,
            world_from_ego: Pose2::default(),
            objects: std::slice::from_ref(&o),
            cloud: Some(cloud),
            roi_in_ego: &[],
            static_in_ego: &[],
        };
        let mut m = Monitor::new(MonitorParams::default()).unwrap();
        let rep = m.check(&frame).unwrap();
        assert_eq!(rep.objects[0].verdict, Verdict::PositionError, "{:?}", rep.objects[0]);
        let header = Header::default();
        let ctx = FrameContext {
            header: &header,
            cloud_stamp: Some(Time::default()),
            cloud_problem: None,
            uuids: &[],
            processing_time_s: 0.0,
        };
        let v = frame_verdicts(&ctx, &[o], &rep);
        assert_eq!(v.objects[0].reason, "displaced_evidence", "{:?}", v.objects[0]);
        let s = check_statuses(&v);
        assert!(
            s[0].values
                .iter()
                .any(|kv| kv.key == "object 1" && kv.value.starts_with("position_error (displaced_evidence)")),
            "{:?}",
            s[0]
        );
    }

    #[test]
    fn each_check_has_its_own_level() {
        let mut v = FrameVerdicts { cloud_paired: true, ..Default::default() };
        v.objects = vec![verdict(1, 0, "consistent", ""), verdict(2, 1, "ghost", "")];
        let s = check_statuses(&v);
        let levels: Vec<(&str, u8)> = s.iter().map(|s| (s.name.as_str(), s.level)).collect();
        assert_eq!(
            levels,
            [
                (check_names::CONSISTENCY, level::ERROR),
                (check_names::MISSED, level::OK),
                (check_names::MOTION, level::OK),
                (check_names::INPUT, level::OK)
            ]
        );
        assert!(s[0].values.iter().any(|kv| kv.key == "object 2" && kv.value.starts_with("ghost")));
        let keys = |s: &DiagnosticStatus| -> Vec<(String, String)> {
            s.values.iter().map(|kv| (kv.key.clone(), kv.value.clone())).collect()
        };
        assert!(keys(&s[0]).contains(&("not_judged_by_sensor".into(), "0".into())), "{:?}", s[0]);
        // Objects the sensor checks could not judge are counted by reason, and change no level.
        v.objects = vec![
            verdict(1, 0, "consistent", ""),
            verdict(4, 4, "not_monitored", "outside_grid"),
            verdict(5, 5, "motion_only_consistent", "occluded"),
            verdict(6, 5, "motion_only_consistent", "occluded"),
        ];
        let s = check_statuses(&v);
        assert_eq!(s[0].level, level::OK);
        let k = keys(&s[0]);
        let at = k.iter().position(|(key, _)| key == "not_judged_by_sensor").unwrap();
        assert_eq!(
            k[at..],
            [
                ("not_judged_by_sensor".to_string(), "3".to_string()),
                ("not_judged_by_sensor: occluded".to_string(), "2".to_string()),
                ("not_judged_by_sensor: outside_grid".to_string(), "1".to_string()),
            ]
        );
        // Without a cloud: the sensor checks WARN, motion still judged.
        v.sensor_status = "no_lidar_data".into();
        v.cloud_paired = false;
        v.objects = vec![verdict(3, 3, "implausible motion", "speed")];
        let s = check_statuses(&v);
        let levels: Vec<u8> = s.iter().map(|s| s.level).collect();
        assert_eq!(levels, [level::WARN, level::WARN, level::ERROR, level::WARN]);
        assert_eq!(s[3].message, "not run: no_lidar_data");
        // The summary status (the bag's /diagnostics) agrees: ERROR.
        assert_eq!(diagnostics(&v).status[0].level, level::ERROR);
    }

    #[test]
    fn clusters_outside_the_roi_are_counted_by_reason_and_change_no_level() {
        use pmon_monitor::{ClusterReport, GridStats, RoiStatus};
        let cluster = |roi: RoiStatus, object: Option<u32>| ClusterReport {
            cells: 3,
            centroid_m: [1.0, 2.0],
            bounds_m: [0.5, 1.5, 1.5, 2.5],
            in_roi: roi.in_roi(),
            roi,
            object,
        };
        let clusters = [
            cluster(RoiStatus::Outside, None),
            cluster(RoiStatus::Grazing, None),
            cluster(RoiStatus::Outside, None),
            cluster(RoiStatus::Outside, Some(0)), // a displaced object's evidence: not excused
            cluster(RoiStatus::Inside, Some(0)),
        ];
        let rep = FrameReport { objects: &[], clusters: &clusters, grid: GridStats::default(), sensor_status: None };
        assert_eq!(rep.outside_roi_counts(), [2, 1]);
        let v = FrameVerdicts { cloud_paired: true, ..Default::default() };
        let mut s = check_statuses(&v);
        add_outside_roi(&mut s, rep.outside_roi_counts());
        let missed = s.iter().find(|s| s.name == check_names::MISSED).unwrap();
        assert_eq!(missed.level, level::OK);
        let keys: Vec<(&str, &str)> = missed.values.iter().map(|kv| (kv.key.as_str(), kv.value.as_str())).collect();
        assert_eq!(keys, [("missed_objects", "0"), ("outside_roi_no_return", "2"), ("outside_roi_grazing", "1")]);
    }
}
