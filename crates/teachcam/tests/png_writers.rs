//! Frames other programs wrote decode in teachcam's one pass (`io::gray_png`) to the pixels
//! the general decoder (`image`) gives: OpenCV and PIL at zlib levels 0–9 (small files made
//! by `scripts/reference/png_writer_fixtures.py`), FFmpeg's PNG encoder at every level and
//! row filter (written here when `ffmpeg` is on the path: skipped with a message elsewhere, a
//! failure under CI).

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::print_stderr,
    reason = "a test fails loudly on a broken fixture and says why it skipped"
)]

use std::path::Path;
use std::process::Command;

use image::GrayImage;
use teachcam::io::gray_png::{decode_gray8, gray8_header};
use teachcam::io::recording::{GrayFrame, read_frame};

fn general(bytes: &[u8]) -> GrayImage {
    image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .expect("the general decoder reads it")
        .into_luma8()
}

/// The fast path takes the file and gives the general decoder's pixels; so does
/// `read_frame`.
fn check(path: &Path) -> GrayImage {
    let bytes = std::fs::read(path).unwrap();
    assert!(gray8_header(&bytes).is_some(), "{}: header", path.display());
    let fast = decode_gray8(&bytes);
    let reference = general(&bytes);
    assert!(
        fast.is_some(),
        "{}: refused by the fast path",
        path.display()
    );
    assert!(
        fast.as_ref() == Some(&reference),
        "{}: other pixels than the general decoder's",
        path.display()
    );
    let GrayFrame::Eight(read) = read_frame(path, None).unwrap() else {
        panic!("{}: not an 8-bit frame", path.display());
    };
    assert!(read == reference, "{}: read_frame differs", path.display());
    reference
}

#[test]
fn opencv_and_pil_frames_decode_in_one_pass() {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/png_writers");
    let mut names: Vec<_> = std::fs::read_dir(&folder)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .collect();
    names.sort();
    assert_eq!(names.len(), 9, "fixtures: {names:?}");
    let first = check(&names[0]);
    for path in &names[1..] {
        // Every writer wrote the same image.
        assert!(check(path) == first, "{}: other image", path.display());
    }
}

#[test]
fn ffmpeg_frames_decode_in_one_pass_at_every_level_and_filter() {
    if !teachcam_testdata::ffmpeg("png_writers") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let source =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/png_writers/opencv_default.png");
    let expected = general(&std::fs::read(&source).unwrap());
    let mut cases: Vec<(u32, &str)> = (0..=9).map(|level| (level, "mixed")).collect();
    cases.extend(["none", "sub", "up", "avg", "paeth"].map(|pred| (1, pred)));
    for (level, pred) in cases {
        let out = dir.path().join(format!("ffmpeg_{level}_{pred}.png"));
        let status = Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-y", "-i"])
            .arg(&source)
            .args(["-compression_level", &level.to_string(), "-pred", pred])
            .arg(&out)
            .status()
            .unwrap();
        assert!(status.success(), "ffmpeg level {level} pred {pred}");
        assert!(
            check(&out) == expected,
            "level {level} pred {pred}: other image"
        );
    }
}
