//! The batch run of the conductor: a whole recording to a trajectory, with every frame of it
//! seen before any status is final (what `track`, `demo` and `doctor` run).
//!
//! ```text
//! TrackInput (a recording folder, or a detections file and the recording's clock)
//!   └─► detected at the roundness gate (pipeline::recording)
//!        └─► (time offsets: blobs moved to common frame times, sync)
//!             └─► gates from the sample ─► Tracker over every frame ─► labels from neighbours
//!                  └─► cameras out ─► σ (metrology::frame) ─► temporal guard ─► samples
//! ```
//! A tool that no frame fits within the measured gates (no pose, or only outliers) is
//! [`PipelineError::ToolNotFound`]: nothing to write.

use std::path::{Path, PathBuf};

use super::PipelineError;
use super::recording::{
    DetectLimits, DetectOptions, detect_for_tracking, gates_from_sample, recording_from_detections,
};
use super::rules::{CameraOut, FrameInput, cameras_out, mark_cameras_out, sample_of};
use crate::camera::Rig;
use crate::correspond::Views;
use crate::identify::{IdentifyConfig, check_identifiable};
use crate::io::detections::Detections;
use crate::io::tracking::{diagnostics_csv, markers_csv};
use crate::io::trajectory::trajectory_text;
use crate::io::{FileError, OutputSet};
use crate::metrology::frame::tip_std_mm;
use crate::source::folder::RecordingClock;
use crate::sync::{
    ResampleIssue, SyncConfig, SyncEstimate, TimeOffsets, estimate_offsets, resample_views,
    time_offsets_json,
};
use crate::tool::Tool;
use crate::track::gates::{Gate, GateOverrides, Gates};
use crate::track::merged::Shapes;
use crate::track::{FrameTrack, Tracker, guard_in_time};
use crate::trajectory::{Status, Trajectory};

/// Where the blobs come from.
#[derive(Debug, Clone, Copy)]
pub enum TrackInput<'a> {
    /// A recording folder, detected here.
    Recording(&'a Path),
    /// Blobs detected once (`detect`'s CSV), with the recording's clock (rate, frame count,
    /// frame times); tracked as detected.
    Detections {
        /// The blobs.
        detections: &'a Detections,
        /// The recording's clock.
        clock: &'a RecordingClock,
    },
}

/// How unsynchronised cameras are brought to common frame times.
#[derive(Debug, Clone, PartialEq)]
pub enum TimeOffsetsChoice {
    /// Estimated from the blobs.
    Auto,
    /// As given, seconds per camera.
    Given(TimeOffsets),
}

/// The batch run's options.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrackOptions {
    /// How markers are detected (a recording input only).
    pub detect: DetectOptions,
    /// Gates fixed by the user; the rest are measured.
    pub gates: GateOverrides,
    /// Unsynchronised cameras (`None`: the cameras are synchronised).
    pub time_offsets: Option<TimeOffsetsChoice>,
}

/// The blobs moved to common frame times, with what happened.
#[derive(Debug, Clone)]
pub struct Synchronised {
    /// Per frame, what could not be moved (the frame's status becomes `degraded`).
    pub issues: Vec<Vec<ResampleIssue>>,
    /// The offsets applied, seconds.
    pub offsets: TimeOffsets,
    /// The estimate, when [`TimeOffsetsChoice::Auto`].
    pub estimate: Option<SyncEstimate>,
}

/// A recording tracked.
#[derive(Debug, Clone)]
pub struct TrackRun {
    /// One sample per frame, with status and `tip_std_mm`.
    pub trajectory: Trajectory,
    /// Every frame's tracking evidence (points, labels, flags).
    pub tracks: Vec<FrameTrack>,
    /// The gates, measured or given.
    pub gates: Gates,
    /// The temporal guard's step gate; `None` when too few steps were measured.
    pub step_gate: Option<Gate>,
    /// The time offsets, when the cameras were not synchronised.
    pub synchronised: Option<Synchronised>,
    /// Rig cameras out of use (no frames, or seeing nothing of the volume).
    pub cameras_out: Vec<CameraOut>,
    /// The recording's rate, frames per second.
    pub fps: f64,
    /// The limits the frames were detected with; `None` for a detections file.
    pub detect_limits: Option<DetectLimits>,
}

/// Where a run's files go: the trajectory, and optionally the markers, the diagnostics, the
/// gates and the time offsets (CONTRACT.md: `track`'s outputs).
#[derive(Debug, Clone, Copy)]
pub struct TrackFiles<'a> {
    /// The trajectory CSV.
    pub trajectory: &'a Path,
    /// `--markers-out`.
    pub markers: Option<&'a Path>,
    /// `--diagnostics`.
    pub diagnostics: Option<&'a Path>,
    /// The gates JSON (`<diagnostics stem>.gates.json`).
    pub gates: Option<&'a Path>,
    /// `--time-offsets-out` (written when the cameras were synchronised).
    pub time_offsets: Option<&'a Path>,
}

impl TrackRun {
    /// Writes the run's files, all or none (every number checked finite first); returns the
    /// files written.
    ///
    /// # Errors
    /// [`FileError`] naming the file that cannot be written or whose values are not finite.
    pub fn write(&self, rig: &Rig, files: &TrackFiles<'_>) -> Result<Vec<PathBuf>, FileError> {
        let outputs = OutputSet::new();
        outputs.add(
            files.trajectory,
            trajectory_text(files.trajectory, &self.trajectory)?.as_bytes(),
        )?;
        if let Some(path) = files.markers {
            outputs.add(path, markers_csv(&self.tracks).as_bytes())?;
        }
        if let Some(path) = files.diagnostics {
            let issues = self.synchronised.as_ref().map(|s| s.issues.as_slice());
            outputs.add(path, diagnostics_csv(&self.tracks, issues).as_bytes())?;
        }
        if let (Some(path), Some(synchronised)) = (files.time_offsets, &self.synchronised) {
            let json = time_offsets_json(rig, &synchronised.offsets)
                .ok_or_else(|| FileError::invalid(path, "a time offset is not finite"))?;
            outputs.add(path, json.as_bytes())?;
        }
        if let Some(path) = files.gates {
            let json = serde_json::to_string_pretty(&self.gates)
                .map_err(|e| FileError::invalid(path, e.to_string()))?;
            outputs.add(path, json.as_bytes())?;
        }
        outputs.commit()
    }
}

/// Tracks `tool` through every frame of `input` seen by `rig`'s cameras; `progress` is called
/// after each frame detected.
///
/// # Errors
/// [`PipelineError`]: the recording unreadable, too few rig cameras in it, a detections file
/// that does not fit, offsets that cannot be estimated, a tool that cannot be told apart at
/// the gates, or a tool that fits no frame ([`PipelineError::ToolNotFound`]).
pub fn track(
    input: TrackInput<'_>,
    rig: &Rig,
    tool: &Tool,
    options: &TrackOptions,
    progress: &dyn Fn(),
) -> Result<TrackRun, PipelineError> {
    let overrides = &options.gates;
    if let Some(tolerance) = overrides.distance_tolerance_mm {
        check_identifiable(
            tool,
            &IdentifyConfig {
                distance_tolerance_mm: tolerance,
            },
        )?;
    }
    let (recording, min_roundness, missing, detect_limits) = match input {
        TrackInput::Recording(root) => {
            let detected = detect_for_tracking(
                root,
                rig,
                tool,
                &options.detect,
                overrides.min_roundness,
                progress,
            )?;
            (
                detected.recording,
                detected.min_roundness,
                detected.missing_cameras,
                Some(detected.limits),
            )
        }
        TrackInput::Detections { detections, clock } => {
            let (recording, gate) =
                recording_from_detections(detections, clock, rig, overrides.min_roundness)?;
            (recording, gate, Vec::new(), None)
        }
    };
    let detected = recording.inputs(rig);
    let mut frames = detected.clone();
    let synchronised = match &options.time_offsets {
        Some(choice) => {
            let views: Vec<Views> = frames.iter().map(|f| f.views.clone()).collect();
            let (resampled, synchronised) = synchronise(choice, rig, &views, recording.fps)?;
            // Resampled blobs no longer sit where their shapes were measured.
            for (frame, views) in frames.iter_mut().zip(resampled) {
                frame.views = views;
                frame.shapes = Shapes::new();
            }
            Some(synchronised)
        }
        None => None,
    };
    let gates = gates_from_sample(rig, tool, &frames, min_roundness, overrides);
    if let Some(chance) = &gates.chance {
        return Err(not_shown(&tool.name, chance));
    }
    let config = gates.track_config();
    check_identifiable(tool, &config.identify)?;

    let tracker = Tracker::new(rig, tool, config);
    let views: Vec<Views> = frames.iter().map(|f| f.views.clone()).collect();
    let shapes: Vec<Shapes> = frames.iter().map(|f| f.shapes.clone()).collect();
    let mut tracks = tracker.track_recording(&views, &shapes);
    let inputs: Vec<&FrameInput> = detected.iter().collect();
    let out = cameras_out(rig, &missing, &tracks, &inputs);
    for track in &mut tracks {
        mark_cameras_out(track, &out);
    }
    let noise: Vec<Vec<f64>> = detected.iter().map(|f| f.blob_noise_px.clone()).collect();
    let stds = tip_std_mm(rig, tool, &tracks, &noise);
    let step_gate = guard_in_time(&mut tracks, &stds);
    let samples = recording
        .sets
        .iter()
        .zip(&tracks)
        .zip(&stds)
        .enumerate()
        .map(|(i, ((set, track), std))| {
            let resampled = synchronised
                .as_ref()
                .is_some_and(|s| s.issues.get(i).is_some_and(|issues| !issues.is_empty()));
            sample_of(i, set.time_s, track, *std, resampled)
        })
        .collect();
    let trajectory = Trajectory { samples };
    if !trajectory
        .samples
        .iter()
        .any(|s| matches!(s.status, Status::Ok | Status::Degraded))
    {
        return Err(PipelineError::ToolNotFound(not_found_message(
            &tool.name, &tracks, &gates,
        )));
    }
    Ok(TrackRun {
        trajectory,
        tracks,
        gates,
        step_gate,
        synchronised,
        cameras_out: out,
        fps: recording.fps,
        detect_limits,
    })
}

/// Resolves the time offsets (estimating with `Auto`) and moves every camera's blobs to the
/// common frame times.
fn synchronise(
    choice: &TimeOffsetsChoice,
    rig: &Rig,
    frames: &[Views],
    fps: f64,
) -> Result<(Vec<Views>, Synchronised), PipelineError> {
    let config = SyncConfig::default();
    let period_s = 1.0 / fps;
    let (offsets, estimate) = match choice {
        TimeOffsetsChoice::Auto => {
            let estimate = estimate_offsets(rig, frames, period_s, &config)?;
            (estimate.time_offsets(), Some(estimate))
        }
        TimeOffsetsChoice::Given(offsets) => (offsets.clone(), None),
    };
    let resampled = resample_views(frames, &offsets, period_s, &config);
    Ok((
        resampled.frames,
        Synchronised {
            issues: resampled.issues,
            offsets,
            estimate,
        },
    ))
}

/// "tool not found" for gates whose sample shows chance alignments, not the tool
/// ([`Gates::chance`]): both conductors refuse such a recording.
#[must_use]
pub fn not_shown(tool: &str, chance: &str) -> PipelineError {
    PipelineError::ToolNotFound(format!(
        "tool '{tool}' not found: {chance}; is it the right tool file? see `teachcam doctor`"
    ))
}

/// "tool 'x' not found in any of N frames", with the most common reasons; or, where frames
/// were posed but every one beyond the gates, how far beyond.
#[must_use]
pub fn not_found_message(tool: &str, tracks: &[FrameTrack], gates: &Gates) -> String {
    let outliers: Vec<f64> = tracks
        .iter()
        .filter_map(|t| t.outcome.as_ref().ok().map(|p| p.rms_mm))
        .collect();
    if !outliers.is_empty() {
        return format!(
            "tool '{tool}' fits none of {} frames within the measured gates: {} posed, every one an outlier (median registration residual {:.2} mm against the {:.3} mm gate); is it the right tool file (a mirror image of the markers' layout, another tool)? see `teachcam doctor`",
            tracks.len(),
            outliers.len(),
            crate::stats::median(&outliers).unwrap_or(f64::NAN),
            gates.max_registration_rms_mm.value,
        );
    }
    let mut reasons: std::collections::BTreeMap<String, usize> = std::collections::BTreeMap::new();
    for t in tracks {
        *reasons.entry(t.reason()).or_default() += 1;
    }
    let mut common: Vec<(String, usize)> = reasons.into_iter().collect();
    common.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let listed: Vec<String> = common
        .iter()
        .take(3)
        .map(|(reason, n)| format!("{n} x {reason}"))
        .collect();
    format!(
        "tool '{tool}' not found in any of {} frames ({}); is it the right tool file? see `teachcam doctor`",
        tracks.len(),
        listed.join("; ")
    )
}
