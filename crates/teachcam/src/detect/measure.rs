//! Per-blob measurements: centres by each method, size, roundness and predicted noise.
//!
//! For intensities `I`, background `b` and noise `σ`, over a set `S` of pixels at `x_i`:
//! ```text
//! centroid  c = Σ w_i x_i / Σ w_i,        w_i = I_i − b
//! noise     var(c_x) = Σ var(I_i) (x_i − c_x)² / (Σ w_i)²,  var(I_i) = σ² + g w_i
//!           (background noise σ, shot noise g per unit of signal; per-axis std reported)
//! ```
//! `Centroid` sums over the blob's own pixels, which cuts the blurred edge at the threshold and
//! so depends on where the pixel grid falls. `Refined` sums over a disc around the blob, of the
//! blob's flux radius plus [`DetectConfig::window_margin_px`], centred on the `Centroid` and
//! then on its own first answer: the blurred edge below the threshold counts too, and the disc
//! (not the bounding box) keeps the number of pure-noise pixels small. The weights are not
//! clipped at zero, which would turn noise into a bias. The disc is cut to the region's
//! bounding box grown by the margin plus one pixel, used only when that box lies inside the
//! image and meets no other region; otherwise `Refined` falls back to the blob's own pixels.

use super::components::Region;
use super::sphere::{SphereRange, sphere_center_pixel};
use super::{Background, Blob, CenterMethod, DetectConfig, GrayView, Intensity, PixelBox};
use crate::geometry::Pixel;

/// Passes of the `Refined` disc window: the second one centres the window on the first's
/// answer; more change nothing measurable.
const REFINE_STEPS: usize = 2;

/// Pixels counted in the plateau of a blob: at least this fraction of the way from the
/// background to the peak.
const PLATEAU_FRACTION: f64 = 0.9;

/// The `Refined` window of each region, its bounding box grown by `margin_px`; `None` where
/// it leaves the image or meets another region's bounding box.
#[must_use]
pub fn exclusive_windows<P: Intensity>(
    image: GrayView<'_, P>,
    regions: &[Region],
    margin_px: u32,
) -> Vec<Option<PixelBox>> {
    let grown: Vec<Option<PixelBox>> = regions
        .iter()
        .map(|r| {
            let b = r.bounds;
            let (w, h) = (image.width as u32, image.height as u32);
            let inside = b.x_min >= margin_px
                && b.y_min >= margin_px
                && b.x_max + margin_px < w
                && b.y_max + margin_px < h;
            inside.then(|| PixelBox {
                x_min: b.x_min - margin_px,
                y_min: b.y_min - margin_px,
                x_max: b.x_max + margin_px,
                y_max: b.y_max + margin_px,
            })
        })
        .collect();
    // Sweep over regions by left edge: a window is lost when any other region's box enters it.
    let mut by_left: Vec<usize> = (0..regions.len()).collect();
    by_left.sort_by_key(|&i| regions[i].bounds.x_min);
    let widest = regions.iter().map(|r| r.bounds.width()).max().unwrap_or(0);
    let mut exclusive = grown.clone();
    for (k, &i) in by_left.iter().enumerate() {
        let Some(window) = grown[i] else { continue };
        // Only regions starting at most `widest` left of the window and before its right edge
        // can overlap it: scan both directions from `k` within that band.
        let overlaps = |j: usize| {
            let b = regions[j].bounds;
            j != i
                && b.x_min <= window.x_max
                && b.x_max >= window.x_min
                && b.y_min <= window.y_max
                && b.y_max >= window.y_min
        };
        let later = by_left[k + 1..]
            .iter()
            .take_while(|&&j| regions[j].bounds.x_min <= window.x_max)
            .any(|&j| overlaps(j));
        let earlier = by_left[..k]
            .iter()
            .rev()
            .take_while(|&&j| regions[j].bounds.x_min + widest > window.x_min)
            .any(|&j| overlaps(j));
        if later || earlier {
            exclusive[i] = None;
        }
    }
    exclusive
}

/// The pixel noise model: variance `background_std² + shot_per_level · (I − b)`.
#[derive(Debug, Clone, Copy)]
struct Noise {
    background_std: f64,
    shot_per_level: f64,
}

/// Sums of weights and weighted coordinates, relative to an origin for accuracy.
#[derive(Debug, Default, Clone, Copy)]
struct Moments {
    count: f64,
    w: f64,
    wx: f64,
    wy: f64,
    x: f64,
    y: f64,
    xx: f64,
    yy: f64,
    xy: f64,
    wxx: f64,
    wyy: f64,
}

impl Moments {
    /// Adds a row segment of `n` pixels starting at column `x0` of row `y`, whose weights sum
    /// to `w`, whose weights times their offset `k` from `x0` sum to `wx`, and times `k²` to
    /// `wx2`: the sums of the coordinates over the segment are arithmetic series.
    fn add_row(&mut self, x0: f64, n: f64, y: f64, w: f64, wx: f64, wx2: f64) {
        // Σ_{k<n} k = n(n−1)/2,  Σ_{k<n} k² = (n−1)n(2n−1)/6
        let sum_k = 0.5 * n * (n - 1.0);
        let sum_k2 = (n - 1.0) * n * (2.0 * n - 1.0) / 6.0;
        self.count += n;
        self.w += w;
        self.wx += wx + x0 * w;
        self.wy += y * w;
        self.x += n * x0 + sum_k;
        self.y += n * y;
        self.xx += n * x0 * x0 + 2.0 * x0 * sum_k + sum_k2;
        self.yy += n * y * y;
        self.xy += y * (n * x0 + sum_k);
        self.wxx += x0 * x0 * w + 2.0 * x0 * wx + wx2;
        self.wyy += y * y * w;
    }

    /// The weighted centroid and its predicted per-axis standard deviation for pixel noise
    /// of variance `σ² + g (I − b)` (background noise `σ`, shot noise `g` per unit of signal).
    fn centroid(&self, noise: &Noise) -> Option<(f64, f64, f64)> {
        if self.w.is_nan() || self.w <= 0.0 {
            return None;
        }
        let (cx, cy) = (self.wx / self.w, self.wy / self.w);
        let spread_x = self.xx - 2.0 * cx * self.x + self.count * cx * cx;
        let spread_y = self.yy - 2.0 * cy * self.y + self.count * cy * cy;
        let weighted_x = self.wxx - 2.0 * cx * self.wx + cx * cx * self.w;
        let weighted_y = self.wyy - 2.0 * cy * self.wy + cy * cy * self.w;
        let variance = noise.background_std.powi(2) * 0.5 * (spread_x + spread_y)
            + noise.shot_per_level * 0.5 * (weighted_x + weighted_y);
        Some((cx, cy, variance.max(0.0).sqrt() / self.w))
    }
}

/// The background-subtracted centroid over the pixels of `window` within `radius_px` of a
/// centre, moved to the result and summed again ([`REFINE_STEPS`] times), with its predicted
/// noise and the flux `Σ (I − b)`; coordinates relative to `origin`.
fn disc_centroid<P: Intensity>(
    image: GrayView<'_, P>,
    window: PixelBox,
    origin: (f64, f64),
    start: (f64, f64),
    radius_px: f64,
    background: &Background,
    noise: &Noise,
) -> Option<((f64, f64, f64), f64)> {
    let mut center = start;
    let mut result = None;
    let r2 = radius_px * radius_px;
    for _ in 0..REFINE_STEPS {
        let mut m = Moments::default();
        for y in window.y_min..=window.y_max {
            let dy = f64::from(y) - origin.1;
            let reach2 = r2 - (dy - center.1).powi(2);
            if reach2 < 0.0 {
                continue;
            }
            // Columns of this row inside the disc, cut to the window.
            let reach = reach2.sqrt();
            let x_lo = (center.0 + origin.0 - reach)
                .ceil()
                .max(f64::from(window.x_min)) as u32;
            let x_hi = (center.0 + origin.0 + reach)
                .floor()
                .min(f64::from(window.x_max)) as u32;
            if x_lo > x_hi {
                continue;
            }
            let row = &image.row(y as usize)[x_lo as usize..=x_hi as usize];
            let (mut w, mut wx, mut wx2) = (0.0, 0.0, 0.0);
            for (k, v) in row.iter().enumerate() {
                let v = f64::from(v.level()) - background.level;
                let k = k as f64;
                w += v;
                wx += v * k;
                wx2 += v * k * k;
            }
            m.add_row(f64::from(x_lo) - origin.0, row.len() as f64, dy, w, wx, wx2);
        }
        let c = m.centroid(noise)?;
        center = (c.0, c.1);
        result = Some((c, m.w));
    }
    result
}

/// The blob of a region, `None` when it has no flux above the background.
#[must_use]
pub fn measure<P: Intensity>(
    image: GrayView<'_, P>,
    region: &Region,
    window: Option<PixelBox>,
    background: &Background,
    cfg: &DetectConfig,
) -> Option<Blob> {
    let b = background.level;
    let origin_x = f64::from(region.bounds.x_min);
    let origin_y = f64::from(region.bounds.y_min);

    // Shape (unweighted) and intensity moments over the blob's own pixels.
    let mut own = Moments::default();
    let mut peak = 0u32;
    let mut total = 0.0;
    let mut endpoints = Vec::with_capacity(2 * region.runs.len());
    for run in &region.runs {
        let y = run.y as usize;
        let row = image.row(y);
        let dy = f64::from(run.y) - origin_y;
        let (mut sum, mut sum_k, mut sum_k2) = (0u64, 0u64, 0u64);
        for (k, v) in row[run.x_start as usize..=run.x_end as usize]
            .iter()
            .enumerate()
        {
            let v = v.level();
            peak = peak.max(v);
            sum += u64::from(v);
            sum_k += k as u64 * u64::from(v);
            sum_k2 += (k * k) as u64 * u64::from(v);
        }
        // Weights `v − b`: Σ (v − b) = Σ v − n b, Σ k (v − b) = Σ k v − b n (n − 1) / 2 and
        // Σ k² (v − b) = Σ k² v − b (n − 1) n (2n − 1) / 6.
        let n = run.len() as f64;
        total += sum as f64;
        own.add_row(
            f64::from(run.x_start) - origin_x,
            n,
            dy,
            sum as f64 - n * b,
            sum_k as f64 - b * 0.5 * n * (n - 1.0),
            sum_k2 as f64 - b * (n - 1.0) * n * (2.0 * n - 1.0) / 6.0,
        );
        endpoints.push(Pixel::new(f64::from(run.x_start), f64::from(run.y)));
        if run.x_end != run.x_start {
            endpoints.push(Pixel::new(f64::from(run.x_end), f64::from(run.y)));
        }
    }
    let area = region.area as f64;

    // Plateau level for the radius.
    let plateau_floor = b + PLATEAU_FRACTION * (f64::from(peak) - b);
    let (mut plateau_sum, mut plateau_count) = (0.0_f64, 0.0_f64);
    for run in &region.runs {
        for &v in &image.row(run.y as usize)[run.x_start as usize..=run.x_end as usize] {
            let v = f64::from(v.level());
            if v >= plateau_floor {
                plateau_sum += v;
                plateau_count += 1.0;
            }
        }
    }
    let plateau = plateau_sum / plateau_count.max(1.0);

    let circle = super::circle::smallest_enclosing_circle(&endpoints)?;
    let noise = Noise {
        background_std: background.noise_std,
        shot_per_level: cfg.shot_noise_per_level.max(0.0),
    };
    let (own_x, own_y, own_std) = own.centroid(&noise)?;
    let (refined, flux) = match window {
        Some(w) if plateau > b => {
            let radius_px = (own.w / (std::f64::consts::PI * (plateau - b))).sqrt();
            disc_centroid(
                image,
                w,
                (origin_x, origin_y),
                (own_x, own_y),
                radius_px + cfg.window_margin_px,
                background,
                &noise,
            )
            .unwrap_or(((own_x, own_y, own_std), own.w))
        }
        _ => ((own_x, own_y, own_std), own.w),
    };
    // A centroid outside the blob's own box means the weights were not the blob's (a window
    // on noise, a blob no brighter than what surrounds it): fall back to the blob's own pixels,
    // then to its enclosing circle, rather than report a centre away from the blob.
    let bounds = region.bounds;
    let inside = |x: f64, y: f64| {
        let (px, py) = (x + origin_x, y + origin_y);
        px >= f64::from(bounds.x_min) - 0.5
            && px <= f64::from(bounds.x_max) + 0.5
            && py >= f64::from(bounds.y_min) - 0.5
            && py <= f64::from(bounds.y_max) + 0.5
    };
    let own_inside = inside(own_x, own_y);
    let (refined, flux) = if inside(refined.0, refined.1) {
        (refined, flux)
    } else if own_inside {
        ((own_x, own_y, own_std), own.w)
    } else {
        (
            (
                circle.center.x - origin_x,
                circle.center.y - origin_y,
                own_std,
            ),
            own.w,
        )
    };
    let (own_x, own_y) = if own_inside {
        (own_x, own_y)
    } else {
        (circle.center.x - origin_x, circle.center.y - origin_y)
    };
    let radius_px = if plateau > b {
        (flux / (std::f64::consts::PI * (plateau - b))).sqrt()
    } else {
        (area / std::f64::consts::PI).sqrt()
    };

    let to_pixel = |x: f64, y: f64| Pixel::new(x + origin_x, y + origin_y);
    let (center, center_std_px) = match cfg.method {
        CenterMethod::SmallestCircle => (circle.center, own_std),
        CenterMethod::Centroid => (to_pixel(own_x, own_y), own_std),
        CenterMethod::Refined => {
            let ellipse_center = to_pixel(refined.0, refined.1);
            let center = cfg.sphere.as_ref().map_or(ellipse_center, |sphere| {
                sphere_center_pixel(
                    &sphere.camera,
                    &ellipse_center,
                    sphere.marker_radius_mm,
                    SphereRange::ApparentRadiusPx(radius_px),
                )
                .unwrap_or(ellipse_center)
            });
            (center, refined.2)
        }
    };

    Some(Blob {
        center,
        area_px: region.area,
        radius_px,
        roundness: roundness(&own, area, circle.radius_px),
        center_std_px,
        bounding_box: region.bounds,
        peak,
        mean: total / area,
    })
}

/// `min(axis ratio, fill)`: the square root of the ratio of the eigenvalues of the pixels'
/// covariance (each pixel a unit square, variance 1/12 per axis), and the area over the area of
/// the smallest enclosing circle of the pixel centres, at most 1.
fn roundness(own: &Moments, area: f64, enclosing_radius_px: f64) -> f64 {
    let (mx, my) = (own.x / area, own.y / area);
    let sxx = own.xx / area - mx * mx + 1.0 / 12.0;
    let syy = own.yy / area - my * my + 1.0 / 12.0;
    let sxy = own.xy / area - mx * my;
    let half_trace = 0.5 * (sxx + syy);
    let gap = (0.25 * (sxx - syy).powi(2) + sxy * sxy).sqrt();
    let axis_ratio = ((half_trace - gap).max(0.0) / (half_trace + gap)).sqrt();
    let fill = if enclosing_radius_px > 0.0 {
        (area / (std::f64::consts::PI * enclosing_radius_px * enclosing_radius_px)).min(1.0)
    } else {
        1.0
    };
    axis_ratio.min(fill)
}

/// Level, as a fraction of the way from the background to a merged region's peak, at which
/// [`split`] separates the markers it holds: where a blurred disc's edge lies.
const SPLIT_LEVEL: f64 = 0.5;

/// The smallest margin, pixels, with which a marker split off a merged region is still
/// measured: below it the `Refined` disc would lose too much of the blurred edge (a margin of
/// 0.5 px tripled the error on blurred discs), so the pair stays rejected.
const SPLIT_MIN_MARGIN_PX: f64 = 1.0;

/// The markers of a region that holds several (images that nearly touch and merged at the
/// detection threshold): the region's own pixels are labelled again at `SPLIT_LEVEL` (half its contrast), and
/// each part is measured with a `Refined` disc that stops halfway between its edge and the
/// nearest other part's, so that no part's disc holds another's edge. Parts closer than
/// `2 × SPLIT_MIN_MARGIN_PX` to another, and parts that fail the size or roundness limits,
/// are left out; a region that does not fall apart gives nothing.
#[must_use]
pub fn split<P: Intensity>(
    image: GrayView<'_, P>,
    region: &Region,
    background: &Background,
    cfg: &DetectConfig,
) -> Vec<Blob> {
    let b = region.bounds;
    let (w, h) = (b.width() as usize, b.height() as usize);
    // The region's own pixels, zero elsewhere in its box, so that nothing else is relabelled.
    let mut mask = vec![P::zero(); w * h];
    let mut peak = 0u32;
    for run in &region.runs {
        let row = image.row(run.y as usize);
        let offset = (run.y - b.y_min) as usize * w;
        for x in run.x_start..=run.x_end {
            let v = row[x as usize];
            peak = peak.max(v.level());
            mask[offset + (x - b.x_min) as usize] = v;
        }
    }
    let level = background.level + SPLIT_LEVEL * (f64::from(peak) - background.level);
    let patch = GrayView {
        width: w,
        height: h,
        pixels: &mask,
    };
    let Some(parts) = super::components::label(patch, level.max(0.0) as u32, 64) else {
        return Vec::new();
    };
    if parts.len() < 2 {
        return Vec::new();
    }
    // Back to image coordinates.
    let parts: Vec<Region> = parts
        .into_iter()
        .map(|mut p| {
            for run in &mut p.runs {
                run.y += b.y_min;
                run.x_start += b.x_min;
                run.x_end += b.x_min;
            }
            p.bounds = PixelBox {
                x_min: p.bounds.x_min + b.x_min,
                y_min: p.bounds.y_min + b.y_min,
                x_max: p.bounds.x_max + b.x_min,
                y_max: p.bounds.y_max + b.y_min,
            };
            p
        })
        .collect();
    // First pass: each part's own centroid and flux radius (what the disc is built from).
    let own_cfg = DetectConfig {
        method: CenterMethod::Centroid,
        sphere: None,
        ..cfg.clone()
    };
    let first: Vec<Option<Blob>> = parts
        .iter()
        .map(|p| measure(image, p, None, background, &own_cfg))
        .collect();
    let mut blobs = Vec::new();
    for (i, part) in parts.iter().enumerate() {
        let Some(own) = &first[i] else { continue };
        let gap = first
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .filter_map(|(_, o)| o.as_ref())
            .map(|o| o.center.distance(&own.center) - o.radius_px - own.radius_px)
            .fold(f64::INFINITY, f64::min);
        let margin_px = (0.5 * gap).min(cfg.window_margin_px);
        if margin_px < SPLIT_MIN_MARGIN_PX
            || part.area < cfg.min_area_px
            || part.area > cfg.max_area_px
        {
            continue;
        }
        let grow = margin_px.ceil() as u32 + 1;
        let window = PixelBox {
            x_min: part.bounds.x_min.saturating_sub(grow),
            y_min: part.bounds.y_min.saturating_sub(grow),
            x_max: (part.bounds.x_max + grow).min(image.width as u32 - 1),
            y_max: (part.bounds.y_max + grow).min(image.height as u32 - 1),
        };
        let part_cfg = DetectConfig {
            window_margin_px: margin_px,
            ..cfg.clone()
        };
        if let Some(blob) = measure(image, part, Some(window), background, &part_cfg)
            && blob.roundness >= cfg.min_roundness
        {
            blobs.push(blob);
        }
    }
    blobs
}
