//! The ROS 2 messages teachcam publishes and records, encoded in CDR ([`super::cdr`]), with
//! their `.msg` definitions as ROS 2 bags embed them (`ros2msg`: the type's own definition,
//! then each type it uses after a line of 80 `=` and `MSG: package/msg/Type`).
//!
//! Field order, types and constants are those of ROS 2's `common_interfaces` and
//! `rcl_interfaces` packages (`builtin_interfaces`, `std_msgs`, `geometry_msgs`, `tf2_msgs`,
//! `diagnostic_msgs`, `trajectory_msgs`, `visualization_msgs`); comments are left out of the
//! texts. `visualization_msgs/msg/Marker` is the layout of Humble and Jazzy (the same fields;
//! Jazzy's text, which adds the constant `ARROW_STRIP`): since Humble it carries
//! `texture_resource`, `texture`, `uv_coordinates` and `mesh_file`, which Foxy and Galactic
//! lack, so a subscriber of those distributions cannot read it live (a bag embeds its schema,
//! so their readers decode it anyway).

use super::cdr::CdrWriter;

/// A message type: its ROS name, the types it uses and its CDR encoding.
pub trait Message {
    /// The ROS 2 type name, `package/msg/Type`.
    const TYPE: &'static str;
    /// Every type it uses, directly or not, in the order their definitions follow its own.
    const DEPENDENCIES: &'static [&'static str];

    /// Writes the message's fields.
    fn write(&self, w: &mut CdrWriter);

    /// The message in CDR with its encapsulation header (what a bag stores, what DDS sends as
    /// the serialized payload).
    fn encode(&self) -> Vec<u8> {
        let mut w = CdrWriter::new();
        self.write(&mut w);
        w.finish()
    }

    /// The complete `ros2msg` definition of the type.
    fn definition() -> String {
        definition_of(Self::TYPE, Self::DEPENDENCIES)
    }
}

/// The complete `ros2msg` definition of `ty` using `dependencies`.
fn definition_of(ty: &str, dependencies: &[&str]) -> String {
    let mut text = msg_text(ty).to_string();
    for dependency in dependencies {
        // rosbag2's "Message Definition Encoding": the delimiter is a line of exactly 80 `=`
        // right after the previous definition's last line.
        if !text.ends_with('\n') {
            text.push('\n');
        }
        text.push_str(&"=".repeat(80));
        text.push_str("\nMSG: ");
        text.push_str(dependency);
        text.push('\n');
        text.push_str(msg_text(dependency));
    }
    text
}

/// The DDS type name ROS 2 gives a message type on the wire:
/// `geometry_msgs/msg/Pose` → `geometry_msgs::msg::dds_::Pose_`.
#[must_use]
pub fn dds_type_name(ros_type: &str) -> String {
    let mut parts: Vec<&str> = ros_type.split('/').collect();
    let name = parts.pop().unwrap_or_default();
    format!("{}::dds_::{name}_", parts.join("::"))
}

/// The `.msg` text of a type teachcam uses (empty for any other).
fn msg_text(ty: &str) -> &'static str {
    match ty {
        "builtin_interfaces/msg/Time" | "builtin_interfaces/msg/Duration" => {
            "int32 sec\nuint32 nanosec\n"
        }
        "std_msgs/msg/Header" => "builtin_interfaces/Time stamp\nstring frame_id\n",
        "geometry_msgs/msg/Point" | "geometry_msgs/msg/Vector3" => {
            "float64 x\nfloat64 y\nfloat64 z\n"
        }
        "geometry_msgs/msg/Quaternion" => "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
        "geometry_msgs/msg/Pose" => "Point position\nQuaternion orientation\n",
        "geometry_msgs/msg/PoseWithCovariance" => "Pose pose\nfloat64[36] covariance\n",
        "geometry_msgs/msg/PoseWithCovarianceStamped" => {
            "std_msgs/Header header\nPoseWithCovariance pose\n"
        }
        "geometry_msgs/msg/Transform" => "Vector3 translation\nQuaternion rotation\n",
        "geometry_msgs/msg/TransformStamped" => {
            "std_msgs/Header header\nstring child_frame_id\nTransform transform\n"
        }
        "tf2_msgs/msg/TFMessage" => "geometry_msgs/TransformStamped[] transforms\n",
        "diagnostic_msgs/msg/KeyValue" => "string key\nstring value\n",
        "diagnostic_msgs/msg/DiagnosticStatus" => {
            "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\nstring hardware_id\nKeyValue[] values\n"
        }
        "diagnostic_msgs/msg/DiagnosticArray" => {
            "std_msgs/Header header\nDiagnosticStatus[] status\n"
        }
        "trajectory_msgs/msg/JointTrajectoryPoint" => {
            "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\nbuiltin_interfaces/Duration time_from_start\n"
        }
        "trajectory_msgs/msg/JointTrajectory" => {
            "std_msgs/Header header\nstring[] joint_names\nJointTrajectoryPoint[] points\n"
        }
        "std_msgs/msg/ColorRGBA" => "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
        "sensor_msgs/msg/CompressedImage" => {
            "std_msgs/Header header\nstring format\nuint8[] data\n"
        }
        "visualization_msgs/msg/UVCoordinate" => "float32 u\nfloat32 v\n",
        "visualization_msgs/msg/MeshFile" => "string filename\nuint8[] data\n",
        "visualization_msgs/msg/Marker" => MARKER_MSG,
        "visualization_msgs/msg/MarkerArray" => "Marker[] markers\n",
        _ => "",
    }
}

/// `visualization_msgs/msg/Marker` as Humble and Jazzy define it (Jazzy's constants).
const MARKER_MSG: &str = "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\nint32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\nint32 ARROW_STRIP=12\n\
int32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n\
std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\ngeometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\nbuiltin_interfaces/Duration lifetime\nbool frame_locked\n\
geometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\n\
string texture_resource\nsensor_msgs/CompressedImage texture\nUVCoordinate[] uv_coordinates\n\
string text\n\
string mesh_resource\nMeshFile mesh_file\nbool mesh_use_embedded_materials\n";

/// `builtin_interfaces/msg/Time` (and `Duration`, the same fields): whole seconds and
/// nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds, `0..1e9`.
    pub nanosec: u32,
}

impl Time {
    /// The time of `seconds`, rounded to the nanosecond; `None` when it is not finite or
    /// outside `int32` seconds.
    #[must_use]
    pub fn from_seconds(seconds: f64) -> Option<Self> {
        let ns = (seconds * 1e9).round();
        if !ns.is_finite() || ns.abs() >= f64::from(i32::MAX) * 1e9 {
            return None;
        }
        #[expect(clippy::cast_possible_truncation, reason = "range checked above")]
        let ns = ns as i64;
        let sec = i32::try_from(ns.div_euclid(1_000_000_000)).ok()?;
        let nanosec = u32::try_from(ns.rem_euclid(1_000_000_000)).ok()?;
        Some(Self { sec, nanosec })
    }

    /// Nanoseconds since zero (as MCAP's log times), 0 for a negative time.
    #[must_use]
    pub fn nanoseconds(self) -> u64 {
        u64::try_from(i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)).unwrap_or(0)
    }

    fn write(self, w: &mut CdrWriter) {
        w.i32(self.sec);
        w.u32(self.nanosec);
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

impl Header {
    fn write(&self, w: &mut CdrWriter) {
        self.stamp.write(w);
        w.string(&self.frame_id);
    }
}

/// A position or translation, metres, and an orientation as ROS orders a quaternion
/// (`x, y, z, w`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RosPose {
    /// Position, metres.
    pub position: [f64; 3],
    /// Orientation `[x, y, z, w]`.
    pub orientation: [f64; 4],
}

impl RosPose {
    fn write(&self, w: &mut CdrWriter) {
        for v in self.position.iter().chain(&self.orientation) {
            w.f64(*v);
        }
    }
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped`.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseWithCovarianceStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose.
    pub pose: RosPose,
    /// Row-major 6×6 covariance of (x, y, z, rotation about x, y, z), m² and rad².
    pub covariance: [f64; 36],
}

impl Message for PoseWithCovarianceStamped {
    const TYPE: &'static str = "geometry_msgs/msg/PoseWithCovarianceStamped";
    const DEPENDENCIES: &'static [&'static str] = &[
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/PoseWithCovariance",
        "geometry_msgs/msg/Pose",
        "geometry_msgs/msg/Point",
        "geometry_msgs/msg/Quaternion",
    ];

    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        self.pose.write(w);
        for v in self.covariance {
            w.f64(v);
        }
    }
}

/// `geometry_msgs/msg/TransformStamped`: `child_frame_id` placed in `header.frame_id`.
#[derive(Debug, Clone, PartialEq)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's origin (metres) and orientation in the parent.
    pub transform: RosPose,
}

/// `tf2_msgs/msg/TFMessage` (`/tf`, `/tf_static`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

impl Message for TfMessage {
    const TYPE: &'static str = "tf2_msgs/msg/TFMessage";
    const DEPENDENCIES: &'static [&'static str] = &[
        "geometry_msgs/msg/TransformStamped",
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/Transform",
        "geometry_msgs/msg/Vector3",
        "geometry_msgs/msg/Quaternion",
    ];

    fn write(&self, w: &mut CdrWriter) {
        w.length(self.transforms.len());
        for t in &self.transforms {
            t.header.write(w);
            w.string(&t.child_frame_id);
            t.transform.write(w);
        }
    }
}

/// `diagnostic_msgs/msg/DiagnosticStatus` levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// `OK` (0).
    Ok = 0,
    /// `WARN` (1).
    Warn = 1,
    /// `ERROR` (2).
    Error = 2,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnosticStatus {
    /// The level.
    pub level: Level,
    /// What is reported on.
    pub name: String,
    /// The status in words.
    pub message: String,
    /// The device.
    pub hardware_id: String,
    /// `diagnostic_msgs/msg/KeyValue` pairs.
    pub values: Vec<(String, String)>,
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnosticArray {
    /// Stamp and frame.
    pub header: Header,
    /// One status per thing reported on.
    pub status: Vec<DiagnosticStatus>,
}

impl Message for DiagnosticArray {
    const TYPE: &'static str = "diagnostic_msgs/msg/DiagnosticArray";
    const DEPENDENCIES: &'static [&'static str] = &[
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "diagnostic_msgs/msg/DiagnosticStatus",
        "diagnostic_msgs/msg/KeyValue",
    ];

    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.length(self.status.len());
        for s in &self.status {
            w.u8(s.level as u8);
            w.string(&s.name);
            w.string(&s.message);
            w.string(&s.hardware_id);
            w.length(s.values.len());
            for (key, value) in &s.values {
                w.string(key);
                w.string(value);
            }
        }
    }
}

/// `trajectory_msgs/msg/JointTrajectoryPoint` (accelerations and efforts left empty).
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectoryPoint {
    /// Joint positions, radians.
    pub positions: Vec<f64>,
    /// Joint velocities, rad/s (empty when not given).
    pub velocities: Vec<f64>,
    /// When the point is reached, from the trajectory's start.
    pub time_from_start: Time,
}

/// `trajectory_msgs/msg/JointTrajectory`.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectory {
    /// Stamp (the start) and frame.
    pub header: Header,
    /// One name per joint, in the order of every point's positions.
    pub joint_names: Vec<String>,
    /// The points.
    pub points: Vec<JointTrajectoryPoint>,
}

impl Message for JointTrajectory {
    const TYPE: &'static str = "trajectory_msgs/msg/JointTrajectory";
    const DEPENDENCIES: &'static [&'static str] = &[
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "trajectory_msgs/msg/JointTrajectoryPoint",
        "builtin_interfaces/msg/Duration",
    ];

    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.length(self.joint_names.len());
        for name in &self.joint_names {
            w.string(name);
        }
        w.length(self.points.len());
        for p in &self.points {
            w.f64_sequence(&p.positions);
            w.f64_sequence(&p.velocities);
            w.f64_sequence(&[]);
            w.f64_sequence(&[]);
            p.time_from_start.write(w);
        }
    }
}

/// A marker's shape (`visualization_msgs/msg/Marker`'s `type` constants used here).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// `SPHERE` (2): one sphere at the pose, `scale` its diameters.
    Sphere = 2,
    /// `SPHERE_LIST` (7): a sphere at each point, `scale` their diameters.
    SphereList = 7,
}

/// `visualization_msgs/msg/Marker`, action `ADD`, with what teachcam draws (the texture,
/// text and mesh fields written empty).
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// Stamp and frame.
    pub header: Header,
    /// Namespace; with `id`, the marker's name (a marker replaces the one of its name).
    pub ns: String,
    /// Its number in the namespace.
    pub id: i32,
    /// The shape.
    pub shape: Shape,
    /// Pose of the shape (identity for a list whose points are in the frame).
    pub pose: RosPose,
    /// Size, metres (a sphere's diameters).
    pub scale: [f64; 3],
    /// `r, g, b, a` in 0..1.
    pub color: [f32; 4],
    /// How long the marker stays without a newer one (zero: for ever).
    pub lifetime: Time,
    /// Points of a list shape, metres.
    pub points: Vec<[f64; 3]>,
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MarkerArray {
    /// The markers.
    pub markers: Vec<Marker>,
}

impl Message for MarkerArray {
    const TYPE: &'static str = "visualization_msgs/msg/MarkerArray";
    const DEPENDENCIES: &'static [&'static str] = &[
        "visualization_msgs/msg/Marker",
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/Pose",
        "geometry_msgs/msg/Point",
        "geometry_msgs/msg/Quaternion",
        "geometry_msgs/msg/Vector3",
        "std_msgs/msg/ColorRGBA",
        "builtin_interfaces/msg/Duration",
        "sensor_msgs/msg/CompressedImage",
        "visualization_msgs/msg/UVCoordinate",
        "visualization_msgs/msg/MeshFile",
    ];

    fn write(&self, w: &mut CdrWriter) {
        w.length(self.markers.len());
        for m in &self.markers {
            m.header.write(w);
            w.string(&m.ns);
            w.i32(m.id);
            w.i32(m.shape as i32);
            w.i32(0); // action ADD
            m.pose.write(w);
            for v in m.scale {
                w.f64(v);
            }
            for v in m.color {
                w.f32(v);
            }
            m.lifetime.write(w);
            w.bool(false); // frame_locked
            w.length(m.points.len());
            for p in &m.points {
                for v in p {
                    w.f64(*v);
                }
            }
            w.length(0); // colors
            w.string(""); // texture_resource
            Header::default().write(w); // texture: header, format, data
            w.string("");
            w.length(0);
            w.length(0); // uv_coordinates
            w.string(""); // text
            w.string(""); // mesh_resource
            w.string(""); // mesh_file: filename, data
            w.length(0);
            w.bool(false); // mesh_use_embedded_materials
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_names_follow_ros2() {
        assert_eq!(
            dds_type_name(PoseWithCovarianceStamped::TYPE),
            "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"
        );
    }

    #[test]
    fn every_dependency_has_a_definition() {
        for deps in [
            PoseWithCovarianceStamped::DEPENDENCIES,
            TfMessage::DEPENDENCIES,
            DiagnosticArray::DEPENDENCIES,
            JointTrajectory::DEPENDENCIES,
            MarkerArray::DEPENDENCIES,
        ] {
            for d in deps {
                assert!(!msg_text(d).is_empty(), "{d}");
            }
        }
        let text = TfMessage::definition();
        assert!(text.starts_with("geometry_msgs/TransformStamped[] transforms\n====="));
        assert!(text.contains("\nMSG: geometry_msgs/msg/Quaternion\nfloat64 x 0\n"));
    }

    #[test]
    fn times_split_into_seconds_and_nanoseconds() {
        assert_eq!(
            Time::from_seconds(1.25),
            Some(Time {
                sec: 1,
                nanosec: 250_000_000
            })
        );
        assert_eq!(Time::from_seconds(f64::NAN), None);
        assert_eq!(Time::from_seconds(3e9), None);
        assert_eq!(
            Time::from_seconds(2.5).map(Time::nanoseconds),
            Some(2_500_000_000)
        );
    }
}
