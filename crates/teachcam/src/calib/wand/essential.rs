//! A camera pair's relative pose from wand correspondences: the essential matrix by the
//! normalised eight-point algorithm on undistorted normalised coordinates, refitted once on the
//! frames whose Sampson error lies within a gate measured from the fit (median + k·MAD), its
//! four decompositions told apart by the points in front of both cameras, and the baseline's
//! scale from the wand's known end-to-end length (Hartley & Zisserman 2004, §11.2, §9.6,
//! §11.4.3).

use nalgebra::{DMatrix, Matrix3, Point2, Vector3};

use crate::geometry::{Pose, pose_from_parts};
use crate::track::gates::median;

/// Corresponding normalised (undistorted, `K⁻¹`) coordinates of one frame's wand markers in
/// cameras a and b, in wand order.
pub(super) type PairFrame = (Vec<Point2<f64>>, Vec<Point2<f64>>);

/// One frame's wand in cameras a and b, b's order possibly the reverse of a's unless `fixed`
/// (both images told the ends apart).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct PairCandidate {
    /// Camera a's markers.
    pub a: Vec<Point2<f64>>,
    /// Camera b's markers.
    pub b: Vec<Point2<f64>>,
    /// Whether b's order is known to match a's.
    pub fixed: bool,
}

/// Random samples drawn by [`resolve_pairing`]: with half the frames' pairings wrong a sample
/// of four frames is all right with probability 1/16, so 600 samples miss with
/// probability (15/16)^600 ≈ 1e-17.
const PAIRING_SAMPLES: usize = 600;

/// MAD multiples of the Sampson gate of the refit.
const SAMPSON_GATE_MADS: f64 = 5.0;

/// `b_from_a` of a camera pair scaled so that the wand's ends lie `length_mm` apart; `None`
/// when the correspondences define no relative pose (too few, degenerate, no decomposition
/// with the points in front).
pub(super) fn relative_pose(frames: &[PairFrame], length_mm: f64) -> Option<Pose> {
    let all: Vec<usize> = (0..frames.len()).collect();
    let first = essential(&correspondences(frames, &all))?;
    let errors: Vec<f64> = frames
        .iter()
        .map(|(a, b)| {
            a.iter()
                .zip(b)
                .map(|(x, y)| sampson(&first, x, y))
                .fold(0.0, f64::max)
        })
        .collect();
    let gate = super::robust_gate(&errors, SAMPSON_GATE_MADS)?;
    let inliers: Vec<usize> = (0..frames.len()).filter(|&i| errors[i] <= gate).collect();
    let e = essential(&correspondences(frames, &inliers))?;
    let (rotation, direction) = decompose(&e, frames, &inliers)?;
    // Scale: the wand's end-to-end length over the unit-baseline triangulation.
    let ratios: Vec<f64> = inliers
        .iter()
        .filter_map(|&i| {
            let (a, b) = &frames[i];
            let x0 = triangulate_pair(&rotation, &direction, a.first()?, b.first()?)?;
            let x2 = triangulate_pair(&rotation, &direction, a.last()?, b.last()?)?;
            let d = (x2 - x0).norm();
            (d > 0.0).then(|| length_mm / d)
        })
        .collect();
    let scale = median(&ratios)?;
    let pose = pose_from_parts(direction * scale, rotation);
    pose.translation
        .vector
        .iter()
        .all(|v| v.is_finite())
        .then_some(pose)
}

/// The chosen frames' correspondences.
fn correspondences(frames: &[PairFrame], chosen: &[usize]) -> Vec<(Point2<f64>, Point2<f64>)> {
    chosen
        .iter()
        .flat_map(|&i| frames[i].0.iter().copied().zip(frames[i].1.iter().copied()))
        .collect()
}

/// The essential matrix of the correspondences (`y'ᵀ E x = 0`), its singular values forced
/// to `(1, 1, 0)`.
fn essential(pairs: &[(Point2<f64>, Point2<f64>)]) -> Option<Matrix3<f64>> {
    let rows = pairs.len();
    if rows < 8 {
        return None;
    }
    let mut a = DMatrix::<f64>::zeros(rows, 9);
    for (r, (x, y)) in pairs.iter().enumerate() {
        let values = [
            y.x * x.x,
            y.x * x.y,
            y.x,
            y.y * x.x,
            y.y * x.y,
            y.y,
            x.x,
            x.y,
            1.0,
        ];
        for (c, v) in values.into_iter().enumerate() {
            a[(r, c)] = v;
        }
    }
    // The null vector of A: the eigenvector of AᵀA with the smallest eigenvalue.
    let ata = a.transpose() * &a;
    let eigen = ata.symmetric_eigen();
    let smallest = eigen
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|p, q| p.1.total_cmp(q.1))?
        .0;
    let v = eigen.eigenvectors.column(smallest);
    let e = Matrix3::new(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]);
    let svd = e.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let e = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 0.0)) * v_t;
    e.iter().all(|x| x.is_finite()).then_some(e)
}

/// The largest Sampson distance of a frame's markers to `E`, b's order reversed or not.
fn frame_error(e: &Matrix3<f64>, a: &[Point2<f64>], b: &[Point2<f64>], reversed: bool) -> f64 {
    let n = b.len();
    a.iter()
        .enumerate()
        .map(|(k, x)| sampson(e, x, &b[if reversed { n - 1 - k } else { k }]))
        .fold(0.0, f64::max)
}

/// Which way round camera b sees each frame's wand relative to camera a, where the images do
/// not tell the ends apart: the essential matrix of least median error (Rousseeuw 1984, least
/// median of squares) over random samples of four frames with random pairings, each frame
/// then paired the way that fits it best. A frame whose other pairing also fits within
/// median + k·MAD of the frames' best errors (the wand in an epipolar plane) is left out.
/// Returns the frames in a's order with b matched to it and the number left out; `None` when
/// no sample defines a matrix.
pub(super) fn resolve_pairing(frames: &[PairCandidate]) -> Option<(Vec<PairFrame>, usize)> {
    use rand::{RngExt, SeedableRng};
    if frames.iter().all(|f| f.fixed) {
        return Some((
            frames.iter().map(|f| (f.a.clone(), f.b.clone())).collect(),
            0,
        ));
    }
    if frames.len() < 4 {
        return None;
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x7061_6972);
    let mut best: Option<(f64, Matrix3<f64>)> = None;
    for _ in 0..PAIRING_SAMPLES {
        let mut pairs = Vec::new();
        let mut chosen: Vec<usize> = Vec::new();
        while chosen.len() < 4 {
            let i = rng.random_range(0..frames.len());
            if !chosen.contains(&i) {
                chosen.push(i);
            }
        }
        for &i in &chosen {
            let f = &frames[i];
            let reversed = !f.fixed && rng.random_range(0..2) == 1;
            let n = f.b.len();
            for (k, x) in f.a.iter().enumerate() {
                pairs.push((*x, f.b[if reversed { n - 1 - k } else { k }]));
            }
        }
        let Some(e) = essential(&pairs) else {
            continue;
        };
        let errors: Vec<f64> = frames
            .iter()
            .map(|f| {
                let straight = frame_error(&e, &f.a, &f.b, false);
                if f.fixed {
                    straight
                } else {
                    straight.min(frame_error(&e, &f.a, &f.b, true))
                }
            })
            .collect();
        let Some(m) = median(&errors) else {
            continue;
        };
        if best.as_ref().is_none_or(|b| m < b.0) {
            best = Some((m, e));
        }
    }
    let (_, e) = best?;
    // (best error, other pairing's error, reversed) per frame.
    let fits: Vec<(f64, f64, bool)> = frames
        .iter()
        .map(|f| {
            let straight = frame_error(&e, &f.a, &f.b, false);
            if f.fixed {
                return (straight, f64::INFINITY, false);
            }
            let reversed = frame_error(&e, &f.a, &f.b, true);
            if reversed < straight {
                (reversed, straight, true)
            } else {
                (straight, reversed, false)
            }
        })
        .collect();
    let best_errors: Vec<f64> = fits.iter().map(|f| f.0).collect();
    let gate = super::robust_gate(&best_errors, SAMPSON_GATE_MADS)?;
    let mut out = Vec::new();
    let mut left_out = 0;
    for (f, (_, other, reversed)) in frames.iter().zip(fits) {
        if other <= gate {
            left_out += 1;
            continue;
        }
        let b = if reversed {
            f.b.iter().rev().copied().collect()
        } else {
            f.b.clone()
        };
        out.push((f.a.clone(), b));
    }
    Some((out, left_out))
}

/// Sampson's first-order distance of a correspondence to `E` (normalised units).
fn sampson(e: &Matrix3<f64>, x: &Point2<f64>, y: &Point2<f64>) -> f64 {
    let (xh, yh) = (Vector3::new(x.x, x.y, 1.0), Vector3::new(y.x, y.y, 1.0));
    let ex = e * xh;
    let ety = e.transpose() * yh;
    let num = yh.dot(&ex);
    let den = ex.x * ex.x + ex.y * ex.y + ety.x * ety.x + ety.y * ety.y;
    if den > 0.0 {
        num.abs() / den.sqrt()
    } else {
        f64::INFINITY
    }
}

/// The decomposition `(R, t̂)` of `E` that puts most triangulated points in front of both
/// cameras (`x_b = R x_a + t̂`, `|t̂| = 1`).
fn decompose(
    e: &Matrix3<f64>,
    frames: &[PairFrame],
    chosen: &[usize],
) -> Option<(nalgebra::UnitQuaternion<f64>, Vector3<f64>)> {
    let svd = e.svd(true, true);
    let (mut u, mut v_t) = (svd.u?, svd.v_t?);
    if u.determinant() < 0.0 {
        u = -u;
    }
    if v_t.determinant() < 0.0 {
        v_t = -v_t;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let t = u.column(2).into_owned();
    let mut best: Option<(usize, Matrix3<f64>, Vector3<f64>)> = None;
    for r in [u * w * v_t, u * w.transpose() * v_t] {
        for sign in [1.0, -1.0] {
            let t = t * sign;
            let rotation = nalgebra::Rotation3::from_matrix_unchecked(r);
            let q = nalgebra::UnitQuaternion::from_rotation_matrix(&rotation);
            let in_front = chosen
                .iter()
                .flat_map(|&i| frames[i].0.iter().zip(&frames[i].1))
                .filter(|(x, y)| {
                    triangulate_pair(&q, &t, x, y).is_some_and(|p| p.z > 0.0 && (r * p + t).z > 0.0)
                })
                .count();
            if best.as_ref().is_none_or(|b| in_front > b.0) {
                best = Some((in_front, r, t));
            }
        }
    }
    let (in_front, r, t) = best?;
    // A majority in front, or the pair is degenerate (all points at infinity, a pure turn).
    let points: usize = chosen.iter().map(|&i| frames[i].0.len()).sum();
    if in_front * 2 <= points {
        return None;
    }
    let rotation = nalgebra::Rotation3::from_matrix_unchecked(r);
    Some((nalgebra::UnitQuaternion::from_rotation_matrix(&rotation), t))
}

/// The midpoint of the two rays of a correspondence, camera a's frame.
fn triangulate_pair(
    rotation: &nalgebra::UnitQuaternion<f64>,
    t: &Vector3<f64>,
    x: &Point2<f64>,
    y: &Point2<f64>,
) -> Option<nalgebra::Point3<f64>> {
    // Ray a: s·da from the origin; ray b: centre c_b = -Rᵀt, direction Rᵀ·db.
    let da = Vector3::new(x.x, x.y, 1.0).normalize();
    let db = (rotation.inverse() * Vector3::new(y.x, y.y, 1.0)).normalize();
    let cb = -(rotation.inverse() * t);
    let (a, b, c) = (da.dot(&da), da.dot(&db), db.dot(&db));
    let (d, e) = (da.dot(&cb), db.dot(&cb));
    let den = a * c - b * b;
    if den.abs() < 1e-12 {
        return None;
    }
    let s = (c * d - b * e) / den;
    let u = (b * d - a * e) / den;
    let pa = da * s;
    let pb = cb + db * u;
    Some(nalgebra::Point3::from((pa + pb) * 0.5))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// Points seen by two known cameras give back their relative pose and the scale.
    #[test]
    fn recovers_a_known_relative_pose() {
        let b_from_a = pose_from_parts(
            Vector3::new(-400.0, 30.0, 120.0),
            UnitQuaternion::from_euler_angles(0.05, 0.6, -0.1),
        );
        let mut frames = Vec::new();
        for k in 0..30 {
            let t = f64::from(k);
            let start = nalgebra::Point3::new(
                100.0 * (0.3 * t).sin(),
                80.0 * (0.7 * t).cos(),
                1000.0 + 90.0 * (0.5 * t).sin(),
            );
            let d =
                Vector3::new((0.4 * t).cos(), (0.9 * t).sin(), 0.3 * (0.2 * t).cos()).normalize();
            let points = [start, start + d * 160.0, start + d * 500.0];
            let project = |p: nalgebra::Point3<f64>| Point2::new(p.x / p.z, p.y / p.z);
            frames.push((
                points.map(project).to_vec(),
                points.map(|p| project(b_from_a * p)).to_vec(),
            ));
        }
        let found = relative_pose(&frames, 500.0).unwrap_or_else(|| panic!("no pose"));
        let translation_error = (found.translation.vector - b_from_a.translation.vector).norm();
        let angle = found.rotation.angle_to(&b_from_a.rotation);
        assert!(translation_error < 1e-6, "{translation_error} mm");
        assert!(angle < 1e-9, "{angle} rad");
    }
}
