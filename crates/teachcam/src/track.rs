//! Tracking: one frame's blobs to the tool's pose, and many frames to a trajectory.
//!
//! Per frame (paper §II): correspond the blobs of all cameras ([`crate::correspond`]),
//! triangulate each correspondence ([`crate::triangulate`], leaving out a view that disagrees
//! with three or more), label the points with the tool's markers ([`crate::identify`]) and
//! register the model onto them with the scale fixed to 1 ([`crate::register`]).
//!
//! Correspondence and identification help each other: where the epipolar geometry leaves
//! several pairings of some blobs (two markers near one epipolar line of a two-camera rig),
//! every combination of pairings is triangulated and identified, and the tool's distances
//! choose. The choice needs a margin: when a second combination gives as many markers and a
//! registration residual within `max(gate, 2 × the best's)`, the frame is a gap
//! ([`Lost::Ambiguous`]); so is a frame whose identification has an equally good rival.
//!
//! Every frame gets a [`Status`] with its reasons ([`Flag`]): `ok`; `degraded` (a view
//! dropped, fewer markers than the tool has); `outlier` (a pose whose registration residual
//! is beyond the gate, or that needed a marker beyond the triangulation or the distance gate,
//! up to [`OUTLIER_LIMIT`] times them, because the frame had too few markers within them — a
//! marker partly hidden, a blob shifted by a neighbour: written, flagged); `lost` ([`Lost`], no pose). The gates are data,
//! measured from the recording ([`gates`]), and so is a mirror the work object makes: points
//! behind it are reflections, left out before identification ([`reflections`]). Frames are
//! independent, so they run in parallel.

pub mod gates;
pub mod merged;
pub mod reflections;
pub mod temporal;

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::camera::Rig;
use crate::correspond::{
    CorrespondConfig, Correspondence, Correspondences, EpipolarGeometry, Views, correspond_all,
};
use crate::geometry::{CameraId, FrameIndex, MarkerId, Point3};
use crate::identify::{IdentifyConfig, identify};
use crate::register::{RegisterError, Scale, register};
use crate::tool::Tool;
use crate::trajectory::{Sample, Status, ToolPose, Trajectory};
use crate::triangulate::{TriangulateConfig, TriangulatedPoint, triangulate_leaving_one_out};

/// Options of every tracking stage: the gates ([`gates::Gates::track_config`] sets them from a
/// recording).
#[derive(Debug, Clone, PartialEq)]
pub struct TrackConfig {
    /// Correspondence.
    pub correspond: CorrespondConfig,
    /// Triangulation.
    pub triangulate: TriangulateConfig,
    /// Identification.
    pub identify: IdentifyConfig,
    /// Largest registration RMS of an `ok` pose, millimetres; beyond it the pose is an
    /// `outlier`, beyond [`OUTLIER_LIMIT`] times it a gap. Default 0.5: a correct fit on the
    /// paper's rig leaves ≈ 0.03 mm, a wrong label millimetres.
    pub max_registration_rms_mm: f64,
    /// A mirror the recording shows: 3-D points behind it are reflections, left out before
    /// identification. Default none: a mirror is learned from the recording
    /// ([`reflections::learn_mirror`]), never assumed.
    pub mirror: Option<reflections::MirrorPlane>,
    /// When a marker's blob counts as merged with something touching it ([`merged`]): its
    /// view is then left out where others remain. Default none: measured from the
    /// recording, and only checked where the blobs' shapes are given
    /// ([`Tracker::track_frame_with_shapes`]).
    pub merged: Option<merged::MergedGate>,
}

/// How many times the registration gate a pose may leave and still be written (as an
/// outlier): beyond it the misfit is no longer noise but a wrong point or a broken tool.
pub const OUTLIER_LIMIT: f64 = 3.0;

/// Most combinations of ambiguous pairings tried in one frame; beyond it the ambiguous blobs
/// are left out (and the frame says so).
pub const MAX_COMBINATIONS: usize = 256;

impl Default for TrackConfig {
    fn default() -> Self {
        Self {
            correspond: CorrespondConfig::default(),
            triangulate: TriangulateConfig::default(),
            identify: IdentifyConfig::default(),
            max_registration_rms_mm: 0.5,
            mirror: None,
            merged: None,
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
    #[error("registration residual {rms_mm:.3} mm exceeds {max_mm:.3} mm")]
    Residual {
        /// RMS residual found.
        rms_mm: f64,
        /// The limit.
        max_mm: f64,
    },
    /// Two labellings fit the tool equally well.
    #[error(
        "ambiguous: two labellings fit the tool with {markers} markers (registration residuals {best_mm:.3} and {rival_mm:.3} mm)"
    )]
    Ambiguous {
        /// Markers in each labelling.
        markers: usize,
        /// The better one's residual.
        best_mm: f64,
        /// The rival's residual.
        rival_mm: f64,
    },
}

/// A reason why a frame with a pose is not simply `ok`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Flag {
    /// A view disagreed with the others and was left out of a marker's point.
    #[error("view of {camera} dropped from a point ({residual_px:.3} px with it)")]
    ViewDropped {
        /// The camera.
        camera: CameraId,
        /// The point's residual with the view, pixels.
        residual_px: f64,
    },
    /// Fewer markers than the tool has.
    #[error("{used} of {of} markers")]
    FewerMarkers {
        /// Markers used.
        used: usize,
        /// Markers of the tool.
        of: usize,
    },
    /// Ambiguous pairings were too many to try.
    #[error("{combinations} pairing combinations; ambiguous blobs left out")]
    TooManyPairings {
        /// Combinations the ambiguous groups had.
        combinations: usize,
    },
    /// A marker's point has a triangulation residual beyond the gate (a marker partly
    /// hidden, a blob shifted by a neighbour); the frame had too few markers without it.
    #[error(
        "a marker's triangulation residual {residual_px:.3} px beyond the {gate_px:.3} px gate"
    )]
    PointResidual {
        /// The point's RMS residual.
        residual_px: f64,
        /// The gate.
        gate_px: f64,
    },
    /// Too few markers within the triangulation and distance gates; posed with both widened.
    #[error(
        "too few markers within the gates: posed with the triangulation and distance gates widened {factor}x"
    )]
    WidenedGates {
        /// How many times the gates.
        factor: f64,
    },
    /// A marker's blob was merged with something touching it and left out of the marker's
    /// point; the other views made it.
    #[error("merged blob in {camera} (size {size_ratio:.2}, roundness {roundness:.2}) left out")]
    MergedViewDropped {
        /// The camera.
        camera: CameraId,
        /// The blob's size ratio ([`merged::size_ratio`]).
        size_ratio: f64,
        /// The blob's roundness.
        roundness: f64,
    },
    /// A marker's blob was merged with something touching it and used: its point had no
    /// other view to spare.
    #[error(
        "merged blob in {camera} (size {size_ratio:.2}, roundness {roundness:.2}) used: no other view"
    )]
    MergedBlobUsed {
        /// The camera.
        camera: CameraId,
        /// The blob's size ratio ([`merged::size_ratio`]).
        size_ratio: f64,
        /// The blob's roundness.
        roundness: f64,
    },
    /// The pose is farther from its neighbours than the recording's motion allows
    /// ([`temporal`]).
    #[error(
        "tip {deviation_mm:.1} mm off its neighbours' path; the tool moves at most {gate_mm:.2} mm per frame"
    )]
    TemporalJump {
        /// Distance of the tip from the path between the tips around it.
        deviation_mm: f64,
        /// The step gate, millimetres per frame.
        gate_mm: f64,
    },
    /// The tool's distances left too few markers; they were labelled by their nearness to
    /// the markers of a neighbouring frame's pose ([`fill_from_neighbours`]).
    #[error("markers labelled by frame {frame}'s pose (too few fitted the tool's distances)")]
    LabelledFromNeighbour {
        /// The neighbouring frame.
        frame: usize,
    },
    /// A rig camera took no part in the frame because it is out of the rig's use: no frames
    /// in the recording, or its calibration sees nothing of the volume
    /// (`crate::pipeline::rules::CameraOut`).
    #[error("{camera} {why}")]
    CameraOut {
        /// The camera's name.
        camera: String,
        /// Why, for people.
        why: OutReason,
    },
    /// The stream's gates were not learned yet: the frame was tracked with the library's
    /// default gates.
    #[error("gates not learned yet ({seen} of {needed} frames seen)")]
    GatesNotLearned {
        /// Frames seen so far.
        seen: usize,
        /// Frames the gates are learned from.
        needed: usize,
    },
    /// The registration residual is beyond the gate.
    #[error("registration residual {rms_mm:.3} mm beyond the {gate_mm:.3} mm gate")]
    RegistrationResidual {
        /// RMS residual found.
        rms_mm: f64,
        /// The gate.
        gate_mm: f64,
    },
}

impl Flag {
    /// The status this flag gives a frame with a pose.
    #[must_use]
    pub fn status(&self) -> Status {
        match self {
            Self::RegistrationResidual { .. }
            | Self::PointResidual { .. }
            | Self::WidenedGates { .. }
            | Self::TemporalJump { .. }
            | Self::LabelledFromNeighbour { .. } => Status::Outlier,
            Self::ViewDropped { .. }
            | Self::FewerMarkers { .. }
            | Self::TooManyPairings { .. }
            | Self::MergedViewDropped { .. }
            | Self::MergedBlobUsed { .. }
            | Self::CameraOut { .. }
            | Self::GatesNotLearned { .. } => Status::Degraded,
        }
    }
}

/// One frame's tracking result with its evidence.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTrack {
    /// The pose, or why there is none.
    pub outcome: Result<ToolPose, Lost>,
    /// Every triangulated point of the frame (with the chosen pairing of ambiguous blobs).
    pub points: Vec<TriangulatedPoint>,
    /// For each identified marker, the index of its point in `points`.
    pub labels: BTreeMap<MarkerId, usize>,
    /// Why a frame with a pose is degraded or an outlier.
    pub flags: Vec<Flag>,
    /// Combinations of ambiguous pairings tried (1 when correspondence was unique).
    pub combinations: usize,
    /// Where a rival labelling fitted the tool as well as the chosen one (the frame is then
    /// lost as ambiguous), the rival's markers, world frame: the evidence a mirror leaves.
    pub rival_in_world: Option<BTreeMap<MarkerId, Point3>>,
    /// Points left out as reflections behind the mirror ([`TrackConfig::mirror`]).
    pub reflections: usize,
    /// Cameras whose blob of some point of the frame was merged ([`merged`]), with or
    /// without a pose: the evidence for a gap too.
    pub merged: Vec<CameraId>,
}

impl FrameTrack {
    /// How many cameras saw the points of the identified markers (the ones the pose used).
    #[must_use]
    pub fn cameras_used(&self) -> usize {
        self.labels
            .values()
            .filter_map(|&i| self.points.get(i))
            .flat_map(|p| p.views.keys())
            .collect::<std::collections::BTreeSet<_>>()
            .len()
    }

    /// The frame's status: `lost` without a pose, else the worst of its flags' statuses.
    #[must_use]
    pub fn status(&self) -> Status {
        if self.outcome.is_err() {
            return Status::Lost;
        }
        self.flags
            .iter()
            .map(Flag::status)
            .max()
            .unwrap_or(Status::Ok)
    }

    /// The reasons for the status, `; `-separated (empty for `ok`).
    #[must_use]
    pub fn reason(&self) -> String {
        match &self.outcome {
            Err(lost) if self.merged.is_empty() => lost.to_string(),
            Err(lost) => {
                let cameras: Vec<String> = self.merged.iter().map(ToString::to_string).collect();
                format!("{lost} (merged blob in {})", cameras.join(", "))
            }
            Ok(_) => self
                .flags
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join("; "),
        }
    }

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

/// Which triangulated points a frame is tracked with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Points {
    /// Residuals within the gate.
    WithinGate,
    /// Also residuals up to [`OUTLIER_LIMIT`] times the gate (flagged).
    BeyondGate,
}

/// A triangulated correspondence with the flags its triangulation raised.
#[derive(Debug, Clone)]
struct FramePoint {
    point: TriangulatedPoint,
    flags: Vec<Flag>,
    /// The camera whose merged blob this point left out or used.
    merged: Option<CameraId>,
}

/// One frame's blobs: centres and, where given, shapes.
struct Frame<'a> {
    views: &'a Views,
    shapes: &'a merged::Shapes,
}

/// One combination's answer.
struct Candidate {
    points: Vec<FramePoint>,
    labels: BTreeMap<MarkerId, usize>,
    outcome: Result<ToolPose, Lost>,
    /// The markers of an equally good rival labelling.
    rival: Option<BTreeMap<MarkerId, Point3>>,
    /// Points left out as reflections.
    reflections: usize,
}

impl Candidate {
    fn markers_in_world(&self) -> BTreeMap<MarkerId, Point3> {
        self.labels
            .iter()
            .map(|(m, p)| (*m, self.points[*p].point.position))
            .collect()
    }
}

impl Candidate {
    /// Markers and residual, for ranking: more markers, then a smaller residual.
    fn rank(&self) -> (usize, f64) {
        match &self.outcome {
            Ok(p) => (p.markers, p.rms_mm),
            Err(_) => (0, f64::INFINITY),
        }
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

    /// The options in use.
    #[must_use]
    pub fn config(&self) -> &TrackConfig {
        &self.config
    }

    /// Tracks one frame from its blob centres (distorted pixels) per camera.
    #[must_use]
    pub fn track_frame(&self, views: &Views) -> FrameTrack {
        self.track_frame_with_shapes(views, &merged::Shapes::new())
    }

    /// Tracks every frame of a recording (in parallel), then labels the frames left with too
    /// few markers from their neighbours ([`fill_from_neighbours`]): what `track` and `doctor`
    /// both do. `views[i]` and `shapes[i]` are frame `i`'s.
    #[must_use]
    pub fn track_recording(&self, views: &[Views], shapes: &[merged::Shapes]) -> Vec<FrameTrack> {
        let mut tracks: Vec<FrameTrack> = views
            .par_iter()
            .zip(shapes)
            .map(|(v, s)| self.track_frame_with_shapes(v, s))
            .collect();
        let frames: Vec<(&Views, &merged::Shapes)> = views.iter().zip(shapes).collect();
        fill_from_neighbours(self, &frames, &mut tracks);
        tracks
    }

    /// Tracks one frame from its blob centres per camera and their shapes (`shapes`, in the
    /// order of `views`; a camera left out is not checked): a marker's blob merged with
    /// something touching it ([`TrackConfig::merged`]) is left out of its point where other
    /// views remain.
    #[must_use]
    pub fn track_frame_with_shapes(&self, views: &Views, shapes: &merged::Shapes) -> FrameTrack {
        let Correspondences { unique, ambiguous } =
            correspond_all(self.rig, &self.geometry, views, &self.config.correspond);
        let frame = Frame { views, shapes };
        let strict = self.track_points(&frame, &unique, &ambiguous, Points::WithinGate);
        if !matches!(strict.outcome, Err(Lost::TooFewMarkers { .. })) {
            return strict;
        }
        // Too few markers within the gate: the points a little beyond it (a marker partly
        // hidden, a blob shifted by a neighbour) may still give a pose, flagged an outlier.
        let mut relaxed = self.track_points(&frame, &unique, &ambiguous, Points::BeyondGate);
        match &relaxed.outcome {
            Ok(_) => {
                relaxed.flags.push(Flag::WidenedGates {
                    factor: OUTLIER_LIMIT,
                });
                relaxed
            }
            Err(_) => strict,
        }
    }

    fn track_points(
        &self,
        frame: &Frame<'_>,
        unique: &[Correspondence],
        ambiguous: &[crate::correspond::Ambiguity],
        which: Points,
    ) -> FrameTrack {
        let unique_points = self.triangulate_all(frame, unique, which);
        let combinations = ambiguous
            .iter()
            .try_fold(1_usize, |n, a| n.checked_mul(a.alternatives.len()))
            .unwrap_or(usize::MAX);
        let mut extra_flags = Vec::new();
        let mut candidates = Vec::new();
        if ambiguous.is_empty() || combinations > MAX_COMBINATIONS {
            if !ambiguous.is_empty() {
                extra_flags.push(Flag::TooManyPairings { combinations });
            }
            candidates.push(self.candidate(unique_points, which));
        } else {
            for k in 0..combinations {
                // Mixed-radix digits of k pick one alternative per group.
                let mut rest = k;
                let mut points = unique_points.clone();
                for group in ambiguous {
                    let n = group.alternatives.len();
                    points.extend(self.triangulate_all(
                        frame,
                        &group.alternatives[rest % n],
                        which,
                    ));
                    rest /= n;
                }
                candidates.push(self.candidate(points, which));
            }
        }
        self.choose(candidates, extra_flags, combinations.min(MAX_COMBINATIONS))
    }

    fn triangulate_all(
        &self,
        frame: &Frame<'_>,
        correspondences: &[Correspondence],
        which: Points,
    ) -> Vec<FramePoint> {
        let gate_px = self.config.triangulate.max_residual_px;
        let relaxed = TriangulateConfig {
            max_residual_px: OUTLIER_LIMIT * gate_px,
            ..self.config.triangulate
        };
        correspondences
            .iter()
            .filter_map(|c| {
                let mut pixels: BTreeMap<CameraId, _> = c
                    .blobs
                    .iter()
                    .filter_map(|(cam, i)| Some((*cam, *frame.views.get(cam)?.get(*i)?)))
                    .collect();
                let mut flags = Vec::new();
                let merged = self.merged_view(frame, c, &pixels);
                if let Some((camera, flag)) = &merged {
                    if pixels.len() > 2 {
                        pixels.remove(camera);
                    }
                    flags.push(flag.clone());
                }
                let strict =
                    triangulate_leaving_one_out(self.rig, &pixels, &self.config.triangulate);
                let (robust, beyond) = match (strict, which) {
                    (Ok(robust), _) => (robust, false),
                    (Err(_), Points::WithinGate) => return None,
                    (Err(_), Points::BeyondGate) => (
                        triangulate_leaving_one_out(self.rig, &pixels, &relaxed).ok()?,
                        true,
                    ),
                };
                if beyond {
                    flags.push(Flag::PointResidual {
                        residual_px: robust.point.residual_px,
                        gate_px,
                    });
                } else if let Some((camera, residual_px)) =
                    robust.dropped.zip(robust.residual_with_all_px)
                {
                    flags.push(Flag::ViewDropped {
                        camera,
                        residual_px,
                    });
                }
                Some(FramePoint {
                    point: robust.point,
                    flags,
                    merged: merged.map(|(camera, _)| camera),
                })
            })
            .collect()
    }

    /// The view of a correspondence whose blob is merged ([`merged`]), the most oversized one,
    /// with its flag: [`Flag::MergedViewDropped`] where two or more other views remain, else
    /// [`Flag::MergedBlobUsed`]. The marker's depth comes from all its views (no gate).
    fn merged_view(
        &self,
        frame: &Frame<'_>,
        correspondence: &Correspondence,
        pixels: &BTreeMap<CameraId, crate::geometry::Pixel>,
    ) -> Option<(CameraId, Flag)> {
        let gate = self.config.merged?;
        if frame.shapes.is_empty() || pixels.len() < 2 {
            return None;
        }
        let loose = TriangulateConfig {
            max_residual_px: f64::INFINITY,
            ..self.config.triangulate
        };
        let point = crate::triangulate::triangulate(self.rig, pixels, &loose).ok()?;
        let diameter_mm = self.tool.marker_diameter_mm;
        correspondence
            .blobs
            .iter()
            .filter_map(|(camera, i)| {
                let shape = frame.shapes.get(camera)?.get(*i)?;
                let ratio =
                    merged::size_ratio(self.rig, *camera, shape, &point.position, diameter_mm)?;
                gate.is_merged(ratio, shape.roundness)
                    .then_some((*camera, ratio, shape.roundness))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(camera, size_ratio, roundness)| {
                let flag = if pixels.len() > 2 {
                    Flag::MergedViewDropped {
                        camera,
                        size_ratio,
                        roundness,
                    }
                } else {
                    Flag::MergedBlobUsed {
                        camera,
                        size_ratio,
                        roundness,
                    }
                };
                (camera, flag)
            })
    }

    fn candidate(&self, points: Vec<FramePoint>, which: Points) -> Candidate {
        let before = points.len();
        let points: Vec<FramePoint> = match &self.config.mirror {
            Some(mirror) => points
                .into_iter()
                .filter(|p| !mirror.is_behind(&p.point.position))
                .collect(),
            None => points,
        };
        let reflections = before - points.len();
        let positions: Vec<Point3> = points.iter().map(|p| p.point.position).collect();
        let identify_config = match which {
            Points::WithinGate => self.config.identify,
            // Widened like the triangulation gate, but never so far that the tool's distances
            // could be confused.
            Points::BeyondGate => {
                let gate_mm = self.config.identify.distance_tolerance_mm;
                IdentifyConfig {
                    distance_tolerance_mm: (OUTLIER_LIMIT * gate_mm)
                        .min(gates::distance_tolerance_ceiling_mm(self.tool))
                        .max(gate_mm),
                }
            }
        };
        let identification = identify(&self.tool.markers_in_tool, &positions, &identify_config);
        let mut outcome = self.pose(&identification.labels, &positions);
        let mut rival_in_world = None;
        if let (Ok(pose), Some(rival)) = (&outcome, &identification.rival) {
            let rival_outcome = self.pose(rival, &positions);
            let rival_mm = rival_outcome.as_ref().map_or(f64::INFINITY, |p| p.rms_mm);
            if self.too_close(pose.rms_mm, rival_mm) {
                rival_in_world = Some(rival.iter().map(|(m, p)| (*m, positions[*p])).collect());
                outcome = Err(Lost::Ambiguous {
                    markers: pose.markers,
                    best_mm: pose.rms_mm,
                    rival_mm,
                });
            }
        }
        Candidate {
            points,
            labels: identification.labels,
            outcome,
            rival: rival_in_world,
            reflections,
        }
    }

    /// Whether a rival's residual is within the margin of the best's: no worse than
    /// `max(gate, 2 × best)`.
    fn too_close(&self, best_mm: f64, rival_mm: f64) -> bool {
        rival_mm <= self.config.max_registration_rms_mm.max(2.0 * best_mm)
    }

    /// The best candidate, or a gap when a rival with other markers' positions is as good.
    fn choose(
        &self,
        mut candidates: Vec<Candidate>,
        mut flags: Vec<Flag>,
        combinations: usize,
    ) -> FrameTrack {
        candidates.sort_by(|a, b| {
            let (ma, ra) = a.rank();
            let (mb, rb) = b.rank();
            mb.cmp(&ma).then(ra.total_cmp(&rb))
        });
        let mut candidates = candidates.into_iter();
        let Some(best) = candidates.next() else {
            return FrameTrack {
                outcome: Err(Lost::TooFewMarkers {
                    identified: 0,
                    points: 0,
                }),
                points: Vec::new(),
                labels: BTreeMap::new(),
                flags,
                combinations,
                rival_in_world: None,
                reflections: 0,
                merged: Vec::new(),
            };
        };
        let mut outcome = best.outcome.clone();
        let mut rival_in_world = best.rival.clone();
        if let Ok(pose) = &best.outcome {
            let same_markers = |c: &Candidate| -> bool {
                best.labels.iter().all(|(m, p)| {
                    c.labels.get(m).is_some_and(|q| {
                        c.points[*q].point.position == best.points[*p].point.position
                    })
                })
            };
            let rival = candidates.find(|c| {
                let (markers, _) = c.rank();
                markers == pose.markers && !same_markers(c)
            });
            if let Some(rival) = rival {
                let rival_mm = rival.rank().1;
                if self.too_close(pose.rms_mm, rival_mm) {
                    rival_in_world = Some(rival.markers_in_world());
                    outcome = Err(Lost::Ambiguous {
                        markers: pose.markers,
                        best_mm: pose.rms_mm,
                        rival_mm,
                    });
                }
            }
        }
        if let Ok(pose) = &outcome {
            flags.extend(
                best.labels
                    .values()
                    .flat_map(|p| best.points[*p].flags.iter().cloned()),
            );
            if pose.markers < self.tool.markers_in_tool.len() {
                flags.push(Flag::FewerMarkers {
                    used: pose.markers,
                    of: self.tool.markers_in_tool.len(),
                });
            }
            if pose.rms_mm > self.config.max_registration_rms_mm {
                flags.push(Flag::RegistrationResidual {
                    rms_mm: pose.rms_mm,
                    gate_mm: self.config.max_registration_rms_mm,
                });
            }
        }
        // With a pose, the merged blobs it used or left out; without, every one the frame had.
        let mut merged: Vec<CameraId> = match &outcome {
            Ok(_) => best
                .labels
                .values()
                .filter_map(|p| best.points[*p].merged)
                .collect(),
            Err(_) => best.points.iter().filter_map(|p| p.merged).collect(),
        };
        merged.sort_unstable();
        merged.dedup();
        FrameTrack {
            outcome,
            points: best.points.into_iter().map(|p| p.point).collect(),
            labels: best.labels,
            flags,
            combinations,
            rival_in_world,
            reflections: best.reflections,
            merged,
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
            OUTLIER_LIMIT * self.config.max_registration_rms_mm,
        )
    }

    /// Labels a frame's points by their nearness to the markers of a neighbour's pose
    /// (`neighbour`, `frame` its index): each marker takes the one point within
    /// [`NEIGHBOUR_RADIUS`] of the tool's closest marker distance of its predicted place,
    /// points up to [`OUTLIER_LIMIT`] times the triangulation gate included; `None` unless
    /// three or more markers are labelled and registration leaves at most [`OUTLIER_LIMIT`]
    /// times the tool's distance ceiling.
    pub fn track_from_neighbour(
        &self,
        views: &Views,
        shapes: &merged::Shapes,
        neighbour: &ToolPose,
        frame: usize,
    ) -> Option<FrameTrack> {
        let Correspondences { unique, .. } =
            correspond_all(self.rig, &self.geometry, views, &self.config.correspond);
        let points: Vec<FramePoint> = self
            .triangulate_all(&Frame { views, shapes }, &unique, Points::BeyondGate)
            .into_iter()
            .filter(|p| {
                self.config
                    .mirror
                    .as_ref()
                    .is_none_or(|m| !m.is_behind(&p.point.position))
            })
            .collect();
        let model = &self.tool.markers_in_tool;
        let closest_mm = (0..model.len())
            .flat_map(|i| (i + 1..model.len()).map(move |j| (i, j)))
            .map(|(i, j)| (model[i] - model[j]).norm())
            .fold(f64::INFINITY, f64::min);
        let radius_mm = NEIGHBOUR_RADIUS * closest_mm;
        let mut labels = BTreeMap::new();
        for (m, marker) in model.iter().enumerate() {
            let predicted = neighbour.world_from_tool * marker;
            let near: Vec<usize> = (0..points.len())
                .filter(|&p| (points[p].point.position - predicted).norm() <= radius_mm)
                .collect();
            if let [only] = near[..] {
                labels.insert(MarkerId(m), only);
            }
        }
        let used: std::collections::BTreeSet<usize> = labels.values().copied().collect();
        if labels.len() < 3 || used.len() < labels.len() {
            return None;
        }
        let markers_in_world = labels
            .iter()
            .map(|(m, p)| (*m, points[*p].point.position))
            .collect();
        let limit_mm = OUTLIER_LIMIT * gates::distance_tolerance_ceiling_mm(self.tool);
        let pose = pose_from_markers(self.tool, &markers_in_world, limit_mm).ok()?;
        let mut flags: Vec<Flag> = labels
            .values()
            .flat_map(|p| points[*p].flags.iter().cloned())
            .collect();
        flags.push(Flag::LabelledFromNeighbour { frame });
        if pose.markers < model.len() {
            flags.push(Flag::FewerMarkers {
                used: pose.markers,
                of: model.len(),
            });
        }
        if pose.rms_mm > self.config.max_registration_rms_mm {
            flags.push(Flag::RegistrationResidual {
                rms_mm: pose.rms_mm,
                gate_mm: self.config.max_registration_rms_mm,
            });
        }
        let mut merged: Vec<CameraId> = labels.values().filter_map(|p| points[*p].merged).collect();
        merged.sort_unstable();
        merged.dedup();
        Some(FrameTrack {
            outcome: Ok(pose),
            points: points.into_iter().map(|p| p.point).collect(),
            labels,
            flags,
            combinations: 1,
            rival_in_world: None,
            reflections: 0,
            merged,
        })
    }

    /// Tracks every frame (in parallel) and assembles the trajectory; frame `i` is at time
    /// `i / fps`. Each sample carries its frame's status.
    #[must_use]
    pub fn track_all(&self, frames: &[Views], fps: f64) -> (Trajectory, Vec<FrameTrack>) {
        let tracks: Vec<FrameTrack> = frames.par_iter().map(|v| self.track_frame(v)).collect();
        let times: Vec<f64> = (0..tracks.len()).map(|i| i as f64 / fps).collect();
        (trajectory_from_tracks(&tracks, &times), tracks)
    }
}

/// A marker's point is labelled from a neighbour's pose when it lies within this fraction of
/// the tool's closest marker distance of the marker's predicted place: under half, so no point
/// is near two markers.
pub const NEIGHBOUR_RADIUS: f64 = 0.3;

/// Frames farthest apart a neighbour's pose labels across.
pub const NEIGHBOUR_FRAMES: usize = 2;

/// The pose a frame lends its neighbours for labelling ([`fill_from_neighbours`]): that of a
/// frame posed `ok` or `degraded`, or labelled so itself.
#[must_use]
pub fn neighbour_pose(track: &FrameTrack) -> Option<ToolPose> {
    let labelled = track
        .flags
        .iter()
        .any(|f| matches!(f, Flag::LabelledFromNeighbour { .. }));
    let pose = track.outcome.as_ref().ok()?;
    (labelled || track.status() <= Status::Degraded).then_some(*pose)
}

/// Frames lost because too few markers fitted the tool's distances (a marker partly hidden
/// moves its point several millimetres) are labelled from the pose of a frame next to them
/// (at most [`NEIGHBOUR_FRAMES`] away; forward through the recording, then backward, so a run
/// of such frames is labelled one from the next): each marker takes the point near its place
/// in the neighbour's pose. Such a pose is an `outlier` ([`Flag::LabelledFromNeighbour`]).
/// A neighbour is a frame posed `ok` or `degraded`, or labelled so itself. `frames[i]` is frame
/// `i`'s blob centres and shapes. Returns how many frames were posed so.
pub fn fill_from_neighbours(
    tracker: &Tracker<'_>,
    frames: &[(&Views, &merged::Shapes)],
    tracks: &mut [FrameTrack],
) -> usize {
    let mut filled = 0;
    let n = tracks.len().min(frames.len());
    let order: Vec<(usize, bool)> = (0..n)
        .map(|i| (i, true))
        .chain((0..n).rev().map(|i| (i, false)))
        .collect();
    for (i, forward) in order {
        if !matches!(tracks[i].outcome, Err(Lost::TooFewMarkers { .. })) {
            continue;
        }
        let near: Vec<usize> = if forward {
            (i.saturating_sub(NEIGHBOUR_FRAMES)..i).rev().collect()
        } else {
            (i + 1..(i + 1 + NEIGHBOUR_FRAMES).min(n)).collect()
        };
        let Some((j, pose)) = near
            .into_iter()
            .find_map(|j| Some((j, neighbour_pose(&tracks[j])?)))
        else {
            continue;
        };
        let (views, shapes) = frames[i];
        if let Some(track) = tracker.track_from_neighbour(views, shapes, &pose, j) {
            tracks[i] = track;
            filled += 1;
        }
    }
    filled
}

/// Why a rig camera is out of use.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub enum OutReason {
    /// The recording has no frames of it.
    NoFrames,
    /// Over the frames measured, none of its blobs took part in a marker's point.
    SeesNothing {
        /// Blobs it saw in those frames.
        blobs_seen: usize,
        /// Frames the other cameras posed.
        posed_frames: usize,
    },
}

impl std::fmt::Display for OutReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoFrames => f.write_str("has no frames in the recording: tracked without it"),
            Self::SeesNothing {
                blobs_seen,
                posed_frames,
            } => write!(
                f,
                "sees nothing of the volume: none of its {blobs_seen} blobs fits the other cameras in {posed_frames} posed frames (check its calibration: `teachcam doctor`)"
            ),
        }
    }
}

/// The trajectory sample of frame `index` at `time_s`: its pose, status and `tip_std_mm`
/// (`degraded` at least where `degraded` says so, e.g. blobs that could not be moved to the
/// common time).
#[must_use]
pub fn sample_of(
    index: usize,
    time_s: f64,
    track: &FrameTrack,
    tip_std_mm: Option<f64>,
    degraded: bool,
) -> Sample {
    match &track.outcome {
        Ok(pose) => {
            let status = match track.status() {
                Status::Ok if degraded => Status::Degraded,
                status => status,
            };
            Sample {
                status,
                tip_std_mm,
                cameras: Some(track.cameras_used()),
                ..Sample::measured(FrameIndex(index), time_s, *pose)
            }
        }
        Err(_) => Sample::gap(FrameIndex(index), time_s),
    }
}

/// The temporal guard ([`temporal`]) over tracked frames: each frame whose pose is farther
/// from its neighbours than the recording's own motion allows gets [`Flag::TemporalJump`]
/// (an outlier). `tip_std_mm[i]` is frame `i`'s tip uncertainty (the gate's floor). Returns
/// the step gate, `None` when too few steps were measured.
pub fn guard_in_time(tracks: &mut [FrameTrack], tip_std_mm: &[Option<f64>]) -> Option<gates::Gate> {
    let frames: Vec<temporal::TipFrame> = tracks
        .iter()
        .enumerate()
        .map(|(i, t)| tip_frame(t, tip_std_mm.get(i).copied().flatten()))
        .collect();
    let check = temporal::temporal_outliers(&frames);
    let gate_mm = check.gate.as_ref().map_or(f64::INFINITY, |g| g.value);
    for (frame, deviation_mm) in check.outliers {
        if let Some(track) = tracks.get_mut(frame) {
            track.flags.push(Flag::TemporalJump {
                deviation_mm,
                gate_mm,
            });
        }
    }
    check.gate
}

/// A tracked frame as the temporal guard sees it: its tip unless it has no pose or is an
/// outlier already, confident when `ok`.
#[must_use]
pub fn tip_frame(track: &FrameTrack, tip_std_mm: Option<f64>) -> temporal::TipFrame {
    let status = track.status();
    temporal::TipFrame {
        tip_in_world: track
            .outcome
            .as_ref()
            .ok()
            .filter(|_| status != Status::Outlier)
            .map(|p| p.tip_in_world),
        confident: status == Status::Ok,
        tip_std_mm,
    }
}

/// The trajectory of tracked frames, frame `i` at `times_s[i]` (its exposure time; a frame
/// without a time is left out), each sample with its frame's status.
#[must_use]
pub fn trajectory_from_tracks(tracks: &[FrameTrack], times_s: &[f64]) -> Trajectory {
    let samples = tracks
        .iter()
        .zip(times_s)
        .enumerate()
        .map(|(i, (t, &time_s))| sample_of(i, time_s, t, None, false))
        .collect();
    Trajectory { samples }
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
