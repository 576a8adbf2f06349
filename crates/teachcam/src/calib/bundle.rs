//! The bundle adjustment of a rig's extrinsics from a rigid body of known markers seen in many
//! frames: every camera's extrinsics (one reference camera fixed: the gauge) and every frame's
//! body pose, the body's marker geometry exact (it fixes the scale), intrinsics fixed.
//!
//! The body is what the calibration waves: the wand ([`super::wand`], 5 DOF: collinear
//! markers have no roll) or a tracked tool ([`super::refine`], 6 DOF). Frame f's marker k sits
//! at `X_fk = body(b_f, k)`; camera i sees it at `u = project(K_i, d_i, camera_from_world_i X_fk)`.
//! The body poses are eliminated by variable projection (Golub & Pereyra 1973; Kaufman's
//! approximation): for given cameras each frame's body is the least-squares pose of its own
//! views (a D-parameter Levenberg–Marquardt), and the outer Levenberg–Marquardt
//! ([`super::lm`]) steps the cameras along the Schur complement
//! `S = A_cc − A_cb A_bb⁻¹ A_bc` of the full normal equations, with the reduced gradient
//! `g = b_c − A_cb A_bb⁻¹ b_b` (Triggs et al. 2000, *Bundle adjustment — a modern synthesis*,
//! §6.1). `S⁻¹ σ²` is then the cameras' marginal covariance. [`adjust_gated`] drops
//! camera-frames whose reprojection RMS lies beyond a gate measured from the residuals
//! (median + k·MAD) and adjusts again.

use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, SVector, Vector2};

use super::intrinsics::{CameraParams, point_d_pose, project_with_jacobian, retract_pose};
use super::lm::{LeastSquares, LmConfig, LmReport, NormalEquations, minimize};
use crate::geometry::{Pixel, Point3, Pose};
use crate::track::gates::robust_scale;

/// A rigid body of markers with a `D`-parameter pose.
pub(crate) trait Body<const D: usize> {
    /// Its pose in the world.
    type Pose: Copy;
    /// Marker `marker` in the world and its derivative by the pose's step.
    fn marker(&self, pose: &Self::Pose, marker: usize) -> (Point3, SMatrix<f64, 3, D>);
    /// `pose ⊞ step`.
    fn retract(&self, pose: &Self::Pose, step: &SVector<f64, D>) -> Self::Pose;
}

/// One camera's view of one frame's body: the camera index and the pixels of the markers it
/// saw, by marker index.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct View {
    /// Camera index in the rig.
    pub camera: usize,
    /// `(marker, pixel)`, distorted pixels.
    pub pixels: Vec<(usize, Pixel)>,
}

/// One marker image's residual with its Jacobians.
struct Residual<const D: usize> {
    residual: Vector2<f64>,
    /// d residual / d camera pose (left perturbation).
    d_camera: SMatrix<f64, 2, 6>,
    /// d residual / d body pose.
    d_body: SMatrix<f64, 2, D>,
}

/// Every residual of one view; `None` when a marker falls behind the camera.
fn residuals<B: Body<D>, const D: usize>(
    body: &B,
    params: &CameraParams,
    camera_from_world: &Pose,
    pose: &B::Pose,
    view: &View,
) -> Option<Vec<Residual<D>>> {
    let rotation = camera_from_world.rotation.to_rotation_matrix();
    view.pixels
        .iter()
        .map(|(marker, pixel)| {
            let (q, d_marker) = body.marker(pose, *marker);
            let p = camera_from_world.transform_point(&q);
            let projection = project_with_jacobian(params, &p)?;
            Some(Residual {
                residual: Vector2::new(projection.pixel.x - pixel.x, projection.pixel.y - pixel.y),
                d_camera: projection.d_point * point_d_pose(&p),
                d_body: projection.d_point * rotation.matrix() * d_marker,
            })
        })
        .collect()
}

/// `Σ r²` of one view; `None` behind the camera.
fn view_cost<B: Body<D>, const D: usize>(
    body: &B,
    params: &CameraParams,
    camera_from_world: &Pose,
    pose: &B::Pose,
    view: &View,
) -> Option<f64> {
    Some(
        residuals(body, params, camera_from_world, pose, view)?
            .iter()
            .map(|r| r.residual.norm_squared())
            .sum(),
    )
}

/// RMS reprojection error of one view over its markers, pixels; `None` behind the camera.
pub(crate) fn view_rms_px<B: Body<D>, const D: usize>(
    body: &B,
    params: &CameraParams,
    camera_from_world: &Pose,
    pose: &B::Pose,
    view: &View,
) -> Option<f64> {
    let cost = view_cost(body, params, camera_from_world, pose, view)?;
    Some((cost / view.pixels.len().max(1) as f64).sqrt())
}

/// One frame's body pose for fixed cameras.
struct FrameProblem<'a, B, const D: usize> {
    body: &'a B,
    params: &'a [CameraParams],
    camera_from_world: &'a [Pose],
    views: &'a [View],
}

impl<B: Body<D>, const D: usize> LeastSquares for FrameProblem<'_, B, D> {
    type State = B::Pose;
    fn parameter_count(&self) -> usize {
        D
    }
    fn cost(&self, pose: &B::Pose) -> Option<f64> {
        self.views
            .iter()
            .map(|v| {
                view_cost(
                    self.body,
                    &self.params[v.camera],
                    &self.camera_from_world[v.camera],
                    pose,
                    v,
                )
            })
            .sum()
    }
    fn normal_equations(&self, pose: &B::Pose) -> Option<NormalEquations> {
        let mut a = SMatrix::<f64, D, D>::zeros();
        let mut b = SVector::<f64, D>::zeros();
        let mut cost = 0.0;
        for v in self.views {
            for r in residuals(
                self.body,
                &self.params[v.camera],
                &self.camera_from_world[v.camera],
                pose,
                v,
            )? {
                a += r.d_body.transpose() * r.d_body;
                b += r.d_body.transpose() * r.residual;
                cost += r.residual.norm_squared();
            }
        }
        Some(NormalEquations {
            jtj: DMatrix::from_column_slice(D, D, a.as_slice()),
            jtr: DVector::from_column_slice(b.as_slice()),
            cost,
        })
    }
    fn retract(&self, pose: &B::Pose, step: &DVector<f64>) -> B::Pose {
        self.body
            .retract(pose, &SVector::<f64, D>::from_column_slice(step.as_slice()))
    }
}

/// The body pose of one frame that best fits its views with the cameras fixed, from `start`.
pub(crate) fn fit_body<B: Body<D>, const D: usize>(
    body: &B,
    params: &[CameraParams],
    camera_from_world: &[Pose],
    views: &[View],
    start: B::Pose,
) -> Option<B::Pose> {
    let problem = FrameProblem::<B, D> {
        body,
        params,
        camera_from_world,
        views,
    };
    let config = LmConfig {
        max_iterations: 50,
        ..LmConfig::default()
    };
    minimize(&problem, start, &config).ok().map(|(p, _)| p)
}

/// The cameras and every frame's body.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BundleState<P> {
    pub camera_from_world: Vec<Pose>,
    pub bodies: Vec<P>,
}

/// The reduced (camera-only) problem.
pub(crate) struct Bundle<'a, B, const D: usize> {
    body: &'a B,
    params: &'a [CameraParams],
    /// Per frame, its views.
    frames: &'a [Vec<View>],
    /// Per camera, the offset of its 6 columns; `None` for the reference camera.
    pub columns: Vec<Option<usize>>,
    count: usize,
}

impl<'a, B, const D: usize> Bundle<'a, B, D> {
    /// The problem with camera `reference` fixed.
    pub fn new(
        body: &'a B,
        params: &'a [CameraParams],
        frames: &'a [Vec<View>],
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
            body,
            params,
            frames,
            columns,
            count,
        }
    }
}

impl<B: Body<D>, const D: usize> Bundle<'_, B, D> {
    /// Runs the adjustment from `start` (whose bodies are first fitted to its cameras).
    pub fn solve(
        &self,
        start: BundleState<B::Pose>,
        config: &LmConfig,
    ) -> Option<(BundleState<B::Pose>, LmReport)> {
        let bodies = self.fit_all(&start.camera_from_world, &start.bodies);
        let start = BundleState {
            camera_from_world: start.camera_from_world,
            bodies,
        };
        minimize(self, start, config).ok()
    }

    fn fit_all(&self, camera_from_world: &[Pose], bodies: &[B::Pose]) -> Vec<B::Pose> {
        self.frames
            .iter()
            .zip(bodies)
            .map(|(views, pose)| {
                fit_body(self.body, self.params, camera_from_world, views, *pose).unwrap_or(*pose)
            })
            .collect()
    }
}

impl<B: Body<D>, const D: usize> LeastSquares for Bundle<'_, B, D> {
    type State = BundleState<B::Pose>;

    fn parameter_count(&self) -> usize {
        self.count
    }

    fn cost(&self, state: &Self::State) -> Option<f64> {
        let mut cost = 0.0;
        for (views, pose) in self.frames.iter().zip(&state.bodies) {
            for v in views {
                cost += view_cost(
                    self.body,
                    &self.params[v.camera],
                    &state.camera_from_world[v.camera],
                    pose,
                    v,
                )?;
            }
        }
        Some(cost)
    }

    fn normal_equations(&self, state: &Self::State) -> Option<NormalEquations> {
        let n = self.count;
        let mut equations = NormalEquations::zeros(n);
        for (views, pose) in self.frames.iter().zip(&state.bodies) {
            // This frame's blocks of the full normal equations.
            let mut a_bb = SMatrix::<f64, D, D>::zeros();
            let mut b_b = SVector::<f64, D>::zeros();
            let mut a_cb = DMatrix::<f64>::zeros(n, D);
            let mut b_c = DVector::<f64>::zeros(n);
            for v in views {
                let rs = residuals(
                    self.body,
                    &self.params[v.camera],
                    &state.camera_from_world[v.camera],
                    pose,
                    v,
                )?;
                let mut block = SMatrix::<f64, 6, 6>::zeros();
                for r in &rs {
                    equations.cost += r.residual.norm_squared();
                    a_bb += r.d_body.transpose() * r.d_body;
                    b_b += r.d_body.transpose() * r.residual;
                    if let Some(at) = self.columns[v.camera] {
                        block += r.d_camera.transpose() * r.d_camera;
                        let mut view = a_cb.view_mut((at, 0), (6, D));
                        view += r.d_camera.transpose() * r.d_body;
                        let mut view = b_c.rows_mut(at, 6);
                        view += r.d_camera.transpose() * r.residual;
                    }
                }
                if let Some(at) = self.columns[v.camera] {
                    let mut view = equations.jtj.view_mut((at, at), (6, 6));
                    view += block;
                }
            }
            let a_bb_inverse = a_bb.try_inverse()?;
            let reduced = &a_cb * a_bb_inverse;
            equations.jtj -= &reduced * a_cb.transpose();
            equations.jtr += b_c - &reduced * b_b;
        }
        Some(equations)
    }

    fn retract(&self, state: &Self::State, step: &DVector<f64>) -> Self::State {
        let camera_from_world: Vec<Pose> = state
            .camera_from_world
            .iter()
            .zip(&self.columns)
            .map(|(pose, column)| column.map_or(*pose, |at| retract_pose(pose, step, at)))
            .collect();
        let bodies = self.fit_all(&camera_from_world, &state.bodies);
        BundleState {
            camera_from_world,
            bodies,
        }
    }
}

/// One camera's σ from the reduced covariance block at `at`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CameraStd {
    /// `sqrt(trace Cov(ω))`, degrees.
    pub rotation_deg: f64,
    /// `sqrt(trace Cov(C))` with `Cov(C) = Rᵀ Cov(τ) R`, millimetres.
    pub centre_mm: f64,
}

fn camera_std(covariance: &DMatrix<f64>, at: usize, camera_from_world: &Pose) -> CameraStd {
    let omega: Matrix3<f64> = covariance.fixed_view::<3, 3>(at, at).into_owned();
    let tau: Matrix3<f64> = covariance.fixed_view::<3, 3>(at + 3, at + 3).into_owned();
    let r = camera_from_world.rotation.to_rotation_matrix().into_inner();
    let centre = r.transpose() * tau * r;
    CameraStd {
        rotation_deg: omega.trace().max(0.0).sqrt().to_degrees(),
        centre_mm: centre.trace().max(0.0).sqrt(),
    }
}

/// Options of [`adjust_gated`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct GateConfig {
    /// MAD multiples of the residual gate.
    pub gate_mads: f64,
    /// Floor of the residual gate, pixels.
    pub min_gate_px: f64,
    /// Rounds of dropping camera-frames and adjusting again.
    pub max_rounds: usize,
    /// Frames needed after a round's drops.
    pub min_frames: usize,
}

/// Why [`adjust_gated`] stopped without a rig.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum AdjustError {
    /// The residuals are undefined at the start (a body behind a camera).
    BadStart,
    /// Too few frames are left after the gate.
    TooFewFrames {
        /// Frames left.
        found: usize,
    },
}

/// A gated adjustment's result.
#[derive(Debug, Clone)]
pub(crate) struct Adjusted<P> {
    /// The cameras and the kept frames' bodies.
    pub state: BundleState<P>,
    /// The kept frames' views.
    pub frames: Vec<Vec<View>>,
    /// The last adjustment's report.
    pub report: LmReport,
    /// The residual gate of the last round, pixels.
    pub gate_px: f64,
    /// Per camera, its camera-frames dropped by the gate.
    pub dropped_per_camera: Vec<usize>,
    /// Optimiser iterations over all rounds.
    pub iterations: usize,
    /// Frames before the gate.
    pub frames_before: usize,
    /// The fixed camera.
    pub reference: usize,
}

/// The adjustment from `start`; camera-frames whose reprojection RMS lies beyond
/// `max(median + k · 1.4826 · MAD, floor)` of all camera-frames are dropped (frames left with
/// fewer than two views dropped whole) and the adjustment run again, until none is dropped or
/// `max_rounds`.
pub(crate) fn adjust_gated<B: Body<D>, const D: usize>(
    body: &B,
    params: &[CameraParams],
    mut frames: Vec<Vec<View>>,
    mut state: BundleState<B::Pose>,
    reference: usize,
    gate: &GateConfig,
    lm: &LmConfig,
) -> Result<Adjusted<B::Pose>, AdjustError> {
    let frames_before = frames.len();
    let mut dropped_per_camera = vec![0usize; params.len()];
    let mut iterations = 0;
    let mut round = 0;
    loop {
        round += 1;
        let problem = Bundle::<B, D>::new(body, params, &frames, reference);
        let (solved, report) = problem
            .solve(state.clone(), lm)
            .ok_or(AdjustError::BadStart)?;
        iterations += report.iterations;
        let rms: Vec<Vec<f64>> = frames
            .iter()
            .zip(&solved.bodies)
            .map(|(views, pose)| {
                views
                    .iter()
                    .map(|v| {
                        view_rms_px(
                            body,
                            &params[v.camera],
                            &solved.camera_from_world[v.camera],
                            pose,
                            v,
                        )
                        .unwrap_or(f64::INFINITY)
                    })
                    .collect()
            })
            .collect();
        let (gate_px, dropped) = residual_gate(&rms, gate.gate_mads, gate.min_gate_px);
        if dropped == 0 || round >= gate.max_rounds {
            return Ok(Adjusted {
                state: solved,
                frames,
                report,
                gate_px,
                dropped_per_camera,
                iterations,
                frames_before,
                reference,
            });
        }
        let (kept_frames, kept_bodies) = keep_within_gate(
            &frames,
            &solved.bodies,
            &rms,
            gate_px,
            &mut dropped_per_camera,
        );
        frames = kept_frames;
        if frames.len() < gate.min_frames {
            return Err(AdjustError::TooFewFrames {
                found: frames.len(),
            });
        }
        state = BundleState {
            camera_from_world: solved.camera_from_world,
            bodies: kept_bodies,
        };
    }
}

/// A round's residual gate, `median + gate_mads · σ̂` of every view's RMS reprojection error
/// (`rms[frame][view]`, pixels), at least `min_gate_px`; and how many views are over it.
pub(crate) fn residual_gate(rms: &[Vec<f64>], gate_mads: f64, min_gate_px: f64) -> (f64, usize) {
    let all: Vec<f64> = rms.iter().flatten().copied().collect();
    let gate_px = robust_scale(&all)
        .map_or(f64::INFINITY, |s| s.median + gate_mads * s.sigma)
        .max(min_gate_px);
    let over = all.iter().filter(|r| **r > gate_px).count();
    (gate_px, over)
}

/// The frames' views within `gate_px` (`rms[frame][view]`), with their frames' bodies; a view
/// over it is counted for its camera in `dropped`, a frame left with fewer than two views
/// goes.
pub(crate) fn keep_within_gate<P: Copy>(
    frames: &[Vec<View>],
    bodies: &[P],
    rms: &[Vec<f64>],
    gate_px: f64,
    dropped: &mut [usize],
) -> (Vec<Vec<View>>, Vec<P>) {
    let mut kept_frames = Vec::new();
    let mut kept_bodies = Vec::new();
    for ((views, body), frame_rms) in frames.iter().zip(bodies).zip(rms) {
        let kept: Vec<View> = views
            .iter()
            .zip(frame_rms)
            .filter_map(|(v, r)| {
                if *r > gate_px {
                    dropped[v.camera] += 1;
                    None
                } else {
                    Some(v.clone())
                }
            })
            .collect();
        if kept.len() >= 2 {
            kept_frames.push(kept);
            kept_bodies.push(*body);
        }
    }
    (kept_frames, kept_bodies)
}

/// One camera's use in an adjustment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CameraFit {
    /// Frames it saw that the adjustment used.
    pub frames: usize,
    /// RMS reprojection error of its marker images, pixels (0 without any).
    pub rms_px: f64,
    /// Its σ (0 for the reference camera), conditional on the intrinsics.
    pub std: CameraStd,
}

impl<P> Adjusted<P> {
    /// Per camera: frames, RMS and σ, with `σ² = cost / (residuals − unknowns)` and the
    /// reduced `JᵀJ`'s inverse; `body_dof` is the body's pose parameter count.
    pub fn camera_fits<B: Body<D, Pose = P>, const D: usize>(
        &self,
        body: &B,
        params: &[CameraParams],
    ) -> Vec<CameraFit> {
        let images: usize = self.frames.iter().flatten().map(|v| v.pixels.len()).sum();
        let cameras = params.len();
        let unknowns = 6 * (cameras.saturating_sub(1)) + D * self.frames.len();
        let sigma2 = self.report.final_cost / (2 * images).saturating_sub(unknowns).max(1) as f64;
        let covariance = self
            .report
            .jtj
            .clone()
            .try_inverse()
            .map(|m| m * sigma2)
            .unwrap_or_else(|| {
                DMatrix::from_element(self.report.jtj.nrows(), self.report.jtj.ncols(), f64::NAN)
            });
        let mut column = 0;
        (0..cameras)
            .map(|c| {
                let mut sum = 0.0;
                let mut markers = 0;
                let mut frames = 0;
                for (views, pose) in self.frames.iter().zip(&self.state.bodies) {
                    for v in views.iter().filter(|v| v.camera == c) {
                        if let Some(cost) =
                            view_cost(body, &params[c], &self.state.camera_from_world[c], pose, v)
                        {
                            sum += cost;
                            markers += v.pixels.len();
                            frames += 1;
                        }
                    }
                }
                let std = if c == self.reference {
                    CameraStd {
                        rotation_deg: 0.0,
                        centre_mm: 0.0,
                    }
                } else {
                    column += 6;
                    camera_std(&covariance, column - 6, &self.state.camera_from_world[c])
                };
                CameraFit {
                    frames,
                    rms_px: if markers > 0 {
                        (sum / markers as f64).sqrt()
                    } else {
                        0.0
                    },
                    std,
                }
            })
            .collect()
    }
}
