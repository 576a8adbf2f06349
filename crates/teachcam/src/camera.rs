//! Camera model: pinhole with OpenCV's 5-coefficient lens distortion, and epipolar geometry
//! between the cameras of a rig.
//!
//! Model (OpenCV `projectPoints`, Bradley–Conrady distortion):
//! ```text
//! X_cam = R * X_world + t                      (camera_from_world)
//! x = X/Z, y = Y/Z,  r² = x² + y²
//! x'' = x (1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2x²)
//! y'' = y (1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2y²) + 2 p2 x y
//! u = fx x'' + cx,  v = fy y'' + cy            (pixel centre of the top-left pixel = (0, 0))
//! ```
//! Undistortion inverts the distortion with Newton's method on the 2x2 system (OpenCV uses a
//! fixed-point iteration that stops after a set count); it reports when it does not converge.
//!
//! Epipolar geometry is computed in *ideal* pixels, the undistorted image `K * (x, y, 1)`:
//! there the epipolar locus of a point is a straight line, while in the distorted image it
//! is a curve. See Hartley & Zisserman, *Multiple View Geometry*, ch. 9.

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Point2, Vector2, Vector3};

use crate::geometry::{CameraId, Pixel, Point3, Pose, Ray};

/// Newton undistortion stops when the re-distorted point is this close to the input, pixels.
pub const UNDISTORT_TOLERANCE_PX: f64 = 1e-9;

/// Newton undistortion gives up after this many steps (it converges in 3–6 in practice).
const UNDISTORT_MAX_ITERATIONS: usize = 50;

/// Points closer than this to the camera's plane (z in millimetres) do not project.
const MIN_DEPTH_MM: f64 = 1e-6;

/// Focal lengths and principal point, pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
}

impl Intrinsics {
    /// The camera matrix `K`.
    #[must_use]
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// Ideal pixel of a normalised image point `(X/Z, Y/Z)`, no distortion.
    #[must_use]
    pub fn ideal_pixel(&self, normalized: &Point2<f64>) -> Pixel {
        Pixel::new(
            self.fx * normalized.x + self.cx,
            self.fy * normalized.y + self.cy,
        )
    }

    /// Normalised image point of an ideal (undistorted) pixel.
    #[must_use]
    pub fn normalized(&self, ideal: &Pixel) -> Point2<f64> {
        Point2::new((ideal.x - self.cx) / self.fx, (ideal.y - self.cy) / self.fy)
    }
}

/// OpenCV's 5-coefficient distortion `[k1, k2, p1, p2, k3]`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Distortion {
    /// Radial, r².
    pub k1: f64,
    /// Radial, r⁴.
    pub k2: f64,
    /// Tangential (decentering), first.
    pub p1: f64,
    /// Tangential (decentering), second.
    pub p2: f64,
    /// Radial, r⁶.
    pub k3: f64,
}

impl Distortion {
    /// From OpenCV's order `[k1, k2, p1, p2, k3]`.
    #[must_use]
    pub const fn from_opencv(c: [f64; 5]) -> Self {
        Self {
            k1: c[0],
            k2: c[1],
            p1: c[2],
            p2: c[3],
            k3: c[4],
        }
    }

    /// In OpenCV's order `[k1, k2, p1, p2, k3]`.
    #[must_use]
    pub const fn to_opencv(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Distorted normalised point of an undistorted one, with the 2x2 Jacobian of the map.
    #[must_use]
    pub fn apply(&self, n: &Point2<f64>) -> (Point2<f64>, Matrix2<f64>) {
        let (x, y) = (n.x, n.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r²)
        let radial_r2 = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let xd = x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y;
        let dxd_dx = radial + x * radial_r2 * 2.0 * x + 2.0 * self.p1 * y + self.p2 * 6.0 * x;
        let dxd_dy = x * radial_r2 * 2.0 * y + 2.0 * self.p1 * x + self.p2 * 2.0 * y;
        let dyd_dx = y * radial_r2 * 2.0 * x + self.p1 * 2.0 * x + 2.0 * self.p2 * y;
        let dyd_dy = radial + y * radial_r2 * 2.0 * y + self.p1 * 6.0 * y + 2.0 * self.p2 * x;
        (
            Point2::new(xd, yd),
            Matrix2::new(dxd_dx, dxd_dy, dyd_dx, dyd_dy),
        )
    }
}

/// Size of a camera's images, pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageSize {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

impl ImageSize {
    /// True when the pixel lies on the sensor (pixel centres run from 0 to size - 1, each pixel
    /// covering ±0.5 around its centre).
    #[must_use]
    pub fn contains(&self, px: &Pixel) -> bool {
        px.x >= -0.5
            && px.y >= -0.5
            && px.x < f64::from(self.width) - 0.5
            && px.y < f64::from(self.height) - 0.5
    }
}

/// Why a camera computation has no answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// Newton's iteration did not bring the re-distorted point within tolerance.
    #[error(
        "undistortion of pixel ({x:.3}, {y:.3}) did not converge (residual {residual_px:.2e} px)"
    )]
    UndistortDiverged {
        /// Pixel column.
        x: f64,
        /// Pixel row.
        y: f64,
        /// Distance from the re-distorted estimate to the pixel, pixels.
        residual_px: f64,
    },
    /// The input pixel is NaN or infinite.
    #[error("pixel ({x}, {y}) is not finite")]
    NotFinite {
        /// Pixel column.
        x: f64,
        /// Pixel row.
        y: f64,
    },
}

/// A calibrated camera: intrinsics, distortion and its place in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Name as in the rig file and the recording's sub-folder.
    pub name: String,
    /// Size of its images.
    pub image_size: ImageSize,
    /// Focal lengths and principal point.
    pub intrinsics: Intrinsics,
    /// Lens distortion.
    pub distortion: Distortion,
    /// World-to-camera extrinsics (`R`, `t` of OpenCV).
    pub camera_from_world: Pose,
}

impl Camera {
    /// The camera centre (optical centre) in world coordinates, millimetres.
    #[must_use]
    pub fn center_in_world(&self) -> Point3 {
        self.camera_from_world
            .inverse_transform_point(&Point3::origin())
    }

    /// Pixel of a point given in this camera's frame; `None` behind or on the camera's plane.
    #[must_use]
    pub fn project_from_camera(&self, point_in_camera: &Point3) -> Option<Pixel> {
        if point_in_camera.z <= MIN_DEPTH_MM
            || !point_in_camera.coords.iter().all(|v| v.is_finite())
        {
            return None;
        }
        let n = Point2::new(
            point_in_camera.x / point_in_camera.z,
            point_in_camera.y / point_in_camera.z,
        );
        Some(self.distort(&n))
    }

    /// Pixel of a world point (OpenCV `projectPoints`); `None` behind the camera. The pixel may
    /// lie outside the image: check with [`ImageSize::contains`].
    #[must_use]
    pub fn project(&self, point_in_world: &Point3) -> Option<Pixel> {
        self.project_from_camera(&self.camera_from_world.transform_point(point_in_world))
    }

    /// Distorted pixel of a normalised image point.
    #[must_use]
    pub fn distort(&self, normalized: &Point2<f64>) -> Pixel {
        let (d, _) = self.distortion.apply(normalized);
        self.intrinsics.ideal_pixel(&d)
    }

    /// Jacobian of [`Camera::project`] with respect to the world point, pixels per millimetre;
    /// `None` behind the camera.
    #[must_use]
    pub fn projection_jacobian(&self, point_in_world: &Point3) -> Option<Matrix2x3<f64>> {
        let p = self.camera_from_world.transform_point(point_in_world);
        if p.z <= MIN_DEPTH_MM {
            return None;
        }
        let inv_z = 1.0 / p.z;
        let n = Point2::new(p.x * inv_z, p.y * inv_z);
        // d(normalised)/d(point in camera)
        let dn_dp = Matrix2x3::new(
            inv_z,
            0.0,
            -p.x * inv_z * inv_z,
            0.0,
            inv_z,
            -p.y * inv_z * inv_z,
        );
        let (_, dd_dn) = self.distortion.apply(&n);
        let k = Matrix2::new(self.intrinsics.fx, 0.0, 0.0, self.intrinsics.fy);
        let rotation = self.camera_from_world.rotation.to_rotation_matrix();
        Some(k * dd_dn * dn_dp * rotation.matrix())
    }

    /// Normalised image point `(X/Z, Y/Z)` whose distorted projection is `px`: Newton's method
    /// on the distortion, to [`UNDISTORT_TOLERANCE_PX`].
    ///
    /// # Errors
    /// [`CameraError::UndistortDiverged`] when the distortion cannot be inverted there (far
    /// outside the image with strong distortion), [`CameraError::NotFinite`] for a NaN pixel.
    pub fn undistort(&self, px: &Pixel) -> Result<Point2<f64>, CameraError> {
        if !px.is_finite() {
            return Err(CameraError::NotFinite { x: px.x, y: px.y });
        }
        let target = self.intrinsics.normalized(px);
        let mut n = target;
        // Squared pixel residuals: no square root per iteration (the renderer undistorts 16
        // rays per pixel near every sphere).
        let tolerance_sq = UNDISTORT_TOLERANCE_PX * UNDISTORT_TOLERANCE_PX;
        let mut residual_sq = f64::INFINITY;
        for _ in 0..UNDISTORT_MAX_ITERATIONS {
            let (d, j) = self.distortion.apply(&n);
            let error = d - target;
            let (ex, ey) = (error.x * self.intrinsics.fx, error.y * self.intrinsics.fy);
            residual_sq = ex * ex + ey * ey;
            if residual_sq <= tolerance_sq {
                return Ok(n);
            }
            // The Newton step J⁻¹·error, the 2x2 inverse written out.
            let det = j.m11 * j.m22 - j.m12 * j.m21;
            if det == 0.0 || !det.is_finite() {
                break;
            }
            n.x -= (j.m22 * error.x - j.m12 * error.y) / det;
            n.y -= (j.m11 * error.y - j.m21 * error.x) / det;
            if !n.coords.iter().all(|v| v.is_finite()) {
                break;
            }
        }
        let residual_px = residual_sq.sqrt();
        Err(CameraError::UndistortDiverged {
            x: px.x,
            y: px.y,
            residual_px,
        })
    }

    /// Ideal (undistorted) pixel of a distorted pixel: where a pinhole camera with the same `K`
    /// would have seen the point.
    ///
    /// # Errors
    /// As [`Camera::undistort`].
    pub fn ideal_pixel(&self, px: &Pixel) -> Result<Pixel, CameraError> {
        Ok(self.intrinsics.ideal_pixel(&self.undistort(px)?))
    }

    /// The ray in world coordinates of all points that project to `px`.
    ///
    /// # Errors
    /// As [`Camera::undistort`].
    pub fn unproject(&self, px: &Pixel) -> Result<Ray, CameraError> {
        let n = self.undistort(px)?;
        let direction_in_camera = Vector3::new(n.x, n.y, 1.0);
        let direction = self
            .camera_from_world
            .rotation
            .inverse_transform_vector(&direction_in_camera);
        Ok(Ray {
            origin: self.center_in_world(),
            direction: nalgebra::Unit::new_normalize(direction),
        })
    }
}

/// A straight line `a x + b y + c = 0` in a camera's ideal pixels, with `a² + b² = 1` so that
/// [`EpipolarLine::distance`] is in pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpipolarLine {
    /// Coefficients `(a, b, c)`.
    pub coefficients: Vector3<f64>,
}

impl EpipolarLine {
    /// Distance of an ideal pixel from the line, pixels.
    #[must_use]
    pub fn distance(&self, ideal: &Pixel) -> f64 {
        let c = &self.coefficients;
        (c.x * ideal.x + c.y * ideal.y + c.z).abs()
    }
}

/// The fundamental matrix `F` with `x_to^T F x_from = 0` for ideal pixels (homogeneous) of one
/// world point seen by both cameras: `F = K_to^-T [t]x R K_from^-1`, where `(R, t)` is
/// `to_from_from`.
#[must_use]
pub fn fundamental_matrix(from: &Camera, to: &Camera) -> Matrix3<f64> {
    let to_from_from = to.camera_from_world * from.camera_from_world.inverse();
    let r = to_from_from.rotation.to_rotation_matrix();
    let t = to_from_from.translation.vector;
    let essential = t.cross_matrix() * r.matrix();
    let k_from_inv = from
        .intrinsics
        .matrix()
        .try_inverse()
        .unwrap_or_else(Matrix3::zeros);
    let k_to_inv = to
        .intrinsics
        .matrix()
        .try_inverse()
        .unwrap_or_else(Matrix3::zeros);
    k_to_inv.transpose() * essential * k_from_inv
}

/// Epipolar line in camera `to`'s ideal pixels of the ideal pixel `ideal_in_from` of camera
/// `from`, given their fundamental matrix; `None` when the line is degenerate (the pixel is the
/// epipole, or the cameras share a centre).
#[must_use]
pub fn epipolar_line(fundamental: &Matrix3<f64>, ideal_in_from: &Pixel) -> Option<EpipolarLine> {
    let l = fundamental * Vector3::new(ideal_in_from.x, ideal_in_from.y, 1.0);
    let norm = l.x.hypot(l.y);
    if norm.is_nan() || norm <= f64::EPSILON || !l.z.is_finite() {
        return None;
    }
    Some(EpipolarLine {
        coefficients: l / norm,
    })
}

/// Cameras in one world frame, each reached by its [`CameraId`] (its index in `cameras`).
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// The cameras, in the rig file's order.
    pub cameras: Vec<Camera>,
}

impl Rig {
    /// The camera of an id, `None` for an id this rig does not have.
    #[must_use]
    pub fn camera(&self, id: CameraId) -> Option<&Camera> {
        self.cameras.get(id.0)
    }

    /// Every camera with its id, in order.
    pub fn iter(&self) -> impl Iterator<Item = (CameraId, &Camera)> {
        self.cameras
            .iter()
            .enumerate()
            .map(|(i, c)| (CameraId(i), c))
    }

    /// The id of the camera with this name.
    #[must_use]
    pub fn id_of(&self, name: &str) -> Option<CameraId> {
        self.cameras
            .iter()
            .position(|c| c.name == name)
            .map(CameraId)
    }

    /// Number of cameras.
    #[must_use]
    pub fn len(&self) -> usize {
        self.cameras.len()
    }

    /// True for a rig without cameras.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.cameras.is_empty()
    }

    /// Fundamental matrices between every ordered pair of distinct cameras, `[from][to]`
    /// (zero on the diagonal).
    #[must_use]
    pub fn fundamental_matrices(&self) -> Vec<Vec<Matrix3<f64>>> {
        self.cameras
            .iter()
            .map(|from| {
                self.cameras
                    .iter()
                    .map(|to| {
                        if std::ptr::eq(from, to) {
                            Matrix3::zeros()
                        } else {
                            fundamental_matrix(from, to)
                        }
                    })
                    .collect()
            })
            .collect()
    }
}

/// A vector of two pixel coordinates, for residual arithmetic.
#[must_use]
pub fn pixel_difference(a: &Pixel, b: &Pixel) -> Vector2<f64> {
    Vector2::new(a.x - b.x, a.y - b.y)
}
