//! A trajectory's frames as ROS 2 messages: what `export mcap` records and `live --ros2`
//! publishes, built by one set of functions.
//!
//! Units and frames follow REP 103: metres, radians, the world frame (the work object) named by
//! [`Frames::world`]. The tool's pose is the tip (`tip_*_mm` / 1000) with the tool's
//! orientation; `/tf` carries the same pose as `world → tool`, and the rig's cameras as
//! `world → camera` (OpenCV's camera axes, which are ROS's optical-frame axes).

use crate::camera::Rig;
use crate::geometry::Pose;
use crate::robot::check::CheckReport;
use crate::robot::kinematics::Maker;
use crate::trajectory::{Sample, Status, ToolPose};

use super::bag::Take;
use crate::tool::Tool;

use super::msg::{
    DiagnosticArray, DiagnosticStatus, Header, JointTrajectory, JointTrajectoryPoint, Level,
    Marker, MarkerArray, PoseWithCovarianceStamped, RosPose, Shape, TfMessage, Time,
    TransformStamped,
};

/// The variance written where teachcam has no estimate (m² or rad²): large enough that a
/// consumer weighting by it ignores the value (the convention of ROS GNSS and odometry
/// drivers), and still finite and positive.
pub const UNKNOWN_VARIANCE: f64 = 1e6;

/// The names of the frames and of the device in the messages.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frames {
    /// The world (work object) frame, every message's `header.frame_id`.
    pub world: String,
    /// The tool's frame in `/tf`.
    pub tool: String,
}

impl Default for Frames {
    fn default() -> Self {
        Self {
            world: "world".into(),
            tool: "teachcam_tool".into(),
        }
    }
}

/// The messages of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameMessages {
    /// The frame's time (`time_s`), the stamp of every message.
    pub stamp: Time,
    /// `/teachcam/tool`, `None` for a frame without a pose.
    pub tool: Option<PoseWithCovarianceStamped>,
    /// `/tf` (`world → tool`), `None` for a frame without a pose.
    pub tf: Option<TfMessage>,
    /// `/teachcam/status`: the frame's status, always.
    pub status: DiagnosticArray,
    /// `/teachcam/markers`: on the frames [`MarkerRate`] picks (a take's; `None` from
    /// [`frame_messages_at`], whose caller decides).
    pub markers: Option<MarkerArray>,
}

/// The period of `/teachcam/markers` (5 Hz): RViz's picture of the tool; the pose itself goes
/// on `/teachcam/tool` at the frame rate.
pub const MARKER_PERIOD_S: f64 = 0.2;

/// Which frames carry markers: the first with a pose, then each first with a pose at least
/// [`MARKER_PERIOD_S`] after the last that did (a time that goes back, a recording played
/// again, starts afresh).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MarkerRate {
    last_s: Option<f64>,
}

impl MarkerRate {
    /// Whether a frame with a pose at `time_s` carries markers (and, if so, notes it).
    pub fn due(&mut self, time_s: f64) -> bool {
        // A frame period that adds up to the period in floating point (6 × 1/30 s) is due.
        let due = self
            .last_s
            .is_none_or(|last| time_s < last || time_s - last >= MARKER_PERIOD_S * (1.0 - 1e-9));
        if due {
            self.last_s = Some(time_s);
        }
        due
    }
}

/// Diameter of the tip's sphere, metres.
pub const TIP_MARKER_M: f64 = 0.005;

/// RViz markers of a tracked pose in the world frame, metres, namespace `teachcam`: id 0 the
/// tool's markers (a `SPHERE_LIST`: the tool model's markers placed at the tracked pose, of the
/// tool's marker diameter; left out without a tool), id 1 the tip (a `SPHERE` of
/// [`TIP_MARKER_M`]). They last two marker periods, so that they vanish when tracking stops.
#[must_use]
pub fn tool_markers(pose: &ToolPose, tool: Option<&Tool>, header: &Header) -> MarkerArray {
    let lifetime = Time::from_seconds(2.0 * MARKER_PERIOD_S).unwrap_or_default();
    let identity = RosPose {
        position: [0.0; 3],
        orientation: [0.0, 0.0, 0.0, 1.0],
    };
    let mut markers = Vec::new();
    if let Some(tool) = tool {
        let d = tool.marker_diameter_mm / 1000.0;
        markers.push(Marker {
            header: header.clone(),
            ns: "teachcam".into(),
            id: 0,
            shape: Shape::SphereList,
            pose: identity,
            scale: [d, d, d],
            color: [0.85, 0.85, 0.85, 1.0],
            lifetime,
            points: tool
                .markers_in_tool
                .iter()
                .map(|m| {
                    let p = pose.world_from_tool * m;
                    [p.x / 1000.0, p.y / 1000.0, p.z / 1000.0]
                })
                .collect(),
        });
    }
    let tip = pose.tip_in_world;
    markers.push(Marker {
        header: header.clone(),
        ns: "teachcam".into(),
        id: 1,
        shape: Shape::Sphere,
        pose: RosPose {
            position: [tip.x / 1000.0, tip.y / 1000.0, tip.z / 1000.0],
            ..identity
        },
        scale: [TIP_MARKER_M; 3],
        color: [1.0, 0.45, 0.0, 1.0],
        lifetime,
        points: Vec::new(),
    });
    MarkerArray { markers }
}

/// Why a frame's messages could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TakeError {
    /// A time that is not finite or does not fit ROS's `int32` seconds.
    #[error("frame {frame}: time {time_s} s cannot be a ROS time (finite, |t| < 2^31 s)")]
    Time {
        /// The frame.
        frame: usize,
        /// Its time.
        time_s: f64,
    },
    /// A pose field that is not finite.
    #[error("frame {frame}: the pose is not finite")]
    NotFinite {
        /// The frame.
        frame: usize,
    },
}

/// The take of tracked frames, as `export mcap` and the studio's Record write it: each
/// frame's messages stamped with its `time_s` (`reason`: its status reason, where the caller
/// has it), markers ([`tool_markers`], with `tool`'s spheres when given) on the frames
/// [`MarkerRate`] picks, and, with a rig, its cameras on `/tf_static` stamped at the first
/// frame's time.
///
/// # Errors
/// [`TakeError`] naming the first frame whose time or pose cannot be written.
pub fn tracked_take<'a>(
    samples: impl IntoIterator<Item = (&'a Sample, Option<&'a str>)>,
    rig: Option<&Rig>,
    tool: Option<&Tool>,
    frames: &Frames,
) -> Result<Take, TakeError> {
    let mut rate = MarkerRate::default();
    let messages = samples
        .into_iter()
        .map(|(sample, reason)| {
            let mut messages = frame_messages(sample, reason, frames)?;
            if let (Some(pose), Some(posed)) = (&sample.pose, &messages.tool)
                && rate.due(sample.time_s)
            {
                messages.markers = Some(tool_markers(pose, tool, &posed.header));
            }
            Ok(messages)
        })
        .collect::<Result<Vec<_>, TakeError>>()?;
    let cameras = rig.map(|rig| {
        let stamp = messages.first().map(|m| m.stamp).unwrap_or_default();
        camera_transforms(rig, frames, stamp)
    });
    Ok(Take {
        frames: messages,
        cameras,
        joint_trajectory: None,
    })
}

/// The messages of `sample`; `reason` is the frame's status reason where the caller has it
/// (live tracking), shown in the status message.
///
/// # Errors
/// [`TakeError`] for a time or pose that cannot be written.
pub fn frame_messages(
    sample: &Sample,
    reason: Option<&str>,
    frames: &Frames,
) -> Result<FrameMessages, TakeError> {
    let stamp = Time::from_seconds(sample.time_s).ok_or(TakeError::Time {
        frame: sample.frame.0,
        time_s: sample.time_s,
    })?;
    frame_messages_at(sample, stamp, reason, frames)
}

/// The messages of `sample` stamped `stamp` instead of its `time_s` (live: the exposure on
/// the wall clock).
///
/// # Errors
/// [`TakeError::NotFinite`] for a pose that cannot be written.
pub fn frame_messages_at(
    sample: &Sample,
    stamp: Time,
    reason: Option<&str>,
    frames: &Frames,
) -> Result<FrameMessages, TakeError> {
    let frame = sample.frame.0;
    let header = Header {
        stamp,
        frame_id: frames.world.clone(),
    };
    let (tool, tf) = match &sample.pose {
        Some(pose) => {
            let ros_pose = tip_pose(pose);
            let covariance = pose_covariance(pose, sample.tip_std_mm);
            let finite = ros_pose
                .position
                .iter()
                .chain(&ros_pose.orientation)
                .chain(&covariance)
                .all(|v| v.is_finite());
            if !finite {
                return Err(TakeError::NotFinite { frame });
            }
            let tf = TfMessage {
                transforms: vec![TransformStamped {
                    header: header.clone(),
                    child_frame_id: frames.tool.clone(),
                    transform: ros_pose,
                }],
            };
            let tool = PoseWithCovarianceStamped {
                header: header.clone(),
                pose: ros_pose,
                covariance,
            };
            (Some(tool), Some(tf))
        }
        None => (None, None),
    };
    Ok(FrameMessages {
        stamp,
        tool,
        tf,
        status: status_message(sample, reason, header),
        markers: None,
    })
}

/// The tool's pose as ROS carries it: the tip in metres, the tool's orientation.
#[must_use]
pub fn tip_pose(pose: &ToolPose) -> RosPose {
    let q = pose.world_from_tool.rotation.quaternion();
    RosPose {
        position: [
            pose.tip_in_world.x / 1000.0,
            pose.tip_in_world.y / 1000.0,
            pose.tip_in_world.z / 1000.0,
        ],
        orientation: [q.i, q.j, q.k, q.w],
    }
}

/// The 6×6 covariance of a pose (row-major; x, y, z in m², rotations about x, y, z in rad²),
/// diagonal: each axis of the tip has the variance `tip_std_mm²` (`tip_std_mm` is the RMS of
/// the three axes' standard uncertainties); each rotation `(tip_std / L)²`, with `L` the
/// tip's distance from the tool frame's origin: the tip's error includes the rotation's error
/// times that lever, so this bounds the rotation's uncertainty from above. Where there is no
/// estimate (no `tip_std_mm`, or the tip within 1 mm of the tool's origin) the variance is
/// [`UNKNOWN_VARIANCE`].
#[must_use]
pub fn pose_covariance(pose: &ToolPose, tip_std_mm: Option<f64>) -> [f64; 36] {
    let tip_std_m = tip_std_mm
        .filter(|s| s.is_finite() && *s > 0.0)
        .map(|s| s / 1000.0);
    let tip_in_tool = pose
        .world_from_tool
        .inverse_transform_point(&pose.tip_in_world);
    let lever_m = tip_in_tool.coords.norm() / 1000.0;
    let position_var = tip_std_m.map_or(UNKNOWN_VARIANCE, |s| s * s);
    let rotation_var = match tip_std_m {
        Some(s) if lever_m >= 1e-3 => (s / lever_m).powi(2),
        _ => UNKNOWN_VARIANCE,
    };
    let mut covariance = [0.0; 36];
    for axis in 0..3 {
        covariance[axis * 7] = position_var;
        covariance[(axis + 3) * 7] = rotation_var;
    }
    covariance
}

/// The frame's status as a `diagnostic_msgs/msg/DiagnosticArray` with one status: level OK
/// for `ok`, WARN for `degraded`, ERROR for `outlier` and `lost`; the message is the status
/// word (and the reason, when given); the values are the frame, the status, the markers, the
/// registration RMS and `tip_std_mm` where known.
fn status_message(sample: &Sample, reason: Option<&str>, header: Header) -> DiagnosticArray {
    let level = match sample.status {
        Status::Ok => Level::Ok,
        Status::Degraded => Level::Warn,
        Status::Outlier | Status::Lost => Level::Error,
    };
    let word = sample.status.name();
    let message = match reason {
        Some(r) if !r.is_empty() => format!("{word}: {r}"),
        _ => word.to_string(),
    };
    let mut values = vec![
        ("frame".to_string(), sample.frame.0.to_string()),
        ("status".to_string(), word.to_string()),
    ];
    if let Some(pose) = &sample.pose {
        values.push(("markers".into(), pose.markers.to_string()));
        values.push(("rms_mm".into(), format!("{:.4}", pose.rms_mm)));
    }
    if let Some(std) = sample.tip_std_mm {
        values.push(("tip_std_mm".into(), format!("{std:.4}")));
    }
    DiagnosticArray {
        header,
        status: vec![DiagnosticStatus {
            level,
            name: "teachcam: tool".into(),
            message,
            hardware_id: "teachcam".into(),
            values,
        }],
    }
}

/// `world → camera` for every camera of the rig (`/tf_static`), named `camera_<name>`.
#[must_use]
pub fn camera_transforms(rig: &Rig, frames: &Frames, stamp: Time) -> TfMessage {
    let transforms = rig
        .cameras
        .iter()
        .map(|camera| {
            let world_from_camera: Pose = camera.camera_from_world.inverse();
            let t = world_from_camera.translation.vector / 1000.0;
            let q = world_from_camera.rotation.quaternion();
            TransformStamped {
                header: Header {
                    stamp,
                    frame_id: frames.world.clone(),
                },
                child_frame_id: format!("camera_{}", camera.name),
                transform: RosPose {
                    position: [t.x, t.y, t.z],
                    orientation: [q.i, q.j, q.k, q.w],
                },
            }
        })
        .collect();
    TfMessage { transforms }
}

/// The joint names ROS-Industrial's and Universal Robots' descriptions give the maker's six
/// axes.
#[must_use]
pub fn joint_names(maker: Maker) -> [&'static str; 6] {
    match maker {
        Maker::Abb => [
            "joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6",
        ],
        Maker::Kuka => [
            "joint_a1", "joint_a2", "joint_a3", "joint_a4", "joint_a5", "joint_a6",
        ],
        Maker::UniversalRobots => [
            "shoulder_pan_joint",
            "shoulder_lift_joint",
            "elbow_joint",
            "wrist_1_joint",
            "wrist_2_joint",
            "wrist_3_joint",
        ],
    }
}

/// The checked joint path as one `trajectory_msgs/msg/JointTrajectory`: the joints of every
/// frame that has a solution (radians, the maker's convention, as `check --joints-out`),
/// `time_from_start` the frame's time after the check's time scaling less the first frame's;
/// the header stamped with the first frame's time. `None` when no frame has joints.
///
/// # Errors
/// [`TakeError::Time`] for a time that cannot be written.
pub fn joint_trajectory(
    report: &CheckReport,
    frames: &Frames,
) -> Result<Option<JointTrajectory>, TakeError> {
    let mut with_joints = report
        .frames
        .iter()
        .filter_map(|f| f.joints.map(|j| (f.target.frame.0, f.target.time_s, j)))
        .peekable();
    let Some(&(first_frame, start_s, _)) = with_joints.peek() else {
        return Ok(None);
    };
    let time = |frame: usize, time_s: f64| {
        Time::from_seconds(time_s).ok_or(TakeError::Time { frame, time_s })
    };
    let stamp = time(first_frame, start_s)?;
    let mut points = Vec::new();
    for (frame, time_s, joints) in with_joints {
        if joints.0.iter().any(|j| !j.is_finite()) {
            return Err(TakeError::NotFinite { frame });
        }
        points.push(JointTrajectoryPoint {
            positions: joints.0.to_vec(),
            velocities: Vec::new(),
            time_from_start: time(frame, time_s - start_s)?,
        });
    }
    Ok(Some(JointTrajectory {
        header: Header {
            stamp,
            frame_id: frames.world.clone(),
        },
        joint_names: joint_names(report.robot.maker)
            .iter()
            .map(ToString::to_string)
            .collect(),
        points,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{FrameIndex, Point3};
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    fn pose() -> ToolPose {
        let world_from_tool = Pose::from_parts(
            Translation3::new(100.0, 200.0, 300.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5),
        );
        ToolPose {
            world_from_tool,
            tip_in_world: world_from_tool * Point3::new(0.0, 0.0, 150.0),
            markers: 4,
            rms_mm: 0.05,
        }
    }

    #[test]
    fn the_tip_is_in_metres_and_the_covariance_follows_tip_std() {
        let mut sample = Sample::measured(FrameIndex(3), 0.1, pose());
        sample.tip_std_mm = Some(0.03);
        let m = frame_messages(&sample, None, &Frames::default()).expect("messages");
        let tool = m.tool.expect("tool");
        assert!((tool.pose.position[0] - 0.1).abs() < 1e-12);
        assert!((tool.pose.position[2] - 0.45).abs() < 1e-12);
        assert!((tool.pose.orientation[2] - 0.25f64.sin()).abs() < 1e-12);
        assert!((tool.covariance[0] - 0.03e-3f64.powi(2)).abs() < 1e-18);
        // lever 150 mm: 0.03 mm / 150 mm = 2e-4 rad.
        assert!((tool.covariance[35] - 2e-4f64.powi(2)).abs() < 1e-15);
        assert_eq!(tool.covariance[1], 0.0);
        assert_eq!(m.stamp.nanosec, 100_000_000);
    }

    #[test]
    fn a_gap_has_a_status_and_no_pose() {
        let m = frame_messages(&Sample::gap(FrameIndex(1), 0.5), None, &Frames::default())
            .expect("messages");
        assert!(m.tool.is_none() && m.tf.is_none());
        assert_eq!(m.status.status[0].level, Level::Error);
        assert_eq!(m.status.status[0].message, "lost");
    }

    #[test]
    fn markers_go_at_five_hertz_and_start_again_when_time_goes_back() {
        let mut rate = MarkerRate::default();
        let due: Vec<usize> = (0..31)
            .filter(|&k| rate.due(f64::from(k) / 30.0))
            .map(|k| k as usize)
            .collect();
        assert_eq!(due, [0, 6, 12, 18, 24, 30]);
        assert!(rate.due(0.0), "a recording played again");
    }

    #[test]
    fn without_an_estimate_the_variance_says_unknown() {
        let c = pose_covariance(&pose(), None);
        assert_eq!(c[0], UNKNOWN_VARIANCE);
        assert_eq!(c[21], UNKNOWN_VARIANCE);
    }
}
