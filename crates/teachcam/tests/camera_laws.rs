//! The law harness every camera passes: agreement with OpenCV's `projectPoints` on stored
//! reference values, project ∘ unproject round trips over the whole image, the projection
//! Jacobian against finite differences, and epipolar consistency between cameras.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use nalgebra::Vector3;
use serde::Deserialize;
use teachcam::camera::{
    Camera, Distortion, ImageSize, Intrinsics, epipolar_line, fundamental_matrix,
};
use teachcam::geometry::{Pixel, Point3, pose_from_parts, rotation_from_rows};

#[derive(Deserialize)]
struct Reference {
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Case {
    camera: CameraSpec,
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
    points_in_world: Vec<[f64; 3]>,
    pixels: Vec<[f64; 2]>,
}

#[derive(Deserialize)]
struct CameraSpec {
    name: String,
    size: [u32; 2],
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    dist: [f64; 5],
}

fn reference() -> Reference {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/opencv_project_points.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn camera(case: &Case) -> Camera {
    let c = &case.camera;
    Camera {
        name: c.name.clone(),
        image_size: ImageSize {
            width: c.size[0],
            height: c.size[1],
        },
        intrinsics: Intrinsics {
            fx: c.fx,
            fy: c.fy,
            cx: c.cx,
            cy: c.cy,
        },
        distortion: Distortion::from_opencv(c.dist),
        camera_from_world: pose_from_parts(
            Vector3::from(case.translation),
            rotation_from_rows(&case.rotation).unwrap(),
        ),
    }
}

fn cameras() -> Vec<Camera> {
    reference().cases.iter().map(camera).collect()
}

#[test]
fn projection_matches_opencv_project_points() {
    for case in reference().cases {
        let cam = camera(&case);
        let mut worst = 0.0_f64;
        for (p, expected) in case.points_in_world.iter().zip(&case.pixels) {
            let px = cam.project(&Point3::new(p[0], p[1], p[2])).unwrap();
            worst = worst.max(px.distance(&Pixel::new(expected[0], expected[1])));
        }
        // OpenCV computes in double precision too: agreement is limited by rounding only.
        assert!(
            worst < 1e-8,
            "{}: worst difference from OpenCV {worst:.3e} px",
            cam.name
        );
    }
}

#[test]
fn unproject_then_project_returns_the_pixel_over_the_whole_image() {
    for cam in cameras() {
        let ImageSize { width, height } = cam.image_size;
        let mut worst = 0.0_f64;
        let step = 8;
        for row in (0..height).step_by(step).chain([height - 1]) {
            for col in (0..width).step_by(step).chain([width - 1]) {
                let px = Pixel::new(f64::from(col), f64::from(row));
                let ray = cam
                    .unproject(&px)
                    .unwrap_or_else(|e| panic!("{}: {e}", cam.name));
                let back = cam.project(&ray.at(1000.0)).unwrap();
                worst = worst.max(back.distance(&px));
            }
        }
        assert!(
            worst < 1e-6,
            "{}: worst round trip {worst:.3e} px",
            cam.name
        );
    }
}

#[test]
fn projection_jacobian_matches_finite_differences() {
    for case in reference().cases {
        let cam = camera(&case);
        for p in case.points_in_world.iter().take(50) {
            let point = Point3::new(p[0], p[1], p[2]);
            let jacobian = cam.projection_jacobian(&point).unwrap();
            let h = 1e-4; // mm; central differences: error ~ h² · third derivative, far below 1e-6 relative
            for axis in 0..3 {
                let mut delta = Vector3::zeros();
                delta[axis] = h;
                let plus = cam.project(&(point + delta)).unwrap();
                let minus = cam.project(&(point - delta)).unwrap();
                let numeric = [
                    (plus.x - minus.x) / (2.0 * h),
                    (plus.y - minus.y) / (2.0 * h),
                ];
                for row in 0..2 {
                    let analytic = jacobian[(row, axis)];
                    let scale = jacobian.abs().max();
                    assert!(
                        (analytic - numeric[row]).abs() < 1e-6 * scale,
                        "{}: d{row}/d{axis} analytic {analytic} numeric {}",
                        cam.name,
                        numeric[row]
                    );
                }
            }
        }
    }
}

#[test]
fn a_point_lies_on_its_epipolar_line_in_every_other_camera() {
    // Two reference cameras placed to see the same points: the second looks at the first's points.
    let cams = cameras();
    let from = &cams[0];
    let mut to = cams[2].clone();
    let center = from.center_in_world();
    let target = from
        .unproject(&Pixel::new(640.0, 512.0))
        .unwrap()
        .at(1200.0);
    // Put `to` 600 mm to the side of `from`, looking at the same target.
    let eye = center
        + from
            .camera_from_world
            .rotation
            .inverse_transform_vector(&Vector3::new(600.0, 50.0, 0.0));
    let forward = (target - eye).normalize();
    let rotation = nalgebra::UnitQuaternion::face_towards(&forward, &Vector3::new(0.0, 1.0, 0.0));
    let world_from_camera = pose_from_parts(eye.coords, rotation);
    to.camera_from_world = world_from_camera.inverse();
    let f = fundamental_matrix(from, &to);
    let mut checked = 0;
    for (i, row) in (0..1024).step_by(64).enumerate() {
        let px = Pixel::new(40.0 + 75.0 * i as f64, f64::from(row));
        let point = from.unproject(&px).unwrap().at(1100.0 + 20.0 * i as f64);
        let Some(seen) = to.project(&point).filter(|p| to.image_size.contains(p)) else {
            continue;
        };
        let line = epipolar_line(&f, &from.ideal_pixel(&px).unwrap()).unwrap();
        let distance = line.distance(&to.ideal_pixel(&seen).unwrap());
        assert!(
            distance < 1e-6,
            "distance from epipolar line {distance:.3e} px"
        );
        checked += 1;
    }
    assert!(checked >= 8, "only {checked} points seen by both cameras");
}

#[test]
fn undistortion_reports_divergence_instead_of_a_wrong_answer() {
    let mut cam = cameras().remove(1);
    cam.distortion = Distortion {
        k1: -0.5,
        k2: 0.0,
        p1: 0.0,
        p2: 0.0,
        k3: 0.0,
    };
    // Barrel distortion x(1 - 0.5 r²) peaks at r = 0.816 with value 0.544: no normalised radius
    // maps to 0.7 · fx pixels, so there is no answer to converge to.
    let px = Pixel::new(
        cam.intrinsics.cx + 0.7 * cam.intrinsics.fx,
        cam.intrinsics.cy,
    );
    assert!(cam.undistort(&px).is_err());
    assert!(cam.undistort(&Pixel::new(f64::NAN, 0.0)).is_err());
}
