//! The simulator's real-world failure modes (issue 14), each measured in the images it draws:
//! small saturated blobs with bloom, JPEG block artefacts, motion blur, uneven light, clutter
//! (mirror images, streaks, a hand partly hiding a marker), a rig file off by 0.4° in one
//! camera, unsynchronised cameras, touching marker images; and the clean scenes unchanged.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use image::GrayImage;
use nalgebra::Vector3;
use teachcam::camera::{Camera, epipolar_line, fundamental_matrix};
use teachcam::geometry::{CameraId, Pixel, Point3, rotation_angle_between};
use teachcam::sim::render::RenderConfig;
use teachcam::sim::{
    Exposure, Scenario, Scene, build_scene, markers_in_world, real_world, render_frame, write_scene,
};

/// FNV-1a over an image's pixels.
fn fnv(image: &GrayImage) -> u64 {
    image.as_raw().iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[test]
fn clean_scenarios_render_the_same_pixels_as_before() {
    // Hashes of frames written by `teachcam simulate --seed 3` before the real-world options
    // existed (commit bec1b49), decoded from their PNG files.
    for (scenario, camera, frame, hash) in [
        (Scenario::Paper, 1, 3, 0x5da5_77a5_8a43_07d7_u64),
        (Scenario::Occluded, 2, 52, 0xb51e_b430_e856_f25f),
        (Scenario::FourCameras, 3, 10, 0x0fd9_26d6_151e_5ecd),
        (Scenario::Static, 0, 5, 0xcc10_e26e_69a3_11c8),
    ] {
        let views = render_frame(&build_scene(scenario, 3), frame, 3);
        assert_eq!(
            fnv(&views[camera].image),
            hash,
            "{} cam{camera} frame {frame} changed",
            scenario.name()
        );
    }
}

/// Pixels within `radius_px` of `center`.
fn disc(image: &GrayImage, center: Pixel, radius_px: f64) -> Vec<(f64, f64, f64)> {
    let mut out = Vec::new();
    let r = radius_px.ceil() as i64 + 1;
    for y in (center.y.round() as i64 - r)..=(center.y.round() as i64 + r) {
        for x in (center.x.round() as i64 - r)..=(center.x.round() as i64 + r) {
            if x < 0 || y < 0 || x >= i64::from(image.width()) || y >= i64::from(image.height()) {
                continue;
            }
            let d = (x as f64 - center.x).hypot(y as f64 - center.y);
            if d <= radius_px {
                out.push((
                    x as f64,
                    y as f64,
                    f64::from(image.get_pixel(x as u32, y as u32).0[0]),
                ));
            }
        }
    }
    out
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

/// The isolated, fully visible markers of some frames of a scene, with their views.
fn clear_markers(scene: &Scene, frames: &[usize], seed: u64) -> Vec<(GrayImage, Pixel, f64)> {
    let mut out = Vec::new();
    for &frame in frames {
        for view in render_frame(scene, frame, seed) {
            for m in &view.markers {
                if m.isolated && m.view.visible_fraction > 0.999 {
                    out.push((view.image.clone(), m.view.center.unwrap(), m.view.radius_px));
                }
            }
        }
    }
    out
}

#[test]
fn stereo_ir_blobs_are_small_saturated_and_bloomed() {
    let scene = build_scene(Scenario::StereoIr, 1);
    let frames = [0, 25, 80, 130, 200, 290];
    let markers = clear_markers(&scene, &frames, 1);
    assert!(markers.len() >= 20, "{} clear markers", markers.len());
    let mut saturated = 0;
    let mut diameters = Vec::new();
    for (image, center, _) in &markers {
        let pixels = disc(image, *center, 6.0);
        if pixels.iter().any(|p| p.2 >= 255.0) {
            saturated += 1;
        }
        // Equal-area diameter of the pixels above half of full scale.
        let above = pixels.iter().filter(|p| p.2 > 127.5).count() as f64;
        diameters.push(2.0 * (above / std::f64::consts::PI).sqrt());
    }
    let fraction = f64::from(saturated) / markers.len() as f64;
    assert!(fraction > 0.95, "saturated fraction {fraction:.2}");
    let (lo, hi) = diameters
        .iter()
        .fold((f64::MAX, 0.0_f64), |(l, h), d| (l.min(*d), h.max(*d)));
    // The brief's 3–6 px; a 10 mm sphere at 2 m is 3.3 px before blur, bloom and smear.
    assert!(lo >= 3.0 && hi <= 6.0, "blob diameters {lo:.2}..{hi:.2} px");

    // The bloom skirt: the same frames without the halo (and without JPEG, which would add
    // its own ringing) against with it, 2.5–4.5 px from the centre. The skirt's predicted level
    // there is f·L·(area of the disc)/(2πσ²)·exp(−d²/2σ²) for a sphere of flux L per pixel
    // (the core's Gaussian is negligible at that distance).
    let mut with = scene.clone();
    with.render.jpeg_quality = None;
    let mut without = with.clone();
    without.render.halo = None;
    let halo = scene.render.halo.unwrap();
    let (mut measured, mut predicted) = (Vec::new(), Vec::new());
    for &frame in &frames {
        let a = render_frame(&with, frame, 1);
        let b = render_frame(&without, frame, 1);
        for (va, vb) in a.iter().zip(&b) {
            for m in va.markers.iter().filter(|m| m.isolated) {
                let c = m.view.center.unwrap();
                let ring = |image: &GrayImage| {
                    let outer = disc(image, c, 4.5);
                    let values: Vec<f64> = outer
                        .iter()
                        .filter(|p| (p.0 - c.x).hypot(p.1 - c.y) >= 2.5)
                        .map(|p| p.2)
                        .collect();
                    mean(&values)
                };
                measured.push(ring(&va.image) - ring(&vb.image));
                let flux = scene.render.marker_dn
                    * std::f64::consts::PI
                    * m.view.radius_px.powi(2)
                    * halo.fraction;
                let s2 = halo.sigma_px * halo.sigma_px;
                // Mean over the ring 2.5..4.5 px of the skirt's Gaussian.
                let ring_mean = (0..20)
                    .map(|k| {
                        let d: f64 = 2.5 + 0.1 * (f64::from(k) + 0.5);
                        d * (-d * d / (2.0 * s2)).exp()
                    })
                    .sum::<f64>()
                    / (0..20)
                        .map(|k| 2.5 + 0.1 * (f64::from(k) + 0.5))
                        .sum::<f64>();
                predicted.push(flux / (2.0 * std::f64::consts::PI * s2) * ring_mean);
            }
        }
    }
    let (m, p) = (mean(&measured), mean(&predicted));
    // Shot noise and quantisation average out over ~40 ring pixels × 20 markers; the motion
    // smear (≤ 3 px) moves light along the ring. 25 % holds both.
    assert!(
        (m - p).abs() < 0.25 * p,
        "bloom skirt {m:.2} DN, model {p:.2} DN"
    );
}

/// Mean absolute horizontal step across 8-pixel block boundaries and inside blocks, over
/// pixels near bright images (where JPEG's quantisation leaves its marks).
fn block_steps(image: &GrayImage) -> (f64, f64) {
    let (mut at, mut inside) = (Vec::new(), Vec::new());
    for y in 0..image.height() {
        for x in 0..image.width() - 1 {
            let (a, b) = (
                f64::from(image.get_pixel(x, y).0[0]),
                f64::from(image.get_pixel(x + 1, y).0[0]),
            );
            if a.max(b) < 4.0 || a.min(b) > 60.0 {
                continue;
            }
            if x % 8 == 7 {
                at.push((a - b).abs());
            } else {
                inside.push((a - b).abs());
            }
        }
    }
    (mean(&at), mean(&inside))
}

#[test]
fn jpeg_artefacts_are_baked_into_the_frames() {
    let scene = build_scene(Scenario::StereoIr, 1);
    let mut lossless = scene.clone();
    lossless.render.jpeg_quality = None;
    let (mut rms, mut n) = (0.0, 0.0);
    for frame in [10, 150] {
        let a = render_frame(&scene, frame, 1);
        let b = render_frame(&lossless, frame, 1);
        for (va, vb) in a.iter().zip(&b) {
            assert_eq!(va.jpeg_quality, Some(55));
            assert_eq!(vb.jpeg_quality, None);
            for (p, q) in va.image.as_raw().iter().zip(vb.image.as_raw()) {
                rms += (f64::from(*p) - f64::from(*q)).powi(2);
                n += 1.0;
            }
            let (at, inside) = block_steps(&va.image);
            let (at_clean, inside_clean) = block_steps(&vb.image);
            // Quantised DCT blocks are flat inside and step at their edges.
            assert!(
                at > 1.15 * inside,
                "jpeg: {at:.2} DN across block edges, {inside:.2} inside"
            );
            assert!(
                at_clean < 1.1 * inside_clean,
                "lossless: {at_clean:.2} DN across, {inside_clean:.2} inside"
            );
        }
    }
    let rms = (rms / n).sqrt();
    // Quality 55 over a near-black frame with a few saturated blobs: the error is ringing
    // around the blobs and the flattening of the sensor noise (0.6 DN read noise).
    assert!(rms > 0.3 && rms < 3.0, "jpeg error rms {rms:.3} DN");
}

#[test]
fn motion_blur_smears_the_marker_along_its_path() {
    // Noise-free, unsaturated, without bloom or JPEG, so that the second moment of a blob
    // is the sphere's plus the motion's exactly.
    let mut scene = build_scene(Scenario::StereoIr, 1);
    scene.render = RenderConfig {
        marker_dn: 200.0,
        read_noise_dn: 0.0,
        shot_noise_dn_per_dn: 0.0,
        background_dn: 0.0,
        ..RenderConfig::default()
    };
    scene.glints.clear();
    scene.streaks.clear();
    scene.mirror = None;
    scene.occluders.clear();
    // A long exposure (40 ms, 9 instants) smears markers by 3–8 px, well past the ±0.05 px²
    // that a blob's sampled second moment varies with its sub-pixel phase.
    scene.exposure = Exposure {
        duration_s: 0.04,
        instants: 9,
    };
    let n = scene.exposure.instants as f64;
    let mut still = scene.clone();
    still.exposure = Exposure::INSTANT;
    let camera = &scene.rig.cameras[0];
    let mut checked = 0;
    for frame in (0..300).step_by(5) {
        let t = frame as f64 / scene.fps;
        let d = scene.exposure.duration_s;
        let span = d * (n - 1.0) / n;
        let ends = [t - 0.5 * span, t + 0.5 * span].map(|time| {
            markers_in_world(&scene.tool, &scene.world_from_tool_at(time))
                .iter()
                .map(|p| camera.project(p).unwrap())
                .collect::<Vec<_>>()
        });
        let moving = &render_frame(&scene, frame, 1)[0];
        let resting = &render_frame(&still, frame, 1)[0];
        for m in moving.markers.iter().filter(|m| m.isolated) {
            let i = m.marker.0;
            let path = Vector3::new(
                ends[1][i].x - ends[0][i].x,
                ends[1][i].y - ends[0][i].y,
                0.0,
            );
            // The n instants sit evenly along `path` (first to last instant), from −1/2 to +1/2
            // of it: a variance of (n + 1)/(12(n − 1))·|path|².
            let length = path.norm();
            if length < 3.0 {
                continue;
            }
            let dir = path / length;
            let c = m.view.center.unwrap();
            let var_along = |image: &GrayImage| {
                let px = disc(image, c, 10.0);
                let w: f64 = px.iter().map(|p| p.2).sum();
                let mx = px.iter().map(|p| p.0 * p.2).sum::<f64>() / w;
                let my = px.iter().map(|p| p.1 * p.2).sum::<f64>() / w;
                px.iter()
                    .map(|p| ((p.0 - mx) * dir.x + (p.1 - my) * dir.y).powi(2) * p.2)
                    .sum::<f64>()
                    / w
            };
            let added = var_along(&moving.image) - var_along(&resting.image);
            let expected = (n + 1.0) / (12.0 * (n - 1.0)) * length * length;
            assert!(
                (added - expected).abs() < 0.1 * expected + 0.06,
                "frame {frame} marker {i}: variance along the path grew {added:.3} px², \
                 expected {expected:.3} px² ({length:.2} px path)"
            );
            checked += 1;
        }
    }
    assert!(checked >= 10, "{checked} smeared markers checked");
}

#[test]
fn uneven_light_follows_its_gradient_and_vignetting() {
    let scene = build_scene(Scenario::StereoIr, 1);
    let camera = &scene.rig.cameras[0];
    let light = teachcam::sim::optics::UnevenLight {
        gradient_x_dn: 30.0,
        gradient_y_dn: -10.0,
        vignetting: 0.4,
    };
    let config = RenderConfig {
        background_dn: 60.0,
        uneven_light: Some(light),
        ..RenderConfig::default()
    };
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(1);
    let (image, _) = teachcam::sim::render::render_view(camera, &[], &[], &config, &mut rng);
    let patch = |x0: u32, y0: u32| {
        let v: Vec<f64> = (y0..y0 + 10)
            .flat_map(|y| (x0..x0 + 10).map(move |x| (x, y)))
            .map(|(x, y)| f64::from(image.get_pixel(x, y).0[0]))
            .collect();
        mean(&v)
    };
    // Centre: 60 DN. Top-left corner patch (u, v ≈ −0.97): (60 − 30u... ) by the model.
    let model = |x: f64, y: f64| {
        let (u, v) = ((x - 319.5) / 319.5, (y - 239.5) / 239.5);
        (60.0 + 30.0 * u - 10.0 * v) * (1.0 - 0.4 * 0.5 * (u * u + v * v))
    };
    for (x0, y0) in [(0, 0), (630, 0), (0, 470), (630, 470), (315, 235)] {
        let measured = patch(x0, y0);
        let expected = model(f64::from(x0) + 4.5, f64::from(y0) + 4.5);
        // 100 pixels of 1.2 DN read noise (+ shot noise): σ of the mean ≈ 0.2 DN.
        assert!(
            (measured - expected).abs() < 1.0,
            "patch at ({x0}, {y0}): {measured:.2} DN, model {expected:.2} DN"
        );
    }
}

#[test]
fn stereo_ir_miscal_writes_cam1_turned_by_0_4_degrees() {
    let scene = build_scene(Scenario::StereoIrMiscal, 1);
    let written = scene.written_rig();
    let truth = &scene.rig;
    assert_eq!(written.cameras[0], truth.cameras[0]);
    let (w, t) = (&written.cameras[1], &truth.cameras[1]);
    let angle = rotation_angle_between(&w.camera_from_world, &t.camera_from_world).to_degrees();
    assert!((angle - 0.4).abs() < 1e-9, "cam1 off by {angle}°");
    assert!((w.center_in_world() - t.center_in_world()).norm() < 1e-9);
    assert!(build_scene(Scenario::StereoIr, 1).miscalibration.is_none());

    // What the error does: epipolar distance of the true projections under each rig.
    let epipolar = |a: &Camera, b: &Camera| {
        let f = fundamental_matrix(a, b);
        let mut d = Vec::new();
        for s in scene.truth.samples.iter().step_by(10) {
            for p in markers_in_world(&scene.tool, &s.pose.unwrap().world_from_tool) {
                let (pa, pb) = (truth.cameras[0].project(&p), truth.cameras[1].project(&p));
                let (Some(pa), Some(pb)) = (pa, pb) else {
                    continue;
                };
                let ia = truth.cameras[0].ideal_pixel(&pa).unwrap();
                let ib = truth.cameras[1].ideal_pixel(&pb).unwrap();
                d.push(epipolar_line(&f, &ia).unwrap().distance(&ib));
            }
        }
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    let clean = epipolar(&truth.cameras[0], &truth.cameras[1]);
    let wrong = epipolar(&written.cameras[0], &written.cameras[1]);
    assert!(clean < 1e-6, "true rig: {clean:.2e} px");
    // fx·0.4°·(share of the turn across the epipolar lines): 657 px · 0.00698 · ~0.9 ≈ 4 px.
    assert!((2.5..6.0).contains(&wrong), "written rig: {wrong:.2} px");

    let dir = tempfile::tempdir().unwrap();
    let mut short = scene.clone();
    short.truth.samples.truncate(2);
    write_scene(&short, dir.path(), 1, &|| {}).unwrap();
    let read = |name: &str| teachcam::io::rig::read_rig(&dir.path().join(name)).unwrap();
    assert_eq!(read("rig.json").cameras.len(), 2);
    let angle = rotation_angle_between(
        &read("rig.json").cameras[1].camera_from_world,
        &read("rig_true.json").cameras[1].camera_from_world,
    )
    .to_degrees();
    assert!((angle - 0.4).abs() < 1e-6, "files: {angle}°");
    let info: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("miscalibration.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(info["camera"], "cam1");
    assert!((info["angle_deg"].as_f64().unwrap() - 0.4).abs() < 1e-12);
}

/// Background-subtracted centroid of the pixels within `radius_px` of `near`.
fn centroid(image: &GrayImage, near: Pixel, radius_px: f64, background: f64) -> Pixel {
    let px = disc(image, near, radius_px);
    let w: f64 = px.iter().map(|p| (p.2 - background).max(0.0)).sum();
    Pixel::new(
        px.iter()
            .map(|p| p.0 * (p.2 - background).max(0.0))
            .sum::<f64>()
            / w,
        px.iter()
            .map(|p| p.1 * (p.2 - background).max(0.0))
            .sum::<f64>()
            / w,
    )
}

#[test]
fn unsynced_cameras_expose_at_their_own_offsets() {
    let scene = build_scene(Scenario::Unsynced, 1);
    assert_eq!(scene.time_offsets_s, vec![0.0, 0.0093, -0.0131]);
    let mut moved = 0;
    for frame in [20, 60, 100] {
        let views = render_frame(&scene, frame, 1);
        let t = scene.truth.samples[frame].time_s;
        for (id, camera) in scene.rig.iter() {
            let offset = scene.time_offset_s(id);
            let at_own = markers_in_world(&scene.tool, &scene.world_from_tool_at(t + offset));
            let at_frame = markers_in_world(
                &scene.tool,
                &scene.truth.samples[frame].pose.unwrap().world_from_tool,
            );
            for m in views[id.0].markers.iter().filter(|m| m.isolated) {
                let own = camera.project(&at_own[m.marker.0]).unwrap();
                let nominal = camera.project(&at_frame[m.marker.0]).unwrap();
                let found = centroid(&views[id.0].image, own, m.view.radius_px + 3.0, 12.0);
                assert!(
                    found.distance(&own) < 0.1,
                    "cam{} frame {frame}: blob {:.3} px from its exposure time's projection",
                    id.0,
                    found.distance(&own)
                );
                if id != CameraId(0) && nominal.distance(&own) > 2.0 {
                    moved += 1;
                }
            }
        }
    }
    // The fast stroke moves a marker 2–20 px in 9–13 ms: the offsets are visible.
    assert!(
        moved >= 12,
        "{moved} markers visibly displaced by the offsets"
    );

    let dir = tempfile::tempdir().unwrap();
    let mut short = scene.clone();
    short.truth.samples.truncate(1);
    write_scene(&short, dir.path(), 1, &|| {}).unwrap();
    let offsets: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("time_offsets.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(offsets["cam0"].as_f64(), Some(0.0));
    assert_eq!(offsets["cam1"].as_f64(), Some(0.0093));
    assert_eq!(offsets["cam2"].as_f64(), Some(-0.0131));
    assert!(!dir.path().join("rig_true.json").exists());
}

#[test]
fn stereo_ir_clutter_is_in_the_images() {
    let scene = build_scene(Scenario::StereoIr, 1);
    // The hand: half of marker 0 in cam0 (frames 40..70), of marker 2 in cam1 (150..175), all
    // of marker 1 in cam1 (230..240).
    let fraction = |frame: usize, camera: usize, marker: usize| {
        render_frame(&scene, frame, 1)[camera].markers[marker]
            .view
            .visible_fraction
    };
    let half = fraction(55, 0, 0);
    assert!(
        (0.2..0.8).contains(&half),
        "cam0 marker 0: {half:.2} visible"
    );
    let half = fraction(160, 1, 2);
    assert!(
        (0.2..0.8).contains(&half),
        "cam1 marker 2: {half:.2} visible"
    );
    assert!(fraction(235, 1, 1) < 0.05);
    assert!(fraction(100, 1, 1) > 0.999);

    // Mirror images in the plate: where the test's own reflection of each marker through
    // z = −350 mm projects, the image is bright (the background is under 10 DN) in the frames
    // where the line of sight crosses the plate.
    let mirror = scene.mirror.unwrap();
    let mut ghosts = 0;
    for frame in [0, 60, 120, 180, 240] {
        let views = render_frame(&scene, frame, 1);
        let pose = scene.truth.samples[frame].pose.unwrap();
        for (id, camera) in scene.rig.iter() {
            let eye = camera.center_in_world();
            for p in markers_in_world(&scene.tool, &pose.world_from_tool) {
                let ghost = Point3::new(p.x, p.y, 2.0 * mirror.height_mm - p.z);
                let s = (eye.z - mirror.height_mm) / (eye.z - ghost.z);
                let hit = eye + (ghost - eye) * s;
                let on_plate = hit.x.abs() < 500.0 && (-900.0..-200.0).contains(&hit.y);
                let Some(px) = camera.project(&ghost) else {
                    continue;
                };
                let inside = px.x > 4.0
                    && px.y > 4.0
                    && px.x < f64::from(camera.image_size.width) - 5.0
                    && px.y < f64::from(camera.image_size.height) - 5.0;
                if on_plate && inside {
                    let peak = disc(&views[id.0].image, px, 1.5)
                        .iter()
                        .map(|q| q.2)
                        .fold(0.0, f64::max);
                    assert!(
                        peak > 30.0,
                        "ghost at {px:?} in cam{} frame {frame}: {peak}",
                        id.0
                    );
                    ghosts += 1;
                }
            }
        }
    }
    assert!(ghosts >= 6, "{ghosts} mirror images checked");

    // Streaks: bright along their whole length.
    let views = render_frame(&scene, 3, 1);
    for s in &scene.streaks {
        let image = &views[s.camera.0].image;
        for k in 1..10 {
            let f = f64::from(k) / 10.0;
            let p = Pixel::new(
                s.streak.from.x + f * (s.streak.to.x - s.streak.from.x),
                s.streak.from.y + f * (s.streak.to.y - s.streak.from.y),
            );
            let peak = disc(image, p, 1.5).iter().map(|q| q.2).fold(0.0, f64::max);
            assert!(peak > 30.0, "streak at {p:?}: {peak}");
        }
    }
}

#[test]
fn four_cameras_hard_has_touching_marker_images() {
    let scene = build_scene(Scenario::FourCamerasHard, 1);
    assert_eq!(scene.rig.len(), 4);
    let radius = scene.tool.marker_radius();
    let mut touching = 0;
    for s in &scene.truth.samples {
        let points = markers_in_world(&scene.tool, &s.pose.unwrap().world_from_tool);
        for camera in &scene.rig.cameras {
            let images: Vec<(Pixel, f64)> = points
                .iter()
                .map(|p| {
                    let d = camera.camera_from_world.transform_point(p).coords.norm();
                    (
                        camera.project(p).unwrap(),
                        camera.intrinsics.fx * radius / d,
                    )
                })
                .collect();
            for i in 0..images.len() {
                for j in i + 1..images.len() {
                    let gap = images[i].0.distance(&images[j].0) - images[i].1 - images[j].1;
                    if gap < 0.5 {
                        touching += 1;
                    }
                }
            }
        }
    }
    assert!(touching >= 10, "{touching} touching marker pairs");
    assert!(scene.mirror.is_some() && !scene.streaks.is_empty());
    assert!(scene.occluders.iter().any(|o| o.sideways_mm > 0.0));
}

#[test]
fn real_world_scenes_are_deterministic_per_seed() {
    for scenario in [Scenario::StereoIr, Scenario::FourCamerasHard] {
        let scene = build_scene(scenario, 5);
        let a = render_frame(&scene, 7, 5);
        let b = render_frame(&build_scene(scenario, 5), 7, 5);
        let c = render_frame(&build_scene(scenario, 6), 7, 6);
        assert_eq!(a, b, "{}", scenario.name());
        assert_ne!(a[1].image, c[1].image, "{}", scenario.name());
    }
    let _ = real_world::stereo_ir_rig();
}
