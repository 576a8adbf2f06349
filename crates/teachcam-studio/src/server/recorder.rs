//! Record / stop: the frame sets the pipeline tracks, written as a recording folder that every
//! command reads (`cam0/000000.png ...`, `timestamps.csv`, `recording.json`, and the rig and
//! tool tracked with), all or nothing.
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
use teachcam::io::FileError;
use teachcam::io::recording::GrayFrame;
use teachcam::io::recording_writer::RecordingWriter;
use teachcam::io::rig::write_rig;
use teachcam::io::tool::write_tool;
use teachcam::source::FrameSet;
use teachcam::tool::Tool;

/// Sets waiting for the writer before new ones are dropped (a quarter second at 30 Hz).
const QUEUE_SETS: usize = 8;

/// One set's frames, in camera order, with their exposure times.
type Frames = Vec<(Arc<GrayFrame>, f64)>;

/// A recording in progress.
#[derive(Debug)]
pub struct Recorder {
    target: PathBuf,
    sender: Option<SyncSender<Frames>>,
    writer: Option<JoinHandle<Result<usize, FileError>>>,
    cameras: usize,
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
            .spawn(move || write(recording, &frames, fps))
            .map_err(|source| FileError::Write {
                path: target.to_path_buf(),
                source,
            })?;
        Ok(Self {
            target: target.to_path_buf(),
            sender: Some(sender),
            writer: Some(writer),
            cameras,
            queued: 0,
            dropped: 0,
        })
    }

    /// Where the recording goes.
    #[must_use]
    pub fn target(&self) -> &Path {
        &self.target
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

    /// Stops: waits for the writer, then puts the folder in place.
    ///
    /// # Errors
    /// The first write that failed; nothing is left then.
    pub fn finish(mut self) -> Result<Written, FileError> {
        self.sender = None;
        let frames = match self.writer.take().map(JoinHandle::join) {
            Some(Ok(result)) => result?,
            _ => {
                return Err(FileError::Write {
                    path: self.target.clone(),
                    source: std::io::Error::other("the recording's writer stopped"),
                });
            }
        };
        Ok(Written {
            summary: format!(
                "{frames} frames per camera ({} cameras); {} sets dropped (writer behind)",
                self.cameras, self.dropped
            ),
            folder: self.target.clone(),
            frames,
            dropped: self.dropped,
        })
    }
}

/// The writer thread: each set as it comes, then the timestamps and the rate, and the folder
/// put in place. Returns the frames per camera.
fn write(
    mut recording: RecordingWriter,
    sets: &Receiver<Frames>,
    fps: f64,
) -> Result<usize, FileError> {
    while let Ok(frames) = sets.recv() {
        let frames: Vec<(&GrayFrame, f64)> = frames.iter().map(|(f, t)| (f.as_ref(), *t)).collect();
        recording.push(&frames)?;
    }
    let written = recording.sets();
    recording.finish(fps)?;
    Ok(written)
}
