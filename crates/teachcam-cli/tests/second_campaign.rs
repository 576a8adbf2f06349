//! Regressions of the second bad-input campaign (`../shared/repro/R8_second_campaign`, issue
//! 30) that give no exit 0 any more: each a refusal naming the file and what was expected.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::path::{Path, PathBuf};

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn simulate(out: &Path) {
    simulate_frames(out, 10);
}

fn simulate_frames(out: &Path, frames: usize) {
    let frames = frames.to_string();
    let done = teachcam(&[
        "simulate",
        "--scenario",
        "paper",
        "--frames",
        &frames,
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

fn repro(name: &str) -> Option<PathBuf> {
    teachcam_testdata::shared_repro("R8_second_campaign").map(|dir| dir.join(name))
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

/// F2: `timestamps.csv` all equal, beyond double precision (1e18 + i/30, 1e12 + i/30), or in milliseconds
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
    let cases: [(&dyn Fn(usize) -> f64, &str); 4] = [
        (&|_| 0.0, "times must increase"),
        (
            &|i| 1e18 + i as f64 / 30.0,
            "beyond what double precision tells apart",
        ),
        // Increasing, but rounded to 0.12 ms: over a thousandth of a frame step.
        (
            &|i| 1e12 + i as f64 / 30.0,
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

/// The repro's cell: the IRB 120 and UR5e reach `straight.csv` with it.
const CELL: [&str; 4] = ["--wobj", "350,0,100,1,0,0,0", "--tcp", "0,0,200,0,1,0,0"];

/// `teachcam export DIALECT straight.csv --robot ROBOT CELL extra... -o dir/output`.
fn export(
    dir: &Path,
    dialect: &str,
    robot: &str,
    output: &str,
    extra: &[&str],
) -> Option<std::process::Output> {
    let straight = repro("straight.csv")?;
    let out = dir.join(output);
    let mut args = vec![
        "export",
        dialect,
        straight.to_str().unwrap(),
        "--robot",
        robot,
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend(CELL);
    args.extend(extra);
    Some(teachcam(&args))
}

/// F4: `--tool-mass 1e9` on the IRB 120 (rated 3 kg) and 50 on the UR5e (5 kg) were written
/// into the program. Both are refused (exit 1) in one line naming the robot, the mass given
/// and the rated one; nothing is written. A mass within the rating is written.
#[test]
fn a_payload_over_the_robots_rating_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (dialect, robot, mass, given, rated, output) in [
        ("rapid", "irb120", "1e9", "1000000000", "3 kg", "m.mod"),
        ("urscript", "ur5e", "50", "50", "5 kg", "m.script"),
    ] {
        let Some(done) = export(dir.path(), dialect, robot, output, &["--tool-mass", mass]) else {
            return;
        };
        let message = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.code(), Some(1), "{robot}: {message}");
        assert!(
            message.contains(robot) && message.contains(given) && message.contains(rated),
            "{robot}: {message}"
        );
        assert_eq!(message.trim().lines().count(), 1, "{message}");
        assert!(
            !dir.path().join(output).exists(),
            "{robot}: nothing written"
        );
    }
    let done = export(
        dir.path(),
        "rapid",
        "irb120",
        "ok.mod",
        &["--tool-mass", "2.5"],
    )
    .unwrap();
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let module = std::fs::read_to_string(dir.path().join("ok.mod")).unwrap();
    assert!(module.contains("[TRUE,[[0.000,0.000,200.000]"), "{module}");
    assert!(module.contains("[2.500,"), "{module}");
}

/// F7: `-o MODULE.mod` wrote `MODULE MODULE` (a RAPID reserved word) and `-o def.script`
/// `def def():`. From a file name the program is now prefixed `tc_` (said on stderr); the
/// same word given with `--name` is refused (exit 2). KRL keeps its file's name, so a keyword
/// is refused; and every dialect needs its extension (`-o p` for KRL was taken).
#[test]
fn reserved_program_names_and_missing_extensions_are_refused_or_prefixed() {
    let dir = tempfile::tempdir().unwrap();
    for (dialect, robot, output, first_line) in [
        ("rapid", "irb120", "MODULE.mod", "MODULE tc_MODULE"),
        ("rapid", "irb120", "main.modx", "MODULE tc_main"),
        ("urscript", "ur5e", "def.script", "def tc_def():"),
        ("urscript", "ur5e", "movel.script", "def tc_movel():"),
    ] {
        let Some(done) = export(dir.path(), dialect, robot, output, &[]) else {
            return;
        };
        let message = String::from_utf8_lossy(&done.stderr);
        assert!(done.status.success(), "{output}: {message}");
        assert!(message.contains("tc_"), "{output}: {message}");
        let text = std::fs::read_to_string(dir.path().join(output)).unwrap();
        assert_eq!(text.lines().next(), Some(first_line), "{output}");
    }
    for (dialect, robot, output, extra, says) in [
        (
            "rapid",
            "irb120",
            "a.mod",
            vec!["--name", "PROC"],
            "reserved",
        ),
        (
            "urscript",
            "ur5e",
            "a.script",
            vec!["--name", "while"],
            "keyword",
        ),
        ("krl", "kr6-r700", "loop.src", vec![], "keyword"),
        ("krl", "kr6-r700", "p", vec![], ".src"),
        ("rapid", "irb120", "p", vec![], ".mod or .modx"),
        ("rapid", "irb120", "p.txt", vec![], ".mod or .modx"),
        ("urscript", "ur5e", "p.py", vec![], ".script"),
    ] {
        let Some(done) = export(dir.path(), dialect, robot, output, &extra) else {
            return;
        };
        let message = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.code(), Some(2), "{output}: {message}");
        assert!(message.contains(says), "{output}: {message}");
        assert!(!dir.path().join(output).exists(), "{output}");
    }
}

fn track(rec: &Path, rig: &Path, tool: &Path, out: &Path) -> std::process::Output {
    teachcam(&[
        "track",
        rec.to_str().unwrap(),
        "--rig",
        rig.to_str().unwrap(),
        "--tool",
        tool.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ])
}

fn fps_of(rec: &Path) -> f64 {
    let info: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(rec.join("recording.json")).unwrap())
            .unwrap();
    info["fps"].as_f64().unwrap()
}

/// F2: cam1's times half a period late gave 54 rows for a 40-frame recording, the frame
/// numbers no longer the recording's indices. Frame i of every camera stays row i (0-based,
/// CONTRACT), and the offset is said.
#[test]
fn a_camera_stamped_half_a_period_late_keeps_the_recording_indices_and_is_said() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    simulate_frames(&rec, 40);
    let fps = fps_of(&rec);
    let mut text = String::from("camera,frame,time_s\n");
    for camera in ["cam0", "cam1", "cam2"] {
        let late = if camera == "cam1" { 0.5 } else { 0.0 };
        for i in 0..40 {
            text.push_str(&format!("{camera},{i},{}\n", (i as f64 + late) / fps));
        }
    }
    std::fs::write(rec.join("timestamps.csv"), text).unwrap();
    let out = dir.path().join("t.csv");
    let done = track(&rec, &rec.join("rig.json"), &rec.join("tool.json"), &out);
    let message = String::from_utf8_lossy(&done.stderr);
    assert!(done.status.success(), "{message}");
    let said = format!("{:+.3} ms", 500.0 / fps);
    assert!(
        message.contains("timestamps.csv") && message.contains("cam1") && message.contains(&said),
        "{said}: {message}"
    );
    let written = teachcam::io::trajectory::read_trajectory(&out).unwrap();
    let frames: Vec<usize> = written.samples.iter().map(|s| s.frame.0).collect();
    assert_eq!(frames, (0..40).collect::<Vec<_>>(), "{message}");
}

/// A change made to one camera of a rig file.
type Edit<'a> = dyn Fn(&mut serde_json::Value) + 'a;

/// F5: a rig camera whose calibration cannot see the volume (fx 1e300, k1 1e6, or placed on
/// another camera; cx 1e7 is `conductor_cli`'s) was dropped without a word. `track` names it
/// with the blobs it saw, no frame is `ok`, and `doctor` points at its calibration.
#[test]
fn a_camera_whose_calibration_sees_nothing_is_named_flagged_and_doctored() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    simulate_frames(&rec, 40);
    let rig: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(rec.join("rig.json")).unwrap()).unwrap();
    let cam0 = rig["cameras"][0].clone();
    let cases: [(&str, &Edit<'_>); 3] = [
        ("fx", &|c| {
            c["fx"] = 1e300.into();
            c["fy"] = 1e300.into();
        }),
        ("k1", &|c| c["distortion"][0] = 1e6.into()),
        ("on cam0", &|c| {
            c["rotation"] = cam0["rotation"].clone();
            c["translation"] = cam0["translation"].clone();
        }),
    ];
    for (case, change) in cases {
        let mut bad = rig.clone();
        change(&mut bad["cameras"][1]);
        let path = dir.path().join("rig_bad.json");
        std::fs::write(&path, bad.to_string()).unwrap();
        let out = dir.path().join("t.csv");
        let done = track(&rec, &path, &rec.join("tool.json"), &out);
        let message = String::from_utf8_lossy(&done.stderr);
        assert!(done.status.success(), "{case}: {message}");
        assert!(
            message.contains("camera cam1 sees nothing of the volume") && message.contains("blobs"),
            "{case}: {message}"
        );
        let written = teachcam::io::trajectory::read_trajectory(&out).unwrap();
        assert!(
            written.samples.iter().filter(|s| s.pose.is_some()).count() >= 30
                && written
                    .samples
                    .iter()
                    .all(|s| s.status != teachcam::trajectory::Status::Ok),
            "{case}: a frame without cam1 is ok"
        );
        let doctor = teachcam(&[
            "doctor",
            rec.to_str().unwrap(),
            "--rig",
            path.to_str().unwrap(),
            "--tool",
            rec.join("tool.json").to_str().unwrap(),
        ]);
        let report = format!(
            "{}{}",
            String::from_utf8_lossy(&doctor.stdout),
            String::from_utf8_lossy(&doctor.stderr)
        );
        assert!(
            report.contains("camera cam1 sees nothing of the volume")
                && report.contains("check its calibration"),
            "{case}: {report}"
        );
    }
}

/// F6: a tip in metres beside markers in millimetres lies inside marker 0's sphere and was
/// accepted: refused naming the file and the marker, nothing written.
#[test]
fn a_tip_inside_a_marker_sphere_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    simulate(&rec);
    let mut tool: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(rec.join("tool.json")).unwrap()).unwrap();
    let tip: Vec<f64> = tool["tip"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() / 1000.0)
        .collect();
    tool["tip"] = tip.into();
    let path = dir.path().join("tool_m.json");
    std::fs::write(&path, tool.to_string()).unwrap();
    let out = dir.path().join("t.csv");
    let done = track(&rec, &rec.join("rig.json"), &path, &out);
    let message = String::from_utf8_lossy(&done.stderr);
    assert_eq!(done.status.code(), Some(1), "{message}");
    assert!(
        message.contains("tool_m.json") && message.contains("inside marker 0's sphere"),
        "{message}"
    );
    assert_eq!(message.trim().lines().count(), 1, "{message}");
    assert!(!out.exists(), "nothing written");
}
