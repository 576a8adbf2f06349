//! Kinematics of a six-axis arm with a spherical wrist, in ABB's joint convention, with the
//! ABB IRB 120-3/0.58 as the model the paper's cell uses (§V-B).
//!
//! Model (ABB convention, base frame: x forward, z up; all joints zero = upper arm horizontal,
//! lower arm vertical, `tool0`'s z along base x):
//! ```text
//! base_from_flange(q) = [wrist_centre(q); Rz(q1) Ry(q2+q3) Rx(q4) Ry(q5) Rx(q6) Ry(π/2)]
//! wrist_centre(q) = Rz(q1) ((a1, 0, c1) + Ry(q2) (0, 0, c2) + Ry(q2+q3) (c3, 0, a2))
//! tool0 = wrist_centre + c4 · (flange z)
//! ```
//! Axes 2, 3 and 5 turn about the arm's y axis (positive: the arm tips forward and down),
//! axes 4 and 6 about the forearm and the flange normal, axis 1 about the base z. This is the
//! ortho-parallel-wrist ("OPW") family of Brandstötter, Angerer and Hofbaur (2014); the
//! inverse below is its closed form written in these coordinates: two shoulder solutions
//! (axis 1 facing the wrist centre or turned away), two elbow solutions, two wrist solutions
//! (axis 5 positive or negative), and every ±360° copy of an axis whose range allows it.
//!
//! The IRB 120's geometry and limits come from ABB's product specification, IRB 120
//! (3HAC035960-001): base to axis 2 290 mm, lower arm 270 mm, forearm offset 70 mm, axis 3 to
//! wrist centre 302 mm, wrist centre to flange 72 mm, so `tool0` at all joints zero is
//! `(374, 0, 630)` mm with orientation `[0.70711, 0, 0.70711, 0]`. Working ranges: axis 1
//! ±165°, axis 2 ±110°, axis 3 −110°..+70°, axis 4 ±160°, axis 5 ±120°, axis 6 ±400°;
//! maximum speeds 250, 250, 250, 320, 320, 420 °/s.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::{UnitQuaternion, Vector3};

use crate::geometry::{Point3, Pose, Vec3, pose_from_parts};

/// Six joint angles in radians, axis 1 first, in the controller's convention (for ABB, the
/// angles of a RAPID `jointtarget`, which prints them in degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Joints(pub [f64; 6]);

impl Joints {
    /// The angles in degrees, as a controller prints them.
    #[must_use]
    pub fn to_degrees(&self) -> [f64; 6] {
        self.0.map(f64::to_degrees)
    }

    /// Joints from degrees.
    #[must_use]
    pub fn from_degrees(degrees: [f64; 6]) -> Self {
        Self(degrees.map(f64::to_radians))
    }
}

/// The link lengths of an arm with a spherical wrist, millimetres (OPW names in brackets).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmGeometry {
    /// Height of axis 2 above the base plate (`c1`).
    pub shoulder_height: f64,
    /// Forward offset of axis 2 from axis 1 (`a1`).
    pub shoulder_offset: f64,
    /// Axis 2 to axis 3 (`c2`).
    pub lower_arm: f64,
    /// Offset of the forearm above axis 3, perpendicular to it (`a2`, taken positive up).
    pub elbow_offset: f64,
    /// Axis 3 to the wrist centre along the forearm (`c3`).
    pub forearm: f64,
    /// Wrist centre to the flange (`c4`).
    pub wrist_to_flange: f64,
}

/// The range and speed of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisLimit {
    /// Lowest angle, radians.
    pub min: f64,
    /// Highest angle, radians.
    pub max: f64,
    /// Maximum speed, radians per second.
    pub max_speed: f64,
}

impl AxisLimit {
    fn from_degrees(min_deg: f64, max_deg: f64, max_speed_deg_s: f64) -> Self {
        Self {
            min: min_deg.to_radians(),
            max: max_deg.to_radians(),
            max_speed: max_speed_deg_s.to_radians(),
        }
    }

    /// True when `angle` lies in the range (a few nanoradians of slack for rounding).
    #[must_use]
    pub fn contains(&self, angle: f64) -> bool {
        angle >= self.min - 1e-9 && angle <= self.max + 1e-9
    }
}

/// A robot arm: its name, geometry and axis limits.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotModel {
    /// Name as users write it (`irb120`).
    pub name: String,
    /// Link lengths.
    pub geometry: ArmGeometry,
    /// Axis 1 to 6.
    pub limits: [AxisLimit; 6],
}

impl RobotModel {
    /// The ABB IRB 120-3/0.58, from ABB's product specification (3HAC035960-001): link
    /// lengths from its dimension drawing, working ranges and maximum axis speeds from its
    /// "Robot motion" table. Axis 3's range is −110°..+70° there (some secondary sources say
    /// −90°); edit `limits` for a controller configured otherwise.
    #[must_use]
    pub fn irb120() -> Self {
        Self {
            name: "irb120".into(),
            geometry: ArmGeometry {
                shoulder_height: 290.0,
                shoulder_offset: 0.0,
                lower_arm: 270.0,
                elbow_offset: 70.0,
                forearm: 302.0,
                wrist_to_flange: 72.0,
            },
            limits: [
                AxisLimit::from_degrees(-165.0, 165.0, 250.0),
                AxisLimit::from_degrees(-110.0, 110.0, 250.0),
                AxisLimit::from_degrees(-110.0, 70.0, 250.0),
                AxisLimit::from_degrees(-160.0, 160.0, 320.0),
                AxisLimit::from_degrees(-120.0, 120.0, 320.0),
                AxisLimit::from_degrees(-400.0, 400.0, 420.0),
            ],
        }
    }

    /// A model by the name users type, `None` for an unknown robot.
    #[must_use]
    pub fn by_name(name: &str) -> Option<Self> {
        match name.to_ascii_lowercase().as_str() {
            "irb120" | "irb-120" | "irb_120" | "irb120-3/0.58" => Some(Self::irb120()),
            _ => None,
        }
    }

    /// The axis whose limit `joints` break first, with its angle, `None` when all are inside.
    #[must_use]
    pub fn axis_outside_limits(&self, joints: &Joints) -> Option<usize> {
        (0..6).find(|&i| !self.limits[i].contains(joints.0[i]))
    }

    /// The largest distance from axis 2 to the wrist centre (arm stretched), millimetres.
    #[must_use]
    pub fn max_wrist_reach(&self) -> f64 {
        let g = &self.geometry;
        g.lower_arm + g.forearm.hypot(g.elbow_offset)
    }
}

/// Which side of axis 1 the wrist centre is on, ABB's `cfx` first criterion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Shoulder {
    /// Wrist centre in front of axis 1 (the usual pose).
    Front,
    /// Wrist centre behind axis 1 (the arm reaches over its back).
    Back,
}

/// Which side of the lower arm the wrist centre is on, ABB's `cfx` second criterion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Elbow {
    /// Wrist centre in front of the lower arm (elbow up for a forward reach).
    Front,
    /// Wrist centre behind the lower arm.
    Behind,
}

/// The arm configuration of one inverse-kinematics solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ArmConfiguration {
    /// Wrist centre relative to axis 1.
    pub shoulder: Shoulder,
    /// Wrist centre relative to the lower arm.
    pub elbow: Elbow,
    /// Axis 5 negative (the wrist flipped).
    pub wrist_flipped: bool,
}

/// ABB's robot configuration data (`confdata`) for a joint solution: the quadrants of axes 1,
/// 4 and 6 and the configuration number `cfx` (RAPID reference, data types, `confdata`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConfData {
    /// Quadrant of axis 1: `floor(q1 / 90°)`.
    pub cf1: i32,
    /// Quadrant of axis 4.
    pub cf4: i32,
    /// Quadrant of axis 6.
    pub cf6: i32,
    /// 0..7: 4·(wrist behind axis 1) + 2·(wrist behind lower arm) + (axis 5 negative).
    pub cfx: i32,
}

/// Tool flange (`tool0`) pose in the base frame for the given joints.
#[must_use]
pub fn forward(geometry: &ArmGeometry, joints: &Joints) -> Pose {
    let q = &joints.0;
    let rotation = arm_rotation(q[0], q[1] + q[2])
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), q[3])
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), q[4])
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), q[5])
        * flange_from_wrist_axes();
    let wrist = wrist_centre(geometry, joints);
    let flange_z = rotation * Vector3::z();
    pose_from_parts(wrist.coords + flange_z * geometry.wrist_to_flange, rotation)
}

/// The wrist centre (where axes 4, 5 and 6 meet) in the base frame.
#[must_use]
pub fn wrist_centre(geometry: &ArmGeometry, joints: &Joints) -> Point3 {
    let q = &joints.0;
    let g = geometry;
    let (s2, c2) = q[1].sin_cos();
    let (s23, c23) = (q[1] + q[2]).sin_cos();
    // In the plane of the arm: forward distance from axis 1 and height.
    let reach = g.shoulder_offset + g.lower_arm * s2 + g.forearm * c23 + g.elbow_offset * s23;
    let height = g.shoulder_height + g.lower_arm * c2 - g.forearm * s23 + g.elbow_offset * c23;
    let (s1, c1) = q[0].sin_cos();
    Point3::new(reach * c1, reach * s1, height)
}

/// `Rz(q1) Ry(q23)`: the forearm's frame before the wrist.
fn arm_rotation(q1: f64, q23: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), q1)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), q23)
}

/// The constant turn from the wrist's axes (x along the forearm) to `tool0` (z along it).
fn flange_from_wrist_axes() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2)
}

/// One solution of the inverse kinematics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSolution {
    /// Joint angles, each in (−π, π].
    pub joints: Joints,
    /// Its arm configuration.
    pub configuration: ArmConfiguration,
}

/// `|sin q5|` below which the wrist counts as exactly singular in the closed form: axes 4 and
/// 6 are then aligned and only `q4 + q6` is determined; axis 4 is set to zero.
const EXACT_WRIST_SINGULARITY: f64 = 1e-10;

/// Every inverse-kinematics solution for a flange pose, up to eight, angles in (−π, π],
/// ignoring joint limits; empty when the wrist centre is out of reach.
#[must_use]
pub fn inverse(geometry: &ArmGeometry, base_from_flange: &Pose) -> Vec<IkSolution> {
    let g = geometry;
    let rotation = base_from_flange.rotation;
    let flange_z = rotation * Vector3::z();
    let wrist: Vec3 = base_from_flange.translation.vector - flange_z * g.wrist_to_flange;
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
        let k = k.clamp(-1.0, 1.0);
        for elbow_branch in [k.asin(), PI - k.asin()] {
            let q3 = wrap(upper_angle - elbow_branch);
            let beta = q3 - upper_angle;
            let a = g.lower_arm - upper * beta.sin();
            let b = upper * beta.cos();
            let q2 = (a * reach - b * height).atan2(a * height + b * reach);
            // Wrist centre in front of the lower arm: the cross product of the lower arm's
            // direction (sin q2, cos q2) with the elbow-to-wrist vector points along -y.
            let (s2, c2) = q2.sin_cos();
            let to_wrist_reach = reach - g.lower_arm * s2;
            let to_wrist_height = height - g.lower_arm * c2;
            let elbow = if s2 * to_wrist_height - c2 * to_wrist_reach <= 0.0 {
                Elbow::Front
            } else {
                Elbow::Behind
            };
            let wrist_rotation =
                arm_rotation(q1, q2 + q3).inverse() * rotation * flange_from_wrist_axes().inverse();
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
                solutions.push(IkSolution {
                    joints: Joints([q1, wrap(q2), q3, wrap(q4), wrap(q5), wrap(q6)]),
                    configuration: ArmConfiguration {
                        shoulder,
                        elbow,
                        wrist_flipped,
                    },
                });
            }
        }
    }
    solutions
}

/// Every joint solution inside the model's limits, with the ±360° copies of each axis whose
/// range is wider than a turn (axis 6 of the IRB 120).
#[must_use]
pub fn inverse_within_limits(model: &RobotModel, base_from_flange: &Pose) -> Vec<IkSolution> {
    let mut out = Vec::new();
    for solution in inverse(&model.geometry, base_from_flange) {
        let mut candidates = vec![solution];
        for axis in 0..6 {
            let limit = &model.limits[axis];
            let mut next = Vec::new();
            for c in &candidates {
                for turns in -2..=2 {
                    let angle = c.joints.0[axis] + f64::from(turns) * TAU;
                    if limit.contains(angle) {
                        let mut copy = *c;
                        copy.joints.0[axis] = angle;
                        next.push(copy);
                    }
                }
            }
            candidates = next;
        }
        out.extend(candidates);
    }
    out
}

/// ABB's `confdata` for a joint solution of an arm in the given configuration.
#[must_use]
pub fn confdata(joints: &Joints, configuration: &ArmConfiguration) -> ConfData {
    let quadrant = |angle: f64| (angle / FRAC_PI_2).floor() as i32;
    let cfx = 4 * i32::from(configuration.shoulder == Shoulder::Back)
        + 2 * i32::from(configuration.elbow == Elbow::Behind)
        + i32::from(joints.0[4] < 0.0);
    ConfData {
        cf1: quadrant(joints.0[0]),
        cf4: quadrant(joints.0[3]),
        cf6: quadrant(joints.0[5]),
        cfx,
    }
}

/// The arm configuration of given joints (the inverse of what [`inverse`] labels).
#[must_use]
pub fn configuration_of(geometry: &ArmGeometry, joints: &Joints) -> ArmConfiguration {
    let q = &joints.0;
    let wrist = wrist_centre(geometry, joints);
    let (s1, c1) = q[0].sin_cos();
    let reach = c1 * wrist.x + s1 * wrist.y - geometry.shoulder_offset;
    let height = wrist.z - geometry.shoulder_height;
    let (s2, c2) = q[1].sin_cos();
    let to_wrist_reach = reach - geometry.lower_arm * s2;
    let to_wrist_height = height - geometry.lower_arm * c2;
    let shoulder = if c1 * wrist.x + s1 * wrist.y >= 0.0 {
        Shoulder::Front
    } else {
        Shoulder::Back
    };
    let elbow = if s2 * to_wrist_height - c2 * to_wrist_reach <= 0.0 {
        Elbow::Front
    } else {
        Elbow::Behind
    };
    ArmConfiguration {
        shoulder,
        elbow,
        wrist_flipped: q[4] < 0.0,
    }
}

/// An angle wrapped into (−π, π].
fn wrap(angle: f64) -> f64 {
    let wrapped = angle.rem_euclid(TAU);
    if wrapped > PI { wrapped - TAU } else { wrapped }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn home_is_abbs_calibration_position() {
        let model = RobotModel::irb120();
        let home = forward(&model.geometry, &Joints([0.0; 6]));
        let t = home.translation.vector;
        assert_relative_eq!(t, Vector3::new(374.0, 0.0, 630.0), epsilon = 1e-9);
        let q = home.rotation.quaternion();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert_relative_eq!(q.w.abs(), h, epsilon = 1e-12);
        assert_relative_eq!(q.j.abs(), h, epsilon = 1e-12);
        assert_relative_eq!(q.w * q.j, 0.5, epsilon = 1e-12);
    }

    #[test]
    fn wrap_keeps_angles_in_half_open_range() {
        assert_relative_eq!(wrap(3.0 * PI), PI, epsilon = 1e-12);
        assert_relative_eq!(wrap(-PI), PI, epsilon = 1e-12);
        assert_relative_eq!(wrap(0.5), 0.5, epsilon = 1e-15);
    }
}
