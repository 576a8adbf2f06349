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

/// Every command of the tree with its `--help` text, the root (`[]`) first, each command
/// before its subcommands, in the order the help lists them.
fn command_tree(dir: &Path) -> Vec<(Vec<String>, String)> {
    let mut nodes = Vec::new();
    let mut todo: Vec<Vec<String>> = vec![Vec::new()];
    while let Some(path) = todo.pop() {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let help = text(&teachcam_in(dir, &args).stdout);
        for child in subcommands(&help).into_iter().rev() {
            let mut p = path.clone();
            p.push(child);
            todo.push(p);
        }
        nodes.push((path, help));
    }
    nodes
}

/// Every leaf command path (`["track"]`, `["c3d", "info"]`, ...).
fn command_paths(dir: &Path) -> Vec<Vec<String>> {
    let mut paths: Vec<Vec<String>> = command_tree(dir)
        .into_iter()
        .filter(|(_, help)| subcommands(help).is_empty())
        .map(|(path, _)| path)
        .collect();
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
    // A negative number reaches the flag's range message (issue 32), not clap's "unexpected
    // argument '-3'".
    (
        "smooth @/raw.csv --cutoff -3 -o @/s.csv",
        2,
        &["--cutoff", "-3 must be above 0"],
    ),
    (
        "track @/rec --rig @/rig.json --tool @/tool.json -o @/o.csv --fps -30",
        2,
        &["--fps", "above 0"],
    ),
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

/// The lines of a help text's `Examples:` section that run `teachcam`.
fn examples(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| l.trim_end() != "Examples:")
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .map(str::trim)
        .filter(|l| l.starts_with("teachcam "))
        .map(str::to_string)
        .collect()
}

/// Examples not run here, by their start, and why.
const NOT_RUN: &[(&str, &str)] = &[
    ("teachcam record --source v4l2:", "needs V4L2 cameras"),
    ("teachcam live --source v4l2:", "needs V4L2 cameras"),
    (
        "teachcam studio",
        "serves until Ctrl-C; tests/record_live.rs starts and stops it, teachcam-studio's tests drive it",
    ),
    (
        "teachcam simulate --scenario wand",
        "renders 430 frames x 4 cameras (about 30 s of CPU); tests/calibrate_wand_cli.rs runs it",
    ),
    (
        "teachcam calibrate wand",
        "needs `simulate --scenario wand` (about 30 s of CPU); tests/calibrate_wand_cli.rs runs it",
    ),
    (
        "teachcam import motive",
        "needs an OptiTrack Motive export; tests/repro_filters.rs imports one",
    ),
];

/// Examples run a second time with `--quiet`, which must leave stderr empty (issue 19: every
/// command says what it wrote, and nothing with `--quiet`); the slow ones are left out.
const QUIET: &[&str] = &[
    "teachcam simulate --scenario static",
    "teachcam simulate --scenario calibration",
    "teachcam calibrate intrinsics",
    "teachcam uncertainty-map",
    "teachcam c3d ",
    "teachcam import ",
    "teachcam smooth ",
    "teachcam spectrum ",
    "teachcam smoothing-study",
    "teachcam check ",
    "teachcam export ",
];

/// `touched.csv` for `align`: four points of the work object touched by the robot, the work
/// object 350 mm in front of the base and 100 mm up (the examples' `--wobj`).
fn write_touched(dir: &Path) {
    let mut text = String::from("x_wobj_mm,y_wobj_mm,z_wobj_mm,x_base_mm,y_base_mm,z_base_mm\n");
    for [x, y, z] in [
        [0.0, 0.0, 0.0],
        [200.0, 0.0, 0.0],
        [0.0, 150.0, 0.0],
        [50.0, 60.0, 80.0],
    ] {
        text.push_str(&format!("{x},{y},{z},{},{y},{}\n", x + 350.0, z + 100.0));
    }
    std::fs::write(dir.join("touched.csv"), text).unwrap();
}

/// `pivot.csv` for `pivot`: the simulated brush turned about its tip (`rec/tool.json`'s
/// `tip`, 5,20,-190) resting at (10, 20, 30) in the world, 25° about two axes.
fn write_pivot(dir: &Path) {
    use nalgebra::{UnitQuaternion, Vector3};
    use teachcam::geometry::{FrameIndex, Point3, pose_from_parts};
    use teachcam::trajectory::{Sample, ToolPose, Trajectory};
    let tip_in_tool = Point3::new(5.0, 20.0, -190.0);
    let rest_in_world = Point3::new(10.0, 20.0, 30.0);
    let samples = (0..60)
        .map(|i| {
            let a = f64::from(i) / 60.0 * std::f64::consts::TAU;
            let rotation =
                UnitQuaternion::from_euler_angles(0.44 * a.sin(), 0.44 * a.cos(), 0.3 * a);
            let translation = rest_in_world.coords - rotation * tip_in_tool.coords;
            let world_from_tool = pose_from_parts(Vector3::from(translation), rotation);
            Sample::measured(
                FrameIndex(i as usize),
                f64::from(i) / 30.0,
                ToolPose {
                    world_from_tool,
                    tip_in_world: world_from_tool * tip_in_tool,
                    markers: 4,
                    rms_mm: 0.01,
                },
            )
        })
        .collect();
    teachcam::io::trajectory::write_trajectory(&dir.join("pivot.csv"), &Trajectory { samples })
        .unwrap();
}

/// Issues 18 and 19: every command's `--help` has examples, and each runs as written (through
/// `sh`, globs and redirections included) in one folder: the root's examples first (the
/// demo, a simulated recording tracked, smoothed, checked and exported), then each command's,
/// in the order of the tree, so that a command's examples may use what its parent's wrote.
/// `check` examples must pass on the robot (issue 18: they used to fail). An example with an
/// output flag says what it wrote; those of [`QUIET`] say nothing on stderr with `--quiet`.
#[test]
fn every_help_example_runs_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let tree = command_tree(root);
    let without: Vec<String> = tree
        .iter()
        .filter(|(_, help)| examples(help).is_empty())
        .map(|(path, _)| format!("teachcam {}", path.join(" ")))
        .collect();
    assert!(
        without.is_empty(),
        "no Examples: in the help of {without:?}"
    );
    write_touched(root);
    write_pivot(root);
    let binary = env!("CARGO_BIN_EXE_teachcam");
    let mut ran: Vec<String> = Vec::new();
    let mut failures = Vec::new();
    for (_, help) in &tree {
        for example in examples(help) {
            if ran.contains(&example) {
                continue;
            }
            ran.push(example.clone());
            if let Some((_, why)) = NOT_RUN.iter().find(|(start, _)| example.starts_with(start)) {
                eprintln!("not run: {example} ({why})");
                continue;
            }
            let line = format!("'{binary}'{}", &example["teachcam".len()..]);
            let started = std::time::Instant::now();
            let o = Command::new("sh")
                .args(["-c", &line])
                .current_dir(root)
                .output()
                .unwrap();
            eprintln!("{:6.1} s  {example}", started.elapsed().as_secs_f64());
            let stdout = text(&o.stdout);
            let failed = !o.status.success()
                || (example.starts_with("teachcam check ")
                    && !stdout.contains("ok: the robot can run this trajectory"));
            let writes = [" -o ", " --out ", " --output "]
                .iter()
                .any(|flag| example.contains(flag));
            let said = stdout.contains("wrote ") || text(&o.stderr).contains("wrote ");
            if failed || (writes && !said) {
                failures.push(format!("{example}\n{stdout}{}", text(&o.stderr)));
            }
            if QUIET.iter().any(|start| example.starts_with(start)) {
                let quiet = format!("'{binary}' --quiet{}", &example["teachcam".len()..]);
                let o = Command::new("sh")
                    .args(["-c", &quiet])
                    .current_dir(root)
                    .output()
                    .unwrap();
                if !o.status.success() || !o.stderr.is_empty() {
                    failures.push(format!("--quiet {example}\n{}", text(&o.stderr)));
                }
            }
        }
    }
    assert!(ran.len() >= 40, "{} examples", ran.len());
    assert!(
        failures.is_empty(),
        "examples that fail:\n{}",
        failures.join("\n")
    );
}
