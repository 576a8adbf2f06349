//! What detection gives for one instant of a recording or a live source: every camera's
//! blobs with its frame's number and exposure time ([`DetectedSet`]), the unit that
//! [`crate::pipeline`] hands from detection to tracking and [`crate::io::detections`] writes.

use std::time::Instant;

use crate::detect::{Blob, RoundnessChoices};

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

impl<B> DetectedSet<B> {
    /// The blobs of the camera named `camera`, `None` where it has no frame in this set (or
    /// is not in the stream at all: a rig camera missing from the source).
    #[must_use]
    pub fn of(&self, camera: &str) -> Option<&CameraDetections<B>> {
        self.cameras.iter().flatten().find(|c| c.camera == camera)
    }
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
