//! Rig calibration on simulated views: board corners projected through a known rig with
//! `Camera::project`, plus Gaussian corner noise, against the known camera poses.

#![allow(
    clippy::print_stderr,
    reason = "tests print the measured numbers that notes/calib.md reports"
)]

use nalgebra::{DVector, Rotation3, Unit, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use teachcam::calib::intrinsics::{IntrinsicsConfig, calibrate_intrinsics};
use teachcam::calib::rig::{
    BundleIntrinsics, RigCalibration, RigConfig, RigObservation, WorldFrame, calibrate_rig,
    views_of_camera,
};
use teachcam::calib::{BoardView, CalibError, Chessboard};
use teachcam::camera::{Camera, Distortion, ImageSize, Intrinsics};
use teachcam::geometry::{CameraId, Pixel, Point3, Pose, Vec3, pose_from_parts};
use teachcam::sim::calibration::{
    CALIBRATION_BOARD, CalibrationScene, IMAGES_PER_CAMERA_FOR_0_02_DEG, PlacementCount,
    WORLD_VIEW, calibration_scene, calibration_scene_with, has_image, world_from_world_board,
};
use teachcam::sim::scenario::{four_camera_rig, paper_rig};

const BOARD: Chessboard = Chessboard {
    inner_cols: 9,
    inner_rows: 6,
    square_mm: 50.0,
};
const SIZE: ImageSize = ImageSize {
    width: 1280,
    height: 1024,
};
/// Corner noise of a good sub-pixel detector on a sharp board, pixels (per coordinate).
const NOISE_PX: f64 = 0.1;
/// Our detector's corner error on rendered 1280x1024 views of the paper's rig, per coordinate
/// (`calib_rig_render.rs::detector_corner_noise_on_rendered_paper_rig_views`: rms 0.025 px
/// pooled over 15 images, 0.019–0.033 px per image; notes/rig.md).
const MEASURED_NOISE_PX: f64 = 0.025;

/// A camera at `centre` looking at `target`, the paper's 1280x1024 sensor and 12 mm lens.
fn look_at(name: &str, centre: Point3, target: Point3, cx_offset: f64) -> Camera {
    let z = (target - centre).normalize();
    let x = z.cross(&Vec3::new(0.0, 1.0, 0.3)).normalize();
    let y = z.cross(&x);
    let rotation = Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_rows(&[
        x.transpose(),
        y.transpose(),
        z.transpose(),
    ]));
    let q = UnitQuaternion::from_rotation_matrix(&rotation);
    let t = -(q * centre.coords);
    Camera {
        name: name.to_owned(),
        image_size: SIZE,
        intrinsics: Intrinsics {
            fx: 1790.0,
            fy: 1791.5,
            cx: 639.5 + cx_offset,
            cy: 511.5 - cx_offset,
        },
        distortion: Distortion::from_opencv([-0.12, 0.08, 0.0008, -0.0005, 0.0]),
        camera_from_world: pose_from_parts(t, q),
    }
}

fn rig(count: usize) -> Vec<Camera> {
    let target = Point3::new(120.0, 75.0, 0.0);
    let centres = [
        Point3::new(-500.0, -300.0, -850.0),
        Point3::new(700.0, -350.0, -800.0),
        Point3::new(150.0, 650.0, -900.0),
        Point3::new(-450.0, 500.0, -750.0),
    ];
    centres[..count]
        .iter()
        .enumerate()
        .map(|(i, c)| look_at(&format!("cam{i}"), *c, target, 4.0 * i as f64))
        .collect()
}

/// Board placements: "world" lying on the work object (the world frame itself), then tilted
/// boards held above it.
fn placements(rng: &mut ChaCha8Rng, count: usize) -> Vec<(String, Pose)> {
    let mut out = vec![("world".to_owned(), Pose::identity())];
    for k in 0..count {
        let axis = Unit::new_normalize(Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            0.0,
        ));
        let tilt = rng.random_range(10f64..40.0).to_radians();
        let spin = rng.random_range(-0.5..0.5);
        let rotation = UnitQuaternion::from_axis_angle(&axis, tilt)
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), spin);
        let centre_in_board = Vec3::new(200.0, 125.0, 0.0);
        let position = Vec3::new(
            rng.random_range(-150.0..150.0) + 120.0,
            rng.random_range(-120.0..120.0) + 75.0,
            rng.random_range(-300.0..-20.0),
        );
        let translation = position - rotation * centre_in_board;
        out.push((format!("v{k:02}"), pose_from_parts(translation, rotation)));
    }
    out
}

/// Noisy observations of every placement a camera sees whole and from the front.
fn observe(
    cameras: &[Camera],
    boards: &[(String, Pose)],
    rng: &mut ChaCha8Rng,
) -> Vec<RigObservation> {
    let noise = Normal::new(0.0, NOISE_PX).unwrap_or_else(|e| panic!("{e}"));
    let corners = BOARD.corners_in_board();
    let mut observations = Vec::new();
    for (name, world_from_board) in boards {
        for (c, camera) in cameras.iter().enumerate() {
            // The printed side faces the camera: the camera lies on the board's -z side.
            let centre_in_board =
                world_from_board.inverse_transform_point(&camera.center_in_world());
            if centre_in_board.z >= 0.0 {
                continue;
            }
            let pixels: Option<Vec<Pixel>> = corners
                .iter()
                .map(|x| {
                    camera
                        .project(&(world_from_board * x))
                        .filter(|p| SIZE.contains(p))
                        .map(|p| Pixel::new(p.x + noise.sample(rng), p.y + noise.sample(rng)))
                })
                .collect();
            if let Some(pixels) = pixels {
                observations.push(RigObservation {
                    camera: CameraId(c),
                    view: name.clone(),
                    corners: pixels,
                });
            }
        }
    }
    observations
}

/// The pipeline of `teachcam calibrate rig`: each camera's intrinsics from its own views, then
/// the rig, world on the board lying on the object, intrinsics refined in the adjustment.
fn calibrate_simulated(
    count: usize,
    seed: u64,
) -> (Vec<Camera>, teachcam::calib::rig::RigCalibration) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = rig(count);
    let boards = placements(&mut rng, 40);
    let observations = observe(&truth, &boards, &mut rng);
    let corners = BOARD.corners_in_board();
    let mut cameras = Vec::new();
    for (c, camera) in truth.iter().enumerate() {
        let views = views_of_camera(&observations, CameraId(c));
        eprintln!("{}: {} views", camera.name, views.len());
        let mut calibrated =
            calibrate_intrinsics(&corners, &views, SIZE, &IntrinsicsConfig::default())
                .unwrap_or_else(|e| panic!("{}: {e}", camera.name))
                .camera;
        calibrated.name = camera.name.clone();
        cameras.push(calibrated);
    }
    let config = RigConfig::refining((0..cameras.len()).map(CameraId));
    let result = calibrate_rig(
        &corners,
        &cameras,
        &observations,
        &WorldFrame::Board("world".into()),
        &config,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    (truth, result)
}

fn check_against_truth(count: usize, seed: u64) {
    let (truth, result) = calibrate_simulated(count, seed);
    eprintln!(
        "rms {:.4} px, per camera {:?}",
        result.rms_px, result.cameras
    );
    // With Gaussian noise of σ per coordinate, the RMS (over 2 coordinates) is about σ √2.
    assert!(
        (result.rms_px / (NOISE_PX * 2f64.sqrt()) - 1.0).abs() < 0.1,
        "rms {}",
        result.rms_px
    );
    let ours0 = &result.rig.cameras[0];
    let truth0 = &truth[0];
    for ((ours, true_camera), residual) in
        result.rig.cameras.iter().zip(&truth).zip(&result.cameras)
    {
        // Absolute: in the world of the board on the object. That board's own pose error
        // moves every camera alike; the adjustment's covariance predicts it.
        let centre_error_mm = (ours.center_in_world() - true_camera.center_in_world()).norm();
        let rotation_error_deg = ours
            .camera_from_world
            .rotation
            .angle_to(&true_camera.camera_from_world.rotation)
            .to_degrees();
        // Relative: this camera seen from camera 0, free of the world board's error.
        let ours_rel = ours.camera_from_world * ours0.camera_from_world.inverse();
        let true_rel = true_camera.camera_from_world * truth0.camera_from_world.inverse();
        let rel_centre_mm = (ours_rel.inverse_transform_point(&Point3::origin())
            - true_rel.inverse_transform_point(&Point3::origin()))
        .norm();
        let rel_rotation_deg = ours_rel.rotation.angle_to(&true_rel.rotation).to_degrees();
        eprintln!(
            "{}: world: centre {centre_error_mm:.4} mm (σ {:.4}), rotation {rotation_error_deg:.5}° (σ {:.5}); from cam0: centre {rel_centre_mm:.4} mm, rotation {rel_rotation_deg:.5}°",
            ours.name, residual.centre_std_mm, residual.rotation_std_deg
        );
        // |error| of a 3-vector beyond 3 sqrt(trace Cov) has probability below 1e-4.
        assert!(
            centre_error_mm < 3.0 * residual.centre_std_mm,
            "{}: centre error {centre_error_mm} mm",
            ours.name
        );
        assert!(
            rotation_error_deg < 3.0 * residual.rotation_std_deg,
            "{}: rotation error {rotation_error_deg}°",
            ours.name
        );
        // The issue asks for 0.5 mm and 0.02°: the centres meet it by far (σ ≈ 0.15 mm); the
        // rotations cannot at σ = 0.1 px (4x the detector's measured noise) with ~25 images per
        // camera, where the principal point's own uncertainty (≈ 0.5 px, i.e. 0.02° at
        // f = 1790 px) sets σ ≈ 0.022–0.029°; `rotations_within_0_02_deg` runs the protocol
        // that reaches it.
        assert!(
            centre_error_mm < 0.5,
            "{}: centre error {centre_error_mm} mm",
            ours.name
        );
    }
}

#[test]
fn three_camera_rig_matches_truth() {
    check_against_truth(3, 7);
}

#[test]
fn four_camera_rig_matches_truth() {
    check_against_truth(4, 11);
}

#[test]
fn camera_sharing_no_view_is_named() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let truth = rig(3);
    let boards = placements(&mut rng, 12);
    let observations: Vec<RigObservation> = observe(&truth, &boards, &mut rng)
        .into_iter()
        // cam2 keeps only views nobody else saw: none.
        .filter(|o| o.camera != CameraId(2))
        .collect();
    let error = calibrate_rig(
        &BOARD.corners_in_board(),
        &truth,
        &observations,
        &WorldFrame::Board("world".into()),
        &RigConfig::default(),
    )
    .err();
    assert_eq!(
        error,
        Some(CalibError::Unlinked {
            camera: "cam2".into()
        })
    );
}

#[test]
fn unknown_world_view_is_named() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let truth = rig(3);
    let boards = placements(&mut rng, 6);
    let observations = observe(&truth, &boards, &mut rng);
    let error = calibrate_rig(
        &BOARD.corners_in_board(),
        &truth,
        &observations,
        &WorldFrame::Board("table".into()),
        &RigConfig::default(),
    )
    .err();
    assert_eq!(
        error,
        Some(CalibError::UnknownWorldView {
            view: "table".into()
        })
    );
}

fn views_of(camera: &Camera, boards: &[(String, Pose)]) -> Vec<BoardView> {
    boards
        .iter()
        .map(|(name, world_from_board)| BoardView {
            name: name.clone(),
            corners: BOARD
                .corners_in_board()
                .iter()
                .filter_map(|x| camera.project(&(world_from_board * x)))
                .collect(),
        })
        .collect()
}

/// Boards all parallel to each other: Zhang's constraints repeat and K is undetermined.
#[test]
fn parallel_views_are_refused() {
    let camera = rig(1).remove(0);
    let boards: Vec<(String, Pose)> = (0..5)
        .map(|k| {
            let shift = Vec3::new(
                20.0 * f64::from(k),
                -10.0 * f64::from(k),
                -30.0 * f64::from(k),
            );
            (
                format!("v{k}"),
                pose_from_parts(shift, UnitQuaternion::identity()),
            )
        })
        .collect();
    let views = views_of(&camera, &boards);
    let error = calibrate_intrinsics(
        &BOARD.corners_in_board(),
        &views,
        SIZE,
        &IntrinsicsConfig::default(),
    )
    .err();
    assert_eq!(error, Some(CalibError::DegenerateViews));
}

#[test]
fn too_few_views_and_bad_corners_are_refused() {
    let camera = rig(1).remove(0);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let boards = placements(&mut rng, 4);
    let mut views = views_of(&camera, &boards);
    let corners = BOARD.corners_in_board();
    let config = IntrinsicsConfig::default();
    assert_eq!(
        calibrate_intrinsics(&corners, &views[..2], SIZE, &config).err(),
        Some(CalibError::TooFewViews {
            views: 2,
            needed: 3
        })
    );
    views[1].corners[7].x = f64::NAN;
    assert_eq!(
        calibrate_intrinsics(&corners, &views, SIZE, &config).err(),
        Some(CalibError::NotFinite {
            view: "v00".into(),
            corner: 7
        })
    );
    views[1].corners.pop();
    assert_eq!(
        calibrate_intrinsics(&corners, &views, SIZE, &config).err(),
        Some(CalibError::CornerCount {
            view: "v00".into(),
            found: 53,
            expected: 54
        })
    );
}

/// Noise-free views: the estimate must reach the truth to numerical precision.
#[test]
fn noise_free_intrinsics_are_exact() {
    let camera = rig(1).remove(0);
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let boards: Vec<(String, Pose)> = placements(&mut rng, 12);
    let views: Vec<BoardView> = views_of(&camera, &boards)
        .into_iter()
        .filter(|v| {
            v.corners.len() == BOARD.corner_count() && v.corners.iter().all(|p| SIZE.contains(p))
        })
        .collect();
    let c = calibrate_intrinsics(
        &BOARD.corners_in_board(),
        &views,
        SIZE,
        &IntrinsicsConfig::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(c.rms_px < 1e-6, "rms {}", c.rms_px);
    assert!((c.camera.intrinsics.fx - camera.intrinsics.fx).abs() < 1e-4);
    assert!((c.camera.intrinsics.cy - camera.intrinsics.cy).abs() < 1e-4);
    assert!((c.camera.distortion.k1 - camera.distortion.k1).abs() < 1e-6);
}

#[test]
fn duplicate_and_unknown_cameras_are_named() {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let truth = rig(3);
    let boards = placements(&mut rng, 6);
    let mut observations = observe(&truth, &boards, &mut rng);
    let corners = BOARD.corners_in_board();
    let world = WorldFrame::Board("world".into());
    let config = RigConfig::default();
    let mut twice = observations.clone();
    twice.push(observations[0].clone());
    assert_eq!(
        calibrate_rig(&corners, &truth, &twice, &world, &config).err(),
        Some(CalibError::DuplicateObservation {
            camera: truth[observations[0].camera.0].name.clone(),
            view: observations[0].view.clone(),
        })
    );
    observations[0].camera = CameraId(7);
    assert_eq!(
        calibrate_rig(&corners, &truth, &observations, &world, &config).err(),
        Some(CalibError::UnknownCamera {
            camera: "camera 7".into(),
            view: observations[0].view.clone(),
        })
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(32))]
    /// Corners that are no board's (random pixels): refused, or a camera with finite,
    /// plausible numbers; never NaN.
    #[test]
    fn random_corners_never_give_nan(seed in 0u64..1_000_000) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let views: Vec<BoardView> = (0..4)
            .map(|k| BoardView {
                name: format!("v{k}"),
                corners: (0..BOARD.corner_count())
                    .map(|_| Pixel::new(rng.random_range(0.0..1280.0), rng.random_range(0.0..1024.0)))
                    .collect(),
            })
            .collect();
        if let Ok(c) = calibrate_intrinsics(&BOARD.corners_in_board(), &views, SIZE, &IntrinsicsConfig::default()) {
            let i = c.camera.intrinsics;
            proptest::prop_assert!([i.fx, i.fy, i.cx, i.cy, c.rms_px].iter().all(|v| v.is_finite()));
            proptest::prop_assert!(i.fx > 0.0 && i.fy > 0.0);
        }
    }
}

/// Observations of the simulator's calibration scene: exact projections of every corner a
/// camera has an image of, plus Gaussian noise of `noise_px` per coordinate.
fn observe_scene(
    scene: &CalibrationScene,
    noise_px: f64,
    rng: &mut ChaCha8Rng,
) -> Vec<RigObservation> {
    let noise = Normal::new(0.0, noise_px).unwrap_or_else(|e| panic!("{e}"));
    let corners = scene.board.corners_in_board();
    let mut observations = Vec::new();
    for placement in &scene.placements {
        for (c, camera) in scene.rig.cameras.iter().enumerate() {
            if !has_image(camera, &scene.board, &scene.look, placement) {
                continue;
            }
            let pixels: Vec<Pixel> = corners
                .iter()
                .map(|x| {
                    let p = camera
                        .project(&(placement.world_from_board * x))
                        .unwrap_or_else(|| panic!("corner behind {}", camera.name));
                    Pixel::new(p.x + noise.sample(rng), p.y + noise.sample(rng))
                })
                .collect();
            observations.push(RigObservation {
                camera: CameraId(c),
                view: placement.name.clone(),
                corners: pixels,
            });
        }
    }
    observations
}

/// Calibrates the simulator's scene as `teachcam calibrate rig` does by default: each
/// camera's intrinsics from its own views, then the bundle adjustment with `treatment` of every
/// camera's intrinsics (`None`: refined), the world on the board lying on the object.
/// Returns the truth in the calibrated world (the world board's frame) and the result.
fn calibrate_scene(
    scene: &CalibrationScene,
    noise_px: f64,
    seed: u64,
    fixed: Option<FixedIntrinsics>,
) -> (Vec<Camera>, RigCalibration) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    let observations = observe_scene(scene, noise_px, &mut rng);
    let corners = scene.board.corners_in_board();
    let mut cameras = Vec::new();
    let mut config = RigConfig::default();
    for (c, camera) in scene.rig.cameras.iter().enumerate() {
        let views = views_of_camera(&observations, CameraId(c));
        let intrinsics = calibrate_intrinsics(
            &corners,
            &views,
            camera.image_size,
            &IntrinsicsConfig::default(),
        )
        .unwrap_or_else(|e| panic!("{}: {e}", camera.name));
        let treatment = match fixed {
            None => BundleIntrinsics::Refined,
            Some(FixedIntrinsics::AsExact) => BundleIntrinsics::Fixed,
            Some(FixedIntrinsics::WithCovariance) => {
                BundleIntrinsics::FixedWithCovariance(Box::new(intrinsics.covariance))
            }
        };
        config.intrinsics.insert(CameraId(c), treatment);
        let mut calibrated = intrinsics.camera;
        calibrated.name = camera.name.clone();
        cameras.push(calibrated);
    }
    let result = calibrate_rig(
        &corners,
        &cameras,
        &observations,
        &WorldFrame::Board(WORLD_VIEW.into()),
        &config,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let world_from_world_board = world_from_world_board(&scene.board);
    let truth = scene
        .rig
        .cameras
        .iter()
        .map(|camera| Camera {
            camera_from_world: camera.camera_from_world * world_from_world_board,
            ..camera.clone()
        })
        .collect();
    (truth, result)
}

#[derive(Debug, Clone, Copy)]
enum FixedIntrinsics {
    AsExact,
    WithCovariance,
}

/// The pose error of every camera as the adjustment's perturbation `exp(ω, τ) * truth`,
/// stacked `(ω, τ)` per camera, and its Mahalanobis norm `eᵀ Cov⁻¹ e` under the adjustment's
/// joint covariance: χ² with 6 × cameras degrees of freedom if the covariance is right.
fn pose_chi_square(truth: &[Camera], result: &RigCalibration) -> f64 {
    let n = 6 * truth.len();
    let mut error = DVector::zeros(n);
    for (c, (ours, truth)) in result.rig.cameras.iter().zip(truth).enumerate() {
        let turn = ours.camera_from_world.rotation * truth.camera_from_world.rotation.inverse();
        let omega = turn.scaled_axis();
        let tau = ours.camera_from_world.translation.vector
            - turn * truth.camera_from_world.translation.vector;
        error.rows_mut(6 * c, 3).copy_from(&omega);
        error.rows_mut(6 * c + 3, 3).copy_from(&tau);
    }
    let cholesky = result
        .camera_pose_covariance
        .clone()
        .cholesky()
        .unwrap_or_else(|| panic!("covariance not positive definite"));
    error.dot(&cholesky.solve(&error))
}

/// Quantile of χ² with `k` degrees of freedom at the standard normal quantile `z`, Wilson &
/// Hilferty (1931): `k (1 - 2/(9k) + z √(2/(9k)))³` (at k = 144, z = ±3.09: 97.2 and 202.2,
/// scipy's exact 97.19 and 202.18).
fn chi_square_quantile(k: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

/// The standard normal quantile at 0.001 (and, negated, at 0.999).
const Z_0_001: f64 = -3.090_232;

/// The adjustment's joint pose covariance against the actual errors over seeds: the summed
/// χ² of 8 independent calibrations (6 × 3 × 8 = 144 degrees of freedom) must lie between its
/// 0.1 % and 99.9 % quantiles (97.2 and 202.2; `scipy.stats.chi2.ppf` gives 97.19 and 202.18). Intrinsics held fixed as exact must fail
/// that bound (the defect `calibrate rig` printed before: σ too small), and held fixed with
/// their covariance propagated must pass it.
#[test]
fn pose_sigma_is_consistent_with_the_errors_over_seeds() {
    const SEEDS: u64 = 8;
    let rig = paper_rig();
    let mut sums = [0.0; 3];
    for seed in 1..=SEEDS {
        let scene = calibration_scene(rig.clone(), 20, seed);
        for (k, fixed) in [
            None,
            Some(FixedIntrinsics::AsExact),
            Some(FixedIntrinsics::WithCovariance),
        ]
        .into_iter()
        .enumerate()
        {
            let (truth, result) = calibrate_scene(&scene, MEASURED_NOISE_PX, seed, fixed);
            sums[k] += pose_chi_square(&truth, &result);
        }
    }
    let dof = (6 * rig.cameras.len()) as f64 * SEEDS as f64;
    let (low, high) = (
        chi_square_quantile(dof, Z_0_001),
        chi_square_quantile(dof, -Z_0_001),
    );
    eprintln!(
        "χ² over {SEEDS} seeds ({dof} dof, 99.8 % interval {low:.1}..{high:.1}): refined {:.1}, fixed as exact {:.1}, fixed with covariance {:.1}",
        sums[0], sums[1], sums[2]
    );
    assert!(
        (low..high).contains(&sums[0]),
        "refined: χ² {} outside {low}..{high}",
        sums[0]
    );
    assert!(
        sums[1] > high,
        "fixed as exact: χ² {} should exceed {high}",
        sums[1]
    );
    assert!(
        (low..high).contains(&sums[2]),
        "fixed with covariance: χ² {} outside {low}..{high}",
        sums[2]
    );
}

/// Issue 8's done-when for rotations: with 40 images per camera (the placements of
/// `PlacementCount::ImagesPerCamera`) and the detector's measured corner noise, every
/// camera's predicted rotation σ is at most 0.0067° (so 3σ ≤ 0.02°), and every actual
/// rotation error is below 0.02° and below 3σ, centres below 0.5 mm, on the paper's rig and
/// the four-camera rig, over three seeds each.
#[test]
fn rotations_within_0_02_deg() {
    for (label, rig) in [("3 cameras", paper_rig()), ("4 cameras", four_camera_rig())] {
        for seed in 1..=3 {
            let scene = calibration_scene_with(
                rig.clone(),
                PlacementCount::ImagesPerCamera(IMAGES_PER_CAMERA_FOR_0_02_DEG),
                seed,
            );
            let (truth, result) = calibrate_scene(&scene, MEASURED_NOISE_PX, seed, None);
            for ((ours, truth), residual) in
                result.rig.cameras.iter().zip(&truth).zip(&result.cameras)
            {
                let rotation_deg = ours
                    .camera_from_world
                    .rotation
                    .angle_to(&truth.camera_from_world.rotation)
                    .to_degrees();
                let centre_mm = (ours.center_in_world() - truth.center_in_world()).norm();
                let pp = residual.intrinsics_std.unwrap_or([f64::NAN; 9]);
                eprintln!(
                    "{label}, seed {seed}, {} placements, {}: {} images, rotation {rotation_deg:.4}° (σ {:.4}°), centre {centre_mm:.3} mm (σ {:.3}), cx ± {:.2} px, cy ± {:.2} px",
                    scene.placements.len() - 1,
                    ours.name,
                    residual.views,
                    residual.rotation_std_deg,
                    residual.centre_std_mm,
                    pp[2],
                    pp[3]
                );
                assert!(
                    residual.rotation_std_deg <= 0.02 / 3.0,
                    "{label} {}: σ",
                    ours.name
                );
                assert!(
                    rotation_deg < 0.02,
                    "{label} seed {seed} {}: {rotation_deg}°",
                    ours.name
                );
                assert!(
                    rotation_deg < 3.0 * residual.rotation_std_deg,
                    "{label} seed {seed} {}: {rotation_deg}° beyond 3σ",
                    ours.name
                );
                assert!(
                    centre_mm < 0.5,
                    "{label} seed {seed} {}: {centre_mm} mm",
                    ours.name
                );
            }
        }
    }
}

/// The observations and OpenCV's result stored by `scripts/reference/rig_opencv_multiview.py`.
fn opencv_multiview() -> serde_json::Value {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/rig_multiview_opencv.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn matrix_rows(value: &serde_json::Value) -> [[f64; 3]; 3] {
    serde_json::from_value(value.clone()).unwrap_or_else(|e| panic!("rotation: {e}"))
}

/// The same noisy corners (3 cameras, 20 placements, 0.025 px) through our pipeline (each
/// camera's intrinsics from its own views, then the adjustment refining them, world = cam0)
/// and through `cv2.calibrateMultiview` (OpenCV 5.0): both minimise the reprojection error
/// over the same model; ours reaches a cost no higher than OpenCV's, the two agree within 3σ,
/// and ours lies within 3σ of the truth.
#[test]
fn matches_opencv_multiview_on_the_same_corners() {
    let reference = opencv_multiview();
    let rig_file = tempfile::NamedTempFile::new().unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(rig_file.path(), reference["rig"].to_string()).unwrap_or_else(|e| panic!("{e}"));
    let truth = teachcam::io::rig::read_rig(rig_file.path()).unwrap_or_else(|e| panic!("rig: {e}"));
    let names: Vec<String> = truth.cameras.iter().map(|c| c.name.clone()).collect();
    let observations: Vec<RigObservation> = reference["observations"]
        .as_array()
        .unwrap_or_else(|| panic!("observations"))
        .iter()
        .map(|o| RigObservation {
            camera: CameraId(
                names
                    .iter()
                    .position(|n| o["camera"] == n.as_str())
                    .unwrap_or_else(|| panic!("camera {}", o["camera"])),
            ),
            view: o["view"].as_str().unwrap_or_default().to_owned(),
            corners: serde_json::from_value::<Vec<[f64; 2]>>(o["corners"].clone())
                .unwrap_or_else(|e| panic!("corners: {e}"))
                .into_iter()
                .map(|[x, y]| Pixel::new(x, y))
                .collect(),
        })
        .collect();
    let corners = CALIBRATION_BOARD.corners_in_board();
    let cameras: Vec<Camera> = truth
        .cameras
        .iter()
        .enumerate()
        .map(|(c, camera)| {
            let views = views_of_camera(&observations, CameraId(c));
            let mut calibrated = calibrate_intrinsics(
                &corners,
                &views,
                camera.image_size,
                &IntrinsicsConfig::default(),
            )
            .unwrap_or_else(|e| panic!("{}: {e}", camera.name))
            .camera;
            calibrated.name = camera.name.clone();
            calibrated
        })
        .collect();
    let result = calibrate_rig(
        &corners,
        &cameras,
        &observations,
        &WorldFrame::Camera(CameraId(0)),
        &RigConfig::refining((0..cameras.len()).map(CameraId)),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let opencv = &reference["opencv"];
    eprintln!(
        "rms: ours {:.5} px, OpenCV {:.5} px",
        result.rms_px,
        opencv["rms_px"].as_f64().unwrap_or(f64::NAN)
    );
    assert!(result.rms_px <= opencv["rms_px"].as_f64().unwrap_or(f64::NAN));
    let truth0 = truth.cameras[0].camera_from_world;
    for (c, (ours, residual)) in result
        .rig
        .cameras
        .iter()
        .zip(&result.cameras)
        .enumerate()
        .skip(1)
    {
        let theirs = &opencv["cameras"][c];
        let rotation = teachcam::geometry::rotation_from_rows(&matrix_rows(&theirs["rotation"]))
            .unwrap_or_else(|e| panic!("{e}"));
        let t: [f64; 3] = serde_json::from_value(theirs["translation"].clone())
            .unwrap_or_else(|e| panic!("translation: {e}"));
        let opencv_pose = pose_from_parts(Vector3::from(t), rotation);
        let true_pose = truth.cameras[c].camera_from_world * truth0.inverse();
        let rotation_deg = |a: &Pose, b: &Pose| a.rotation.angle_to(&b.rotation).to_degrees();
        let centre_mm = |a: &Pose, b: &Pose| {
            (a.inverse_transform_point(&Point3::origin())
                - b.inverse_transform_point(&Point3::origin()))
            .norm()
        };
        let ours = ours.camera_from_world;
        eprintln!(
            "{}: ours vs OpenCV {:.5}° {:.4} mm; vs truth ours {:.5}° {:.4} mm, OpenCV {:.5}° {:.4} mm; σ {:.5}° {:.4} mm",
            residual.name,
            rotation_deg(&ours, &opencv_pose),
            centre_mm(&ours, &opencv_pose),
            rotation_deg(&ours, &true_pose),
            centre_mm(&ours, &true_pose),
            rotation_deg(&opencv_pose, &true_pose),
            centre_mm(&opencv_pose, &true_pose),
            residual.rotation_std_deg,
            residual.centre_std_mm
        );
        assert!(rotation_deg(&ours, &opencv_pose) < 3.0 * residual.rotation_std_deg);
        assert!(centre_mm(&ours, &opencv_pose) < 3.0 * residual.centre_std_mm);
        assert!(rotation_deg(&ours, &true_pose) < 3.0 * residual.rotation_std_deg);
        assert!(centre_mm(&ours, &true_pose) < 3.0 * residual.centre_std_mm);
    }
}
