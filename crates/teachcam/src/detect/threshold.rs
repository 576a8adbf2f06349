//! Background level and noise of a marker image, from a sparse sample.
//!
//! Model: the background is the bulk of the image (markers cover well under a quarter of it),
//! so its level is the sample median `b` and its noise the interquartile range scaled to a
//! Gaussian standard deviation, `σ = (Q3 − Q1) / 1.349`. Both ignore the markers (breakdown
//! point 25 %). Integer images quantise low noise (σ = 2 units has quartiles a unit or two
//! apart), so each quantile is interpolated within its integer value, read as the interval
//! `[v − ½, v + ½]` (the grouped-data quantile). The sample is every 4th column of every 8th
//! row: about 41 000 values of a 1280×1024 frame, a thirty-second of the image.

use super::{GrayView, Intensity};

/// Column stride of the sample.
const SAMPLE_STEP_X: usize = 4;
/// Row stride of the sample.
const SAMPLE_STEP_Y: usize = 8;
/// Interquartile range of a unit Gaussian, `2 Φ⁻¹(3/4)`.
const GAUSSIAN_IQR: f64 = 1.348_979_500_392_163;
/// The automatic threshold sits this many noise deviations above the background.
pub const AUTO_THRESHOLD_SIGMAS: f64 = 8.0;
/// The automatic threshold sits at least this fraction of full scale above the background
/// (noise-free images have σ = 0).
pub const AUTO_THRESHOLD_MIN_CONTRAST: f64 = 1.0 / 32.0;

/// Background level and noise of an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Background {
    /// Median of the sample (interpolated), in image units.
    pub level: f64,
    /// Robust standard deviation of the background noise, in image units.
    pub noise_std: f64,
}

impl Background {
    /// The automatic threshold: `level + max(8 σ, full scale / 32)`, rounded up; at least
    /// full scale when nothing can be above it.
    #[must_use]
    pub fn auto_threshold<P: Intensity>(&self) -> u32 {
        let full = f64::from(P::FULL_SCALE);
        let margin =
            (AUTO_THRESHOLD_SIGMAS * self.noise_std).max(AUTO_THRESHOLD_MIN_CONTRAST * full);
        let t = (self.level + margin).ceil();
        if t >= full { P::FULL_SCALE } else { t as u32 }
    }

    /// `contrast` above the level, rounded up, never below [`Self::auto_threshold`] (noise
    /// makes no blob) and at most full scale.
    #[must_use]
    pub fn threshold_above<P: Intensity>(&self, contrast: f64) -> u32 {
        let full = f64::from(P::FULL_SCALE);
        let t = (self.level + contrast).ceil();
        let above = if t.is_nan() || t >= full {
            P::FULL_SCALE
        } else {
            t.max(0.0) as u32
        };
        above.max(self.auto_threshold::<P>())
    }
}

/// Background level and noise from a sparse sample of the image (module docs); zero for an
/// empty image.
#[must_use]
pub fn estimate_background<P: Intensity>(image: GrayView<'_, P>) -> Background {
    let mut histogram = vec![0u32; P::FULL_SCALE as usize + 1];
    let mut count = 0usize;
    // Offset the sampled rows so that a 1-row image and the middle of small images are seen.
    let first_row = (image.height / 2) % SAMPLE_STEP_Y;
    for y in (first_row..image.height).step_by(SAMPLE_STEP_Y) {
        let row = image.row(y);
        let mut x = 0;
        while x < row.len() {
            histogram[row[x].level() as usize] += 1;
            x += SAMPLE_STEP_X;
        }
        count += row.len().div_ceil(SAMPLE_STEP_X);
    }
    if count == 0 {
        return Background {
            level: 0.0,
            noise_std: 0.0,
        };
    }
    let n = count as f64;
    let quantile = |q: f64| interpolated_quantile(&histogram, q * n);
    Background {
        level: quantile(0.5),
        noise_std: (quantile(0.75) - quantile(0.25)) / GAUSSIAN_IQR,
    }
}

/// The value below which `rank` of the counted values lie, each integer value `v` spread
/// evenly over `[v − ½, v + ½]`.
fn interpolated_quantile(histogram: &[u32], rank: f64) -> f64 {
    let mut below = 0.0;
    for (value, &count) in histogram.iter().enumerate() {
        let count = f64::from(count);
        if count > 0.0 && below + count >= rank {
            return value as f64 - 0.5 + (rank - below) / count;
        }
        below += count;
    }
    histogram.len() as f64 - 0.5
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolated_median_and_quartiles_of_a_known_sample() {
        // Background 10 with values 9, 10, 11 and a bright marker.
        // A 1-row image sampled at every 4th column: values 8, 9, 10, 11, 12 in turn, with
        // counts 1, 2, 4, 2, 1 per ten samples.
        let cycle = [8u8, 9, 9, 10, 10, 10, 10, 11, 11, 12];
        let pixels: Vec<u8> = (0..4000).map(|i| cycle[(i / 4) % 10]).collect();
        let view = GrayView {
            width: 4000,
            height: 1,
            pixels: &pixels,
        };
        let b = estimate_background(view);
        // 1000 samples; the median rank 500 falls in the middle of value 10's 400 samples,
        // the quartiles (ranks 250 and 750) 150 samples into 9's 200 and 50 into 11's 200.
        assert!((b.level - 10.0).abs() < 1e-12, "{b:?}");
        let q1 = 8.5 + 150.0 / 200.0;
        let q3 = 10.5 + 50.0 / 200.0;
        assert!(
            (b.noise_std - (q3 - q1) / GAUSSIAN_IQR).abs() < 1e-12,
            "{b:?}"
        );
        // 8 σ = 8.90 > 255/32 = 7.97: 10 + 8.90 rounded up.
        assert_eq!(b.auto_threshold::<u8>(), 19);
    }

    #[test]
    fn white_image_has_no_reachable_threshold() {
        let pixels = vec![255u8; 100];
        let view = GrayView {
            width: 10,
            height: 10,
            pixels: &pixels,
        };
        assert_eq!(estimate_background(view).auto_threshold::<u8>(), 255);
    }
}
