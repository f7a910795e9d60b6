//! pmon in a ROS 2 stack: ROS 2 / Autoware messages in CDR, rosbag2 MCAP bags in and results out.
//!
//! Around the core: the monitor never learns about ROS. See `docs/ros2.md`.

pub mod bag;
pub mod cdr;
pub mod convert;
pub mod frame;
pub mod mcap_check;
pub mod msg;
pub mod output;
pub mod pointcloud;
pub mod scene;
pub mod tf;
pub mod verdicts;
pub mod write_dataset;
