//! Zhang's closed-form calibration from plane homographies (Zhang 2000, §3.1, and appendix A).
//!
//! A board point `(X, Y, 0)` and its ideal pixel satisfy `s (u, v, 1)ᵀ = H (X, Y, 1)ᵀ` with
//! `H = K [r1 r2 t]`. Since `r1 ⟂ r2` and `|r1| = |r2|`, each view gives two linear
//! constraints on `B = K⁻ᵀ K⁻¹`: `h1ᵀ B h2 = 0` and `h1ᵀ B h1 = h2ᵀ B h2`. With `n ≥ 3`
//! views (or 2 with zero skew imposed) `B`, hence `K`, follows from the null vector of
//! `V b = 0`. Each board pose then follows from `K⁻¹ H`, made a rotation by SVD.
//!
//! Distortion is ignored here: the result only starts the Levenberg–Marquardt refinement in
//! [`super::intrinsics`].

use nalgebra::{DMatrix, Matrix3, Rotation3, SVD, UnitQuaternion, Vector3, Vector6};

use crate::camera::Intrinsics;
use crate::geometry::{Pixel, Point3, Pose, pose_from_parts};

/// Why the closed form has no answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ZhangError {
    /// A homography needs at least four board corners.
    #[error("view {view}: {count} corners, a homography needs at least 4")]
    TooFewCorners {
        /// Index of the view in the input.
        view: usize,
        /// Corners given.
        count: usize,
    },
    /// The corners of a view do not determine a homography (collinear, or not finite).
    #[error("view {view}: the corners do not determine a homography (collinear or not finite)")]
    DegenerateHomography {
        /// Index of the view in the input.
        view: usize,
    },
    /// Too few views for the unknowns.
    #[error("{views} views of the board, calibration needs at least {needed}")]
    TooFewViews {
        /// Views given.
        views: usize,
        /// Views needed.
        needed: usize,
    },
    /// The views constrain the camera matrix in too few directions: boards all parallel, or
    /// all seen head-on.
    #[error(
        "the board views are degenerate (all parallel to each other or to the image): the camera matrix is not determined"
    )]
    DegenerateViews,
}

/// Homography `H` with `ideal pixel ~ H (X, Y, 1)` from board points (z = 0) and pixels:
/// normalised DLT (Hartley & Zisserman, alg. 4.2).
///
/// # Errors
/// [`ZhangError`] for fewer than 4 points or a degenerate configuration.
pub fn homography(
    points_in_board: &[Point3],
    pixels: &[Pixel],
    view: usize,
) -> Result<Matrix3<f64>, ZhangError> {
    let n = points_in_board.len().min(pixels.len());
    if n < 4 {
        return Err(ZhangError::TooFewCorners { view, count: n });
    }
    let degenerate = ZhangError::DegenerateHomography { view };
    let board: Vec<(f64, f64)> = points_in_board[..n].iter().map(|p| (p.x, p.y)).collect();
    let image: Vec<(f64, f64)> = pixels[..n].iter().map(|p| (p.x, p.y)).collect();
    let t_board = normalising_transform(&board).ok_or_else(|| degenerate.clone())?;
    let t_image = normalising_transform(&image).ok_or_else(|| degenerate.clone())?;
    let mut a = DMatrix::zeros(2 * n, 9);
    for (k, (b, i)) in board.iter().zip(&image).enumerate() {
        let p = t_board * Vector3::new(b.0, b.1, 1.0);
        let q = t_image * Vector3::new(i.0, i.1, 1.0);
        let (x, y) = (p.x / p.z, p.y / p.z);
        let (u, v) = (q.x / q.z, q.y / q.z);
        let r0 = [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u];
        let r1 = [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y, -v];
        for c in 0..9 {
            a[(2 * k, c)] = r0[c];
            a[(2 * k + 1, c)] = r1[c];
        }
    }
    let h = null_vector(a).ok_or_else(|| degenerate.clone())?;
    let normalised = Matrix3::from_row_slice(h.as_slice());
    let t_image_inv = t_image.try_inverse().ok_or_else(|| degenerate.clone())?;
    let mut result = t_image_inv * normalised * t_board;
    let scale = result[(2, 2)];
    if !result.iter().all(|v| v.is_finite()) || scale.abs() <= f64::EPSILON {
        return Err(degenerate);
    }
    result /= scale;
    Ok(result)
}

/// Similarity that moves the centroid to 0 and the mean distance to √2.
fn normalising_transform(points: &[(f64, f64)]) -> Option<Matrix3<f64>> {
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(sx, sy), p| (sx + p.0 / n, sy + p.1 / n));
    let mean_distance = points
        .iter()
        .map(|p| (p.0 - mx).hypot(p.1 - my))
        .sum::<f64>()
        / n;
    if !mean_distance.is_finite() || mean_distance <= 0.0 {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / mean_distance;
    Some(Matrix3::new(
        s,
        0.0,
        -s * mx,
        0.0,
        s,
        -s * my,
        0.0,
        0.0,
        1.0,
    ))
}

/// Unit vector minimising `|A x|`: the right singular vector of the smallest singular value.
fn null_vector(a: DMatrix<f64>) -> Option<nalgebra::DVector<f64>> {
    let columns = a.ncols();
    // Work on AᵀA (columns x columns) so the SVD is small and always yields all of V.
    let ata = a.transpose() * a;
    let svd = SVD::new(ata, false, true);
    let v_t = svd.v_t?;
    let (index, _) = svd
        .singular_values
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let v = v_t.row(index).transpose();
    (v.len() == columns && v.iter().all(|x| x.is_finite())).then_some(v)
}

/// The row `v_ij` of Zhang's equation (appendix A): `h_iᵀ B h_j = v_ijᵀ b`.
fn v_row(h: &Matrix3<f64>, i: usize, j: usize) -> Vector6<f64> {
    let hi = h.column(i);
    let hj = h.column(j);
    Vector6::new(
        hi[0] * hj[0],
        hi[0] * hj[1] + hi[1] * hj[0],
        hi[1] * hj[1],
        hi[2] * hj[0] + hi[0] * hj[2],
        hi[2] * hj[1] + hi[1] * hj[2],
        hi[2] * hj[2],
    )
}

/// Intrinsics from three or more homographies, skew forced to zero (the model has none).
///
/// # Errors
/// [`ZhangError::TooFewViews`] below 2 views, [`ZhangError::DegenerateViews`] when the views
/// do not determine `K` (the conditioning of `V` is checked, not just its rank).
pub fn intrinsics_from_homographies(
    homographies: &[Matrix3<f64>],
) -> Result<Intrinsics, ZhangError> {
    if homographies.len() < 2 {
        return Err(ZhangError::TooFewViews {
            views: homographies.len(),
            needed: 2,
        });
    }
    // Scale each homography so that pixels and board units do not unbalance the rows.
    let rows = 2 * homographies.len() + 1;
    let mut v = DMatrix::zeros(rows, 6);
    for (k, h) in homographies.iter().enumerate() {
        let h = h / h.norm();
        let v12 = v_row(&h, 0, 1);
        let d = v_row(&h, 0, 0) - v_row(&h, 1, 1);
        for c in 0..6 {
            v[(2 * k, c)] = v12[c];
            v[(2 * k + 1, c)] = d[c];
        }
    }
    // Zero skew: B12 = 0.
    let weight = v.norm() / (rows as f64).sqrt();
    v[(rows - 1, 1)] = weight;

    let ata = v.transpose() * &v;
    let svd = SVD::new(ata, false, false);
    let mut singular: Vec<f64> = svd.singular_values.iter().copied().collect();
    singular.sort_by(|a, b| b.total_cmp(a));
    // b is a null vector of V: the second smallest singular value must stand clear of zero.
    if singular[4].is_nan() || singular[4] <= 1e-12 * singular[0] {
        return Err(ZhangError::DegenerateViews);
    }
    let b = null_vector(v).ok_or(ZhangError::DegenerateViews)?;
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let denominator = b11 * b22 - b12 * b12;
    let tiny = f64::EPSILON * b11.abs().max(b22.abs()).powi(2);
    if denominator.is_nan() || denominator.abs() <= tiny || b11 == 0.0 {
        return Err(ZhangError::DegenerateViews);
    }
    let cy = (b12 * b13 - b11 * b23) / denominator;
    let lambda = b33 - (b13 * b13 + cy * (b12 * b13 - b11 * b23)) / b11;
    let fx2 = lambda / b11;
    let fy2 = lambda * b11 / denominator;
    if !(fx2 > 0.0 && fy2 > 0.0) {
        return Err(ZhangError::DegenerateViews);
    }
    let fx = fx2.sqrt();
    let fy = fy2.sqrt();
    let skew = -b12 * fx * fx * fy / lambda;
    let cx = skew * cy / fy - b13 * fx * fx / lambda;
    let intrinsics = Intrinsics { fx, fy, cx, cy };
    if [fx, fy, cx, cy].iter().all(|v| v.is_finite()) {
        Ok(intrinsics)
    } else {
        Err(ZhangError::DegenerateViews)
    }
}

/// `camera_from_board` from a homography and the intrinsics (Zhang 2000, §3.1), with the
/// rotation made orthonormal by SVD and the board in front of the camera.
#[must_use]
pub fn pose_from_homography(homography: &Matrix3<f64>, intrinsics: &Intrinsics) -> Option<Pose> {
    let k_inv = intrinsics.matrix().try_inverse()?;
    let m = k_inv * homography;
    let mut scale = 1.0 / m.column(0).norm();
    // The board origin must lie in front of the camera (t_z > 0).
    if m[(2, 2)] * scale < 0.0 {
        scale = -scale;
    }
    let r1 = m.column(0) * scale;
    let r2 = m.column(1) * scale;
    let t = m.column(2) * scale;
    let r3 = r1.cross(&r2);
    let q = Matrix3::from_columns(&[r1, r2, r3]);
    let svd = SVD::new(q, true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        r = -r;
    }
    if !r.iter().chain(t.iter()).all(|v| v.is_finite()) {
        return None;
    }
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Some(pose_from_parts(Vector3::new(t[0], t[1], t[2]), rotation))
}
