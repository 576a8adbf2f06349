//! Doctor: why a recording tracks badly, read from the tracking evidence, and what to do.
//!
//! Input: every frame's blobs per camera (as detected, before any roundness cut) and its
//! [`FrameTrack`]. Output: a plain-data [`Report`]:
//! - **where frames are lost**: each lost frame is put at the first stage that could not go
//!   on — detect (fewer than two cameras see as many blobs as a pose needs), correspond (fewer
//!   than three 3-D points), identify (points, but fewer than three markers named),
//!   register (the fit refused or its residual over the limit);
//! - **what the data shows**: per camera, blob diameters and roundness; per camera pair, the
//!   epipolar distance of blob matches made without the tracker's tolerance (mutual nearest
//!   to the epipolar line within a wide window, the next candidate `match_ratio` times
//!   farther: unambiguous matches), the triangulation and registration residuals, how often
//!   the tool's distances appear among the 3-D points;
//! - **findings**, each with its advice: a camera whose blobs take part in no point while the
//!   others pose the tool (its calibration sees nothing of the volume; `track` flags its
//!   frames), a camera that disagrees with the others (with three or
//!   more cameras: the camera shared by every disagreeing pair, no pair without it
//!   disagreeing), a pair that disagrees (two cameras cannot say which one is off), blobs too
//!   small for sub-pixel centres, blobs less round than the detector's cut, a tool whose
//!   distances are not in the data.
//!
//! A rotation error θ of one camera moves its image points by up to f·θ, so a pair's median
//! epipolar distance d gives θ ≳ d / f (a lower bound: part of the turn moves points along the
//! epipolar lines, where it is not seen).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::camera::{Rig, epipolar_line};
use crate::detect::Blob;
use crate::geometry::{CameraId, Pixel};
use crate::pipeline::rules::{OUT_AFTER_POSED_FRAMES, blobs_used};
use crate::tool::Tool;
use crate::track::{FrameTrack, Lost};

/// Options of the diagnosis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoctorConfig {
    /// Widest epipolar distance of a pair match, pixels. Default 40: a camera turned by 1° at
    /// f = 1800 px moves its points by 31 px, and real marker images are rarely closer.
    pub match_window_px: f64,
    /// A match counts only when the next candidate is this many times farther from the
    /// epipolar line (in both directions). Default 3.
    pub match_ratio: f64,
    /// Median epipolar distance above which a pair disagrees, pixels. Default 1.5: a good
    /// calibration leaves under 0.5 px; a published real stereo calibration left 0.6 px at best.
    pub pair_disagreement_px: f64,
    /// Smallest marker image diameter whose centre is reliable, pixels. Default 5: below it
    /// compression and pixelisation move centres by a tenth of a pixel and more (notes/doctor.md).
    pub min_blob_diameter_px: f64,
    /// The detector's roundness cut, to say how many blobs it drops. Default 0.75, `detect`'s.
    pub min_roundness: f64,
    /// How close a distance between 3-D points must come to one of the tool's, millimetres.
    /// Default 3.
    pub distance_tolerance_mm: f64,
}

impl Default for DoctorConfig {
    fn default() -> Self {
        Self {
            match_window_px: 40.0,
            match_ratio: 3.0,
            pair_disagreement_px: 1.5,
            min_blob_diameter_px: 5.0,
            min_roundness: 0.75,
            distance_tolerance_mm: 3.0,
        }
    }
}

/// The 10th, 50th and 90th percentiles of a quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    /// 10th percentile.
    pub p10: f64,
    /// Median.
    pub median: f64,
    /// 90th percentile.
    pub p90: f64,
    /// Values.
    pub count: usize,
}

impl Spread {
    /// The spread of some values, `None` for none (non-finite values are left out).
    #[must_use]
    pub fn of(values: &[f64]) -> Option<Self> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        Some(Self {
            p10: at(0.1),
            median: at(0.5),
            p90: at(0.9),
            count: v.len(),
        })
    }
}

/// The stage at which a lost frame stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
pub enum Stage {
    /// Fewer than two cameras see three blobs.
    Detect,
    /// Fewer than three 3-D points.
    Correspond,
    /// Points, but fewer than three markers identified.
    Identify,
    /// The registration refused the markers or its residual was over the limit.
    Register,
}

impl Stage {
    /// What the stage's losses mean, for the report.
    #[must_use]
    pub const fn meaning(self) -> &'static str {
        match self {
            Self::Detect => "detect: fewer than two cameras see 3 blobs",
            Self::Correspond => "correspond: fewer than 3 blobs matched across cameras",
            Self::Identify => "identify: 3-D points, but the tool's distances not among them",
            Self::Register => "register: the fit refused or its residual over the limit",
        }
    }
}

/// One camera's blobs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraReport {
    /// The camera.
    pub camera: String,
    /// Blobs per frame.
    pub blobs_per_frame: Option<Spread>,
    /// Equal-flux diameters, pixels.
    pub diameter_px: Option<Spread>,
    /// Roundness (1 = disc).
    pub roundness: Option<Spread>,
    /// Fraction of blobs under the detector's roundness cut.
    pub below_roundness_cut: f64,
    /// Blobs it saw over the recording.
    pub blobs_seen: usize,
    /// Of those, the blobs that took part in a marker's point of a posed frame.
    pub blobs_used: usize,
    /// The marker's predicted image diameter at the tracked distances, pixels.
    pub predicted_diameter_px: Option<f64>,
    /// Distance from the camera to the tool in tracked frames (median), millimetres.
    pub distance_mm: Option<f64>,
}

/// One camera pair's agreement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairReport {
    /// First camera.
    pub a: String,
    /// Second camera.
    pub b: String,
    /// Epipolar distances of unambiguous blob matches, pixels.
    pub epipolar_px: Option<Spread>,
    /// True when the median is over [`DoctorConfig::pair_disagreement_px`].
    pub disagrees: bool,
}

/// Something the data shows, with what to do about it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Finding {
    /// A camera whose blobs take part in no point while the others pose the tool: its
    /// calibration does not see the volume the others see.
    CameraSeesNothing {
        /// The camera.
        camera: String,
        /// Blobs it saw.
        blobs_seen: usize,
        /// Frames the other cameras posed.
        posed_frames: usize,
    },
    /// One camera disagrees with every other while the others agree.
    CameraDisagrees {
        /// The camera.
        camera: String,
        /// Median epipolar distance over its pairs, pixels.
        epipolar_px: f64,
        /// Lower bound of its rotation error, degrees.
        angle_deg: f64,
    },
    /// A pair disagrees and nothing says which of its cameras is off.
    PairDisagrees {
        /// First camera.
        a: String,
        /// Second camera.
        b: String,
        /// Median epipolar distance, pixels.
        epipolar_px: f64,
        /// Lower bound of the relative rotation error, degrees.
        angle_deg: f64,
    },
    /// Marker images too small for reliable centres.
    BlobsTooSmall {
        /// The camera.
        camera: String,
        /// Median diameter, pixels.
        diameter_px: f64,
        /// The smallest reliable diameter, pixels.
        min_px: f64,
        /// Distance to bring the tool to (or closer), millimetres, when known.
        closer_mm: Option<f64>,
    },
    /// Many blobs less round than the detector keeps.
    BlobsNotRound {
        /// The camera.
        camera: String,
        /// Fraction of its blobs under the cut.
        fraction: f64,
        /// A `--min-roundness` that keeps 95 % of them.
        suggested_min_roundness: f64,
    },
    /// The tool's distances are rarely among the 3-D points.
    WrongTool {
        /// Frames with three or more 3-D points.
        frames_with_points: usize,
        /// Of those, the fraction where every tool distance appears.
        fraction_with_tool: f64,
    },
}

impl std::fmt::Display for Finding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::CameraSeesNothing {
                camera,
                blobs_seen,
                posed_frames,
            } => write!(
                f,
                "camera {camera} sees nothing of the volume: none of its {blobs_seen} blobs takes part in a marker's point in {posed_frames} frames the others posed; check its calibration in the rig file (fx/fy, cx/cy, distortion, image_size, its pose) or recalibrate {camera}"
            ),
            Self::CameraDisagrees {
                camera,
                epipolar_px,
                angle_deg,
            } => write!(
                f,
                "camera {camera} disagrees with the others ({epipolar_px:.2} px from the epipolar lines, the others agree): its rotation is off by {angle_deg:.2} deg or more; recalibrate {camera}"
            ),
            Self::PairDisagrees {
                a,
                b,
                epipolar_px,
                angle_deg,
            } => write!(
                f,
                "cameras {a} and {b} disagree ({epipolar_px:.2} px from the epipolar lines): their relative rotation is off by {angle_deg:.2} deg or more; recalibrate the pair (with two cameras nothing says which one)"
            ),
            Self::BlobsTooSmall {
                camera,
                diameter_px,
                min_px,
                closer_mm,
            } => {
                write!(
                    f,
                    "camera {camera}: marker images are {diameter_px:.1} px across, under the {min_px:.0} px that sub-pixel centres need; use bigger markers or move the tool closer"
                )?;
                if let Some(d) = closer_mm {
                    write!(f, " (to {d:.0} mm or less)")?;
                }
                Ok(())
            }
            Self::BlobsNotRound {
                camera,
                fraction,
                suggested_min_roundness,
            } => write!(
                f,
                "camera {camera}: {:.0} % of the blobs are less round than the detector keeps; try --min-roundness {suggested_min_roundness:.2}",
                100.0 * fraction
            ),
            Self::WrongTool {
                frames_with_points,
                fraction_with_tool,
            } => write!(
                f,
                "the tool's distances appear in {:.0} % of the {frames_with_points} frames with 3-D points: is this the right tool file?",
                100.0 * fraction_with_tool
            ),
        }
    }
}

/// The diagnosis of a recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// Frames in the recording.
    pub frames: usize,
    /// Frames with a pose.
    pub posed: usize,
    /// Lost frames by the stage that stopped them.
    pub lost: BTreeMap<Stage, usize>,
    /// Per camera.
    pub cameras: Vec<CameraReport>,
    /// Per camera pair.
    pub pairs: Vec<PairReport>,
    /// Triangulation residuals of identified markers, pixels.
    pub triangulation_residual_px: Option<Spread>,
    /// Registration RMS of posed frames, millimetres.
    pub registration_rms_mm: Option<Spread>,
    /// What the data shows and what to do, most important first.
    pub findings: Vec<Finding>,
}

/// Diagnoses a recording from every frame's blobs (`blobs[frame][camera]`, before any
/// roundness cut) and its tracking result (`tracks[frame]`).
#[must_use]
pub fn diagnose(
    rig: &Rig,
    tool: &Tool,
    blobs: &[BTreeMap<CameraId, Vec<Blob>>],
    tracks: &[FrameTrack],
    config: &DoctorConfig,
) -> Report {
    let needed = tool.markers_in_tool.len().min(3);
    let mut lost = BTreeMap::new();
    for (frame_blobs, track) in blobs.iter().zip(tracks) {
        let stage = match &track.outcome {
            Ok(_) => continue,
            Err(Lost::Register(_) | Lost::Residual { .. }) => Stage::Register,
            Err(_) => {
                let seeing = frame_blobs.values().filter(|b| b.len() >= needed).count();
                if seeing < 2 {
                    Stage::Detect
                } else if track.points.len() < 3 {
                    Stage::Correspond
                } else {
                    Stage::Identify
                }
            }
        };
        *lost.entry(stage).or_insert(0) += 1;
    }
    let posed = tracks.iter().filter(|t| t.outcome.is_ok()).count();
    let cameras = camera_reports(rig, tool, blobs, tracks, config);
    let pairs = pair_reports(rig, blobs, config);
    let triangulation: Vec<f64> = tracks
        .iter()
        .flat_map(|t| t.labels.values().map(|&p| t.points[p].residual_px))
        .collect();
    let registration: Vec<f64> = tracks
        .iter()
        .filter_map(|t| t.outcome.as_ref().ok().map(|p| p.rms_mm))
        .collect();
    let mut findings: Vec<Finding> = if posed >= OUT_AFTER_POSED_FRAMES {
        cameras
            .iter()
            .filter(|c| c.blobs_used == 0)
            .map(|c| Finding::CameraSeesNothing {
                camera: c.camera.clone(),
                blobs_seen: c.blobs_seen,
                posed_frames: posed,
            })
            .collect()
    } else {
        Vec::new()
    };
    findings.extend(calibration_findings(rig, &pairs));
    for c in &cameras {
        if let Some(d) = c
            .diameter_px
            .filter(|d| d.median < config.min_blob_diameter_px)
        {
            findings.push(Finding::BlobsTooSmall {
                camera: c.camera.clone(),
                diameter_px: d.median,
                min_px: config.min_blob_diameter_px,
                closer_mm: c
                    .distance_mm
                    .map(|mm| mm * d.median / config.min_blob_diameter_px),
            });
        }
    }
    for (c, camera) in cameras.iter().zip(&rig.cameras) {
        if c.below_roundness_cut > 0.1 {
            let mut r: Vec<f64> = blobs
                .iter()
                .filter_map(|f| f.get(&rig.id_of(&camera.name)?))
                .flatten()
                .map(|b| b.roundness)
                .collect();
            r.sort_by(f64::total_cmp);
            let p5 = r.get(r.len() / 20).copied().unwrap_or(config.min_roundness);
            findings.push(Finding::BlobsNotRound {
                camera: c.camera.clone(),
                fraction: c.below_roundness_cut,
                suggested_min_roundness: (p5 * 100.0).floor() / 100.0,
            });
        }
    }
    if let Some(f) = wrong_tool(tool, tracks, config) {
        findings.push(f);
    }
    Report {
        frames: tracks.len(),
        posed,
        lost,
        cameras,
        pairs,
        triangulation_residual_px: Spread::of(&triangulation),
        registration_rms_mm: Spread::of(&registration),
        findings,
    }
}

fn camera_reports(
    rig: &Rig,
    tool: &Tool,
    blobs: &[BTreeMap<CameraId, Vec<Blob>>],
    tracks: &[FrameTrack],
    config: &DoctorConfig,
) -> Vec<CameraReport> {
    let used = blobs_used(tracks);
    rig.iter()
        .map(|(id, camera)| {
            let all: Vec<&Blob> = blobs.iter().filter_map(|f| f.get(&id)).flatten().collect();
            let counts: Vec<f64> = blobs
                .iter()
                .map(|f| f.get(&id).map_or(0.0, |b| b.len() as f64))
                .collect();
            let distances: Vec<f64> = tracks
                .iter()
                .filter_map(|t| t.outcome.as_ref().ok())
                .map(|p| {
                    camera
                        .camera_from_world
                        .transform_point(&p.world_from_tool.translation.vector.into())
                        .coords
                        .norm()
                })
                .collect();
            let distance_mm = Spread::of(&distances).map(|s| s.median);
            let below = all
                .iter()
                .filter(|b| b.roundness < config.min_roundness)
                .count();
            CameraReport {
                camera: camera.name.clone(),
                blobs_per_frame: Spread::of(&counts),
                diameter_px: Spread::of(&all.iter().map(|b| 2.0 * b.radius_px).collect::<Vec<_>>()),
                roundness: Spread::of(&all.iter().map(|b| b.roundness).collect::<Vec<_>>()),
                below_roundness_cut: below as f64 / all.len().max(1) as f64,
                blobs_seen: all.len(),
                blobs_used: used.get(&id).copied().unwrap_or(0),
                predicted_diameter_px: distance_mm
                    .map(|d| camera.intrinsics.fx * tool.marker_diameter_mm / d),
                distance_mm,
            }
        })
        .collect()
}

/// The ideal (undistorted) pixels of one camera's blobs.
fn ideal_pixels(rig: &Rig, id: CameraId, blobs: &[Blob]) -> Vec<Pixel> {
    let Some(camera) = rig.camera(id) else {
        return Vec::new();
    };
    blobs
        .iter()
        .filter_map(|b| camera.ideal_pixel(&b.center).ok())
        .collect()
}

/// Epipolar distances of the unambiguous matches between two cameras' blobs in every frame.
fn pair_distances(
    rig: &Rig,
    a: CameraId,
    b: CameraId,
    blobs: &[BTreeMap<CameraId, Vec<Blob>>],
    config: &DoctorConfig,
) -> Vec<f64> {
    let (Some(ca), Some(cb)) = (rig.camera(a), rig.camera(b)) else {
        return Vec::new();
    };
    let f_ab = crate::camera::fundamental_matrix(ca, cb);
    let mut out = Vec::new();
    for frame in blobs {
        let (Some(ba), Some(bb)) = (frame.get(&a), frame.get(&b)) else {
            continue;
        };
        let (pa, pb) = (ideal_pixels(rig, a, ba), ideal_pixels(rig, b, bb));
        // d[i][j]: distance of b's blob j from the epipolar line of a's blob i.
        let d: Vec<Vec<f64>> = pa
            .iter()
            .map(|p| {
                epipolar_line(&f_ab, p).map_or_else(
                    || vec![f64::INFINITY; pb.len()],
                    |line| pb.iter().map(|q| line.distance(q)).collect(),
                )
            })
            .collect();
        for (i, row) in d.iter().enumerate() {
            let Some((j, best)) = nearest_two(row) else {
                continue;
            };
            if best.0 > config.match_window_px || best.1 < config.match_ratio * best.0.max(0.3) {
                continue;
            }
            let column: Vec<f64> = d.iter().map(|r| r[j]).collect();
            let Some((i_back, back)) = nearest_two(&column) else {
                continue;
            };
            if i_back == i && back.1 >= config.match_ratio * back.0.max(0.3) {
                out.push(best.0);
            }
        }
    }
    out
}

/// The index of the smallest value and (smallest, second smallest; ∞ when alone).
fn nearest_two(values: &[f64]) -> Option<(usize, (f64, f64))> {
    let (mut index, mut first, mut second) = (None, f64::INFINITY, f64::INFINITY);
    for (k, v) in values.iter().enumerate() {
        if *v < first {
            second = first;
            first = *v;
            index = Some(k);
        } else if *v < second {
            second = *v;
        }
    }
    index.map(|k| (k, (first, second)))
}

fn pair_reports(
    rig: &Rig,
    blobs: &[BTreeMap<CameraId, Vec<Blob>>],
    config: &DoctorConfig,
) -> Vec<PairReport> {
    let mut pairs = Vec::new();
    for a in 0..rig.len() {
        for b in a + 1..rig.len() {
            let d = pair_distances(rig, CameraId(a), CameraId(b), blobs, config);
            let spread = Spread::of(&d).filter(|s| s.count >= 10);
            pairs.push(PairReport {
                a: rig.cameras[a].name.clone(),
                b: rig.cameras[b].name.clone(),
                epipolar_px: spread,
                disagrees: spread.is_some_and(|s| s.median > config.pair_disagreement_px),
            });
        }
    }
    pairs
}

/// The camera shared by every disagreeing pair (three or more cameras), or the disagreeing
/// pairs themselves.
fn calibration_findings(rig: &Rig, pairs: &[PairReport]) -> Vec<Finding> {
    let judged: Vec<&PairReport> = pairs.iter().filter(|p| p.epipolar_px.is_some()).collect();
    let bad: Vec<&PairReport> = judged.iter().copied().filter(|p| p.disagrees).collect();
    if bad.is_empty() {
        return Vec::new();
    }
    let focal = |name: &str| {
        rig.id_of(name)
            .and_then(|id| rig.camera(id))
            .map_or(1.0, |c| c.intrinsics.fx)
    };
    let median = |p: &PairReport| p.epipolar_px.map_or(0.0, |s| s.median);
    if rig.len() >= 3 {
        for camera in &rig.cameras {
            let name = camera.name.as_str();
            let with: Vec<&&PairReport> = judged
                .iter()
                .filter(|p| p.a == name || p.b == name)
                .collect();
            let all_with_bad = !with.is_empty() && with.iter().all(|p| p.disagrees);
            let none_without_bad = bad.iter().all(|p| p.a == name || p.b == name);
            if all_with_bad && none_without_bad {
                let mut m: Vec<f64> = with.iter().map(|p| median(p)).collect();
                m.sort_by(f64::total_cmp);
                let epipolar_px = m[m.len() / 2];
                return vec![Finding::CameraDisagrees {
                    camera: name.to_string(),
                    epipolar_px,
                    angle_deg: (epipolar_px / focal(name)).to_degrees(),
                }];
            }
        }
    }
    bad.iter()
        .map(|p| Finding::PairDisagrees {
            a: p.a.clone(),
            b: p.b.clone(),
            epipolar_px: median(p),
            angle_deg: (median(p) / focal(&p.a).max(focal(&p.b))).to_degrees(),
        })
        .collect()
}

/// A finding when the tool's distances are rarely among the frames' 3-D points.
fn wrong_tool(tool: &Tool, tracks: &[FrameTrack], config: &DoctorConfig) -> Option<Finding> {
    let m = &tool.markers_in_tool;
    let mut wanted = Vec::new();
    for i in 0..m.len() {
        for j in i + 1..m.len() {
            wanted.push((m[i] - m[j]).norm());
        }
    }
    let mut frames_with_points = 0;
    let mut with_tool = 0;
    for t in tracks.iter().filter(|t| t.points.len() >= 3) {
        frames_with_points += 1;
        let mut seen = Vec::new();
        for i in 0..t.points.len() {
            for j in i + 1..t.points.len() {
                seen.push((t.points[i].position - t.points[j].position).norm());
            }
        }
        let found = wanted
            .iter()
            .filter(|w| {
                seen.iter()
                    .any(|s| (s - *w).abs() <= config.distance_tolerance_mm)
            })
            .count();
        // Three markers give the pose: the tool is there when three of its distances are.
        if found >= wanted.len().min(3) {
            with_tool += 1;
        }
    }
    let fraction_with_tool = with_tool as f64 / frames_with_points.max(1) as f64;
    (frames_with_points >= 10 && fraction_with_tool < 0.2).then_some(Finding::WrongTool {
        frames_with_points,
        fraction_with_tool,
    })
}
