//! Regressions of the second bad-input campaign (`../shared/repro/R8_second_campaign`, issue
//! 30) that give no exit 0 any more: each a refusal naming the file and what was expected.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::path::Path;

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn simulate(out: &Path) {
    let done = teachcam(&[
        "simulate",
        "--scenario",
        "paper",
        "--frames",
        "10",
        "--seed",
        "8",
        "--out",
        out.to_str().unwrap(),
        "-q",
    ]);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
}

/// F8: `recording.json` of `[1000]` was read as 1000 fps, and an unknown key (`"units"`) was
/// ignored: both are refused (exit 1) naming the file, and nothing is written.
#[test]
fn a_recording_json_that_is_not_the_rate_object_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    simulate(&rec);
    for (text, says) in [
        ("[1000]", "expected an object"),
        (r#"{"fps": 30, "units": "m"}"#, "unknown field `units`"),
    ] {
        std::fs::write(rec.join("recording.json"), text).unwrap();
        let out = dir.path().join("t.csv");
        let done = teachcam(&[
            "track",
            rec.to_str().unwrap(),
            "--rig",
            rec.join("rig.json").to_str().unwrap(),
            "--tool",
            rec.join("tool.json").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let message = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.code(), Some(1), "{text}: {message}");
        assert!(
            message.contains("recording.json") && message.contains(says),
            "{text}: {message}"
        );
        assert!(!out.exists(), "{text}: nothing written");
    }
}

fn repro(name: &str) -> Option<std::path::PathBuf> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/repro/R8_second_campaign")
        .join(name);
    if path.exists() {
        return Some(path);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "{} is missing under CI",
        path.display()
    );
    eprintln!("skipped: {} is not there", path.display());
    None
}

/// F1: robot points in metres against camera points in millimetres, or a mirrored set, gave
/// exit 0 with a 75 mm / 50 mm fit and a `--wobj` to paste. Now a refusal naming the worst
/// point and what the points look like; no `--wobj` printed.
#[test]
fn align_refuses_a_unit_mix_up_and_a_mirror_image() {
    for (file, says) in [
        ("align_scaled_m.csv", "look like metres"),
        ("align_mirrored.csv", "mirror image"),
    ] {
        let Some(points) = repro(file) else {
            return;
        };
        let done = teachcam(&["align", points.to_str().unwrap()]);
        let message = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.code(), Some(1), "{file}: {message}");
        assert!(
            message.contains(file) && message.contains("worst point") && message.contains(says),
            "{file}: {message}"
        );
        assert!(
            !String::from_utf8_lossy(&done.stdout).contains("--wobj"),
            "{file}"
        );
    }
}

/// F2: `timestamps.csv` all equal, beyond double precision (1e18 + i/30), or in milliseconds
/// under a 30 fps `recording.json` gave exit 0 with times 0, 0, 0 or frame 1 at 33.3 s. Each
/// is refused naming the file, the camera and the frame.
#[test]
fn timestamps_that_do_not_increase_or_disagree_with_the_rate_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    simulate(&rec);
    let fps: f64 = {
        let info: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(rec.join("recording.json")).unwrap())
                .unwrap();
        info["fps"].as_f64().unwrap()
    };
    let written = |time: &dyn Fn(usize) -> f64| {
        let mut text = String::from("camera,frame,time_s\n");
        for camera in ["cam0", "cam1", "cam2"] {
            for i in 0..10 {
                text.push_str(&format!("{camera},{i},{}\n", time(i)));
            }
        }
        std::fs::write(rec.join("timestamps.csv"), text).unwrap();
    };
    let cases: [(&dyn Fn(usize) -> f64, &str); 3] = [
        (&|_| 0.0, "times must increase"),
        (
            &|i| 1e18 + i as f64 / 30.0,
            "beyond what double precision tells apart",
        ),
        (&|i| i as f64 * 1000.0 / fps, "look like milliseconds"),
    ];
    for (time, says) in cases {
        written(time);
        let out = dir.path().join("t.csv");
        let done = teachcam(&[
            "track",
            rec.to_str().unwrap(),
            "--rig",
            rec.join("rig.json").to_str().unwrap(),
            "--tool",
            rec.join("tool.json").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let message = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.code(), Some(1), "{says}: {message}");
        assert!(
            message.contains("timestamps.csv")
                && message.contains("cam0")
                && message.contains(says),
            "{says}: {message}"
        );
        assert!(!out.exists(), "{says}: nothing written");
    }
    // Times in seconds at the recording's rate are taken.
    written(&|i| i as f64 / fps);
    let done = teachcam(&[
        "track",
        rec.to_str().unwrap(),
        "--rig",
        rec.join("rig.json").to_str().unwrap(),
        "--tool",
        rec.join("tool.json").to_str().unwrap(),
        "-o",
        dir.path().join("ok.csv").to_str().unwrap(),
    ]);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
}
