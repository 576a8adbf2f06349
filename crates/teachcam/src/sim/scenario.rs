//! The simulated scenes: the paper's rig, brush and painter's stroke (§V-A, §III), and variants.
//!
//! Rig: three 1280×1024 cameras with a 12 mm lens on 6.7 µm pixels (fx = 12 / 0.0067 ≈ 1791 px),
//! mild barrel distortion, 1 m from the work object, looking at it from three directions far
//! apart (the paper asks for cameras "the most distant possible one from each other").
//! World frame: on the work object, z up. Brush: four 10 mm spheres with six distinct distances
//! (closest two differ by 12 mm), tip 190 mm below the cluster. Stroke: the paper's model of a
//! trajectory, a sum of sinusoids per translation and rotation component (§III).

use std::f64::consts::TAU;

use nalgebra::{UnitQuaternion, Vector3};

use crate::camera::{Camera, Distortion, ImageSize, Intrinsics, Rig};
use crate::geometry::{Point3, Pose, pose_from_parts};
use crate::tool::Tool;

/// Focal length of the paper's cameras: 12 mm lens over 6.7 µm pixels.
pub const PAPER_FOCAL_PX: f64 = 12.0 / 0.0067;

/// Distance from each camera to the point it looks at, millimetres (the paper's "about 1 m").
pub const PAPER_CAMERA_DISTANCE_MM: f64 = 1000.0;

/// Where the cameras look: above the work object, in the middle of the brush's cluster path.
const LOOK_AT_MM: [f64; 3] = [0.0, 0.0, 120.0];

/// A camera of the paper's kind looking at `LOOK_AT_MM` from an azimuth and an elevation.
fn paper_camera(name: &str, azimuth_deg: f64, elevation_deg: f64, distortion: [f64; 5]) -> Camera {
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    let target = Point3::from(LOOK_AT_MM);
    let eye = target
        + Vector3::new(az.cos() * el.cos(), az.sin() * el.cos(), el.sin())
            * PAPER_CAMERA_DISTANCE_MM;
    // Camera z looks at the target; camera y (image down) points as close to world -z as it can.
    let rotation = UnitQuaternion::face_towards(&(target - eye), &-Vector3::z());
    let world_from_camera = pose_from_parts(eye.coords, rotation);
    Camera {
        name: name.to_string(),
        image_size: ImageSize {
            width: 1280,
            height: 1024,
        },
        intrinsics: Intrinsics {
            fx: PAPER_FOCAL_PX,
            fy: PAPER_FOCAL_PX,
            cx: 639.5,
            cy: 511.5,
        },
        distortion: Distortion::from_opencv(distortion),
        camera_from_world: world_from_camera.inverse(),
    }
}

/// The paper's trinocular rig: three cameras 120° apart in azimuth at different elevations.
#[must_use]
pub fn paper_rig() -> Rig {
    Rig {
        cameras: vec![
            paper_camera("cam0", -90.0, 45.0, [-0.08, 0.05, 0.0, 0.0, 0.0]),
            paper_camera("cam1", 30.0, 35.0, [-0.07, 0.04, 0.0005, -0.0003, 0.0]),
            paper_camera("cam2", 150.0, 55.0, [-0.09, 0.06, -0.0004, 0.0002, 0.0]),
        ],
    }
}

/// The paper's rig with a fourth camera looking down from high above.
#[must_use]
pub fn four_camera_rig() -> Rig {
    let mut rig = paper_rig();
    rig.cameras.push(paper_camera(
        "cam3",
        60.0,
        75.0,
        [-0.06, 0.03, 0.0, 0.0, 0.0],
    ));
    rig
}

/// The simulated brush: four 10 mm spheres, all six distances at least 12 mm apart, the tip
/// 190 mm below the cluster along the handle (tool -z).
#[must_use]
pub fn paper_brush() -> Tool {
    let markers = [
        [0.0, 0.0, 0.0],
        [53.0, 59.0, 26.0],
        [-47.0, 6.0, 34.0],
        [45.0, -8.0, 4.0],
    ];
    let tool_from_tcp =
        pose_from_parts(Vector3::new(5.0, 20.0, -190.0), UnitQuaternion::identity());
    let markers = markers
        .iter()
        .map(|m| Point3::new(m[0], m[1], m[2]))
        .collect();
    Tool {
        name: "brush".into(),
        marker_diameter_mm: 10.0,
        markers_in_tool: markers,
        tool_from_tcp,
    }
}

/// One sinusoid: amplitude, frequency in Hz, phase in radians.
#[derive(Debug, Clone, Copy)]
struct Wave(f64, f64, f64);

fn sum(waves: &[Wave], time_s: f64) -> f64 {
    waves
        .iter()
        .map(|w| w.0 * (TAU * w.1 * time_s + w.2).sin())
        .sum()
}

/// The tool centre point's pose at time `t` of a painter's stroke: the tip sweeps the work
/// object (z near 0) in loops of ±100 mm while the brush leans 25° towards the painter and
/// rocks and turns by up to ±15°. Every component is a sum of sinusoids below 2 Hz.
#[must_use]
pub fn painter_stroke(time_s: f64) -> Pose {
    let x = sum(
        &[
            Wave(80.0, 0.31, 0.0),
            Wave(15.0, 1.13, 0.7),
            Wave(3.0, 1.9, 2.0),
        ],
        time_s,
    );
    let y = sum(&[Wave(55.0, 0.47, 0.5), Wave(12.0, 1.71, 1.1)], time_s);
    let z = 4.0 + sum(&[Wave(3.0, 0.83, 0.2), Wave(1.0, 1.6, 0.0)], time_s);
    let lean = 25_f64.to_radians()
        + sum(
            &[
                Wave(8_f64.to_radians(), 0.41, 0.3),
                Wave(2_f64.to_radians(), 1.37, 0.0),
            ],
            time_s,
        );
    let roll = sum(
        &[
            Wave(10_f64.to_radians(), 0.37, 1.4),
            Wave(2_f64.to_radians(), 1.21, 0.0),
        ],
        time_s,
    );
    let turn = 20_f64.to_radians() + sum(&[Wave(15_f64.to_radians(), 0.29, 0.9)], time_s);
    // Turn about the world vertical, then lean the handle towards the painter (-y), then roll.
    let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), turn)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -lean)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), roll);
    pose_from_parts(Vector3::new(x, y, z), rotation)
}
