//! The user's path through files: `teachcam simulate`, then `teachcam track` on the PNG
//! recording, compared with the simulator's `truth.csv`; and the inputs a user can get wrong.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::path::Path;

use teachcam::io::trajectory::read_trajectory;

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn simulate(scenario: &str, out: &Path, frames: usize) {
    let frames = frames.to_string();
    let out = out.to_str().unwrap();
    let status = teachcam(&[
        "simulate",
        "--scenario",
        scenario,
        "--out",
        out,
        "--seed",
        "4",
        "--frames",
        &frames,
    ]);
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
}

fn track(rec: &Path, extra: &[&str]) -> std::process::Output {
    let rig = rec.join("rig.json");
    let tool = rec.join("tool.json");
    let out = rec.join("raw.csv");
    let mut args = vec![
        "track",
        rec.to_str().unwrap(),
        "--rig",
        rig.to_str().unwrap(),
        "--tool",
        tool.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    teachcam(&args)
}

/// Tip errors of every frame against the truth (`None` where the frame has no pose).
fn tip_errors(rec: &Path) -> Vec<Option<f64>> {
    let truth = read_trajectory(&rec.join("truth.csv")).unwrap();
    let raw = read_trajectory(&rec.join("raw.csv")).unwrap();
    truth
        .samples
        .iter()
        .zip(&raw.samples)
        .map(|(t, r)| Some((t.pose?.tip_in_world - r.pose?.tip_in_world).norm()))
        .collect()
}

fn rms(errors: &[f64]) -> f64 {
    (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt()
}

#[test]
fn paper_and_occluded_recordings_are_tracked_within_twice_the_noise_models_error() {
    // Bounds from the noise model, about twice what it gives: over seeds 4, 5, 6 (60 frames,
    // this binary, 2026-12-06) the tip RMS was 0.0162–0.0171 mm on the paper and 0.0174–
    // 0.0181 mm occluded, the worst frame 0.032–0.038 mm (notes/second-campaign.md); the
    // issues' acceptance bars were 0.10 / 0.15 mm RMS and 1 mm worst, which a 5× regression
    // passed.
    for (scenario, limit_mm) in [("paper", 0.035), ("occluded", 0.036)] {
        let dir = tempfile::tempdir().unwrap();
        // 60 of the 120 frames hold all but the last occlusion event of `occluded`.
        simulate(scenario, dir.path(), 60);
        let out = track(
            dir.path(),
            &[
                "--diagnostics",
                dir.path().join("diag.csv").to_str().unwrap(),
            ],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let frames = read_trajectory(&dir.path().join("raw.csv")).unwrap().len();
        assert_eq!(
            frames,
            read_trajectory(&dir.path().join("truth.csv"))
                .unwrap()
                .len(),
            "one row per frame"
        );
        let errors: Vec<f64> = tip_errors(dir.path())
            .into_iter()
            .map(|e| e.expect("every frame has a pose"))
            .collect();
        let (rms_mm, worst) = (rms(&errors), errors.iter().copied().fold(0.0, f64::max));
        // The per-frame uncertainty must tell the size of the error: its RMS over the frames
        // against the actual RMS error. Triangulation residuals, which set its scale, cannot
        // see an error along the epipolar lines, so it may fall a little short (measured 0.87–
        // 0.93 on the paper, occluded and four-camera scenes); from the blobs' noise alone it
        // was 0.33.
        let predicted: Vec<f64> = read_trajectory(&dir.path().join("raw.csv"))
            .unwrap()
            .samples
            .iter()
            .map(|s| s.tip_std_mm.expect("every frame has a tip_std_mm"))
            .collect();
        let told = rms(&predicted) / rms_mm;
        println!(
            "{scenario}: {} frames, tip RMS {rms_mm:.4} mm, worst {worst:.4} mm, tip_std_mm RMS {:.4} mm ({told:.2} of the error)",
            errors.len(),
            rms(&predicted)
        );
        assert!(rms_mm <= limit_mm, "{scenario}: tip RMS {rms_mm} mm");
        // The painter's real motion never trips the temporal guard.
        let diagnostics = std::fs::read_to_string(dir.path().join("diag.csv")).unwrap();
        assert!(
            !diagnostics.contains("neighbours' path"),
            "{scenario}: real motion flagged as a jump:\n{diagnostics}"
        );
        assert!(worst < 0.08, "{scenario}: a wrong pose ({worst} mm)");
        assert!(
            (0.75..1.33).contains(&told),
            "{scenario}: tip_std_mm is {told} of the error"
        );
    }
}

#[test]
fn bad_inputs_are_refused_with_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path();
    simulate("static", rec, 5);
    assert!(track(rec, &[]).status.success());

    // A tool with two markers.
    std::fs::write(
        rec.join("tool2.json"),
        r#"{"name": "b", "marker_diameter_mm": 10, "markers": [[0,0,0],[50,0,0]], "tip": [0,0,0]}"#,
    )
    .unwrap();
    let out = teachcam(&[
        "track",
        rec.to_str().unwrap(),
        "--rig",
        rec.join("rig.json").to_str().unwrap(),
        "--tool",
        rec.join("tool2.json").to_str().unwrap(),
        "-o",
        rec.join("x.csv").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("at least 3"));
    assert!(!rec.join("x.csv").exists(), "no output written");

    // The rig says another image size.
    let rig = std::fs::read_to_string(rec.join("rig.json")).unwrap();
    std::fs::write(rec.join("rig.json"), rig.replacen("1280", "1920", 1)).unwrap();
    let out = track(rec, &[]);
    assert_eq!(out.status.code(), Some(1));
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(
        message.contains("1280x1024") && message.contains("1920x1024") && message.contains("cam0"),
        "{message}"
    );
    std::fs::write(rec.join("rig.json"), &rig).unwrap();

    // A rig camera without a sub-folder (unplugged): tracked with the cameras left, the camera
    // named, and no frame `ok` (issue 29: a missing camera is not a refusal).
    std::fs::rename(rec.join("cam2"), rec.join("side")).unwrap();
    let out = track(rec, &[]);
    let message = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{message}");
    assert!(
        message.contains("camera cam2 has no frames in the recording"),
        "{message}"
    );
    let written = read_trajectory(&rec.join("raw.csv")).unwrap();
    assert!(
        written.samples.iter().any(|s| s.pose.is_some())
            && written
                .samples
                .iter()
                .all(|s| s.status != teachcam::trajectory::Status::Ok),
        "{:?}",
        written.samples.iter().map(|s| s.status).collect::<Vec<_>>()
    );
    std::fs::rename(rec.join("side"), rec.join("cam2")).unwrap();

    // Frames where nothing is visible stay as explicit gaps.
    let black = image::GrayImage::new(1280, 1024);
    for camera in ["cam0", "cam1", "cam2"] {
        black.save(rec.join(camera).join("000002.png")).unwrap();
    }
    let out = track(
        rec,
        &["--diagnostics", rec.join("diag.csv").to_str().unwrap()],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let errors = tip_errors(rec);
    assert_eq!(errors.len(), 5);
    assert!(
        errors[2].is_none()
            && errors
                .iter()
                .enumerate()
                .all(|(i, e)| i == 2 || e.is_some())
    );
    let diagnostics = std::fs::read_to_string(rec.join("diag.csv")).unwrap();
    assert!(
        diagnostics
            .lines()
            .nth(3)
            .unwrap()
            .starts_with("2,lost,0 markers identified"),
        "{diagnostics}"
    );
}

/// Issue 19: `track --detections` tracks `detect`'s blobs, so a recording tracked from its
/// images and from its `detections.csv` gives the same trajectory and diagnostics, byte for
/// byte; a file naming a camera the rig lacks, or a frame past the recording, is refused.
#[test]
fn tracking_detect_output_gives_the_trajectory_of_the_images() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    simulate("occluded", &rec, 30);
    let file = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (rig, tool) = (rec.join("rig.json"), rec.join("tool.json"));
    let (rig, tool) = (rig.to_str().unwrap(), tool.to_str().unwrap());
    let r = rec.to_str().unwrap();
    let from_images = teachcam(&[
        "track",
        r,
        "--rig",
        rig,
        "--tool",
        tool,
        "-o",
        &file("images.csv"),
        "--diagnostics",
        &file("images-diag.csv"),
    ]);
    assert!(
        from_images.status.success(),
        "{}",
        String::from_utf8_lossy(&from_images.stderr)
    );
    let detect = teachcam(&[
        "detect",
        r,
        "--rig",
        rig,
        "--tool",
        tool,
        "-o",
        &file("d.csv"),
    ]);
    assert!(
        detect.status.success(),
        "{}",
        String::from_utf8_lossy(&detect.stderr)
    );
    // `track --detections d.csv`, with `first` before it and `rest` after its output.
    let detections_file = file("d.csv");
    let track_detections = |first: &[&str], output: &str, rest: &[&str]| {
        let mut args = first.to_vec();
        args.extend([
            "track",
            r,
            "--detections",
            &detections_file,
            "--rig",
            rig,
            "--tool",
            tool,
            "-o",
            output,
        ]);
        args.extend(rest);
        teachcam(&args)
    };
    let from_detections = track_detections(
        &[],
        &file("detections.csv"),
        &["--diagnostics", &file("detections-diag.csv")],
    );
    assert!(
        from_detections.status.success(),
        "{}",
        String::from_utf8_lossy(&from_detections.stderr)
    );
    // --quiet: nothing on stderr, not even the gates.
    let quiet = track_detections(&["--quiet"], &file("quiet.csv"), &[]);
    assert!(quiet.status.success() && quiet.stdout.is_empty());
    assert!(
        quiet.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&quiet.stderr)
    );
    let read = |name: &str| std::fs::read_to_string(file(name)).unwrap();
    assert_eq!(read("quiet.csv"), read("detections.csv"));
    // The gates: one line by default (issue 32), the table with a reason per gate behind
    // --verbose; the gates file is written either way.
    let gates_lines = |stderr: &[u8]| {
        String::from_utf8_lossy(stderr)
            .lines()
            .filter(|l| l.contains("registration"))
            .count()
    };
    let images_stderr = String::from_utf8_lossy(&from_images.stderr);
    assert_eq!(gates_lines(&from_images.stderr), 1, "{images_stderr}");
    assert!(images_stderr.contains("--verbose"), "{images_stderr}");
    assert!(
        !images_stderr.contains("triangulation residual"),
        "{images_stderr}"
    );
    let verbose = track_detections(&[], &file("verbose.csv"), &["--verbose"]);
    let verbose_stderr = String::from_utf8_lossy(&verbose.stderr);
    assert!(verbose.status.success(), "{verbose_stderr}");
    for row in [
        "triangulation residual",
        "registration residual",
        "tip step per frame",
    ] {
        assert!(verbose_stderr.contains(row), "{verbose_stderr} lacks {row}");
    }
    assert!(std::path::Path::new(&file("images-diag.gates.json")).is_file());
    assert_eq!(read("images.csv").lines().count(), 31);
    assert_eq!(read("images.csv"), read("detections.csv"));
    assert_eq!(read("images-diag.csv"), read("detections-diag.csv"));

    let detections = read("d.csv");
    for (name, text, words) in [
        (
            "stranger.csv",
            detections.replacen("\ncam1,", "\ncam7,", 1),
            &[
                "stranger.csv",
                "camera cam7 is not in the rig",
                "cam0, cam1, cam2",
            ][..],
        ),
        (
            "beyond.csv",
            format!("{detections}cam0,30,100,100,4,50,1,0.01,200\n"),
            &[
                "beyond.csv",
                "cam0 frame 30 is beyond the recording",
                "30 frames",
            ][..],
        ),
    ] {
        std::fs::write(file(name), text).unwrap();
        let o = teachcam(&[
            "track",
            r,
            "--detections",
            &file(name),
            "--rig",
            rig,
            "--tool",
            tool,
            "-o",
            &file("refused.csv"),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        for word in words {
            assert!(stderr.contains(word), "{stderr} lacks {word}");
        }
        assert!(!Path::new(&file("refused.csv")).exists());
    }
}
