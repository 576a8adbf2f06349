//! One camera's calibration in the three forms users meet: `camera.json` (CONTRACT.md: one
//! rig camera object with `rms_px`, extrinsics optional), OpenCV `FileStorage` YAML
//! (`camera_matrix`, `distortion_coefficients` as `!!opencv-matrix`) and ROS `camera_info`
//! YAML (`camera_calibration_parsers`: `camera_matrix`, `distortion_model: plumb_bob`,
//! `distortion_coefficients`, `rectification_matrix`, `projection_matrix`).
//!
//! Both YAML dialects share the subset read here: top-level `key: value` lines, and under a
//! matrix key indented `rows`, `cols`, `dt` and a `data: [ ... ]` flow list that may span
//! lines. No YAML crate is needed for that subset, and each refusal names the line or key.

use std::collections::BTreeMap;
use std::path::Path;

use super::rig::CameraFile;
use super::{FileError, parse_json, read_text, write_atomically, write_json};
use crate::camera::{Camera, Distortion, ImageSize, Intrinsics};
use crate::geometry::Pose;

/// A camera as read from a calibration file, with the RMS error the file states (if any).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraCalibration {
    /// The camera (extrinsics identity unless the file gives them).
    pub camera: Camera,
    /// RMS reprojection error of its calibration, pixels, when the file states one.
    pub rms_px: Option<f64>,
}

/// Reads `camera.json`, OpenCV YAML or ROS YAML, chosen by the extension (`.json`, `.yaml`,
/// `.yml`); a camera without a name in the file is named after the file's stem.
///
/// # Errors
/// [`FileError`] naming the file and the line or field.
pub fn read_camera(path: &Path) -> Result<CameraCalibration, FileError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("camera")
        .to_owned();
    match extension.as_deref() {
        Some("json") => {
            let file: CameraFile = parse_json(path, &read_text(path)?)?;
            let mut camera = file
                .to_camera(&format!("camera {}", file.name))
                .map_err(|m| FileError::invalid(path, m))?;
            if camera.name.is_empty() {
                camera.name = stem;
            }
            if file.rms_px.is_some_and(|r| !r.is_finite()) {
                return Err(FileError::invalid(path, "rms_px is not finite"));
            }
            Ok(CameraCalibration {
                camera,
                rms_px: file.rms_px,
            })
        }
        Some("yaml" | "yml") => parse_camera_yaml(path, &read_text(path)?, &stem),
        _ => Err(FileError::invalid(
            path,
            "unknown camera file type: expected .json, .yaml or .yml",
        )),
    }
}

/// Writes `camera.json`: the contract's camera object with `rms_px`; extrinsics only when the
/// camera has some (not the identity).
///
/// # Errors
/// [`FileError::Invalid`] for a non-finite number (never written), [`FileError::Write`].
pub fn write_camera_json(path: &Path, camera: &Camera, rms_px: f64) -> Result<(), FileError> {
    check_finite(path, camera, rms_px)?;
    let mut file = CameraFile::from_camera(camera);
    if camera.camera_from_world == Pose::identity() {
        file.rotation = None;
        file.translation = None;
    }
    file.rms_px = Some(rms_px);
    write_json(path, &file)
}

/// Writes OpenCV `FileStorage` YAML, readable by `cv2.FileStorage(path, READ)`.
///
/// # Errors
/// As [`write_camera_json`].
pub fn write_opencv_yaml(path: &Path, camera: &Camera, rms_px: f64) -> Result<(), FileError> {
    check_finite(path, camera, rms_px)?;
    let Intrinsics { fx, fy, cx, cy } = camera.intrinsics;
    let d = camera.distortion.to_opencv();
    let text = format!(
        "%YAML:1.0\n---\nimage_width: {}\nimage_height: {}\n\
         camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {} ]\n\
         distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ {} ]\n\
         avg_reprojection_error: {}\n",
        camera.image_size.width,
        camera.image_size.height,
        list(&[fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]),
        list(&d),
        number(rms_px),
    );
    write_atomically(path, text.as_bytes())
}

/// Writes ROS `camera_info` YAML (`camera_calibration_parsers`' layout, `plumb_bob`), with an
/// identity rectification and `P = [K | 0]` (a monocular camera).
///
/// # Errors
/// As [`write_camera_json`].
pub fn write_ros_yaml(path: &Path, camera: &Camera) -> Result<(), FileError> {
    check_finite(path, camera, 0.0)?;
    let Intrinsics { fx, fy, cx, cy } = camera.intrinsics;
    let matrix = |name: &str, rows: usize, cols: usize, data: &[f64]| {
        format!(
            "{name}:\n  rows: {rows}\n  cols: {cols}\n  data: [{}]\n",
            list(data)
        )
    };
    let text = format!(
        "image_width: {}\nimage_height: {}\ncamera_name: {}\n{}distortion_model: plumb_bob\n{}{}{}",
        camera.image_size.width,
        camera.image_size.height,
        camera.name,
        matrix(
            "camera_matrix",
            3,
            3,
            &[fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
        ),
        matrix(
            "distortion_coefficients",
            1,
            5,
            &camera.distortion.to_opencv()
        ),
        matrix(
            "rectification_matrix",
            3,
            3,
            &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        ),
        matrix(
            "projection_matrix",
            3,
            4,
            &[fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
        ),
    );
    write_atomically(path, text.as_bytes())
}

/// A number as YAML reads it back exactly (Rust's shortest round-trip form).
fn number(value: f64) -> String {
    let text = format!("{value:?}");
    text
}

fn list(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| number(*v))
        .collect::<Vec<_>>()
        .join(", ")
}

fn check_finite(path: &Path, camera: &Camera, rms_px: f64) -> Result<(), FileError> {
    let Intrinsics { fx, fy, cx, cy } = camera.intrinsics;
    let all = [fx, fy, cx, cy, rms_px]
        .into_iter()
        .chain(camera.distortion.to_opencv())
        .chain(camera.camera_from_world.translation.vector.iter().copied())
        .chain(camera.camera_from_world.rotation.coords.iter().copied());
    for value in all {
        if !value.is_finite() {
            return Err(FileError::invalid(
                path,
                "refusing to write a camera with a non-finite number",
            ));
        }
    }
    Ok(())
}

/// A top-level YAML key: its scalar (or tag) and nested `key: value` lines.
#[derive(Debug, Default)]
struct Entry {
    line: usize,
    value: String,
    children: BTreeMap<String, (usize, String)>,
}

/// Parses the YAML subset into top-level entries.
fn parse_entries(path: &Path, text: &str) -> Result<BTreeMap<String, Entry>, FileError> {
    let mut entries: BTreeMap<String, Entry> = BTreeMap::new();
    let mut current: Option<String> = None;
    // An open flow list: (top key, child key, line, text so far).
    let mut open: Option<(String, String, usize, String)> = None;
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        if let Some((top, child, start, mut so_far)) = open.take() {
            so_far.push(' ');
            so_far.push_str(raw.trim());
            if raw.contains(']') {
                insert_child(&mut entries, &top, child, start, so_far);
            } else {
                open = Some((top, child, start, so_far));
            }
            continue;
        }
        let content = raw.split('#').next().unwrap_or("").trim_end();
        let trimmed = content.trim_start();
        if trimmed.is_empty() || trimmed.starts_with('%') || trimmed == "---" || trimmed == "..." {
            continue;
        }
        let Some((key, value)) = trimmed.split_once(':') else {
            return Err(FileError::invalid_line(
                path,
                line,
                format!("expected `key: value`, got `{trimmed}`"),
            ));
        };
        let key = key.trim().to_owned();
        let value = value.trim().to_owned();
        let indented = content.len() != trimmed.len();
        if indented {
            let Some(top) = current.clone() else {
                return Err(FileError::invalid_line(
                    path,
                    line,
                    "indented line without a parent key",
                ));
            };
            if value.starts_with('[') && !value.contains(']') {
                open = Some((top, key, line, value));
            } else {
                insert_child(&mut entries, &top, key, line, value);
            }
        } else {
            if entries.contains_key(&key) {
                return Err(FileError::invalid_line(
                    path,
                    line,
                    format!("{key} appears twice"),
                ));
            }
            entries.insert(
                key.clone(),
                Entry {
                    line,
                    value,
                    children: BTreeMap::new(),
                },
            );
            current = Some(key);
        }
    }
    if let Some((top, child, start, _)) = open {
        return Err(FileError::invalid_line(
            path,
            start,
            format!("{top}.{child}: the list is not closed with ]"),
        ));
    }
    Ok(entries)
}

fn insert_child(
    entries: &mut BTreeMap<String, Entry>,
    top: &str,
    key: String,
    line: usize,
    value: String,
) {
    if let Some(entry) = entries.get_mut(top) {
        entry.children.insert(key, (line, value));
    }
}

/// A scalar number at `line`.
fn parse_number(path: &Path, line: usize, what: &str, text: &str) -> Result<f64, FileError> {
    let text = text.trim().trim_matches('"');
    let value: f64 = text.parse().map_err(|_| {
        FileError::invalid_line(path, line, format!("{what}: `{text}` is not a number"))
    })?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(FileError::invalid_line(
            path,
            line,
            format!("{what} is not finite"),
        ))
    }
}

/// A matrix entry: `rows`, `cols` and `data` of the right length.
fn matrix(
    path: &Path,
    entries: &BTreeMap<String, Entry>,
    key: &str,
) -> Result<(usize, usize, Vec<f64>), FileError> {
    let entry = entries
        .get(key)
        .ok_or_else(|| FileError::invalid(path, format!("{key} is missing")))?;
    let child = |name: &str| {
        entry.children.get(name).ok_or_else(|| {
            FileError::invalid_line(path, entry.line, format!("{key}: {name} is missing"))
        })
    };
    let count = |name: &str| -> Result<usize, FileError> {
        let (line, text) = child(name)?;
        text.trim().parse().map_err(|_| {
            FileError::invalid_line(
                path,
                *line,
                format!("{key}.{name}: `{text}` is not a count"),
            )
        })
    };
    let rows = count("rows")?;
    let cols = count("cols")?;
    let (line, text) = child("data")?;
    let inner = text
        .trim()
        .strip_prefix('[')
        .and_then(|t| t.trim_end().strip_suffix(']'))
        .ok_or_else(|| {
            FileError::invalid_line(path, *line, format!("{key}.data: expected [ ... ]"))
        })?;
    let data = inner
        .split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .map(|t| parse_number(path, *line, &format!("{key}.data"), t))
        .collect::<Result<Vec<f64>, _>>()?;
    if data.len() != rows * cols {
        return Err(FileError::invalid_line(
            path,
            *line,
            format!("{key}: {} numbers for {rows}x{cols}", data.len()),
        ));
    }
    Ok((rows, cols, data))
}

/// Parses OpenCV or ROS calibration YAML.
fn parse_camera_yaml(path: &Path, text: &str, stem: &str) -> Result<CameraCalibration, FileError> {
    let entries = parse_entries(path, text)?;
    let size = |key: &str| -> Result<u32, FileError> {
        let entry = entries
            .get(key)
            .ok_or_else(|| FileError::invalid(path, format!("{key} is missing")))?;
        match entry.value.trim().parse::<u32>() {
            Ok(v) if v > 0 => Ok(v),
            _ => Err(FileError::invalid_line(
                path,
                entry.line,
                format!("{key}: `{}` is not a positive pixel count", entry.value),
            )),
        }
    };
    let image_size = ImageSize {
        width: size("image_width")?,
        height: size("image_height")?,
    };
    let (rows, cols, k) = matrix(path, &entries, "camera_matrix")?;
    if (rows, cols) != (3, 3) {
        return Err(FileError::invalid(
            path,
            format!("camera_matrix is {rows}x{cols}, not 3x3"),
        ));
    }
    if k[1] != 0.0 {
        return Err(FileError::invalid(
            path,
            format!(
                "camera_matrix has skew {} (the camera model has none)",
                k[1]
            ),
        ));
    }
    if k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err(FileError::invalid(
            path,
            "camera_matrix: last row must be [0, 0, 1] and K[1][0] = 0",
        ));
    }
    if !(k[0] > 0.0 && k[4] > 0.0) {
        return Err(FileError::invalid(
            path,
            "camera_matrix: focal lengths must be positive",
        ));
    }
    if let Some(model) = entries.get("distortion_model") {
        let name = model.value.trim().trim_matches('"');
        if name != "plumb_bob" && name != "rational_polynomial" {
            return Err(FileError::invalid_line(
                path,
                model.line,
                format!("distortion_model {name} is not supported (plumb_bob only)"),
            ));
        }
    }
    let (_, _, d) = matrix(path, &entries, "distortion_coefficients")?;
    // OpenCV's longer models (8, 12, 14 coefficients) reduce to ours when the extra terms are 0.
    if !matches!(d.len(), 4 | 5 | 8 | 12 | 14) || d.iter().skip(5).any(|v| *v != 0.0) {
        return Err(FileError::invalid(
            path,
            format!(
                "distortion_coefficients: {} coefficients with non-zero terms beyond [k1, k2, p1, p2, k3] are not supported",
                d.len()
            ),
        ));
    }
    let k3 = d.get(4).copied().unwrap_or(0.0);
    let rms_px = match entries.get("avg_reprojection_error") {
        Some(entry) => Some(parse_number(
            path,
            entry.line,
            "avg_reprojection_error",
            &entry.value,
        )?),
        None => None,
    };
    let name = entries
        .get("camera_name")
        .map(|e| e.value.trim().trim_matches('"').to_owned())
        .filter(|n| !n.is_empty())
        .unwrap_or_else(|| stem.to_owned());
    Ok(CameraCalibration {
        camera: Camera {
            name,
            image_size,
            intrinsics: Intrinsics {
                fx: k[0],
                fy: k[4],
                cx: k[2],
                cy: k[5],
            },
            distortion: Distortion::from_opencv([d[0], d[1], d[2], d[3], k3]),
            camera_from_world: Pose::identity(),
        },
        rms_px,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn camera() -> Camera {
        Camera {
            name: "cam0".into(),
            image_size: ImageSize {
                width: 640,
                height: 480,
            },
            intrinsics: Intrinsics {
                fx: 536.073_453_139_207_8,
                fy: 536.016_362_745_337_8,
                cx: 342.370_468_258_061_35,
                cy: 235.536_870_651_115_75,
            },
            distortion: Distortion::from_opencv([-0.265, -0.0467, 0.00183, -0.000315, 0.2523]),
            camera_from_world: Pose::identity(),
        }
    }

    #[test]
    fn every_format_round_trips_exactly() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let c = camera();
        let json = dir.path().join("cam0.json");
        write_camera_json(&json, &c, 0.25).unwrap_or_else(|e| panic!("{e}"));
        let back = read_camera(&json).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.camera, c);
        assert_eq!(back.rms_px, Some(0.25));
        let opencv = dir.path().join("cam0.yaml");
        write_opencv_yaml(&opencv, &c, 0.25).unwrap_or_else(|e| panic!("{e}"));
        let back = read_camera(&opencv).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.camera, c);
        assert_eq!(back.rms_px, Some(0.25));
        let ros = dir.path().join("ros.yml");
        write_ros_yaml(&ros, &c).unwrap_or_else(|e| panic!("{e}"));
        let back = read_camera(&ros).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.camera, c);
    }

    #[test]
    fn nan_is_never_written() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let mut c = camera();
        c.intrinsics.cx = f64::NAN;
        let path = dir.path().join("bad.json");
        assert!(write_camera_json(&path, &c, 0.1).is_err());
        assert!(write_opencv_yaml(&dir.path().join("bad.yaml"), &c, 0.1).is_err());
        assert!(!path.exists());
    }

    /// The documented ROS layout (camera_calibration_parsers), written by hand.
    #[test]
    fn reads_ros_camera_info() {
        let text = [
            "image_width: 640",
            "image_height: 480",
            "camera_name: narrow_stereo",
            "camera_matrix:",
            "  rows: 3",
            "  cols: 3",
            "  data: [500.5, 0, 320.25, 0, 501.0, 240.5, 0, 0, 1]",
            "distortion_model: plumb_bob",
            "distortion_coefficients:",
            "  rows: 1",
            "  cols: 5",
            "  data: [-0.1, 0.01, 0.001, -0.002, 0]",
            "rectification_matrix:",
            "  rows: 3",
            "  cols: 3",
            "  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]",
            "projection_matrix:",
            "  rows: 3",
            "  cols: 4",
            "  data: [500.5, 0, 320.25, 0, 0, 501.0, 240.5, 0, 0, 0, 1, 0]",
        ]
        .join("\n");
        let text = text.as_str();
        let c =
            parse_camera_yaml(Path::new("ros.yaml"), text, "x").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(c.camera.name, "narrow_stereo");
        assert_eq!(c.camera.intrinsics.cx, 320.25);
        assert_eq!(c.camera.distortion.p2, -0.002);
    }

    #[test]
    fn refusals_name_the_line_or_key() {
        let path = Path::new("c.yaml");
        let base = "image_width: 640\nimage_height: 480\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 2, 0, 1, 2, 0, 0, 1]\n";
        let err = |text: &str| {
            parse_camera_yaml(path, text, "c")
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        assert_eq!(err(base), "c.yaml: distortion_coefficients is missing");
        let text = format!(
            "{base}distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [0, 0, 0, x, 0]\n"
        );
        assert_eq!(
            err(&text),
            "c.yaml:10: distortion_coefficients.data: `x` is not a number"
        );
        let text = format!(
            "{base}distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [0, 0,\n 0, 0\n"
        );
        assert_eq!(
            err(&text),
            "c.yaml:10: distortion_coefficients.data: the list is not closed with ]"
        );
        let skewed = base.replace("[1, 0, 2", "[1, 0.5, 2");
        assert!(
            err(&format!(
                "{skewed}distortion_coefficients:\n  rows: 1\n  cols: 4\n  data: [0, 0, 0, 0]\n"
            ))
            .contains("skew")
        );
    }

    proptest! {
        /// Any text, or any line of a valid file replaced by noise: an answer or an error,
        /// never a panic.
        #[test]
        fn parser_never_panics(text in "\\PC{0,300}", line in 0usize..20, noise in "[ -~]{0,40}") {
            let _ = parse_camera_yaml(Path::new("f.yaml"), &text, "f");
            let valid = "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 5.0e+02, 0., 3.2e+02, 0.,\n       5.0e+02, 2.4e+02, 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ -0.2, 0.1, 0., 0., 0. ]\n";
            let mut lines: Vec<&str> = valid.lines().collect();
            let at = line % lines.len();
            lines[at] = &noise;
            let _ = parse_camera_yaml(Path::new("f.yaml"), &lines.join("\n"), "f");
        }
    }
}
