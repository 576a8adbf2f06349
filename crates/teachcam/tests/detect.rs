//! Marker detection against closed-form discs, OpenCV's numbers on a real image, and bad input.

#[path = "support/discs.rs"]
mod discs;

use discs::{Disc, Scene};
use teachcam::detect::{
    Blob, CenterMethod, DetectConfig, DetectError, GrayView, Threshold, detect, detect_choices,
    detect_dynamic,
};
use teachcam::geometry::Pixel;

/// Discs of radius 3–10 px at sub-pixel positions from a seeded generator, well apart.
fn scattered_discs(seed: u64, count: usize, width: u32, height: u32) -> Vec<Disc> {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut discs: Vec<Disc> = Vec::new();
    while discs.len() < count {
        let radius_px = rng.random_range(3.0..10.0);
        let x = rng.random_range(20.0..f64::from(width) - 20.0);
        let y = rng.random_range(20.0..f64::from(height) - 20.0);
        // Edges at least 12 px apart: no window of one blob meets another.
        if discs
            .iter()
            .all(|d| (d.x - x).hypot(d.y - y) > d.radius_px + radius_px + 12.0)
        {
            discs.push(Disc { x, y, radius_px });
        }
    }
    discs
}

fn paper_like_scene(seed: u64) -> Scene {
    Scene {
        width: 480,
        height: 360,
        background: 12.0,
        amplitude: 200.0,
        blur_px: 0.8,
        noise_std: 2.0,
        seed,
    }
}

/// Distance from each disc to the nearest blob centre; `None` where no blob lies within 2 px.
fn errors(discs: &[Disc], blobs: &[Blob]) -> Vec<Option<f64>> {
    discs
        .iter()
        .map(|d| {
            let truth = Pixel::new(d.x, d.y);
            blobs
                .iter()
                .map(|b| b.center.distance(&truth))
                .min_by(f64::total_cmp)
                .filter(|&e| e < 2.0)
        })
        .collect()
}

struct Figures {
    mean: f64,
    p99: f64,
    max: f64,
    missed: usize,
}

fn figures(errors: &[Option<f64>]) -> Figures {
    let mut found: Vec<f64> = errors.iter().flatten().copied().collect();
    found.sort_by(f64::total_cmp);
    let n = found.len().max(1);
    Figures {
        mean: found.iter().sum::<f64>() / n as f64,
        p99: found[((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1],
        max: found.last().copied().unwrap_or(f64::NAN),
        missed: errors.len() - found.len(),
    }
}

#[test]
fn refined_centres_meet_the_accuracy_targets_on_noisy_blurred_discs() {
    let methods = [
        CenterMethod::Refined,
        CenterMethod::Centroid,
        CenterMethod::SmallestCircle,
    ];
    let mut per_method: Vec<Vec<Option<f64>>> = vec![Vec::new(); methods.len()];
    for image_seed in 0..20 {
        let scene = paper_like_scene(image_seed);
        let discs = scattered_discs(image_seed, 20, scene.width, scene.height);
        let image = discs::render_u8(&scene, &discs);
        for (m, method) in methods.iter().enumerate() {
            let cfg = DetectConfig {
                method: *method,
                ..DetectConfig::default()
            };
            let blobs = detect(&image, &cfg).unwrap();
            assert_eq!(blobs.len(), discs.len(), "image {image_seed}, {method}");
            per_method[m].extend(errors(&discs, &blobs));
        }
    }
    let all: Vec<Figures> = per_method.iter().map(|e| figures(e)).collect();
    for (method, f) in methods.iter().zip(&all) {
        eprintln!(
            "{method:>15}: mean {:.4} px, p99 {:.4} px, max {:.4} px, missed {} of {}",
            f.mean,
            f.p99,
            f.max,
            f.missed,
            per_method[0].len()
        );
    }
    let refined = &all[0];
    assert_eq!(refined.missed, 0);
    assert!(refined.mean <= 0.02, "mean {}", refined.mean);
    assert!(refined.p99 <= 0.06, "p99 {}", refined.p99);
    // The paper's method is markedly worse: that is why it is not the default.
    assert!(all[2].mean > 2.0 * refined.mean);
}

#[test]
fn noise_free_discs_show_the_bias_floor_of_each_method() {
    // No noise: what remains is the estimator's own bias from the pixel grid.
    let mut worst = [0.0f64; 2];
    for image_seed in 0..10 {
        let scene = Scene {
            noise_std: 0.0,
            ..paper_like_scene(image_seed)
        };
        let discs = scattered_discs(100 + image_seed, 20, scene.width, scene.height);
        let image = discs::render_u8(&scene, &discs);
        for (m, method) in [CenterMethod::Refined, CenterMethod::Centroid]
            .iter()
            .enumerate()
        {
            let cfg = DetectConfig {
                method: *method,
                ..DetectConfig::default()
            };
            let blobs = detect(&image, &cfg).unwrap();
            let f = figures(&errors(&discs, &blobs));
            assert_eq!(f.missed, 0);
            worst[m] = worst[m].max(f.max);
        }
    }
    eprintln!(
        "noise-free worst error: refined {:.4} px, centroid {:.4} px",
        worst[0], worst[1]
    );
    // Rounding to 8 bits alone moves a centroid by up to about 0.5 / (200 · √area) per pixel.
    assert!(worst[0] < 0.01, "refined bias {}", worst[0]);
}

#[test]
fn sixteen_bit_images_give_the_same_accuracy() {
    let scene = Scene {
        background: 12.0 * 257.0,
        amplitude: 200.0 * 257.0,
        noise_std: 2.0 * 257.0,
        ..paper_like_scene(7)
    };
    let discs = scattered_discs(7, 20, scene.width, scene.height);
    let image = discs::render_u16(&scene, &discs);
    let blobs = detect(&image, &DetectConfig::default()).unwrap();
    let f = figures(&errors(&discs, &blobs));
    assert_eq!((blobs.len(), f.missed), (20, 0));
    assert!(
        f.mean <= 0.02 && f.p99 <= 0.06,
        "mean {} p99 {}",
        f.mean,
        f.p99
    );
    // Through `DynamicImage` too.
    let dynamic = image::DynamicImage::ImageLuma16(image);
    assert_eq!(
        detect_dynamic(&dynamic, &DetectConfig::default()).unwrap(),
        blobs
    );
}

#[test]
fn radius_and_predicted_noise_match_the_truth() {
    // One disc, 200 noise draws: the spread of the centre against the predicted std, and
    // the flux radius against the drawn radius.
    let disc = Disc {
        x: 60.3,
        y: 40.7,
        radius_px: 6.0,
    };
    let mut xs = Vec::new();
    let mut predicted = Vec::new();
    for seed in 0..200 {
        let scene = Scene {
            width: 120,
            height: 80,
            ..paper_like_scene(seed)
        };
        let image = discs::render_u8(&scene, &[disc]);
        let blobs = detect(&image, &DetectConfig::default()).unwrap();
        assert_eq!(blobs.len(), 1);
        assert!(
            (blobs[0].radius_px - disc.radius_px).abs() < 0.1,
            "radius {}",
            blobs[0].radius_px
        );
        xs.push(blobs[0].center.x);
        predicted.push(blobs[0].center_std_px);
    }
    let mean = xs.iter().sum::<f64>() / xs.len() as f64;
    let std = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (xs.len() - 1) as f64).sqrt();
    let predicted = predicted.iter().sum::<f64>() / predicted.len() as f64;
    // 200 draws estimate a std to ±10 % (1σ = 1/√(2·199) = 5 %); allow 20 %.
    assert!(
        (std / predicted - 1.0).abs() < 0.2,
        "measured {std} predicted {predicted}"
    );
}

#[test]
fn touching_discs_are_rejected_not_merged_into_one_centre() {
    let scene = paper_like_scene(3);
    for (r1, r2, gap) in [
        (6.0, 6.0, 0.0),
        (8.0, 3.0, 0.5),
        (5.0, 5.0, -1.0),
        (9.0, 4.0, 0.0),
    ] {
        let discs = [
            Disc {
                x: 100.2,
                y: 80.6,
                radius_px: r1,
            },
            Disc {
                x: 100.2 + r1 + r2 + gap,
                y: 80.6 + 0.4,
                radius_px: r2,
            },
        ];
        let image = discs::render_u8(&scene, &discs);
        let blobs = detect(&image, &DetectConfig::default()).unwrap();
        assert!(blobs.is_empty(), "radii {r1} {r2} gap {gap}: {blobs:?}");
    }
}

#[test]
fn nearly_touching_discs_that_merge_at_threshold_are_split_and_measured() {
    // Gaps of 2–4 px between edges: the blurred tails merge the two at the detection
    // threshold for some of them, yet each marker must come out alone, at its centre.
    let mut worst: f64 = 0.0;
    let mut merged = 0;
    for (k, gap) in [2.2, 2.6, 2.85, 3.2, 3.6, 4.0].into_iter().enumerate() {
        for seed in 0..4 {
            let scene = Scene {
                blur_px: 0.6,
                noise_std: 1.4,
                ..paper_like_scene(100 * k as u64 + seed)
            };
            let (r1, r2) = (9.3, 9.76);
            let angle = 1.3 + 0.4 * seed as f64;
            let a = Disc {
                x: 200.37,
                y: 150.81,
                radius_px: r1,
            };
            let b = Disc {
                x: a.x + (r1 + r2 + gap) * angle.cos(),
                y: a.y + (r1 + r2 + gap) * angle.sin(),
                radius_px: r2,
            };
            let image = discs::render_u8(&scene, &[a, b]);
            let threshold =
                teachcam::detect::estimate_background(teachcam::detect::GrayView::new(&image))
                    .auto_threshold::<u8>();
            let regions = teachcam::detect::components::label(
                teachcam::detect::GrayView::new(&image),
                threshold,
                100,
            )
            .unwrap();
            merged += usize::from(regions.len() == 1);
            let blobs = detect(&image, &DetectConfig::default()).unwrap();
            let f = figures(&errors(&[a, b], &blobs));
            assert_eq!((blobs.len(), f.missed), (2, 0), "gap {gap}, seed {seed}");
            worst = worst.max(f.max);
        }
    }
    eprintln!("near pairs: {merged} of 24 merged at threshold, worst error {worst:.4} px");
    // Some pairs really merged, so the split path was exercised.
    assert!(merged > 0);
    assert!(worst < 0.06, "worst {worst}");
}

/// The roundness floor chosen after detection gives what detecting with it gives.
fn assert_choices_match_detection(image: &image::GrayImage, cfg: &DetectConfig, gates: &[f64]) {
    let choices = detect_choices(GrayView::new(image), cfg).unwrap_or_else(|e| panic!("{e}"));
    for &gate in gates {
        let direct = detect(
            image,
            &DetectConfig {
                min_roundness: gate,
                ..cfg.clone()
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let chosen = choices.at(gate);
        if gate < cfg.min_roundness {
            assert_eq!(
                chosen, None,
                "gate {gate} below the floor {}",
                cfg.min_roundness
            );
        } else {
            assert_eq!(
                chosen,
                Some(direct),
                "gate {gate}, floor {}",
                cfg.min_roundness
            );
        }
    }
}

#[test]
fn roundness_chosen_after_detection_equals_detection_with_it() {
    // A round disc, a pair that merges at threshold and splits at half contrast, a touching
    // pair (one unround blob that does not split) and a pair overlapping so much that it is
    // one long blob of middling roundness.
    let scene = Scene {
        blur_px: 0.6,
        noise_std: 1.4,
        ..paper_like_scene(7)
    };
    let discs = [
        Disc {
            x: 60.3,
            y: 60.7,
            radius_px: 7.0,
        },
        Disc {
            x: 200.37,
            y: 150.81,
            radius_px: 9.3,
        },
        Disc {
            x: 200.37 + 21.3 * 1.3f64.cos(),
            y: 150.81 + 21.3 * 1.3f64.sin(),
            radius_px: 9.76,
        },
        Disc {
            x: 350.2,
            y: 80.6,
            radius_px: 6.0,
        },
        Disc {
            x: 362.2,
            y: 81.0,
            radius_px: 6.0,
        },
        Disc {
            x: 120.4,
            y: 280.3,
            radius_px: 8.0,
        },
        Disc {
            x: 126.9,
            y: 283.1,
            radius_px: 8.0,
        },
    ];
    let image = discs::render_u8(&scene, &discs);
    let cfg = DetectConfig {
        min_roundness: 0.3,
        ..DetectConfig::default()
    };
    let gates: Vec<f64> = (0..=16).map(|k| 0.25 + 0.05 * f64::from(k)).collect();
    assert_choices_match_detection(&image, &cfg, &gates);
    // The scene changes with the gate (else the comparison proves nothing): at the lowest
    // gate the unround blobs are kept whole, at the highest only the round ones and the split
    // parts.
    let counts: Vec<usize> = [0.3, 0.95]
        .iter()
        .map(|&g| {
            detect_choices(GrayView::new(&image), &cfg)
                .unwrap()
                .at(g)
                .unwrap()
                .len()
        })
        .collect();
    assert_ne!(counts[0], counts[1], "{counts:?}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    /// Any small image, any floor: each gate at or above the floor, the blobs' own roundness
    /// values among them (the comparison is `>=`), gives detection's blobs at that gate.
    #[test]
    fn any_image_roundness_chosen_after_detection_equals_detection(
        width in 1u32..48,
        height in 1u32..48,
        seed in 0u64..1_000_000,
        floor in 0.0f64..1.0,
        method in proptest::sample::select(vec![CenterMethod::Refined, CenterMethod::Centroid, CenterMethod::SmallestCircle]),
    ) {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let image = image::GrayImage::from_fn(width, height, |_, _| {
            let v: u8 = rng.random();
            image::Luma([if v < 170 { 10 } else { v }])
        });
        let cfg = DetectConfig {
            threshold: Threshold::Fixed(100),
            min_area_px: 1,
            min_roundness: floor,
            method,
            ..DetectConfig::default()
        };
        let mut gates: Vec<f64> = detect(&image, &DetectConfig { min_roundness: 0.0, ..cfg.clone() })
            .unwrap()
            .iter()
            .map(|b| b.roundness)
            .collect();
        gates.extend([floor - 0.01, floor, 0.5 * (floor + 1.0), 1.0, 1.5]);
        assert_choices_match_detection(&image, &cfg, &gates);
    }
}

#[test]
fn blobs_at_the_image_border_are_rejected() {
    let scene = paper_like_scene(4);
    let discs = [
        Disc {
            x: 2.0,
            y: 100.0,
            radius_px: 6.0,
        },
        Disc {
            x: 200.0,
            y: 100.0,
            radius_px: 6.0,
        },
    ];
    let blobs = detect(&discs::render_u8(&scene, &discs), &DetectConfig::default()).unwrap();
    assert_eq!(blobs.len(), 1);
    assert!((blobs[0].center.x - 200.0).abs() < 0.1);
}

#[test]
fn bad_images_give_an_empty_result_or_a_clear_error() {
    let cfg = DetectConfig::default();
    // All white, all black, 1×1, empty.
    assert!(
        detect(
            &image::GrayImage::from_pixel(64, 48, image::Luma([255])),
            &cfg
        )
        .unwrap()
        .is_empty()
    );
    assert!(
        detect(&image::GrayImage::new(64, 48), &cfg)
            .unwrap()
            .is_empty()
    );
    assert!(
        detect(
            &image::GrayImage::from_pixel(1, 1, image::Luma([200])),
            &cfg
        )
        .unwrap()
        .is_empty()
    );
    assert!(
        detect(&image::GrayImage::new(0, 0), &cfg)
            .unwrap()
            .is_empty()
    );
    // Pure uniform noise: the automatic threshold is above it.
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let noise = image::GrayImage::from_fn(1280, 1024, |_, _| image::Luma([rng.random::<u8>()]));
    assert!(detect(&noise, &cfg).unwrap().is_empty());
    // With a threshold forced into the noise, the region cap stops it and says so.
    let low = DetectConfig {
        threshold: Threshold::Fixed(230),
        ..cfg
    };
    let error = detect(&noise, &low).unwrap_err();
    assert!(matches!(
        error,
        DetectError::TooManyRegions {
            limit: 20_000,
            threshold: 230
        }
    ));
    assert!(error.to_string().contains("threshold 230"));
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
    /// Any small image: no panic, and every centre, radius and roundness is a finite number
    /// with the centre inside the blob's box.
    #[test]
    fn any_image_gives_sane_blobs(
        width in 1u32..40,
        height in 1u32..40,
        seed in 0u64..1_000_000,
        threshold in proptest::option::of(0u32..256),
        method in proptest::sample::select(vec![CenterMethod::Refined, CenterMethod::Centroid, CenterMethod::SmallestCircle]),
    ) {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let sparse = rng.random_bool(0.5);
        let image = image::GrayImage::from_fn(width, height, |_, _| {
            let v: u8 = rng.random();
            image::Luma([if sparse && v < 200 { 10 } else { v }])
        });
        let cfg = DetectConfig {
            threshold: threshold.map_or(Threshold::Auto, Threshold::Fixed),
            min_area_px: 1,
            min_roundness: 0.0,
            method,
            ..DetectConfig::default()
        };
        for blob in detect(&image, &cfg).unwrap() {
            let b = blob.bounding_box;
            proptest::prop_assert!(blob.center.is_finite() && blob.radius_px.is_finite());
            proptest::prop_assert!((0.0..=1.0).contains(&blob.roundness));
            proptest::prop_assert!(blob.center.x >= f64::from(b.x_min) - 3.0 && blob.center.x <= f64::from(b.x_max) + 3.0);
            proptest::prop_assert!(blob.center.y >= f64::from(b.y_min) - 3.0 && blob.center.y <= f64::from(b.y_max) + 3.0);
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(32))]
    /// 16-bit images, values over the whole range: no panic, sane blobs.
    #[test]
    fn any_16_bit_image_gives_sane_blobs(
        width in 1u32..32,
        height in 1u32..32,
        seed in 0u64..1_000_000,
        threshold in proptest::option::of(0u32..65536),
    ) {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let image: image::ImageBuffer<image::Luma<u16>, Vec<u16>> =
            image::ImageBuffer::from_fn(width, height, |_, _| {
                let v: u16 = rng.random();
                image::Luma([if v < 50_000 { 3000 } else { v }])
            });
        let cfg = DetectConfig {
            threshold: threshold.map_or(Threshold::Auto, Threshold::Fixed),
            min_area_px: 1,
            min_roundness: 0.0,
            ..DetectConfig::default()
        };
        for blob in detect(&image, &cfg).unwrap() {
            proptest::prop_assert!(blob.center.is_finite() && blob.radius_px.is_finite());
            proptest::prop_assert!(blob.center_std_px.is_finite() && blob.center_std_px >= 0.0);
        }
    }
}

/// `shared/data`, or `None` (test skipped) when it is missing outside CI.
fn shared_data() -> Option<std::path::PathBuf> {
    teachcam_testdata::shared_data("")
}

#[derive(serde::Deserialize)]
struct OpencvComponent {
    area: usize,
    bbox: [u32; 4],
    centroid: [f64; 2],
    intensity_sums: [f64; 3],
    min_enclosing_circle: [f64; 3],
}

#[derive(serde::Deserialize)]
struct OpencvReference {
    threshold: u32,
    components: Vec<OpencvComponent>,
}

#[test]
fn opencv_components_on_its_blob_image() {
    let Some(data) = shared_data() else { return };
    let rgba = image::open(data.join("blob/detect_blob.png"))
        .unwrap()
        .to_rgba8();
    let grey = image::GrayImage::from_fn(rgba.width(), rgba.height(), |x, y| {
        let p = rgba.get_pixel(x, y).0;
        image::Luma([p[0].max(p[1]).max(p[2])])
    });
    let reference: OpencvReference = serde_json::from_str(
        &std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/detect_blob_opencv.json"
        ))
        .unwrap(),
    )
    .unwrap();
    let cfg = |method| DetectConfig {
        threshold: Threshold::Fixed(reference.threshold),
        min_area_px: 1,
        max_area_px: usize::MAX,
        min_roundness: 0.0,
        method,
        ..DetectConfig::default()
    };
    let background =
        teachcam::detect::estimate_background(teachcam::detect::GrayView::new(&grey)).level;
    // Mostly black: the interpolated median lies within the zero bin.
    assert!((0.0..0.5).contains(&background));
    let centroid = detect(&grey, &cfg(CenterMethod::Centroid)).unwrap();
    let circle = detect(&grey, &cfg(CenterMethod::SmallestCircle)).unwrap();
    // OpenCV's list minus the frame around the image (it touches the border).
    let inner: Vec<&OpencvComponent> = reference
        .components
        .iter()
        .filter(|c| c.bbox[0] > 0)
        .collect();
    assert_eq!(centroid.len(), inner.len());
    for ((ours, ours_circle), theirs) in centroid.iter().zip(&circle).zip(&inner) {
        let b = ours.bounding_box;
        assert_eq!([b.x_min, b.y_min, b.x_max, b.y_max], theirs.bbox);
        assert_eq!(ours.area_px, theirs.area);
        // Background-subtracted weights from OpenCV's pixel set and numpy's sums.
        let n = theirs.area as f64;
        let [sum_i, sum_ix, sum_iy] = theirs.intensity_sums;
        let flux = sum_i - background * n;
        let expected = Pixel::new(
            (sum_ix - background * n * theirs.centroid[0]) / flux,
            (sum_iy - background * n * theirs.centroid[1]) / flux,
        );
        assert!(
            ours.center.distance(&expected) < 1e-9,
            "{:?} vs {expected:?}",
            ours.center
        );
        // minEnclosingCircle works in f32 and pads its radius: agree to 1e-3 px.
        let [cx, cy, _] = theirs.min_enclosing_circle;
        assert!(
            ours_circle.center.distance(&Pixel::new(cx, cy)) < 1e-3,
            "{:?} vs {cx} {cy}",
            ours_circle.center
        );
    }
    // With the default filters, only the round shapes survive: the discs (and no square,
    // ellipse, ring or the cluster of touching circles).
    let round = detect(
        &grey,
        &DetectConfig {
            threshold: Threshold::Fixed(reference.threshold),
            ..DetectConfig::default()
        },
    )
    .unwrap();
    let kept: Vec<(u32, u32)> = round
        .iter()
        .map(|b| (b.bounding_box.x_min, b.bounding_box.y_min))
        .collect();
    // The five filled discs (two small, two medium, the shaded one), by their top-left corners;
    // not the squares, rectangles, ellipses, the ring or the cluster of touching circles.
    assert_eq!(
        kept,
        vec![(42, 45), (166, 45), (79, 106), (34, 208), (163, 518)]
    );
    for b in &round {
        assert!(b.roundness > 0.9, "{kept:?}");
    }
}
