//! Rotations on SO(3): unrolled into a vector space, smoothed there, rolled back onto the
//! trajectory's own rotations.
//!
//! Model (in the spirit of Jupp & Kent 1987, "Fitting smooth paths to spherical data"):
//! the path of rotations `R_k` is unrolled into `v_0 = 0`, `v_k = v_{k-1} + log(R_{k-1}⁻¹ R_k)`,
//! the sum of the body-frame increments (rotation vectors, radians). Any linear smoother `S`
//! that keeps constants (every one here: Butterworth, splines, Bezier, B-splines) is applied to
//! `v`, and each rotation is moved by its own correction: `R̂_k = R_k · exp(S(v)_k - v_k)`.
//!
//! Why this form: `S(v)_k - v_k = Σ_j s_kj (v_j - v_k)` depends only on increments between
//! nearby samples, so a large rotation is never taken through one global tangent space and
//! never distorted; for rotations about one fixed axis `v` is exactly the unwrapped angle and
//! the result is exactly the scalar smoother applied to that angle; the output is a unit
//! quaternion by construction, and the hemisphere of the input quaternions plays no role (the
//! increment `log` takes the shortest rotation, `|θ| ≤ π`).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rayon::prelude::*;

/// The rotation vector (axis × angle, radians, angle in `[0, π]`) of `q`, accurate near zero
/// where `acos` of the scalar part loses digits.
#[must_use]
pub fn log(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let q = q.quaternion();
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.vector().into_owned())
    } else {
        (q.w, q.vector().into_owned())
    };
    let sin_half = v.norm();
    if sin_half < 1e-300 {
        return 2.0 * v;
    }
    let angle = 2.0 * sin_half.atan2(w);
    v * (angle / sin_half)
}

/// The rotation of rotation vector `v` (radians).
#[must_use]
pub fn exp(v: &Vector3<f64>) -> UnitQuaternion<f64> {
    let angle = v.norm();
    let half = 0.5 * angle;
    // sin(x/2)/x, with its series near zero.
    let scale = if angle < 1e-8 {
        0.5 - angle * angle / 48.0
    } else {
        half.sin() / angle
    };
    UnitQuaternion::new_unchecked(Quaternion::from_parts(half.cos(), v * scale))
}

/// Unrolls a path of rotations: `v_0 = 0`, `v_k = v_{k-1} + log(R_{k-1}⁻¹ R_k)`.
#[must_use]
pub fn unroll(rotations: &[UnitQuaternion<f64>]) -> Vec<Vector3<f64>> {
    // The steps' logarithms side by side (each stands alone), summed in order.
    let steps: Vec<Vector3<f64>> = rotations
        .par_windows(2)
        .map(|w| log(&(w[0].inverse() * w[1])))
        .collect();
    let mut out = Vec::with_capacity(rotations.len());
    let mut sum = Vector3::zeros();
    if !rotations.is_empty() {
        out.push(sum);
    }
    for step in &steps {
        sum += step;
        out.push(sum);
    }
    out
}

/// Moves each rotation by its smoothed correction: `R_k · exp(smoothed_k - unrolled_k)`.
#[must_use]
pub fn roll_back(
    rotations: &[UnitQuaternion<f64>],
    unrolled: &[Vector3<f64>],
    smoothed: &[Vector3<f64>],
) -> Vec<UnitQuaternion<f64>> {
    rotations
        .iter()
        .zip(unrolled.iter().zip(smoothed))
        .map(|(r, (v, s))| corrected(r, v, s))
        .collect()
}

/// One rotation moved by its smoothed correction: `R · exp(smoothed - unrolled)`.
#[must_use]
pub fn corrected(
    rotation: &UnitQuaternion<f64>,
    unrolled: &Vector3<f64>,
    smoothed: &Vector3<f64>,
) -> UnitQuaternion<f64> {
    rotation * exp(&(smoothed - unrolled))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_and_exp_are_inverse_up_to_pi() {
        for angle in [0.0, 1e-12, 1e-6, 0.3, 2.0, 3.1] {
            let v = Vector3::new(0.3, -0.5, 0.81).normalize() * angle;
            let back = log(&exp(&v));
            assert!((back - v).norm() < 1e-14, "{angle}: {back} vs {v}");
            let nalgebra = UnitQuaternion::from_scaled_axis(v);
            assert!(exp(&v).angle_to(&nalgebra) < 1e-15);
        }
    }

    #[test]
    fn unrolling_a_fixed_axis_gives_the_unwrapped_angle() {
        // Three full turns about one axis: the unrolled path is the angle itself, past ±π.
        let axis = Vector3::new(1.0, 2.0, -2.0).normalize();
        let angles: Vec<f64> = (0..200).map(|k| 0.1 * k as f64 - 0.5).collect();
        let rotations: Vec<_> = angles
            .iter()
            .map(|a| UnitQuaternion::from_scaled_axis(axis * *a))
            .collect();
        let v = unroll(&rotations);
        for (vk, a) in v.iter().zip(&angles) {
            assert!((vk - axis * (a - angles[0])).norm() < 1e-12);
        }
        let back = roll_back(&rotations, &v, &v);
        for (a, b) in back.iter().zip(&rotations) {
            assert!(a.angle_to(b) < 1e-12);
        }
    }
}
