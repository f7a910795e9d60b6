//! The DDS side: subscriptions, publications, the event loop, shutdown.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use pmon_monitor::{Monitor, MonitorParams, Pose2};
use pmon_ros::bag::{BagSummary, Problem};
use pmon_ros::convert::pose2;
use pmon_ros::frame::{read_cloud, FrameChecker, ObjectList, ReadCloud};
use pmon_ros::msg::{
    DetectedObjects, DiagnosticArray, FrameVerdicts, Odometry, PointCloud2, TfMessage, Time, TrackedObjects,
};
use pmon_ros::tf::TfBuffer;
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{
    Context, ContextOptions, Gid, MessageInfo, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher,
    QosProfile, Subscription,
};
use serde::de::DeserializeOwned;

use crate::config::{NodeConfig, ObjectsType, Reliability};
use crate::pairing::{Dropped, Pairer};
use crate::status::{node_status, NodeCounters};

/// The node could not start or stopped on an error.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// A topic, node or namespace name ROS 2 does not accept.
    #[error("invalid ROS 2 name {name:?}: {message}")]
    Name {
        /// The name.
        name: String,
        /// Why.
        message: String,
    },
    /// DDS refused to create the participant, a topic, a reader or a writer.
    #[error("DDS: cannot create {what}: {message}")]
    Dds {
        /// What.
        what: String,
        /// Why.
        message: String,
    },
    /// A setting out of range.
    #[error("{0}")]
    Config(String),
    /// The monitor's parameters or a frame were refused.
    #[error("monitor: {0}")]
    Monitor(String),
}

/// What a run did (printed at shutdown).
#[derive(Clone, Debug, Default)]
pub struct NodeSummary {
    /// Frames, verdicts, unpaired lists and clouds, problems: as `pmon check bag.mcap` counts them.
    pub checks: BagSummary,
    /// Drops, losses, latencies.
    pub counters: NodeCounters,
}

/// The largest DDS domain id (RTPS port mapping: 7400 + 250 * domain + offsets must fit in 16 bits).
pub const MAX_DOMAIN_ID: u16 = 232;

/// Problems kept for the summary (each is also logged when it happens); more are counted only.
const MAX_PROBLEMS: usize = 1000;
/// Odometry samples kept.
const MAX_ODOMETRY: usize = 400;
/// How far back time-stamped transforms are kept, seconds.
const TF_HISTORY_S: f64 = 10.0;

enum ObjectsSub {
    Tracked(Subscription<TrackedObjects>),
    Detected(Subscription<DetectedObjects>),
}

fn qos(reliability: Reliability, depth: usize) -> QosProfile {
    let q = QosProfile::subscription_default()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: depth.max(1) });
    match reliability {
        Reliability::BestEffort => q.reliability_best_effort(),
        Reliability::Reliable => q.reliability_reliable(WhenFull::DEFAULT),
    }
}

fn dds(what: &str) -> impl Fn(ros2_client::CreateError) -> NodeError + '_ {
    move |e| NodeError::Dds { what: what.into(), message: e.to_string() }
}

struct Endpoints {
    node: Node,
}

impl Endpoints {
    fn subscription<T: 'static>(
        &mut self,
        topic: &str,
        (package, ty): (&str, &str),
        q: &QosProfile,
    ) -> Result<Subscription<T>, NodeError> {
        let name = Name::parse(topic).map_err(|e| NodeError::Name { name: topic.into(), message: format!("{e:?}") })?;
        let what = format!("subscription {topic} ({package}/msg/{ty})");
        let t = self.node.create_topic(&name, MessageTypeName::new(package, ty), q).map_err(dds(&what))?;
        self.node.create_subscription(&t, None).map_err(dds(&what))
    }

    fn publisher<T: serde::Serialize>(
        &mut self,
        topic: &str,
        (package, ty): (&str, &str),
        q: &QosProfile,
    ) -> Result<Publisher<T>, NodeError> {
        let name = Name::parse(topic).map_err(|e| NodeError::Name { name: topic.into(), message: format!("{e:?}") })?;
        let what = format!("publisher {topic} ({package}/msg/{ty})");
        let t = self.node.create_topic(&name, MessageTypeName::new(package, ty), q).map_err(dds(&what))?;
        self.node.create_publisher(&t, None).map_err(dds(&what))
    }
}

/// Samples lost between two received ones of the same publisher (DDS sequence numbers), for the
/// bounded-history losses a slow node would otherwise never see.
#[derive(Default)]
struct SequenceGaps {
    last: BTreeMap<Gid, i64>,
}

impl SequenceGaps {
    fn lost(&mut self, info: &MessageInfo) -> u64 {
        let seq = info.sequence_number();
        let gap = self.last.insert(info.publisher_gid(), seq).map_or(0, |prev| seq - prev - 1);
        u64::try_from(gap).unwrap_or(0)
    }
}

/// Samples taken from one subscription per turn of the loop (a bound; the rest are taken in the next turn).
const MAX_TAKE: usize = 256;

/// Takes the available samples (at most [`MAX_TAKE`]); decode errors are returned as messages (RustDDS moves
/// past an undecodable sample, so it is reported once and gone).
fn drain<T: 'static + DeserializeOwned>(sub: &Subscription<T>, out: &mut Vec<Result<(T, MessageInfo), String>>) {
    for _ in 0..MAX_TAKE {
        match sub.take() {
            Ok(Some(s)) => out.push(Ok(s)),
            Ok(None) => break,
            Err(e) => out.push(Err(e.to_string())),
        }
    }
}

fn secs(start: Instant) -> f64 {
    start.elapsed().as_secs_f64()
}

fn now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// Runs the node until `stop` is set (Ctrl-C) or `max_frames` frames were checked. `log` gets one line per
/// event worth telling (start, problems, drops).
///
/// # Errors
/// [`NodeError`] when the node cannot start (bad names, DDS) or the monitor refuses its parameters.
#[allow(clippy::too_many_lines)]
pub fn run(
    cfg: &NodeConfig,
    params: &MonitorParams,
    stop: &AtomicBool,
    log: &mut dyn FnMut(&str),
) -> Result<NodeSummary, NodeError> {
    if cfg.domain_id > MAX_DOMAIN_ID {
        return Err(NodeError::Config(format!(
            "DDS domain {} is out of range: ROS 2 uses 0..={MAX_DOMAIN_ID} (the UDP ports of higher domains \
             do not fit)",
            cfg.domain_id
        )));
    }
    let mut monitor = Monitor::new(*params).map_err(|e| NodeError::Monitor(e.to_string()))?;
    let context =
        Context::with_options(ContextOptions::new().domain_id(cfg.domain_id)).map_err(dds("the DDS participant"))?;
    let node_name = NodeName::new(&cfg.namespace, &cfg.node_name).map_err(|e| NodeError::Name {
        name: format!("{}/{}", cfg.namespace.trim_end_matches('/'), cfg.node_name),
        message: format!("{e:?}"),
    })?;
    let node = context
        .new_node(node_name, NodeOptions::new().enable_rosout(false))
        .map_err(|e| NodeError::Dds { what: "the node".into(), message: format!("{e:?}") })?;
    let mut ep = Endpoints { node };
    let t = &cfg.topics;
    let depth = cfg.depth;
    let cloud_qos = qos(cfg.cloud_reliability, depth);
    let objects_qos = qos(cfg.objects_reliability, depth);
    let static_qos = qos(Reliability::Reliable, depth.max(10)).durability(Durability::TransientLocal);
    let out_qos = qos(Reliability::Reliable, depth);
    let clouds: Subscription<PointCloud2> =
        ep.subscription(&t.cloud_topic, ("sensor_msgs", "PointCloud2"), &cloud_qos)?;
    let objects = match cfg.objects_type {
        ObjectsType::Tracked => ObjectsSub::Tracked(ep.subscription(
            &t.objects_topic,
            ("autoware_perception_msgs", "TrackedObjects"),
            &objects_qos,
        )?),
        ObjectsType::Detected => ObjectsSub::Detected(ep.subscription(
            &t.objects_topic,
            ("autoware_perception_msgs", "DetectedObjects"),
            &objects_qos,
        )?),
    };
    let odometry: Subscription<Odometry> =
        ep.subscription(&t.odometry_topic, ("nav_msgs", "Odometry"), &objects_qos)?;
    let tf: Subscription<TfMessage> = ep.subscription(&t.tf_topic, ("tf2_msgs", "TFMessage"), &objects_qos)?;
    let tf_static: Subscription<TfMessage> =
        ep.subscription(&t.tf_static_topic, ("tf2_msgs", "TFMessage"), &static_qos)?;
    let verdicts_pub: Publisher<FrameVerdicts> =
        ep.publisher(&cfg.verdicts_topic, ("pmon_msgs", "FrameVerdicts"), &out_qos)?;
    let diagnostics_pub: Publisher<DiagnosticArray> =
        ep.publisher(&cfg.diagnostics_topic, ("diagnostic_msgs", "DiagnosticArray"), &out_qos)?;

    let mut poll = Poll::new().map_err(|e| NodeError::Dds { what: "the event loop".into(), message: e.to_string() })?;
    let register = |s: &mut dyn ros2_client::dds::rustdds::mio1::event::Source, token: usize| {
        poll.registry()
            .register(s, Token(token), Interest::READABLE)
            .map_err(|e| NodeError::Dds { what: "the event loop".into(), message: e.to_string() })
    };
    let mut clouds = clouds;
    let mut objects = objects;
    let mut odometry = odometry;
    let mut tf = tf;
    let mut tf_static = tf_static;
    register(&mut clouds, 0)?;
    match &mut objects {
        ObjectsSub::Tracked(s) => register(s, 1)?,
        ObjectsSub::Detected(s) => register(s, 1)?,
    }
    register(&mut odometry, 2)?;
    register(&mut tf, 3)?;
    register(&mut tf_static, 4)?;
    log(&format!(
        "pmon ros2: node {}/{} on DDS domain {}: {} + {} ({}) -> {}, {}",
        cfg.namespace.trim_end_matches('/'),
        cfg.node_name,
        cfg.domain_id,
        t.cloud_topic,
        t.objects_topic,
        match cfg.objects_type {
            ObjectsType::Tracked => "TrackedObjects",
            ObjectsType::Detected => "DetectedObjects",
        },
        cfg.verdicts_topic,
        cfg.diagnostics_topic
    ));

    let started = Instant::now();
    let mut pairer: Pairer<(Time, ReadCloud), (ObjectList, u64, f64)> = Pairer::new(cfg.pairing);
    let mut tf_buf = TfBuffer::default();
    let mut odo: Vec<(f64, Pose2)> = Vec::new();
    let mut gaps = (SequenceGaps::default(), SequenceGaps::default());
    let mut events = Events::with_capacity(16);
    let mut frame_index = 0u64;
    let mut last_frame_s = 0.0f64;
    let mut first_list_s: Option<f64> = None;
    let mut last_stale_s = f64::NEG_INFINITY;
    let mut st = State { checks: BagSummary::default(), counters: NodeCounters::default() };

    loop {
        let stopping = stop.load(Ordering::SeqCst);
        if !stopping {
            if let Err(e) = poll.poll(&mut events, Some(Duration::from_millis(50))) {
                if e.kind() != std::io::ErrorKind::Interrupted {
                    return Err(NodeError::Dds { what: "the event loop".into(), message: e.to_string() });
                }
            }
        }
        let now = secs(started);
        // Transforms and odometry first: a frame is placed with what has arrived.
        let mut tfs = Vec::new();
        drain(&tf_static, &mut tfs);
        let n_static = tfs.len();
        drain(&tf, &mut tfs);
        for (i, m) in tfs.into_iter().enumerate() {
            match m {
                Ok((m, _)) => tf_buf.add(&m, i < n_static),
                Err(e) => st.problem(&t.tf_topic, format!("transforms not used: {e}"), log),
            }
        }
        tf_buf.finish();
        let mut odos = Vec::new();
        drain(&odometry, &mut odos);
        for m in odos {
            match m {
                Ok((o, _)) => {
                    let p = &o.pose.pose;
                    odo.push((o.header.stamp.as_secs_f64(), pose2(p.position.x, p.position.y, &p.orientation)));
                }
                Err(e) => st.problem(&t.odometry_topic, format!("odometry not used: {e}"), log),
            }
        }
        odo.sort_by(|a, b| a.0.total_cmp(&b.0));
        if odo.len() > MAX_ODOMETRY {
            odo.drain(..odo.len() - MAX_ODOMETRY);
        }
        let mut cls = Vec::new();
        drain(&clouds, &mut cls);
        for m in cls {
            match m {
                Ok((c, info)) => {
                    st.counters.clouds_lost_in_dds += gaps.0.lost(&info);
                    st.checks.clouds += 1;
                    let stamp = c.header.stamp;
                    let (cloud, non_finite) = read_cloud(c);
                    if non_finite > 0 {
                        st.problem(&t.cloud_topic, format!("{non_finite} non-finite points left out"), log);
                    }
                    if let Err(e) = &cloud {
                        st.checks.undecodable += 1;
                        st.problem(&t.cloud_topic, format!("cloud not used (sensor checks not run): {e}"), log);
                    }
                    if let Some(d) = pairer.push_cloud(stamp.as_secs_f64(), (stamp, cloud)) {
                        st.dropped(d, cfg.pairing.max_lists, log);
                    }
                }
                Err(e) => {
                    st.checks.undecodable += 1;
                    st.problem(&t.cloud_topic, format!("cloud not used: {e}"), log);
                }
            }
        }
        let mut lists: Vec<Result<(ObjectList, MessageInfo), String>> = Vec::new();
        match &objects {
            ObjectsSub::Tracked(s) => {
                let mut v = Vec::new();
                drain(s, &mut v);
                lists.extend(v.into_iter().map(|r| r.map(|(m, i)| (ObjectList::Tracked(m), i))));
            }
            ObjectsSub::Detected(s) => {
                let mut v = Vec::new();
                drain(s, &mut v);
                lists.extend(v.into_iter().map(|r| r.map(|(m, i)| (ObjectList::Detected(m), i))));
            }
        }
        for m in lists {
            match m {
                Ok((list, info)) => {
                    st.counters.lists_lost_in_dds += gaps.1.lost(&info);
                    let stamp = list.header().stamp.as_secs_f64();
                    first_list_s.get_or_insert(now);
                    if let Some(d) = pairer.push_list(stamp, (list, now_ns(), now), now) {
                        st.dropped(d, cfg.pairing.max_lists, log);
                    }
                }
                Err(e) => {
                    st.checks.undecodable += 1;
                    st.problem(&t.objects_topic, format!("object list not checked: {e}"), log);
                }
            }
        }

        // Check every list that is ready (all of them when stopping).
        let limit_reached = |n: u64| cfg.max_frames.is_some_and(|m| n >= m);
        while !limit_reached(frame_index) {
            // The ego pose: a list waits for one at or after its stamp.
            let latest_pose = odo.last().map(|o| o.0).into_iter().chain(tf_buf.latest(&t.ego_frame)).reduce(f64::max);
            // Before any pose has arrived, the first list waits for one (up to the pairing wait); a system
            // without odometry or `/tf` pays that wait once.
            let no_pose_yet_ok = first_list_s.is_some_and(|f| secs(started) - f >= cfg.pairing.wait_s);
            let pose_ready = |stamp_s: f64| latest_pose.map_or(no_pose_yet_ok, |p| p >= stamp_s);
            let Some(ready) = pairer.next(secs(started), stopping, &pose_ready) else { break };
            let (list, log_time_ns, arrived_s) = ready.list;
            let cloud = ready.cloud.map(|(_, c)| (c.0, Some(c.1.clone())));
            if cloud.is_none() && st.checks.unpaired_object_lists.len() < MAX_PROBLEMS {
                st.checks.unpaired_object_lists.push(list.header().stamp);
            }
            let checker = FrameChecker { cfg: t, params, tf: &tf_buf, odometry: &odo };
            let mut verdicts = None;
            let mut outside_roi = [0, 0];
            let mut sink = |f: &pmon_ros::bag::CheckedFrame<'_>| {
                verdicts = Some(f.verdicts.clone());
                outside_roi = f.report.outside_roi_counts();
                Ok(())
            };
            checker
                .check(&mut monitor, &list, log_time_ns, cloud, frame_index, &mut st.checks, &mut sink)
                .map_err(NodeError::Monitor)?;
            frame_index += 1;
            last_frame_s = secs(started);
            let Some(v) = verdicts else { continue };
            let mut diag = pmon_ros::verdicts::diagnostics(&v);
            let mut statuses = pmon_ros::verdicts::check_statuses(&v);
            pmon_ros::verdicts::add_outside_roi(&mut statuses, outside_roi);
            diag.status.extend(statuses);
            let latency_s = secs(started) - arrived_s;
            st.counters.record_latency(v.processing_time_s, latency_s);
            diag.status.push(node_status(&mut st.counters, None, &cfg.params));
            if let Err(e) = verdicts_pub.publish(v) {
                st.counters.publish_errors += 1;
                st.problem(&cfg.verdicts_topic, format!("not published: {e}"), log);
            }
            if let Err(e) = diagnostics_pub.publish(diag) {
                st.counters.publish_errors += 1;
                st.problem(&cfg.diagnostics_topic, format!("not published: {e}"), log);
            }
        }
        // No object list checked for a while: say so (STALE), once per `stale_after_s`.
        let idle = now - last_frame_s;
        if idle >= cfg.stale_after_s && now - last_stale_s >= cfg.stale_after_s {
            last_stale_s = now;
            let status = node_status(&mut st.counters, Some(idle), &cfg.params);
            let diag = DiagnosticArray {
                header: pmon_ros::msg::Header { stamp: Time::from_nanos(now_ns()), frame_id: String::new() },
                status: vec![status],
            };
            if diagnostics_pub.publish(diag).is_err() {
                st.counters.publish_errors += 1;
            }
        }
        tf_buf.prune(TF_HISTORY_S);
        if limit_reached(frame_index) || (stopping && pairer.waiting() == 0) {
            break;
        }
    }
    let (lists_left, clouds_left) = pairer.leftovers();
    st.counters.lists_dropped += lists_left.len() as u64;
    if !lists_left.is_empty() {
        log(&format!("{} object lists left unchecked at the frame limit", lists_left.len()));
    }
    for stamp in clouds_left {
        st.dropped(Dropped::UnpairedCloud(stamp), cfg.pairing.max_lists, log);
    }
    st.counters.run_time_s = secs(started);
    // Let the reliable writers hand over their last samples before the participant goes.
    std::thread::sleep(Duration::from_millis(300));
    Ok(NodeSummary { checks: st.checks, counters: st.counters })
}

/// The run's counts, with the bounded lists of problems.
struct State {
    checks: BagSummary,
    counters: NodeCounters,
}

impl State {
    /// Logs a problem and keeps it for the summary (the first `MAX_PROBLEMS`; later ones are counted).
    fn problem(&mut self, topic: &str, message: String, log: &mut dyn FnMut(&str)) {
        log(&format!("{topic}: {message}"));
        if self.checks.problems.len() < MAX_PROBLEMS {
            self.checks.problems.push(Problem { topic: topic.into(), log_time_ns: now_ns(), message });
        } else {
            self.counters.problems_not_kept += 1;
        }
    }

    /// Counts (and logs) what the pairing gave up on.
    fn dropped(&mut self, d: Dropped, max_lists: usize, log: &mut dyn FnMut(&str)) {
        match d {
            Dropped::List(stamp) => {
                self.counters.lists_dropped += 1;
                log(&format!("object list at {stamp:.3} s dropped unchecked: {max_lists} lists were waiting"));
            }
            Dropped::UnpairedCloud(stamp) => {
                if self.checks.unpaired_clouds.len() < MAX_PROBLEMS {
                    self.checks.unpaired_clouds.push(seconds_to_time(stamp));
                }
                self.counters.clouds_unpaired += 1;
            }
        }
    }
}

/// A stamp in seconds back to `builtin_interfaces/Time` (non-negative stamps).
#[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
fn seconds_to_time(s: f64) -> Time {
    Time::from_nanos((s.max(0.0) * 1e9).round() as u64)
}
