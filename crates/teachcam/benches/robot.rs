//! Robot stage benchmarks: forward and inverse kinematics, the check of a one-minute path,
//! simplification, the RAPID writer and pivot calibration, on seeded closed-form inputs.
//! Python references (same inputs, this machine): `scripts/reference/bench_robot.py`.

use std::f64::consts::{PI, TAU};
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use teachcam::geometry::{FrameIndex, Pose, pose_from_parts};
use teachcam::robot::check::{CheckConfig, check_path};
use teachcam::robot::frames::{PivotConfig, pivot_calibration};
use teachcam::robot::kinematics::{Joints, Robot, forward, inverse};
use teachcam::robot::program::build_program;
use teachcam::robot::rapid::{RapidConfig, rapid_module};
use teachcam::robot::simplify::{SimplifyConfig, simplify};
use teachcam::robot::{Cell, TcpTarget};

/// 10 000 joint vectors uniformly inside the IRB 120's ranges.
fn random_joints() -> Vec<Joints> {
    let model = Robot::irb120();
    let mut rng = ChaCha8Rng::seed_from_u64(120);
    (0..10_000)
        .map(|_| {
            Joints(std::array::from_fn(|i| {
                let l = &model.limits[i];
                rng.random_range(l.min..l.max)
            }))
        })
        .collect()
}

/// A one-minute painter's stroke at 30 Hz (1800 targets), brush pointing down.
fn minute_stroke() -> Vec<TcpTarget> {
    (0..1800)
        .map(|k| {
            let t = f64::from(k) / 30.0;
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
            TcpTarget {
                frame: FrameIndex(k as usize),
                time_s: t,
                wobj_from_tcp: pose_from_parts(
                    tip,
                    tilt * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI),
                ),
            }
        })
        .collect()
}

fn cell() -> Cell {
    Cell {
        base_from_wobj: pose_from_parts(
            Vector3::new(350.0, 0.0, 150.0),
            UnitQuaternion::identity(),
        ),
        flange_from_tcp: pose_from_parts(Vector3::new(0.0, 0.0, 150.0), UnitQuaternion::identity()),
    }
}

fn kinematics(c: &mut Criterion) {
    let model = Robot::irb120();
    let joints = random_joints();
    let poses: Vec<Pose> = joints.iter().map(|j| forward(&model, j)).collect();
    let mut group = c.benchmark_group("robot");
    group.bench_function("forward_10k", |b| {
        b.iter(|| {
            for j in &joints {
                black_box(forward(&model, black_box(j)));
            }
        });
    });
    group.bench_function("inverse_all_solutions_10k", |b| {
        b.iter(|| {
            for p in &poses {
                black_box(inverse(&model, black_box(p)));
            }
        });
    });
    let targets = minute_stroke();
    let cell = cell();
    group.bench_function("check_1800_frames", |b| {
        b.iter(|| check_path(&model, &cell, black_box(&targets), &CheckConfig::default()));
    });
    let tolerance = SimplifyConfig::default();
    group.bench_function("simplify_1800_frames", |b| {
        b.iter(|| simplify(black_box(&targets), &tolerance));
    });
    let report = check_path(&model, &cell, &targets, &CheckConfig::default());
    group.bench_function("rapid_1800_frames", |b| {
        b.iter(|| {
            let program = build_program("stroke", &cell, black_box(&report), &tolerance);
            rapid_module(&program, &RapidConfig::default())
        });
    });
    let tip = Vector3::new(3.0, -15.0, -180.0);
    let pivots: Vec<Pose> = (0..300)
        .map(|k| {
            let t = f64::from(k) / 300.0 * TAU;
            let r = UnitQuaternion::from_euler_angles(
                0.5 * t.sin(),
                0.5 * t.cos(),
                0.3 * (2.0 * t).sin(),
            );
            pose_from_parts(Vector3::new(100.0, 50.0, 0.0) - r * tip, r)
        })
        .collect();
    group.bench_function("pivot_300_poses", |b| {
        b.iter(|| pivot_calibration(black_box(&pivots), &PivotConfig::default()));
    });
    group.finish();
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
