//! Closed-form test images: uniform discs of known centre and radius on a background, each
//! pixel holding the disc's area fraction over the pixel (32×32 supersampling on the pixels the
//! edge crosses), optionally blurred by a Gaussian (which moves no centroid), then Gaussian
//! noise and rounding. Shared by the detection tests, benchmark and frame writer through
//! `#[path]`.

#![allow(dead_code, reason = "each includer uses part of it")]

use image::{GrayImage, ImageBuffer, Luma};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A disc: centre in pixels (OpenCV convention) and radius in pixels.
#[derive(Debug, Clone, Copy)]
pub struct Disc {
    pub x: f64,
    pub y: f64,
    pub radius_px: f64,
}

/// Image-wide rendering parameters.
#[derive(Debug, Clone, Copy)]
pub struct Scene {
    pub width: u32,
    pub height: u32,
    /// Background level, image units.
    pub background: f64,
    /// Disc level above the background, image units.
    pub amplitude: f64,
    /// Gaussian blur standard deviation, pixels (0 for none).
    pub blur_px: f64,
    /// Noise standard deviation, image units.
    pub noise_std: f64,
    /// Seed of the noise.
    pub seed: u64,
}

const SUPERSAMPLE: usize = 32;

/// Area fraction of `disc` over the unit pixel centred at (px, py).
fn coverage(disc: &Disc, px: f64, py: f64) -> f64 {
    let d = (px - disc.x).hypot(py - disc.y);
    if d <= disc.radius_px - 0.75 {
        return 1.0;
    }
    if d >= disc.radius_px + 0.75 {
        return 0.0;
    }
    let step = 1.0 / SUPERSAMPLE as f64;
    let mut inside = 0usize;
    for i in 0..SUPERSAMPLE {
        let sx = px - 0.5 + (i as f64 + 0.5) * step;
        for j in 0..SUPERSAMPLE {
            let sy = py - 0.5 + (j as f64 + 0.5) * step;
            if (sx - disc.x).powi(2) + (sy - disc.y).powi(2) <= disc.radius_px * disc.radius_px {
                inside += 1;
            }
        }
    }
    inside as f64 / (SUPERSAMPLE * SUPERSAMPLE) as f64
}

/// The noise-free image in floating point, `width × height`, row-major.
pub fn render_exact(scene: &Scene, discs: &[Disc]) -> Vec<f64> {
    let (w, h) = (scene.width as usize, scene.height as usize);
    let mut image = vec![scene.background; w * h];
    let margin = (4.0 * scene.blur_px).ceil() as i64 + 2;
    for disc in discs {
        let x0 = ((disc.x - disc.radius_px).floor() as i64 - margin).max(0);
        let x1 = ((disc.x + disc.radius_px).ceil() as i64 + margin).min(w as i64 - 1);
        let y0 = ((disc.y - disc.radius_px).floor() as i64 - margin).max(0);
        let y1 = ((disc.y + disc.radius_px).ceil() as i64 + margin).min(h as i64 - 1);
        if x0 > x1 || y0 > y1 {
            continue;
        }
        let pw = (x1 - x0 + 1) as usize;
        let ph = (y1 - y0 + 1) as usize;
        let mut patch = vec![0.0; pw * ph];
        for j in 0..ph {
            for i in 0..pw {
                patch[j * pw + i] = coverage(disc, (x0 + i as i64) as f64, (y0 + j as i64) as f64);
            }
        }
        if scene.blur_px > 0.0 {
            patch = blur(&patch, pw, ph, scene.blur_px);
        }
        for j in 0..ph {
            for i in 0..pw {
                image[(y0 as usize + j) * w + x0 as usize + i] +=
                    scene.amplitude * patch[j * pw + i];
            }
        }
    }
    image
}

/// Separable Gaussian blur with zero outside the patch (the patch margin holds the tails).
fn blur(patch: &[f64], w: usize, h: usize, sigma: f64) -> Vec<f64> {
    let half = (4.0 * sigma).ceil() as i64;
    let kernel: Vec<f64> = (-half..=half)
        .map(|k| (-(k * k) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = kernel.iter().sum();
    let kernel: Vec<f64> = kernel.iter().map(|k| k / total).collect();
    let pass = |src: &[f64], horizontal: bool| {
        let mut out = vec![0.0; w * h];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut acc = 0.0;
                for (k, weight) in kernel.iter().enumerate() {
                    let o = k as i64 - half;
                    let (sx, sy) = if horizontal { (x + o, y) } else { (x, y + o) };
                    if sx >= 0 && sy >= 0 && sx < w as i64 && sy < h as i64 {
                        acc += weight * src[(sy as usize) * w + sx as usize];
                    }
                }
                out[(y as usize) * w + x as usize] = acc;
            }
        }
        out
    };
    pass(&pass(patch, true), false)
}

/// Adds noise and rounds to integers within `0..=full_scale`.
fn quantise(scene: &Scene, exact: &[f64], full_scale: f64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(scene.seed);
    let noise = Normal::new(0.0, scene.noise_std.max(0.0)).ok();
    exact
        .iter()
        .map(|&v| {
            let n = match (&noise, scene.noise_std > 0.0) {
                (Some(d), true) => d.sample(&mut rng),
                _ => 0.0,
            };
            (v + n).round().clamp(0.0, full_scale)
        })
        .collect()
}

/// An 8-bit image of the discs.
pub fn render_u8(scene: &Scene, discs: &[Disc]) -> GrayImage {
    let values = quantise(scene, &render_exact(scene, discs), 255.0);
    GrayImage::from_raw(
        scene.width,
        scene.height,
        values.iter().map(|&v| v as u8).collect(),
    )
    .unwrap_or_else(|| GrayImage::new(scene.width, scene.height))
}

/// A 16-bit image of the discs.
pub fn render_u16(scene: &Scene, discs: &[Disc]) -> ImageBuffer<Luma<u16>, Vec<u16>> {
    let values = quantise(scene, &render_exact(scene, discs), 65535.0);
    ImageBuffer::from_raw(
        scene.width,
        scene.height,
        values.iter().map(|&v| v as u16).collect(),
    )
    .unwrap_or_else(|| ImageBuffer::new(scene.width, scene.height))
}

/// The benchmark frames: 1280×1024, 8-bit, `count` discs of radius 4–10 px on a 10×5 grid
/// with sub-pixel offsets from a closed form (no RNG), background 12, contrast 200, blur
/// 0.8 px, noise 2 units. Frame `index` shifts the offsets so frames differ.
pub fn benchmark_frame(count: usize, index: usize) -> (GrayImage, Vec<Disc>) {
    let scene = Scene {
        width: 1280,
        height: 1024,
        background: 12.0,
        amplitude: 200.0,
        blur_px: 0.8,
        noise_std: 2.0,
        seed: 1000 + index as u64,
    };
    let discs: Vec<Disc> = (0..count.min(50))
        .map(|k| {
            let (col, row) = ((k % 10) as f64, (k / 10) as f64);
            let phase = (k * 7 + index * 3) as f64;
            Disc {
                x: 80.0 + 120.0 * col + 23.0 * (0.37 * phase).sin(),
                y: 100.0 + 190.0 * row + 31.0 * (0.23 * phase).cos(),
                radius_px: 4.0 + 6.0 * (0.5 + 0.5 * (1.3 * phase).sin()),
            }
        })
        .collect();
    (render_u8(&scene, &discs), discs)
}
