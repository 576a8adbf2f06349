//! Robot stage: kinematics against independent numbers and laws, the check on closed-form
//! strokes (reachable, too far, too fast), programs read back, frames and pivot calibration.

use std::f64::consts::{PI, TAU};
use std::path::PathBuf;

use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;
use teachcam::geometry::{FrameIndex, Point3, Pose, pose_from_parts};
use teachcam::robot::check::{CheckConfig, FrameIssue, Suggestion, check_path};
use teachcam::robot::frames::{FramesError, PivotConfig, align_frames, pivot_calibration};
use teachcam::robot::kinematics::{
    Joints, Robot, confdata, configuration_of, forward, inverse, inverse_within_limits,
};
use teachcam::robot::program::build_program;
use teachcam::robot::rapid::{RapidConfig, rapid_module};
use teachcam::robot::simplify::{SimplifyConfig, simplify};
use teachcam::robot::{Cell, TcpTarget, tcp_targets};
use teachcam::trajectory::{Sample, ToolPose, Trajectory};

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/robot")
}

fn assert_pose_near(a: &Pose, b: &Pose, position_mm: f64, angle_rad: f64, what: &str) {
    let dp = (a.translation.vector - b.translation.vector).norm();
    let da = a.rotation.angle_to(&b.rotation);
    assert!(
        dp <= position_mm && da <= angle_rad,
        "{what}: {dp:.3e} mm, {da:.3e} rad apart"
    );
}

// ---------------------------------------------------------------------------------------------
// Kinematics

#[test]
fn irb120_parameters_match_abbs_product_specification() {
    let m = Robot::irb120();
    let teachcam::robot::kinematics::Arm::SphericalWrist(p) = m.arm else {
        panic!("the IRB 120 has a spherical wrist");
    };
    // 3HAC035960-001, dimension drawing: 290 / 270 / 70 / 302 / 72 mm.
    assert_eq!(
        [p.c1, p.a1, p.c2, -p.a2, p.c3, p.c4],
        [290.0, 0.0, 270.0, 70.0, 302.0, 72.0]
    );
    let ranges: Vec<(f64, f64, f64)> = m
        .limits
        .iter()
        .map(|l| {
            (
                l.min.to_degrees().round(),
                l.max.to_degrees().round(),
                l.max_speed.to_degrees().round(),
            )
        })
        .collect();
    assert_eq!(
        ranges,
        vec![
            (-165.0, 165.0, 250.0),
            (-110.0, 110.0, 250.0),
            (-110.0, 70.0, 250.0),
            (-160.0, 160.0, 320.0),
            (-120.0, 120.0, 320.0),
            (-400.0, 400.0, 420.0)
        ]
    );
    // The data sheet's reach (580 mm) is axis 2 to the wrist centre, arm stretched.
    assert!(
        (m.max_wrist_reach() - 580.0).abs() < 1.0,
        "{}",
        m.max_wrist_reach()
    );
}

#[derive(serde::Deserialize)]
struct FkReference {
    poses: Vec<FkPose>,
}

#[derive(serde::Deserialize)]
struct FkPose {
    joints_deg: [f64; 6],
    position_mm: [f64; 3],
    quaternion_wxyz: [f64; 4],
}

/// Forward kinematics against the ROS-Industrial URDF chain evaluated by SciPy (and
/// cross-checked there against a DH table): `scripts/reference/irb120_fk.py`.
#[test]
fn forward_kinematics_matches_the_urdf_reference() {
    let text = std::fs::read_to_string(data_dir().join("irb120_fk.json")).unwrap();
    let reference: FkReference = serde_json::from_str(&text).unwrap();
    assert!(reference.poses.len() >= 40);
    let model = Robot::irb120();
    for (i, p) in reference.poses.iter().enumerate() {
        let pose = forward(&model, &Joints::from_degrees(p.joints_deg));
        let [w, x, y, z] = p.quaternion_wxyz;
        let expected = pose_from_parts(
            Vector3::from(p.position_mm),
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z)),
        );
        // Float64 chains of six transforms: 1e-9 mm and 1e-12 rad are far above rounding.
        assert_pose_near(&pose, &expected, 1e-9, 1e-12, &format!("pose {i}"));
    }
}

fn joints_strategy() -> impl Strategy<Value = Joints> {
    let m = Robot::irb120();
    let l = m.limits;
    (
        l[0].min..l[0].max,
        l[1].min..l[1].max,
        l[2].min..l[2].max,
        l[3].min..l[3].max,
        l[4].min..l[4].max,
        l[5].min..l[5].max,
    )
        .prop_map(|(a, b, c, d, e, f)| Joints([a, b, c, d, e, f]))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// FK∘IK: every solution reproduces the pose, and the joints that made it are among the
    /// solutions within limits (up to full turns of axis 6). Away from the singularities
    /// (|sin q5| > 1e-3, wrist centre off axis 1, elbow not stretched) where they are unique.
    #[test]
    fn inverse_kinematics_round_trips(joints in joints_strategy()) {
        let model = Robot::irb120();
        prop_assume!(joints.0[4].sin().abs() > 1e-3);
        let wrist = teachcam::robot::kinematics::wrist_centre(&model, &joints);
        prop_assume!(wrist.x.hypot(wrist.y) > 1.0);
        let pose = forward(&model, &joints);
        let all = inverse(&model, &pose);
        prop_assert!(!all.is_empty());
        for s in &all {
            let again = forward(&model, &s.joints);
            let dp = (again.translation.vector - pose.translation.vector).norm();
            let da = again.rotation.angle_to(&pose.rotation);
            prop_assert!(dp < 1e-7 && da < 1e-9, "solution {:?}: {dp} mm {da} rad", s.joints);
            prop_assert_eq!(configuration_of(&model, &s.joints), s.configuration);
        }
        let within = inverse_within_limits(&model, &pose);
        let found = within.iter().any(|s| {
            (0..6).all(|i| (s.joints.0[i] - joints.0[i]).abs() < 1e-6)
        });
        prop_assert!(found, "original joints {:?} not among {} solutions", joints, within.len());
    }
}

#[test]
fn a_generic_pose_has_eight_solutions_in_distinct_configurations() {
    let model = Robot::irb120();
    let joints = Joints::from_degrees([20.0, 10.0, -20.0, 30.0, 40.0, 50.0]);
    let all = inverse(&model, &forward(&model, &joints));
    assert_eq!(all.len(), 8);
    let mut configurations: Vec<i32> = all
        .iter()
        .map(|s| confdata(&s.joints, &s.configuration).cfx)
        .collect();
    configurations.sort_unstable();
    assert_eq!(configurations, (0..8).collect::<Vec<_>>());
}

#[test]
fn confdata_follows_abbs_quadrants() {
    let model = Robot::irb120();
    let joints = Joints::from_degrees([100.0, 0.0, 0.0, -10.0, 30.0, 185.0]);
    let c = confdata(&joints, &configuration_of(&model, &joints));
    assert_eq!((c.cf1, c.cf4, c.cf6, c.cfx), (1, -1, 2, 0));
    let flipped = Joints::from_degrees([-30.0, 0.0, 0.0, 0.0, -30.0, -45.0]);
    let c = confdata(&flipped, &configuration_of(&model, &flipped));
    assert_eq!((c.cf1, c.cf4, c.cf6, c.cfx), (-1, 0, -1, 1));
}

#[test]
fn out_of_reach_pose_has_no_solution() {
    let model = Robot::irb120();
    let far = pose_from_parts(Vector3::new(800.0, 0.0, 300.0), UnitQuaternion::identity());
    assert!(inverse(&model, &far).is_empty());
}

// ---------------------------------------------------------------------------------------------
// Closed-form strokes

/// The brush of CONTRACT.md: tip at (0, -15, -180) in the tool frame.
fn tool_from_tcp() -> Pose {
    pose_from_parts(Vector3::new(0.0, -15.0, -180.0), UnitQuaternion::identity())
}

/// A painter's stroke as sums of sinusoids (the paper's model), `seconds` long at 30 Hz:
/// tip within ±70 mm of the work object's origin, brush pointing down, tilting by up to 12°.
fn stroke(seconds: f64, time_scale: f64) -> Trajectory {
    let frames = (seconds * 30.0).round() as usize;
    let samples = (0..frames)
        .map(|k| {
            let t = k as f64 / 30.0;
            let tip = Vector3::new(
                60.0 * (TAU * 0.4 * t).sin() + 10.0 * (TAU * 1.3 * t + 0.3).sin(),
                40.0 * (TAU * 0.25 * t + 1.0).sin(),
                15.0 + 8.0 * (TAU * 0.7 * t).sin(),
            );
            let tilt = UnitQuaternion::from_euler_angles(
                0.2 * (TAU * 0.3 * t).sin(),
                0.15 * (TAU * 0.45 * t + 0.5).sin(),
                0.5 * (TAU * 0.2 * t).sin(),
            );
            let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI);
            let world_from_tcp = pose_from_parts(tip, tilt * down);
            let world_from_tool = world_from_tcp * tool_from_tcp().inverse();
            Sample::measured(
                FrameIndex(k),
                t * time_scale,
                ToolPose {
                    world_from_tool,
                    tip_in_world: Point3::from(tip),
                    markers: 4,
                    rms_mm: 0.05,
                },
            )
        })
        .collect();
    Trajectory { samples }
}

/// The work object 350 mm in front of the IRB 120 at 150 mm height, the brush 150 mm out
/// of the flange.
fn cell() -> Cell {
    Cell {
        base_from_wobj: pose_from_parts(
            Vector3::new(350.0, 0.0, 150.0),
            UnitQuaternion::identity(),
        ),
        flange_from_tcp: pose_from_parts(Vector3::new(0.0, 0.0, 150.0), UnitQuaternion::identity()),
    }
}

fn targets(trajectory: &Trajectory) -> Vec<TcpTarget> {
    tcp_targets(trajectory, &UnitQuaternion::identity())
}

#[test]
fn targets_are_the_tip_with_the_tools_orientation() {
    let trajectory = stroke(2.0, 1.0);
    for (sample, target) in trajectory.samples.iter().zip(targets(&trajectory)) {
        let pose = sample.pose.unwrap();
        let expected = pose.world_from_tool * tool_from_tcp();
        assert_pose_near(&target.wobj_from_tcp, &expected, 1e-9, 1e-12, "target");
    }
}

#[test]
fn reachable_stroke_passes_and_its_joints_reproduce_every_target() {
    let model = Robot::irb120();
    let cell = cell();
    let trajectory = stroke(6.0, 1.0);
    let targets = targets(&trajectory);
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    let failing: Vec<String> = report
        .failing()
        .take(3)
        .map(|f| format!("{:?}", f.issues))
        .collect();
    assert!(report.passes(), "{failing:?}");
    assert!(report.suggestions.is_empty());
    assert!(report.peak_speed_ratio > 0.01 && report.peak_speed_ratio < 1.0);
    // Against the allowed speed: the data sheet's times the speed fraction.
    let fraction = CheckConfig::default().speed_fraction;
    let peak_ratio = (0..6)
        .map(|i| report.peak_joint_speed[i] / (model.limits[i].max_speed * fraction))
        .fold(0.0, f64::max);
    assert!((peak_ratio - report.peak_speed_ratio).abs() < 1e-12);
    // Accelerations are the differences of speeds: bounded by twice the peak speed over a
    // frame interval, and non-zero for a moving path.
    for i in 0..6 {
        let a = report.peak_joint_acceleration[i];
        assert!(a > 0.0 && a <= 2.0 * report.peak_joint_speed[i] * 30.0 + 1e-9);
    }
    // The contract's law on the written table: base_from_flange(joints) * flange_from_tcp
    // = base_from_wobj * wobj_from_tcp, joints read back from the CSV text (6 decimals of a
    // degree: 1.7e-8 rad, i.e. about 1e-5 mm at 600 mm).
    let csv = teachcam::robot::table::joints_csv(&report);
    let mut lines = csv.lines();
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with("frame,j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg")
    );
    let mut rows = 0;
    let mut cfx = None;
    for (line, target) in lines.zip(&targets) {
        let fields: Vec<&str> = line.split(',').collect();
        assert_eq!(fields[0].parse::<usize>().unwrap(), target.frame.0);
        let degrees: Vec<f64> = fields[1..7].iter().map(|f| f.parse().unwrap()).collect();
        let joints = Joints::from_degrees(degrees.try_into().unwrap());
        let left = forward(&model, &joints) * cell.flange_from_tcp;
        let right = cell.base_from_wobj * target.wobj_from_tcp;
        assert_pose_near(
            &left,
            &right,
            1e-3,
            1e-6,
            &format!("frame {}", target.frame.0),
        );
        // One configuration along the whole path.
        let this = fields[11].to_string();
        assert_eq!(cfx.get_or_insert(this.clone()), &this);
        rows += 1;
    }
    assert_eq!(rows, targets.len());
}

#[test]
fn too_far_stroke_is_reported_frame_by_frame_with_a_verified_move() {
    let model = Robot::irb120();
    let mut cell = cell();
    cell.base_from_wobj.translation.vector.x = 560.0;
    let targets = targets(&stroke(4.0, 1.0));
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    assert!(!report.passes());
    // The arm reaches 580 mm from axis 2 to its wrist centre, which sits 150 + 72 mm above
    // the tip here: tips beyond about x = 580 - ... are out of reach, so some frames are and
    // some are not.
    let unreachable = report.unreachable_count();
    assert!(
        unreachable > 0 && unreachable < targets.len(),
        "{unreachable}"
    );
    for f in report.frames.iter().filter(|f| f.joints.is_none()) {
        assert!(
            f.issues
                .iter()
                .any(|i| matches!(i, FrameIssue::OutOfReach | FrameIssue::OutsideLimits { .. })),
            "frame {} {:?}",
            f.target.frame.0,
            f.issues
        );
    }
    let Some(Suggestion::UseWorkObject { base_from_wobj, .. }) =
        report.suggestions.first().copied()
    else {
        panic!("no work-object suggestion: {:?}", report.suggestions);
    };
    let by_in_base = base_from_wobj.translation.vector - cell.base_from_wobj.translation.vector;
    assert!(by_in_base.x < 0.0, "{by_in_base:?}");
    assert!(
        (base_from_wobj
            .rotation
            .angle_to(&cell.base_from_wobj.rotation))
            < 1e-12,
        "the nearest fix turned the work object"
    );
    cell.base_from_wobj = base_from_wobj;
    let moved = check_path(&model, &cell, &targets, &CheckConfig::default());
    assert_eq!(moved.unreachable_count(), 0);
}

#[test]
fn too_fast_stroke_fails_and_the_suggested_slowdown_passes() {
    let model = Robot::irb120();
    let cell = cell();
    // The stroke played 8 times faster.
    let fast = targets(&stroke(4.0, 1.0 / 8.0));
    let recorded = CheckConfig {
        time_scale: teachcam::robot::check::TimeScale::Fixed(1.0),
        ..CheckConfig::default()
    };
    let report = check_path(&model, &cell, &fast, &recorded);
    assert!(!report.passes());
    assert!(report.frames.iter().any(|f| {
        f.issues
            .iter()
            .any(|i| matches!(i, FrameIssue::TooFast { .. }))
    }));
    let Some(Suggestion::SlowDown { factor }) = report.suggestions.first().copied() else {
        panic!("no slow-down suggestion: {:?}", report.suggestions);
    };
    assert!(factor > 1.0 && factor < 8.0, "{factor}");
    // Speeds scale with 1/factor exactly (same joints, times stretched).
    let slowed: Vec<TcpTarget> = fast
        .iter()
        .map(|t| TcpTarget {
            time_s: t.time_s * factor,
            ..*t
        })
        .collect();
    let again = check_path(&model, &cell, &slowed, &recorded);
    assert!(again.passes(), "peak {}", again.peak_speed_ratio);
    // The default (auto) slows by that factor itself.
    let auto = check_path(&model, &cell, &fast, &CheckConfig::default());
    assert!(auto.passes());
    assert!(
        (auto.timing.factor - factor).abs() < 1e-9,
        "{:?}",
        auto.timing
    );
    assert!(again.peak_speed_ratio > 0.98, "{}", again.peak_speed_ratio);
}

#[test]
fn wrist_singularity_is_reported() {
    let model = Robot::irb120();
    // A TCP whose flange keeps axis 5 at zero: the flange along base x, forearm horizontal.
    let joints = Joints::from_degrees([0.0, 10.0, 0.0, 0.0, 1.0, 0.0]);
    let base_from_flange = forward(&model, &joints);
    let cell = Cell::default();
    let targets = vec![TcpTarget {
        frame: FrameIndex(0),
        time_s: 0.0,
        wobj_from_tcp: base_from_flange,
    }];
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    assert!(report.passes());
    assert_eq!(report.near_singular_count(), 1);
}

// ---------------------------------------------------------------------------------------------
// Simplification and programs

#[test]
fn simplified_path_keeps_every_target_within_tolerance() {
    let targets = targets(&stroke(6.0, 1.0));
    let config = SimplifyConfig::default();
    let kept = simplify(&targets, &config);
    assert_eq!(kept.first(), Some(&0));
    assert_eq!(kept.last(), Some(&(targets.len() - 1)));
    assert!(
        kept.len() < targets.len() / 2,
        "{} of {}",
        kept.len(),
        targets.len()
    );
    // Measured here, not by the simplifier's own `relative_error`: each dropped target's
    // distance in mm from the straight segment between the kept targets around it (the
    // robot's linear move), and its angle from the nearest orientation on the geodesic
    // between their orientations (sampled every 0.1 %: at most the angle the robot's slerp
    // leaves).
    let mut farthest_mm: f64 = 0.0;
    let mut farthest_deg: f64 = 0.0;
    for pair in kept.windows(2) {
        let (start, end) = (
            &targets[pair[0]].wobj_from_tcp,
            &targets[pair[1]].wobj_from_tcp,
        );
        let (a, b) = (start.translation.vector, end.translation.vector);
        for target in &targets[pair[0] + 1..pair[1]] {
            let p = target.wobj_from_tcp.translation.vector;
            let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
            farthest_mm = farthest_mm.max((a + (b - a) * t - p).norm());
            let nearest = (0..=1000)
                .map(|i| {
                    let turned = start.rotation.slerp(&end.rotation, f64::from(i) / 1000.0);
                    turned.angle_to(&target.wobj_from_tcp.rotation)
                })
                .fold(f64::INFINITY, f64::min);
            farthest_deg = farthest_deg.max(nearest.to_degrees());
        }
    }
    println!(
        "{} of {} targets kept; farthest dropped target {farthest_mm:.4} mm, {farthest_deg:.4} deg off the moves",
        kept.len(),
        targets.len()
    );
    assert!(
        farthest_mm <= config.position_tolerance + 1e-9,
        "{farthest_mm} mm"
    );
    assert!(
        farthest_deg <= config.orientation_tolerance.to_degrees() + 1e-6,
        "{farthest_deg} deg"
    );
    // A straight line at constant orientation collapses to its two ends.
    let line: Vec<TcpTarget> = (0..100)
        .map(|k| TcpTarget {
            frame: FrameIndex(k),
            time_s: k as f64 / 30.0,
            wobj_from_tcp: pose_from_parts(
                Vector3::new(k as f64, 2.0 * k as f64, 0.0),
                UnitQuaternion::identity(),
            ),
        })
        .collect();
    assert_eq!(simplify(&line, &config), vec![0, 99]);
}

/// Reads `CONST robtarget name := [[x,y,z],[q1,q2,q3,q4],[cf...],[...]];` lines back.
#[expect(
    clippy::unwrap_used,
    reason = "test helper: a malformed line fails the test"
)]
fn robtargets(module: &str) -> Vec<(Pose, [i32; 4])> {
    module
        .lines()
        .filter(|l| l.trim_start().starts_with("CONST robtarget"))
        .map(|l| {
            let value = l.split(":=").nth(1).unwrap();
            let numbers: Vec<f64> = value
                .replace(['[', ']', ';'], "")
                .split(',')
                .map(|v| v.trim().parse::<f64>().unwrap())
                .collect();
            let pose = pose_from_parts(
                Vector3::new(numbers[0], numbers[1], numbers[2]),
                UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                    numbers[3], numbers[4], numbers[5], numbers[6],
                )),
            );
            let conf = [7, 8, 9, 10].map(|i| numbers[i] as i32);
            (pose, conf)
        })
        .collect()
}

#[test]
fn rapid_targets_equal_the_tcp_poses_and_the_checked_configuration() {
    let model = Robot::irb120();
    let cell = cell();
    let targets = targets(&stroke(6.0, 1.0));
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    let program = build_program("stroke", &cell, &report, &SimplifyConfig::default());
    let module = rapid_module(&program, &RapidConfig::default());
    let written = robtargets(&module);
    assert_eq!(written.len(), program.moves.len());
    for ((pose, conf), m) in written.iter().zip(&program.moves) {
        let frame = m.target.frame.0;
        // Done-when criterion: 0.01 mm and 0.001°.
        assert_pose_near(
            pose,
            &targets[frame].wobj_from_tcp,
            0.01,
            0.001f64.to_radians(),
            &format!("frame {frame}"),
        );
        let f = &report.frames[frame];
        let c = confdata(&f.joints.unwrap(), &f.configuration.unwrap());
        assert_eq!(*conf, [c.cf1, c.cf4, c.cf6, c.cfx]);
    }
    // Every move's speed reproduces its recorded duration.
    for pair in program.moves.windows(2) {
        let d = (pair[1].target.wobj_from_tcp.translation.vector
            - pair[0].target.wobj_from_tcp.translation.vector)
            .norm();
        let dt = pair[1].target.time_s - pair[0].target.time_s;
        assert!((d / pair[1].tcp_speed - dt).abs() < 1e-9 || d < 1e-6);
    }
    assert!(module.starts_with("MODULE stroke\n") && module.ends_with("ENDMODULE\n"));
    assert_eq!(module.matches("MoveL ").count(), program.moves.len() - 1);
}

#[test]
fn long_rapid_programs_are_split_into_routines() {
    let model = Robot::irb120();
    let cell = cell();
    let targets = targets(&stroke(6.0, 1.0));
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    let tight = SimplifyConfig {
        position_tolerance: 0.001,
        orientation_tolerance: 1e-6,
    };
    let program = build_program("stroke", &cell, &report, &tight);
    assert_eq!(program.moves.len(), targets.len());
    let config = RapidConfig {
        max_moves_per_routine: 50,
    };
    let module = rapid_module(&program, &config);
    let routines = (targets.len() - 1).div_ceil(50);
    assert_eq!(module.matches("PROC path_").count(), routines);
    assert_eq!(module.matches("    path_").count(), routines);
}

// ---------------------------------------------------------------------------------------------
// Frames

#[test]
fn alignment_recovers_the_work_object_and_reports_the_residual() {
    let truth = pose_from_parts(
        Vector3::new(420.0, -35.0, 80.0),
        UnitQuaternion::from_euler_angles(0.05, -0.1, 1.2),
    );
    let in_wobj = [
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(200.0, 0.0, 0.0),
        Point3::new(0.0, 150.0, 0.0),
        Point3::new(200.0, 150.0, 10.0),
    ];
    let in_base: Vec<Point3> = in_wobj.iter().map(|p| truth * p).collect();
    let exact = align_frames(&in_wobj, &in_base).unwrap();
    assert_pose_near(&exact.base_from_wobj, &truth, 1e-9, 1e-12, "exact");
    assert!(exact.rms_mm < 1e-9);
    // One touched point 0.4 mm off along z: the residual shows it.
    let mut off = in_base.clone();
    off[3].z += 0.4;
    let fit = align_frames(&in_wobj, &off).unwrap();
    assert!(fit.rms_mm > 0.05 && fit.rms_mm < 0.4, "{}", fit.rms_mm);
    assert_eq!(
        fit.residuals_mm
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap()
            .0,
        3
    );
    let line = [
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(2.0, 0.0, 0.0),
    ];
    assert!(matches!(
        align_frames(&line, &line),
        Err(FramesError::Collinear)
    ));
    assert!(matches!(
        align_frames(&in_wobj[..2], &in_base[..2]),
        Err(FramesError::TooFewPoints { count: 2 })
    ));
}

#[test]
fn pivot_calibration_recovers_the_tip_and_refuses_too_little_rotation() {
    let tip_in_tool = Point3::new(3.0, -15.0, -180.0);
    let pivot = Point3::new(100.0, 50.0, 0.0);
    let pose_for = |rotation: UnitQuaternion<f64>| {
        let translation = pivot.coords - rotation * tip_in_tool.coords;
        pose_from_parts(translation, rotation)
    };
    let poses: Vec<Pose> = (0..60)
        .map(|k| {
            let t = k as f64 / 60.0 * TAU;
            pose_for(UnitQuaternion::from_euler_angles(
                0.5 * t.sin(),
                0.5 * t.cos(),
                0.3 * (2.0 * t).sin(),
            ))
        })
        .collect();
    let result = pivot_calibration(&poses, &PivotConfig::default()).unwrap();
    assert!((result.tip_in_tool - tip_in_tool).norm() < 1e-6);
    assert!((result.pivot_in_world - pivot).norm() < 1e-6);
    assert!(result.rms_mm < 1e-6);
    // Turning about the tool's z axis only leaves the tip's z unknown.
    let spun: Vec<Pose> = (0..30)
        .map(|k| {
            pose_for(UnitQuaternion::from_axis_angle(
                &Vector3::z_axis(),
                k as f64 * 0.2,
            ))
        })
        .collect();
    assert!(matches!(
        pivot_calibration(&spun, &PivotConfig::default()),
        Err(FramesError::TooLittleRotation { .. })
    ));
}

// ---------------------------------------------------------------------------------------------
// Golden files: the programs of a 1 s stroke must stay byte-stable (set UPDATE_GOLDEN=1 to
// rewrite them after a deliberate change, then read the diff).

#[expect(
    clippy::unwrap_used,
    reason = "test helper: failing to write a golden file fails the test"
)]
fn golden(name: &str, text: &str) {
    let path = data_dir().join(name);
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&path, text).unwrap();
        return;
    }
    let expected = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (run with UPDATE_GOLDEN=1)", path.display()));
    assert!(
        expected == text,
        "{} differs from the written program (UPDATE_GOLDEN=1 rewrites it)",
        path.display()
    );
}

#[test]
fn programs_match_their_golden_files() {
    use teachcam::robot::krl::krl_program;
    use teachcam::robot::table::{joints_csv, poses_csv};
    use teachcam::robot::urscript::{UrScriptConfig, urscript_program};
    let model = Robot::irb120();
    let cell = cell();
    let targets = targets(&stroke(1.0, 1.0));
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    assert!(report.passes());
    let program = build_program("stroke", &cell, &report, &SimplifyConfig::default());
    golden(
        "stroke.mod",
        &rapid_module(&program, &RapidConfig::default()),
    );
    golden("stroke_poses.csv", &poses_csv(&report));
    golden("stroke_joints.csv", &joints_csv(&report));
    // KRL on a KR 6 R700 (the brush along FLANGE x), URScript on a UR5e.
    let kuka = Robot::kr6_r700();
    let kuka_cell = Cell {
        base_from_wobj: pose_from_parts(
            Vector3::new(450.0, 0.0, 150.0),
            UnitQuaternion::identity(),
        ),
        flange_from_tcp: pose_from_parts(
            Vector3::new(150.0, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI / 2.0),
        ),
    };
    let report = check_path(&kuka, &kuka_cell, &targets, &CheckConfig::default());
    assert!(report.passes());
    let program = build_program("stroke", &kuka_cell, &report, &SimplifyConfig::default());
    let krl = krl_program(&program);
    golden("stroke.src", &krl.src);
    golden("stroke.dat", &krl.dat);
    golden("stroke_kr6_joints.csv", &joints_csv(&report));
    let ur = Robot::ur5e();
    let ur_cell = Cell {
        base_from_wobj: pose_from_parts(
            Vector3::new(400.0, 0.0, 100.0),
            UnitQuaternion::identity(),
        ),
        ..cell
    };
    let report = check_path(&ur, &ur_cell, &targets, &CheckConfig::default());
    assert!(report.passes());
    let program = build_program("stroke", &ur_cell, &report, &SimplifyConfig::default());
    golden(
        "stroke.script",
        &urscript_program(&program, &UrScriptConfig::default()),
    );
    golden("stroke_ur5e_joints.csv", &joints_csv(&report));
}

/// KRL's A, B, C and URScript's rotation vectors read back give the targets' orientations.
#[test]
fn krl_and_urscript_orientations_read_back() {
    use teachcam::robot::krl::krl_program;
    use teachcam::robot::urscript::{UrScriptConfig, urscript_program};
    let model = Robot::irb120();
    let cell = cell();
    let targets = targets(&stroke(2.0, 1.0));
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    let program = build_program("stroke", &cell, &report, &SimplifyConfig::default());
    let krl = krl_program(&program);
    let points: Vec<&str> = krl
        .dat
        .lines()
        .filter(|l| l.contains("DECL E6POS"))
        .collect();
    assert_eq!(points.len(), program.moves.len());
    for (line, m) in points.iter().zip(&program.moves) {
        let inner = line.split('{').nth(1).unwrap().trim_end_matches('}');
        let v: Vec<f64> = inner
            .split(',')
            .map(|f| f.split_whitespace().nth(1).unwrap().parse().unwrap())
            .collect();
        let (a, b, c) = (v[3].to_radians(), v[4].to_radians(), v[5].to_radians());
        // KUKA: R = Rz(A) Ry(B) Rx(C).
        let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a)
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), b)
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), c);
        let pose = pose_from_parts(Vector3::new(v[0], v[1], v[2]), rotation);
        assert_pose_near(&pose, &m.target.wobj_from_tcp, 0.001, 1e-6, "krl point");
    }
    let script = urscript_program(&program, &UrScriptConfig::default());
    // The first target is reached by a movej to its joints, the others by movel.
    let moves: Vec<&str> = script.lines().filter(|l| l.contains("movel(")).collect();
    assert_eq!(moves.len(), program.moves.len() - 1);
    assert_eq!(script.matches("movej(").count(), 1);
    for (line, m) in moves.iter().zip(&program.moves[1..]) {
        let inner = line.split("p[").nth(1).unwrap().split(']').next().unwrap();
        let v: Vec<f64> = inner
            .split(',')
            .map(|f| f.trim().parse().unwrap())
            .collect();
        let rotation = UnitQuaternion::from_scaled_axis(Vector3::new(v[3], v[4], v[5]));
        let pose = pose_from_parts(Vector3::new(v[0], v[1], v[2]) * 1000.0, rotation);
        assert_pose_near(&pose, &m.target.wobj_from_tcp, 0.001, 1e-6, "urscript pose");
    }
}

// ---------------------------------------------------------------------------------------------
// The demo trajectory (the simulator's paper scenario) on the IRB 120: the issue's "done when".

/// The work object 350 mm in front of the robot, 100 mm up; the brush mounted 200 mm out of
/// the flange with its tool z axis (up, away from the tip) against the flange's z (down).
fn demo_cell() -> Cell {
    Cell {
        base_from_wobj: pose_from_parts(
            Vector3::new(350.0, 0.0, 100.0),
            UnitQuaternion::identity(),
        ),
        flange_from_tcp: pose_from_parts(
            Vector3::new(0.0, 0.0, 200.0),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI),
        ),
    }
}

#[test]
fn demo_trajectory_passes_and_its_program_reproduces_the_tcp_poses() {
    use teachcam::sim::{Scenario, build_scene};
    let scene = build_scene(Scenario::Paper, 1);
    let model = Robot::irb120();
    let cell = demo_cell();
    let targets = tcp_targets(&scene.truth, &scene.tool.tool_from_tcp.rotation);
    assert_eq!(targets.len(), scene.truth.len());
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    assert!(report.passes(), "{:?}", report.failing().next());
    // Targets: the truth's tip with the tool's orientation, computed here independently from
    // world_from_tool and the tool file.
    let program = build_program("demo", &cell, &report, &SimplifyConfig::default());
    let module = rapid_module(&program, &RapidConfig::default());
    let written = robtargets(&module);
    assert_eq!(written.len(), program.moves.len());
    for ((pose, _), m) in written.iter().zip(&program.moves) {
        let sample = &scene.truth.samples[m.target.frame.0];
        let expected = sample.pose.unwrap().world_from_tool * scene.tool.tool_from_tcp;
        assert_pose_near(pose, &expected, 0.01, 0.001f64.to_radians(), "demo target");
    }
    // Joints reproduce every target through forward kinematics.
    for f in &report.frames {
        let joints = f.joints.unwrap();
        let left = forward(&model, &joints) * cell.flange_from_tcp;
        let right = cell.base_from_wobj * f.target.wobj_from_tcp;
        assert_pose_near(&left, &right, 1e-6, 1e-9, "demo joints");
    }
}

/// With 0.05 mm of Gaussian noise on each pose's position, the residual is the noise's 3-D
/// RMS (σ√3 ≈ 0.087 mm, less 6 fitted parameters out of 180 equations), and the tip error is
/// about σ / (spread √n) ≈ 0.02 mm: 0.1 mm is five of those.
#[test]
fn pivot_calibration_residual_measures_the_noise() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, 0.05).unwrap();
    let tip_in_tool = Vector3::new(3.0, -15.0, -180.0);
    let poses: Vec<Pose> = (0..60)
        .map(|k| {
            let t = k as f64 / 60.0 * TAU;
            let r = UnitQuaternion::from_euler_angles(0.5 * t.sin(), 0.5 * t.cos(), 0.3 * t);
            let jitter = Vector3::from_fn(|_, _| noise.sample(&mut rng));
            pose_from_parts(Vector3::new(100.0, 50.0, 0.0) - r * tip_in_tool + jitter, r)
        })
        .collect();
    let result = pivot_calibration(&poses, &PivotConfig::default()).unwrap();
    let expected_rms = 0.05 * 3f64.sqrt() * (174.0f64 / 180.0).sqrt();
    assert!(
        (result.rms_mm / expected_rms - 1.0).abs() < 0.25,
        "rms {} vs {expected_rms}",
        result.rms_mm
    );
    assert!((result.tip_in_tool.coords - tip_in_tool).norm() < 0.1);
}

// ---------------------------------------------------------------------------------------------
// Parsers: never a panic, always a named cause, written forms read back.

proptest! {
    #[test]
    fn pose_text_parser_never_panics(text in ".{0,80}") {
        let _ = teachcam::geometry::parse_pose(&text);
    }

    #[test]
    fn pose_text_parser_refuses_numbers_with_a_named_cause(
        values in proptest::collection::vec(-1e4f64..1e4, 0..10)
    ) {
        let text = values.iter().map(|v| format!("{v}")).collect::<Vec<_>>().join(",");
        if let Err(e) = teachcam::geometry::parse_pose(&text) {
            prop_assert!(e.to_string().contains(&text));
        }
    }

    #[test]
    fn pose_text_round_trips(
        x in -2000.0f64..2000.0, y in -2000.0f64..2000.0, z in -2000.0f64..2000.0,
        roll in -PI..PI, pitch in -1.5f64..1.5, yaw in -PI..PI,
    ) {
        let pose = pose_from_parts(
            Vector3::new(x, y, z),
            UnitQuaternion::from_euler_angles(roll, pitch, yaw),
        );
        let back = teachcam::geometry::parse_pose(&teachcam::robot::pose_text(&pose)).unwrap();
        prop_assert!((back.translation.vector - pose.translation.vector).norm() < 1e-3);
        prop_assert!(back.rotation.angle_to(&pose.rotation) < 1e-8);
    }

    #[test]
    fn point_pairs_parser_never_panics(body in "[0-9a-z,.\\-\\n ]{0,200}") {
        let text = format!("x_wobj_mm,y_wobj_mm,z_wobj_mm,x_base_mm,y_base_mm,z_base_mm\n{body}");
        match teachcam::robot::frames::parse_point_pairs(&text) {
            Ok(pairs) => prop_assert_eq!(pairs.in_wobj.len(), pairs.in_base.len()),
            Err(message) => prop_assert!(message.starts_with("line ")),
        }
    }
}

#[test]
fn pose_text_errors_name_the_problem() {
    use teachcam::geometry::{PoseTextError, parse_pose};
    assert!(matches!(parse_pose("1,2,3"), Err(PoseTextError::Shape(_))));
    assert!(matches!(
        parse_pose("1,2,3,1,1,0,0"),
        Err(PoseTextError::NotUnit { .. })
    ));
    let pose = parse_pose(" 350, 0 ,150,1,0,0,0").unwrap();
    assert_eq!(pose.translation.vector, Vector3::new(350.0, 0.0, 150.0));
}

/// At the singularities the closed form still returns poses that forward kinematics
/// reproduces: wrist (axis 5 at zero: only q4 + q6 is determined) and shoulder (wrist centre
/// on axis 1: q1 is free).
#[test]
fn inverse_kinematics_at_singularities_reproduces_the_pose() {
    let model = Robot::irb120();
    let wrist = Joints::from_degrees([10.0, 20.0, -10.0, 30.0, 0.0, 40.0]);
    // The shoulder: J2 = 0 and J3 tipping the forearm up to put the wrist centre over axis 1
    // needs a pose; build it from a wrist centre on the z axis directly.
    let over_axis_1 = pose_from_parts(
        Vector3::new(0.0, 0.0, 290.0 + 400.0 + 72.0),
        UnitQuaternion::identity(),
    );
    for (name, pose) in [
        ("wrist", forward(&model, &wrist)),
        ("shoulder", over_axis_1),
    ] {
        let all = inverse(&model, &pose);
        assert!(!all.is_empty(), "{name}");
        for s in &all {
            assert_pose_near(&forward(&model, &s.joints), &pose, 1e-7, 1e-9, name);
        }
    }
}

#[test]
fn non_increasing_time_is_reported_not_divided_by() {
    let model = Robot::irb120();
    let mut targets = targets(&stroke(1.0, 1.0));
    targets[10].time_s = targets[9].time_s;
    let report = check_path(&model, &cell(), &targets, &CheckConfig::default());
    assert!(!report.passes());
    assert!(
        report.frames[10]
            .issues
            .iter()
            .any(|i| matches!(i, FrameIssue::TimeNotIncreasing { .. }))
    );
    assert!(
        report
            .frames
            .iter()
            .all(|f| f.joint_speed.iter().all(|v| v.is_finite()))
    );
}

/// A dwell (the brush held still for a second) keeps its duration in RAPID through `\T`.
#[test]
fn rapid_dwell_keeps_its_recorded_duration() {
    let model = Robot::irb120();
    let cell = cell();
    let still = pose_from_parts(
        Vector3::new(0.0, 0.0, 20.0),
        UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI),
    );
    let targets: Vec<TcpTarget> = [0.0, 1.0]
        .iter()
        .enumerate()
        .map(|(k, &t)| TcpTarget {
            frame: FrameIndex(k),
            time_s: t,
            wobj_from_tcp: still,
        })
        .collect();
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    let program = build_program("dwell", &cell, &report, &SimplifyConfig::default());
    let module = rapid_module(&program, &RapidConfig::default());
    assert!(
        module.contains("MoveL p0002, v0002\\T:=1.0000, fine,"),
        "{module}"
    );
}

/// A world whose z points into the table (a rig calibrated from a chessboard lying on it):
/// with the README's `--wobj` the brush points up and no frame is in reach. The check finds a
/// turned and placed work object, verified; with it every frame is in reach.
#[test]
fn a_world_upside_down_gets_a_verified_work_object() {
    for model in [Robot::irb120(), Robot::kr6_r700()] {
        let mut cell = cell();
        cell.base_from_wobj.rotation = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI);
        if model.maker == teachcam::robot::kinematics::Maker::Kuka {
            cell.flange_from_tcp = pose_from_parts(
                Vector3::new(150.0, 0.0, 0.0),
                UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI / 2.0),
            );
        }
        let targets = targets(&stroke(4.0, 1.0));
        let report = check_path(&model, &cell, &targets, &CheckConfig::default());
        assert!(report.unreachable_count() > 0, "{}", model.name);
        let fixed = match report.suggestions.first().copied() {
            Some(Suggestion::UseWorkObject { base_from_wobj, .. }) => Cell {
                base_from_wobj,
                ..cell
            },
            other => panic!("{}: no work-object suggestion: {other:?}", model.name),
        };
        // The suggestion as printed (3 decimals, 9 in the quaternion) read back.
        if let Some(Suggestion::UseWorkObject { .. }) = report.suggestions.first() {
            let text = report.suggestions[0].to_string();
            let pose = text.split('"').nth(1).unwrap();
            let parsed = teachcam::geometry::parse_pose(pose).unwrap();
            assert_pose_near(&parsed, &fixed.base_from_wobj, 1e-3, 1e-8, "printed --wobj");
        }
        let again = check_path(&model, &fixed, &targets, &CheckConfig::default());
        assert_eq!(
            again.unreachable_count(),
            0,
            "{}: {:?}",
            model.name,
            report.suggestions
        );
    }
}
