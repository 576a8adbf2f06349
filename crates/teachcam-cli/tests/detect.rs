//! `teachcam detect` and `teachcam repeatability` end to end: outputs, exit codes, messages.

use std::path::Path;

use image::{GrayImage, Luma};

/// A frame with bright discs (pixel coverage by 8×8 supersampling) on a background of 12 to 14.
fn disc_frame(centres: &[(f64, f64, f64)], jitter: u32) -> GrayImage {
    GrayImage::from_fn(160, 120, |x, y| {
        let mut v = 12.0 + f64::from((x * 7 + y * 13 + jitter) % 3);
        for &(cx, cy, r) in centres {
            let mut inside = 0;
            for i in 0..8 {
                for j in 0..8 {
                    let sx = f64::from(x) - 0.5 + (f64::from(i) + 0.5) / 8.0;
                    let sy = f64::from(y) - 0.5 + (f64::from(j) + 0.5) / 8.0;
                    if (sx - cx).powi(2) + (sy - cy).powi(2) <= r * r {
                        inside += 1;
                    }
                }
            }
            v += 200.0 * f64::from(inside) / 64.0;
        }
        Luma([v.round().min(255.0) as u8])
    })
}

const CENTRES: [(f64, f64, f64); 2] = [(40.3, 50.6, 6.0), (110.8, 70.2, 8.0)];

fn recording(root: &Path, cameras: &[&str], frames: u32) {
    for camera in cameras {
        std::fs::create_dir_all(root.join(camera)).unwrap();
        for f in 0..frames {
            disc_frame(&CENTRES, f)
                .save(root.join(camera).join(format!("{f:06}.png")))
                .unwrap();
        }
    }
}

#[path = "support/run.rs"]
mod run;
use run::teachcam;

#[test]
fn detect_writes_the_contract_columns_for_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    recording(&rec, &["cam0", "cam1"], 3);
    let out = dir.path().join("detections.csv");
    let run = teachcam(&["detect", rec.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("camera,frame,x_px,y_px,radius_px,area_px,roundness,center_std_px,peak")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2 * 3 * 2);
    assert_eq!((rows[0][0], rows[0][1]), ("cam0", "0"));
    assert_eq!((rows[11][0], rows[11][1]), ("cam1", "2"));
    for row in &rows {
        let (x, y, r): (f64, f64, f64) = (
            row[2].parse().unwrap(),
            row[3].parse().unwrap(),
            row[4].parse().unwrap(),
        );
        let truth = CENTRES
            .iter()
            .find(|c| (c.0 - x).hypot(c.1 - y) < 0.1)
            .unwrap_or_else(|| panic!("no disc near {x} {y}"));
        assert!((r - truth.2).abs() < 0.2, "radius {r} vs {}", truth.2);
    }
    // The paper's centre method is selectable.
    let run = teachcam(&[
        "detect",
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--method",
        "smallest-circle",
    ]);
    assert!(run.status.success());
}

#[test]
fn a_truncated_png_is_refused_naming_camera_frame_and_file() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    recording(&rec, &["cam0"], 3);
    let victim = rec.join("cam0/000001.png");
    let bytes = std::fs::read(&victim).unwrap();
    std::fs::write(&victim, &bytes[..bytes.len() / 2]).unwrap();
    let out = dir.path().join("detections.csv");
    let run = teachcam(&["detect", rec.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("camera cam0, frame 1"), "{stderr}");
    assert!(stderr.contains("000001.png"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(!out.exists(), "no partial output");
}

#[test]
fn bad_arguments_and_folders_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.csv");
    let missing = dir.path().join("nothing");
    let run = teachcam(&[
        "detect",
        missing.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(1));
    let rec = dir.path().join("rec");
    recording(&rec, &["cam0"], 1);
    let run = teachcam(&[
        "detect",
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--min-roundness",
        "1.5",
    ]);
    // A flag value wrong on its own is a usage error (issue 15's one exit-code rule).
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("--min-roundness"));
    let run = teachcam(&[
        "detect",
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--method",
        "hough",
    ]);
    assert_eq!(run.status.code(), Some(2));
    // A rig without the recording's camera.
    let rig = dir.path().join("rig.json");
    std::fs::write(
        &rig,
        r#"{"units":"mm","cameras":[{"name":"camX","image_size":[160,120],"fx":500.0,"fy":500.0,"cx":79.5,"cy":59.5,"distortion":[0,0,0,0,0],"rotation":[[1,0,0],[0,1,0],[0,0,1]],"translation":[0,0,0]}]}"#,
    )
    .unwrap();
    let run = teachcam(&[
        "detect",
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--rig",
        rig.to_str().unwrap(),
        "--marker-diameter",
        "10",
    ]);
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("cam0") && stderr.contains("not in the rig"),
        "{stderr}"
    );
    assert!(!out.exists());
}

#[test]
fn repeatability_reports_each_static_marker_and_plots_it() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    recording(&rec, &["cam0"], 12);
    let out = dir.path().join("rep.csv");
    let svg = dir.path().join("rep.svg");
    let run = teachcam(&[
        "repeatability",
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 2, "{text}");
    assert!(
        rows.iter()
            .all(|r| r.starts_with("cam0,") && r.contains(",12,"))
    );
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.starts_with("<svg") && plot.trim_end().ends_with("</svg>"));
    // Two markers, measured and predicted each, plus the legend's dot.
    assert_eq!(plot.matches("<circle").count(), 2 * 2 + 1);
}
