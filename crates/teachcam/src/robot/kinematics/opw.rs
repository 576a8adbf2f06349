//! The closed form of an arm with an ortho-parallel basis and a spherical wrist ("OPW",
//! Brandstötter, Angerer and Hofbaur 2014), written in one fixed joint convention that the
//! makers' conventions map onto ([`super::OpwParameters`]).
//!
//! Model (base frame: x forward, z up; all angles zero = lower arm vertical, forearm
//! horizontal, `tool0`'s z along base x; this is ABB's own convention):
//! ```text
//! base_from_tool0(q) = [wrist_centre(q); Rz(q1) Ry(q2+q3) Rx(q4) Ry(q5) Rx(q6) Ry(π/2)]
//! wrist_centre(q) = Rz(q1) ((a1, 0, c1) + Ry(q2) (0, 0, c2) + Ry(q2+q3) (c3, 0, −a2))
//! tool0 = wrist_centre + c4 · (tool0 z)
//! ```
//! Axes 2, 3 and 5 turn about the arm's y axis (positive: the arm tips forward and down), axes
//! 4 and 6 about the forearm and the flange normal, axis 1 about the base z. The inverse gives
//! two shoulder solutions (axis 1 facing the wrist centre or turned away), two elbow solutions
//! and two wrist solutions (axis 5 positive or negative).

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{UnitQuaternion, Vector3};

use super::{ArmConfiguration, Elbow, Shoulder, wrap};
use crate::geometry::{Point3, Pose, Vec3, pose_from_parts};

/// The link lengths of an arm with a spherical wrist, millimetres (OPW names in brackets).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmGeometry {
    /// Height of axis 2 above the base plate (`c1`).
    pub shoulder_height: f64,
    /// Forward offset of axis 2 from axis 1 (`a1`).
    pub shoulder_offset: f64,
    /// Axis 2 to axis 3 (`c2`).
    pub lower_arm: f64,
    /// Offset of the forearm above axis 3, perpendicular to it (`−a2`: OPW counts it negative
    /// upward).
    pub elbow_offset: f64,
    /// Axis 3 to the wrist centre along the forearm (`c3`).
    pub forearm: f64,
    /// Wrist centre to the flange (`c4`).
    pub wrist_to_flange: f64,
}

impl ArmGeometry {
    /// The largest distance from axis 2 to the wrist centre (arm stretched), millimetres.
    #[must_use]
    pub fn max_wrist_reach(&self) -> f64 {
        self.lower_arm + self.forearm.hypot(self.elbow_offset)
    }

    /// Axis 3's angle (this module's convention) at which axis 2, axis 3 and the wrist centre
    /// are in line: the elbow's stretched singularity.
    #[must_use]
    pub fn stretched_axis3(&self) -> f64 {
        self.elbow_offset.atan2(self.forearm) - FRAC_PI_2
    }
}

/// `tool0` in the base frame for joints in this module's convention.
#[must_use]
pub fn forward(geometry: &ArmGeometry, q: &[f64; 6]) -> Pose {
    let rotation = arm_rotation(q[0], q[1] + q[2])
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), q[3])
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), q[4])
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), q[5])
        * tool0_from_wrist_axes();
    let wrist = wrist_centre(geometry, q);
    let flange_z = rotation * Vector3::z();
    pose_from_parts(wrist.coords + flange_z * geometry.wrist_to_flange, rotation)
}

/// The wrist centre (where axes 4, 5 and 6 meet) in the base frame.
#[must_use]
pub fn wrist_centre(geometry: &ArmGeometry, q: &[f64; 6]) -> Point3 {
    let g = geometry;
    let (s2, c2) = q[1].sin_cos();
    let (s23, c23) = (q[1] + q[2]).sin_cos();
    // In the plane of the arm: forward distance from axis 1 and height.
    let reach = g.shoulder_offset + g.lower_arm * s2 + g.forearm * c23 + g.elbow_offset * s23;
    let height = g.shoulder_height + g.lower_arm * c2 - g.forearm * s23 + g.elbow_offset * c23;
    let (s1, c1) = q[0].sin_cos();
    Point3::new(reach * c1, reach * s1, height)
}

/// The points where the links meet, base frame: the base origin, axis 1 at shoulder height,
/// axis 2, axis 3, the end of the elbow offset, the wrist centre and `tool0`'s origin.
#[must_use]
pub fn link_points(geometry: &ArmGeometry, q: &[f64; 6]) -> Vec<Point3> {
    let g = geometry;
    let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), q[0]);
    let lower = arm_rotation(q[0], q[1]);
    let fore = arm_rotation(q[0], q[1] + q[2]);
    let axis2 = Point3::from(turn * Vector3::new(g.shoulder_offset, 0.0, g.shoulder_height));
    let axis3 = axis2 + lower * Vector3::new(0.0, 0.0, g.lower_arm);
    let offset = axis3 + fore * Vector3::new(0.0, 0.0, g.elbow_offset);
    let wrist = offset + fore * Vector3::new(g.forearm, 0.0, 0.0);
    let tool0 = Point3::from(forward(geometry, q).translation.vector);
    vec![
        Point3::origin(),
        Point3::new(0.0, 0.0, g.shoulder_height),
        axis2,
        axis3,
        offset,
        wrist,
        tool0,
    ]
}

/// `Rz(q1) Ry(q23)`: the forearm's frame before the wrist.
fn arm_rotation(q1: f64, q23: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), q1)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), q23)
}

/// The constant turn from the wrist's axes (x along the forearm) to `tool0` (z along it).
fn tool0_from_wrist_axes() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2)
}

/// `|sin q5|` below which the wrist counts as exactly singular in the closed form: axes 4 and
/// 6 are then aligned and only `q4 + q6` is determined; axis 4 is set to zero.
const EXACT_WRIST_SINGULARITY: f64 = 1e-10;

/// Every solution for a `tool0` pose, up to eight, angles in (−π, π], ignoring joint limits;
/// empty when the wrist centre is out of reach.
#[must_use]
pub fn inverse(
    geometry: &ArmGeometry,
    base_from_tool0: &Pose,
) -> Vec<([f64; 6], ArmConfiguration)> {
    let g = geometry;
    let rotation = base_from_tool0.rotation;
    let flange_z = rotation * Vector3::z();
    let wrist: Vec3 = base_from_tool0.translation.vector - flange_z * g.wrist_to_flange;
    let upper = g.forearm.hypot(g.elbow_offset);
    let upper_angle = g.elbow_offset.atan2(g.forearm);
    let mut solutions = Vec::with_capacity(8);
    let facing = wrist.y.atan2(wrist.x);
    for shoulder in [Shoulder::Front, Shoulder::Back] {
        let q1 = match shoulder {
            Shoulder::Front => facing,
            Shoulder::Back => wrap(facing + PI),
        };
        let (s1, c1) = q1.sin_cos();
        let reach = c1 * wrist.x + s1 * wrist.y - g.shoulder_offset;
        let height = wrist.z - g.shoulder_height;
        let distance_sq = reach * reach + height * height;
        // sin(φ - q3) from the triangle axis 2, axis 3, wrist centre.
        let k = (distance_sq - g.lower_arm.powi(2) - upper * upper) / (2.0 * g.lower_arm * upper);
        if !k.is_finite() || k.abs() > 1.0 {
            continue;
        }
        for elbow_branch in [k.asin(), PI - k.asin()] {
            let q3 = wrap(upper_angle - elbow_branch);
            let beta = q3 - upper_angle;
            let a = g.lower_arm - upper * beta.sin();
            let b = upper * beta.cos();
            let q2 = (a * reach - b * height).atan2(a * height + b * reach);
            let elbow = elbow_of(g, q2, reach, height);
            let wrist_rotation =
                arm_rotation(q1, q2 + q3).inverse() * rotation * tool0_from_wrist_axes().inverse();
            let m = wrist_rotation.to_rotation_matrix().into_inner();
            // Rx(q4) Ry(q5) Rx(q6): m00 = c5, m01 = s5 s6, m02 = s5 c6, m10 = s4 s5,
            // m20 = -c4 s5.
            let s5_abs = m[(0, 1)].hypot(m[(0, 2)]);
            for wrist_flipped in [false, true] {
                let sign = if wrist_flipped { -1.0 } else { 1.0 };
                let q5 = (sign * s5_abs).atan2(m[(0, 0)]);
                let (q4, q6) = if s5_abs < EXACT_WRIST_SINGULARITY {
                    // Axes 4 and 6 aligned: Rx(q4 + q6) (or Rx(q4 - q6) with q5 = π).
                    let sum = m[(2, 1)].atan2(m[(1, 1)]);
                    (0.0, if m[(0, 0)] > 0.0 { sum } else { -sum })
                } else {
                    (
                        (sign * m[(1, 0)]).atan2(-sign * m[(2, 0)]),
                        (sign * m[(0, 1)]).atan2(sign * m[(0, 2)]),
                    )
                };
                solutions.push((
                    [q1, wrap(q2), q3, wrap(q4), wrap(q5), wrap(q6)],
                    ArmConfiguration {
                        shoulder,
                        elbow,
                        wrist_flipped,
                    },
                ));
            }
        }
    }
    solutions
}

/// Wrist centre in front of the lower arm: the cross product of the lower arm's direction
/// `(sin q2, cos q2)` with the elbow-to-wrist vector points along −y.
fn elbow_of(geometry: &ArmGeometry, q2: f64, reach: f64, height: f64) -> Elbow {
    let (s2, c2) = q2.sin_cos();
    let to_wrist_reach = reach - geometry.lower_arm * s2;
    let to_wrist_height = height - geometry.lower_arm * c2;
    if s2 * to_wrist_height - c2 * to_wrist_reach <= 0.0 {
        Elbow::Front
    } else {
        Elbow::Behind
    }
}

/// The arm configuration of joints in this module's convention (what [`inverse`] labels).
#[must_use]
pub fn configuration_of(geometry: &ArmGeometry, q: &[f64; 6]) -> ArmConfiguration {
    let wrist = wrist_centre(geometry, q);
    let (s1, c1) = q[0].sin_cos();
    let radial = c1 * wrist.x + s1 * wrist.y;
    let shoulder = if radial >= 0.0 {
        Shoulder::Front
    } else {
        Shoulder::Back
    };
    let elbow = elbow_of(
        geometry,
        q[1],
        radial - geometry.shoulder_offset,
        wrist.z - geometry.shoulder_height,
    );
    ArmConfiguration {
        shoulder,
        elbow,
        wrist_flipped: q[4].sin() < 0.0,
    }
}
