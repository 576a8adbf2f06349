//! No wrong pose marked `ok` on `stereo-ir`: the planar triangle's mirror image in the steel
//! plate is found from the recording and left out, checked against the scenario's truth.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use rayon::prelude::*;
use teachcam::correspond::Views;
use teachcam::detect::{Blob, DetectConfig, detect};
use teachcam::sim::{Scenario, Scene, build_scene, real_world, render_frame};
use teachcam::track::gates::{Gate, GateOverrides, ROUNDNESS_FLOOR, measure_gates, roundness_gate};
use teachcam::track::uncertainty::tip_std_mm;
use teachcam::track::{FrameTrack, Tracker};
use teachcam::trajectory::Status;

/// The scene's frames rendered and detected as `teachcam track` does: the roundness gate
/// measured on the blobs found with its lowest floor, then the blobs above it.
fn detected(scene: &Scene, frames: &[usize]) -> (Vec<Views>, Vec<Vec<f64>>, Gate) {
    let blobs: Vec<Vec<(usize, Vec<Blob>)>> = frames
        .par_iter()
        .map(|&frame| {
            render_frame(scene, frame, 5)
                .into_iter()
                .map(|view| {
                    let camera = &scene.rig.cameras[view.camera.0];
                    let config = DetectConfig {
                        min_roundness: ROUNDNESS_FLOOR,
                        ..DetectConfig::for_marker(
                            camera,
                            scene.tool.marker_diameter_mm,
                            300.0,
                            3000.0,
                        )
                    };
                    (view.camera.0, detect(&view.image, &config).unwrap())
                })
                .collect()
        })
        .collect();
    let roundness: Vec<f64> = blobs
        .iter()
        .flatten()
        .flat_map(|(_, b)| b.iter().map(|b| b.roundness))
        .collect();
    let gate = roundness_gate(&roundness, None);
    let mut views = Vec::new();
    let mut noise = Vec::new();
    for frame in &blobs {
        let mut v = Views::new();
        let mut n = Vec::new();
        for (camera, found) in frame {
            let kept: Vec<&Blob> = found.iter().filter(|b| b.roundness >= gate.value).collect();
            v.insert(
                teachcam::geometry::CameraId(*camera),
                kept.iter().map(|b| b.center).collect(),
            );
            n.extend(kept.iter().map(|b| b.center_std_px));
        }
        views.push(v);
        noise.push(n);
    }
    (views, noise, gate)
}

/// Each frame's tip error against the truth, millimetres, `None` without a pose.
fn tip_errors(scene: &Scene, frames: &[usize], tracks: &[FrameTrack]) -> Vec<Option<f64>> {
    frames
        .iter()
        .zip(tracks)
        .map(|(&frame, track)| {
            let pose = track.outcome.as_ref().ok()?;
            let truth = scene.truth.samples[frame].pose?;
            Some((pose.tip_in_world - truth.tip_in_world).norm())
        })
        .collect()
}

#[test]
fn the_triangles_mirror_image_in_the_plate_is_never_posed() {
    let scene = build_scene(Scenario::StereoIr, 1);
    // The hand hides marker 0 in cam0 over frames 40–69 and marker 2 in cam1 over 150–174;
    // the frames before show the triangle and its mirror image both complete.
    let frames: Vec<usize> = (0..70).chain(145..180).collect();
    let (views, noise, min_roundness) = detected(&scene, &frames);
    let gates = measure_gates(
        &scene.rig,
        &scene.tool,
        &views,
        &[],
        min_roundness,
        &GateOverrides::default(),
    );

    // The plate the simulator put 350 mm under the working volume, found from the frames.
    let plate = real_world::stereo_ir_mirror();
    let mirror = gates
        .mirror
        .clone()
        .unwrap_or_else(|| panic!("{}", gates.mirror_reason));
    assert!(
        mirror.normal.z > 0.9995,
        "normal {:?} more than 1.8° from up",
        mirror.normal
    );
    assert!(
        (mirror.offset_mm - plate.height_mm).abs() < 5.0,
        "plane at {} mm, the plate at {} mm",
        mirror.offset_mm,
        plate.height_mm
    );

    let config = gates.track_config();
    let tracker = Tracker::new(&scene.rig, &scene.tool, config.clone());
    let tracks: Vec<FrameTrack> = views.iter().map(|v| tracker.track_frame(v)).collect();
    let errors = tip_errors(&scene, &frames, &tracks);
    let stds = tip_std_mm(&scene.rig, &scene.tool, &tracks, &noise);
    let mut posed = 0;
    for ((frame, track), (error, std)) in frames.iter().zip(&tracks).zip(errors.iter().zip(&stds)) {
        let Some(error) = error else { continue };
        posed += 1;
        let std = std.unwrap();
        // A tip error beyond 4 of its own σ is no noise: a wrong point or a ghost.
        assert!(
            *error <= 4.0 * std || track.status() != Status::Ok,
            "frame {frame}: tip {error:.1} mm off with σ {std:.2} mm, status ok"
        );
    }

    // Without the mirror the same frames pose the ghost (hundreds of millimetres off) and
    // lose the frames it makes ambiguous: the test can fail.
    let blind = Tracker::new(
        &scene.rig,
        &scene.tool,
        teachcam::track::TrackConfig {
            mirror: None,
            ..config
        },
    );
    let blind_tracks: Vec<FrameTrack> = views.iter().map(|v| blind.track_frame(v)).collect();
    let blind_errors = tip_errors(&scene, &frames, &blind_tracks);
    let ghosts = blind_errors
        .iter()
        .flatten()
        .filter(|e| **e > 100.0)
        .count();
    let blind_stds = tip_std_mm(&scene.rig, &scene.tool, &blind_tracks, &noise);
    let right = |errors: &[Option<f64>], stds: &[Option<f64>]| {
        errors
            .iter()
            .zip(stds)
            .filter(|(e, s)| e.zip(**s).is_some_and(|(e, s)| e <= 4.0 * s))
            .count()
    };
    let (right_with, right_blind) = (right(&errors, &stds), right(&blind_errors, &blind_stds));
    assert!(ghosts >= 5, "{ghosts} ghost poses without the mirror");
    // The frames the ghost made ambiguous are posed once it is left out.
    assert!(
        right_with > right_blind,
        "{right_with} frames posed within 4 σ with the mirror, {right_blind} without"
    );
    // The frames that posed the ghost had ghost points left out (the chosen pairing of
    // ambiguous blobs and the frame's final answer need not hold all of them).
    let left_out: usize = tracks
        .iter()
        .zip(&blind_errors)
        .filter(|(_, e)| e.is_some_and(|e| e > 100.0))
        .map(|(t, _)| t.reflections)
        .sum();
    assert!(
        left_out >= ghosts,
        "{left_out} reflections left out in {ghosts} ghost frames"
    );
    eprintln!(
        "{} frames: {posed} posed with the mirror, {right_with} within 4 σ ({ghosts} ghosts without it, {right_blind} within 4 σ)",
        frames.len()
    );
}
