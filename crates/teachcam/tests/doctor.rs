//! `doctor` on simulated recordings whose trouble is known: a camera turned by 0.4° in the rig
//! file, a stereo pair off, marker images too small, the wrong tool.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::collections::BTreeMap;

use nalgebra::Vector3;
use teachcam::camera::Rig;
use teachcam::correspond::Views;
use teachcam::detect::{DetectConfig, detect};
use teachcam::doctor::{DoctorConfig, Finding, Report, diagnose};
use teachcam::geometry::CameraId;
use teachcam::sim::{Miscalibration, Scenario, Scene, build_scene, real_world, render_frame};
use teachcam::tool::Tool;
use teachcam::track::{TrackConfig, Tracker};

/// Renders `frames` of a scene, detects (any roundness) and tracks them with `rig` and `tool`
/// as `teachcam doctor` does, and diagnoses.
fn doctor(scene: &Scene, rig: &Rig, tool: &Tool, frames: &[usize]) -> Report {
    let keep = DetectConfig::default().min_roundness;
    let mut blobs = Vec::new();
    let mut views = Vec::new();
    for &frame in frames {
        let mut frame_blobs = BTreeMap::new();
        let mut frame_views = Views::new();
        for view in render_frame(scene, frame, 1) {
            let camera = &rig.cameras[view.camera.0];
            let config = DetectConfig {
                min_roundness: 0.0,
                ..DetectConfig::for_marker(camera, tool.marker_diameter_mm, 300.0, 3000.0)
            };
            let found = detect(&view.image, &config).unwrap();
            frame_views.insert(
                view.camera,
                found
                    .iter()
                    .filter(|b| b.roundness >= keep)
                    .map(|b| b.center)
                    .collect(),
            );
            frame_blobs.insert(view.camera, found);
        }
        blobs.push(frame_blobs);
        views.push(frame_views);
    }
    let tracker = Tracker::new(rig, tool, TrackConfig::default());
    let tracks: Vec<_> = views.iter().map(|v| tracker.track_frame(v)).collect();
    diagnose(rig, tool, &blobs, &tracks, &DoctorConfig::default())
}

fn calibration_findings(report: &Report) -> Vec<&Finding> {
    report
        .findings
        .iter()
        .filter(|f| {
            matches!(
                f,
                Finding::CameraDisagrees { .. } | Finding::PairDisagrees { .. }
            )
        })
        .collect()
}

fn frames(step: usize, count: usize) -> Vec<usize> {
    (0..count).map(|k| k * step).collect()
}

#[test]
fn doctor_names_the_camera_turned_by_0_4_degrees() {
    for (scenario, camera, axis) in [
        (Scenario::Paper, 1, Vector3::new(1.0, 0.2, 0.1)),
        (Scenario::FourCameras, 2, Vector3::new(0.3, 1.0, 0.2)),
    ] {
        let mut scene = build_scene(scenario, 1);
        scene.miscalibration = Some(Miscalibration {
            camera: CameraId(camera),
            axis_in_camera: axis,
            angle: 0.4_f64.to_radians(),
        });
        let written = scene.written_rig();
        let report = doctor(&scene, &written, &scene.tool, &frames(8, 15));
        let found = calibration_findings(&report);
        let name = format!("cam{camera}");
        assert!(
            matches!(found.as_slice(), [Finding::CameraDisagrees { camera: c, angle_deg, .. }]
                if *c == name && *angle_deg > 0.1 && *angle_deg < 0.45),
            "{}: {found:?}; pairs {:?}",
            scenario.name(),
            report.pairs
        );
        // The same recording with the true rig: every pair agrees.
        let clean = doctor(&scene, &scene.rig, &scene.tool, &frames(8, 15));
        assert!(
            calibration_findings(&clean).is_empty(),
            "{}: {:?}",
            scenario.name(),
            clean.findings
        );
        assert!(
            clean
                .pairs
                .iter()
                .all(|p| p.epipolar_px.unwrap().median < 0.2)
        );
        assert_eq!(clean.posed, 15, "{}: {:?}", scenario.name(), clean.lost);
    }
}

#[test]
fn doctor_says_the_stereo_pair_disagrees_and_the_blobs_are_too_small() {
    let scene = build_scene(Scenario::StereoIrMiscal, 1);
    let report = doctor(&scene, &scene.written_rig(), &scene.tool, &frames(10, 30));
    let found = calibration_findings(&report);
    assert!(
        matches!(found.as_slice(), [Finding::PairDisagrees { epipolar_px, angle_deg, .. }]
            if *epipolar_px > 2.0 && *angle_deg > 0.15 && *angle_deg < 0.45),
        "{found:?}; pairs {:?}",
        report.pairs
    );
    // The tool at 2 m images 4–5 px across: too small, move closer.
    for camera in ["cam0", "cam1"] {
        assert!(
            report.findings.iter().any(|f| matches!(f,
                Finding::BlobsTooSmall { camera: c, diameter_px, .. }
                    if c == camera && *diameter_px < 5.0)),
            "{camera}: {:?}",
            report.findings
        );
    }
    let truth = doctor(&scene, &scene.rig, &scene.tool, &frames(10, 30));
    assert!(calibration_findings(&truth).is_empty(), "{:?}", truth.pairs);
    // The paper's 10 mm markers at 1 m image 18 px: not too small.
    let paper = build_scene(Scenario::Paper, 1);
    let report = doctor(&paper, &paper.rig, &paper.tool, &frames(10, 6));
    assert!(
        !report
            .findings
            .iter()
            .any(|f| matches!(f, Finding::BlobsTooSmall { .. })),
        "{:?}",
        report.findings
    );
}

#[test]
fn doctor_says_when_the_tool_is_not_in_the_data() {
    let scene = build_scene(Scenario::Paper, 1);
    let wrong = real_world::triangle_tool();
    let report = doctor(&scene, &scene.rig, &wrong, &frames(8, 15));
    assert_eq!(report.posed, 0);
    assert!(
        report
            .findings
            .iter()
            .any(|f| matches!(f, Finding::WrongTool { fraction_with_tool, .. } if *fraction_with_tool < 0.2)),
        "{:?}",
        report.findings
    );
    assert!(
        report
            .lost
            .keys()
            .all(|s| *s == teachcam::doctor::Stage::Identify)
    );
    let right = doctor(&scene, &scene.rig, &scene.tool, &frames(8, 15));
    assert!(
        !right
            .findings
            .iter()
            .any(|f| matches!(f, Finding::WrongTool { .. })),
        "{:?}",
        right.findings
    );
}
