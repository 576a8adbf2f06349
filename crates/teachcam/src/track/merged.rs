//! Merged blobs: a marker's image that a glint, a reflection or another marker touches.
//!
//! Model. A sphere of diameter `D` at depth `z` in a camera of focal length `f` images as a
//! disc of radius `r̂ = f · D / (2 z)` (pinhole; the lens's local scale and the optics' blur
//! and bloom are what the ratio below learns). A blob's *size ratio* is its measured radius
//! over `r̂` at the depth of the marker it was triangulated into. Over the confidently
//! tracked markers of the gate sample the ratio is steady (blur, bloom and threshold scale it
//! alike); a blob whose ratio is beyond `median + 4σ̂` of that sample, or which is less round
//! than `median − 4σ̂` of the sample's roundness while larger than a typical marker (halfway
//! to the size gate; a marker partly hidden is smaller, and is not merged), holds more than
//! one sphere's light:
//! its centre is pulled towards whatever touches it.
//!
//! A merged view is left out of its marker's point where two or more other views remain
//! (leave one out); where it is one of two views, nothing else is left and its centre is used,
//! the frame `degraded` with the reason.

use std::collections::BTreeMap;

use crate::camera::Rig;
use crate::geometry::{CameraId, Point3};

/// A blob's size and shape, as detection measured them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlobShape {
    /// Radius of a uniform disc with the blob's flux and plateau level, pixels.
    pub radius_px: f64,
    /// 1 for a disc, about 0.5 for two touching equal discs.
    pub roundness: f64,
}

impl BlobShape {
    /// The shape of a detected blob.
    #[must_use]
    pub fn of(blob: &crate::detect::Blob) -> Self {
        Self {
            radius_px: blob.radius_px,
            roundness: blob.roundness,
        }
    }
}

/// Each camera's blobs' shapes, in the order of the frame's [`crate::correspond::Views`].
pub type Shapes = BTreeMap<CameraId, Vec<BlobShape>>;

/// When a marker's blob counts as merged (measured by [`crate::track::gates`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MergedGate {
    /// Largest size ratio (measured radius over the sphere's predicted one) of a single
    /// marker's blob.
    pub max_size_ratio: f64,
    /// Median size ratio of confidently tracked markers.
    pub typical_size_ratio: f64,
    /// Smallest roundness of a single marker's blob larger than typical (halfway to
    /// `max_size_ratio`).
    pub min_roundness: f64,
}

impl MergedGate {
    /// Whether a blob of this size ratio and roundness holds more than one sphere's light.
    #[must_use]
    pub fn is_merged(&self, size_ratio: f64, roundness: f64) -> bool {
        size_ratio > self.max_size_ratio
            || (roundness < self.min_roundness
                && size_ratio >= 0.5 * (self.typical_size_ratio + self.max_size_ratio))
    }
}

/// The radius, pixels, of the image of a sphere of `diameter_mm` centred at `point_in_world`
/// in camera `camera`: `f · D / (2 z)` with `f` the mean focal length; `None` behind it.
#[must_use]
pub fn predicted_radius_px(
    rig: &Rig,
    camera: CameraId,
    point_in_world: &Point3,
    diameter_mm: f64,
) -> Option<f64> {
    let cam = rig.camera(camera)?;
    let z = cam.camera_from_world.transform_point(point_in_world).z;
    let f = 0.5 * (cam.intrinsics.fx + cam.intrinsics.fy);
    (z > 0.0).then(|| f * diameter_mm / (2.0 * z))
}

/// The size ratio of a blob imaging a sphere at `point_in_world`: measured over predicted
/// radius; `None` without a prediction.
#[must_use]
pub fn size_ratio(
    rig: &Rig,
    camera: CameraId,
    shape: &BlobShape,
    point_in_world: &Point3,
    diameter_mm: f64,
) -> Option<f64> {
    let predicted = predicted_radius_px(rig, camera, point_in_world, diameter_mm)?;
    (predicted > 0.0).then(|| shape.radius_px / predicted)
}
