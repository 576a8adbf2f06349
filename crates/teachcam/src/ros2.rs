//! ROS 2 without a ROS installation: the messages teachcam publishes (`live --ros2`) and
//! records (`export mcap`), in CDR with their `.msg` definitions, and MCAP takes.
//!
//! - [`cdr`]: the CDR encoding (little endian, encapsulation header).
//! - [`msg`]: the message types (`geometry_msgs`, `tf2_msgs`, `diagnostic_msgs`,
//!   `trajectory_msgs`, `visualization_msgs`) and their definitions.
//! - [`take`]: a trajectory's frames, a rig's cameras and a checked joint path as messages.
//! - [`bag`]: a take written as a ROS 2 MCAP file (CDR, `ros2msg` schemas embedded).

pub mod cdr;
pub mod bag;
pub mod msg;
pub mod take;
