//! One camera's intrinsics from views of a planar target: Zhang's closed form, then
//! Levenberg–Marquardt over `fx, fy, cx, cy, k1, k2, p1, p2, k3` and every board pose.
//!
//! Residual of corner `k` in view `v`: `project(K, d, camera_from_board_v * X_k) - u_vk`
//! (the model of [`crate::camera`]). RMS errors are OpenCV's: `sqrt(Σ |residual|² / N)` over
//! the `N` corners, so they compare one to one with `cv2.calibrateCamera`'s return value.
//! Standard errors come from `σ² (JᵀJ)⁻¹` with `σ² = Σ r² / (2N - parameters)`.

use nalgebra::{DVector, Isometry3, Matrix2x3, Matrix3, SMatrix, Vector3};

use crate::camera::{Camera, Distortion, ImageSize, Intrinsics};
use crate::geometry::{Pixel, Point3, Pose};

use super::lm::{LeastSquares, LmConfig, NormalEquations, minimize};
use super::zhang::{ZhangError, homography, intrinsics_from_homographies, pose_from_homography};
use super::{BoardView, CalibError};

/// Camera parameters in the optimiser's order: `fx, fy, cx, cy, k1, k2, p1, p2, k3`.
pub(crate) type CameraParams = [f64; 9];

/// Parameter vector of a camera's intrinsics and distortion.
pub(crate) fn params_of(intrinsics: &Intrinsics, distortion: &Distortion) -> CameraParams {
    let [k1, k2, p1, p2, k3] = distortion.to_opencv();
    [
        intrinsics.fx,
        intrinsics.fy,
        intrinsics.cx,
        intrinsics.cy,
        k1,
        k2,
        p1,
        p2,
        k3,
    ]
}

/// The camera of a parameter vector.
pub(crate) fn camera_of(
    params: &CameraParams,
    name: &str,
    image_size: ImageSize,
    camera_from_world: Pose,
) -> Camera {
    Camera {
        name: name.to_owned(),
        image_size,
        intrinsics: Intrinsics {
            fx: params[0],
            fy: params[1],
            cx: params[2],
            cy: params[3],
        },
        distortion: Distortion::from_opencv([
            params[4], params[5], params[6], params[7], params[8],
        ]),
        camera_from_world,
    }
}

/// A projected pixel with its derivatives.
pub(crate) struct ProjectionJacobian {
    pub pixel: Pixel,
    /// d pixel / d camera parameters.
    pub d_params: SMatrix<f64, 2, 9>,
    /// d pixel / d point in the camera frame.
    pub d_point: Matrix2x3<f64>,
}

/// Projection of a point in the camera frame and its Jacobians; `None` behind the camera.
pub(crate) fn project_with_jacobian(
    params: &CameraParams,
    point_in_camera: &Point3,
) -> Option<ProjectionJacobian> {
    let p = point_in_camera;
    if p.z.is_nan() || p.z <= 1e-9 {
        return None;
    }
    let [fx, fy, _, _, k1, k2, p1, p2, k3] = *params;
    let inv_z = 1.0 / p.z;
    let (x, y) = (p.x * inv_z, p.y * inv_z);
    let distortion = Distortion::from_opencv([k1, k2, p1, p2, k3]);
    let (d, dd_dn) = distortion.apply(&nalgebra::Point2::new(x, y));
    let pixel = Pixel::new(fx * d.x + params[2], fy * d.y + params[3]);
    let r2 = x * x + y * y;
    let (r4, r6) = (r2 * r2, r2 * r2 * r2);
    #[rustfmt::skip]
    let d_params = SMatrix::<f64, 2, 9>::from_row_slice(&[
        d.x, 0.0, 1.0, 0.0, fx * x * r2, fx * x * r4, fx * 2.0 * x * y, fx * (r2 + 2.0 * x * x), fx * x * r6,
        0.0, d.y, 0.0, 1.0, fy * y * r2, fy * y * r4, fy * (r2 + 2.0 * y * y), fy * 2.0 * x * y, fy * y * r6,
    ]);
    let dn_dp = Matrix2x3::new(inv_z, 0.0, -x * inv_z, 0.0, inv_z, -y * inv_z);
    let k = nalgebra::Matrix2::new(fx, 0.0, 0.0, fy);
    let d_point = k * dd_dn * dn_dp;
    Some(ProjectionJacobian {
        pixel,
        d_params,
        d_point,
    })
}

/// d point / d (ω, τ) for the left perturbation `exp(ω, τ) * pose` of a point `p` it produced:
/// `[-[p]×, I]`.
pub(crate) fn point_d_pose(p: &Point3) -> SMatrix<f64, 3, 6> {
    let mut m = SMatrix::<f64, 3, 6>::zeros();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-Vector3::new(p.x, p.y, p.z).cross_matrix()));
    m.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&Matrix3::identity());
    m
}

/// `exp(ω, τ) * pose` for the 6 entries of `step` starting at `at`.
pub(crate) fn retract_pose(pose: &Pose, step: &DVector<f64>, at: usize) -> Pose {
    let omega = Vector3::new(step[at], step[at + 1], step[at + 2]);
    let tau = Vector3::new(step[at + 3], step[at + 4], step[at + 5]);
    Isometry3::new(tau, omega) * pose
}

/// Options of [`calibrate_intrinsics`].
#[derive(Debug, Clone, PartialEq)]
pub struct IntrinsicsConfig {
    /// Keep `k3 = 0` (OpenCV's `CALIB_FIX_K3`); false, as `cv2.calibrateCamera`'s default.
    pub fix_k3: bool,
    /// Keep `p1 = p2 = 0` (`CALIB_ZERO_TANGENT_DIST`); false, as OpenCV's default.
    pub fix_tangential: bool,
    /// Keep `fy / fx` at the closed form's ratio (`CALIB_FIX_ASPECT_RATIO`); false.
    pub fix_aspect_ratio: bool,
    /// A view whose RMS exceeds this multiple of the median view RMS is named an outlier; 3.
    pub outlier_rms_factor: f64,
    /// The optimiser's settings.
    pub lm: LmConfig,
}

impl Default for IntrinsicsConfig {
    fn default() -> Self {
        Self {
            fix_k3: false,
            fix_tangential: false,
            fix_aspect_ratio: false,
            outlier_rms_factor: 3.0,
            lm: LmConfig::default(),
        }
    }
}

/// Residual of one view after calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewResidual {
    /// The view's name (its image file).
    pub name: String,
    /// RMS reprojection error of its corners, pixels.
    pub rms_px: f64,
    /// Where the board was: `camera_from_board`.
    pub camera_from_board: Pose,
}

/// A calibrated camera and how well it fits.
#[derive(Debug, Clone, PartialEq)]
pub struct IntrinsicCalibration {
    /// The camera (extrinsics identity; name empty, for the caller to set).
    pub camera: Camera,
    /// RMS reprojection error over all corners, pixels (OpenCV's definition).
    pub rms_px: f64,
    /// Per view, in input order.
    pub views: Vec<ViewResidual>,
    /// Names of views whose RMS exceeds `outlier_rms_factor` × the median.
    pub outlier_views: Vec<String>,
    /// One standard error of `fx, fy, cx, cy, k1, k2, p1, p2, k3` (0 for fixed ones).
    pub standard_errors: [f64; 9],
    /// Their covariance, `σ² (JᵀJ)⁻¹` with the board poses marginalised (zero rows and columns
    /// for fixed ones; NaN when `JᵀJ` is singular): what a rig calibration holding these
    /// intrinsics fixed propagates ([`super::rig::BundleIntrinsics::FixedWithCovariance`]).
    pub covariance: SMatrix<f64, 9, 9>,
    /// Optimiser iterations.
    pub iterations: usize,
    /// False when the optimiser stopped at its iteration limit rather than at a minimum.
    pub converged: bool,
}

/// Least squares over the camera parameters (along `directions`) and every board pose.
struct IntrinsicsProblem<'a> {
    points_in_board: &'a [Point3],
    views: &'a [BoardView],
    /// Each free camera-parameter column as a direction in parameter space.
    directions: Vec<CameraParams>,
}

#[derive(Clone)]
struct IntrinsicsState {
    params: CameraParams,
    camera_from_board: Vec<Pose>,
}

impl IntrinsicsProblem<'_> {
    fn residuals_of_view(
        &self,
        state: &IntrinsicsState,
        v: usize,
        mut each: impl FnMut(f64, f64, Option<&ProjectionJacobian>, &Point3),
    ) -> bool {
        let pose = &state.camera_from_board[v];
        for (x, observed) in self.points_in_board.iter().zip(&self.views[v].corners) {
            let p = pose.transform_point(x);
            let Some(projection) = project_with_jacobian(&state.params, &p) else {
                return false;
            };
            each(
                projection.pixel.x - observed.x,
                projection.pixel.y - observed.y,
                Some(&projection),
                &p,
            );
        }
        true
    }
}

impl LeastSquares for IntrinsicsProblem<'_> {
    type State = IntrinsicsState;

    fn parameter_count(&self) -> usize {
        self.directions.len() + 6 * self.views.len()
    }

    fn cost(&self, state: &IntrinsicsState) -> Option<f64> {
        let mut cost = 0.0;
        for v in 0..self.views.len() {
            if !self.residuals_of_view(state, v, |rx, ry, _, _| cost += rx * rx + ry * ry) {
                return None;
            }
        }
        Some(cost)
    }

    fn normal_equations(&self, state: &IntrinsicsState) -> Option<NormalEquations> {
        let n_dir = self.directions.len();
        let mut equations = NormalEquations::zeros(self.parameter_count());
        let mut row: Vec<(usize, f64)> = Vec::with_capacity(n_dir + 6);
        for v in 0..self.views.len() {
            let offset = n_dir + 6 * v;
            let ok = self.residuals_of_view(state, v, |rx, ry, projection, p| {
                let Some(projection) = projection else { return };
                let d_pose = projection.d_point * point_d_pose(p);
                for (axis, residual) in [(0, rx), (1, ry)] {
                    row.clear();
                    for (c, direction) in self.directions.iter().enumerate() {
                        let value: f64 = (0..9)
                            .map(|i| projection.d_params[(axis, i)] * direction[i])
                            .sum();
                        row.push((c, value));
                    }
                    for j in 0..6 {
                        row.push((offset + j, d_pose[(axis, j)]));
                    }
                    equations.add_row(residual, &row);
                }
            });
            if !ok {
                return None;
            }
        }
        Some(equations)
    }

    fn retract(&self, state: &IntrinsicsState, step: &DVector<f64>) -> IntrinsicsState {
        let mut params = state.params;
        for (c, direction) in self.directions.iter().enumerate() {
            for i in 0..9 {
                params[i] += step[c] * direction[i];
            }
        }
        let n_dir = self.directions.len();
        let camera_from_board = state
            .camera_from_board
            .iter()
            .enumerate()
            .map(|(v, pose)| retract_pose(pose, step, n_dir + 6 * v))
            .collect();
        IntrinsicsState {
            params,
            camera_from_board,
        }
    }
}

/// Checks the target is planar (z = 0) and every view has one pixel per target point.
pub(crate) fn check_views(
    points_in_board: &[Point3],
    views: &[BoardView],
) -> Result<(), CalibError> {
    if let Some(k) = points_in_board
        .iter()
        .position(|p| p.z != 0.0 || !p.coords.iter().all(|v| v.is_finite()))
    {
        return Err(CalibError::NotPlanar { point: k });
    }
    for view in views {
        if view.corners.len() != points_in_board.len() {
            return Err(CalibError::CornerCount {
                view: view.name.clone(),
                found: view.corners.len(),
                expected: points_in_board.len(),
            });
        }
        if let Some(k) = view.corners.iter().position(|p| !p.is_finite()) {
            return Err(CalibError::NotFinite {
                view: view.name.clone(),
                corner: k,
            });
        }
    }
    Ok(())
}

/// `camera_from_board` of each view by Zhang's closed form, for the given intrinsics.
pub(crate) fn initial_poses(
    points_in_board: &[Point3],
    views: &[BoardView],
    intrinsics: &Intrinsics,
) -> Result<Vec<Pose>, CalibError> {
    views
        .iter()
        .enumerate()
        .map(|(v, view)| {
            let h =
                homography(points_in_board, &view.corners, v).map_err(|e| zhang_error(e, views))?;
            pose_from_homography(&h, intrinsics).ok_or_else(|| CalibError::DegenerateView {
                view: view.name.clone(),
            })
        })
        .collect()
}

pub(crate) fn zhang_error(error: ZhangError, views: &[BoardView]) -> CalibError {
    let name = |v: usize| {
        views
            .get(v)
            .map_or_else(String::new, |view| view.name.clone())
    };
    match error {
        ZhangError::TooFewCorners { view, .. } | ZhangError::DegenerateHomography { view } => {
            CalibError::DegenerateView { view: name(view) }
        }
        ZhangError::TooFewViews { views, needed } => CalibError::TooFewViews { views, needed },
        ZhangError::DegenerateViews => CalibError::DegenerateViews,
    }
}

/// Calibrates one camera from `views` of the planar target `points_in_board` (z = 0).
///
/// # Errors
/// [`CalibError`]: fewer than 3 views, a view with the wrong number of corners, degenerate
/// views (all parallel), or an optimisation that ends with non-finite or absurd parameters.
pub fn calibrate_intrinsics(
    points_in_board: &[Point3],
    views: &[BoardView],
    image_size: ImageSize,
    config: &IntrinsicsConfig,
) -> Result<IntrinsicCalibration, CalibError> {
    const MIN_VIEWS: usize = 3;
    if views.len() < MIN_VIEWS {
        return Err(CalibError::TooFewViews {
            views: views.len(),
            needed: MIN_VIEWS,
        });
    }
    check_views(points_in_board, views)?;
    let homographies = views
        .iter()
        .enumerate()
        .map(|(v, view)| homography(points_in_board, &view.corners, v))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| zhang_error(e, views))?;
    let intrinsics =
        intrinsics_from_homographies(&homographies).map_err(|e| zhang_error(e, views))?;
    let camera_from_board = initial_poses(points_in_board, views, &intrinsics)?;
    let start = IntrinsicsState {
        params: params_of(&intrinsics, &Distortion::default()),
        camera_from_board,
    };

    let mut directions: Vec<CameraParams> = Vec::new();
    let unit = |i: usize| {
        let mut d = [0.0; 9];
        d[i] = 1.0;
        d
    };
    if config.fix_aspect_ratio {
        let mut d = unit(0);
        d[1] = intrinsics.fy / intrinsics.fx;
        directions.push(d);
    } else {
        directions.push(unit(0));
        directions.push(unit(1));
    }
    directions.extend([2, 3, 4, 5].map(unit));
    if !config.fix_tangential {
        directions.extend([6, 7].map(unit));
    }
    if !config.fix_k3 {
        directions.push(unit(8));
    }
    let problem = IntrinsicsProblem {
        points_in_board,
        views,
        directions,
    };
    let (state, report) =
        minimize(&problem, start, &config.lm).map_err(|_| CalibError::Diverged {
            detail: "residuals not finite at Zhang's starting point".to_owned(),
        })?;

    let camera = camera_of(&state.params, "", image_size, Pose::identity());
    check_camera(&camera, image_size)?;
    let corner_count = (views.len() * points_in_board.len()) as f64;
    let rms_px = (report.final_cost / corner_count).sqrt();
    let mut view_residuals = Vec::with_capacity(views.len());
    for (v, view) in views.iter().enumerate() {
        let mut cost = 0.0;
        problem.residuals_of_view(&state, v, |rx, ry, _, _| cost += rx * rx + ry * ry);
        view_residuals.push(ViewResidual {
            name: view.name.clone(),
            rms_px: (cost / points_in_board.len() as f64).sqrt(),
            camera_from_board: state.camera_from_board[v],
        });
    }
    if !rms_px.is_finite() {
        return Err(CalibError::Diverged {
            detail: "the reprojection error is not finite".to_owned(),
        });
    }
    let outlier_views = outliers(&view_residuals, config.outlier_rms_factor);

    let dof = 2.0 * corner_count - problem.parameter_count() as f64;
    let sigma2 = if dof > 0.0 {
        report.final_cost / dof
    } else {
        f64::NAN
    };
    // Cov(params) = D Cov(directions) Dᵀ, D holding one free direction per column.
    let mut covariance = SMatrix::<f64, 9, 9>::from_element(f64::NAN);
    if let Some(inverse) = report.jtj.clone().try_inverse() {
        for i in 0..9 {
            for j in 0..9 {
                let mut value = 0.0;
                for (a, da) in problem.directions.iter().enumerate() {
                    for (b, db) in problem.directions.iter().enumerate() {
                        value += da[i] * db[j] * inverse[(a, b)];
                    }
                }
                covariance[(i, j)] = value * sigma2;
            }
        }
    }
    let standard_errors: [f64; 9] = std::array::from_fn(|i| {
        let variance = covariance[(i, i)];
        if variance.is_nan() {
            0.0
        } else {
            variance.max(0.0).sqrt()
        }
    });
    Ok(IntrinsicCalibration {
        camera,
        rms_px,
        views: view_residuals,
        outlier_views,
        standard_errors,
        covariance,
        iterations: report.iterations,
        converged: report.converged,
    })
}

/// Names of views whose RMS exceeds `factor` × the median view RMS.
pub(crate) fn outliers(views: &[ViewResidual], factor: f64) -> Vec<String> {
    let mut rms: Vec<f64> = views.iter().map(|v| v.rms_px).collect();
    rms.sort_by(f64::total_cmp);
    let median = rms.get(rms.len() / 2).copied().unwrap_or(0.0);
    views
        .iter()
        .filter(|v| v.rms_px > factor * median)
        .map(|v| v.name.clone())
        .collect()
}

/// Refuses a camera with non-finite or impossible parameters (a diverged optimisation).
pub(crate) fn check_camera(camera: &Camera, image_size: ImageSize) -> Result<(), CalibError> {
    let params = params_of(&camera.intrinsics, &camera.distortion);
    if !params.iter().all(|v| v.is_finite()) {
        return Err(CalibError::Diverged {
            detail: "a camera parameter is not finite".to_owned(),
        });
    }
    let Intrinsics { fx, fy, cx, cy } = camera.intrinsics;
    let (w, h) = (f64::from(image_size.width), f64::from(image_size.height));
    let plausible =
        fx > 0.0 && fy > 0.0 && (-w..=2.0 * w).contains(&cx) && (-h..=2.0 * h).contains(&cy);
    if !plausible {
        return Err(CalibError::Diverged {
            detail: format!(
                "fx = {fx:.1}, fy = {fy:.1}, cx = {cx:.1}, cy = {cy:.1} px is not a camera for a {}x{} image",
                image_size.width, image_size.height
            ),
        });
    }
    Ok(())
}
