//! Issue 16 end to end: `teachcam simulate --scenario wand` renders a wand dance and a ground
//! frame through the four-camera rig, `teachcam calibrate wand` calibrates the rig from the
//! images and the cameras' intrinsics alone, and every camera is compared with the truth
//! (`rig_true.json`, world = the L-frame). 100 frames of the dance (1.7 s at 60 Hz) keep the
//! test short; the library test `calib_wand` measures a longer one.
//! Tolerances: about 2.5× what the rendered dance gives (centres 0.027 mm, rotations 0.0016°;
//! the issue's acceptance, 1 mm and 0.05°, let a 30× regression pass), wand length RMS ≤ 0.1 mm. Then `teachcam calibrate refine` mending a bumped camera from a recording of
//! a tool (the stereo twin of the real recording, the four-camera rig) and its refusals.

#![allow(
    clippy::unwrap_used,
    clippy::print_stderr,
    reason = "a test fails loudly on a broken fixture and prints the numbers it measured"
)]

use std::path::Path;
use std::process::Command;

use teachcam::geometry::CameraId;
use teachcam::io::rig::{read_rig, write_rig};
use teachcam::sim::Miscalibration;

fn teachcam() -> Command {
    Command::new(env!("CARGO_BIN_EXE_teachcam"))
}

/// The number after `key` in `text`.
fn number_after(text: &str, key: &str) -> f64 {
    let tail = &text[text.find(key).unwrap() + key.len()..];
    let end = tail
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(tail.len());
    tail[..end].parse().unwrap()
}

#[test]
fn calibrate_wand_recovers_the_simulated_rig_and_its_ground_frame() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    let status = teachcam()
        .args(["simulate", "--scenario", "wand", "--frames", "100", "--out"])
        .arg(&sim)
        .status()
        .unwrap();
    assert!(status.success());
    for file in ["cameras.json", "wand.json", "lframe.json", "rig_true.json"] {
        assert!(sim.join(file).is_file(), "{file}");
    }
    let out = dir.path().join("rig.json");
    let run = teachcam()
        .arg("calibrate")
        .arg("wand")
        .arg(sim.join("wand"))
        .arg("--cameras")
        .arg(sim.join("cameras.json"))
        .arg("--wand")
        .arg(sim.join("wand.json"))
        .arg("--ground")
        .arg(sim.join("ground"))
        .arg("--ground-tool")
        .arg(sim.join("lframe.json"))
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    eprintln!("{stdout}{}", String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success());
    let length_rms = number_after(&stdout, "error rms ");
    assert!(length_rms <= 0.1, "{length_rms}");
    assert!(number_after(&stdout, "frames used ") >= 50.0);
    let found = read_rig(&out).unwrap();
    let truth = read_rig(&sim.join("rig_true.json")).unwrap();
    for (a, b) in found.cameras.iter().zip(&truth.cameras) {
        let centre_mm = (a.center_in_world() - b.center_in_world()).norm();
        let angle_deg = a
            .camera_from_world
            .rotation
            .angle_to(&b.camera_from_world.rotation)
            .to_degrees();
        eprintln!(
            "{}: centre {centre_mm:.4} mm, rotation {angle_deg:.5} deg",
            a.name
        );
        // Measured 0.023–0.027 mm and 0.0011–0.0016° (2026-12-06): about 2.5×.
        assert!(centre_mm < 0.07, "{}: {centre_mm} mm", a.name);
        assert!(angle_deg < 0.004, "{}: {angle_deg} deg", a.name);
    }
}

#[test]
fn calibrate_wand_refuses_a_one_camera_file_and_a_ground_without_its_tool() {
    let dir = tempfile::tempdir().unwrap();
    let cameras = dir.path().join("cameras.json");
    std::fs::write(
        &cameras,
        r#"{"units": "mm", "cameras": [{"name": "cam0", "image_size": [640, 480],
        "fx": 600.0, "fy": 600.0, "cx": 319.5, "cy": 239.5, "distortion": [0, 0, 0, 0, 0]}]}"#,
    )
    .unwrap();
    let wand = dir.path().join("wand.json");
    std::fs::write(
        &wand,
        r#"{"name": "wand", "marker_diameter_mm": 14.0, "markers_mm": [0.0, 160.0, 500.0]}"#,
    )
    .unwrap();
    let run = |extra: &[&str]| {
        teachcam()
            .arg("calibrate")
            .arg("wand")
            .arg(dir.path())
            .arg("--cameras")
            .arg(&cameras)
            .arg("--wand")
            .arg(&wand)
            .args(extra)
            .arg("-o")
            .arg(dir.path().join("rig.json"))
            .output()
            .unwrap()
    };
    let one = run(&[]);
    assert_eq!(one.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&one.stderr).contains("at least 2"));
    let usage = run(&["--ground", "somewhere"]);
    assert_eq!(usage.status.code(), Some(2));
    assert!(!dir.path().join("rig.json").exists());
}

/// `teachcam calibrate refine REC --rig R --tool T -o OUT`: status, stdout and stderr.
fn refine(recording: &Path, rig: &Path, tool: &Path, out: &Path) -> (Option<i32>, String, String) {
    let run = teachcam()
        .args(["calibrate", "refine"])
        .arg(recording)
        .arg("--rig")
        .arg(rig)
        .arg("--tool")
        .arg(tool)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&run.stdout).into_owned(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    );
    eprintln!("{stdout}{stderr}");
    (run.status.code(), stdout, stderr)
}

/// Frames `teachcam track` poses with default flags through `rig`.
fn posed_by_track(recording: &Path, rig: &Path, tool: &Path, out: &Path) -> f64 {
    let run = teachcam()
        .arg("track")
        .arg(recording)
        .arg("--rig")
        .arg(rig)
        .arg("--tool")
        .arg(tool)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    assert!(run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    number_after(&stderr, ".csv: ")
}

/// Rotation (degrees) and centre (mm) differences per camera, and the σ the file carries.
fn differences(found: &Path, truth: &Path) -> Vec<(String, f64, f64, f64, f64)> {
    let text: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(found).unwrap()).unwrap();
    let (found, truth) = (read_rig(found).unwrap(), read_rig(truth).unwrap());
    found
        .cameras
        .iter()
        .zip(&truth.cameras)
        .zip(text["cameras"].as_array().unwrap())
        .map(|((a, b), file)| {
            let angle = a
                .camera_from_world
                .rotation
                .angle_to(&b.camera_from_world.rotation)
                .to_degrees();
            let centre = (a.center_in_world() - b.center_in_world()).norm();
            (
                a.name.clone(),
                angle,
                centre,
                file["rotation_std_deg"].as_f64().unwrap(),
                file["centre_std_mm"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// Issue 16, `calibrate refine`: the simulator's twin of the real stereo recording with its
/// rig file 0.4° off in cam1. After refinement cam1 is within 3σ of the truth (σ as the
/// adjustment writes it; the frames' blob noise gives ≈ 0.01°) and within 0.002° of what
/// refining the true rig from the same footage gives (the noise floor: both start points reach
/// the same minimum), the pair's epipolar distance falls from the bump's ≈ 4 px to the blob
/// noise (< 0.1 px), and `track` with default flags poses ≥ 95 % of the frames it poses
/// through the true rig. A 1° turn (beyond the measured gates) reaches the same minimum.
#[test]
fn calibrate_refine_mends_the_stereo_pair_turned_by_0_4_degrees() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    let status = teachcam()
        .args(["simulate", "--scenario", "stereo-ir-miscal", "--out"])
        .arg(&sim)
        .status()
        .unwrap();
    assert!(status.success());
    let tool = sim.join("tool.json");
    let refined = dir.path().join("refined.json");
    let (code, stdout, _) = refine(&sim, &sim.join("rig.json"), &tool, &refined);
    assert_eq!(code, Some(0));
    let before = number_after(&stdout, "median ");
    let after = number_after(&stdout, "px before, ");
    assert!((2.5..6.0).contains(&before), "before {before} px");
    assert!(after < 0.1, "after {after} px");
    let truth = sim.join("rig_true.json");
    let found = differences(&refined, &truth);
    let (name, angle, centre, angle_std, centre_std) = &found[1];
    eprintln!("{name}: {angle:.5}° (σ {angle_std:.5}), {centre:.3} mm (σ {centre_std:.3})");
    assert!(
        *angle <= 3.0 * angle_std && *angle < 0.04,
        "{name}: {angle}°"
    );
    // The σ the adjustment writes along the pair's depth is wide (2.9 mm); the centre itself
    // comes back within 0.30 mm: capped at about 3× that, not at 3σ alone.
    assert!(
        *centre <= 3.0 * centre_std && *centre < 1.0,
        "{name}: {centre} mm"
    );
    // The held camera as written (1e-6: the file's decimal round trip).
    assert!(
        found[0].1 < 1e-6 && found[0].2 < 1e-6,
        "the held camera moved"
    );

    let floor = dir.path().join("floor.json");
    assert_eq!(refine(&sim, &truth, &tool, &floor).0, Some(0));
    let a = read_rig(&refined).unwrap().cameras[1].camera_from_world;
    let b = read_rig(&floor).unwrap().cameras[1].camera_from_world;
    let between = a.rotation.angle_to(&b.rotation).to_degrees();
    assert!(
        between < 0.002,
        "refined from the bump vs from the truth: {between}°"
    );

    // Turned by 1°: ~10 px off the epipolar lines, beyond the measured gates' 5 px ceiling, so
    // the first round tracks with the gates widened; the same minimum again.
    let far_off = Miscalibration {
        camera: CameraId(1),
        axis_in_camera: nalgebra::Vector3::new(0.9, 0.3, 0.3),
        angle: 1.0_f64.to_radians(),
    }
    .apply(&read_rig(&truth).unwrap());
    let far_off_file = dir.path().join("far_off.json");
    write_rig(&far_off_file, &far_off).unwrap();
    let mended = dir.path().join("mended.json");
    let (code, stdout, _) = refine(&sim, &far_off_file, &tool, &mended);
    assert_eq!(code, Some(0));
    assert!(number_after(&stdout, "median ") > 8.0, "{stdout}");
    let c = read_rig(&mended).unwrap().cameras[1].camera_from_world;
    let between = c.rotation.angle_to(&b.rotation).to_degrees();
    assert!(
        between < 0.002,
        "refined from 1° off vs from the truth: {between}°"
    );

    let through_truth = posed_by_track(&sim, &truth, &tool, &dir.path().join("t.csv"));
    let through_refined = posed_by_track(&sim, &refined, &tool, &dir.path().join("r.csv"));
    eprintln!(
        "track poses {through_refined} frames through the refined rig, {through_truth} through the true rig"
    );
    assert!(through_refined >= 0.95 * through_truth);
}

/// The paper's four-camera rig with cam2 turned by 0.4° in the rig file: the bumped camera's
/// views are left out by triangulation, recovered by their common offset, and the adjustment
/// (the best-agreeing camera held) puts every camera back within 3σ of the truth (σ ≈ 0.0015°,
/// 0.02 mm at this blob noise). Then the refusals: a recording too short for the adjustment,
/// and a tool that is never found, exit 1 with one line each and nothing written.
#[test]
fn calibrate_refine_mends_a_bumped_camera_of_four_and_refuses_what_it_cannot_use() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    let status = teachcam()
        .args(["simulate", "--scenario", "four-cameras", "--out"])
        .arg(&sim)
        .status()
        .unwrap();
    assert!(status.success());
    let truth = sim.join("rig.json");
    let bumped = Miscalibration {
        camera: CameraId(2),
        axis_in_camera: nalgebra::Vector3::new(0.3, 1.0, 0.2),
        angle: 0.4_f64.to_radians(),
    }
    .apply(&read_rig(&truth).unwrap());
    let bumped_file = dir.path().join("bumped.json");
    write_rig(&bumped_file, &bumped).unwrap();
    let tool = sim.join("tool.json");
    let refined = dir.path().join("refined.json");
    let (code, stdout, _) = refine(&sim, &bumped_file, &tool, &refined);
    assert_eq!(code, Some(0));
    assert!(!stdout.contains("held fixed: cam2"), "{stdout}");
    for (name, angle, centre, angle_std, centre_std) in differences(&refined, &truth) {
        eprintln!("{name}: {angle:.5}° (σ {angle_std:.5}), {centre:.4} mm (σ {centre_std:.4})");
        // + 1e-6: the held camera (σ 0) through the file's decimal round trip.
        assert!(
            angle <= 3.0 * angle_std + 1e-6 && angle < 0.01,
            "{name}: {angle}°"
        );
        // Measured up to 0.031 mm (σ ≈ 0.023 mm): capped at about 3×, not at 3σ alone.
        assert!(
            centre <= 3.0 * centre_std + 1e-6 && centre < 0.1,
            "{name}: {centre} mm"
        );
    }

    // 12 frames: fewer confident frames than the adjustment needs.
    let short = dir.path().join("short");
    std::fs::create_dir(&short).unwrap();
    std::fs::copy(sim.join("recording.json"), short.join("recording.json")).unwrap();
    for camera in &bumped.cameras {
        let (from, to) = (sim.join(&camera.name), short.join(&camera.name));
        std::fs::create_dir(&to).unwrap();
        let mut files: Vec<_> = std::fs::read_dir(&from)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        for file in files.iter().take(12) {
            std::fs::copy(file, to.join(file.file_name().unwrap())).unwrap();
        }
    }
    let out = dir.path().join("never.json");
    let (code, _, stderr) = refine(&short, &bumped_file, &tool, &out);
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("12 frames tracked with confidence") && stderr.contains("at least 20"),
        "{stderr}"
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    // A tool the recording does not show.
    let triangle = dir.path().join("triangle.json");
    std::fs::write(
        &triangle,
        r#"{"name": "triangle", "marker_diameter_mm": 10.0,
        "markers": [[0, 0, 0], [150, 0, 0], [20, 90, 0]], "tip": [56.7, 30, -150]}"#,
    )
    .unwrap();
    let (code, _, stderr) = refine(&short, &bumped_file, &triangle, &out);
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("'triangle' was posed in none of the 12 frames"),
        "{stderr}"
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(!out.exists());
}

/// `calibrate wand --detections` with no images: the wand scenario's dance with a two-marker
/// wand (660 mm), each camera-frame's two points projected through the true rig with 0.2 px
/// of Gaussian noise and shuffled, written once as teachcam's detections.csv and once as
/// DLTdv's xypts.csv (y from the bottom edge, pixels from 1, NaN where missing). Both give the
/// same rig, within 1 mm and 0.05° of the truth (σ here ≈ 0.1–0.2 mm, 0.01°: see the library
/// test); the report's figures are the printed ones. A file of neither format is refused in
/// one line.
#[test]
fn calibrate_wand_from_detections_and_dltdv_points_of_a_two_marker_wand() {
    use rand::{RngExt, SeedableRng};
    use rand_distr::{Distribution, Normal};
    let dir = tempfile::tempdir().unwrap();
    let scene = teachcam::sim::wand::wand_scene(29);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(29);
    let noise = Normal::new(0.0, 0.2).unwrap();
    let ends = [
        teachcam::geometry::Point3::new(0.0, 0.0, -80.0),
        teachcam::geometry::Point3::new(0.0, 0.0, 580.0),
    ];
    let cameras = scene.rig.len();
    let mut detections = String::from("camera,frame,x_px,y_px,radius_px\n");
    let mut dltdv: Vec<String> = (1..=2)
        .flat_map(|p| {
            (1..=cameras).flat_map(move |c| [format!("pt{p}_cam{c}_X"), format!("pt{p}_cam{c}_Y")])
        })
        .collect();
    let mut dltdv_text = format!("{}\n", dltdv.join(","));
    for f in 0..300 {
        let pose = scene.truth.samples[f].pose.unwrap().world_from_tool;
        dltdv = vec!["NaN".to_string(); 4 * cameras];
        for (id, camera) in scene.rig.iter() {
            let mut pixels: Vec<_> = ends
                .iter()
                .filter_map(|p| camera.project(&(pose * p)))
                .filter(|p| camera.image_size.contains(p))
                .map(|p| (p.x + noise.sample(&mut rng), p.y + noise.sample(&mut rng)))
                .collect();
            if rng.random_range(0..2) == 1 {
                pixels.reverse();
            }
            let height = camera.image_size.height as f64;
            for (k, (x, y)) in pixels.iter().enumerate() {
                detections.push_str(&format!("{},{f},{x},{y},0\n", camera.name));
                let at = 2 * (k * cameras + id.0);
                dltdv[at] = format!("{}", x + 1.0);
                dltdv[at + 1] = format!("{}", height - y);
            }
        }
        dltdv_text.push_str(&format!("{}\n", dltdv.join(",")));
    }
    let points = dir.path().join("detections.csv");
    std::fs::write(&points, detections).unwrap();
    let xypts = dir.path().join("wand-xypts.csv");
    std::fs::write(&xypts, dltdv_text).unwrap();
    let cameras_file = dir.path().join("cameras.json");
    write_rig(&cameras_file, &scene.rig).unwrap();
    let wand = dir.path().join("wand.json");
    std::fs::write(
        &wand,
        r#"{"name": "two", "marker_diameter_mm": 14.0, "markers_mm": [0.0, 660.0]}"#,
    )
    .unwrap();
    let run = |points: &Path, extra: &[&str], name: &str| {
        let out = dir.path().join(format!("{name}.json"));
        let report = dir.path().join(format!("{name}_report.json"));
        let output = teachcam()
            .args(["calibrate", "wand", "--detections"])
            .arg(points)
            .arg("--cameras")
            .arg(&cameras_file)
            .arg("--wand")
            .arg(&wand)
            .args(extra)
            .arg("-o")
            .arg(&out)
            .arg("--report")
            .arg(&report)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout).to_string();
        eprintln!("{stdout}{}", String::from_utf8_lossy(&output.stderr));
        assert!(output.status.success());
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
        (read_rig(&out).unwrap(), report, stdout)
    };
    let (rig, report, stdout) = run(&points, &[], "csv");
    let (dlt_rig, dlt_report, _) = run(&xypts, &["--dltdv-origin", "bottom"], "dlt");
    // The printed figures are the report's.
    let mean = report["length_mean_mm"].as_f64().unwrap();
    let std_percent = report["length_std_percent"].as_f64().unwrap();
    assert!((number_after(&stdout, "wand length: mean ") - mean).abs() < 1e-3);
    assert!((mean - 660.0).abs() < 0.1, "{mean}");
    assert!(std_percent < 0.1, "{std_percent}");
    let world_from_camera0 = scene.rig.cameras[0].camera_from_world.inverse();
    for ((found, dlt), truth) in rig
        .cameras
        .iter()
        .zip(&dlt_rig.cameras)
        .zip(&scene.rig.cameras)
    {
        let truth_pose = truth.camera_from_world * world_from_camera0;
        let centre = (found.camera_from_world.inverse().translation.vector
            - truth_pose.inverse().translation.vector)
            .norm();
        let angle = found
            .camera_from_world
            .rotation
            .angle_to(&truth_pose.rotation)
            .to_degrees();
        let between = (found.center_in_world() - dlt.center_in_world()).norm();
        eprintln!(
            "{}: centre {centre:.4} mm, rotation {angle:.5} deg; csv vs DLTdv {between:.2e} mm",
            found.name
        );
        assert!(centre < 1.0 && angle < 0.05);
        assert!(between < 1e-6, "{between}");
    }
    assert_eq!(report["frames_used"], dlt_report["frames_used"]);
    for c in report["cameras"].as_array().unwrap() {
        assert!(c["reprojection_rms_px"].as_f64().unwrap() < 0.3, "{c}");
    }
    // Neither format: one line naming the file.
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "frame,u,v\n0,1,2\n").unwrap();
    let output = teachcam()
        .args(["calibrate", "wand", "--detections"])
        .arg(&bad)
        .arg("--cameras")
        .arg(&cameras_file)
        .arg("--wand")
        .arg(&wand)
        .arg("-o")
        .arg(dir.path().join("never.json"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("bad.csv") && stderr.contains("neither"),
        "{stderr}"
    );
    assert!(!dir.path().join("never.json").exists());
}
