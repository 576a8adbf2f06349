//! A frame's sketch (`detect::sketch`) detects as the frame itself does, for every threshold at
//! or above the level it was made at and every narrower window: real IR video frames, real
//! photographs (chessboards: large bright regions, many of them), the simulator's hardest
//! frames (saturated blobs, bloom, JPEG, glints, streaks, touching markers), 16-bit frames and
//! noise with more regions than allowed. The expectation is the detector run on the decoded
//! frame, not the sketch's own code.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::print_stderr,
    reason = "a test fails loudly on a broken fixture and says why it skipped"
)]

use image::{GrayImage, ImageBuffer, Luma};
use teachcam::detect::learn::FrameSample;
use teachcam::detect::sketch::Sketch;
use teachcam::detect::{
    CenterMethod, DetectConfig, DetectError, GrayView, Intensity, Threshold, detect_choices,
    detect_view, estimate_background,
};
use teachcam::io::recording::GrayFrame;
use teachcam::sim::{Scenario, build_scene, render_frame};
use teachcam::source::video::{VideoReader, probe};

/// The configurations each frame is detected with from its sketch, made with `base`: the
/// automatic threshold, thresholds above the background from just past the noise to near full
/// scale, fixed levels at and above the automatic one, other floors, sizes, centres, and
/// windows up to the sketch's. `lowest` is the level the sketch keeps every pixel above: the
/// automatic one, or `base`'s fixed threshold when lower.
fn configs(base: &DetectConfig, lowest: u32, full: u32) -> Vec<DetectConfig> {
    let mut all = vec![base.clone()];
    for contrast in [0.02, 0.1, 0.33, 0.6, 0.95] {
        all.push(DetectConfig {
            threshold: Threshold::AboveBackground(contrast * f64::from(full)),
            ..base.clone()
        });
    }
    for level in [lowest, lowest + 1, (lowest + full) / 2, full - 1] {
        if level < lowest {
            continue;
        }
        all.push(DetectConfig {
            threshold: Threshold::Fixed(level.min(full)),
            ..base.clone()
        });
    }
    all.push(DetectConfig {
        min_roundness: 0.0,
        min_area_px: 1,
        ..base.clone()
    });
    for method in [CenterMethod::Centroid, CenterMethod::SmallestCircle] {
        all.push(DetectConfig {
            method,
            ..base.clone()
        });
    }
    for margin in [0.0, 0.5, base.window_margin_px - 1.0] {
        all.push(DetectConfig {
            window_margin_px: margin.max(0.0),
            ..base.clone()
        });
    }
    all
}

/// Every detection of `configs` is the same from `image`'s sketch as from `image`; returns
/// the blobs found, to show the frame was not empty.
fn same_from_sketch<P: Intensity>(
    image: &ImageBuffer<Luma<P>, Vec<P>>,
    frame: &GrayFrame,
    base: &DetectConfig,
    what: &str,
) -> usize {
    let view = GrayView::new(image);
    let sketch = Sketch::of(frame, base);
    let auto = estimate_background(view).auto_threshold::<P>();
    let lowest = match base.threshold {
        Threshold::Fixed(level) => level.min(auto),
        _ => auto,
    };
    let mut found = 0;
    for config in configs(base, lowest, P::FULL_SCALE) {
        let direct = detect_view(view, &config);
        found += direct.as_ref().map_or(0, Vec::len);
        assert_eq!(sketch.detect(&config), direct, "{what}: {config:?}");
        assert_eq!(
            sketch.detect_choices(&config),
            detect_choices(view, &config),
            "{what}: choices, {config:?}"
        );
    }
    assert_eq!(
        sketch.sample(base),
        FrameSample::detect(view, base),
        "{what}: permissive sample"
    );
    found
}

fn same_from_sketch_8(image: &GrayImage, base: &DetectConfig, what: &str) -> usize {
    same_from_sketch(image, &GrayFrame::Eight(image.clone()), base, what)
}

/// The base configuration: the default with a wider window than the default.
fn base() -> DetectConfig {
    DetectConfig {
        window_margin_px: 3.5,
        ..DetectConfig::default()
    }
}

#[test]
fn real_ir_video_frames_detect_the_same_from_their_sketches() {
    if !teachcam_testdata::ffmpeg("real_ir_video_frames_detect_the_same_from_their_sketches") {
        return;
    }
    let Some(data) = teachcam_testdata::shared_data("real-ir") else {
        return;
    };
    let video = data.join("normal.avi");
    let info = probe(&video, "cam0").unwrap();
    let mut reader = VideoReader::start(&video, info, 1).unwrap();
    let (mut index, mut frames, mut blobs) = (0, 0, 0);
    while let Some(frame) = reader.next_frame() {
        let frame = frame.unwrap();
        // Every 5th frame: compressed saturated discs, their bloom skirts and block specks.
        if index % 5 == 0 {
            let GrayFrame::Eight(image) = &frame else {
                panic!("an 8-bit video decodes to 8 bits");
            };
            blobs += same_from_sketch_8(image, &base(), &format!("normal.avi frame {index}"));
            frames += 1;
        }
        index += 1;
    }
    assert_eq!(frames, 81);
    assert!(blobs > frames * 5, "{blobs} blobs in {frames} frames");
}

#[test]
fn photographs_detect_the_same_from_their_sketches() {
    let Some(calib) = teachcam_testdata::shared_data("calib") else {
        return;
    };
    let Some(blob) = teachcam_testdata::shared_data("blob") else {
        return;
    };
    let mut photos = vec![blob.join("detect_blob.png")];
    for entry in std::fs::read_dir(calib.join("opencv-stereo-9x6")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "jpg" || e == "png") {
            photos.push(path);
        }
    }
    photos.sort();
    photos.truncate(8);
    assert!(photos.len() >= 5, "{photos:?}");
    // A photograph's background is no marker scene's: its spread puts the automatic level at
    // full scale. A fixed level in the middle makes regions of every size and shape.
    let base = DetectConfig {
        threshold: Threshold::Fixed(128),
        ..base()
    };
    let mut blobs = 0;
    for path in &photos {
        let mut image = image::open(path).unwrap().to_luma8();
        blobs += same_from_sketch_8(&image, &base, &path.display().to_string());
        // Inverted: the dark squares and blobs become the bright regions.
        image::imageops::invert(&mut image);
        blobs += same_from_sketch_8(&image, &base, &format!("{} inverted", path.display()));
        // The same photograph at 16 bits, the low byte filled as a 16-bit camera would.
        let deep: ImageBuffer<Luma<u16>, Vec<u16>> =
            ImageBuffer::from_fn(image.width(), image.height(), |x, y| {
                let v = u16::from(image.get_pixel(x, y)[0]);
                Luma([(v * 257) ^ ((x * 7 + y * 13) % 97) as u16])
            });
        let deep_base = DetectConfig {
            threshold: Threshold::Fixed(128 * 257),
            ..base.clone()
        };
        same_from_sketch(
            &deep,
            &GrayFrame::Sixteen(deep.clone()),
            &deep_base,
            &format!("{} at 16 bits", path.display()),
        );
    }
    assert!(blobs > 0);
}

#[test]
fn the_simulators_hardest_frames_detect_the_same_from_their_sketches() {
    let mut blobs = 0;
    for scenario in [
        Scenario::StereoIr,
        Scenario::FourCamerasHard,
        Scenario::Paper,
    ] {
        let scene = build_scene(scenario, 7);
        let count = scene.truth.samples.len();
        for frame in [0, count / 3, 2 * count / 3] {
            for view in render_frame(&scene, frame, 7) {
                blobs += same_from_sketch_8(
                    &view.image,
                    &base(),
                    &format!("{scenario:?} frame {frame} camera {}", view.camera.0),
                );
            }
        }
    }
    assert!(blobs > 100, "{blobs}");
}

#[test]
fn a_frame_with_more_regions_than_allowed_is_kept_whole() {
    // Salt noise: one lit pixel in 16, thousands of separate regions above any threshold.
    let image = GrayImage::from_fn(320, 240, |x, y| {
        let h = (x.wrapping_mul(2_654_435_761) ^ y.wrapping_mul(40_503)) % 16;
        Luma([if h == 0 { 220 } else { 10 }])
    });
    let base = DetectConfig {
        max_regions: 50,
        ..base()
    };
    let frame = GrayFrame::Eight(image.clone());
    let sketch = Sketch::of(&frame, &base);
    assert!(
        sketch.bytes() >= 320 * 240,
        "kept whole: {} bytes",
        sketch.bytes()
    );
    // Every detection refuses the frame as the frame itself does.
    let view = GrayView::new(&image);
    assert!(matches!(
        detect_view(view, &base),
        Err(DetectError::TooManyRegions { .. })
    ));
    same_from_sketch_8(&image, &base, "salt noise");
    // With room for the regions the sketch keeps a box per region: far less than the frame
    // would be for a dark frame with a few blobs, and the same detections.
    let roomy = DetectConfig {
        max_regions: 20_000,
        ..base
    };
    same_from_sketch_8(&image, &roomy, "salt noise, regions allowed");
}

#[test]
fn a_detection_the_sketch_cannot_serve_is_refused() {
    let scene = build_scene(Scenario::Paper, 3);
    let view = render_frame(&scene, 0, 3).remove(0);
    let image = view.image;
    let auto = estimate_background(GrayView::new(&image)).auto_threshold::<u8>();
    let sketch = Sketch::of(&GrayFrame::Eight(image.clone()), &base());
    // A dark frame with a few markers keeps a small part of itself.
    assert!(
        sketch.bytes() * 20 < image.len(),
        "{} of {} bytes",
        sketch.bytes(),
        image.len()
    );
    let below = DetectConfig {
        threshold: Threshold::Fixed(auto - 1),
        ..base()
    };
    assert!(matches!(
        sketch.detect(&below),
        Err(DetectError::Sketch { .. })
    ));
    let wider = DetectConfig {
        window_margin_px: 5.0,
        ..base()
    };
    assert!(matches!(
        sketch.detect_choices(&wider),
        Err(DetectError::Sketch { .. })
    ));
    // A sketch made for a fixed threshold below the automatic level serves it.
    let low = Sketch::of(&GrayFrame::Eight(image.clone()), &below);
    assert_eq!(
        low.detect(&below),
        detect_view(GrayView::new(&image), &below)
    );
}
