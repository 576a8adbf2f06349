//! The wand in each camera-frame: exactly three blobs, collinear in ideal pixels within a gate
//! measured from the recording, ordered by the middle marker's off-centre split.

use std::collections::BTreeMap;

use super::{MIN_SPLIT_ASYMMETRY, Wand, WandConfig, robust_gate};
use crate::camera::Rig;
use crate::correspond::Views;
use crate::geometry::{CameraId, Pixel};

/// One frame's wand views: per camera the three pixels (as detected) in wand order.
pub type WandFrame = BTreeMap<CameraId, [Pixel; 3]>;

/// What [`wand_views`] kept and why it left the rest.
#[derive(Debug, Clone, PartialEq)]
pub struct WandViews {
    /// Per frame of the recording, the cameras that saw the wand whole.
    pub frames: Vec<WandFrame>,
    /// Camera-frames with exactly three blobs.
    pub three_blobs: usize,
    /// Of those, left out as not collinear.
    pub not_collinear: usize,
    /// Of those, left out because the split could not tell the ends apart.
    pub ambiguous_ends: usize,
    /// The collinearity gate used, ideal pixels.
    pub line_gate_px: f64,
}

/// The wand in every camera-frame showing exactly three blobs that lie on one line (ideal
/// pixels, within a gate measured from all such camera-frames) with the middle one nearer the
/// end of marker 0 (`rig` supplies each camera's intrinsics; `frames[f][camera]` are its blob
/// centres). Cameras missing from `rig` are ignored.
#[must_use]
pub fn wand_views(rig: &Rig, frames: &[Views], wand: &Wand, config: &WandConfig) -> WandViews {
    // (frame, camera, detected pixels, off-line distance, split) of every three-blob view.
    let mut candidates: Vec<(usize, CameraId, [Pixel; 3], f64, f64)> = Vec::new();
    for (f, views) in frames.iter().enumerate() {
        for (&id, blobs) in views {
            let (Some(camera), [a, b, c]) = (rig.camera(id), blobs.as_slice()) else {
                continue;
            };
            let pixels = [*a, *b, *c];
            let Ok(ideal) = pixels
                .iter()
                .map(|p| camera.ideal_pixel(p))
                .collect::<Result<Vec<_>, _>>()
            else {
                continue;
            };
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
            // Marker 0 is the end nearer the middle marker (for a split below one half).
            let near_i = (along < 0.5) == (wand.split() < 0.5);
            let (first, last) = if near_i { (i, j) } else { (j, i) };
            let split = if near_i { along } else { 1.0 - along };
            candidates.push((
                f,
                id,
                [pixels[first], pixels[m], pixels[last]],
                off_line,
                split,
            ));
        }
    }
    let off_lines: Vec<f64> = candidates.iter().map(|c| c.3).collect();
    let line_gate_px = robust_gate(&off_lines, config.gate_mads)
        .map_or(config.min_line_gate_px, |g| g.max(config.min_line_gate_px));
    let mut out = WandViews {
        frames: vec![WandFrame::new(); frames.len()],
        three_blobs: candidates.len(),
        not_collinear: 0,
        ambiguous_ends: 0,
        line_gate_px,
    };
    for (f, id, ordered, off_line, split) in candidates {
        if off_line > line_gate_px {
            out.not_collinear += 1;
        } else if (split.min(1.0 - split) - 0.5).abs() < MIN_SPLIT_ASYMMETRY {
            out.ambiguous_ends += 1;
        } else {
            out.frames[f].insert(id, ordered);
        }
    }
    out
}
