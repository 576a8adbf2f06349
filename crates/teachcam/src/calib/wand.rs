//! A rig's extrinsics from a wand waved through the working volume, as optical trackers
//! calibrate (OptiTrack Motive, Vicon, Qualisys; Borghese & Cerveri 2000, *Calibrating a video
//! camera pair with a rigid bar*, Pattern Recognition 33), and the world frame from a marker
//! frame lying on the work object (the paper's vision frame on the object, §V-A).
//!
//! Model: the wand carries three collinear markers at `p_0 < p_1 < p_2` millimetres along its
//! axis, the middle one off centre (0/160/500: the 160/340 split tells the ends apart). In
//! frame f the wand's marker 0 sits at `s_f` with the unit axis `d_f` (5 DOF: a collinear wand
//! has no roll), marker k at `s_f + p_k d_f`; camera i sees it at
//! `u = project(K_i, d_i, camera_from_world_i (s_f + p_k d_f))`, intrinsics known.
//! 1. [`wand_views`]: in every camera-frame with exactly three blobs, undistorted, collinear
//!    within a gate measured from the recording, ordered by the split.
//! 2. Start: the reference camera (0) is the world; each other camera joins through the solved
//!    camera it shares most frames with, by the essential matrix of their wand
//!    correspondences ([`essential`]), scaled by the wand's end-to-end length.
//! 3. [`bundle`]: Levenberg–Marquardt over every camera's extrinsics (camera 0 fixed) and
//!    every frame's wand, the wand's lengths exact (they fix the scale).
//! 4. Camera-frames whose reprojection RMS lies beyond median + k·MAD of all camera-frames
//!    (a marker hidden and a reflection in its place, two images merged) are dropped and the
//!    adjustment run again, until none is dropped.
//! 5. The wand length error (what Motive grades a calibration by): each used frame's markers
//!    triangulated independently through the calibrated rig, `|X_2 − X_0| − (p_2 − p_0)`.
//!
//! [`set_ground`] then tracks a marker frame lying still on the work object through the
//! calibrated rig ([`crate::track::Tracker`], registration by [`crate::track::pose_from_markers`])
//! and makes its tool frame the world.

mod bundle;
mod essential;
mod ground;
mod views;

pub use ground::{GroundReport, set_ground};
pub use views::{WandFrame, WandViews, wand_views};

use std::collections::BTreeMap;

use nalgebra::{Point2, Unit};

use crate::camera::Rig;
use crate::geometry::{CameraId, Pixel, Point3, Pose};
use crate::track::gates::robust_scale;
use crate::triangulate::{TriangulateConfig, triangulate};

use super::bundle::{AdjustError, BundleState, GateConfig, View, adjust_gated};
use super::intrinsics::{CameraParams, params_of};
use super::lm::LmConfig;
use bundle::{WandBody, WandPose};
use essential::{PairFrame, relative_pose};

/// A calibration wand: collinear markers along its axis (`wand.json`).
#[derive(Debug, Clone, PartialEq)]
pub struct Wand {
    /// Its name.
    pub name: String,
    /// Marker diameter, millimetres.
    pub marker_diameter_mm: f64,
    /// The markers' positions along the axis, millimetres, increasing, the middle one off
    /// centre.
    pub markers_mm: [f64; 3],
}

impl Wand {
    /// A checked wand.
    ///
    /// # Errors
    /// [`WandError::BadWand`] naming what is wrong.
    pub fn new(
        name: String,
        marker_diameter_mm: f64,
        markers_mm: [f64; 3],
    ) -> Result<Self, WandError> {
        let bad = |message: String| Err(WandError::BadWand { message });
        if !(marker_diameter_mm.is_finite() && marker_diameter_mm > 0.0) {
            return bad(format!(
                "marker_diameter_mm must be positive, got {marker_diameter_mm}"
            ));
        }
        let [a, b, c] = markers_mm;
        if !(markers_mm.iter().all(|v| v.is_finite()) && a < b && b < c) {
            return bad(format!(
                "markers_mm must be three increasing positions, got [{a}, {b}, {c}]"
            ));
        }
        if (b - a) < marker_diameter_mm || (c - b) < marker_diameter_mm {
            return bad(format!(
                "markers_mm [{a}, {b}, {c}]: neighbours closer than a marker diameter ({marker_diameter_mm} mm)"
            ));
        }
        if ((b - a) / (c - a) - 0.5).abs() < MIN_SPLIT_ASYMMETRY {
            return bad(format!(
                "markers_mm [{a}, {b}, {c}]: the middle marker must be off centre (at most {:.0} % of the length from either end) so that the ends can be told apart",
                100.0 * (0.5 - MIN_SPLIT_ASYMMETRY)
            ));
        }
        Ok(Self {
            name,
            marker_diameter_mm,
            markers_mm,
        })
    }

    /// Distance from marker 0 to marker 2, millimetres.
    #[must_use]
    pub fn length_mm(&self) -> f64 {
        self.markers_mm[2] - self.markers_mm[0]
    }

    /// Where the middle marker sits between the ends, as a fraction of the length.
    #[must_use]
    pub fn split(&self) -> f64 {
        (self.markers_mm[1] - self.markers_mm[0]) / self.length_mm()
    }

    /// The positions relative to marker 0.
    fn positions_from_start(&self) -> [f64; 3] {
        self.markers_mm.map(|p| p - self.markers_mm[0])
    }
}

/// The middle marker's split must differ from one half by this much (in the wand file and,
/// for an image, seen from a camera): perspective moves the image's split, and a split near
/// one half cannot tell the ends apart.
pub const MIN_SPLIT_ASYMMETRY: f64 = 0.08;

/// Why a wand calibration failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WandError {
    /// The wand description is unusable.
    #[error("wand: {message}")]
    BadWand {
        /// What is wrong.
        message: String,
    },
    /// Too few frames show the wand in two or more cameras.
    #[error(
        "{found} frames show the wand whole in two or more cameras; calibration needs at least {needed}"
    )]
    TooFewFrames {
        /// Frames found.
        found: usize,
        /// Frames needed.
        needed: usize,
    },
    /// A camera shares too few wand frames with the cameras already placed.
    #[error(
        "camera {camera} shares at most {shared} wand frames with the cameras placed before it (needs {needed}): wave the wand where it and another camera both see it"
    )]
    CameraNotLinked {
        /// The camera's name.
        camera: String,
        /// The most frames it shares with a placed camera.
        shared: usize,
        /// Frames needed.
        needed: usize,
    },
    /// A camera pair's correspondences define no relative pose.
    #[error(
        "cameras {a} and {b}: their wand views define no relative pose (the wand barely moved, or stayed in a plane through both cameras)"
    )]
    DegeneratePair {
        /// One camera.
        a: String,
        /// The other.
        b: String,
    },
    /// The wand's markers stayed near one plane: the depth across it is undetermined.
    #[error(
        "the wand's markers stayed within {thickness_mm:.1} mm of one plane ({extent_mm:.0} mm across): wave it through the volume, not in a plane"
    )]
    PlanarDance {
        /// RMS distance of the markers from their best plane, millimetres.
        thickness_mm: f64,
        /// RMS extent along the plane's widest direction, millimetres.
        extent_mm: f64,
    },
    /// The bundle adjustment could not start or gave non-finite poses.
    #[error("the bundle adjustment failed: {message}")]
    Bundle {
        /// Why.
        message: String,
    },
    /// The ground frame was posed in too few frames.
    #[error("ground frame '{tool}': posed in {posed} of {frames} frames (needs {needed})")]
    Ground {
        /// The marker frame's name.
        tool: String,
        /// Frames posed.
        posed: usize,
        /// Frames in the ground recording.
        frames: usize,
        /// Frames needed.
        needed: usize,
    },
}

/// Options of [`wand_views`] and [`calibrate_wand`].
#[derive(Debug, Clone, PartialEq)]
pub struct WandConfig {
    /// Floor of the collinearity gate, ideal pixels: 1 px, well above the sub-pixel scatter
    /// of a marker centre, below where a stray blob usually falls.
    pub min_line_gate_px: f64,
    /// MAD multiples of the collinearity gate and of the residual gate: 5.
    pub gate_mads: f64,
    /// Floor of the residual gate, pixels: 0.3 px, above the reprojection RMS of centres with
    /// the few-hundredths-of-a-pixel noise of bright markers, so that a clean recording loses
    /// no frames to a tiny MAD.
    pub min_residual_gate_px: f64,
    /// Frames with the wand in two or more cameras needed: 20 (100 unknowns of 10 frames'
    /// wands and 6 per camera want several times as many observations).
    pub min_frames: usize,
    /// Frames a camera must share with a placed camera to be placed from it: 10 (30
    /// correspondences for the 8-point algorithm and its refit).
    pub min_shared_frames: usize,
    /// Rounds of dropping camera-frames and adjusting again: 4.
    pub max_rounds: usize,
    /// The adjustment's optimiser (defaults: [`LmConfig::default`], 200 iterations).
    pub lm: LmConfig,
}

impl Default for WandConfig {
    fn default() -> Self {
        Self {
            min_line_gate_px: 1.0,
            gate_mads: 5.0,
            min_residual_gate_px: 0.3,
            min_frames: 20,
            min_shared_frames: 10,
            max_rounds: 4,
            lm: LmConfig::default(),
        }
    }
}

/// `median + k · σ̂` of the values (σ̂ = 1.4826 · MAD, Rousseeuw & Croux 1993), `None` for none.
pub(super) fn robust_gate(values: &[f64], k: f64) -> Option<f64> {
    robust_scale(values).map(|s| s.median + k * s.sigma)
}

/// One camera's result.
#[derive(Debug, Clone, PartialEq)]
pub struct WandCameraResult {
    /// The camera's name.
    pub name: String,
    /// Frames whose wand it saw and that the adjustment used.
    pub frames: usize,
    /// Its camera-frames dropped by the residual gate.
    pub dropped: usize,
    /// RMS reprojection error of its used marker images, pixels.
    pub rms_px: f64,
    /// One standard error of its orientation, degrees (`sqrt(trace Cov(ω))`, 0 for the
    /// reference camera, conditional on the intrinsics).
    pub rotation_std_deg: f64,
    /// One standard error of its centre, millimetres (`sqrt(trace Cov(C))`, in the reference
    /// camera's frame; 0 for the reference camera).
    pub centre_std_mm: f64,
}

/// A wand calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct WandCalibration {
    /// The rig, world = the reference camera's frame (camera 0), millimetres.
    pub rig: Rig,
    /// Per camera, in rig order.
    pub cameras: Vec<WandCameraResult>,
    /// Frames the adjustment used (the wand in two or more cameras after the gate).
    pub frames_used: usize,
    /// Frames with the wand in two or more cameras before the gate, left out by it.
    pub frames_rejected: usize,
    /// The residual gate of the last round, pixels.
    pub residual_gate_px: f64,
    /// RMS of the wand's end-to-end length triangulated independently in each used frame,
    /// minus its true length, millimetres.
    pub length_rms_mm: f64,
    /// Largest absolute such length error, millimetres.
    pub length_max_mm: f64,
    /// Optimiser iterations over all rounds.
    pub iterations: usize,
    /// False when the last adjustment stopped at its iteration limit.
    pub converged: bool,
}

/// Calibrates the extrinsics of `rig`'s cameras (their intrinsics are used as they are, their
/// extrinsics ignored) from the wand views of [`wand_views`]. The world is camera 0's frame.
///
/// # Errors
/// [`WandError`]: too few frames, a camera not linked to the others, a degenerate pair or
/// dance, an adjustment that fails.
pub fn calibrate_wand(
    rig: &Rig,
    views: &[WandFrame],
    wand: &Wand,
    config: &WandConfig,
) -> Result<WandCalibration, WandError> {
    let positions = wand.positions_from_start();
    let params: Vec<CameraParams> = rig
        .cameras
        .iter()
        .map(|c| params_of(&c.intrinsics, &c.distortion))
        .collect();
    let usable: Vec<&WandFrame> = views.iter().filter(|f| f.len() >= 2).collect();
    if usable.len() < config.min_frames {
        return Err(WandError::TooFewFrames {
            found: usable.len(),
            needed: config.min_frames,
        });
    }
    let camera_from_world = initial_cameras(rig, &usable, wand, config)?;
    // Each frame's observations and its starting wand from the linear triangulation.
    let mut start_rig = rig.clone();
    for (camera, pose) in start_rig.cameras.iter_mut().zip(&camera_from_world) {
        camera.camera_from_world = *pose;
    }
    let loose = TriangulateConfig {
        max_residual_px: f64::INFINITY,
        ..TriangulateConfig::default()
    };
    let mut frames: Vec<Vec<View>> = Vec::new();
    let mut wands: Vec<WandPose> = Vec::new();
    for frame in &usable {
        let marker = |k: usize| {
            let pixels: BTreeMap<CameraId, Pixel> =
                frame.iter().map(|(id, p)| (*id, p[k])).collect();
            triangulate(&start_rig, &pixels, &loose)
                .ok()
                .map(|t| t.position)
        };
        let (Some(x0), Some(x2)) = (marker(0), marker(2)) else {
            continue;
        };
        let Some(axis) = Unit::try_new(x2 - x0, 1e-9) else {
            continue;
        };
        frames.push(
            frame
                .iter()
                .map(|(id, p)| View {
                    camera: id.0,
                    pixels: p.iter().copied().enumerate().collect(),
                })
                .collect(),
        );
        wands.push(WandPose { start: x0, axis });
    }
    check_spread(&wands, &positions)?;
    let body = WandBody {
        positions_mm: positions,
    };
    let gate = GateConfig {
        gate_mads: config.gate_mads,
        min_gate_px: config.min_residual_gate_px,
        max_rounds: config.max_rounds,
        min_frames: config.min_frames,
    };
    let start = BundleState {
        camera_from_world,
        bodies: wands,
    };
    let adjusted =
        adjust_gated(&body, &params, frames, start, 0, &gate, &config.lm).map_err(|e| match e {
            AdjustError::BadStart => WandError::Bundle {
                message: "the residuals are undefined at the start (a wand behind a camera)".into(),
            },
            AdjustError::TooFewFrames { found } => WandError::TooFewFrames {
                found,
                needed: config.min_frames,
            },
        })?;
    let state = &adjusted.state;
    if !state
        .camera_from_world
        .iter()
        .all(|p| p.translation.vector.iter().all(|v| v.is_finite()))
    {
        return Err(WandError::Bundle {
            message: "the adjusted poses are not finite".into(),
        });
    }
    let mut calibrated = rig.clone();
    for (camera, pose) in calibrated.cameras.iter_mut().zip(&state.camera_from_world) {
        camera.camera_from_world = *pose;
    }
    let cameras = rig
        .cameras
        .iter()
        .zip(adjusted.camera_fits(&body, &params))
        .zip(&adjusted.dropped_per_camera)
        .map(|((camera, fit), dropped)| WandCameraResult {
            name: camera.name.clone(),
            frames: fit.frames,
            dropped: *dropped,
            rms_px: fit.rms_px,
            rotation_std_deg: fit.std.rotation_deg,
            centre_std_mm: fit.std.centre_mm,
        })
        .collect();
    let frames = &adjusted.frames;
    let report = &adjusted.report;
    let iterations = adjusted.iterations;
    let gate_px = adjusted.gate_px;
    let total_frames = adjusted.frames_before;
    let (length_rms_mm, length_max_mm) = length_errors(&calibrated, frames, wand);
    Ok(WandCalibration {
        rig: calibrated,
        cameras,
        frames_used: frames.len(),
        frames_rejected: total_frames - frames.len(),
        residual_gate_px: gate_px,
        length_rms_mm,
        length_max_mm,
        iterations,
        converged: report.converged,
    })
}

/// Each camera's `camera_from_world` (world = camera 0) from the essential matrices of camera
/// pairs, every camera placed from the placed camera it shares most frames with.
fn initial_cameras(
    rig: &Rig,
    frames: &[&WandFrame],
    wand: &Wand,
    config: &WandConfig,
) -> Result<Vec<Pose>, WandError> {
    let n = rig.len();
    let mut placed: Vec<Option<Pose>> = vec![None; n];
    if let Some(first) = placed.first_mut() {
        *first = Some(Pose::identity());
    }
    let normalised =
        |id: CameraId, px: &Pixel| -> Option<Point2<f64>> { rig.camera(id)?.undistort(px).ok() };
    while placed.iter().any(Option::is_none) {
        // The (placed, unplaced) pair sharing most frames.
        let mut best: Option<(usize, usize, usize)> = None;
        for a in (0..n).filter(|&a| placed[a].is_some()) {
            for b in (0..n).filter(|&b| placed[b].is_none()) {
                let shared = frames
                    .iter()
                    .filter(|f| f.contains_key(&CameraId(a)) && f.contains_key(&CameraId(b)))
                    .count();
                if best.is_none_or(|x| shared > x.2) {
                    best = Some((a, b, shared));
                }
            }
        }
        let Some((a, b, shared)) = best else {
            break;
        };
        if shared < config.min_shared_frames {
            let unplaced = (0..n).find(|&c| placed[c].is_none()).unwrap_or(b);
            return Err(WandError::CameraNotLinked {
                camera: rig.cameras[unplaced].name.clone(),
                shared,
                needed: config.min_shared_frames,
            });
        }
        let pair: Vec<PairFrame> = frames
            .iter()
            .filter_map(|f| {
                let (pa, pb) = (f.get(&CameraId(a))?, f.get(&CameraId(b))?);
                let xa = [
                    normalised(CameraId(a), &pa[0])?,
                    normalised(CameraId(a), &pa[1])?,
                    normalised(CameraId(a), &pa[2])?,
                ];
                let xb = [
                    normalised(CameraId(b), &pb[0])?,
                    normalised(CameraId(b), &pb[1])?,
                    normalised(CameraId(b), &pb[2])?,
                ];
                Some((xa, xb))
            })
            .collect();
        let b_from_a =
            relative_pose(&pair, wand.length_mm()).ok_or_else(|| WandError::DegeneratePair {
                a: rig.cameras[a].name.clone(),
                b: rig.cameras[b].name.clone(),
            })?;
        let a_from_world = placed[a].unwrap_or_else(Pose::identity);
        placed[b] = Some(b_from_a * a_from_world);
    }
    Ok(placed
        .into_iter()
        .map(|p| p.unwrap_or_else(Pose::identity))
        .collect())
}

/// Refuses a dance whose markers stayed near one plane.
fn check_spread(wands: &[WandPose], positions: &[f64; 3]) -> Result<(), WandError> {
    let points: Vec<Point3> = wands
        .iter()
        .flat_map(|w| positions.iter().map(move |p| w.marker(*p)))
        .collect();
    if points.is_empty() {
        return Ok(());
    }
    let mean = points
        .iter()
        .fold(nalgebra::Vector3::zeros(), |s, p| s + p.coords)
        / points.len() as f64;
    let mut scatter = nalgebra::Matrix3::zeros();
    for p in &points {
        let d = p.coords - mean;
        scatter += d * d.transpose();
    }
    scatter /= points.len() as f64;
    let eigen = scatter.symmetric_eigenvalues();
    let smallest = eigen.min().max(0.0).sqrt();
    let largest = eigen.max().max(0.0).sqrt();
    // A plane: the thinnest direction under 2 % of the widest.
    if smallest < 0.02 * largest {
        return Err(WandError::PlanarDance {
            thickness_mm: smallest,
            extent_mm: largest,
        });
    }
    Ok(())
}

/// RMS and max of the end-to-end length error over the frames, each frame's two end markers
/// triangulated independently through `rig`.
fn length_errors(rig: &Rig, frames: &[Vec<View>], wand: &Wand) -> (f64, f64) {
    let config = TriangulateConfig {
        max_residual_px: f64::INFINITY,
        ..TriangulateConfig::default()
    };
    let errors: Vec<f64> = frames
        .iter()
        .filter_map(|observations| {
            let marker = |k: usize| {
                let pixels: BTreeMap<CameraId, Pixel> = observations
                    .iter()
                    .filter_map(|v| {
                        let (_, p) = v.pixels.iter().find(|(m, _)| *m == k)?;
                        Some((CameraId(v.camera), *p))
                    })
                    .collect();
                triangulate(rig, &pixels, &config).ok().map(|t| t.position)
            };
            Some((marker(2)? - marker(0)?).norm() - wand.length_mm())
        })
        .collect();
    if errors.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let max = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    (rms, max)
}
