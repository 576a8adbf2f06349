//! Detection accuracy on the simulator's `paper` scenario against the exact projections of the
//! sphere centres (the acceptance figures; numbers in `notes/detect.md`).

use rayon::prelude::*;
use teachcam::detect::{
    Blob, CenterMethod, DetectConfig, RepeatabilityConfig, detect, repeatability,
};
use teachcam::sim::{Scenario, build_scene, render_frame};

/// Working distances of the paper's rig, camera centre to marker, millimetres.
const NEAR_MM: f64 = 500.0;
const FAR_MM: f64 = 2000.0;

struct Figures {
    mean: f64,
    p99: f64,
    max: f64,
    missed: usize,
    markers: usize,
}

/// The four ways measured: Refined with and without the sphere correction, Centroid and the
/// paper's SmallestCircle.
const VARIANTS: [(&str, CenterMethod, bool); 4] = [
    ("refined + sphere", CenterMethod::Refined, true),
    (
        "refined, no sphere correction",
        CenterMethod::Refined,
        false,
    ),
    ("centroid", CenterMethod::Centroid, false),
    ("smallest-circle", CenterMethod::SmallestCircle, false),
];

/// Errors of every isolated, fully visible marker over every `step`-th frame, per variant.
fn measure(step: usize) -> Vec<Figures> {
    let scene = build_scene(Scenario::Paper, 1);
    // Every `step`-th frame, and frame 116, where markers 0 and 3 of cam1 are 2.85 px apart
    // and merge at the threshold (a regression: they were rejected instead of split).
    let mut frames: Vec<usize> = (0..scene.truth.samples.len()).step_by(step).collect();
    frames.push(116);
    // Render in parallel; each frame's noise has its own seeded stream.
    let per_frame: Vec<Vec<(Vec<f64>, usize)>> = frames
        .par_iter()
        .map(|&frame| {
            let mut out = vec![(Vec::new(), 0); VARIANTS.len()];
            for view in render_frame(&scene, frame, 7) {
                let camera = &scene.rig.cameras[view.camera.0];
                for (k, (_, method, sphere)) in VARIANTS.iter().enumerate() {
                    let mut cfg = DetectConfig::for_marker(
                        camera,
                        scene.tool.marker_diameter_mm,
                        NEAR_MM,
                        FAR_MM,
                    );
                    cfg.method = *method;
                    if !sphere {
                        cfg.sphere = None;
                    }
                    let blobs: Vec<Blob> = match detect(&view.image, &cfg) {
                        Ok(blobs) => blobs,
                        Err(e) => panic!("frame {frame}, {}: {e}", camera.name),
                    };
                    for marker in &view.markers {
                        let Some(truth) = marker.view.center else {
                            continue;
                        };
                        if !marker.isolated || marker.view.visible_fraction < 1.0 {
                            continue;
                        }
                        match blobs
                            .iter()
                            .map(|b| b.center.distance(&truth))
                            .min_by(f64::total_cmp)
                            .filter(|&e| e < 2.0)
                        {
                            Some(e) => out[k].0.push(e),
                            None => out[k].1 += 1,
                        }
                    }
                }
            }
            out
        })
        .collect();
    (0..VARIANTS.len())
        .map(|k| {
            let mut errors: Vec<f64> = per_frame.iter().flat_map(|f| f[k].0.clone()).collect();
            let missed: usize = per_frame.iter().map(|f| f[k].1).sum();
            errors.sort_by(f64::total_cmp);
            let n = errors.len();
            assert!(n > 0);
            Figures {
                mean: errors.iter().sum::<f64>() / n as f64,
                p99: errors[((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1],
                max: errors[n - 1],
                missed,
                markers: n + missed,
            }
        })
        .collect()
}

#[test]
fn paper_scenario_accuracy_against_the_exact_sphere_centre_projections() {
    let figures = measure(6);
    for ((name, _, _), f) in VARIANTS.iter().zip(&figures) {
        eprintln!(
            "{name:>30}: mean {:.4} px, p99 {:.4} px, max {:.4} px, missed {} of {}",
            f.mean, f.p99, f.max, f.missed, f.markers
        );
    }
    let refined = &figures[0];
    assert_eq!(refined.missed, 0);
    assert!(refined.mean <= 0.02, "mean {}", refined.mean);
    assert!(refined.p99 <= 0.06, "p99 {}", refined.p99);
    // The paper's method, for comparison: several times worse, and never missing either.
    assert_eq!(figures[3].missed, 0);
    assert!(figures[3].mean > 3.0 * refined.mean);
}

#[test]
fn static_scenario_spread_matches_the_predicted_centre_noise() {
    // The brush at rest: only the image noise changes from frame to frame. With the
    // renderer's shot-noise gain given, the detector's predicted centre std must match the
    // measured spread (12 markers × 30 frames: the rms over markers is known to about 4 %).
    let scene = build_scene(Scenario::Static, 3);
    let frames: Vec<usize> = (0..30).collect();
    let per_frame: Vec<Vec<Vec<Blob>>> = frames
        .par_iter()
        .map(|&frame| {
            render_frame(&scene, frame, 11)
                .into_iter()
                .map(|view| {
                    let camera = &scene.rig.cameras[view.camera.0];
                    let cfg = DetectConfig {
                        shot_noise_per_level: scene.render.shot_noise_dn_per_dn,
                        ..DetectConfig::for_marker(
                            camera,
                            scene.tool.marker_diameter_mm,
                            NEAR_MM,
                            FAR_MM,
                        )
                    };
                    match detect(&view.image, &cfg) {
                        Ok(blobs) => blobs,
                        Err(e) => panic!("frame {frame}: {e}"),
                    }
                })
                .collect()
        })
        .collect();
    let mut measured = Vec::new();
    let mut predicted = Vec::new();
    for camera in 0..scene.rig.len() {
        let blobs: Vec<Vec<Blob>> = per_frame.iter().map(|f| f[camera].clone()).collect();
        let spreads = repeatability(&blobs, &RepeatabilityConfig::default());
        assert_eq!(spreads.len(), scene.tool.markers_in_tool.len());
        for s in spreads {
            assert_eq!(s.frames, frames.len());
            measured.push(s.std_px);
            predicted.push(s.predicted_std_px);
        }
    }
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let (m, p) = (rms(&measured), rms(&predicted));
    eprintln!("static: measured centre std {m:.5} px, predicted {p:.5} px");
    assert!((m / p - 1.0).abs() < 0.15, "measured {m} predicted {p}");
}
