//! Calibration on real photographs and Zhang's data, against stored OpenCV references
//! (`scripts/reference/calib_opencv.py` → `tests/data/calib_opencv_reference.json`).

use std::path::PathBuf;

use serde_json::Value;
use teachcam::calib::Chessboard;
use teachcam::calib::chessboard::{CornerConfig, find_chessboard_corners, gray_like_opencv};
use teachcam::geometry::Pixel;

/// `../shared/data/calib`, or `None` (test skipped) when absent outside CI.
fn calib_data() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/calib");
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "test data folder {} is missing (CI is set, so this is a failure)",
        dir.display()
    );
    eprintln!("skipped: test data folder {} is missing", dir.display());
    None
}

fn reference() -> Value {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/calib_opencv_reference.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

const BOARD: Chessboard = Chessboard {
    inner_cols: 9,
    inner_rows: 6,
    square_mm: 25.0,
};

fn reference_corners(reference: &Value, key: &str) -> Option<Vec<Pixel>> {
    reference["corners"][key].as_array().map(|points| {
        points
            .iter()
            .map(|p| {
                Pixel::new(
                    p[0].as_f64().unwrap_or(f64::NAN),
                    p[1].as_f64().unwrap_or(f64::NAN),
                )
            })
            .collect()
    })
}

fn load_gray(path: &std::path::Path) -> image::GrayImage {
    let image = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    gray_like_opencv(&image)
}

/// Boards OpenCV finds and we do not (yet): squares of about 5 px after blur, where two corners
/// fall under the saddle threshold (notes/calib.md).
const KNOWN_MISSES: [&str; 1] = ["caliscope-4cam-chessboard-9x6/cam_0_frame_100.jpg"];

/// Every image of both real sets: found exactly where OpenCV finds a board, in OpenCV's order.
#[test]
fn corners_match_opencv_on_real_photographs() {
    let Some(data) = calib_data() else { return };
    let reference = reference();
    let keys: Vec<String> = reference["corners"]
        .as_object()
        .map(|o| o.keys().cloned().collect())
        .unwrap_or_default();
    assert_eq!(keys.len(), 34, "reference lists every image");
    let config = CornerConfig::default();
    let mut all_differences = Vec::new();
    let mut failures = Vec::new();
    let mut missed: Vec<String> = Vec::new();
    for key in &keys {
        let image = load_gray(&data.join(key));
        let ours = find_chessboard_corners(&image, &BOARD, &config);
        match (reference_corners(&reference, key), ours) {
            (None, Err(_)) => {}
            (None, Ok(_)) => failures.push(format!("{key}: OpenCV finds no board, we found one")),
            (Some(_), Err(e)) if KNOWN_MISSES.contains(&key.as_str()) => {
                eprintln!("{key}: known miss: {e}");
                missed.push(key.clone());
            }
            (Some(_), Err(e)) => {
                failures.push(format!("{key}: OpenCV finds the board, we do not: {e}"));
            }
            (Some(theirs), Ok(ours)) => {
                assert_eq!(ours.len(), theirs.len(), "{key}");
                let d: Vec<f64> = ours
                    .iter()
                    .zip(&theirs)
                    .map(|(a, b)| a.distance(b))
                    .collect();
                let max = d.iter().copied().fold(0.0, f64::max);
                let mean = d.iter().sum::<f64>() / d.len() as f64;
                eprintln!("{key}: mean {mean:.4} px, max {max:.4} px");
                if max > 0.1 {
                    failures.push(format!("{key}: max difference {max:.3} px"));
                }
                all_differences.extend(d);
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
    assert_eq!(
        missed, KNOWN_MISSES,
        "a known miss is now found: update KNOWN_MISSES"
    );
    let mean = all_differences.iter().sum::<f64>() / all_differences.len() as f64;
    let max = all_differences.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "all: {} corners, mean {mean:.4} px, max {max:.4} px",
        all_differences.len()
    );
    // Same algorithm, same window: differences come from JPEG decoding (±1 grey level) and the
    // stopping rule (0.001 px); a wrong order or a wrong corner would be ≥ 20 px.
    assert!(mean < 0.02, "mean difference {mean} px");
    assert!(max < 0.1, "max difference {max} px");
}
