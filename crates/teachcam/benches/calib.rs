//! Calibration, single-threaded: corner finding on OpenCV's `left01.jpg` (640x480, 9x6 inner
//! corners), on caliscope's `cam_1_frame_1070.jpg` (1280x720 colour photograph) and on a
//! rendered 1280x1024 view (the calibration scenario's world board in cam0, as `teachcam
//! simulate --scenario calibration` writes it, up to the noise draw), and
//! `calibrate_intrinsics` on the 13 left views (OpenCV's stored corners).
//! `scripts/reference/calib_opencv.py` times `findChessboardCorners + cornerSubPix` and
//! `calibrateCamera` on the same input, `scripts/reference/bench_corners_opencv.py` the corner
//! finding on any image files.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use teachcam::calib::chessboard::{CornerConfig, find_chessboard_corners, gray_like_opencv};
use teachcam::calib::intrinsics::{IntrinsicsConfig, calibrate_intrinsics};
use teachcam::calib::{BoardView, Chessboard};
use teachcam::camera::ImageSize;
use teachcam::geometry::Pixel;
use teachcam::sim::Scenario;
use teachcam::sim::calibration::{WORLD_VIEW, calibration_scene};

const BOARD: Chessboard = Chessboard {
    inner_cols: 9,
    inner_rows: 6,
    square_mm: 25.0,
};

fn bench_calib(c: &mut Criterion) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut group = c.benchmark_group("calib");
    let data = root.join("../../../shared/data/calib");
    let config = CornerConfig::default();
    for (name, path) in [
        (
            "find_corners_left01_640x480",
            "opencv-stereo-9x6/left01.jpg",
        ),
        (
            "find_corners_caliscope_cam1_1280x720",
            "caliscope-4cam-chessboard-9x6/cam_1_frame_1070.jpg",
        ),
    ] {
        if let Ok(image) = image::open(data.join(path)) {
            let gray = gray_like_opencv(&image);
            let found = find_chessboard_corners(&gray, &BOARD, &config);
            assert!(found.is_ok(), "{path}: {found:?}");
            group.bench_function(name, |b| {
                b.iter(|| find_chessboard_corners(black_box(&gray), &BOARD, &config))
            });
        }
    }
    let scene = calibration_scene(Scenario::Calibration.rig(), 3, 1);
    if let Some(world) = scene.placements.iter().find(|p| p.name == WORLD_VIEW) {
        let view = scene.board_view(
            &scene.rig.cameras[0],
            world,
            &mut ChaCha8Rng::seed_from_u64(1),
        );
        let board = scene.board;
        let found = find_chessboard_corners(&view.image, &board, &config);
        assert!(found.is_ok(), "rendered world view: {found:?}");
        group.bench_function("find_corners_render_1280x1024", |b| {
            b.iter(|| find_chessboard_corners(black_box(&view.image), &board, &config))
        });
    }
    let reference: serde_json::Value =
        std::fs::read_to_string(root.join("tests/data/calib_opencv_reference.json"))
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_default();
    let views: Vec<BoardView> = (1..=14)
        .filter(|k| *k != 10)
        .filter_map(|k| {
            let key = format!("opencv-stereo-9x6/left{k:02}.jpg");
            let corners = reference["corners"][&key].as_array()?;
            Some(BoardView {
                name: key,
                corners: corners
                    .iter()
                    .filter_map(|p| Some(Pixel::new(p[0].as_f64()?, p[1].as_f64()?)))
                    .collect(),
            })
        })
        .collect();
    if views.len() == 13 {
        let points = BOARD.corners_in_board();
        let size = ImageSize {
            width: 640,
            height: 480,
        };
        let config = IntrinsicsConfig::default();
        group.bench_function("calibrate_intrinsics_13_views", |b| {
            b.iter(|| calibrate_intrinsics(&points, black_box(&views), size, &config))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_calib);
criterion_main!(benches);
