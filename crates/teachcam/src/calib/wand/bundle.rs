//! The wand bundle adjustment: every camera's extrinsics (the reference camera fixed: the
//! gauge) and every frame's wand pose, the wand's marker positions along its axis fixed (the
//! scale), intrinsics fixed.
//!
//! A frame's wand is 5 DOF (a collinear wand has no roll): marker 0 at `s` and the unit axis
//! `d`, marker k at `s + p_k d`. The wand poses are eliminated by variable projection
//! (Golub & Pereyra 1973; Kaufman's approximation): for given cameras each frame's wand is the
//! least-squares pose of its own views (a 5-parameter Levenberg–Marquardt), and the outer
//! Levenberg–Marquardt ([`super::super::lm`]) steps the cameras along the Schur complement
//! `S = A_cc − A_cw A_ww⁻¹ A_wc` of the full normal equations, with the reduced gradient
//! `g = b_c − A_cw A_ww⁻¹ b_w` (Triggs et al. 2000, *Bundle adjustment — a modern synthesis*,
//! §6.1). `S⁻¹ σ²` is then the cameras' marginal covariance.

use nalgebra::{DVector, Matrix3, SMatrix, SVector, Unit, Vector3};

use super::super::intrinsics::{CameraParams, point_d_pose, project_with_jacobian, retract_pose};
use super::super::lm::{LeastSquares, LmConfig, LmReport, NormalEquations, minimize};
use crate::geometry::{Pixel, Point3, Pose};

/// One frame's wand: marker 0's position and the axis towards marker 2, reference frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct WandPose {
    /// Marker 0, millimetres.
    pub start: Point3,
    /// Unit axis.
    pub axis: Unit<Vector3<f64>>,
}

impl WandPose {
    /// Marker at `position_mm` along the axis.
    pub fn marker(&self, position_mm: f64) -> Point3 {
        self.start + self.axis.into_inner() * position_mm
    }
}

/// Two unit vectors completing `axis` to an orthonormal basis (a fixed function of the axis,
/// so the Jacobian and the retraction use the same one).
fn basis(axis: &Unit<Vector3<f64>>) -> (Vector3<f64>, Vector3<f64>) {
    let a = axis.into_inner();
    let helper = if a.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = a.cross(&helper).normalize();
    let e2 = a.cross(&e1);
    (e1, e2)
}

/// `pose ⊞ step` for the 5 entries of `step` from `at`.
fn retract_wand(pose: &WandPose, step: &DVector<f64>, at: usize) -> WandPose {
    let (e1, e2) = basis(&pose.axis);
    WandPose {
        start: pose.start + Vector3::new(step[at], step[at + 1], step[at + 2]),
        axis: Unit::new_normalize(pose.axis.into_inner() + e1 * step[at + 3] + e2 * step[at + 4]),
    }
}

/// One camera's view of one frame's wand: camera index and the three pixels in wand order.
pub(super) type Observation = (usize, [Pixel; 3]);

/// One marker's residual with its Jacobians.
struct Residual {
    residual: [f64; 2],
    /// d residual / d camera pose (left perturbation).
    d_camera: SMatrix<f64, 2, 6>,
    /// d residual / d wand (`δs`, then the two axis tilts).
    d_wand: SMatrix<f64, 2, 5>,
}

/// Every residual of one observation; `None` when a marker falls behind the camera.
fn residuals(
    params: &CameraParams,
    camera_from_world: &Pose,
    wand: &WandPose,
    positions_mm: &[f64; 3],
    pixels: &[Pixel; 3],
) -> Option<[Residual; 3]> {
    let (e1, e2) = basis(&wand.axis);
    let rotation = camera_from_world.rotation.to_rotation_matrix();
    let one = |k: usize| -> Option<Residual> {
        let q = wand.marker(positions_mm[k]);
        let p = camera_from_world.transform_point(&q);
        let projection = project_with_jacobian(params, &p)?;
        let d_camera = projection.d_point * point_d_pose(&p);
        let d_world = projection.d_point * rotation.matrix();
        let mut d_wand = SMatrix::<f64, 2, 5>::zeros();
        d_wand.fixed_view_mut::<2, 3>(0, 0).copy_from(&d_world);
        d_wand
            .column_mut(3)
            .copy_from(&(d_world * e1 * positions_mm[k]));
        d_wand
            .column_mut(4)
            .copy_from(&(d_world * e2 * positions_mm[k]));
        Some(Residual {
            residual: [
                projection.pixel.x - pixels[k].x,
                projection.pixel.y - pixels[k].y,
            ],
            d_camera,
            d_wand,
        })
    };
    Some([one(0)?, one(1)?, one(2)?])
}

/// One frame's wand pose for fixed cameras.
struct FrameProblem<'a> {
    params: &'a [CameraParams],
    camera_from_world: &'a [Pose],
    observations: &'a [Observation],
    positions_mm: &'a [f64; 3],
}

impl LeastSquares for FrameProblem<'_> {
    type State = WandPose;
    fn parameter_count(&self) -> usize {
        5
    }
    fn cost(&self, wand: &WandPose) -> Option<f64> {
        frame_cost(
            self.params,
            self.camera_from_world,
            self.observations,
            self.positions_mm,
            wand,
        )
    }
    fn normal_equations(&self, wand: &WandPose) -> Option<NormalEquations> {
        let mut equations = NormalEquations::zeros(5);
        for (c, pixels) in self.observations {
            let rs = residuals(
                &self.params[*c],
                &self.camera_from_world[*c],
                wand,
                self.positions_mm,
                pixels,
            )?;
            for r in &rs {
                for axis in 0..2 {
                    let row: Vec<(usize, f64)> = (0..5).map(|j| (j, r.d_wand[(axis, j)])).collect();
                    equations.add_row(r.residual[axis], &row);
                }
            }
        }
        Some(equations)
    }
    fn retract(&self, wand: &WandPose, step: &DVector<f64>) -> WandPose {
        retract_wand(wand, step, 0)
    }
}

/// `Σ r²` of one frame.
fn frame_cost(
    params: &[CameraParams],
    camera_from_world: &[Pose],
    observations: &[Observation],
    positions_mm: &[f64; 3],
    wand: &WandPose,
) -> Option<f64> {
    let mut cost = 0.0;
    for (c, pixels) in observations {
        for r in residuals(
            &params[*c],
            &camera_from_world[*c],
            wand,
            positions_mm,
            pixels,
        )? {
            cost += r.residual[0].powi(2) + r.residual[1].powi(2);
        }
    }
    Some(cost)
}

/// The wand pose of one frame that best fits its views with the cameras fixed, from `start`.
pub(super) fn fit_wand(
    params: &[CameraParams],
    camera_from_world: &[Pose],
    observations: &[Observation],
    positions_mm: &[f64; 3],
    start: WandPose,
) -> Option<WandPose> {
    let problem = FrameProblem {
        params,
        camera_from_world,
        observations,
        positions_mm,
    };
    let config = LmConfig {
        max_iterations: 50,
        ..LmConfig::default()
    };
    minimize(&problem, start, &config).ok().map(|(w, _)| w)
}

/// RMS reprojection error of one observation, pixels; `None` behind the camera.
pub(super) fn observation_rms_px(
    params: &CameraParams,
    camera_from_world: &Pose,
    wand: &WandPose,
    positions_mm: &[f64; 3],
    pixels: &[Pixel; 3],
) -> Option<f64> {
    let rs = residuals(params, camera_from_world, wand, positions_mm, pixels)?;
    let sum: f64 = rs
        .iter()
        .map(|r| r.residual[0].powi(2) + r.residual[1].powi(2))
        .sum();
    Some((sum / 3.0).sqrt())
}

/// The cameras and every frame's wand.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct BundleState {
    pub camera_from_world: Vec<Pose>,
    pub wands: Vec<WandPose>,
}

/// The reduced (camera-only) problem.
pub(super) struct Bundle<'a> {
    pub params: &'a [CameraParams],
    /// Per frame, its observations.
    pub frames: &'a [Vec<Observation>],
    pub positions_mm: &'a [f64; 3],
    /// Per camera, the offset of its 6 columns; `None` for the reference camera.
    pub columns: Vec<Option<usize>>,
    pub count: usize,
}

impl<'a> Bundle<'a> {
    /// The problem with `reference` fixed.
    pub fn new(
        params: &'a [CameraParams],
        frames: &'a [Vec<Observation>],
        positions_mm: &'a [f64; 3],
        reference: usize,
    ) -> Self {
        let mut count = 0;
        let columns = (0..params.len())
            .map(|c| {
                (c != reference).then(|| {
                    count += 6;
                    count - 6
                })
            })
            .collect();
        Self {
            params,
            frames,
            positions_mm,
            columns,
            count,
        }
    }

    /// Runs the adjustment from `start` (whose wands are first fitted to its cameras).
    pub fn solve(&self, start: BundleState, config: &LmConfig) -> Option<(BundleState, LmReport)> {
        let wands = self.fit_all(&start.camera_from_world, &start.wands);
        let start = BundleState {
            camera_from_world: start.camera_from_world,
            wands,
        };
        minimize(self, start, config).ok()
    }

    fn fit_all(&self, camera_from_world: &[Pose], wands: &[WandPose]) -> Vec<WandPose> {
        self.frames
            .iter()
            .zip(wands)
            .map(|(observations, wand)| {
                fit_wand(
                    self.params,
                    camera_from_world,
                    observations,
                    self.positions_mm,
                    *wand,
                )
                .unwrap_or(*wand)
            })
            .collect()
    }
}

impl LeastSquares for Bundle<'_> {
    type State = BundleState;

    fn parameter_count(&self) -> usize {
        self.count
    }

    fn cost(&self, state: &BundleState) -> Option<f64> {
        let mut cost = 0.0;
        for (observations, wand) in self.frames.iter().zip(&state.wands) {
            cost += frame_cost(
                self.params,
                &state.camera_from_world,
                observations,
                self.positions_mm,
                wand,
            )?;
        }
        Some(cost)
    }

    fn normal_equations(&self, state: &BundleState) -> Option<NormalEquations> {
        let n = self.count;
        let mut equations = NormalEquations::zeros(n);
        for (observations, wand) in self.frames.iter().zip(&state.wands) {
            // This frame's blocks of the full normal equations.
            let mut a_ww = SMatrix::<f64, 5, 5>::zeros();
            let mut b_w = SVector::<f64, 5>::zeros();
            let mut a_cw = nalgebra::DMatrix::<f64>::zeros(n, 5);
            let mut b_c = DVector::<f64>::zeros(n);
            let mut a_cc: Vec<(usize, SMatrix<f64, 6, 6>)> = Vec::new();
            for (c, pixels) in observations {
                let rs = residuals(
                    &self.params[*c],
                    &state.camera_from_world[*c],
                    wand,
                    self.positions_mm,
                    pixels,
                )?;
                let mut block = SMatrix::<f64, 6, 6>::zeros();
                for r in &rs {
                    let residual = nalgebra::Vector2::new(r.residual[0], r.residual[1]);
                    equations.cost += residual.norm_squared();
                    a_ww += r.d_wand.transpose() * r.d_wand;
                    b_w += r.d_wand.transpose() * residual;
                    if let Some(at) = self.columns[*c] {
                        block += r.d_camera.transpose() * r.d_camera;
                        let cw = r.d_camera.transpose() * r.d_wand;
                        let mut view = a_cw.view_mut((at, 0), (6, 5));
                        view += cw;
                        let bc = r.d_camera.transpose() * residual;
                        let mut view = b_c.rows_mut(at, 6);
                        view += bc;
                    }
                }
                if let Some(at) = self.columns[*c] {
                    a_cc.push((at, block));
                }
            }
            for (at, block) in &a_cc {
                let mut view = equations.jtj.view_mut((*at, *at), (6, 6));
                view += block;
            }
            let a_ww_inverse = a_ww.try_inverse()?;
            let reduced = &a_cw * a_ww_inverse;
            equations.jtj -= &reduced * a_cw.transpose();
            equations.jtr += b_c - &reduced * b_w;
        }
        Some(equations)
    }

    fn retract(&self, state: &BundleState, step: &DVector<f64>) -> BundleState {
        let camera_from_world: Vec<Pose> = state
            .camera_from_world
            .iter()
            .zip(&self.columns)
            .map(|(pose, column)| column.map_or(*pose, |at| retract_pose(pose, step, at)))
            .collect();
        let wands = self.fit_all(&camera_from_world, &state.wands);
        BundleState {
            camera_from_world,
            wands,
        }
    }
}

/// One camera's σ from the reduced covariance block at `at`: rotation (degrees,
/// `sqrt(trace Cov(ω))`) and centre (millimetres, `Cov(C) = Rᵀ Cov(τ) R`).
pub(super) fn camera_std(
    covariance: &nalgebra::DMatrix<f64>,
    at: usize,
    camera_from_world: &Pose,
) -> (f64, f64) {
    let omega: Matrix3<f64> = covariance.fixed_view::<3, 3>(at, at).into_owned();
    let tau: Matrix3<f64> = covariance.fixed_view::<3, 3>(at + 3, at + 3).into_owned();
    let r = camera_from_world.rotation.to_rotation_matrix().into_inner();
    let centre = r.transpose() * tau * r;
    (
        omega.trace().max(0.0).sqrt().to_degrees(),
        centre.trace().max(0.0).sqrt(),
    )
}
