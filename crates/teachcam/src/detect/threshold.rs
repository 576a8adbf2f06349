//! Background level and noise of a marker image, from a sparse sample.
//!
//! Model: the background is the bulk of the image (markers cover well under half of it), so
//! its level is the sample median `b` and its noise the median absolute deviation scaled to a
//! Gaussian standard deviation, `σ = 1.4826 · MAD`. Both are robust to the markers (breakdown
//! point 50 %). The sample is every 4th column of every 8th row: about 41 000 values of a
//! 1280×1024 frame, a thirty-second of the image.

use super::{GrayView, Intensity};

/// Column stride of the sample.
const SAMPLE_STEP_X: usize = 4;
/// Row stride of the sample.
const SAMPLE_STEP_Y: usize = 8;
/// Scale from the median absolute deviation to a Gaussian standard deviation.
const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;
/// The automatic threshold sits this many noise deviations above the background.
pub const AUTO_THRESHOLD_SIGMAS: f64 = 8.0;
/// The automatic threshold sits at least this fraction of full scale above the background
/// (noise-free images have σ = 0).
pub const AUTO_THRESHOLD_MIN_CONTRAST: f64 = 1.0 / 32.0;

/// Background level and noise of an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Background {
    /// Median of the sample, in image units.
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
        let margin = (AUTO_THRESHOLD_SIGMAS * self.noise_std).max(AUTO_THRESHOLD_MIN_CONTRAST * full);
        let t = (self.level + margin).ceil();
        if t >= full { P::FULL_SCALE } else { t as u32 }
    }
}

/// Background level and noise from a sparse sample of the image (module docs); zero for an
/// empty image.
#[must_use]
pub fn estimate_background<P: Intensity>(image: GrayView<'_, P>) -> Background {
    let mut sample: Vec<u32> = Vec::with_capacity(
        image.width.div_ceil(SAMPLE_STEP_X) * image.height.div_ceil(SAMPLE_STEP_Y),
    );
    // Offset the sampled rows so that a 1-row image and the middle of small images are seen.
    let first_row = (image.height / 2) % SAMPLE_STEP_Y;
    for y in (first_row..image.height).step_by(SAMPLE_STEP_Y) {
        sample.extend(image.row(y).iter().step_by(SAMPLE_STEP_X).map(|v| v.level()));
    }
    if sample.is_empty() {
        return Background {
            level: 0.0,
            noise_std: 0.0,
        };
    }
    let level = median(&mut sample);
    for v in &mut sample {
        *v = v.abs_diff(level);
    }
    let mad = median(&mut sample);
    Background {
        level: f64::from(level),
        noise_std: MAD_TO_SIGMA * f64::from(mad),
    }
}

/// The lower median of a non-empty slice (reorders it).
fn median(values: &mut [u32]) -> u32 {
    let mid = (values.len() - 1) / 2;
    *values.select_nth_unstable(mid).1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_mad_of_a_known_sample() {
        // Background 10 with values 9, 10, 11 and a bright marker.
        let pixels: Vec<u8> = (0..64 * 64)
            .map(|i| match i % 3 {
                0 => 9,
                1 => 10,
                _ => 11,
            })
            .collect();
        let view = GrayView {
            width: 64,
            height: 64,
            pixels: &pixels,
        };
        let b = estimate_background(view);
        assert_eq!(b.level, 10.0);
        assert!((b.noise_std - MAD_TO_SIGMA).abs() < 1e-12);
        // 8 σ = 11.86 > 255/32 = 7.97
        assert_eq!(b.auto_threshold::<u8>(), 22);
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
