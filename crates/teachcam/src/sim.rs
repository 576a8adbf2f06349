//! The simulator: a virtual rig films a brush following a known trajectory, so that every stage
//! can be checked against ground truth.
//!
//! A [`Scene`] holds the rig, the tool, its motion and true trajectory, and what else the cameras
//! see (dark occluders in front of markers, glints and streaks that exist in one view only,
//! mirror images of the markers in a shiny work object), how each camera exposes (motion blur
//! over the exposure, a time offset from camera 0) and the rig file a user would really have
//! (one camera's rotation slightly wrong). [`render_frame`] draws one frame of every camera by
//! ray casting ([`render`], [`optics`]), and [`write_scene`] writes the contract's recording
//! folder with `rig.json`, `tool.json`, `truth.csv`, the exact projection of every sphere centre
//! in every view (`projections.csv`), and the truths of what was made wrong on purpose
//! (`rig_true.json` + `miscalibration.json`, `time_offsets.json`). Everything is deterministic
//! for a seed: each (camera, frame) draws its noise from its own seeded stream, so frames can be
//! rendered in any order or in parallel.
//!
//! Time: frame k of camera c is exposed around `t = k / fps + offset_c` in camera 0's time base
//! (`offset_0 = 0`), over `[t − d/2, t + d/2]` for an exposure of d seconds; `truth.csv` holds the
//! poses at `k / fps`.

pub mod board;
pub mod calibration;
pub mod clutter;
pub mod optics;
pub mod real_world;
pub mod render;
pub mod scenario;
pub mod wand;

use std::path::Path;

use image::GrayImage;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use nalgebra::{UnitQuaternion, Vector3};

use crate::camera::{Camera, Rig};
use crate::geometry::{CameraId, FrameIndex, MarkerId, Pixel, Point3, Pose};
use crate::io::FileError;
use crate::tool::Tool;
use crate::trajectory::{Sample, ToolPose, Trajectory};
use optics::Streak;
use render::{Glint, RenderConfig, Sphere, SphereView, render_exposure};

/// The named scenes of `teachcam simulate --scenario NAME`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scenario {
    /// The paper's rig and brush, a 4 s painter's stroke at 30 Hz.
    Paper,
    /// The brush at rest for 100 frames: repeatability studies (paper §IV).
    Static,
    /// The paper's stroke with markers hidden in some views, glints, and a glint touching a
    /// marker's image.
    Occluded,
    /// The paper's stroke seen by four cameras.
    FourCameras,
    /// Chessboard views for rig calibration (the paper's rig): see [`calibration`]. Written by
    /// [`calibration::write_calibration`], not as a recording.
    Calibration,
    /// Chessboard views for calibrating the four-camera rig.
    FourCamerasCalibration,
    /// The real stereo IR recording's twin (issue 14): two 640×480 PS3 Eye cameras 2 m away, a
    /// hand-held 3-marker triangle at 50 Hz with motion blur, small saturated blobs with bloom,
    /// JPEG quality 55, uneven light, glints, streaks, mirror images in a steel plate, a hand
    /// partly hiding markers. See [`real_world`].
    StereoIr,
    /// `stereo-ir` with `rig.json` 0.4° off in cam1's rotation (the true rig in
    /// `rig_true.json`).
    StereoIrMiscal,
    /// The paper's rig with unsynchronised cameras: cam1 exposes 9.3 ms after cam0, cam2
    /// 13.1 ms before, at 30 Hz, with a fast stroke (the paper's, 2.5 times faster, up to
    /// 0.9 m/s); the offsets in `time_offsets.json`.
    Unsynced,
    /// Four cameras with everything at once: markers hidden and partly hidden, glints (two
    /// touching markers' images), streaks, the brush's mirror image in a shiny work object,
    /// markers whose images touch; the paper's clean optics.
    FourCamerasHard,
    /// A calibration wand (0/160/500 mm) waved through the four-camera rig, 400 frames at
    /// 60 Hz, 10 % of camera-frames imperfect, and an L-frame on the work object: see
    /// [`wand`]. Written by [`wand::write_wand_scenario`], not as one recording.
    Wand,
}

impl Scenario {
    /// Every scenario, for listings and help.
    pub const ALL: [Scenario; 11] = [
        Scenario::Paper,
        Scenario::Static,
        Scenario::Occluded,
        Scenario::FourCameras,
        Scenario::Calibration,
        Scenario::FourCamerasCalibration,
        Scenario::StereoIr,
        Scenario::StereoIrMiscal,
        Scenario::Unsynced,
        Scenario::FourCamerasHard,
        Scenario::Wand,
    ];

    /// The scenario's command-line name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Static => "static",
            Self::Occluded => "occluded",
            Self::FourCameras => "four-cameras",
            Self::Calibration => "calibration",
            Self::FourCamerasCalibration => "four-cameras-calibration",
            Self::StereoIr => "stereo-ir",
            Self::StereoIrMiscal => "stereo-ir-miscal",
            Self::Unsynced => "unsynced",
            Self::FourCamerasHard => "four-cameras-hard",
            Self::Wand => "wand",
        }
    }

    /// True for the chessboard scenarios, which [`calibration::write_calibration`] writes
    /// instead of a recording.
    #[must_use]
    pub const fn is_calibration(self) -> bool {
        matches!(self, Self::Calibration | Self::FourCamerasCalibration)
    }

    /// The scenario's true rig: the paper's three cameras, four, or the PS3 Eye pair.
    #[must_use]
    pub fn rig(self) -> Rig {
        match self {
            Self::FourCameras
            | Self::FourCamerasCalibration
            | Self::FourCamerasHard
            | Self::Wand => scenario::four_camera_rig(),
            Self::Paper | Self::Static | Self::Occluded | Self::Calibration | Self::Unsynced => {
                scenario::paper_rig()
            }
            Self::StereoIr | Self::StereoIrMiscal => real_world::stereo_ir_rig(),
        }
    }

    /// The scenario of a command-line name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// A dark sphere that hides what is behind it in some frames (a hand, the painter's sleeve).
#[derive(Debug, Clone, PartialEq)]
pub struct Occluder {
    /// Frames in which it is there.
    pub frames: std::ops::Range<usize>,
    /// The camera it is placed in front of.
    pub camera: CameraId,
    /// The marker it hides from that camera.
    pub marker: MarkerId,
    /// Where on the line from the camera centre (0) to the marker (1) its centre sits.
    pub fraction: f64,
    /// Radius, millimetres.
    pub radius: f64,
    /// How far its centre sits beside that line, along the camera's x axis, millimetres: 0
    /// hides the marker whole (when the radius allows), about the radius hides half of it.
    pub sideways_mm: f64,
}

/// A streak in one camera's images over a range of frames.
#[derive(Debug, Clone, PartialEq)]
pub struct StrayStreak {
    /// Frames in which it shines.
    pub frames: std::ops::Range<usize>,
    /// The camera that sees it.
    pub camera: CameraId,
    /// Where and how bright.
    pub streak: Streak,
}

/// A shiny horizontal plate (the work object) that mirrors the markers: each marker has a
/// mirror image at its reflection through the plane `z = height_mm`, seen by a camera when the
/// line of sight to that image crosses the plane inside the plate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mirror {
    /// Height of the plate in the world, millimetres.
    pub height_mm: f64,
    /// The plate's extent along world x, millimetres.
    pub x_range_mm: (f64, f64),
    /// The plate's extent along world y, millimetres.
    pub y_range_mm: (f64, f64),
    /// Fraction of a marker's brightness its mirror image has (the light crosses the plate
    /// twice, so a steel plate of reflectance 0.4 gives about 0.15).
    pub reflectance: f64,
}

/// How long each camera's exposure lasts and how finely the image integrates motion over it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    /// Exposure time, seconds; 0 renders the instant of the frame.
    pub duration_s: f64,
    /// Instants the exposure is integrated over (odd, so that the middle one is the frame's
    /// time); 1 for no motion blur.
    pub instants: usize,
}

impl Exposure {
    /// An instantaneous exposure (no motion blur): the paper's scenes.
    pub const INSTANT: Self = Self {
        duration_s: 0.0,
        instants: 1,
    };

    /// The times of the instants of an exposure centred on `time_s`.
    #[must_use]
    pub fn instants_around(&self, time_s: f64) -> Vec<f64> {
        let n = self.instants.max(1);
        (0..n)
            .map(|k| time_s + self.duration_s * ((k as f64 + 0.5) / n as f64 - 0.5))
            .collect()
    }
}

/// How the tool moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// The paper's painter's stroke, played `speed` times as fast from its time `start_s`.
    PainterStroke {
        /// Playback speed, 1 for the paper's stroke.
        speed: f64,
        /// The stroke's time at frame 0, seconds.
        start_s: f64,
    },
    /// At rest at the pose the painter's stroke has at `time_s`.
    Still {
        /// The stroke's time of the pose, seconds.
        time_s: f64,
    },
    /// A hand waving the triangle in front of the PS3 Eye pair ([`real_world::hand_motion`]).
    Hand,
    /// A calibration wand waved through the volume ([`wand::wand_dance`]).
    WandDance,
    /// At rest at this pose.
    Resting(Pose),
}

impl Motion {
    /// The tool centre point's pose at a time.
    #[must_use]
    pub fn world_from_tcp(&self, time_s: f64) -> Pose {
        match *self {
            Self::PainterStroke { speed, start_s } => {
                scenario::painter_stroke(time_s * speed + start_s)
            }
            Self::Still { time_s } => scenario::painter_stroke(time_s),
            Self::Hand => real_world::hand_motion(time_s),
            Self::WandDance => wand::wand_dance(time_s),
            Self::Resting(pose) => pose,
        }
    }
}

/// One camera's rotation in the written rig file off from the truth: `rig.json` says
/// `camera_from_world = R(axis, angle) · camera_from_world_true` (a turn about the camera's own
/// centre, which stays where it is).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Miscalibration {
    /// The camera whose rotation is wrong.
    pub camera: CameraId,
    /// The rotation's axis in the camera's frame (normalised when applied).
    pub axis_in_camera: Vector3<f64>,
    /// The rotation's angle, radians.
    pub angle: f64,
}

impl Miscalibration {
    /// The rig as written: `rig` with this camera's rotation turned.
    #[must_use]
    pub fn apply(&self, rig: &Rig) -> Rig {
        let mut written = rig.clone();
        if let Some(camera) = written.cameras.get_mut(self.camera.0) {
            let axis = nalgebra::Unit::new_normalize(self.axis_in_camera);
            let turn = UnitQuaternion::from_axis_angle(&axis, self.angle);
            camera.camera_from_world = Pose::from_parts(nalgebra::Translation3::identity(), turn)
                * camera.camera_from_world;
        }
        written
    }
}

/// A glint in one camera's images over a range of frames.
#[derive(Debug, Clone, PartialEq)]
pub struct StrayGlint {
    /// Frames in which it shines.
    pub frames: std::ops::Range<usize>,
    /// The camera that sees it.
    pub camera: CameraId,
    /// Where it is: a fixed pixel, or next to a marker's image so that the two touch.
    pub place: GlintPlace,
    /// Radius, pixels.
    pub radius_px: f64,
    /// Brightness above background, DN.
    pub radiance_dn: f64,
}

/// Where a glint sits in the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GlintPlace {
    /// A fixed pixel.
    Fixed(Pixel),
    /// Beside a marker's image, offset along +x by the marker's apparent radius plus this
    /// radius minus `overlap_px`, so that the two images touch.
    Touching {
        /// The marker.
        marker: MarkerId,
        /// How far the two discs overlap, pixels.
        overlap_px: f64,
    },
}

/// A complete simulated recording setup.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Which scenario this is.
    pub scenario: Scenario,
    /// The cameras.
    pub rig: Rig,
    /// The tracked tool.
    pub tool: Tool,
    /// Frames per second.
    pub fps: f64,
    /// The true pose of every frame (`markers` = the tool's marker count, `rms_mm` = 0).
    pub truth: Trajectory,
    /// Dark spheres hiding markers.
    pub occluders: Vec<Occluder>,
    /// Glints.
    pub glints: Vec<StrayGlint>,
    /// Streaks.
    pub streaks: Vec<StrayStreak>,
    /// A shiny work object mirroring the markers, if any.
    pub mirror: Option<Mirror>,
    /// Image formation.
    pub render: RenderConfig,
    /// How the tool moves (the truth samples it at the frame times).
    pub motion: Motion,
    /// Every camera's exposure.
    pub exposure: Exposure,
    /// Each camera's exposure time offset from camera 0's, seconds, by camera index; empty:
    /// the cameras are triggered together.
    pub time_offsets_s: Vec<f64>,
    /// The error of the rig file written as `rig.json`; `None`: the true rig is written.
    pub miscalibration: Option<Miscalibration>,
}

impl Scene {
    /// The world pose of the tool at a time (camera 0's time base).
    #[must_use]
    pub fn world_from_tool_at(&self, time_s: f64) -> Pose {
        self.motion.world_from_tcp(time_s) * self.tool.tool_from_tcp.inverse()
    }

    /// A camera's exposure time offset from camera 0's, seconds.
    #[must_use]
    pub fn time_offset_s(&self, camera: CameraId) -> f64 {
        self.time_offsets_s.get(camera.0).copied().unwrap_or(0.0)
    }

    /// The rig written as `rig.json`: the true rig unless the scene has a miscalibration.
    #[must_use]
    pub fn written_rig(&self) -> Rig {
        self.miscalibration
            .map_or_else(|| self.rig.clone(), |m| m.apply(&self.rig))
    }
}

/// Frames of the paper's stroke: 4 s at the paper's 30 Hz trigger.
pub(crate) const STROKE_FRAMES: usize = 120;

/// Builds a scenario's recording scene. `seed` places the random glints and streaks. The
/// calibration scenarios have no recording: this gives their rig filming the paper's stroke;
/// their board views come from [`calibration::calibration_scene`].
#[must_use]
pub fn build_scene(scenario: Scenario, seed: u64) -> Scene {
    let mut scene = Scene {
        scenario,
        rig: scenario.rig(),
        tool: scenario::paper_brush(),
        fps: 30.0,
        truth: Trajectory::default(),
        occluders: Vec::new(),
        glints: Vec::new(),
        streaks: Vec::new(),
        mirror: None,
        render: RenderConfig::default(),
        motion: Motion::PainterStroke {
            speed: 1.0,
            start_s: 0.0,
        },
        exposure: Exposure::INSTANT,
        time_offsets_s: Vec::new(),
        miscalibration: None,
    };
    let mut frames = STROKE_FRAMES;
    match scenario {
        Scenario::Paper
        | Scenario::FourCameras
        | Scenario::Calibration
        | Scenario::FourCamerasCalibration => {}
        Scenario::Static => {
            scene.motion = Motion::Still { time_s: 1.3 };
            frames = 100;
        }
        Scenario::Occluded => (scene.occluders, scene.glints) = occlusions(seed),
        Scenario::StereoIr | Scenario::StereoIrMiscal => {
            frames = real_world::STEREO_IR_FRAMES;
            scene.tool = real_world::triangle_tool();
            scene.fps = real_world::STEREO_IR_FPS;
            scene.render = real_world::stereo_ir_render();
            scene.motion = Motion::Hand;
            scene.exposure = real_world::stereo_ir_exposure();
            scene.mirror = Some(real_world::stereo_ir_mirror());
            (scene.occluders, scene.glints, scene.streaks) =
                real_world::stereo_ir_clutter(seed, frames);
            if scenario == Scenario::StereoIrMiscal {
                scene.miscalibration = Some(real_world::stereo_ir_miscalibration());
            }
        }
        Scenario::Unsynced => {
            scene.motion = Motion::PainterStroke {
                speed: 2.5,
                start_s: 0.0,
            };
            scene.time_offsets_s = vec![0.0, 0.0093, -0.0131];
        }
        Scenario::FourCamerasHard => clutter::four_cameras_hard(&mut scene, seed),
        Scenario::Wand => {
            wand::dress(&mut scene, seed);
            frames = wand::WAND_FRAMES;
        }
    }
    scene.truth = truth(&scene, frames);
    scene
}

/// The true poses of the first `frames` frames of a scene's motion.
pub fn truth(scene: &Scene, frames: usize) -> Trajectory {
    let tool = &scene.tool;
    let samples = (0..frames)
        .map(|f| {
            let time_s = f as f64 / scene.fps;
            let world_from_tool = scene.world_from_tool_at(time_s);
            let tip_in_world = world_from_tool * tool.tip_in_tool();
            Sample::measured(
                FrameIndex(f),
                time_s,
                ToolPose {
                    world_from_tool,
                    tip_in_world,
                    markers: tool.markers_in_tool.len(),
                    rms_mm: 0.0,
                },
            )
        })
        .collect();
    Trajectory { samples }
}

/// The `occluded` scenario's events: one marker hidden from one camera in three stretches (two
/// markers at once in the last), persistent glints in every camera, flickering ones, and a
/// glint touching a marker's image.
pub(crate) fn occlusions(seed: u64) -> (Vec<Occluder>, Vec<StrayGlint>) {
    let occluders = vec![
        Occluder {
            frames: 20..45,
            camera: CameraId(1),
            marker: MarkerId(2),
            fraction: 0.6,
            radius: 12.0,
            sideways_mm: 0.0,
        },
        Occluder {
            frames: 60..80,
            camera: CameraId(0),
            marker: MarkerId(0),
            fraction: 0.7,
            radius: 10.0,
            sideways_mm: 0.0,
        },
        Occluder {
            frames: 90..105,
            camera: CameraId(2),
            marker: MarkerId(3),
            fraction: 0.5,
            radius: 10.0,
            sideways_mm: 0.0,
        },
        Occluder {
            frames: 95..105,
            camera: CameraId(1),
            marker: MarkerId(1),
            fraction: 0.5,
            radius: 10.0,
            sideways_mm: 0.0,
        },
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6c69_6e74);
    let mut glints = Vec::new();
    for camera in 0..3 {
        for _ in 0..2 {
            let center = Pixel::new(
                rng.random_range(100.0..1180.0),
                rng.random_range(100.0..924.0),
            );
            glints.push(StrayGlint {
                frames: 0..STROKE_FRAMES,
                camera: CameraId(camera),
                place: GlintPlace::Fixed(center),
                radius_px: rng.random_range(2.0..5.0),
                radiance_dn: rng.random_range(120.0..220.0),
            });
        }
        for _ in 0..6 {
            let start = rng.random_range(0..STROKE_FRAMES - 5);
            let center = Pixel::new(
                rng.random_range(50.0..1230.0),
                rng.random_range(50.0..974.0),
            );
            glints.push(StrayGlint {
                frames: start..start + 5,
                camera: CameraId(camera),
                place: GlintPlace::Fixed(center),
                radius_px: rng.random_range(2.0..8.0),
                radiance_dn: rng.random_range(100.0..220.0),
            });
        }
    }
    glints.push(StrayGlint {
        frames: 50..58,
        camera: CameraId(2),
        place: GlintPlace::Touching {
            marker: MarkerId(1),
            overlap_px: 1.0,
        },
        radius_px: 6.0,
        radiance_dn: 180.0,
    });
    (occluders, glints)
}

/// The truth of one marker in one view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerView {
    /// The marker.
    pub marker: MarkerId,
    /// What the renderer knows of its sphere in this view.
    pub view: SphereView,
    /// True when no other bright image (marker or glint) comes within a blur width of this
    /// marker's image: a detector must find it, alone, at its centre.
    pub isolated: bool,
}

/// One camera's image of one frame with its truth.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedView {
    /// The camera.
    pub camera: CameraId,
    /// The 8-bit image.
    pub image: GrayImage,
    /// Every marker's truth, in marker order.
    pub markers: Vec<MarkerView>,
    /// Glints drawn in this view.
    pub glints: Vec<Glint>,
    /// The JPEG quality the image went through, `None` when lossless.
    pub jpeg_quality: Option<u8>,
}

/// The world positions of the tool's markers in a frame of the truth, `None` in a gap.
#[must_use]
pub fn markers_in_world(tool: &Tool, world_from_tool: &Pose) -> Vec<Point3> {
    tool.markers_in_tool
        .iter()
        .map(|m| world_from_tool * m)
        .collect()
}

/// The seed of one (camera, frame) noise stream.
fn view_seed(seed: u64, camera: CameraId, frame: usize) -> u64 {
    seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ ((camera.0 as u64) << 48) ^ frame as u64
}

/// Renders every camera's view of one frame.
#[must_use]
pub fn render_frame(scene: &Scene, frame: usize, seed: u64) -> Vec<RenderedView> {
    let Some(sample) = scene.truth.samples.get(frame) else {
        return Vec::new();
    };
    let Some(pose) = sample.pose else {
        return Vec::new();
    };
    scene
        .rig
        .iter()
        .map(|(camera_id, camera)| {
            let exposure_time_s = sample.time_s + scene.time_offset_s(camera_id);
            // The instants' marker positions; the paper's synchronised instantaneous scenes
            // use the truth pose itself.
            let instants: Vec<Vec<Point3>> =
                if scene.exposure.instants <= 1 && scene.time_offset_s(camera_id) == 0.0 {
                    vec![markers_in_world(&scene.tool, &pose.world_from_tool)]
                } else {
                    scene
                        .exposure
                        .instants_around(exposure_time_s)
                        .into_iter()
                        .map(|t| markers_in_world(&scene.tool, &scene.world_from_tool_at(t)))
                        .collect()
                };
            let middle = &instants[instants.len() / 2];
            let sets: Vec<SphereSet> = instants
                .iter()
                .map(|points| spheres_in_view(scene, camera_id, camera, frame, points))
                .collect();
            let first_mirror_image = sets[sets.len() / 2].first_mirror_image;
            let spheres: Vec<Vec<Sphere>> = sets.into_iter().map(|s| s.spheres).collect();
            let glints = glints_in_view(scene, camera_id, camera, frame, middle);
            let streaks: Vec<Streak> = scene
                .streaks
                .iter()
                .filter(|s| s.camera == camera_id && s.frames.contains(&frame))
                .map(|s| s.streak)
                .collect();
            let mut rng = ChaCha8Rng::seed_from_u64(view_seed(seed, camera_id, frame));
            let (image, views) =
                render_exposure(camera, &spheres, &glints, &streaks, &scene.render, &mut rng);
            let (image, jpeg_quality) = match scene.render.jpeg_quality {
                None => (image, None),
                Some(q) => match optics::jpeg_round_trip(&image, q) {
                    Ok(compressed) => (compressed, Some(q)),
                    Err(_) => (image, None),
                },
            };
            let smear_px = marker_smear_px(camera, &instants);
            let markers = isolation(
                scene,
                &views,
                first_mirror_image,
                &glints,
                &streaks,
                &smear_px,
            );
            RenderedView {
                camera: camera_id,
                image,
                markers,
                glints,
                jpeg_quality,
            }
        })
        .collect()
}

/// The spheres one camera sees at one instant.
struct SphereSet {
    /// The markers (first, in marker order), the occluders in front of them, then the markers'
    /// mirror images.
    spheres: Vec<Sphere>,
    /// Index of the first mirror image.
    first_mirror_image: usize,
}

/// The spheres one camera sees at one instant: the markers, the occluders placed in front of
/// them, and their mirror images in the scene's plate.
fn spheres_in_view(
    scene: &Scene,
    camera_id: CameraId,
    camera: &Camera,
    frame: usize,
    marker_points: &[Point3],
) -> SphereSet {
    let radius = scene.tool.marker_radius();
    let mut spheres: Vec<Sphere> = marker_points
        .iter()
        .map(|p| Sphere {
            center_in_world: *p,
            radius,
            radiance_dn: scene.render.marker_dn,
        })
        .collect();
    let eye = camera.center_in_world();
    for o in scene
        .occluders
        .iter()
        .filter(|o| o.camera == camera_id && o.frames.contains(&frame))
    {
        if let Some(target) = marker_points.get(o.marker.0) {
            let mut center_in_world = eye + (target - eye) * o.fraction;
            if o.sideways_mm != 0.0 {
                let camera_x_in_world = camera.camera_from_world.rotation.inverse() * Vector3::x();
                center_in_world += camera_x_in_world * o.sideways_mm;
            }
            spheres.push(Sphere {
                center_in_world,
                radius: o.radius,
                radiance_dn: 0.0,
            });
        }
    }
    let first_mirror_image = spheres.len();
    if let Some(mirror) = scene.mirror {
        for p in marker_points {
            let image_in_world = Point3::new(p.x, p.y, 2.0 * mirror.height_mm - p.z);
            if p.z <= mirror.height_mm {
                continue;
            }
            // Where the line of sight to the mirror image crosses the plate.
            let s = (eye.z - mirror.height_mm) / (eye.z - image_in_world.z);
            let crossing = eye + (image_in_world - eye) * s;
            let on_plate = (mirror.x_range_mm.0..=mirror.x_range_mm.1).contains(&crossing.x)
                && (mirror.y_range_mm.0..=mirror.y_range_mm.1).contains(&crossing.y);
            if eye.z > mirror.height_mm && on_plate {
                spheres.push(Sphere {
                    center_in_world: image_in_world,
                    radius,
                    radiance_dn: scene.render.marker_dn * mirror.reflectance,
                });
            }
        }
    }
    SphereSet {
        spheres,
        first_mirror_image,
    }
}

/// The glints one camera sees in a frame, placed against the markers' positions.
fn glints_in_view(
    scene: &Scene,
    camera_id: CameraId,
    camera: &Camera,
    frame: usize,
    marker_points: &[Point3],
) -> Vec<Glint> {
    let radius = scene.tool.marker_radius();
    scene
        .glints
        .iter()
        .filter(|g| g.camera == camera_id && g.frames.contains(&frame))
        .filter_map(|g| {
            let center = match g.place {
                GlintPlace::Fixed(p) => p,
                GlintPlace::Touching { marker, overlap_px } => {
                    let p = camera.project(marker_points.get(marker.0)?)?;
                    let distance = camera
                        .camera_from_world
                        .transform_point(marker_points.get(marker.0)?)
                        .coords
                        .norm();
                    let marker_radius_px = camera.intrinsics.fx * radius / distance;
                    Pixel::new(p.x + marker_radius_px + g.radius_px - overlap_px, p.y)
                }
            };
            Some(Glint {
                center,
                radius_px: g.radius_px,
                radiance_dn: g.radiance_dn,
            })
        })
        .collect()
}

/// How far each marker's image moves over the exposure, pixels (0 without motion blur).
fn marker_smear_px(camera: &Camera, instants: &[Vec<Point3>]) -> Vec<f64> {
    let (Some(first), Some(last)) = (instants.first(), instants.last()) else {
        return Vec::new();
    };
    first
        .iter()
        .zip(last)
        .map(|(a, b)| match (camera.project(a), camera.project(b)) {
            (Some(a), Some(b)) => a.distance(&b),
            _ => 0.0,
        })
        .collect()
}

/// Each marker's truth in a view: isolated when no other bright image (marker, mirror image,
/// glint, streak) comes within a blur width (plus the motion smear) of it.
fn isolation(
    scene: &Scene,
    views: &[SphereView],
    first_mirror_image: usize,
    glints: &[Glint],
    streaks: &[Streak],
    smear_px: &[f64],
) -> Vec<MarkerView> {
    let marker_count = scene.tool.markers_in_tool.len();
    let bright: Vec<usize> = (0..views.len())
        .filter(|&j| j < marker_count || j >= first_mirror_image)
        .collect();
    let reach_px = scene.render.psf_margin_px() as f64 - 1.0;
    let blur_gap = if scene.render.halo.is_some() {
        reach_px
    } else {
        3.0 * scene.render.blur_sigma_px + 1.0
    };
    (0..marker_count)
        .map(|i| {
            let view = views[i];
            let gap = blur_gap + smear_px.get(i).copied().unwrap_or(0.0);
            let isolated = view.center.is_some_and(|c| {
                let others_clear = bright.iter().filter(|j| **j != i).all(|&j| {
                    views[j]
                        .center
                        .is_none_or(|o| o.distance(&c) > view.radius_px + views[j].radius_px + gap)
                });
                let glints_clear = glints
                    .iter()
                    .all(|g| g.center.distance(&c) > view.radius_px + g.radius_px + gap);
                let streaks_clear = streaks
                    .iter()
                    .all(|s| s.distance_px(c.x, c.y) > view.radius_px + 0.5 * s.width_px + gap);
                others_clear && glints_clear && streaks_clear
            });
            MarkerView {
                marker: MarkerId(i),
                view,
                isolated,
            }
        })
        .collect()
}

/// Writes a scene as the contract's files: `recording.json`, `<camera>/<frame>.png`, `rig.json`,
/// `tool.json`, `truth.csv`, and `projections.csv`
/// (`camera,frame,marker,x_px,y_px,radius_px,visible_fraction,isolated`, one row per marker per
/// view, the exact projection of the sphere's centre). Frames are rendered in parallel;
/// `on_frame` is called once per frame written.
///
/// All or nothing: the files are written into a staging folder that replaces `out`'s entries
/// only once every frame is written ([`crate::io::StagedFolder`]), so a failure or an interrupt
/// never leaves old and new frames mixed.
///
/// # Errors
/// [`FileError`] when a file cannot be written.
pub fn write_scene(
    scene: &Scene,
    out: &Path,
    seed: u64,
    on_frame: &(dyn Fn() + Sync),
) -> Result<(), FileError> {
    let staged = crate::io::StagedFolder::new(out)?;
    write_scene_into(scene, staged.path(), seed, on_frame)?;
    staged.commit().map(drop)
}

fn write_scene_into(
    scene: &Scene,
    out: &Path,
    seed: u64,
    on_frame: &(dyn Fn() + Sync),
) -> Result<(), FileError> {
    for camera in &scene.rig.cameras {
        crate::io::create_folder(&out.join(&camera.name))?;
    }
    let folder_of = |camera: CameraId| out.join(&scene.rig.cameras[camera.0].name);
    let rows: Vec<String> = (0..scene.truth.len())
        .into_par_iter()
        .map(|frame| {
            let views = render_frame(scene, frame, seed);
            let mut rows = String::new();
            for view in views {
                if view.jpeg_quality != scene.render.jpeg_quality {
                    return Err(FileError::Invalid {
                        path: folder_of(view.camera),
                        message: format!(
                            "frame {frame}: the jpeg codec refused the {}x{} image",
                            view.image.width(),
                            view.image.height()
                        ),
                    });
                }
                let camera = &scene.rig.cameras[view.camera.0];
                crate::io::recording::write_png(
                    &out.join(&camera.name)
                        .join(crate::io::recording::frame_file_name(frame)),
                    &view.image,
                )?;
                for m in &view.markers {
                    let (x, y) = m.view.center.map_or((String::new(), String::new()), |c| {
                        (format!("{:.6}", c.x), format!("{:.6}", c.y))
                    });
                    rows.push_str(&format!(
                        "{},{frame},{},{x},{y},{:.4},{:.4},{}\n",
                        camera.name,
                        m.marker.0,
                        m.view.radius_px,
                        m.view.visible_fraction,
                        u8::from(m.isolated)
                    ));
                }
            }
            on_frame();
            Ok(rows)
        })
        .collect::<Result<_, FileError>>()?;
    let mut projections =
        String::from("camera,frame,marker,x_px,y_px,radius_px,visible_fraction,isolated\n");
    rows.iter().for_each(|r| projections.push_str(r));
    crate::io::write_atomically(&out.join("projections.csv"), projections.as_bytes())?;
    crate::io::recording::write_recording_info(out, scene.fps)?;
    crate::io::rig::write_rig(&out.join("rig.json"), &scene.written_rig())?;
    if let Some(m) = scene.miscalibration {
        crate::io::rig::write_rig(&out.join("rig_true.json"), &scene.rig)?;
        let axis = m.axis_in_camera.normalize();
        let camera = scene
            .rig
            .cameras
            .get(m.camera.0)
            .map_or("", |c| c.name.as_str());
        let text = serde_json::json!({
            "camera": camera,
            "angle_deg": m.angle.to_degrees(),
            "axis_in_camera": [axis.x, axis.y, axis.z],
            "meaning": "rig.json's camera_from_world = R(axis_in_camera, angle) * rig_true.json's",
        });
        crate::io::write_atomically(
            &out.join("miscalibration.json"),
            format!("{text:#}\n").as_bytes(),
        )?;
    }
    if !scene.time_offsets_s.is_empty() {
        let offsets: serde_json::Map<String, serde_json::Value> = scene
            .rig
            .iter()
            .map(|(id, c)| (c.name.clone(), serde_json::json!(scene.time_offset_s(id))))
            .collect();
        crate::io::write_atomically(
            &out.join("time_offsets.json"),
            format!("{:#}\n", serde_json::Value::Object(offsets)).as_bytes(),
        )?;
    }
    crate::io::tool::write_tool(&out.join("tool.json"), &scene.tool)?;
    crate::io::trajectory::write_trajectory(&out.join("truth.csv"), &scene.truth)
}
