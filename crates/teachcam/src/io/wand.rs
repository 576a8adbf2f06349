//! `wand.json`: a calibration wand's collinear markers (CONTRACT.md, `teachcam calibrate
//! wand`).
//!
//! ```json
//! {"name": "wand", "marker_diameter_mm": 14.0, "markers_mm": [0.0, 160.0, 500.0]}
//! {"name": "easywand", "marker_diameter_mm": 12.0, "markers_mm": [0.0, 660.0]}
//! ```
//! Two or three markers; three with the middle one off centre tell the ends apart in one
//! image, otherwise the cameras' agreement does.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{FileError, parse_json, read_text, write_json};
use crate::calib::wand::Wand;

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct WandFile {
    name: String,
    marker_diameter_mm: f64,
    markers_mm: Vec<f64>,
}

/// Reads and checks a wand file.
///
/// # Errors
/// [`FileError`] naming the file and the field: unreadable, not JSON, a missing key, not two
/// or three increasing positions a marker diameter apart.
pub fn read_wand(path: &Path) -> Result<Wand, FileError> {
    let file: WandFile = parse_json(path, &read_text(path)?)?;
    Wand::new(file.name, file.marker_diameter_mm, file.markers_mm)
        .map_err(|e| FileError::invalid(path, e.to_string()))
}

/// Writes a wand file whole.
///
/// # Errors
/// [`FileError::Write`].
pub fn write_wand(path: &Path, wand: &Wand) -> Result<(), FileError> {
    let file = WandFile {
        name: wand.name.clone(),
        marker_diameter_mm: wand.marker_diameter_mm,
        markers_mm: wand.markers_mm.clone(),
    };
    write_json(path, &file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_contract_wand_and_a_two_marker_one_and_refuses_four() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("wand.json");
        std::fs::write(
            &path,
            r#"{"name": "wand", "marker_diameter_mm": 14.0, "markers_mm": [0.0, 160.0, 500.0]}"#,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let wand = read_wand(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(wand.markers_mm, [0.0, 160.0, 500.0]);
        let out = dir.path().join("out.json");
        write_wand(&out, &wand).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(read_wand(&out).unwrap_or_else(|e| panic!("{e}")), wand);
        std::fs::write(
            &path,
            r#"{"name": "wand", "marker_diameter_mm": 12.0, "markers_mm": [0.0, 660.0]}"#,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let two = read_wand(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(two.markers_mm, [0.0, 660.0]);
        assert!((two.length_mm() - 660.0).abs() < 1e-12);
        assert!(!two.ends_told_apart());
        std::fs::write(
            &path,
            r#"{"name": "wand", "marker_diameter_mm": 14.0, "markers_mm": [0.0, 100.0, 250.0, 500.0]}"#,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let error = read_wand(&path)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(error.contains("2 or 3 collinear markers, got 4"), "{error}");
    }
}
