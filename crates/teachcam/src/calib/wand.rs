//! A rig's extrinsics from a wand waved through the working volume, as optical trackers
//! calibrate (OptiTrack Motive, Vicon, Qualisys; Borghese & Cerveri 2000, *Calibrating a video
//! camera pair with a rigid bar*, Pattern Recognition 33), and the world frame from a marker
//! frame lying on the work object (the paper's vision frame on the object, §V-A).
//!
//! Model: the wand carries two or three collinear markers at `p_0 < … < p_last` millimetres
//! along its axis (two: easyWand's and Argus's wand; three with the middle one off centre,
//! 0/160/500, where the 160/340 split tells the ends apart in one image). In frame f the
//! wand's marker 0 sits at `s_f` with the unit axis `d_f` (5 DOF: a collinear wand has no
//! roll), marker k at `s_f + p_k d_f`; camera i sees it at
//! `u = project(K_i, d_i, camera_from_world_i (s_f + p_k d_f))`, intrinsics known.
//! 1. [`wand_views`]: every camera-frame with exactly as many blobs as markers, undistorted;
//!    three collinear within a gate measured from the recording and ordered by the split
//!    where it is clear; otherwise the ends are left unlabelled.
//! 2. Start: the reference camera (0) is the world; each other camera joins through the solved
//!    camera it shares most frames with, by the essential matrix of their wand
//!    correspondences ([`essential`]), scaled by the wand's end-to-end length. Where the
//!    images do not tell the ends apart, the pair's pairing per frame is the one that fits
//!    the essential matrix of least median error over random samples of frames.
//! 3. Labelling: in every frame each unlabelled camera's order is the one (of every
//!    combination) whose markers triangulate with the least reprojection error through the
//!    current rig; a frame whose second-best labelling also fits within the gate (the wand
//!    in an epipolar plane) is dropped as ambiguous and counted.
//! 4. [`bundle`]: Levenberg–Marquardt over every camera's extrinsics (camera 0 fixed) and
//!    every frame's wand, the wand's lengths exact (they fix the scale). With unlabelled
//!    views the labelling is redone through the adjusted rig and the adjustment run again.
//! 5. Camera-frames whose reprojection RMS lies beyond median + k·MAD of all camera-frames
//!    (a marker hidden and a reflection in its place, two images merged) are dropped and the
//!    adjustment run again, until none is dropped.
//! 6. The wand length (what Motive and easyWand grade a calibration by): each used frame's end
//!    markers triangulated independently through the calibrated rig, `|X_last − X_0|`; its
//!    mean, its standard deviation (easyWand's "wand score" is it in % of the mean) and its
//!    error against `p_last − p_0`.
//!
//! [`set_ground`] then tracks a marker frame lying still on the work object through the
//! calibrated rig ([`crate::track::Tracker`], registration by [`crate::track::pose_from_markers`])
//! and makes its tool frame the world.

mod bundle;
mod essential;
mod ground;
pub mod run;
mod views;

pub use ground::{GroundReport, set_ground};
pub use views::{WandFrame, WandImage, WandViews, wand_views};

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
use essential::{PairCandidate, relative_pose, resolve_pairing};

/// A calibration wand: two or three collinear markers along its axis (`wand.json`).
#[derive(Debug, Clone, PartialEq)]
pub struct Wand {
    /// Its name.
    pub name: String,
    /// Marker diameter, millimetres.
    pub marker_diameter_mm: f64,
    /// The markers' positions along the axis, millimetres, increasing: two (the common wand of
    /// easyWand, Argus and most biomechanics labs), or three (the middle one off centre tells
    /// the ends apart in an image; centred, the ends are told apart by the cameras' agreement
    /// as for two).
    pub markers_mm: Vec<f64>,
}

impl Wand {
    /// A checked wand.
    ///
    /// # Errors
    /// [`WandError::BadWand`] naming what is wrong.
    pub fn new(
        name: String,
        marker_diameter_mm: f64,
        markers_mm: Vec<f64>,
    ) -> Result<Self, WandError> {
        let bad = |message: String| Err(WandError::BadWand { message });
        if !(marker_diameter_mm.is_finite() && marker_diameter_mm > 0.0) {
            return bad(format!(
                "marker_diameter_mm must be positive, got {marker_diameter_mm}"
            ));
        }
        if !(2..=3).contains(&markers_mm.len()) {
            return bad(format!(
                "markers_mm: a wand has 2 or 3 collinear markers, got {}",
                markers_mm.len()
            ));
        }
        if !(markers_mm.iter().all(|v| v.is_finite()) && markers_mm.windows(2).all(|w| w[0] < w[1]))
        {
            return bad(format!(
                "markers_mm must be increasing positions, got {markers_mm:?}"
            ));
        }
        if markers_mm
            .windows(2)
            .any(|w| (w[1] - w[0]) < marker_diameter_mm)
        {
            return bad(format!(
                "markers_mm {markers_mm:?}: neighbours closer than a marker diameter ({marker_diameter_mm} mm)"
            ));
        }
        Ok(Self {
            name,
            marker_diameter_mm,
            markers_mm,
        })
    }

    /// Distance from the first marker to the last, millimetres.
    #[must_use]
    pub fn length_mm(&self) -> f64 {
        self.markers_mm.last().copied().unwrap_or(0.0)
            - self.markers_mm.first().copied().unwrap_or(0.0)
    }

    /// Where the middle marker of a three-marker wand sits between the ends, as a fraction of
    /// the length (`None` for two markers).
    #[must_use]
    pub fn split(&self) -> Option<f64> {
        match self.markers_mm.as_slice() {
            [a, b, _] => Some((b - a) / self.length_mm()),
            _ => None,
        }
    }

    /// Whether one image can tell the ends apart: three markers, the middle one off centre by
    /// at least [`MIN_SPLIT_ASYMMETRY`].
    #[must_use]
    pub fn ends_told_apart(&self) -> bool {
        self.split()
            .is_some_and(|s| (s - 0.5).abs() >= MIN_SPLIT_ASYMMETRY)
    }

    /// The positions relative to the first marker.
    fn positions_from_start(&self) -> Vec<f64> {
        let first = self.markers_mm.first().copied().unwrap_or(0.0);
        self.markers_mm.iter().map(|p| p - first).collect()
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
    /// Frames with the wand in two or more cameras left out because no labelling of their
    /// unlabelled ends fitted clearly better than another (the wand in an epipolar plane).
    pub frames_ambiguous: usize,
    /// The residual gate of the last round, pixels.
    pub residual_gate_px: f64,
    /// Mean of the wand's end-to-end length triangulated independently in each used frame,
    /// millimetres.
    pub length_mean_mm: f64,
    /// Standard deviation of those lengths, millimetres.
    pub length_std_mm: f64,
    /// RMS of those lengths minus the wand's true length, millimetres.
    pub length_rms_mm: f64,
    /// Largest absolute such length error, millimetres.
    pub length_max_mm: f64,
    /// Optimiser iterations over all rounds.
    pub iterations: usize,
    /// False when the last adjustment stopped at its iteration limit.
    pub converged: bool,
}

impl WandCalibration {
    /// The wand length's standard deviation in % of its mean (easyWand's wand score).
    #[must_use]
    pub fn length_std_percent(&self) -> f64 {
        100.0 * self.length_std_mm / self.length_mean_mm
    }
}

/// `rig` with the cameras placed at `camera_from_world`.
fn placed(rig: &Rig, camera_from_world: &[Pose]) -> Rig {
    let mut out = rig.clone();
    for (camera, pose) in out.cameras.iter_mut().zip(camera_from_world) {
        camera.camera_from_world = *pose;
    }
    out
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
    let unlabelled = usable
        .iter()
        .any(|f| f.values().any(|image| !image.ends_known));
    let labelled = label_frames(&placed(rig, &camera_from_world), &usable, config);
    check_spread(&labelled.wands, &positions)?;
    let body = WandBody {
        positions_mm: positions,
    };
    let gate = GateConfig {
        gate_mads: config.gate_mads,
        min_gate_px: config.min_residual_gate_px,
        max_rounds: config.max_rounds,
        min_frames: config.min_frames,
    };
    let adjust = |labelled: Labelled, camera_from_world: Vec<Pose>| {
        let start = BundleState {
            camera_from_world,
            bodies: labelled.wands,
        };
        adjust_gated(&body, &params, labelled.frames, start, 0, &gate, &config.lm).map_err(|e| {
            match e {
                AdjustError::BadStart => WandError::Bundle {
                    message: "the residuals are undefined at the start (a wand behind a camera)"
                        .into(),
                },
                AdjustError::TooFewFrames { found } => WandError::TooFewFrames {
                    found,
                    needed: config.min_frames,
                },
            }
        })
    };
    let mut ambiguous = labelled.ambiguous;
    let mut adjusted = adjust(labelled, camera_from_world)?;
    if unlabelled {
        // The labelling again, through the adjusted rig, and the adjustment from it.
        let cameras = adjusted.state.camera_from_world.clone();
        let relabelled = label_frames(&placed(rig, &cameras), &usable, config);
        ambiguous = relabelled.ambiguous;
        let iterations = adjusted.iterations;
        adjusted = adjust(relabelled, cameras)?;
        adjusted.iterations += iterations;
    }
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
    let calibrated = placed(rig, &state.camera_from_world);
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
    let lengths = wand_lengths(&calibrated, frames, wand.markers_mm.len());
    let stats = LengthStats::of(&lengths, wand.length_mm());
    Ok(WandCalibration {
        rig: calibrated,
        cameras,
        frames_used: frames.len(),
        frames_rejected: adjusted.frames_before - frames.len(),
        frames_ambiguous: ambiguous,
        residual_gate_px: adjusted.gate_px,
        length_mean_mm: stats.mean,
        length_std_mm: stats.std,
        length_rms_mm: stats.error_rms,
        length_max_mm: stats.error_max,
        iterations: adjusted.iterations,
        converged: adjusted.report.converged,
    })
}

/// Frames labelled for the adjustment.
struct Labelled {
    /// Per kept frame, its views in wand order.
    frames: Vec<Vec<View>>,
    /// Per kept frame, its wand triangulated through the rig.
    wands: Vec<WandPose>,
    /// Frames left out as ambiguous.
    ambiguous: usize,
}

/// Most unlabelled cameras in one frame whose orders are tried in every combination (2¹²).
const MAX_FREE_CAMERAS: usize = 12;

/// Every frame's views in wand order: each camera whose image left the ends unlabelled takes
/// the order that, with the others', triangulates the markers with the least reprojection
/// RMS through `rig` (every combination tried; with no camera labelled, the first camera's
/// order is the wand's: the symmetric wand's two directions are the same wand). A frame whose
/// second-best combination also fits within `median + k·σ̂` of the frames' best RMS (floor
/// `min_residual_gate_px`) is left out as ambiguous.
fn label_frames(rig: &Rig, frames: &[&WandFrame], config: &WandConfig) -> Labelled {
    let loose = TriangulateConfig {
        max_residual_px: f64::INFINITY,
        ..TriangulateConfig::default()
    };
    // The reprojection RMS of one labelling (over the markers that triangulate; the ends
    // must) and its end markers.
    let fit = |images: &[(CameraId, &WandImage)], reversed: &[bool]| {
        let markers = images.first().map_or(0, |(_, i)| i.pixels.len());
        let mut sum = 0.0;
        let mut count = 0usize;
        let mut ends = (None, None);
        for k in 0..markers {
            let pixels: BTreeMap<CameraId, Pixel> = images
                .iter()
                .zip(reversed)
                .map(|((id, image), r)| {
                    let n = image.pixels.len();
                    (*id, image.pixels[if *r { n - 1 - k } else { k }])
                })
                .collect();
            let end = k == 0 || k + 1 == markers;
            let point = match triangulate(rig, &pixels, &loose) {
                Ok(point) => point,
                // A middle marker that does not triangulate through a rough start leaves the
                // frame to its ends.
                Err(_) if !end => continue,
                Err(_) => return None,
            };
            sum += point.residual_px * point.residual_px * pixels.len() as f64;
            count += pixels.len();
            if k == 0 {
                ends.0 = Some(point.position);
            }
            if k + 1 == markers {
                ends.1 = Some(point.position);
            }
        }
        let (Some(first), Some(last)) = ends else {
            return None;
        };
        Some(((sum / count.max(1) as f64).sqrt(), first, last))
    };
    // (frame index, reversed per camera, best RMS, second-best RMS, wand).
    let mut found: Vec<(usize, Vec<bool>, f64, f64, WandPose)> = Vec::new();
    for (f, frame) in frames.iter().enumerate() {
        let images: Vec<(CameraId, &WandImage)> = frame.iter().map(|(id, i)| (*id, i)).collect();
        let any_known = images.iter().any(|(_, i)| i.ends_known);
        let free: Vec<usize> = (0..images.len())
            .filter(|&c| !images[c].1.ends_known && (any_known || c > 0))
            .collect();
        if free.len() > MAX_FREE_CAMERAS {
            continue;
        }
        let mut best: Option<(f64, Vec<bool>, Point3, Point3)> = None;
        let mut second = f64::INFINITY;
        for combination in 0..(1usize << free.len()) {
            let mut reversed = vec![false; images.len()];
            for (bit, &c) in free.iter().enumerate() {
                reversed[c] = combination >> bit & 1 == 1;
            }
            let Some((rms, first, last)) = fit(&images, &reversed) else {
                continue;
            };
            match &best {
                Some(b) if rms >= b.0 => second = second.min(rms),
                _ => {
                    if let Some(b) = &best {
                        second = second.min(b.0);
                    }
                    best = Some((rms, reversed, first, last));
                }
            }
        }
        let Some((rms, reversed, first, last)) = best else {
            continue;
        };
        let Some(axis) = Unit::try_new(last - first, 1e-9) else {
            continue;
        };
        found.push((f, reversed, rms, second, WandPose { start: first, axis }));
    }
    let best_rms: Vec<f64> = found.iter().map(|x| x.2).collect();
    let gate = robust_gate(&best_rms, config.gate_mads)
        .unwrap_or(f64::INFINITY)
        .max(config.min_residual_gate_px);
    let mut out = Labelled {
        frames: Vec::new(),
        wands: Vec::new(),
        ambiguous: 0,
    };
    for (f, reversed, _, second, wand) in found {
        if second <= gate {
            out.ambiguous += 1;
            continue;
        }
        out.frames.push(
            frames[f]
                .iter()
                .zip(&reversed)
                .map(|((id, image), r)| View {
                    camera: id.0,
                    pixels: image.ordered(*r).into_iter().enumerate().collect(),
                })
                .collect(),
        );
        out.wands.push(wand);
    }
    out
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
    let normalised = |id: CameraId, image: &WandImage| -> Option<Vec<Point2<f64>>> {
        let camera = rig.camera(id)?;
        image
            .pixels
            .iter()
            .map(|p| camera.undistort(p).ok())
            .collect()
    };
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
        let candidates: Vec<PairCandidate> = frames
            .iter()
            .filter_map(|f| {
                let (ia, ib) = (f.get(&CameraId(a))?, f.get(&CameraId(b))?);
                Some(PairCandidate {
                    a: normalised(CameraId(a), ia)?,
                    b: normalised(CameraId(b), ib)?,
                    fixed: ia.ends_known && ib.ends_known,
                })
            })
            .collect();
        let degenerate = || WandError::DegeneratePair {
            a: rig.cameras[a].name.clone(),
            b: rig.cameras[b].name.clone(),
        };
        let (pair, _) = resolve_pairing(&candidates).ok_or_else(degenerate)?;
        let b_from_a = relative_pose(&pair, wand.length_mm()).ok_or_else(degenerate)?;
        let a_from_world = placed[a].unwrap_or_else(Pose::identity);
        placed[b] = Some(b_from_a * a_from_world);
    }
    Ok(placed
        .into_iter()
        .map(|p| p.unwrap_or_else(Pose::identity))
        .collect())
}

/// Refuses a dance whose markers stayed near one plane.
fn check_spread(wands: &[WandPose], positions: &[f64]) -> Result<(), WandError> {
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

/// Each frame's wand length: its end markers (0 and `markers − 1`) triangulated
/// independently through `rig`, millimetres.
fn wand_lengths(rig: &Rig, frames: &[Vec<View>], markers: usize) -> Vec<f64> {
    let config = TriangulateConfig {
        max_residual_px: f64::INFINITY,
        ..TriangulateConfig::default()
    };
    frames
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
            Some((marker(markers.checked_sub(1)?)? - marker(0)?).norm())
        })
        .collect()
}

/// Mean, standard deviation and error against the true length of wand lengths.
struct LengthStats {
    mean: f64,
    std: f64,
    error_rms: f64,
    error_max: f64,
}

impl LengthStats {
    /// The statistics of `lengths` (NaN for none).
    fn of(lengths: &[f64], true_mm: f64) -> Self {
        if lengths.is_empty() {
            return Self {
                mean: f64::NAN,
                std: f64::NAN,
                error_rms: f64::NAN,
                error_max: f64::NAN,
            };
        }
        let n = lengths.len() as f64;
        let mean = lengths.iter().sum::<f64>() / n;
        let std =
            (lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
        let error_rms = (lengths.iter().map(|l| (l - true_mm).powi(2)).sum::<f64>() / n).sqrt();
        let error_max = lengths
            .iter()
            .fold(0.0f64, |m, l| m.max((l - true_mm).abs()));
        Self {
            mean,
            std,
            error_rms,
            error_max,
        }
    }
}
