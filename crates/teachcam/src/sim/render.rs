//! Ray-cast rendering of marker spheres through the lens model.
//!
//! For every pixel near a sphere's image, `supersampling²` sub-pixel positions are unprojected
//! through the camera (exact inverse distortion) and the rays are intersected with every
//! sphere (markers bright, occluders dark); the nearest hit decides the sample. The coverage
//! image is then blurred by a Gaussian point-spread function, offset by the background, given
//! Gaussian read noise plus shot noise, and quantised to 8 bits. A sphere's image is thus the
//! true perspective conic, distortion included, and its truth is the exact projection of the
//! sphere's centre.

use std::cell::RefCell;

use image::GrayImage;
use nalgebra::Vector3;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use super::optics::{Halo, Streak, UnevenLight};
use crate::camera::Camera;
use crate::geometry::{Pixel, Point3};

/// How the camera forms an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderConfig {
    /// Sub-pixel samples per pixel side: 4 gives 16 rays per pixel, enough to make the
    /// area-coverage error (≈ 1/(2·4²) of a pixel on the edge) negligible after blur.
    pub supersampling: u32,
    /// Standard deviation of the Gaussian point-spread function, pixels: a sharp 12 mm lens at
    /// f/4 with 6.7 µm pixels spreads a point over about a pixel.
    pub blur_sigma_px: f64,
    /// Background level, digital numbers (8-bit): the infrared filter leaves a dark scene.
    pub background_dn: f64,
    /// Level of a retro-reflective marker above the background, DN: bright, unsaturated.
    pub marker_dn: f64,
    /// Read noise standard deviation, DN.
    pub read_noise_dn: f64,
    /// Shot-noise variance per DN of signal (1 / gain in electrons per DN).
    pub shot_noise_dn_per_dn: f64,
    /// Bloom: the wide skirt of the point-spread function; `None` for the paper's sharp lens.
    pub halo: Option<Halo>,
    /// Ambient light gradient and vignetting; `None` for the paper's flat dark background.
    pub uneven_light: Option<UnevenLight>,
    /// JPEG quality each frame goes through (encode then decode); `None`: lossless frames.
    /// Applied by [`super::render_frame`], after quantisation.
    pub jpeg_quality: Option<u8>,
}

impl RenderConfig {
    /// How far past a bright shape the point-spread function reaches, pixels: 4σ of its widest
    /// part, plus one.
    #[must_use]
    pub fn psf_margin_px(&self) -> i64 {
        let sigma = self
            .halo
            .map_or(self.blur_sigma_px, |h| h.sigma_px.max(self.blur_sigma_px));
        (4.0 * sigma).ceil() as i64 + 1
    }
}

impl Default for RenderConfig {
    fn default() -> Self {
        Self {
            supersampling: 4,
            blur_sigma_px: 0.6,
            background_dn: 12.0,
            marker_dn: 180.0,
            read_noise_dn: 1.2,
            shot_noise_dn_per_dn: 0.04,
            halo: None,
            uneven_light: None,
            jpeg_quality: None,
        }
    }
}

/// A sphere in the scene, in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre, millimetres.
    pub center_in_world: Point3,
    /// Radius, millimetres.
    pub radius: f64,
    /// Brightness above background, DN; 0 for a dark occluder.
    pub radiance_dn: f64,
}

/// A small bright spot drawn straight into one camera's image: a specular glint that exists in
/// that view only and has no 3-D counterpart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Glint {
    /// Centre, pixels.
    pub center: Pixel,
    /// Radius, pixels.
    pub radius_px: f64,
    /// Brightness above background, DN.
    pub radiance_dn: f64,
}

/// What the renderer knows about one sphere in one view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereView {
    /// Exact projection of the sphere's centre (the detector's target), `None` behind the camera.
    pub center: Option<Pixel>,
    /// Apparent radius of the sphere's image, pixels (pinhole approximation).
    pub radius_px: f64,
    /// Fraction of the sphere's silhouette samples that see this sphere (occlusion by other
    /// spheres, or the image border, lower it).
    pub visible_fraction: f64,
}

/// Entries of the per-view table of normal draws (a power of two).
const NOISE_TABLE_SIZE: usize = 1 << 16;

/// An axis-aligned pixel rectangle, inclusive bounds, clipped to the image.
#[derive(Debug, Clone, Copy)]
pub(super) struct PixelBox {
    pub(super) x0: i64,
    pub(super) y0: i64,
    pub(super) x1: i64,
    pub(super) y1: i64,
}

impl PixelBox {
    pub(super) fn around(center: Pixel, half: f64, width: u32, height: u32) -> Option<Self> {
        let b = Self {
            x0: ((center.x - half).floor() as i64).max(0),
            y0: ((center.y - half).floor() as i64).max(0),
            x1: ((center.x + half).ceil() as i64).min(i64::from(width) - 1),
            y1: ((center.y + half).ceil() as i64).min(i64::from(height) - 1),
        };
        (b.x0 <= b.x1 && b.y0 <= b.y1).then_some(b)
    }

    pub(super) fn grown(self, by: i64, width: u32, height: u32) -> Self {
        Self {
            x0: (self.x0 - by).max(0),
            y0: (self.y0 - by).max(0),
            x1: (self.x1 + by).min(i64::from(width) - 1),
            y1: (self.y1 + by).min(i64::from(height) - 1),
        }
    }
}

thread_local! {
    /// Image-sized buffers of zeros, kept by the thread between views: a 1280×1024 view
    /// needs three to five of 5 MB, and fresh ones cost a page fault and a page clear every
    /// 4 KiB (a fifth of the demo's CPU); a returned one is cleared where it was written.
    static ZEROS: RefCell<Vec<Vec<f32>>> = const { RefCell::new(Vec::new()) };
}

/// Buffers kept by a thread at most.
const ZEROS_KEPT: usize = 8;

/// An image-sized buffer of values, all zero but in the rectangles marked as written (mark
/// before writing): on drop those are cleared and the buffer goes back to the thread's pool.
pub(super) struct Scratch {
    values: Vec<f32>,
    written: Vec<PixelBox>,
    width: usize,
}

impl Scratch {
    /// Zeros for a `width × height` image, from the pool when it has such a buffer.
    pub(super) fn zeros(width: u32, height: u32) -> Self {
        let len = width as usize * height as usize;
        let pooled = ZEROS
            .try_with(|pool| {
                let mut pool = pool.try_borrow_mut().ok()?;
                let at = pool.iter().position(|b| b.len() == len)?;
                Some(pool.swap_remove(at))
            })
            .ok()
            .flatten();
        Self {
            values: pooled.unwrap_or_else(|| vec![0.0; len]),
            written: Vec::new(),
            width: width as usize,
        }
    }

    /// Marks `b` as about to be written.
    pub(super) fn mark(&mut self, b: PixelBox) {
        self.written.push(b);
    }

    /// The values, to write where marked.
    pub(super) fn values_mut(&mut self) -> &mut [f32] {
        &mut self.values
    }
}

impl std::ops::Deref for Scratch {
    type Target = [f32];
    fn deref(&self) -> &[f32] {
        &self.values
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let mut values = std::mem::take(&mut self.values);
        for b in &self.written {
            for row in b.y0..=b.y1 {
                let start = row as usize * self.width;
                if let Some(run) = values.get_mut(start + b.x0 as usize..=start + b.x1 as usize) {
                    run.fill(0.0);
                }
            }
        }
        let _ = ZEROS.try_with(|pool| {
            if let Ok(mut pool) = pool.try_borrow_mut()
                && pool.len() < ZEROS_KEPT
            {
                pool.push(values);
            }
        });
    }
}

/// Nearest intersection distance of a ray from the origin along unit `direction` with a
/// sphere (centre in the same frame), `None` when it misses.
fn ray_sphere(direction: &Vector3<f64>, center: &Vector3<f64>, radius: f64) -> Option<f64> {
    let along = direction.dot(center);
    let closest_sq = center.norm_squared() - along * along;
    let discriminant = radius * radius - closest_sq;
    if discriminant < 0.0 {
        return None;
    }
    let t = along - discriminant.sqrt();
    (t > 0.0).then_some(t)
}

/// Image-space half-size that surely contains a sphere's image: the projection of its limb
/// circle, sampled around, plus a margin for the blur.
fn sphere_extent(
    camera: &Camera,
    center_in_camera: &Vector3<f64>,
    radius: f64,
) -> Option<(Pixel, f64)> {
    let distance = center_in_camera.norm();
    if distance <= radius || center_in_camera.z <= radius {
        return None;
    }
    let center_px = camera.project_from_camera(&Point3::from(*center_in_camera))?;
    let axis = center_in_camera / distance;
    let u = axis
        .cross(&Vector3::y())
        .try_normalize(1e-12)
        .unwrap_or_else(|| axis.cross(&Vector3::x()).normalize());
    let v = axis.cross(&u);
    // The limb (silhouette) circle: centre r²/d towards the camera, radius r·sqrt(1 - r²/d²).
    let limb_center = center_in_camera - axis * (radius * radius / distance);
    let limb_radius = radius * (1.0 - radius * radius / (distance * distance)).sqrt();
    let mut half = 0.0_f64;
    for k in 0..16 {
        let angle = f64::from(k) * std::f64::consts::TAU / 16.0;
        let point = limb_center + (u * angle.cos() + v * angle.sin()) * limb_radius;
        let px = camera.project_from_camera(&Point3::from(point))?;
        half = half
            .max((px.x - center_px.x).abs())
            .max((px.y - center_px.y).abs());
    }
    Some((center_px, half))
}

/// Renders one camera's view of the spheres and glints, returning the 8-bit image and, for
/// each sphere in order, its exact centre projection and visibility.
pub fn render_view<R: Rng>(
    camera: &Camera,
    spheres: &[Sphere],
    glints: &[Glint],
    config: &RenderConfig,
    rng: &mut R,
) -> (GrayImage, Vec<SphereView>) {
    render_exposure(
        camera,
        std::slice::from_ref(&spheres.to_vec()),
        glints,
        &[],
        config,
        rng,
    )
}

/// Renders one camera's view over an exposure: `instants` holds the spheres (the same spheres
/// in the same order) at equally spaced times of the exposure, and the image integrates them
/// (motion blur), each instant weighted `1/instants.len()`. The truth (`SphereView`s) is that of
/// the middle instant, the exposure's centre. Glints and streaks are still.
pub fn render_exposure<R: Rng>(
    camera: &Camera,
    instants: &[Vec<Sphere>],
    glints: &[Glint],
    streaks: &[Streak],
    config: &RenderConfig,
    rng: &mut R,
) -> (GrayImage, Vec<SphereView>) {
    let (width, height) = (camera.image_size.width, camera.image_size.height);
    let mut coverage = Scratch::zeros(width, height);
    let blur_margin = config.psf_margin_px();
    let mut boxes = Vec::new();
    let mut views = Vec::new();
    let weight = 1.0 / instants.len().max(1) as f64;
    for (k, spheres) in instants.iter().enumerate() {
        let weighted: Vec<Sphere> = spheres
            .iter()
            .map(|s| Sphere {
                radiance_dn: s.radiance_dn * weight,
                ..*s
            })
            .collect();
        let instant_views = cast_spheres(
            camera,
            &weighted,
            config,
            blur_margin,
            &mut coverage,
            &mut boxes,
        );
        if k == instants.len() / 2 {
            views = instant_views;
        }
    }
    let n = config.supersampling.max(1);
    for glint in glints {
        let Some(b) = PixelBox::around(glint.center, glint.radius_px + 1.0, width, height) else {
            continue;
        };
        coverage.mark(b);
        add_flat_shape(
            coverage.values_mut(),
            width,
            b,
            n,
            glint.radiance_dn,
            |x, y| (x - glint.center.x).hypot(y - glint.center.y) <= glint.radius_px,
        );
        boxes.push(b.grown(blur_margin, width, height));
    }
    for streak in streaks {
        let half = 0.5 * streak.width_px + 1.0;
        let (lo, hi) = (
            Pixel::new(
                streak.from.x.min(streak.to.x),
                streak.from.y.min(streak.to.y),
            ),
            Pixel::new(
                streak.from.x.max(streak.to.x),
                streak.from.y.max(streak.to.y),
            ),
        );
        let middle = Pixel::new(0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
        let reach = 0.5 * (hi.x - lo.x).max(hi.y - lo.y) + half;
        let Some(b) = PixelBox::around(middle, reach, width, height) else {
            continue;
        };
        coverage.mark(b);
        add_flat_shape(
            coverage.values_mut(),
            width,
            b,
            n,
            streak.radiance_dn,
            |x, y| streak.distance_px(x, y) <= 0.5 * streak.width_px,
        );
        boxes.push(b.grown(blur_margin, width, height));
    }

    let image = form_image(&coverage, width, height, &boxes, config, rng);
    (image, views)
}

/// Adds `radiance_dn` times the covered fraction of every pixel of `b` to `coverage`, where
/// `inside(x, y)` says whether a sub-pixel sample lies in the shape.
fn add_flat_shape(
    coverage: &mut [f32],
    width: u32,
    b: PixelBox,
    n: u32,
    radiance_dn: f64,
    inside: impl Fn(f64, f64) -> bool,
) {
    let step = 1.0 / f64::from(n);
    for row in b.y0..=b.y1 {
        for col in b.x0..=b.x1 {
            let mut hits = 0;
            for sy in 0..n {
                for sx in 0..n {
                    let x = col as f64 - 0.5 + (f64::from(sx) + 0.5) * step;
                    let y = row as f64 - 0.5 + (f64::from(sy) + 0.5) * step;
                    if inside(x, y) {
                        hits += 1;
                    }
                }
            }
            coverage[row as usize * width as usize + col as usize] +=
                (radiance_dn * f64::from(hits) * step * step) as f32;
        }
    }
}

/// Ray-casts every sphere into `coverage` (the nearest hit of each sub-pixel ray decides),
/// pushes each image's box grown by `blur_margin` onto `boxes`, and returns each sphere's
/// truth in this view.
fn cast_spheres(
    camera: &Camera,
    spheres: &[Sphere],
    config: &RenderConfig,
    blur_margin: i64,
    coverage: &mut Scratch,
    boxes: &mut Vec<PixelBox>,
) -> Vec<SphereView> {
    let (width, height) = (camera.image_size.width, camera.image_size.height);
    let centers: Vec<Vector3<f64>> = spheres
        .iter()
        .map(|s| {
            camera
                .camera_from_world
                .transform_point(&s.center_in_world)
                .coords
        })
        .collect();
    let mut views = Vec::with_capacity(spheres.len());
    let n = config.supersampling.max(1);
    let step = 1.0 / f64::from(n);

    for (i, sphere) in spheres.iter().enumerate() {
        let extent = sphere_extent(camera, &centers[i], sphere.radius);
        let center = camera.project(&sphere.center_in_world);
        let distance = centers[i].norm();
        let radius_px = if distance > sphere.radius {
            camera.intrinsics.fx * sphere.radius
                / (distance * distance - sphere.radius * sphere.radius).sqrt()
        } else {
            0.0
        };
        let Some((center_px, half)) = extent else {
            views.push(SphereView {
                center,
                radius_px,
                visible_fraction: 0.0,
            });
            continue;
        };
        // Count over the unclipped box so that a sphere leaving the image loses visibility.
        let unclipped = (
            (center_px.x - half - 1.0).floor() as i64,
            (center_px.y - half - 1.0).floor() as i64,
            (center_px.x + half + 1.0).ceil() as i64,
            (center_px.y + half + 1.0).ceil() as i64,
        );
        // The pixels of the box inside the image are written.
        let written = PixelBox {
            x0: unclipped.0.max(0),
            y0: unclipped.1.max(0),
            x1: unclipped.2.min(i64::from(width) - 1),
            y1: unclipped.3.min(i64::from(height) - 1),
        };
        if written.x0 <= written.x1 && written.y0 <= written.y1 {
            coverage.mark(written);
        }
        let coverage = coverage.values_mut();
        let (mut silhouette, mut visible) = (0_u64, 0_u64);
        for row in unclipped.1..=unclipped.3 {
            for col in unclipped.0..=unclipped.2 {
                let inside =
                    col >= 0 && row >= 0 && col < i64::from(width) && row < i64::from(height);
                let mut value = 0.0;
                for sy in 0..n {
                    for sx in 0..n {
                        let px = Pixel::new(
                            col as f64 - 0.5 + (f64::from(sx) + 0.5) * step,
                            row as f64 - 0.5 + (f64::from(sy) + 0.5) * step,
                        );
                        let Ok(normalized) = camera.undistort(&px) else {
                            continue;
                        };
                        let direction = Vector3::new(normalized.x, normalized.y, 1.0).normalize();
                        if ray_sphere(&direction, &centers[i], sphere.radius).is_none() {
                            continue;
                        }
                        silhouette += 1;
                        let nearest = centers
                            .iter()
                            .zip(spheres)
                            .enumerate()
                            .filter_map(|(j, (c, s))| {
                                ray_sphere(&direction, c, s.radius).map(|t| (j, t))
                            })
                            .min_by(|a, b| a.1.total_cmp(&b.1));
                        if let Some((j, _)) = nearest {
                            if j == i && inside {
                                visible += 1;
                            }
                            if j == i {
                                value += sphere.radiance_dn;
                            }
                        }
                    }
                }
                if inside {
                    let index = row as usize * width as usize + col as usize;
                    // Pixels seen by several spheres' boxes get the same nearest-hit value from
                    // each: only the sphere actually hit adds radiance.
                    coverage[index] += (value * step * step) as f32;
                }
            }
        }
        views.push(SphereView {
            center,
            radius_px,
            visible_fraction: if silhouette > 0 {
                visible as f64 / silhouette as f64
            } else {
                0.0
            },
        });
        if let Some(b) = PixelBox::around(center_px, half + 1.0, width, height) {
            boxes.push(b.grown(blur_margin, width, height));
        }
    }
    views
}

/// The sensor's image of a radiance map: `coverage` (DN above background per pixel, zero
/// outside every box) blurred by the point-spread function inside `boxes`, offset by the
/// background, given read and shot noise, and quantised to 8 bits. Shared by every renderer.
pub(super) fn form_image<R: Rng>(
    coverage: &[f32],
    width: u32,
    height: u32,
    boxes: &[PixelBox],
    config: &RenderConfig,
    rng: &mut R,
) -> GrayImage {
    let mut blurred = blur_regions(coverage, width, height, boxes, config.blur_sigma_px);
    if let Some(halo) = config.halo {
        let skirt = blur_regions(coverage, width, height, boxes, halo.sigma_px);
        let core = 1.0 - halo.fraction;
        for (b, s) in blurred.values_mut().iter_mut().zip(skirt.iter()) {
            *b = (core * f64::from(*b) + halo.fraction * f64::from(*s)) as f32;
        }
    }
    // Noise: independent standard normal draws for every pixel, taken at random from a table of
    // draws made afresh for each view (a 2¹⁶-entry table sampled with replacement is
    // statistically indistinguishable from direct draws here and ten times faster).
    let table: Vec<f32> = (0..NOISE_TABLE_SIZE)
        .map(|_| StandardNormal.sample(rng))
        .collect();
    // Where nothing was drawn and the light is even, a pixel's value depends on its draw only:
    // those values, one per table entry, are computed once (the same arithmetic as below).
    let dark: Option<Vec<u8>> = config.uneven_light.is_none().then(|| {
        table
            .iter()
            .map(|d| (config.background_dn + config.read_noise_dn * f64::from(*d) + 0.5) as u8)
            .collect()
    });
    let mut image = GrayImage::new(width, height);
    for (index, (value, signal)) in image.iter_mut().zip(blurred.iter()).enumerate() {
        let entry = (rng.next_u32() as usize) & (NOISE_TABLE_SIZE - 1);
        if *signal == 0.0
            && let Some(dark) = &dark
        {
            *value = dark[entry];
            continue;
        }
        let draw = f64::from(table[entry]);
        let signal = f64::from(*signal);
        let sigma = if signal == 0.0 {
            config.read_noise_dn
        } else {
            (config.read_noise_dn * config.read_noise_dn + config.shot_noise_dn_per_dn * signal)
                .sqrt()
        };
        let level = match config.uneven_light {
            None => config.background_dn + signal,
            Some(light) => {
                let (col, row) = (index % width as usize, index / width as usize);
                light.level(
                    col as u32,
                    row as u32,
                    width,
                    height,
                    config.background_dn + signal,
                )
            }
        };
        // Rounded to the nearest level and clamped to 0..=255: `as u8` truncates and saturates,
        // so adding one half rounds (half up) without a call to `round`.
        *value = (level + sigma * draw + 0.5) as u8;
    }
    image
}

/// Separable Gaussian blur of `source`, computed inside each box (pixels outside every box
/// are zero in `source` and stay zero). Overlapping boxes compute identical values.
fn blur_regions(
    source: &[f32],
    width: u32,
    height: u32,
    boxes: &[PixelBox],
    sigma: f64,
) -> Scratch {
    let mut out = Scratch::zeros(width, height);
    if sigma <= 0.0 {
        out.mark(PixelBox {
            x0: 0,
            y0: 0,
            x1: i64::from(width) - 1,
            y1: i64::from(height) - 1,
        });
        out.values_mut().copy_from_slice(source);
        return out;
    }
    let radius = (4.0 * sigma).ceil() as i64;
    let kernel: Vec<f32> = {
        let raw: Vec<f64> = (-radius..=radius)
            .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp())
            .collect();
        let sum: f64 = raw.iter().sum();
        raw.iter().map(|v| (v / sum) as f32).collect()
    };
    let w = width as usize;
    let mut horizontal = Scratch::zeros(width, height);
    for b in boxes {
        let grown = b.grown(radius, width, height);
        horizontal.mark(PixelBox {
            y0: grown.y0,
            y1: grown.y1,
            ..*b
        });
        out.mark(*b);
    }
    let (horizontal_values, out_values) = (horizontal.values_mut(), out.values_mut());
    for b in boxes {
        let grown = b.grown(radius, width, height);
        for row in grown.y0..=grown.y1 {
            for col in b.x0..=b.x1 {
                let mut acc = 0.0;
                for (k, weight) in kernel.iter().enumerate() {
                    let c = col + k as i64 - radius;
                    if c >= 0 && c < i64::from(width) {
                        acc += weight * source[row as usize * w + c as usize];
                    }
                }
                horizontal_values[row as usize * w + col as usize] = acc;
            }
        }
    }
    for b in boxes {
        for row in b.y0..=b.y1 {
            for col in b.x0..=b.x1 {
                let mut acc = 0.0;
                for (k, weight) in kernel.iter().enumerate() {
                    let r = row + k as i64 - radius;
                    if r >= 0 && r < i64::from(height) {
                        acc += weight * horizontal_values[r as usize * w + col as usize];
                    }
                }
                out_values[row as usize * w + col as usize] = acc;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Spheres at camera-frame points of the paper rig's first camera, and a glint.
    fn view_of(points: &[(f64, f64, f64)], glint: Pixel) -> GrayImage {
        let scene = crate::sim::build_scene(crate::sim::Scenario::Paper, 1);
        let camera = &scene.rig.cameras[0];
        let spheres: Vec<Sphere> = points
            .iter()
            .map(|&(x, y, z)| Sphere {
                center_in_world: camera
                    .camera_from_world
                    .inverse_transform_point(&Point3::new(x, y, z)),
                radius: 6.5,
                radiance_dn: 200.0,
            })
            .collect();
        let glints = [Glint {
            center: glint,
            radius_px: 2.0,
            radiance_dn: 150.0,
        }];
        let config = RenderConfig {
            halo: Some(Halo {
                fraction: 0.1,
                sigma_px: 4.0,
            }),
            ..RenderConfig::default()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        render_view(camera, &spheres, &glints, &config, &mut rng).0
    }

    /// A thread's buffers come back to its pool all zero: the view it renders after another
    /// (spheres, glint and halo elsewhere) is the view a fresh thread renders.
    #[test]
    fn a_view_after_another_is_the_view_a_fresh_thread_renders() {
        let second = || {
            view_of(
                &[(120.0, -80.0, 950.0), (150.0, -60.0, 960.0)],
                Pixel::new(900.0, 700.0),
            )
        };
        let fresh = std::thread::spawn(second)
            .join()
            .expect("the fresh thread renders");
        let first = view_of(
            &[(-40.0, 30.0, 1000.0), (-10.0, 50.0, 1010.0)],
            Pixel::new(200.0, 300.0),
        );
        let after = second();
        assert!(first != after, "the two views differ");
        assert!(
            after == fresh,
            "the view after another differs from a fresh one"
        );
    }
}
