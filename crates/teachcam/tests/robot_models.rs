//! Every known robot against a forward kinematics written here from its maker's published
//! numbers, independently of the library's OPW and DH code: a product of exponentials from the
//! axes at the maker's zero (ABB, KUKA) and a plain 4×4 DH chain (UR). Home poses from the data
//! sheets, inverse kinematics on random reachable poses through every branch, KUKA's Status and
//! Turn, robot files.

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{Matrix4, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use teachcam::geometry::{Pose, pose_from_parts};
use teachcam::robot::kinematics::{
    Joints, Maker, Robot, configuration_of, forward, inverse, inverse_within_limits, status_turn,
    wrist_centre,
};

/// One revolute axis at the maker's zero: direction and a point on it, base frame, mm.
struct Axis {
    direction: [f64; 3],
    point: [f64; 3],
}

/// A product-of-exponentials arm: six axes and the flange at all joints zero.
struct PoeArm {
    axes: [Axis; 6],
    flange_at_zero: Pose,
}

fn poe_forward(arm: &PoeArm, joints: &Joints) -> Pose {
    let mut pose = Pose::identity();
    for (axis, q) in arm.axes.iter().zip(joints.0) {
        let direction = Vector3::from(axis.direction).normalize();
        let rotation =
            UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(direction), q);
        let point = Vector3::from(axis.point);
        pose *= pose_from_parts(point - rotation * point, rotation);
    }
    pose * arm.flange_at_zero
}

/// ABB IRB 120 at ABB's zero (3HAC035960-001): lower arm vertical, forearm horizontal; axis 1
/// up through the base, axes 2, 3 and 5 along +y at heights 290, 560 and 630 mm, axes 4 and 6
/// along +x at 630 mm; tool0 at (374, 0, 630) with z forward and x down.
fn irb120_poe() -> PoeArm {
    PoeArm {
        axes: [
            Axis {
                direction: [0.0, 0.0, 1.0],
                point: [0.0, 0.0, 0.0],
            },
            Axis {
                direction: [0.0, 1.0, 0.0],
                point: [0.0, 0.0, 290.0],
            },
            Axis {
                direction: [0.0, 1.0, 0.0],
                point: [0.0, 0.0, 560.0],
            },
            Axis {
                direction: [1.0, 0.0, 0.0],
                point: [0.0, 0.0, 630.0],
            },
            Axis {
                direction: [0.0, 1.0, 0.0],
                point: [302.0, 0.0, 630.0],
            },
            Axis {
                direction: [1.0, 0.0, 0.0],
                point: [0.0, 0.0, 630.0],
            },
        ],
        flange_at_zero: pose_from_parts(
            Vector3::new(374.0, 0.0, 630.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2),
        ),
    }
}

/// KUKA KR 6 sixx at KUKA's zero (all of A1..A6 at 0°): the arm stretched forward
/// horizontally; A1 turns about −z (KUKA counts it clockwise seen from above), A2, A3 and A5
/// about +y, A4 and A6 about −x; A2 25 mm forward and 400 mm up, A3 `c2` further, A4 35 mm
/// above A3, the wrist root point `c3` beyond, the FLANGE 80 mm beyond that with x out of
/// the flange and parallel to $ROBROOT.
fn kr6_poe(c2: f64, c3: f64) -> PoeArm {
    let a3 = 25.0 + c2;
    let wrist = a3 + c3;
    PoeArm {
        axes: [
            Axis {
                direction: [0.0, 0.0, -1.0],
                point: [0.0, 0.0, 0.0],
            },
            Axis {
                direction: [0.0, 1.0, 0.0],
                point: [25.0, 0.0, 400.0],
            },
            Axis {
                direction: [0.0, 1.0, 0.0],
                point: [a3, 0.0, 400.0],
            },
            Axis {
                direction: [-1.0, 0.0, 0.0],
                point: [0.0, 0.0, 435.0],
            },
            Axis {
                direction: [0.0, 1.0, 0.0],
                point: [wrist, 0.0, 435.0],
            },
            Axis {
                direction: [-1.0, 0.0, 0.0],
                point: [0.0, 0.0, 435.0],
            },
        ],
        flange_at_zero: pose_from_parts(
            Vector3::new(wrist + 80.0, 0.0, 435.0),
            UnitQuaternion::identity(),
        ),
    }
}

/// UR's DH table (d, a, α per joint, mm and rad) multiplied as 4×4 matrices.
fn ur_dh_forward(d: [f64; 6], a: [f64; 6], joints: &Joints) -> Pose {
    let alpha = [FRAC_PI_2, 0.0, 0.0, FRAC_PI_2, -FRAC_PI_2, 0.0];
    let mut t = Matrix4::<f64>::identity();
    for i in 0..6 {
        let (st, ct) = joints.0[i].sin_cos();
        let (sa, ca) = alpha[i].sin_cos();
        #[rustfmt::skip]
        let link = Matrix4::new(
            ct, -st * ca, st * sa, a[i] * ct,
            st, ct * ca, -ct * sa, a[i] * st,
            0.0, sa, ca, d[i],
            0.0, 0.0, 0.0, 1.0,
        );
        t *= link;
    }
    let rotation =
        nalgebra::Rotation3::from_matrix_unchecked(t.fixed_view::<3, 3>(0, 0).into_owned());
    pose_from_parts(
        Vector3::new(t[(0, 3)], t[(1, 3)], t[(2, 3)]),
        UnitQuaternion::from_rotation_matrix(&rotation),
    )
}

/// The independent forward kinematics of a known robot.
fn reference_forward(robot: &Robot, joints: &Joints) -> Pose {
    match robot.name.as_str() {
        "irb120" => poe_forward(&irb120_poe(), joints),
        "kr6-r700" => poe_forward(&kr6_poe(315.0, 365.0), joints),
        "kr6-r900" => poe_forward(&kr6_poe(455.0, 420.0), joints),
        "ur5e" => ur_dh_forward(
            [162.5, 0.0, 0.0, 133.3, 99.7, 99.6],
            [0.0, -425.0, -392.2, 0.0, 0.0, 0.0],
            joints,
        ),
        "ur10e" => ur_dh_forward(
            [180.7, 0.0, 0.0, 174.15, 119.85, 116.55],
            [0.0, -612.7, -571.55, 0.0, 0.0, 0.0],
            joints,
        ),
        other => panic!("no reference for {other}"),
    }
}

#[expect(
    clippy::unwrap_used,
    reason = "test helper: every known name must resolve"
)]
fn all_robots() -> Vec<Robot> {
    teachcam::robot::kinematics::models::KNOWN_ROBOTS
        .iter()
        .map(|name| Robot::by_name(name).unwrap())
        .collect()
}

fn distance(a: &Pose, b: &Pose) -> (f64, f64) {
    (
        (a.translation.vector - b.translation.vector).norm(),
        a.rotation.angle_to(&b.rotation),
    )
}

#[test]
fn home_poses_are_the_data_sheets() {
    let cases = [
        ("irb120", [0.0; 6], [374.0, 0.0, 630.0]),
        (
            "kr6-r700",
            [0.0, -90.0, 90.0, 0.0, 0.0, 0.0],
            [470.0, 0.0, 750.0],
        ),
        (
            "kr6-r900",
            [0.0, -90.0, 90.0, 0.0, 0.0, 0.0],
            [525.0, 0.0, 890.0],
        ),
        ("ur5e", [0.0; 6], [-817.2, -232.9, 62.8]),
        ("ur10e", [0.0; 6], [-1184.25, -290.7, 60.85]),
    ];
    for (name, joints_deg, position) in cases {
        let robot = Robot::by_name(name).unwrap();
        let pose = forward(&robot, &Joints::from_degrees(joints_deg));
        let dp = (pose.translation.vector - Vector3::from(position)).norm();
        assert!(dp < 1e-9, "{name}: home {:?}", pose.translation.vector);
    }
    // KUKA's FLANGE at home is parallel to $ROBROOT (x out of the flange, forward).
    for name in ["kr6-r700", "kr6-r900"] {
        let robot = Robot::by_name(name).unwrap();
        let pose = forward(
            &robot,
            &Joints::from_degrees([0.0, -90.0, 90.0, 0.0, 0.0, 0.0]),
        );
        assert!(pose.rotation.angle() < 1e-12, "{name}");
    }
    // UR's flange at zero: z out of the flange along −y, x along +x... as the DH table says:
    // frame 6 = Rx(π/2)·Rx(π/2)·Rx(−π/2) = Rx(π/2).
    let ur = forward(&Robot::ur5e(), &Joints([0.0; 6]));
    let expected = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), FRAC_PI_2);
    assert!(ur.rotation.angle_to(&expected) < 1e-12);
}

#[test]
fn forward_kinematics_matches_the_independent_chains() {
    let mut rng = ChaCha8Rng::seed_from_u64(18);
    for robot in all_robots() {
        let mut worst = (0.0f64, 0.0f64);
        for _ in 0..2000 {
            let joints = Joints(std::array::from_fn(|i| {
                rng.random_range(robot.limits[i].min..robot.limits[i].max)
            }));
            let (dp, da) = distance(
                &forward(&robot, &joints),
                &reference_forward(&robot, &joints),
            );
            worst = (worst.0.max(dp), worst.1.max(da));
        }
        eprintln!(
            "{}: FK vs the independent chain, worst {:.2e} mm, {:.2e} rad",
            robot.name, worst.0, worst.1
        );
        // Six f64 transforms of lengths under 1.2 m: 1e-9 mm and 1e-12 rad are far above rounding.
        assert!(
            worst.0 < 1e-9 && worst.1 < 1e-12,
            "{}: {worst:?}",
            robot.name
        );
    }
}

/// Away from the singularities (|sin q5| > 1e-3; wrist point more than 1 mm off axis 1; elbow
/// bent by more than 1e-3 rad), where the branches are distinct.
fn generic(robot: &Robot, joints: &Joints) -> bool {
    let wrist = wrist_centre(robot, joints);
    let bent = match &robot.arm {
        teachcam::robot::kinematics::Arm::SphericalWrist(p) => {
            let theta3 = p.sign_corrections[2] * joints.0[2] - p.offsets[2];
            (theta3 - (-p.a2).atan2(p.c3)).sin().abs() > 1e-3
        }
        teachcam::robot::kinematics::Arm::Ur(_) => joints.0[2].sin().abs() > 1e-3,
    };
    let radius = wrist.x.hypot(wrist.y);
    let off_axis = match &robot.arm {
        teachcam::robot::kinematics::Arm::Ur(p) => radius > p.d4.abs() + 1.0,
        teachcam::robot::kinematics::Arm::SphericalWrist(_) => radius > 1.0,
    };
    joints.0[4].sin().abs() > 1e-3 && bent && off_axis
}

/// IK on random reachable poses: every branch the closed form returns, through the
/// independent forward kinematics, lands on the pose within 1e-6 mm and 1e-9 rad (the
/// acceptance is 0.01 mm and 0.001°); the original's branch is among them and every one of
/// the eight branches is exercised; the joints that made the pose are among the solutions
/// within the limits.
#[test]
fn inverse_kinematics_reproduces_random_poses_through_every_branch() {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for robot in all_robots() {
        let mut worst = (0.0f64, 0.0f64);
        let mut poses = 0;
        let mut solutions = 0;
        let mut branch_count = [0usize; 8];
        while poses < 3000 {
            let joints = Joints(std::array::from_fn(|i| {
                rng.random_range(robot.limits[i].min..robot.limits[i].max)
            }));
            if !generic(&robot, &joints) {
                continue;
            }
            poses += 1;
            let pose = reference_forward(&robot, &joints);
            let all = inverse(&robot, &pose);
            let original = configuration_of(&robot, &joints);
            assert!(
                all.iter().any(|s| s.configuration == original),
                "{}: the original branch is missing for {joints:?}",
                robot.name
            );
            for s in &all {
                branch_count[usize::from(s.configuration.code())] += 1;
                let (dp, da) = distance(&reference_forward(&robot, &s.joints), &pose);
                worst = (worst.0.max(dp), worst.1.max(da));
                assert_eq!(
                    configuration_of(&robot, &s.joints),
                    s.configuration,
                    "{}",
                    robot.name
                );
                solutions += 1;
            }
            let within = inverse_within_limits(&robot, &pose);
            assert!(
                within
                    .iter()
                    .any(|s| (0..6).all(|i| (s.joints.0[i] - joints.0[i]).abs() < 1e-6)),
                "{}: {joints:?} not among {} solutions",
                robot.name,
                within.len()
            );
        }
        eprintln!(
            "{}: {solutions} IK solutions of {poses} poses, worst {:.2e} mm, {:.2e} rad; branches {branch_count:?}",
            robot.name, worst.0, worst.1
        );
        // Every branch is exercised (a pose reachable from the front shoulder only has four).
        assert!(
            branch_count.iter().all(|&n| n >= 300),
            "{}: branches {branch_count:?}",
            robot.name
        );
        assert!(
            worst.0 < 1e-6 && worst.1 < 1e-9,
            "{}: worst {worst:?} over {solutions} solutions",
            robot.name
        );
    }
}

#[test]
fn kuka_status_and_turn_follow_kukas_definitions() {
    let robot = Robot::kr6_r700();
    // Home with A5 slightly positive: basic area, A3 = 90° ≥ φ, A5 > 0: S = 'B010'; only A2 is
    // negative: T = 'B000010'.
    let home = Joints::from_degrees([0.0, -90.0, 90.0, 0.0, 10.0, 0.0]);
    let st = status_turn(&robot, &home, &configuration_of(&robot, &home));
    assert_eq!((st.status, st.turn), (2, 2));
    // A5 negative and A1, A4, A6 negative: S bit 2, T bits 0, 1, 3, 4, 5.
    let flipped = Joints::from_degrees([-20.0, -80.0, 100.0, -30.0, -40.0, -50.0]);
    let st = status_turn(&robot, &flipped, &configuration_of(&robot, &flipped));
    assert_eq!((st.status, st.turn), (6, 0b11_1011));
    // Overhead: the wrist root point behind A1 (A2 far back).
    let overhead = Joints::from_degrees([0.0, -150.0, 60.0, 0.0, 30.0, 0.0]);
    let wrist = wrist_centre(&robot, &overhead);
    assert!(wrist.x < 0.0, "{wrist:?}");
    let st = status_turn(&robot, &overhead, &configuration_of(&robot, &overhead));
    assert_eq!(st.status & 1, 1);
    // Bit 1 switches where A2, A3 and the wrist root point line up: A3 = atan(35/365) = 5.48°.
    for (a3, bit) in [(5.0, 0), (6.0, 2)] {
        let j = Joints::from_degrees([0.0, -90.0, a3, 0.0, 30.0, 0.0]);
        let st = status_turn(&robot, &j, &configuration_of(&robot, &j));
        assert_eq!(st.status & 2, bit, "A3 = {a3}");
    }
}

#[test]
fn makers_and_flanges_are_the_makers() {
    assert_eq!(Robot::irb120().maker, Maker::Abb);
    assert_eq!(Robot::kr6_r900().maker, Maker::Kuka);
    assert_eq!(Robot::ur10e().maker, Maker::UniversalRobots);
    assert!(Robot::by_name("KR6_R700").is_some());
    assert!(Robot::by_name("kr6").is_none());
    // A pose straight down at the KR 6's home reach: FLANGE x points down.
    let robot = Robot::kr6_r700();
    let down = Joints::from_degrees([0.0, -90.0, 90.0, 0.0, 90.0, 0.0]);
    let x = forward(&robot, &down).rotation * Vector3::x();
    assert!((x - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12, "{x:?}");
    let _ = PI;
}

#[test]
fn robot_files_describe_the_known_arms_and_name_their_mistakes() {
    use std::path::Path;
    use teachcam::io::robot::parse_robot;
    let path = Path::new("arm.json");
    let kuka = r#"{"name": "my-kr6", "maker": "kuka",
        "opw": {"a1_mm": 25, "a2_mm": -35, "b_mm": 0, "c1_mm": 400, "c2_mm": 315, "c3_mm": 365,
                "c4_mm": 80, "offsets_deg": [0, -90, 0, 0, 0, 0],
                "sign_corrections": [-1, 1, 1, -1, 1, -1]},
        "joints": [{"min_deg": -170, "max_deg": 170, "max_speed_deg_s": 360},
                   {"min_deg": -190, "max_deg": 45, "max_speed_deg_s": 300},
                   {"min_deg": -120, "max_deg": 156, "max_speed_deg_s": 360},
                   {"min_deg": -185, "max_deg": 185, "max_speed_deg_s": 381},
                   {"min_deg": -120, "max_deg": 120, "max_speed_deg_s": 388},
                   {"min_deg": -350, "max_deg": 350, "max_speed_deg_s": 615}]}"#;
    let robot = parse_robot(path, kuka).unwrap();
    let builtin = Robot::kr6_r700();
    assert_eq!(robot.maker, builtin.maker);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..100 {
        let joints = Joints(std::array::from_fn(|i| {
            rng.random_range(builtin.limits[i].min..builtin.limits[i].max)
        }));
        let (dp, da) = distance(
            &forward(&robot, &joints),
            &reference_forward(&builtin, &joints),
        );
        assert!(dp < 1e-9 && da < 1e-12);
    }
    let ur = r#"{"name": "my-ur5e", "maker": "ur",
        "dh": {"d1_mm": 162.5, "a2_mm": -425, "a3_mm": -392.2, "d4_mm": 133.3, "d5_mm": 99.7,
               "d6_mm": 99.6},
        "joints": [{"min_deg": -360, "max_deg": 360, "max_speed_deg_s": 180},
                   {"min_deg": -360, "max_deg": 360, "max_speed_deg_s": 180},
                   {"min_deg": -360, "max_deg": 360, "max_speed_deg_s": 180},
                   {"min_deg": -360, "max_deg": 360, "max_speed_deg_s": 180},
                   {"min_deg": -360, "max_deg": 360, "max_speed_deg_s": 180},
                   {"min_deg": -360, "max_deg": 360, "max_speed_deg_s": 180}]}"#;
    assert_eq!(parse_robot(path, ur).unwrap().arm, Robot::ur5e().arm);
    for (broken, says) in [
        (kuka.replace("\"b_mm\": 0", "\"b_mm\": 5"), "b_mm"),
        (
            kuka.replace("[-1, 1, 1, -1, 1, -1]", "[-1, 1, 1, -1, 1, 2]"),
            "sign_corrections[5]",
        ),
        (
            kuka.replace(
                "\"min_deg\": -120, \"max_deg\": 120",
                "\"min_deg\": 120, \"max_deg\": -120",
            ),
            "joints[4]",
        ),
        (
            kuka.replace("\"maker\": \"kuka\"", "\"maker\": \"fanuc\""),
            "fanuc",
        ),
        (kuka.replace("\"c2_mm\": 315", "\"c2_mm\": -315"), "c2_mm"),
        (ur.replace("\"dh\"", "\"opw\""), "d1_mm"),
    ] {
        let e = parse_robot(path, &broken).unwrap_err().to_string();
        assert!(e.contains("arm.json") && e.contains(says), "{says}: {e}");
    }
}

/// A 20 s painter's loop at 30 Hz: the tip circling 60 mm around the work object's origin
/// while bobbing 10 mm, the brush pointing down and tilting by up to 14°.
fn painting_loop() -> Vec<teachcam::robot::TcpTarget> {
    use std::f64::consts::TAU;
    (0..600)
        .map(|k| {
            let t = f64::from(k) / 30.0;
            let phase = TAU * t / 10.0;
            let tip = Vector3::new(
                60.0 * phase.cos(),
                60.0 * phase.sin(),
                20.0 + 10.0 * (3.0 * phase).sin(),
            );
            let tilt = UnitQuaternion::from_euler_angles(
                0.25 * (2.0 * phase).sin(),
                0.2 * (phase + 0.4).cos(),
                0.6 * phase.sin(),
            );
            teachcam::robot::TcpTarget {
                frame: teachcam::geometry::FrameIndex(k as usize),
                time_s: t,
                wobj_from_tcp: pose_from_parts(
                    tip,
                    tilt * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI),
                ),
            }
        })
        .collect()
}

/// Where each robot paints the loop: the work object in front of it, the brush 150 mm out of
/// the flange along the flange's normal (ABB and UR: z; KUKA: x, so the TCP's z is FLANGE x).
fn painting_cell(robot: &Robot) -> teachcam::robot::Cell {
    let x = match robot.name.as_str() {
        "irb120" => 350.0,
        "kr6-r700" => 450.0,
        "kr6-r900" => 550.0,
        "ur5e" => 400.0,
        _ => 600.0,
    };
    let along_normal = match robot.maker {
        Maker::Kuka => pose_from_parts(
            Vector3::new(150.0, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), FRAC_PI_2),
        ),
        Maker::Abb | Maker::UniversalRobots => {
            pose_from_parts(Vector3::new(0.0, 0.0, 150.0), UnitQuaternion::identity())
        }
    };
    teachcam::robot::Cell {
        base_from_wobj: pose_from_parts(Vector3::new(x, 0.0, 120.0), UnitQuaternion::identity()),
        flange_from_tcp: along_normal,
    }
}

/// The contract's law on `--joints-out`'s table, for every robot: the joints read back from
/// the CSV text (degrees, 6 decimals: 1.7e-8 rad, about 2e-5 mm at 1.2 m) through the
/// independent forward kinematics reproduce every target to 0.01 mm and 0.001°, in one arm
/// configuration, with the maker's configuration columns.
#[test]
fn joints_table_reproduces_the_path_through_the_independent_kinematics() {
    use teachcam::robot::check::{CheckConfig, check_path};
    use teachcam::robot::table::joints_csv;
    let targets = painting_loop();
    for robot in all_robots() {
        let cell = painting_cell(&robot);
        let start = std::time::Instant::now();
        let report = check_path(&robot, &cell, &targets, &CheckConfig::default());
        let elapsed = start.elapsed();
        assert!(
            report.passes(),
            "{}: {:?}",
            robot.name,
            report.failing().next().map(|f| &f.issues)
        );
        let csv = joints_csv(&report);
        let mut lines = csv.lines();
        let header = lines.next().unwrap();
        let expected_tail = match robot.maker {
            Maker::Abb => "time_s,cf1,cf4,cf6,cfx,ok",
            Maker::Kuka => "time_s,s,t,ok",
            Maker::UniversalRobots => "time_s,configuration,ok",
        };
        assert_eq!(
            header,
            format!("frame,j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg,{expected_tail}")
        );
        let mut worst = (0.0f64, 0.0f64);
        let mut configurations = std::collections::BTreeSet::new();
        for (line, target) in lines.zip(&targets) {
            let fields: Vec<&str> = line.split(',').collect();
            let degrees: [f64; 6] = std::array::from_fn(|i| fields[i + 1].parse().unwrap());
            let joints = Joints::from_degrees(degrees);
            let left = reference_forward(&robot, &joints) * cell.flange_from_tcp;
            let right = cell.base_from_wobj * target.wobj_from_tcp;
            let (dp, da) = distance(&left, &right);
            worst = (worst.0.max(dp), worst.1.max(da));
            configurations.insert(fields[8..fields.len() - 1].join(","));
        }
        eprintln!(
            "{}: {} frames checked in {:.1} ms, joints table vs independent FK worst {:.2e} mm, {:.2e} deg",
            robot.name,
            targets.len(),
            elapsed.as_secs_f64() * 1e3,
            worst.0,
            worst.1.to_degrees()
        );
        assert!(
            worst.0 <= 0.01 && worst.1.to_degrees() <= 0.001,
            "{}: {worst:?}",
            robot.name
        );
        // KUKA's Turn and ABB's quadrants may change along the loop; UR's branch may not.
        if robot.maker == Maker::UniversalRobots {
            assert_eq!(
                configurations.len(),
                1,
                "{}: {configurations:?}",
                robot.name
            );
        }
    }
}

/// A UR's base sweeping 360° through ±180°: the check follows it continuously (no 360° jump,
/// which no axis could make in a frame) and keeps it inside ±360°; the IRB 120's axis 6 the
/// same through its ±400°.
#[test]
fn turning_axes_are_followed_through_half_turns() {
    use teachcam::robot::check::{CheckConfig, check_path};
    for (robot, axis) in [(Robot::ur5e(), 0), (Robot::irb120(), 5)] {
        let targets: Vec<teachcam::robot::TcpTarget> = (0..301)
            .map(|k| {
                let mut degrees = [10.0, -80.0, 70.0, -60.0, 50.0, 40.0];
                if robot.maker == Maker::Abb {
                    degrees = [10.0, 20.0, -10.0, 30.0, 50.0, 0.0];
                }
                degrees[axis] = -170.0 + 1.2 * f64::from(k);
                teachcam::robot::TcpTarget {
                    frame: teachcam::geometry::FrameIndex(k as usize),
                    time_s: f64::from(k) / 30.0,
                    wobj_from_tcp: reference_forward(&robot, &Joints::from_degrees(degrees)),
                }
            })
            .collect();
        let report = check_path(
            &robot,
            &teachcam::robot::Cell::default(),
            &targets,
            &CheckConfig::default(),
        );
        assert!(
            report.passes(),
            "{}: {:?}",
            robot.name,
            report.failing().next()
        );
        let angles: Vec<f64> = report
            .frames
            .iter()
            .map(|f| f.joints.unwrap().0[axis].to_degrees())
            .collect();
        for pair in angles.windows(2) {
            assert!(
                (pair[1] - pair[0] - 1.2).abs() < 1e-6,
                "{}: {pair:?}",
                robot.name
            );
        }
        assert!(angles.iter().all(|a| a.abs() <= 400.0));
        assert!((angles[300] - angles[0] - 360.0).abs() < 1e-6);
    }
}

/// The programs of the painting loop on a robot of each maker.
fn loop_program(robot: &Robot) -> teachcam::robot::program::Program {
    use teachcam::robot::check::{CheckConfig, check_path};
    use teachcam::robot::program::build_program;
    use teachcam::robot::simplify::SimplifyConfig;
    let cell = painting_cell(robot);
    let report = check_path(robot, &cell, &painting_loop(), &CheckConfig::default());
    assert!(report.passes(), "{}", robot.name);
    build_program("loop_1", &cell, &report, &SimplifyConfig::default())
}

/// The calls `name(args)` of a URScript line, with their argument counts (commas at depth
/// zero inside the call's parentheses).
fn calls(line: &str) -> Vec<(String, usize)> {
    let bytes: Vec<char> = line.chars().collect();
    let mut out = Vec::new();
    for (i, c) in bytes.iter().enumerate() {
        if *c != '(' {
            continue;
        }
        let mut j = i;
        while j > 0 && (bytes[j - 1].is_ascii_alphanumeric() || bytes[j - 1] == '_') {
            j -= 1;
        }
        let name: String = bytes[j..i].iter().collect();
        if name.is_empty() {
            continue;
        }
        let (mut depth, mut args, mut empty) = (0i32, 1usize, true);
        for c in &bytes[i + 1..] {
            match c {
                '(' | '[' => depth += 1,
                ')' | ']' if depth == 0 => break,
                ')' | ']' => depth -= 1,
                ',' if depth == 0 => args += 1,
                c if !c.is_whitespace() => empty = false,
                _ => {}
            }
        }
        out.push((name, if empty { 0 } else { args }));
    }
    out
}

/// Every function a URScript program calls exists in the URScript manual with that arity:
/// the writer's table against the manual's signatures (written here from the e-Series
/// manual), every generated call against the table; the first move is a `movej` whose
/// joints (radians) reach the first target through the independent forward kinematics.
#[test]
fn urscript_calls_exist_with_the_manuals_arity() {
    use teachcam::robot::urscript::{URSCRIPT_FUNCTIONS, UrScriptConfig, urscript_program};
    // URScript manual (e-Series, 5.x): movej(q, a=1.4, v=1.05, t=0, r=0),
    // movel(pose, a=1.2, v=0.25, t=0, r=0), pose_trans(p_from, p_from_to),
    // set_payload(m, cog), set_tcp(pose).
    let manual: [(&str, usize, usize); 5] = [
        ("movej", 1, 5),
        ("movel", 1, 5),
        ("pose_trans", 2, 2),
        ("set_payload", 1, 2),
        ("set_tcp", 1, 1),
    ];
    assert_eq!(URSCRIPT_FUNCTIONS, manual);
    for robot in [Robot::ur5e(), Robot::ur10e()] {
        let program = loop_program(&robot);
        let script = urscript_program(&program, &UrScriptConfig::default());
        let mut seen = std::collections::BTreeSet::new();
        for line in script.lines() {
            let defining = line.trim_start().starts_with("def ");
            for (name, args) in calls(line) {
                if name == program.name {
                    assert!(args == 0 && (defining || line == "loop_1()"), "{line}");
                    continue;
                }
                let Some(&(_, min, max)) = manual.iter().find(|(n, _, _)| *n == name) else {
                    panic!(
                        "{}: '{name}' is not a URScript function: {line}",
                        robot.name
                    );
                };
                assert!((min..=max).contains(&args), "{name} with {args}: {line}");
                seen.insert(name);
            }
        }
        assert_eq!(seen.len(), 5, "{seen:?}");
        let first = script.lines().find(|l| l.contains("movej(")).unwrap();
        let inner = first.split('[').nth(1).unwrap().split(']').next().unwrap();
        let q: Vec<f64> = inner
            .split(',')
            .map(|v| v.trim().parse().unwrap())
            .collect();
        let joints = Joints(q.try_into().unwrap());
        let cell = painting_cell(&robot);
        let reached = reference_forward(&robot, &joints) * cell.flange_from_tcp;
        let wanted = cell.base_from_wobj * program.moves[0].target.wobj_from_tcp;
        let (dp, da) = distance(&reached, &wanted);
        // Six decimals of a radian: 1e-6 rad on arms about a metre long, 0.001 mm.
        assert!(dp < 0.005 && da < 1e-5, "{}: {dp} mm {da} rad", robot.name);
    }
}

/// KRL's structure, checked by hand (no KRL parser is packaged here): `DEF name( )` …
/// `END` once, `DEFDAT name` … `ENDDAT` once, every declaration in the `.dat`, the `.src`
/// executable only; the first motion a `PTP` to a point carrying `S` and `T`; every point a
/// full E6POS (`X Y Z A B C S T E1..E6`); every point moved to declared; S and T those of the
/// joints the check chose.
#[test]
fn krl_programs_have_kukas_structure() {
    use teachcam::robot::krl::krl_program;
    for robot in [Robot::kr6_r700(), Robot::kr6_r900()] {
        let program = loop_program(&robot);
        let krl = krl_program(&program);
        let src: Vec<&str> = krl.src.lines().map(str::trim).collect();
        let dat: Vec<&str> = krl.dat.lines().map(str::trim).collect();
        let body: Vec<&str> = src
            .iter()
            .copied()
            .filter(|l| !l.starts_with('&') && !l.starts_with(';') && !l.is_empty())
            .collect();
        assert_eq!(body.first(), Some(&"DEF loop_1( )"));
        assert_eq!(body.last(), Some(&"END"));
        assert_eq!(body.iter().filter(|l| l.starts_with("DEF ")).count(), 1);
        assert_eq!(body.iter().filter(|l| **l == "END").count(), 1);
        assert!(body.iter().all(|l| !l.starts_with("DECL")));
        for needed in ["$TOOL=", "$BASE=", "$LOAD.M=", "$LOAD.CM="] {
            let at = body.iter().position(|l| l.starts_with(needed)).unwrap();
            let first_motion = body.iter().position(|l| l.starts_with("PTP ")).unwrap();
            assert!(at < first_motion, "{needed} after the first motion");
        }
        let motions: Vec<&str> = body
            .iter()
            .copied()
            .filter(|l| l.starts_with("PTP ") || l.starts_with("LIN "))
            .collect();
        assert!(motions[0].starts_with("PTP XP1"));
        assert!(motions[1..].iter().all(|l| l.starts_with("LIN ")));
        assert_eq!(motions.len(), program.moves.len());
        assert_eq!(dat.iter().filter(|l| l.starts_with("DEFDAT ")).count(), 1);
        assert_eq!(dat.iter().filter(|l| **l == "ENDDAT").count(), 1);
        assert_eq!(dat.last(), Some(&"ENDDAT"));
        let fields = [
            "X", "Y", "Z", "A", "B", "C", "S", "T", "E1", "E2", "E3", "E4", "E5", "E6",
        ];
        let mut points = std::collections::BTreeMap::new();
        for line in dat.iter().filter(|l| l.starts_with("DECL E6POS ")) {
            let (name, value) = line["DECL E6POS ".len()..].split_once('=').unwrap();
            let inner = value.strip_prefix('{').unwrap().strip_suffix('}').unwrap();
            let pairs: Vec<(&str, f64)> = inner
                .split(',')
                .map(|f| {
                    let (k, v) = f.split_once(' ').unwrap();
                    (k, v.parse::<f64>().unwrap())
                })
                .collect();
            let keys: Vec<&str> = pairs.iter().map(|p| p.0).collect();
            assert_eq!(keys, fields, "{line}");
            points.insert(name.to_string(), pairs);
        }
        for m in &motions {
            let name = m.split_whitespace().nth(1).unwrap();
            assert!(points.contains_key(name), "{name} not declared");
        }
        let first = &points["XP1"];
        let move0 = &program.moves[0];
        let st = status_turn(
            &robot,
            &move0.joints.unwrap(),
            &move0.configuration.unwrap(),
        );
        assert_eq!(first[6].1, f64::from(st.status));
        assert_eq!(first[7].1, f64::from(st.turn));
        assert!(st.status < 8 && st.turn < 64);
    }
}

/// RAPID modules through an independent RAPID parser, `rapidchecker` (grammar and format):
/// the golden stroke, and the painting loop's first moves with a given tool load split into
/// routines. Skipped (said so) where the checker is not installed; under CI=true its absence
/// fails.
#[test]
fn rapid_modules_pass_rapidchecker() {
    use teachcam::robot::program::ToolLoad;
    use teachcam::robot::rapid::{RapidConfig, rapid_module};
    let dir = tempfile::tempdir().unwrap();
    let golden = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/robot/stroke.mod"),
    )
    .unwrap();
    let mut program = loop_program(&Robot::irb120());
    // The first 15 moves: the checker (pyparsing) takes seconds per module.
    program.moves.truncate(15);
    program.load = Some(ToolLoad {
        mass_kg: 1.5,
        cog_in_flange: Vector3::new(0.0, -10.0, 80.0),
    });
    let loaded = rapid_module(&program, &RapidConfig::default());
    let split = rapid_module(
        &program,
        &RapidConfig {
            max_moves_per_routine: 7,
        },
    );
    assert!(split.matches("PROC path_").count() > 1);
    let mut files = Vec::new();
    for (name, text) in [
        ("stroke.mod", golden),
        ("loaded.mod", loaded),
        ("split.mod", split),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        files.push(path);
    }
    let test = "rapid_modules_pass_rapidchecker";
    let Some(parsed) = teachcam_testdata::rapidchecker(test, &files) else {
        return;
    };
    if let Err(output) = parsed {
        panic!("{output}");
    }
    // The checker can fail: a comma where RAPID wants a semicolon is refused.
    let broken = dir.path().join("broken.mod");
    let text = std::fs::read_to_string(&files[0])
        .unwrap()
        .replacen("ENDPROC", "ENDPROC,", 1);
    std::fs::write(&broken, text).unwrap();
    assert!(
        teachcam_testdata::rapidchecker(test, &[broken]).is_some_and(|r| r.is_err()),
        "rapidchecker accepted a broken module"
    );
}

/// The IRB 120's load diagram (product specification 3HAC035960-001, "Maximum load and moment
/// of inertia"): J5 = m ((Z + 0.072)² + L²) ≤ 0.175 kg·m², J6 = m L² ≤ 0.085 kg·m², with the
/// rated 3 kg. Values worked by hand from those formulas.
#[test]
fn the_irb120_load_diagram_refuses_a_far_centre_of_gravity() {
    let robot = Robot::irb120();
    // 2 kg 200 mm out along the flange's axis: J5 = 2 · 0.272² = 0.148: fits.
    assert_eq!(robot.load_problem(2.0, [0.0, 0.0, 200.0]), Ok(None));
    // 3 kg there: J5 = 3 · 0.272² = 0.222 > 0.175.
    let refusal = robot.load_problem(3.0, [0.0, 0.0, 200.0]).unwrap_err();
    assert!(
        refusal.contains("axis 5") && refusal.contains("0.222"),
        "{refusal}"
    );
    // 2 kg 250 mm to the side: J5 = 2 (0.072² + 0.25²) = 0.135 fits, J6 = 2 · 0.0625 = 0.125 > 0.085.
    let refusal = robot.load_problem(2.0, [250.0, 0.0, 0.0]).unwrap_err();
    assert!(
        refusal.contains("axis 6") && refusal.contains("0.125"),
        "{refusal}"
    );
    // Over the rated payload whatever the centre of gravity.
    assert!(
        robot
            .load_problem(3.5, [0.0; 3])
            .unwrap_err()
            .contains("3 kg")
    );
    // A model without a load diagram says the centre of gravity went unchecked.
    assert!(
        Robot::ur5e()
            .load_problem(2.0, [0.0, 0.0, 500.0])
            .unwrap()
            .is_some_and(|note| note.contains("not checked"))
    );
}
