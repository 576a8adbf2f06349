//! A rig calibrated from rendered photographs: chessboard images cast through each camera's
//! lens model (distortion included), corners found by the detector, intrinsics per camera,
//! then the rig; camera poses against the truth.

#![allow(
    clippy::print_stderr,
    reason = "tests print the measured numbers that notes/calib.md reports"
)]

use image::GrayImage;
use nalgebra::{Rotation3, Unit, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use teachcam::calib::Chessboard;
use teachcam::calib::chessboard::{CornerConfig, find_chessboard_corners};
use teachcam::calib::intrinsics::{IntrinsicsConfig, calibrate_intrinsics};
use teachcam::calib::rig::{RigConfig, RigObservation, WorldFrame, calibrate_rig, views_of_camera};
use teachcam::camera::{Camera, Distortion, ImageSize, Intrinsics};
use teachcam::geometry::{CameraId, Pixel, Point3, Pose, Vec3, pose_from_parts};
use teachcam::sim::board::{BoardLook, render_board};
use teachcam::sim::render::RenderConfig;

const BOARD: Chessboard = Chessboard {
    inner_cols: 9,
    inner_rows: 6,
    square_mm: 25.0,
};
const SIZE: ImageSize = ImageSize {
    width: 640,
    height: 480,
};

fn look_at(name: &str, centre: Point3, target: Point3) -> Camera {
    let z = (target - centre).normalize();
    let x = z.cross(&Vec3::new(0.0, 1.0, 0.2)).normalize();
    let y = z.cross(&x);
    let rotation = Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_rows(&[
        x.transpose(),
        y.transpose(),
        z.transpose(),
    ]));
    let q = UnitQuaternion::from_rotation_matrix(&rotation);
    Camera {
        name: name.to_owned(),
        image_size: SIZE,
        intrinsics: Intrinsics {
            fx: 620.0,
            fy: 621.0,
            cx: 322.0,
            cy: 236.0,
        },
        distortion: Distortion::from_opencv([-0.18, 0.06, 0.0005, -0.0004, 0.0]),
        camera_from_world: pose_from_parts(-(q * centre.coords), q),
    }
}

/// What `camera` sees of the board at `world_from_board`, cast through its lens by the
/// simulator's chessboard renderer: dark squares at 10 %, paper at 90 %, one square of margin,
/// on a 40 % background, a sharp lens (0.5 px blur) and no noise.
fn render(camera: &Camera, world_from_board: &Pose) -> GrayImage {
    let background_dn = 0.4 * 255.0;
    let look = BoardLook {
        margin_mm: BOARD.square_mm,
        white_dn: 0.9 * 255.0 - background_dn,
        black_dn: 0.1 * 255.0 - background_dn,
        ..BoardLook::default()
    };
    let config = RenderConfig {
        blur_sigma_px: 0.5,
        background_dn,
        read_noise_dn: 0.0,
        shot_noise_dn_per_dn: 0.0,
        ..RenderConfig::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    render_board(camera, &BOARD, world_from_board, &look, &config, &mut rng).image
}

#[test]
fn rig_from_rendered_photographs_matches_truth() {
    let target = Point3::new(100.0, 60.0, 0.0);
    let truth = [
        look_at("cam0", Point3::new(-300.0, -150.0, -550.0), target),
        look_at("cam1", Point3::new(450.0, -200.0, -500.0), target),
        look_at("cam2", Point3::new(100.0, 450.0, -550.0), target),
    ];
    let mut placements = vec![("world".to_owned(), Pose::identity())];
    let tilts = [
        (25.0, 0.0, 0.3),
        (30.0, 1.0, -0.2),
        (35.0, 2.0, 0.1),
        (20.0, 3.0, 0.0),
        (30.0, 4.0, -0.3),
        (25.0, 5.0, 0.2),
    ];
    for (k, (tilt, axis_angle, spin)) in tilts.iter().enumerate() {
        let f64_axis: f64 = *axis_angle;
        let axis = Unit::new_normalize(Vector3::new(f64_axis.cos(), f64_axis.sin(), 0.0));
        let rotation = UnitQuaternion::from_axis_angle(&axis, f64::to_radians(*tilt))
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), *spin);
        let centre = Vec3::new(100.0, 62.5, 0.0);
        let position = Vec3::new(
            100.0 + 20.0 * k as f64 - 50.0,
            60.0,
            -60.0 - 15.0 * k as f64,
        );
        placements.push((
            format!("v{k}"),
            pose_from_parts(position - rotation * centre, rotation),
        ));
    }
    // Squares here are 7–25 px: the finder narrows its sub-pixel windows there by itself.
    let config = CornerConfig::default();
    let mut observations = Vec::new();
    for (c, camera) in truth.iter().enumerate() {
        for (name, world_from_board) in &placements {
            let image = render(camera, world_from_board);
            match find_chessboard_corners(&image, &BOARD, &config) {
                Ok(corners) => {
                    // Every accepted board on the right corners (issue 8: refusing fewer
                    // oblique views must not let a wrong board through).
                    let truth: Vec<Pixel> = BOARD
                        .corners_in_board()
                        .iter()
                        .map(|point| {
                            camera
                                .project(&world_from_board.transform_point(point))
                                .unwrap_or_else(|| panic!("corner behind {}", camera.name))
                        })
                        .collect();
                    let worst_px = truth
                        .iter()
                        .zip(&corners)
                        .map(|(t, ours)| t.distance(ours))
                        .fold(0.0, f64::max);
                    let shortest_step_px = truth
                        .windows(2)
                        .map(|pair| pair[0].distance(&pair[1]))
                        .chain(
                            truth
                                .iter()
                                .zip(&truth[BOARD.inner_cols..])
                                .map(|(a, b)| a.distance(b)),
                        )
                        .fold(f64::INFINITY, f64::min);
                    eprintln!(
                        "{} {name}: worst corner {worst_px:.3} px, shortest step {shortest_step_px:.1} px",
                        camera.name
                    );
                    assert!(
                        worst_px < 0.25 * shortest_step_px,
                        "{} {name}: corner {worst_px} px off",
                        camera.name
                    );
                    observations.push(RigObservation {
                        camera: CameraId(c),
                        view: name.clone(),
                        corners,
                    });
                }
                Err(e) => eprintln!("{} {name}: {e}", camera.name),
            }
        }
    }
    // 21 renders; squares down to 5.5 px along a foreshortened axis. Seeds that look past
    // their four nearest saddles find two that seeds from them alone refuse (18 found then);
    // cam1 v1 stays refused (its lattice takes in the sheet's edge).
    assert!(
        observations.len() >= 20,
        "{} of 21 boards found",
        observations.len()
    );
    let points = BOARD.corners_in_board();
    let mut cameras = Vec::new();
    for (c, camera) in truth.iter().enumerate() {
        let views = views_of_camera(&observations, CameraId(c));
        let result = calibrate_intrinsics(&points, &views, SIZE, &IntrinsicsConfig::default())
            .unwrap_or_else(|e| panic!("{}: {e}", camera.name));
        eprintln!(
            "{}: {} views, rms {:.4} px, fx {:.3} (620), cx {:.3} (322), k1 {:.4} (-0.18)",
            camera.name,
            views.len(),
            result.rms_px,
            result.camera.intrinsics.fx,
            result.camera.intrinsics.cx,
            result.camera.distortion.k1
        );
        for v in &result.views {
            eprintln!("  {}: {:.3} px", v.name, v.rms_px);
        }
        let mut calibrated = result.camera;
        calibrated.name = camera.name.clone();
        cameras.push(calibrated);
    }
    let result = calibrate_rig(
        &points,
        &cameras,
        &observations,
        &WorldFrame::Board("world".into()),
        &RigConfig::refining((0..cameras.len()).map(CameraId)),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    for ((ours, true_camera), residual) in
        result.rig.cameras.iter().zip(&truth).zip(&result.cameras)
    {
        let centre_mm = (ours.center_in_world() - true_camera.center_in_world()).norm();
        let rotation_deg = ours
            .camera_from_world
            .rotation
            .angle_to(&true_camera.camera_from_world.rotation)
            .to_degrees();
        eprintln!(
            "{}: rms {:.4} px, centre error {centre_mm:.4} mm (σ {:.4}), rotation error {rotation_deg:.5}° (σ {:.5})",
            ours.name, residual.rms_px, residual.centre_std_mm, residual.rotation_std_deg
        );
        // Rendering leaves ~0.05 px of corner error; the adjustment's σ comes from those
        // residuals. |error| of a 3-vector beyond 3 sqrt(trace Cov) has probability < 1e-4.
        assert!(
            centre_mm < 3.0 * residual.centre_std_mm,
            "{}: centre error {centre_mm} mm",
            ours.name
        );
        assert!(
            rotation_deg < 3.0 * residual.rotation_std_deg,
            "{}: rotation error {rotation_deg}°",
            ours.name
        );
    }
}

/// Corner noise of our detector on rendered 1280x1024 views of the paper's rig (the
/// `calibration` scenario's placements and image formation) against the renderer's exact
/// corners: the "realistic corner noise" that `calib_rig_sim.rs` adds to projected corners.
/// The error per coordinate is reported with its spread over images. `calib_rig_sim.rs`
/// assumes 0.025 px (`MEASURED_NOISE_PX`) when it shows that 40 images per camera bring
/// every rotation σ to at most 0.0063°; 10 % more noise moves that to 0.0069°, past the
/// 0.0067° (3σ = 0.02°) goal, so the measured noise must stay below 0.0275 px or the
/// protocol needs more images.
#[test]
fn detector_corner_noise_on_rendered_paper_rig_views() {
    use rand::SeedableRng;
    use teachcam::sim::calibration::{calibration_scene, has_image};
    use teachcam::sim::scenario::paper_rig;

    let scene = calibration_scene(paper_rig(), 8, 21);
    let config = CornerConfig::default();
    let mut errors: Vec<f64> = Vec::new();
    let mut per_image_std: Vec<f64> = Vec::new();
    let (mut found, mut refused) = (0, 0);
    for (index, placement) in scene.placements.iter().enumerate().skip(1) {
        for camera in &scene.rig.cameras {
            if !has_image(camera, &scene.board, &scene.look, placement) {
                continue;
            }
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1000 + index as u64);
            // The truth is the exact projection; `None` only behind the camera.
            let view = scene.board_view(camera, placement, &mut rng);
            let Ok(corners) = find_chessboard_corners(&view.image, &scene.board, &config) else {
                refused += 1;
                continue;
            };
            found += 1;
            let mut image_errors = Vec::new();
            for (ours, truth) in corners.iter().zip(&view.corners) {
                let truth = truth.unwrap_or_else(|| panic!("a corner behind {}", camera.name));
                image_errors.extend([ours.x - truth.x, ours.y - truth.y]);
            }
            let n = image_errors.len() as f64;
            per_image_std.push((image_errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt());
            errors.extend(image_errors);
        }
    }
    let n = errors.len() as f64;
    let mean = errors.iter().sum::<f64>() / n;
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    per_image_std.sort_by(f64::total_cmp);
    eprintln!(
        "corner error per coordinate over {found} images ({refused} refused): mean {mean:.4} px, rms {rms:.4} px; per image rms min {:.4}, median {:.4}, max {:.4} px",
        per_image_std[0],
        per_image_std[per_image_std.len() / 2],
        per_image_std[per_image_std.len() - 1]
    );
    assert!(found >= 12, "{found} of {} images found", found + refused);
    assert!(mean.abs() < 0.01, "corner bias {mean} px");
    assert!(rms < 0.025 * 1.1, "corner noise {rms} px per coordinate");
}
