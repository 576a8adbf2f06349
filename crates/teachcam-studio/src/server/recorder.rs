//! Record / stop: the frame sets the pipeline tracks, written as a recording folder that every
//! command reads (`cam0/000000.png ...`, `timestamps.csv`, `recording.json`, and the rig and
//! tool tracked with), with the take the studio tracked meanwhile as a ROS 2 bag
//! (`take.mcap`, by the library's [`tracked_take`] and [`mcap_bytes`], as `export mcap`
//! writes one), all or nothing.
//!
//! The library's [`RecordingWriter`] (the one `teachcam record` uses) stages the folder beside
//! its target and puts it in place on stop; a failed write or a studio that dies leaves nothing. Frames go to a writer thread through a
//! short queue; when the disk is behind, sets are dropped and counted (as `teachcam record`
//! does), never queued without bound: the cameras do not wait.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
use std::thread::JoinHandle;

use teachcam::camera::Rig;
use teachcam::geometry::FrameIndex;
use teachcam::io::recording::GrayFrame;
use teachcam::io::recording_writer::RecordingWriter;
use teachcam::io::rig::write_rig;
use teachcam::io::tool::write_tool;
use teachcam::io::{FileError, write_atomically};
use teachcam::ros2::bag::mcap_bytes;
use teachcam::ros2::take::{Frames as RosFrames, tracked_take};
use teachcam::source::FrameSet;
use teachcam::tool::Tool;
use teachcam::trajectory::Sample;

use super::state::gaps_between;

/// The status reason of a frame the source dropped (the pipeline was behind).
const DROPPED: &str = "the source dropped this frame: tracking was behind";

/// The take's ROS 2 bag, inside the recording folder.
pub const MCAP_FILE: &str = "take.mcap";

/// Sets waiting for the writer before new ones are dropped (a quarter second at 30 Hz).
const QUEUE_SETS: usize = 8;

/// One set's frames, in camera order, with their exposure times.
type Frames = Vec<(Arc<GrayFrame>, f64)>;

/// A recording in progress.
#[derive(Debug)]
pub struct Recorder {
    target: PathBuf,
    sender: Option<SyncSender<Frames>>,
    writer: Option<JoinHandle<Result<RecordingWriter, FileError>>>,
    cameras: usize,
    fps: f64,
    rig: Rig,
    tool: Tool,
    /// The frames the conductor tracked while recording, with their status reasons, on one
    /// time line (see [`Recorder::track`]).
    tracked: Vec<(Sample, String)>,
    /// The last tracked frame's index and time as the stream gave them.
    last_tracked: Option<(usize, f64)>,
    /// What is added to a tracked frame's index and time (non-zero after a recording played
    /// started again).
    offset: (usize, f64),
    /// Sets handed to the writer.
    pub queued: usize,
    /// Sets dropped: the writer was behind, or a camera had no frame.
    pub dropped: usize,
}

/// A recording written.
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    /// The folder.
    pub folder: PathBuf,
    /// Frames per camera.
    pub frames: usize,
    /// The take's bag.
    pub mcap: PathBuf,
    /// Its `/teachcam/tool` messages: the tracked frames with a pose.
    pub tool_messages: usize,
    /// Sets dropped.
    pub dropped: usize,
    /// One line for the terminal.
    pub summary: String,
}

/// The first `take-NNN` that does not exist in `out`.
#[must_use]
pub fn next_take(out: &Path) -> PathBuf {
    (1..)
        .map(|n| out.join(format!("take-{n:03}")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| out.join("take"))
}

impl Recorder {
    /// Starts a recording into `target` of the rig's cameras at `fps`.
    ///
    /// # Errors
    /// [`FileError::Write`] when the staging folder cannot be made.
    pub fn start(target: &Path, rig: &Rig, tool: &Tool, fps: f64) -> Result<Self, FileError> {
        let names: Vec<String> = rig.iter().map(|(_, c)| c.name.clone()).collect();
        let recording = RecordingWriter::create(target, &names)?;
        write_rig(&recording.staging().join("rig.json"), rig)?;
        write_tool(&recording.staging().join("tool.json"), tool)?;
        let (sender, frames) = sync_channel(QUEUE_SETS);
        let cameras = names.len();
        let writer = std::thread::Builder::new()
            .name("studio-recorder".into())
            .spawn(move || write(recording, &frames))
            .map_err(|source| FileError::Write {
                path: target.to_path_buf(),
                source,
            })?;
        Ok(Self {
            target: target.to_path_buf(),
            sender: Some(sender),
            writer: Some(writer),
            cameras,
            fps,
            rig: rig.clone(),
            tool: tool.clone(),
            tracked: Vec::new(),
            last_tracked: None,
            offset: (0, 0.0),
            queued: 0,
            dropped: 0,
        })
    }

    /// Where the recording goes.
    #[must_use]
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Keeps a frame the conductor tracked (every one, also when its set is dropped), after
    /// explicit gaps for the frames the source dropped before it (as the studio's take has
    /// them). A recording played that starts again (its frames count from 0 anew) continues
    /// the take's time line one frame period after its last frame, as its sets continue the
    /// folder.
    pub fn track(&mut self, mut sample: Sample, reason: String) {
        if let (Some((last_frame, _)), Some((previous, _))) =
            (self.last_tracked, self.tracked.last())
            && sample.frame.0 <= last_frame
        {
            self.offset = (
                previous.frame.0 + 1 - sample.frame.0,
                previous.time_s + 1.0 / self.fps - sample.time_s,
            );
        }
        self.last_tracked = Some((sample.frame.0, sample.time_s));
        sample.frame = FrameIndex(sample.frame.0 + self.offset.0);
        sample.time_s += self.offset.1;
        if let Some((previous, _)) = self.tracked.last() {
            let gaps = gaps_between((previous.frame.0, previous.time_s), sample.frame, self.fps);
            self.tracked
                .extend(gaps.map(|gap| (gap, DROPPED.to_string())));
        }
        self.tracked.push((sample, reason));
    }

    /// Hands a set to the writer (its frames in rig order), or counts it dropped.
    pub fn push(&mut self, set: &FrameSet, positions: &[Option<usize>]) {
        let frames: Option<Frames> = positions
            .iter()
            .map(|p| {
                let frame = set.cameras.get((*p)?)?.as_ref()?;
                let image = frame.decode("", None).ok()?;
                Some((image, frame.time_s))
            })
            .collect();
        let (Some(frames), Some(sender)) = (frames, &self.sender) else {
            self.dropped += 1;
            return;
        };
        if frames.len() != self.cameras {
            self.dropped += 1;
            return;
        }
        match sender.try_send(frames) {
            Ok(()) => self.queued += 1,
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => self.dropped += 1,
        }
    }

    /// Stops: waits for the writer, writes the take's bag beside the frames, then puts the
    /// folder in place.
    ///
    /// # Errors
    /// The first write that failed, or a tracked frame the bag cannot hold; nothing is left
    /// then.
    pub fn finish(mut self) -> Result<Written, FileError> {
        self.sender = None;
        let recording = match self.writer.take().map(JoinHandle::join) {
            Some(Ok(result)) => result?,
            _ => {
                return Err(FileError::Write {
                    path: self.target.clone(),
                    source: std::io::Error::other("the recording's writer stopped"),
                });
            }
        };
        let frames = recording.sets();
        let mcap = self.target.join(MCAP_FILE);
        let tool_messages = self.write_take(&recording.staging().join(MCAP_FILE), &mcap)?;
        recording.finish(self.fps)?;
        Ok(Written {
            summary: format!(
                "{frames} frames per camera ({} cameras); {} sets dropped (writer behind); {MCAP_FILE}: {} tracked frames, {tool_messages} poses",
                self.cameras,
                self.dropped,
                self.tracked.len()
            ),
            folder: self.target.clone(),
            frames,
            mcap,
            tool_messages,
            dropped: self.dropped,
        })
    }

    /// Writes the tracked frames as a ROS 2 bag at `staged` (`named` in messages): frames and
    /// times counted from the first tracked frame, as the studio's take
    /// ([`super::state::Take::trajectory`]). Returns the tool messages written.
    fn write_take(&self, staged: &Path, named: &Path) -> Result<usize, FileError> {
        let first = self
            .tracked
            .first()
            .map_or((0, 0.0), |(s, _)| (s.frame.0, s.time_s));
        let samples: Vec<Sample> = self
            .tracked
            .iter()
            .map(|(s, _)| {
                let mut s = *s;
                s.frame = FrameIndex(s.frame.0.saturating_sub(first.0));
                s.time_s -= first.1;
                s
            })
            .collect();
        let take = tracked_take(
            samples
                .iter()
                .zip(&self.tracked)
                .map(|(s, (_, reason))| (s, Some(reason.as_str()))),
            Some(&self.rig),
            Some(&self.tool),
            &RosFrames::default(),
        )
        .map_err(|e| FileError::Invalid {
            path: named.to_path_buf(),
            message: e.to_string(),
        })?;
        let bytes = mcap_bytes(&take).map_err(|e| FileError::Invalid {
            path: named.to_path_buf(),
            message: e.to_string(),
        })?;
        write_atomically(staged, &bytes)?;
        Ok(take.frames.iter().filter(|f| f.tool.is_some()).count())
    }
}

/// The writer thread: each set as it comes; returns the recording, to be finished.
fn write(
    mut recording: RecordingWriter,
    sets: &Receiver<Frames>,
) -> Result<RecordingWriter, FileError> {
    while let Ok(frames) = sets.recv() {
        let frames: Vec<(&GrayFrame, f64)> = frames.iter().map(|(f, t)| (f.as_ref(), *t)).collect();
        recording.push(&frames)?;
    }
    Ok(recording)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use teachcam::geometry::{Point3, Pose};
    use teachcam::sim::scenario::{paper_brush, paper_rig};
    use teachcam::trajectory::ToolPose;

    fn posed(frame: usize, time_s: f64, x_mm: f64) -> Sample {
        Sample::measured(
            FrameIndex(frame),
            time_s,
            ToolPose {
                world_from_tool: Pose::identity(),
                tip_in_world: Point3::new(x_mm, 0.0, 0.0),
                markers: 4,
                rms_mm: 0.05,
            },
        )
    }

    fn folder_entries(out: &Path) -> Vec<std::ffi::OsString> {
        std::fs::read_dir(out)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect()
    }

    #[test]
    fn a_take_the_bag_cannot_hold_leaves_no_recording() {
        let out = tempfile::tempdir().unwrap();
        let target = out.path().join("take-001");
        let mut recorder = Recorder::start(&target, &paper_rig(), &paper_brush(), 30.0).unwrap();
        recorder.track(posed(0, 0.0, 1.0), String::new());
        recorder.track(posed(1, 1.0 / 30.0, f64::NAN), String::new());
        let error = recorder.finish().unwrap_err().to_string();
        assert!(
            error.contains("take.mcap") && error.contains("frame 1"),
            "{error}"
        );
        assert!(folder_entries(out.path()).is_empty(), "nothing left behind");
    }

    #[test]
    fn dropped_frames_are_gaps_and_a_recording_played_again_goes_on_in_time() {
        let out = tempfile::tempdir().unwrap();
        let target = out.path().join("take-001");
        let mut recorder = Recorder::start(&target, &paper_rig(), &paper_brush(), 10.0).unwrap();
        recorder.track(posed(5, 0.5, 1.0), String::new());
        recorder.track(posed(8, 0.8, 2.0), String::new());
        // The folder played again from its frame 0.
        recorder.track(posed(0, 0.0, 3.0), String::new());
        let frames: Vec<(usize, f64, bool)> = recorder
            .tracked
            .iter()
            .map(|(s, _)| (s.frame.0, s.time_s, s.pose.is_some()))
            .collect();
        let expected = [
            (5, 0.5, true),
            (6, 0.6, false),
            (7, 0.7, false),
            (8, 0.8, true),
            (9, 0.9, true),
        ];
        assert_eq!(frames.len(), expected.len());
        for (got, want) in frames.iter().zip(expected) {
            assert_eq!((got.0, got.2), (want.0, want.2));
            assert!((got.1 - want.1).abs() < 1e-12, "{got:?} against {want:?}");
        }
        assert_eq!(recorder.tracked[1].1, DROPPED);
        let written = recorder.finish().unwrap();
        assert_eq!(written.tool_messages, 3);
        assert!(target.join(MCAP_FILE).is_file());
    }
}
