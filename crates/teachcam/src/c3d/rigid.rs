//! A rigid cluster of another tracker's markers as a teachcam tool: its model from the data,
//! and its pose in every frame.
//!
//! **Tool from data** (generalised Procrustes, Gower 1975): take the frames of a stretch where
//! every chosen marker is valid; register each frame onto the first (SVD, scale 1), average the
//! aligned positions, register every frame onto that mean and average again. The mean shape is
//! then written in the *tool frame* chosen from its first three markers `m0, m1, m2`:
//! ```text
//! origin = m0,  x = (m1 - m0)/|m1 - m0|,  z = x × (m2 - m0) normalised,  y = z × x
//! ```
//! (the "three-marker technical frame" of biomechanics: reproducible from the labels alone).
//! The tip is a marker's mean position when one is named, else the origin.
//!
//! **Tracking**: per frame, the tool's markers are found by label (the tracker already
//! identified them) or by the paper's distance-matrix voting ([`crate::identify`]) among all
//! valid points; the model is registered onto them with the scale fixed to 1
//! ([`crate::register`], paper §II-C). Fewer than three markers, a refused registration or a
//! residual above the limit leave an explicit gap.
//!
//! Identification refuses what is not there: a frame is *confident* when every marker of the
//! tool is identified with no rival labelling. Without a single confident frame the tool is not
//! in the data and every frame is a gap (a cloud of body markers holds chance triangles at a
//! tool's distances, never the whole tool). The registration gate is learned from the
//! confident frames ([`crate::track::gates::registration_gate`]); a frame with fewer markers
//! or a residual beyond it is `degraded` or `outlier`, beyond three times it (or the
//! configured limit) a gap; a frame with a rival labelling is a gap.

use std::collections::BTreeMap;
use std::ops::Range;

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::{C3dError, PointData};
use crate::geometry::{FrameIndex, MarkerId, Point3, Pose, pose_from_parts};
use crate::identify::{IdentifyConfig, identify};
use crate::register::{Scale, register};
use crate::tool::Tool;
use crate::track::gates::{MIN_SAMPLES, registration_gate};
use crate::track::{OUTLIER_LIMIT, pose_from_markers};
use crate::trajectory::{Sample, Status, Trajectory};

/// Rounds of alignment onto the mean shape (the first aligns onto frame one's shape; a second
/// round removes that frame's noise from the reference; more change nothing measurable).
const PROCRUSTES_ROUNDS: usize = 2;

/// A tool model measured from marker data, with how well the markers kept their shape.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolFromData {
    /// The tool (markers in the tool frame, millimetres; tip as asked).
    pub tool: Tool,
    /// The tool frame in the data's frame at the first frame used (millimetres).
    pub data_from_tool: Pose,
    /// Frames in which every marker was valid, and so were used.
    pub frames_used: usize,
    /// Per marker, RMS distance of its aligned positions from its mean, millimetres: how rigid
    /// the cluster was and how noisy the tracker.
    pub marker_rms_mm: Vec<f64>,
}

/// What the tool built from data is called and how it is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolFromDataConfig {
    /// The tool's name in `tool.json`.
    pub name: String,
    /// Sphere diameter written to `tool.json`, millimetres (10 mm: a common passive marker;
    /// it only has to be smaller than the closest marker pair).
    pub marker_diameter_mm: f64,
}

impl Default for ToolFromDataConfig {
    fn default() -> Self {
        Self {
            name: "tool".into(),
            marker_diameter_mm: 10.0,
        }
    }
}

/// The positions of `columns` in one frame, millimetres, when all are valid.
fn frame_positions(
    points: &PointData,
    frame: usize,
    columns: &[usize],
    millimetres_per_unit: f64,
) -> Option<Vec<Point3>> {
    columns
        .iter()
        .map(|&c| {
            points
                .sample(FrameIndex(frame), c)
                .map(|s| Point3::from(s.position.coords * millimetres_per_unit))
        })
        .collect()
}

/// Builds a tool from the markers in `columns` (the first three set the tool frame; see the
/// module docs) over the frames in `frames`; `tip` is an optional column whose mean position
/// becomes the tool centre point.
///
/// # Errors
/// [`C3dError::BadValue`] when fewer than three markers are given, no frame in the range has
/// all of them valid, the first three are collinear or the data cannot be registered;
/// [`C3dError::UnknownUnits`] for units other than mm, cm, m, in; a [`Tool`] check failure
/// (markers closer than the sphere diameter) as [`C3dError::BadValue`].
pub fn tool_from_data(
    points: &PointData,
    columns: &[usize],
    frames: Range<usize>,
    tip: Option<usize>,
    config: &ToolFromDataConfig,
) -> Result<ToolFromData, C3dError> {
    let bad = |reason: String| C3dError::BadValue {
        field: "tool from data",
        reason,
    };
    if columns.len() < 3 {
        return Err(bad(format!(
            "{} markers given; a tool needs at least 3",
            columns.len()
        )));
    }
    let scale = points.millimetres_per_unit()?;
    let mut all = columns.to_vec();
    all.extend(tip);
    let end = frames.end.min(points.frame_count());
    let shapes: Vec<Vec<Point3>> = (frames.start..end)
        .filter_map(|f| frame_positions(points, f, &all, scale))
        .collect();
    let Some(first) = shapes.first() else {
        return Err(bad(format!(
            "no frame in {}..{} has every chosen marker valid",
            frames.start, end
        )));
    };
    let n = columns.len();
    let mut mean: Vec<Point3> = first.clone();
    let mut aligned: Vec<Vec<Point3>> = Vec::new();
    for _ in 0..PROCRUSTES_ROUNDS {
        aligned = shapes
            .iter()
            .map(|shape| {
                let r = register(&shape[..n], &mean[..n], Scale::Fixed)
                    .map_err(|e| bad(format!("cannot align frames: {e}")))?;
                Ok(shape.iter().map(|p| r.measured_from_model * p).collect())
            })
            .collect::<Result<_, C3dError>>()?;
        mean = (0..all.len())
            .map(|k| {
                let sum: Vector3<f64> = aligned.iter().map(|s| s[k].coords).sum();
                Point3::from(sum / aligned.len() as f64)
            })
            .collect();
    }
    let marker_rms_mm = (0..n)
        .map(|k| {
            let sq: f64 = aligned
                .iter()
                .map(|s| (s[k] - mean[k]).norm_squared())
                .sum();
            (sq / aligned.len() as f64).sqrt()
        })
        .collect();
    let data_from_tool = three_marker_frame(mean[0], mean[1], mean[2])
        .ok_or_else(|| bad("the first three markers are collinear: no tool frame".into()))?;
    let tool_from_data = data_from_tool.inverse();
    let markers_in_tool: Vec<Point3> = mean[..n].iter().map(|p| tool_from_data * p).collect();
    let tip_in_tool = tip.map_or_else(Point3::origin, |_| tool_from_data * mean[n]);
    let tool = Tool::new(
        config.name.clone(),
        config.marker_diameter_mm,
        markers_in_tool,
        pose_from_parts(tip_in_tool.coords, UnitQuaternion::identity()),
    )
    .map_err(|e| bad(e.to_string()))?;
    Ok(ToolFromData {
        tool,
        data_from_tool,
        frames_used: shapes.len(),
        marker_rms_mm,
    })
}

/// The frame with origin `m0`, x towards `m1` and `m2` in the xy-plane (y towards it); `None`
/// when the three are collinear.
fn three_marker_frame(m0: Point3, m1: Point3, m2: Point3) -> Option<Pose> {
    let x = (m1 - m0).try_normalize(1e-9)?;
    let z = x.cross(&(m2 - m0)).try_normalize(1e-9)?;
    let y = z.cross(&x);
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    Some(pose_from_parts(
        m0.coords,
        UnitQuaternion::from_rotation_matrix(&rotation),
    ))
}

/// How the tool's markers are found in each frame.
#[derive(Debug, Clone, PartialEq)]
pub enum MarkerSelection {
    /// Column `columns[k]` is the tool's marker `k` (the tracker labelled them).
    Labels(Vec<usize>),
    /// Distance-matrix identification among every valid point of the frame.
    Identify(IdentifyConfig),
}

/// Options of tracking a tool in marker data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackMarkersConfig {
    /// Largest registration RMS of an accepted pose, millimetres: commercial trackers' markers
    /// scatter by 0.05–0.4 mm (SOURCE.md of the test data), a wrong or swapped label leaves
    /// several millimetres.
    pub max_registration_rms_mm: f64,
}

impl Default for TrackMarkersConfig {
    fn default() -> Self {
        Self {
            max_registration_rms_mm: 2.0,
        }
    }
}

/// The tool's pose in every frame of `points` (time `frame / rate`), gaps where it cannot be
/// registered (see the module docs).
///
/// # Errors
/// [`C3dError::UnknownUnits`] when the data's units cannot be converted to millimetres;
/// [`C3dError::BadValue`] when a label column is out of range.
pub fn track_markers(
    points: &PointData,
    tool: &Tool,
    selection: &MarkerSelection,
    config: &TrackMarkersConfig,
) -> Result<Trajectory, C3dError> {
    let scale = points.millimetres_per_unit()?;
    if let MarkerSelection::Labels(columns) = selection {
        if columns.len() != tool.markers_in_tool.len() {
            return Err(C3dError::BadValue {
                field: "markers",
                reason: format!(
                    "{} labels for a tool of {} markers",
                    columns.len(),
                    tool.markers_in_tool.len()
                ),
            });
        }
        if let Some(c) = columns.iter().find(|&&c| c >= points.marker_count()) {
            return Err(C3dError::BadValue {
                field: "markers",
                reason: format!("column {c} of {}", points.marker_count()),
            });
        }
    }
    let n = tool.markers_in_tool.len();
    // Each frame's markers, and those of a rival labelling as large.
    type Markers = BTreeMap<MarkerId, Point3>;
    let frames: Vec<(Markers, Option<Markers>)> = (0..points.frame_count())
        .map(|f| match selection {
            MarkerSelection::Labels(columns) => {
                let markers = columns
                    .iter()
                    .enumerate()
                    .filter_map(|(k, &c)| {
                        let s = points.sample(FrameIndex(f), c)?;
                        Some((MarkerId(k), Point3::from(s.position.coords * scale)))
                    })
                    .collect();
                (markers, None)
            }
            MarkerSelection::Identify(identify_config) => {
                let all: Vec<Point3> = points
                    .frame(FrameIndex(f))
                    .unwrap_or_default()
                    .iter()
                    .flatten()
                    .map(|s| Point3::from(s.position.coords * scale))
                    .collect();
                let found = identify(&tool.markers_in_tool, &all, identify_config);
                let at = |labels: &BTreeMap<MarkerId, usize>| -> Markers {
                    labels.iter().map(|(m, &i)| (*m, all[i])).collect()
                };
                (at(&found.labels), found.rival.as_ref().map(at))
            }
        })
        .collect();
    let hard_limit_mm = config.max_registration_rms_mm;
    let gate_mm = match selection {
        MarkerSelection::Labels(_) => hard_limit_mm,
        MarkerSelection::Identify(_) => {
            let confident: Vec<f64> = frames
                .iter()
                .filter(|(markers, rival)| rival.is_none() && markers.len() == n)
                .filter_map(|(markers, _)| pose_from_markers(tool, markers, hard_limit_mm).ok())
                .map(|p| p.rms_mm)
                .collect();
            if confident.is_empty() {
                // The tool is not in the data: no frame may pose on chance matches.
                return Ok(Trajectory {
                    samples: (0..points.frame_count())
                        .map(|f| Sample::gap(FrameIndex(f), f as f64 / points.rate_hz))
                        .collect(),
                });
            }
            // With too few confident frames to measure a gate, the worst they showed is it.
            let gate = if confident.len() < MIN_SAMPLES {
                confident.iter().copied().fold(0.0, f64::max)
            } else {
                registration_gate(&confident, None).value
            };
            gate.min(hard_limit_mm)
        }
    };
    let samples = frames
        .iter()
        .enumerate()
        .map(|(f, (markers, rival))| {
            let time_s = f as f64 / points.rate_hz;
            let limit_mm = (OUTLIER_LIMIT * gate_mm).min(hard_limit_mm);
            let pose = pose_from_markers(tool, markers, limit_mm);
            // A rival labelling that fits within the margin (the same rule as `track`'s) makes
            // the frame a gap; one that lands on the same pose is no rival.
            let rivalled = match (&pose, rival) {
                (Ok(p), Some(rival)) => pose_from_markers(tool, rival, limit_mm).is_ok_and(|r| {
                    let same = (r.tip_in_world - p.tip_in_world).norm() < 1e-6
                        && r.world_from_tool
                            .rotation
                            .angle_to(&p.world_from_tool.rotation)
                            < 1e-9;
                    !same && r.rms_mm <= gate_mm.max(2.0 * p.rms_mm)
                }),
                _ => false,
            };
            match pose {
                Ok(p) if !rivalled => {
                    let status = if p.rms_mm > gate_mm {
                        Status::Outlier
                    } else if p.markers < n {
                        Status::Degraded
                    } else {
                        Status::Ok
                    };
                    Sample {
                        status,
                        ..Sample::measured(FrameIndex(f), time_s, p)
                    }
                }
                _ => Sample::gap(FrameIndex(f), time_s),
            }
        })
        .collect();
    Ok(Trajectory { samples })
}

/// The tool's markers and tip in every frame of a trajectory, as marker data for a C3D file:
/// labels `<tool>:M0`, `<tool>:M1`, ... and `<tool>:tip`, millimetres, the registration
/// residual as each sample's residual; a frame without a pose is a gap for every marker.
///
/// # Errors
/// [`C3dError::Unwritable`] when the trajectory has no frame rate (fewer than two samples or
/// time not increasing).
pub fn points_from_trajectory(trajectory: &Trajectory, tool: &Tool) -> Result<PointData, C3dError> {
    let rate_hz = trajectory
        .sample_rate_hz()
        .ok_or_else(|| C3dError::Unwritable {
            reason: "the trajectory has no frame rate (fewer than two samples?)".into(),
        })?;
    let mut labels: Vec<String> = (0..tool.markers_in_tool.len())
        .map(|k| format!("{}:M{k}", tool.name))
        .collect();
    labels.push(format!("{}:tip", tool.name));
    let frames: Vec<Vec<Option<super::PointSample>>> = trajectory
        .samples
        .iter()
        .map(|s| {
            let sample = |position: Point3, residual: f64| {
                s.pose.map(|_| super::PointSample {
                    position,
                    residual,
                    camera_mask: 0,
                })
            };
            match &s.pose {
                Some(p) => tool
                    .markers_in_tool
                    .iter()
                    .map(|m| sample(p.world_from_tool * m, p.rms_mm))
                    .chain([sample(p.tip_in_world, p.rms_mm)])
                    .collect(),
                None => vec![None; labels.len()],
            }
        })
        .collect();
    PointData::new(labels, rate_hz, "mm".into(), &frames)
}

/// The tool's *measured* markers in every tracked frame, as marker data for a C3D file: labels
/// `<tool>:M0`, `<tool>:M1`, ... (the triangulated point identified as that marker, a gap where
/// none was) and `<tool>:tip` (the registered tip, a gap without a pose); millimetres. The
/// camera mask has bit `i` set when camera `i` (ids 0–6) saw the marker; the residual is the
/// pose's registration RMS for the tip and 0 for markers (their reprojection residual is in
/// pixels, which C3D has no place for).
///
/// # Errors
/// [`C3dError::Unwritable`] for a rate that is not positive and finite.
pub fn points_from_tracks(
    tracks: &[crate::track::FrameTrack],
    tool: &Tool,
    rate_hz: f64,
) -> Result<PointData, C3dError> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(C3dError::Unwritable {
            reason: format!("frame rate {rate_hz} Hz"),
        });
    }
    let n = tool.markers_in_tool.len();
    let mut labels: Vec<String> = (0..n).map(|k| format!("{}:M{k}", tool.name)).collect();
    labels.push(format!("{}:tip", tool.name));
    let frames: Vec<Vec<Option<super::PointSample>>> = tracks
        .iter()
        .map(|track| {
            let mut row: Vec<Option<super::PointSample>> = (0..n)
                .map(|k| {
                    let point = track.points.get(*track.labels.get(&MarkerId(k))?)?;
                    let camera_mask = point
                        .views
                        .keys()
                        .filter(|c| c.0 < 7)
                        .fold(0u8, |mask, c| mask | 1 << c.0);
                    Some(super::PointSample {
                        position: point.position,
                        residual: 0.0,
                        camera_mask,
                    })
                })
                .collect();
            row.push(track.outcome.as_ref().ok().map(|pose| super::PointSample {
                position: pose.tip_in_world,
                residual: pose.rms_mm,
                camera_mask: 0,
            }));
            row
        })
        .collect();
    PointData::new(labels, rate_hz, "mm".into(), &frames)
}

/// [`points_from_trajectory`] with the tool's *measured* markers in place of the registered
/// ones: `measured` is `teachcam track --markers-out` as [`crate::vendor::read_markers_csv`]
/// reads it (labels `M0`, `M1`, ... by marker id, frames as in the trajectory). A marker not
/// identified in a frame is a gap; the tip stays the registered tip.
///
/// # Errors
/// As [`points_from_trajectory`], and [`C3dError::BadValue`] when `measured` has more frames
/// than the trajectory or markers the tool does not have.
pub fn points_from_trajectory_and_measured(
    trajectory: &Trajectory,
    tool: &Tool,
    measured: &PointData,
) -> Result<PointData, C3dError> {
    let mut points = points_from_trajectory(trajectory, tool)?;
    let n = tool.markers_in_tool.len();
    if measured.frame_count() > points.frame_count() || measured.marker_count() > n {
        return Err(C3dError::BadValue {
            field: "measured markers",
            reason: format!(
                "{} frames of {} markers for a trajectory of {} frames and a tool of {n}",
                measured.frame_count(),
                measured.marker_count(),
                points.frame_count()
            ),
        });
    }
    let columns: Vec<Option<usize>> = (0..n)
        .map(|k| measured.labels.iter().position(|l| *l == format!("M{k}")))
        .collect();
    let width = points.marker_count();
    for frame in 0..points.frame_count() {
        for (k, column) in columns.iter().enumerate() {
            let sample = column
                .and_then(|c| measured.sample(FrameIndex(frame), c))
                .copied();
            points.samples[frame * width + k] = sample;
        }
    }
    Ok(points)
}
