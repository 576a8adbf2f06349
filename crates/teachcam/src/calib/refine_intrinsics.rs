//! Intrinsics refined from a tracked recording, judged on frames the fit never saw.
//!
//! A rig's intrinsics come from somewhere else (a chessboard, a maker's calibration) and may
//! not hold for the footage; a lower epipolar error is then no evidence (on a real stereo
//! recording it halved while the tool's rigidity got 35 % worse). This module adjusts, per
//! camera, the focal length `f` (`fx` and `fy` scaled together), the principal point
//! `(cx, cy)`, `k1` and optionally `k2`, with every camera's extrinsics but the held one's and
//! the tool's marker geometry except its scale (a tool file measured by the tracker carries
//! the old rig's bias), from the confident frames of [`super::refine`].
//!
//! Model: frame f's marker k at `X_fk = world_from_tool_f m_k`, seen by camera i at
//! `u = project(K_i, d_i, camera_from_world_i X_fk)`. Unknowns: the cameras' extrinsics (left
//! perturbation, one camera fixed: the gauge), the free intrinsics (`f` multiplicatively:
//! `fx ← fx (1 + δ)`, `fy ← fy (1 + δ)`), the markers `m` moved along the `3N − 7` directions
//! orthogonal to the tool's rigid motions and its scale (the tool's pose absorbs the first,
//! the marker geometry's RMS radius about its centroid is kept exact after each step: it
//! fixes the world's scale), and each frame's pose, eliminated by variable projection as in
//! [`super::bundle`] (the outer Levenberg–Marquardt steps along the Schur complement).
//!
//! Which parameters are determined: after a fit with all asked for free, a parameter whose
//! one-σ change moves the image of the camera's outermost observation by more than
//! [`IntrinsicsRefineConfig::max_std_effect_px`] is held at its input value and the fit is run
//! again (`f`: `σ_rel f r`, `cx`/`cy`: `σ`, `k1`: `σ f r³`, `k2`: `σ f r⁵`, with `r` the largest
//! normalised radius observed).
//!
//! Judging: [`held_out_rigidity`] triangulates the held-out frames' marker images through a
//! rig and measures how much the distances between the tool's markers vary (their pooled
//! standard deviation): the rig that makes the tool most rigid on frames it was not fitted
//! on is the better one, whatever the epipolar error says.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector, SMatrix, SVector, Vector3};

use super::bundle::{View, fit_body, keep_within_gate, residual_gate};
use super::intrinsics::{CameraParams, point_d_pose, project_with_jacobian, retract_pose};
use super::lm::{LeastSquares, LmConfig, LmReport, NormalEquations, minimize};
use super::refine::ToolBody;
use crate::camera::Rig;
use crate::geometry::{CameraId, Pixel, Point3, Pose};
use crate::triangulate::{TriangulateConfig, triangulate};

/// The intrinsic parameters this module can free, in column order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Intrinsic {
    /// The focal length, `fx` and `fy` scaled together.
    Focal,
    /// The principal point's x.
    Cx,
    /// The principal point's y.
    Cy,
    /// The first radial distortion coefficient.
    K1,
    /// The second radial distortion coefficient.
    K2,
}

impl Intrinsic {
    /// Every parameter, in column order.
    pub const ALL: [Self; 5] = [Self::Focal, Self::Cx, Self::Cy, Self::K1, Self::K2];

    /// Its name as printed.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Focal => "f",
            Self::Cx => "cx",
            Self::Cy => "cy",
            Self::K1 => "k1",
            Self::K2 => "k2",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// Options of [`refine_intrinsics`].
#[derive(Debug, Clone, PartialEq)]
pub struct IntrinsicsRefineConfig {
    /// A parameter whose one-σ change moves the camera's outermost observation by more than
    /// this many pixels is not determined by the footage and is held: 0.5 px (a few times the
    /// reprojection RMS of bright marker centres).
    pub max_std_effect_px: f64,
    /// MAD multiples of the residual gate: 5, as the extrinsic refinement's.
    pub gate_mads: f64,
    /// Floor of the residual gate, pixels: 0.3.
    pub min_gate_px: f64,
    /// Rounds of dropping camera-frames: 4.
    pub max_gate_rounds: usize,
    /// The optimiser.
    pub lm: LmConfig,
}

impl Default for IntrinsicsRefineConfig {
    fn default() -> Self {
        Self {
            max_std_effect_px: 0.5,
            gate_mads: 5.0,
            min_gate_px: 0.3,
            max_gate_rounds: 4,
            lm: LmConfig::default(),
        }
    }
}

/// One frame's observations: the tool's pose to start from and each camera's identified
/// marker images.
#[derive(Debug, Clone, PartialEq)]
pub struct Observed {
    /// `world_from_tool` through the rig the frame was tracked with.
    pub world_from_tool: Pose,
    /// Per camera, `(marker, distorted pixel)`.
    pub views: BTreeMap<CameraId, Vec<(usize, Pixel)>>,
}

/// What [`refine_intrinsics`] found for one camera.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraIntrinsicsFit {
    /// Per freed parameter, `(parameter, value, σ)`; `f` as `fx` in pixels.
    pub free: Vec<(Intrinsic, f64, f64)>,
    /// Parameters asked for but held, with the image effect of their σ in pixels.
    pub held: Vec<(Intrinsic, f64)>,
    /// Camera-frames used.
    pub frames: usize,
    /// Camera-frames dropped by the residual gate.
    pub dropped: usize,
    /// RMS reprojection error, pixels.
    pub rms_px: f64,
    /// Orientation σ, degrees (0 for the held camera).
    pub rotation_std_deg: f64,
    /// Centre σ, millimetres (0 for the held camera).
    pub centre_std_mm: f64,
}

/// A refinement of intrinsics, extrinsics and the tool's shape.
#[derive(Debug, Clone, PartialEq)]
pub struct IntrinsicsRefinement {
    /// The refined rig.
    pub rig: Rig,
    /// The tool's markers as fitted (the input's RMS radius).
    pub markers_in_tool: Vec<Point3>,
    /// Per camera, in rig order.
    pub cameras: Vec<CameraIntrinsicsFit>,
    /// Frames used after the gate.
    pub frames_used: usize,
    /// The residual gate, pixels.
    pub gate_px: f64,
    /// False when the optimiser stopped at its iteration limit.
    pub converged: bool,
}

/// Why a refinement of intrinsics failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IntrinsicsRefineError {
    /// The residuals are undefined at the start.
    #[error("the residuals are undefined at the start (a marker behind a camera)")]
    BadStart,
    /// The result is not finite.
    #[error("the refined parameters are not finite")]
    NotFinite,
    /// Too few frames after the gate.
    #[error("{found} frames left after the residual gate")]
    TooFewFrames {
        /// Frames left.
        found: usize,
    },
}

#[derive(Debug, Clone)]
struct State {
    cameras: Vec<Pose>,
    params: Vec<CameraParams>,
    markers: Vec<Point3>,
    bodies: Vec<Pose>,
}

/// The outer parameters' columns.
struct Layout {
    extrinsic: Vec<Option<usize>>,
    intrinsic: Vec<[Option<usize>; 5]>,
    shape: Option<usize>,
    shape_basis: DMatrix<f64>,
    count: usize,
}

/// The `3N − 7` (or fewer) unit directions of marker motion orthogonal to the rigid motions
/// and the scaling of `markers` about their centroid, as columns.
fn shape_basis(markers: &[Point3]) -> DMatrix<f64> {
    let n = markers.len();
    let centroid = markers.iter().fold(Vector3::zeros(), |s, m| s + m.coords) / n.max(1) as f64;
    let mut gauge = DMatrix::<f64>::zeros(3 * n, 7);
    for (k, m) in markers.iter().enumerate() {
        let c = m.coords - centroid;
        for axis in 0..3 {
            gauge[(3 * k + axis, axis)] = 1.0;
            let mut e = Vector3::zeros();
            e[axis] = 1.0;
            let rotated = e.cross(&c);
            for row in 0..3 {
                gauge[(3 * k + row, 3 + axis)] = rotated[row];
            }
            gauge[(3 * k + axis, 6)] = c[axis];
        }
    }
    // The complement of the gauge's column space: the left singular vectors beyond its rank.
    let full = gauge.clone() * gauge.transpose();
    let eigen = full.symmetric_eigen();
    let largest = eigen.eigenvalues.iter().fold(0.0f64, |a, b| a.max(*b));
    let columns: Vec<DVector<f64>> = (0..3 * n)
        .filter(|&i| eigen.eigenvalues[i] <= 1e-9 * largest.max(1e-300))
        .map(|i| eigen.eigenvectors.column(i).into_owned())
        .collect();
    if columns.is_empty() {
        return DMatrix::zeros(3 * n, 0);
    }
    DMatrix::from_columns(&columns)
}

fn rms_radius(markers: &[Point3]) -> f64 {
    let n = markers.len().max(1) as f64;
    let centroid = markers.iter().fold(Vector3::zeros(), |s, m| s + m.coords) / n;
    (markers
        .iter()
        .map(|m| (m.coords - centroid).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt()
}

impl Layout {
    fn new(
        cameras: usize,
        held: usize,
        free: &[Vec<Intrinsic>],
        shape_free: bool,
        markers: &[Point3],
    ) -> Self {
        let mut count = 0;
        let mut take = |k: usize| {
            count += k;
            count - k
        };
        let extrinsic = (0..cameras).map(|c| (c != held).then(|| take(6))).collect();
        let intrinsic = (0..cameras)
            .map(|c| {
                let mut cols = [None; 5];
                for p in Intrinsic::ALL {
                    if free.get(c).is_some_and(|f| f.contains(&p)) {
                        cols[p.index()] = Some(take(1));
                    }
                }
                cols
            })
            .collect();
        let shape_basis = if shape_free {
            shape_basis(markers)
        } else {
            DMatrix::zeros(3 * markers.len(), 0)
        };
        let shape = (shape_basis.ncols() > 0).then(|| take(shape_basis.ncols()));
        Self {
            extrinsic,
            intrinsic,
            shape,
            shape_basis,
            count,
        }
    }
}

struct Problem<'a> {
    layout: &'a Layout,
    frames: &'a [Vec<View>],
    scale: f64,
}

/// One residual: value, dense outer Jacobian (2 × count), body Jacobian.
struct Row {
    residual: nalgebra::Vector2<f64>,
    outer: DMatrix<f64>,
    body: SMatrix<f64, 2, 6>,
}

impl Problem<'_> {
    fn rows(&self, state: &State, camera: usize, pose: &Pose, view: &View) -> Option<Vec<Row>> {
        let params = &state.params[camera];
        let camera_from_world = &state.cameras[camera];
        let r_camera = camera_from_world.rotation.to_rotation_matrix().into_inner();
        let r_body = pose.rotation.to_rotation_matrix().into_inner();
        let n = self.layout.count;
        view.pixels
            .iter()
            .map(|(marker, pixel)| {
                let x = pose.transform_point(state.markers.get(*marker)?);
                let p = camera_from_world.transform_point(&x);
                let projection = project_with_jacobian(params, &p)?;
                let mut outer = DMatrix::<f64>::zeros(2, n);
                if let Some(at) = self.layout.extrinsic[camera] {
                    outer
                        .view_mut((0, at), (2, 6))
                        .copy_from(&(projection.d_point * point_d_pose(&p)));
                }
                let d = &projection.d_params;
                for p in Intrinsic::ALL {
                    let Some(at) = self.layout.intrinsic[camera][p.index()] else {
                        continue;
                    };
                    let column = match p {
                        Intrinsic::Focal => d.column(0) * params[0] + d.column(1) * params[1],
                        Intrinsic::Cx => d.column(2).into_owned(),
                        Intrinsic::Cy => d.column(3).into_owned(),
                        Intrinsic::K1 => d.column(4).into_owned(),
                        Intrinsic::K2 => d.column(5).into_owned(),
                    };
                    outer.view_mut((0, at), (2, 1)).copy_from(&column);
                }
                if let Some(at) = self.layout.shape {
                    let d_marker = projection.d_point * r_camera * r_body;
                    let basis = self.layout.shape_basis.rows(3 * marker, 3);
                    let block = d_marker * basis;
                    outer
                        .view_mut((0, at), (2, block.ncols()))
                        .copy_from(&block);
                }
                Some(Row {
                    residual: nalgebra::Vector2::new(
                        projection.pixel.x - pixel.x,
                        projection.pixel.y - pixel.y,
                    ),
                    outer,
                    body: projection.d_point * r_camera * point_d_pose(&x),
                })
            })
            .collect()
    }

    fn view_cost(&self, state: &State, pose: &Pose, view: &View) -> Option<f64> {
        let params = &state.params[view.camera];
        let camera_from_world = &state.cameras[view.camera];
        view.pixels
            .iter()
            .map(|(marker, pixel)| {
                let x = pose.transform_point(state.markers.get(*marker)?);
                let p = camera_from_world.transform_point(&x);
                let u = project_with_jacobian(params, &p)?.pixel;
                Some((u.x - pixel.x).powi(2) + (u.y - pixel.y).powi(2))
            })
            .sum()
    }

    fn fit_bodies(&self, state: &mut State) {
        let tool = ToolBody {
            markers_in_tool: &state.markers,
        };
        let bodies: Vec<Pose> = self
            .frames
            .iter()
            .zip(&state.bodies)
            .map(|(views, pose)| {
                fit_body(&tool, &state.params, &state.cameras, views, *pose).unwrap_or(*pose)
            })
            .collect();
        state.bodies = bodies;
    }
}

impl LeastSquares for Problem<'_> {
    type State = State;

    fn parameter_count(&self) -> usize {
        self.layout.count
    }

    fn cost(&self, state: &State) -> Option<f64> {
        let mut cost = 0.0;
        for (views, pose) in self.frames.iter().zip(&state.bodies) {
            for v in views {
                cost += self.view_cost(state, pose, v)?;
            }
        }
        Some(cost)
    }

    fn normal_equations(&self, state: &State) -> Option<NormalEquations> {
        let n = self.layout.count;
        let mut equations = NormalEquations::zeros(n);
        for (views, pose) in self.frames.iter().zip(&state.bodies) {
            let mut a_bb = SMatrix::<f64, 6, 6>::zeros();
            let mut b_b = SVector::<f64, 6>::zeros();
            let mut a_cb = DMatrix::<f64>::zeros(n, 6);
            let mut b_c = DVector::<f64>::zeros(n);
            for v in views {
                for row in self.rows(state, v.camera, pose, v)? {
                    equations.cost += row.residual.norm_squared();
                    a_bb += row.body.transpose() * row.body;
                    b_b += row.body.transpose() * row.residual;
                    equations.jtj += row.outer.transpose() * &row.outer;
                    a_cb += row.outer.transpose() * row.body;
                    b_c += row.outer.transpose() * row.residual;
                }
            }
            let inverse = a_bb.try_inverse()?;
            let reduced = &a_cb * inverse;
            equations.jtj -= &reduced * a_cb.transpose();
            equations.jtr += b_c - &reduced * b_b;
        }
        Some(equations)
    }

    fn retract(&self, state: &State, step: &DVector<f64>) -> State {
        let layout = self.layout;
        let mut next = state.clone();
        for (c, pose) in next.cameras.iter_mut().enumerate() {
            if let Some(at) = layout.extrinsic[c] {
                *pose = retract_pose(pose, step, at);
            }
        }
        for (c, params) in next.params.iter_mut().enumerate() {
            for p in Intrinsic::ALL {
                let Some(at) = layout.intrinsic[c][p.index()] else {
                    continue;
                };
                match p {
                    Intrinsic::Focal => {
                        params[0] *= 1.0 + step[at];
                        params[1] *= 1.0 + step[at];
                    }
                    Intrinsic::Cx => params[2] += step[at],
                    Intrinsic::Cy => params[3] += step[at],
                    Intrinsic::K1 => params[4] += step[at],
                    Intrinsic::K2 => params[5] += step[at],
                }
            }
        }
        if let Some(at) = layout.shape {
            let delta = &layout.shape_basis * step.rows(at, layout.shape_basis.ncols());
            for (k, m) in next.markers.iter_mut().enumerate() {
                m.coords += Vector3::new(delta[3 * k], delta[3 * k + 1], delta[3 * k + 2]);
            }
            let factor = self.scale / rms_radius(&next.markers);
            let n = next.markers.len() as f64;
            let centroid = next
                .markers
                .iter()
                .fold(Vector3::zeros(), |s, m| s + m.coords)
                / n;
            for m in &mut next.markers {
                m.coords = centroid + (m.coords - centroid) * factor;
            }
        }
        self.fit_bodies(&mut next);
        next
    }
}

/// A gated adjustment's result.
struct Gated {
    state: State,
    /// The kept frames' views.
    frames: Vec<Vec<View>>,
    /// Per camera, camera-frames dropped.
    dropped: Vec<usize>,
    /// The last round's gate, pixels.
    gate_px: f64,
    report: LmReport,
}

/// Runs one adjustment, dropping camera-frames beyond `median + k·σ̂` (floor
/// [`IntrinsicsRefineConfig::min_gate_px`]) of all camera-frames' RMS and adjusting again.
fn adjust(
    layout: &Layout,
    mut frames: Vec<Vec<View>>,
    mut state: State,
    scale: f64,
    config: &IntrinsicsRefineConfig,
) -> Result<Gated, IntrinsicsRefineError> {
    let mut dropped = vec![0usize; state.cameras.len()];
    let mut round = 0;
    loop {
        round += 1;
        let problem = Problem {
            layout,
            frames: &frames,
            scale,
        };
        problem.fit_bodies(&mut state);
        let (solved, report) =
            minimize(&problem, state, &config.lm).map_err(|_| IntrinsicsRefineError::BadStart)?;
        let rms: Vec<Vec<f64>> = frames
            .iter()
            .zip(&solved.bodies)
            .map(|(views, pose)| {
                views
                    .iter()
                    .map(|v| {
                        problem
                            .view_cost(&solved, pose, v)
                            .map_or(f64::INFINITY, |c| (c / v.pixels.len().max(1) as f64).sqrt())
                    })
                    .collect()
            })
            .collect();
        let (gate, over) = residual_gate(&rms, config.gate_mads, config.min_gate_px);
        if over == 0 || round >= config.max_gate_rounds {
            return Ok(Gated {
                state: solved,
                frames,
                dropped,
                gate_px: gate,
                report,
            });
        }
        let (kept_frames, kept_bodies) =
            keep_within_gate(&frames, &solved.bodies, &rms, gate, &mut dropped);
        if kept_frames.len() < 10 {
            return Err(IntrinsicsRefineError::TooFewFrames {
                found: kept_frames.len(),
            });
        }
        frames = kept_frames;
        state = State {
            bodies: kept_bodies,
            ..solved
        };
    }
}

/// Per camera, the largest normalised radius `|(x/z, y/z)|` of its observations.
fn largest_radius(state: &State, frames: &[Vec<View>], cameras: usize) -> Vec<f64> {
    let mut largest = vec![0.0f64; cameras];
    for (views, pose) in frames.iter().zip(&state.bodies) {
        for v in views {
            for (marker, _) in &v.pixels {
                let Some(m) = state.markers.get(*marker) else {
                    continue;
                };
                let p = state.cameras[v.camera].transform_point(&pose.transform_point(m));
                if p.z > 0.0 {
                    largest[v.camera] = largest[v.camera].max((p.x / p.z).hypot(p.y / p.z));
                }
            }
        }
    }
    largest
}

/// The image effect in pixels of a one-σ change of `p` at normalised radius `r`.
fn std_effect_px(p: Intrinsic, std: f64, fx: f64, r: f64) -> f64 {
    match p {
        Intrinsic::Focal => std * fx * r,
        Intrinsic::Cx | Intrinsic::Cy => std,
        Intrinsic::K1 => std * fx * r.powi(3),
        Intrinsic::K2 => std * fx * r.powi(5),
    }
}

/// Refines `rig` from `frames` (confident frames of a tracked recording): the extrinsics of
/// every camera but `held`, the tool's markers (starting at `markers_in_tool`) except their
/// scale when `shape_free`, and per camera the parameters in `free` that the footage
/// determines (the others held, with the image effect of their σ).
///
/// # Errors
/// [`IntrinsicsRefineError`]: residuals undefined at the start, too few frames after the
/// gate, a non-finite result.
pub fn refine_intrinsics(
    rig: &Rig,
    markers_in_tool: &[Point3],
    frames: &[Observed],
    held: CameraId,
    free: &[Intrinsic],
    shape_free: bool,
    config: &IntrinsicsRefineConfig,
) -> Result<IntrinsicsRefinement, IntrinsicsRefineError> {
    let cameras = rig.len();
    let views: Vec<Vec<View>> = frames
        .iter()
        .map(|f| {
            f.views
                .iter()
                .map(|(camera, pixels)| View {
                    camera: camera.0,
                    pixels: pixels.clone(),
                })
                .collect()
        })
        .collect();
    let start = State {
        cameras: rig.cameras.iter().map(|c| c.camera_from_world).collect(),
        params: rig
            .cameras
            .iter()
            .map(|c| super::intrinsics::params_of(&c.intrinsics, &c.distortion))
            .collect(),
        markers: markers_in_tool.to_vec(),
        bodies: frames.iter().map(|f| f.world_from_tool).collect(),
    };
    let scale = rms_radius(markers_in_tool);
    let mut freed: Vec<Vec<Intrinsic>> = vec![free.to_vec(); cameras];
    let mut held_params: Vec<Vec<(Intrinsic, f64)>> = vec![Vec::new(); cameras];
    loop {
        let layout = Layout::new(cameras, held.0, &freed, shape_free, markers_in_tool);
        let Gated {
            state,
            frames: kept,
            dropped,
            gate_px: gate,
            report,
        } = adjust(&layout, views.clone(), start.clone(), scale, config)?;
        let images: usize = kept.iter().flatten().map(|v| v.pixels.len()).sum();
        let unknowns = layout.count + 6 * kept.len();
        let sigma2 = report.final_cost / (2 * images).saturating_sub(unknowns).max(1) as f64;
        let covariance = report
            .jtj
            .clone()
            .try_inverse()
            .map(|m| m * sigma2)
            .unwrap_or_else(|| DMatrix::from_element(layout.count, layout.count, f64::NAN));
        let radius = largest_radius(&state, &kept, cameras);
        // Parameters not determined: the largest image effect per camera goes first.
        let mut undetermined = false;
        for c in 0..cameras {
            let fx = state.params[c][0];
            let worst = freed[c]
                .iter()
                .filter_map(|p| {
                    let at = layout.intrinsic[c][p.index()]?;
                    let effect =
                        std_effect_px(*p, covariance[(at, at)].max(0.0).sqrt(), fx, radius[c]);
                    (!effect.is_finite() || effect > config.max_std_effect_px)
                        .then_some((*p, effect))
                })
                .max_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((p, effect)) = worst {
                freed[c].retain(|q| *q != p);
                held_params[c].push((p, effect));
                undetermined = true;
            }
        }
        if undetermined {
            continue;
        }
        let finite = state.params.iter().flatten().all(|v| v.is_finite())
            && state
                .markers
                .iter()
                .all(|m| m.coords.iter().all(|v| v.is_finite()))
            && state.cameras.iter().all(|p| {
                p.translation
                    .vector
                    .iter()
                    .chain(p.rotation.coords.iter())
                    .all(|v| v.is_finite())
            });
        if !finite {
            return Err(IntrinsicsRefineError::NotFinite);
        }
        let mut refined = rig.clone();
        for (c, camera) in refined.cameras.iter_mut().enumerate() {
            let p = &state.params[c];
            *camera =
                super::intrinsics::camera_of(p, &camera.name, camera.image_size, state.cameras[c]);
        }
        let problem = Problem {
            layout: &layout,
            frames: &kept,
            scale,
        };
        let fits = (0..cameras)
            .map(|c| {
                let (mut sum, mut markers, mut used) = (0.0, 0usize, 0usize);
                for (views, pose) in kept.iter().zip(&state.bodies) {
                    for v in views.iter().filter(|v| v.camera == c) {
                        if let Some(cost) = problem.view_cost(&state, pose, v) {
                            sum += cost;
                            markers += v.pixels.len();
                            used += 1;
                        }
                    }
                }
                let (rotation_std_deg, centre_std_mm) =
                    layout.extrinsic[c].map_or((0.0, 0.0), |at| {
                        let omega = covariance.fixed_view::<3, 3>(at, at).into_owned();
                        let tau = covariance.fixed_view::<3, 3>(at + 3, at + 3).into_owned();
                        let r = state.cameras[c].rotation.to_rotation_matrix().into_inner();
                        let centre = r.transpose() * tau * r;
                        (
                            omega.trace().max(0.0).sqrt().to_degrees(),
                            centre.trace().max(0.0).sqrt(),
                        )
                    });
                let free = freed[c]
                    .iter()
                    .filter_map(|p| {
                        let at = layout.intrinsic[c][p.index()]?;
                        let std = covariance[(at, at)].max(0.0).sqrt();
                        let params = &state.params[c];
                        Some(match p {
                            Intrinsic::Focal => (*p, params[0], std * params[0]),
                            Intrinsic::Cx => (*p, params[2], std),
                            Intrinsic::Cy => (*p, params[3], std),
                            Intrinsic::K1 => (*p, params[4], std),
                            Intrinsic::K2 => (*p, params[5], std),
                        })
                    })
                    .collect();
                CameraIntrinsicsFit {
                    free,
                    held: held_params[c].clone(),
                    frames: used,
                    dropped: dropped[c],
                    rms_px: if markers > 0 {
                        (sum / markers as f64).sqrt()
                    } else {
                        0.0
                    },
                    rotation_std_deg,
                    centre_std_mm,
                }
            })
            .collect();
        return Ok(IntrinsicsRefinement {
            rig: refined,
            markers_in_tool: state.markers,
            cameras: fits,
            frames_used: kept.len(),
            gate_px: gate,
            converged: report.converged,
        });
    }
}

/// The tool's rigidity through `rig` on `frames`: each marker seen by two or more cameras
/// triangulated, the distance of every marker pair measured in every frame where both are,
/// and the pooled standard deviation of those distances over the frames (`√` of the mean of
/// the pairs' variances), millimetres; `None` with no pair seen in two frames.
#[must_use]
pub fn held_out_rigidity(rig: &Rig, frames: &[Observed]) -> Option<f64> {
    let config = TriangulateConfig {
        max_residual_px: f64::INFINITY,
        ..TriangulateConfig::default()
    };
    let mut distances: BTreeMap<(usize, usize), Vec<f64>> = BTreeMap::new();
    for frame in frames {
        let mut by_marker: BTreeMap<usize, BTreeMap<CameraId, Pixel>> = BTreeMap::new();
        for (camera, pixels) in &frame.views {
            for (marker, pixel) in pixels {
                by_marker
                    .entry(*marker)
                    .or_default()
                    .insert(*camera, *pixel);
            }
        }
        let points: Vec<(usize, Point3)> = by_marker
            .iter()
            .filter(|(_, views)| views.len() >= 2)
            .filter_map(|(marker, views)| {
                Some((*marker, triangulate(rig, views, &config).ok()?.position))
            })
            .collect();
        for (i, (a, pa)) in points.iter().enumerate() {
            for (b, pb) in &points[i + 1..] {
                distances
                    .entry((*a, *b))
                    .or_default()
                    .push((pa - pb).norm());
            }
        }
    }
    let variances: Vec<f64> = distances
        .values()
        .filter(|d| d.len() >= 2)
        .map(|d| {
            let mean = d.iter().sum::<f64>() / d.len() as f64;
            d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (d.len() - 1) as f64
        })
        .collect();
    (!variances.is_empty()).then(|| (variances.iter().sum::<f64>() / variances.len() as f64).sqrt())
}
