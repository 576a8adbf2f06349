//! From the centre of a sphere's image to the projection of the sphere's centre.
//!
//! Model. The rays from the camera centre tangent to a sphere of radius `R` at distance `D`
//! form a circular cone around the direction to the sphere's centre, of half-angle
//! `α = asin(R / D)`. If that direction makes the angle `θ` with the optical axis, the cone
//! cuts the normalised image plane `z = 1` in an ellipse whose major axis points away from the
//! principal point, with (`s = sin α`, `Δ = cos²θ − s²`):
//! ```text
//! centre  m = sin θ cos θ / Δ        (the sphere centre projects to t = tan θ < m)
//! axes    a = s cos α / Δ,   b = s / √Δ,   area π a b = π s² cos α / Δ^{3/2}
//! ```
//! Solving the first line for `t` gives `m s² t² + t − m (1 − s²) = 0`, whose root is taken
//! in the cancellation-free form `t = 2 m (1 − s²) / (1 + √(1 + 4 m² s² (1 − s²)))`. The
//! offset `m − t ≈ t (1 + t²) s²` is 0.025 px for a 10 mm sphere at 1 m in the corner of the
//! paper's 1790 px camera, and grows as `1 / D²`.
//!
//! `s` is exact when the distance is known ([`SphereRange::DistanceMm`], e.g. from
//! triangulation); from the image alone ([`SphereRange::ApparentRadiusPx`]) it follows from the
//! ellipse's area by a short fixed-point iteration (`s²` is tiny, so it converges in a few
//! steps). Lens distortion is handled by working on undistorted normalised coordinates and
//! treating the measured centre as the distorted image of the ellipse's centre (exact to the
//! second order of the distortion across the blob). Source: Matsuoka & Maruyama, ISPRS 2016;
//! Heikkilä, *Geometric camera calibration using circular control points*, TPAMI 2000.

use crate::camera::{Camera, CameraError};
use crate::geometry::Pixel;

/// Fixed-point steps from the apparent size; each gains a factor `s²` (< 10⁻³) in accuracy.
const APPARENT_SIZE_ITERATIONS: usize = 4;

/// What fixes the sphere's angular size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SphereRange {
    /// Distance from the camera centre to the sphere's centre, millimetres (exact).
    DistanceMm(f64),
    /// The blob's equal-area radius `√(area / π)`, pixels (from the image alone).
    ApparentRadiusPx(f64),
}

/// The pixel where the centre of a sphere of `radius_mm` projects, from the measured centre
/// of its image `ellipse_center` (a centroid of the blob). Returns the input unchanged when the
/// range is not a positive finite number or the sphere would enclose the camera.
///
/// # Errors
/// [`CameraError`] when the pixel cannot be undistorted.
pub fn sphere_center_pixel(
    camera: &Camera,
    ellipse_center: &Pixel,
    radius_mm: f64,
    range: SphereRange,
) -> Result<Pixel, CameraError> {
    let n = camera.undistort(ellipse_center)?;
    let m = n.coords.norm();
    let valid = |v: f64| v.is_finite() && v > 0.0;
    if m == 0.0 || !valid(radius_mm) {
        return Ok(*ellipse_center);
    }
    let s2 = match range {
        SphereRange::DistanceMm(d) if valid(d) && radius_mm < d => (radius_mm / d).powi(2),
        SphereRange::ApparentRadiusPx(r) if valid(r) => {
            // Normalised area: pixel area over fx·fy·det(distortion Jacobian).
            let (_, jacobian) = camera.distortion.apply(&n);
            let scale = camera.intrinsics.fx * camera.intrinsics.fy * jacobian.determinant();
            if !valid(scale) {
                return Ok(*ellipse_center);
            }
            let area_over_pi = r * r / scale;
            let mut s2 = 0.0;
            let mut t = m;
            for _ in 0..APPARENT_SIZE_ITERATIONS {
                let delta = 1.0 / (1.0 + t * t) - s2;
                if !valid(delta) {
                    return Ok(*ellipse_center);
                }
                s2 = area_over_pi * delta.powf(1.5) / (1.0 - s2).sqrt();
                if s2.is_nan() || s2 >= 1.0 {
                    return Ok(*ellipse_center);
                }
                t = tangent_of_center(m, s2);
            }
            s2
        }
        _ => return Ok(*ellipse_center),
    };
    let t = tangent_of_center(m, s2);
    let corrected = n * (t / m);
    Ok(camera.distort(&corrected))
}

/// `tan θ` of the sphere's centre from the ellipse centre's distance `m` from the principal
/// point (normalised) and `s² = sin² α` (module docs).
fn tangent_of_center(m: f64, s2: f64) -> f64 {
    2.0 * m * (1.0 - s2) / (1.0 + (1.0 + 4.0 * m * m * s2 * (1.0 - s2)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Distortion, ImageSize, Intrinsics};
    use crate::geometry::{Point3, Pose, Vec3};
    use nalgebra::{DMatrix, Point2};

    fn paper_camera(distortion: Distortion) -> Camera {
        Camera {
            name: "cam0".into(),
            image_size: ImageSize {
                width: 1280,
                height: 1024,
            },
            intrinsics: Intrinsics {
                fx: 1790.0,
                fy: 1790.0,
                cx: 639.5,
                cy: 511.5,
            },
            distortion,
            camera_from_world: Pose::identity(),
        }
    }

    /// The silhouette of a sphere on `z = 1`, from first principles: the circle of tangency
    /// (points `P` on the sphere with `(P − C)·P = 0`) projected centrally. Then the conic
    /// through those points is fitted (least squares, exact here since they lie on one) and
    /// its centre and area read off. Independent of the closed forms in the module.
    fn silhouette_ellipse(center: &Point3, radius: f64) -> (Point2<f64>, f64) {
        let c = center.coords;
        let d = c.norm();
        let axis = c / d;
        // The tangency circle: centre at distance (d² − R²)/d along the axis, radius R·√(d²−R²)/d.
        let along = (d * d - radius * radius) / d;
        let ring = radius * (d * d - radius * radius).sqrt() / d;
        let u = axis.cross(&Vec3::x()).normalize();
        let v = axis.cross(&u);
        let points: Vec<Point2<f64>> = (0..64)
            .map(|k| {
                let phi = std::f64::consts::TAU * f64::from(k) / 64.0;
                let p = axis * along + (u * phi.cos() + v * phi.sin()) * ring;
                Point2::new(p.x / p.z, p.y / p.z)
            })
            .collect();
        // Conic A x² + B xy + C y² + D x + E y + F = 0: null vector of the design matrix.
        let design = DMatrix::from_fn(points.len(), 6, |r, col| {
            let (x, y) = (points[r].x, points[r].y);
            [x * x, x * y, y * y, x, y, 1.0][col]
        });
        let svd = design.svd(false, true);
        let v_t = svd.v_t.unwrap();
        let q = v_t.row(5);
        let (a, b, cc, dd, e, f) = (q[0], q[1], q[2], q[3], q[4], q[5]);
        let det = 4.0 * a * cc - b * b;
        let x0 = (b * e - 2.0 * cc * dd) / det;
        let y0 = (b * dd - 2.0 * a * e) / det;
        // Area of the ellipse: 2π |value at centre| / √det, with the value F' = conic(x0, y0).
        let f0 = a * x0 * x0 + b * x0 * y0 + cc * y0 * y0 + dd * x0 + e * y0 + f;
        let area = 2.0 * std::f64::consts::PI * f0.abs() / det.sqrt();
        (Point2::new(x0, y0), area)
    }

    #[test]
    fn exact_range_recovers_the_centre_projection_against_the_fitted_silhouette() {
        for distortion in [
            Distortion::default(),
            Distortion::from_opencv([-0.1, 0.05, 0.001, -0.0005, 0.0]),
        ] {
            let camera = paper_camera(distortion);
            for center in [
                Point3::new(300.0, -240.0, 700.0),
                Point3::new(-40.0, 10.0, 1000.0),
                Point3::new(250.0, 200.0, 400.0),
            ] {
                let radius = 5.0;
                let (ellipse_center, area) = silhouette_ellipse(&center, radius);
                let measured = camera.distort(&ellipse_center);
                let truth = camera.project(&center).unwrap();
                let d = center.coords.norm();
                let exact =
                    sphere_center_pixel(&camera, &measured, radius, SphereRange::DistanceMm(d))
                        .unwrap();
                assert!(exact.distance(&truth) < 1e-7, "{exact:?} vs {truth:?}");
                // The bias being corrected is real and of the predicted size.
                assert!(measured.distance(&truth) > 1e-3);
                // From the apparent size: area in pixels as the image shows it (no distortion
                // here, so the area is the normalised area times fx·fy).
                if distortion == Distortion::default() {
                    let radius_px = (area * 1790.0 * 1790.0 / std::f64::consts::PI).sqrt();
                    let apparent = sphere_center_pixel(
                        &camera,
                        &measured,
                        radius,
                        SphereRange::ApparentRadiusPx(radius_px),
                    )
                    .unwrap();
                    assert!(
                        apparent.distance(&truth) < 1e-7,
                        "{apparent:?} vs {truth:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn on_axis_and_degenerate_inputs_leave_the_centre() {
        let camera = paper_camera(Distortion::default());
        let principal = Pixel::new(639.5, 511.5);
        let out =
            sphere_center_pixel(&camera, &principal, 5.0, SphereRange::DistanceMm(800.0)).unwrap();
        assert_eq!(out, principal);
        let p = Pixel::new(10.0, 20.0);
        for range in [
            SphereRange::DistanceMm(f64::NAN),
            SphereRange::DistanceMm(3.0),
            SphereRange::ApparentRadiusPx(-1.0),
        ] {
            assert_eq!(sphere_center_pixel(&camera, &p, 5.0, range).unwrap(), p);
        }
        assert!(
            sphere_center_pixel(
                &camera,
                &Pixel::new(f64::NAN, 0.0),
                5.0,
                SphereRange::DistanceMm(800.0)
            )
            .is_err()
        );
    }
}
