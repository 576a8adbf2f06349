//! `live --ros2`: the conductor's frames published on DDS as ROS 2 topics, through RustDDS (pure
//! Rust RTPS: no ROS installation, no C library).
//!
//! The messages are `teachcam::ros2::take`'s (the ones `export mcap` records), encoded by the
//! library's CDR writer; this module only puts them on the wire with ROS 2's names: topic
//! `rt/<topic>`, type `package::msg::dds_::Type_`, QoS as ROS 2's default profile (reliable,
//! volatile, keep last 10), `/tf_static` transient local, keep last 1, as tf2's static
//! broadcaster. `/teachcam/markers` (`visualization_msgs/msg/MarkerArray`, Humble's and
//! Jazzy's layout) goes out at 5 Hz on frames with a pose.
//!
//! Discovery follows ROS 2's own switches: `ROS_DOMAIN_ID` (default 0);
//! `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (or, when that is unset, `ROS_LOCALHOST_ONLY=1`)
//! restricts the participant to the loopback interface — it announces itself by unicast to the
//! standard discovery ports of the domain on 127.0.0.1 and advertises only 127.0.0.1 — and
//! otherwise DDS's usual discovery (multicast on every interface) is used.

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, bail};
use rustdds::no_key::{DataWriter, SerializerAdapter};
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{
    DomainParticipant, DomainParticipantBuilder, QosPolicies, QosPolicyBuilder,
    RepresentationIdentifier, TopicKind,
};
use teachcam::camera::Rig;
use teachcam::pipeline::TrackedFrame;
use teachcam::ros2::msg::{
    DiagnosticArray, MarkerArray, Message, PoseWithCovarianceStamped, TfMessage, Time,
    dds_type_name,
};
use teachcam::ros2::take::{
    Frames, MarkerRate, camera_transforms, frame_messages_at, tool_markers,
};
use teachcam::tool::Tool;

/// A message already encoded by `teachcam::ros2` (CDR with its encapsulation header).
#[derive(Debug, Clone)]
pub struct Encoded(Vec<u8>);

/// RustDDS's serializer for [`Encoded`]: the payload after the 4-byte encapsulation header
/// (RustDDS writes the header itself from [`SerializerAdapter::output_encoding`]).
#[derive(Debug)]
pub struct Encapsulated;

/// An encoded message without its encapsulation header.
#[derive(Debug, thiserror::Error)]
#[error("an encoded ROS 2 message is shorter than its encapsulation header")]
pub struct NoHeader;

impl SerializerAdapter<Encoded> for Encapsulated {
    type Error = NoHeader;

    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }

    fn to_bytes(value: &Encoded) -> Result<rustdds::bytes::Bytes, NoHeader> {
        let body = value.0.get(4..).ok_or(NoHeader)?;
        Ok(rustdds::bytes::Bytes::copy_from_slice(body))
    }
}

/// How far DDS discovery reaches: ROS 2's `ROS_AUTOMATIC_DISCOVERY_RANGE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DiscoveryRange {
    /// This machine only: the loopback interface, unicast.
    Localhost,
    /// DDS's default: every interface, multicast.
    Subnet,
}

/// The DDS settings ROS 2's environment gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RosEnv {
    /// `ROS_DOMAIN_ID`, default 0.
    pub domain_id: u16,
    /// From `ROS_AUTOMATIC_DISCOVERY_RANGE`, else `ROS_LOCALHOST_ONLY`.
    pub range: DiscoveryRange,
}

impl RosEnv {
    /// Reads the variables through `var` (`std::env::var` in the binary).
    ///
    /// # Errors
    /// One line naming the variable, its value and what was expected.
    pub fn from_vars(var: impl Fn(&str) -> Option<String>) -> anyhow::Result<Self> {
        let domain_id = match var("ROS_DOMAIN_ID").filter(|v| !v.trim().is_empty()) {
            None => 0,
            // ROS 2 documents 0..=101 as safe and 0..=232 as usable on Linux (UDP ports).
            Some(v) => match v.trim().parse::<u16>() {
                Ok(id) if id <= 232 => id,
                _ => bail!("ROS_DOMAIN_ID={v}: expected a DDS domain 0..232"),
            },
        };
        let range = match var("ROS_AUTOMATIC_DISCOVERY_RANGE").filter(|v| !v.trim().is_empty()) {
            Some(v) => match v.trim() {
                "LOCALHOST" => DiscoveryRange::Localhost,
                "SUBNET" | "SYSTEM_DEFAULT" => DiscoveryRange::Subnet,
                other => bail!(
                    "ROS_AUTOMATIC_DISCOVERY_RANGE={other}: teachcam supports LOCALHOST, SUBNET or SYSTEM_DEFAULT"
                ),
            },
            None => match var("ROS_LOCALHOST_ONLY").as_deref().map(str::trim) {
                Some("1") => DiscoveryRange::Localhost,
                _ => DiscoveryRange::Subnet,
            },
        };
        Ok(Self { domain_id, range })
    }
}

/// ROS 2's default QoS profile (`rmw_qos_profile_default`): reliable, volatile, keep last 10.
fn default_qos() -> QosPolicies {
    QosPolicyBuilder::new()
        .reliability(Reliability::Reliable {
            max_blocking_time: rustdds::Duration::from_millis(100),
        })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
        .build()
}

/// tf2's static broadcaster's QoS: reliable, transient local, keep last 1.
fn static_qos() -> QosPolicies {
    QosPolicyBuilder::new()
        .reliability(Reliability::Reliable {
            max_blocking_time: rustdds::Duration::from_millis(100),
        })
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
        .build()
}

type Writer = DataWriter<Encoded, Encapsulated>;

/// The session's DDS participant and its writers.
pub struct Ros2Live {
    // Kept alive for the writers (dropping it ends the participant).
    _participant: DomainParticipant,
    tool: Writer,
    tf: Writer,
    status: Writer,
    /// `/teachcam/markers`, on the frames `marker_rate` picks (5 Hz).
    markers: Writer,
    marker_rate: MarkerRate,
    /// The tool tracked: its markers drawn at each pose.
    tool_model: Tool,
    // Kept alive: a transient-local writer hands its sample to readers that join later.
    _tf_static: Writer,
    cameras: TfMessage,
    frames: Frames,
    /// Wall clock and monotonic clock read together: turns an exposure `Instant` into a ROS
    /// time.
    epoch: (SystemTime, Instant),
    last_cameras: Option<Instant>,
    published: Published,
}

impl std::fmt::Debug for Ros2Live {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros2Live")
            .field("frames", &self.frames)
            .field("published", &self.published)
            .finish_non_exhaustive()
    }
}

/// What was published, for the summary.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Published {
    /// `/teachcam/tool` messages.
    pub tool: usize,
    /// `/tf` messages.
    pub tf: usize,
    /// `/teachcam/status` messages.
    pub status: usize,
    /// `/teachcam/markers` messages (5 Hz, frames with a pose).
    pub markers: usize,
    /// Writes DDS refused (the frame's messages are then lost, the session goes on).
    pub failed: usize,
}

/// How often the cameras are repeated on `/tf` (tf2 listeners drop transforms older than
/// their buffer, 10 s by default).
const CAMERAS_EVERY: Duration = Duration::from_secs(1);

impl Ros2Live {
    /// Joins the domain `env` names and creates the writers: `/teachcam/tool`, `/tf`,
    /// `/teachcam/status`, `/teachcam/markers` (`tool_model`'s markers), and `/tf_static`
    /// with the rig's cameras (written once).
    ///
    /// # Errors
    /// When DDS cannot start (no free participant port, no network interface).
    pub fn start(
        env: RosEnv,
        rig: &Rig,
        tool_model: &Tool,
        frames: Frames,
    ) -> anyhow::Result<Self> {
        let mut builder = DomainParticipantBuilder::new(env.domain_id);
        if env.range == DiscoveryRange::Localhost {
            builder = builder.with_only_networks([std::net::Ipv4Addr::LOCALHOST]);
        }
        let participant = builder
            .build()
            .with_context(|| format!("cannot join DDS domain {}", env.domain_id))?;
        let publisher = participant
            .create_publisher(&default_qos())
            .context("cannot create the DDS publisher")?;
        let writer = |name: &str, ros_type: &str, qos: QosPolicies| -> anyhow::Result<Writer> {
            let topic = participant
                .create_topic(
                    format!("rt{name}"),
                    dds_type_name(ros_type),
                    &qos,
                    TopicKind::NoKey,
                )
                .with_context(|| format!("cannot create the DDS topic {name}"))?;
            publisher
                .create_datawriter_no_key::<Encoded, Encapsulated>(&topic, Some(qos))
                .with_context(|| format!("cannot create the DDS writer of {name}"))
        };
        let tool = writer(
            "/teachcam/tool",
            PoseWithCovarianceStamped::TYPE,
            default_qos(),
        )?;
        let tf = writer("/tf", TfMessage::TYPE, default_qos())?;
        let status = writer("/teachcam/status", DiagnosticArray::TYPE, default_qos())?;
        let markers = writer("/teachcam/markers", MarkerArray::TYPE, default_qos())?;
        let tf_static = writer("/tf_static", TfMessage::TYPE, static_qos())?;
        let epoch = (SystemTime::now(), Instant::now());
        let cameras = camera_transforms(rig, &frames, ros_time(epoch.0));
        if !cameras.transforms.is_empty() {
            tf_static
                .write(Encoded(cameras.encode()), None)
                .map_err(|e| anyhow::anyhow!("cannot write /tf_static: {e:?}"))?;
        }
        Ok(Self {
            _participant: participant,
            tool,
            tf,
            status,
            markers,
            marker_rate: MarkerRate::default(),
            tool_model: tool_model.clone(),
            _tf_static: tf_static,
            cameras,
            frames,
            epoch,
            last_cameras: None,
            published: Published::default(),
        })
    }

    /// The ROS time of a frame: its exposure on the wall clock where the source has one (live
    /// cameras, the simulator), else the session's start plus the frame's time.
    fn stamp(&self, frame: &TrackedFrame) -> Time {
        let (wall, mono) = self.epoch;
        let at = match frame.detections.exposed_at {
            Some(exposed) => match exposed.checked_duration_since(mono) {
                Some(after) => wall + after,
                None => wall - mono.saturating_duration_since(exposed),
            },
            None => wall + Duration::from_secs_f64(frame.sample.time_s.max(0.0)),
        };
        ros_time(at)
    }

    /// Publishes one frame: its status always; with a pose `/teachcam/tool` and `/tf`
    /// (`world → tool`); the cameras on `/tf` once a second.
    ///
    /// # Errors
    /// A frame whose pose or time cannot be written (not finite), naming the frame.
    pub fn publish(&mut self, frame: &TrackedFrame) -> anyhow::Result<()> {
        let stamp = self.stamp(frame);
        let reason = frame.reason();
        let messages = frame_messages_at(&frame.sample, stamp, Some(&reason), &self.frames)?;
        let mut tf = messages.tf;
        let now = Instant::now();
        if self
            .last_cameras
            .is_none_or(|at| now.duration_since(at) >= CAMERAS_EVERY)
            && !self.cameras.transforms.is_empty()
        {
            self.last_cameras = Some(now);
            let mut cameras = self.cameras.clone();
            for t in &mut cameras.transforms {
                t.header.stamp = stamp;
            }
            match &mut tf {
                Some(tf) => tf.transforms.extend(cameras.transforms),
                None => tf = Some(cameras),
            }
        }
        if let Some(tool) = messages.tool {
            if let Some(pose) = &frame.sample.pose
                && self.marker_rate.due(frame.sample.time_s)
            {
                let markers = tool_markers(pose, Some(&self.tool_model), &tool.header);
                let ok = self.markers.write(Encoded(markers.encode()), None).is_ok();
                self.count(ok, |p| &mut p.markers);
            }
            let ok = self.tool.write(Encoded(tool.encode()), None).is_ok();
            self.count(ok, |p| &mut p.tool);
        }
        if let Some(tf) = tf {
            let ok = self.tf.write(Encoded(tf.encode()), None).is_ok();
            self.count(ok, |p| &mut p.tf);
        }
        let ok = self
            .status
            .write(Encoded(messages.status.encode()), None)
            .is_ok();
        self.count(ok, |p| &mut p.status);
        Ok(())
    }

    fn count(&mut self, ok: bool, field: impl Fn(&mut Published) -> &mut usize) {
        if ok {
            *field(&mut self.published) += 1;
        } else {
            self.published.failed += 1;
        }
    }

    /// What was published so far.
    #[must_use]
    pub fn published(&self) -> Published {
        self.published
    }
}

/// A wall-clock instant as ROS time (seconds and nanoseconds since the Unix epoch).
fn ros_time(at: SystemTime) -> Time {
    let since = at.duration_since(UNIX_EPOCH).unwrap_or_default();
    Time {
        sec: i32::try_from(since.as_secs()).unwrap_or(i32::MAX),
        nanosec: since.subsec_nanos(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(vars: &[(&str, &str)]) -> anyhow::Result<RosEnv> {
        RosEnv::from_vars(|name| {
            vars.iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| (*v).to_string())
        })
    }

    #[test]
    fn ros_variables_choose_domain_and_range() {
        let default = env(&[]).expect("default");
        assert_eq!(default.domain_id, 0);
        assert_eq!(default.range, DiscoveryRange::Subnet);
        let local = env(&[("ROS_LOCALHOST_ONLY", "1"), ("ROS_DOMAIN_ID", "7")]).expect("local");
        assert_eq!(local.domain_id, 7);
        assert_eq!(local.range, DiscoveryRange::Localhost);
        // The newer variable wins over the deprecated one.
        let range = env(&[
            ("ROS_LOCALHOST_ONLY", "1"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET"),
        ])
        .expect("range");
        assert_eq!(range.range, DiscoveryRange::Subnet);
        assert!(env(&[("ROS_DOMAIN_ID", "300")]).is_err());
        assert!(env(&[("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF")]).is_err());
    }

    #[test]
    fn the_payload_leaves_the_header_to_dds() {
        let bytes = Encapsulated::to_bytes(&Encoded(vec![0, 1, 0, 0, 42])).expect("payload");
        assert_eq!(bytes.as_ref(), &[42]);
        assert!(Encapsulated::to_bytes(&Encoded(vec![0, 1])).is_err());
    }
}
