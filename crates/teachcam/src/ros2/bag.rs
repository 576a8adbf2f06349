//! A take as a ROS 2 MCAP file, as `ros2 bag record -s mcap` writes one: profile `ros2`,
//! message encoding `cdr`, each topic's schema the complete `ros2msg` definition, each channel
//! with the QoS ROS 2 offered (`/tf_static` transient local, so a late subscriber still gets
//! the cameras when the take is played). Chunks are uncompressed.

use std::collections::BTreeMap;
use std::io::Cursor;

use super::msg::{
    DiagnosticArray, JointTrajectory, MarkerArray, Message, PoseWithCovarianceStamped, TfMessage,
};
use super::take::FrameMessages;

/// The topics of a take.
pub mod topic {
    /// The tool's pose.
    pub const TOOL: &str = "/teachcam/tool";
    /// Transforms that move.
    pub const TF: &str = "/tf";
    /// Transforms that do not (the cameras).
    pub const TF_STATIC: &str = "/tf_static";
    /// Each frame's status.
    pub const STATUS: &str = "/teachcam/status";
    /// The checked joint path.
    pub const JOINT_TRAJECTORY: &str = "/teachcam/joint_trajectory";
    /// RViz's markers of the tool and the tip, at 5 Hz.
    pub const MARKERS: &str = "/teachcam/markers";
}

/// Everything a take holds.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Take {
    /// Every frame's messages, in time order.
    pub frames: Vec<FrameMessages>,
    /// `world → camera` of the rig's cameras, when a rig is known.
    pub cameras: Option<TfMessage>,
    /// The checked joint path, when a robot was given.
    pub joint_trajectory: Option<JointTrajectory>,
}

/// The MCAP writer failed (it writes to memory: a bug, not the user's data).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("MCAP writer: {0}")]
pub struct BagError(String);

fn bag_error(e: ::mcap::McapError) -> BagError {
    BagError(e.to_string())
}

/// The QoS profile rosbag2 records for a channel (`offered_qos_profiles`): reliable, keep
/// last, `transient_local` or volatile, no deadline, lifespan or lease.
fn offered_qos(transient_local: bool) -> String {
    let infinite = "\n    sec: 9223372036\n    nsec: 854775807";
    format!(
        "- history: 3\n  depth: 0\n  reliability: 1\n  durability: {}\n  deadline:{infinite}\n  lifespan:{infinite}\n  liveliness: 1\n  liveliness_lease_duration:{infinite}\n  avoid_ros_namespace_conventions: false",
        if transient_local { 1 } else { 2 }
    )
}

struct Channels<'a> {
    writer: ::mcap::Writer<Cursor<Vec<u8>>>,
    ids: BTreeMap<&'a str, u16>,
    sequence: u32,
}

impl<'a> Channels<'a> {
    fn add<M: Message>(&mut self, topic: &'a str) -> Result<(), BagError> {
        let schema = self
            .writer
            .add_schema(M::TYPE, "ros2msg", M::definition().as_bytes())
            .map_err(bag_error)?;
        let metadata = BTreeMap::from([(
            "offered_qos_profiles".to_string(),
            offered_qos(topic == topic::TF_STATIC),
        )]);
        let id = self
            .writer
            .add_channel(schema, topic, "cdr", &metadata)
            .map_err(bag_error)?;
        self.ids.insert(topic, id);
        Ok(())
    }

    fn write<M: Message>(
        &mut self,
        topic: &str,
        log_time: u64,
        message: &M,
    ) -> Result<(), BagError> {
        let channel_id = self
            .ids
            .get(topic)
            .copied()
            .ok_or_else(|| BagError(format!("no channel for {topic}")))?;
        self.sequence += 1;
        let header = ::mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        self.writer
            .write_to_known_channel(&header, &message.encode())
            .map_err(bag_error)
    }
}

/// The take as the bytes of an MCAP file: per frame `/tf` and `/teachcam/tool` (frames with a
/// pose) and `/teachcam/status`, `/teachcam/markers` on the frames that have them; `/tf_static` and `/teachcam/joint_trajectory` once, at the
/// first frame's time. Log and publish times are the messages' stamps.
///
/// # Errors
/// [`BagError`] when the MCAP writer fails.
pub fn mcap_bytes(take: &Take) -> Result<Vec<u8>, BagError> {
    let options = ::mcap::WriteOptions::new()
        .profile("ros2")
        .compression(None);
    let writer = options.create(Cursor::new(Vec::new())).map_err(bag_error)?;
    let mut channels = Channels {
        writer,
        ids: BTreeMap::new(),
        sequence: 0,
    };
    channels.add::<TfMessage>(topic::TF)?;
    channels.add::<PoseWithCovarianceStamped>(topic::TOOL)?;
    channels.add::<DiagnosticArray>(topic::STATUS)?;
    if take.cameras.is_some() {
        channels.add::<TfMessage>(topic::TF_STATIC)?;
    }
    if take.joint_trajectory.is_some() {
        channels.add::<JointTrajectory>(topic::JOINT_TRAJECTORY)?;
    }
    if take.frames.iter().any(|f| f.markers.is_some()) {
        channels.add::<MarkerArray>(topic::MARKERS)?;
    }
    let start = take.frames.first().map_or(0, |f| f.stamp.nanoseconds());
    if let Some(cameras) = &take.cameras {
        channels.write(topic::TF_STATIC, start, cameras)?;
    }
    if let Some(joints) = &take.joint_trajectory {
        channels.write(
            topic::JOINT_TRAJECTORY,
            joints.header.stamp.nanoseconds(),
            joints,
        )?;
    }
    for frame in &take.frames {
        let time = frame.stamp.nanoseconds();
        if let Some(tf) = &frame.tf {
            channels.write(topic::TF, time, tf)?;
        }
        if let Some(tool) = &frame.tool {
            channels.write(topic::TOOL, time, tool)?;
        }
        channels.write(topic::STATUS, time, &frame.status)?;
        if let Some(markers) = &frame.markers {
            channels.write(topic::MARKERS, time, markers)?;
        }
    }
    channels.writer.finish().map_err(bag_error)?;
    Ok(channels.writer.into_inner().into_inner())
}
