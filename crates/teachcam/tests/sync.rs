//! Camera time offsets against the simulator's truth: the paper's rig and brush, each camera
//! filming the stroke at its own shifted times (exact projections plus detection-like noise;
//! the image-level scene is in `sync_render`), the offsets estimated, applied, and the tool
//! tracked.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::collections::BTreeMap;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use teachcam::correspond::Views;
use teachcam::geometry::{CameraId, Pixel, Pose};
use teachcam::sim::scenario::painter_stroke;
use teachcam::sim::{Scenario, Scene, build_scene, markers_in_world};
use teachcam::sync::{
    SyncConfig, SyncError, TimeOffsets, estimate_offsets, parse_time_offsets,
    read_time_offsets_json, resample_views, time_offsets_json,
};
use teachcam::track::{TrackConfig, Tracker};

/// Detection noise per axis: the sub-pixel detector's pessimistic 1σ on clean images.
const PIXEL_NOISE: f64 = 0.05;

/// The hidden scene's offsets: camera 1 exposes 9.3 ms late, camera 2 13.1 ms early.
fn scene_offsets() -> TimeOffsets {
    BTreeMap::from([(CameraId(1), 0.0093), (CameraId(2), -0.0131)])
}

/// The tool's pose at time `t` of the paper's stroke played `speed` times as fast.
fn world_from_tool(scene: &Scene, speed: f64, time_s: f64) -> Pose {
    painter_stroke(speed * time_s) * scene.tool.tool_from_tcp.inverse()
}

/// Every frame's views with camera `c` exposing frame `k` at `k/fps + offset_c`; `speed`
/// scales the stroke's pace (0 holds the tool still).
fn shifted_views(speed: f64, offsets: &TimeOffsets, seed: u64) -> (Scene, Vec<Views>) {
    let scene = build_scene(Scenario::Paper, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, PIXEL_NOISE).unwrap();
    let frames = (0..scene.truth.len())
        .map(|frame| {
            let mut views = Views::new();
            for (id, camera) in scene.rig.iter() {
                let time_s = frame as f64 / scene.fps + offsets.get(&id).copied().unwrap_or(0.0);
                let pose = world_from_tool(&scene, speed, time_s + 1.0);
                let mut pixels: Vec<Pixel> = markers_in_world(&scene.tool, &pose)
                    .iter()
                    .filter_map(|p| camera.project(p))
                    .filter(|p| camera.image_size.contains(p))
                    .map(|p| Pixel::new(p.x + noise.sample(&mut rng), p.y + noise.sample(&mut rng)))
                    .collect();
                pixels.rotate_left(frame % 3);
                views.insert(id, pixels);
            }
            views
        })
        .collect();
    (scene, frames)
}

/// RMS tip error of the tracked frames against the truth at the common (reference) times, and
/// the number of frames tracked.
fn tip_rms(scene: &Scene, speed: f64, frames: &[Views]) -> (f64, usize) {
    let tracker = Tracker::new(&scene.rig, &scene.tool, TrackConfig::default());
    let (trajectory, _) = tracker.track_all(frames, scene.fps);
    let errors: Vec<f64> = trajectory
        .samples
        .iter()
        .enumerate()
        .filter_map(|(frame, s)| {
            let truth = world_from_tool(scene, speed, frame as f64 / scene.fps + 1.0)
                * scene.tool.tip_in_tool();
            Some((s.pose?.tip_in_world - truth).norm())
        })
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    (rms, errors.len())
}

#[test]
fn offsets_of_a_fast_stroke_are_recovered_within_their_sigma_and_a_millisecond() {
    let truth = scene_offsets();
    for (speed, seed) in [(1.0, 1), (2.5, 2)] {
        let (scene, frames) = shifted_views(speed, &truth, seed);
        let estimate =
            estimate_offsets(&scene.rig, &frames, 1.0 / scene.fps, &SyncConfig::default()).unwrap();
        println!("speed {speed}: {estimate:#?}");
        assert_eq!(estimate.reference, CameraId(0));
        for (camera, expected) in &truth {
            let found = estimate.offsets[camera];
            let error = found.offset_s - expected;
            println!(
                "speed {speed} {camera}: offset {:.4} ms (truth {:.1} ms), error {:.4} ms, σ {:.4} ms",
                found.offset_s * 1e3,
                expected * 1e3,
                error * 1e3,
                found.sigma_s * 1e3
            );
            // The σ must be informative (a large σ would make the next check empty) and honest.
            assert!(
                found.sigma_s > 0.0 && found.sigma_s < 0.2e-3,
                "σ {}",
                found.sigma_s
            );
            assert!(
                error.abs() <= 4.0 * found.sigma_s,
                "error {error} beyond 4σ"
            );
            assert!(error.abs() < 1e-3);
        }
        assert!(estimate.residual_rms_px < 2.0 * PIXEL_NOISE * 2.0_f64.sqrt());
        assert!(estimate.unshifted_residual_rms_px > 5.0 * estimate.residual_rms_px);
    }
}

#[test]
fn a_synchronised_rig_gives_offsets_consistent_with_zero() {
    let (scene, frames) = shifted_views(1.5, &TimeOffsets::new(), 5);
    let estimate =
        estimate_offsets(&scene.rig, &frames, 1.0 / scene.fps, &SyncConfig::default()).unwrap();
    for (camera, found) in &estimate.offsets {
        println!(
            "{camera}: {:.4} ms σ {:.4} ms",
            found.offset_s * 1e3,
            found.sigma_s * 1e3
        );
        assert!(found.offset_s.abs() <= 4.0 * found.sigma_s.max(1e-9));
        assert!(found.sigma_s < 0.2e-3);
    }
}

#[test]
fn a_static_tool_is_refused_not_guessed() {
    let (scene, frames) = shifted_views(0.0, &scene_offsets(), 7);
    let result = estimate_offsets(&scene.rig, &frames, 1.0 / scene.fps, &SyncConfig::default());
    println!("{result:?}");
    match result {
        Err(SyncError::TooLittleMotion { .. } | SyncError::NoTimingInformation { .. }) => {}
        other => panic!("a static tool must be refused, got {other:?}"),
    }
    let message = result.unwrap_err().to_string();
    assert!(message.contains("static"), "{message}");
}

#[test]
fn corrected_tracking_is_as_good_as_synchronised_tracking() {
    let speed = 2.5;
    let (scene, unsynced) = shifted_views(speed, &scene_offsets(), 11);
    let (_, synced) = shifted_views(speed, &TimeOffsets::new(), 11);
    let period_s = 1.0 / scene.fps;
    let config = SyncConfig::default();
    let estimate = estimate_offsets(&scene.rig, &unsynced, period_s, &config).unwrap();
    let resampled = resample_views(&unsynced, &estimate.time_offsets(), period_s, &config);
    let (synced_rms, synced_count) = tip_rms(&scene, speed, &synced);
    let (raw_rms, raw_count) = tip_rms(&scene, speed, &unsynced);
    let (corrected_rms, corrected_count) = tip_rms(&scene, speed, &resampled.frames);
    let flagged = resampled.issues.iter().filter(|i| !i.is_empty()).count();
    println!(
        "tip RMS: synchronised {synced_rms:.4} mm ({synced_count} frames), unsynchronised \
         {raw_rms:.4} mm ({raw_count}), corrected {corrected_rms:.4} mm ({corrected_count}), \
         {flagged} frames with resampling issues"
    );
    for (frame, issues) in resampled.issues.iter().enumerate() {
        for issue in issues {
            println!("frame {frame}: {issue}");
        }
    }
    assert!(corrected_rms <= 2.0 * synced_rms);
    assert!(corrected_count + 4 >= synced_count);
    // The first and last frames hold blobs whose tracks end before the common time.
    assert!(!resampled.issues[0].is_empty() || !resampled.issues[scene.truth.len() - 1].is_empty());
}

#[test]
fn offsets_parse_and_round_trip_through_the_contract_json() {
    let rig = build_scene(Scenario::Paper, 1).rig;
    let offsets = parse_time_offsets("cam1=0.0093, cam2=-0.0131", &rig).unwrap();
    assert_eq!(offsets, scene_offsets());
    let json = time_offsets_json(&rig, &offsets).unwrap();
    assert_eq!(
        json,
        "{\"cam0\": 0.0, \"cam1\": 0.0093, \"cam2\": -0.0131}\n"
    );
    let back = read_time_offsets_json(&json, &rig).unwrap();
    assert_eq!(back.get(&CameraId(1)), Some(&0.0093));
    assert_eq!(back.get(&CameraId(0)), Some(&0.0));
    for bad in ["cam1", "cam1=fast", "cam1=inf", "cam1=0.1=2"] {
        assert!(
            matches!(
                parse_time_offsets(bad, &rig),
                Err(SyncError::BadEntry { .. })
            ),
            "{bad}"
        );
    }
    let unknown = parse_time_offsets("cam7=0.01", &rig)
        .unwrap_err()
        .to_string();
    assert!(
        unknown.contains("cam7") && unknown.contains("cam0, cam1, cam2"),
        "{unknown}"
    );
    assert!(read_time_offsets_json("[1, 2]", &rig).is_err());
    assert!(time_offsets_json(&rig, &BTreeMap::from([(CameraId(1), f64::NAN)])).is_none());
}
