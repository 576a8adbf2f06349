//! `rig.json` and `camera.json` (CONTRACT.md, "Rig file"): OpenCV intrinsics, distortion and
//! world-to-camera extrinsics per camera, in millimetres.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{FileError, parse_json, read_text, write_json};
use crate::camera::{Camera, Distortion, ImageSize, Intrinsics, Rig};
use crate::geometry::{Pose, pose_from_parts, rotation_from_rows, rotation_rows};

/// One camera as the file writes it.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraFile {
    /// Name; also the recording's sub-folder for this camera.
    pub name: String,
    /// `[width, height]` in pixels.
    pub image_size: [u32; 2],
    /// Focal length x, pixels.
    pub fx: f64,
    /// Focal length y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// `[k1, k2, p1, p2, k3]`.
    pub distortion: [f64; 5],
    /// World-to-camera rotation, row-major; optional in `camera.json`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[[f64; 3]; 3]>,
    /// World-to-camera translation, millimetres; optional in `camera.json`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub translation: Option<[f64; 3]>,
    /// RMS reprojection error of the calibration, pixels (`camera.json`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rms_px: Option<f64>,
    /// One standard error of the camera's centre from the calibration that wrote it,
    /// millimetres (`calibrate refine`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centre_std_mm: Option<f64>,
    /// One standard error of its orientation, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation_std_deg: Option<f64>,
}

/// One camera's σ as a rig file may carry it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraStdFile {
    /// `centre_std_mm`.
    pub centre_std_mm: f64,
    /// `rotation_std_deg`.
    pub rotation_std_deg: f64,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RigFile {
    units: String,
    cameras: Vec<CameraFile>,
}

impl CameraFile {
    /// The file form of a camera.
    #[must_use]
    pub fn from_camera(camera: &Camera) -> Self {
        Self {
            name: camera.name.clone(),
            image_size: [camera.image_size.width, camera.image_size.height],
            fx: camera.intrinsics.fx,
            fy: camera.intrinsics.fy,
            cx: camera.intrinsics.cx,
            cy: camera.intrinsics.cy,
            distortion: camera.distortion.to_opencv(),
            rotation: Some(rotation_rows(&camera.camera_from_world.rotation)),
            translation: Some(camera.camera_from_world.translation.vector.into()),
            rms_px: None,
            centre_std_mm: None,
            rotation_std_deg: None,
        }
    }

    /// The camera, checked; `what` names it in messages (`camera 1 (cam1)`). Missing extrinsics
    /// give the identity (a lone camera's own frame).
    ///
    /// # Errors
    /// A lowercase message naming the field.
    pub fn to_camera(&self, what: &str) -> Result<Camera, String> {
        let [width, height] = self.image_size;
        if width == 0 || height == 0 {
            return Err(format!("{what}: image_size {width}x{height} is empty"));
        }
        for (field, value) in [
            ("fx", self.fx),
            ("fy", self.fy),
            ("cx", self.cx),
            ("cy", self.cy),
        ] {
            if !value.is_finite() {
                return Err(format!("{what}: {field} is not finite"));
            }
        }
        if self.fx <= 0.0 || self.fy <= 0.0 {
            return Err(format!(
                "{what}: focal lengths must be positive (fx {}, fy {})",
                self.fx, self.fy
            ));
        }
        if self.distortion.iter().any(|v| !v.is_finite()) {
            return Err(format!("{what}: distortion has a non-finite coefficient"));
        }
        let camera_from_world = match (self.rotation, self.translation) {
            (Some(rows), Some(t)) => {
                let rotation =
                    rotation_from_rows(&rows).map_err(|e| format!("{what}: rotation: {e}"))?;
                if t.iter().any(|v| !v.is_finite()) {
                    return Err(format!("{what}: translation is not finite"));
                }
                pose_from_parts(nalgebra::Vector3::from(t), rotation)
            }
            (None, None) => Pose::identity(),
            _ => return Err(format!("{what}: rotation and translation go together")),
        };
        Ok(Camera {
            name: self.name.clone(),
            image_size: ImageSize { width, height },
            intrinsics: Intrinsics {
                fx: self.fx,
                fy: self.fy,
                cx: self.cx,
                cy: self.cy,
            },
            distortion: Distortion::from_opencv(self.distortion),
            camera_from_world,
        })
    }
}

/// Reads and checks a rig file: units `mm`, at least one camera, unique names, every camera
/// valid (positive focal lengths, finite numbers, orthonormal rotations with `det = +1`).
///
/// # Errors
/// [`FileError::Invalid`] naming the camera and the field.
pub fn read_rig(path: &Path) -> Result<Rig, FileError> {
    read_rig_file(path, true)
}

/// Reads a cameras file (`teachcam calibrate wand --cameras`): a rig file whose cameras may
/// lack extrinsics (they are then the identity); checked as [`read_rig`] otherwise.
///
/// # Errors
/// [`FileError::Invalid`] naming the camera and the field.
pub fn read_cameras(path: &Path) -> Result<Rig, FileError> {
    read_rig_file(path, false)
}

fn read_rig_file(path: &Path, extrinsics_required: bool) -> Result<Rig, FileError> {
    let file: RigFile = parse_json(path, &read_text(path)?)?;
    if file.units != "mm" {
        return Err(FileError::invalid(
            path,
            format!("units must be \"mm\", got \"{}\"", file.units),
        ));
    }
    if file.cameras.is_empty() {
        return Err(FileError::invalid(path, "cameras is empty"));
    }
    let mut cameras = Vec::with_capacity(file.cameras.len());
    for (i, c) in file.cameras.iter().enumerate() {
        if file.cameras[..i].iter().any(|other| other.name == c.name) {
            return Err(FileError::invalid(
                path,
                format!("camera {i}: name \"{}\" is used twice", c.name),
            ));
        }
        if extrinsics_required && (c.rotation.is_none() || c.translation.is_none()) {
            return Err(FileError::invalid(
                path,
                format!(
                    "camera {i} ({}): rotation and translation are required in a rig",
                    c.name
                ),
            ));
        }
        cameras.push(
            c.to_camera(&format!("camera {i} ({})", c.name))
                .map_err(|m| FileError::invalid(path, m))?,
        );
    }
    Ok(Rig { cameras })
}

/// Writes a cameras file whole: the rig's intrinsics without extrinsics.
///
/// # Errors
/// [`FileError::Write`].
pub fn write_cameras(path: &Path, rig: &Rig) -> Result<(), FileError> {
    let file = RigFile {
        units: "mm".into(),
        cameras: rig
            .cameras
            .iter()
            .map(|c| CameraFile {
                rotation: None,
                translation: None,
                ..CameraFile::from_camera(c)
            })
            .collect(),
    };
    write_json(path, &file)
}

/// Writes a rig file whole.
///
/// # Errors
/// [`FileError::Write`].
pub fn write_rig(path: &Path, rig: &Rig) -> Result<(), FileError> {
    write_rig_with_std(path, rig, &[])
}

/// Writes a rig file whole with each camera's σ (`std[i]` for camera i; cameras beyond
/// `std` get none).
///
/// # Errors
/// [`FileError::Write`].
pub fn write_rig_with_std(path: &Path, rig: &Rig, std: &[CameraStdFile]) -> Result<(), FileError> {
    let file = RigFile {
        units: "mm".into(),
        cameras: rig
            .cameras
            .iter()
            .enumerate()
            .map(|(i, camera)| {
                let s = std.get(i);
                CameraFile {
                    centre_std_mm: s.map(|s| s.centre_std_mm),
                    rotation_std_deg: s.map(|s| s.rotation_std_deg),
                    ..CameraFile::from_camera(camera)
                }
            })
            .collect(),
    };
    write_json(path, &file)
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"{"units": "mm", "cameras": [{"name": "cam0", "image_size": [1280, 1024],
        "fx": 1791.0, "fy": 1791.0, "cx": 639.5, "cy": 511.5, "distortion": [-0.1, 0.05, 0.0, 0.0, 0.0],
        "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "translation": [0.0, 0.0, 1000.0]}]}"#;

    fn write(dir: &Path, text: &str) -> std::path::PathBuf {
        let path = dir.join("rig.json");
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn reads_the_contract_example_and_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let rig = read_rig(&write(dir.path(), GOOD)).unwrap();
        assert_eq!(rig.cameras[0].intrinsics.fx, 1791.0);
        assert_eq!(
            rig.cameras[0].center_in_world(),
            crate::geometry::Point3::new(0.0, 0.0, -1000.0)
        );
        let out = dir.path().join("out.json");
        write_rig(&out, &rig).unwrap();
        assert_eq!(read_rig(&out).unwrap(), rig);
    }

    #[test]
    fn refuses_bad_rigs_naming_camera_and_field() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            (GOOD.replace("\"mm\"", "\"m\""), "units"),
            (GOOD.replace("[[1, 0, 0], [0, 1, 0]", "[[1, 0.2, 0], [0, 1, 0]"), "camera 0 (cam0): rotation: rotation is not orthonormal"),
            (GOOD.replace("[[1, 0, 0], [0, 1, 0]", "[[-1, 0, 0], [0, 1, 0]"), "determinant"),
            (GOOD.replace("\"fx\": 1791.0", "\"fx\": -1.0"), "focal lengths"),
            (GOOD.replace("\"fx\": 1791.0, ", ""), "missing field `fx`"),
            (GOOD.replace("[1280, 1024]", "[0, 1024]"), "image_size"),
            (GOOD.replace(", \"translation\": [0.0, 0.0, 1000.0]", ""), "rotation and translation are required"),
            (GOOD.replace("[{", "[{\"name\": \"cam0\", \"image_size\": [1, 1], \"fx\": 1, \"fy\": 1, \"cx\": 0, \"cy\": 0, \"distortion\": [0,0,0,0,0], \"rotation\": [[1,0,0],[0,1,0],[0,0,1]], \"translation\": [0,0,0]}, {"), "used twice"),
            (r#"{"units": "mm", "cameras": []}"#.to_string(), "cameras is empty"),
        ];
        for (text, needle) in cases {
            let message = read_rig(&write(dir.path(), &text)).unwrap_err().to_string();
            assert!(
                message.contains(needle) && message.contains("rig.json"),
                "{needle} not in {message}"
            );
        }
    }
}
