//! The conductor: frames from any [`crate::source`] to tracked frames, as they come.
//!
//! ```text
//! FrameSource ─► batch of FrameSets ─► decode + size check + detect   (rayon, every camera × set)
//!                                      └─► DetectedSet  (blobs per camera, per-frame times)
//!                                           └─► Tracker::track_frame   (rayon, every set)
//!                                                └─► TrackedFrame { detections, track, σ, latency }
//! ```
//! Files and live sources are the same stream. A file source is read in batches of a few sets
//! per core, so PNG decoding and detection run in parallel; a live source one set at a time, so
//! that no set waits for the next one (its cameras still run in parallel). Every frame's size is
//! checked against the rig (or, without a rig, the camera's first frame): a frame of another
//! size is refused naming the camera, the frame and both sizes, never tracked.
//!
//! The per-frame tip uncertainty is the first-order propagation of the frame's blob noise
//! ([`crate::metrology::first_order`]), scaled to the pixel error that the triangulation
//! residuals of the frames so far show ([`NoiseScale`], `σ̂` of
//! [`crate::metrology::residual_noise_px`]), which also holds detector bias and calibration
//! error.

use std::collections::{BTreeMap, VecDeque};
use std::time::Instant;

use rayon::prelude::*;

use crate::camera::Rig;
use crate::correspond::Views;
use crate::detect::{
    Blob, DetectConfig, DetectError, GrayView, RoundnessChoices, detect, detect_choices,
};
use crate::geometry::CameraId;
use crate::io::recording::GrayFrame;
use crate::metrology::first_order;
use crate::source::{FrameSet, FrameSource, SourceError, SourceStats};
use crate::tool::Tool;
use crate::track::{FrameTrack, TrackConfig, Tracker};

/// Why the stream stopped.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// The source failed (a file, a video, a camera, a frame of the wrong size).
    #[error(transparent)]
    Source(#[from] SourceError),
    /// Detection refused a frame.
    #[error("camera {camera}, frame {frame}: {source}")]
    Detect {
        /// The camera.
        camera: String,
        /// The frame.
        frame: usize,
        /// The cause.
        source: DetectError,
    },
    /// A rig camera is not among the source's cameras.
    #[error("rig camera {camera} is not in the source (found: {found})")]
    MissingCamera {
        /// The rig's camera.
        camera: String,
        /// The source's cameras.
        found: String,
    },
    /// The configuration does not match the cameras.
    #[error("{0}")]
    Config(String),
}

/// One camera's blobs in one set: `B` is [`Vec<Blob>`], or [`RoundnessChoices`] when the
/// roundness floor is chosen after detection.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraDetections<B = Vec<Blob>> {
    /// The camera's name.
    pub camera: String,
    /// The frame's number in the camera's own stream.
    pub frame: usize,
    /// The frame's exposure time, seconds.
    pub time_s: f64,
    /// The blobs, in raster order.
    pub blobs: B,
}

/// The blobs of every camera at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectedSet<B = Vec<Blob>> {
    /// The set's index in the stream (the recording's frame number).
    pub index: usize,
    /// The set's time, seconds.
    pub time_s: f64,
    /// When the set was exposed, for live sources.
    pub exposed_at: Option<Instant>,
    /// One entry per detected camera, in the order the stream was given its configurations;
    /// `None` where the camera had no frame at this instant.
    pub cameras: Vec<Option<CameraDetections<B>>>,
}

impl DetectedSet<RoundnessChoices> {
    /// The set as [`detect`] with roundness floor `min_roundness` finds it; `None` below the
    /// floor the choices were detected with.
    #[must_use]
    pub fn at(&self, min_roundness: f64) -> Option<DetectedSet> {
        let cameras = self
            .cameras
            .iter()
            .map(|camera| match camera {
                None => Some(None),
                Some(c) => Some(Some(CameraDetections {
                    camera: c.camera.clone(),
                    frame: c.frame,
                    time_s: c.time_s,
                    blobs: c.blobs.at(min_roundness)?,
                })),
            })
            .collect::<Option<_>>()?;
        Some(DetectedSet {
            index: self.index,
            time_s: self.time_s,
            exposed_at: self.exposed_at,
            cameras,
        })
    }
}

/// What a stream finds in one camera's frame: its blobs ([`Vec<Blob>`], by [`detect`]) or its
/// blobs for every roundness floor from the configuration's up ([`RoundnessChoices`], by
/// [`detect_choices`]).
pub trait FrameDetections: Sized + Send {
    /// Detects `image` with `config`.
    ///
    /// # Errors
    /// As [`detect`].
    fn detect_frame(image: &GrayFrame, config: &DetectConfig) -> Result<Self, DetectError>;
}

impl FrameDetections for Vec<Blob> {
    fn detect_frame(image: &GrayFrame, config: &DetectConfig) -> Result<Self, DetectError> {
        match image {
            GrayFrame::Eight(i) => detect(i, config),
            GrayFrame::Sixteen(i) => detect(i, config),
        }
    }
}

impl FrameDetections for RoundnessChoices {
    fn detect_frame(image: &GrayFrame, config: &DetectConfig) -> Result<Self, DetectError> {
        match image {
            GrayFrame::Eight(i) => detect_choices(GrayView::new(i), config),
            GrayFrame::Sixteen(i) => detect_choices(GrayView::new(i), config),
        }
    }
}

/// A camera to detect: its name among the source's cameras, its detector configuration, and
/// the size its frames must have (`None`: the size of its first frame).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSetup {
    /// The camera's name.
    pub name: String,
    /// Its detector configuration.
    pub detect: DetectConfig,
    /// `(width, height)` every frame must have.
    pub size: Option<(u32, u32)>,
}

/// One camera's frame detected: its size and blobs, or nothing when it had no frame.
type DetectedFrame<B> = Result<Option<((u32, u32), CameraDetections<B>)>, PipelineError>;

/// Detection over a source's frames, set by set; `B` is what each camera's frame gives
/// ([`FrameDetections`]).
#[derive(Debug)]
pub struct DetectStream<'s, B = Vec<Blob>> {
    source: &'s mut dyn FrameSource,
    /// For each detected camera: its position among the source's cameras, its configuration.
    cameras: Vec<(usize, DetectConfig)>,
    sizes: Vec<Option<(u32, u32)>>,
    batch: usize,
    ready: VecDeque<DetectedSet<B>>,
    done: bool,
}

impl<'s> DetectStream<'s> {
    /// Detects these cameras of `source`, in this order.
    ///
    /// # Errors
    /// [`PipelineError::MissingCamera`] when a name is not among the source's cameras.
    pub fn new(
        source: &'s mut dyn FrameSource,
        cameras: Vec<CameraSetup>,
    ) -> Result<Self, PipelineError> {
        Self::detecting(source, cameras)
    }

    /// Every camera of the source, each with the same configuration and its first frame's size.
    ///
    /// # Errors
    /// Never in practice (every name is the source's own); kept for one signature.
    pub fn all_cameras(
        source: &'s mut dyn FrameSource,
        config: &DetectConfig,
    ) -> Result<Self, PipelineError> {
        let cameras = source
            .cameras()
            .iter()
            .map(|c| CameraSetup {
                name: c.name.clone(),
                detect: config.clone(),
                size: None,
            })
            .collect();
        Self::new(source, cameras)
    }
}

impl<'s, B: FrameDetections> DetectStream<'s, B> {
    /// Detects these cameras of `source`, in this order, each frame into a `B`.
    ///
    /// # Errors
    /// [`PipelineError::MissingCamera`] when a name is not among the source's cameras.
    pub fn detecting(
        source: &'s mut dyn FrameSource,
        cameras: Vec<CameraSetup>,
    ) -> Result<Self, PipelineError> {
        let names: Vec<String> = source.cameras().iter().map(|c| c.name.clone()).collect();
        let mut detected = Vec::new();
        let mut sizes = Vec::new();
        for CameraSetup {
            name,
            detect: config,
            size,
        } in cameras
        {
            let Some(position) = names.iter().position(|n| *n == name) else {
                return Err(PipelineError::MissingCamera {
                    camera: name,
                    found: names.join(", "),
                });
            };
            let known = source.cameras()[position].size;
            if let (Some(expected), Some(known)) = (size, known)
                && expected != known
            {
                return Err(SourceError::FrameSize {
                    camera: name,
                    frame: 0,
                    size: known,
                    expected,
                }
                .into());
            }
            detected.push((position, config));
            sizes.push(size.or(known));
        }
        let batch = if source.is_live() {
            1
        } else {
            4 * rayon::current_num_threads()
        };
        Ok(Self {
            source,
            cameras: detected,
            sizes,
            batch,
            ready: VecDeque::new(),
            done: false,
        })
    }

    /// The source's nominal rate.
    #[must_use]
    pub fn fps(&self) -> f64 {
        self.source.fps()
    }

    /// The number of sets when the source knows it.
    #[must_use]
    pub fn len_hint(&self) -> Option<usize> {
        self.source.len_hint()
    }

    /// What the source dropped or left unpaired so far.
    #[must_use]
    pub fn stats(&self) -> SourceStats {
        self.source.stats()
    }

    /// The names of the detected cameras, in the order of [`DetectedSet::cameras`].
    #[must_use]
    pub fn camera_names(&self) -> Vec<String> {
        self.cameras
            .iter()
            .map(|(p, _)| self.source.cameras()[*p].name.clone())
            .collect()
    }

    /// Reads, decodes and detects the next batch of sets, in order.
    fn next_batch(&mut self) -> Result<Vec<DetectedSet<B>>, PipelineError> {
        let mut sets: Vec<FrameSet> = Vec::with_capacity(self.batch);
        while sets.len() < self.batch {
            match self.source.next_set() {
                Some(set) => sets.push(set?),
                None => {
                    self.done = true;
                    break;
                }
            }
        }
        let names: Vec<String> = self.camera_names();
        let jobs: Vec<(usize, usize)> = (0..sets.len())
            .flat_map(|s| (0..self.cameras.len()).map(move |c| (s, c)))
            .collect();
        let sizes = &self.sizes;
        let cameras = &self.cameras;
        let results: Vec<DetectedFrame<B>> = jobs
            .par_iter()
            .map(|&(s, c)| {
                let (position, config) = &cameras[c];
                let Some(frame) = sets[s].cameras.get(*position).and_then(Option::as_ref) else {
                    return Ok(None);
                };
                let name = &names[c];
                let image = frame.decode(name, sizes[c])?;
                let blobs =
                    B::detect_frame(&image, config).map_err(|source| PipelineError::Detect {
                        camera: name.clone(),
                        frame: frame.frame,
                        source,
                    })?;
                Ok(Some((
                    image.dimensions(),
                    CameraDetections {
                        camera: name.clone(),
                        frame: frame.frame,
                        time_s: frame.time_s,
                        blobs,
                    },
                )))
            })
            .collect();
        let mut results = results.into_iter();
        let mut detected = Vec::with_capacity(sets.len());
        for set in &sets {
            let mut cameras = Vec::with_capacity(self.cameras.len());
            for c in 0..self.cameras.len() {
                let result = results.next().ok_or_else(|| {
                    PipelineError::Config("internal: a detection went missing".into())
                })??;
                let Some((size, detections)) = result else {
                    cameras.push(None);
                    continue;
                };
                // Without a rig the camera's first frame sets its size: later frames must agree.
                match self.sizes[c] {
                    Some(expected) if expected != size => {
                        return Err(SourceError::FrameSize {
                            camera: detections.camera,
                            frame: detections.frame,
                            size,
                            expected,
                        }
                        .into());
                    }
                    Some(_) => {}
                    None => self.sizes[c] = Some(size),
                }
                cameras.push(Some(detections));
            }
            detected.push(DetectedSet {
                index: set.index,
                time_s: set.time_s,
                exposed_at: set.exposed_at,
                cameras,
            });
        }
        Ok(detected)
    }
}

impl<B: FrameDetections> Iterator for DetectStream<'_, B> {
    type Item = Result<DetectedSet<B>, PipelineError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.ready.is_empty() && !self.done {
            match self.next_batch() {
                Ok(sets) => self.ready.extend(sets),
                Err(e) => {
                    self.done = true;
                    self.ready.clear();
                    return Some(Err(e));
                }
            }
        }
        self.ready.pop_front().map(Ok)
    }
}

/// Options of the conductor.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PipelineConfig {
    /// Detector configuration of each rig camera (a camera without one gets
    /// [`DetectConfig::for_marker`] with the tool's marker size between 300 mm and 3 m).
    pub detect: BTreeMap<CameraId, DetectConfig>,
    /// Tracking options.
    pub track: TrackConfig,
}

/// One tracked instant with its evidence.
#[derive(Debug, Clone)]
pub struct TrackedFrame {
    /// The blobs of every rig camera (in rig order), with their frames' times.
    pub detections: DetectedSet,
    /// The pose or why there is none, with the triangulated points and labels.
    pub track: FrameTrack,
    /// RMS of the frame's blobs' predicted centre noise, pixels (image noise only).
    pub blob_noise_px: f64,
    /// First-order tip uncertainty (RMS over the axes), millimetres, at the frame's blob noise
    /// scaled to what the residuals of the frames so far show; `None` without a pose.
    pub tip_std_mm: Option<f64>,
    /// When the pose was ready.
    pub tracked_at: Instant,
}

impl TrackedFrame {
    /// Seconds from exposure to pose, for live sources.
    #[must_use]
    pub fn latency_s(&self) -> Option<f64> {
        self.detections
            .exposed_at
            .map(|e| self.tracked_at.saturating_duration_since(e).as_secs_f64())
    }
}

/// The running ratio of the pixel error the triangulation residuals show (pooled
/// `Σ n r² / Σ (2n − 3)`) to the blobs' predicted noise (`Σ σ² / count`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NoiseScale {
    residual_squares: f64,
    residual_freedom: usize,
    predicted_squares: f64,
    predicted_count: usize,
}

impl NoiseScale {
    /// Adds a frame's evidence.
    pub fn add(&mut self, track: &FrameTrack, blob_noise_px: &[f64]) {
        for point in track.labels.values().filter_map(|&p| track.points.get(p)) {
            let n = point.views.len();
            if n >= 2 && point.residual_px.is_finite() {
                self.residual_squares += n as f64 * point.residual_px * point.residual_px;
                self.residual_freedom += 2 * n - 3;
            }
        }
        self.predicted_squares += blob_noise_px.iter().map(|s| s * s).sum::<f64>();
        self.predicted_count += blob_noise_px.len();
    }

    /// The factor from predicted to shown pixel error (1 until both are known).
    #[must_use]
    pub fn factor(&self) -> f64 {
        if self.residual_freedom == 0 || self.predicted_count == 0 || self.predicted_squares <= 0.0
        {
            return 1.0;
        }
        let shown = (self.residual_squares / self.residual_freedom as f64).sqrt();
        let predicted = (self.predicted_squares / self.predicted_count as f64).sqrt();
        shown / predicted
    }
}

/// The first-order tip uncertainty of a pose at `noise_px` per image coordinate.
#[must_use]
pub fn tip_std_mm(rig: &Rig, tool: &Tool, track: &FrameTrack, noise_px: f64) -> Option<f64> {
    let pose = track.outcome.as_ref().ok()?;
    (noise_px > 0.0)
        .then(|| first_order(rig, tool, &pose.world_from_tool, noise_px).ok())
        .flatten()
        .map(|u| u.tip_rms_mm)
}

/// Tracking over a source's frames, set by set.
#[derive(Debug)]
pub struct TrackStream<'a> {
    detect: DetectStream<'a>,
    rig: &'a Rig,
    tool: &'a Tool,
    tracker: Tracker<'a>,
    ids: Vec<CameraId>,
    scale: NoiseScale,
    pending: VecDeque<TrackedFrame>,
}

impl<'a> TrackStream<'a> {
    /// Tracks `tool` through the frames of `source` seen by `rig`'s cameras (matched by name;
    /// every rig camera must be in the source, extra source cameras are ignored).
    ///
    /// # Errors
    /// [`PipelineError::MissingCamera`] naming a rig camera the source lacks.
    pub fn new(
        source: &'a mut dyn FrameSource,
        rig: &'a Rig,
        tool: &'a Tool,
        config: &PipelineConfig,
    ) -> Result<Self, PipelineError> {
        let cameras = rig
            .iter()
            .map(|(id, camera)| {
                let detect = config.detect.get(&id).cloned().unwrap_or_else(|| {
                    DetectConfig::for_marker(camera, tool.marker_diameter_mm, 300.0, 3000.0)
                });
                CameraSetup {
                    name: camera.name.clone(),
                    detect,
                    size: Some((camera.image_size.width, camera.image_size.height)),
                }
            })
            .collect();
        let ids = rig.iter().map(|(id, _)| id).collect();
        Ok(Self {
            detect: DetectStream::new(source, cameras)?,
            rig,
            tool,
            tracker: Tracker::new(rig, tool, config.track.clone()),
            ids,
            scale: NoiseScale::default(),
            pending: VecDeque::new(),
        })
    }

    /// The source's nominal rate.
    #[must_use]
    pub fn fps(&self) -> f64 {
        self.detect.fps()
    }

    /// The number of sets when the source knows it.
    #[must_use]
    pub fn len_hint(&self) -> Option<usize> {
        self.detect.len_hint()
    }

    /// What the source dropped or left unpaired so far.
    #[must_use]
    pub fn stats(&self) -> SourceStats {
        self.detect.stats()
    }

    /// The rig's view of a set: each camera's blob centres, keyed by rig id.
    #[must_use]
    pub fn views(&self, set: &DetectedSet) -> Views {
        self.ids
            .iter()
            .zip(&set.cameras)
            .filter_map(|(id, c)| Some((*id, c.as_ref()?.blobs.iter().map(|b| b.center).collect())))
            .collect()
    }

    fn track_batch(&mut self, sets: Vec<DetectedSet>) -> Vec<TrackedFrame> {
        let views: Vec<Views> = sets.iter().map(|set| self.views(set)).collect();
        let tracker = &self.tracker;
        let tracks: Vec<FrameTrack> = views.par_iter().map(|v| tracker.track_frame(v)).collect();
        sets.into_iter()
            .zip(tracks)
            .map(|(detections, track)| {
                let noise: Vec<f64> = detections
                    .cameras
                    .iter()
                    .flatten()
                    .flat_map(|c| c.blobs.iter().map(|b| b.center_std_px))
                    .collect();
                self.scale.add(&track, &noise);
                let blob_noise_px = rms(&noise);
                let tip_std_mm = tip_std_mm(
                    self.rig,
                    self.tool,
                    &track,
                    self.scale.factor() * blob_noise_px,
                );
                TrackedFrame {
                    detections,
                    track,
                    blob_noise_px,
                    tip_std_mm,
                    tracked_at: Instant::now(),
                }
            })
            .collect()
    }
}

/// Root mean square; 0 for none.
fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len().max(1) as f64).sqrt()
}

impl Iterator for TrackStream<'_> {
    type Item = Result<TrackedFrame, PipelineError>;

    fn next(&mut self) -> Option<Self::Item> {
        if let Some(frame) = self.pending.pop_front() {
            return Some(Ok(frame));
        }
        // Take what detection has ready (a whole batch for files, one set when live).
        let first = match self.detect.next()? {
            Ok(set) => set,
            Err(e) => return Some(Err(e)),
        };
        let mut sets = vec![first];
        while let Some(set) = self.detect.ready.pop_front() {
            sets.push(set);
        }
        let tracked = self.track_batch(sets);
        self.pending.extend(tracked);
        self.pending.pop_front().map(Ok)
    }
}
