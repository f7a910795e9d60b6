//! One object list -> one checked frame: the objects placed in the ego frame, the paired cloud moved into it
//! through TF, the monitor run, the verdict message built. Shared by `pmon check bag.mcap` ([`crate::bag`])
//! and the live node (`pmon ros2`), so both give the same verdicts for the same messages.

use std::time::Instant;

use pmon_monitor::{FrameReport, Monitor, MonitorParams, ObjectState, Pose2};
use pmon_recording::{OwnedCloud, RecordedFrame};

use crate::bag::{BagConfig, BagSummary, CheckedFrame, Problem};
use crate::convert::{detected, inverse, tracked};
use crate::msg::{DetectedObjects, Header, PointCloud2, Time, TrackedObjects, Uuid};
use crate::pointcloud::to_points;
use crate::tf::TfBuffer;
use crate::verdicts::{frame_verdicts, FrameContext};

/// An object list of either Autoware type.
#[derive(Clone, Debug, PartialEq)]
pub enum ObjectList {
    /// `autoware_perception_msgs/TrackedObjects`.
    Tracked(TrackedObjects),
    /// `autoware_perception_msgs/DetectedObjects`.
    Detected(DetectedObjects),
}

impl ObjectList {
    /// The list's header.
    #[must_use]
    pub fn header(&self) -> &Header {
        match self {
            Self::Tracked(m) => &m.header,
            Self::Detected(m) => &m.header,
        }
    }
}

/// A decoded cloud: its points (sensor frame) and header, or why it could not be used.
pub type ReadCloud = Result<(Vec<[f32; 3]>, Header), String>;

/// A paired cloud as the checker gets it: its stamp, and the cloud (`None`: it could not be found).
pub type PairedCloud = Option<(Time, Option<ReadCloud>)>;

/// A `PointCloud2`'s points, or why they cannot be used; non-finite points are left out and counted.
pub fn read_cloud(c: PointCloud2) -> (ReadCloud, usize) {
    match to_points(&c) {
        Ok(pts) => (Ok((pts.points, c.header)), pts.non_finite),
        Err(e) => (Err(e.to_string()), 0),
    }
}

/// What places the objects and the cloud: configuration, TF, the ego's odometry (sorted by stamp, seconds).
pub struct FrameChecker<'a> {
    /// Topics, frames, tolerances.
    pub cfg: &'a BagConfig,
    /// The monitor's parameters (default uncertainty).
    pub params: &'a MonitorParams,
    /// Transforms.
    pub tf: &'a TfBuffer,
    /// The ego pose from odometry, `(stamp_s, world_from_ego)`, sorted by stamp.
    pub odometry: &'a [(f64, Pose2)],
}

impl FrameChecker<'_> {
    /// The ego pose at `t_s`: the odometry nearest in stamp within `pose_tolerance_s`, else `/tf`.
    #[must_use]
    pub fn ego_pose(&self, t_s: f64) -> Option<Pose2> {
        let k = self.odometry.partition_point(|o| o.0 < t_s);
        let best = [k.checked_sub(1), Some(k)]
            .into_iter()
            .flatten()
            .filter_map(|j| self.odometry.get(j))
            .min_by(|a, b| (a.0 - t_s).abs().total_cmp(&(b.0 - t_s).abs()));
        if let Some((t, p)) = best {
            if (t - t_s).abs() <= self.cfg.pose_tolerance_s {
                return Some(*p);
            }
        }
        self.tf.lookup2(&self.cfg.world_frame, &self.cfg.ego_frame, t_s, self.cfg.pose_tolerance_s)
    }

    /// Checks one object list (frame number `index`, received at `log_time_ns`) with its paired cloud, counts
    /// it in `summary` (problems listed there under the object topic) and hands the result to `sink`.
    ///
    /// # Errors
    /// The monitor refused the frame, or the sink failed (its message).
    #[allow(clippy::too_many_arguments, clippy::too_many_lines)]
    pub fn check(
        &self,
        monitor: &mut Monitor,
        list: &ObjectList,
        log_time_ns: u64,
        cloud_in: PairedCloud,
        index: u64,
        summary: &mut BagSummary,
        sink: &mut dyn FnMut(&CheckedFrame<'_>) -> Result<(), String>,
    ) -> Result<(), String> {
        let cloud_stamp = cloud_in.as_ref().map(|(t, _)| *t);
        let cfg = self.cfg;
        let header = list.header();
        let t_s = header.stamp.as_secs_f64();
        let objects_topic = cfg.objects_topic.as_str();
        let mut note = |m: String| {
            summary.problems.push(Problem { topic: objects_topic.into(), log_time_ns, message: m });
        };
        let world_from_ego = self.ego_pose(t_s);
        if world_from_ego.is_none() {
            note(format!("no ego pose within {} s: plausibility runs in the ego frame", cfg.pose_tolerance_s));
        }
        // Where the objects are: the ego frame, the world frame, or a frame with a transform to the ego.
        let ego_from_msg = if header.frame_id == cfg.ego_frame {
            Some(Pose2::default())
        } else if header.frame_id == cfg.world_frame {
            world_from_ego.as_ref().map(inverse)
        } else {
            self.tf.lookup2(&cfg.ego_frame, &header.frame_id, t_s, cfg.pose_tolerance_s)
        };
        let mut objects_problem = None;
        let ego_from_msg = ego_from_msg.unwrap_or_else(|| {
            objects_problem = Some(format!("missing transform {} <- {}", cfg.ego_frame, header.frame_id));
            Pose2::default()
        });
        let default = self.params.default_uncertainty;
        let (mut objects, uuids): (Vec<ObjectState>, Vec<Uuid>) = match list {
            ObjectList::Tracked(m) => {
                m.objects.iter().map(|o| (tracked(o, &ego_from_msg, &default), o.object_id)).unzip()
            }
            ObjectList::Detected(m) => m
                .objects
                .iter()
                .enumerate()
                // Detections have no track id: a fresh id each frame (frame << 20 | index), new tracks.
                .map(|(i, o)| (detected(o, (index << 20) | i as u64, &ego_from_msg, &default), Uuid::default()))
                .unzip(),
        };
        if let Some(m) = &objects_problem {
            note(format!("objects not placed ({m}): every object is not monitored (invalid state)"));
            // NaN positions make the monitor say "not monitored: invalid state" for each object.
            for o in &mut objects {
                o.x_m = f32::NAN;
            }
        }
        // The cloud, moved into the ego frame through the sensor's extrinsic.
        let mut cloud_problem = None;
        let mut cloud = None;
        if let Some((_, entry)) = cloud_in {
            match entry {
                Some(Ok((points, h))) => {
                    match self.tf.lookup3(&cfg.ego_frame, &h.frame_id, h.stamp.as_secs_f64(), cfg.pose_tolerance_s) {
                        Some(ego_from_sensor) => cloud = Some(OwnedCloud { points_in_sensor: points, ego_from_sensor }),
                        None => {
                            let m = format!("missing transform {} <- {}", cfg.ego_frame, h.frame_id);
                            note(format!("{m}: sensor checks not run"));
                            cloud_problem = Some(m);
                        }
                    }
                }
                Some(Err(e)) => cloud_problem = Some(format!("malformed cloud: {e}")),
                None => cloud_problem = Some("cloud not found".into()),
            }
        }
        let frame = RecordedFrame {
            index,
            timestamp_s: t_s,
            world_from_ego: world_from_ego.unwrap_or_default(),
            objects,
            cloud,
            roi_in_ego: Vec::new(),
            static_in_ego: Vec::new(),
        };
        let mut polygons = Vec::new();
        let view = frame.as_frame(&mut polygons);
        let started = Instant::now();
        let rep = monitor.check(&view).map_err(|e| format!("object list at {t_s:.3} s: {e}"))?;
        let processing_time_s = started.elapsed().as_secs_f64();
        let ctx = FrameContext { header, cloud_stamp, cloud_problem, uuids: &uuids, processing_time_s };
        let verdicts = frame_verdicts(&ctx, &frame.objects, &rep);
        summary.frames += 1;
        summary.objects += rep.objects.len() as u64;
        let missed = rep.missed_objects() as u64;
        summary.missed_objects += missed;
        if rep.object_alarms() > 0 || missed > 0 {
            summary.frames_with_alarms += 1;
        }
        for r in rep.objects {
            *summary.verdicts.entry(r.verdict.to_string()).or_default() += 1;
        }
        // The report borrows the monitor; an owned copy lets the sink see the grid as well.
        let (objects, clusters) = (rep.objects.to_vec(), rep.clusters.to_vec());
        let report =
            FrameReport { objects: &objects, clusters: &clusters, grid: rep.grid, sensor_status: rep.sensor_status };
        sink(&CheckedFrame { frame: &frame, report: &report, verdicts: &verdicts, monitor })
    }
}
