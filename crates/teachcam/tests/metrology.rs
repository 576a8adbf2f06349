//! Monte Carlo through the real tracking chain against the closed-form first-order
//! propagation, on the paper's rig.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use teachcam::metrology::{first_order, monte_carlo};
use teachcam::sim::{Scenario, build_scene};
use teachcam::track::TrackConfig;

#[test]
fn monte_carlo_and_first_order_agree_on_three_poses() {
    let scene = build_scene(Scenario::Paper, 1);
    let trials = 3000;
    for frame in [0, 45, 100] {
        let pose = scene.truth.samples[frame].pose.unwrap().world_from_tool;
        let mc = monte_carlo(
            &scene.rig,
            &scene.tool,
            &pose,
            0.15,
            trials,
            11,
            &TrackConfig::default(),
        )
        .unwrap();
        let fo = first_order(&scene.rig, &scene.tool, &pose, 0.15).unwrap();
        println!(
            "frame {frame}: tip RMS MC {:.4} mm, first order {:.4} mm; failed {}",
            mc.uncertainty.tip_rms_mm, fo.tip_rms_mm, mc.failed_trials
        );
        assert_eq!(mc.failed_trials, 0);
        // The relative sampling error of a standard deviation from n trials is 1/sqrt(2n), 1.3 %
        // here; 10 % leaves room for the non-linearity the first-order model ignores.
        let close = |a: f64, b: f64| (a - b).abs() / b < 0.10;
        assert!(
            close(mc.uncertainty.tip_rms_mm, fo.tip_rms_mm),
            "tip RMS {} vs {}",
            mc.uncertainty.tip_rms_mm,
            fo.tip_rms_mm
        );
        for axis in 0..3 {
            assert!(
                close(mc.uncertainty.tip_std_mm[axis], fo.tip_std_mm[axis]),
                "tip std axis {axis}"
            );
            assert!(
                close(
                    mc.uncertainty.rotation_std_deg[axis],
                    fo.rotation_std_deg[axis]
                ),
                "rotation std axis {axis}"
            );
            assert!(
                close(
                    mc.uncertainty.position_std_mm[axis],
                    fo.position_std_mm[axis]
                ),
                "position std axis {axis}"
            );
            // No bias beyond 4 standard errors of the mean.
            assert!(
                mc.tip_bias_mm[axis].abs()
                    < 4.0 * mc.uncertainty.tip_std_mm[axis] / (trials as f64).sqrt(),
                "bias axis {axis}"
            );
        }
    }
}

#[test]
fn monte_carlo_is_deterministic_for_a_seed() {
    let scene = build_scene(Scenario::Paper, 1);
    let pose = scene.truth.samples[10].pose.unwrap().world_from_tool;
    let a = monte_carlo(
        &scene.rig,
        &scene.tool,
        &pose,
        0.1,
        600,
        5,
        &TrackConfig::default(),
    )
    .unwrap();
    let b = monte_carlo(
        &scene.rig,
        &scene.tool,
        &pose,
        0.1,
        600,
        5,
        &TrackConfig::default(),
    )
    .unwrap();
    assert_eq!(a, b);
}

/// The pixel error the triangulation residuals show is the noise put in: 2000 points of the
/// paper's work volume projected into its three cameras (and, for every fourth, two of them)
/// with Gaussian noise of σ per coordinate, triangulated by the tracker's own code.
#[test]
fn residuals_show_the_pixel_noise() {
    use rand::{RngExt, SeedableRng};
    use rand_distr::{Distribution, Normal};
    use teachcam::geometry::{CameraId, Pixel, Point3};
    use teachcam::metrology::residual_noise_px;
    use teachcam::triangulate::{TriangulateConfig, triangulate};

    let scene = build_scene(Scenario::Paper, 1);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for sigma_px in [0.01, 0.15] {
        let noise = Normal::new(0.0, sigma_px).unwrap();
        let mut points = Vec::new();
        let mut freedom = 0_u32;
        for k in 0..2000 {
            let tip = scene.truth.samples[k % scene.truth.samples.len()]
                .pose
                .unwrap()
                .tip_in_world;
            let point = Point3::new(
                tip.x + rng.random_range(-50.0..50.0),
                tip.y + rng.random_range(-50.0..50.0),
                tip.z + rng.random_range(-50.0..50.0),
            );
            let cameras = if k % 4 == 0 { 2 } else { 3 };
            let views = (0..cameras)
                .map(|c| {
                    let p = scene.rig.cameras[c].project(&point).unwrap();
                    let noisy =
                        Pixel::new(p.x + noise.sample(&mut rng), p.y + noise.sample(&mut rng));
                    (CameraId(c), noisy)
                })
                .collect();
            points.push(triangulate(&scene.rig, &views, &TriangulateConfig::default()).unwrap());
            freedom += 2 * cameras as u32 - 3;
        }
        let shown = residual_noise_px(&points).unwrap();
        // σ̂²/σ² is χ²(ν)/ν with ν = 5000 degrees of freedom here: relative SD of σ̂ is
        // 1/sqrt(2ν) = 1 %; 4 % is four of those.
        println!("σ {sigma_px} px: residuals show {shown:.5} px over {freedom} degrees of freedom");
        assert!(
            (shown / sigma_px - 1.0).abs() < 4.0 / (2.0 * f64::from(freedom)).sqrt(),
            "{shown}"
        );
    }
}
