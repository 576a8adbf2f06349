//! `teachcam track --time-offsets`: the simulator's `unsynced` recording timed and tracked
//! through files, the offsets written and read back, and the refusals.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::collections::BTreeMap;
use std::path::Path;

use teachcam::io::trajectory::read_trajectory;

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn simulate(scenario: &str, out: &Path, frames: usize) {
    let frames = frames.to_string();
    let status = teachcam(&[
        "simulate",
        "--scenario",
        scenario,
        "--out",
        out.to_str().unwrap(),
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

fn track(rec: &Path, out: &str, extra: &[&str]) -> std::process::Output {
    let rig = rec.join("rig.json");
    let tool = rec.join("tool.json");
    let out = rec.join(out);
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

fn offsets(path: &Path) -> BTreeMap<String, f64> {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// RMS tip error against `truth.csv` and frames posed.
fn tip_rms(rec: &Path, out: &str) -> (f64, usize) {
    let truth = read_trajectory(&rec.join("truth.csv")).unwrap();
    let measured = read_trajectory(&rec.join(out)).unwrap();
    let errors: Vec<f64> = truth
        .samples
        .iter()
        .zip(&measured.samples)
        .filter_map(|(t, m)| Some((t.pose?.tip_in_world - m.pose?.tip_in_world).norm()))
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    (rms, errors.len())
}

#[test]
fn track_times_the_unsynced_recording_and_reads_its_own_offsets_back() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    simulate("unsynced", &rec, 60);
    let out_json = rec.join("found.json");
    let run = track(
        &rec,
        "auto.csv",
        &[
            "--time-offsets",
            "auto",
            "--time-offsets-out",
            out_json.to_str().unwrap(),
            "--diagnostics",
            rec.join("diag.csv").to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    println!("{stderr}");
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("time offsets on cam0's clock"), "{stderr}");
    let truth = offsets(&rec.join("time_offsets.json"));
    let found = offsets(&out_json);
    assert_eq!(
        found.keys().collect::<Vec<_>>(),
        truth.keys().collect::<Vec<_>>()
    );
    for (camera, t) in &truth {
        // The acceptance's tolerance; the library tests check the σ.
        assert!(
            (found[camera] - t).abs() < 1e-3,
            "{camera}: {} vs {t}",
            found[camera]
        );
    }
    let (auto_rms, auto_count) = tip_rms(&rec, "auto.csv");
    let plain = track(&rec, "plain.csv", &[]);
    assert!(plain.status.success());
    let (plain_rms, plain_count) = tip_rms(&rec, "plain.csv");
    println!(
        "tip RMS: corrected {auto_rms:.4} mm ({auto_count} frames), uncorrected {plain_rms:.4} mm ({plain_count})"
    );
    // Synchronised, this scene tracks at 0.0144 mm (library test `sync_render`): twice that.
    assert!(auto_rms <= 2.0 * 0.0144, "{auto_rms}");
    assert!(auto_count + 4 >= 60);
    let diagnostics = std::fs::read_to_string(rec.join("diag.csv")).unwrap();
    assert!(diagnostics.lines().next().unwrap().ends_with(",resampling"));
    assert!(diagnostics.contains("degraded"), "track ends are reported");
    // The written file is a valid --time-offsets value and gives the same trajectory.
    let again = track(
        &rec,
        "again.csv",
        &["--time-offsets", out_json.to_str().unwrap()],
    );
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_eq!(tip_rms(&rec, "again.csv"), (auto_rms, auto_count));
}

#[test]
fn a_static_tool_and_bad_offsets_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    simulate("static", &rec, 40);
    let run = track(&rec, "raw.csv", &["--time-offsets", "auto"]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("static"), "{stderr}");
    assert!(!rec.join("raw.csv").exists(), "nothing written");
    for bad in ["cam9=0.01", "cam1=fast", "cam1"] {
        let run = track(&rec, "raw.csv", &["--time-offsets", bad]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{bad}: {stderr}");
        assert!(stderr.contains("--time-offsets"), "{stderr}");
    }
    let run = track(&rec, "raw.csv", &["--time-offsets-out", "x.json"]);
    assert_eq!(
        run.status.code(),
        Some(2),
        "--time-offsets-out needs --time-offsets"
    );
}
