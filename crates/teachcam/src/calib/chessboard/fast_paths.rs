//! The corner finder's fast paths against the plain definitions they replace, on random
//! images: 16-bit integer smoothing and ChESS sums equal the `f32` formulas bit for bit,
//! block non-maximum suppression finds exactly the pixels a full 7x7 scan finds, and the
//! sub-pixel sums in lanes equal the sequential sums to rounding.

use image::GrayImage;
use proptest::prelude::*;

use super::subpix::normal_equations;
use super::{BlockMaxima, Plane, RING, RING_RADIUS, SMALL_RING, chess_response, local_maxima};

/// Block maxima of a whole response map, row after row.
fn block_maxima(response: &[f32], w: usize, h: usize, r: usize) -> BlockMaxima {
    let mut blocks = BlockMaxima::new(w, h, r);
    for y in r..h - r {
        blocks.add_row(y, &response[y * w + r..y * w + w - r]);
    }
    blocks
}

/// Separable [1 2 1]/4 smoothing in `f32`, edges replicated: the definition.
fn smoothed_f32(image: &GrayImage) -> Vec<f32> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let at = |x: usize, y: usize| f32::from(image.as_raw()[y * w + x]);
    let mut tmp = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (l, r) = (at(x.saturating_sub(1), y), at((x + 1).min(w - 1), y));
            tmp[y * w + x] = 0.25 * (l + 2.0 * at(x, y) + r);
        }
    }
    let mut out = vec![0.0f32; w * h];
    for y in 0..h {
        let (up, down) = (y.saturating_sub(1), (y + 1).min(h - 1));
        for x in 0..w {
            out[y * w + x] = 0.25 * (tmp[up * w + x] + 2.0 * tmp[y * w + x] + tmp[down * w + x]);
        }
    }
    out
}

/// The ChESS response of one pixel of an `f32` plane for one ring: the definition.
fn chess_f32(plane: &[f32], w: usize, x: usize, y: usize, ring: &[(i32, i32); 16]) -> f32 {
    let a: Vec<f32> = ring
        .iter()
        .map(|&(dx, dy)| plane[(y as i32 + dy) as usize * w + (x as i32 + dx) as usize])
        .collect();
    let local = (plane[y * w + x]
        + plane[y * w + x - 1]
        + plane[y * w + x + 1]
        + plane[(y - 1) * w + x]
        + plane[(y + 1) * w + x])
        / 5.0;
    let mut value = 0.0f32;
    for n in 0..4 {
        value += (a[n] + a[n + 8] - a[n + 4] - a[n + 12]).abs();
    }
    let mut sum = 0.0f32;
    for n in 0..8 {
        value -= (a[n] - a[n + 8]).abs();
        sum += a[n] + a[n + 8];
    }
    value - 16.0 * (sum / 16.0 - local).abs()
}

/// Every pixel above the threshold that beats its whole 7x7 window (ties to the first in
/// raster order): the definition.
fn maxima_by_full_scan(response: &[f32], w: usize, h: usize, relative: f32) -> Vec<(usize, usize)> {
    let threshold = relative * response.iter().fold(0.0f32, |m, &v| m.max(v));
    let mut maxima = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let value = response[y * w + x];
            if value <= threshold {
                continue;
            }
            let beaten = (y.saturating_sub(3)..=(y + 3).min(h - 1)).any(|yy| {
                (x.saturating_sub(3)..=(x + 3).min(w - 1)).any(|xx| {
                    let other = response[yy * w + xx];
                    other > value || (other == value && (yy, xx) < (y, x))
                })
            });
            if !beaten {
                maxima.push((y, x));
            }
        }
    }
    maxima
}

/// A random gray image: smooth blobs and steps plus noise, so saddles, edges and flat
/// patches all occur, with every gray level reachable (0 and 255 included).
fn image_strategy() -> impl Strategy<Value = GrayImage> {
    (13u32..48, 13u32..48, any::<u64>()).prop_map(|(w, h, seed)| {
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let (cx, cy) = (
            (next() % u64::from(w)) as i64,
            (next() % u64::from(h)) as i64,
        );
        let contrast = (next() % 256) as i64;
        GrayImage::from_fn(w, h, |x, y| {
            let quadrant = (i64::from(x) < cx) ^ (i64::from(y) < cy);
            let base = if quadrant { contrast } else { 255 - contrast };
            let noise = (next() % 41) as i64 - 20;
            image::Luma([(base + noise).clamp(0, 255) as u8])
        })
    })
}

proptest! {
    #[test]
    fn integer_smoothing_equals_the_f32_definition(image in image_strategy()) {
        let smooth = Plane::from_gray(&image).smoothed();
        let expected = smoothed_f32(&image);
        for y in 0..smooth.height {
            for x in 0..smooth.width {
                let want = expected[y * smooth.width + x];
                prop_assert_eq!(smooth.at(x, y).to_bits(), want.to_bits());
            }
        }
    }

    #[test]
    fn integer_chess_response_equals_the_f32_definition(image in image_strategy()) {
        let smooth = Plane::from_gray(&image).smoothed();
        let plain = smoothed_f32(&image);
        let (w, h) = (smooth.width, smooth.height);
        let (response, blocks) = chess_response(&smooth);
        let r = RING_RADIUS as usize;
        prop_assert_eq!(&blocks.values, &block_maxima(&response, w, h, r).values);
        for y in 0..h {
            for x in 0..w {
                let expected = if (r..h - r).contains(&y) && (r..w - r).contains(&x) {
                    let large = chess_f32(&plain, w, x, y, &RING);
                    let best = large.max(chess_f32(&plain, w, x, y, &SMALL_RING));
                    if best > 0.0 { best } else { 0.0 }
                } else {
                    0.0
                };
                let got = response[y * w + x];
                prop_assert_eq!(got.to_bits(), expected.to_bits(), "pixel ({}, {})", x, y);
            }
        }
    }

    /// Responses quantised to a few levels, so plateaus and ties are common.
    #[test]
    fn block_suppression_equals_the_full_scan(
        (w, h, levels) in (11usize..40, 11usize..40, 1u32..6),
        seed in any::<u64>(),
    ) {
        let mut state = seed | 1;
        let r = RING_RADIUS as usize;
        let response: Vec<f32> = (0..w * h)
            .map(|k| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let (x, y) = (k % w, k / w);
                let inside = (r..h - r).contains(&y) && (r..w - r).contains(&x);
                if inside { (state % u64::from(levels + 1)) as f32 * 0.5 } else { 0.0 }
            })
            .collect();
        for relative in [0.04f32, 0.5, 1.0] {
            let blocks = block_maxima(&response, w, h, r);
            let mut found = local_maxima(&response, &blocks, w, h, relative);
            found.sort_unstable();
            prop_assert_eq!(found, maxima_by_full_scan(&response, w, h, relative));
        }
    }

    #[test]
    fn lane_sums_equal_the_sequential_sums(half in 2i32..12, seed in any::<u64>()) {
        let side = (2 * half + 1) as usize;
        let buffer_side = side + 2;
        let mut state = seed | 1;
        let buffer: Vec<f64> = (0..buffer_side * buffer_side)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state % 25_600) as f64 / 100.0
            })
            .collect();
        let mask: Vec<f64> = (0..side * side).map(|k| 0.5 + (k % 7) as f64 / 10.0).collect();
        let mut expected = [0.0f64; 5];
        for i in 0..side {
            for j in 0..side {
                let (px, py) = (f64::from(j as i32 - half), f64::from(i as i32 - half));
                let at = (i + 1) * buffer_side + j + 1;
                let gx = buffer[at + 1] - buffer[at - 1];
                let gy = buffer[at + buffer_side] - buffer[at - buffer_side];
                let m = mask[i * side + j];
                let (gxx, gxy, gyy) = (gx * gx * m, gx * gy * m, gy * gy * m);
                expected[0] += gxx;
                expected[1] += gxy;
                expected[2] += gyy;
                expected[3] += gxx * px + gxy * py;
                expected[4] += gxy * px + gyy * py;
            }
        }
        let sums = normal_equations(&buffer, buffer_side, &mask, half);
        // Sums of |terms| bound the rounding of either order: 1e-12 of them is 5e3 ulps.
        let scale: f64 = expected.iter().map(|v| v.abs()).sum::<f64>() + 1.0;
        for (got, want) in sums.iter().zip(expected) {
            prop_assert!((got - want).abs() <= 1e-12 * scale, "{} vs {}", got, want);
        }
    }
}
