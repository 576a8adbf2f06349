//! Detection limits measured from the recording in hand: the threshold and the smallest blob
//! from the blob population of a sample of frames (the roundness floor is measured after them,
//! from the blobs they give: [`crate::track::gates::roundness_gate`]).
//!
//! Model. Each sampled frame is detected permissively ([`FrameSample::detect`]: the automatic
//! threshold, every size from one pixel, every roundness), and every blob gives its contrast
//! `c = peak − b` (`b` the frame's background median) and its flux `Σ (I − b)`. The markers
//! carry almost all of the flux of a marker scene, specks and compression noise almost none,
//! so the markers' contrast is the *flux-weighted median* `C` of the contrasts of the blobs
//! that could be markers (roundness at least [`CANDIDATE_ROUNDNESS`]: a streak or a lit edge
//! is long, and would outweigh small markers): a hundred 4-px specks of contrast 14 weigh less
//! than one marker of 50 px at 255.
//!
//! - *Threshold*: `b + C / 3` in every frame (never below the automatic level). A saturated
//!   marker under lossy compression has a bloom skirt at ~9 % of full scale two pixels past its
//!   edge and block artefacts of a few percent (notes/sim-real.md): at the automatic threshold
//!   (`b + full scale / 32`) skirt and artefacts join the blob, make it irregular and leave
//!   specks beside it; at a third of the markers' contrast the blob is the marker's core and its
//!   halo belongs to it (the refined centre sums the whole window around it, skirt included).
//!   A third, not a half, keeps markers imaged at half the typical contrast (far or at the
//!   edge of the light) above it. On the real PS3 Eye recording (`normal.avi`) fixed levels of
//!   80 and 100 DN (C = 255) gave five markers in 399 and 398 of 402 frames
//!   (notes/detect-learned.md).
//! - *Smallest blob*: the blobs that pass that threshold have flux radii `r`; the smallest
//!   markers (1st percentile `r₁`) cover about `π r₁²` pixels above it, and a blob under a
//!   quarter of that, `π (r₁/2)²`, is a speck, not a marker. Never below the configured floor.
//!   (The 1st, not the 5th: a marker leaving the view or the light shrinks to a few pixels;
//!   on `normal.avi` the 5th percentile's quarter, 8 px, lost two such frames.)
//!
//! With fewer than [`MIN_BLOBS`] blobs in the sample (an empty scene), nothing is learned and
//! the configured limits stay, said in the reason.

use super::{
    Background, Blob, DetectConfig, DetectError, GrayView, Intensity, Threshold,
    estimate_background,
};

/// Blobs less round than this (two touching equal discs score 0.5) are not markers and do not
/// weigh in the markers' contrast: streaks, lit edges.
pub const CANDIDATE_ROUNDNESS: f64 = 0.5;

/// Fewest blobs of a sample the limits are learned from.
pub const MIN_BLOBS: usize = 10;

/// The learned threshold sits at this fraction of the markers' contrast above the background.
pub const CONTRAST_FRACTION: f64 = 1.0 / 3.0;

/// The blobs of one sampled frame, detected permissively, with the frame's background.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameSample {
    /// The frame's background median, image units.
    pub background: f64,
    /// Every blob above the automatic threshold, of any size from one pixel and any roundness.
    pub blobs: Vec<Blob>,
}

impl FrameSample {
    /// `image` detected with `base`'s largest size and centre method, but the automatic
    /// threshold, no smallest size and no roundness floor.
    ///
    /// # Errors
    /// As [`super::detect_view`].
    pub fn detect<P: Intensity>(
        image: GrayView<'_, P>,
        base: &DetectConfig,
    ) -> Result<Self, DetectError> {
        Self::detect_with(image, &estimate_background(image), base)
    }

    /// [`Self::detect`] with the image's background given (a [`super::sketch::Sketch`]'s).
    ///
    /// # Errors
    /// As [`super::detect_view`].
    pub(crate) fn detect_with<P: Intensity>(
        image: GrayView<'_, P>,
        background: &Background,
        base: &DetectConfig,
    ) -> Result<Self, DetectError> {
        Ok(Self {
            background: background.level,
            blobs: super::detect_view_with(image, background, &Self::permissive(base))?,
        })
    }

    /// `base` with the automatic threshold, no smallest size and no roundness floor.
    #[must_use]
    pub fn permissive(base: &DetectConfig) -> DetectConfig {
        DetectConfig {
            threshold: Threshold::Auto,
            min_area_px: 1,
            min_roundness: 0.0,
            sphere: None,
            ..base.clone()
        }
    }
}

/// One learned limit: its value and how it was set, for people.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Limit {
    /// The value, in the limit's unit.
    pub value: f64,
    /// How it was set.
    pub reason: String,
}

/// The limits of one camera's detection.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CameraLimits {
    /// Threshold above each frame's background, image units; `None`: the automatic threshold.
    pub contrast: Option<f64>,
    /// Smallest blob kept, pixels.
    pub min_area_px: usize,
    /// How the threshold was set.
    pub threshold_reason: String,
    /// How the smallest blob was set.
    pub min_area_reason: String,
}

impl CameraLimits {
    /// `config` with these limits: the threshold unless it is fixed, the smallest blob.
    pub fn apply(&self, config: &mut DetectConfig) {
        if let (Some(c), Threshold::Auto) = (self.contrast, config.threshold) {
            config.threshold = Threshold::AboveBackground(c);
        }
        config.min_area_px = self.min_area_px;
    }

    /// One short phrase: `threshold +85 (1/3 of the markers' contrast 255), min area 5 px`.
    #[must_use]
    pub fn summary(&self) -> String {
        let threshold = match self.contrast {
            Some(c) => format!("threshold background + {c:.0} ({})", self.threshold_reason),
            None => format!("threshold {}", self.threshold_reason),
        };
        format!(
            "{threshold}, min area {} px ({})",
            self.min_area_px, self.min_area_reason
        )
    }
}

/// The limits learned from one camera's sampled frames, starting from `config` (its smallest
/// blob is the floor; a fixed threshold stays, said in the reason; `min_area_given` keeps the
/// smallest blob as given).
#[must_use]
pub fn learn_limits(
    samples: &[FrameSample],
    config: &DetectConfig,
    min_area_given: bool,
) -> CameraLimits {
    // (contrast, flux, flux radius) of every blob.
    let blobs: Vec<(f64, f64, f64)> = samples
        .iter()
        .flat_map(|s| {
            s.blobs
                .iter()
                .filter(|b| b.roundness >= CANDIDATE_ROUNDNESS)
                .map(|b| {
                    let contrast = f64::from(b.peak) - s.background;
                    let flux = b.area_px as f64 * (b.mean - s.background);
                    (contrast, flux, b.radius_px)
                })
        })
        .filter(|(c, f, r)| c.is_finite() && *c > 0.0 && f.is_finite() && *f > 0.0 && r.is_finite())
        .collect();
    let given_threshold = match config.threshold {
        Threshold::Fixed(t) => Some((None, format!("{t} given (--threshold)"))),
        Threshold::AboveBackground(c) => Some((Some(c), "given".to_string())),
        Threshold::Auto => None,
    };
    let too_few = format!(
        "{} blobs in {} sampled frames, fewer than {MIN_BLOBS} to learn from",
        blobs.len(),
        samples.len()
    );
    let (contrast, threshold_reason) = match given_threshold {
        Some(given) => given,
        None if blobs.len() < MIN_BLOBS => (None, format!("automatic per frame ({too_few})")),
        None => {
            let markers = weighted_median(blobs.iter().map(|&(c, f, _)| (c, f)));
            (
                Some(markers * CONTRAST_FRACTION),
                format!(
                    "1/3 of the markers' contrast {markers:.0}, flux-weighted median of {} blobs",
                    blobs.len()
                ),
            )
        }
    };
    // The blobs the threshold keeps (a fixed one: those whose peak is above it).
    let kept = |contrast_of_blob: f64, peak: u32| match (contrast, config.threshold) {
        (Some(c), _) => contrast_of_blob > c,
        (None, Threshold::Fixed(t)) => peak > t,
        (None, _) => true,
    };
    let mut radii: Vec<f64> = samples
        .iter()
        .flat_map(|s| {
            s.blobs
                .iter()
                .filter(|b| {
                    b.radius_px.is_finite() && kept(f64::from(b.peak) - s.background, b.peak)
                })
                .map(|b| b.radius_px)
        })
        .collect();
    let (min_area_px, min_area_reason) = if min_area_given {
        (config.min_area_px, "given (--min-area)".to_string())
    } else if radii.len() < MIN_BLOBS {
        (
            config.min_area_px,
            format!(
                "default: {} blobs above the threshold, fewer than {MIN_BLOBS}",
                radii.len()
            ),
        )
    } else {
        radii.sort_by(f64::total_cmp);
        let r1 = radii[(radii.len() - 1) / 100];
        let speck = std::f64::consts::PI * (0.5 * r1).powi(2);
        let learned = (speck.floor() as usize).max(config.min_area_px);
        (
            learned,
            format!("a quarter of the smallest markers' area, radius p1 {r1:.1} px"),
        )
    };
    CameraLimits {
        contrast,
        min_area_px,
        threshold_reason,
        min_area_reason,
    }
}

/// The value below and above which half the total weight lies (`values` non-empty, weights
/// positive).
fn weighted_median(values: impl Iterator<Item = (f64, f64)>) -> f64 {
    let mut values: Vec<(f64, f64)> = values.collect();
    values.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = values.iter().map(|v| v.1).sum();
    let mut below = 0.0;
    for &(value, weight) in &values {
        below += weight;
        if below >= 0.5 * total {
            return value;
        }
    }
    values.last().map_or(0.0, |v| v.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::PixelBox;
    use crate::geometry::Pixel;

    fn blob(peak: u32, area_px: usize, mean: f64, radius_px: f64) -> Blob {
        Blob {
            center: Pixel::new(10.0, 10.0),
            area_px,
            radius_px,
            roundness: 0.9,
            center_std_px: 0.01,
            bounding_box: PixelBox {
                x_min: 0,
                y_min: 0,
                x_max: 1,
                y_max: 1,
            },
            peak,
            mean,
        }
    }

    #[test]
    fn markers_outweigh_many_specks() {
        // Per frame: five markers (peak 255, 50 px of mean 180) and forty specks (peak 14,
        // 4 px of mean 10) on a background of 2.
        let frame = FrameSample {
            background: 2.0,
            blobs: (0..5)
                .map(|_| blob(255, 50, 180.0, 4.0))
                .chain((0..40).map(|_| blob(14, 4, 10.0, 0.8)))
                .collect(),
        };
        let limits = learn_limits(&vec![frame; 10], &DetectConfig::default(), false);
        // The flux-weighted median is the markers' contrast 253: a third of it.
        let c = limits.contrast.unwrap();
        assert!((c - 253.0 / 3.0).abs() < 1e-9, "{limits:?}");
        // Only the markers pass it: a quarter of π 4² is 12.6 px.
        assert_eq!(limits.min_area_px, 12, "{limits:?}");
    }

    #[test]
    fn an_empty_scene_keeps_the_configured_limits() {
        let limits = learn_limits(&[FrameSample::default()], &DetectConfig::default(), false);
        assert_eq!(limits.contrast, None);
        assert_eq!(limits.min_area_px, DetectConfig::default().min_area_px);
        assert!(limits.threshold_reason.contains("fewer than"), "{limits:?}");
        assert!(limits.min_area_reason.contains("fewer than"), "{limits:?}");
    }

    #[test]
    fn given_limits_stay() {
        let frame = FrameSample {
            background: 0.0,
            blobs: vec![blob(200, 40, 120.0, 3.0); 20],
        };
        let config = DetectConfig {
            threshold: Threshold::Fixed(90),
            min_area_px: 7,
            ..DetectConfig::default()
        };
        let limits = learn_limits(&[frame], &config, true);
        assert_eq!(limits.contrast, None);
        assert_eq!(limits.min_area_px, 7);
        let mut applied = config.clone();
        limits.apply(&mut applied);
        assert_eq!(applied, config);
    }
}
