//! Marker detection: bright blobs in a grey image, each with a sub-pixel centre (paper §II-A,
//! §IV-A).
//!
//! Model. A reflective sphere lit from the camera images as a bright, nearly uniform ellipse
//! on a dark background, blurred by the lens and the pixels:
//! ```text
//! I(x) = b + a · (1_E ⊛ h)(x) + n(x)     b background, a contrast, E the ellipse,
//!                                        h a symmetric blur, n noise of std σ
//! ```
//! 1. *Threshold.* `T = b + max(8 σ, full scale / 32)`, with `b` the median and `σ` the
//!    median absolute deviation × 1.4826 of a sparse sample of the image (markers cover a
//!    small part of it). At 8 σ, a Gaussian background pixel exceeds `T` with probability
//!    6·10⁻¹⁶, so noise makes no blob. Overridable ([`Threshold::Fixed`]).
//! 2. *Components.* One pass over the image collects the runs of pixels `> T` row by row
//!    (skipping dark stretches 64 pixels at a time) and joins 8-connected runs with a
//!    union–find ([`components`]); nothing else touches the whole image.
//! 3. *Centre*, per blob ([`CenterMethod`]):
//!    - `SmallestCircle`: the centre of the smallest circle enclosing the blob's pixel centres
//!      (Welzl 1991), the paper's "SmallestCircle" choice (§IV-A, 0.15 px repeatability);
//!    - `Centroid`: `Σ (I − b) x / Σ (I − b)` over the blob's pixels;
//!    - `Refined` (the default): the same centroid over a disc around the blob that holds the
//!      whole blurred edge ([`measure`]; weights `I − b`, not clipped, so noise adds no bias).
//!      The centroid of `1_E ⊛ h` is the centre of `E` for any symmetric `h`, so blur adds no
//!      bias either.
//!      With a [`SphereProjection`], the ellipse centre is then moved to the projection of the
//!      sphere's centre ([`sphere`]).
//! 4. *Filters.* Area limits (derivable from the marker diameter, a camera and a range of
//!    working distances, [`DetectConfig::for_marker`]) and a roundness floor: two markers whose
//!    images touch form a blob that is long (moment axis ratio) and fills its enclosing circle
//!    badly, so it never gets one wrong centre. Such a blob is labelled again at half its
//!    contrast ([`measure::split`]); markers that come apart there with at least 2 px between
//!    their edges are measured each within its own half of the gap, closer ones are rejected.
//!    A blob touching the image border is cut off, so it is rejected too.
//!
//! Sources: Cordier et al., §II-A and §IV-A (`paper.md`); Welzl, *Smallest enclosing disks*,
//! 1991; the centre bias of a sphere's image: Matsuoka & Maruyama, *Eccentricity on an image
//! caused by projection of a circle and a sphere*, ISPRS 2016.

pub mod circle;
pub mod components;
pub mod learn;
pub mod measure;
pub mod repeatability;
pub mod sketch;
pub mod sphere;
pub mod sets;
pub mod threshold;

use image::{DynamicImage, ImageBuffer, Luma};

use crate::camera::Camera;
use crate::geometry::Pixel;

pub use circle::{Circle, smallest_enclosing_circle};
pub use repeatability::{MarkerSpread, RepeatabilityConfig, repeatability};
pub use sets::{CameraDetections, DetectedSet};
pub use sphere::{SphereRange, sphere_center_pixel};
pub use threshold::{Background, estimate_background};

/// A grey pixel type the detector reads: 8- or 16-bit.
pub trait Intensity: image::Primitive + Ord + Send + Sync + 'static {
    /// Full scale of the type (255 or 65535).
    const FULL_SCALE: u32;
    /// The value as an unsigned integer.
    fn level(self) -> u32;
}

impl Intensity for u8 {
    const FULL_SCALE: u32 = 255;
    #[inline]
    fn level(self) -> u32 {
        u32::from(self)
    }
}

impl Intensity for u16 {
    const FULL_SCALE: u32 = 65535;
    #[inline]
    fn level(self) -> u32 {
        u32::from(self)
    }
}

/// A borrowed grey image: `width × height` pixels, row-major, no padding.
#[derive(Debug, Clone, Copy)]
pub struct GrayView<'a, P> {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width × height` values, row after row.
    pub pixels: &'a [P],
}

impl<'a, P: Intensity> GrayView<'a, P> {
    /// A view of an `image` buffer (8-bit `GrayImage` or 16-bit `ImageBuffer<Luma<u16>, _>`).
    #[must_use]
    pub fn new(image: &'a ImageBuffer<Luma<P>, Vec<P>>) -> Self {
        Self {
            width: image.width() as usize,
            height: image.height() as usize,
            pixels: image.as_raw(),
        }
    }

    /// Row `y`.
    #[inline]
    fn row(&self, y: usize) -> &'a [P] {
        &self.pixels[y * self.width..(y + 1) * self.width]
    }
}

/// How the foreground threshold is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Threshold {
    /// From the image: background median plus `max(8 σ, full scale / 32)` (module docs).
    Auto,
    /// A pixel is foreground when its value is strictly above this level (OpenCV's
    /// `THRESH_BINARY`), in the image's own units (0–255 or 0–65535).
    Fixed(u32),
    /// This many image units above each frame's background median, and never below
    /// [`Threshold::Auto`]'s level: the threshold [`learn`] measures from the markers'
    /// contrast, following the background from frame to frame.
    AboveBackground(f64),
}

impl Threshold {
    /// The level a pixel must be strictly above in an image of type `P` with `background`.
    #[must_use]
    pub fn level<P: Intensity>(self, background: &Background) -> u32 {
        match self {
            Self::Auto => background.auto_threshold::<P>(),
            Self::Fixed(level) => level,
            Self::AboveBackground(contrast) => background.threshold_above::<P>(contrast),
        }
    }
}

/// Which estimate of a blob's centre [`Blob::center`] holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CenterMethod {
    /// The paper's: centre of the smallest circle enclosing the blob's pixels.
    SmallestCircle,
    /// Background-subtracted intensity-weighted centroid of the blob's pixels.
    Centroid,
    /// Background-subtracted centroid over a window holding the whole blurred edge, moved from
    /// the ellipse centre to the sphere centre's projection when a [`SphereProjection`] is set.
    #[default]
    Refined,
}

impl std::str::FromStr for CenterMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "smallest-circle" => Ok(Self::SmallestCircle),
            "centroid" => Ok(Self::Centroid),
            "refined" => Ok(Self::Refined),
            other => Err(format!(
                "unknown centre method '{other}' (expected smallest-circle, centroid or refined)"
            )),
        }
    }
}

impl std::fmt::Display for CenterMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::SmallestCircle => "smallest-circle",
            Self::Centroid => "centroid",
            Self::Refined => "refined",
        })
    }
}

/// What the detector needs to move a blob's centre to the projection of a sphere's centre.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereProjection {
    /// The camera that took the image (intrinsics and distortion are used).
    pub camera: Camera,
    /// Radius of the marker spheres, millimetres.
    pub marker_radius_mm: f64,
}

/// Detector options. `Default` suits the paper's setup with no prior knowledge of the markers.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectConfig {
    /// Foreground threshold. Default: [`Threshold::Auto`], from the image itself.
    pub threshold: Threshold,
    /// Smallest blob kept, pixels above threshold. Default 4: smaller spots carry too few
    /// pixels for a sub-pixel centre.
    pub min_area_px: usize,
    /// Largest blob kept, pixels above threshold. Default 40 000 (a radius of about 110 px,
    /// a 10 mm sphere at 80 mm from the paper's 1790 px lens).
    pub max_area_px: usize,
    /// Smallest roundness kept ([`Blob::roundness`], 1 for a disc). Default 0.75: a sphere's
    /// image at the corner of the paper's lens has 0.9; two touching equal discs have 0.5.
    pub min_roundness: f64,
    /// The most connected regions above threshold an image may hold before it is refused as
    /// noise or a wrong threshold. Default 20 000: far beyond any marker scene, and a bound on
    /// work and memory.
    pub max_regions: usize,
    /// Centre estimate. Default [`CenterMethod::Refined`], the most accurate.
    pub method: CenterMethod,
    /// How far beyond a blob's flux radius the `Refined` centroid sums, pixels. Default 2: it
    /// holds the blurred edge (a Gaussian blur of σ up to 1 px) and little more; on discs with
    /// 0.8 px blur and 2-unit noise, 1.5–2 px gave the smallest errors (0.5 px: 3.5× worse,
    /// 4 px: 1.5× worse, from more noise pixels).
    pub window_margin_px: f64,
    /// Noise variance (image units²) added per image unit of signal above the background:
    /// shot noise, `1 / gain` in electrons per unit. Used only for [`Blob::center_std_px`].
    /// Default 0: unknown without the camera's data sheet, so the prediction counts the
    /// background noise alone and is low on bright blobs.
    pub shot_noise_per_level: f64,
    /// Camera and marker size for the sphere-centre correction of [`CenterMethod::Refined`].
    /// Default `None`: centres stay at the ellipse centre (off by at most a few hundredths of a
    /// pixel at the paper's 1 m, see [`sphere`]).
    pub sphere: Option<SphereProjection>,
}

impl Default for DetectConfig {
    fn default() -> Self {
        Self {
            threshold: Threshold::Auto,
            min_area_px: 4,
            max_area_px: 40_000,
            min_roundness: 0.75,
            max_regions: 20_000,
            method: CenterMethod::Refined,
            window_margin_px: 2.0,
            shot_noise_per_level: 0.0,
            sphere: None,
        }
    }
}

impl DetectConfig {
    /// Limits for markers of `marker_diameter_mm` seen by `camera` from `near_mm` to `far_mm`
    /// (distance from the camera centre): the image radius is `f · R / d`; the area limits
    /// allow for half a radius-pixel of blur and threshold either way, and the sphere
    /// correction is enabled.
    #[must_use]
    pub fn for_marker(camera: &Camera, marker_diameter_mm: f64, near_mm: f64, far_mm: f64) -> Self {
        let f = 0.5 * (camera.intrinsics.fx + camera.intrinsics.fy);
        let radius_mm = 0.5 * marker_diameter_mm;
        let largest_px = f * radius_mm / near_mm.max(radius_mm) + 1.5;
        let smallest_px = (f * radius_mm / far_mm.max(radius_mm) - 1.0).max(1.0);
        let area = |r: f64| std::f64::consts::PI * r * r;
        Self {
            min_area_px: (area(smallest_px).floor() as usize).max(1),
            max_area_px: area(largest_px).ceil() as usize,
            sphere: Some(SphereProjection {
                camera: camera.clone(),
                marker_radius_mm: radius_mm,
            }),
            ..Self::default()
        }
    }
}

/// An axis-aligned box of pixels, inclusive bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelBox {
    /// Leftmost column.
    pub x_min: u32,
    /// Top row.
    pub y_min: u32,
    /// Rightmost column.
    pub x_max: u32,
    /// Bottom row.
    pub y_max: u32,
}

impl PixelBox {
    /// Columns covered.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.x_max - self.x_min + 1
    }

    /// Rows covered.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.y_max - self.y_min + 1
    }
}

/// One detected marker image.
#[derive(Debug, Clone, PartialEq)]
pub struct Blob {
    /// Centre by the configured [`CenterMethod`], pixels.
    pub center: Pixel,
    /// Pixels above threshold.
    pub area_px: usize,
    /// Radius of a uniform disc with the blob's background-subtracted flux and plateau level,
    /// `sqrt(Σ (I − b) / (π (plateau − b)))`: blur-independent, pixels.
    pub radius_px: f64,
    /// `min(moment axis ratio, area / area of the enclosing circle)`: 1 for a disc, about 0.5
    /// for two touching equal discs.
    pub roundness: f64,
    /// Predicted per-axis standard deviation of the centre, pixels: the background noise
    /// (estimated from the image) and [`DetectConfig::shot_noise_per_level`] propagated
    /// through the centroid (0 on a noise-free image). For `SmallestCircle`, the `Centroid`
    /// prediction: the circle has no noise model, and scatters about ten times more.
    pub center_std_px: f64,
    /// Smallest box holding the blob's pixels.
    pub bounding_box: PixelBox,
    /// Brightest value in the blob.
    pub peak: u32,
    /// Mean value of the blob's pixels.
    pub mean: f64,
}

/// Why an image cannot be searched for markers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DetectError {
    /// Too many separate regions above the threshold: noise or a threshold below the
    /// background.
    #[error(
        "more than {limit} separate regions above threshold {threshold}: the image is noise or the threshold is too low"
    )]
    TooManyRegions {
        /// The configured cap ([`DetectConfig::max_regions`]).
        limit: usize,
        /// The threshold used.
        threshold: u32,
    },
    /// The pixel buffer does not hold `width × height` values.
    #[error("image buffer holds {len} values, not {width} x {height}")]
    BadBuffer {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
        /// Values in the buffer.
        len: usize,
    },
    /// A sketched frame asked for a detection that may read pixels it did not keep.
    #[error(
        "internal: a frame sketched above level {kept_level} was asked for a detection at level {level} or with a wider window"
    )]
    Sketch {
        /// The detection's threshold.
        level: u32,
        /// The level the sketch kept every pixel above.
        kept_level: u32,
    },
}

/// Blobs of an 8- or 16-bit grey image, in raster order of their first pixel.
///
/// # Errors
/// [`DetectError::TooManyRegions`] when the image holds more than
/// [`DetectConfig::max_regions`] regions above threshold.
pub fn detect<P: Intensity>(
    image: &ImageBuffer<Luma<P>, Vec<P>>,
    cfg: &DetectConfig,
) -> Result<Vec<Blob>, DetectError> {
    detect_view(GrayView::new(image), cfg)
}

/// Blobs of any decoded image: 8- and 16-bit grey as they are, colour converted to grey
/// (`image`'s Rec. 709 luma), other depths to 16-bit grey.
///
/// # Errors
/// As [`detect`].
pub fn detect_dynamic(image: &DynamicImage, cfg: &DetectConfig) -> Result<Vec<Blob>, DetectError> {
    match image {
        DynamicImage::ImageLuma8(gray) => detect(gray, cfg),
        DynamicImage::ImageLuma16(gray) => detect(gray, cfg),
        DynamicImage::ImageLumaA8(_) | DynamicImage::ImageRgb8(_) | DynamicImage::ImageRgba8(_) => {
            detect(&image.to_luma8(), cfg)
        }
        _ => detect(&image.to_luma16(), cfg),
    }
}

/// Blobs of a borrowed grey image; see [`detect`].
///
/// # Errors
/// As [`detect`], and [`DetectError::BadBuffer`] when the buffer's length is not
/// `width × height`.
pub fn detect_view<P: Intensity>(
    image: GrayView<'_, P>,
    cfg: &DetectConfig,
) -> Result<Vec<Blob>, DetectError> {
    let regions = region_blobs(image, None, cfg, cfg.min_roundness)?;
    Ok(gated(&regions, cfg.min_roundness))
}

/// [`detect_view`] with the image's background given (a [`sketch::Sketch`]'s).
pub(crate) fn detect_view_with<P: Intensity>(
    image: GrayView<'_, P>,
    background: &Background,
    cfg: &DetectConfig,
) -> Result<Vec<Blob>, DetectError> {
    let regions = region_blobs(image, Some(background), cfg, cfg.min_roundness)?;
    Ok(gated(&regions, cfg.min_roundness))
}

/// A frame's blobs for every roundness floor from the configuration's
/// ([`DetectConfig::min_roundness`]) up, so that the floor can be chosen after detection from
/// the blobs themselves without detecting the image again: each region measured whole and
/// split ([`measure::split`]). The floor changes the result at two places only, both kept here:
/// a whole blob below it is split instead, and split parts below it are left out.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RoundnessChoices {
    floor: f64,
    regions: Vec<RegionBlobs>,
}

impl RoundnessChoices {
    /// The lowest floor the choices hold: the configuration's.
    #[must_use]
    pub fn floor(&self) -> f64 {
        self.floor
    }

    /// The blobs [`detect`] gives with [`DetectConfig::min_roundness`] set to `min_roundness`,
    /// the same blobs in the same order; `None` below [`Self::floor`] (blobs less round than
    /// the floor were not kept).
    #[must_use]
    pub fn at(&self, min_roundness: f64) -> Option<Vec<Blob>> {
        (min_roundness >= self.floor).then(|| gated(&self.regions, min_roundness))
    }
}

/// One region's blob measured whole and, where it may be needed, the parts it splits into.
#[derive(Debug, Clone, PartialEq)]
struct RegionBlobs {
    /// The region as one blob; `None` when it is too large or has no flux.
    whole: Option<Blob>,
    /// [`measure::split`]'s parts (each at least as round as the detection's floor); computed
    /// when `whole` is missing or less round than the `split_below` it was detected with.
    parts: Vec<Blob>,
}

/// What [`detect`] keeps of `regions` at a roundness floor: a region's whole blob when it is
/// that round, else its parts that are.
fn gated(regions: &[RegionBlobs], min_roundness: f64) -> Vec<Blob> {
    let mut blobs = Vec::with_capacity(regions.len());
    for region in regions {
        match &region.whole {
            Some(blob) if blob.roundness >= min_roundness => blobs.push(blob.clone()),
            // Not one round marker: perhaps several whose images merged.
            _ => blobs.extend(
                region
                    .parts
                    .iter()
                    .filter(|p| p.roundness >= min_roundness)
                    .cloned(),
            ),
        }
    }
    blobs
}

/// The choices of every roundness floor from `cfg`'s up; see [`RoundnessChoices`].
///
/// # Errors
/// As [`detect_view`].
pub fn detect_choices<P: Intensity>(
    image: GrayView<'_, P>,
    cfg: &DetectConfig,
) -> Result<RoundnessChoices, DetectError> {
    Ok(RoundnessChoices {
        floor: cfg.min_roundness,
        regions: region_blobs(image, None, cfg, f64::INFINITY)?,
    })
}

/// [`detect_choices`] with the image's background given (a [`sketch::Sketch`]'s).
pub(crate) fn detect_choices_with<P: Intensity>(
    image: GrayView<'_, P>,
    background: &Background,
    cfg: &DetectConfig,
) -> Result<RoundnessChoices, DetectError> {
    Ok(RoundnessChoices {
        floor: cfg.min_roundness,
        regions: region_blobs(image, Some(background), cfg, f64::INFINITY)?,
    })
}

/// Each kept region's blob, and its split parts where the whole blob is missing or less round
/// than `split_below`; the background estimated from `image` unless given.
fn region_blobs<P: Intensity>(
    image: GrayView<'_, P>,
    background: Option<&Background>,
    cfg: &DetectConfig,
    split_below: f64,
) -> Result<Vec<RegionBlobs>, DetectError> {
    if image.width.checked_mul(image.height) != Some(image.pixels.len()) {
        return Err(DetectError::BadBuffer {
            width: image.width,
            height: image.height,
            len: image.pixels.len(),
        });
    }
    if image.pixels.is_empty() {
        return Ok(Vec::new());
    }
    let background = background
        .copied()
        .unwrap_or_else(|| estimate_background(image));
    let threshold = cfg.threshold.level::<P>(&background);
    if threshold >= P::FULL_SCALE {
        return Ok(Vec::new());
    }
    let regions = components::label(image, threshold, cfg.max_regions).ok_or(
        DetectError::TooManyRegions {
            limit: cfg.max_regions,
            threshold,
        },
    )?;
    let margin_px = sketch::window_growth_px(cfg);
    let windows = measure::exclusive_windows(image, &regions, margin_px);
    let mut kept = Vec::with_capacity(regions.len());
    for (region, window) in regions.iter().zip(windows) {
        if region.area < cfg.min_area_px || region.touches_border(image.width, image.height) {
            continue;
        }
        let whole = (region.area <= cfg.max_area_px)
            .then(|| measure::measure(image, region, window, &background, cfg))
            .flatten();
        let parts = match &whole {
            Some(blob) if blob.roundness >= split_below => Vec::new(),
            _ => measure::split(image, region, &background, cfg),
        };
        kept.push(RegionBlobs { whole, parts });
    }
    Ok(kept)
}
