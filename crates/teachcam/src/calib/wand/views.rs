//! The wand in each camera-frame: exactly as many blobs as the wand has markers; three must be
//! collinear in ideal pixels within a gate measured from the recording, and are ordered by the
//! middle marker's off-centre split where it tells the ends apart. Two blobs (and three whose
//! split does not tell the ends apart) are kept with their ends unlabelled: which end is which
//! is settled across cameras by [`super::calibrate_wand`].

use std::collections::BTreeMap;

use super::{MIN_SPLIT_ASYMMETRY, Wand, WandConfig, robust_gate};
use crate::camera::Rig;
use crate::correspond::Views;
use crate::geometry::{CameraId, Pixel};

/// One camera's image of the wand: its markers' pixels (as detected) in wand order, or in
/// wand order or its reverse when `ends_known` is false.
#[derive(Debug, Clone, PartialEq)]
pub struct WandImage {
    /// The markers' pixels.
    pub pixels: Vec<Pixel>,
    /// Whether `pixels[0]` is known to be marker 0 (a three-marker wand's split told the ends
    /// apart); otherwise the order may be reversed.
    pub ends_known: bool,
}

impl WandImage {
    /// An image whose order is known.
    #[must_use]
    pub fn labelled(pixels: Vec<Pixel>) -> Self {
        Self {
            pixels,
            ends_known: true,
        }
    }

    /// The pixels in wand order (`reversed`: the other way round).
    #[must_use]
    pub fn ordered(&self, reversed: bool) -> Vec<Pixel> {
        if reversed {
            self.pixels.iter().rev().copied().collect()
        } else {
            self.pixels.clone()
        }
    }
}

/// One frame's wand views: per camera its image of the wand.
pub type WandFrame = BTreeMap<CameraId, WandImage>;

/// What [`wand_views`] kept and why it left the rest.
#[derive(Debug, Clone, PartialEq)]
pub struct WandViews {
    /// Per frame of the recording, the cameras that saw the wand whole.
    pub frames: Vec<WandFrame>,
    /// Camera-frames with exactly as many blobs as the wand has markers.
    pub whole: usize,
    /// Of those, left out as not collinear (three markers).
    pub not_collinear: usize,
    /// Of those, kept with the ends not told apart by the image (every two-marker view, and
    /// three-marker views whose split is near one half).
    pub ends_unlabelled: usize,
    /// The collinearity gate used, ideal pixels (0 for a two-marker wand).
    pub line_gate_px: f64,
}

/// The wand in every camera-frame showing exactly as many blobs as it has markers (`rig`
/// supplies each camera's intrinsics; `frames[f][camera]` are its blob centres or digitised
/// points). Three blobs must lie on one line (ideal pixels, within a gate measured from all
/// such camera-frames); their order comes from the split where it tells the ends apart.
/// Cameras missing from `rig` and points that cannot be undistorted are left out.
#[must_use]
pub fn wand_views(rig: &Rig, frames: &[Views], wand: &Wand, config: &WandConfig) -> WandViews {
    let count = wand.markers_mm.len();
    // (frame, camera, pixels in a wand order, off-line distance, ends known) of every view.
    let mut candidates: Vec<(usize, CameraId, Vec<Pixel>, f64, bool)> = Vec::new();
    for (f, views) in frames.iter().enumerate() {
        for (&id, blobs) in views {
            let Some(camera) = rig.camera(id) else {
                continue;
            };
            if blobs.len() != count {
                continue;
            }
            let Ok(ideal) = blobs
                .iter()
                .map(|p| camera.ideal_pixel(p))
                .collect::<Result<Vec<_>, _>>()
            else {
                continue;
            };
            let [a, b, c] = blobs.as_slice() else {
                candidates.push((f, id, blobs.clone(), 0.0, false));
                continue;
            };
            let pixels = [*a, *b, *c];
            // The ends: the farthest pair.
            let pairs = [(0, 1, 2), (0, 2, 1), (1, 2, 0)];
            let Some(&(i, j, m)) = pairs.iter().max_by(|p, q| {
                ideal[p.0]
                    .distance(&ideal[p.1])
                    .total_cmp(&ideal[q.0].distance(&ideal[q.1]))
            }) else {
                continue;
            };
            let length = ideal[i].distance(&ideal[j]);
            if length <= 0.0 {
                continue;
            }
            let (ex, ey) = (
                (ideal[j].x - ideal[i].x) / length,
                (ideal[j].y - ideal[i].y) / length,
            );
            let (mx, my) = (ideal[m].x - ideal[i].x, ideal[m].y - ideal[i].y);
            let off_line = (mx * ey - my * ex).abs();
            let along = (mx * ex + my * ey) / length;
            let split = wand.split().unwrap_or(0.5);
            // Marker 0 is the end nearer the middle marker (for a split below one half).
            let near_i = (along < 0.5) == (split < 0.5);
            let (first, last) = if near_i { (i, j) } else { (j, i) };
            let seen = if near_i { along } else { 1.0 - along };
            let ends_known =
                wand.ends_told_apart() && (seen.min(1.0 - seen) - 0.5).abs() >= MIN_SPLIT_ASYMMETRY;
            candidates.push((
                f,
                id,
                vec![pixels[first], pixels[m], pixels[last]],
                off_line,
                ends_known,
            ));
        }
    }
    let line_gate_px = if count == 3 {
        let off_lines: Vec<f64> = candidates.iter().map(|c| c.3).collect();
        robust_gate(&off_lines, config.gate_mads)
            .map_or(config.min_line_gate_px, |g| g.max(config.min_line_gate_px))
    } else {
        0.0
    };
    let mut out = WandViews {
        frames: vec![WandFrame::new(); frames.len()],
        whole: candidates.len(),
        not_collinear: 0,
        ends_unlabelled: 0,
        line_gate_px,
    };
    for (f, id, pixels, off_line, ends_known) in candidates {
        if count == 3 && off_line > line_gate_px {
            out.not_collinear += 1;
            continue;
        }
        if !ends_known {
            out.ends_unlabelled += 1;
        }
        out.frames[f].insert(id, WandImage { pixels, ends_known });
    }
    out
}
