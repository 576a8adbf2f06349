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
