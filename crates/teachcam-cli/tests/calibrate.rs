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

/// One line on stderr, exit 1, no output file: what a user's mistake in the inputs gets.
fn refused(args: &[&str], out: &std::path::Path) -> String {
    let run = teachcam().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert_eq!(run.status.code(), Some(1), "{args:?}: {stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
    assert!(!out.exists(), "{args:?} wrote {}", out.display());
    stderr
}

#[test]
fn missing_or_foreign_images_and_unknown_names_are_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("camera.json");
    let board = [
        "--pattern",
        "chessboard",
        "--inner",
        "9x6",
        "--square",
        "25",
    ];
    let nothere = dir.path().join("nothere.jpg");
    let mut args = vec!["calibrate", "intrinsics"];
    args.extend(board);
    args.extend([nothere.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let message = refused(&args, &out);
    assert!(
        message.contains("nothere.jpg: no such image file"),
        "{message}"
    );

    let csv = dir.path().join("corners.csv");
    std::fs::write(&csv, "x,y\n1,2\n").unwrap();
    let image = args.len() - 3;
    args[image] = csv.to_str().unwrap();
    let message = refused(&args, &out);
    assert!(
        message.contains("corners.csv: not an image") && message.contains(".png, .jpg or .jpeg"),
        "{message}"
    );

    // A rig folder: the names given must be in it, and the message lists what is.
    let boards = dir.path().join("boards");
    for camera in ["cam0", "cam1"] {
        std::fs::create_dir_all(boards.join(camera)).unwrap();
        for view in ["world", "v000"] {
            std::fs::write(boards.join(camera).join(format!("{view}.png")), b"").unwrap();
        }
    }
    let rig = dir.path().join("rig.json");
    let mut args = vec!["calibrate", "rig"];
    args.extend(board);
    args.extend([boards.to_str().unwrap(), "-o", rig.to_str().unwrap()]);
    let with = |extra: &[&str]| -> Vec<String> {
        args.iter().chain(extra).map(|s| (*s).to_string()).collect()
    };
    let run = |extra: &[&str]| {
        let owned = with(extra);
        let borrowed: Vec<&str> = owned.iter().map(String::as_str).collect();
        refused(&borrowed, &rig)
    };
    let message = run(&["--world", "table"]);
    assert!(
        message.contains("--world table") && message.contains("views: v000, world"),
        "{message}"
    );
    let message = run(&["--world", "world", "--intrinsics", "cam9=cam9.json"]);
    assert!(
        message.contains("--intrinsics cam9=cam9.json") && message.contains("cameras: cam0, cam1"),
        "{message}"
    );
    let message = run(&["--world-camera", "cam7"]);
    assert!(message.contains("--world-camera cam7"), "{message}");

    // Neither --world nor --world-camera: a usage error naming both.
    let owned = with(&[]);
    let borrowed: Vec<&str> = owned.iter().map(String::as_str).collect();
    let usage = teachcam().args(&borrowed).output().unwrap();
    let stderr = String::from_utf8_lossy(&usage.stderr);
    assert_eq!(usage.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--world") && stderr.contains("--world-camera"),
        "{stderr}"
    );
}

/// The CRC-32 of PNG chunks (ISO 3309, polynomial 0xEDB88320).
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[test]
fn an_image_too_large_to_decode_is_refused_from_its_header() {
    // A PNG whose header claims 20000x20000 gray pixels (400 MB decoded) and holds no pixels.
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(20_000u32.to_be_bytes());
    ihdr.extend(20_000u32.to_be_bytes());
    ihdr.extend([8, 0, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc32(&ihdr).to_be_bytes());
    // A first IDAT (an empty zlib stream): the decoder reads the header up to it.
    for (kind, data) in [
        (&b"IDAT"[..], &b"x\x9c\x03\x00\x00\x00\x00\x01"[..]),
        (b"IEND", b""),
    ] {
        let mut chunk = kind.to_vec();
        chunk.extend(data);
        png.extend(u32::try_from(data.len()).unwrap().to_be_bytes());
        png.extend(&chunk);
        png.extend(crc32(&chunk).to_be_bytes());
    }
    let dir = tempfile::tempdir().unwrap();
    let image = dir.path().join("huge.png");
    std::fs::write(&image, png).unwrap();
    let out = dir.path().join("camera.json");
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
            image.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(run.status.code(), Some(1), "{said}");
    assert!(
        said.contains("huge.png") && said.contains("20000x20000") && said.contains("megapixels"),
        "{said}"
    );
    assert!(!out.exists());
}
