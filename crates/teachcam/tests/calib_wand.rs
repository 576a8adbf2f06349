//! Wand calibration against the simulator's truth: the `wand` scenario's images rendered by
//! the sphere renderer, detected, the wand found, the rig calibrated, then the ground frame.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use rayon::prelude::*;
use teachcam::calib::wand::{WandConfig, calibrate_wand, set_ground, wand_views};
use teachcam::camera::Rig;
use teachcam::correspond::Views;
use teachcam::detect::{DetectConfig, detect};
use teachcam::geometry::rotation_angle_between;
use teachcam::sim::wand::{contract_wand, ground_scene, imperfect_camera_frames, wand_scene};
use teachcam::sim::{Scene, render_frame};

/// Frames of the dance rendered here: 150 of the 400 (2.5 s at 60 Hz; rendering and
/// detecting 600 images is most of the test's time, the calibration takes 0.3 s). Every kind
/// of imperfection occurs in them; 240 frames gave 0.018 mm and 0.0002° from the truth.
const FRAMES: usize = 150;

/// Frames of the still ground recording used here (of its 30).
const GROUND_FRAMES: usize = 10;

/// Every frame's detected blob centres, per camera.
fn detected(scene: &Scene, frames: usize, seed: u64) -> Vec<Views> {
    (0..frames)
        .into_par_iter()
        .map(|f| {
            render_frame(scene, f, seed)
                .into_iter()
                .map(|view| {
                    let camera = &scene.rig.cameras[view.camera.0];
                    let config = DetectConfig::for_marker(
                        camera,
                        scene.tool.marker_diameter_mm,
                        300.0,
                        3000.0,
                    );
                    let blobs = detect(&view.image, &config).unwrap();
                    (view.camera, blobs.iter().map(|b| b.center).collect())
                })
                .collect()
        })
        .collect()
}

/// `rig` with its world moved to camera 0's frame.
fn in_camera0_frame(rig: &Rig) -> Rig {
    let world_from_camera0 = rig.cameras[0].camera_from_world.inverse();
    let mut moved = rig.clone();
    for camera in &mut moved.cameras {
        camera.camera_from_world *= world_from_camera0;
    }
    moved
}

/// Largest centre distance (mm) and rotation difference (degrees) between two rigs.
fn rig_errors(found: &Rig, truth: &Rig) -> (f64, f64) {
    found
        .cameras
        .iter()
        .zip(&truth.cameras)
        .fold((0.0f64, 0.0f64), |(c, r), (a, b)| {
            let centre = (a.center_in_world() - b.center_in_world()).norm();
            let angle: f64 = rotation_angle_between(&a.camera_from_world, &b.camera_from_world);
            (c.max(centre), r.max(angle.to_degrees()))
        })
}

#[test]
fn a_rendered_wand_dance_calibrates_the_rig_within_a_millimetre() {
    let seed = 16;
    let scene = wand_scene(seed);
    let imperfect = imperfect_camera_frames(&scene)
        .iter()
        .filter(|(f, _)| *f < FRAMES)
        .count();
    // The scene's imperfections: about 10 % of the camera-frames.
    let fraction = imperfect as f64 / (4 * FRAMES) as f64;
    assert!((0.07..0.13).contains(&fraction), "{fraction}");
    let clock = std::time::Instant::now();
    let frames = detected(&scene, FRAMES, seed);
    eprintln!(
        "rendered and detected in {:.1} s",
        clock.elapsed().as_secs_f64()
    );
    let clock = std::time::Instant::now();
    let wand = contract_wand();
    let config = WandConfig::default();
    let views = wand_views(&scene.rig, &frames, &wand, &config);
    let result = calibrate_wand(&scene.rig, &views.frames, &wand, &config).unwrap();
    eprintln!("calibrated in {:.1} s", clock.elapsed().as_secs_f64());
    let truth = in_camera0_frame(&scene.rig);
    let (centre_mm, rotation_deg) = rig_errors(&result.rig, &truth);
    eprintln!(
        "wand: {} three-blob views, {} not collinear, {} ends unlabelled; frames used {} rejected {}; gate {:.3} px; \
         centre error {centre_mm:.3} mm, rotation error {rotation_deg:.4} deg; length RMS {:.4} mm max {:.4} mm; \
         iterations {}",
        views.whole,
        views.not_collinear,
        views.ends_unlabelled,
        result.frames_used,
        result.frames_rejected,
        result.residual_gate_px,
        result.length_rms_mm,
        result.length_max_mm,
        result.iterations
    );
    for c in &result.cameras {
        eprintln!(
            "  {}: {} frames, {} dropped, {:.3} px, σ {:.4} deg {:.3} mm",
            c.name, c.frames, c.dropped, c.rms_px, c.rotation_std_deg, c.centre_std_mm
        );
    }
    // About 3× what this dance gives (measured 2026-12-06: centres 0.020 mm, rotations
    // 0.0004°; the bundle's σ 0.01–0.02 mm, 0.001°); the acceptance, 1 mm and 0.05°,
    // let a 30× regression pass.
    assert!(centre_mm < 0.06, "camera centres off by {centre_mm} mm");
    assert!(rotation_deg < 0.002, "rotations off by {rotation_deg} deg");
    assert!(result.length_rms_mm <= 0.1, "{}", result.length_rms_mm);
    assert!(result.converged);

    // The ground frame: the L-frame's tool frame is the simulator's world.
    let ground = ground_scene(seed);
    let ground_frames = detected(&ground, GROUND_FRAMES, seed ^ 0x67);
    let (grounded, report) = set_ground(&result.rig, &ground_frames, &ground.tool).unwrap();
    let (centre_mm, rotation_deg) = rig_errors(&grounded, &scene.rig);
    eprintln!(
        "ground: posed {} of {}, scatter {:.4} mm, registration {:.3} mm; centre error {centre_mm:.3} mm, rotation error {rotation_deg:.4} deg",
        report.posed, report.frames, report.scatter_mm, report.registration_rms_mm
    );
    assert_eq!(report.posed, report.frames);
    // The ground frame adds its own (measured: 0.030 mm, 0.0015°): about 2.5×.
    assert!(centre_mm < 0.08, "camera centres off by {centre_mm} mm");
    assert!(rotation_deg < 0.004, "rotations off by {rotation_deg} deg");
    assert!(
        report.cameras_below.is_empty(),
        "{:?}",
        report.cameras_below
    );
    // The same L-frame described turned over (its z into the work object): every camera is
    // below its plane, which the CLI warns of.
    let flipped = teachcam::tool::Tool::new(
        ground.tool.name.clone(),
        ground.tool.marker_diameter_mm,
        ground
            .tool
            .markers_in_tool
            .iter()
            .map(|m| teachcam::geometry::Point3::new(m.x, -m.y, -m.z))
            .collect(),
        ground.tool.tool_from_tcp,
    )
    .unwrap();
    let (_, upside_down) = set_ground(&result.rig, &ground_frames, &flipped).unwrap();
    assert_eq!(upside_down.cameras_below.len(), scene.rig.cameras.len());

    // The stroke: the paper's brush stroke (120 frames) on the same four-camera rig,
    // its markers projected exactly with 0.009 px of noise (what these renders leave after the
    // fit, so the rig's error is not hidden under noise), tracked through the wand-calibrated
    // rig and through the true rig; the issue asks ≤ 1.5×.
    let (via_wand, via_truth) = (stroke_tip_rms_mm(&grounded), stroke_tip_rms_mm(&scene.rig));
    eprintln!(
        "stroke tip RMS: {via_wand:.4} mm through the wand rig, {via_truth:.4} mm through the true rig"
    );
    assert!(via_wand <= 1.5 * via_truth, "{via_wand} vs {via_truth} mm");
}

/// Tip RMS (mm) against the truth of the four-camera stroke tracked through `rig` (every
/// frame must be posed).
fn stroke_tip_rms_mm(rig: &Rig) -> f64 {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let stroke = teachcam::sim::build_scene(teachcam::sim::Scenario::FourCameras, 1);
    assert_eq!(stroke.rig.cameras.len(), rig.cameras.len());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let noise = Normal::new(0.0, 0.009).unwrap();
    let tracker = teachcam::track::Tracker::new(rig, &stroke.tool, Default::default());
    let mut sum = 0.0;
    for sample in &stroke.truth.samples {
        let truth = sample.pose.unwrap();
        let world = teachcam::sim::markers_in_world(&stroke.tool, &truth.world_from_tool);
        let views: Views = stroke
            .rig
            .iter()
            .map(|(id, camera)| {
                let pixels = world
                    .iter()
                    .filter_map(|p| camera.project(p))
                    .map(|p| {
                        teachcam::geometry::Pixel::new(
                            p.x + noise.sample(&mut rng),
                            p.y + noise.sample(&mut rng),
                        )
                    })
                    .collect();
                (id, pixels)
            })
            .collect();
        let posed = tracker.track_frame(&views).outcome.unwrap();
        sum += (posed.tip_in_world - truth.tip_in_world).norm_squared();
    }
    (sum / stroke.truth.samples.len() as f64).sqrt()
}

/// Every frame's exact wand projections plus Gaussian noise of `noise_px`, in shuffled order;
/// in every `corrupt_every`-th camera-frame the middle marker's image is moved along the wand
/// by `shift_px` (a reflection beside a hidden marker: three collinear blobs, wrong in place).
fn projected(
    scene: &Scene,
    frames: usize,
    noise_px: f64,
    corrupt_every: usize,
    shift_px: f64,
) -> (Vec<Views>, usize) {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, noise_px).unwrap();
    let mut corrupted = 0;
    let mut count = 0;
    let views = (0..frames)
        .map(|f| {
            let pose = scene.truth.samples[f].pose.unwrap().world_from_tool;
            let world = teachcam::sim::markers_in_world(&scene.tool, &pose);
            let mut views = Views::new();
            for (id, camera) in scene.rig.iter() {
                let mut pixels: Vec<teachcam::geometry::Pixel> = world
                    .iter()
                    .filter_map(|p| camera.project(p))
                    .filter(|p| camera.image_size.contains(p))
                    .map(|p| {
                        teachcam::geometry::Pixel::new(
                            p.x + noise.sample(&mut rng),
                            p.y + noise.sample(&mut rng),
                        )
                    })
                    .collect();
                if pixels.len() == 3 {
                    count += 1;
                    if count % corrupt_every == 0 {
                        let (a, c) = (pixels[0], pixels[2]);
                        let length = a.distance(&c);
                        pixels[1].x += shift_px * (c.x - a.x) / length;
                        pixels[1].y += shift_px * (c.y - a.y) / length;
                        corrupted += 1;
                    }
                }
                pixels.reverse();
                views.insert(id, pixels);
            }
            views
        })
        .collect();
    (views, corrupted)
}

#[test]
fn camera_frames_with_a_misplaced_marker_are_dropped_by_the_residual_gate() {
    let scene = wand_scene(3);
    // 0.02 px: the detector's noise on these images (the rendered test's 0.009 px RMS after
    // the fit); every 12th camera-frame corrupted by 3 px along the wand.
    let (frames, corrupted) = projected(&scene, 400, 0.02, 12, 3.0);
    let wand = contract_wand();
    let config = WandConfig::default();
    let views = wand_views(&scene.rig, &frames, &wand, &config);
    let result = calibrate_wand(&scene.rig, &views.frames, &wand, &config).unwrap();
    let dropped: usize = result.cameras.iter().map(|c| c.dropped).sum();
    let (centre_mm, rotation_deg) = rig_errors(&result.rig, &in_camera0_frame(&scene.rig));
    eprintln!(
        "gate: {corrupted} corrupted, {dropped} dropped, gate {:.3} px; centre error {centre_mm:.4} mm, rotation error {rotation_deg:.5} deg, length RMS {:.4} mm",
        result.residual_gate_px, result.length_rms_mm
    );
    // Nine in ten of the corrupted camera-frames dropped at least (one left out earlier by
    // the ambiguity rule never reaches the gate), and clean ones dropped with them no more
    // than a tenth as many.
    assert!(
        dropped <= corrupted + corrupted / 10,
        "{dropped} of {corrupted}"
    );
    assert!(dropped * 10 >= corrupted * 9, "{dropped} of {corrupted}");
    // Measured 0.0077 mm and 0.0005° with the corrupted views dropped: about 4×.
    assert!(
        centre_mm < 0.03 && rotation_deg < 0.002,
        "{centre_mm} mm, {rotation_deg} deg"
    );
    assert!(result.length_rms_mm <= 0.1);
}

/// The refusals, on exact projections (0.02 px noise) of the dance through the true
/// rig: a dance too short and the wand seen by one camera only are refused. A dance in one
/// plane is not degenerate for the adjustment when the intrinsics are known (a chessboard is
/// planar too): it must give either a refusal naming the plane or the true rig, never a
/// wrong one. (Measured: the true rig, to 1e-13 px without noise; the planarity check looks
/// at the essential-matrix start's markers, which for this dance are not planar.)
#[test]
fn a_short_dance_and_a_wand_in_one_camera_are_refused_and_a_planar_dance_gives_the_truth() {
    use teachcam::calib::wand::WandError;
    let scene = wand_scene(5);
    let wand = contract_wand();
    let config = WandConfig::default();
    let calibrate = |frames: &[Views]| {
        let views = wand_views(&scene.rig, frames, &wand, &config);
        calibrate_wand(&scene.rig, &views.frames, &wand, &config)
    };
    // 15 frames: fewer than the 20 with the wand in two or more cameras that are needed.
    let (short, _) = projected(&scene, 15, 0.02, usize::MAX, 0.0);
    let error = calibrate(&short).unwrap_err();
    assert!(
        matches!(error, WandError::TooFewFrames { found, needed: 20 } if found <= 15),
        "{error}"
    );
    // 400 frames, but only camera 0 keeps its images: no frame has the wand in two cameras.
    let (all, _) = projected(&scene, 400, 0.02, usize::MAX, 0.0);
    let one_camera: Vec<Views> = all
        .iter()
        .map(|v| {
            v.iter()
                .filter(|(id, _)| id.0 == 0)
                .map(|(id, p)| (*id, p.clone()))
                .collect()
        })
        .collect();
    let error = calibrate(&one_camera).unwrap_err();
    assert!(
        matches!(error, WandError::TooFewFrames { found: 0, .. }),
        "{error}"
    );
    assert!(error.to_string().contains("two or more cameras"), "{error}");

    // A dance in one plane: the wand slid flat over the dance's mean height, 200 frames.
    let positions = wand.markers_mm.clone();
    let centre = scene
        .truth
        .samples
        .iter()
        .filter_map(|s| s.pose)
        .map(|p| p.world_from_tool.translation.vector)
        .fold(nalgebra::Vector3::zeros(), |s, t| s + t)
        / scene.truth.samples.len() as f64;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, 0.02).unwrap();
    let planar: Vec<Views> = (0..200)
        .map(|f| {
            let t = f as f64 * 0.05;
            let start =
                centre + nalgebra::Vector3::new(150.0 * t.sin(), 120.0 * (1.3 * t).cos(), 0.0);
            let axis = nalgebra::Vector3::new((0.7 * t).cos(), (0.7 * t).sin(), 0.0);
            let world: Vec<teachcam::geometry::Point3> = positions
                .iter()
                .map(|p| {
                    teachcam::geometry::Point3::from(
                        start + axis * (p - positions[0]) - axis * 250.0,
                    )
                })
                .collect();
            scene
                .rig
                .iter()
                .map(|(id, camera)| {
                    let pixels = world
                        .iter()
                        .filter_map(|p| camera.project(p))
                        .filter(|p| camera.image_size.contains(p))
                        .map(|p| {
                            teachcam::geometry::Pixel::new(
                                p.x + noise.sample(&mut rng),
                                p.y + noise.sample(&mut rng),
                            )
                        })
                        .collect();
                    (id, pixels)
                })
                .collect()
        })
        .collect();
    match calibrate(&planar) {
        Err(error) => {
            eprintln!("planar dance refused: {error}");
            assert!(error.to_string().contains("plane"), "{error}");
        }
        Ok(result) => {
            let (centre_mm, rotation_deg) = rig_errors(&result.rig, &in_camera0_frame(&scene.rig));
            eprintln!(
                "planar dance calibrated: centre error {centre_mm:.4} mm, rotation error {rotation_deg:.5} deg; frames used {}, rejected {}, ambiguous {}, rms {:?}",
                result.frames_used,
                result.frames_rejected,
                result.frames_ambiguous,
                result.cameras.iter().map(|c| c.rms_px).collect::<Vec<_>>()
            );
            // Measured 0.028 mm and 0.0018° (a planar dance determines the rig less well than
            // a full one): about 2.5×.
            assert!(
                centre_mm < 0.07 && rotation_deg < 0.005,
                "{centre_mm} mm, {rotation_deg} deg"
            );
        }
    }
}

/// The observations compared with scipy: `tests/data/wand_observations.csv` (`frame,camera,
/// marker,u,v`, distorted pixels in wand order) and `wand_observations_rig.json` (the true rig
/// in camera 0's frame: intrinsics for both solvers, the truth for the script's start).
fn reference_paths() -> (std::path::PathBuf, std::path::PathBuf) {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    (
        data.join("wand_observations.csv"),
        data.join("wand_observations_rig.json"),
    )
}

/// Writes the reference input when `TEACHCAM_WRITE_WAND_OBSERVATIONS` is set: 300 frames of
/// the dance projected exactly through the true rig, 0.05 px of Gaussian noise, kept by
/// `wand_views` as a recording's would be.
#[test]
fn write_the_wand_observations_for_the_scipy_reference_when_asked() {
    if std::env::var_os("TEACHCAM_WRITE_WAND_OBSERVATIONS").is_none() {
        return;
    }
    let scene = wand_scene(21);
    let (frames, _) = projected(&scene, 300, 0.05, usize::MAX, 0.0);
    let wand = contract_wand();
    let views = wand_views(&scene.rig, &frames, &wand, &WandConfig::default());
    let mut csv = String::from("frame,camera,marker,u,v\n");
    for (f, frame) in views.frames.iter().enumerate() {
        // The images whose ends the split told apart (the reference needs them labelled).
        let frame: Vec<_> = frame.iter().filter(|(_, i)| i.ends_known).collect();
        if frame.len() < 2 {
            continue;
        }
        for (id, image) in frame {
            for (k, p) in image.pixels.iter().enumerate() {
                csv.push_str(&format!("{f},{},{k},{:.6},{:.6}\n", id.0, p.x, p.y));
            }
        }
    }
    let (observations, rig) = reference_paths();
    std::fs::write(observations, csv).unwrap();
    teachcam::io::rig::write_rig(&rig, &in_camera0_frame(&scene.rig)).unwrap();
}

/// The wand bundle adjustment against an independent solver on the same observations:
/// `scripts/reference/wand_bundle_scipy.py` (scipy `least_squares`, its own projection, its
/// own parameterisation and start) → `tests/data/wand_bundle_scipy.json`. Both minimise the
/// same cost, so they must reach the same minimum: every camera within a tenth of its σ
/// (σ from the noise of 0.05 px; the difference is the solvers' convergence, not noise).
#[test]
fn the_wand_bundle_reaches_scipys_minimum_on_the_same_observations() {
    let (observations, rig_path) = reference_paths();
    let rig = teachcam::io::rig::read_rig(&rig_path).unwrap();
    let text = std::fs::read_to_string(observations).unwrap();
    let mut frames: std::collections::BTreeMap<usize, teachcam::calib::wand::WandFrame> =
        std::collections::BTreeMap::new();
    for line in text.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let (f, c, k): (usize, usize, usize) = (
            v[0].parse().unwrap(),
            v[1].parse().unwrap(),
            v[2].parse().unwrap(),
        );
        let p = teachcam::geometry::Pixel::new(v[3].parse().unwrap(), v[4].parse().unwrap());
        frames
            .entry(f)
            .or_default()
            .entry(teachcam::geometry::CameraId(c))
            .or_insert_with(|| teachcam::calib::wand::WandImage::labelled(vec![p; 3]))
            .pixels[k] = p;
    }
    let frames: Vec<_> = frames.into_values().collect();
    let result = calibrate_wand(&rig, &frames, &contract_wand(), &WandConfig::default()).unwrap();
    assert_eq!(result.frames_used, frames.len());
    assert!(result.cameras.iter().all(|c| c.dropped == 0));
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/wand_bundle_scipy.json"),
        )
        .unwrap(),
    )
    .unwrap();
    for (c, (camera, fit)) in result.rig.cameras.iter().zip(&result.cameras).enumerate() {
        let r = &reference["cameras"][c];
        let centre: Vec<f64> = (0..3)
            .map(|i| r["centre_mm"][i].as_f64().unwrap())
            .collect();
        let centre = teachcam::geometry::Point3::new(centre[0], centre[1], centre[2]);
        let rows: Vec<Vec<f64>> = (0..3)
            .map(|i| {
                (0..3)
                    .map(|j| r["rotation"][i][j].as_f64().unwrap())
                    .collect()
            })
            .collect();
        let theirs =
            nalgebra::UnitQuaternion::from_matrix(&nalgebra::Matrix3::from_fn(|i, j| rows[i][j]));
        let angle = camera
            .camera_from_world
            .rotation
            .angle_to(&theirs)
            .to_degrees();
        let moved = (camera.center_in_world() - centre).norm();
        eprintln!(
            "{}: vs scipy {moved:.2e} mm, {angle:.2e} deg (σ {:.4} mm, {:.5} deg)",
            camera.name, fit.centre_std_mm, fit.rotation_std_deg
        );
        assert!(
            moved <= 0.1 * fit.centre_std_mm + 1e-9,
            "{}: {moved} mm",
            camera.name
        );
        assert!(
            angle <= 0.1 * fit.rotation_std_deg + 1e-9,
            "{}: {angle} deg",
            camera.name
        );
    }
    let rms = reference["reprojection_rms_px"].as_f64().unwrap();
    let ours = (result
        .cameras
        .iter()
        .map(|c| c.rms_px * c.rms_px * c.frames as f64)
        .sum::<f64>()
        / result.cameras.iter().map(|c| c.frames as f64).sum::<f64>())
    .sqrt();
    eprintln!("reprojection rms: ours {ours:.6} px, scipy {rms:.6} px");
    assert!((ours - rms).abs() < 1e-4 * rms.max(1e-3), "{ours} vs {rms}");
}

/// The dance's wand of two markers 660 mm apart (centred where the contract wand's middle
/// is), projected exactly through the true rig with Gaussian noise of `noise_px`, each
/// camera-frame's two points in random order (ends not labelled, shuffled per frame and per
/// camera); a camera sees the wand when both points fall in its image. Also returns the same
/// points in true order.
fn two_marker_dance(
    scene: &Scene,
    frames: usize,
    noise_px: f64,
    seed: u64,
) -> (Vec<Views>, Vec<Views>) {
    use rand::{RngExt, SeedableRng};
    use rand_distr::{Distribution, Normal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, noise_px).unwrap();
    let ends = [
        teachcam::geometry::Point3::new(0.0, 0.0, -80.0),
        teachcam::geometry::Point3::new(0.0, 0.0, 580.0),
    ];
    (0..frames)
        .map(|f| {
            let pose = scene.truth.samples[f].pose.unwrap().world_from_tool;
            let mut shuffled = Views::new();
            let mut ordered = Views::new();
            for (id, camera) in scene.rig.iter() {
                let pixels: Vec<teachcam::geometry::Pixel> = ends
                    .iter()
                    .filter_map(|p| camera.project(&(pose * p)))
                    .filter(|p| camera.image_size.contains(p))
                    .map(|p| {
                        teachcam::geometry::Pixel::new(
                            p.x + noise.sample(&mut rng),
                            p.y + noise.sample(&mut rng),
                        )
                    })
                    .collect();
                ordered.insert(id, pixels.clone());
                let mut pixels = pixels;
                if rng.random_range(0..2) == 1 {
                    pixels.reverse();
                }
                shuffled.insert(id, pixels);
            }
            (shuffled, ordered)
        })
        .unzip()
}

/// The most common wand, two markers (easyWand's, Argus's): ends unlabelled and shuffled per
/// frame and per camera, 0.2 px of noise per axis (a careful digitiser's). Judged against the
/// truth: the rig within 3 of its own σ (σ from the same noise); each camera's reprojection
/// RMS (per marker image, 2-D) within 25 % of what the noise leaves over the whole fit,
/// `σ√2·√(1 − unknowns/residuals)`; the wand length std no more than 10 % above that of the
/// same points (true order) triangulated through the true rig; its mean within three of its
/// standard errors of 660 mm.
#[test]
fn a_two_marker_wand_with_shuffled_ends_calibrates_the_rig() {
    use teachcam::calib::wand::Wand;
    let scene = wand_scene(29);
    let noise_px = 0.2;
    let (frames, ordered) = two_marker_dance(&scene, 400, noise_px, 29);
    let wand = Wand::new("two".into(), 14.0, vec![0.0, 660.0]).unwrap();
    let config = WandConfig::default();
    let views = wand_views(&scene.rig, &frames, &wand, &config);
    assert_eq!(views.ends_unlabelled, views.whole);
    let clock = std::time::Instant::now();
    let result = calibrate_wand(&scene.rig, &views.frames, &wand, &config).unwrap();
    let seconds = clock.elapsed().as_secs_f64();
    let truth = in_camera0_frame(&scene.rig);
    let (centre_mm, rotation_deg) = rig_errors(&result.rig, &truth);
    let centre_std = result
        .cameras
        .iter()
        .map(|c| c.centre_std_mm)
        .fold(0.0, f64::max);
    let rotation_std = result
        .cameras
        .iter()
        .map(|c| c.rotation_std_deg)
        .fold(0.0, f64::max);
    // The noise's own length scatter: the points in true order through the true rig.
    let loose = teachcam::triangulate::TriangulateConfig {
        max_residual_px: f64::INFINITY,
        ..Default::default()
    };
    let true_lengths: Vec<f64> = ordered
        .iter()
        .filter_map(|views| {
            let whole: Vec<_> = views.iter().filter(|(_, p)| p.len() == 2).collect();
            if whole.len() < 2 {
                return None;
            }
            let end = |k: usize| {
                let pixels = whole.iter().map(|(id, p)| (**id, p[k])).collect();
                teachcam::triangulate::triangulate(&scene.rig, &pixels, &loose)
                    .ok()
                    .map(|t| t.position)
            };
            Some((end(1)? - end(0)?).norm())
        })
        .collect();
    let n = true_lengths.len() as f64;
    let true_mean = true_lengths.iter().sum::<f64>() / n;
    let true_std = (true_lengths
        .iter()
        .map(|l| (l - true_mean).powi(2))
        .sum::<f64>()
        / (n - 1.0))
        .sqrt();
    // What the noise leaves: 2 coordinates per marker image, 5 unknowns per frame, 6 per
    // camera but the first.
    let images: usize = result.cameras.iter().map(|c| 2 * c.frames).sum();
    let unknowns = 5 * result.frames_used + 6 * (result.cameras.len() - 1);
    let expected_rms =
        noise_px * 2f64.sqrt() * (1.0 - unknowns as f64 / (2 * images) as f64).sqrt();
    eprintln!(
        "two-marker wand: {} whole views; frames used {}, rejected {}, ambiguous {}; {seconds:.2} s; \
         centre error {centre_mm:.4} mm (σ ≤ {centre_std:.4}), rotation error {rotation_deg:.5} deg (σ ≤ {rotation_std:.5}); \
         length mean {:.4} mm, std {:.4} mm ({:.4} %); through the true rig {true_mean:.4} / {true_std:.4} mm; \
         expected rms {expected_rms:.4} px",
        views.whole,
        result.frames_used,
        result.frames_rejected,
        result.frames_ambiguous,
        result.length_mean_mm,
        result.length_std_mm,
        result.length_std_percent()
    );
    for c in &result.cameras {
        eprintln!(
            "  {}: {} frames, {} dropped, rms {:.4} px",
            c.name, c.frames, c.dropped, c.rms_px
        );
    }
    assert!(result.converged);
    assert!(result.frames_used >= 300, "{}", result.frames_used);
    assert!(
        centre_mm <= 3.0 * centre_std,
        "{centre_mm} mm vs σ {centre_std}"
    );
    assert!(
        rotation_deg <= 3.0 * rotation_std,
        "{rotation_deg} deg vs σ {rotation_std}"
    );
    for c in &result.cameras {
        assert!(
            (c.rms_px / expected_rms - 1.0).abs() <= 0.25,
            "{}: {} px vs {expected_rms}",
            c.name,
            c.rms_px
        );
    }
    assert!(
        result.length_std_mm <= 1.1 * true_std,
        "{} vs {true_std}",
        result.length_std_mm
    );
    let standard_error = result.length_std_mm / (result.frames_used as f64).sqrt();
    assert!(
        (result.length_mean_mm - 660.0).abs() <= 3.0 * standard_error,
        "{} ± {standard_error}",
        result.length_mean_mm
    );
}
