//! The README's path from a clean clone to a robot program, run as written: every `teachcam`
//! line of the first shell block under "How the pipeline runs", in an empty folder, in order.
//! A README edit that breaks the path fails here.

#![allow(
    clippy::unwrap_used,
    clippy::print_stderr,
    reason = "a test fails loudly on a broken fixture"
)]

use std::path::Path;
use std::process::Command;

#[path = "support/report.rs"]
mod report;

/// The first ```sh block after the heading that starts with `heading`.
fn shell_block(readme: &str, heading: &str) -> Vec<String> {
    let after = &readme[readme.find(heading).unwrap()..];
    let start = after.find("```sh\n").unwrap() + "```sh\n".len();
    let end = start + after[start..].find("```").unwrap();
    after[start..end].lines().map(str::to_string).collect()
}

/// A command line's words: split on blanks, `"..."` kept whole, a `#` comment after a blank
/// dropped.
fn words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut quoted = false;
    let mut in_word = false;
    for c in line.chars() {
        match c {
            '"' => {
                quoted = !quoted;
                in_word = true;
            }
            '#' if !quoted && !in_word => break,
            c if c.is_whitespace() && !quoted => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    in_word = false;
                }
            }
            c => {
                word.push(c);
                in_word = true;
            }
        }
    }
    if in_word {
        words.push(word);
    }
    words
}

#[test]
fn the_readme_path_runs_as_written() {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md"))
            .unwrap();
    let lines = shell_block(&readme, "## How the pipeline runs");
    let dir = tempfile::tempdir().unwrap();
    let mut ran = Vec::new();
    for line in &lines {
        let words = words(line);
        let Some((program, args)) = words.split_first() else {
            continue;
        };
        assert_eq!(
            program, "teachcam",
            "a README step that is not teachcam: {line}"
        );
        let out = Command::new(env!("CARGO_BIN_EXE_teachcam"))
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let is_doctor = args.first().is_some_and(|a| a == "doctor");
        assert!(
            out.status.success() || is_doctor,
            "README step failed: {line}\n{stdout}{stderr}"
        );
        if args.first().is_some_and(|a| a == "report") {
            // The README's file names (smooth.csv, rec/, rig.json): every figure is drawn.
            assert!(!stderr.contains("missing"), "{line}\n{stderr}");
            let page = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
            report::assert_every_figure_drawn(&page);
            // ... and a browser draws them all, with no console error.
            teachcam_testdata::browser::assert_report_drawn(
                "readme_path report",
                &dir.path().join("report.html"),
                report::model_of(&page)["figures"].as_array().unwrap(),
            );
        }
        if args.first().is_some_and(|a| a == "check") {
            assert!(
                stdout.contains("ok: the robot can run this trajectory"),
                "{line}\n{stdout}{stderr}"
            );
        }
        ran.push(args[0].clone());
    }
    eprintln!("ran: {}", ran.join(", "));
    for step in ["calibrate", "track", "smooth", "check", "export", "report"] {
        assert!(ran.iter().any(|r| r == step), "the path has no {step} step");
    }
    for file in [
        "rig.json",
        "raw.csv",
        "smooth.csv",
        "joints.csv",
        "stroke.mod",
    ] {
        assert!(dir.path().join(file).is_file(), "{file} not written");
    }
}
