//! One conductor: a recording read as a stream (what `live --source folder:REC` and the studio
//! run) against the batch run of the same recording (what `track` runs), on rendered scenes
//! with bad views (hidden markers, glints, clutter, two cameras), and both against the
//! simulator's truth.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::path::Path;

use teachcam::pipeline::batch::{TrackInput, TrackOptions, TrackRun, track};
use teachcam::pipeline::recording::{DetectOptions, learn_from_recording};
use teachcam::pipeline::{StreamOptions, TrackStream};
use teachcam::sim::{Scenario, build_scene, write_scene};
use teachcam::source::folder::FolderSource;
use teachcam::track::gates::GateOverrides;
use teachcam::trajectory::{Sample, Status};

/// The scenario's first `frames` frames written as a recording.
fn recording(scenario: Scenario, frames: usize, dir: &Path) -> teachcam::sim::Scene {
    let mut scene = build_scene(scenario, 7);
    scene.truth.samples.truncate(frames);
    write_scene(&scene, dir, 7, &|| {}).unwrap();
    scene
}

fn streamed(dir: &Path, scene: &teachcam::sim::Scene) -> Vec<Sample> {
    let learned = learn_from_recording(
        dir,
        &scene.rig,
        &scene.tool,
        &DetectOptions::default(),
        &GateOverrides::default(),
    )
    .unwrap();
    let mut source = FolderSource::open(dir, None).unwrap();
    TrackStream::new(
        &mut source,
        &scene.rig,
        &scene.tool,
        StreamOptions::recording(learned),
    )
    .unwrap()
    .map(|f| f.unwrap().sample)
    .collect()
}

fn batch(dir: &Path, scene: &teachcam::sim::Scene) -> TrackRun {
    track(
        TrackInput::Recording(dir),
        &scene.rig,
        &scene.tool,
        &TrackOptions::default(),
        &|| {},
    )
    .unwrap()
}

/// The bars: the stream poses ≥ 97 % of the frames the batch poses, gives the same
/// status on ≥ 98 %, and no frame it calls `ok` is one the batch does not pose, calls an
/// outlier, or places more than 3 `tip_std_mm` away. And every `ok` frame of either is within
/// 4 of its own `tip_std_mm` of the truth (σ is honest: 4σ of a 3-D RMS is beyond 99.9 %).
fn agree(scenario: Scenario, frames: usize) {
    let dir = tempfile::tempdir().unwrap();
    let scene = recording(scenario, frames, dir.path());
    let run = batch(dir.path(), &scene);
    let stream = streamed(dir.path(), &scene);
    assert_eq!(stream.len(), run.trajectory.len(), "{scenario:?}");
    let posed = |s: &[Sample]| s.iter().filter(|s| s.pose.is_some()).count();
    let (posed_stream, posed_batch) = (posed(&stream), posed(&run.trajectory.samples));
    assert!(
        posed_stream as f64 >= 0.97 * posed_batch as f64,
        "{scenario:?}: stream posed {posed_stream}, batch {posed_batch}"
    );
    let same = stream
        .iter()
        .zip(&run.trajectory.samples)
        .filter(|(a, b)| a.status == b.status)
        .count();
    assert!(
        same as f64 >= 0.98 * stream.len() as f64,
        "{scenario:?}: same status on {same} of {}",
        stream.len()
    );
    for (i, (s, b)) in stream.iter().zip(&run.trajectory.samples).enumerate() {
        assert_eq!(s.frame.0, i);
        if s.status != Status::Ok {
            continue;
        }
        let tip = s.pose.unwrap().tip_in_world;
        let Some(b_pose) = b.pose.filter(|_| b.status != Status::Outlier) else {
            panic!("{scenario:?} frame {i}: stream ok, batch {}", b.status);
        };
        let std = b.tip_std_mm.unwrap();
        let apart = (tip - b_pose.tip_in_world).norm();
        assert!(
            apart <= 3.0 * std,
            "{scenario:?} frame {i}: {apart} mm apart, tip_std {std}"
        );
    }
    for samples in [&stream, &run.trajectory.samples] {
        for (s, truth) in samples.iter().zip(&scene.truth.samples) {
            if s.status != Status::Ok {
                continue;
            }
            let error = (s.pose.unwrap().tip_in_world - truth.pose.unwrap().tip_in_world).norm();
            let std = s.tip_std_mm.unwrap();
            assert!(
                error <= 4.0 * std,
                "{scenario:?} frame {}: error {error} mm, tip_std {std} mm",
                s.frame.0
            );
        }
    }
}

#[test]
fn a_recording_streamed_agrees_with_its_batch_run_occluded() {
    agree(Scenario::Occluded, 150);
}

#[test]
fn a_recording_streamed_agrees_with_its_batch_run_two_cameras() {
    agree(Scenario::StereoIr, 150);
}

#[test]
fn a_recording_streamed_agrees_with_its_batch_run_four_cameras_cluttered() {
    agree(Scenario::FourCamerasHard, 120);
}
