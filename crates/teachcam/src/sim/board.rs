//! Ray-cast rendering of a planar chessboard through the lens model, for rig calibration
//! against truth.
//!
//! Model: the board's frame has its inner corners at `(c s, r s, 0)` in OpenCV's order
//! ([`Chessboard::corners_in_board`]); square `(i, j)` covers `[i s, (i+1) s) x [j s, (j+1) s)`
//! for `i = -1..cols`, `j = -1..rows` (`cols + 1` by `rows + 1` squares) and is dark when `i + j` is even (the square between
//! corners 0, 1, `cols`, `cols + 1` is dark, as [`crate::calib::chessboard`] expects); a white
//! margin surrounds the squares. The printed side is the board's `-z` side (a camera that sees
//! it looks along the board's `+z`, OpenCV's object frame); from behind, the sheet is a plain
//! grey back.
//!
//! A pixel's footprint on the board is found by casting the rays through its four corners
//! (`Camera::undistort` exactly every 4 px, interpolated between with an error below 1e-3 px,
//! then the exact intersection with the plane `z_board = 0`): a pixel whose four corners fall in one square (or all off the sheet) is
//! uniform and takes their mean radiance; any other pixel is supersampled by `n²` n-rooks samples,
//! the board point of each sample interpolated bilinearly between the four exact corner rays
//! (the map from pixel to plane is smooth: over one pixel its bilinear error is of order
//! `1/(8 f)` pixel, ~1e-4 px here, far below the corner noise). Only pixels inside the
//! projected outline of the sheet (plus 2 px) are cast at all. The radiance map then goes
//! through the same point-spread blur, noise and 8-bit quantisation as the sphere renderer
//! ([`super::render`]). Truth: the exact projection of every inner corner.

use image::GrayImage;
use nalgebra::{Matrix3, Vector3};
use rand::Rng;

use super::render::{PixelBox, RenderConfig, form_image};
use crate::calib::Chessboard;
use crate::camera::Camera;
use crate::geometry::{Pixel, Point3, Pose};

/// How the board looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardLook {
    /// White paper around the outer squares, millimetres: 25 mm (half a 50 mm square) keeps
    /// the outer corners clear of the sheet's edge for the detector's ring and window.
    pub margin_mm: f64,
    /// White squares and margin, DN above background: bright, unsaturated after noise.
    pub white_dn: f64,
    /// Black squares, DN above background: printed black reflects a little.
    pub black_dn: f64,
    /// The unprinted back of the sheet, DN above background.
    pub back_dn: f64,
    /// Uneven light: the fraction of the light lost from the sheet's `-x` edge to its `+x`
    /// edge, linearly; 0 (uniform) by default.
    pub light_falloff: f64,
    /// Samples per pixel side where a pixel straddles an edge, placed as n rooks (n² distinct
    /// rows and columns): 8 (64 samples) resolves an edge along a pixel axis to 1/64 px, and
    /// edges at other angles finer still on average along their length.
    pub supersampling: u32,
}

impl Default for BoardLook {
    fn default() -> Self {
        Self {
            margin_mm: 25.0,
            white_dn: 190.0,
            black_dn: 15.0,
            back_dn: 90.0,
            light_falloff: 0.0,
            supersampling: 8,
        }
    }
}

/// One camera's rendered view of the board, with its truth.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardImage {
    /// The 8-bit image.
    pub image: GrayImage,
    /// The exact projection of every inner corner, in OpenCV's order; `None` behind the camera.
    pub corners: Vec<Option<Pixel>>,
    /// True when the camera sees the printed side.
    pub front_facing: bool,
    /// True when the whole sheet, margin included, lies inside the image.
    pub whole_in_image: bool,
}

/// What a point of the board plane shows; equal regions have equal colour (up to the light).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Region {
    /// Off the sheet, or no intersection: background.
    Off,
    /// The plain back of the sheet.
    Back,
    /// The white margin.
    Margin,
    /// Square `(i, j)`.
    Square(i64, i64),
}

/// The sheet's geometry in the board frame, and the plane as one camera sees it.
struct Sheet<'a> {
    board: &'a Chessboard,
    look: &'a BoardLook,
    /// The sheet's outline: `x_min, y_min, x_max, y_max`, millimetres.
    outline: [f64; 4],
    front: bool,
    board_from_camera_rotation: Matrix3<f64>,
    board_in_camera: Vector3<f64>,
    normal_in_camera: Vector3<f64>,
}

impl<'a> Sheet<'a> {
    fn new(board: &'a Chessboard, look: &'a BoardLook, camera_from_board: &Pose) -> Self {
        let s = board.square_mm;
        let outline = [
            -s - look.margin_mm,
            -s - look.margin_mm,
            board.inner_cols as f64 * s + look.margin_mm,
            board.inner_rows as f64 * s + look.margin_mm,
        ];
        let rotation = camera_from_board.rotation.to_rotation_matrix().into_inner();
        let board_in_camera = camera_from_board.translation.vector;
        let normal_in_camera = rotation.column(2).into_owned();
        // The camera centre lies on the board's -z side exactly when n · t > 0.
        let front = normal_in_camera.dot(&board_in_camera) > 0.0;
        Self {
            board,
            look,
            outline,
            front,
            board_from_camera_rotation: rotation.transpose(),
            board_in_camera,
            normal_in_camera,
        }
    }

    /// The board-plane point (x, y) hit by the ray through a normalised image point.
    fn hit(&self, x: f64, y: f64) -> Option<[f64; 2]> {
        let direction = Vector3::new(x, y, 1.0);
        let denominator = self.normal_in_camera.dot(&direction);
        let along = self.normal_in_camera.dot(&self.board_in_camera) / denominator;
        if !along.is_finite() || along <= 0.0 {
            return None;
        }
        let in_board = self.board_from_camera_rotation * (direction * along - self.board_in_camera);
        Some([in_board.x, in_board.y])
    }

    fn region(&self, point: Option<[f64; 2]>) -> Region {
        let Some([x, y]) = point else {
            return Region::Off;
        };
        let [x0, y0, x1, y1] = self.outline;
        if !(x >= x0 && x < x1 && y >= y0 && y < y1) {
            return Region::Off;
        }
        if !self.front {
            return Region::Back;
        }
        let s = self.board.square_mm;
        let i = (x / s).floor() as i64;
        let j = (y / s).floor() as i64;
        let cols = self.board.inner_cols as i64;
        let rows = self.board.inner_rows as i64;
        if (-1..cols).contains(&i) && (-1..rows).contains(&j) {
            Region::Square(i, j)
        } else {
            Region::Margin
        }
    }

    /// Radiance above background, DN.
    fn radiance(&self, point: Option<[f64; 2]>) -> f64 {
        let level = match self.region(point) {
            Region::Off => return 0.0,
            Region::Back => self.look.back_dn,
            Region::Margin => self.look.white_dn,
            Region::Square(i, j) if (i + j).rem_euclid(2) == 0 => self.look.black_dn,
            Region::Square(..) => self.look.white_dn,
        };
        let x = point.map_or(0.0, |p| p[0]);
        let [x0, _, x1, _] = self.outline;
        level * (1.0 - self.look.light_falloff * (x - x0) / (x1 - x0))
    }

    /// Points along the sheet's outline, board frame, for its image's extent.
    fn outline_points(&self) -> Vec<Point3> {
        const PER_EDGE: usize = 64;
        let [x0, y0, x1, y1] = self.outline;
        (0..PER_EDGE)
            .flat_map(|k| {
                let a = k as f64 / PER_EDGE as f64;
                let x = x0 + a * (x1 - x0);
                let y = y0 + a * (y1 - y0);
                [
                    Point3::new(x, y0, 0.0),
                    Point3::new(x1, y, 0.0),
                    Point3::new(x1 + x0 - x, y1, 0.0),
                    Point3::new(x0, y1 + y0 - y, 0.0),
                ]
            })
            .collect()
    }
}

/// The pixels to cast, and whether the whole sheet is in the image.
fn extent(camera: &Camera, sheet: &Sheet, camera_from_board: &Pose) -> (Option<PixelBox>, bool) {
    let (width, height) = (camera.image_size.width, camera.image_size.height);
    let full = PixelBox {
        x0: 0,
        y0: 0,
        x1: i64::from(width) - 1,
        y1: i64::from(height) - 1,
    };
    let projected: Option<Vec<Pixel>> = sheet
        .outline_points()
        .iter()
        .map(|p| camera.project_from_camera(&camera_from_board.transform_point(p)))
        .collect();
    // Part of the sheet behind the camera: its image is unbounded; cast every pixel.
    let Some(projected) = projected else {
        return (Some(full), false);
    };
    let whole = projected.iter().all(|p| camera.image_size.contains(p));
    let (mut lo, mut hi) = (
        Pixel::new(f64::INFINITY, f64::INFINITY),
        Pixel::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    for p in &projected {
        lo = Pixel::new(lo.x.min(p.x), lo.y.min(p.y));
        hi = Pixel::new(hi.x.max(p.x), hi.y.max(p.y));
    }
    let bounds = PixelBox {
        x0: ((lo.x - 2.0).floor() as i64).max(0),
        y0: ((lo.y - 2.0).floor() as i64).max(0),
        x1: ((hi.x + 2.0).ceil() as i64).min(full.x1),
        y1: ((hi.y + 2.0).ceil() as i64).min(full.y1),
    };
    (
        (bounds.x0 <= bounds.x1 && bounds.y0 <= bounds.y1).then_some(bounds),
        whole,
    )
}

/// True when `camera` sees the printed side of the board at `world_from_board` and the whole
/// sheet, margin included, inside its image (geometry only, nothing rendered).
#[must_use]
pub fn sees_whole_front(
    camera: &Camera,
    board: &Chessboard,
    look: &BoardLook,
    world_from_board: &Pose,
) -> bool {
    let camera_from_board = camera.camera_from_world * world_from_board;
    let sheet = Sheet::new(board, look, &camera_from_board);
    sheet.front && extent(camera, &sheet, &camera_from_board).1
}

/// True when `camera` sees the printed side of the board at `world_from_board` with every
/// inner corner at least `border_px` inside its image (geometry only).
#[must_use]
pub fn sees_corners_front(
    camera: &Camera,
    board: &Chessboard,
    world_from_board: &Pose,
    border_px: f64,
) -> bool {
    let camera_from_board = camera.camera_from_world * world_from_board;
    let look = BoardLook::default();
    let front = Sheet::new(board, &look, &camera_from_board).front;
    let (width, height) = (
        f64::from(camera.image_size.width),
        f64::from(camera.image_size.height),
    );
    front
        && board.corners_in_board().iter().all(|p| {
            camera
                .project_from_camera(&camera_from_board.transform_point(p))
                .is_some_and(|q| {
                    q.x >= border_px
                        && q.y >= border_px
                        && q.x <= width - 1.0 - border_px
                        && q.y <= height - 1.0 - border_px
                })
        })
}

/// Renders one camera's view of a chessboard at `world_from_board`, with the truth of its
/// corners. Deterministic for the state of `rng`.
pub fn render_board<R: Rng>(
    camera: &Camera,
    board: &Chessboard,
    world_from_board: &Pose,
    look: &BoardLook,
    config: &RenderConfig,
    rng: &mut R,
) -> BoardImage {
    let (width, height) = (camera.image_size.width, camera.image_size.height);
    let camera_from_board = camera.camera_from_world * world_from_board;
    let sheet = Sheet::new(board, look, &camera_from_board);
    let corners = board
        .corners_in_board()
        .iter()
        .map(|p| camera.project_from_camera(&camera_from_board.transform_point(p)))
        .collect();
    let (bounds, whole_in_image) = extent(camera, &sheet, &camera_from_board);
    let mut coverage = vec![0.0_f32; width as usize * height as usize];
    let mut boxes = Vec::new();
    if let Some(b) = bounds {
        cast(camera, &sheet, b, &mut coverage);
        boxes.push(b.grown(config.psf_margin_px(), width, height));
    }
    BoardImage {
        image: form_image(&coverage, width, height, &boxes, config, rng),
        corners,
        front_facing: sheet.front,
        whole_in_image,
    }
}

/// Pixel-corner spacing of the exactly undistorted rays, pixels. Between them the normalised
/// ray is interpolated bilinearly; the error is `h²/8 · |∂²n/∂u²|`, for the simulated lenses
/// (|k1| ≤ 0.1 at r ≤ 0.45) about `16/8 · 6 |k1| r / f` ≈ 3e-4 px at h = 4 (the test
/// `interpolated_rays_match_exact_undistortion` measures it).
const RAY_GRID_STEP_PX: usize = 4;

/// Normalised rays of the pixel corners of a box, exact every [`RAY_GRID_STEP_PX`] and
/// interpolated between: `Camera::undistort` is an iterative solve and would otherwise be
/// most of a view's rendering time.
struct RayGrid {
    nodes: Vec<Option<[f64; 2]>>,
    node_cols: usize,
}

impl RayGrid {
    fn new(camera: &Camera, bounds: &PixelBox) -> Self {
        let corners_x = (bounds.x1 - bounds.x0 + 2) as usize;
        let corners_y = (bounds.y1 - bounds.y0 + 2) as usize;
        let node_cols = corners_x.div_ceil(RAY_GRID_STEP_PX) + 1;
        let node_rows = corners_y.div_ceil(RAY_GRID_STEP_PX) + 1;
        let nodes = (0..node_rows)
            .flat_map(|r| (0..node_cols).map(move |c| (c, r)))
            .map(|(c, r)| {
                let px = Pixel::new(
                    (bounds.x0 + (c * RAY_GRID_STEP_PX) as i64) as f64 - 0.5,
                    (bounds.y0 + (r * RAY_GRID_STEP_PX) as i64) as f64 - 0.5,
                );
                camera.undistort(&px).ok().map(|n| [n.x, n.y])
            })
            .collect();
        Self { nodes, node_cols }
    }

    /// The normalised ray of pixel corner `(gx, gy)` of the box; `None` where a node failed.
    fn at(&self, gx: usize, gy: usize) -> Option<[f64; 2]> {
        let (c, r) = (gx / RAY_GRID_STEP_PX, gy / RAY_GRID_STEP_PX);
        let u = (gx % RAY_GRID_STEP_PX) as f64 / RAY_GRID_STEP_PX as f64;
        let v = (gy % RAY_GRID_STEP_PX) as f64 / RAY_GRID_STEP_PX as f64;
        let node = |dc: usize, dr: usize| self.nodes[(r + dr) * self.node_cols + c + dc];
        let (a, b, cc, d) = (node(0, 0)?, node(1, 0)?, node(0, 1)?, node(1, 1)?);
        Some([0, 1].map(|k| {
            (a[k] * (1.0 - u) + b[k] * u) * (1.0 - v) + (cc[k] * (1.0 - u) + d[k] * u) * v
        }))
    }
}

/// Fills `coverage` inside `bounds` with the sheet's radiance, DN.
fn cast(camera: &Camera, sheet: &Sheet, bounds: PixelBox, coverage: &mut [f32]) {
    let width = camera.image_size.width as usize;
    let grid_cols = (bounds.x1 - bounds.x0 + 2) as usize;
    let grid_rows = (bounds.y1 - bounds.y0 + 2) as usize;
    let ray = |px: Pixel| -> Option<[f64; 2]> {
        let normalized = camera.undistort(&px).ok()?;
        sheet.hit(normalized.x, normalized.y)
    };
    let rays = RayGrid::new(camera, &bounds);
    // Board points of the pixel corners: corner (gx, gy) is at pixel (x0 + gx - ½, y0 + gy - ½).
    let grid: Vec<Option<[f64; 2]>> = (0..grid_rows)
        .flat_map(|gy| (0..grid_cols).map(move |gx| (gx, gy)))
        .map(|(gx, gy)| match rays.at(gx, gy) {
            Some(n) => sheet.hit(n[0], n[1]),
            None => ray(Pixel::new(
                (bounds.x0 + gx as i64) as f64 - 0.5,
                (bounds.y0 + gy as i64) as f64 - 0.5,
            )),
        })
        .collect();
    let shade: Vec<(Region, f64)> = grid
        .iter()
        .map(|p| (sheet.region(*p), sheet.radiance(*p)))
        .collect();
    let n = sheet.look.supersampling.max(1);
    let step = 1.0 / f64::from(n);
    // n-rooks samples on a sheared grid: n² distinct columns and rows, so an edge along either
    // pixel axis is resolved to 1/n² of a pixel, not 1/n.
    let samples: Vec<[f64; 2]> = (0..n)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .map(|(i, j)| {
            [
                (f64::from(i) + (f64::from(j) + 0.5) * step) * step,
                (f64::from(j) + (f64::from(i) + 0.5) * step) * step,
            ]
        })
        .collect();
    for gy in 0..grid_rows - 1 {
        for gx in 0..grid_cols - 1 {
            let corners = [
                gy * grid_cols + gx,
                gy * grid_cols + gx + 1,
                (gy + 1) * grid_cols + gx,
                (gy + 1) * grid_cols + gx + 1,
            ];
            let region = shade[corners[0]].0;
            let value = if corners.iter().all(|k| shade[*k].0 == region) {
                corners.iter().map(|k| shade[*k].1).sum::<f64>() / 4.0
            } else {
                let (col, row) = (bounds.x0 + gx as i64, bounds.y0 + gy as i64);
                let quad = corners.map(|k| grid[k]);
                let sum: f64 = samples
                    .iter()
                    .map(|[u, v]| {
                        let point = match quad {
                            [Some(a), Some(b), Some(c), Some(d)] => Some([0, 1].map(|k| {
                                (a[k] * (1.0 - u) + b[k] * u) * (1.0 - v)
                                    + (c[k] * (1.0 - u) + d[k] * u) * v
                            })),
                            // A ray of this pixel misses the plane (the horizon): cast exactly.
                            _ => ray(Pixel::new(col as f64 - 0.5 + u, row as f64 - 0.5 + v)),
                        };
                        sheet.radiance(point)
                    })
                    .sum();
                sum / samples.len() as f64
            };
            let index = (bounds.y0 as usize + gy) * width + bounds.x0 as usize + gx;
            coverage[index] = value as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::scenario::paper_rig;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    const BOARD: Chessboard = Chessboard {
        inner_cols: 9,
        inner_rows: 6,
        square_mm: 50.0,
    };

    /// The interpolated rays agree with exact undistortion to well below the corner noise.
    #[test]
    fn interpolated_rays_match_exact_undistortion() {
        for camera in crate::sim::scenario::four_camera_rig().cameras {
            let bounds = PixelBox {
                x0: 0,
                y0: 0,
                x1: 1279,
                y1: 1023,
            };
            let rays = RayGrid::new(&camera, &bounds);
            let mut worst_px = 0.0_f64;
            for gy in (0..1025).step_by(7) {
                for gx in (0..1281).step_by(5) {
                    let px = Pixel::new(gx as f64 - 0.5, gy as f64 - 0.5);
                    let exact = camera.undistort(&px).unwrap_or_else(|e| panic!("{e}"));
                    let n = rays.at(gx, gy).unwrap_or_else(|| panic!("no ray"));
                    worst_px = worst_px.max(
                        ((n[0] - exact.x) * camera.intrinsics.fx)
                            .hypot((n[1] - exact.y) * camera.intrinsics.fy),
                    );
                }
            }
            assert!(worst_px < 1e-3, "{}: {worst_px} px", camera.name);
        }
    }

    /// A point of a square's interior images at that square's level, the back at the back's.
    #[test]
    fn squares_have_their_colour_and_the_back_is_plain() {
        let camera = paper_rig().cameras.remove(0);
        // Board facing the camera: its +z along the camera's viewing direction.
        let world_from_camera = camera.camera_from_world.inverse();
        let world_from_board = world_from_camera * Pose::translation(-200.0, -125.0, 1000.0);
        let config = RenderConfig {
            read_noise_dn: 0.0,
            shot_noise_dn_per_dn: 0.0,
            ..RenderConfig::default()
        };
        let look = BoardLook::default();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let front = render_board(&camera, &BOARD, &world_from_board, &look, &config, &mut rng);
        assert!(front.front_facing && front.whole_in_image);
        let level = |image: &GrayImage, board_x: f64, board_y: f64| {
            let p = camera
                .project(&(world_from_board * Point3::new(board_x, board_y, 0.0)))
                .unwrap_or_else(|| panic!("no projection"));
            f64::from(image.get_pixel(p.x.round() as u32, p.y.round() as u32)[0])
        };
        let background = config.background_dn;
        // Square (0, 0) dark, (1, 0) white, the margin white.
        assert!((level(&front.image, 25.0, 25.0) - background - look.black_dn).abs() <= 1.0);
        assert!((level(&front.image, 75.0, 25.0) - background - look.white_dn).abs() <= 1.0);
        assert!((level(&front.image, -60.0, 100.0) - background - look.white_dn).abs() <= 1.0);
        // Turned over (half a turn about its x axis, centre kept): the plain back.
        let flipped = world_from_board
            * Pose::translation(0.0, 250.0, 0.0)
            * Pose::rotation(Vector3::x() * std::f64::consts::PI);
        let back = render_board(&camera, &BOARD, &flipped, &look, &config, &mut rng);
        assert!(!back.front_facing);
        assert!((level(&back.image, 25.0, 25.0) - background - look.back_dn).abs() <= 1.0);
        assert!((level(&back.image, 75.0, 25.0) - background - look.back_dn).abs() <= 1.0);
        // Far outside the sheet: the background.
        assert_eq!(f64::from(front.image.get_pixel(2, 2)[0]), background);
    }
}
