//! A rig's extrinsics refined from any tracked recording, the tool's marker geometry fixing the
//! scale: a calibration that has drifted (a bumped camera) is mended from the footage itself,
//! as optical trackers refine continuously (OptiTrack Motive's continuous calibration).
//!
//! Model: in frame f the tool is at `world_from_tool_f` (6 DOF), its marker k at
//! `X_fk = world_from_tool_f m_k` with `m_k` exact from the tool file; camera i sees it at
//! `u = project(K_i, d_i, camera_from_world_i X_fk)`, intrinsics held as given. The unknowns
//! are every camera's extrinsics but one and every used frame's tool pose, solved by the
//! rig bundle adjustment ([`super::bundle`], the same as the wand's, with a 6-DOF body).
//!
//! Rounds (track → adjust → track): the caller tracks the recording through the current rig
//! (the first round with the gates widened, since a bumped camera moves its images off the
//! epipolar lines and loses most frames at the measured gates); frames whose identification is
//! confident ([`confident_views`]) give the observations; the adjustment moves the cameras;
//! the next round tracks through the moved rig. Rounds stop when no camera moves by more than
//! [`RefineConfig::settled_deg`] / [`RefineConfig::settled_mm`], or after
//! [`RefineConfig::max_rounds`].
//!
//! Gauge: the world stays where the input rig has it by holding one camera fixed, the one
//! that agrees best with the others (the smallest median over its pairs of the median
//! epipolar distance, first round's observations; ties go to the lower index), or the one the
//! caller names. With two cameras which one moved cannot be told from the footage: the pair's
//! relative pose is what the recording measures, and camera 0 is held unless told otherwise.

use std::collections::BTreeMap;

use nalgebra::{Isometry3, SMatrix, SVector, Vector2, Vector3};

use super::bundle::{AdjustError, Body, BundleState, GateConfig, View, adjust_gated};
use super::intrinsics::{CameraParams, params_of, point_d_pose};
use super::lm::LmConfig;
use super::refine_intrinsics::{
    CameraIntrinsicsFit, Intrinsic, IntrinsicsRefineConfig, Observed, held_out_rigidity,
    refine_intrinsics,
};
use crate::camera::{Rig, epipolar_line, fundamental_matrix, pixel_difference};
use crate::correspond::Views;
use crate::geometry::{CameraId, Pixel, Point3, Pose, rotation_angle_between};
use crate::tool::Tool;
use crate::track::FrameTrack;
use crate::trajectory::Status;

/// The tool as a body of the bundle adjustment: pose `world_from_tool`, stepped by the left
/// perturbation `exp(ω, τ) · world_from_tool`.
pub(super) struct ToolBody<'a> {
    pub(super) markers_in_tool: &'a [Point3],
}

impl Body<6> for ToolBody<'_> {
    type Pose = Pose;

    fn marker(&self, world_from_tool: &Pose, marker: usize) -> (Point3, SMatrix<f64, 3, 6>) {
        let x = world_from_tool.transform_point(&self.markers_in_tool[marker]);
        (x, point_d_pose(&x))
    }

    fn retract(&self, world_from_tool: &Pose, step: &SVector<f64, 6>) -> Pose {
        let omega = Vector3::new(step[0], step[1], step[2]);
        let tau = Vector3::new(step[3], step[4], step[5]);
        Isometry3::new(tau, omega) * world_from_tool
    }
}

/// Options of [`refine_rig`].
#[derive(Debug, Clone, PartialEq)]
pub struct RefineConfig {
    /// Confident frames needed: 20 (6 unknowns per frame and 6 per camera want several times
    /// as many observations; a recording has hundreds).
    pub min_frames: usize,
    /// The camera held fixed (the gauge); `None`: the best-agreeing camera.
    pub hold: Option<CameraId>,
    /// MAD multiples of the residual gate: 5, as the wand's.
    pub gate_mads: f64,
    /// Floor of the residual gate, pixels: 0.3 px, as the wand's (above the reprojection RMS
    /// of bright marker centres, so that a clean recording loses no frames to a tiny MAD).
    pub min_residual_gate_px: f64,
    /// Rounds of dropping camera-frames within one adjustment: 4.
    pub max_gate_rounds: usize,
    /// Rounds of track → adjust: 3 (the first moves a bumped camera most of the way, the
    /// second tracks the frames the first rig lost, the third confirms).
    pub max_rounds: usize,
    /// A round that moves no camera by more than this many degrees ...: 0.002°.
    pub settled_deg: f64,
    /// ... and millimetres ends the rounds: 0.01 mm.
    pub settled_mm: f64,
    /// Confident frames each camera must see: 10 (its 6 unknowns from at least 30 marker
    /// images).
    pub min_camera_frames: usize,
    /// A camera missing from a confident frame (its views left out by triangulation or
    /// correspondence: the bumped camera) gets its blobs back when they sit within this
    /// fraction of its image width of where the other cameras put the markers: 0.05 (64 px on
    /// 1280 px, about 2° at a 1790 px focal length).
    pub max_offset_fraction: f64,
    /// ... and every marker's blob is offset like the others within this many pixels: 3 (a
    /// bump turns the camera, which shifts a tool's few-centimetre image almost uniformly),
    /// with no second blob that close.
    pub offset_agreement_px: f64,
    /// The adjustment's optimiser.
    pub lm: LmConfig,
    /// Intrinsics to refine per camera where the footage determines them
    /// ([`super::refine_intrinsics`]): focal length, principal point, k1; empty: extrinsics only.
    pub intrinsics: Vec<Intrinsic>,
    /// Also try `k2`, kept only where it makes the tool more rigid on the held-out frames.
    pub try_k2: bool,
    /// Every this many confident frames one is held out to judge the candidate rigs: 5.
    pub hold_out_every: usize,
    /// Options of the intrinsics' adjustment.
    pub intrinsics_config: IntrinsicsRefineConfig,
}

impl Default for RefineConfig {
    fn default() -> Self {
        Self {
            min_frames: 20,
            hold: None,
            gate_mads: 5.0,
            min_residual_gate_px: 0.3,
            max_gate_rounds: 4,
            max_rounds: 3,
            settled_deg: 0.002,
            settled_mm: 0.01,
            min_camera_frames: 10,
            max_offset_fraction: 0.05,
            offset_agreement_px: 3.0,
            lm: LmConfig::default(),
            intrinsics: vec![
                Intrinsic::Focal,
                Intrinsic::Cx,
                Intrinsic::Cy,
                Intrinsic::K1,
            ],
            try_k2: true,
            hold_out_every: 5,
            intrinsics_config: IntrinsicsRefineConfig::default(),
        }
    }
}

/// Why a refinement failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RefineError {
    /// The tool was posed in no frame.
    #[error("the tool '{tool}' was posed in none of the {frames} frames")]
    ToolNotFound {
        /// The tool's name.
        tool: String,
        /// Frames tracked.
        frames: usize,
    },
    /// Too few frames were tracked with confidence.
    #[error(
        "{found} frames tracked with confidence (every marker identified in two or more cameras, no rival labelling); refinement needs at least {needed}"
    )]
    TooFewFrames {
        /// Confident frames found.
        found: usize,
        /// Frames needed.
        needed: usize,
    },
    /// A camera sees the tool in too few confident frames.
    #[error(
        "camera {camera} sees the tool in {frames} confident frames; refinement needs {needed} per camera"
    )]
    CameraUnseen {
        /// The camera's name.
        camera: String,
        /// Confident frames it sees.
        frames: usize,
        /// Frames needed.
        needed: usize,
    },
    /// The camera to hold is not in the rig.
    #[error("camera {camera} to hold fixed is not in the rig ({cameras} cameras)")]
    UnknownHold {
        /// The index asked for.
        camera: usize,
        /// Cameras in the rig.
        cameras: usize,
    },
    /// The adjustment could not start or gave non-finite poses.
    #[error("the bundle adjustment failed: {message}")]
    Bundle {
        /// Why.
        message: String,
    },
}

/// One frame's confident observations.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfidentFrame {
    /// The frame's index in the tracks.
    pub frame: usize,
    /// The tool's pose through the rig it was tracked with.
    pub world_from_tool: Pose,
    /// Per camera, the identified markers it saw: `(marker index, distorted pixel)`.
    pub views: BTreeMap<CameraId, Vec<(usize, Pixel)>>,
}

/// The frames whose identification is confident: a pose that is not an outlier, every marker
/// of the tool identified, each in two or more cameras, no rival labelling. Ambiguous
/// pairings are allowed: the tracker already loses a frame whose rival combination fits the
/// tool nearly as well, and with widened gates (a bumped camera) nearly every frame of a
/// two-camera rig has several.
#[must_use]
pub fn confident_views(tool: &Tool, tracks: &[FrameTrack]) -> Vec<ConfidentFrame> {
    tracks
        .iter()
        .enumerate()
        .filter_map(|(frame, track)| {
            let pose = track.outcome.as_ref().ok()?;
            let confident = track.status() != Status::Outlier
                && track.labels.len() == tool.markers_in_tool.len()
                && track.rival_in_world.is_none();
            if !confident {
                return None;
            }
            let mut views: BTreeMap<CameraId, Vec<(usize, Pixel)>> = BTreeMap::new();
            for (marker, point) in &track.labels {
                let point = track.points.get(*point)?;
                if point.views.len() < 2 {
                    return None;
                }
                for (camera, pixel) in &point.views {
                    views.entry(*camera).or_default().push((marker.0, *pixel));
                }
            }
            Some(ConfidentFrame {
                frame,
                world_from_tool: pose.world_from_tool,
                views,
            })
        })
        .collect()
}

/// The median epipolar distance of one camera pair over the same observations.
#[derive(Debug, Clone, PartialEq)]
pub struct PairEpipolar {
    /// One camera's name.
    pub a: String,
    /// The other's.
    pub b: String,
    /// Marker images seen by both.
    pub count: usize,
    /// Median distance of b's ideal pixel from a's epipolar line through the input rig, px.
    pub before_px: f64,
    /// The same through the refined rig, px.
    pub after_px: f64,
}

/// What moved in one camera and how well it is now known.
#[derive(Debug, Clone, PartialEq)]
pub struct RefinedCamera {
    /// The camera's name.
    pub name: String,
    /// Its centre's displacement from the input rig, millimetres.
    pub moved_mm: f64,
    /// Its rotation's change from the input rig, degrees.
    pub turned_deg: f64,
    /// Camera-frames it contributed to the last adjustment.
    pub frames: usize,
    /// Its camera-frames dropped by the residual gate in the last adjustment.
    pub dropped: usize,
    /// RMS reprojection error of its marker images, pixels.
    pub rms_px: f64,
    /// One standard error of its orientation, degrees (0 for the held camera; conditional on
    /// the intrinsics).
    pub rotation_std_deg: f64,
    /// One standard error of its centre, millimetres (0 for the held camera).
    pub centre_std_mm: f64,
}

/// A refinement.
#[derive(Debug, Clone, PartialEq)]
pub struct Refinement {
    /// The refined rig (world where the input rig has it: the held camera unchanged).
    pub rig: Rig,
    /// The camera held fixed.
    pub held: CameraId,
    /// Per camera, in rig order.
    pub cameras: Vec<RefinedCamera>,
    /// Per camera pair, the epipolar distance before and after, on the last round's
    /// observations.
    pub pairs: Vec<PairEpipolar>,
    /// Per round, the frames tracked with confidence.
    pub confident_per_round: Vec<usize>,
    /// Frames the last adjustment used.
    pub frames_used: usize,
    /// Confident frames of the last round the residual gate left out.
    pub frames_rejected: usize,
    /// The residual gate of the last adjustment, pixels.
    pub residual_gate_px: f64,
    /// False when the last adjustment stopped at its iteration limit.
    pub converged: bool,
    /// Per camera, the chosen adjustment's intrinsics (freed with σ, held with why); empty
    /// when the input rig was kept.
    pub intrinsics: Vec<CameraIntrinsicsFit>,
    /// The tool's markers as the chosen adjustment fitted them (scale kept).
    pub markers_in_tool: Vec<Point3>,
    /// Each candidate's rigidity on the held-out frames (pooled std of the marker distances,
    /// mm; `None` when not measurable) by name: "extrinsics", "intrinsics", "intrinsics + k2".
    pub held_out: Vec<(String, Option<f64>)>,
    /// The input rig's rigidity on the same frames.
    pub input_rigidity_mm: Option<f64>,
    /// Confident frames held out.
    pub held_out_frames: usize,
    /// The candidate with the most rigid tool on the held-out frames.
    pub chosen: String,
    /// True when that candidate was not better there than the input rig, which is written
    /// unchanged.
    pub kept_input: bool,
}

/// Gives each camera missing from a confident frame its blobs back (`blobs`: the frame's
/// blob centres by camera, as tracked): the tool's markers at the frame's pose projected into
/// the camera, each one's nearest blob within [`RefineConfig::max_offset_fraction`] of the
/// image width, their median offset, then each marker's blob within
/// [`RefineConfig::offset_agreement_px`] of its projection plus that offset, one blob each and
/// no second one as close. A camera whose markers do not all match stays missing.
fn recover_views(
    rig: &Rig,
    tool: &Tool,
    frame: &mut ConfidentFrame,
    blobs: &Views,
    config: &RefineConfig,
) {
    for (id, camera) in rig.iter() {
        if frame.views.contains_key(&id) {
            continue;
        }
        let Some(blobs) = blobs.get(&id) else {
            continue;
        };
        let projected: Vec<Pixel> = tool
            .markers_in_tool
            .iter()
            .filter_map(|m| camera.project(&frame.world_from_tool.transform_point(m)))
            .collect();
        if projected.len() != tool.markers_in_tool.len() || blobs.len() < projected.len() {
            continue;
        }
        let max_offset = config.max_offset_fraction * f64::from(camera.image_size.width);
        let nearest = |at: &Pixel| -> Option<Vector2<f64>> {
            blobs
                .iter()
                .map(|b| pixel_difference(b, at))
                .min_by(|a, b| a.norm().total_cmp(&b.norm()))
                .filter(|d| d.norm() <= max_offset)
        };
        let offsets: Option<Vec<Vector2<f64>>> = projected.iter().map(nearest).collect();
        let Some(offsets) = offsets else {
            continue;
        };
        let median = |axis: usize| {
            let mut v: Vec<f64> = offsets.iter().map(|o| o[axis]).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let offset = Vector2::new(median(0), median(1));
        let mut matched: Vec<(usize, Pixel)> = Vec::new();
        for (marker, at) in projected.iter().enumerate() {
            let expected = Pixel::new(at.x + offset.x, at.y + offset.y);
            let close: Vec<&Pixel> = blobs
                .iter()
                .filter(|b| pixel_difference(b, &expected).norm() <= config.offset_agreement_px)
                .collect();
            if let [blob] = close.as_slice()
                && !matched.iter().any(|(_, p)| p == *blob)
            {
                matched.push((marker, **blob));
            } else {
                break;
            }
        }
        if matched.len() == projected.len() {
            frame.views.insert(id, matched);
        }
    }
}

/// Per camera pair `(a < b)`, the marker images both saw, as ideal pixels through `rig`, and
/// the median distance from the epipolar line.
fn pair_medians(rig: &Rig, frames: &[ConfidentFrame]) -> BTreeMap<(usize, usize), (usize, f64)> {
    let mut distances: BTreeMap<(usize, usize), Vec<f64>> = BTreeMap::new();
    let fundamentals = rig.fundamental_matrices();
    for frame in frames {
        for (a, views_a) in &frame.views {
            for (b, views_b) in frame.views.range(CameraId(a.0 + 1)..) {
                let (Some(ca), Some(cb)) = (rig.camera(*a), rig.camera(*b)) else {
                    continue;
                };
                for (marker, pa) in views_a {
                    let Some((_, pb)) = views_b.iter().find(|(m, _)| m == marker) else {
                        continue;
                    };
                    let (Ok(ia), Ok(ib)) = (ca.ideal_pixel(pa), cb.ideal_pixel(pb)) else {
                        continue;
                    };
                    let f = fundamentals
                        .get(a.0)
                        .and_then(|row| row.get(b.0))
                        .copied()
                        .unwrap_or_else(|| fundamental_matrix(ca, cb));
                    if let Some(line) = epipolar_line(&f, &ia) {
                        distances
                            .entry((a.0, b.0))
                            .or_default()
                            .push(line.distance(&ib));
                    }
                }
            }
        }
    }
    distances
        .into_iter()
        .filter_map(|(pair, mut d)| {
            d.sort_by(f64::total_cmp);
            let median = *d.get(d.len() / 2)?;
            Some((pair, (d.len(), median)))
        })
        .collect()
}

/// The camera that agrees best with the others: the smallest median, over the pairs it is in,
/// of the pair's median epipolar distance; ties to the lower index.
fn best_agreeing(rig: &Rig, frames: &[ConfidentFrame]) -> CameraId {
    let pairs = pair_medians(rig, frames);
    let mut best = (0, f64::INFINITY);
    for c in 0..rig.len() {
        let mut mine: Vec<f64> = pairs
            .iter()
            .filter(|((a, b), _)| *a == c || *b == c)
            .map(|(_, (_, m))| *m)
            .collect();
        if mine.is_empty() {
            continue;
        }
        mine.sort_by(f64::total_cmp);
        let median = mine[(mine.len() - 1) / 2];
        // A margin of 1 % so that equal agreement (two cameras) keeps the lower index.
        if median < 0.99 * best.1 {
            best = (c, median);
        }
    }
    CameraId(best.0)
}

/// One adjustment of `rig` from confident frames, `held` fixed.
fn adjust_once(
    rig: &Rig,
    params: &[CameraParams],
    body: &ToolBody<'_>,
    frames: &[ConfidentFrame],
    held: CameraId,
    config: &RefineConfig,
) -> Result<super::bundle::Adjusted<Pose>, RefineError> {
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
    let start = BundleState {
        camera_from_world: rig.cameras.iter().map(|c| c.camera_from_world).collect(),
        bodies: frames.iter().map(|f| f.world_from_tool).collect(),
    };
    let gate = GateConfig {
        gate_mads: config.gate_mads,
        min_gate_px: config.min_residual_gate_px,
        max_rounds: config.max_gate_rounds,
        min_frames: config.min_frames,
    };
    let adjusted = adjust_gated(body, params, views, start, held.0, &gate, &config.lm).map_err(
        |e| match e {
            AdjustError::BadStart => RefineError::Bundle {
                message: "the residuals are undefined at the start (a marker behind a camera)"
                    .into(),
            },
            AdjustError::TooFewFrames { found } => RefineError::TooFewFrames {
                found,
                needed: config.min_frames,
            },
        },
    )?;
    let finite = adjusted.state.camera_from_world.iter().all(|p| {
        p.translation
            .vector
            .iter()
            .chain(p.rotation.coords.iter())
            .all(|v| v.is_finite())
    });
    if !finite {
        return Err(RefineError::Bundle {
            message: "the adjusted poses are not finite".into(),
        });
    }
    Ok(adjusted)
}

/// Refines `rig`'s extrinsics (intrinsics held) from a recording of `tool` whose blob centres
/// are `blobs` (per frame, by camera): `track(rig, round)` tracks every frame of it through
/// `rig` (one track per frame, in order), and the rounds run as the module says.
///
/// # Errors
/// [`RefineError`]: the tool never posed, too few confident frames, an unknown held camera, an
/// adjustment that fails.
pub fn refine_rig(
    rig: &Rig,
    tool: &Tool,
    blobs: &[Views],
    config: &RefineConfig,
    mut track: impl FnMut(&Rig, usize) -> Vec<FrameTrack>,
) -> Result<Refinement, RefineError> {
    if let Some(hold) = config.hold
        && hold.0 >= rig.len()
    {
        return Err(RefineError::UnknownHold {
            camera: hold.0,
            cameras: rig.len(),
        });
    }
    let params: Vec<CameraParams> = rig
        .cameras
        .iter()
        .map(|c| params_of(&c.intrinsics, &c.distortion))
        .collect();
    let body = ToolBody {
        markers_in_tool: &tool.markers_in_tool,
    };
    let mut current = rig.clone();
    let mut held = config.hold;
    let mut confident_per_round = Vec::new();
    let mut last = None;
    for round in 0..config.max_rounds.max(1) {
        let tracks = track(&current, round);
        if tracks.iter().all(|t| t.outcome.is_err()) {
            return Err(RefineError::ToolNotFound {
                tool: tool.name.clone(),
                frames: tracks.len(),
            });
        }
        let mut frames = confident_views(tool, &tracks);
        confident_per_round.push(frames.len());
        if frames.len() < config.min_frames {
            return Err(RefineError::TooFewFrames {
                found: frames.len(),
                needed: config.min_frames,
            });
        }
        for frame in &mut frames {
            if let Some(views) = blobs.get(frame.frame) {
                recover_views(&current, tool, frame, views, config);
            }
        }
        for (id, camera) in current.iter() {
            let seen = frames.iter().filter(|f| f.views.contains_key(&id)).count();
            if seen < config.min_camera_frames {
                return Err(RefineError::CameraUnseen {
                    camera: camera.name.clone(),
                    frames: seen,
                    needed: config.min_camera_frames,
                });
            }
        }
        let hold = *held.get_or_insert_with(|| best_agreeing(&current, &frames));
        let adjusted = adjust_once(&current, &params, &body, &frames, hold, config)?;
        let mut moved = current.clone();
        for (camera, pose) in moved
            .cameras
            .iter_mut()
            .zip(&adjusted.state.camera_from_world)
        {
            camera.camera_from_world = *pose;
        }
        let settled = current.cameras.iter().zip(&moved.cameras).all(|(a, b)| {
            rotation_angle_between(&a.camera_from_world, &b.camera_from_world).to_degrees()
                <= config.settled_deg
                && (a.center_in_world() - b.center_in_world()).norm() <= config.settled_mm
        });
        current = moved;
        last = Some(frames);
        if settled {
            break;
        }
    }
    let (Some(frames), Some(held)) = (last, held) else {
        return Err(RefineError::TooFewFrames {
            found: 0,
            needed: config.min_frames,
        });
    };
    let judged = judge_candidates(rig, &current, tool, &frames, held, config)?;
    let chosen = &judged.candidates[judged.chosen];
    let written = if judged.kept_input { rig } else { &chosen.rig };
    let cameras = rig
        .cameras
        .iter()
        .zip(&written.cameras)
        .zip(&chosen.fits)
        .map(|((before, after), fit)| RefinedCamera {
            name: before.name.clone(),
            moved_mm: (before.center_in_world() - after.center_in_world()).norm(),
            turned_deg: rotation_angle_between(&before.camera_from_world, &after.camera_from_world)
                .to_degrees(),
            frames: fit.frames,
            dropped: fit.dropped,
            rms_px: fit.rms_px,
            rotation_std_deg: fit.rotation_std_deg,
            centre_std_mm: fit.centre_std_mm,
        })
        .collect();
    let current = written.clone();
    let before = pair_medians(rig, &frames);
    let after = pair_medians(&current, &frames);
    let pairs = before
        .iter()
        .map(|((a, b), (count, before_px))| PairEpipolar {
            a: rig.cameras[*a].name.clone(),
            b: rig.cameras[*b].name.clone(),
            count: *count,
            before_px: *before_px,
            after_px: after.get(&(*a, *b)).map_or(f64::NAN, |x| x.1),
        })
        .collect();
    Ok(Refinement {
        rig: current,
        held,
        cameras,
        pairs,
        confident_per_round,
        frames_used: chosen.frames_used,
        frames_rejected: judged.training_frames - chosen.frames_used,
        residual_gate_px: chosen.gate_px,
        converged: chosen.converged,
        intrinsics: if judged.kept_input {
            Vec::new()
        } else {
            chosen.fits.clone()
        },
        markers_in_tool: if judged.kept_input {
            tool.markers_in_tool.clone()
        } else {
            chosen.markers_in_tool.clone()
        },
        held_out: judged
            .candidates
            .iter()
            .map(|c| (c.name.clone(), c.rigidity_mm))
            .collect(),
        input_rigidity_mm: judged.input_rigidity_mm,
        held_out_frames: judged.held_out_frames,
        chosen: judged.candidates[judged.chosen].name.clone(),
        kept_input: judged.kept_input,
    })
}

/// A candidate rig fitted on the training frames and judged on the held-out ones.
struct Candidate {
    name: String,
    rig: Rig,
    fits: Vec<CameraIntrinsicsFit>,
    markers_in_tool: Vec<Point3>,
    frames_used: usize,
    gate_px: f64,
    converged: bool,
    rigidity_mm: Option<f64>,
}

/// The candidates and the choice among them.
struct Judged {
    candidates: Vec<Candidate>,
    chosen: usize,
    kept_input: bool,
    input_rigidity_mm: Option<f64>,
    held_out_frames: usize,
    training_frames: usize,
}

/// Fits the candidate rigs (extrinsics only; with the determined intrinsics and the tool's
/// shape; with `k2` too) from `current` on every confident frame but every
/// [`RefineConfig::hold_out_every`]-th, measures the tool's rigidity through each and through
/// `input` on the frames held out, and chooses the most rigid; when that is not more rigid
/// than `input`, the input is kept.
fn judge_candidates(
    input: &Rig,
    current: &Rig,
    tool: &Tool,
    frames: &[ConfidentFrame],
    held: CameraId,
    config: &RefineConfig,
) -> Result<Judged, RefineError> {
    let every = config.hold_out_every.max(2);
    let (mut training, mut held_out) = (Vec::new(), Vec::new());
    for (i, f) in frames.iter().enumerate() {
        let observed = Observed {
            world_from_tool: f.world_from_tool,
            views: f.views.clone(),
        };
        if i % every == every - 1 {
            held_out.push(observed);
        } else {
            training.push(observed);
        }
    }
    let mut models: Vec<(&str, Vec<Intrinsic>, bool)> = vec![("extrinsics", Vec::new(), false)];
    if !config.intrinsics.is_empty() {
        models.push(("intrinsics", config.intrinsics.clone(), true));
        if config.try_k2 && !config.intrinsics.contains(&Intrinsic::K2) {
            let mut with_k2 = config.intrinsics.clone();
            with_k2.push(Intrinsic::K2);
            models.push(("intrinsics + k2", with_k2, true));
        }
    }
    let mut candidates = Vec::new();
    for (name, free, shape) in models {
        let fitted = refine_intrinsics(
            current,
            &tool.markers_in_tool,
            &training,
            held,
            &free,
            shape,
            &config.intrinsics_config,
        );
        let fitted = match fitted {
            Ok(f) => f,
            // The extrinsics alone must fit: the rounds just did on these frames.
            Err(e) if candidates.is_empty() => {
                return Err(RefineError::Bundle {
                    message: e.to_string(),
                });
            }
            Err(_) => continue,
        };
        let rigidity_mm = held_out_rigidity(&fitted.rig, &held_out);
        candidates.push(Candidate {
            name: name.to_owned(),
            rigidity_mm,
            rig: fitted.rig,
            fits: fitted.cameras,
            markers_in_tool: fitted.markers_in_tool,
            frames_used: fitted.frames_used,
            gate_px: fitted.gate_px,
            converged: fitted.converged,
        });
    }
    let rigidity = |c: &Candidate| c.rigidity_mm.unwrap_or(f64::INFINITY);
    let chosen = (0..candidates.len())
        .min_by(|a, b| rigidity(&candidates[*a]).total_cmp(&rigidity(&candidates[*b])))
        .unwrap_or(0);
    let input_rigidity_mm = held_out_rigidity(input, &held_out);
    let kept_input = input_rigidity_mm
        .is_some_and(|input| candidates.get(chosen).is_none_or(|c| rigidity(c) > input));
    Ok(Judged {
        candidates,
        chosen,
        kept_input,
        input_rigidity_mm,
        held_out_frames: held_out.len(),
        training_frames: training.len(),
    })
}
