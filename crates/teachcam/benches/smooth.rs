//! Smoothing benchmarks: one hour of trajectory at 100 Hz (360,000 frames), file to file and in
//! memory. The SciPy side of the same job is `scripts/reference/smooth_bench_scipy.py`; the
//! numbers are in `notes/smooth.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use teachcam::geometry::{FrameIndex, Point3, pose_from_parts};
use teachcam::io::trajectory::{read_trajectory, write_trajectory};
use teachcam::smooth::{Method, SmoothConfig, smooth};
use teachcam::trajectory::{Sample, ToolPose, Trajectory};

const FS_HZ: f64 = 100.0;

/// A painter's hour: slow sinusoids plus 0.3 mm and 2 mrad of noise, seeded.
fn hour() -> Trajectory {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mm = Normal::new(0.0, 0.3).unwrap_or_else(|_| unreachable!());
    let rad = Normal::new(0.0, 0.002).unwrap_or_else(|_| unreachable!());
    let tip_in_tool = Point3::new(0.0, -15.0, -180.0);
    let tau = std::f64::consts::TAU;
    let samples = (0..360_000)
        .map(|i| {
            let t = i as f64 / FS_HZ;
            let position = Vector3::new(
                300.0 + 80.0 * (tau * 0.21 * t).sin() + mm.sample(&mut rng),
                50.0 * (tau * 0.17 * t).cos() + mm.sample(&mut rng),
                120.0 + 20.0 * (tau * 0.5 * t).sin() + mm.sample(&mut rng),
            );
            let rotation = UnitQuaternion::from_scaled_axis(Vector3::new(
                0.4 * (tau * 0.11 * t).sin() + rad.sample(&mut rng),
                0.3 * (tau * 0.07 * t).cos() + rad.sample(&mut rng),
                (tau * 0.05 * t).sin() + rad.sample(&mut rng),
            ));
            let world_from_tool = pose_from_parts(position, rotation);
            Sample::measured(
                FrameIndex(i),
                t,
                ToolPose {
                    world_from_tool,
                    tip_in_world: world_from_tool * tip_in_tool,
                    markers: 4,
                    rms_mm: 0.02,
                },
            )
        })
        .collect();
    Trajectory { samples }
}

fn bench(c: &mut Criterion) {
    let trajectory = hour();
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("temporary folder: {e}"));
    let input = dir.path().join("hour.csv");
    let output = dir.path().join("smoothed.csv");
    write_trajectory(&input, &trajectory).unwrap_or_else(|e| panic!("{e}"));
    let config = SmoothConfig::default();
    let mut group = c.benchmark_group("smooth");
    group.sample_size(10);
    group.bench_function("file_to_file_1h_100hz_lowpass_10hz", |b| {
        b.iter(|| {
            let t = read_trajectory(&input).unwrap_or_else(|e| panic!("{e}"));
            let s = smooth(&t, &config).unwrap_or_else(|e| panic!("{e}"));
            write_trajectory(&output, &s).unwrap_or_else(|e| panic!("{e}"));
        });
    });
    group.bench_function("read_1h", |b| {
        b.iter(|| black_box(read_trajectory(&input).unwrap_or_else(|e| panic!("{e}"))));
    });
    group.bench_function("lowpass_in_memory_1h", |b| {
        b.iter(|| black_box(smooth(&trajectory, &config).unwrap_or_else(|e| panic!("{e}"))));
    });
    let nurbs = SmoothConfig {
        method: Method::Nurbs {
            degree: 3,
            knot_spacing_s: 0.1,
        },
        ..config
    };
    group.bench_function("nurbs_in_memory_1h", |b| {
        b.iter(|| black_box(smooth(&trajectory, &nurbs).unwrap_or_else(|e| panic!("{e}"))));
    });
    group.bench_function("write_1h", |b| {
        b.iter(|| write_trajectory(&output, &trajectory).unwrap_or_else(|e| panic!("{e}")));
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
