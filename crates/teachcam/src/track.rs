//! Tracking: one frame's blobs to the tool's pose, and many frames to a trajectory.
//!
//! Per frame (paper §II): correspond the blobs of all cameras ([`crate::correspond`]),
//! triangulate each correspondence ([`crate::triangulate`]), label the points with the tool's
//! markers ([`crate::identify`]) and register the model onto them with the scale fixed to 1
//! ([`crate::register`]). A frame needs three identified markers; otherwise it is an explicit
//! gap with the reason. Frames are independent, so they run in parallel.

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::camera::Rig;
use crate::correspond::{CorrespondConfig, EpipolarGeometry, Views, correspond};
use crate::geometry::{CameraId, FrameIndex, MarkerId, Point3};
use crate::identify::{IdentifyConfig, identify};
use crate::register::{RegisterError, Scale, register};
use crate::tool::Tool;
use crate::trajectory::{Sample, ToolPose, Trajectory};
use crate::triangulate::{TriangulateConfig, TriangulatedPoint, triangulate};

/// Options of every tracking stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackConfig {
    /// Correspondence.
    pub correspond: CorrespondConfig,
    /// Triangulation.
    pub triangulate: TriangulateConfig,
    /// Identification.
    pub identify: IdentifyConfig,
    /// Largest registration RMS of an accepted pose, millimetres: a correct fit on the paper's
    /// rig leaves ≈ 0.03 mm; a wrong label leaves millimetres.
    pub max_registration_rms_mm: f64,
}

impl Default for TrackConfig {
    fn default() -> Self {
        Self {
            correspond: CorrespondConfig::default(),
            triangulate: TriangulateConfig::default(),
            identify: IdentifyConfig::default(),
            max_registration_rms_mm: 0.5,
        }
    }
}

/// Why a frame has no pose.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Lost {
    /// Fewer than three markers identified.
    #[error("{identified} markers identified among {points} 3-D points; a pose needs 3")]
    TooFewMarkers {
        /// Markers identified.
        identified: usize,
        /// 3-D points reconstructed.
        points: usize,
    },
    /// Registration refused the identified markers.
    #[error("registration: {0}")]
    Register(#[from] RegisterError),
    /// The registered model does not fit the points.
    #[error("registration residual {rms_mm:.3} mm exceeds {max_mm} mm")]
    Residual {
        /// RMS residual found.
        rms_mm: f64,
        /// The limit.
        max_mm: f64,
    },
}

/// One frame's tracking result with its evidence.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTrack {
    /// The pose, or why there is none.
    pub outcome: Result<ToolPose, Lost>,
    /// Every triangulated point of the frame.
    pub points: Vec<TriangulatedPoint>,
    /// For each identified marker, the index of its point in `points`.
    pub labels: BTreeMap<MarkerId, usize>,
}

impl FrameTrack {
    /// Number of cameras that saw an identified marker, per marker.
    #[must_use]
    pub fn views_per_marker(&self) -> BTreeMap<MarkerId, usize> {
        self.labels
            .iter()
            .map(|(m, p)| (*m, self.points[*p].views.len()))
            .collect()
    }

    /// The identified markers' positions, world frame.
    #[must_use]
    pub fn markers_in_world(&self) -> BTreeMap<MarkerId, Point3> {
        self.labels
            .iter()
            .map(|(m, p)| (*m, self.points[*p].position))
            .collect()
    }
}

/// The rig-dependent state that every frame shares.
#[derive(Debug, Clone)]
pub struct Tracker<'a> {
    rig: &'a Rig,
    tool: &'a Tool,
    geometry: EpipolarGeometry,
    config: TrackConfig,
}

impl<'a> Tracker<'a> {
    /// A tracker for a rig and a tool.
    #[must_use]
    pub fn new(rig: &'a Rig, tool: &'a Tool, config: TrackConfig) -> Self {
        Self {
            rig,
            tool,
            geometry: EpipolarGeometry::new(rig),
            config,
        }
    }

    /// Tracks one frame from its blob centres (distorted pixels) per camera.
    #[must_use]
    pub fn track_frame(&self, views: &Views) -> FrameTrack {
        let correspondences = correspond(self.rig, &self.geometry, views, &self.config.correspond);
        let points: Vec<TriangulatedPoint> = correspondences
            .iter()
            .filter_map(|c| {
                let pixels: BTreeMap<CameraId, _> = c
                    .blobs
                    .iter()
                    .filter_map(|(cam, i)| Some((*cam, *views.get(cam)?.get(*i)?)))
                    .collect();
                triangulate(self.rig, &pixels, &self.config.triangulate).ok()
            })
            .collect();
        let positions: Vec<Point3> = points.iter().map(|p| p.position).collect();
        let identification = identify(
            &self.tool.markers_in_tool,
            &positions,
            &self.config.identify,
        );
        let labels = identification.labels;
        let outcome = self.pose(&labels, &positions);
        FrameTrack {
            outcome,
            points,
            labels,
        }
    }

    fn pose(
        &self,
        labels: &BTreeMap<MarkerId, usize>,
        positions: &[Point3],
    ) -> Result<ToolPose, Lost> {
        if labels.len() < 3 {
            return Err(Lost::TooFewMarkers {
                identified: labels.len(),
                points: positions.len(),
            });
        }
        let markers_in_world = labels.iter().map(|(m, p)| (*m, positions[*p])).collect();
        pose_from_markers(
            self.tool,
            &markers_in_world,
            self.config.max_registration_rms_mm,
        )
    }

    /// Tracks every frame (in parallel) and assembles the trajectory; frame `i` is at time
    /// `i / fps`.
    #[must_use]
    pub fn track_all(&self, frames: &[Views], fps: f64) -> (Trajectory, Vec<FrameTrack>) {
        let tracks: Vec<FrameTrack> = frames.par_iter().map(|v| self.track_frame(v)).collect();
        let samples = tracks
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let time_s = i as f64 / fps;
                match &t.outcome {
                    Ok(pose) => Sample::measured(FrameIndex(i), time_s, *pose),
                    Err(_) => Sample::gap(FrameIndex(i), time_s),
                }
            })
            .collect();
        (Trajectory { samples }, tracks)
    }
}

/// The tool's pose from its identified markers' world positions: SVD registration with the
/// scale fixed to 1 (the paper's choice), refused with fewer than three markers or when the
/// fit leaves more than `max_rms_mm`.
///
/// # Errors
/// [`Lost`] saying why there is no pose.
pub fn pose_from_markers(
    tool: &Tool,
    markers_in_world: &BTreeMap<MarkerId, Point3>,
    max_rms_mm: f64,
) -> Result<ToolPose, Lost> {
    if markers_in_world.len() < 3 {
        return Err(Lost::TooFewMarkers {
            identified: markers_in_world.len(),
            points: markers_in_world.len(),
        });
    }
    let model: Vec<Point3> = markers_in_world
        .keys()
        .map(|m| tool.markers_in_tool.get(m.0).copied())
        .collect::<Option<_>>()
        .ok_or(Lost::TooFewMarkers {
            identified: 0,
            points: markers_in_world.len(),
        })?;
    let measured: Vec<Point3> = markers_in_world.values().copied().collect();
    let registration = register(&model, &measured, Scale::Fixed)?;
    if registration.rms_mm > max_rms_mm {
        return Err(Lost::Residual {
            rms_mm: registration.rms_mm,
            max_mm: max_rms_mm,
        });
    }
    let world_from_tool = registration.measured_from_model;
    Ok(ToolPose {
        world_from_tool,
        tip_in_world: world_from_tool * tool.tip_in_tool(),
        markers: markers_in_world.len(),
        rms_mm: registration.rms_mm,
    })
}
