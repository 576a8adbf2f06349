//! Frames, rigid transforms, points, pixels, rays and ids.
//!
//! Model: a rigid transform `a_from_b` maps coordinates given in frame `b` into frame `a`,
//! `x_a = a_from_b * x_b`, so chains read right to left and inner names cancel:
//! `world_from_tip = world_from_tool * tool_from_tip`. Transforms are [`Pose`]
//! (`nalgebra::Isometry3<f64>`); lengths are millimetres, angles radians.
//!
//! Quaternions are Hamilton, unit, written `(qw, qx, qy, qz)` as ABB RAPID writes them, with
//! `qw >= 0` unless continuity along a trajectory asks for the other sign
//! ([`Quat::continuous_with`]).

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// A 3-D point in millimetres. The frame is in the variable's name (`marker_in_world`).
pub type Point3 = nalgebra::Point3<f64>;

/// A 3-D direction or displacement in millimetres.
pub type Vec3 = Vector3<f64>;

/// A rigid transform `a_from_b` (rotation then translation, millimetres).
pub type Pose = Isometry3<f64>;

/// A position on a camera's sensor in pixels, OpenCV's convention: the centre of the top-left
/// pixel is `(0, 0)`, x to the right, y down. Never a plain vector: a pixel is not a length.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pixel {
    /// Column coordinate, pixels.
    pub x: f64,
    /// Row coordinate, pixels.
    pub y: f64,
}

impl Pixel {
    /// A pixel position.
    #[must_use]
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Euclidean distance to another pixel, in pixels.
    #[must_use]
    pub fn distance(&self, other: &Pixel) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }

    /// True when both coordinates are finite numbers.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

/// A half-line in 3-D: `origin + s * direction` for `s >= 0`, `direction` of unit length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Where the ray starts (a camera centre), millimetres.
    pub origin: Point3,
    /// Unit direction.
    pub direction: nalgebra::Unit<Vec3>,
}

impl Ray {
    /// The point at distance `s` millimetres along the ray.
    #[must_use]
    pub fn at(&self, s: f64) -> Point3 {
        self.origin + self.direction.into_inner() * s
    }
}

/// Identifies a camera of a rig: its index in the rig's camera list, which never changes once
/// the rig is loaded. Observations are keyed by it, never by position in another list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct CameraId(pub usize);

/// Identifies a marker of a tool: its index in the tool file's `markers` list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct MarkerId(pub usize);

/// A 0-based frame number in the recording's order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct FrameIndex(pub usize);

impl std::fmt::Display for CameraId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "camera {}", self.0)
    }
}

impl std::fmt::Display for MarkerId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "marker {}", self.0)
    }
}

impl std::fmt::Display for FrameIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "frame {}", self.0)
    }
}

/// A unit quaternion in the contract's written form `(qw, qx, qy, qz)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quat {
    /// Scalar part.
    pub w: f64,
    /// Vector part, x.
    pub x: f64,
    /// Vector part, y.
    pub y: f64,
    /// Vector part, z.
    pub z: f64,
}

/// Tolerance on `|q| - 1` for a quaternion read from a file to count as unit.
pub const UNIT_QUATERNION_TOLERANCE: f64 = 1e-6;

impl Quat {
    /// The written form of a rotation, with `qw >= 0`.
    #[must_use]
    pub fn from_rotation(rotation: &UnitQuaternion<f64>) -> Self {
        let q = rotation.quaternion();
        let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
        Self {
            w: sign * q.w,
            x: sign * q.i,
            y: sign * q.j,
            z: sign * q.k,
        }
    }

    /// The rotation, when the four numbers are finite and of unit norm within
    /// [`UNIT_QUATERNION_TOLERANCE`] (then renormalised); `None` otherwise.
    #[must_use]
    pub fn to_rotation(&self) -> Option<UnitQuaternion<f64>> {
        let q = Quaternion::new(self.w, self.x, self.y, self.z);
        let norm = q.norm();
        if !norm.is_finite() || (norm - 1.0).abs() > UNIT_QUATERNION_TOLERANCE {
            return None;
        }
        Some(UnitQuaternion::from_quaternion(q))
    }

    /// This quaternion or its negative (the same rotation), whichever is closer to `previous`,
    /// so that a sequence stays on one hemisphere along time.
    #[must_use]
    pub fn continuous_with(&self, previous: &Quat) -> Self {
        let dot =
            self.w * previous.w + self.x * previous.x + self.y * previous.y + self.z * previous.z;
        if dot < 0.0 {
            Self {
                w: -self.w,
                x: -self.x,
                y: -self.y,
                z: -self.z,
            }
        } else {
            *self
        }
    }

    /// The four numbers in written order.
    #[must_use]
    pub const fn to_array(&self) -> [f64; 4] {
        [self.w, self.x, self.y, self.z]
    }
}

/// A pose from a translation in millimetres and a rotation.
#[must_use]
pub fn pose_from_parts(translation: Vec3, rotation: UnitQuaternion<f64>) -> Pose {
    Isometry3::from_parts(Translation3::from(translation), rotation)
}

/// Angle in radians of the relative rotation between two poses (0 for equal rotations),
/// computed from quaternions, which stays accurate near zero where a rotation-matrix trace
/// formula loses digits.
#[must_use]
pub fn rotation_angle_between(a: &Pose, b: &Pose) -> f64 {
    a.rotation.angle_to(&b.rotation)
}

/// Error of a 3x3 matrix read from a file as a rotation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RotationError {
    /// Some entry is NaN or infinite.
    #[error("rotation has a non-finite entry")]
    NotFinite,
    /// `R^T R` is not the identity within tolerance.
    #[error("rotation is not orthonormal (|R^T R - I| = {deviation:.2e})")]
    NotOrthonormal {
        /// Largest absolute entry of `R^T R - I`.
        deviation: f64,
    },
    /// The determinant is -1: a reflection, not a rotation.
    #[error("rotation has determinant {determinant:.6}, not +1 (a reflection)")]
    Reflection {
        /// The determinant found.
        determinant: f64,
    },
}

/// Tolerance on the entries of `R^T R - I` for a matrix read from a file (six printed digits
/// leave about 1e-6 of error).
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-5;

/// A rotation from a row-major 3x3 matrix, checked for finiteness, orthonormality and `det = +1`,
/// then projected onto SO(3) so that printed digits do not accumulate.
///
/// # Errors
/// [`RotationError`] when the matrix is not a rotation within [`ORTHONORMAL_TOLERANCE`].
pub fn rotation_from_rows(rows: &[[f64; 3]; 3]) -> Result<UnitQuaternion<f64>, RotationError> {
    if rows.iter().flatten().any(|v| !v.is_finite()) {
        return Err(RotationError::NotFinite);
    }
    let m = nalgebra::Matrix3::from_fn(|r, c| rows[r][c]);
    let deviation = (m.transpose() * m - nalgebra::Matrix3::identity())
        .abs()
        .max();
    if deviation > ORTHONORMAL_TOLERANCE {
        return Err(RotationError::NotOrthonormal { deviation });
    }
    let determinant = m.determinant();
    if determinant < 0.0 {
        return Err(RotationError::Reflection { determinant });
    }
    let rotation =
        nalgebra::Rotation3::from_matrix_eps(&m, 1e-12, 100, nalgebra::Rotation3::identity());
    Ok(UnitQuaternion::from_rotation_matrix(&rotation))
}

/// The row-major 3x3 matrix of a rotation, as rig files write it.
#[must_use]
pub fn rotation_rows(rotation: &UnitQuaternion<f64>) -> [[f64; 3]; 3] {
    let m = rotation.to_rotation_matrix();
    let m = m.matrix();
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}

/// Why a pose written as text was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseTextError {
    /// Not seven comma-separated numbers.
    #[error(
        "expected 7 comma-separated numbers x,y,z,qw,qx,qy,qz (mm and a unit quaternion), got '{0}'"
    )]
    Shape(String),
    /// The quaternion is not of unit length.
    #[error(
        "quaternion qw,qx,qy,qz of '{text}' has norm {norm:.6}: expected a unit quaternion, norm 1 within {QUATERNION_NORM_TOLERANCE} (3 decimals are enough)"
    )]
    NotUnit {
        /// The text given.
        text: String,
        /// Its quaternion's norm.
        norm: f64,
    },
}

/// How far from 1 the norm of a quaternion given as text may be: a unit quaternion rounded
/// to three decimals (`0.707,0,0,0.707`, norm 0.99985) is off by at most 1e-3. It is
/// renormalised: the rotation moves by at most about 0.1°, what the rounding itself did.
pub const QUATERNION_NORM_TOLERANCE: f64 = 2e-3;

/// A pose from the text `x,y,z,qw,qx,qy,qz` (millimetres, then a unit quaternion within
/// [`QUATERNION_NORM_TOLERANCE`], renormalised), the form of the `--pose`, `--wobj` and
/// `--tcp` flags.
///
/// # Errors
/// [`PoseTextError`] quoting the text.
pub fn parse_pose(text: &str) -> Result<Pose, PoseTextError> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| PoseTextError::Shape(text.to_string()))?;
    let [x, y, z, qw, qx, qy, qz] = values[..] else {
        return Err(PoseTextError::Shape(text.to_string()));
    };
    if ![x, y, z].iter().all(|v| v.is_finite()) {
        return Err(PoseTextError::Shape(text.to_string()));
    }
    let q = Quaternion::new(qw, qx, qy, qz);
    let norm = q.norm();
    if !norm.is_finite() || (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
        return Err(PoseTextError::NotUnit {
            text: text.to_string(),
            norm,
        });
    }
    Ok(pose_from_parts(
        Vec3::new(x, y, z),
        UnitQuaternion::from_quaternion(q),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn quaternion_written_form_has_nonnegative_w() {
        let r = UnitQuaternion::from_euler_angles(0.3, -2.9, 1.0);
        let q = Quat::from_rotation(&r);
        assert!(q.w >= 0.0);
        let back = q.to_rotation().unwrap();
        assert_relative_eq!(back.angle_to(&r), 0.0, epsilon = 1e-9);
    }

    #[test]
    fn pose_text_parses_and_refuses() {
        let p = parse_pose("1, 2, 3, 0.7071068, 0, 0, 0.7071068").unwrap();
        assert_relative_eq!(p.translation.vector, Vec3::new(1.0, 2.0, 3.0));
        assert_relative_eq!(
            p.rotation.angle(),
            std::f64::consts::FRAC_PI_2,
            epsilon = 1e-6
        );
        assert!(matches!(
            parse_pose("1,2,3,1,0,0"),
            Err(PoseTextError::Shape(_))
        ));
        assert!(matches!(
            parse_pose("1,2,3,1,0,0,x"),
            Err(PoseTextError::Shape(_))
        ));
        assert!(matches!(
            parse_pose("1,2,3,2,0,0,0"),
            Err(PoseTextError::NotUnit { .. })
        ));
        // Rounded to three decimals: accepted, renormalised.
        let rounded = parse_pose("0,0,0,0.707,0,0,0.707").unwrap();
        assert_relative_eq!(
            rounded.rotation.angle(),
            std::f64::consts::FRAC_PI_2,
            epsilon = 1e-9
        );
        let message = parse_pose("0,0,0,0.9,0,0,0.1").unwrap_err().to_string();
        assert!(
            message.contains("norm 0.905539") && message.contains("within 0.002"),
            "{message}"
        );
        assert!(matches!(
            parse_pose("nan,2,3,1,0,0,0"),
            Err(PoseTextError::Shape(_))
        ));
    }

    #[test]
    fn non_unit_quaternion_is_refused() {
        assert!(
            Quat {
                w: 1.0,
                x: 0.1,
                y: 0.0,
                z: 0.0
            }
            .to_rotation()
            .is_none()
        );
        assert!(
            Quat {
                w: f64::NAN,
                x: 0.0,
                y: 0.0,
                z: 0.0
            }
            .to_rotation()
            .is_none()
        );
    }

    #[test]
    fn continuity_flips_to_the_previous_hemisphere() {
        let a = Quat {
            w: 0.1,
            x: 0.99498743710662,
            y: 0.0,
            z: 0.0,
        };
        let b = Quat {
            w: 0.05,
            x: -0.99874921777191,
            y: 0.0,
            z: 0.0,
        };
        let c = b.continuous_with(&a);
        assert!(c.w < 0.0 && c.x > 0.0);
    }

    #[test]
    fn rotation_rows_round_trip_and_checks() {
        let r = UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3);
        let rows = rotation_rows(&r);
        let back = rotation_from_rows(&rows).unwrap();
        assert_relative_eq!(back.angle_to(&r), 0.0, epsilon = 1e-9);
        let mirrored = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(matches!(
            rotation_from_rows(&mirrored),
            Err(RotationError::Reflection { .. })
        ));
        let skewed = [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(matches!(
            rotation_from_rows(&skewed),
            Err(RotationError::NotOrthonormal { .. })
        ));
        let nan = [[f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(rotation_from_rows(&nan), Err(RotationError::NotFinite));
    }
}
