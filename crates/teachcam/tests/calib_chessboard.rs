//! Chessboard corners on rendered boards whose true corners are known: perspective, uneven
//! light, blur; partial boards refused; arbitrary images never panic.

#![allow(
    clippy::print_stderr,
    reason = "tests print the measured numbers that notes/calib.md reports"
)]

use image::GrayImage;
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use teachcam::calib::Chessboard;
use teachcam::calib::chessboard::{CornerConfig, find_chessboard_corners};
use teachcam::camera::{Camera, Distortion, ImageSize, Intrinsics};
use teachcam::geometry::{Point3, Pose, pose_from_parts};
use teachcam::sim::board::{BoardLook, render_board};
use teachcam::sim::render::RenderConfig;

const BOARD: Chessboard = Chessboard {
    inner_cols: 9,
    inner_rows: 6,
    square_mm: 20.0,
};

fn camera(pose: Pose) -> Camera {
    Camera {
        name: "render".into(),
        image_size: ImageSize {
            width: 640,
            height: 480,
        },
        intrinsics: Intrinsics {
            fx: 800.0,
            fy: 800.0,
            cx: 319.5,
            cy: 239.5,
        },
        distortion: Distortion::default(),
        camera_from_world: pose,
    }
}

/// Renders the board with the simulator's chessboard renderer (`teachcam::sim::board`):
/// 10x7 squares, the square between corners 0, 1, 9, 10 dark, a white margin of one square,
/// on a mid-grey background, light falling by `light_falloff` across the sheet, blurred by a
/// Gaussian of `blur_px`, noise-free. The camera's pose is `camera_from_board`.
fn render(camera: &Camera, light_falloff: f64, blur_px: f64) -> GrayImage {
    let background_dn = 0.45 * 255.0;
    let look = BoardLook {
        margin_mm: BOARD.square_mm,
        white_dn: 0.9 * 255.0 - background_dn,
        black_dn: 0.1 * 255.0 - background_dn,
        light_falloff,
        ..BoardLook::default()
    };
    let config = RenderConfig {
        blur_sigma_px: blur_px,
        background_dn,
        read_noise_dn: 0.0,
        shot_noise_dn_per_dn: 0.0,
        ..RenderConfig::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    render_board(camera, &BOARD, &Pose::identity(), &look, &config, &mut rng).image
}

/// The board's pose: tilted about an in-plane axis, centred on the optical axis at 500 mm.
fn board_pose(tilt_deg: f64, spin_deg: f64, shift: Vector3<f64>) -> Pose {
    let rotation = UnitQuaternion::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(1.0, 0.6, 0.0)),
        tilt_deg.to_radians(),
    ) * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), spin_deg.to_radians());
    let centre = Vector3::new(4.0 * BOARD.square_mm, 2.5 * BOARD.square_mm, 0.0);
    pose_from_parts(
        Vector3::new(0.0, 0.0, 500.0) + shift - rotation * centre,
        rotation,
    )
}

fn errors(camera: &Camera, found: &[teachcam::geometry::Pixel]) -> (f64, f64) {
    let truth: Vec<_> = BOARD
        .corners_in_board()
        .iter()
        .map(|p: &Point3| {
            camera
                .project(p)
                .unwrap_or(teachcam::geometry::Pixel::new(f64::NAN, f64::NAN))
        })
        .collect();
    let d: Vec<f64> = found
        .iter()
        .zip(&truth)
        .map(|(a, b)| a.distance(b))
        .collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    (mean, d.iter().copied().fold(0.0, f64::max))
}

/// Perspective, a board turned half a turn, light falling from 100 % to 35 % across the sheet,
/// mild blur: found, in OpenCV's order (corner 0 where the dark square is), near the truth.
#[test]
fn rendered_boards_give_true_corners_in_order() {
    let light = 0.65;
    for (tilt, spin, blur) in [
        (0.0, 0.0, 0.7),
        (35.0, 10.0, 0.7),
        (25.0, 180.0, 1.0),
        (40.0, -70.0, 1.5),
    ] {
        let cam = camera(board_pose(tilt, spin, Vector3::zeros()));
        let image = render(&cam, light, blur);
        let found = find_chessboard_corners(&image, &BOARD, &CornerConfig::default())
            .unwrap_or_else(|e| panic!("tilt {tilt}, spin {spin}: {e}"));
        let (mean, max) = errors(&cam, &found);
        eprintln!("tilt {tilt}°, spin {spin}°, blur {blur} px: mean {mean:.4} px, max {max:.4} px");
        // 8-bit rounding and 8x8 supersampling bias a corner by a few hundredths of a pixel;
        // a corner out of order would be ≥ 20 px away.
        assert!(max < 0.1, "tilt {tilt}, spin {spin}: max error {max} px");
    }
}

/// A board cut by the image border is refused, not completed by guessing.
#[test]
fn partial_board_is_refused() {
    let cam = camera(board_pose(10.0, 0.0, Vector3::new(130.0, 0.0, 0.0)));
    let image = render(&cam, 0.0, 0.7);
    let result = find_chessboard_corners(&image, &BOARD, &CornerConfig::default());
    assert!(result.is_err(), "partial board accepted");
}

/// Heavy blur: either refused or still right; never wrong corners.
#[test]
fn heavy_blur_is_refused_or_right() {
    for blur in [3.0, 6.0] {
        let cam = camera(board_pose(20.0, 5.0, Vector3::zeros()));
        let image = render(&cam, 0.0, blur);
        match find_chessboard_corners(&image, &BOARD, &CornerConfig::default()) {
            Ok(found) => {
                let (mean, max) = errors(&cam, &found);
                eprintln!("blur {blur} px: found, mean {mean:.4} px, max {max:.4} px");
                assert!(max < 0.5, "blur {blur}: max error {max} px");
            }
            Err(e) => eprintln!("blur {blur} px: refused: {e}"),
        }
    }
}

/// A blank image and one too small to search are refused.
#[test]
fn blank_and_tiny_images_are_refused() {
    let config = CornerConfig::default();
    assert!(find_chessboard_corners(&GrayImage::new(640, 480), &BOARD, &config).is_err());
    assert!(find_chessboard_corners(&GrayImage::new(5, 400), &BOARD, &config).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Any small image: an answer or an error, never a panic.
    #[test]
    fn arbitrary_images_never_panic(width in 1u32..48, height in 1u32..48, seed in any::<u64>()) {
        let mut state = seed;
        let image = GrayImage::from_fn(width, height, |_, _| {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            image::Luma([(state >> 56) as u8])
        });
        let _ = find_chessboard_corners(&image, &BOARD, &CornerConfig::default());
    }
}
