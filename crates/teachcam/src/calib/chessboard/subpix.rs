//! Sub-pixel corner refinement: OpenCV's `cornerSubPix` (Förstner & Gülch 1987). At the true
//! corner `q`, every image gradient `g(p)` in the window is orthogonal to `p - q`, so `q`
//! minimises `Σ w(p) (g(p) · (p - q))²`: `q = (Σ w g gᵀ)⁻¹ Σ w g gᵀ p`, iterated with the
//! window resampled (bilinear) around each new `q`; `w` is OpenCV's Gaussian mask.

use crate::geometry::Pixel;

use super::{CornerConfig, Plane};

/// Sub-pixel corners: first with a window a quarter of the local square (so that no other
/// corner falls inside it, as OpenCV refines inside `findChessboardCorners`), then with the
/// configured window, narrowed where the coarse corners lie close (see [`final_half_window`]).
pub(super) fn refine_grid(
    plane: &Plane,
    grid: &[Pixel],
    cols: usize,
    config: &CornerConfig,
) -> Vec<Pixel> {
    let rows = grid.len() / cols;
    let coarse: Vec<Pixel> = grid
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let (r, c) = (k / cols, k % cols);
            let mut square = f64::INFINITY;
            for (rr, cc) in [
                (r.wrapping_sub(1), c),
                (r + 1, c),
                (r, c.wrapping_sub(1)),
                (r, c + 1),
            ] {
                if rr < rows && cc < cols {
                    square = square.min(p.distance(&grid[rr * cols + cc]));
                }
            }
            let coarse_half =
                ((square / 4.0).round() as usize).clamp(2, config.subpix_half_window_px);
            corner_subpix(plane, *p, coarse_half, config)
        })
        .collect();
    coarse
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let half = if config.narrow_subpix_window {
                final_half_window(&coarse, cols, k, config.subpix_half_window_px)
            } else {
                config.subpix_half_window_px
            };
            corner_subpix(plane, *p, half, config)
        })
        .collect()
}

/// Share of the way to the nearest other corner that the final window may reach.
///
/// The Förstner estimate is unbiased only while every gradient in its window lies on a line
/// through the corner; a neighbouring corner brings two edges that do not, and so does the
/// paper's edge beyond the board's outer corners (half a square out on many printed targets).
/// Measured on rendered oblique boards against their truth (notes/corners.md): OpenCV's fixed
/// 23x23 window left corners 0.84 px off on 45 px squares and found almost no board with
/// squares under 20 px (their corners slid onto each other); windows reaching 0.45 of the way
/// keep every corner within 0.26 px from 20 px squares up and find them all. On OpenCV's own
/// photographs the calibration's RMS falls from 0.41 to 0.23 px.
const WINDOW_REACH: f64 = 0.45;

/// The final pass's half window for corner `k` of the coarse `grid`: the configured one
/// (OpenCV's, so corners on boards with large squares match `cornerSubPix` one to one),
/// narrowed to [`WINDOW_REACH`] of the Chebyshev distance (the window is square) to the
/// nearest of its eight neighbours.
fn final_half_window(grid: &[Pixel], cols: usize, k: usize, configured: usize) -> usize {
    let rows = grid.len() / cols;
    let (r, c) = (k / cols, k % cols);
    let p = grid[k];
    let mut nearest = f64::INFINITY;
    for rr in r.saturating_sub(1)..(r + 2).min(rows) {
        for cc in c.saturating_sub(1)..(c + 2).min(cols) {
            if (rr, cc) != (r, c) {
                let other = grid[rr * cols + cc];
                nearest = nearest.min((other.x - p.x).abs().max((other.y - p.y).abs()));
            }
        }
    }
    ((WINDOW_REACH * nearest).floor() as usize).clamp(2, configured.max(2))
}

/// OpenCV's `cornerSubPix` with no dead zone: iterate
/// `q ← (Σ w g gᵀ)⁻¹ Σ w g gᵀ p` over a `(2h+1)²` window resampled around `q`.
fn corner_subpix(
    plane: &Plane,
    start: Pixel,
    half_window_px: usize,
    config: &CornerConfig,
) -> Pixel {
    let half = half_window_px as i32;
    let side = (2 * half + 1) as usize;
    let buffer_side = side + 2;
    let mut mask = vec![0.0f64; side * side];
    for i in 0..side {
        let y = f64::from(i as i32 - half) / f64::from(half.max(1));
        for j in 0..side {
            let x = f64::from(j as i32 - half) / f64::from(half.max(1));
            mask[i * side + j] = (-y * y).exp() * (-x * x).exp();
        }
    }
    let eps2 = config.subpix_epsilon_px * config.subpix_epsilon_px;
    let mut buffer = vec![0.0f64; buffer_side * buffer_side];
    let mut q = start;
    for _ in 0..config.subpix_max_iterations {
        // buffer[(i, j)] samples q + (j - half - 1, i - half - 1): one fractional offset for
        // the whole patch, so the bilinear weights are shared when it lies inside the image.
        let x0 = q.x - f64::from(half + 1);
        let y0 = q.y - f64::from(half + 1);
        let (bx, by) = (x0.floor(), y0.floor());
        let inside = bx >= 0.0
            && by >= 0.0
            && bx + (buffer_side as f64) < plane.width as f64
            && by + (buffer_side as f64) < plane.height as f64;
        if inside {
            let (ax, ay) = (x0 - bx, y0 - by);
            let (w00, w01, w10, w11) = (
                (1.0 - ax) * (1.0 - ay),
                ax * (1.0 - ay),
                (1.0 - ax) * ay,
                ax * ay,
            );
            let (bx, by) = (bx as usize, by as usize);
            for i in 0..buffer_side {
                let top = &plane.data[(by + i) * plane.width + bx..];
                let bottom = &plane.data[(by + i + 1) * plane.width + bx..];
                for j in 0..buffer_side {
                    buffer[i * buffer_side + j] = w00 * f64::from(top[j])
                        + w01 * f64::from(top[j + 1])
                        + w10 * f64::from(bottom[j])
                        + w11 * f64::from(bottom[j + 1]);
                }
            }
        } else {
            for i in 0..buffer_side {
                for j in 0..buffer_side {
                    buffer[i * buffer_side + j] = plane.bilinear(x0 + j as f64, y0 + i as f64);
                }
            }
        }
        let (mut a, mut b, mut c, mut bb1, mut bb2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..side {
            let py = f64::from(i as i32 - half);
            for j in 0..side {
                let px = f64::from(j as i32 - half);
                let m = mask[i * side + j];
                let at = (i + 1) * buffer_side + j + 1;
                let gx = buffer[at + 1] - buffer[at - 1];
                let gy = buffer[at + buffer_side] - buffer[at - buffer_side];
                let (gxx, gxy, gyy) = (gx * gx * m, gx * gy * m, gy * gy * m);
                a += gxx;
                b += gxy;
                c += gyy;
                bb1 += gxx * px + gxy * py;
                bb2 += gxy * px + gyy * py;
            }
        }
        let det = a * c - b * b;
        if det.abs() <= f64::EPSILON * f64::EPSILON {
            break;
        }
        let next = Pixel::new(
            q.x + (c * bb1 - b * bb2) / det,
            q.y + (-b * bb1 + a * bb2) / det,
        );
        let moved2 = (next.x - q.x).powi(2) + (next.y - q.y).powi(2);
        q = next;
        if q.x < 0.0
            || q.y < 0.0
            || q.x >= plane.width as f64
            || q.y >= plane.height as f64
            || moved2 <= eps2
        {
            break;
        }
    }
    // As OpenCV: a corner that wandered out of its window did not converge; keep the start.
    if (q.x - start.x).abs() > f64::from(half) || (q.y - start.y).abs() > f64::from(half) {
        start
    } else {
        q
    }
}

/// The gradient structure tensor `Σ g gᵀ` over a `(2 half + 1)²` window around `p`, as its
/// eigenvalues `(λmin, λmax)`: a corner has two strong gradient directions (both large), an
/// edge one (λmin ≈ 0), a flat patch none.
pub(super) fn structure_eigenvalues(plane: &Plane, p: Pixel, half: usize) -> (f64, f64) {
    let half = half as i64;
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for dy in -half..=half {
        for dx in -half..=half {
            let (x, y) = (p.x + dx as f64, p.y + dy as f64);
            let gx = plane.bilinear(x + 1.0, y) - plane.bilinear(x - 1.0, y);
            let gy = plane.bilinear(x, y + 1.0) - plane.bilinear(x, y - 1.0);
            a += gx * gx;
            b += gx * gy;
            c += gy * gy;
        }
    }
    let mean = 0.5 * (a + c);
    let spread = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    (mean - spread, mean + spread)
}
