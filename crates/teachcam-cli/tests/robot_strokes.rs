//! Strokes and trimming (issue 28): a take with two strokes and a lift between, written from a
//! closed-form path (the tip's height rises as `3 + 37 sin²(π (t − 1.5))` mm between 1.5 s
//! and 2.5 s, so it crosses the 10 mm lift at `1.5 + u` and `2.5 − u` s with
//! `u = asin(√(7/37)) / π`), the brush's orientation the simulator's painter's stroke.
//!
//! Checked: `strokes` splits within one frame of those crossings; the exported RAPID (parsed
//! here from its text) approaches and retracts each stroke along the tool's axis — two joint
//! moves onto approach poses, two linear moves off the paint — names both strokes, passes
//! rapidchecker and replays; `--from/--to` keeps the right frames; a span outside the take or
//! empty is a usage error naming the take's span; a take that never touches the surface has no
//! stroke (`strokes` exits 1 naming the tip's lowest height; `export` takes it whole, saying
//! so).

use std::f64::consts::PI;
use std::path::Path;

use nalgebra::{Quaternion, Translation3, UnitQuaternion, Vector3};
use teachcam::geometry::{FrameIndex, Point3, Pose, pose_from_parts};
use teachcam::io::trajectory::write_trajectory;
use teachcam::sim::scenario::painter_stroke;
use teachcam::trajectory::{Sample, ToolPose, Trajectory};

#[path = "support/run.rs"]
mod run;
use run::teachcam;

const WOBJ: &str = "350,0,100,1,0,0,0";
const TCP: &str = "0,0,200,0,1,0,0";
const FPS: f64 = 30.0;
/// Frames of the take: 4 s at 30 Hz.
const FRAMES: usize = 120;

/// The tip's height over the work surface at `t`, mm: 3 mm while painting, a lift between
/// 1.5 s and 2.5 s, `lift_top` mm at its top.
fn height(t: f64, lift_top: f64) -> f64 {
    if (1.5..=2.5).contains(&t) {
        3.0 + (lift_top - 3.0) * (PI * (t - 1.5)).sin().powi(2)
    } else {
        3.0
    }
}

/// When the lift crosses 10 mm on the way up and down, seconds.
fn crossings() -> (f64, f64) {
    let u = (7.0f64 / 37.0).sqrt().asin() / PI;
    (1.5 + u, 2.5 - u)
}

/// Writes the take: the tip moves along x at 40 mm/s with a sway in y, at `height + offset`.
fn write_take(path: &Path, offset: f64) {
    let samples = (0..FRAMES)
        .map(|k| {
            let t = k as f64 / FPS;
            let tip = Vector3::new(
                -80.0 + 40.0 * t,
                30.0 * (2.0 * PI * 0.3 * t).sin(),
                height(t, 40.0) + offset,
            );
            let pose = pose_from_parts(tip, painter_stroke(t).rotation);
            Sample::measured(
                FrameIndex(k),
                t,
                ToolPose {
                    world_from_tool: pose,
                    tip_in_world: Point3::from(tip),
                    markers: 4,
                    rms_mm: 0.05,
                },
            )
        })
        .collect();
    write_trajectory(path, &Trajectory { samples }).unwrap();
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn json(bytes: &[u8]) -> serde_json::Value {
    serde_json::from_slice(bytes).unwrap_or_else(|e| panic!("{e}: {}", text(bytes)))
}

/// Every number in `text`.
fn numbers(text: &str) -> Vec<f64> {
    text.split(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'e' | 'E')))
        .filter_map(|t| t.parse::<f64>().ok())
        .collect()
}

/// A RAPID module's moves in order: (instruction, target pose in the work object) and the
/// comments naming strokes.
fn rapid_moves(module: &str) -> (Vec<(String, Pose)>, Vec<String>) {
    let mut targets = std::collections::HashMap::new();
    let mut moves = Vec::new();
    let mut strokes = Vec::new();
    for line in module.lines().map(str::trim) {
        if let Some(rest) = line.strip_prefix("CONST robtarget ") {
            let (name, value) = rest.split_once(":=").unwrap();
            let v = numbers(value);
            let pose = Pose::from_parts(
                Translation3::new(v[0], v[1], v[2]),
                UnitQuaternion::from_quaternion(Quaternion::new(v[3], v[4], v[5], v[6])),
            );
            targets.insert(name.trim().to_string(), pose);
        } else if line.starts_with("MoveJ ") || line.starts_with("MoveL ") {
            let name = line[6..].split(',').next().unwrap().trim();
            moves.push((line[..5].to_string(), targets[name]));
        } else if line.starts_with("! Stroke") {
            strokes.push(line.to_string());
        }
    }
    (moves, strokes)
}

/// How far `to` lies from `from` along `from`'s tool axis, and across it.
fn along_tool_axis(from: &Pose, to: &Pose) -> (f64, f64) {
    let d = to.translation.vector - from.translation.vector;
    let axis = from.rotation * Vector3::z();
    let along = d.dot(&axis);
    (along, (d - axis * along).norm())
}

#[test]
fn two_strokes_are_split_at_the_lift_approached_and_retracted_each() {
    let dir = tempfile::tempdir().unwrap();
    let take = dir.path().join("two.csv");
    write_take(&take, 0.0);
    let take_arg = take.to_str().unwrap();

    // The split, within one frame of the constructed crossings.
    let out = teachcam(&["strokes", take_arg, "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let listed = json(&out.stdout);
    let strokes = listed["strokes"].as_array().unwrap();
    assert_eq!(strokes.len(), 2, "{listed}");
    let (up, down) = crossings();
    let frame = 1.0 / FPS;
    let end_1 = strokes[0]["end_s"].as_f64().unwrap();
    let start_2 = strokes[1]["start_s"].as_f64().unwrap();
    assert!(
        (end_1 - up).abs() <= frame,
        "stroke 1 ends at {end_1} s, lift at {up} s"
    );
    assert!(
        (start_2 - down).abs() <= frame,
        "stroke 2 starts at {start_2} s, down at {down} s"
    );
    assert_eq!(strokes[0]["first_frame"], 0);
    assert_eq!(strokes[1]["last_frame"], FRAMES - 1);
    assert_eq!(strokes[0]["ends"], "lift");
    // 40 mm/s along x with the sway's y speed (at most 2π·0.3·30 ≈ 57 mm/s): the mean is
    // between the two.
    let mean = strokes[0]["mean_speed_mm_s"].as_f64().unwrap();
    assert!((40.0..75.0).contains(&mean), "{mean}");
    let listing = teachcam(&["strokes", take_arg]);
    assert!(text(&listing.stdout).contains("mean_speed_mm_s"));

    // The program: each stroke approached by a joint move and left linearly, along the axis.
    let module = dir.path().join("two.mod");
    let out = teachcam(&[
        "export",
        "rapid",
        take_arg,
        "--robot",
        "irb120",
        "--wobj",
        WOBJ,
        "--tcp",
        TCP,
        "-o",
        module.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let program = std::fs::read_to_string(&module).unwrap();
    let (moves, comments) = rapid_moves(&program);
    assert!(
        comments[0].starts_with("! Stroke 1 of 2: frames 0-"),
        "{program}"
    );
    assert!(
        comments[1].starts_with("! Stroke 2 of 2: frames "),
        "{program}"
    );
    assert_eq!(comments.len(), 2, "{program}");
    let joint_moves: Vec<usize> = (0..moves.len())
        .filter(|&i| moves[i].0 == "MoveJ")
        .collect();
    assert_eq!(joint_moves.len(), 2, "{program}");
    let mut approaches = 0;
    for &i in &joint_moves {
        // The joint move goes above the next (paint) point, along its tool axis, same tool
        // orientation.
        let (lift, across) = along_tool_axis(&moves[i + 1].1, &moves[i].1);
        assert!(
            lift >= 20.0 && across < 0.01,
            "approach {i}: {lift} mm along, {across} across"
        );
        assert!(moves[i + 1].1.rotation.angle_to(&moves[i].1.rotation) < 1e-6);
        assert!(moves[i + 1].1.translation.vector.z <= 10.0);
        approaches += 1;
    }
    // Retracts: linear moves straight up the tool's axis by 20 mm or more off a paint point.
    let retracts: Vec<usize> = (1..moves.len())
        .filter(|&i| {
            let (lift, across) = along_tool_axis(&moves[i - 1].1, &moves[i].1);
            moves[i].0 == "MoveL" && lift >= 20.0 && across < 0.01
        })
        .collect();
    assert_eq!(approaches, 2);
    assert_eq!(retracts.len(), 2, "{program}");
    assert_eq!(retracts[1], moves.len() - 1, "the last move retracts");
    assert_eq!(
        retracts[0] + 1,
        joint_moves[1],
        "stroke 1's retract precedes stroke 2's approach"
    );
    // Between the strokes nothing paints the lift: every paint point is on the surface.
    for (i, (_, pose)) in moves.iter().enumerate() {
        if !joint_moves.contains(&i) && !retracts.contains(&i) {
            assert!(pose.translation.vector.z <= 10.0, "move {i} at {pose:?}");
        }
    }
    if let Some(Err(output)) =
        teachcam_testdata::rapidchecker("robot_strokes", std::slice::from_ref(&module))
    {
        panic!("rapidchecker refuses the module: {output}");
    }
    let replay = teachcam(&["replay", module.to_str().unwrap(), "--robot", "irb120"]);
    assert!(
        replay.status.success(),
        "{}{}",
        text(&replay.stdout),
        text(&replay.stderr)
    );
}

#[test]
fn from_and_to_trim_to_the_frames_of_the_span() {
    let dir = tempfile::tempdir().unwrap();
    let take = dir.path().join("two.csv");
    write_take(&take, 0.0);
    let take_arg = take.to_str().unwrap();
    let out = teachcam(&[
        "strokes", take_arg, "--from", "0.5", "--to", "3.0", "--json",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let listed = json(&out.stdout);
    let strokes = listed["strokes"].as_array().unwrap();
    assert_eq!(strokes[0]["first_frame"], 15);
    assert_eq!(strokes[strokes.len() - 1]["last_frame"], 90);
    // check's joints: the strokes' frames within the span.
    let joints = dir.path().join("joints.csv");
    let out = teachcam(&[
        "check",
        take_arg,
        "--robot",
        "irb120",
        "--wobj",
        WOBJ,
        "--tcp",
        TCP,
        "--from",
        "0.5",
        "--to",
        "3.0",
        "--joints-out",
        joints.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let rows: Vec<usize> = std::fs::read_to_string(&joints)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    let (up, down) = crossings();
    let expected: Vec<usize> = (15..=90)
        .filter(|&k| {
            let t = k as f64 / FPS;
            height(t, 40.0) <= 10.0 && !(up < t && t < down)
        })
        .collect();
    assert_eq!(rows, expected);

    // Bad spans: a usage error naming the take's span.
    for bad in [
        &["--from", "3", "--to", "2"][..],
        &["--to", "9"],
        &["--from", "-1"],
    ] {
        let mut args = vec!["strokes", take_arg];
        args.extend_from_slice(bad);
        let out = teachcam(&args);
        assert_eq!(out.status.code(), Some(2), "{bad:?}: {}", text(&out.stderr));
        let stderr = text(&out.stderr);
        assert!(stderr.contains("runs 0.000-3.967 s"), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        let mut export = vec!["export", "rapid", take_arg, "-o"];
        let module = dir.path().join("bad.mod");
        export.push(module.to_str().unwrap());
        export.extend_from_slice(bad);
        assert_eq!(teachcam(&export).status.code(), Some(2));
        assert!(!module.exists());
    }
}

#[test]
fn a_take_that_never_touches_the_surface_has_no_stroke() {
    let dir = tempfile::tempdir().unwrap();
    let take = dir.path().join("high.csv");
    // Everything 50 mm higher: the lowest point is 53 mm above the surface.
    write_take(&take, 50.0);
    let take_arg = take.to_str().unwrap();
    let out = teachcam(&["strokes", take_arg]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = text(&out.stderr);
    assert!(stderr.contains("lowest height is 53.0 mm"), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    let module = dir.path().join("high.mod");
    let out = teachcam(&[
        "export",
        "rapid",
        take_arg,
        "--robot",
        "irb120",
        "--wobj",
        WOBJ,
        "--tcp",
        TCP,
        "-o",
        module.to_str().unwrap(),
    ]);
    // export and check take such a take whole (a world whose xy-plane is not the surface),
    // saying so.
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("warning: no stroke") && stderr.contains("lowest height is 53.0 mm"),
        "{stderr}"
    );
    let program = std::fs::read_to_string(&module).unwrap();
    let (moves, comments) = rapid_moves(&program);
    assert_eq!(comments.len(), 1, "{program}");
    assert!(
        comments[0].starts_with("! Stroke 1 of 1: frames 0-119"),
        "{program}"
    );
    assert_eq!(moves.iter().filter(|m| m.0 == "MoveJ").count(), 1);
    // A lift threshold above the take finds it one stroke.
    let out = teachcam(&["strokes", take_arg, "--lift-mm", "100", "--json"]);
    assert!(out.status.success());
    assert_eq!(json(&out.stdout)["strokes"].as_array().unwrap().len(), 1);
}

/// An axisymmetric brush spinning 900° about its own axis over 3 s: axis 6 of the IRB 120
/// (±400°) cannot follow; with the roll free (`--free-tool-axis`) the program is written and
/// says so in its header, and its targets keep the tip and the tool's axis.
#[test]
fn a_free_tool_axis_exports_a_spin_axis_6_cannot_follow() {
    let dir = tempfile::tempdir().unwrap();
    let take = dir.path().join("spin.csv");
    let poses: Vec<Pose> = (0..90)
        .map(|k| {
            let t = k as f64 / FPS;
            let axis = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 20f64.to_radians())
                * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -25f64.to_radians());
            let spin =
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), (300.0 * t).to_radians());
            pose_from_parts(Vector3::new(-40.0 + 80.0 * t / 3.0, 0.0, 3.0), axis * spin)
        })
        .collect();
    let samples = poses
        .iter()
        .enumerate()
        .map(|(k, pose)| {
            Sample::measured(
                FrameIndex(k),
                k as f64 / FPS,
                ToolPose {
                    world_from_tool: *pose,
                    tip_in_world: Point3::from(pose.translation.vector),
                    markers: 4,
                    rms_mm: 0.05,
                },
            )
        })
        .collect();
    write_trajectory(&take, &Trajectory { samples }).unwrap();
    let module = dir.path().join("spin.mod");
    let mut args = vec![
        "export",
        "rapid",
        take.to_str().unwrap(),
        "--robot",
        "irb120",
        "--wobj",
        WOBJ,
        "--tcp",
        TCP,
        "-o",
        module.to_str().unwrap(),
    ];
    let out = teachcam(&args);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stdout));
    assert!(
        text(&out.stdout).contains("axis 6 outside its range"),
        "{}",
        text(&out.stdout)
    );
    assert!(!module.exists());
    args.push("--free-tool-axis");
    let out = teachcam(&args);
    assert!(
        out.status.success(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    let program = std::fs::read_to_string(&module).unwrap();
    assert!(
        program.contains("! tool axis free: roll chosen per frame, range "),
        "{program}"
    );
    // Every paint target: on the demonstrated tip and tool axis (to the literals' 0.001 mm
    // and 1e-7), its roll chosen.
    let (moves, _) = rapid_moves(&program);
    let mut turned: f64 = 0.0;
    for (_, pose) in moves.iter().filter(|(_, p)| p.translation.vector.z < 10.0) {
        let nearest = poses
            .iter()
            .min_by(|a, b| {
                let d = |p: &Pose| (p.translation.vector - pose.translation.vector).norm();
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        assert!((nearest.translation.vector - pose.translation.vector).norm() < 0.002);
        let axis = |p: &Pose| p.rotation * Vector3::z();
        assert!((axis(nearest) - axis(pose)).norm() < 1e-6);
        turned = turned.max(nearest.rotation.angle_to(&pose.rotation));
    }
    assert!(turned > 1f64.to_radians());
    if let Some(Err(output)) =
        teachcam_testdata::rapidchecker("robot_strokes", std::slice::from_ref(&module))
    {
        panic!("rapidchecker refuses the module: {output}");
    }
}
