//! The conductor at camera rate: every set tracked as it comes under the batch's rules, with
//! the gates learned from the footage and a temporal guard that looks [`StreamOptions::lag_frames`]
//! frames ahead, so that a frame's status is final when it is emitted.
//!
//! ```text
//! FrameSource ─► DetectStream (every roundness floor from the lowest) ─► set at the gate
//!   ─► learning? (Learning::FirstFrames: default gates, `degraded`, until N frames are seen;
//!                 then Learned::from_frames, as track measures them)
//!   ─► Tracker (learned gates, merged blobs, mirror) ─► cameras out ─► σ (metrology::frame)
//!   ─► window of lag frames: labels from a neighbour's pose (the two frames before and after),
//!      the temporal guard (step gate from the steps so far, ghosts seen within the window)
//!   ─► TrackedFrame { sample, status, reason, evidence } (status final)
//! ```
//! A recording read as a stream learns its gates first from the same sample `track` measures
//! (`Learning::Given(learn_from_recording(..))`); a camera learns them from its first frames.
//! The exposure-to-pose latency is measured when the pose is computed; the lag adds
//! `lag_frames / fps` before a frame's status is final.

use std::collections::VecDeque;
use std::time::Instant;

use rayon::prelude::*;

use super::recording::{DetectOptions, Learned, learn_from_recording};
use super::rules::{CameraOut, FrameInput, frame_inputs, mark_cameras_out, sample_of};
use super::{DetectStream, DetectedSet, PipelineError};
use crate::camera::Rig;
use crate::correspond::Views;
use crate::detect::RoundnessChoices;
use crate::geometry::CameraId;
use crate::metrology::frame::Typical;
use crate::source::{FrameSource, SourceSpec, SourceStats};
use crate::tool::Tool;
use crate::track::gates::{GateOverrides, Gates, ROUNDNESS_FLOOR, roundness_gate};
use crate::track::temporal::{MIN_STEPS, TipFrame, ghosts, step_gate_of};
use crate::track::{Flag, FrameTrack, Lost, NEIGHBOUR_FRAMES, Tracker, neighbour_pose, tip_frame};
use crate::trajectory::{Sample, Status};

/// How a stream comes by its gates.
#[derive(Debug, Clone)]
pub enum Learning {
    /// Learned before the first frame (a recording's sample:
    /// [`super::recording::learn_from_recording`]).
    Given(Box<Learned>),
    /// From the stream's own first frames: until this many are seen, frames are tracked with
    /// the library's default gates and are at best `degraded`.
    FirstFrames(usize),
}

/// Options of a stream.
#[derive(Debug, Clone)]
pub struct StreamOptions {
    /// How markers are detected.
    pub detect: DetectOptions,
    /// Gates fixed by the user (learning measures the rest).
    pub gates: GateOverrides,
    /// Where the gates come from.
    pub learning: Learning,
    /// Frames the temporal guard looks ahead before a frame's status is final (0: it sees
    /// only the past, and flags nothing; the batch sees the whole recording).
    pub lag_frames: usize,
}

impl StreamOptions {
    /// For a live source at `fps`: gates learned from its first [`LEARN_SECONDS`] (at least
    /// 30 frames), no lag.
    #[must_use]
    pub fn live(fps: f64) -> Self {
        Self {
            detect: DetectOptions::default(),
            gates: GateOverrides::default(),
            learning: Learning::FirstFrames(learn_frames(fps)),
            lag_frames: 0,
        }
    }

    /// For a recording whose gates were learned from its sample: the guard looks
    /// [`RECORDING_LAG_FRAMES`] ahead.
    #[must_use]
    pub fn recording(learned: Learned) -> Self {
        Self {
            detect: DetectOptions::default(),
            gates: GateOverrides::default(),
            learning: Learning::Given(Box::new(learned)),
            lag_frames: RECORDING_LAG_FRAMES,
        }
    }
}

impl StreamOptions {
    /// The options every front end uses for `spec`: a recording folder's gates learned from
    /// its sample first ([`super::recording::learn_from_recording`], as `track` measures them)
    /// with the guard's look-ahead; a camera or the simulator at `fps` learning from its first
    /// frames, no lag.
    ///
    /// # Errors
    /// As [`super::recording::learn_from_recording`].
    pub fn for_source(
        spec: &SourceSpec,
        fps: f64,
        rig: &Rig,
        tool: &Tool,
        detect: DetectOptions,
        gates: GateOverrides,
    ) -> Result<Self, PipelineError> {
        Ok(match spec {
            SourceSpec::Folder(root) => Self {
                learning: Learning::Given(Box::new(learn_from_recording(
                    root, rig, tool, &detect, &gates,
                )?)),
                detect,
                gates,
                lag_frames: RECORDING_LAG_FRAMES,
            },
            SourceSpec::Sim(_) | SourceSpec::V4l2(_) => Self {
                detect,
                gates,
                learning: Learning::FirstFrames(learn_frames(fps)),
                lag_frames: 0,
            },
        })
    }
}

/// Seconds of a live source its gates are learned from.
pub const LEARN_SECONDS: f64 = 2.0;

/// Frames of `fps` in [`LEARN_SECONDS`], at least 30 (the gates need a few hundred markers).
#[must_use]
pub fn learn_frames(fps: f64) -> usize {
    let frames = if fps.is_finite() && fps > 0.0 {
        (LEARN_SECONDS * fps).ceil() as usize
    } else {
        0
    };
    frames.max(30)
}

/// The temporal guard's look-ahead for recordings: a ghost of up to 7 frames has a longer
/// segment after it within 15 frames.
pub const RECORDING_LAG_FRAMES: usize = 15;

/// Tip steps the stream's step gate is measured from at most (the latest ones).
const MAX_STEPS: usize = 5000;

/// One tracked instant with its evidence; its status is final.
#[derive(Debug, Clone)]
pub struct TrackedFrame {
    /// The blobs of every rig camera the source has (in rig order), at the roundness gate,
    /// with their frames' times.
    pub detections: DetectedSet,
    /// The pose or why there is none, with the triangulated points, labels and flags.
    pub track: FrameTrack,
    /// The trajectory sample: pose, `tip_std_mm` and status.
    pub sample: Sample,
    /// RMS of the frame's blobs' predicted centre noise, pixels (image noise only).
    pub blob_noise_px: f64,
    /// The tip uncertainty (RMS over the axes), millimetres; `None` without a pose.
    pub tip_std_mm: Option<f64>,
    /// When the pose was computed.
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

    /// The frame's status (final).
    #[must_use]
    pub fn status(&self) -> Status {
        self.sample.status
    }

    /// Why the status, `; `-separated (empty for `ok`).
    #[must_use]
    pub fn reason(&self) -> String {
        self.track.reason()
    }
}

/// A frame in the window: tracked, not yet emitted (or kept as history once emitted).
#[derive(Debug, Clone)]
struct Held {
    detections: DetectedSet,
    input: FrameInput,
    track: FrameTrack,
    tip_std_mm: Option<f64>,
    tracked_at: Instant,
    /// The frame as the temporal guard saw it when emitted (before its own flag).
    guard_tip: Option<TipFrame>,
}

/// The rules once learned.
#[derive(Debug)]
struct Rules<'a> {
    tracker: Tracker<'a>,
    gates: Gates,
    typical: Typical,
    out: Vec<CameraOut>,
}

/// Tracking over a source's frames, set by set, every status final when emitted.
#[derive(Debug)]
pub struct TrackStream<'a> {
    detect: DetectStream<'a, RoundnessChoices>,
    rig: &'a Rig,
    tool: &'a Tool,
    options: StreamOptions,
    /// Rig id of each detected camera, in the stream's order.
    ids: Vec<Option<CameraId>>,
    missing: Vec<String>,
    /// The default gates' tracker while learning.
    provisional: Tracker<'a>,
    rules: Option<Rules<'a>>,
    /// Frames seen while learning: the set at the lowest floor, and its track.
    learning: Vec<DetectedSet<RoundnessChoices>>,
    /// Emitted frames kept for the guard's and the neighbours' look back.
    history: VecDeque<Held>,
    /// Frames tracked, not yet emitted (at most `lag_frames`, then one more).
    window: VecDeque<Held>,
    /// Tip steps between consecutive `ok` frames so far, and their `tip_std_mm`.
    steps: VecDeque<f64>,
    step_stds: VecDeque<f64>,
    last_tip: Option<(usize, TipFrame)>,
    ready: VecDeque<TrackedFrame>,
    ended: bool,
}

impl<'a> TrackStream<'a> {
    /// Tracks `tool` through the frames of `source` seen by `rig`'s cameras (matched by name;
    /// rig cameras the source lacks are out of use, named in every frame's reason; extra
    /// source cameras are ignored).
    ///
    /// # Errors
    /// [`PipelineError::TooFewCameras`] when the source has fewer than two rig cameras; near
    /// not below far.
    pub fn new(
        source: &'a mut dyn FrameSource,
        rig: &'a Rig,
        tool: &'a Tool,
        options: StreamOptions,
    ) -> Result<Self, PipelineError> {
        options.detect.check()?;
        let floor = match &options.learning {
            Learning::Given(learned) => learned.gates.min_roundness.value,
            Learning::FirstFrames(_) => options.gates.min_roundness.unwrap_or(ROUNDNESS_FLOOR),
        };
        let (mut setups, missing) =
            options
                .detect
                .rig_setups(rig, tool, source.cameras(), floor)?;
        if let Learning::Given(learned) = &options.learning {
            learned.apply_limits(&mut setups);
        }
        let ids = setups.iter().map(|s| rig.id_of(&s.name)).collect();
        let detect = DetectStream::detecting(source, setups)?;
        let mut stream = Self {
            detect,
            rig,
            tool,
            ids,
            missing,
            provisional: Tracker::new(rig, tool, Gates::defaults().track_config()),
            rules: None,
            learning: Vec::new(),
            history: VecDeque::new(),
            window: VecDeque::new(),
            steps: VecDeque::new(),
            step_stds: VecDeque::new(),
            last_tip: None,
            ready: VecDeque::new(),
            ended: false,
            options,
        };
        if let Learning::Given(learned) = &stream.options.learning {
            let learned = (**learned).clone();
            stream.rules = Some(stream.rules_from(learned));
        }
        Ok(stream)
    }

    fn rules_from(&self, learned: Learned) -> Rules<'a> {
        let mut out = learned.cameras_out;
        for camera in &self.missing {
            if !out.iter().any(|o| &o.camera == camera) {
                out.push(CameraOut {
                    camera: camera.clone(),
                    why: super::rules::OutReason::NoFrames,
                });
            }
        }
        Rules {
            tracker: Tracker::new(self.rig, self.tool, learned.gates.track_config()),
            gates: learned.gates,
            typical: learned.typical,
            out,
        }
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

    /// The gates in use, once learned.
    #[must_use]
    pub fn gates(&self) -> Option<&Gates> {
        self.rules.as_ref().map(|r| &r.gates)
    }

    /// The rig cameras out of use, once learned.
    #[must_use]
    pub fn cameras_out(&self) -> &[CameraOut] {
        self.rules.as_ref().map_or(&[], |r| r.out.as_slice())
    }

    /// The rig's view of a set: each camera's blob centres, keyed by rig id.
    #[must_use]
    pub fn views(&self, set: &DetectedSet) -> Views {
        frame_inputs(&self.ids, set).views
    }

    /// The roundness floor sets are taken at now.
    fn roundness(&self) -> f64 {
        match &self.rules {
            Some(rules) => rules.gates.min_roundness.value,
            None => self.options.gates.min_roundness.unwrap_or(ROUNDNESS_FLOOR),
        }
    }

    /// Tracks a batch of sets (in parallel once the gates are learned) and puts them through
    /// the window.
    fn take(&mut self, sets: Vec<DetectedSet<RoundnessChoices>>) {
        let mut sets = sets.into_iter();
        while self.rules.is_none() {
            let Some(set) = sets.next() else { return };
            self.learn_from(set);
        }
        let sets: Vec<DetectedSet<RoundnessChoices>> = sets.collect();
        let roundness = self.roundness();
        let Some(rules) = &self.rules else { return };
        let (rig, tool, ids) = (self.rig, self.tool, &self.ids);
        let tracked: Vec<Held> = sets
            .par_iter()
            .filter_map(|set| {
                let at = set.at(roundness)?;
                let input = frame_inputs(ids, &at);
                let mut track = rules
                    .tracker
                    .track_frame_with_shapes(&input.views, &input.shapes);
                mark_cameras_out(&mut track, &rules.out);
                let tip_std_mm = rules
                    .typical
                    .tip_std_mm(rig, tool, &track, &input.blob_noise_px);
                Some(Held {
                    detections: at,
                    input,
                    track,
                    tip_std_mm,
                    tracked_at: Instant::now(),
                    guard_tip: None,
                })
            })
            .collect();
        for held in tracked {
            self.enter(held);
        }
    }

    /// A set seen while the gates are being learned: tracked with the default gates and
    /// flagged; the gates learned once enough sets are seen.
    fn learn_from(&mut self, set: DetectedSet<RoundnessChoices>) {
        let needed = match &self.options.learning {
            Learning::FirstFrames(n) => *n,
            Learning::Given(_) => 0,
        };
        let floor = self.roundness();
        let Some(at) = set.at(floor) else { return };
        let input = frame_inputs(&self.ids, &at);
        let mut track = self
            .provisional
            .track_frame_with_shapes(&input.views, &input.shapes);
        self.learning.push(set);
        if track.outcome.is_ok() {
            track.flags.push(Flag::GatesNotLearned {
                seen: self.learning.len(),
                needed,
            });
            track
                .flags
                .extend(self.missing.iter().map(|camera| Flag::CameraOut {
                    camera: camera.clone(),
                    why: super::rules::OutReason::NoFrames,
                }));
        }
        let tip_std_mm =
            Typical::default().tip_std_mm(self.rig, self.tool, &track, &input.blob_noise_px);
        self.enter(Held {
            detections: at,
            input,
            track,
            tip_std_mm,
            tracked_at: Instant::now(),
            guard_tip: None,
        });
        if self.learning.len() >= needed {
            let sets = std::mem::take(&mut self.learning);
            let roundness: Vec<f64> = sets
                .iter()
                .filter_map(|s| s.at(floor))
                .flat_map(|s| s.cameras.into_iter().flatten())
                .flat_map(|c| c.blobs.into_iter().map(|b| b.roundness))
                .collect();
            let gate = roundness_gate(&roundness, self.options.gates.min_roundness);
            let at = gate.value.max(floor);
            let frames: Vec<FrameInput> = sets
                .iter()
                .filter_map(|s| s.at(at))
                .map(|s| frame_inputs(&self.ids, &s))
                .collect();
            let learned = Learned::from_frames(
                self.rig,
                self.tool,
                &frames,
                gate,
                &self.options.gates,
                &self.missing,
            );
            self.rules = Some(self.rules_from(learned));
        }
    }

    /// Labels `held` (too few markers fitted the tool's distances) from `neighbour`'s pose.
    fn relabel(&self, held: &mut Held, neighbour: &FrameTrack, neighbour_index: usize) -> bool {
        let (Some(pose), Some(rules)) = (neighbour_pose(neighbour), &self.rules) else {
            return false;
        };
        let Some(mut track) = rules.tracker.track_from_neighbour(
            &held.input.views,
            &held.input.shapes,
            &pose,
            neighbour_index,
        ) else {
            return false;
        };
        mark_cameras_out(&mut track, &rules.out);
        held.tip_std_mm =
            rules
                .typical
                .tip_std_mm(self.rig, self.tool, &track, &held.input.blob_noise_px);
        held.track = track;
        true
    }

    /// A tracked frame into the window: labelled from the frames before it where too few
    /// markers fitted, lending its pose to those just before it, then the frames beyond the
    /// lag emitted.
    fn enter(&mut self, mut held: Held) {
        let index = held.detections.index;
        let near = |i: usize, j: usize| i.abs_diff(j) <= NEIGHBOUR_FRAMES;
        if too_few_markers(&held.track) {
            // Forward: the nearest frame before it that lends a pose.
            let before: Vec<(usize, FrameTrack)> = self
                .window
                .iter()
                .rev()
                .chain(self.history.iter().rev())
                .take_while(|h| near(h.detections.index, index))
                .map(|h| (h.detections.index, h.track.clone()))
                .collect();
            for (j, neighbour) in &before {
                if self.relabel(&mut held, neighbour, *j) {
                    break;
                }
            }
        }
        // Backward: frames of the window before it, nearest first, each from the nearest
        // frame after it (this one, or one labelled so just now: a run is labelled one from
        // the next, as the batch's backward pass does, as far back as the window reaches).
        self.window.push_back(held);
        let n = self.window.len();
        for k in (0..n.saturating_sub(1)).rev() {
            let k_index = self.window[k].detections.index;
            if !too_few_markers(&self.window[k].track) {
                continue;
            }
            for a in k + 1..n {
                let a_index = self.window[a].detections.index;
                if !near(a_index, k_index) {
                    break;
                }
                let neighbour = self.window[a].track.clone();
                let mut candidate = self.window[k].clone();
                if self.relabel(&mut candidate, &neighbour, a_index) {
                    self.window[k] = candidate;
                    break;
                }
            }
        }
        while self.window.len() > self.options.lag_frames {
            self.emit_oldest();
        }
    }

    /// The oldest frame of the window through the temporal guard and out.
    fn emit_oldest(&mut self) {
        let Some(mut held) = self.window.pop_front() else {
            return;
        };
        let index = held.detections.index;
        let tip = tip_frame(&held.track, held.tip_std_mm);
        held.guard_tip = Some(tip);
        if let Some((last, previous)) = self.last_tip
            && last + 1 == index
            && previous.confident
            && tip.confident
            && let (Some(a), Some(b)) = (previous.tip_in_world, tip.tip_in_world)
        {
            self.steps.push_back((b - a).norm());
            self.step_stds.extend(tip.tip_std_mm);
            while self.steps.len() > MAX_STEPS {
                self.steps.pop_front();
            }
            while self.step_stds.len() > MAX_STEPS {
                self.step_stds.pop_front();
            }
        }
        self.last_tip = Some((index, tip));
        if self.rules.is_some() && self.steps.len() >= MIN_STEPS {
            let steps: Vec<f64> = self.steps.iter().copied().collect();
            let stds: Vec<f64> = self.step_stds.iter().copied().collect();
            if let Some(gate) = step_gate_of(&steps, &stds) {
                // The guard's context: the frames behind (as they were before the guard), this
                // one, the window ahead; frame positions are recording indices apart.
                let mut frames: Vec<TipFrame> = Vec::new();
                let first = self.history.front().map_or(index, |h| h.detections.index);
                let context = self
                    .history
                    .iter()
                    .map(|h| {
                        (
                            h.detections.index,
                            h.guard_tip.unwrap_or(TipFrame::absent()),
                        )
                    })
                    .chain(std::iter::once((index, tip)))
                    .chain(
                        self.window
                            .iter()
                            .map(|h| (h.detections.index, tip_frame(&h.track, h.tip_std_mm))),
                    );
                for (i, frame) in context {
                    let at = i - first;
                    if frames.len() <= at {
                        frames.resize(at + 1, TipFrame::absent());
                    }
                    frames[at] = frame;
                }
                if let Some(&(_, deviation_mm)) = ghosts(&frames, gate.value)
                    .iter()
                    .find(|(i, _)| *i == index - first)
                {
                    held.track.flags.push(Flag::TemporalJump {
                        deviation_mm,
                        gate_mm: gate.value,
                    });
                }
            }
        }
        let sample = sample_of(
            index,
            held.detections.time_s,
            &held.track,
            held.tip_std_mm,
            false,
        );
        let frame = TrackedFrame {
            detections: held.detections.clone(),
            track: held.track.clone(),
            sample,
            blob_noise_px: crate::stats::rms(&held.input.blob_noise_px),
            tip_std_mm: held.tip_std_mm,
            tracked_at: held.tracked_at,
        };
        self.ready.push_back(frame);
        self.history.push_back(held);
        let keep = (4 * self.options.lag_frames)
            .max(2 * NEIGHBOUR_FRAMES)
            .max(30);
        while self.history.len() > keep {
            self.history.pop_front();
        }
    }
}

/// Whether a frame was lost because too few markers fitted the tool's distances (what a
/// neighbour's pose may label).
fn too_few_markers(track: &FrameTrack) -> bool {
    matches!(track.outcome, Err(Lost::TooFewMarkers { .. }))
}

impl Iterator for TrackStream<'_> {
    type Item = Result<TrackedFrame, PipelineError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(frame) = self.ready.pop_front() {
                return Some(Ok(frame));
            }
            if self.ended {
                return None;
            }
            match self.detect.next() {
                None => {
                    self.ended = true;
                    while !self.window.is_empty() {
                        self.emit_oldest();
                    }
                }
                Some(Err(e)) => {
                    self.ended = true;
                    return Some(Err(e));
                }
                Some(Ok(set)) => {
                    // Take what detection has ready (a whole batch for files, one set live).
                    let mut sets = vec![set];
                    sets.extend(self.detect.take_ready());
                    self.take(sets);
                }
            }
        }
    }
}
