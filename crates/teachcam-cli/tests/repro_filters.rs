//! Regression tests for the wrong successes reproduced in `../shared/repro` (R2..R6): each
//! input is read straight from there and is now refused with one line naming what is wrong, or
//! answered correctly.

use std::path::{Path, PathBuf};
use std::process::Output;

use teachcam::io::trajectory::read_trajectory;
use teachcam_testdata::shared_repro;

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs `args`, expects exit 1 with one line on stderr holding every one of `needles`, and no
/// output file at `output`.
fn assert_refused(args: &[&str], output: &Path, needles: &[&str]) -> String {
    assert_refused_with(1, args, output, needles)
}

/// As [`assert_refused`] with exit code `code`.
fn assert_refused_with(code: i32, args: &[&str], output: &Path, needles: &[&str]) -> String {
    let o = teachcam(args);
    let message = stderr(&o);
    assert_eq!(o.status.code(), Some(code), "{args:?}: {message}");
    assert_eq!(message.trim_end().lines().count(), 1, "{args:?}: {message}");
    for needle in needles {
        assert!(
            message.contains(needle),
            "{args:?}: {message} lacks {needle:?}"
        );
    }
    assert!(!output.exists(), "{args:?} left {}", output.display());
    message
}

fn repro(folder: &str) -> Option<PathBuf> {
    shared_repro(folder)
}

#[test]
fn r2_a_constant_stays_constant_through_high_order_low_cutoff_lowpass() {
    let Some(dir) = repro("R2_lowpass_unstable") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.csv");
    // Before: 1e92 mm, 5e11 mm and z = 76.5 mm (true 180.8); exit 0 each time.
    for (file, order, cutoff) in [
        ("const_1000.csv", "12", "6"),
        ("const_1000.csv", "8", "2"),
        ("const_2000.csv", "8", "6"),
    ] {
        let input = dir.join(file);
        let o = teachcam(&[
            "smooth",
            path(&input),
            "--order",
            order,
            "--cutoff",
            cutoff,
            "-o",
            path(&out),
        ]);
        assert!(
            o.status.success(),
            "{file} {order} {cutoff}: {}",
            stderr(&o)
        );
        let before = read_trajectory(&input).unwrap();
        let after = read_trajectory(&out).unwrap();
        assert_eq!(before.len(), after.len());
        for (b, a) in before.samples.iter().zip(&after.samples) {
            let (b, a) = (b.pose.unwrap(), a.pose.unwrap());
            let moved = (a.world_from_tool.translation.vector
                - b.world_from_tool.translation.vector)
                .norm()
                .max((a.tip_in_world - b.tip_in_world).norm());
            // The file's 6 decimals of a number within 1e-9 of the input's are the input's.
            assert!(
                moved <= 1e-9,
                "{file} order {order} at {cutoff} Hz: moved {moved:e} mm"
            );
        }
        std::fs::remove_file(&out).unwrap();
    }
    // 300 samples at 30 Hz hold neither 0.1 Hz at order 8 nor 0.01 Hz (before: z 193.29,
    // zeros); 1e-9 Hz is not a filter double precision can hold (before: NaN).
    let const_30 = dir.join("const_30.csv");
    for (order, cutoff, needle) in [
        ("8", "0.1", "the record holds 300 samples"),
        ("8", "0.01", "the record holds 300 samples"),
        ("2", "0.01", "the record holds 300 samples"),
        ("2", "1e-9", "cannot be held in double precision"),
    ] {
        assert_refused(
            &[
                "smooth",
                path(&const_30),
                "--order",
                order,
                "--cutoff",
                cutoff,
                "-o",
                path(&out),
            ],
            &out,
            &["const_30.csv", needle],
        );
    }
}

#[test]
fn r6_tiny_time_steps_and_absurd_frame_rates_are_refused_naming_the_range() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out.csv");
    if let Some(dir) = repro("R6_smooth_nan_tiny_dt") {
        // Before: every pose field NaN, time_s all 0.000000, exit 0.
        assert_refused(
            &["smooth", path(&dir.join("tiny_dt.csv")), "-o", path(&out)],
            &out,
            &["tiny_dt.csv", "time_s", "0.001..=100000 Hz"],
        );
    }
    let Some(rec) = repro("R1_wrong_size_later_frames/rec") else {
        return;
    };
    let rig = rec.join("rig.json");
    let tool = rec.join("tool.json");
    // Before: time_s all 0.000000 at --fps 1e7, exit 0. A flag's value: a usage error.
    assert_refused_with(
        2,
        &[
            "track",
            path(&rec),
            "--rig",
            path(&rig),
            "--tool",
            path(&tool),
            "--fps",
            "1e7",
            "-o",
            path(&out),
        ],
        &out,
        &["--fps", "10000000 Hz", "0.001..=100000 Hz"],
    );
    // recording.json {"fps": 1e-320}: before, time_s = inf.
    let copy = tmp.path().join("rec");
    for camera in ["cam0", "cam1", "cam2"] {
        std::fs::create_dir_all(copy.join(camera)).unwrap();
        for entry in std::fs::read_dir(rec.join(camera)).unwrap() {
            let entry = entry.unwrap();
            std::fs::copy(entry.path(), copy.join(camera).join(entry.file_name())).unwrap();
        }
    }
    std::fs::write(copy.join("recording.json"), "{\"fps\": 1e-320}").unwrap();
    assert_refused(
        &[
            "track",
            path(&copy),
            "--rig",
            path(&rig),
            "--tool",
            path(&tool),
            "-o",
            path(&out),
        ],
        &out,
        &["recording.json", "fps = ", "0.001..=100000 Hz"],
    );
}

#[test]
fn r3_importers_place_rows_by_their_frame_numbers() {
    let Some(dir) = repro("R3_vendor_dropped_row") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let tool = dir.join("tool.json");
    let import = |kind: &str, file: &str| {
        let out = tmp.path().join(format!("{file}.csv"));
        let o = teachcam(&[
            "import",
            kind,
            path(&dir.join(file)),
            "--tool",
            path(&tool),
            "-o",
            path(&out),
        ]);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        read_trajectory(&out).unwrap()
    };
    // Before: 119 rows, the row of frame 50 holding frame 51's pose (Frame/Time ignored), and
    // swapped rows written swapped.
    let motive = import("motive", "motive_row50_missing.csv");
    let missing = import("qualisys", "qualisys_row51_missing.tsv");
    let swapped = import("qualisys", "qualisys_rows_swapped.tsv");
    // Motive numbers frames from 0, QTM from 1: the missing row is frame index 50 in both.
    for (name, t, gap) in [("motive", &motive, 50), ("qualisys", &missing, 50)] {
        assert_eq!(
            t.len(),
            120,
            "{name}: one row per frame, the dropped one a gap"
        );
        assert!(
            t.samples[gap].pose.is_none(),
            "{name}: frame {gap} is a gap"
        );
        let posed = t.samples.iter().filter(|s| s.pose.is_some()).count();
        assert_eq!(posed, 119, "{name}");
    }
    // The swapped export comes out in frame order: each of its frames is the same pose as in
    // the export whose rows are in order (all but frame index 50, which that one lacks).
    assert_eq!(swapped.len(), 120);
    for (frame, (a, b)) in swapped.samples.iter().zip(&missing.samples).enumerate() {
        assert_eq!(a.frame, b.frame);
        if frame == 50 {
            assert!(a.pose.is_some() && b.pose.is_none());
            continue;
        }
        let (a, b) = (a.pose.unwrap(), b.pose.unwrap());
        let d = (a.tip_in_world - b.tip_in_world).norm();
        assert!(d < 1e-9, "frame {frame}: tips {d} mm apart");
    }
    // QTM frames 9 and 10 (indices 8 and 9) are swapped in the file: their poses differ, so
    // the order matters.
    let tip =
        |t: &teachcam::trajectory::Trajectory, f: usize| t.samples[f].pose.unwrap().tip_in_world;
    assert!((tip(&swapped, 8) - tip(&swapped, 9)).norm() > 1.0);
}

#[test]
fn r4_calibrate_rig_refuses_a_camera_with_two_image_sizes() {
    let Some(dir) = repro("R4_rig_calib_mixed_sizes") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("rig.json");
    // Before: exit 0, right's image_size [1280, 720] with cx 330.7, cy 251.4 (fitted on the
    // 640x480 images).
    let st = dir.join("st");
    assert_refused(
        &[
            "calibrate",
            "rig",
            "--inner",
            "9x6",
            "--square",
            "25",
            path(&st),
            "--world",
            "01",
            "-o",
            path(&out),
        ],
        &out,
        &["1280x720", "640x480", "right"],
    );
}

#[test]
fn r5_control_characters_in_c3d_labels_stay_on_one_line() {
    let Some(dir) = repro("R5_c3d_label_newline") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("t.csv");
    // Before: the label bytes "t\nX" echoed raw, the message on two lines.
    assert_refused(
        &[
            "import",
            "c3d",
            path(&dir.join("nl.c3d")),
            "--markers",
            "a,b,c",
            "-o",
            path(&out),
        ],
        &out,
        &["nl.c3d"],
    );
}
