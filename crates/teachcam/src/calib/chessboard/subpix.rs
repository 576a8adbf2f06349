//! Sub-pixel corner refinement: OpenCV's `cornerSubPix` (Förstner & Gülch 1987). At the true
//! corner `q`, every image gradient `g(p)` in the window is orthogonal to `p - q`, so `q`
//! minimises `Σ w(p) (g(p) · (p - q))²`: `q = (Σ w g gᵀ)⁻¹ Σ w g gᵀ p`, iterated with the
//! window resampled (bilinear) around each new `q`; `w` is OpenCV's Gaussian mask.

use crate::geometry::Pixel;

use super::{CornerConfig, Plane, edge_neighbours, grid_neighbours};

/// Sub-pixel corners: first with a window a quarter of the local square (so that no other
/// corner falls inside it, as OpenCV refines inside `findChessboardCorners`), then with the
/// configured window, narrowed where the coarse corners lie close (see [`final_half_window`]).
pub(super) fn refine_grid(
    plane: &Plane,
    grid: &[Pixel],
    cols: usize,
    config: &CornerConfig,
) -> Vec<Pixel> {
    let coarse: Vec<Pixel> = grid
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let square = edge_neighbours(k, cols, grid.len())
                .map(|n| p.distance(&grid[n]))
                .fold(f64::INFINITY, f64::min);
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
    let p = grid[k];
    let nearest = grid_neighbours(k, cols, grid.len(), 1)
        .map(|n| (grid[n].x - p.x).abs().max((grid[n].y - p.y).abs()))
        .fold(f64::INFINITY, f64::min);
    ((WINDOW_REACH * nearest).floor() as usize)
        .max(2)
        .min(configured)
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
    // OpenCV's mask is the product of one Gaussian per axis: `side` exponentials, not `side²`.
    let gauss: Vec<f64> = (0..side)
        .map(|i| {
            let t = f64::from(i as i32 - half) / f64::from(half.max(1));
            (-t * t).exp()
        })
        .collect();
    let mask: Vec<f64> = gauss
        .iter()
        .flat_map(|gy| gauss.iter().map(move |gx| gy * gx))
        .collect();
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
            // Weights times the plane's unit (a power of two): the same products as scaling
            // the samples to gray levels first.
            let unit = f64::from(plane.gray_per_unit);
            let (w00, w01, w10, w11) = (w00 * unit, w01 * unit, w10 * unit, w11 * unit);
            for (i, out) in buffer.chunks_exact_mut(buffer_side).enumerate() {
                let top = &plane.data[(by + i) * plane.width + bx..][..=buffer_side];
                let bottom = &plane.data[(by + i + 1) * plane.width + bx..][..=buffer_side];
                for (j, o) in out.iter_mut().enumerate() {
                    *o = w00 * f64::from(top[j])
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
        let [a, b, c, bb1, bb2] = normal_equations(&buffer, buffer_side, &mask, half);
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

/// The sums of OpenCV's normal equations over a `(2 half + 1)²` window whose samples, with a
/// one-pixel border, are `buffer` (rows of `buffer_side`): with `g` the central-difference
/// gradient, `m` the mask and `p` the offset from the window's centre,
/// `[Σ m gx², Σ m gx gy, Σ m gy², Σ m (gx² px + gx gy py), Σ m (gx gy px + gy² py)]`.
/// Summed in four interleaved lanes per row, `px` and `py` factored out of the row sums, so
/// the loop vectorises and does fewer products: the order of the 529 terms changes the sums
/// by ~1e-16 relative, and the corner by far less than the 0.001 px stopping step.
pub(super) fn normal_equations(
    buffer: &[f64],
    buffer_side: usize,
    mask: &[f64],
    half: i32,
) -> [f64; 5] {
    const LANES: usize = 4;
    let side = buffer_side - 2;
    let body = side - side % LANES;
    // Per row, the sums over the row's pixels with `px` factored out of them:
    // Σ m gx² px and Σ m gx gy px, the `py` terms added per row.
    let (mut a, mut b, mut c, mut bb1, mut bb2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..side {
        let py = f64::from(i as i32 - half);
        let up = &buffer[i * buffer_side + 1..][..side];
        let down = &buffer[(i + 2) * buffer_side + 1..][..side];
        let left = &buffer[(i + 1) * buffer_side..][..side];
        let right = &buffer[(i + 1) * buffer_side + 2..][..side];
        let mask = &mask[i * side..][..side];
        let mut lanes = [[0.0f64; LANES]; 5];
        let mut add = |lane: usize, j: usize| {
            let px = f64::from(j as i32 - half);
            let (gx, gy) = (right[j] - left[j], down[j] - up[j]);
            let m_gx = mask[j] * gx;
            let (gxx, gxy, gyy) = (m_gx * gx, m_gx * gy, mask[j] * gy * gy);
            lanes[0][lane] += gxx;
            lanes[1][lane] += gxy;
            lanes[2][lane] += gyy;
            lanes[3][lane] += gxx * px;
            lanes[4][lane] += gxy * px;
        };
        for j0 in (0..body).step_by(LANES) {
            for lane in 0..LANES {
                add(lane, j0 + lane);
            }
        }
        for j in body..side {
            add(j - body, j);
        }
        let [sxx, sxy, syy, sxx_px, sxy_px] = lanes.map(|lane| lane.iter().sum::<f64>());
        a += sxx;
        b += sxy;
        c += syy;
        bb1 += sxx_px + sxy * py;
        bb2 += sxy_px + syy * py;
    }
    [a, b, c, bb1, bb2]
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
