//! A recording detected: every frame's blobs (with progress), the sample its gates are measured
//! from, and those gates ([`Learned`]), as both the batch and the stream use them.
//!
//! Sampling (what `track` has always done, now in one place): the roundness gate from the
//! blobs of [`ROUNDNESS_SAMPLE_FRAMES`] sets spread over the recording, detected at the lowest
//! floor ([`ROUNDNESS_FLOOR`]); every other gate from [`GATE_SAMPLE_FRAMES`] frames spread over
//! it, detected at that roundness ([`crate::track::gates::measure_gates`]). A stream over a
//! recording learns the same gates by reading only those frames first ([`learn_from_recording`]).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::Path;

use super::rules::{CameraOut, FrameInput, cameras_out, frame_inputs};
use rayon::prelude::*;

use super::detect_stream::FromSketch;
use super::{CameraSetup, DetectStream, FrameDetections, PipelineError};
use crate::camera::Rig;
use crate::detect::learn::{CameraLimits, FrameSample, learn_limits};
use crate::detect::sketch::Sketch;
use crate::detect::{
    Blob, CameraDetections, CenterMethod, DetectConfig, DetectedSet, RoundnessChoices, Threshold,
};
use crate::geometry::CameraId;
use crate::io::detections::Detections;
use crate::metrology::frame::Typical;
use crate::source::folder::{FolderSource, RecordingClock};
use crate::source::{FrameData, FrameSet, FrameSource, SourceCamera, SourceError, SourceStats};
use crate::tool::Tool;
use crate::track::Tracker;
use crate::track::gates::{
    Gate, GateOverrides, Gates, ROUNDNESS_FLOOR, measure_gates, roundness_gate, sample_frames,
};
use crate::track::merged::Shapes;

/// Sets whose blobs (detected at the lowest floor) measure the roundness gate.
pub const ROUNDNESS_SAMPLE_FRAMES: usize = 60;

/// Frames tracked in the first pass that measures the other gates.
pub const GATE_SAMPLE_FRAMES: usize = 300;

/// How markers are detected for tracking: the options `track`, `live`, the studio, `doctor`
/// and `calibrate refine` share.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectOptions {
    /// Frames per second overriding the recording's (`None`: recording.json, the videos', 30).
    pub fps: Option<f64>,
    /// The centre estimate.
    pub method: CenterMethod,
    /// A fixed threshold in the images' units (`None`: automatic per frame).
    pub threshold: Option<u32>,
    /// Nearest distance from a camera to a marker, millimetres: the largest blob.
    pub near_mm: f64,
    /// Farthest distance from a camera to a marker, millimetres: the smallest blob.
    pub far_mm: f64,
}

impl Default for DetectOptions {
    fn default() -> Self {
        Self {
            fps: None,
            // The most accurate centre (notes/detect.md).
            method: CenterMethod::Refined,
            threshold: None,
            // A hand-held tool between 0.3 m and 3 m of every camera: desk to room scale.
            near_mm: 300.0,
            far_mm: 3000.0,
        }
    }
}

impl DetectOptions {
    /// The detector configuration of one rig camera for `tool`'s markers at `min_roundness`.
    #[must_use]
    pub fn config(
        &self,
        camera: &crate::camera::Camera,
        tool: &Tool,
        min_roundness: f64,
    ) -> DetectConfig {
        let mut detect =
            DetectConfig::for_marker(camera, tool.marker_diameter_mm, self.near_mm, self.far_mm);
        detect.method = self.method;
        detect.min_roundness = min_roundness;
        if let Some(t) = self.threshold {
            detect.threshold = Threshold::Fixed(t);
        }
        detect
    }

    /// The setups of the rig's cameras that `source_cameras` has, in the rig's order, each
    /// frame of the rig's size, and the names of the rig's cameras it lacks.
    ///
    /// # Errors
    /// [`PipelineError::TooFewCameras`] when fewer than two rig cameras are there.
    pub fn rig_setups(
        &self,
        rig: &Rig,
        tool: &Tool,
        source_cameras: &[SourceCamera],
        min_roundness: f64,
    ) -> Result<(Vec<CameraSetup>, Vec<String>), PipelineError> {
        let mut setups = Vec::new();
        let mut missing = Vec::new();
        for camera in &rig.cameras {
            if source_cameras.iter().any(|c| c.name == camera.name) {
                setups.push(CameraSetup {
                    name: camera.name.clone(),
                    detect: self.config(camera, tool, min_roundness),
                    size: Some((camera.image_size.width, camera.image_size.height)),
                });
            } else {
                missing.push(camera.name.clone());
            }
        }
        if setups.len() < 2 {
            return Err(PipelineError::TooFewCameras {
                found: setups.len(),
                cameras: rig
                    .cameras
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                missing: missing.join(", "),
            });
        }
        Ok((setups, missing))
    }

    /// `near_mm < far_mm`, both positive and finite.
    ///
    /// # Errors
    /// [`PipelineError::Config`] saying which.
    pub fn check(&self) -> Result<(), PipelineError> {
        if self.near_mm.is_finite()
            && self.far_mm.is_finite()
            && 0.0 < self.near_mm
            && self.near_mm < self.far_mm
        {
            Ok(())
        } else {
            Err(PipelineError::Config(format!(
                "--near {} and --far {}: near must be less than far",
                self.near_mm, self.far_mm
            )))
        }
    }
}

/// A recording's frames detected: every set (one instant: each camera's frame, its time and
/// blobs), the cameras in the order of each set's entries, and the rate. `B` is
/// [`Vec<Blob>`], or [`RoundnessChoices`] when the roundness floor is chosen afterwards.
#[derive(Debug)]
pub struct DetectedRecording<B = Vec<Blob>> {
    /// The detected cameras, in the order of [`DetectedSet::cameras`].
    pub cameras: Vec<String>,
    /// Frames per second (`--fps`, else recording.json, else the videos', else 30).
    pub fps: f64,
    /// The sets, in order.
    pub sets: Vec<DetectedSet<B>>,
    /// The number of sets the source announced before decoding, where it knew it.
    pub len_hint: Option<usize>,
}

impl DetectedRecording {
    /// Each set's blobs by rig camera id (cameras the rig lacks are left out).
    #[must_use]
    pub fn blobs_by_camera(&self, rig: &Rig) -> Vec<BTreeMap<CameraId, Vec<Blob>>> {
        let ids: Vec<Option<CameraId>> = self.cameras.iter().map(|c| rig.id_of(c)).collect();
        self.sets
            .iter()
            .map(|set| {
                ids.iter()
                    .zip(&set.cameras)
                    .filter_map(|(id, c)| Some(((*id)?, c.as_ref()?.blobs.clone())))
                    .collect()
            })
            .collect()
    }

    /// Every set as tracking through `rig` takes it ([`frame_inputs`]).
    #[must_use]
    pub fn inputs(&self, rig: &Rig) -> Vec<FrameInput> {
        let ids: Vec<Option<CameraId>> = self.cameras.iter().map(|c| rig.id_of(c)).collect();
        self.sets
            .iter()
            .map(|set| frame_inputs(&ids, set))
            .collect()
    }
}

impl DetectedRecording<RoundnessChoices> {
    /// The recording as detected with roundness floor `min_roundness`; `None` below the floor
    /// it was detected with.
    #[must_use]
    pub fn at(&self, min_roundness: f64) -> Option<DetectedRecording> {
        Some(DetectedRecording {
            cameras: self.cameras.clone(),
            fps: self.fps,
            sets: self
                .sets
                .iter()
                .map(|set| set.at(min_roundness))
                .collect::<Option<_>>()?,
            len_hint: self.len_hint,
        })
    }
}

/// A sample of at most `at_most` sets of a source that announced `len_hint` sets: spread
/// evenly over the recording, or its first ones when its length was not known.
#[must_use]
pub fn sampled_sets(len_hint: Option<usize>, at_most: usize) -> Vec<usize> {
    match len_hint {
        Some(count) => sample_frames(count, at_most),
        None => (0..at_most).collect(),
    }
}

/// Detects every set of `source` with `setups` (which cameras, how; each frame's size checked
/// against its setup's or the camera's first frame), calling `progress` after each set.
///
/// # Errors
/// [`PipelineError`] naming the camera, frame or file that cannot be read or has another size.
pub fn detect_recording<B: FrameDetections>(
    source: &mut dyn FrameSource,
    setups: Vec<CameraSetup>,
    progress: &dyn Fn(),
) -> Result<DetectedRecording<B>, PipelineError> {
    let len_hint = source.len_hint();
    let mut stream = DetectStream::<B>::detecting(source, setups)?;
    let cameras = stream.camera_names();
    let fps = stream.fps();
    let mut sets = Vec::new();
    for set in &mut stream {
        sets.push(set?);
        progress();
    }
    Ok(DetectedRecording {
        cameras,
        fps,
        sets,
        len_hint,
    })
}

/// A recording detected for tracking, with the limits it was detected with.
#[derive(Debug)]
pub struct DetectedForTracking {
    /// Every frame's blobs.
    pub recording: DetectedRecording,
    /// The roundness gate (measured from a sample unless overridden).
    pub min_roundness: Gate,
    /// Every limit of the detection, measured from samples unless given.
    pub limits: DetectLimits,
    /// The rig's cameras the recording has no frames of.
    pub missing_cameras: Vec<String>,
}

/// Detects every frame of the recording folder `root` for tracking `tool` through `rig` with
/// the limits [`detect_learned`] measures (the flags of `options` and `min_roundness`
/// override them). Rig cameras without frames are left out and named.
///
/// # Errors
/// [`PipelineError`] as [`detect_recording`]; near not below far; fewer than two rig cameras.
pub fn detect_for_tracking(
    root: &Path,
    rig: &Rig,
    tool: &Tool,
    options: &DetectOptions,
    min_roundness: Option<f64>,
    progress: &dyn Fn(),
) -> Result<DetectedForTracking, PipelineError> {
    options.check()?;
    let source = FolderSource::open(root, options.fps)?;
    let floor = min_roundness.unwrap_or(ROUNDNESS_FLOOR);
    let (setups, missing_cameras) = options.rig_setups(rig, tool, source.cameras(), floor)?;
    let given = LimitsGiven {
        min_area_px: false,
        min_roundness,
    };
    let (recording, limits) = detect_learned_within(
        source,
        root,
        options.fps,
        setups,
        given,
        SKETCH_BYTES,
        progress,
    )?;
    Ok(DetectedForTracking {
        recording,
        min_roundness: limits.min_roundness.clone(),
        limits,
        missing_cameras,
    })
}

/// Sets sampled to learn each camera's threshold and smallest blob from.
pub const LIMIT_SAMPLE_FRAMES: usize = 60;

/// Which limits the user fixed (the threshold is fixed in the setups' configurations).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LimitsGiven {
    /// The setups' smallest blob is given: keep it.
    pub min_area_px: bool,
    /// The roundness floor, when given.
    pub min_roundness: Option<f64>,
}

/// The limits a recording was detected with: each camera's threshold and smallest blob
/// ([`crate::detect::learn`]) and the roundness floor ([`roundness_gate`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DetectLimits {
    /// Each detected camera's name and limits, in the recording's order.
    pub cameras: Vec<(String, CameraLimits)>,
    /// The roundness floor.
    pub min_roundness: Gate,
    /// Sets the threshold and smallest blob were learned from.
    pub sampled_sets: usize,
}

impl DetectLimits {
    /// The limits in one line, for people.
    #[must_use]
    pub fn summary(&self) -> String {
        let cameras: Vec<String> = self
            .cameras
            .iter()
            .map(|(name, limits)| format!("{name}: {}", limits.summary()))
            .collect();
        format!(
            "detect limits (from {} sampled frames; flags override): {}; min roundness {:.2} ({})",
            self.sampled_sets,
            cameras.join("; "),
            self.min_roundness.value,
            self.min_roundness.reason
        )
    }
}

/// Learns each camera's threshold and smallest blob from [`LIMIT_SAMPLE_FRAMES`] sets spread
/// over `source` (each detected permissively, [`FrameSample`]) and sets them in `setups`; a
/// fixed threshold and a given smallest blob stay. Returns the limits and the sets sampled.
///
/// # Errors
/// As [`detect_recording`].
pub fn learn_camera_limits(
    source: &mut dyn FrameSource,
    setups: &mut [CameraSetup],
    min_area_given: bool,
) -> Result<(Vec<(String, CameraLimits)>, usize), PipelineError> {
    if nothing_to_learn(setups, min_area_given) {
        return Ok(limits_from_samples(&[], setups, min_area_given));
    }
    let keep: BTreeSet<usize> = sampled_sets(source.len_hint(), LIMIT_SAMPLE_FRAMES)
        .into_iter()
        .collect();
    let mut sampled = Sampled {
        inner: source,
        keep,
    };
    let samples: DetectedRecording<FrameSample> =
        detect_recording(&mut sampled, setups.to_vec(), &|| {})?;
    Ok(limits_from_samples(&samples.sets, setups, min_area_given))
}

/// True when every camera's threshold is fixed and the smallest blob given: no sample needed.
fn nothing_to_learn(setups: &[CameraSetup], min_area_given: bool) -> bool {
    min_area_given
        && setups
            .iter()
            .all(|s| matches!(s.detect.threshold, Threshold::Fixed(_)))
}

/// Each camera's limits learned from the permissive detections of the sampled `sets` (none:
/// the limits as configured), set in `setups`; with the number of sets.
fn limits_from_samples(
    sets: &[DetectedSet<FrameSample>],
    setups: &mut [CameraSetup],
    min_area_given: bool,
) -> (Vec<(String, CameraLimits)>, usize) {
    let limits = setups
        .iter_mut()
        .enumerate()
        .map(|(i, setup)| {
            let frames: Vec<FrameSample> = sets
                .iter()
                .filter_map(|set| set.cameras.get(i)?.as_ref())
                .map(|c| c.blobs.clone())
                .collect();
            let limits = learn_limits(&frames, &setup.detect, min_area_given);
            limits.apply(&mut setup.detect);
            (setup.name.clone(), limits)
        })
        .collect();
    (limits, sets.len())
}

/// Pixels the sketches of one recording may keep at most ([`Sketch`]; beyond, the recording
/// is read once for the sample and once more for the detection).
const SKETCH_BYTES: usize = 512 << 20;

/// Where [`detect_learned`] reads the frames of each of its passes from.
enum Frames<'a> {
    /// Every frame sketched in one read of the recording.
    Sketched(DetectedRecording<Sketch>),
    /// The recording read again for each pass.
    Reread {
        /// The recording folder.
        root: &'a Path,
        /// `--fps`.
        fps: Option<f64>,
    },
}

impl<'a> Frames<'a> {
    /// Reads `source`, the recording `root` opened with `fps`, once, sketching every frame
    /// for `setups` (`progress` after each set), or, when the sketches would keep more than
    /// `budget` bytes, leaves it to be read again for each pass.
    fn read(
        mut source: FolderSource,
        root: &'a Path,
        fps: Option<f64>,
        setups: &[CameraSetup],
        budget: usize,
        progress: &dyn Fn(),
    ) -> Result<Self, PipelineError> {
        let len_hint = source.len_hint();
        let mut stream = DetectStream::<Sketch>::detecting(&mut source, setups.to_vec())?;
        let cameras = stream.camera_names();
        let rate = stream.fps();
        let mut sets = Vec::new();
        let mut bytes = 0;
        for set in &mut stream {
            let set = set?;
            bytes += set
                .cameras
                .iter()
                .flatten()
                .map(|c| c.blobs.bytes())
                .sum::<usize>();
            if bytes > budget {
                return Ok(Self::Reread { root, fps });
            }
            sets.push(set);
            progress();
        }
        Ok(Self::Sketched(DetectedRecording {
            cameras,
            fps: rate,
            sets,
            len_hint,
        }))
    }

    /// Every set detected with `setups`.
    fn detect<B: FromSketch>(
        &self,
        setups: Vec<CameraSetup>,
        progress: &dyn Fn(),
    ) -> Result<DetectedRecording<B>, PipelineError> {
        match self {
            Self::Sketched(recording) => Ok(DetectedRecording {
                cameras: recording.cameras.clone(),
                fps: recording.fps,
                sets: from_sketches(recording.sets.iter(), &setups)?,
                len_hint: recording.len_hint,
            }),
            Self::Reread { root, fps } => {
                let mut source = FolderSource::open(root, *fps)?;
                detect_recording(&mut source, setups, progress)
            }
        }
    }

    /// [`learn_camera_limits`] on these frames.
    fn camera_limits(
        &self,
        setups: &mut [CameraSetup],
        min_area_given: bool,
    ) -> Result<(Vec<(String, CameraLimits)>, usize), PipelineError> {
        match self {
            Self::Sketched(recording) if !nothing_to_learn(setups, min_area_given) => {
                let keep: BTreeSet<usize> = sampled_sets(recording.len_hint, LIMIT_SAMPLE_FRAMES)
                    .into_iter()
                    .collect();
                let sampled = recording.sets.iter().filter(|s| keep.contains(&s.index));
                let samples: Vec<DetectedSet<FrameSample>> = from_sketches(sampled, setups)?;
                Ok(limits_from_samples(&samples, setups, min_area_given))
            }
            Self::Sketched(_) => Ok(limits_from_samples(&[], setups, min_area_given)),
            Self::Reread { root, fps } => {
                let mut source = FolderSource::open(root, *fps)?;
                learn_camera_limits(&mut source, setups, min_area_given)
            }
        }
    }
}

/// `sets` detected from their sketches with `setups` (in the sets' camera order), in
/// parallel; the first set's error in order where any fails.
fn from_sketches<'s, B: FromSketch>(
    sets: impl Iterator<Item = &'s DetectedSet<Sketch>>,
    setups: &[CameraSetup],
) -> Result<Vec<DetectedSet<B>>, PipelineError> {
    let sets: Vec<&DetectedSet<Sketch>> = sets.collect();
    let detected: Vec<Result<DetectedSet<B>, PipelineError>> = sets
        .par_iter()
        .map(|set| from_sketch_set(set, setups))
        .collect();
    detected.into_iter().collect()
}

/// One set detected from its cameras' sketches with `setups`.
fn from_sketch_set<B: FromSketch>(
    set: &DetectedSet<Sketch>,
    setups: &[CameraSetup],
) -> Result<DetectedSet<B>, PipelineError> {
    let mut cameras = Vec::with_capacity(set.cameras.len());
    for (camera, setup) in set.cameras.iter().zip(setups) {
        let Some(c) = camera else {
            cameras.push(None);
            continue;
        };
        let blobs =
            B::from_sketch(&c.blobs, &setup.detect).map_err(|source| PipelineError::Detect {
                camera: c.camera.clone(),
                frame: c.frame,
                source,
            })?;
        cameras.push(Some(CameraDetections {
            camera: c.camera.clone(),
            frame: c.frame,
            time_s: c.time_s,
            blobs,
        }));
    }
    Ok(DetectedSet {
        index: set.index,
        time_s: set.time_s,
        exposed_at: set.exposed_at,
        cameras,
    })
}

/// Detects every frame of the recording folder `root` with `setups` and limits measured from
/// the recording itself: each camera's threshold and smallest blob from a sample
/// ([`learn_camera_limits`]), then the roundness floor from the blobs of
/// [`ROUNDNESS_SAMPLE_FRAMES`] sets detected at those limits with the lowest floor
/// ([`roundness_gate`]). The recording is read once: every frame is kept as a [`Sketch`] of
/// what a detection can read, and detected from it at the learned limits (the same blobs as
/// from the frame); a recording whose sketches would pass [`SKETCH_BYTES`] is read again
/// for each pass instead. What `given` (and a fixed threshold in `setups`) fixes stays.
/// `detect`, `track`, `calibrate refine` and `doctor` all detect so.
///
/// # Errors
/// [`PipelineError`] as [`detect_recording`].
pub fn detect_learned(
    root: &Path,
    fps: Option<f64>,
    setups: Vec<CameraSetup>,
    given: LimitsGiven,
    progress: &dyn Fn(),
) -> Result<(DetectedRecording, DetectLimits), PipelineError> {
    let source = FolderSource::open(root, fps)?;
    detect_learned_within(source, root, fps, setups, given, SKETCH_BYTES, progress)
}

/// [`detect_learned`] of `source`, the recording `root` opened with `fps`, with the sketches'
/// budget in bytes.
fn detect_learned_within(
    source: FolderSource,
    root: &Path,
    fps: Option<f64>,
    mut setups: Vec<CameraSetup>,
    given: LimitsGiven,
    budget: usize,
    progress: &dyn Fn(),
) -> Result<(DetectedRecording, DetectLimits), PipelineError> {
    let frames = Frames::read(source, root, fps, &setups, budget, progress)?;
    let (cameras, sampled) = frames.camera_limits(&mut setups, given.min_area_px)?;
    let floor = given.min_roundness.unwrap_or(ROUNDNESS_FLOOR);
    for setup in &mut setups {
        setup.detect.min_roundness = floor;
    }
    let (recording, min_roundness) = match given.min_roundness {
        Some(_) => {
            let gate = roundness_gate(&[], given.min_roundness);
            (frames.detect(setups, progress)?, gate)
        }
        None => {
            let choices: DetectedRecording<RoundnessChoices> =
                frames.detect(setups.clone(), progress)?;
            let sample: BTreeSet<usize> = sampled_sets(choices.len_hint, ROUNDNESS_SAMPLE_FRAMES)
                .into_iter()
                .collect();
            let gate = roundness_gate(&sample_roundness(&choices.sets, &sample), None);
            let detected = match choices.at(gate.value) {
                Some(detected) => detected,
                // A gate below the floor (none is measured so): detect again with it.
                None => {
                    for setup in &mut setups {
                        setup.detect.min_roundness = gate.value;
                    }
                    frames.detect(setups, progress)?
                }
            };
            (detected, gate)
        }
    };
    Ok((
        recording,
        DetectLimits {
            cameras,
            min_roundness,
            sampled_sets: sampled,
        },
    ))
}

/// The roundness of every blob (above the lowest floor) of the sets of `sample`.
fn sample_roundness(sets: &[DetectedSet<RoundnessChoices>], sample: &BTreeSet<usize>) -> Vec<f64> {
    sets.iter()
        .filter(|s| sample.contains(&s.index))
        .filter_map(|s| s.at(ROUNDNESS_FLOOR))
        .flat_map(|s| s.cameras.into_iter().flatten())
        .flat_map(|c| c.blobs.into_iter().map(|b| b.roundness))
        .collect()
}

/// The gates measured from [`GATE_SAMPLE_FRAMES`] frames spread over the recording
/// (`frames[i]` is frame `i`), as `track` and `doctor` measure them.
#[must_use]
pub fn gates_from_sample(
    rig: &Rig,
    tool: &Tool,
    frames: &[FrameInput],
    min_roundness: Gate,
    overrides: &GateOverrides,
) -> Gates {
    let sample = sample_frames(frames.len(), GATE_SAMPLE_FRAMES);
    let views: Vec<_> = sample.iter().map(|&f| frames[f].views.clone()).collect();
    let shapes: Vec<Shapes> = sample.iter().map(|&f| frames[f].shapes.clone()).collect();
    measure_gates(rig, tool, &views, &shapes, min_roundness, overrides)
}

/// The recording as `detect` saw it, from its detections file: one set per frame of the
/// recording, each rig camera's blobs of that frame (those below a given `min_roundness` left
/// out), times and rate from the recording's clock. Returns the roundness gate too: as given,
/// or the least round blob of the file.
///
/// # Errors
/// [`PipelineError::Detections`] for a camera the rig lacks or a frame beyond the recording.
pub fn recording_from_detections(
    detections: &Detections,
    clock: &RecordingClock,
    rig: &Rig,
    min_roundness: Option<f64>,
) -> Result<(DetectedRecording, Gate), PipelineError> {
    let names: Vec<&str> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
    if let Some(stranger) = detections.cameras.keys().find(|c| rig.id_of(c).is_none()) {
        return Err(PipelineError::Detections(format!(
            "camera {stranger} is not in the rig (its cameras: {})",
            names.join(", ")
        )));
    }
    let frames = clock.frames.unwrap_or_else(|| detections.frame_count());
    let beyond = detections
        .cameras
        .iter()
        .filter_map(|(camera, by_frame)| Some((camera, *by_frame.keys().next_back()?)))
        .find(|(_, last)| *last >= frames);
    if let Some((camera, frame)) = beyond {
        return Err(PipelineError::Detections(format!(
            "camera {camera} frame {frame} is beyond the recording ({frames} frames: 0 to {})",
            frames.saturating_sub(1)
        )));
    }
    let gate = match min_roundness {
        Some(_) => roundness_gate(&[], min_roundness),
        None => Gate {
            value: detections
                .cameras
                .values()
                .flat_map(|f| f.values().flatten())
                .map(|b| b.roundness)
                .fold(f64::INFINITY, f64::min)
                .min(1.0),
            reason: "as detected (the detections file's least round blob)".into(),
        },
    };
    let sets = (0..frames)
        .map(|frame| {
            let time_s = clock.time_s(frame, &names);
            let cameras = names
                .iter()
                .map(|camera| {
                    Some(crate::detect::CameraDetections {
                        camera: (*camera).to_string(),
                        frame,
                        time_s,
                        blobs: detections
                            .blobs(camera, frame)
                            .iter()
                            .filter(|b| b.roundness >= gate.value)
                            .cloned()
                            .collect(),
                    })
                })
                .collect();
            DetectedSet {
                index: frame,
                time_s,
                exposed_at: None,
                cameras,
            }
        })
        .collect();
    let recording = DetectedRecording {
        cameras: names.iter().map(|c| (*c).to_string()).collect(),
        fps: clock.fps,
        sets,
        len_hint: Some(frames),
    };
    Ok((recording, gate))
}

/// What a stream needs before its first frame: the gates and the σ model's typical values,
/// measured from frames of the footage, and the rig's cameras it has no frames of.
#[derive(Debug, Clone)]
pub struct Learned {
    /// Every tracking gate, the roundness gate among them.
    pub gates: Gates,
    /// The typical residuals the σ model scales every frame's `tip_std_mm` by.
    pub typical: Typical,
    /// The rig's cameras out of use (no frames, or seeing nothing of the volume).
    pub cameras_out: Vec<CameraOut>,
    /// Each camera's threshold and smallest blob ([`learn_camera_limits`]); empty when they
    /// were not learned (a camera's first frames: the configured limits).
    pub camera_limits: Vec<(String, CameraLimits)>,
}

impl Learned {
    /// Learned from frames already detected at the roundness gate: the other gates from
    /// [`gates_from_sample`], the typical residuals from those frames tracked with them.
    #[must_use]
    pub fn from_frames(
        rig: &Rig,
        tool: &Tool,
        frames: &[FrameInput],
        min_roundness: Gate,
        overrides: &GateOverrides,
        missing_cameras: &[String],
    ) -> Self {
        let gates = gates_from_sample(rig, tool, frames, min_roundness, overrides);
        let tracker = Tracker::new(rig, tool, gates.track_config());
        let sample = sample_frames(frames.len(), GATE_SAMPLE_FRAMES);
        let tracks: Vec<_> = sample
            .iter()
            .map(|&f| tracker.track_frame_with_shapes(&frames[f].views, &frames[f].shapes))
            .collect();
        let noise: Vec<Vec<f64>> = sample
            .iter()
            .map(|&f| frames[f].blob_noise_px.clone())
            .collect();
        let inputs: Vec<&FrameInput> = sample.iter().map(|&f| &frames[f]).collect();
        Self {
            cameras_out: cameras_out(rig, missing_cameras, &tracks, &inputs),
            gates,
            typical: Typical::of(&tracks, &noise),
            camera_limits: Vec::new(),
        }
    }

    /// `setups` with the learned threshold and smallest blob of their cameras.
    pub fn apply_limits(&self, setups: &mut [CameraSetup]) {
        for setup in setups {
            if let Some((_, limits)) = self.camera_limits.iter().find(|(n, _)| *n == setup.name) {
                limits.apply(&mut setup.detect);
            }
        }
    }
}

/// The gates of a recording folder learned as `track` measures them, reading only the frames
/// of its samples (every other frame is skipped undecoded where the source allows), for a
/// stream over that recording.
///
/// # Errors
/// As [`detect_for_tracking`].
pub fn learn_from_recording(
    root: &Path,
    rig: &Rig,
    tool: &Tool,
    options: &DetectOptions,
    overrides: &GateOverrides,
) -> Result<Learned, PipelineError> {
    options.check()?;
    let mut source = FolderSource::open(root, options.fps)?;
    let floor = overrides.min_roundness.unwrap_or(ROUNDNESS_FLOOR);
    let (mut setups, missing_cameras) = options.rig_setups(rig, tool, source.cameras(), floor)?;
    let len_hint = source.len_hint();
    let roundness_sample: BTreeSet<usize> = sampled_sets(len_hint, ROUNDNESS_SAMPLE_FRAMES)
        .into_iter()
        .collect();
    let gate_sample: BTreeSet<usize> = sampled_sets(len_hint, GATE_SAMPLE_FRAMES)
        .into_iter()
        .collect();
    let keep: BTreeSet<usize> = roundness_sample.union(&gate_sample).copied().collect();
    // The second sample's sets are kept as the first pass reads past them, so that a video
    // is not decoded once more for them (a pipe cannot skip frames).
    let mut kept = Keeping {
        inner: &mut source,
        keep: &keep,
        kept: VecDeque::new(),
        bytes: 0,
        over_budget: false,
    };
    let (camera_limits, _) = learn_camera_limits(&mut kept, &mut setups, false)?;
    let (kept, over_budget) = (kept.kept, kept.over_budget);
    let mut fresh;
    let mut replay;
    let second: &mut dyn FrameSource = if over_budget {
        fresh = FolderSource::open(root, options.fps)?;
        &mut fresh
    } else {
        replay = Replay {
            kept,
            rest: &mut source,
        };
        &mut replay
    };
    let mut sampled = Sampled {
        inner: second,
        keep,
    };
    let choices: DetectedRecording<RoundnessChoices> =
        detect_recording(&mut sampled, setups, &|| {})?;
    let min_roundness = match overrides.min_roundness {
        Some(_) => roundness_gate(&[], overrides.min_roundness),
        None => roundness_gate(&sample_roundness(&choices.sets, &roundness_sample), None),
    };
    let ids: Vec<Option<CameraId>> = choices.cameras.iter().map(|c| rig.id_of(c)).collect();
    // The frames of the gate sample at their indices, the rest empty: `gates_from_sample`
    // picks the same frames `track` does.
    let count = len_hint.unwrap_or(GATE_SAMPLE_FRAMES);
    let mut frames = vec![FrameInput::default(); count];
    for set in &choices.sets {
        if !gate_sample.contains(&set.index) || set.index >= count {
            continue;
        }
        // The gate is never below the floor the sample was detected with unless overridden,
        // and then the floor is the override.
        if let Some(at) = set.at(min_roundness.value.max(floor)) {
            frames[set.index] = frame_inputs(&ids, &at);
        }
    }
    let mut learned = Learned::from_frames(
        rig,
        tool,
        &frames,
        min_roundness,
        overrides,
        &missing_cameras,
    );
    learned.camera_limits = camera_limits;
    if let Some(chance) = &learned.gates.chance {
        return Err(super::batch::not_shown(&tool.name, chance));
    }
    Ok(learned)
}

/// Decoded pixels kept for the second pass at most, counted two bytes a sample whatever the
/// depth (beyond: the recording is read again).
const KEPT_BYTES: usize = 512 << 20;

/// A source that hands on every set and keeps a copy of those of `keep` (decoded pixels are
/// shared, not copied; PNG frames are kept as their paths and cost nothing) until
/// [`KEPT_BYTES`] would be passed.
#[derive(Debug)]
struct Keeping<'s, 'k> {
    inner: &'s mut dyn FrameSource,
    keep: &'k BTreeSet<usize>,
    kept: VecDeque<FrameSet>,
    bytes: usize,
    over_budget: bool,
}

impl FrameSource for Keeping<'_, '_> {
    fn cameras(&self) -> &[SourceCamera] {
        self.inner.cameras()
    }

    fn fps(&self) -> f64 {
        self.inner.fps()
    }

    fn len_hint(&self) -> Option<usize> {
        self.inner.len_hint()
    }

    fn is_live(&self) -> bool {
        false
    }

    fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>> {
        let set = self.inner.next_set()?;
        if let Ok(set) = &set
            && !self.over_budget
            && self.keep.contains(&set.index)
        {
            self.bytes += set
                .cameras
                .iter()
                .flatten()
                .map(|c| match &c.data {
                    FrameData::Decoded(frame) => {
                        let (width, height) = frame.dimensions();
                        width as usize * height as usize * 2
                    }
                    FrameData::Png(_) => 0,
                })
                .sum::<usize>();
            if self.bytes > KEPT_BYTES {
                self.over_budget = true;
                self.kept.clear();
            } else {
                self.kept.push_back(set.clone());
            }
        }
        Some(set)
    }

    fn stats(&self) -> SourceStats {
        self.inner.stats()
    }
}

/// The sets a [`Keeping`] kept, then the rest of the source it read them from: the same sets
/// as the source read afresh, filtered to the kept indices.
#[derive(Debug)]
struct Replay<'s> {
    kept: VecDeque<FrameSet>,
    rest: &'s mut dyn FrameSource,
}

impl FrameSource for Replay<'_> {
    fn cameras(&self) -> &[SourceCamera] {
        self.rest.cameras()
    }

    fn fps(&self) -> f64 {
        self.rest.fps()
    }

    fn len_hint(&self) -> Option<usize> {
        self.rest.len_hint()
    }

    fn is_live(&self) -> bool {
        false
    }

    fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>> {
        match self.kept.pop_front() {
            Some(set) => Some(Ok(set)),
            None => self.rest.next_set(),
        }
    }

    fn stats(&self) -> SourceStats {
        self.rest.stats()
    }
}

/// A source that hands on only the sets of `keep` (others are read past, not decoded).
#[derive(Debug)]
struct Sampled<'s> {
    inner: &'s mut dyn FrameSource,
    keep: BTreeSet<usize>,
}

impl FrameSource for Sampled<'_> {
    fn cameras(&self) -> &[SourceCamera] {
        self.inner.cameras()
    }

    fn fps(&self) -> f64 {
        self.inner.fps()
    }

    fn len_hint(&self) -> Option<usize> {
        self.inner.len_hint()
    }

    fn is_live(&self) -> bool {
        false
    }

    fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>> {
        let last = *self.keep.last()?;
        loop {
            match self.inner.next_set()? {
                Ok(set) if self.keep.contains(&set.index) => return Some(Ok(set)),
                Ok(set) if set.index >= last => return None,
                Ok(_) => {}
                Err(e) => return Some(Err(e)),
            }
        }
    }

    fn stats(&self) -> SourceStats {
        self.inner.stats()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Scenario, build_scene, write_scene};

    /// The same detections and limits whether the frames were sketched in one read or the
    /// recording read again for each pass (sketches over budget): the occluded scene, whose
    /// roundness gate and limits are learned, and with every limit given.
    #[test]
    fn a_recording_over_the_sketch_budget_is_read_again_to_the_same_detections() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let mut scene = build_scene(Scenario::Occluded, 5);
        scene.truth.samples.truncate(40);
        write_scene(&scene, dir.path(), 5, &|| {}).expect("the scene written");
        let tool = &scene.tool;
        let options = DetectOptions::default();
        let setups: Vec<CameraSetup> = scene
            .rig
            .cameras
            .iter()
            .map(|camera| CameraSetup {
                name: camera.name.clone(),
                detect: options.config(camera, tool, ROUNDNESS_FLOOR),
                size: None,
            })
            .collect();
        let fixed: Vec<CameraSetup> = setups
            .iter()
            .cloned()
            .map(|mut s| {
                s.detect.threshold = Threshold::Fixed(60);
                s
            })
            .collect();
        let all_given = LimitsGiven {
            min_area_px: true,
            min_roundness: Some(0.6),
        };
        for (setups, given) in [(setups, LimitsGiven::default()), (fixed, all_given)] {
            let run = |budget| {
                let source = FolderSource::open(dir.path(), None).expect("the recording opened");
                detect_learned_within(
                    source,
                    dir.path(),
                    None,
                    setups.clone(),
                    given,
                    budget,
                    &|| {},
                )
                .expect("the recording detected")
            };
            let (sketched, sketched_limits) = run(SKETCH_BYTES);
            let (reread, reread_limits) = run(0);
            assert_eq!(sketched.sets.len(), 40);
            assert!(
                sketched.sets.iter().any(|s| s
                    .cameras
                    .iter()
                    .flatten()
                    .any(|c| !c.blobs.is_empty()))
            );
            assert_eq!(sketched.sets, reread.sets);
            assert_eq!(sketched.cameras, reread.cameras);
            assert_eq!(sketched_limits, reread_limits);
        }
    }
}
