//! `wand`: a calibration wand waved through the four-camera rig's working volume, and an
//! L-frame lying still on the work object, for `teachcam calibrate wand` (issue 16).
//!
//! The wand is the contract's `wand.json`: three 14 mm markers at 0, 160 and 500 mm along its
//! axis. Its middle (250 mm from marker 0) moves in a sum of sinusoids around a point 150 mm
//! above the work object (±90 mm across, ±50 mm in height) while its axis turns about the
//! vertical (about 1.3 turns over 400 frames) and tilts up to ±50°, 400 frames at 60 Hz. About
//! 10 % of the camera-frames are imperfect: in 5 % a dark occluder hides one marker, in 5 % a
//! glint (a reflection) shines somewhere in the image. Some camera-frames also lose a marker
//! past the image border or see two markers' images merge when the wand points at the camera.
//! The ground frame: four 14 mm markers in an L (0/60/180 mm along x, 110 mm along y) lying in
//! the world's xy plane, its tool frame the world, 30 still frames. The truth is the rig.

use std::path::Path;

use nalgebra::{UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{GlintPlace, Motion, Occluder, Scene, StrayGlint, build_scene};
use crate::calib::wand::Wand;
use crate::geometry::{CameraId, MarkerId, Pixel, Point3, Pose, pose_from_parts};
use crate::io::FileError;
use crate::tool::Tool;

/// Frames of the wand dance: 400 at 60 Hz (the acceptance scene).
pub const WAND_FRAMES: usize = 400;

/// Frame rate of the wand dance, Hz.
pub const WAND_FPS: f64 = 60.0;

/// Frames of the still ground-frame recording.
pub const GROUND_FRAMES: usize = 30;

/// Fraction of camera-frames with a marker hidden, and (separately) with a glint.
const IMPERFECT_EACH: f64 = 0.05;

/// The contract's wand: 14 mm markers at 0, 160 and 500 mm.
#[must_use]
pub fn contract_wand() -> Wand {
    Wand {
        name: "wand".into(),
        marker_diameter_mm: 14.0,
        markers_mm: vec![0.0, 160.0, 500.0],
    }
}

/// The wand as the simulator's tool: its markers along tool z.
#[must_use]
pub fn wand_tool(wand: &Wand) -> Tool {
    Tool {
        name: wand.name.clone(),
        marker_diameter_mm: wand.marker_diameter_mm,
        markers_in_tool: wand
            .markers_mm
            .iter()
            .map(|p| Point3::new(0.0, 0.0, *p))
            .collect(),
        tool_from_tcp: Pose::identity(),
    }
}

/// The ground frame: four 14 mm markers in an L, all six distances distinct (60, 110, 120,
/// 125, 180, 211 mm), in the tool's xy plane.
#[must_use]
pub fn lframe_tool() -> Tool {
    Tool {
        name: "lframe".into(),
        marker_diameter_mm: 14.0,
        markers_in_tool: vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(180.0, 0.0, 0.0),
            Point3::new(0.0, 110.0, 0.0),
            Point3::new(60.0, 0.0, 0.0),
        ],
        tool_from_tcp: Pose::identity(),
    }
}

/// The wand's pose (tool = wand frame, marker k at `k`'s position along tool z) at a time.
#[must_use]
pub fn wand_dance(time_s: f64) -> Pose {
    let wave =
        |a: f64, hz: f64, phase: f64| a * (std::f64::consts::TAU * hz * time_s + phase).sin();
    let middle = Vector3::new(
        wave(70.0, 0.21, 0.3) + wave(20.0, 0.67, 1.2),
        wave(60.0, 0.27, 1.0) + wave(15.0, 0.8, 0.0),
        150.0 + wave(50.0, 0.33, 2.0),
    );
    let azimuth = std::f64::consts::TAU * 0.19 * time_s + wave(0.5, 0.5, 0.0);
    let elevation = wave(0.87, 0.23, 0.4);
    let axis = Vector3::new(
        elevation.cos() * azimuth.cos(),
        elevation.cos() * azimuth.sin(),
        elevation.sin(),
    );
    let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &axis).unwrap_or_else(|| {
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
    });
    // Marker 0 sits 250 mm before the middle along the axis.
    pose_from_parts(middle - axis * 250.0, rotation)
}

/// The wand dance scene on the four-camera rig, with its imperfect camera-frames.
#[must_use]
pub fn wand_scene(seed: u64) -> Scene {
    build_scene(super::Scenario::Wand, seed)
}

/// Dresses a scene of the four-camera rig as the wand dance (`build_scene` then takes its
/// truth over [`WAND_FRAMES`]).
pub(super) fn dress(scene: &mut Scene, seed: u64) {
    scene.tool = wand_tool(&contract_wand());
    scene.fps = WAND_FPS;
    scene.motion = Motion::WandDance;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7761_6e64);
    for frame in 0..WAND_FRAMES {
        for (camera, spec) in scene.rig.iter() {
            let draw: f64 = rng.random_range(0.0..1.0);
            if draw < IMPERFECT_EACH {
                scene.occluders.push(Occluder {
                    frames: frame..frame + 1,
                    camera,
                    marker: MarkerId(rng.random_range(0..3)),
                    fraction: 0.8,
                    radius: 12.0,
                    sideways_mm: 0.0,
                });
            } else if draw < 2.0 * IMPERFECT_EACH {
                let (w, h) = (
                    f64::from(spec.image_size.width),
                    f64::from(spec.image_size.height),
                );
                scene.glints.push(StrayGlint {
                    frames: frame..frame + 1,
                    camera,
                    place: GlintPlace::Fixed(Pixel::new(
                        rng.random_range(0.1 * w..0.9 * w),
                        rng.random_range(0.1 * h..0.9 * h),
                    )),
                    radius_px: rng.random_range(3.0..8.0),
                    radiance_dn: rng.random_range(120.0..220.0),
                });
            }
        }
    }
}

/// The still L-frame on the work object, seen by the same rig.
#[must_use]
pub fn ground_scene(seed: u64) -> Scene {
    let mut scene = build_scene(super::Scenario::Wand, seed);
    scene.tool = lframe_tool();
    scene.fps = WAND_FPS;
    scene.motion = Motion::Resting(Pose::identity());
    scene.occluders.clear();
    scene.glints.clear();
    scene.truth = super::truth(&scene, GROUND_FRAMES);
    scene
}

/// Writes the `wand` scenario: `wand/` (the dance, a recording), `ground/` (the L-frame, a
/// recording), `cameras.json` (the true intrinsics, no extrinsics), `wand.json`,
/// `lframe.json` and the true rig `rig_true.json` (world = the L-frame's frame). Each
/// recording folder also holds the simulator's usual truth files (its `rig.json` is the true
/// rig too). `frames` limits the dance's frames.
///
/// # Errors
/// [`FileError`] when a file cannot be written.
pub fn write_wand_scenario(
    out: &Path,
    seed: u64,
    frames: Option<usize>,
    on_frame: &(dyn Fn() + Sync),
) -> Result<(), FileError> {
    let mut dance = wand_scene(seed);
    if let Some(n) = frames {
        dance.truth.samples.truncate(n);
    }
    let ground = ground_scene(seed);
    // All or nothing, as `write_scene` (whose own staging then happens inside this one).
    let staged = crate::io::StagedFolder::new(out)?;
    let out = staged.path();
    super::write_scene(&dance, &out.join("wand"), seed, on_frame)?;
    super::write_scene(&ground, &out.join("ground"), seed ^ 0x67, on_frame)?;
    crate::io::rig::write_cameras(&out.join("cameras.json"), &dance.rig)?;
    crate::io::rig::write_rig(&out.join("rig_true.json"), &dance.rig)?;
    crate::io::wand::write_wand(&out.join("wand.json"), &contract_wand())?;
    crate::io::tool::write_tool(&out.join("lframe.json"), &ground.tool)?;
    staged.commit().map(drop)
}

/// Every camera-frame of a scene with an imperfection placed on purpose: `(frame, camera)`.
#[must_use]
pub fn imperfect_camera_frames(scene: &Scene) -> Vec<(usize, CameraId)> {
    let mut out: Vec<(usize, CameraId)> = scene
        .occluders
        .iter()
        .map(|o| (o.frames.start, o.camera))
        .chain(scene.glints.iter().map(|g| (g.frames.start, g.camera)))
        .collect();
    out.sort();
    out.dedup();
    out
}
