//! The paper's metrology loop closed on images: on the simulator's `static` recording (the
//! brush at rest, only the image noise changes), the spread of the detected marker centres
//! gives the pixel noise; Monte Carlo and first-order propagation at that noise must predict
//! the spread of the tracked tip.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::collections::BTreeMap;

use teachcam::correspond::Views;
use teachcam::detect::{DetectConfig, detect};
use teachcam::geometry::{CameraId, Point3};
use teachcam::metrology::{first_order, monte_carlo};
use teachcam::sim::{Scenario, build_scene, render_frame};
use teachcam::track::{TrackConfig, Tracker};

#[test]
fn tracked_tip_spread_matches_the_predicted_uncertainty() {
    let scene = build_scene(Scenario::Static, 2);
    let configs: Vec<DetectConfig> = scene
        .rig
        .cameras
        .iter()
        .map(|c| DetectConfig::for_marker(c, scene.tool.marker_diameter_mm, 300.0, 3000.0))
        .collect();
    let tracker = Tracker::new(&scene.rig, &scene.tool, TrackConfig::default());
    let mut tips: Vec<Point3> = Vec::new();
    // Detected centres per (camera, marker), matched to the truth by proximity.
    let mut centres: BTreeMap<(CameraId, usize), Vec<(f64, f64)>> = BTreeMap::new();
    for frame in 0..scene.truth.len() {
        let rendered = render_frame(&scene, frame, 2);
        let mut views = Views::new();
        for view in &rendered {
            let blobs = detect(&view.image, &configs[view.camera.0]).unwrap();
            for m in &view.markers {
                let truth = m.view.center.unwrap();
                if let Some(b) = blobs.iter().find(|b| b.center.distance(&truth) < 2.0) {
                    centres
                        .entry((view.camera, m.marker.0))
                        .or_default()
                        .push((b.center.x, b.center.y));
                }
            }
            views.insert(view.camera, blobs.iter().map(|b| b.center).collect());
        }
        tips.push(tracker.track_frame(&views).outcome.unwrap().tip_in_world);
    }
    // Pooled per-axis standard deviation of the detected centres.
    let (mut sum_sq, mut dof) = (0.0, 0.0);
    for samples in centres.values() {
        let n = samples.len() as f64;
        let (mx, my) = (
            samples.iter().map(|s| s.0).sum::<f64>() / n,
            samples.iter().map(|s| s.1).sum::<f64>() / n,
        );
        sum_sq += samples
            .iter()
            .map(|s| (s.0 - mx).powi(2) + (s.1 - my).powi(2))
            .sum::<f64>();
        dof += 2.0 * (n - 1.0);
    }
    let noise_px = (sum_sq / dof).sqrt();
    let n = tips.len() as f64;
    let mean = tips
        .iter()
        .map(|p| p.coords)
        .sum::<nalgebra::Vector3<f64>>()
        / n;
    let empirical_rms = (tips
        .iter()
        .map(|p| (p.coords - mean).norm_squared())
        .sum::<f64>()
        / (n - 1.0))
        .sqrt();
    let pose = scene.truth.samples[0].pose.unwrap().world_from_tool;
    let mc = monte_carlo(
        &scene.rig,
        &scene.tool,
        &pose,
        noise_px,
        4000,
        3,
        &TrackConfig::default(),
    )
    .unwrap();
    let fo = first_order(&scene.rig, &scene.tool, &pose, noise_px).unwrap();
    println!(
        "static: detected centre noise {noise_px:.4} px; tip spread tracked {empirical_rms:.4} mm, Monte Carlo {:.4} mm, first order {:.4} mm",
        mc.uncertainty.tip_rms_mm, fo.tip_rms_mm
    );
    // The spread of 100 frames estimates a standard deviation to about 1/sqrt(2·300) ≈ 4 % per
    // axis, 7 % for the pooled noise: 20 % is three of those combined with room for the
    // noise not being isotropic.
    let close = |a: f64, b: f64| (a - b).abs() / b < 0.20;
    assert!(
        close(mc.uncertainty.tip_rms_mm, empirical_rms),
        "Monte Carlo {} vs tracked {}",
        mc.uncertainty.tip_rms_mm,
        empirical_rms
    );
    assert!(
        close(fo.tip_rms_mm, empirical_rms),
        "first order {} vs tracked {}",
        fo.tip_rms_mm,
        empirical_rms
    );
}
