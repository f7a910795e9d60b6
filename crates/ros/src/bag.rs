//! `pmon check bag.mcap`: read a rosbag2 MCAP, pair point clouds with object lists, run the monitor.
//!
//! Two passes over the file: the first decodes everything but the clouds' points (object lists, odometry,
//! transforms, cloud headers) and plans the frames; the second decodes each paired cloud once and checks the
//! frames in the object lists' file order as soon as their cloud has been read. Only clouds read ahead of
//! their object list are held in memory.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::{Path, PathBuf};

use pmon_monitor::{FrameReport, Monitor, MonitorParams, Pose2};
use pmon_recording::RecordedFrame;

use crate::cdr::decode;
use crate::convert::pose2;
pub use crate::frame::{FrameChecker, ObjectList, ReadCloud};
use crate::msg::{FrameVerdicts, HeaderOnly, Odometry, PointCloud2, TfMessage, Time};
use crate::pointcloud::to_points;
use crate::tf::TfBuffer;

/// Topics, frames and tolerances. `Default` is Autoware's (Universe) naming.
#[derive(Clone, Debug, PartialEq)]
pub struct BagConfig {
    /// `sensor_msgs/PointCloud2` topic.
    pub cloud_topic: String,
    /// `autoware_perception_msgs/TrackedObjects` or `DetectedObjects` topic (the type is read from the bag).
    pub objects_topic: String,
    /// `nav_msgs/Odometry` of the ego vehicle (`map` -> `base_link`); `/tf` is used when it is absent.
    pub odometry_topic: String,
    /// `tf2_msgs/TFMessage` topic.
    pub tf_topic: String,
    /// `tf2_msgs/TFMessage` static topic.
    pub tf_static_topic: String,
    /// The ego frame the monitor works in.
    pub ego_frame: String,
    /// The world frame of the ego pose.
    pub world_frame: String,
    /// Largest |object stamp - cloud stamp| for a pairing, seconds. Autoware stamps objects with the stamp of
    /// the cloud they came from, so pairs match exactly; the default, 0.05 s, is half a 10 Hz period.
    pub pairing_tolerance_s: f64,
    /// Largest |object stamp - pose stamp| for an ego pose (odometry or `/tf`), seconds.
    pub pose_tolerance_s: f64,
}

impl Default for BagConfig {
    fn default() -> Self {
        Self {
            cloud_topic: "/sensing/lidar/concatenated/pointcloud".into(),
            objects_topic: "/perception/object_recognition/tracking/objects".into(),
            odometry_topic: "/localization/kinematic_state".into(),
            tf_topic: "/tf".into(),
            tf_static_topic: "/tf_static".into(),
            ego_frame: "base_link".into(),
            world_frame: "map".into(),
            pairing_tolerance_s: 0.05,
            pose_tolerance_s: 0.05,
        }
    }
}

/// A bag that cannot be read at all.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// I/O.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Not a readable MCAP file (bad magic, truncated, bad chunk).
    #[error("{path}: not a readable MCAP file: {message}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// What the reader said.
        message: String,
    },
    /// The object topic is missing or of an unsupported type.
    #[error("{path}: {message}")]
    Topics {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The monitor refused a frame or the sink failed.
    #[error("{path}: {message}")]
    Frame {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Something about one message or frame that the user must know (listed, counted, never skipped silently).
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// Topic.
    pub topic: String,
    /// Log time of the message, nanoseconds.
    pub log_time_ns: u64,
    /// What happened and what pmon did about it.
    pub message: String,
}

/// What a run over a bag found, beyond the verdicts.
#[derive(Clone, Debug, Default)]
pub struct BagSummary {
    /// Object lists checked (frames).
    pub frames: u64,
    /// Object states checked.
    pub objects: u64,
    /// Verdict counts (`Display` of the verdict).
    pub verdicts: BTreeMap<String, u64>,
    /// Frames with at least one alarm.
    pub frames_with_alarms: u64,
    /// Missed-object alarms.
    pub missed_objects: u64,
    /// Clouds read.
    pub clouds: u64,
    /// Object lists with no cloud within the tolerance (checked with the plausibility checks only), by stamp.
    pub unpaired_object_lists: Vec<Time>,
    /// Clouds no object list was paired with, by stamp.
    pub unpaired_clouds: Vec<Time>,
    /// Messages that did not decode, clouds that could not be used, missing transforms and poses.
    pub problems: Vec<Problem>,
    /// Messages on the object or cloud topic that did not decode (also in `problems`).
    pub undecodable: u64,
}

/// One checked frame, handed to the sink.
pub struct CheckedFrame<'a> {
    /// The frame as the monitor saw it (ego frame; the cloud in the sensor frame).
    pub frame: &'a RecordedFrame,
    /// The monitor's report.
    pub report: &'a FrameReport<'a>,
    /// The verdict message (with the diagnostics built from it by [`crate::verdicts::diagnostics`]).
    pub verdicts: &'a FrameVerdicts,
    /// The monitor (its grid holds this frame's occupancy).
    pub monitor: &'a Monitor,
}

struct Planned {
    list: ObjectList,
    log_time_ns: u64,
    /// Stream index of the paired cloud.
    cloud: Option<usize>,
    /// Its stamp.
    cloud_stamp: Time,
}

/// Reads a whole file (MCAP readers work on a byte slice).
///
/// # Errors
/// [`BagError::Io`].
pub fn read_file(path: &Path) -> Result<Vec<u8>, BagError> {
    std::fs::read(path).map_err(|source| BagError::Io { path: path.to_path_buf(), source })
}

fn mcap_err(path: &Path, e: &mcap::McapError) -> BagError {
    BagError::Mcap { path: path.to_path_buf(), message: e.to_string() }
}

/// Checks every length in an MCAP file before the `mcap` crate parses it ([`crate::mcap_check`]): a length
/// prefix beyond its record, a record beyond its file or chunk, or chunks that would decompress to more than
/// [`crate::mcap_check::MAX_INFLATION`] times the file's size are an error naming the file and the record's
/// offset, instead of an allocation of the size they announce. [`check_bag`] calls it first.
///
/// # Errors
/// [`BagError::Mcap`].
pub fn check_mcap(path: &Path, bytes: &[u8]) -> Result<(), BagError> {
    crate::mcap_check::check_lengths(bytes)
        .map_err(|e| BagError::Mcap { path: path.to_path_buf(), message: e.to_string() })
}

/// Runs the monitor over a bag, calling `sink` for each checked frame in the object lists' order.
///
/// # Errors
/// [`BagError`] when the file cannot be read as MCAP (its lengths are checked first: [`check_mcap`]), has no object topic, or the sink fails. Bad messages
/// inside a readable bag are not errors: they are listed in [`BagSummary::problems`].
#[allow(clippy::too_many_lines)]
pub fn check_bag(
    path: &Path,
    bytes: &[u8],
    cfg: &BagConfig,
    params: &MonitorParams,
    sink: &mut dyn FnMut(&CheckedFrame<'_>) -> Result<(), String>,
) -> Result<BagSummary, BagError> {
    let mut summary = BagSummary::default();
    let mut lists: Vec<Planned> = Vec::new();
    let mut clouds: Vec<(usize, Time)> = Vec::new();
    let mut odometry: Vec<(f64, Pose2)> = Vec::new();
    let mut tf = TfBuffer::default();
    let mut object_topic_seen = false;
    let problem = |s: &mut BagSummary, topic: &str, t: u64, m: String| {
        s.problems.push(Problem { topic: topic.into(), log_time_ns: t, message: m });
    };

    check_mcap(path, bytes)?;

    // Pass 1: everything but the points.
    let stream = mcap::MessageStream::new(bytes).map_err(|e| mcap_err(path, &e))?;
    for (index, msg) in stream.enumerate() {
        let msg = msg.map_err(|e| mcap_err(path, &e))?;
        let topic = msg.channel.topic.as_str();
        let schema = msg.channel.schema.as_ref().map_or("", |s| s.name.as_str());
        if topic == cfg.objects_topic {
            object_topic_seen = true;
            let list = match schema {
                "autoware_perception_msgs/msg/TrackedObjects" => decode(&msg.data).map(ObjectList::Tracked),
                "autoware_perception_msgs/msg/DetectedObjects" => decode(&msg.data).map(ObjectList::Detected),
                other => {
                    return Err(BagError::Topics {
                        path: path.into(),
                        message: format!(
                            "topic {topic} has type {other:?}; expected autoware_perception_msgs/msg/TrackedObjects or DetectedObjects"
                        ),
                    })
                }
            };
            match list {
                Ok(list) => {
                    lists.push(Planned { list, log_time_ns: msg.log_time, cloud: None, cloud_stamp: Time::default() })
                }
                Err(e) => {
                    summary.undecodable += 1;
                    problem(&mut summary, topic, msg.log_time, format!("object list not checked: {e}"));
                }
            }
        } else if topic == cfg.cloud_topic {
            match decode::<HeaderOnly>(&msg.data) {
                Ok(h) => clouds.push((index, h.header.stamp)),
                Err(e) => {
                    summary.undecodable += 1;
                    problem(&mut summary, topic, msg.log_time, format!("cloud not used: {e}"));
                }
            }
        } else if topic == cfg.odometry_topic {
            match decode::<Odometry>(&msg.data) {
                Ok(o) => {
                    let p = &o.pose.pose;
                    odometry.push((o.header.stamp.as_secs_f64(), pose2(p.position.x, p.position.y, &p.orientation)));
                }
                Err(e) => problem(&mut summary, topic, msg.log_time, format!("odometry not used: {e}")),
            }
        } else if topic == cfg.tf_topic || topic == cfg.tf_static_topic {
            match decode::<TfMessage>(&msg.data) {
                Ok(m) => tf.add(&m, topic == cfg.tf_static_topic),
                Err(e) => problem(&mut summary, topic, msg.log_time, format!("transforms not used: {e}")),
            }
        }
    }
    if !object_topic_seen {
        return Err(BagError::Topics {
            path: path.into(),
            message: format!("no messages on the object topic {}", cfg.objects_topic),
        });
    }
    tf.finish();
    odometry.sort_by(|a, b| a.0.total_cmp(&b.0));
    summary.clouds = clouds.len() as u64;

    // Pairing: the cloud nearest in stamp, within the tolerance.
    let mut by_stamp: Vec<(f64, usize)> = clouds.iter().map(|(i, t)| (t.as_secs_f64(), *i)).collect();
    by_stamp.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut used = vec![false; by_stamp.len()];
    let stamp_of: BTreeMap<usize, Time> = clouds.iter().copied().collect();
    for p in &mut lists {
        let t = p.list.header().stamp.as_secs_f64();
        let k = by_stamp.partition_point(|c| c.0 < t);
        let best = [k.checked_sub(1), Some(k)]
            .into_iter()
            .flatten()
            .filter(|&j| j < by_stamp.len())
            .min_by(|&a, &b| (by_stamp[a].0 - t).abs().total_cmp(&(by_stamp[b].0 - t).abs()));
        match best.filter(|&j| (by_stamp[j].0 - t).abs() <= cfg.pairing_tolerance_s) {
            Some(j) => {
                used[j] = true;
                p.cloud = Some(by_stamp[j].1);
                p.cloud_stamp = stamp_of.get(&by_stamp[j].1).copied().unwrap_or_default();
            }
            None => summary.unpaired_object_lists.push(p.list.header().stamp),
        }
    }
    for (j, (_, index)) in by_stamp.iter().enumerate() {
        if !used[j] {
            summary.unpaired_clouds.push(stamp_of.get(index).copied().unwrap_or_default());
        }
    }

    // Pass 2: decode the paired clouds and check frames in order.
    let mut uses: BTreeMap<usize, usize> = BTreeMap::new();
    for p in &lists {
        if let Some(c) = p.cloud {
            *uses.entry(c).or_default() += 1;
        }
    }
    let used_clouds: BTreeSet<usize> = uses.keys().copied().collect();
    let mut monitor =
        Monitor::new(*params).map_err(|e| BagError::Frame { path: path.into(), message: e.to_string() })?;
    let mut ready: BTreeMap<usize, ReadCloud> = BTreeMap::new();
    let mut queue: VecDeque<Planned> = lists.into();
    let mut frame_index = 0u64;
    let run = FrameChecker { cfg, params, tf: &tf, odometry: &odometry };
    let frame_err = |message| BagError::Frame { path: path.into(), message };
    let mut check = |monitor: &mut Monitor,
                     p: &Planned,
                     ready: &mut BTreeMap<usize, ReadCloud>,
                     index: u64,
                     summary: &mut BagSummary|
     -> Result<(), BagError> {
        // A cloud paired with several lists is cloned for all but its last.
        let cloud = p.cloud.map(|ci| {
            let remaining = uses.get_mut(&ci).map(|u| {
                *u -= 1;
                *u
            });
            let entry = if remaining == Some(0) { ready.remove(&ci) } else { ready.get(&ci).cloned() };
            (p.cloud_stamp, entry)
        });
        run.check(monitor, &p.list, p.log_time_ns, cloud, index, summary, sink).map_err(frame_err)
    };
    let stream = mcap::MessageStream::new(bytes).map_err(|e| mcap_err(path, &e))?;
    for (index, msg) in stream.enumerate() {
        let msg = msg.map_err(|e| mcap_err(path, &e))?;
        if used_clouds.contains(&index) {
            let cloud = decode::<PointCloud2>(&msg.data).map_err(|e| e.to_string()).and_then(|c| {
                let pts = to_points(&c).map_err(|e| e.to_string())?;
                if pts.non_finite > 0 {
                    summary.problems.push(Problem {
                        topic: msg.channel.topic.clone(),
                        log_time_ns: msg.log_time,
                        message: format!("{} non-finite points left out", pts.non_finite),
                    });
                }
                Ok((pts.points, c.header))
            });
            if let Err(e) = &cloud {
                summary.undecodable += 1;
                summary.problems.push(Problem {
                    topic: msg.channel.topic.clone(),
                    log_time_ns: msg.log_time,
                    message: format!("cloud not used (sensor checks not run): {e}"),
                });
            }
            ready.insert(index, cloud);
        }
        while queue.front().is_some_and(|p| p.cloud.is_none_or(|c| ready.contains_key(&c))) {
            let Some(p) = queue.pop_front() else { break };
            check(&mut monitor, &p, &mut ready, frame_index, &mut summary)?;
            frame_index += 1;
        }
    }
    // Clouds that never arrived cannot happen (they were indexed in pass 1); check whatever is left anyway.
    while let Some(p) = queue.pop_front() {
        check(&mut monitor, &p, &mut ready, frame_index, &mut summary)?;
        frame_index += 1;
    }
    Ok(summary)
}
