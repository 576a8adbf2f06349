//! Regression tests for the wrong successes reproduced in `../shared/repro` (R2..R6): each
//! input is read straight from there and is now refused with one line naming what is wrong, or
//! answered correctly.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use teachcam::io::trajectory::read_trajectory;
use teachcam_testdata::shared_repro;

fn teachcam(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(args)
        .output()
        .unwrap()
}

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
