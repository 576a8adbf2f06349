//! Frame sources and the conductor: recording folders, every frame's size checked, the
//! simulator as a live source.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::path::Path;

use teachcam::io::recording::{GrayFrame, frame_file_name, read_frame, write_png};
use teachcam::io::{rig::read_rig, tool::read_tool};
use teachcam::pipeline::recording::{DetectOptions, learn_from_recording};
use teachcam::pipeline::{StreamOptions, TrackStream};
use teachcam::sim::{Scenario, build_scene, write_scene};
use teachcam::source::folder::FolderSource;
use teachcam::source::{FrameSource, SourceConfig, SourceSpec, open_source};
use teachcam::track::gates::GateOverrides;

/// The paper's scene cut to its first `frames` frames, written as a recording.
fn short_recording(dir: &Path, frames: usize) -> teachcam::sim::Scene {
    let mut scene = build_scene(Scenario::Paper, 1);
    scene.truth.samples.truncate(frames);
    write_scene(&scene, dir, 1, &|| {}).unwrap();
    scene
}

/// Tracks a recording folder through the conductor; the first error's message on failure.
fn track_folder(root: &Path) -> Result<Vec<teachcam::pipeline::TrackedFrame>, String> {
    let rig = read_rig(&root.join("rig.json")).unwrap();
    let tool = read_tool(&root.join("tool.json")).unwrap();
    let learned = learn_from_recording(
        root,
        &rig,
        &tool,
        &DetectOptions::default(),
        &GateOverrides::default(),
    )
    .map_err(|e| e.to_string())?;
    let mut source = FolderSource::open(root, None).map_err(|e| e.to_string())?;
    TrackStream::new(&mut source, &rig, &tool, StreamOptions::recording(learned))
        .map_err(|e| e.to_string())?
        .map(|f| f.map_err(|e| e.to_string()))
        .collect()
}

#[test]
fn a_recording_tracks_through_the_conductor_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let scene = short_recording(dir.path(), 6);
    let frames = track_folder(dir.path()).unwrap();
    assert_eq!(frames.len(), 6);
    for (i, frame) in frames.iter().enumerate() {
        assert_eq!(frame.detections.index, i);
        assert!((frame.detections.time_s - i as f64 / scene.fps).abs() < 1e-12);
        let pose = frame
            .track
            .outcome
            .as_ref()
            .expect("every frame of the paper scene poses");
        let truth = scene.truth.samples[i].pose.unwrap();
        // The paper scene's tip RMS is ≤ 0.02 mm (tests/track.rs); 0.1 mm is five times that.
        assert!((pose.tip_in_world - truth.tip_in_world).norm() < 0.1);
        assert!(frame.tip_std_mm.is_some_and(|s| s > 0.0 && s < 0.1));
    }
}

/// Regression (repro R1): later frames 3 rows shorter than the rig's were tracked 2.1 mm off
/// with exit 0, because only frame 0's size was checked. Every frame is checked now.
#[test]
fn a_later_frame_of_the_wrong_size_is_refused_naming_camera_frame_and_sizes() {
    let dir = tempfile::tempdir().unwrap();
    short_recording(dir.path(), 3);
    for frame in 1..3 {
        let path = dir.path().join("cam1").join(frame_file_name(frame));
        let GrayFrame::Eight(image) = read_frame(&path, None).unwrap() else {
            panic!("the simulator writes 8-bit frames");
        };
        let cropped = image::imageops::crop_imm(&image, 0, 3, 1280, 1021).to_image();
        write_png(&path, &cropped).unwrap();
    }
    let message = track_folder(dir.path()).unwrap_err();
    assert_eq!(
        message,
        "camera cam1, frame 1: image is 1280x1021, expected 1280x1024"
    );
}

#[test]
fn the_shared_repro_of_wrong_sized_later_frames_is_refused() {
    let Some(data) = teachcam_testdata::shared_data("") else {
        return;
    };
    let rec = data.join("../repro/R1_wrong_size_later_frames/rec");
    let message = track_folder(&rec).unwrap_err();
    assert!(
        message.starts_with("camera cam0, frame 1: image is 1280x1021, expected 1280x1024"),
        "{message}"
    );
}

#[test]
fn a_camera_with_fewer_frames_is_refused_naming_both() {
    let dir = tempfile::tempdir().unwrap();
    short_recording(dir.path(), 3);
    std::fs::remove_file(dir.path().join("cam2").join(frame_file_name(2))).unwrap();
    let message = match FolderSource::open(dir.path(), None) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a recording with unequal cameras was opened"),
    };
    assert!(
        message.contains("camera cam2 has 2 frames but camera cam0 has 3"),
        "{message}"
    );
}

#[test]
fn timestamps_beside_the_frames_give_each_frame_its_time() {
    let dir = tempfile::tempdir().unwrap();
    short_recording(dir.path(), 4);
    // cam1 exposes 5 ms after the others.
    let mut text = String::from("camera,frame,time_s\n");
    for camera in ["cam0", "cam1", "cam2"] {
        for frame in 0..4 {
            let late = if camera == "cam1" { 0.005 } else { 0.0 };
            text.push_str(&format!(
                "{camera},{frame},{}\n",
                frame as f64 / 30.0 + late
            ));
        }
    }
    std::fs::write(dir.path().join("timestamps.csv"), text).unwrap();
    let mut source = FolderSource::open(dir.path(), None).unwrap();
    let mut sets = 0;
    while let Some(set) = source.next_set() {
        let set = set.unwrap();
        let times: Vec<f64> = set
            .cameras
            .iter()
            .map(|c| c.as_ref().unwrap().time_s)
            .collect();
        assert!((times[1] - times[0] - 0.005).abs() < 1e-9, "{times:?}");
        sets += 1;
    }
    assert_eq!(sets, 4);
    assert!((source.stats().max_pair_spread_s - 0.005).abs() < 1e-9);
}

#[test]
fn a_source_is_named_and_opened_by_its_spec() {
    let dir = tempfile::tempdir().unwrap();
    short_recording(dir.path(), 2);
    let spec: SourceSpec = format!("folder:{}", dir.path().display()).parse().unwrap();
    let source = open_source(&spec, &SourceConfig::default()).unwrap();
    let names: Vec<&str> = source.cameras().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["cam0", "cam1", "cam2"]);
    assert_eq!(source.len_hint(), Some(2));
    assert_eq!(source.fps(), 30.0);
}
