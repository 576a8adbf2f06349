//! Rigid-body registration: the pose that carries the tool's model markers onto the measured
//! ones.
//!
//! The paper's SVD method (§II-C; Umeyama 1991, Arun et al. 1987): with centroids `p̂`, `p̂'`
//! and centred vectors `rᵢ = pᵢ - p̂`, `r'ᵢ = p'ᵢ - p̂'`,
//! ```text
//! M = Σ r'ᵢ rᵢᵀ = U S Vᵀ,   R = U diag(1, 1, sign det(U Vᵀ)) Vᵀ,   T = p̂' - s R p̂
//! ```
//! The determinant term makes `R` a rotation even when the best orthogonal fit is a reflection
//! (a mirrored or degenerate point set). Scale is fixed to 1 for tracking (the paper's
//! choice) or free, in which case `s = tr(diag(1,1,±1) S) / Σ|rᵢ|²` (Umeyama's least-squares
//! scale; the paper's equation 4 gives the ratio of squared norms, whose square root is the
//! right figure only for a perfect fit).

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use crate::geometry::{Point3, Pose, pose_from_parts};

/// Whether registration estimates a scale factor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    /// Scale fixed to 1: a rigid tool (the paper's choice for tracking).
    #[default]
    Fixed,
    /// Scale estimated (a similarity), e.g. to check a model's units.
    Free,
}

/// The registered pose and its fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Registration {
    /// The transform from the model's frame to the measurement's frame (`world_from_tool` when
    /// the model is the tool and the measurements are in the world).
    pub measured_from_model: Pose,
    /// Scale factor (1 with [`Scale::Fixed`]).
    pub scale: f64,
    /// RMS distance between transformed model points and measured points, millimetres.
    pub rms_mm: f64,
}

/// Why points cannot be registered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RegisterError {
    /// Fewer than three point pairs.
    #[error("{count} point pairs; registration needs 3 non-collinear")]
    TooFewPoints {
        /// Pairs given.
        count: usize,
    },
    /// Different numbers of model and measured points.
    #[error("{model} model points but {measured} measured points")]
    CountMismatch {
        /// Model points.
        model: usize,
        /// Measured points.
        measured: usize,
    },
    /// The model points are (nearly) collinear: the rotation about their line is undefined.
    #[error("model points are collinear: the rotation about their line is undefined")]
    Collinear,
    /// A coordinate is NaN or infinite.
    #[error("a point is not finite")]
    NotFinite,
}

/// Ratio of the second singular value of the centred model to the first below which the
/// points count as collinear.
const COLLINEAR_RATIO: f64 = 1e-6;

/// Registers model points onto measured points, pair by pair (`model[i]` ↔ `measured[i]`).
///
/// # Errors
/// [`RegisterError`] for fewer than three pairs, mismatched counts, non-finite or collinear
/// points.
pub fn register(
    model: &[Point3],
    measured: &[Point3],
    scale: Scale,
) -> Result<Registration, RegisterError> {
    if model.len() != measured.len() {
        return Err(RegisterError::CountMismatch {
            model: model.len(),
            measured: measured.len(),
        });
    }
    if model.len() < 3 {
        return Err(RegisterError::TooFewPoints { count: model.len() });
    }
    if model
        .iter()
        .chain(measured)
        .any(|p| !p.coords.iter().all(|v| v.is_finite()))
    {
        return Err(RegisterError::NotFinite);
    }
    let n = model.len() as f64;
    let model_centroid: Vector3<f64> = model.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let measured_centroid: Vector3<f64> =
        measured.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let mut m = Matrix3::zeros();
    let mut model_spread = Matrix3::zeros();
    let mut model_variance = 0.0;
    for (p, q) in model.iter().zip(measured) {
        let r = p.coords - model_centroid;
        let r_measured = q.coords - measured_centroid;
        m += r_measured * r.transpose();
        model_spread += r * r.transpose();
        model_variance += r.norm_squared();
    }
    let spread = model_spread.symmetric_eigenvalues();
    let (largest, middle) = {
        let mut e = [spread[0], spread[1], spread[2]];
        e.sort_by(|a, b| b.total_cmp(a));
        (e[0], e[1])
    };
    if largest <= 0.0 || middle.max(0.0).sqrt() < COLLINEAR_RATIO * largest.sqrt() {
        return Err(RegisterError::Collinear);
    }
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(RegisterError::Collinear);
    };
    let sign = (u * v_t).determinant().signum();
    let d = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, sign));
    let rotation_matrix = u * d * v_t;
    let s = match scale {
        Scale::Fixed => 1.0,
        Scale::Free => (d * Matrix3::from_diagonal(&svd.singular_values)).trace() / model_variance,
    };
    let rotation =
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rotation_matrix));
    let translation = measured_centroid - s * (rotation * model_centroid);
    let measured_from_model = pose_from_parts(translation, rotation);
    let squared: f64 = model
        .iter()
        .zip(measured)
        .map(|(p, q)| (Point3::from(s * (rotation * p.coords) + translation) - q).norm_squared())
        .sum();
    Ok(Registration {
        measured_from_model,
        scale: s,
        rms_mm: (squared / n).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn model() -> Vec<Point3> {
        [
            [0.0, 0.0, 0.0],
            [53.0, 59.0, 26.0],
            [-47.0, 6.0, 34.0],
            [45.0, -8.0, 4.0],
        ]
        .iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect()
    }

    proptest! {
        #[test]
        fn recovers_any_rigid_motion(
            axis in prop::array::uniform3(-1.0..1.0_f64),
            angle in -std::f64::consts::PI..std::f64::consts::PI,
            t in prop::array::uniform3(-2000.0..2000.0_f64),
        ) {
            let axis = nalgebra::Unit::try_new(Vector3::from(axis), 1e-3).unwrap_or(Vector3::z_axis());
            let truth = pose_from_parts(Vector3::from(t), UnitQuaternion::from_axis_angle(&axis, angle));
            let measured: Vec<Point3> = model().iter().map(|p| truth * p).collect();
            let r = register(&model(), &measured, Scale::Fixed).unwrap();
            prop_assert!(r.measured_from_model.rotation.angle_to(&truth.rotation) < 1e-9);
            prop_assert!((r.measured_from_model.translation.vector - truth.translation.vector).norm() < 1e-8);
            prop_assert!(r.rms_mm < 1e-9);
        }

        #[test]
        fn a_mirrored_input_never_gives_a_reflection(angle in -std::f64::consts::PI..std::f64::consts::PI) {
            let mirrored: Vec<Point3> = model().iter().map(|p| {
                let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), angle) * p;
                Point3::new(-q.x, q.y, q.z)
            }).collect();
            let r = register(&model(), &mirrored, Scale::Fixed).unwrap();
            let det = r.measured_from_model.rotation.to_rotation_matrix().matrix().determinant();
            prop_assert!((det - 1.0).abs() < 1e-9);
            prop_assert!(r.rms_mm > 1.0, "a mirror image cannot be fitted by a rotation");
        }
    }

    #[test]
    fn free_scale_recovers_a_similarity() {
        let truth = pose_from_parts(
            Vector3::new(10.0, -20.0, 30.0),
            UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1),
        );
        let measured: Vec<Point3> = model()
            .iter()
            .map(|p| truth * Point3::from(p.coords * 1.25))
            .collect();
        let r = register(&model(), &measured, Scale::Free).unwrap();
        assert!((r.scale - 1.25).abs() < 1e-12);
        assert!(r.rms_mm < 1e-9);
    }

    #[test]
    fn refuses_degenerate_input() {
        let line: Vec<Point3> = (0..4)
            .map(|i| Point3::new(f64::from(i) * 10.0, 0.0, 0.0))
            .collect();
        assert_eq!(
            register(&line, &line, Scale::Fixed),
            Err(RegisterError::Collinear)
        );
        assert_eq!(
            register(&model()[..2], &model()[..2], Scale::Fixed),
            Err(RegisterError::TooFewPoints { count: 2 })
        );
        assert_eq!(
            register(&model(), &model()[..3], Scale::Fixed),
            Err(RegisterError::CountMismatch {
                model: 4,
                measured: 3
            })
        );
        let mut nan = model();
        nan[1].x = f64::NAN;
        assert_eq!(
            register(&model(), &nan, Scale::Fixed),
            Err(RegisterError::NotFinite)
        );
    }
}
