//! Universal Robots' arms: the Denavit–Hartenberg model UR publishes for its e-Series, and its
//! closed-form inverse (the wrist is not spherical: axes 2, 3 and 4 are parallel instead).
//!
//! Model (UR, "DH parameters for calculations of kinematics and dynamics"; classic DH,
//! `T_i = Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i)`, `θ_i` the joint angle of `movej`):
//! ```text
//! i      1     2     3     4     5      6
//! a      0     a2    a3    0     0      0
//! d      d1    0     0     d4    d5     d6
//! α      π/2   0     0     π/2   −π/2   0
//! ```
//! Frame 0 is the controller's Base frame and frame 6 the tool flange (z out of the flange).
//!
//! Inverse (derived here; the same steps as Hawkins, "Analytic inverse kinematics for the
//! Universal Robots UR-5/UR-10 arms", 2013): with `z1 = (sin θ1, −cos θ1, 0)` the common
//! direction of axes 2, 3 and 4, every link but `d4` and `d6` is perpendicular to it, so
//! - `p5 · z1 = d4` with `p5 = p6 − d6 z6`: two solutions for θ1;
//! - `z1` seen in the flange frame is `(s5 c6, −s5 s6, c5)`: θ5 (two signs) and θ6;
//! - axes 2 and 3 then form a planar two-link arm reaching frame 3's origin: two elbows;
//!   θ4 closes the sum θ2 + θ3 + θ4 read from the rotation.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::{ArmConfiguration, Elbow, Shoulder, wrap};
use crate::geometry::Pose;

/// The six non-zero DH lengths of a UR-like arm, millimetres (signs as UR publishes them:
/// `a2`, `a3` negative).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UrParameters {
    /// Base to shoulder axis height.
    pub d1: f64,
    /// Upper arm length (shoulder to elbow axis).
    pub a2: f64,
    /// Forearm length (elbow to wrist 1 axis).
    pub a3: f64,
    /// Shoulder offset along the parallel axes, to wrist 1.
    pub d4: f64,
    /// Wrist 1 to wrist 2.
    pub d5: f64,
    /// Wrist 2 to the flange.
    pub d6: f64,
}

impl UrParameters {
    fn a(&self) -> [f64; 6] {
        [0.0, self.a2, self.a3, 0.0, 0.0, 0.0]
    }

    fn d(&self) -> [f64; 6] {
        [self.d1, 0.0, 0.0, self.d4, self.d5, self.d6]
    }

    /// The largest distance from the shoulder axis to wrist 1's axis, millimetres.
    #[must_use]
    pub fn max_reach(&self) -> f64 {
        self.a2.abs() + self.a3.abs()
    }
}

const ALPHA: [f64; 6] = [
    std::f64::consts::FRAC_PI_2,
    0.0,
    0.0,
    std::f64::consts::FRAC_PI_2,
    -std::f64::consts::FRAC_PI_2,
    0.0,
];

/// One DH step `Rz(θ) Tz(d) Tx(a) Rx(α)`.
fn link(theta: f64, d: f64, a: f64, alpha: f64) -> Pose {
    let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), theta);
    let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), alpha);
    Isometry3::from_parts(Translation3::from(rz * Vector3::new(a, 0.0, d)), rz * rx)
}

/// The tool flange in the base frame.
#[must_use]
pub fn forward(parameters: &UrParameters, q: &[f64; 6]) -> Pose {
    let (a, d) = (parameters.a(), parameters.d());
    (0..6).fold(Pose::identity(), |pose, i| {
        pose * link(q[i], d[i], a[i], ALPHA[i])
    })
}

/// The origins of DH frames 0 to 6 in the base frame (frame 6: the tool flange).
#[must_use]
pub fn link_points(parameters: &UrParameters, q: &[f64; 6]) -> Vec<crate::geometry::Point3> {
    let (a, d) = (parameters.a(), parameters.d());
    let mut pose = Pose::identity();
    let mut points = vec![crate::geometry::Point3::origin()];
    for i in 0..6 {
        pose *= link(q[i], d[i], a[i], ALPHA[i]);
        points.push(crate::geometry::Point3::from(pose.translation.vector));
    }
    points
}

/// Frame 5's origin in the base frame (where the flange axis meets wrist 2's axis, less `d6`).
fn wrist_point(parameters: &UrParameters, base_from_flange: &Pose) -> Vector3<f64> {
    base_from_flange.translation.vector - base_from_flange.rotation * Vector3::z() * parameters.d6
}

/// `|sin θ5|` below which axes 4 and 6 are taken as aligned: θ6 is then set to zero and the
/// others solved for it (only θ4 + θ6 is determined there).
const EXACT_WRIST_SINGULARITY: f64 = 1e-10;

/// Every solution for a flange pose, up to eight, angles in (−π, π], ignoring joint limits.
#[must_use]
pub fn inverse(
    parameters: &UrParameters,
    base_from_flange: &Pose,
) -> Vec<([f64; 6], ArmConfiguration)> {
    let p = parameters;
    let (a, d) = (p.a(), p.d());
    let p5 = wrist_point(p, base_from_flange);
    let radius = p5.x.hypot(p5.y);
    if !(radius.is_finite() && radius >= p.d4.abs()) {
        return Vec::new();
    }
    let phi = p5.y.atan2(p5.x);
    let s = (p.d4 / radius).asin();
    let m = base_from_flange.rotation.to_rotation_matrix().into_inner();
    let (x6, y6, z6) = (m.column(0), m.column(1), m.column(2));
    let mut solutions = Vec::with_capacity(8);
    for shoulder in [Shoulder::Front, Shoulder::Back] {
        let q1 = match shoulder {
            Shoulder::Front => phi + s,
            Shoulder::Back => phi + std::f64::consts::PI - s,
        };
        let z1 = Vector3::new(q1.sin(), -q1.cos(), 0.0);
        let (sx, sy, c5) = (x6.dot(&z1), y6.dot(&z1), z6.dot(&z1));
        let s5_abs = sx.hypot(sy);
        for wrist_flipped in [false, true] {
            let sign = if wrist_flipped { -1.0 } else { 1.0 };
            let q5 = (sign * s5_abs).atan2(c5);
            let q6 = if s5_abs < EXACT_WRIST_SINGULARITY {
                0.0
            } else {
                (-sign * sy).atan2(sign * sx)
            };
            // Frame 4 in frame 1, then frame 3's origin there.
            let base_from_1 = link(q1, d[0], a[0], ALPHA[0]);
            let from_4_to_6 = link(q5, d[4], a[4], ALPHA[4]) * link(q6, d[5], a[5], ALPHA[5]);
            let one_from_4 = base_from_1.inverse() * base_from_flange * from_4_to_6.inverse();
            // Frame 4's origin is frame 3's plus d4 along z3, which is frame 1's z: in
            // frame 1 their x and y agree, and those are the planar arm's reach.
            let origin4 = one_from_4.translation.vector;
            let (x, y) = (origin4.x, origin4.y);
            let r14 = one_from_4.rotation.to_rotation_matrix().into_inner();
            let q234 = r14[(1, 0)].atan2(r14[(0, 0)]);
            let cos3 = (x * x + y * y - p.a2 * p.a2 - p.a3 * p.a3) / (2.0 * p.a2 * p.a3);
            if !cos3.is_finite() || cos3.abs() > 1.0 {
                continue;
            }
            let cos3 = cos3.clamp(-1.0, 1.0);
            for elbow in [Elbow::Front, Elbow::Behind] {
                let q3 = match elbow {
                    Elbow::Front => cos3.acos(),
                    Elbow::Behind => -cos3.acos(),
                };
                let q2 = y.atan2(x) - (p.a3 * q3.sin()).atan2(p.a2 + p.a3 * q3.cos());
                let q4 = q234 - q2 - q3;
                solutions.push((
                    [wrap(q1), wrap(q2), q3, wrap(q4), wrap(q5), wrap(q6)],
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

/// The configuration of joints (what [`inverse`] labels): shoulder `Front` when frame 5's
/// origin lies on the `+x` side of frame 1 (`cos(θ1 − atan2(p5y, p5x)) ≥ 0`), elbow `Front`
/// when `sin θ3 ≥ 0`, wrist flipped when `sin θ5 < 0`.
#[must_use]
pub fn configuration_of(parameters: &UrParameters, q: &[f64; 6]) -> ArmConfiguration {
    let p5 = wrist_point(parameters, &forward(parameters, q));
    let radial = q[0].cos() * p5.x + q[0].sin() * p5.y;
    ArmConfiguration {
        shoulder: if radial >= 0.0 {
            Shoulder::Front
        } else {
            Shoulder::Back
        },
        elbow: if q[2].sin() >= 0.0 {
            Elbow::Front
        } else {
            Elbow::Behind
        },
        wrist_flipped: q[4].sin() < 0.0,
    }
}
