//! Recordings as every command that reads one reads it: a folder of PNG sub-folders or videos,
//! detected by the library ([`teachcam::pipeline::recording`]) with a progress bar on a
//! terminal and its failures marked as the user's data.

use std::path::Path;

use teachcam::pipeline::recording::{DetectedRecording, detect_recording};
use teachcam::pipeline::{CameraSetup, FrameDetections, PipelineError};
use teachcam::source::folder::FolderSource;
use teachcam::source::{FrameSource, SourceCamera};

use crate::Rejected;
use crate::progress::Progress;

/// Detects a recording folder's frames, PNG sub-folders and video files alike (CONTRACT,
/// "Recording"), with each frame's time from `timestamps.csv` where it lies beside them.
/// `cameras` chooses, from the source's cameras, which to detect and how (each frame's size is
/// checked against its setup's, or against the camera's first frame). Frames decode and detect
/// in parallel; a progress bar shows on a terminal.
///
/// # Errors
/// Rejected data naming the folder, camera, frame or file that cannot be read, has another
/// size, or is missing; what `cameras` returns.
pub fn detect_folder<B: FrameDetections>(
    root: &Path,
    fps: Option<f64>,
    cameras: impl FnOnce(&[SourceCamera]) -> anyhow::Result<Vec<CameraSetup>>,
) -> anyhow::Result<DetectedRecording<B>> {
    let mut source = FolderSource::open(root, fps).rejected()?;
    let setups = cameras(source.cameras())?;
    let progress = Progress::new("detect", source.len_hint().unwrap_or(0) as u64);
    let recording = detect_recording(&mut source, setups, &|| progress.tick()).rejected()?;
    progress.finish();
    Ok(recording)
}

/// A library error of the conductor as the binary reports it: the tool not found (exit 3),
/// a bad `--near`/`--far` (usage), anything else the user's data (exit 1).
pub fn pipeline_error(error: PipelineError, tool: &Path) -> anyhow::Error {
    match error {
        PipelineError::ToolNotFound(message) => anyhow::Error::new(crate::ToolNotFound(message)),
        PipelineError::Config(message) => anyhow::anyhow!(message),
        e @ PipelineError::Identify(_) => anyhow::Error::new(crate::DataRejected(
            anyhow::Error::new(e).context(tool.display().to_string()),
        )),
        e => anyhow::Error::new(crate::DataRejected(e.into())),
    }
}
