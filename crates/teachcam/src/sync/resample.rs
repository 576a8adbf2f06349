//! Applying offsets: each camera's blobs moved to the common frame times.
//!
//! A camera whose frame `k` was exposed at `k·T + δ` shows the common time `f·T` at its
//! fractional frame `f − δ/T`; each of its blob tracks is sampled there. A blob whose track
//! does not reach that far (the track's first or last frame, a marker that appears or
//! vanishes, a link broken by fast or crossing motion) cannot be moved and is left out of the
//! frame; a sample whose interpolation error estimate exceeds the limit (fast motion, or a
//! lower order near a track's end) is kept and reported.

use super::tracks::{BlobTrack, link_tracks};
use super::{ResampleIssue, Resampled, SyncConfig, TimeOffsets};
use crate::correspond::Views;
use crate::geometry::{CameraId, Pixel};

/// Every frame's blobs at the common frame times, and what could not be done per frame.
/// Cameras without an offset, or with offset 0, pass through untouched.
#[must_use]
pub fn resample_views(
    frames: &[Views],
    offsets: &TimeOffsets,
    frame_period_s: f64,
    config: &SyncConfig,
) -> Resampled {
    let mut out: Vec<Views> = frames.to_vec();
    let mut issues: Vec<Vec<ResampleIssue>> = vec![Vec::new(); frames.len()];
    let cameras: Vec<CameraId> = {
        let mut ids: Vec<CameraId> = frames.iter().flat_map(|v| v.keys().copied()).collect();
        ids.sort();
        ids.dedup();
        ids
    };
    for camera in cameras {
        let offset_s = offsets.get(&camera).copied().unwrap_or(0.0);
        if offset_s == 0.0 {
            continue;
        }
        let offset_periods = offset_s / frame_period_s;
        let blobs: Vec<Vec<Pixel>> = frames
            .iter()
            .map(|v| v.get(&camera).cloned().unwrap_or_default())
            .collect();
        let tracks = link_tracks(&blobs, config.link_ratio);
        let mut moved: Vec<Vec<Pixel>> = vec![Vec::new(); frames.len()];
        let mut worst_error: Vec<f64> = vec![0.0; frames.len()];
        for track in &tracks {
            place_track(
                track,
                offset_periods,
                config.interpolation_points,
                &mut moved,
                &mut worst_error,
            );
        }
        for (frame, pixels) in moved.into_iter().enumerate() {
            let before = blobs[frame].len();
            if pixels.len() < before {
                issues[frame].push(ResampleIssue::NotMoved {
                    camera,
                    blobs: before - pixels.len(),
                });
            }
            if worst_error[frame] > config.max_interpolation_error_px {
                issues[frame].push(ResampleIssue::Uncertain {
                    camera,
                    error_px: worst_error[frame],
                });
            }
            if frames[frame].contains_key(&camera) {
                out[frame].insert(camera, pixels);
            }
        }
    }
    Resampled {
        frames: out,
        issues,
    }
}

/// Samples one track at every frame whose common time it spans.
fn place_track(
    track: &BlobTrack,
    offset_periods: f64,
    interpolation_points: usize,
    moved: &mut [Vec<Pixel>],
    worst_error: &mut [f64],
) {
    // Frames f with first ≤ f − offset ≤ last.
    let low = (track.first_frame as f64 + offset_periods).ceil().max(0.0) as usize;
    let high = (track.last_frame() as f64 + offset_periods).floor();
    if high < 0.0 {
        return;
    }
    let high = (high as usize).min(moved.len().saturating_sub(1));
    for frame in low..=high {
        let Some(sample) = track.sample(frame as f64 - offset_periods, interpolation_points) else {
            continue;
        };
        if let Some(pixels) = moved.get_mut(frame) {
            pixels.push(sample.position);
        }
        if let Some(worst) = worst_error.get_mut(frame) {
            *worst = worst.max(sample.error_px());
        }
    }
}
