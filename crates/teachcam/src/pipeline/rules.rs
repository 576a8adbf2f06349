//! The per-frame rules both paths of the conductor apply, written once: what tracking takes of
//! a detected set ([`frame_inputs`]), which rig cameras are out of use ([`cameras_out`]) and
//! how that marks a frame, and the trajectory sample a tracked frame becomes ([`sample_of`], from [`crate::track`]).
//!
//! A camera is out when the recording has no frames of it (unplugged, its folder absent) or
//! when, over the frames measured, none of its blobs took part in a marker's point while the
//! others posed the tool: its calibration does not see the volume (a principal point far off
//! the image, a camera placed on another). Tracking goes on with the cameras left; every frame
//! then carries [`Flag::CameraOut`] and is at best `degraded`, so a result that used fewer
//! cameras than the rig has never passes as `ok`.

use std::collections::BTreeMap;
use std::fmt;

use crate::camera::Rig;
use crate::correspond::Views;
use crate::detect::DetectedSet;
use crate::geometry::CameraId;
use crate::track::merged::{BlobShape, Shapes};
use crate::track::{Flag, FrameTrack};
pub use crate::track::{OutReason, sample_of};

/// A detected set as tracking takes it: the blob centres and shapes per rig camera, and every
/// blob's predicted centre noise per axis (pixels).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameInput {
    /// Blob centres per rig camera (distorted pixels).
    pub views: Views,
    /// Blob shapes per rig camera, in the order of `views`.
    pub shapes: Shapes,
    /// Every blob's predicted centre noise per axis, pixels.
    pub blob_noise_px: Vec<f64>,
}

/// What tracking takes of `set`, whose cameras are the rig's `ids` (in the set's order; `None`
/// for a camera the rig lacks, left out).
#[must_use]
pub fn frame_inputs(ids: &[Option<CameraId>], set: &DetectedSet) -> FrameInput {
    let mut input = FrameInput::default();
    for (id, camera) in ids.iter().zip(&set.cameras) {
        let (Some(id), Some(camera)) = (id, camera) else {
            continue;
        };
        input
            .views
            .insert(*id, camera.blobs.iter().map(|b| b.center).collect());
        input
            .shapes
            .insert(*id, camera.blobs.iter().map(BlobShape::of).collect());
        input
            .blob_noise_px
            .extend(camera.blobs.iter().map(|b| b.center_std_px));
    }
    input
}

/// A rig camera out of use, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CameraOut {
    /// The camera's name.
    pub camera: String,
    /// Why.
    pub why: OutReason,
}

impl fmt::Display for CameraOut {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "camera {} {}", self.camera, self.why)
    }
}

/// Frames posed by the other cameras a camera must take no part in before it is out: a
/// camera that merely misses the tool for a moment is not out.
pub const OUT_AFTER_POSED_FRAMES: usize = 10;

/// The rig's cameras out of use: `missing` (no frames), then those that took part in none of
/// the points of `tracks` while at least [`OUT_AFTER_POSED_FRAMES`] of them were posed
/// (`inputs[i]` is `tracks[i]`'s frame).
#[must_use]
pub fn cameras_out(
    rig: &Rig,
    missing: &[String],
    tracks: &[FrameTrack],
    inputs: &[&FrameInput],
) -> Vec<CameraOut> {
    let mut out: Vec<CameraOut> = missing
        .iter()
        .map(|camera| CameraOut {
            camera: camera.clone(),
            why: OutReason::NoFrames,
        })
        .collect();
    let posed = tracks.iter().filter(|t| t.outcome.is_ok()).count();
    if posed < OUT_AFTER_POSED_FRAMES {
        return out;
    }
    let used = blobs_used(tracks);
    for (id, camera) in rig.iter() {
        if missing.contains(&camera.name) || used.get(&id).copied().unwrap_or(0) > 0 {
            continue;
        }
        let blobs_seen = inputs
            .iter()
            .filter_map(|i| i.views.get(&id))
            .map(Vec::len)
            .sum();
        out.push(CameraOut {
            camera: camera.name.clone(),
            why: OutReason::SeesNothing {
                blobs_seen,
                posed_frames: posed,
            },
        });
    }
    out
}

/// Per camera, the blobs that took part in a marker's point of a posed frame of `tracks` (a
/// camera absent from the map took part in none).
#[must_use]
pub fn blobs_used(tracks: &[FrameTrack]) -> BTreeMap<CameraId, usize> {
    let mut used: BTreeMap<CameraId, usize> = BTreeMap::new();
    for track in tracks.iter().filter(|t| t.outcome.is_ok()) {
        for point in track.labels.values().filter_map(|&p| track.points.get(p)) {
            for camera in point.views.keys() {
                *used.entry(*camera).or_default() += 1;
            }
        }
    }
    used
}

/// Marks a tracked frame with the cameras out of use (each a [`Flag::CameraOut`]).
pub fn mark_cameras_out(track: &mut FrameTrack, out: &[CameraOut]) {
    if track.outcome.is_err() {
        return;
    }
    track.flags.extend(out.iter().map(|o| Flag::CameraOut {
        camera: o.camera.clone(),
        why: o.why.clone(),
    }));
}
