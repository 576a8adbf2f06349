//! Tracking benchmarks: one frame from blob centres to the tool's pose (correspondence,
//! triangulation, identification, registration), for the paper's three cameras and a
//! four-camera rig, and the Monte Carlo uncertainty at 10,000 trials.

#![allow(clippy::unwrap_used, reason = "benchmark fixtures")]

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use teachcam::correspond::Views;
use teachcam::detect::{DetectConfig, detect};
use teachcam::geometry::Pixel;
use teachcam::metrology::{first_order, monte_carlo};
use teachcam::sim::{Scenario, build_scene, markers_in_world, render_frame};
use teachcam::track::{TrackConfig, Tracker};

fn views_of(scenario: Scenario, frame: usize) -> (teachcam::sim::Scene, Views) {
    let scene = build_scene(scenario, 1);
    let world = markers_in_world(
        &scene.tool,
        &scene.truth.samples[frame].pose.unwrap().world_from_tool,
    );
    let mut views = Views::new();
    for (id, camera) in scene.rig.iter() {
        // Shuffled order and a few hundredths of a pixel off, as detections come.
        let mut pixels: Vec<Pixel> = world
            .iter()
            .filter_map(|p| camera.project(p))
            .map(|p| Pixel::new(p.x + 0.03, p.y - 0.02))
            .collect();
        pixels.rotate_left(id.0 % 4);
        views.insert(id, pixels);
    }
    (scene, views)
}

fn track_frame(c: &mut Criterion) {
    for (name, scenario) in [
        ("3 cameras", Scenario::Paper),
        ("4 cameras", Scenario::FourCameras),
    ] {
        let (scene, views) = views_of(scenario, 30);
        let tracker = Tracker::new(&scene.rig, &scene.tool, TrackConfig::default());
        assert!(tracker.track_frame(&views).outcome.is_ok());
        c.bench_function(
            &format!("track_frame blobs to pose, {name}, 4 markers"),
            |b| b.iter(|| tracker.track_frame(black_box(&views))),
        );
    }
}

fn images_to_pose(c: &mut Criterion) {
    let scene = build_scene(Scenario::Paper, 1);
    let rendered = render_frame(&scene, 30, 1);
    let configs: Vec<DetectConfig> = scene
        .rig
        .cameras
        .iter()
        .map(|cam| DetectConfig::for_marker(cam, scene.tool.marker_diameter_mm, 300.0, 3000.0))
        .collect();
    let tracker = Tracker::new(&scene.rig, &scene.tool, TrackConfig::default());
    let pose = |views: &[teachcam::sim::RenderedView]| {
        let mut frame = Views::new();
        for v in views {
            let blobs = detect(&v.image, &configs[v.camera.0]).unwrap();
            frame.insert(v.camera, blobs.iter().map(|b| b.center).collect());
        }
        tracker.track_frame(&frame)
    };
    assert!(pose(&rendered).outcome.is_ok());
    c.bench_function(
        "images to pose, 3 cameras 1280x1024, 4 markers (decoded images)",
        |b| b.iter(|| pose(black_box(&rendered))),
    );
}

fn uncertainty(c: &mut Criterion) {
    let scene = build_scene(Scenario::Paper, 1);
    let pose = scene.truth.samples[30].pose.unwrap().world_from_tool;
    let mut group = c.benchmark_group("uncertainty");
    group.sample_size(10);
    group.bench_function("monte carlo 10000 trials, 0.15 px", |b| {
        b.iter(|| {
            monte_carlo(
                &scene.rig,
                &scene.tool,
                &pose,
                0.15,
                10_000,
                1,
                &TrackConfig::default(),
            )
            .unwrap()
        })
    });
    group.bench_function("first order", |b| {
        b.iter(|| first_order(&scene.rig, &scene.tool, black_box(&pose), 0.15).unwrap())
    });
    group.finish();
}

criterion_group!(benches, track_frame, images_to_pose, uncertainty);
criterion_main!(benches);
