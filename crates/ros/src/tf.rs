//! A small transform buffer: `parent_from_child` edges from `/tf_static` (latest wins) and time-stamped
//! edges from `/tf` (nearest in time within a tolerance), looked up along the child -> parent chain.

use std::collections::BTreeMap;

use pmon_monitor::{Isometry3, Pose2};

use crate::convert::{compose, compose3, isometry, pose2};
use crate::msg::{TfMessage, Transform};

/// Longest chain followed (a bound for cyclic or very deep trees).
pub const MAX_CHAIN: usize = 32;

/// Transforms keyed by child frame.
#[derive(Clone, Debug, Default)]
pub struct TfBuffer {
    statics: BTreeMap<String, (String, Transform)>,
    dynamic: BTreeMap<String, Vec<(f64, String, Transform)>>,
}

impl TfBuffer {
    /// Adds a `tf2_msgs/TFMessage`; `is_static` for `/tf_static`.
    pub fn add(&mut self, msg: &TfMessage, is_static: bool) {
        for t in &msg.transforms {
            let edge = (t.header.frame_id.clone(), t.transform);
            if is_static {
                self.statics.insert(t.child_frame_id.clone(), edge);
            } else {
                self.dynamic.entry(t.child_frame_id.clone()).or_default().push((
                    t.header.stamp.as_secs_f64(),
                    edge.0,
                    edge.1,
                ));
            }
        }
    }

    /// Sorts the dynamic edges by time (call once after the last `add`).
    pub fn finish(&mut self) {
        for v in self.dynamic.values_mut() {
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
    }

    /// Forgets the time-stamped edges of each child more than `history_s` older than that child's newest (a
    /// live node's buffer stays bounded). Call after [`Self::finish`].
    pub fn prune(&mut self, history_s: f64) {
        for v in self.dynamic.values_mut() {
            let Some(newest) = v.last().map(|e| e.0) else { continue };
            let keep_from = v.partition_point(|e| e.0 < newest - history_s);
            v.drain(..keep_from);
        }
    }

    /// The newest stamp of the time-stamped edge to `child`, seconds.
    #[must_use]
    pub fn latest(&self, child: &str) -> Option<f64> {
        self.dynamic.get(child).and_then(|v| v.last()).map(|e| e.0)
    }

    /// True when no transform was added.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.statics.is_empty() && self.dynamic.is_empty()
    }

    fn edge(&self, child: &str, t_s: f64, tolerance_s: f64) -> Option<(&str, &Transform)> {
        if let Some((p, t)) = self.statics.get(child) {
            return Some((p, t));
        }
        let v = self.dynamic.get(child)?;
        let i = v.partition_point(|e| e.0 < t_s);
        let best = [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|j| v.get(j))
            .min_by(|a, b| (a.0 - t_s).abs().total_cmp(&(b.0 - t_s).abs()))?;
        ((best.0 - t_s).abs() <= tolerance_s).then_some((best.1.as_str(), &best.2))
    }

    /// `target_from_source` in 3D, following parents from `source` until `target`; `None` when the chain
    /// does not reach `target` (a missing transform).
    #[must_use]
    pub fn lookup3(&self, target: &str, source: &str, t_s: f64, tolerance_s: f64) -> Option<Isometry3> {
        let mut acc = Isometry3::IDENTITY;
        let mut frame = source;
        for _ in 0..MAX_CHAIN {
            if frame == target {
                return Some(acc);
            }
            let (parent, t) = self.edge(frame, t_s, tolerance_s)?;
            acc = compose3(&isometry(t), &acc);
            frame = parent;
        }
        None
    }

    /// `target_from_source` in the plane (x, y, yaw).
    #[must_use]
    pub fn lookup2(&self, target: &str, source: &str, t_s: f64, tolerance_s: f64) -> Option<Pose2> {
        let mut acc = Pose2::default();
        let mut frame = source;
        for _ in 0..MAX_CHAIN {
            if frame == target {
                return Some(acc);
            }
            let (parent, t) = self.edge(frame, t_s, tolerance_s)?;
            acc = compose(&pose2(t.translation.x, t.translation.y, &t.rotation), &acc);
            frame = parent;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Header, Quaternion, Time, TransformStamped, Vector3};

    fn ts(parent: &str, child: &str, sec: i32, x: f64) -> TransformStamped {
        TransformStamped {
            header: Header { stamp: Time { sec, nanosec: 0 }, frame_id: parent.into() },
            child_frame_id: child.into(),
            transform: Transform { translation: Vector3 { x, y: 0.0, z: 0.0 }, rotation: Quaternion::default() },
        }
    }

    #[test]
    fn chains_statics_and_nearest_dynamic() {
        let mut b = TfBuffer::default();
        b.add(
            &TfMessage { transforms: vec![ts("base_link", "sensor_kit", 0, 1.0), ts("sensor_kit", "lidar", 0, 0.5)] },
            true,
        );
        b.add(
            &TfMessage { transforms: vec![ts("map", "base_link", 10, 100.0), ts("map", "base_link", 11, 110.0)] },
            false,
        );
        b.finish();
        let e = b.lookup3("base_link", "lidar", 0.0, 0.0).unwrap();
        assert!((e.translation_m[0] - 1.5).abs() < 1e-6);
        let p = b.lookup2("map", "base_link", 10.9, 0.2).unwrap();
        assert!((p.x_m - 110.0).abs() < 1e-9);
        assert!(b.lookup2("map", "base_link", 12.0, 0.2).is_none(), "too far in time");
        assert!(b.lookup3("base_link", "camera", 0.0, 0.0).is_none(), "missing transform");
        assert_eq!(b.latest("base_link"), Some(11.0));
        assert_eq!(b.latest("lidar"), None, "static edges have no stamp");
        b.prune(0.5);
        assert!(b.lookup2("map", "base_link", 10.0, 0.2).is_none(), "pruned");
        assert!(b.lookup2("map", "base_link", 11.0, 0.2).is_some(), "the newest edge is kept");
        // A cycle ends at the chain bound.
        b.add(&TfMessage { transforms: vec![ts("b", "a", 0, 0.0), ts("a", "b", 0, 0.0)] }, true);
        assert!(b.lookup3("base_link", "a", 0.0, 0.0).is_none());
    }
}
