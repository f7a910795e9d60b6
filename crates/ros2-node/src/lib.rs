//! pmon as a live ROS 2 node (`pmon ros2`, docs/ros2.md): subscribes to a `sensor_msgs/PointCloud2` topic and
//! an Autoware object list, pairs them by stamp ([`pairing`]), checks each object list with the monitor exactly
//! as `pmon check bag.mcap` does ([`pmon_ros::frame`]), and publishes `pmon_msgs/FrameVerdicts` and
//! `diagnostic_msgs/DiagnosticArray`.
//!
//! DDS through `ros2-client` (pure Rust, RustDDS): no ROS installation. Around the core: the monitor never
//! learns about ROS or DDS.

pub mod config;
pub mod node;
pub mod pairing;
pub mod status;

pub use config::{NodeConfig, ObjectsType, Reliability};
pub use node::{run, NodeError, NodeSummary};
