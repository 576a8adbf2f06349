//! Kinematics of the six-axis arms a program can be written for: one [`Robot`] description
//! (maker, geometry, joint ranges and speeds) serves the check, the programs and the inverse
//! kinematics, in the maker's own joint convention (what the pendant shows).
//!
//! Two families ([`Arm`]):
//! - **Spherical wrist** (ABB, KUKA): the ortho-parallel-wrist ("OPW") parameters of
//!   Brandstötter, Angerer and Hofbaur (2014) as ROS-Industrial's `opw_kinematics` writes them:
//!   lengths `a1, a2, b, c1, c2, c3, c4`; the model's angle of joint i is
//!   `θ_i = s_i · q_i − o_i` with `q_i` the maker's angle, `s_i = ±1` its sign correction and
//!   `o_i` its offset. At `θ = 0` the arm stands stretched upward and `tool0` (z out of the
//!   flange) is parallel to the base. The closed form is [`opw`].
//! - **UR-like** (Universal Robots): UR's published Denavit–Hartenberg model ([`ur`]), joint
//!   angles those of `movej`.
//!
//! The flange frame is the one the maker's programs mean ([`Maker::tool0_from_flange`]): ABB's
//! `tool0` and UR's tool flange have z out of the flange; KUKA's FLANGE frame has x out of the
//! flange (`FLANGE = tool0 · Ry(−90°)`; at KUKA's home `{A1 0, A2 −90, A3 90, A4 0, A5 0, A6 0}`
//! it is parallel to `$ROBROOT`).
//!
//! Every pose has up to eight solutions (shoulder × elbow × wrist, [`ArmConfiguration`]) and,
//! for axes whose range is wider than a turn, their ±360° copies ([`inverse_within_limits`]).

pub mod models;
pub mod opw;
pub mod ur;

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::geometry::{Point3, Pose};
pub use opw::ArmGeometry;
pub use ur::UrParameters;

/// Six joint angles in radians, axis 1 first, in the maker's convention (ABB: a RAPID
/// `jointtarget`; KUKA: A1–A6 as the pendant shows them; UR: `movej`'s angles).
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
    /// A limit from degrees and degrees per second.
    #[must_use]
    pub fn from_degrees(min_deg: f64, max_deg: f64, max_speed_deg_s: f64) -> Self {
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

/// Who made the arm: decides the flange frame, the joint conventions' meaning and which
/// program dialect may drive it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Maker {
    /// ABB (RAPID).
    Abb,
    /// KUKA (KRL).
    Kuka,
    /// Universal Robots (URScript).
    UniversalRobots,
}

impl Maker {
    /// The maker's name, for messages.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::Abb => "ABB",
            Self::Kuka => "KUKA",
            Self::UniversalRobots => "Universal Robots",
        }
    }

    /// The maker's flange frame in `tool0` (z out of the flange): identity for ABB's `tool0`
    /// and UR's tool flange, `Ry(−90°)` for KUKA's FLANGE (x out of the flange).
    #[must_use]
    pub fn tool0_from_flange(self) -> UnitQuaternion<f64> {
        match self {
            Self::Kuka => UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -FRAC_PI_2),
            Self::Abb | Self::UniversalRobots => UnitQuaternion::identity(),
        }
    }
}

/// OPW parameters of a spherical-wrist arm (ROS-Industrial `opw_kinematics` convention),
/// lengths in millimetres, offsets in radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpwParameters {
    /// Forward offset of axis 2 from axis 1.
    pub a1: f64,
    /// Offset between axes 3 and 4, negative when the forearm sits above axis 3.
    pub a2: f64,
    /// Lateral offset (must be zero: no supported arm has one).
    pub b: f64,
    /// Height of axis 2 above the base.
    pub c1: f64,
    /// Axis 2 to axis 3.
    pub c2: f64,
    /// Axis 3 to the wrist centre.
    pub c3: f64,
    /// Wrist centre to the flange.
    pub c4: f64,
    /// `o_i` of `θ_i = s_i q_i − o_i`, radians.
    pub offsets: [f64; 6],
    /// `s_i`, each +1 or −1.
    pub sign_corrections: [f64; 6],
}

impl OpwParameters {
    /// The lengths in [`opw`]'s terms.
    #[must_use]
    pub fn geometry(&self) -> ArmGeometry {
        ArmGeometry {
            shoulder_height: self.c1,
            shoulder_offset: self.a1,
            lower_arm: self.c2,
            elbow_offset: -self.a2,
            forearm: self.c3,
            wrist_to_flange: self.c4,
        }
    }

    /// [`opw`]'s angles (its axis 3 is OPW's θ3 − 90°) from the maker's.
    fn model_from_maker(&self, q: &Joints) -> [f64; 6] {
        let mut theta: [f64; 6] =
            std::array::from_fn(|i| self.sign_corrections[i] * q.0[i] - self.offsets[i]);
        theta[2] -= FRAC_PI_2;
        theta
    }

    /// The maker's angles from [`opw`]'s.
    fn maker_from_model(&self, model: &[f64; 6]) -> Joints {
        let mut theta = *model;
        theta[2] += FRAC_PI_2;
        Joints(std::array::from_fn(|i| {
            self.sign_corrections[i] * (theta[i] + self.offsets[i])
        }))
    }
}

/// The kinematic family and its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Arm {
    /// Spherical wrist: OPW parameters.
    SphericalWrist(OpwParameters),
    /// Universal Robots' DH model.
    Ur(UrParameters),
}

/// A robot arm: its name, maker, kinematics and axis limits.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// Name as users write it (`irb120`, `kr6-r700`, `ur5e`).
    pub name: String,
    /// Its maker.
    pub maker: Maker,
    /// Its kinematics.
    pub arm: Arm,
    /// Axis 1 to 6, in the maker's convention.
    pub limits: [AxisLimit; 6],
    /// The heaviest load its maker allows on the flange, kg (`None`: not known).
    pub max_payload_kg: Option<f64>,
    /// The maker's limits on the load's moments of inertia about the wrist axes (its load
    /// diagram), `None` when the model carries none.
    pub wrist_inertia: Option<WristInertia>,
}

/// A maker's limits on the load's moments of inertia about axes 5 and 6 (ABB's product
/// specifications, "Maximum load and moment of inertia"): for a load of mass `m` whose centre
/// of gravity is `z` along the flange's axis and `l` from it, `m ((z + d5)² + l²) ≤ J5` and
/// `m l² ≤ J6`, with `d5` from axis 5 to the flange. A point mass: the load's own inertia
/// about its centre is not known to teachcam and counted as zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WristInertia {
    /// Distance from axis 5 to the flange, millimetres.
    pub axis5_to_flange_mm: f64,
    /// Largest moment of inertia about axis 5, kg·m².
    pub j5_max_kgm2: f64,
    /// Largest moment of inertia about axis 6, kg·m².
    pub j6_max_kgm2: f64,
}

impl Robot {
    /// Why a tool of `mass_kg` with its centre of gravity at `cog_in_flange_mm` (the flange's
    /// frame, millimetres) is too much for this robot: over the rated payload, or beyond its
    /// load diagram ([`WristInertia`]); `Ok(Some(note))` when the centre of gravity could not
    /// be judged (no load diagram in the model), `Ok(None)` when it fits.
    ///
    /// # Errors
    /// One line naming the robot, what was given and the limit.
    pub fn load_problem(
        &self,
        mass_kg: f64,
        cog_in_flange_mm: [f64; 3],
    ) -> Result<Option<String>, String> {
        if !(mass_kg.is_finite() && mass_kg >= 0.0)
            || cog_in_flange_mm.iter().any(|c| !c.is_finite())
        {
            return Err(format!(
                "tool mass {mass_kg} kg at {cog_in_flange_mm:?} mm: a finite, non-negative mass and a finite centre of gravity expected"
            ));
        }
        if let Some(rated) = self.max_payload_kg
            && mass_kg > rated
        {
            return Err(format!(
                "tool mass {mass_kg} kg: the {} is rated for {rated} kg (its data sheet's payload); a lighter tool or a larger robot",
                self.name
            ));
        }
        let Some(limits) = self.wrist_inertia else {
            return Ok(Some(format!(
                "the tool's centre of gravity is not checked: the {} model carries no load diagram (see its maker's)",
                self.name
            )));
        };
        let [x, y, z] = cog_in_flange_mm.map(|c| c / 1000.0);
        let l2 = x * x + y * y;
        let d5 = limits.axis5_to_flange_mm / 1000.0;
        let j5 = mass_kg * ((z + d5).powi(2) + l2);
        let j6 = mass_kg * l2;
        for (axis, j, max) in [(5, j5, limits.j5_max_kgm2), (6, j6, limits.j6_max_kgm2)] {
            if j > max {
                return Err(format!(
                    "tool mass {mass_kg} kg with its centre of gravity at ({:.0}, {:.0}, {:.0}) mm from the flange: {j:.3} kg·m² about axis {axis} of the {}, over its load diagram's {max} kg·m²; bring the centre of gravity nearer the flange or lighten the tool",
                    cog_in_flange_mm[0], cog_in_flange_mm[1], cog_in_flange_mm[2], self.name
                ));
            }
        }
        Ok(None)
    }
}

impl Robot {
    /// The axis whose limit `joints` break first, `None` when all are inside.
    #[must_use]
    pub fn axis_outside_limits(&self, joints: &Joints) -> Option<usize> {
        (0..6).find(|&i| !self.limits[i].contains(joints.0[i]))
    }

    /// The largest distance from the shoulder axis to the wrist (arm stretched), millimetres.
    #[must_use]
    pub fn max_wrist_reach(&self) -> f64 {
        match &self.arm {
            Arm::SphericalWrist(p) => p.geometry().max_wrist_reach(),
            Arm::Ur(p) => p.max_reach(),
        }
    }

    /// A point well inside the arm's workspace, in its base frame: 60 % of the reach in front
    /// of the shoulder axis, at its height.
    #[must_use]
    pub fn comfortable_point(&self) -> Point3 {
        let reach = 0.6 * self.max_wrist_reach();
        match &self.arm {
            Arm::SphericalWrist(p) => Point3::new(p.a1 + reach, 0.0, p.c1),
            Arm::Ur(p) => Point3::new(reach, 0.0, p.d1),
        }
    }
}

/// Which side of axis 1 the wrist is on (ABB's `cfx` and KUKA's status bit 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Shoulder {
    /// Wrist centre in front of axis 1 (the usual pose).
    Front,
    /// Wrist centre behind axis 1 (the arm reaches over its back).
    Back,
}

/// Which side of the lower arm the wrist is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Elbow {
    /// Wrist centre in front of the lower arm (elbow up for a forward reach); for UR,
    /// `sin θ3 ≥ 0`.
    Front,
    /// The other elbow.
    Behind,
}

/// The arm configuration of one inverse-kinematics solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ArmConfiguration {
    /// Wrist relative to axis 1.
    pub shoulder: Shoulder,
    /// Wrist relative to the lower arm.
    pub elbow: Elbow,
    /// Axis 5 negative (the wrist flipped).
    pub wrist_flipped: bool,
}

impl ArmConfiguration {
    /// The branch as a number 0..7: 4·(shoulder back) + 2·(elbow behind) + (wrist flipped);
    /// for ABB it is `cfx`.
    #[must_use]
    pub fn code(&self) -> u8 {
        4 * u8::from(self.shoulder == Shoulder::Back)
            + 2 * u8::from(self.elbow == Elbow::Behind)
            + u8::from(self.wrist_flipped)
    }
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

/// KUKA's Status and Turn of a joint solution (KUKA System Software 8, "Operating and
/// Programming Instructions for System Integrators", §"Status" and §"Turn"):
/// - Status bit 0: the wrist root point (where A4, A5, A6 meet) has a negative x in the A1
///   coordinate system (`$ROBROOT` turned with A1): the overhead area;
/// - bit 1: `A3 ≥ φ`, φ the A3 angle at which A2, A3 and the wrist root point are in line
///   (0° without an A3–A4 offset; 5.5° for the KR 6 sixx's 35 mm over 365 mm);
/// - bit 2: `A5 ≤ 0`;
/// - Turn bit i (i = 0..5): axis i+1's angle is negative.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StatusTurn {
    /// `S`, 0..7.
    pub status: u8,
    /// `T`, 0..63.
    pub turn: u8,
}

/// One solution of the inverse kinematics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSolution {
    /// Joint angles in the maker's convention.
    pub joints: Joints,
    /// Its arm configuration.
    pub configuration: ArmConfiguration,
}

fn rotation_pose(rotation: UnitQuaternion<f64>) -> Pose {
    Isometry3::from_parts(Translation3::identity(), rotation)
}

/// The maker's flange frame in the base frame for the given joints.
#[must_use]
pub fn forward(robot: &Robot, joints: &Joints) -> Pose {
    let base_from_tool0 = match &robot.arm {
        Arm::SphericalWrist(p) => opw::forward(&p.geometry(), &p.model_from_maker(joints)),
        Arm::Ur(p) => ur::forward(p, &joints.0),
    };
    base_from_tool0 * rotation_pose(robot.maker.tool0_from_flange())
}

/// The wrist point in the base frame: the wrist centre of a spherical wrist, frame 5's origin
/// of a UR arm (the point the shoulder singularity is about).
#[must_use]
pub fn wrist_centre(robot: &Robot, joints: &Joints) -> Point3 {
    match &robot.arm {
        Arm::SphericalWrist(p) => opw::wrist_centre(&p.geometry(), &p.model_from_maker(joints)),
        Arm::Ur(p) => {
            let flange = ur::forward(p, &joints.0);
            Point3::from(flange.translation.vector - flange.rotation * Vector3::z() * p.d6)
        }
    }
}

/// The arm drawn as a chain of straight links: the points where its links meet, in the base
/// frame, from the base plate to the flange. A spherical wrist gives seven (base, axis 1 at
/// shoulder height, axis 2, axis 3, the elbow offset, the wrist centre, the flange); a UR arm
/// the seven origins of its DH frames 0–6. The first is the base origin, the last the flange
/// origin of [`forward`]; consecutive points are a fixed link length apart for any joints.
#[must_use]
pub fn link_points(robot: &Robot, joints: &Joints) -> Vec<Point3> {
    match &robot.arm {
        Arm::SphericalWrist(p) => opw::link_points(&p.geometry(), &p.model_from_maker(joints)),
        Arm::Ur(p) => ur::link_points(p, &joints.0),
    }
}

/// Every inverse-kinematics solution for a flange pose (the maker's flange frame), up to
/// eight, angles wrapped into (−π, π], ignoring joint limits; empty when out of reach.
#[must_use]
pub fn inverse(robot: &Robot, base_from_flange: &Pose) -> Vec<IkSolution> {
    let base_from_tool0 =
        base_from_flange * rotation_pose(robot.maker.tool0_from_flange().inverse());
    match &robot.arm {
        Arm::SphericalWrist(p) => opw::inverse(&p.geometry(), &base_from_tool0)
            .into_iter()
            .map(|(model, configuration)| IkSolution {
                joints: Joints(p.maker_from_model(&model).0.map(wrap)),
                configuration,
            })
            .collect(),
        Arm::Ur(p) => ur::inverse(p, &base_from_tool0)
            .into_iter()
            .map(|(joints, configuration)| IkSolution {
                joints: Joints(joints),
                configuration,
            })
            .collect(),
    }
}

/// Every joint solution inside the robot's limits, with the ±360° copies of each axis whose
/// range allows them (axis 6 of the IRB 120 and of the KR 6; every axis of a UR).
#[must_use]
pub fn inverse_within_limits(robot: &Robot, base_from_flange: &Pose) -> Vec<IkSolution> {
    let mut out = Vec::new();
    for solution in inverse(robot, base_from_flange) {
        let mut candidates = vec![solution];
        for axis in 0..6 {
            let limit = &robot.limits[axis];
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

/// The arm configuration of given joints (the inverse of what [`inverse`] labels).
#[must_use]
pub fn configuration_of(robot: &Robot, joints: &Joints) -> ArmConfiguration {
    match &robot.arm {
        Arm::SphericalWrist(p) => opw::configuration_of(&p.geometry(), &p.model_from_maker(joints)),
        Arm::Ur(p) => ur::configuration_of(p, &joints.0),
    }
}

/// ABB's `confdata` for a joint solution of an arm in the given configuration.
#[must_use]
pub fn confdata(joints: &Joints, configuration: &ArmConfiguration) -> ConfData {
    let quadrant = |angle: f64| (angle / FRAC_PI_2).floor() as i32;
    ConfData {
        cf1: quadrant(joints.0[0]),
        cf4: quadrant(joints.0[3]),
        cf6: quadrant(joints.0[5]),
        cfx: i32::from(configuration.code()),
    }
}

/// KUKA's Status and Turn ([`StatusTurn`]) of a joint solution.
#[must_use]
pub fn status_turn(robot: &Robot, joints: &Joints, configuration: &ArmConfiguration) -> StatusTurn {
    let q = &joints.0;
    let elbow_up = match &robot.arm {
        Arm::SphericalWrist(p) => {
            // φ in the maker's convention: OPW's θ3 of the stretched arm is atan2(−a2, c3).
            let phi = p.sign_corrections[2] * ((-p.a2).atan2(p.c3) + p.offsets[2]);
            if p.sign_corrections[2] > 0.0 {
                q[2] >= phi
            } else {
                q[2] <= phi
            }
        }
        Arm::Ur(_) => configuration.elbow == Elbow::Front,
    };
    let status = u8::from(configuration.shoulder == Shoulder::Back)
        + 2 * u8::from(elbow_up)
        + 4 * u8::from(q[4] <= 0.0);
    let turn = (0..6).map(|i| u8::from(q[i] < 0.0) << i).sum();
    StatusTurn { status, turn }
}

/// An angle wrapped into (−π, π].
pub(crate) fn wrap(angle: f64) -> f64 {
    let wrapped = angle.rem_euclid(TAU);
    if wrapped > PI { wrapped - TAU } else { wrapped }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn home_is_abbs_calibration_position() {
        let robot = Robot::irb120();
        let home = forward(&robot, &Joints([0.0; 6]));
        let t = home.translation.vector;
        assert_relative_eq!(t, Vector3::new(374.0, 0.0, 630.0), epsilon = 1e-9);
        let q = home.rotation.quaternion();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert_relative_eq!(q.w.abs(), h, epsilon = 1e-12);
        assert_relative_eq!(q.j.abs(), h, epsilon = 1e-12);
        assert_relative_eq!(q.w * q.j, 0.5, epsilon = 1e-12);
    }

    #[test]
    fn link_points_run_from_the_base_to_the_flange_with_fixed_link_lengths() {
        for robot in [Robot::irb120(), Robot::kr6_r700(), Robot::ur5e()] {
            let lengths = |joints: &Joints| -> Vec<f64> {
                link_points(&robot, joints)
                    .windows(2)
                    .map(|pair| (pair[1] - pair[0]).norm())
                    .collect()
            };
            let home = lengths(&Joints([0.0; 6]));
            for joints in [
                Joints([0.3, -0.4, 0.5, 1.1, -0.7, 2.0]),
                Joints([-1.2, 0.2, -0.3, -2.0, 1.0, -0.5]),
            ] {
                let points = link_points(&robot, &joints);
                assert_eq!(points.len(), 7, "{}", robot.name);
                assert_relative_eq!(points[0], Point3::origin(), epsilon = 1e-12);
                let flange = forward(&robot, &joints).translation.vector;
                assert_relative_eq!(points[6].coords, flange, epsilon = 1e-9);
                if matches!(robot.arm, Arm::SphericalWrist(_)) {
                    assert_relative_eq!(points[5], wrist_centre(&robot, &joints), epsilon = 1e-9);
                }
                for (a, b) in lengths(&joints).iter().zip(&home) {
                    assert_relative_eq!(*a, *b, epsilon = 1e-9);
                }
            }
        }
    }

    #[test]
    fn wrap_keeps_angles_in_half_open_range() {
        assert_relative_eq!(wrap(3.0 * PI), PI, epsilon = 1e-12);
        assert_relative_eq!(wrap(-PI), PI, epsilon = 1e-12);
        assert_relative_eq!(wrap(0.5), 0.5, epsilon = 1e-15);
    }
}
