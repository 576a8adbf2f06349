//! What real cameras add to the ideal image: bloom around saturated markers, uneven light,
//! bright streaks, lossy compression.
//!
//! Model (each off unless a scenario asks for it, so the clean scenes stay byte-identical):
//! - **Halo** (bloom): the point-spread function is a mixture
//!   `psf = (1 − f)·G(σ) + f·G(σ_halo)` — the sharp core of the lens plus the wide skirt that
//!   lens flare, sensor crosstalk and the IR filter's scatter put around a bright source. With a
//!   marker brighter than full scale (`marker_dn` > 255) the core clips at 255 and the skirt
//!   stays visible beside it, as on a real PS3 Eye frame (notes/sim-real.md: core clipped at 255
//!   to r ≈ 2.5 px, skirt at 9 % of full scale 2 px past the edge, e-folding over ≈ 2 px).
//! - **Uneven light**: ambient infrared (a window, a lamp) adds a linear gradient to the
//!   background, and the lens loses light towards the corners, `gain = 1 − v·r²` with r = 1 at
//!   a corner (cos⁴-law vignetting to second order).
//! - **Streaks**: specular highlights along an edge of a shiny work object, drawn as bright
//!   line segments with no 3-D counterpart.
//! - **JPEG**: each frame is encoded at a quality and decoded again through the `image` crate,
//!   so 8×8 block artefacts and ringing are baked into the frames (still written as PNG),
//!   like the MPEG-4 part 2 recordings real users bring (same DCT-block quantisation).

use image::GrayImage;
use image::codecs::jpeg::{JpegDecoder, JpegEncoder};

use crate::geometry::Pixel;

/// The wide part of the point-spread function.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Halo {
    /// Fraction of the light spread into the skirt.
    pub fraction: f64,
    /// Standard deviation of the skirt, pixels.
    pub sigma_px: f64,
}

/// Ambient light and vignetting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnevenLight {
    /// Background added at the right edge relative to the centre (the opposite at the left
    /// edge), DN.
    pub gradient_x_dn: f64,
    /// Background added at the bottom edge relative to the centre, DN.
    pub gradient_y_dn: f64,
    /// Fraction of the light lost at the image corners (vignetting).
    pub vignetting: f64,
}

impl UnevenLight {
    /// The image level at pixel (col, row) of a `width`×`height` image where the flat sensor
    /// would read `level_dn` (background plus signal), before noise.
    #[must_use]
    pub fn level(&self, col: u32, row: u32, width: u32, height: u32, level_dn: f64) -> f64 {
        let half_w = 0.5 * f64::from(width.max(2) - 1);
        let half_h = 0.5 * f64::from(height.max(2) - 1);
        let (u, v) = (
            (f64::from(col) - half_w) / half_w,
            (f64::from(row) - half_h) / half_h,
        );
        let ambient = self.gradient_x_dn * u + self.gradient_y_dn * v;
        let r_sq = 0.5 * (u * u + v * v);
        (level_dn + ambient).max(0.0) * (1.0 - self.vignetting * r_sq)
    }
}

/// A bright line segment drawn straight into one camera's image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Streak {
    /// One end, pixels.
    pub from: Pixel,
    /// The other end, pixels.
    pub to: Pixel,
    /// Full width, pixels.
    pub width_px: f64,
    /// Brightness above background, DN.
    pub radiance_dn: f64,
}

impl Streak {
    /// Distance from (x, y) to the segment, pixels.
    #[must_use]
    pub fn distance_px(&self, x: f64, y: f64) -> f64 {
        let (dx, dy) = (self.to.x - self.from.x, self.to.y - self.from.y);
        let length_sq = dx * dx + dy * dy;
        let t = if length_sq > 0.0 {
            (((x - self.from.x) * dx + (y - self.from.y) * dy) / length_sq).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (x - (self.from.x + t * dx)).hypot(y - (self.from.y + t * dy))
    }
}

/// The JPEG codec refused an image (only images wider or taller than 65535 px).
#[derive(Debug, thiserror::Error)]
#[error("cannot jpeg-compress a {width}x{height} image at quality {quality}: {source}")]
pub struct CompressionError {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The quality asked for.
    pub quality: u8,
    /// The codec's reason.
    pub source: image::ImageError,
}

/// The image after a JPEG round trip at `quality` (1–100, clamped).
///
/// # Errors
/// [`CompressionError`] when the codec refuses the image.
pub fn jpeg_round_trip(image: &GrayImage, quality: u8) -> Result<GrayImage, CompressionError> {
    let quality = quality.clamp(1, 100);
    let error = |source| CompressionError {
        width: image.width(),
        height: image.height(),
        quality,
        source,
    };
    let mut bytes = Vec::new();
    JpegEncoder::new_with_quality(&mut bytes, quality)
        .encode_image(image)
        .map_err(error)?;
    let decoder = JpegDecoder::new(std::io::Cursor::new(bytes)).map_err(error)?;
    let decoded = image::DynamicImage::from_decoder(decoder).map_err(error)?;
    Ok(decoded.to_luma8())
}
