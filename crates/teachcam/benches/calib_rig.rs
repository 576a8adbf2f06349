//! Rig calibration, single-threaded, on the stored noisy corners of 3 cameras and 20 board
//! placements (`tests/data/rig_multiview_opencv.json`): each camera's intrinsics from its own
//! views then the bundle adjustment refining them (the work of `cv2.calibrateMultiview`, which
//! `scripts/reference/rig_opencv_multiview.py` times on the same corners), and the adjustment
//! alone.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use teachcam::calib::intrinsics::{IntrinsicsConfig, calibrate_intrinsics};
use teachcam::calib::rig::{RigConfig, RigObservation, WorldFrame, calibrate_rig, views_of_camera};
use teachcam::camera::{Camera, ImageSize};
use teachcam::geometry::{CameraId, Pixel, Point3};
use teachcam::sim::calibration::CALIBRATION_BOARD;

const SIZE: ImageSize = ImageSize {
    width: 1280,
    height: 1024,
};
const CAMERAS: usize = 3;

fn observations() -> Vec<RigObservation> {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/rig_multiview_opencv.json");
    let reference: serde_json::Value = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_default();
    reference["observations"]
        .as_array()
        .map(|list| {
            list.iter()
                .filter_map(|o| {
                    let camera = o["camera"].as_str()?.strip_prefix("cam")?.parse().ok()?;
                    let corners: Vec<[f64; 2]> =
                        serde_json::from_value(o["corners"].clone()).ok()?;
                    Some(RigObservation {
                        camera: CameraId(camera),
                        view: o["view"].as_str()?.to_owned(),
                        corners: corners.into_iter().map(|[x, y]| Pixel::new(x, y)).collect(),
                    })
                })
                .collect()
        })
        .unwrap_or_default()
}

fn intrinsics(points: &[Point3], observations: &[RigObservation]) -> Option<Vec<Camera>> {
    (0..CAMERAS)
        .map(|c| {
            let views = views_of_camera(observations, CameraId(c));
            calibrate_intrinsics(points, &views, SIZE, &IntrinsicsConfig::default())
                .ok()
                .map(|result| result.camera)
        })
        .collect()
}

fn bench_rig(c: &mut Criterion) {
    let observations = observations();
    let points = CALIBRATION_BOARD.corners_in_board();
    let world = WorldFrame::Camera(CameraId(0));
    let config = RigConfig::refining((0..CAMERAS).map(CameraId));
    let Some(cameras) = intrinsics(&points, &observations) else {
        return;
    };
    let mut group = c.benchmark_group("calib_rig");
    group.sample_size(20);
    group.bench_function("intrinsics_and_bundle_3_cameras_20_placements", |b| {
        b.iter(|| {
            intrinsics(&points, black_box(&observations))
                .map(|cameras| calibrate_rig(&points, &cameras, &observations, &world, &config))
        })
    });
    group.bench_function("bundle_3_cameras_20_placements", |b| {
        b.iter(|| calibrate_rig(&points, &cameras, black_box(&observations), &world, &config))
    });
    group.finish();
}

criterion_group!(benches, bench_rig);
criterion_main!(benches);
