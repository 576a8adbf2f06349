//! `teachcam check` and `teachcam export` on closed-form strokes: exit statuses, frame-by-frame
//! reports, programs written whole or not at all.

use std::f64::consts::{PI, TAU};
use std::path::Path;
use std::process::Output;

use nalgebra::{UnitQuaternion, Vector3};
use teachcam::geometry::{FrameIndex, Point3, pose_from_parts};
use teachcam::io::trajectory::write_trajectory;
use teachcam::trajectory::{Sample, ToolPose, Trajectory};

const WOBJ: &str = "350,0,150,1,0,0,0";
const TCP: &str = "0,0,150,1,0,0,0";
/// The KR 6's work object 450 mm in front of it, 150 mm up; the brush 150 mm out of the
/// FLANGE, along its x (KUKA's flange normal): the TCP's z is the flange's x.
const KUKA_WOBJ: &str = "450,0,150,1,0,0,0";
const KUKA_TCP: &str = "150,0,0,0.707106781,0,0.707106781,0";
/// The UR5e's work object 400 mm along its base x, 100 mm up.
const UR_WOBJ: &str = "400,0,100,1,0,0,0";

/// A 4 s painter's stroke at 30 Hz (sums of sinusoids), brush pointing down, `time_scale`
/// stretching its timing; tool frame = TCP frame.
fn write_stroke(path: &Path, time_scale: f64) {
    let samples = (0..120)
        .map(|k| {
            let t = f64::from(k) / 30.0;
            let tip = Vector3::new(
                60.0 * (TAU * 0.4 * t).sin(),
                40.0 * (TAU * 0.25 * t + 1.0).sin(),
                5.0 + 4.0 * (TAU * 0.7 * t).sin(),
            );
            let rotation = UnitQuaternion::from_euler_angles(0.2 * (TAU * 0.3 * t).sin(), 0.1, 0.3)
                * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI);
            Sample::measured(
                FrameIndex(k as usize),
                t * time_scale,
                ToolPose {
                    world_from_tool: pose_from_parts(tip, rotation),
                    tip_in_world: Point3::from(tip),
                    markers: 4,
                    rms_mm: 0.05,
                },
            )
        })
        .collect();
    write_trajectory(path, &Trajectory { samples }).unwrap();
}

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn check_passes_and_writes_one_joint_row_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory, 1.0);
    let joints = dir.path().join("joints.csv");
    let out = teachcam(&[
        "check",
        trajectory.to_str().unwrap(),
        "--robot",
        "irb120",
        "--wobj",
        WOBJ,
        "--tcp",
        TCP,
        "--joints-out",
        joints.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let table = std::fs::read_to_string(&joints).unwrap();
    assert!(table.starts_with("frame,j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg"));
    assert_eq!(table.lines().count(), 121);
    // Each axis's peak speed against its limit, one line an axis: the peak agrees with the
    // finite differences of the joint table over the trajectory's times (played at the printed
    // time scale).
    let stdout = text(&out.stdout);
    let scale: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("time scale "))
        .and_then(|rest| rest.split(':').next())
        .unwrap_or_else(|| panic!("no time scale in {stdout}"))
        .parse()
        .unwrap();
    let times: Vec<f64> = std::fs::read_to_string(&trajectory)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let rows: Vec<Vec<f64>> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    for axis in 1..=6 {
        let peak = rows
            .windows(2)
            .map(|w| {
                let dt = scale * (times[w[1][0] as usize] - times[w[0][0] as usize]);
                (w[1][axis] - w[0][axis]).abs() / dt
            })
            .fold(0.0, f64::max);
        let line = stdout
            .lines()
            .find_map(|l| l.trim().strip_prefix(&format!("axis {axis}: peak ")))
            .unwrap_or_else(|| panic!("no line for axis {axis} in {stdout}"));
        let printed: f64 = line.split(' ').next().unwrap().parse().unwrap();
        // Printed to the degree per second; the table's angles to its decimals.
        assert!(
            (printed - peak).abs() <= 0.6,
            "axis {axis}: printed {printed}, table {peak}"
        );
        assert!(line.contains("% of "), "{line}");
    }
}

#[test]
fn too_far_is_reported_frame_by_frame_with_exit_status_1() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory, 1.0);
    let out = teachcam(&[
        "check",
        trajectory.to_str().unwrap(),
        "--wobj",
        "650,0,150,1,0,0,0",
        "--tcp",
        TCP,
    ]);
    assert_eq!(out.status.code(), Some(1));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("frames 0-119: out of reach"), "{stdout}");
    assert!(text(&out.stderr).contains("stroke.csv"));
    // The suggestion is a --wobj to paste, and pasted it passes.
    let wobj = stdout
        .lines()
        .find_map(|l| l.strip_prefix("suggestion: --wobj \""))
        .and_then(|rest| rest.split('"').next())
        .unwrap_or_else(|| panic!("no --wobj suggestion in {stdout}"));
    let pasted = teachcam(&[
        "check",
        trajectory.to_str().unwrap(),
        "--wobj",
        wobj,
        "--tcp",
        TCP,
    ]);
    assert_eq!(pasted.status.code(), Some(0), "{}", text(&pasted.stdout));
}

/// The position and the tool's z axis of every robtarget of a RAPID module, in order: the
/// axis from the quaternion `[q1..q4] = [w, x, y, z]` by the rotation matrix's third column.
fn robtargets(module: &str) -> Vec<([f64; 3], [f64; 3])> {
    module
        .lines()
        .filter_map(|l| l.trim().strip_prefix("CONST robtarget "))
        .map(|l| {
            let numbers: Vec<f64> = l
                .split(['[', ']', ',', ';', '='])
                .filter_map(|t| t.trim().parse().ok())
                .collect();
            let [x, y, z, w, qx, qy, qz] = numbers[..7] else {
                panic!("robtarget {l}")
            };
            let axis = [
                2.0 * (qx * qz + w * qy),
                2.0 * (qy * qz - w * qx),
                1.0 - 2.0 * (qx * qx + qy * qy),
            ];
            ([x, y, z], axis)
        })
        .collect()
}

#[test]
fn a_demonstration_faster_than_the_arm_is_slowed_and_approached() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("fast.csv");
    write_stroke(&trajectory, 1.0 / 10.0);
    let program = dir.path().join("fast.mod");
    let args = [
        "export",
        "rapid",
        trajectory.to_str().unwrap(),
        "--wobj",
        WOBJ,
        "--tcp",
        TCP,
        "-o",
        program.to_str().unwrap(),
    ];
    // At the demonstration's own timing: refused, naming the axis and the factor that fits.
    let mut recorded = args.to_vec();
    recorded.extend(["--time-scale", "1"]);
    let out = teachcam(&recorded);
    assert_eq!(out.status.code(), Some(1));
    let stdout = text(&out.stdout);
    assert!(stdout.contains("too fast"), "{stdout}");
    let factor: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("suggestion: slow the trajectory down by a factor of "))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|f| f.parse().ok())
        .unwrap_or_else(|| panic!("no factor in {stdout}"));
    assert!(factor > 1.0);
    assert!(!program.exists());
    // Default: slowed by that factor, said on stderr and in the module's header.
    let out = teachcam(&args);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let said = format!("time scale {factor:.2}: axis");
    assert!(text(&out.stderr).contains(&said), "{}", text(&out.stderr));
    let module = std::fs::read_to_string(&program).unwrap();
    assert!(module.contains(&format!("! {said}")), "{module}");
    // The factor is the smallest that passes: the per-frame check passes at it, not 0.02 less.
    let check = |scale: f64| {
        teachcam(&[
            "check",
            trajectory.to_str().unwrap(),
            "--wobj",
            WOBJ,
            "--tcp",
            TCP,
            "--time-scale",
            &format!("{scale}"),
        ])
        .status
        .code()
    };
    assert_eq!(check(factor), Some(0));
    assert_eq!(check(factor - 0.02), Some(1));
    // Approach and retract: 50 mm back along the tool's z from the first and last points.
    let targets = robtargets(&module);
    let n = targets.len();
    for (lifted, paint) in [(targets[0], targets[1]), (targets[n - 1], targets[n - 2])] {
        for i in 0..3 {
            let expected = paint.0[i] - 50.0 * paint.1[i];
            assert!(
                (lifted.0[i] - expected).abs() < 0.01,
                "{lifted:?} {paint:?}"
            );
        }
    }
    let moves: Vec<&str> = module
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("Move"))
        .collect();
    assert!(moves[0].starts_with("MoveJ p0001,"), "{moves:?}");
    assert!(moves[1].starts_with("MoveL p0002,") && moves[1].contains(", fine,"));
    assert!(moves[moves.len() - 2].contains(", fine,"), "{moves:?}");
    // --force still writes the too-fast demonstration at its own timing.
    let mut forced = recorded.clone();
    forced.push("--force");
    let out = teachcam(&forced);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let module = std::fs::read_to_string(&program).unwrap();
    assert!(module.contains("time scale 1.00 (given)"), "{module}");
}

#[test]
fn every_dialect_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory, 1.0);
    for (dialect, robot, wobj, tcp, file, first) in [
        ("rapid", "irb120", WOBJ, TCP, "p.mod", "MODULE p"),
        (
            "krl",
            "kr6-r700",
            KUKA_WOBJ,
            KUKA_TCP,
            "p.src",
            "&ACCESS RVP",
        ),
        // `p` starts URScript's pose literals: the program is named tc_p.
        ("urscript", "ur5e", UR_WOBJ, TCP, "p.script", "def tc_p():"),
        (
            "csv",
            "kr6-r900",
            KUKA_WOBJ,
            KUKA_TCP,
            "p.csv",
            "frame,time_s,x_mm",
        ),
    ] {
        let path = dir.path().join(file);
        let out = teachcam(&[
            "export",
            dialect,
            trajectory.to_str().unwrap(),
            "--robot",
            robot,
            "--wobj",
            wobj,
            "--tcp",
            tcp,
            "-o",
            path.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{dialect}: {}", text(&out.stderr));
        assert!(std::fs::read_to_string(&path).unwrap().starts_with(first));
    }
    let src = std::fs::read_to_string(dir.path().join("p.src")).unwrap();
    let dat = std::fs::read_to_string(dir.path().join("p.dat")).unwrap();
    assert_krl_shape(&src, "DEF p(", "END");
    assert_krl_shape(&dat, "DEFDAT p", "ENDDAT");
}

/// What the KRL grammar of ANTLR's grammars-v4 asks of a module beyond KSS syntax (found by
/// running it on these programs, notes/robots.md): before `DEF`/`DEFDAT` only `&` header lines
/// (a comment or blank line there is a stray NEWLINE token); in a `.src`, declarations without
/// values; at most one approximation keyword per motion.
fn assert_krl_shape(text: &str, opening: &str, closing: &str) {
    let mut lines = text.lines().map(str::trim);
    let first = lines
        .by_ref()
        .find(|l| !l.starts_with('&'))
        .unwrap_or_default();
    assert!(first.starts_with(opening), "first line {first:?}");
    assert_eq!(
        text.lines().map(str::trim).rfind(|l| !l.is_empty()),
        Some(closing)
    );
    for line in text.lines().map(str::trim) {
        let code = line.split(';').next().unwrap_or_default();
        if opening.starts_with("DEF ") {
            assert!(
                !(code.starts_with("DECL") && code.contains('=')),
                "a .src declaration with a value: {line}"
            );
        }
        let approximations = ["C_DIS", "C_ORI", "C_VEL", "C_PTP"]
            .iter()
            .filter(|k| code.split_whitespace().any(|w| w == **k))
            .count();
        assert!(
            approximations <= 1 || code.starts_with("PTP") && approximations == 2,
            "{line}"
        );
    }
}

#[test]
fn bad_inputs_name_the_flag_or_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory, 1.0);
    let path = trajectory.to_str().unwrap();
    let out = teachcam(&["check", path, "--wobj", "1,2,3"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("--wobj"));
    let out = teachcam(&["check", path, "--tcp", "0,0,0,2,0,0,0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("--tcp"));
    let out = teachcam(&["check", path, "--robot", "kr6"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("kr6"));
    let missing = dir.path().join("missing.csv");
    let out = teachcam(&["check", missing.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("missing.csv"));
    std::fs::write(&trajectory, "frame,time_s\n0,0\n").unwrap();
    let never = dir.path().join("never.mod");
    let out = teachcam(&["export", "rapid", path, "-o", never.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("header"));
    assert!(!never.exists());
}

#[test]
fn align_prints_the_work_object_and_refuses_collinear_points() {
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("touched.csv");
    // base = wobj + (350, 0, 150), rotated 90° about z: (x, y) -> (-y, x).
    std::fs::write(
        &points,
        "x_wobj_mm,y_wobj_mm,z_wobj_mm,x_base_mm,y_base_mm,z_base_mm\n\
         0,0,0,350,0,150\n100,0,0,350,100,150\n0,100,0,250,0,150\n100,100,5,250,100,155\n",
    )
    .unwrap();
    let out = teachcam(&["align", points.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains(
            "--wobj \"350.000,0.000,150.000,0.707106781,0.000000000,0.000000000,0.707106781\""
        ),
        "{stdout}"
    );
    std::fs::write(
        &points,
        "x_wobj_mm,y_wobj_mm,z_wobj_mm,x_base_mm,y_base_mm,z_base_mm\n0,0,0,0,0,0\n1,0,0,1,0,0\n2,0,0,2,0,0\n",
    )
    .unwrap();
    let out = teachcam(&["align", points.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("collinear"));
    std::fs::write(&points, "x,y\n").unwrap();
    let out = teachcam(&["align", points.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("line 1"));
}

#[test]
fn pivot_refuses_a_recording_that_does_not_turn() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("pivot.csv");
    // The stroke above turns about a fixed axis only (its tilt varies about one axis): refused.
    write_stroke(&trajectory, 1.0);
    let out = teachcam(&["pivot", trajectory.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("turned too little"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn acceleration_limit_is_judged_when_given() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory, 1.0);
    let path = trajectory.to_str().unwrap();
    let base = ["check", path, "--wobj", WOBJ, "--tcp", TCP];
    let mut strict = base.to_vec();
    strict.extend(["--max-acceleration-deg-s2", "1"]);
    // Slowed (accelerations fall with the square of the time scale), it passes.
    let out = teachcam(&strict);
    assert!(out.status.success(), "{}", text(&out.stdout));
    assert!(text(&out.stdout).contains("limits the demonstration"));
    strict.extend(["--time-scale", "1"]);
    let out = teachcam(&strict);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stdout).contains("accelerates too hard"));
    let mut loose = base.to_vec();
    loose.extend(["--max-acceleration-deg-s2", "100000"]);
    assert!(teachcam(&loose).status.success());
}

/// `--help` explains the robot commands with an example and the contract's flags.
#[test]
fn help_texts_explain_the_robot_commands() {
    for (command, flags) in [
        (
            "check",
            &["--robot", "--wobj", "--tcp", "--joints-out", "Examples:"][..],
        ),
        (
            "export",
            &[
                "rapid",
                "krl",
                "urscript",
                "--force",
                "--tolerance-mm",
                "Examples:",
            ][..],
        ),
        ("align", &["x_wobj_mm", "Examples:"][..]),
        ("pivot", &["--min-rotation-deg", "Examples:"][..]),
    ] {
        let out = teachcam(&[command, "--help"]);
        assert!(out.status.success());
        let help = text(&out.stdout);
        for flag in flags {
            assert!(
                help.contains(flag),
                "{command} --help lacks {flag}:\n{help}"
            );
        }
    }
}

/// Each dialect drives its maker's robots: another maker's is refused with one line (exit 2)
/// unless `--force`; KRL's DEF must be the file's name and a name KSS accepts.
#[test]
fn dialects_refuse_other_makers_and_krl_names_kss_refuses() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory, 1.0);
    let path = trajectory.to_str().unwrap();
    let out_mod = dir.path().join("p.mod");
    let args = [
        "export",
        "rapid",
        path,
        "--robot",
        "kr6-r700",
        "--wobj",
        KUKA_WOBJ,
        "--tcp",
        KUKA_TCP,
        "-o",
        out_mod.to_str().unwrap(),
    ];
    let out = teachcam(&args);
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(
        err.contains("RAPID programs drive ABB robots") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(!out_mod.exists());
    let mut forced = args.to_vec();
    forced.push("--force");
    assert!(teachcam(&forced).status.success());
    for (file, name, says) in [
        ("2nd-stroke.src", None, "has '-'"),
        ("2nd_stroke.src", None, "must start with a letter"),
        ("stroke-2.src", None, "has '-'"),
        ("a_very_long_program_name_indeed.src", None, "at most 24"),
        ("stroke.src", Some("other"), "must be its file's name"),
    ] {
        let output = dir.path().join(file);
        let mut args = vec![
            "export",
            "krl",
            path,
            "--robot",
            "kr6-r700",
            "--wobj",
            KUKA_WOBJ,
            "--tcp",
            KUKA_TCP,
            "-o",
            output.to_str().unwrap(),
        ];
        if let Some(name) = name {
            args.extend(["--name", name]);
        }
        let out = teachcam(&args);
        assert_eq!(out.status.code(), Some(2), "{file}");
        let err = text(&out.stderr);
        assert!(err.contains(says), "{file}: {err}");
        assert!(!output.exists() && !output.with_extension("dat").exists());
    }
    let good = dir.path().join("Stroke_2.src");
    let out = teachcam(&[
        "export",
        "krl",
        path,
        "--robot",
        "kr6-r700",
        "--wobj",
        KUKA_WOBJ,
        "--tcp",
        KUKA_TCP,
        "-o",
        good.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let src = std::fs::read_to_string(&good).unwrap();
    assert!(
        src.contains("DEF Stroke_2( )") && src.contains("PTP XP1"),
        "{src}"
    );
}

/// `--tool-mass` and `--tool-cog` set the load every dialect writes; without them the
/// program says the load was assumed.
#[test]
fn tool_load_is_written_as_given_or_said_to_be_assumed() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory, 1.0);
    let path = trajectory.to_str().unwrap();
    let module = dir.path().join("p.mod");
    let base = [
        "export",
        "rapid",
        path,
        "--wobj",
        WOBJ,
        "--tcp",
        TCP,
        "-o",
        module.to_str().unwrap(),
    ];
    assert!(teachcam(&base).status.success());
    let text_mod = std::fs::read_to_string(&module).unwrap();
    assert!(
        text_mod.contains("[0.200,[0.000,0.000,75.000]"),
        "{text_mod}"
    );
    assert!(text_mod.contains("assumed"));
    let mut given = base.to_vec();
    given.extend(["--tool-mass", "1.25", "--tool-cog", "0,-10,80"]);
    assert!(teachcam(&given).status.success());
    let text_mod = std::fs::read_to_string(&module).unwrap();
    assert!(
        text_mod.contains("[1.250,[0.000,-10.000,80.000]"),
        "{text_mod}"
    );
    assert!(text_mod.contains(", given."));
    let script = dir.path().join("p.script");
    let out = teachcam(&[
        "export",
        "urscript",
        path,
        "--robot",
        "ur5e",
        "--wobj",
        UR_WOBJ,
        "--tcp",
        TCP,
        "--tool-mass",
        "1.25",
        "--tool-cog",
        "0,-10,80",
        "-o",
        script.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let text_script = std::fs::read_to_string(&script).unwrap();
    assert!(
        text_script.contains("set_payload(1.250, [0.000000, -0.010000, 0.080000])"),
        "{text_script}"
    );
    let mut bad = base.to_vec();
    bad.extend(["--tool-cog", "1,2"]);
    let out = teachcam(&bad);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("--tool-cog"));
}

/// A robot given as a file (a UR5e's DH table) checks like the built-in one; a broken file is
/// refused naming it and the field; each maker's joints table has its configuration columns.
#[test]
fn robots_from_files_and_each_makers_joints_table() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory, 1.0);
    let path = trajectory.to_str().unwrap();
    let joint = r#"{"min_deg": -360, "max_deg": 360, "max_speed_deg_s": 180}"#;
    let robot = dir.path().join("arm.json");
    std::fs::write(
        &robot,
        format!(
            r#"{{"name": "my-ur5e", "maker": "ur", "dh": {{"d1_mm": 162.5, "a2_mm": -425,
            "a3_mm": -392.2, "d4_mm": 133.3, "d5_mm": 99.7, "d6_mm": 99.6}},
            "joints": [{joint}, {joint}, {joint}, {joint}, {joint}, {joint}]}}"#
        ),
    )
    .unwrap();
    let from_file = dir.path().join("file.csv");
    let builtin = dir.path().join("builtin.csv");
    for (name, out) in [(robot.to_str().unwrap(), &from_file), ("ur5e", &builtin)] {
        let o = teachcam(&[
            "check",
            path,
            "--robot",
            name,
            "--wobj",
            UR_WOBJ,
            "--tcp",
            TCP,
            "--joints-out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}{}", text(&o.stdout), text(&o.stderr));
    }
    let table = std::fs::read_to_string(&builtin).unwrap();
    assert_eq!(table, std::fs::read_to_string(&from_file).unwrap());
    assert!(
        table.starts_with(
            "frame,j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg,time_s,configuration,ok\n"
        )
    );
    let kuka = dir.path().join("kuka.csv");
    let o = teachcam(&[
        "check",
        path,
        "--robot",
        "kr6-r900",
        "--wobj",
        KUKA_WOBJ,
        "--tcp",
        KUKA_TCP,
        "--joints-out",
        kuka.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}{}", text(&o.stdout), text(&o.stderr));
    assert!(
        std::fs::read_to_string(&kuka)
            .unwrap()
            .starts_with("frame,j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg,time_s,s,t,ok\n")
    );
    std::fs::write(&robot, r#"{"name": "x", "maker": "ur", "joints": []}"#).unwrap();
    let o = teachcam(&["check", path, "--robot", robot.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let err = text(&o.stderr);
    assert!(err.contains("arm.json") && err.contains("\"dh\""), "{err}");
}

/// The `warning:` lines of a command's stderr.
fn warnings(o: &Output) -> Vec<String> {
    text(&o.stderr)
        .lines()
        .filter(|l| l.starts_with("warning: "))
        .map(str::to_string)
        .collect()
}

/// Issue 19: lengths likely given in metres (or micrometres) pass every format check, so the
/// commands that load them say so on one line naming the value: a TCP under 5 mm from the
/// flange, a tool's markers under 1 mm apart, a rig whose cameras all sit within 50 mm of the
/// origin or one beyond 50 m. Millimetre values, and the default TCP on the flange, say nothing.
#[test]
fn lengths_likely_in_the_wrong_unit_are_warned_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let trajectory = file("stroke.csv");
    write_stroke(Path::new(&trajectory), 1.0);

    // --tcp "0,0,0.15,...": the brush's 0.15 m given as metres.
    let metres_tcp = "0,0,0.15,1,0,0,0";
    let o = teachcam(&[
        "check",
        &trajectory,
        "--robot",
        "irb120",
        "--wobj",
        WOBJ,
        "--tcp",
        metres_tcp,
    ]);
    let w = warnings(&o);
    assert_eq!(w.len(), 1, "{}", text(&o.stderr));
    for word in ["0.15 mm from the flange", "under 5 mm", "metres", "0,0,200"] {
        assert!(w[0].contains(word), "{} lacks {word}", w[0]);
    }
    for tcp in [TCP, "0,0,0,1,0,0,0"] {
        let o = teachcam(&[
            "check",
            &trajectory,
            "--robot",
            "irb120",
            "--wobj",
            WOBJ,
            "--tcp",
            tcp,
        ]);
        assert!(warnings(&o).is_empty(), "--tcp {tcp}: {}", text(&o.stderr));
    }

    // A tool whose two markers are 0.6 mm apart (its others tens of millimetres away: a tool
    // wholly in metres is refused as collinear by the reader already).
    std::fs::write(
        file("tool_m.json"),
        r#"{"name": "brush", "marker_diameter_mm": 0.5,
            "markers": [[0, 0, 0], [0.6, 0, 0], [0, 70, 0], [30, 40, 20]], "tip": [0, 0, -180]}"#,
    )
    .unwrap();
    std::fs::write(
        file("tool.json"),
        r#"{"name": "brush", "marker_diameter_mm": 10,
            "markers": [[0, 0, 0], [50, 0, 0], [0, 70, 0], [30, 40, 20]], "tip": [0, 0, -180]}"#,
    )
    .unwrap();
    let o = teachcam(&["tool-check", &file("tool_m.json")]);
    let w = warnings(&o);
    assert_eq!(w.len(), 1, "{}", text(&o.stderr));
    for word in [
        "tool_m.json",
        "markers 0 and 1 are 0.6 mm apart",
        "under 1 mm",
        "metres",
    ] {
        assert!(w[0].contains(word), "{} lacks {word}", w[0]);
    }
    assert!(warnings(&teachcam(&["tool-check", &file("tool.json")])).is_empty());

    // Rigs: two cameras 1 m above the work object, given in mm, in metres and in micrometres.
    let rig = |name: &str, height: f64| {
        let camera = |n: usize, x: f64| {
            format!(
                r#"{{"name": "cam{n}", "image_size": [1280, 1024], "fx": 1791, "fy": 1791,
                    "cx": 639.5, "cy": 511.5, "distortion": [0, 0, 0, 0, 0],
                    "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "translation": [{x}, 0, {height}]}}"#
            )
        };
        let text = format!(
            r#"{{"units": "mm", "cameras": [{}, {}]}}"#,
            camera(0, 0.0),
            camera(1, -height / 4.0)
        );
        std::fs::write(file(name), text).unwrap();
        file(name)
    };
    let pose = "0,0,1000,1,0,0,0";
    for (name, height, words) in [
        (
            "rig_m.json",
            1.0,
            &[
                "rig_m.json",
                "within 1.031 mm of the world origin",
                "cam1",
                "metres",
            ][..],
        ),
        (
            "rig_um.json",
            1.0e9,
            &[
                "rig_um.json",
                "cam1's centre is 1030776.4 m",
                "over 50 m",
                "micrometres",
            ][..],
        ),
    ] {
        let rig = rig(name, height);
        let o = teachcam(&[
            "uncertainty",
            "--rig",
            &rig,
            "--tool",
            &file("tool.json"),
            "--pose",
            pose,
            "--trials",
            "10",
        ]);
        let w = warnings(&o);
        assert_eq!(w.len(), 1, "{name}: {}", text(&o.stderr));
        for word in words {
            assert!(w[0].contains(word), "{} lacks {word}", w[0]);
        }
    }
    let o = teachcam(&[
        "uncertainty",
        "--rig",
        &rig("rig.json", 1000.0),
        "--tool",
        &file("tool.json"),
        "--pose",
        "0,0,0,1,0,0,0",
        "--trials",
        "10",
    ]);
    assert!(warnings(&o).is_empty(), "{}", text(&o.stderr));
}

/// `teachcam replay PROGRAM --robot R --trajectory TRAJ --json`: the exit status and the JSON.
fn replay(program: &Path, robot: &str, trajectory: &Path) -> (Option<i32>, serde_json::Value) {
    let out = teachcam(&[
        "replay",
        program.to_str().unwrap(),
        "--robot",
        robot,
        "--trajectory",
        trajectory.to_str().unwrap(),
        "--json",
    ]);
    let json = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {} {}", text(&out.stdout), text(&out.stderr)));
    (out.status.code(), json)
}

/// Every program the exports above write (RAPID, KRL, URScript; the stroke at its own pace and
/// ten times faster, slowed by the time scale; the default and a coarser tolerance), played as
/// a controller would: no joint over 1.05 × its limit, and every demonstrated position within
/// the tolerance plus half the zone (the blend's largest corner cut, r/2; the zone is the
/// tolerance) of the played path. The replay exits 1 exactly when an axis is over its limit
/// (the time scale fits the frames the check measured; the controller interpolates between the
/// simplified targets, up to 1.2 % faster on the fast stroke).
#[test]
fn every_exported_program_replays_within_the_limits_and_the_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    for (name, pace) in [("stroke", 1.0), ("fast", 0.1)] {
        let trajectory = dir.path().join(format!("{name}.csv"));
        write_stroke(&trajectory, pace);
        for (dialect, robot, wobj, tcp, extension) in [
            ("rapid", "irb120", WOBJ, TCP, "mod"),
            ("krl", "kr6-r700", KUKA_WOBJ, KUKA_TCP, "src"),
            ("urscript", "ur5e", UR_WOBJ, TCP, "script"),
        ] {
            for tolerance in [0.5, 2.0] {
                let program = dir.path().join(format!("{name}_{dialect}.{extension}"));
                let out = teachcam(&[
                    "export",
                    dialect,
                    trajectory.to_str().unwrap(),
                    "--robot",
                    robot,
                    "--wobj",
                    wobj,
                    "--tcp",
                    tcp,
                    "--tolerance-mm",
                    &tolerance.to_string(),
                    "-o",
                    program.to_str().unwrap(),
                ]);
                assert!(out.status.success(), "{dialect}: {}", text(&out.stderr));
                let (status, json) = replay(&program, robot, &trajectory);
                let what = format!("{name} {dialect} {tolerance} mm: {json}");
                let peak = json["joints"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|j| j["ratio"].as_f64().unwrap())
                    .fold(0.0, f64::max);
                assert!(peak <= 1.05, "{what}");
                assert_eq!(json["unreachable_samples"], 0, "{what}");
                // Exit 1 exactly when an axis is over its limit.
                assert_eq!(status, Some(i32::from(peak > 1.0)), "{what}");
                let deviation = json["deviation_mm"]["max"].as_f64().unwrap();
                assert!(deviation <= 1.5 * tolerance + 0.01, "{what}");
                eprintln!(
                    "{name} {dialect} {tolerance} mm: {} moves, {:.2} s, peak {:.3} of the limit, deviation max {deviation:.3} mm",
                    json["moves"],
                    json["duration_s"].as_f64().unwrap(),
                    peak
                );
                assert_eq!(json["deviation_mm"]["points"], 120, "{what}");
            }
        }
    }
}
