//! Repeatability of blob centres (paper §IV-A, Fig. 10): a static marker filmed many times,
//! the standard deviation of its centre against its blob area.
//!
//! The blobs of every frame are gathered into tracks: a blob joins the track whose mean centre
//! is nearest, when within [`RepeatabilityConfig::match_radius_px`], or starts a new one.
//! For a track with centres `c_k`, `k = 1..n`:
//! ```text
//! std_x = √(Σ (x_k − x̄)² / (n − 1)),  std_y likewise,  std = √((std_x² + std_y²) / 2)
//! ```
//! `std` is the per-axis deviation the paper reports (0.15 px for its SmallestCircle), and the
//! input noise of the Monte Carlo study (§IV-B).

use super::Blob;
use crate::geometry::Pixel;

/// Options of the repeatability study.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepeatabilityConfig {
    /// A blob joins a track whose mean centre is at most this far, pixels. Default 1: ten
    /// times the paper's 0.15 px spread, and far below the distance between two markers.
    pub match_radius_px: f64,
    /// Tracks seen in fewer frames are left out. Default 10: fewer draws give a standard
    /// deviation uncertain by more than 25 %.
    pub min_frames: usize,
}

impl Default for RepeatabilityConfig {
    fn default() -> Self {
        Self {
            match_radius_px: 1.0,
            min_frames: 10,
        }
    }
}

/// The spread of one static marker's centre over the frames.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerSpread {
    /// Mean centre, pixels.
    pub mean_center: Pixel,
    /// Frames the marker was found in.
    pub frames: usize,
    /// Mean blob area, pixels.
    pub mean_area_px: f64,
    /// Standard deviation of the centre's x, pixels.
    pub std_x_px: f64,
    /// Standard deviation of the centre's y, pixels.
    pub std_y_px: f64,
    /// Per-axis standard deviation, `√((std_x² + std_y²) / 2)`, pixels.
    pub std_px: f64,
    /// Mean of the detector's own prediction ([`Blob::center_std_px`]), pixels.
    pub predicted_std_px: f64,
}

/// The spread of every static marker seen in at least `min_frames` of `frames` (each the
/// blobs of one frame of one camera), ordered by mean area.
#[must_use]
pub fn repeatability(frames: &[Vec<Blob>], cfg: &RepeatabilityConfig) -> Vec<MarkerSpread> {
    struct Track<'a> {
        sum_x: f64,
        sum_y: f64,
        blobs: Vec<&'a Blob>,
    }
    let mut tracks: Vec<Track<'_>> = Vec::new();
    for blob in frames.iter().flatten() {
        let nearest = tracks
            .iter_mut()
            .map(|t| {
                let n = t.blobs.len() as f64;
                let mean = Pixel::new(t.sum_x / n, t.sum_y / n);
                (mean.distance(&blob.center), t)
            })
            .filter(|(d, _)| *d <= cfg.match_radius_px)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match nearest {
            Some((_, track)) => {
                track.sum_x += blob.center.x;
                track.sum_y += blob.center.y;
                track.blobs.push(blob);
            }
            None => tracks.push(Track {
                sum_x: blob.center.x,
                sum_y: blob.center.y,
                blobs: vec![blob],
            }),
        }
    }
    let mut spreads: Vec<MarkerSpread> = tracks
        .iter()
        .filter(|t| t.blobs.len() >= cfg.min_frames.max(2))
        .map(|t| {
            let n = t.blobs.len() as f64;
            let mean = Pixel::new(t.sum_x / n, t.sum_y / n);
            let var = |f: &dyn Fn(&Blob) -> f64, m: f64| {
                t.blobs.iter().map(|b| (f(b) - m).powi(2)).sum::<f64>() / (n - 1.0)
            };
            let var_x = var(&|b| b.center.x, mean.x);
            let var_y = var(&|b| b.center.y, mean.y);
            MarkerSpread {
                mean_center: mean,
                frames: t.blobs.len(),
                mean_area_px: t.blobs.iter().map(|b| b.area_px as f64).sum::<f64>() / n,
                std_x_px: var_x.sqrt(),
                std_y_px: var_y.sqrt(),
                std_px: (0.5 * (var_x + var_y)).sqrt(),
                predicted_std_px: t.blobs.iter().map(|b| b.center_std_px).sum::<f64>() / n,
            }
        })
        .collect();
    spreads.sort_by(|a, b| a.mean_area_px.total_cmp(&b.mean_area_px));
    spreads
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::PixelBox;

    fn blob(x: f64, y: f64, area_px: usize) -> Blob {
        Blob {
            center: Pixel::new(x, y),
            area_px,
            radius_px: 3.0,
            roundness: 1.0,
            center_std_px: 0.01,
            bounding_box: PixelBox {
                x_min: 0,
                y_min: 0,
                x_max: 1,
                y_max: 1,
            },
            peak: 200,
            mean: 150.0,
        }
    }

    #[test]
    fn spreads_of_known_jitter() {
        // Marker A alternates x = 10 ± 0.1 (y fixed), marker B alternates y = 50 ± 0.2; a
        // stray blob appears once. 20 frames.
        let frames: Vec<Vec<Blob>> = (0..20)
            .map(|k| {
                let s = if k % 2 == 0 { 1.0 } else { -1.0 };
                let mut f = vec![
                    blob(10.0 + 0.1 * s, 20.0, 30),
                    blob(40.0, 50.0 + 0.2 * s, 80),
                ];
                if k == 3 {
                    f.push(blob(100.0, 100.0, 5));
                }
                f
            })
            .collect();
        let spreads = repeatability(&frames, &RepeatabilityConfig::default());
        assert_eq!(spreads.len(), 2);
        // Sample std of ±a alternating over 20 draws: a √(20/19).
        let factor = (20.0f64 / 19.0).sqrt();
        let a = &spreads[0];
        assert_eq!((a.frames, a.mean_area_px), (20, 30.0));
        assert!((a.std_x_px - 0.1 * factor).abs() < 1e-12 && a.std_y_px == 0.0);
        assert!((a.std_px - 0.1 * factor / 2f64.sqrt()).abs() < 1e-12);
        let b = &spreads[1];
        assert!((b.std_y_px - 0.2 * factor).abs() < 1e-12);
        assert!((b.mean_center.y - 50.0).abs() < 1e-12);
    }
}
