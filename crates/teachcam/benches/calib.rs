//! Calibration on OpenCV's sample chessboard photographs, single-threaded: corner finding on
//! `left01.jpg` (640x480, 9x6 inner corners) and `calibrate_intrinsics` on the 13 left views
//! (OpenCV's stored corners). `scripts/reference/calib_opencv.py` times
//! `findChessboardCorners + cornerSubPix` and `calibrateCamera` on the same input.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use teachcam::calib::chessboard::{CornerConfig, find_chessboard_corners, gray_like_opencv};
use teachcam::calib::intrinsics::{IntrinsicsConfig, calibrate_intrinsics};
use teachcam::calib::{BoardView, Chessboard};
use teachcam::camera::ImageSize;
use teachcam::geometry::Pixel;

const BOARD: Chessboard = Chessboard {
    inner_cols: 9,
    inner_rows: 6,
    square_mm: 25.0,
};

fn bench_calib(c: &mut Criterion) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut group = c.benchmark_group("calib");
    let image_path = root.join("../../../shared/data/calib/opencv-stereo-9x6/left01.jpg");
    if let Ok(image) = image::open(&image_path) {
        let gray = gray_like_opencv(&image);
        let config = CornerConfig::default();
        group.bench_function("find_corners_left01_640x480", |b| {
            b.iter(|| find_chessboard_corners(black_box(&gray), &BOARD, &config))
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
