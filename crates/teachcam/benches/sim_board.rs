//! The chessboard renderer, single-threaded: one 1280x1024 view of the calibration scenario's
//! world board (the 9x6, 50 mm board lying on the work object, seen by the paper's cam0), and
//! one held placement, with the scenario's look (8x8 n-rooks samples on edge pixels, blur,
//! noise). OpenCV has no ray-cast renderer; the nearest operation, `cv2.warpPerspective` of
//! a supersampled board texture into a 1280x1024 image (pinhole only, no lens distortion),
//! is timed by `scripts/reference/simboard_opencv.py`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use teachcam::sim::Scenario;
use teachcam::sim::calibration::calibration_scene;

fn bench_board(c: &mut Criterion) {
    let scene = calibration_scene(Scenario::Calibration.rig(), 4, 1);
    let mut group = c.benchmark_group("sim_board");
    group.sample_size(20);
    let camera = &scene.rig.cameras[0];
    for placement in scene.placements.iter().take(2) {
        group.bench_function(format!("render_1280x1024_{}", placement.name), |b| {
            let mut rng = ChaCha8Rng::seed_from_u64(1);
            b.iter(|| scene.board_view(black_box(camera), placement, &mut rng))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_board);
criterion_main!(benches);
