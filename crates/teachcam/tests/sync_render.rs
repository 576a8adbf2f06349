//! Camera time offsets on rendered images: the simulator's `unsynced` scene (the paper's rig,
//! cam1 +9.3 ms, cam2 −13.1 ms, the stroke at 2.5× pace, 30 Hz), detected, the offsets
//! estimated, the blobs moved and the tool tracked; the same scene rendered synchronised is
//! the yardstick.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use rayon::prelude::*;
use teachcam::correspond::Views;
use teachcam::detect::{DetectConfig, detect};
use teachcam::sim::{Scenario, Scene, build_scene, render_frame};
use teachcam::sync::{SyncConfig, estimate_offsets, resample_views};
use teachcam::track::{TrackConfig, Tracker};

/// Every frame's detected blob centres per camera.
fn detected_views(scene: &Scene, seed: u64) -> Vec<Views> {
    let configs: Vec<DetectConfig> = scene
        .rig
        .cameras
        .iter()
        .map(|c| DetectConfig::for_marker(c, scene.tool.marker_diameter_mm, 300.0, 3000.0))
        .collect();
    (0..scene.truth.len())
        .into_par_iter()
        .map(|frame| {
            render_frame(scene, frame, seed)
                .into_iter()
                .map(|view| {
                    let blobs = detect(&view.image, &configs[view.camera.0]).unwrap();
                    (view.camera, blobs.iter().map(|b| b.center).collect())
                })
                .collect()
        })
        .collect()
}

/// RMS tip error against the truth (camera 0's clock) and frames posed.
fn tip_rms(scene: &Scene, frames: &[Views]) -> (f64, usize) {
    let tracker = Tracker::new(&scene.rig, &scene.tool, TrackConfig::default());
    let (trajectory, _) = tracker.track_all(frames, scene.fps);
    let errors: Vec<f64> = scene
        .truth
        .samples
        .iter()
        .zip(&trajectory.samples)
        .filter_map(|(t, m)| Some((t.pose?.tip_in_world - m.pose?.tip_in_world).norm()))
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    (rms, errors.len())
}

#[test]
fn the_unsynced_scene_is_timed_within_a_millisecond_and_tracks_as_if_synchronised() {
    let seed = 4;
    let scene = build_scene(Scenario::Unsynced, seed);
    let period_s = 1.0 / scene.fps;
    let config = SyncConfig::default();
    let frames = detected_views(&scene, seed);
    let estimate = estimate_offsets(&scene.rig, &frames, period_s, &config).unwrap();
    for (camera, found) in &estimate.offsets {
        let truth = scene.time_offset_s(*camera);
        let error = found.offset_s - truth;
        println!(
            "{camera}: {:+.4} ms (truth {:+.1} ms), error {:+.4} ms, σ {:.4} ms, {} matches",
            found.offset_s * 1e3,
            truth * 1e3,
            error * 1e3,
            found.sigma_s * 1e3,
            found.matches
        );
        assert!(error.abs() < 1e-3, "{camera}: error {error} s");
        if found.sigma_s > 0.0 {
            assert!(found.sigma_s < 0.2e-3, "{camera}: σ {} s", found.sigma_s);
            assert!(
                error.abs() <= 4.0 * found.sigma_s,
                "{camera}: error beyond 4σ"
            );
        }
    }
    println!(
        "epipolar RMS {:.3} px unshifted -> {:.3} px over {} matches",
        estimate.unshifted_residual_rms_px, estimate.residual_rms_px, estimate.matches
    );
    let resampled = resample_views(&frames, &estimate.time_offsets(), period_s, &config);
    let mut synchronised = scene.clone();
    synchronised.time_offsets_s.clear();
    let (synced_rms, synced_count) = tip_rms(&synchronised, &detected_views(&synchronised, seed));
    let (raw_rms, raw_count) = tip_rms(&scene, &frames);
    let (corrected_rms, corrected_count) = tip_rms(&scene, &resampled.frames);
    let flagged = resampled.issues.iter().filter(|i| !i.is_empty()).count();
    println!(
        "tip RMS: synchronised {synced_rms:.4} mm ({synced_count} frames), unsynchronised \
         {raw_rms:.4} mm ({raw_count}), corrected {corrected_rms:.4} mm ({corrected_count}), \
         {flagged} frames with resampling issues"
    );
    assert!(corrected_rms <= 2.0 * synced_rms);
    assert!(corrected_count + 6 >= synced_count);
}
