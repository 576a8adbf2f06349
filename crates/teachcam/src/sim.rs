//! The simulator: a virtual rig films a brush following a known trajectory, so that every stage
//! can be checked against ground truth.
//!
//! A [`Scene`] holds the rig, the tool, the true trajectory and what else the cameras see (dark
//! occluders in front of markers, glints that exist in one view only). [`render_frame`] draws
//! one frame of every camera by ray casting ([`render`]), and [`write_scene`] writes the
//! contract's recording folder with `rig.json`, `tool.json`, `truth.csv` and the exact projection
//! of every sphere centre in every view (`projections.csv`). Everything is deterministic for a
//! seed: each (camera, frame) draws its noise from its own seeded stream, so frames can be
//! rendered in any order or in parallel.

pub mod board;
pub mod calibration;
pub mod render;
pub mod scenario;

use std::path::Path;

use image::GrayImage;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::camera::Rig;
use crate::geometry::{CameraId, FrameIndex, MarkerId, Pixel, Point3, Pose};
use crate::io::FileError;
use crate::tool::Tool;
use crate::trajectory::{Sample, ToolPose, Trajectory};
use render::{Glint, RenderConfig, Sphere, SphereView, render_view};

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
}

impl Scenario {
    /// Every scenario, for listings and help.
    pub const ALL: [Scenario; 6] = [
        Scenario::Paper,
        Scenario::Static,
        Scenario::Occluded,
        Scenario::FourCameras,
        Scenario::Calibration,
        Scenario::FourCamerasCalibration,
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
        }
    }

    /// True for the chessboard scenarios, which [`calibration::write_calibration`] writes
    /// instead of a recording.
    #[must_use]
    pub const fn is_calibration(self) -> bool {
        matches!(self, Self::Calibration | Self::FourCamerasCalibration)
    }

    /// The scenario's rig: the paper's three cameras, or four.
    #[must_use]
    pub fn rig(self) -> Rig {
        match self {
            Self::FourCameras | Self::FourCamerasCalibration => scenario::four_camera_rig(),
            Self::Paper | Self::Static | Self::Occluded | Self::Calibration => {
                scenario::paper_rig()
            }
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
    /// Image formation.
    pub render: RenderConfig,
}

/// Frames of the paper's stroke: 4 s at the paper's 30 Hz trigger.
const STROKE_FRAMES: usize = 120;

/// Builds a scenario's recording scene. `seed` places the random glints of `occluded`. The
/// calibration scenarios have no recording: this gives their rig filming the paper's stroke;
/// their board views come from [`calibration::calibration_scene`].
#[must_use]
pub fn build_scene(scenario: Scenario, seed: u64) -> Scene {
    let fps = 30.0;
    let tool = scenario::paper_brush();
    let rig = scenario.rig();
    let frames = if scenario == Scenario::Static {
        100
    } else {
        STROKE_FRAMES
    };
    let samples = (0..frames)
        .map(|f| {
            let time_s = f as f64 / fps;
            let stroke_time = if scenario == Scenario::Static {
                1.3
            } else {
                time_s
            };
            let world_from_tcp = scenario::painter_stroke(stroke_time);
            let world_from_tool = world_from_tcp * tool.tool_from_tcp.inverse();
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
    let (occluders, glints) = if scenario == Scenario::Occluded {
        occlusions(seed)
    } else {
        (Vec::new(), Vec::new())
    };
    Scene {
        scenario,
        rig,
        tool,
        fps,
        truth: Trajectory { samples },
        occluders,
        glints,
        render: RenderConfig::default(),
    }
}

/// The `occluded` scenario's events: one marker hidden from one camera in three stretches (two
/// markers at once in the last), persistent glints in every camera, flickering ones, and a
/// glint touching a marker's image.
fn occlusions(seed: u64) -> (Vec<Occluder>, Vec<StrayGlint>) {
    let occluders = vec![
        Occluder {
            frames: 20..45,
            camera: CameraId(1),
            marker: MarkerId(2),
            fraction: 0.6,
            radius: 12.0,
        },
        Occluder {
            frames: 60..80,
            camera: CameraId(0),
            marker: MarkerId(0),
            fraction: 0.7,
            radius: 10.0,
        },
        Occluder {
            frames: 90..105,
            camera: CameraId(2),
            marker: MarkerId(3),
            fraction: 0.5,
            radius: 10.0,
        },
        Occluder {
            frames: 95..105,
            camera: CameraId(1),
            marker: MarkerId(1),
            fraction: 0.5,
            radius: 10.0,
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
    let Some(pose) = scene.truth.samples.get(frame).and_then(|s| s.pose) else {
        return Vec::new();
    };
    let marker_points = markers_in_world(&scene.tool, &pose.world_from_tool);
    let radius = scene.tool.marker_radius();
    scene
        .rig
        .iter()
        .map(|(camera_id, camera)| {
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
                    spheres.push(Sphere {
                        center_in_world: eye + (target - eye) * o.fraction,
                        radius: o.radius,
                        radiance_dn: 0.0,
                    });
                }
            }
            let glints: Vec<Glint> = scene
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
                .collect();
            let mut rng = ChaCha8Rng::seed_from_u64(view_seed(seed, camera_id, frame));
            let (image, views) = render_view(camera, &spheres, &glints, &scene.render, &mut rng);
            let blur_gap = 3.0 * scene.render.blur_sigma_px + 1.0;
            let markers = (0..marker_points.len())
                .map(|i| {
                    let view = views[i];
                    let isolated = view.center.is_some_and(|c| {
                        let others_clear = (0..marker_points.len()).filter(|j| *j != i).all(|j| {
                            views[j].center.is_none_or(|o| {
                                o.distance(&c) > view.radius_px + views[j].radius_px + blur_gap
                            })
                        });
                        let glints_clear = glints.iter().all(|g| {
                            g.center.distance(&c) > view.radius_px + g.radius_px + blur_gap
                        });
                        others_clear && glints_clear
                    });
                    MarkerView {
                        marker: MarkerId(i),
                        view,
                        isolated,
                    }
                })
                .collect();
            RenderedView {
                camera: camera_id,
                image,
                markers,
                glints,
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
/// # Errors
/// [`FileError`] when a file cannot be written.
pub fn write_scene(
    scene: &Scene,
    out: &Path,
    seed: u64,
    on_frame: &(dyn Fn() + Sync),
) -> Result<(), FileError> {
    for camera in &scene.rig.cameras {
        crate::io::create_folder(&out.join(&camera.name))?;
    }
    let rows: Vec<String> = (0..scene.truth.len())
        .into_par_iter()
        .map(|frame| {
            let views = render_frame(scene, frame, seed);
            let mut rows = String::new();
            for view in views {
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
    crate::io::rig::write_rig(&out.join("rig.json"), &scene.rig)?;
    crate::io::tool::write_tool(&out.join("tool.json"), &scene.tool)?;
    crate::io::trajectory::write_trajectory(&out.join("truth.csv"), &scene.truth)
}
