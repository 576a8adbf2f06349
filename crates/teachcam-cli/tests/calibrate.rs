//! `teachcam calibrate`: exit codes, outputs written whole or not at all, on real photographs.

#![allow(
    clippy::unwrap_used,
    clippy::print_stderr,
    reason = "a test fails loudly on a broken fixture and says why it is skipped"
)]

use std::path::PathBuf;
use std::process::Command;

fn stereo_data() -> Option<PathBuf> {
    teachcam_testdata::shared_data("calib")
}

fn teachcam() -> Command {
    Command::new(env!("CARGO_BIN_EXE_teachcam"))
}

#[test]
fn intrinsics_writes_camera_json_and_yaml() {
    let Some(data) = stereo_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut images: Vec<PathBuf> = (1..=14)
        .filter(|k| *k != 10)
        .map(|k| data.join(format!("opencv-stereo-9x6/left{k:02}.jpg")))
        .collect();
    // A photograph from the stereo pair's other camera, mixed in by mistake, is named an
    // outlier (its RMS is 3.7x the median); one without a board is named and skipped.
    images.push(data.join("opencv-stereo-9x6/right02.jpg"));
    images.push(data.join("caliscope-4cam-chessboard-9x6/cam_0_frame_000.jpg"));
    for output in ["left.json", "left.yaml"] {
        let out = dir.path().join(output);
        let run = teachcam()
            .args([
                "calibrate",
                "intrinsics",
                "--pattern",
                "chessboard",
                "--inner",
                "9x6",
                "--square",
                "25",
            ])
            .args(&images)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            run.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&run.stderr)
        );
        assert!(
            stdout.contains("cam_0_frame_000.jpg: skipped: no complete 9x6 chessboard"),
            "{stdout}"
        );
        let outliers: Vec<&str> = stdout.lines().filter(|l| l.contains("(outlier)")).collect();
        assert_eq!(outliers.len(), 1, "{stdout}");
        assert!(outliers[0].starts_with("right02.jpg: rms"), "{stdout}");
        let camera = teachcam::io::camera_file::read_camera(&out).unwrap();
        // The bar against `cv2.calibrateCamera` on the 13 left images (536.07 px).
        assert!((camera.camera.intrinsics.fx / 536.07 - 1.0).abs() < 5e-3);
        assert_eq!(camera.camera.name, "left");
    }
}

#[test]
fn no_board_is_rejected_with_exit_1_and_no_file() {
    let Some(data) = stereo_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("camera.json");
    let run = teachcam()
        .args([
            "calibrate",
            "intrinsics",
            "--inner",
            "9x6",
            "--square",
            "25",
        ])
        .arg(data.join("caliscope-4cam-chessboard-9x6/cam_0_frame_000.jpg"))
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("no image shows a complete 9x6 chessboard"),
        "{stderr}"
    );
    assert!(!out.exists());
    // Two views only: too few, named as such.
    let run = teachcam()
        .args([
            "calibrate",
            "intrinsics",
            "--inner",
            "9x6",
            "--square",
            "25",
        ])
        .arg(data.join("opencv-stereo-9x6/left01.jpg"))
        .arg(data.join("opencv-stereo-9x6/left03.jpg"))
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("2 usable views, calibration needs at least 3"),
        "{stderr}"
    );
    assert!(!out.exists());
}

#[test]
fn bad_pattern_size_is_a_usage_error() {
    let run = teachcam()
        .args([
            "calibrate",
            "intrinsics",
            "--inner",
            "9by6",
            "--square",
            "25",
            "a.png",
            "-o",
            "c.json",
        ])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
}

/// The stereo pair as a two-camera rig, world = the left camera: the baseline of
/// `cv2.stereoCalibrate` (83.62 mm).
#[test]
fn rig_from_stereo_folders() {
    let Some(data) = stereo_data() else { return };
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("images");
    for (camera, prefix) in [("left", "left"), ("right", "right")] {
        std::fs::create_dir_all(images.join(camera)).unwrap();
        for k in (1..=14).filter(|k| *k != 10) {
            std::fs::copy(
                data.join(format!("opencv-stereo-9x6/{prefix}{k:02}.jpg")),
                images.join(camera).join(format!("{k:02}.jpg")),
            )
            .unwrap();
        }
    }
    let out = dir.path().join("rig.json");
    let run = teachcam()
        .args([
            "calibrate",
            "rig",
            "--inner",
            "9x6",
            "--square",
            "25",
            "--world-camera",
            "left",
        ])
        .arg(&images)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let rig = teachcam::io::rig::read_rig(&out).unwrap();
    let baseline = rig.cameras[1].camera_from_world.translation.vector.norm();
    eprintln!("{stdout}baseline {baseline:.4} mm");
    assert!((baseline / 83.6232 - 1.0).abs() < 0.01);
}

/// `--refine-intrinsics` (the default, kept for compatibility) and `--fix-intrinsics`
/// contradict each other: a usage error, before any image is read.
#[test]
fn refine_and_fix_intrinsics_together_are_a_usage_error() {
    let run = teachcam()
        .args([
            "calibrate",
            "rig",
            "--inner",
            "9x6",
            "--square",
            "25",
            "--world",
            "table",
            "--refine-intrinsics",
            "--fix-intrinsics",
            "no-such-folder",
            "-o",
            "rig.json",
        ])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("--fix-intrinsics"), "{stderr}");
}
