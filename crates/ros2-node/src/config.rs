//! The node's configuration: topics, QoS, frames, pairing limits.

use pmon_ros::bag::BagConfig;

use crate::pairing::PairingConfig;

/// Which Autoware object list the node subscribes to (DDS matches topics by type, so it must be known).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectsType {
    /// `autoware_perception_msgs/TrackedObjects` (UUIDs: the motion checks follow tracks).
    Tracked,
    /// `autoware_perception_msgs/DetectedObjects` (no ids: each detection is a new track).
    Detected,
}

/// Delivery guarantee of a subscription or publication.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reliability {
    /// Samples may be lost; matches both best-effort and reliable publishers.
    BestEffort,
    /// Lost samples are resent; matches reliable publishers only.
    Reliable,
}

/// Everything the node needs besides the monitor's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeConfig {
    /// Input topics, frames and the pairing and pose tolerances (the same as `pmon check bag.mcap`).
    pub topics: BagConfig,
    /// The object list's type.
    pub objects_type: ObjectsType,
    /// Output: `pmon_msgs/FrameVerdicts`.
    pub verdicts_topic: String,
    /// Output: `diagnostic_msgs/DiagnosticArray`.
    pub diagnostics_topic: String,
    /// The node's name.
    pub node_name: String,
    /// The node's namespace.
    pub namespace: String,
    /// DDS domain (`ROS_DOMAIN_ID`).
    pub domain_id: u16,
    /// QoS of the cloud subscription (Autoware publishes clouds best effort: the sensor-data profile).
    pub cloud_reliability: Reliability,
    /// QoS of the object-list and odometry subscriptions.
    pub objects_reliability: Reliability,
    /// History depth (keep last N) of every subscription and publication.
    pub depth: usize,
    /// Pairing tolerance, wait and buffer limits.
    pub pairing: PairingConfig,
    /// Stop after this many checked frames (replays and tests); `None`: run until Ctrl-C.
    pub max_frames: Option<u64>,
    /// Publish a STALE `/diagnostics` when no object list was checked for this long, seconds.
    pub stale_after_s: f64,
    /// The monitor's parameters in words (`the defaults (Table I)`, or the file or profile over them and the keys
    /// it changes), the `params` key-value of the `pmon: node` status: which configuration is monitoring.
    pub params: String,
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self {
            topics: BagConfig::default(),
            objects_type: ObjectsType::Tracked,
            verdicts_topic: pmon_ros::output::topics::VERDICTS.into(),
            diagnostics_topic: pmon_ros::output::topics::DIAGNOSTICS.into(),
            node_name: "pmon".into(),
            namespace: "/".into(),
            domain_id: 0,
            cloud_reliability: Reliability::BestEffort,
            objects_reliability: Reliability::Reliable,
            depth: 5,
            pairing: PairingConfig::default(),
            max_frames: None,
            stale_after_s: 1.0,
            params: "the defaults (Table I)".into(),
        }
    }
}
