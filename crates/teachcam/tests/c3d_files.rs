//! The C3D reader against the eight real files in `../shared/data/c3d`, compared with numbers
//! extracted by ezc3d 1.7.2 (`scripts/reference/c3d_reference.py`, stored in
//! `tests/data/c3d/*.json`).

use std::path::PathBuf;

use serde::Deserialize;
use teachcam::c3d::{self, PointData};
use teachcam::geometry::FrameIndex;

/// The shared data folder, or `None` (test skipped) when it is absent outside CI.
fn data_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/c3d");
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but the test data folder {} is missing",
        dir.display()
    );
    eprintln!("skipped: test data folder {} is missing", dir.display());
    None
}

/// The fourth word of a point, decoded by the reference script from the raw bytes.
#[derive(Debug, Deserialize)]
struct Word {
    residual: f64,
    camera_mask: u8,
}

#[derive(Debug, Deserialize)]
struct Reference {
    file: String,
    processor: u8,
    labels: Vec<String>,
    rate_hz: f64,
    units: String,
    frames: usize,
    header_first_frame: usize,
    middle_frame: usize,
    first_frame: Vec<Option<[f64; 3]>>,
    middle: Vec<Option<[f64; 3]>>,
    last: Vec<Option<[f64; 3]>>,
    first_words: Vec<Option<Word>>,
    middle_words: Vec<Option<Word>>,
    invalid_per_marker: Vec<usize>,
    valid_sum_per_marker: Vec<[f64; 3]>,
}

fn reference(stem: &str) -> Reference {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/c3d")
        .join(format!("{stem}.json"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Stored values are 32-bit floats or 16-bit integers times a 32-bit scale: two readers agree
/// to a few float32 steps of the value.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 4.0 * f64::from(f32::EPSILON) * a.abs().max(b.abs()).max(1.0)
}

fn check_frame(points: &PointData, frame: usize, expected: &[Option<[f64; 3]>], file: &str) {
    assert_eq!(expected.len(), points.marker_count(), "{file}");
    for (marker, want) in expected.iter().enumerate() {
        let got = points.sample(FrameIndex(frame), marker);
        match (got, want) {
            (None, None) => {}
            (Some(s), Some(w)) => {
                let g = [s.position.x, s.position.y, s.position.z];
                for axis in 0..3 {
                    assert!(
                        close(g[axis], w[axis]),
                        "{file} frame {frame} marker {marker} axis {axis}: {} vs ezc3d {}",
                        g[axis],
                        w[axis]
                    );
                }
            }
            _ => panic!("{file} frame {frame} marker {marker}: validity {got:?} vs ezc3d {want:?}"),
        }
    }
}

/// Residual and camera mask where the word is valid; a negative word is a gap. A valid word
/// with non-finite coordinates is a gap too (ezc3d agrees: `check_frame`).
fn check_words(points: &PointData, frame: usize, expected: &[Option<Word>], file: &str) {
    for (marker, want) in expected.iter().enumerate() {
        let got = points.sample(FrameIndex(frame), marker);
        match (got, want) {
            (Some(g), Some(w)) => {
                assert!(
                    close(g.residual, w.residual) && g.camera_mask == w.camera_mask,
                    "{file} frame {frame} marker {marker}: {g:?} vs {w:?}"
                );
            }
            (Some(g), None) => panic!("{file} frame {frame} marker {marker}: {g:?} vs a gap"),
            (None, _) => {}
        }
    }
}

fn check_file(stem: &str) {
    let Some(dir) = data_dir() else { return };
    let want = reference(stem);
    let file = dir.join(&want.file);
    let c3d = c3d::read_file(&file).unwrap_or_else(|e| panic!("{e}"));
    let points = &c3d.points;
    let processor = match c3d.processor {
        c3d::Processor::Intel => 1,
        c3d::Processor::Dec => 2,
        c3d::Processor::Mips => 3,
    };
    assert_eq!(processor, want.processor, "{stem} processor");
    assert_eq!(points.labels, want.labels, "{stem} labels");
    assert_eq!(points.rate_hz, want.rate_hz, "{stem} rate");
    assert_eq!(points.units, want.units, "{stem} units");
    assert_eq!(points.frame_count(), want.frames, "{stem} frames");
    // ezc3d reports the header's first frame 0-based (and clamps 0 to 0).
    let first = usize::from(c3d.header.first_frame).saturating_sub(1);
    assert_eq!(first, want.header_first_frame, "{stem} first frame");
    check_frame(points, 0, &want.first_frame, stem);
    check_frame(points, want.middle_frame, &want.middle, stem);
    check_frame(points, want.frames - 1, &want.last, stem);
    check_words(points, 0, &want.first_words, stem);
    check_words(points, want.middle_frame, &want.middle_words, stem);
    for marker in 0..points.marker_count() {
        let mut invalid = 0;
        let mut sum = [0.0; 3];
        for frame in 0..points.frame_count() {
            match points.sample(FrameIndex(frame), marker) {
                Some(s) => {
                    sum[0] += s.position.x;
                    sum[1] += s.position.y;
                    sum[2] += s.position.z;
                }
                None => invalid += 1,
            }
        }
        assert_eq!(
            invalid, want.invalid_per_marker[marker],
            "{stem} marker {marker} gaps"
        );
        for axis in 0..3 {
            let w = want.valid_sum_per_marker[marker][axis];
            // Summation order differs (numpy pairwise vs sequential): relative 1e-9 is far
            // above that rounding and far below any single wrong sample.
            assert!(
                (sum[axis] - w).abs() <= 1e-9 * w.abs().max(1.0) * points.frame_count() as f64,
                "{stem} marker {marker} axis {axis} sum {} vs ezc3d {w}",
                sum[axis]
            );
        }
    }
}

#[test]
fn c3dorg_sample01_integer_storage() {
    check_file("c3dorg_sample01_Eb015pi");
}

#[test]
fn ezc3d_optotrak_header_frame_count_disagrees() {
    check_file("ezc3d_Optotrak");
}

#[test]
fn ezc3d_qualisys() {
    check_file("ezc3d_Qualisys");
}

#[test]
fn ezc3d_vicon() {
    check_file("ezc3d_Vicon");
}

#[test]
fn ktk_basket_sprint_optitrack() {
    check_file("ktk_basket_sprint_optitrack");
}

#[test]
fn ktk_racing_probing_acromion() {
    check_file("ktk_racing_probing_acromion_R");
}

#[test]
fn ktk_racing_probing_olecrane() {
    check_file("ktk_racing_probing_olecrane_R");
}

#[test]
fn ktk_racing_static_all_probe_samples_invalid() {
    check_file("ktk_racing_static");
}

/// NDI's export declares 1149 frames (header and `POINT:FRAMES`) and holds 29 whole frames:
/// the reader keeps the claim beside what it read.
#[test]
fn optotrak_declared_frames_kept() {
    let Some(dir) = data_dir() else { return };
    let c3d = c3d::read_file(&dir.join("ezc3d_Optotrak.c3d")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(c3d.declared_frames, 1149);
    assert_eq!(c3d.points.frame_count(), 29);
}
