//! Chessboard inner corners in a photograph, refined to sub-pixel, in OpenCV's order.
//!
//! Pipeline:
//! 1. **Saddle response** (ChESS, Bennett & Lasenby 2014): on a 16-sample ring of radius
//!    5 px around each pixel, an X-junction has opposite samples alike and quarter-turn
//!    samples unlike, `R = Σ|I_n + I_{n+8} - I_{n+4} - I_{n+12}| - Σ|I_n - I_{n+8}|
//!    - 16 |ring mean - local mean|`; edges and blobs score low. Local maxima are candidates.
//! 2. **Grid growth**: from a seed whose four nearest candidates form two opposite pairs (or,
//!    when no board is found so, whose nearer candidates hold two crossing pairs), walk
//!    the lattice by linear extrapolation, taking the nearest candidate within a fraction of
//!    the step. A board is found when a fully populated `cols x rows` window exists whose
//!    squares alternate dark/bright (a photograph of a real board, not a lattice of clutter).
//!    A lattice grown on a board axis and a diagonal (the seed's nearest saddles on a
//!    foreshortened board) is renumbered by a unimodular shear before the window is sought.
//! 3. **Order** as `cv2.findChessboardCorners` returns it (checked one to one on OpenCV's
//!    sample images): rows of `cols` corners; walking a row then stepping to the next row turns
//!    clockwise on screen (y down); the square between corners 0, 1, `cols`, `cols + 1` is dark.
//! 4. **Sub-pixel**: OpenCV's `cornerSubPix` (Förstner): the corner `q` minimises
//!    `Σ w(p) (∇I(p) · (p - q))²` over a window, iterated with bilinear resampling. Where
//!    OpenCV's window would take in a neighbouring corner's edges, it is narrowed to under half
//!    the way there (on OpenCV's own sample photographs this cuts the calibration's RMS
//!    reprojection error from 0.41 to 0.23 px).
//! 5. **Checks**: a board whose refined corners slide together is refused, and so is one with
//!    a corner off the place a homography through its neighbours gives it (a lattice grown
//!    partly on clutter, or numbered a square off).
//!
//! A partial, blurred or absent board is refused with [`ChessboardError`], never guessed.
//!
//! Speed without changing the answer: the smoothed image is kept as exact integers (sixteenths
//! of a gray level), so the ChESS sums run in 16-bit integer vectors and equal the `f32`
//! formula bit for bit; non-maximum suppression checks only each 4x4 block's winner (Neubeck
//! & Van Gool 2006). `fast_paths` tests both against the plain definitions on random images.

use std::collections::{BTreeMap, VecDeque};

use image::GrayImage;

use nalgebra::Vector3;

use crate::geometry::{Pixel, Point3};

use super::{Chessboard, zhang};

#[cfg(test)]
mod fast_paths;
mod subpix;

use subpix::refine_grid;

/// Options of [`find_chessboard_corners`].
#[derive(Debug, Clone, PartialEq)]
pub struct CornerConfig {
    /// Half size of the sub-pixel window, pixels (OpenCV's `winSize`); 11, as in OpenCV's
    /// calibration tutorial, searches a 23x23 window.
    pub subpix_half_window_px: usize,
    /// Narrow a corner's sub-pixel window to under half the way to its nearest neighbouring
    /// corner where the configured one would reach further; true. False keeps OpenCV's fixed
    /// window everywhere, which reproduces `cornerSubPix` one to one (and its bias where the
    /// window takes in other corners: notes/corners.md).
    pub narrow_subpix_window: bool,
    /// Sub-pixel iterations at most; 30 as in OpenCV's calibration tutorial.
    pub subpix_max_iterations: usize,
    /// Sub-pixel refinement stops when a step is shorter than this, pixels; 0.001 as in
    /// OpenCV's calibration tutorial.
    pub subpix_epsilon_px: f64,
    /// Saddle candidates weaker than this fraction of the strongest are ignored; 0.04 keeps
    /// the corners of a dim, tilted board and drops sensor noise.
    pub min_relative_response: f64,
    /// A lattice step accepts the nearest candidate within this fraction of the predicted
    /// step; 0.35 tolerates strong perspective without jumping to a diagonal neighbour.
    pub step_tolerance: f64,
}

impl Default for CornerConfig {
    fn default() -> Self {
        Self {
            subpix_half_window_px: 11,
            narrow_subpix_window: true,
            subpix_max_iterations: 30,
            subpix_epsilon_px: 0.001,
            min_relative_response: 0.04,
            step_tolerance: 0.35,
        }
    }
}

/// Why no board was returned for an image.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChessboardError {
    /// The image has no X-junctions at all (blank, blurred or too small).
    #[error("no chessboard corners in the image (no saddle points)")]
    NoSaddles,
    /// Saddles were found but no complete lattice of the requested size.
    #[error(
        "no complete {cols}x{rows} chessboard found (largest lattice {found} corners, {candidates} candidates)"
    )]
    NotFound {
        /// Inner corners per row asked for.
        cols: usize,
        /// Inner corner rows asked for.
        rows: usize,
        /// Corners in the largest lattice grown.
        found: usize,
        /// Saddle candidates in the image.
        candidates: usize,
    },
    /// The image is smaller than the detector's ring.
    #[error("image of {width}x{height} pixels is too small for corner detection")]
    TooSmall {
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
    },
}

/// Gray levels as OpenCV computes them (`cvtColor`, `IMREAD_GRAYSCALE`): ITU-R BT.601 luma
/// `Y = 0.299 R + 0.587 G + 0.114 B` in OpenCV's 14-bit fixed point, so that corners match
/// OpenCV's on colour photographs too (the `image` crate's `to_luma8` uses BT.709 weights).
#[must_use]
pub fn gray_like_opencv(image: &image::DynamicImage) -> GrayImage {
    if let image::DynamicImage::ImageLuma8(gray) = image {
        return gray.clone();
    }
    let rgb = image.to_rgb8();
    let (width, height) = rgb.dimensions();
    let data = rgb
        .pixels()
        .map(|p| {
            let [r, g, b] = p.0;
            ((u32::from(r) * 4899 + u32::from(g) * 9617 + u32::from(b) * 1868 + 8192) >> 14) as u8
        })
        .collect();
    GrayImage::from_raw(width, height, data).unwrap_or_else(|| image.to_luma8())
}

/// Ring of 16 samples at radius 5 px, a quarter turn every 4 samples.
const RING: [(i32, i32); 16] = [
    (5, 0),
    (5, 2),
    (4, 4),
    (2, 5),
    (0, 5),
    (-2, 5),
    (-4, 4),
    (-5, 2),
    (-5, 0),
    (-5, -2),
    (-4, -4),
    (-2, -5),
    (0, -5),
    (2, -5),
    (4, -4),
    (5, -2),
];
const RING_RADIUS: i32 = 5;

/// Ring of 16 samples at radius 3 px, for boards whose squares are under about 20 px.
const SMALL_RING: [(i32, i32); 16] = [
    (3, 0),
    (3, 1),
    (2, 2),
    (1, 3),
    (0, 3),
    (-1, 3),
    (-2, 2),
    (-3, 1),
    (-3, 0),
    (-3, -1),
    (-2, -2),
    (-1, -3),
    (0, -3),
    (1, -3),
    (2, -2),
    (3, -1),
];

/// A gray image, row-major, as integers in units of `gray_per_unit` gray levels: a photograph
/// (1) or its [1 2 1] smoothing (1/16). A power-of-two unit keeps every sample exact in `f32`,
/// so the ChESS sums can run in 16-bit integers and still equal the `f32` sums bit for bit.
struct Plane {
    width: usize,
    height: usize,
    data: Vec<u16>,
    gray_per_unit: f32,
}

impl Plane {
    fn from_gray(image: &GrayImage) -> Self {
        Self {
            width: image.width() as usize,
            height: image.height() as usize,
            data: image.as_raw().iter().map(|&v| u16::from(v)).collect(),
            gray_per_unit: 1.0,
        }
    }

    fn at(&self, x: usize, y: usize) -> f32 {
        f32::from(self.data[y * self.width + x]) * self.gray_per_unit
    }

    /// Separable [1 2 1]/4 smoothing, edges replicated, of a plane of gray levels (0..=255, as
    /// [`Plane::from_gray`] makes): the sums `Σ w_i w_j I` stay below 16 · 256, and the result
    /// is kept as those sums in sixteenths of a gray level (what `f32` would hold exactly).
    fn smoothed(&self) -> Self {
        let (w, h) = (self.width, self.height);
        let mut data = vec![0u16; w * h];
        // Down the columns first, one row at a time: integer sums are exact in any order.
        let mut down = vec![0u16; w];
        for (y, out) in data.chunks_exact_mut(w).enumerate() {
            let above = &self.data[y.saturating_sub(1) * w..][..w];
            let here = &self.data[y * w..][..w];
            let below = &self.data[(y + 1).min(h - 1) * w..][..w];
            for ((d, &a), (&c, &b)) in down.iter_mut().zip(above).zip(here.iter().zip(below)) {
                *d = a + 2 * c + b;
            }
            out[0] = 3 * down[0] + down[1];
            out[w - 1] = down[w - 2] + 3 * down[w - 1];
            let inner = out[1..w - 1].iter_mut().zip(&down[..w - 2]);
            for ((o, &l), (&c, &r)) in inner.zip(down[1..w - 1].iter().zip(&down[2..])) {
                *o = l + 2 * c + r;
            }
        }
        Self {
            width: w,
            height: h,
            data,
            gray_per_unit: self.gray_per_unit / 16.0,
        }
    }

    /// Bilinear sample with edges replicated (OpenCV `getRectSubPix` semantics).
    fn bilinear(&self, x: f64, y: f64) -> f64 {
        let max_x = (self.width - 1) as f64;
        let max_y = (self.height - 1) as f64;
        let xc = x.clamp(0.0, max_x);
        let yc = y.clamp(0.0, max_y);
        let x0 = xc.floor();
        let y0 = yc.floor();
        let ax = xc - x0;
        let ay = yc - y0;
        let (ix, iy) = (x0 as usize, y0 as usize);
        let ix1 = (ix + 1).min(self.width - 1);
        let iy1 = (iy + 1).min(self.height - 1);
        let top = f64::from(self.at(ix, iy)) * (1.0 - ax) + f64::from(self.at(ix1, iy)) * ax;
        let bottom = f64::from(self.at(ix, iy1)) * (1.0 - ax) + f64::from(self.at(ix1, iy1)) * ax;
        top * (1.0 - ay) + bottom * ay
    }
}

/// A saddle candidate: integer position and response.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    x: f64,
    y: f64,
    response: f32,
}

/// The inner corners of `board` in `image`, in OpenCV's order (rows of `board.inner_cols`),
/// refined to sub-pixel.
///
/// # Errors
/// [`ChessboardError`] when the image holds no complete board of that size.
pub fn find_chessboard_corners(
    image: &GrayImage,
    board: &Chessboard,
    config: &CornerConfig,
) -> Result<Vec<Pixel>, ChessboardError> {
    let min_side = 2 * (RING_RADIUS as u32) + 3;
    if image.width() < min_side || image.height() < min_side {
        return Err(ChessboardError::TooSmall {
            width: image.width(),
            height: image.height(),
        });
    }
    let raw = Plane::from_gray(image);
    let smooth = raw.smoothed();
    let candidates = saddle_candidates(&smooth, config);
    if candidates.is_empty() {
        return Err(ChessboardError::NoSaddles);
    }
    let (cols, rows) = (board.inner_cols, board.inner_rows);
    let mut largest = 0;
    // First complete lattices only; then a lattice missing one corner (a finger over it, a
    // glint), that corner inferred from its neighbours and kept only if a saddle is there.
    // Seeds first take their axes from their four nearest saddles; only when no board is found
    // that way do they look further out (a strongly foreshortened board).
    for (seed_axes, max_missing) in [
        (SeedAxes::Nearest, 0),
        (SeedAxes::Nearest, 1),
        (SeedAxes::Crossing, 0),
        (SeedAxes::Crossing, 1),
    ] {
        // Seeds in order of response: a real board's corners are the strongest saddles.
        for seed in 0..candidates.len().min(64) {
            let Some(lattice) = grow_lattice(&candidates, seed, seed_axes, 3 * cols * rows, config)
            else {
                continue;
            };
            largest = largest.max(lattice.len());
            if lattice.len() + max_missing < cols * rows {
                continue;
            }
            // The seed's axes may be a board axis and a diagonal (a foreshortened board's
            // diagonal can be shorter than its long step): the lattice is then whole but
            // numbered on sheared axes. Renumbered on the board's axes, its cells are squares
            // again, which `board_window` checks by their alternating brightness.
            let Some((grid, inferred)) = SHEARS.iter().find_map(|&shear| {
                board_window(
                    &sheared(&lattice, shear),
                    &candidates,
                    &smooth,
                    cols,
                    rows,
                    max_missing,
                )
            }) else {
                continue;
            };
            let refined = refine_grid(&raw, &grid, cols, config);
            if !stays_on_its_corner(&grid, &refined, cols, &inferred)
                || !fits_its_neighbourhood(&refined, cols)
            {
                continue;
            }
            if inferred
                .iter()
                .all(|&k| confirms_inferred(&smooth, &grid, &refined, cols, k))
            {
                return Ok(refined);
            }
        }
    }
    Err(ChessboardError::NotFound {
        cols,
        rows,
        found: largest,
        candidates: candidates.len(),
    })
}

/// ChESS responses, non-maximum suppressed over a 7x7 neighbourhood, strongest first.
fn saddle_candidates(plane: &Plane, config: &CornerConfig) -> Vec<Candidate> {
    let (response, blocks) = chess_response(plane);
    let (w, h) = (plane.width, plane.height);
    let relative = config.min_relative_response as f32;
    let mut maxima = local_maxima(&response, &blocks, w, h, relative);
    // Raster order before the stable sort below, so equal responses keep a fixed order.
    maxima.sort_unstable();
    let mut candidates: Vec<Candidate> = maxima
        .into_iter()
        .map(|(y, x)| {
            // Centre of mass of the response around the maximum: a better start for the
            // lattice walk than the integer pixel.
            let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
            for yy in y - 1..=y + 1 {
                for xx in x - 1..=x + 1 {
                    let v = f64::from(response[yy * w + xx]);
                    sx += v * xx as f64;
                    sy += v * yy as f64;
                    sw += v;
                }
            }
            Candidate {
                x: sx / sw,
                y: sy / sw,
                response: response[y * w + x],
            }
        })
        .collect();
    candidates.sort_by(|a, b| b.response.total_cmp(&a.response));
    candidates
}

/// Maxima of a response over the 4x4 blocks tiling its interior `[r, w - r) x [r, h - r)`,
/// gathered one row at a time while the row is still in the cache.
struct BlockMaxima {
    r: usize,
    y_end: usize,
    /// Blocks per row of blocks.
    cols: usize,
    /// Row-major, `cols` a row; block `(by, bx)` starts at pixel `(r + 4 by, r + 4 bx)`.
    values: Vec<f32>,
    /// Per interior column, the maximum over the current row of blocks so far.
    column_max: Vec<f32>,
}

impl BlockMaxima {
    const SIDE: usize = 4;

    fn new(w: usize, h: usize, r: usize) -> Self {
        let cols = (w - 2 * r).div_ceil(Self::SIDE);
        let rows = (h - 2 * r).div_ceil(Self::SIDE);
        Self {
            r,
            y_end: h - r,
            cols,
            values: vec![0.0; cols * rows],
            column_max: vec![0.0; w - 2 * r],
        }
    }

    /// Takes the interior of row `y` (`interior[x - r]` for pixel `x`); rows come in order.
    fn add_row(&mut self, y: usize, interior: &[f32]) {
        let in_block = (y - self.r) % Self::SIDE;
        if in_block == 0 {
            self.column_max.copy_from_slice(interior);
        } else {
            for (m, v) in self.column_max.iter_mut().zip(interior) {
                *m = larger(*m, *v);
            }
        }
        if in_block + 1 == Self::SIDE || y + 1 == self.y_end {
            let by = (y - self.r) / Self::SIDE;
            let row = &mut self.values[by * self.cols..(by + 1) * self.cols];
            for (m, run) in row.iter_mut().zip(self.column_max.chunks(Self::SIDE)) {
                *m = run.iter().fold(0.0f32, |m, &v| larger(m, v));
            }
        }
    }
}

/// Pixels `(y, x)` of `response` (`w x h`, zero within `r` of the border, its block maxima in
/// `blocks`) above `relative` times the largest response that beat every other pixel of
/// their 7x7 neighbourhood; ties go to the first in raster order, so a plateau yields one.
/// Only each 4x4 block's own winner is checked against its neighbourhood (Neubeck & Van Gool
/// 2006): a pixel's block lies inside its 7x7 window, so a pixel that beats its window beats
/// its block, and a block's loser cannot be a maximum.
fn local_maxima(
    response: &[f32],
    blocks: &BlockMaxima,
    w: usize,
    h: usize,
    relative: f32,
) -> Vec<(usize, usize)> {
    const NMS: usize = 3;
    const BLOCK: usize = BlockMaxima::SIDE;
    let r = blocks.r;
    let (x_end, y_end) = (w - r, h - r);
    let block_max = &blocks.values;
    let block_xs: Vec<usize> = (r..x_end).step_by(BLOCK).collect();
    let block_ys: Vec<usize> = (r..y_end).step_by(BLOCK).collect();
    let threshold = relative * block_max.iter().fold(0.0f32, |m, &v| larger(m, v));
    let beats = |value: f32, y: usize, x: usize, yy: usize, xx: usize| {
        let other = response[yy * w + xx];
        value > other || (value == other && (y, x) <= (yy, xx))
    };
    let mut maxima = Vec::new();
    for (row_of_blocks, &y0) in block_max.chunks_exact(block_xs.len()).zip(&block_ys) {
        for (&value, &x0) in row_of_blocks.iter().zip(&block_xs) {
            if value <= threshold {
                continue;
            }
            // The block's winner: its first pixel in raster order holding the block's maximum.
            let Some((y, x)) = (y0..(y0 + BLOCK).min(y_end))
                .flat_map(|yy| (x0..(x0 + BLOCK).min(x_end)).map(move |xx| (yy, xx)))
                .find(|&(yy, xx)| response[yy * w + xx] == value)
            else {
                continue;
            };
            let is_max = (y.saturating_sub(NMS)..=(y + NMS).min(h - 1)).all(|yy| {
                (x.saturating_sub(NMS)..=(x + NMS).min(w - 1)).all(|xx| beats(value, y, x, yy, xx))
            });
            if is_max {
                maxima.push((y, x));
            }
        }
    }
    maxima
}

/// The ChESS response at every pixel, the stronger of two ring radii (5 px for large
/// squares, 3 px for small ones), 0 where not positive and within the ring of the border;
/// with its maxima over 4x4 blocks.
fn chess_response(plane: &Plane) -> (Vec<f32>, BlockMaxima) {
    let (w, h) = (plane.width, plane.height);
    let r = RING_RADIUS as usize;
    let mut response = vec![0.0f32; w * h];
    // Row by row, each term over a run of pixels at once (loops the compiler vectorises):
    // ring sample k of pixel x + r is rows[k][x]. Runs of `TILE` pixels keep the 16 sample
    // rows of both rings in the L1 cache on wide images.
    const TILE: usize = 256;
    let n = w - 2 * r;
    let rows_of = |ring: &[(i32, i32); 16], y: usize, x0: usize, len: usize| -> [&[u16]; 16] {
        std::array::from_fn(|k| {
            let (dx, dy) = ring[k];
            let start = (y as i64 + i64::from(dy)) as usize * w
                + (x0 as i64 + r as i64 + i64::from(dx)) as usize;
            &plane.data[start..start + len]
        })
    };
    let mut scratch = ChessRow::new(TILE.min(n), plane.gray_per_unit);
    let mut cross_mean = vec![0.0f32; n];
    let mut small = vec![0.0f32; TILE.min(n)];
    let mut blocks = BlockMaxima::new(w, h, r);
    for y in r..h - r {
        let above = &plane.data[(y - 1) * w + r..(y - 1) * w + r + n];
        let here = &plane.data[y * w + r - 1..y * w + r + n + 1];
        let below = &plane.data[(y + 1) * w + r..(y + 1) * w + r + n];
        scratch.set_cross(above, here, below, &mut cross_mean);
        for x0 in (0..n).step_by(TILE) {
            let len = TILE.min(n - x0);
            let out = &mut response[y * w + r + x0..][..len];
            let cross = &cross_mean[x0..x0 + len];
            scratch.responses(&rows_of(&RING, y, x0, len), cross, out);
            let small = &mut small[..len];
            scratch.responses(&rows_of(&SMALL_RING, y, x0, len), cross, small);
            for (o, v) in out.iter_mut().zip(small.iter()) {
                let best = larger(*o, *v);
                *o = if best > 0.0 { best } else { 0.0 };
            }
        }
        blocks.add_row(y, &response[y * w + r..][..n]);
    }
    (response, blocks)
}

/// The larger of two responses. Responses are never NaN, so a plain comparison is exact; it
/// compiles to one vector instruction, where `f32::max` adds NaN handling to every lane.
fn larger(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}

/// Buffers for the ChESS responses of a run of pixels, in the plane's integer units.
struct ChessRow {
    /// Per pixel, half of
    /// `Σ_{n<4} |a_n + a_{n+8} - a_{n+4} - a_{n+12}| - Σ_{n<8} |a_n - a_{n+8}|`: twice it is
    /// at most 4 · 2 · 4080 in magnitude for samples below 16 · 256, so it fits `i16`.
    contrast: Vec<i16>,
    /// Per pixel, `Σ a_n` over the ring: at most 16 · 4080, so it fits `u16`.
    ring_sum: Vec<u16>,
    gray_per_unit: f32,
}

impl ChessRow {
    fn new(len: usize, gray_per_unit: f32) -> Self {
        Self {
            contrast: vec![0; len],
            ring_sum: vec![0; len],
            gray_per_unit,
        }
    }

    /// The means of the 5-pixel crosses (centre and 4-neighbours) of row `here` (one sample
    /// wider on each side than `cross_mean`), between rows `above` and `below`, gray levels.
    fn set_cross(&self, above: &[u16], here: &[u16], below: &[u16], cross_mean: &mut [f32]) {
        let unit = self.gray_per_unit;
        for (x, mean) in cross_mean.iter_mut().enumerate() {
            // Five samples below 16 · 256 each: the sum fits in 16 bits. The same `f32`
            // division of the same exact sum as an all-`f32` evaluation.
            let sum = here[x + 1] + here[x] + here[x + 2] + above[x] + below[x];
            *mean = f32::from(sum) * unit / 5.0;
        }
    }

    /// ChESS responses in gray levels: `out[x]` for the ring whose sample `k` is
    /// `ring[k][x]`, around pixels whose cross means are `cross_mean[x]`:
    /// `Σ_{n<4} |a_n + a_{n+8} - a_{n+4} - a_{n+12}| - Σ_{n<8} |a_n - a_{n+8}|`
    /// `- 16 |mean(a) - cross mean|`. The sums are exact in integers; the last term is then
    /// formed with the same `f32` operations on the same exact values as an all-`f32`
    /// evaluation, so it equals it bit for bit.
    fn responses(&mut self, ring: &[&[u16]; 16], cross_mean: &[f32], out: &mut [f32]) {
        let len = out.len();
        let (contrast, ring_sum) = (&mut self.contrast[..len], &mut self.ring_sum[..len]);
        // One pass per quarter turn n: samples n, n + 4, n + 8, n + 12 give one term of the
        // first sum and two of the second. With the opposite pairs as intervals
        // [lo1, hi1] ∋ a_n, a_{n+8} and [lo2, hi2] ∋ a_{n+4}, a_{n+12}, the three terms
        // |a_n + a_{n+8} - a_{n+4} - a_{n+12}| - |a_n - a_{n+8}| - |a_{n+4} - a_{n+12}| are
        // exactly 2 max(lo1 - hi2, lo2 - hi1), twice the signed gap between the intervals:
        // fewer operations, same integer. Each pass adds at most 4080 in magnitude.
        for k in 0..4 {
            let (a, b, c, d) = (
                &ring[k][..len],
                &ring[k + 8][..len],
                &ring[k + 4][..len],
                &ring[k + 12][..len],
            );
            for x in 0..len {
                let (a, b, c, d) = (a[x] as i16, b[x] as i16, c[x] as i16, d[x] as i16);
                let (lo1, hi1, lo2, hi2) = (a.min(b), a.max(b), c.min(d), c.max(d));
                let gap = (lo1 - hi2).max(lo2 - hi1);
                let sum = (lo1 + hi1 + lo2 + hi2) as u16;
                // The first pass sets the sums, so no pass to clear them.
                (contrast[x], ring_sum[x]) = if k == 0 {
                    (gap, sum)
                } else {
                    (contrast[x] + gap, ring_sum[x] + sum)
                };
            }
        }
        let unit = self.gray_per_unit;
        let ring_mean_per_unit = unit / 16.0;
        let cross_mean = &cross_mean[..len];
        for (x, o) in out.iter_mut().enumerate() {
            let ring_mean = f32::from(ring_sum[x]) * ring_mean_per_unit;
            let contrast = f32::from(2 * contrast[x]) * unit;
            *o = contrast - 16.0 * (ring_mean - cross_mean[x]).abs();
        }
    }
}

fn distance2(a: &Candidate, bx: f64, by: f64) -> f64 {
    (a.x - bx).powi(2) + (a.y - by).powi(2)
}

/// The candidate nearest to `(x, y)` within `radius`, excluding `used` ones.
fn nearest(candidates: &[Candidate], x: f64, y: f64, radius: f64, used: &[bool]) -> Option<usize> {
    let mut best = None;
    let mut best_d2 = radius * radius;
    for (i, c) in candidates.iter().enumerate() {
        if used[i] {
            continue;
        }
        let d2 = distance2(c, x, y);
        if d2 < best_d2 {
            best_d2 = d2;
            best = Some(i);
        }
    }
    best
}

/// Lattice coordinates `(i, j)` → candidate index.
type Lattice = BTreeMap<(i32, i32), usize>;

/// How a seed picks the two axes it grows the lattice along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SeedAxes {
    /// Its four nearest saddles form two opposite pairs: a lattice node on any board seen
    /// less than very obliquely.
    Nearest,
    /// The nearest saddle with an opposite one, then the nearest with an opposite one that
    /// crosses it: on a board foreshortened to a third along one axis, the four nearest
    /// saddles are ±1 and ±2 steps along that axis, and the other axis lies further out.
    Crossing,
}

/// Grows the lattice through `seed`; `None` when the seed does not look like a lattice node.
fn grow_lattice(
    candidates: &[Candidate],
    seed: usize,
    seed_axes: SeedAxes,
    max_nodes: usize,
    config: &CornerConfig,
) -> Option<Lattice> {
    let s = candidates[seed];
    let mut near: Vec<(f64, usize)> = candidates
        .iter()
        .enumerate()
        .filter(|&(i, _)| i != seed)
        .map(|(i, c)| (distance2(c, s.x, s.y), i))
        .collect();
    if near.len() < 4 {
        return None;
    }
    let considered = near.len().min(if seed_axes == SeedAxes::Nearest {
        4
    } else {
        SEED_NEIGHBOURS
    });
    near.select_nth_unstable_by(considered - 1, |a, b| a.0.total_cmp(&b.0));
    near.truncate(considered);
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    let d: Vec<(f64, f64)> = near
        .iter()
        .map(|&(_, i)| (candidates[i].x - s.x, candidates[i].y - s.y))
        .collect();
    let opposite = |a: (f64, f64), b: (f64, f64)| {
        let gap = (a.0 + b.0).hypot(a.1 + b.1);
        gap < config.step_tolerance * a.0.hypot(a.1).max(b.0.hypot(b.1))
    };
    let has_opposite = |k: usize| (0..d.len()).any(|m| m != k && opposite(d[k], d[m]));
    let sine =
        |u: (f64, f64), v: (f64, f64)| (u.0 * v.1 - u.1 * v.0) / (u.0.hypot(u.1) * v.0.hypot(v.1));
    if seed_axes == SeedAxes::Nearest && !(0..d.len()).all(has_opposite) {
        return None;
    }
    let first = (0..d.len()).find(|&k| has_opposite(k))?;
    let u = d[first];
    let v = d[(0..d.len()).find(|&k| sine(u, d[k]).abs() >= 0.5 && has_opposite(k))?];

    let mut lattice = Lattice::new();
    let mut used = vec![false; candidates.len()];
    // Per node: the last step seen along i and along j.
    let mut steps: BTreeMap<(i32, i32), [(f64, f64); 2]> = BTreeMap::new();
    lattice.insert((0, 0), seed);
    used[seed] = true;
    steps.insert((0, 0), [u, v]);
    let mut queue = VecDeque::from([(0i32, 0i32)]);
    while let Some((i, j)) = queue.pop_front() {
        if lattice.len() >= max_nodes {
            // Grown over clutter or a weak-response field: no board of this size here.
            return None;
        }
        let p = candidates[lattice[&(i, j)]];
        let node_steps = steps[&(i, j)];
        for (axis, sign) in [(0usize, 1i32), (0, -1), (1, 1), (1, -1)] {
            let (di, dj) = if axis == 0 { (sign, 0) } else { (0, sign) };
            let target = (i + di, j + dj);
            if lattice.contains_key(&target) {
                continue;
            }
            // Extrapolate from the node behind when there is one (follows perspective).
            let step = match lattice.get(&(i - di, j - dj)) {
                Some(&behind) => (p.x - candidates[behind].x, p.y - candidates[behind].y),
                None => {
                    let base = node_steps[axis];
                    (base.0 * f64::from(sign), base.1 * f64::from(sign))
                }
            };
            let radius = config.step_tolerance * step.0.hypot(step.1);
            let (x, y) = (p.x + step.0, p.y + step.1);
            let Some(found) = nearest(candidates, x, y, radius, &used) else {
                continue;
            };
            used[found] = true;
            lattice.insert(target, found);
            let actual = (
                (candidates[found].x - p.x) * f64::from(sign),
                (candidates[found].y - p.y) * f64::from(sign),
            );
            let mut new_steps = node_steps;
            new_steps[axis] = actual;
            steps.insert(target, new_steps);
            queue.push_back(target);
        }
    }
    Some(lattice)
}

/// Nearest saddles a [`SeedAxes::Crossing`] seed looks among: enough to reach the long axis of
/// a board foreshortened to a fifth along the other (±1…±5 steps along it come first).
const SEED_NEIGHBOURS: usize = 12;

/// Renumberings of a lattice tried in turn, as `(along i, along j)`: `(k, 0)` maps node
/// `(i, j)` to `(i + k j, j)`, `(0, k)` to `(i, j + k i)`. A seed axis on a diagonal makes the
/// shear ±1; ±2 covers a step to the next-but-one diagonal. The identity comes first.
const SHEARS: [(i32, i32); 9] = [
    (0, 0),
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (2, 0),
    (-2, 0),
    (0, 2),
    (0, -2),
];

/// `lattice` renumbered by one of [`SHEARS`]: a unimodular change of axes, so every node keeps
/// its neighbours and only the axes the window is read along change.
fn sheared(lattice: &Lattice, (along_i, along_j): (i32, i32)) -> Lattice {
    lattice
        .iter()
        .map(|(&(i, j), &c)| ((i + along_i * j, j + along_j * i), c))
        .collect()
}

/// The board inside a grown lattice: a `cols x rows` window (either way round) with at most
/// `max_missing` corners absent (predicted from their neighbours), whose squares alternate in
/// brightness, ordered as OpenCV orders it; with the indices of the predicted corners.
fn board_window(
    lattice: &Lattice,
    candidates: &[Candidate],
    plane: &Plane,
    cols: usize,
    rows: usize,
    max_missing: usize,
) -> Option<(Vec<Pixel>, Vec<usize>)> {
    let i_min = lattice.keys().map(|k| k.0).min()?;
    let i_max = lattice.keys().map(|k| k.0).max()?;
    let j_min = lattice.keys().map(|k| k.1).min()?;
    let j_max = lattice.keys().map(|k| k.1).max()?;
    let mut found: Option<(Vec<Vec<Pixel>>, Vec<Pixel>)> = None;
    for (span_i, span_j) in [(cols, rows), (rows, cols)] {
        let (span_i, span_j) = (span_i as i32, span_j as i32);
        for i0 in i_min..=i_max - span_i + 1 {
            for j0 in j_min..=j_max - span_j + 1 {
                // grid[b][a]: a along i, b along j.
                let sparse: Vec<Vec<Option<Pixel>>> = (0..span_j)
                    .map(|b| {
                        (0..span_i)
                            .map(|a| {
                                lattice
                                    .get(&(i0 + a, j0 + b))
                                    .map(|&c| Pixel::new(candidates[c].x, candidates[c].y))
                            })
                            .collect()
                    })
                    .collect();
                let missing = sparse.iter().flatten().filter(|p| p.is_none()).count();
                if missing > max_missing {
                    continue;
                }
                let Some((grid, predicted)) = fill_missing(&sparse) else {
                    continue;
                };
                if !alternates(&grid, plane) {
                    continue;
                }
                let grid = if span_i as usize == cols {
                    grid
                } else {
                    transpose(&grid)
                };
                if found.is_some() {
                    // Two boards or a lattice of clutter: refuse rather than guess.
                    return None;
                }
                found = Some((grid, predicted));
            }
        }
        if cols == rows {
            break;
        }
    }
    let (grid, predicted) = found?;
    let ordered = opencv_order(grid, plane);
    let inferred = ordered
        .iter()
        .enumerate()
        .filter(|(_, p)| predicted.contains(p))
        .map(|(k, _)| k)
        .collect();
    Some((ordered, inferred))
}

/// Fills absent corners by linear prediction from two neighbours on a line (the midpoint of
/// a pair around it, or the extrapolation of two on one side); `None` when one cannot be.
fn fill_missing(sparse: &[Vec<Option<Pixel>>]) -> Option<(Vec<Vec<Pixel>>, Vec<Pixel>)> {
    let rows = sparse.len() as i64;
    let cols = sparse.first().map_or(0, Vec::len) as i64;
    let at = |r: i64, c: i64| -> Option<Pixel> {
        if (0..rows).contains(&r) && (0..cols).contains(&c) {
            sparse[r as usize][c as usize]
        } else {
            None
        }
    };
    let mut predicted = Vec::new();
    let mut grid = Vec::with_capacity(sparse.len());
    for r in 0..rows {
        let mut row = Vec::with_capacity(cols as usize);
        for c in 0..cols {
            if let Some(p) = at(r, c) {
                row.push(p);
                continue;
            }
            let mut guess = None;
            for (dr, dc) in [(0, 1), (1, 0)] {
                if let (Some(a), Some(b)) = (at(r - dr, c - dc), at(r + dr, c + dc)) {
                    guess = Some(Pixel::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y)));
                    break;
                }
            }
            if guess.is_none() {
                for (dr, dc) in [(0, 1), (0, -1), (1, 0), (-1, 0)] {
                    if let (Some(a), Some(b)) = (at(r + dr, c + dc), at(r + 2 * dr, c + 2 * dc)) {
                        guess = Some(Pixel::new(2.0 * a.x - b.x, 2.0 * a.y - b.y));
                        break;
                    }
                }
            }
            let guess = guess?;
            predicted.push(guess);
            row.push(guess);
        }
        grid.push(row);
    }
    Some((grid, predicted))
}

/// Indices of the corners within `reach` rows and columns of corner `k` of a grid of `len`
/// corners in rows of `cols`, row by row, `k` itself left out: reach 1 gives its eight
/// neighbours, reach 2 the 5x5 block around it.
fn grid_neighbours(k: usize, cols: usize, len: usize, reach: usize) -> impl Iterator<Item = usize> {
    let (r, c) = (k / cols, k % cols);
    let rows = len / cols;
    (r.saturating_sub(reach)..(r + reach + 1).min(rows))
        .flat_map(move |rr| {
            (c.saturating_sub(reach)..(c + reach + 1).min(cols)).map(move |cc| rr * cols + cc)
        })
        .filter(move |&n| n != k)
}

/// Indices of the corners next to corner `k` along its row and its column (two to four).
fn edge_neighbours(k: usize, cols: usize, len: usize) -> impl Iterator<Item = usize> {
    grid_neighbours(k, cols, len, 1).filter(move |&n| n / cols == k / cols || n % cols == k % cols)
}

/// True when sub-pixel refinement kept every pair of lattice neighbours at least half their
/// distance apart. Where squares are only a few pixels wide along a foreshortened axis, the
/// sub-pixel window reaches the neighbouring corner and two corners can slide onto one.
/// Pairs with an `inferred` corner are skipped: its predicted position is only a guess, and
/// [`confirms_inferred`] checks it.
fn stays_on_its_corner(grid: &[Pixel], refined: &[Pixel], cols: usize, inferred: &[usize]) -> bool {
    let apart = |a: usize, b: usize| {
        inferred.contains(&a)
            || inferred.contains(&b)
            || refined[a].is_finite()
                && refined[b].is_finite()
                && refined[a].distance(&refined[b]) >= 0.5 * grid[a].distance(&grid[b])
    };
    (0..grid.len()).all(|k| {
        (k % cols + 1 == cols || apart(k, k + 1)) && (k + cols >= grid.len() || apart(k, k + cols))
    })
}

/// How far, in lattice steps, a refined corner may lie from where a homography through its
/// neighbours puts it. On the 34 real photographs of `../shared/data/calib` the worst correct
/// corner lies 0.14 step off (strong lens distortion, 10 px squares); a corner on the wrong
/// square, on clutter or slid onto a neighbour lies a whole step or more off.
const MAX_OFF_NEIGHBOURHOOD_STEPS: f64 = 0.3;

/// True when every refined corner agrees with its neighbourhood: a homography fitted to the
/// other corners within two lattice steps (a plane seen in perspective; lens distortion bends
/// it little over so short a span) predicts it within [`MAX_OFF_NEIGHBOURHOOD_STEPS`] of the
/// shortest lattice step there. The last check on a board: a lattice grown partly on clutter
/// or numbered one square off passes the brightness checks but not this one.
fn fits_its_neighbourhood(refined: &[Pixel], cols: usize) -> bool {
    let on_lattice = |n: usize| Point3::new((n % cols) as f64, (n / cols) as f64, 0.0);
    (0..refined.len()).all(|k| {
        let block: Vec<usize> = grid_neighbours(k, cols, refined.len(), 2).collect();
        let lattice: Vec<Point3> = block.iter().map(|&n| on_lattice(n)).collect();
        let pixels: Vec<Pixel> = block.iter().map(|&n| refined[n]).collect();
        let Ok(h) = zhang::homography(&lattice, &pixels, k) else {
            return false;
        };
        let map = |i: f64, j: f64| {
            let p = h * Vector3::new(i, j, 1.0);
            Pixel::new(p.x / p.z, p.y / p.z)
        };
        let (i, j) = ((k % cols) as f64, (k / cols) as f64);
        let predicted = map(i, j);
        // The local step as the neighbourhood's homography has it, so that a corner off its
        // place does not change the yardstick it is measured with.
        let step = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
            .iter()
            .map(|(di, dj)| predicted.distance(&map(i + di, j + dj)))
            .fold(f64::INFINITY, f64::min);
        predicted.distance(&refined[k]) <= MAX_OFF_NEIGHBOURHOOD_STEPS * step
    })
}

/// An inferred corner stands when refinement moved it less than a quarter of a square from
/// its prediction and settled on a corner as well defined as its neighbours: a structure
/// tensor with two strong directions (`λmin / λmax ≥ 0.2`), and `λmin` at least a fifth of
/// the neighbours' median (not a flat patch, not an edge). A ChESS test would refuse a corner
/// with a finger over one quadrant; the gradients of the other three still pin it.
fn confirms_inferred(
    plane: &Plane,
    predicted: &[Pixel],
    refined: &[Pixel],
    cols: usize,
    k: usize,
) -> bool {
    let neighbour = if k % cols + 1 < cols { k + 1 } else { k - 1 };
    let square = predicted[k].distance(&predicted[neighbour]);
    let settled = refined[k];
    if !(settled.is_finite() && predicted[k].distance(&settled) <= 0.25 * square) {
        return false;
    }
    let half = ((square / 4.0).round() as usize).max(2);
    let (lo, hi) = subpix::structure_eigenvalues(plane, settled, half);
    let mut others: Vec<f64> = edge_neighbours(k, cols, refined.len())
        .map(|n| subpix::structure_eigenvalues(plane, refined[n], half).0)
        .collect();
    others.sort_by(f64::total_cmp);
    let Some(&median) = others.get(others.len() / 2) else {
        return false;
    };
    hi > 0.0 && lo >= 0.2 * hi && lo >= 0.2 * median
}

fn transpose(grid: &[Vec<Pixel>]) -> Vec<Vec<Pixel>> {
    let rows = grid.len();
    let cols = grid.first().map_or(0, Vec::len);
    (0..cols)
        .map(|c| (0..rows).map(|r| grid[r][c]).collect())
        .collect()
}

/// Mean brightness at the centre of square `(r, c)` of a corner grid.
fn square_brightness(grid: &[Vec<Pixel>], plane: &Plane, r: usize, c: usize) -> f64 {
    let x = 0.25 * (grid[r][c].x + grid[r][c + 1].x + grid[r + 1][c].x + grid[r + 1][c + 1].x);
    let y = 0.25 * (grid[r][c].y + grid[r][c + 1].y + grid[r + 1][c].y + grid[r + 1][c + 1].y);
    plane.bilinear(x, y)
}

/// Brightness differences between neighbouring squares of a corner grid, each signed so it is
/// positive when the square whose index sum is even is the brighter one.
fn neighbour_differences(grid: &[Vec<Pixel>], plane: &Plane) -> Vec<f64> {
    let rows = grid.len() - 1;
    let cols = grid[0].len() - 1;
    let mut differences = Vec::with_capacity(2 * rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            let here = square_brightness(grid, plane, r, c);
            let sign = if (r + c) % 2 == 0 { 1.0 } else { -1.0 };
            for (rr, cc) in [(r + 1, c), (r, c + 1)] {
                if rr < rows && cc < cols {
                    differences.push(sign * (here - square_brightness(grid, plane, rr, cc)));
                }
            }
        }
    }
    differences
}

/// True when neighbouring squares of the grid differ in brightness with one consistent sign
/// (uneven light shifts both squares of a pair alike and keeps the sign).
fn alternates(grid: &[Vec<Pixel>], plane: &Plane) -> bool {
    let differences = neighbour_differences(grid, plane);
    let positive = differences.iter().filter(|d| **d > 0.0).count();
    let negative = differences.iter().filter(|d| **d < 0.0).count();
    let pairs = positive + negative;
    // One square pair in ten may disagree (glare, a pen mark); a clutter lattice has no rule.
    pairs > 0 && positive.max(negative) * 10 >= pairs * 9
}

/// OpenCV's order: a row then the next row turn clockwise on screen, and the first square
/// (corners 0, 1, cols, cols + 1) is dark.
fn opencv_order(mut grid: Vec<Vec<Pixel>>, plane: &Plane) -> Vec<Pixel> {
    let cross = |g: &[Vec<Pixel>]| {
        let (p0, p1, p2) = (g[0][0], g[0][1], g[1][0]);
        (p1.x - p0.x) * (p2.y - p0.y) - (p1.y - p0.y) * (p2.x - p0.x)
    };
    if cross(&grid) < 0.0 {
        for row in &mut grid {
            row.reverse();
        }
    }
    let contrast: f64 = neighbour_differences(&grid, plane).iter().sum();
    if contrast > 0.0 {
        // Square (0, 0) is bright: turn the board half a turn (keeps the handedness).
        grid.reverse();
        for row in &mut grid {
            row.reverse();
        }
    }
    grid.into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 9x6 grid seen in strong perspective (one side 1.6x the other), bent by barrel
    /// distortion of 3 % at its corners: what a real photograph gives.
    fn perspective_grid() -> Vec<Pixel> {
        let (cols, rows) = (9, 6);
        (0..rows * cols)
            .map(|k| {
                let (i, j) = ((k % cols) as f64, (k / cols) as f64);
                let w = 1.0 + 0.07 * i;
                let (x, y) = ((40.0 * i + 5.0 * j) / w, (30.0 * j - 4.0 * i) / w);
                let (cx, cy) = (x - 110.0, y - 60.0);
                let bend = 1.0 - 0.03 * (cx * cx + cy * cy) / (140.0 * 140.0);
                Pixel::new(320.0 + cx * bend, 240.0 + cy * bend)
            })
            .collect()
    }

    #[test]
    fn a_board_in_perspective_fits_its_neighbourhoods() {
        assert!(fits_its_neighbourhood(&perspective_grid(), 9));
    }

    /// A corner a third of a step off its place (wrong square, clutter, a slide towards a
    /// neighbour) is refused wherever it sits; one a tenth of a step off (noise, blur) is not.
    #[test]
    fn a_corner_off_its_place_is_refused() {
        let grid = perspective_grid();
        for k in [0_usize, 4, 13, 31, 53] {
            let step = edge_neighbours(k, 9, grid.len())
                .map(|n| grid[k].distance(&grid[n]))
                .fold(f64::INFINITY, f64::min);
            for (share, fits) in [(0.1, true), (0.35, false)] {
                for (dx, dy) in [(1.0, 0.0), (0.0, 1.0), (-0.6, 0.8)] {
                    let mut moved = grid.clone();
                    moved[k] =
                        Pixel::new(grid[k].x + share * step * dx, grid[k].y + share * step * dy);
                    assert_eq!(
                        fits_its_neighbourhood(&moved, 9),
                        fits,
                        "corner {k} moved {share} of a step along ({dx}, {dy})"
                    );
                }
            }
        }
    }
}
