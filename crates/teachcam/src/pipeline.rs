//! The conductor: frames from any [`crate::source`] to tracked frames, for a whole recording
//! (`track`) and at camera rate (`live`, the studio, every live front end), under one set of
//! rules.
//!
//! ```text
//! FrameSource ─► detect_stream   decode + size check + detect  (rayon, every camera × set)
//!                 └─► DetectedSet (blobs per camera, per-frame times)
//! recording  ─► a recording detected, its sample, the gates measured from it (Learned)
//! batch      ─► TrackOptions → TrackRun { trajectory, tracks, gates, synchronised }
//! stream     ─► TrackStream: the same rules set by set, gates learned from the recording's
//!               sample or from a live source's first frames, the temporal guard with a lag
//! rules      ─► what both apply, written once: a set's views, shapes and blob noise; the
//!               cameras that see nothing; a frame's status, reason and trajectory sample
//! ```
//! Rules and where they live: gates (roundness, epipolar, triangulation, distances,
//! registration, merged blobs, mirror) [`crate::track::gates`], measured by
//! [`recording::Learned`] for both paths; merged blobs, reflections and the tracking of a
//! frame [`crate::track::Tracker`]; labels from a neighbour's pose
//! [`crate::track::fill_from_neighbours`] (the batch over the whole recording, the stream over
//! its window); the temporal guard [`crate::track::temporal`]; the σ model
//! [`crate::metrology::frame`]; the sample written and the cameras out [`rules`].
//!
//! Where the two paths differ, because a stream cannot see the future: the stream's typical
//! residuals (σ's yardstick) are those of the frames its gates were learned from, not of the
//! whole recording; its temporal guard sees [`stream::StreamOptions::lag_frames`] frames
//! ahead (a frame's status is final when it is emitted) and measures its step gate from the
//! frames so far; a live source's first frames are `degraded` until its gates are learned.
//! Every frame's size is checked against the rig (or, without a rig, the camera's first
//! frame): a frame of another size is refused naming the camera, the frame and both sizes.

pub mod batch;
pub mod detect_stream;
pub mod recording;
pub mod rules;
pub mod stream;

pub use crate::detect::{CameraDetections, DetectedSet};
pub use detect_stream::{DetectStream, FrameDetections};
pub use stream::{StreamOptions, TrackStream, TrackedFrame};

use crate::detect::DetectError;
use crate::source::SourceError;

/// Why the conductor stopped.
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
    /// A camera asked for is not among the source's cameras.
    #[error("rig camera {camera} is not in the source (found: {found})")]
    MissingCamera {
        /// The rig's camera.
        camera: String,
        /// The source's cameras.
        found: String,
    },
    /// Too few rig cameras have frames to triangulate anything.
    #[error(
        "only {found} of the rig's cameras ({cameras}) are in the recording; two are needed (missing: {missing})"
    )]
    TooFewCameras {
        /// How many rig cameras the source has.
        found: usize,
        /// The rig's cameras.
        cameras: String,
        /// The rig's cameras the source lacks.
        missing: String,
    },
    /// A detections file does not fit the rig or the recording.
    #[error("{0}")]
    Detections(String),
    /// Time offsets could not be estimated.
    #[error("--time-offsets auto: {0}")]
    Sync(#[from] crate::sync::SyncError),
    /// The tool cannot be told apart at the measured distance tolerance.
    #[error(transparent)]
    Identify(#[from] crate::identify::IdentifyError),
    /// The tool fits no frame (no pose, or only outliers).
    #[error("{0}")]
    ToolNotFound(String),
    /// The configuration does not match the cameras.
    #[error("{0}")]
    Config(String),
}

/// A camera to detect: its name among the source's cameras, its detector configuration, and
/// the size its frames must have (`None`: the size of its first frame).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSetup {
    /// The camera's name.
    pub name: String,
    /// Its detector configuration.
    pub detect: crate::detect::DetectConfig,
    /// `(width, height)` every frame must have.
    pub size: Option<(u32, u32)>,
}
