//! One exit-code rule for every command (issue 15): 2 for usage (flags, flag values, output
//! paths), 1 for the user's files rejected, and every error one line naming the flag or file.
//! The walk reads the command tree from `teachcam --help`, so a command added later is walked
//! too.

use std::path::Path;
use std::process::{Command, Output};

fn teachcam_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The names listed under `Commands:` in a help text (`help` itself left out).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

/// Every leaf command path (`["track"]`, `["c3d", "info"]`, ...).
fn command_paths(dir: &Path) -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    let mut todo: Vec<Vec<String>> = vec![Vec::new()];
    while let Some(path) = todo.pop() {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let help = text(&teachcam_in(dir, &args).stdout);
        let children = subcommands(&help);
        if children.is_empty() {
            paths.push(path);
        } else {
            for child in children {
                let mut p = path.clone();
                p.push(child);
                todo.push(p);
            }
        }
    }
    paths.sort();
    paths
}

/// The options of a help text whose default is a number or a list of numbers
/// (`--near <NEAR>  ... [default: 300]`).
fn numeric_options(help: &str) -> Vec<String> {
    let mut options = Vec::new();
    let mut current: Option<String> = None;
    for line in help.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('-') {
            current = trimmed
                .split([' ', ','])
                .find(|w| w.starts_with("--"))
                .map(str::to_string);
        }
        if let (Some(option), Some(rest)) = (&current, line.split("[default: ").nth(1)) {
            let value = rest.trim_end_matches(']');
            let numeric = !value.is_empty()
                && value
                    .chars()
                    .all(|c| c.is_ascii_digit() || ".,-e_".contains(c));
            if numeric && !options.contains(option) {
                options.push(option.clone());
            }
        }
    }
    options
}

fn assert_one_line(o: &Output, what: &str) -> String {
    let stderr = text(&o.stderr);
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "{what}: stderr is not one line:\n{stderr}"
    );
    stderr
}

#[test]
fn every_command_refuses_unknown_flags_and_bad_numbers_with_exit_2_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let paths = command_paths(dir.path());
    assert!(paths.len() >= 20, "{paths:?}");
    let mut numeric = 0;
    for path in &paths {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        let help = text(&teachcam_in(dir.path(), &[&args[..], &["--help"]].concat()).stdout);
        args.push("--no-such-flag");
        let o = teachcam_in(dir.path(), &args);
        let what = args.join(" ");
        assert_eq!(o.status.code(), Some(2), "{what}");
        assert!(assert_one_line(&o, &what).contains("--no-such-flag"));
        args.pop();
        for option in numeric_options(&help) {
            for bad in ["nan", "x"] {
                let o = teachcam_in(dir.path(), &[&args[..], &[option.as_str(), bad]].concat());
                let what = format!("{} {option} {bad}", args.join(" "));
                assert_eq!(o.status.code(), Some(2), "{what}: {}", text(&o.stderr));
                let stderr = assert_one_line(&o, &what);
                assert!(stderr.contains(&option), "{what}: {stderr}");
                numeric += 1;
            }
        }
    }
    // The walk reached the numeric flags (about a hundred across the commands).
    assert!(numeric > 60, "{numeric}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "a refused command wrote something"
    );
}

/// `(arguments, expected exit code, words the one-line message holds)`. `@` is the scratch
/// folder, where `raw.csv` is a valid trajectory and `missing.csv` does not exist.
const TABLE: &[(&str, i32, &[&str])] = &[
    // Flag values wrong on their own: usage, 2 (issue 15 item 10).
    (
        "uncertainty --rig @/rig.json --tool @/tool.json --pose 0,0,190",
        2,
        &["--pose", "7 comma-separated"],
    ),
    (
        "check @/raw.csv --wobj 350,0,100",
        2,
        &["--wobj", "7 comma-separated"],
    ),
    (
        "export rapid @/raw.csv --tcp 0,0,200,2,0,0,0 -o @/x.mod",
        2,
        &["--tcp", "unit"],
    ),
    (
        "track @/rec --rig @/rig.json --tool @/tool.json -o @/o.csv --fps 0",
        2,
        &["--fps", "above 0"],
    ),
    (
        "track @/rec --rig @/rig.json --tool @/tool.json -o @/o.csv --fps inf",
        2,
        &["--fps", "finite"],
    ),
    (
        "simulate --frames 0 --out @/sim",
        2,
        &["--frames", "at least 1"],
    ),
    ("smooth @/raw.csv --cutoff 0 -o @/s.csv", 2, &["--cutoff"]),
    ("smooth @/raw.csv --order 0 -o @/s.csv", 2, &["--order"]),
    (
        "uncertainty --rig @/rig.json --tool @/tool.json --pose 0,0,190,1,0,0,0 --trials 100000000",
        2,
        &["--trials", "1000000"],
    ),
    (
        "check @/raw.csv --speed-fraction 1.5",
        2,
        &["--speed-fraction", "(0, 1]"],
    ),
    ("import c3d @/x.c3d --fps 0 -o @/t.csv", 2, &["--fps"]),
    (
        "detect @/rec --min-roundness 2 -o @/d.csv",
        2,
        &["--min-roundness"],
    ),
    ("export nope @/raw.csv -o @/x.mod", 2, &["nope"]),
    ("track @/rec --rig @/rig.json", 2, &["--tool", "--output"]),
    // Output paths: usage, 2.
    (
        "smooth @/raw.csv -o @/raw.csv",
        2,
        &["raw.csv", "also an input"],
    ),
    (
        "smooth @/raw.csv -o @/nodir/s.csv",
        2,
        &["nodir", "does not exist"],
    ),
    (
        "spectrum @/raw.csv -o @/x.svg",
        2,
        &[".svg", "another format"],
    ),
    (
        "export krl @/raw.csv -o @/stroke.mod",
        2,
        &[".mod", "another format"],
    ),
    (
        "export urscript @/raw.csv -o @/stroke.src",
        2,
        &[".src", "another format"],
    ),
    // The user's files: 1, naming the file.
    ("smooth @/missing.csv -o @/s.csv", 1, &["missing.csv"]),
    ("check @/missing.csv", 1, &["missing.csv"]),
    ("export rapid @/missing.csv -o @/x.mod", 1, &["missing.csv"]),
    ("spectrum @/missing.csv -o @/x.csv", 1, &["missing.csv"]),
    ("pivot @/missing.csv", 1, &["missing.csv"]),
    ("align @/missing.csv", 1, &["missing.csv"]),
    ("c3d info @/missing.c3d", 1, &["missing.c3d"]),
    (
        "track @/rec --rig @/missing.json --tool @/tool.json -o @/o.csv",
        1,
        &["missing.json"],
    ),
    (
        "uncertainty --rig @/missing.json --tool @/tool.json --pose 0,0,190,1,0,0,0",
        1,
        &["missing.json"],
    ),
    ("tool-check @/missing.json", 1, &["missing.json"]),
    ("report @/nowhere", 1, &["raw.csv"]),
];

#[test]
fn the_catalogue_of_usage_mistakes_and_missing_files_exits_as_the_rule_says() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::write(
        root.join("raw.csv"),
        "frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,tip_x_mm,tip_y_mm,tip_z_mm,markers,rms_mm\n\
         0,0.0,0,0,250,1,0,0,0,0,0,100,4,0.01\n\
         1,0.01,0,0,250,1,0,0,0,0,0,100,4,0.01\n",
    )
    .unwrap();
    let before = std::fs::read(root.join("raw.csv")).unwrap();
    for (args, code, words) in TABLE {
        let args: Vec<String> = args
            .split_whitespace()
            .map(|a| a.replace('@', root.to_str().unwrap()))
            .collect();
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = teachcam_in(root, &args);
        let what = args.join(" ");
        let stderr = assert_one_line(&o, &what);
        assert_eq!(o.status.code(), Some(*code), "{what}: {stderr}");
        for word in *words {
            assert!(stderr.contains(word), "{what}: {stderr} lacks {word:?}");
        }
    }
    assert_eq!(std::fs::read(root.join("raw.csv")).unwrap(), before);
    let mut left: Vec<String> = std::fs::read_dir(root)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["raw.csv"], "a refused command wrote something");
}
