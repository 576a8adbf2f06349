//! Scenes that reproduce what real footage does to a tracker (issue 14): the two-camera
//! PlayStation 3 Eye rig of the real stereo recording, its hand-held marker triangle, a hand's
//! motion at 50 Hz, and the clutter a workshop adds.
//!
//! Rig: two 640×480 cameras with the intrinsics and the strong barrel distortion (k1 ≈ −0.43)
//! that the recording's authors published for their PS3 Eye pair (fx ≈ 660 px, principal
//! points off centre), 306 mm apart (their stereo baseline), 2 m from the working volume,
//! 0.6 m above it looking down 17°, both aimed at its centre. World frame: the centre of the
//! working volume, z up, the cameras on the −y side.
//! Tool: three 10 mm spheres in a triangle with distinct sides (150, 92 and 158 mm) on a
//! 150 mm handle; at 2 m a sphere images 3.3 px across, 4–5 px with the blur and bloom (the
//! recording's 4–5 px blobs).
//! Motion: a hand waving the triangle ±200 mm across, ±120 mm up and down, ±80 mm in depth,
//! turning it by up to ±30°, at 0.2–1.4 Hz with a 7 Hz tremor of 0.4 mm; peak speed about
//! 0.7 m/s, so a 12 ms exposure smears a marker by up to 3 px.
//! Image formation (measured on `../shared/data/real-ir/normal.avi`, notes/sim-real.md):
//! markers three times brighter than full scale (the core clips at 255), a bloom skirt of 10 %
//! at σ = 2.2 px, black level 1 DN and read noise 0.6 DN (the background reads 0–3 DN),
//! JPEG quality 55.

use std::f64::consts::TAU;

use nalgebra::{UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::optics::{Halo, Streak, UnevenLight};
use super::render::RenderConfig;
use super::{Exposure, GlintPlace, Mirror, Miscalibration, Occluder, StrayGlint, StrayStreak};
use crate::camera::{Camera, Distortion, ImageSize, Intrinsics, Rig};
use crate::geometry::{CameraId, MarkerId, Pixel, Point3, Pose, pose_from_parts};
use crate::tool::Tool;

/// Distance from each camera to the centre of the working volume, millimetres.
pub const STEREO_IR_DISTANCE_MM: f64 = 2000.0;

/// Baseline of the published PS3 Eye stereo pair, millimetres (its projection matrix's
/// Tx = −230.8 px at f = 753.5 px, on a 39 mm chessboard: 306 mm).
pub const STEREO_IR_BASELINE_MM: f64 = 306.0;

/// Frame rate of the real recording, Hz.
pub const STEREO_IR_FPS: f64 = 50.0;

/// Frames of the `stereo-ir` scenes: 6 s at 50 Hz.
pub const STEREO_IR_FRAMES: usize = 300;

/// A PS3 Eye of the published pair, at `eye_in_world`, aimed at the world origin.
fn ps3_eye(
    name: &str,
    eye_in_world: Point3,
    intrinsics: Intrinsics,
    distortion: [f64; 5],
) -> Camera {
    let rotation = UnitQuaternion::face_towards(&(Point3::origin() - eye_in_world), &-Vector3::z());
    Camera {
        name: name.to_string(),
        image_size: ImageSize {
            width: 640,
            height: 480,
        },
        intrinsics,
        distortion: Distortion::from_opencv(distortion),
        camera_from_world: pose_from_parts(eye_in_world.coords, rotation).inverse(),
    }
}

/// The two-camera PS3 Eye rig of the real stereo recording.
#[must_use]
pub fn stereo_ir_rig() -> Rig {
    let down = 17.5_f64.to_radians();
    let back = STEREO_IR_DISTANCE_MM * down.cos();
    let up = STEREO_IR_DISTANCE_MM * down.sin();
    let half = 0.5 * STEREO_IR_BASELINE_MM;
    Rig {
        cameras: vec![
            ps3_eye(
                "cam0",
                Point3::new(-half, -back, up),
                Intrinsics {
                    fx: 664.8,
                    fy: 662.8,
                    cx: 312.5,
                    cy: 261.5,
                },
                [-0.406, 0.174, 0.0089, 0.0045, 0.0],
            ),
            ps3_eye(
                "cam1",
                Point3::new(half, -back, up),
                Intrinsics {
                    fx: 657.2,
                    fy: 656.7,
                    cx: 248.8,
                    cy: 191.8,
                },
                [-0.445, 0.243, 0.0108, 0.0009, 0.0],
            ),
        ],
    }
}

/// The hand-held triangle: three 10 mm spheres, sides 150, 92.2 and 158.1 mm (every pair of
/// distances at least 8 mm apart), the tip 150 mm behind the triangle's centre on its handle
/// (tool −z; the triangle faces the cameras along tool +z).
#[must_use]
pub fn triangle_tool() -> Tool {
    let markers = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(150.0, 0.0, 0.0),
        Point3::new(20.0, 90.0, 0.0),
    ];
    Tool {
        name: "triangle".into(),
        marker_diameter_mm: 10.0,
        markers_in_tool: markers,
        tool_from_tcp: pose_from_parts(
            Vector3::new(56.7, 30.0, -150.0),
            UnitQuaternion::identity(),
        ),
    }
}

fn wave(amplitude: f64, frequency_hz: f64, phase: f64, time_s: f64) -> f64 {
    amplitude * (TAU * frequency_hz * time_s + phase).sin()
}

/// The triangle's tip pose at time `t` of the hand's motion (see the module docs).
#[must_use]
pub fn hand_motion(time_s: f64) -> Pose {
    let t = time_s;
    let tremor = |phase: f64| wave(0.4, 7.1, phase, t);
    let x = wave(200.0, 0.23, 0.0, t) + wave(40.0, 0.9, 1.0, t) + tremor(0.0);
    let y = wave(80.0, 0.31, 0.4, t) + tremor(1.3);
    let z = wave(120.0, 0.37, 2.0, t) + wave(25.0, 1.4, 0.3, t) + tremor(2.6);
    let spin = wave(30_f64.to_radians(), 0.27, 0.5, t);
    let tilt = wave(25_f64.to_radians(), 0.33, 1.7, t);
    let yaw = wave(20_f64.to_radians(), 0.21, 2.9, t);
    // Face the cameras (tool +z towards world −y), then turn about the view axis, tilt, yaw.
    let facing = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), TAU / 4.0);
    let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tilt)
        * facing
        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), spin);
    // The tip sits 150 mm behind the triangle's centre: place it so that the triangle moves
    // about the origin.
    pose_from_parts(Vector3::new(x, y + 150.0, z), rotation)
}

/// Image formation of the PS3 Eye recording (module docs; the numbers in notes/sim-real.md).
#[must_use]
pub fn stereo_ir_render() -> RenderConfig {
    RenderConfig {
        supersampling: 4,
        blur_sigma_px: 0.7,
        background_dn: 1.0,
        marker_dn: 760.0,
        read_noise_dn: 0.6,
        shot_noise_dn_per_dn: 0.04,
        halo: Some(Halo {
            fraction: 0.10,
            sigma_px: 2.2,
        }),
        uneven_light: Some(UnevenLight {
            gradient_x_dn: 8.0,
            gradient_y_dn: -5.0,
            vignetting: 0.3,
        }),
        jpeg_quality: Some(55),
    }
}

/// The exposure of the PS3 Eye at 50 Hz: 12 ms, integrated over 5 instants.
#[must_use]
pub const fn stereo_ir_exposure() -> Exposure {
    Exposure {
        duration_s: 0.012,
        instants: 5,
    }
}

/// The shiny work object under the working volume: a steel plate 350 mm below its centre,
/// whose mirror images of the markers both cameras see (a ghost triangle of 3-D points).
#[must_use]
pub const fn stereo_ir_mirror() -> Mirror {
    Mirror {
        height_mm: -350.0,
        x_range_mm: (-500.0, 500.0),
        y_range_mm: (-900.0, -200.0),
        reflectance: 0.15,
    }
}

/// What else real footage of the triangle brings: the hand partly hiding a marker (three
/// stretches, each in one camera), fixed and flickering glints, specular streaks along the
/// plate's edge, a glint touching a marker's image. Placed from `seed`.
#[must_use]
pub fn stereo_ir_clutter(
    seed: u64,
    frames: usize,
) -> (Vec<Occluder>, Vec<StrayGlint>, Vec<StrayStreak>) {
    let occluders = vec![
        Occluder {
            frames: 40..70,
            camera: CameraId(0),
            marker: MarkerId(0),
            fraction: 0.95,
            radius: 40.0,
            sideways_mm: 40.0,
        },
        Occluder {
            frames: 150..175,
            camera: CameraId(1),
            marker: MarkerId(2),
            fraction: 0.95,
            radius: 40.0,
            sideways_mm: 41.0,
        },
        Occluder {
            frames: 230..240,
            camera: CameraId(1),
            marker: MarkerId(1),
            fraction: 0.95,
            radius: 40.0,
            sideways_mm: 0.0,
        },
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7265_616c);
    let mut glints = Vec::new();
    let mut streaks = Vec::new();
    for camera in 0..2 {
        for _ in 0..2 {
            glints.push(StrayGlint {
                frames: 0..frames,
                camera: CameraId(camera),
                place: GlintPlace::Fixed(Pixel::new(
                    rng.random_range(20.0..620.0),
                    rng.random_range(300.0..460.0),
                )),
                radius_px: rng.random_range(1.0..2.5),
                radiance_dn: rng.random_range(80.0..400.0),
            });
        }
        for _ in 0..8 {
            let start = rng.random_range(0..frames.saturating_sub(6).max(1));
            glints.push(StrayGlint {
                frames: start..start + 6,
                camera: CameraId(camera),
                place: GlintPlace::Fixed(Pixel::new(
                    rng.random_range(20.0..620.0),
                    rng.random_range(20.0..460.0),
                )),
                radius_px: rng.random_range(1.0..3.0),
                radiance_dn: rng.random_range(100.0..500.0),
            });
        }
        let y = rng.random_range(400.0..450.0);
        let x = rng.random_range(60.0..200.0);
        streaks.push(StrayStreak {
            frames: 0..frames,
            camera: CameraId(camera),
            streak: Streak {
                from: Pixel::new(x, y),
                to: Pixel::new(
                    x + rng.random_range(150.0..300.0),
                    y + rng.random_range(-8.0..8.0),
                ),
                width_px: rng.random_range(1.5..3.0),
                radiance_dn: rng.random_range(60.0..160.0),
            },
        });
    }
    glints.push(StrayGlint {
        frames: 100..110,
        camera: CameraId(0),
        place: GlintPlace::Touching {
            marker: MarkerId(1),
            overlap_px: 0.5,
        },
        radius_px: 2.0,
        radiance_dn: 500.0,
    });
    (occluders, glints, streaks)
}

/// The rig file of `stereo-ir-miscal`: cam1 turned by 0.4° about an axis mostly along its x
/// (a tilt, which moves its image points across the epipolar lines by about fx·0.4°·0.9 ≈ 4 px,
/// like the published calibration's 4.6 px).
#[must_use]
pub fn stereo_ir_miscalibration() -> Miscalibration {
    Miscalibration {
        camera: CameraId(1),
        axis_in_camera: Vector3::new(0.9, 0.3, 0.3),
        angle: 0.4_f64.to_radians(),
    }
}
