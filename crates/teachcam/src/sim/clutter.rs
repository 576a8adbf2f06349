//! `four-cameras-hard`: the four-camera rig filming the paper's stroke with every kind of
//! clutter at once — the scene of issue 15's hidden acceptance ("a 4-camera scene with
//! reflections, occlusions and markers whose images touch").
//!
//! Events: the `occluded` scenario's dark occluders (cam0–cam2) plus one in cam3, three hands
//! hiding half of a marker, persistent and flickering glints in every camera, two glints
//! touching markers' images, a streak per camera, and the brush's mirror image in the
//! polished work object (a plate at z = 0 reflecting 35 % of a marker's light, so every
//! camera sees a dim mirrored brush below the real one: 3-D points with the brush's distances
//! but mirrored chirality). The stroke is played from its 27.5th second, where the brush turns
//! so that in 16 of the 480 views two markers' images touch or overlap (by up to 4 px; the test
//! `four_cameras_hard_has_touching_marker_images` counts them).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::optics::Streak;
use super::{
    GlintPlace, Mirror, Motion, Occluder, STROKE_FRAMES, Scene, StrayGlint, StrayStreak, occlusions,
};
use crate::geometry::{CameraId, MarkerId, Pixel};

/// Fills a paper-stroke scene on the four-camera rig with the `four-cameras-hard` events.
pub(super) fn four_cameras_hard(scene: &mut Scene, seed: u64) {
    let (mut occluders, mut glints) = occlusions(seed);
    occluders.push(Occluder {
        frames: 70..85,
        camera: CameraId(3),
        marker: MarkerId(2),
        fraction: 0.6,
        radius: 12.0,
        sideways_mm: 0.0,
    });
    for (frames, camera, marker) in [
        (10..25, CameraId(3), MarkerId(1)),
        (45..60, CameraId(1), MarkerId(0)),
        (100..115, CameraId(0), MarkerId(3)),
    ] {
        occluders.push(Occluder {
            frames,
            camera,
            marker,
            fraction: 0.8,
            radius: 25.0,
            sideways_mm: 24.0,
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6861_7264);
    let mut streaks = Vec::new();
    for camera in 0..4 {
        if camera == 3 {
            for _ in 0..2 {
                glints.push(StrayGlint {
                    frames: 0..STROKE_FRAMES,
                    camera: CameraId(camera),
                    place: GlintPlace::Fixed(Pixel::new(
                        rng.random_range(100.0..1180.0),
                        rng.random_range(100.0..924.0),
                    )),
                    radius_px: rng.random_range(2.0..5.0),
                    radiance_dn: rng.random_range(120.0..220.0),
                });
            }
        }
        let from = Pixel::new(
            rng.random_range(100.0..700.0),
            rng.random_range(700.0..980.0),
        );
        streaks.push(StrayStreak {
            frames: 0..STROKE_FRAMES,
            camera: CameraId(camera),
            streak: Streak {
                from,
                to: Pixel::new(
                    from.x + rng.random_range(200.0..450.0),
                    from.y + rng.random_range(-40.0..40.0),
                ),
                width_px: rng.random_range(2.0..4.0),
                radiance_dn: rng.random_range(80.0..200.0),
            },
        });
    }
    glints.push(StrayGlint {
        frames: 30..36,
        camera: CameraId(3),
        place: GlintPlace::Touching {
            marker: MarkerId(0),
            overlap_px: 1.5,
        },
        radius_px: 8.0,
        radiance_dn: 180.0,
    });
    scene.motion = Motion::PainterStroke {
        speed: 1.0,
        start_s: 27.5,
    };
    scene.occluders = occluders;
    scene.glints = glints;
    scene.streaks = streaks;
    scene.mirror = Some(Mirror {
        height_mm: 0.0,
        x_range_mm: (-400.0, 400.0),
        y_range_mm: (-400.0, 400.0),
        reflectance: 0.35,
    });
}
