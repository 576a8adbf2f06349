//! `teachcam c3d info` on a real file, compared with ezc3d's numbers
//! (`crates/teachcam/tests/data/c3d/*.json`), and its exit status on bad input.

use std::path::PathBuf;
use std::process::Command;

fn shared_c3d() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/c3d");
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but the test data folder {} is missing",
        dir.display()
    );
    println!("skipped: test data folder {} is missing", dir.display());
    None
}

fn reference(stem: &str) -> serde_json::Value {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../teachcam/tests/data/c3d")
        .join(format!("{stem}.json"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn info_prints_labels_rate_frames_units_and_first_frame() {
    let Some(dir) = shared_c3d() else { return };
    for stem in ["ktk_racing_probing_acromion_R", "c3dorg_sample01_Eb015pi"] {
        let out = Command::new(env!("CARGO_BIN_EXE_teachcam"))
            .args(["c3d", "info"])
            .arg(dir.join(format!("{stem}.c3d")))
            .output()
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let info: serde_json::Value =
            serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
        let want = reference(stem);
        assert_eq!(info["labels"], want["labels"], "{stem}");
        assert_eq!(info["rate_hz"], want["rate_hz"], "{stem}");
        assert_eq!(info["frames"], want["frames"], "{stem}");
        assert_eq!(info["units"], want["units"], "{stem}");
        let (got, want) = (&info["first_frame"], &want["first_frame"]);
        let (Some(got), Some(want)) = (got.as_array(), want.as_array()) else {
            panic!("{stem}: first_frame is not an array");
        };
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            if w.is_null() {
                assert!(g.is_null(), "{stem}: {g} where ezc3d has a gap");
                continue;
            }
            for axis in 0..3 {
                let (g, w) = (g[axis].as_f64(), w[axis].as_f64());
                let (Some(g), Some(w)) = (g, w) else {
                    panic!("{stem}: {g:?} vs {w:?}")
                };
                assert!(
                    (g - w).abs() <= 1e-6 * w.abs().max(1.0),
                    "{stem}: {g} vs {w}"
                );
            }
        }
    }
}

#[test]
fn info_rejects_a_truncated_file_with_exit_status_1() {
    let Some(dir) = shared_c3d() else { return };
    let bytes = std::fs::read(dir.join("ezc3d_Optotrak.c3d")).unwrap_or_else(|e| panic!("{e}"));
    let temp = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let cut = temp.path().join("cut.c3d");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap_or_else(|e| panic!("{e}"));
    let out = Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(["c3d", "info"])
        .arg(&cut)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("cut.c3d") && stderr.contains("truncated"),
        "{stderr}"
    );
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
}

/// The Optotrak probe through the CLI: tool from data, trajectory, then back out as C3D.
#[test]
fn import_probe_then_export_c3d() {
    let Some(dir) = shared_c3d() else { return };
    let temp = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (tool, traj, out) = (
        temp.path().join("probe.json"),
        temp.path().join("traj.csv"),
        temp.path().join("probe.c3d"),
    );
    let status = Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(["import", "c3d"])
        .arg(dir.join("ktk_racing_probing_olecrane_R.c3d"))
        .args([
            "--markers",
            "Probe1,Probe2,Probe3,Probe4,Probe5,Probe6",
            "--tool-out",
        ])
        .arg(&tool)
        .arg("-o")
        .arg(&traj)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let text = std::fs::read_to_string(&traj).unwrap_or_else(|e| panic!("{e}"));
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 140);
    for row in &rows {
        let rms: f64 = row[13].parse().unwrap_or(f64::NAN);
        assert!(rms < 0.5, "sub-millimetre registration: {row:?}");
        assert_eq!(row[12], "6");
    }
    // The first marker is the tool origin: its exported position is the trajectory's.
    let out_status = Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(["c3d", "export"])
        .arg(&traj)
        .arg("--tool")
        .arg(&tool)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        out_status.status.success(),
        "{}",
        String::from_utf8_lossy(&out_status.stderr)
    );
    let info = Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(["c3d", "info"])
        .arg(&out)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    let info: serde_json::Value =
        serde_json::from_slice(&info.stdout).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(info["frames"], 140);
    assert_eq!(info["rate_hz"], 69.5);
    assert_eq!(info["labels"][6], "ktk_racing_probing_olecrane_R:tip");
    for axis in 0..3 {
        let exported = info["first_frame"][0][axis].as_f64().unwrap_or(f64::NAN);
        let tracked: f64 = rows[0][2 + axis].parse().unwrap_or(f64::NAN);
        // float32 storage of ~1000 mm: 6e-5 mm; the CSV prints 1e-6 mm.
        assert!((exported - tracked).abs() < 1e-4, "{exported} vs {tracked}");
    }
}

#[test]
fn import_refuses_unknown_labels_with_exit_status_1() {
    let Some(dir) = shared_c3d() else { return };
    let temp = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let out = Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(["import", "c3d"])
        .arg(dir.join("ktk_racing_probing_olecrane_R.c3d"))
        .args(["--markers", "Probe1,Probe2,Nope"])
        .arg("-o")
        .arg(temp.path().join("t.csv"))
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("no marker labelled \"Nope\""), "{stderr}");
    assert!(!temp.path().join("t.csv").exists(), "no partial output");
}

/// The probe's trajectory becomes a RAPID program. The Optotrak lab frame is far from an
/// IRB 120, so the work object places the first probe pose at (350, 0, 300) mm in the base
/// frame, tool z pointing down: `base_from_wobj = target * world_from_tool(frame 0)⁻¹`,
/// computed with scipy from the trajectory's first row (the probe barely moves in the trial).
#[test]
fn probe_trajectory_exports_to_rapid() {
    let Some(dir) = shared_c3d() else { return };
    let temp = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (traj, program) = (temp.path().join("traj.csv"), temp.path().join("probe.mod"));
    let run = |args: &[&std::ffi::OsStr]| {
        let out = Command::new(env!("CARGO_BIN_EXE_teachcam"))
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let file = dir.join("ktk_racing_probing_acromion_R.c3d");
    run(&[
        "import".as_ref(),
        "c3d".as_ref(),
        file.as_os_str(),
        "--markers".as_ref(),
        "Probe1,Probe2,Probe3,Probe4,Probe5,Probe6".as_ref(),
        "-o".as_ref(),
        traj.as_os_str(),
    ]);
    run(&[
        "export".as_ref(),
        "rapid".as_ref(),
        traj.as_os_str(),
        "--wobj".as_ref(),
        "-679.866,202.499,-630.479,0.523850483,0.560218429,0.414935909,-0.489452933".as_ref(),
        "-o".as_ref(),
        program.as_os_str(),
    ]);
    let text = std::fs::read_to_string(&program).unwrap_or_else(|e| panic!("{e}"));
    assert!(text.starts_with("MODULE"), "{text}");
    assert!(text.contains("MoveL p0002"), "{text}");
}
