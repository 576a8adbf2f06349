//! Smoothing whole trajectories: positions as scipy, rotations on SO(3), tip, gaps, bad input.

use nalgebra::{UnitQuaternion, Vector3};
use serde_json::Value;
use teachcam::geometry::{FrameIndex, Point3, pose_from_parts};
use teachcam::smooth::bezier::bezier_at_samples;
use teachcam::smooth::butterworth::Butterworth;
use teachcam::smooth::spline::SplineEnds;
use teachcam::smooth::{CutoffConvention, Method, ShortRuns, SmoothConfig, SmoothError, smooth};
use teachcam::trajectory::{PoseSource, Sample, ToolPose, Trajectory};

const TIP_IN_TOOL: Point3 = Point3::new(0.0, -15.0, -180.0);

fn trajectory(fs: f64, positions: &[[f64; 3]], rotations: &[UnitQuaternion<f64>]) -> Trajectory {
    let samples = positions
        .iter()
        .zip(rotations)
        .enumerate()
        .map(|(i, (p, r))| {
            let world_from_tool = pose_from_parts(Vector3::new(p[0], p[1], p[2]), *r);
            Sample::measured(
                FrameIndex(i),
                i as f64 / fs,
                ToolPose {
                    world_from_tool,
                    tip_in_world: world_from_tool * TIP_IN_TOOL,
                    markers: 4,
                    rms_mm: 0.02,
                },
            )
        })
        .collect();
    Trajectory { samples }
}

fn lowpass(cutoff_hz: f64, order: usize) -> SmoothConfig {
    SmoothConfig {
        method: Method::Lowpass {
            cutoff_hz,
            order,
            convention: CutoffConvention::SinglePass,
        },
        ..SmoothConfig::default()
    }
}

/// A deterministic pseudo-noise in [-1, 1] (no RNG needed for these laws).
fn noise(i: usize, salt: f64) -> f64 {
    ((i as f64 * 12.9898 + salt * 78.233).sin() * 43758.5453).rem_euclid(1.0) * 2.0 - 1.0
}

#[test]
fn positions_are_scipy_filtfilt_and_the_tip_follows_the_smoothed_pose() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/smooth/scipy_reference.json"
    );
    let r: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    for case in r["lowpass"].as_array().unwrap() {
        let fs = case["fs_hz"].as_f64().unwrap();
        let order = case["order"].as_u64().unwrap() as usize;
        let fc = case["cutoff_hz"].as_f64().unwrap();
        let x: Vec<f64> = case["x"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let y: Vec<f64> = case["y"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let positions: Vec<[f64; 3]> = x.iter().map(|v| [*v, -0.5 * v, 300.0 + 2.0 * v]).collect();
        let rotations: Vec<_> = (0..x.len())
            .map(|i| {
                UnitQuaternion::from_euler_angles(
                    0.3 + 0.01 * noise(i, 1.0),
                    0.1 * i as f64 / fs,
                    0.2,
                )
            })
            .collect();
        let out = smooth(&trajectory(fs, &positions, &rotations), &lowpass(fc, order)).unwrap();
        let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (s, expected) in out.samples.iter().zip(&y) {
            let pose = s.pose.unwrap();
            let t = pose.world_from_tool.translation.vector;
            assert!(
                (t.x - expected).abs() < 1e-9 * scale,
                "{fc} Hz order {order}"
            );
            assert!((t.y + 0.5 * expected).abs() < 1e-9 * scale);
            assert!((t.z - 300.0 - 2.0 * expected).abs() < 1e-9 * (300.0 + 2.0 * scale));
            let tip = pose.world_from_tool * TIP_IN_TOOL;
            assert!((tip - pose.tip_in_world).norm() < 1e-9);
            assert_eq!(s.source, PoseSource::Measured);
        }
    }
}

#[test]
fn rotation_about_one_axis_is_smoothed_exactly_as_its_angle() {
    // Two and a half turns about a tilted axis with noise: the result's angle is filtfilt of
    // the unwrapped angle, and the quaternions stay unit.
    let fs = 100.0;
    let n = 600;
    let axis = Vector3::new(0.2, -0.4, 0.9).normalize();
    let angle: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            2.5 * std::f64::consts::TAU * t / 6.0 + 0.4 * (2.0 * t).sin() + 0.01 * noise(i, 2.0)
        })
        .collect();
    let rotations: Vec<_> = angle
        .iter()
        .map(|a| UnitQuaternion::from_scaled_axis(axis * *a))
        .collect();
    let positions = vec![[0.0; 3]; n];
    let out = smooth(&trajectory(fs, &positions, &rotations), &lowpass(5.0, 4)).unwrap();
    let expected = Butterworth::lowpass(4, 5.0, fs)
        .unwrap()
        .filtfilt(&angle)
        .unwrap();
    for (s, a) in out.samples.iter().zip(&expected) {
        let r = s.pose.unwrap().world_from_tool.rotation;
        let truth = UnitQuaternion::from_scaled_axis(axis * *a);
        assert!(r.angle_to(&truth) < 1e-9, "{}", r.angle_to(&truth));
        assert!((r.quaternion().norm() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn large_smooth_rotations_about_moving_axes_pass_the_lowpass_unchanged() {
    // 100-degree swings about all three axes at 0.2-0.4 Hz, far below a 10 Hz cut-off:
    // a linear filter passes such motion within |1 - H(f)|, and so must the SO(3) one.
    let fs = 100.0;
    let n = 1000;
    let rotations: Vec<_> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            UnitQuaternion::from_euler_angles(
                0.9 * (0.4 * std::f64::consts::TAU * t).sin(),
                0.7 * (0.25 * std::f64::consts::TAU * t).cos(),
                1.5 * (0.2 * std::f64::consts::TAU * t).sin(),
            )
        })
        .collect();
    let positions = vec![[0.0; 3]; n];
    let out = smooth(&trajectory(fs, &positions, &rotations), &lowpass(10.0, 4)).unwrap();
    let change: Vec<f64> = out
        .samples
        .iter()
        .zip(&rotations)
        .map(|(s, r)| s.pose.unwrap().world_from_tool.rotation.angle_to(r))
        .collect();
    let worst = change.iter().copied().fold(0.0, f64::max);
    let interior = change[50..n - 50].iter().copied().fold(0.0, f64::max);
    // Inside, |1 - H(0.4 Hz)²| ≈ 1e-11 for the scalar filter; measured 1.8e-8 rad here, the
    // unrolling's second-order terms.
    assert!(interior < 1e-6, "largest change inside {interior:e} rad");
    // At the ends, scipy's odd-extension padding moves any curved signal: bound the SO(3)
    // change by the scalar filter's change on the three Euler angles at the ends.
    let filter = Butterworth::lowpass(4, 10.0, fs).unwrap();
    let scalar_end_change = (0..3)
        .map(|axis| {
            let angle: Vec<f64> = rotations
                .iter()
                .map(|r| {
                    let (a, b, c) = r.euler_angles();
                    [a, b, c][axis]
                })
                .collect();
            let filtered = filter.filtfilt(&angle).unwrap();
            angle
                .iter()
                .zip(&filtered)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    eprintln!("so3 {worst:e}, scalar Euler {scalar_end_change:e}");
    assert!(
        worst < 2.0 * scalar_end_change,
        "largest change {worst:e} rad, scalar filter's {scalar_end_change:e}"
    );
}

#[test]
fn short_gaps_are_filled_and_marked_long_gaps_stay() {
    // A cubic motion: not-a-knot splines reproduce cubics, so the filled frames are exact.
    let fs = 30.0;
    let n = 60;
    let f = |t: f64| [10.0 + 3.0 * t - t * t + 0.5 * t.powi(3), -2.0 * t, 5.0];
    let positions: Vec<[f64; 3]> = (0..n).map(|i| f(i as f64 / fs)).collect();
    let axis = Vector3::z_axis();
    let rotations: Vec<_> = (0..n)
        .map(|i| UnitQuaternion::from_axis_angle(&axis, 0.05 * i as f64))
        .collect();
    let mut t = trajectory(fs, &positions, &rotations);
    for i in (10..13).chain(30..45) {
        t.samples[i].pose = None;
    }
    let config = SmoothConfig {
        method: Method::Spline {
            ends: SplineEnds::NotAKnot,
        },
        max_gap_frames: 5,
        ..SmoothConfig::default()
    };
    let out = smooth(&t, &config).unwrap();
    for (i, rotation) in rotations.iter().enumerate().take(13).skip(10) {
        let s = &out.samples[i];
        assert_eq!(s.source, PoseSource::Filled);
        let p = s.pose.unwrap();
        let x = p.world_from_tool.translation.vector;
        let truth = f(i as f64 / fs);
        assert!((x.x - truth[0]).abs() < 1e-9 && (x.y - truth[1]).abs() < 1e-9);
        assert!(p.world_from_tool.rotation.angle_to(rotation) < 1e-12);
        assert!((p.world_from_tool * TIP_IN_TOOL - p.tip_in_world).norm() < 1e-9);
    }
    assert!((30..45).all(|i| out.samples[i].pose.is_none()));
    assert_eq!(out.samples[29].source, PoseSource::Measured);
    // A spline through uniform samples gives the samples back: no noise is removed (Fig. 4).
    for i in 0..10 {
        let a = out.samples[i].pose.unwrap().world_from_tool;
        let b = t.samples[i].pose.unwrap().world_from_tool;
        assert!((a.translation.vector - b.translation.vector).norm() < 1e-12);
    }
}

#[test]
fn bezier_through_all_samples_flattens_a_sinusoid_by_cos_pi_over_period_to_the_degree() {
    // With the N samples x_k = sin(2πk/T + φ) as control points, the curve at u = 1/2 is
    // Σ B_k(1/2) x_k = cos(π/T)^(N-1) · x_{(N-1)/2}: the motion shrinks with every sample added
    // (paper §III-B, Fig. 5), while the noise is averaged away.
    for (samples, period) in [(201, 50.0), (401, 40.0), (101, 25.0)] {
        let x: Vec<f64> = (0..samples)
            .map(|k| (std::f64::consts::TAU * k as f64 / period + 0.7).sin())
            .collect();
        let curve = bezier_at_samples(&x);
        let middle = (samples - 1) / 2;
        let gain = (std::f64::consts::PI / period)
            .cos()
            .powi(samples as i32 - 1);
        assert!((curve[middle] - gain * x[middle]).abs() < 1e-12);
        assert!(gain < 0.7, "the flattening is large: {gain}");
    }
}

#[test]
fn nurbs_removes_noise_and_keeps_slow_motion() {
    let fs = 100.0;
    let n = 500;
    let clean: Vec<f64> = (0..n)
        .map(|i| 40.0 * (std::f64::consts::TAU * 0.5 * i as f64 / fs).sin())
        .collect();
    let positions: Vec<[f64; 3]> = clean
        .iter()
        .enumerate()
        .map(|(i, c)| [c + noise(i, 3.0), 0.0, 0.0])
        .collect();
    let rotations = vec![UnitQuaternion::identity(); n];
    let config = SmoothConfig {
        method: Method::Nurbs {
            degree: 3,
            knot_spacing_s: 0.2,
        },
        ..SmoothConfig::default()
    };
    let out = smooth(&trajectory(fs, &positions, &rotations), &config).unwrap();
    let rms =
        |f: &dyn Fn(usize) -> f64| ((0..n).map(|i| f(i).powi(2)).sum::<f64>() / n as f64).sqrt();
    let raw = rms(&|i| positions[i][0] - clean[i]);
    let fitted = rms(&|i| out.samples[i].pose.unwrap().world_from_tool.translation.x - clean[i]);
    // Uniform noise of RMS 0.577 mm; a 0.2 s knot spacing keeps ~13 of 500 degrees of freedom.
    assert!(fitted < 0.3 * raw, "fitted {fitted} raw {raw}");
}

#[test]
fn bad_input_is_refused_with_the_frame() {
    let fs = 100.0;
    let n = 40;
    let positions: Vec<[f64; 3]> = (0..n).map(|i| [i as f64, 0.0, 0.0]).collect();
    let rotations = vec![UnitQuaternion::identity(); n];
    let good = trajectory(fs, &positions, &rotations);
    let message = |t: &Trajectory, c: &SmoothConfig| smooth(t, c).unwrap_err().to_string();

    let mut uneven = good.clone();
    uneven.samples[17].time_s += 0.004;
    assert!(message(&uneven, &lowpass(5.0, 2)).contains("frame 17"));

    let mut skipped = good.clone();
    skipped.samples.remove(20);
    assert!(message(&skipped, &lowpass(5.0, 2)).contains("frame 21 follows frame 19"));
    // A missing row is named before an uneven step, even one earlier in the file.
    let mut both = skipped.clone();
    both.samples[5].time_s += 0.004;
    assert!(message(&both, &lowpass(5.0, 2)).contains("frame 21 follows frame 19"));
    both.samples.insert(20, good.samples[20]);
    assert!(message(&both, &lowpass(5.0, 2)).contains("frame 5"));

    let nyquist = message(&good, &lowpass(50.0, 2));
    assert!(nyquist.contains("Nyquist"), "{nyquist}");

    let mut short = good.clone();
    for i in 10..13 {
        short.samples[i].pose = None;
    }
    // 10 Hz: the 27 samples of frames 13..=39 hold its step response (20 samples to settle;
    // 5 Hz would need 33 and be refused as below what the run can hold).
    let config = SmoothConfig {
        max_gap_frames: 0,
        ..lowpass(10.0, 4)
    };
    let too_short = message(&short, &config);
    assert!(
        too_short.contains("frames 0..=9") && too_short.contains("padding"),
        "{too_short}"
    );

    // The same run turned into an explicit gap on request.
    let as_gap = SmoothConfig {
        short_runs: ShortRuns::Gap,
        ..config
    };
    let out = smooth(&short, &as_gap).unwrap();
    assert!(out.samples[..13].iter().all(|s| s.pose.is_none()));
    assert!(out.samples[13..].iter().all(|s| s.pose.is_some()));

    let mut moved_tip = good.clone();
    if let Some(p) = moved_tip.samples[33].pose.as_mut() {
        p.tip_in_world.x += 1.0;
    }
    assert!(matches!(
        smooth(&moved_tip, &lowpass(5.0, 2)),
        Err(SmoothError::InconsistentTip { frame: 33, .. })
    ));
    // Given the tool's tip, the trajectory's own tip column is not needed.
    let given = SmoothConfig {
        tip_in_tool: Some(TIP_IN_TOOL),
        ..lowpass(5.0, 2)
    };
    assert!(smooth(&moved_tip, &given).is_ok());

    let mut nan = good.clone();
    if let Some(p) = nan.samples[5].pose.as_mut() {
        p.world_from_tool.translation.vector.y = f64::NAN;
    }
    assert!(message(&nan, &lowpass(5.0, 2)).contains("frame 5"));
}

mod never_panics {
    use super::*;
    use proptest::prelude::*;

    fn method() -> impl Strategy<Value = Method> {
        prop_oneof![
            (0.0f64..60.0, 0usize..14).prop_map(|(cutoff_hz, order)| Method::Lowpass {
                cutoff_hz,
                order,
                convention: CutoffConvention::WinterTwoPass,
            }),
            Just(Method::Spline {
                ends: SplineEnds::Natural
            }),
            (1usize..60).prop_map(|max_control_points| Method::Bezier { max_control_points }),
            (0usize..8, prop_oneof![-0.1f64..1.0, 1e-300f64..1e-250]).prop_map(
                |(degree, knot_spacing_s)| Method::Nurbs {
                    degree,
                    knot_spacing_s
                }
            ),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Any trajectory (gaps anywhere, wild values, jittered times) with any method gives a
        /// trajectory of the same frames or an error, never a panic; poses keep unit
        /// quaternions and finite numbers.
        #[test]
        fn smooth_returns_a_result_for_any_input(
            values in proptest::collection::vec((any::<bool>(), -1e4f64..1e4, -4.0f64..4.0), 0..60),
            jitter in proptest::option::of(0usize..60),
            max_gap_frames in 0usize..8,
            method in method(),
        ) {
            let mut samples: Vec<Sample> = values
                .iter()
                .enumerate()
                .map(|(i, (present, x, angle))| {
                    let world_from_tool = pose_from_parts(
                        Vector3::new(*x, -x, 1.0),
                        UnitQuaternion::from_euler_angles(*angle, -angle, 0.5 * angle),
                    );
                    let mut s = Sample::measured(FrameIndex(i), i as f64 / 30.0, ToolPose {
                        world_from_tool,
                        tip_in_world: world_from_tool * TIP_IN_TOOL,
                        markers: 4,
                        rms_mm: 0.0,
                    });
                    if !present {
                        s.pose = None;
                    }
                    s
                })
                .collect();
            if let Some(j) = jitter.filter(|j| *j < samples.len()) {
                samples[j].time_s += 0.01;
            }
            let t = Trajectory { samples };
            let config = SmoothConfig { method, max_gap_frames, ..SmoothConfig::default() };
            if let Ok(out) = smooth(&t, &config) {
                prop_assert_eq!(out.len(), t.len());
                for s in &out.samples {
                    if let Some(p) = s.pose {
                        prop_assert!((p.world_from_tool.rotation.quaternion().norm() - 1.0).abs() < 1e-9);
                        prop_assert!(p.world_from_tool.translation.vector.iter().all(|v| v.is_finite()));
                    }
                }
            }
        }
    }
}

#[test]
fn sample_rate_survives_the_csv_microsecond_rounding() {
    // 1/30 s is written as 0.033333: the span read back is off by up to 1e-6 s.
    for (fs, n) in [(30.0, 901), (29.97, 500), (100.0, 1234), (119.88, 77)] {
        let positions = vec![[1.0, 2.0, 3.0]; n];
        let rotations = vec![UnitQuaternion::identity(); n];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        teachcam::io::trajectory::write_trajectory(&path, &trajectory(fs, &positions, &rotations))
            .unwrap();
        let back = teachcam::io::trajectory::read_trajectory(&path).unwrap();
        let timing = teachcam::smooth::check_timing(&back, 1e-3).unwrap();
        assert_eq!(timing.sample_rate_hz, fs);
    }
}

#[test]
fn spline_method_fills_gaps_with_its_own_end_conditions() {
    // Natural ends bend a cubic near the ends, not-a-knot does not: a gap near the start,
    // filled by the spline method, follows the ends asked for (the spline itself is checked
    // against scipy in smooth_scipy.rs).
    use teachcam::smooth::spline::CubicSpline;
    let fs = 30.0;
    let n = 20;
    let f = |t: f64| 5.0 * t.powi(3) + 3.0 * t * t - t;
    let positions: Vec<[f64; 3]> = (0..n).map(|i| [f(i as f64 / fs), 0.0, 0.0]).collect();
    let rotations = vec![UnitQuaternion::identity(); n];
    let mut t = trajectory(fs, &positions, &rotations);
    t.samples[2].pose = None;
    let measured: Vec<usize> = (0..n).filter(|i| *i != 2).collect();
    let x: Vec<f64> = measured.iter().map(|i| *i as f64 / fs).collect();
    let y: Vec<f64> = measured.iter().map(|i| positions[*i][0]).collect();
    for ends in [SplineEnds::Natural, SplineEnds::NotAKnot] {
        let config = SmoothConfig {
            method: Method::Spline { ends },
            ..SmoothConfig::default()
        };
        let out = smooth(&t, &config).unwrap();
        let filled = out.samples[2].pose.unwrap().world_from_tool.translation.x;
        let expected = CubicSpline::new(&x, &y, ends).unwrap().value(2.0 / fs);
        assert!((filled - expected).abs() < 1e-12, "{ends:?}");
    }
    let natural = CubicSpline::new(&x, &y, SplineEnds::Natural)
        .unwrap()
        .value(2.0 / fs);
    assert!(
        (natural - f(2.0 / fs)).abs() > 1e-6,
        "the two ends must differ here"
    );
}
