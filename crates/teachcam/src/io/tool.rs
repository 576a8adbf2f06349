//! `tool.json`: the tool's markers and tip (CONTRACT.md, "Tool file").
//!
//! ```json
//! {"name": "brush", "marker_diameter_mm": 10.0,
//!  "markers": [[0, 0, 0], [62, 8, 0], [18, 47, 9], [-26, 71, 22]],
//!  "tip": [0, -15, -180], "tip_rotation": [1, 0, 0, 0]}
//! ```
//! `tip_rotation` (optional, `qw, qx, qy, qz`) turns the TCP frame relative to the tool frame;
//! `"axisymmetric": true` (optional) says the tool is symmetric about the TCP's z, so the robot
//! may choose the rotation about it ([`read_axisymmetric`]).

use std::path::Path;

use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};

use super::{FileError, json_text, parse_json, read_text, write_atomically};
use crate::geometry::{Point3, Quat, pose_from_parts};
use crate::tool::Tool;

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToolFile {
    name: String,
    marker_diameter_mm: f64,
    markers: Vec<[f64; 3]>,
    tip: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tip_rotation: Option<[f64; 4]>,
    /// True for a tool symmetric about the TCP's z (a round brush, a nozzle): the robot may
    /// choose the rotation about it ([`crate::robot::free_axis`]). Optional, default false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    axisymmetric: bool,
}

/// True when a tool file says `"axisymmetric": true` (the robot may turn the tool about its
/// TCP's z); false when it says false or nothing.
///
/// # Errors
/// [`FileError`] as [`read_tool`].
pub fn read_axisymmetric(path: &Path) -> Result<bool, FileError> {
    let file: ToolFile = parse_json(path, &read_text(path)?)?;
    Ok(file.axisymmetric)
}

/// Reads and checks a tool file.
///
/// # Errors
/// [`FileError`] naming the file and the field: unreadable, not JSON, a missing key, a
/// non-unit `tip_rotation`, or a tool that cannot be tracked ([`crate::tool::ToolError`]).
pub fn read_tool(path: &Path) -> Result<Tool, FileError> {
    let file: ToolFile = parse_json(path, &read_text(path)?)?;
    let rotation = match file.tip_rotation {
        None => UnitQuaternion::identity(),
        Some([w, x, y, z]) => Quat { w, x, y, z }.to_rotation().ok_or_else(|| {
            FileError::invalid(
                path,
                "tip_rotation is not a finite unit quaternion (qw, qx, qy, qz)",
            )
        })?,
    };
    let markers = file
        .markers
        .iter()
        .map(|m| Point3::new(m[0], m[1], m[2]))
        .collect();
    let tool_from_tcp = pose_from_parts(nalgebra::Vector3::from(file.tip), rotation);
    let tool = Tool::new(file.name, file.marker_diameter_mm, markers, tool_from_tcp)
        .map_err(|e| FileError::invalid(path, e.to_string()))?;
    check_tip_outside_markers(path, &tool)?;
    Ok(tool)
}

/// The tip is where the tool touches the work, outside every marker's sphere: a tip inside one
/// (a tip in metres beside markers in millimetres lands there) is refused. A tip exactly at a
/// marker's centre is a frame without a tip (a ground frame, a tool built from a C3D file
/// whose origin is a marker) and is taken.
fn check_tip_outside_markers(path: &Path, tool: &Tool) -> Result<(), FileError> {
    let tip = tool.tip_in_tool();
    let radius_mm = 0.5 * tool.marker_diameter_mm;
    for (i, marker) in tool.markers_in_tool.iter().enumerate() {
        let distance_mm = (tip - marker).norm();
        if distance_mm > 0.0 && distance_mm < radius_mm {
            return Err(FileError::invalid(
                path,
                format!(
                    "tip [{}, {}, {}] lies inside marker {i}'s sphere ({distance_mm:.3} mm from its centre, radius {radius_mm} mm): the tip must be outside the spheres, in millimetres (was it given in metres?)",
                    tip.x, tip.y, tip.z
                ),
            ));
        }
    }
    Ok(())
}

/// Writes a tool file whole.
///
/// # Errors
/// [`FileError::Write`].
pub fn write_tool(path: &Path, tool: &Tool) -> Result<(), FileError> {
    write_atomically(path, tool_json(path, tool)?.as_bytes())
}

/// The text of a tool file (for an [`super::OutputSet`]); `path` names the file in errors.
///
/// # Errors
/// [`FileError::Write`] when the tool cannot be serialised.
pub fn tool_json(path: &Path, tool: &Tool) -> Result<String, FileError> {
    let rotation = tool.tool_from_tcp.rotation;
    let file = ToolFile {
        name: tool.name.clone(),
        marker_diameter_mm: tool.marker_diameter_mm,
        markers: tool
            .markers_in_tool
            .iter()
            .map(|p| [p.x, p.y, p.z])
            .collect(),
        tip: tool.tool_from_tcp.translation.vector.into(),
        tip_rotation: (rotation.angle() > 0.0).then(|| Quat::from_rotation(&rotation).to_array()),
        axisymmetric: false,
    };
    json_text(path, &file)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, text: &str) -> std::path::PathBuf {
        let path = dir.join("tool.json");
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn reads_the_contract_example_and_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(
            dir.path(),
            r#"{"name": "brush", "marker_diameter_mm": 10.0,
            "markers": [[0, 0, 0], [62, 8, 0], [18, 47, 9], [-26, 71, 22]], "tip": [0, -15, -180]}"#,
        );
        let tool = read_tool(&path).unwrap();
        assert_eq!(tool.markers_in_tool.len(), 4);
        assert_eq!(tool.tip_in_tool(), Point3::new(0.0, -15.0, -180.0));
        let out = dir.path().join("out.json");
        write_tool(&out, &tool).unwrap();
        assert_eq!(read_tool(&out).unwrap(), tool);
        // Without "axisymmetric" a tool is not; with it, the same tool that is.
        assert!(!read_axisymmetric(&path).unwrap());
        let round = write(
            dir.path(),
            r#"{"name": "brush", "marker_diameter_mm": 10.0, "axisymmetric": true,
            "markers": [[0, 0, 0], [62, 8, 0], [18, 47, 9], [-26, 71, 22]], "tip": [0, -15, -180]}"#,
        );
        assert!(read_axisymmetric(&round).unwrap());
        assert_eq!(read_tool(&round).unwrap(), tool);
    }

    #[test]
    fn refuses_bad_files_naming_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            (
                r#"{"name": "b", "marker_diameter_mm": 10, "markers": [[0,0,0],[50,0,0],[0,50,0]]}"#,
                "tip",
            ),
            (
                r#"{"name": "b", "marker_diameter_mm": 10, "markers": [[0,0,0],[50,0,0]], "tip": [0,0,0]}"#,
                "at least 3",
            ),
            (
                r#"{"name": "b", "marker_diameter_mm": 10, "markers": [[0,0,0],[50,0,0],[100,0,0]], "tip": [0,0,0]}"#,
                "collinear",
            ),
            (
                // A brush written in metres (markers 50 mm apart, 10 mm spheres).
                r#"{"name": "b", "marker_diameter_mm": 0.01, "markers": [[0,0,0],[0.05,0,0],[0,0.05,0]], "tip": [0,0,0.15]}"#,
                "given in metres",
            ),
            (
                r#"{"name": "b", "marker_diameter_mm": 10, "markers": [[0,0,0],[50,0,0],[0,50,0]], "tip": [0,0,0], "tip_rotation": [1,1,0,0]}"#,
                "tip_rotation",
            ),
            (
                r#"{"name": "b", "marker_diameter_mm": 10, "markers": [[0,0,0],[50,0],[0,50,0]], "tip": [0,0,0]}"#,
                "line 1",
            ),
            ("not json", "tool.json"),
            (
                // The tip in metres (0.19 m along -z) beside markers in millimetres: inside
                // marker 0's sphere (second campaign F6).
                r#"{"name": "b", "marker_diameter_mm": 10, "markers": [[0,0,0],[50,0,0],[0,50,0]], "tip": [0.005,0.02,-0.19]}"#,
                "inside marker 0's sphere",
            ),
        ];
        for (text, needle) in cases {
            let message = read_tool(&write(dir.path(), text)).unwrap_err().to_string();
            assert!(
                message.contains(needle) && message.contains("tool.json"),
                "{text} -> {message}"
            );
        }
    }
}
