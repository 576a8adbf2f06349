//! The robot: frames shared by vision and robot, the arm's kinematics, the check of a
//! trajectory on the arm, and robot programs (ABB RAPID, KUKA KRL, UR URScript, CSV).
//!
//! Model (paper §V, CONTRACT.md "Robot frames"): the trajectory's world frame is the work
//! object's frame. A robot target is `wobj_from_tcp`, the tip position with the tool's
//! orientation (composed with the tool file's `tip_rotation`). The cell places the work object
//! in the robot's base (`base_from_wobj`, RAPID's `uframe`) and the brush on the flange
//! (`flange_from_tcp`, RAPID's `tframe`); the arm must then reach, for every target,
//! ```text
//! base_from_flange(joints) = base_from_wobj * wobj_from_tcp * flange_from_tcp⁻¹
//! ```
//! Stages, in the order data flows: [`frames`] (vision↔robot alignment, pivot calibration),
//! [`kinematics`] (IRB 120 forward and inverse), [`check`] (reach, limits, speeds,
//! singularities), [`free_axis`] (the roll about an axisymmetric tool's axis chosen per
//! frame), [`strokes`] (a take cut into the runs the brush paints, trimmed to a span),
//! [`gaps`] (runs of frames without a pose a straight move would cross),
//! [`simplify`] (fewer targets within a path tolerance), [`program`] (moves
//! with speeds from the recorded timing), then the dialects [`rapid`], [`krl`], [`urscript`]
//! and [`table`] (CSV).

pub mod check;
pub mod checked;
pub mod frames;
pub mod free_axis;
pub mod gaps;
pub mod kinematics;
pub mod krl;
pub mod program;
pub mod rapid;
pub mod replay;
pub mod simplify;
pub mod strokes;
pub mod table;
pub mod urscript;

use nalgebra::UnitQuaternion;

use crate::geometry::{FrameIndex, Pose, pose_from_parts};
use crate::trajectory::Trajectory;

/// Where the work object and the tool sit on the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// The work object (the trajectory's world) in the robot's base frame (`--wobj`).
    pub base_from_wobj: Pose,
    /// The tool centre point in the flange frame `tool0` (`--tcp`).
    pub flange_from_tcp: Pose,
}

impl Default for Cell {
    /// Work object at the base, TCP at the flange: the identity frames of a bare robot.
    fn default() -> Self {
        Self {
            base_from_wobj: Pose::identity(),
            flange_from_tcp: Pose::identity(),
        }
    }
}

impl Cell {
    /// The flange pose that puts the TCP on a target.
    #[must_use]
    pub fn base_from_flange(&self, wobj_from_tcp: &Pose) -> Pose {
        self.base_from_wobj * wobj_from_tcp * self.flange_from_tcp.inverse()
    }
}

/// One robot target: the TCP in the work object's frame at a recorded time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcpTarget {
    /// Frame of the recording it comes from.
    pub frame: FrameIndex,
    /// Its time, seconds from the recording's start.
    pub time_s: f64,
    /// The TCP frame in the work-object frame.
    pub wobj_from_tcp: Pose,
}

/// The robot targets of a trajectory, one per frame with a pose (gaps are skipped; the frame
/// numbers keep them visible): position from the tip column, orientation the tool's composed
/// with `tip_rotation`, the tool file's (`tool_from_tcp.rotation`; identity without a tool file).
#[must_use]
pub fn tcp_targets(trajectory: &Trajectory, tip_rotation: &UnitQuaternion<f64>) -> Vec<TcpTarget> {
    trajectory
        .samples
        .iter()
        .filter_map(|s| {
            let pose = s.pose?;
            Some(TcpTarget {
                frame: s.frame,
                time_s: s.time_s,
                wobj_from_tcp: pose_from_parts(
                    pose.tip_in_world.coords,
                    pose.world_from_tool.rotation * tip_rotation,
                ),
            })
        })
        .collect()
}

/// A warning when `--tcp` looks written for another maker's flange frame: an offset along z
/// with the TCP's z along it too (identity, or turned half a turn about x) on a KUKA, whose
/// FLANGE has x out of the flange (the brush would stick out sideways), or the same along x
/// on an ABB or UR arm (z out of the flange). `None` otherwise, and within 1 mm of the flange.
#[must_use]
pub fn tcp_convention_warning(
    robot: &kinematics::Robot,
    flange_from_tcp: &crate::geometry::Pose,
) -> Option<String> {
    let t = flange_from_tcp.translation.vector;
    let length = t.norm();
    let along = |axis: usize| t[axis].abs() > 0.99 * length;
    // The TCP's z (the brush's axis) along the offset too, as the other maker writes it.
    let tool_z = flange_from_tcp.rotation * nalgebra::Vector3::z();
    let axial = |axis: usize| along(axis) && tool_z[axis].abs() > 0.99;
    if length < 1.0 {
        return None;
    }
    let (axis, out_axis, example) = match robot.maker {
        kinematics::Maker::Kuka if axial(2) => (
            "z",
            "x",
            format!(
                "\"{},0,0,0.7071068,0,-0.7071068,0\"",
                rapid::number(length, 1)
            ),
        ),
        kinematics::Maker::Abb | kinematics::Maker::UniversalRobots if axial(0) => (
            "x",
            "z",
            format!("\"0,0,{},1,0,0,0\"", rapid::number(length, 1)),
        ),
        _ => return None,
    };
    Some(format!(
        "--tcp: an offset and tool axis along {axis} on the {}, whose flange frame has {out_axis} out of the flange: the brush would stick out sideways (along the flange axis it is {out_axis}, e.g. --tcp {example})",
        robot.name
    ))
}

/// The text form of a pose, `x,y,z,qw,qx,qy,qz`, that [`crate::geometry::parse_pose`]
/// reads back
/// (0.001 mm and 1e-9 in the quaternion, no negative zeros).
#[must_use]
pub fn pose_text(pose: &Pose) -> String {
    let t = pose.translation.vector;
    let q = crate::geometry::Quat::from_rotation(&pose.rotation);
    let n = rapid::number;
    format!(
        "{},{},{},{},{},{},{}",
        n(t.x, 3),
        n(t.y, 3),
        n(t.z, 3),
        n(q.w, 9),
        n(q.x, 9),
        n(q.y, 9),
        n(q.z, 9)
    )
}
