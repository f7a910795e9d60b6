//! The verdicts do not depend on the order of the object list (issue #10): a tracker may list the same objects in
//! any order, and from frame to frame in different orders; every object keeps its verdict, cause and offset, and
//! every conflict cluster goes to the same object. Checked on the built-in crowded street with half of the tracks
//! displaced (where boxes compete for the same evidence), listed by id, reversed and shuffled.

use std::collections::BTreeMap;

use pmon_monitor::{ClusterReport, Monitor, MonitorParams, ObjectReport, ObjectState, SensorVerdict};
use pmon_recording::RecordedFrame;
use pmon_scenario::Simulator;

fn street(seed: u64, seconds: f64) -> Vec<RecordedFrame> {
    let cfg = pmon_campaign::sim_tasks::scenario_config("pedestrians", seed, Some(seconds)).unwrap();
    let mut sim = Simulator::new(&cfg).unwrap();
    let mut frames = Vec::new();
    while let Some(f) = sim.step() {
        frames.push(f.frame);
    }
    frames
}

/// Every other track (by id) displaced by 1.5 m for the whole stretch, each in its own direction.
fn displace(frames: &mut [RecordedFrame]) {
    for f in frames {
        for o in f.objects.iter_mut().filter(|o| o.id % 2 == 0) {
            let a = o.id as f32 * 2.4;
            o.x_m += 1.5 * a.cos();
            o.y_m += 1.5 * a.sin();
        }
    }
}

/// Per frame: each object's report by id, and each cluster with the id of the object it went to.
type Checked = Vec<(BTreeMap<u64, ObjectReport>, Vec<(ClusterReport, Option<u64>)>)>;

fn check_all(frames: &[RecordedFrame], reorder: impl Fn(usize, &mut Vec<ObjectState>)) -> Checked {
    let mut monitor = Monitor::new(MonitorParams::default()).unwrap();
    let mut out = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        let mut f = f.clone();
        reorder(k, &mut f.objects);
        let mut polygons = Vec::new();
        let report = monitor.check(&f.as_frame(&mut polygons)).unwrap();
        // Every object gets its report in input order.
        let ids: Vec<u64> = report.objects.iter().map(|r| r.id).collect();
        assert_eq!(ids, f.objects.iter().map(|o| o.id).collect::<Vec<_>>(), "frame {k}: reports out of input order");
        let by_id = report.objects.iter().map(|r| (r.id, *r)).collect();
        let clusters = report
            .clusters
            .iter()
            .map(|c| (*c, c.object.and_then(|j| f.objects.get(j as usize)).map(|o| o.id)))
            .map(|(c, id)| (ClusterReport { object: None, ..c }, id))
            .collect();
        out.push((by_id, clusters));
    }
    out
}

#[test]
fn verdicts_do_not_depend_on_the_order_of_the_object_list() {
    let mut frames = street(23, 1.5);
    displace(&mut frames);
    let by_id = check_all(&frames, |_, objects| objects.sort_by_key(|o| o.id));
    let reversed = check_all(&frames, |_, objects| {
        objects.sort_by_key(|o| o.id);
        objects.reverse();
    });
    // A different order in every frame: rotated by the frame's index and every other pair swapped.
    let shuffled = check_all(&frames, |k, objects| {
        objects.sort_by_key(|o| o.id);
        let n = objects.len().max(1);
        objects.rotate_left((7 * k + 3) % n);
        for pair in objects.chunks_mut(2) {
            pair.reverse();
        }
    });
    for (name, other) in [("reversed", &reversed), ("shuffled", &shuffled)] {
        for (k, (a, b)) in by_id.iter().zip(other).enumerate() {
            for (id, r) in &a.0 {
                assert_eq!(Some(r), b.0.get(id), "{name}, frame {k}, object {id}");
            }
            assert_eq!(a.1, b.1, "{name}, frame {k}: clusters or the objects they went to");
        }
    }
    // The check is about something: displaced boxes were flagged, and conflict clusters given to objects.
    let flagged = by_id.iter().flat_map(|f| f.0.values()).filter(|r| r.sensor.verdict == SensorVerdict::PositionError);
    assert!(flagged.count() >= 20, "too few position errors to compare");
    assert!(by_id.iter().flat_map(|f| &f.1).filter(|c| c.1.is_some()).count() >= 10, "too few clusters given");
}
