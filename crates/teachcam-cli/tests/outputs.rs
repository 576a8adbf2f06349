//! Output sets all or nothing, output paths checked before any work, Ctrl-C (issue 15, R7).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use nalgebra::{UnitQuaternion, Vector3};
use teachcam::geometry::{FrameIndex, Point3, pose_from_parts};
use teachcam::io::trajectory::write_trajectory;
use teachcam::trajectory::{Sample, ToolPose, Trajectory};

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The names in a folder, sorted.
fn names(folder: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A slow stroke of `frames` frames at 100 Hz, the tip 5 mm over the work surface (the world's
/// xy-plane), reachable by the IRB 120 with the demo's cell.
fn write_stroke(path: &Path, frames: usize) {
    let tip_in_tool = Point3::new(0.0, 0.0, -150.0);
    let samples = (0..frames)
        .map(|i| {
            let t = i as f64 / 100.0;
            let world_from_tool = pose_from_parts(
                Vector3::new(20.0 * (0.5 * t).sin(), 10.0 * (0.3 * t).cos(), 155.0),
                UnitQuaternion::identity(),
            );
            Sample::measured(
                FrameIndex(i),
                t,
                ToolPose {
                    world_from_tool,
                    tip_in_world: world_from_tool * tip_in_tool,
                    markers: 4,
                    rms_mm: 0.01,
                },
            )
        })
        .collect();
    write_trajectory(path, &Trajectory { samples }).unwrap();
}

/// A 3-frame simulated recording of the paper's scene.
fn simulate(dir: &Path) -> PathBuf {
    let rec = dir.join("rec");
    let o = teachcam(&["simulate", "--frames", "3", "--out", s(&rec)]);
    assert!(o.status.success(), "{}", stderr(&o));
    rec
}

#[test]
fn track_writes_its_four_files_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let rec = simulate(dir.path());
    let (rig, tool) = (rec.join("rig.json"), rec.join("tool.json"));
    let out = dir.path().join("out.csv");
    let markers = dir.path().join("markers.csv");
    let track = |diagnostics: &Path| {
        teachcam(&[
            "track",
            s(&rec),
            "--rig",
            s(&rig),
            "--tool",
            s(&tool),
            "-o",
            s(&out),
            "--markers-out",
            s(&markers),
            "--diagnostics",
            s(diagnostics),
        ])
    };
    // R7: the diagnostics' folder is missing. Refused before any work, nothing written.
    let o = track(&dir.path().join("nodir").join("diag.csv"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("nodir/diag.csv"), "{}", stderr(&o));
    assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
    assert_eq!(names(dir.path()), ["rec"]);
    // All four (the gates beside the diagnostics), and the success message names them.
    let diagnostics = dir.path().join("diag.csv");
    let o = track(&diagnostics);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        names(dir.path()),
        [
            "diag.csv",
            "diag.gates.json",
            "markers.csv",
            "out.csv",
            "rec"
        ]
    );
    let said = stderr(&o);
    assert!(
        said.contains("out.csv") && said.contains("markers.csv") && said.contains("diag.csv"),
        "{said}"
    );
    assert!(said.contains("3 of 3 frames tracked"), "{said}");
    // An output that is an input (refused for its extension or as an input: either way whole).
    let before = std::fs::read(&tool).unwrap();
    let o = teachcam(&[
        "track",
        s(&rec),
        "--rig",
        s(&rig),
        "--tool",
        s(&tool),
        "-o",
        s(&tool),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("tool.json"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&tool).unwrap(), before);
}

/// The KR 6 R700's work object 450 mm in front of it, 100 mm up; the brush 200 mm out of the
/// FLANGE along its x, the TCP's z pointing back at the flange (KUKA's FLANGE has x out).
const KUKA_WOBJ: &str = "450,0,100,1,0,0,0";
const KUKA_TCP: &str = "200,0,0,0.707106781,0,-0.707106781,0";

#[test]
fn export_krl_writes_src_and_dat_or_neither() {
    let dir = tempfile::tempdir().unwrap();
    let stroke = dir.path().join("smooth.csv");
    write_stroke(&stroke, 50);
    let export = |output: &Path| {
        teachcam(&[
            "export",
            "krl",
            s(&stroke),
            "--robot",
            "kr6-r700",
            "--wobj",
            KUKA_WOBJ,
            "--tcp",
            KUKA_TCP,
            "-o",
            s(output),
        ])
    };
    // R7: the .src is a folder; the .dat must not be left behind.
    let src = dir.path().join("q.src");
    std::fs::create_dir(&src).unwrap();
    let o = export(&src);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("q.src"), "{}", stderr(&o));
    assert_eq!(names(dir.path()), ["q.src", "smooth.csv"]);
    // The .dat is a folder: the .src must not be written either.
    std::fs::create_dir(dir.path().join("p.dat")).unwrap();
    let o = export(&dir.path().join("p.src"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(names(dir.path()), ["p.dat", "q.src", "smooth.csv"]);
    // A KRL program into a RAPID module's name.
    let o = export(&dir.path().join("stroke.mod"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(".mod names another format"),
        "{}",
        stderr(&o)
    );
    // Both, named on success; --quiet says nothing.
    let o = export(&dir.path().join("stroke.src"));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("stroke.src, "), "{}", stderr(&o));
    assert!(stderr(&o).contains("stroke.dat: "), "{}", stderr(&o));
    assert!(dir.path().join("stroke.dat").is_file());
    let mut quiet = vec!["--quiet"];
    let stroke_src = dir.path().join("stroke.src");
    quiet.extend([
        "export",
        "krl",
        s(&stroke),
        "--robot",
        "kr6-r700",
        "--wobj",
        KUKA_WOBJ,
        "--tcp",
        KUKA_TCP,
        "-o",
        s(&stroke_src),
    ]);
    let o = teachcam(&quiet);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stderr.is_empty() && o.stdout.is_empty(), "{}", stderr(&o));
}

#[test]
fn smooth_refuses_to_overwrite_its_input_and_a_wrong_extension() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("raw.csv");
    write_stroke(&raw, 200);
    let before = std::fs::read(&raw).unwrap();
    // The same file under another spelling.
    let same = dir.path().join(".").join("raw.csv");
    let o = teachcam(&["smooth", s(&raw), "-o", s(&same)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("also an input"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&raw).unwrap(), before);
    let o = teachcam(&["spectrum", s(&raw), "-o", s(&dir.path().join("x.svg"))]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(".svg names another format"),
        "{}",
        stderr(&o)
    );
    assert_eq!(names(dir.path()), ["raw.csv"]);
}

/// SIGINT (130) and SIGTERM (143) while `smooth` writes a large output: the old output stays
/// whole, no temporary is left (R7: a 152 MB hidden temporary stayed), and one line says which
/// signal ended it (after SIGTERM every command exited 130 and said nothing: second campaign).
#[test]
fn an_interrupt_removes_the_temporaries_and_keeps_the_old_output() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("raw.csv");
    // 300,000 rows (about 45 MB of output): its temporary lives long enough to be seen.
    write_stroke(&raw, 300_000);
    let out = dir.path().join("smooth.csv");
    for (signal, code, name) in [("-INT", 130, "SIGINT"), ("-TERM", 143, "SIGTERM")] {
        std::fs::write(&out, "the previous output\n").unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_teachcam"))
            .args(["smooth", s(&raw), "--method", "spline", "-o", s(&out)])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let temporary = format!(".smooth.csv.teachcam-tmp-{}", child.id());
        let start = Instant::now();
        let mut seen = false;
        while start.elapsed() < Duration::from_secs(120) {
            if names(dir.path()).contains(&temporary) {
                seen = true;
                break;
            }
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        assert!(seen, "{name}: the temporary {temporary} never appeared");
        let killed = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        let ended = child.wait_with_output().unwrap();
        let said = String::from_utf8_lossy(&ended.stderr);
        let left = names(dir.path());
        if ended.status.code() == Some(code) {
            assert_eq!(
                std::fs::read_to_string(&out).unwrap(),
                "the previous output\n",
                "{name}"
            );
            assert_eq!(said.trim().lines().count(), 1, "{name}: {said}");
            assert!(said.contains(name), "{name}: {said}");
        } else {
            // The signal came after the rename: the new output is whole.
            assert!(ended.status.success(), "{name}: {:?} {said}", ended.status);
            assert!(std::fs::read_to_string(&out).unwrap().starts_with("frame,"));
        }
        assert_eq!(
            left,
            ["raw.csv", "smooth.csv"],
            "{name}: {:?}",
            ended.status
        );
    }
}

#[test]
fn simulate_replaces_a_recording_whole_never_mixing_old_and_new_frames() {
    let dir = tempfile::tempdir().unwrap();
    let rec = simulate(dir.path());
    std::fs::write(rec.join("notes.txt"), "the user's").unwrap();
    let o = teachcam(&["simulate", "--frames", "1", "--out", s(&rec)]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Before, frames 1 and 2 of the 3-frame run stayed beside the new frame 0.
    for camera in ["cam0", "cam1", "cam2"] {
        assert_eq!(names(&rec.join(camera)), ["000000.png"], "{camera}");
    }
    assert!(names(&rec).contains(&"notes.txt".to_string()));
    assert_eq!(names(dir.path()), ["rec"], "a staging folder is left");
    // A file where the folder should be: a usage error, as every unwritable output is.
    let file = dir.path().join("file");
    std::fs::write(&file, "x").unwrap();
    let o = teachcam(&["simulate", "--frames", "1", "--out", s(&file)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("not a folder"), "{}", stderr(&o));
    assert_eq!(names(dir.path()), ["file", "rec"]);
}
