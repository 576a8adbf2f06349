//! All cameras of a rig in one world frame, from boards seen by several cameras at once,
//! then a bundle adjustment of every camera and board pose together.
//!
//! Model: board placement `v` (a "view": one instant, the board somewhere) has a pose
//! `world_from_board_v`; camera `i` sees corner `X_k` at
//! `u = project(K_i, d_i, camera_from_world_i * world_from_board_v * X_k)`.
//! 1. Each observation's `camera_from_board` from its homography (ideal pixels), refined by
//!    Levenberg–Marquardt on its own (PnP).
//! 2. The world frame is one board placement (the paper's pattern lying on the work object,
//!    §V-A: `world_from_board = I` for it) or one camera. Poses spread from it through the
//!    graph of cameras and views, breadth first:
//!    `camera_from_world = camera_from_board * board_from_world` and back.
//! 3. Bundle adjustment: LM over every camera pose (and, per camera, its intrinsics and
//!    distortion) and every board pose, the world's anchor held fixed (the gauge).
//! 4. Covariance: `Cov(θ) = σ² (JᵀJ)⁻¹` over the free parameters `θ`, `σ² = Σ r² / (2N - n)`.
//!    Intrinsics held fixed with a known covariance `Cov_K` add, to first order,
//!    `A Cov_K Aᵀ` with `A = (J_θᵀJ_θ)⁻¹ J_θᵀJ_K` (the poses' shift when `K` moves); intrinsics
//!    held fixed without one make every σ conditional on them ([`RigCalibration::conditional_on`]).
//!    A camera's rotation trades off against its principal point (a turn by `δ` about the
//!    camera's y axis moves the image like `cx` moving by `f δ`), so refining the intrinsics
//!    is what makes the rotation σ honest (Hartley & Zisserman 2004, §6.3 and App. 6).
//!
//! The world frame set by a board is the board's own: x along its rows of corners, y along
//! its columns, z = x × y, pointing into the board, away from the cameras that see it
//! (OpenCV's object frame), origin at corner 0.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector, Matrix3, SMatrix};

use crate::camera::{Camera, Rig};
use crate::geometry::{CameraId, Pixel, Point3, Pose};

use super::intrinsics::{
    CameraParams, camera_of, check_camera, check_views, params_of, point_d_pose,
    project_with_jacobian, retract_pose,
};
use super::lm::{LeastSquares, LmConfig, NormalEquations, minimize};
use super::zhang::{homography, pose_from_homography};
use super::{BoardView, CalibError};

/// One camera's view of one board placement.
#[derive(Debug, Clone, PartialEq)]
pub struct RigObservation {
    /// The camera that saw it.
    pub camera: CameraId,
    /// The board placement (the same name in every camera that saw it at that instant).
    pub view: String,
    /// One pixel per target point, in the target's order.
    pub corners: Vec<Pixel>,
}

/// The views `camera` has among `observations`, named by placement: what its own intrinsic
/// calibration starts from.
#[must_use]
pub fn views_of_camera(observations: &[RigObservation], camera: CameraId) -> Vec<BoardView> {
    observations
        .iter()
        .filter(|o| o.camera == camera)
        .map(|o| BoardView {
            name: o.view.clone(),
            corners: o.corners.clone(),
        })
        .collect()
}

/// What fixes the world frame.
#[derive(Debug, Clone, PartialEq)]
pub enum WorldFrame {
    /// The board of this placement, lying on the work object (the paper's choice).
    Board(String),
    /// This camera's frame (stereo pairs: OpenCV's `stereoCalibrate` convention).
    Camera(CameraId),
}

/// Covariance of a camera's `fx, fy, cx, cy, k1, k2, p1, p2, k3` (pixels², unitless²).
pub type IntrinsicsCovariance = SMatrix<f64, 9, 9>;

/// How the bundle adjustment treats one camera's intrinsics and distortion.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum BundleIntrinsics {
    /// Held at the camera's values and treated as exact (OpenCV's `CALIB_FIX_INTRINSIC`): every
    /// pose σ is then conditional on them and too small by their own uncertainty.
    #[default]
    Fixed,
    /// Held at the camera's values; this covariance of theirs is propagated into the pose
    /// covariance to first order.
    FixedWithCovariance(Box<IntrinsicsCovariance>),
    /// Refined with the poses, so the pose σ include the intrinsics' uncertainty.
    Refined,
}

/// Options of [`calibrate_rig`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RigConfig {
    /// Per camera, how the adjustment treats its intrinsics; a camera not listed is
    /// [`BundleIntrinsics::Fixed`]. Default: none listed, as `cv2.stereoCalibrate` with
    /// `CALIB_FIX_INTRINSIC` (`teachcam calibrate rig` refines every camera with enough views).
    pub intrinsics: BTreeMap<CameraId, BundleIntrinsics>,
    /// The optimiser's settings (defaults: [`LmConfig::default`]).
    pub lm: LmConfig,
}

impl RigConfig {
    /// Every one of `cameras` refined, the others fixed, default optimiser.
    #[must_use]
    pub fn refining(cameras: impl IntoIterator<Item = CameraId>) -> Self {
        Self {
            intrinsics: cameras
                .into_iter()
                .map(|c| (c, BundleIntrinsics::Refined))
                .collect(),
            lm: LmConfig::default(),
        }
    }

    fn treatment(&self, camera: usize) -> &BundleIntrinsics {
        self.intrinsics
            .get(&CameraId(camera))
            .unwrap_or(&BundleIntrinsics::Fixed)
    }
}

/// Residual of one camera after the bundle adjustment.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraResidual {
    /// The camera's name.
    pub name: String,
    /// RMS reprojection error of its corners, pixels.
    pub rms_px: f64,
    /// Board views it saw.
    pub views: usize,
    /// One standard error of its orientation in the world, degrees: `sqrt(trace Cov(ω))`
    /// from `σ² (JᵀJ)⁻¹` of the adjustment (0 for the camera that defines the world).
    pub rotation_std_deg: f64,
    /// One standard error of its centre in the world, millimetres: `sqrt(trace Cov(c))`.
    pub centre_std_mm: f64,
    /// Covariance of its orientation error `ω` (radians², camera frame: the estimate is
    /// `exp(ω) * R_true`, so `ω = log(R R_trueᵀ)`); zeros for the camera that defines the world.
    pub rotation_covariance: Matrix3<f64>,
    /// Covariance of its centre in the world, millimetres².
    pub centre_covariance: Matrix3<f64>,
    /// One standard error of `fx, fy, cx, cy, k1, k2, p1, p2, k3` (pixels for the first four):
    /// the adjustment's when refined, the given covariance's when fixed with one, `None` when
    /// held fixed as exact.
    pub intrinsics_std: Option<[f64; 9]>,
}

/// A calibrated rig.
#[derive(Debug, Clone, PartialEq)]
pub struct RigCalibration {
    /// The cameras in the world frame, in input order.
    pub rig: Rig,
    /// Per camera, in input order.
    pub cameras: Vec<CameraResidual>,
    /// RMS reprojection error over all corners of all cameras, pixels.
    pub rms_px: f64,
    /// Every board placement in the world frame.
    pub world_from_board: BTreeMap<String, Pose>,
    /// Joint covariance of every camera's pose, 6 rows per camera in input order: the
    /// orientation `ω` (radians, as [`CameraResidual::rotation_covariance`]) then `τ`
    /// (millimetres) of the perturbation `exp(ω, τ) * camera_from_world`; zeros for the camera
    /// that defines the world. Cameras share board poses, so their errors correlate.
    pub camera_pose_covariance: DMatrix<f64>,
    /// Cameras whose intrinsics were held fixed as exact: every σ above is conditional on
    /// them (empty when all were refined or came with a covariance).
    pub conditional_on: Vec<String>,
    /// Optimiser iterations of the bundle adjustment.
    pub iterations: usize,
    /// False when the adjustment stopped at its iteration limit rather than at a minimum.
    pub converged: bool,
}

/// Single-camera pose problem (PnP): the board pose only, the camera fixed.
struct PoseProblem<'a> {
    params: CameraParams,
    points_in_board: &'a [Point3],
    corners: &'a [Pixel],
}

impl LeastSquares for PoseProblem<'_> {
    type State = Pose;
    fn parameter_count(&self) -> usize {
        6
    }
    fn cost(&self, pose: &Pose) -> Option<f64> {
        let mut cost = 0.0;
        for (x, u) in self.points_in_board.iter().zip(self.corners) {
            let projection = project_with_jacobian(&self.params, &pose.transform_point(x))?;
            cost += (projection.pixel.x - u.x).powi(2) + (projection.pixel.y - u.y).powi(2);
        }
        Some(cost)
    }
    fn normal_equations(&self, pose: &Pose) -> Option<NormalEquations> {
        let mut equations = NormalEquations::zeros(6);
        for (x, u) in self.points_in_board.iter().zip(self.corners) {
            let p = pose.transform_point(x);
            let projection = project_with_jacobian(&self.params, &p)?;
            let d = projection.d_point * point_d_pose(&p);
            for (axis, residual) in [(0, projection.pixel.x - u.x), (1, projection.pixel.y - u.y)] {
                let row: Vec<(usize, f64)> = (0..6).map(|j| (j, d[(axis, j)])).collect();
                equations.add_row(residual, &row);
            }
        }
        Some(equations)
    }
    fn retract(&self, pose: &Pose, step: &DVector<f64>) -> Pose {
        retract_pose(pose, step, 0)
    }
}

/// `camera_from_board` of one observation: homography of the ideal pixels, then PnP.
fn board_pose(
    camera: &Camera,
    points_in_board: &[Point3],
    view: &BoardView,
) -> Result<Pose, CalibError> {
    let degenerate = || CalibError::DegenerateView {
        view: view.name.clone(),
    };
    let ideal: Vec<Pixel> = view
        .corners
        .iter()
        .map(|px| camera.ideal_pixel(px))
        .collect::<Result<_, _>>()
        .map_err(|_| degenerate())?;
    let h = homography(points_in_board, &ideal, 0).map_err(|_| degenerate())?;
    let start = pose_from_homography(&h, &camera.intrinsics).ok_or_else(degenerate)?;
    let problem = PoseProblem {
        params: params_of(&camera.intrinsics, &camera.distortion),
        points_in_board,
        corners: &view.corners,
    };
    let (pose, _) = minimize(&problem, start, &LmConfig::default()).map_err(|_| degenerate())?;
    Ok(pose)
}

/// Where each unknown of the bundle adjustment sits in the step vector.
struct Layout {
    /// Per camera: offset of its intrinsics (9 columns), if refined.
    intrinsics: Vec<Option<usize>>,
    /// Per camera: offset of its pose (6 columns), unless it is the world's anchor.
    camera_pose: Vec<Option<usize>>,
    /// Per view: offset of its pose (6 columns), unless it is the world's anchor.
    view_pose: Vec<Option<usize>>,
    count: usize,
}

impl Layout {
    /// Columns for every camera pose and view pose except the anchors', and for the
    /// intrinsics of the cameras `solved`; then those of the cameras `appended` (at the end,
    /// so the solved columns keep their places).
    fn new(
        cameras: usize,
        views: usize,
        anchor_camera: Option<usize>,
        anchor_view: Option<usize>,
        solved: impl Fn(usize) -> bool,
        appended: impl Fn(usize) -> bool,
    ) -> Self {
        let mut count = 0;
        let mut take = |n: usize| {
            let offset = count;
            count += n;
            Some(offset)
        };
        let mut intrinsics: Vec<Option<usize>> = (0..cameras)
            .map(|c| if solved(c) { take(9) } else { None })
            .collect();
        let camera_pose = (0..cameras)
            .map(|c| {
                if Some(c) == anchor_camera {
                    None
                } else {
                    take(6)
                }
            })
            .collect();
        let view_pose = (0..views)
            .map(|v| {
                if Some(v) == anchor_view {
                    None
                } else {
                    take(6)
                }
            })
            .collect();
        for (c, slot) in intrinsics.iter_mut().enumerate() {
            if appended(c) {
                *slot = take(9);
            }
        }
        Self {
            intrinsics,
            camera_pose,
            view_pose,
            count,
        }
    }
}

#[derive(Clone)]
struct RigState {
    params: Vec<CameraParams>,
    camera_from_world: Vec<Pose>,
    world_from_board: Vec<Pose>,
}

struct BundleProblem<'a> {
    points_in_board: &'a [Point3],
    /// `(camera index, view index, corners)`.
    observations: Vec<(usize, usize, &'a [Pixel])>,
    layout: Layout,
}

impl BundleProblem<'_> {
    /// Calls `each(camera, residual x, residual y, projection, point in world, point in camera)`
    /// for every corner; false when a point falls behind its camera.
    fn for_each_residual(
        &self,
        state: &RigState,
        mut each: impl FnMut(
            usize,
            usize,
            f64,
            f64,
            &super::intrinsics::ProjectionJacobian,
            &Point3,
            &Point3,
        ),
    ) -> bool {
        for &(c, v, corners) in &self.observations {
            let camera_from_world = &state.camera_from_world[c];
            let world_from_board = &state.world_from_board[v];
            for (x, u) in self.points_in_board.iter().zip(corners) {
                let q = world_from_board.transform_point(x);
                let p = camera_from_world.transform_point(&q);
                let Some(projection) = project_with_jacobian(&state.params[c], &p) else {
                    return false;
                };
                each(
                    c,
                    v,
                    projection.pixel.x - u.x,
                    projection.pixel.y - u.y,
                    &projection,
                    &q,
                    &p,
                );
            }
        }
        true
    }
}

impl LeastSquares for BundleProblem<'_> {
    type State = RigState;

    fn parameter_count(&self) -> usize {
        self.layout.count
    }

    fn cost(&self, state: &RigState) -> Option<f64> {
        let mut cost = 0.0;
        self.for_each_residual(state, |_, _, rx, ry, _, _, _| cost += rx * rx + ry * ry)
            .then_some(cost)
    }

    fn normal_equations(&self, state: &RigState) -> Option<NormalEquations> {
        let mut equations = NormalEquations::zeros(self.layout.count);
        let mut row: Vec<(usize, f64)> = Vec::with_capacity(21);
        let ok = self.for_each_residual(state, |c, v, rx, ry, projection, q, p| {
            let d_camera = projection.d_point * point_d_pose(p);
            let rotation = state.camera_from_world[c].rotation.to_rotation_matrix();
            let d_board = projection.d_point * rotation.matrix() * point_d_pose(q);
            for (axis, residual) in [(0, rx), (1, ry)] {
                row.clear();
                if let Some(offset) = self.layout.intrinsics[c] {
                    row.extend((0..9).map(|i| (offset + i, projection.d_params[(axis, i)])));
                }
                if let Some(offset) = self.layout.camera_pose[c] {
                    row.extend((0..6).map(|j| (offset + j, d_camera[(axis, j)])));
                }
                if let Some(offset) = self.layout.view_pose[v] {
                    row.extend((0..6).map(|j| (offset + j, d_board[(axis, j)])));
                }
                equations.add_row(residual, &row);
            }
        });
        ok.then_some(equations)
    }

    fn retract(&self, state: &RigState, step: &DVector<f64>) -> RigState {
        let mut next = state.clone();
        for (c, params) in next.params.iter_mut().enumerate() {
            if let Some(offset) = self.layout.intrinsics[c] {
                for (i, value) in params.iter_mut().enumerate() {
                    *value += step[offset + i];
                }
            }
        }
        for (c, pose) in next.camera_from_world.iter_mut().enumerate() {
            if let Some(offset) = self.layout.camera_pose[c] {
                *pose = retract_pose(pose, step, offset);
            }
        }
        for (v, pose) in next.world_from_board.iter_mut().enumerate() {
            if let Some(offset) = self.layout.view_pose[v] {
                *pose = retract_pose(pose, step, offset);
            }
        }
        next
    }
}

/// Calibrates the extrinsics of `cameras` (their intrinsics and distortion are the start, or
/// the answer when not refined) from `observations` of the planar target `points_in_board`.
///
/// # Errors
/// [`CalibError`]: a bad view, a camera linked to the world by no shared view, an unknown
/// world view, or a diverged bundle adjustment.
pub fn calibrate_rig(
    points_in_board: &[Point3],
    cameras: &[Camera],
    observations: &[RigObservation],
    world: &WorldFrame,
    config: &RigConfig,
) -> Result<RigCalibration, CalibError> {
    // Views by name, in sorted order (deterministic, independent of input order).
    let view_names: Vec<String> = {
        let mut names: Vec<String> = observations.iter().map(|o| o.view.clone()).collect();
        names.sort();
        names.dedup();
        names
    };
    let view_index: BTreeMap<&str, usize> = view_names
        .iter()
        .enumerate()
        .map(|(i, n)| (n.as_str(), i))
        .collect();
    let mut camera_from_board: BTreeMap<(usize, usize), Pose> = BTreeMap::new();
    for observation in observations {
        let c = observation.camera.0;
        let camera = cameras.get(c).ok_or_else(|| CalibError::UnknownCamera {
            camera: observation.camera.to_string(),
            view: observation.view.clone(),
        })?;
        let view = BoardView {
            name: format!("{} in {}", observation.view, camera.name),
            corners: observation.corners.clone(),
        };
        check_views(points_in_board, std::slice::from_ref(&view))?;
        let v = view_index[observation.view.as_str()];
        if camera_from_board.contains_key(&(c, v)) {
            return Err(CalibError::DuplicateObservation {
                camera: camera.name.clone(),
                view: observation.view.clone(),
            });
        }
        camera_from_board.insert((c, v), board_pose(camera, points_in_board, &view)?);
    }

    // Spread poses from the world's anchor through the camera–view graph.
    let mut camera_from_world: Vec<Option<Pose>> = vec![None; cameras.len()];
    let mut world_from_board: Vec<Option<Pose>> = vec![None; view_names.len()];
    let (anchor_camera, anchor_view) = match world {
        WorldFrame::Board(name) => {
            let v = *view_index
                .get(name.as_str())
                .ok_or_else(|| CalibError::UnknownWorldView { view: name.clone() })?;
            world_from_board[v] = Some(Pose::identity());
            (None, Some(v))
        }
        WorldFrame::Camera(id) => {
            if id.0 >= cameras.len() {
                return Err(CalibError::UnknownCamera {
                    camera: id.to_string(),
                    view: "the world frame".to_owned(),
                });
            }
            camera_from_world[id.0] = Some(Pose::identity());
            (Some(id.0), None)
        }
    };
    loop {
        let mut changed = false;
        for (&(c, v), pose) in &camera_from_board {
            match (camera_from_world[c], world_from_board[v]) {
                (Some(cw), None) => {
                    world_from_board[v] = Some(cw.inverse() * pose);
                    changed = true;
                }
                (None, Some(wb)) => {
                    camera_from_world[c] = Some(pose * wb.inverse());
                    changed = true;
                }
                _ => {}
            }
        }
        if !changed {
            break;
        }
    }
    let camera_from_world: Vec<Pose> = camera_from_world
        .into_iter()
        .zip(cameras)
        .map(|(pose, camera)| {
            pose.ok_or_else(|| CalibError::Unlinked {
                camera: camera.name.clone(),
            })
        })
        .collect::<Result<_, _>>()?;
    // Every view was seen by some camera, and every camera is now placed.
    let world_from_board: Vec<Pose> = world_from_board
        .into_iter()
        .map(|pose| pose.unwrap_or_else(Pose::identity))
        .collect();

    let refined = |c: usize| matches!(config.treatment(c), BundleIntrinsics::Refined);
    let layout = Layout::new(
        cameras.len(),
        view_names.len(),
        anchor_camera,
        anchor_view,
        refined,
        |_| false,
    );
    let indexed: Vec<(usize, usize, &[Pixel])> = observations
        .iter()
        .map(|o| {
            (
                o.camera.0,
                view_index[o.view.as_str()],
                o.corners.as_slice(),
            )
        })
        .collect();
    let problem = BundleProblem {
        points_in_board,
        observations: indexed.clone(),
        layout,
    };
    let start = RigState {
        params: cameras
            .iter()
            .map(|c| params_of(&c.intrinsics, &c.distortion))
            .collect(),
        camera_from_world,
        world_from_board,
    };
    let (state, report) =
        minimize(&problem, start, &config.lm).map_err(|_| CalibError::Diverged {
            detail: "a board lies behind a camera at the starting point".to_owned(),
        })?;

    let mut sums = vec![(0.0, 0usize); cameras.len()];
    problem.for_each_residual(&state, |c, _, rx, ry, _, _, _| {
        sums[c].0 += rx * rx + ry * ry;
        sums[c].1 += 1;
    });
    let total_corners: usize = sums.iter().map(|s| s.1).sum();
    let rms_px = (report.final_cost / total_corners.max(1) as f64).sqrt();
    if !rms_px.is_finite() {
        return Err(CalibError::Diverged {
            detail: "the reprojection error is not finite".to_owned(),
        });
    }
    let dof = 2.0 * total_corners as f64 - problem.layout.count as f64;
    let sigma2 = if dof > 0.0 {
        report.final_cost / dof
    } else {
        f64::NAN
    };
    let given = |c: usize| match config.treatment(c) {
        BundleIntrinsics::FixedWithCovariance(covariance) => Some(covariance.as_ref()),
        _ => None,
    };
    let covariance = if (0..cameras.len()).any(|c| given(c).is_some()) {
        // The same problem with the given intrinsics' columns appended, for J_θᵀJ_K.
        let full = BundleProblem {
            points_in_board,
            observations: indexed,
            layout: Layout::new(
                cameras.len(),
                view_names.len(),
                anchor_camera,
                anchor_view,
                refined,
                |c| given(c).is_some(),
            ),
        };
        full.normal_equations(&state).and_then(|equations| {
            let mut given_covariance = DMatrix::zeros(9 * cameras.len(), 9 * cameras.len());
            let mut columns = Vec::new();
            for c in 0..cameras.len() {
                if let (Some(offset), Some(k)) = (full.layout.intrinsics[c], given(c)) {
                    let at = columns.len();
                    columns.extend(offset..offset + 9);
                    given_covariance.view_mut((at, at), (9, 9)).copy_from(k);
                }
            }
            let given_covariance = given_covariance.view((0, 0), (columns.len(), columns.len()));
            propagated_covariance(
                &equations.jtj,
                problem.layout.count,
                sigma2,
                &given_covariance.into_owned(),
            )
        })
    } else {
        report
            .jtj
            .clone()
            .try_inverse()
            .map(|inverse| inverse * sigma2)
    };
    let mut camera_pose_covariance = DMatrix::zeros(6 * cameras.len(), 6 * cameras.len());
    for (a, offset_a) in problem.layout.camera_pose.iter().enumerate() {
        for (b, offset_b) in problem.layout.camera_pose.iter().enumerate() {
            if let (Some(oa), Some(ob)) = (offset_a, offset_b) {
                let block = covariance.as_ref().map_or_else(
                    || DMatrix::from_element(6, 6, f64::NAN),
                    |cov| cov.view((*oa, *ob), (6, 6)).into_owned(),
                );
                camera_pose_covariance
                    .view_mut((6 * a, 6 * b), (6, 6))
                    .copy_from(&block);
            }
        }
    }
    let conditional_on: Vec<String> = cameras
        .iter()
        .enumerate()
        .filter(|(c, _)| matches!(config.treatment(*c), BundleIntrinsics::Fixed))
        .map(|(_, camera)| camera.name.clone())
        .collect();
    let mut rig_cameras = Vec::with_capacity(cameras.len());
    let mut residuals = Vec::with_capacity(cameras.len());
    for (c, camera) in cameras.iter().enumerate() {
        let calibrated = camera_of(
            &state.params[c],
            &camera.name,
            camera.image_size,
            state.camera_from_world[c],
        );
        check_camera(&calibrated, camera.image_size)?;
        let pose_ok = calibrated
            .camera_from_world
            .translation
            .vector
            .iter()
            .chain(calibrated.camera_from_world.rotation.coords.iter())
            .all(|v| v.is_finite());
        if !pose_ok {
            return Err(CalibError::Diverged {
                detail: format!("the pose of camera {} is not finite", camera.name),
            });
        }
        let views = observations.iter().filter(|o| o.camera.0 == c).count();
        let block = |row: usize, column: usize| -> Matrix3<f64> {
            camera_pose_covariance
                .fixed_view::<3, 3>(6 * c + row, 6 * c + column)
                .into_owned()
        };
        let rotation_covariance = block(0, 0);
        // The centre `-Rᵀt` moves by `-Rᵀτ` under the perturbation.
        let rotation = state.camera_from_world[c].rotation.to_rotation_matrix();
        let centre_covariance = rotation.matrix().transpose() * block(3, 3) * rotation.matrix();
        let intrinsics_std = match (config.treatment(c), problem.layout.intrinsics[c]) {
            (BundleIntrinsics::Refined, Some(offset)) => Some(std::array::from_fn(|i| {
                covariance.as_ref().map_or(f64::NAN, |cov| {
                    cov[(offset + i, offset + i)].max(0.0).sqrt()
                })
            })),
            (BundleIntrinsics::FixedWithCovariance(k), _) => {
                Some(std::array::from_fn(|i| k[(i, i)].max(0.0).sqrt()))
            }
            _ => None,
        };
        residuals.push(CameraResidual {
            name: camera.name.clone(),
            rms_px: (sums[c].0 / sums[c].1.max(1) as f64).sqrt(),
            views,
            rotation_std_deg: rotation_covariance.trace().max(0.0).sqrt().to_degrees(),
            centre_std_mm: centre_covariance.trace().max(0.0).sqrt(),
            rotation_covariance,
            centre_covariance,
            intrinsics_std,
        });
        rig_cameras.push(calibrated);
    }
    Ok(RigCalibration {
        rig: Rig {
            cameras: rig_cameras,
        },
        cameras: residuals,
        rms_px,
        world_from_board: view_names.into_iter().zip(state.world_from_board).collect(),
        camera_pose_covariance,
        conditional_on,
        iterations: report.iterations,
        converged: report.converged,
    })
}

/// Covariance of the first `free` parameters: `σ² H_ff⁻¹ + A Cov_K Aᵀ`, `A = H_ff⁻¹ H_fK`, where
/// `H = JᵀJ` over the free parameters followed by the fixed intrinsics whose covariance
/// `Cov_K` is given (least squares moves `θ` by `-A δK` when `K` is off by `δK`).
fn propagated_covariance(
    jtj: &DMatrix<f64>,
    free: usize,
    sigma2: f64,
    given: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let fixed = jtj.nrows() - free;
    let inverse = jtj.view((0, 0), (free, free)).into_owned().try_inverse()?;
    let a = &inverse * jtj.view((0, free), (free, fixed));
    Some(inverse * sigma2 + &a * given * a.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two measurements `y₁ = θ + K`, `y₂ = θ` with `K` held at an estimate of variance `v`:
    /// `θ̂ = (y₁ - K + y₂) / 2`, so `Var θ̂ = σ²/2 + v/4`.
    #[test]
    fn propagated_covariance_matches_the_closed_form() {
        // Jacobian columns (θ, K): rows (1, 1) and (1, 0).
        let jtj = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 1.0]);
        let (sigma2, v) = (0.3, 0.8);
        let covariance = propagated_covariance(&jtj, 1, sigma2, &DMatrix::from_element(1, 1, v))
            .unwrap_or_else(|| panic!("singular"));
        assert!((covariance[(0, 0)] - (sigma2 / 2.0 + v / 4.0)).abs() < 1e-15);
    }
}
