//! `pmon ros2`: the live ROS 2 node (DDS through `pmon-ros2-node`; docs/ros2.md).

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use pmon_ros2_node::pairing::PairingConfig;
use pmon_ros2_node::status::quantile;
use pmon_ros2_node::{NodeConfig, ObjectsType, Reliability};

use pmon_ros::bag::BagConfig;

use crate::bag::write_summary;
use crate::config::described_params;

/// `--objects-type`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ObjectsTypeArg {
    /// `autoware_perception_msgs/TrackedObjects`.
    Tracked,
    /// `autoware_perception_msgs/DetectedObjects`.
    Detected,
}

/// `--cloud-qos`, `--objects-qos`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ReliabilityArg {
    /// Best effort (matches every publisher; Autoware's sensor-data profile for clouds).
    BestEffort,
    /// Reliable (matches reliable publishers only).
    Reliable,
}

impl From<ReliabilityArg> for Reliability {
    fn from(r: ReliabilityArg) -> Self {
        match r {
            ReliabilityArg::BestEffort => Self::BestEffort,
            ReliabilityArg::Reliable => Self::Reliable,
        }
    }
}

/// Options of `pmon ros2`.
#[derive(Args, Debug)]
pub struct Ros2Args {
    /// The `sensor_msgs/PointCloud2` topic.
    #[arg(long, default_value = "/sensing/lidar/concatenated/pointcloud")]
    pub cloud_topic: String,
    /// The object list's topic (`--objects-type` says which type).
    #[arg(long, default_value = "/perception/object_recognition/tracking/objects")]
    pub objects_topic: String,
    /// The ego `nav_msgs/Odometry` topic (`/tf` map -> base_link is used when it has none).
    #[arg(long, default_value = "/localization/kinematic_state")]
    pub odometry_topic: String,
    /// The ego frame the monitor works in.
    #[arg(long, default_value = "base_link")]
    pub ego_frame: String,
    /// The world frame of the ego pose.
    #[arg(long, default_value = "map")]
    pub world_frame: String,
    /// Largest |object stamp - cloud stamp| for a pairing, seconds.
    #[arg(long, default_value_t = 0.05)]
    pub pairing_tolerance_s: f64,
    /// The object list's type (DDS matches topics by type).
    #[arg(long, value_enum, default_value_t = ObjectsTypeArg::Tracked)]
    pub objects_type: ObjectsTypeArg,
    /// The `/tf` topic.
    #[arg(long, default_value = "/tf")]
    pub tf_topic: String,
    /// The `/tf_static` topic (subscribed transient local, so transforms published before the node started
    /// arrive).
    #[arg(long, default_value = "/tf_static")]
    pub tf_static_topic: String,
    /// Output: `pmon_msgs/FrameVerdicts`, one per checked object list.
    #[arg(long, default_value = "/pmon/verdicts")]
    pub verdicts_topic: String,
    /// Output: `diagnostic_msgs/DiagnosticArray`, one per checked object list (and STALE when idle).
    #[arg(long, default_value = "/diagnostics")]
    pub diagnostics_topic: String,
    /// Reliability of the cloud subscription.
    #[arg(long, value_enum, default_value_t = ReliabilityArg::BestEffort)]
    pub cloud_qos: ReliabilityArg,
    /// Reliability of the object-list, odometry and `/tf` subscriptions.
    #[arg(long, value_enum, default_value_t = ReliabilityArg::Reliable)]
    pub objects_qos: ReliabilityArg,
    /// History depth (keep last N) of every subscription and publication.
    #[arg(long, default_value_t = 5)]
    pub depth: usize,
    /// Longest an object list waits for its cloud, seconds (then it is checked without one, reported).
    #[arg(long, default_value_t = 0.3)]
    pub pairing_wait_s: f64,
    /// Clouds held for pairing (the oldest goes first; one never paired is reported).
    #[arg(long, default_value_t = 4)]
    pub max_clouds: usize,
    /// Object lists waiting for their cloud (a further one drops the oldest, reported).
    #[arg(long, default_value_t = 4)]
    pub max_waiting_lists: usize,
    /// Publish a STALE `/diagnostics` when no object list was checked for this long, seconds.
    #[arg(long, default_value_t = 1.0)]
    pub stale_after_s: f64,
    /// DDS domain (as `ROS_DOMAIN_ID`; default: that variable, else 0).
    #[arg(long)]
    pub domain_id: Option<u16>,
    /// The node's name.
    #[arg(long, default_value = "pmon")]
    pub node_name: String,
    /// The node's namespace.
    #[arg(long, default_value = "/")]
    pub namespace: String,
    /// Stop after this many checked object lists (replays, tests); default: run until Ctrl-C.
    #[arg(long)]
    pub max_frames: Option<u64>,
    /// Monitor parameters: a ROS 2 parameter file in Autoware's style (`.yaml`: `/**:` -> `ros__parameters:`) or
    /// pmon's TOML, or a profile pmon ships (`profile:recall`); any subset of `pmon params`' keys, the same
    /// validation everywhere.
    #[arg(long)]
    pub params: Option<PathBuf>,
}

impl Ros2Args {
    /// The node's configuration; `params` is the monitor's parameters in words (`config::described_params`), for
    /// `/diagnostics`.
    fn config(&self, params: String) -> Result<NodeConfig> {
        let finite_positive = |name: &str, v: f64| {
            anyhow::ensure!(v.is_finite() && v > 0.0, "--{name} must be a positive number of seconds, got {v}");
            Ok(())
        };
        finite_positive("pairing-wait-s", self.pairing_wait_s)?;
        finite_positive("stale-after-s", self.stale_after_s)?;
        anyhow::ensure!(
            self.pairing_tolerance_s.is_finite() && self.pairing_tolerance_s >= 0.0,
            "--pairing-tolerance-s must be a non-negative number of seconds, got {}",
            self.pairing_tolerance_s
        );
        anyhow::ensure!(self.depth >= 1, "--depth must be at least 1");
        let topics = BagConfig {
            cloud_topic: self.cloud_topic.clone(),
            objects_topic: self.objects_topic.clone(),
            odometry_topic: self.odometry_topic.clone(),
            tf_topic: self.tf_topic.clone(),
            tf_static_topic: self.tf_static_topic.clone(),
            ego_frame: self.ego_frame.clone(),
            world_frame: self.world_frame.clone(),
            pairing_tolerance_s: self.pairing_tolerance_s,
            ..BagConfig::default()
        };
        Ok(NodeConfig {
            objects_type: match self.objects_type {
                ObjectsTypeArg::Tracked => ObjectsType::Tracked,
                ObjectsTypeArg::Detected => ObjectsType::Detected,
            },
            pairing: PairingConfig {
                tolerance_s: topics.pairing_tolerance_s,
                wait_s: self.pairing_wait_s,
                max_clouds: self.max_clouds.max(1),
                max_lists: self.max_waiting_lists.max(1),
            },
            topics,
            verdicts_topic: self.verdicts_topic.clone(),
            diagnostics_topic: self.diagnostics_topic.clone(),
            node_name: self.node_name.clone(),
            namespace: self.namespace.clone(),
            domain_id: match (self.domain_id, std::env::var("ROS_DOMAIN_ID")) {
                (Some(d), _) => d,
                (None, Ok(v)) if !v.trim().is_empty() => {
                    v.trim().parse().with_context(|| format!("ROS_DOMAIN_ID={v:?} is not a DDS domain id (0..=232)"))?
                }
                (None, _) => 0,
            },
            cloud_reliability: self.cloud_qos.into(),
            objects_reliability: self.objects_qos.into(),
            depth: self.depth,
            max_frames: self.max_frames,
            stale_after_s: self.stale_after_s,
            params,
        })
    }
}

/// `pmon ros2`: runs until Ctrl-C (or SIGTERM, or `--max-frames`), then prints what it checked, dropped and
/// how fast. Exit status 0 after a clean shutdown, 2 when the node could not start.
pub fn run(args: &Ros2Args) -> Result<ExitCode> {
    let (params, described) = described_params(args.params.as_deref())?;
    let cfg = args.config(described)?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)).context("cannot install the Ctrl-C handler")?;
    let mut log = |line: &str| eprintln!("{line}");
    let summary = pmon_ros2_node::run(&cfg, &params, &stop, &mut log)?;
    if stop.load(Ordering::SeqCst) {
        eprintln!("pmon ros2: stopping (Ctrl-C or SIGTERM): the waiting object lists were checked");
    }
    let mut out = io::stdout().lock();
    write_summary(&mut out, "pmon ros2", &summary.checks)?;
    let c = &summary.counters;
    let ms = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |s| format!("{:.2} ms", s * 1e3));
    writeln!(
        out,
        "node: {:.1} s, object lists dropped {} (waiting queue full or left at the frame limit), lost in DDS {} \
         object lists and {} clouds, clouds without an object list {}, publish errors {}",
        c.run_time_s, c.lists_dropped, c.lists_lost_in_dds, c.clouds_lost_in_dds, c.clouds_unpaired, c.publish_errors
    )?;
    writeln!(
        out,
        "check time per frame: median {}, p99 {}; arrival to publication: median {}, p99 {} ({} frames)",
        ms(quantile(&c.check_s, 0.5)),
        ms(quantile(&c.check_s, 0.99)),
        ms(quantile(&c.latency_s, 0.5)),
        ms(quantile(&c.latency_s, 0.99)),
        c.latency_s.len()
    )?;
    Ok(ExitCode::SUCCESS)
}
