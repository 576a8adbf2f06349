//! Video files as camera streams, decoded by FFmpeg: a rendered recording encoded losslessly
//! (FFV1) and lossily (H.264, MPEG-4 part 2) tracks like its PNG frames; the real IR video reads
//! whole, its five markers found frame after frame.
//!
//! Needs `ffmpeg` and `ffprobe` on the path (`.ci/run` installs them): skipped with a message
//! elsewhere when they are missing, a failure under CI.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::print_stderr,
    reason = "a test fails loudly on a broken fixture and says why it skipped"
)]

use std::path::Path;
use std::process::Command;

use teachcam::detect::DetectConfig;
use teachcam::io::{rig::read_rig, tool::read_tool};
use teachcam::metrology::first_order;
use teachcam::pipeline::recording::{DetectOptions, learn_from_recording};
use teachcam::pipeline::{DetectStream, StreamOptions, TrackStream, TrackedFrame};
use teachcam::sim::{Scenario, build_scene, write_scene};
use teachcam::source::FrameSource;
use teachcam::source::folder::FolderSource;
use teachcam::track::gates::GateOverrides;

const FRAMES: usize = 12;

/// The paper's scene, its first frames as PNG folders in `root/png`.
fn render(root: &Path) -> teachcam::sim::Scene {
    let mut scene = build_scene(Scenario::Paper, 1);
    scene.truth.samples.truncate(FRAMES);
    write_scene(&scene, &root.join("png"), 1, &|| {}).unwrap();
    scene
}

/// `root/<name>/` with the rig, the tool and every camera encoded by ffmpeg with `codec`.
fn encode(root: &Path, name: &str, extension: &str, codec: &[&str]) -> std::path::PathBuf {
    let png = root.join("png");
    let out = root.join(name);
    std::fs::create_dir_all(&out).unwrap();
    for file in ["rig.json", "tool.json", "recording.json"] {
        std::fs::copy(png.join(file), out.join(file)).unwrap();
    }
    for camera in ["cam0", "cam1", "cam2"] {
        let status = Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-framerate", "30", "-i"])
            .arg(png.join(camera).join("%06d.png"))
            .args(codec)
            .arg(out.join(format!("{camera}.{extension}")))
            .status()
            .unwrap();
        assert!(status.success(), "ffmpeg {codec:?} failed");
    }
    out
}

fn track(root: &Path) -> Vec<TrackedFrame> {
    let rig = read_rig(&root.join("rig.json")).unwrap();
    let tool = read_tool(&root.join("tool.json")).unwrap();
    let learned = learn_from_recording(
        root,
        &rig,
        &tool,
        &DetectOptions::default(),
        &GateOverrides::default(),
    )
    .unwrap();
    let mut source = FolderSource::open(root, None).unwrap();
    TrackStream::new(&mut source, &rig, &tool, StreamOptions::recording(learned))
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap()
}

/// Every blob centre of a frame, camera by camera.
fn centres(frame: &TrackedFrame) -> Vec<Vec<(f64, f64)>> {
    frame
        .detections
        .cameras
        .iter()
        .map(|c| {
            c.as_ref()
                .unwrap()
                .blobs
                .iter()
                .map(|b| (b.center.x, b.center.y))
                .collect()
        })
        .collect()
}

#[test]
fn videos_track_like_their_png_frames() {
    if !teachcam_testdata::ffmpeg("video") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = render(dir.path());
    let png = track(&dir.path().join("png"));
    assert_eq!(png.len(), FRAMES);

    // Lossless: FFV1 in Matroska, gray samples kept exactly: the same detections, bit for bit.
    let ffv1 = track(&encode(
        dir.path(),
        "ffv1",
        "mkv",
        &["-c:v", "ffv1", "-pix_fmt", "gray"],
    ));
    assert_eq!(ffv1.len(), FRAMES);
    for (a, b) in png.iter().zip(&ffv1) {
        assert_eq!(centres(a), centres(b), "frame {}", a.detections.index);
        assert_eq!(a.track.outcome, b.track.outcome);
    }

    // Lossy: H.264 (CRF 18, the usual "visually lossless" setting) and MPEG-4 part 2 (q 2, as
    // the PS3 Eye recordings are). Every blob must still be found, and the tip must move only by
    // what the blobs moved: the centre shifts measured between PNG and video (σ per image
    // coordinate) propagated through the rig to the tip (first order), 4σ of the 3-D error.
    let rig = &scene.rig;
    let tool = &scene.tool;
    for (name, extension, codec) in [
        (
            "h264",
            "mp4",
            &["-c:v", "libx264", "-crf", "18", "-pix_fmt", "yuv420p"][..],
        ),
        (
            "mpeg4",
            "avi",
            &["-c:v", "mpeg4", "-q:v", "2", "-pix_fmt", "yuv420p"][..],
        ),
    ] {
        let lossy = track(&encode(dir.path(), name, extension, codec));
        assert_eq!(lossy.len(), FRAMES, "{name}");
        let mut shifts = Vec::new();
        for (a, b) in png.iter().zip(&lossy) {
            for (blobs_a, blobs_b) in centres(a).iter().zip(&centres(b)) {
                assert_eq!(
                    blobs_a.len(),
                    blobs_b.len(),
                    "{name}: frame {}",
                    a.detections.index
                );
                for (pa, pb) in blobs_a.iter().zip(blobs_b) {
                    shifts.push(pb.0 - pa.0);
                    shifts.push(pb.1 - pa.1);
                }
            }
        }
        let shift_px = (shifts.iter().map(|s| s * s).sum::<f64>() / shifts.len() as f64).sqrt();
        let largest_px = shifts.iter().fold(0.0f64, |m, s| m.max(s.abs()));
        eprintln!("{name}: centre shift {shift_px:.4} px RMS, largest {largest_px:.4} px");
        // A blob is the same detection when it moved by far less than its radius (≈ 5 px).
        assert!(largest_px < 1.0, "{name}: a centre moved {largest_px} px");
        for (a, b) in png.iter().zip(&lossy) {
            let (Ok(pa), Ok(pb)) = (&a.track.outcome, &b.track.outcome) else {
                panic!("{name}: frame {} lost a pose", a.detections.index);
            };
            let predicted = first_order(rig, tool, &pa.world_from_tool, shift_px)
                .unwrap()
                .tip_rms_mm;
            let moved = (pb.tip_in_world - pa.tip_in_world).norm();
            assert!(
                moved <= 4.0 * predicted,
                "{name}: frame {}: tip moved {moved:.4} mm, predicted σ {predicted:.4} mm",
                a.detections.index
            );
        }
    }
}

#[test]
fn the_real_ir_video_reads_whole_with_its_five_markers() {
    if !teachcam_testdata::ffmpeg("video") {
        return;
    }
    let Some(data) = teachcam_testdata::shared_data("real-ir") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(
        data.join("normal.avi").canonicalize().unwrap(),
        dir.path().join("cam0.avi"),
    )
    .unwrap();
    let mut source = FolderSource::open(dir.path(), None).unwrap();
    assert_eq!(source.cameras()[0].size, Some((752, 480)));
    assert_eq!(source.len_hint(), Some(402));
    assert!((source.fps() - 20.0).abs() < 1e-9, "the AVI's own rate");
    // This footage's markers are saturated, block-compressed discs of 23–450 px whose
    // roundness falls to 0.32 (measured over the 402 frames); the specks beside them are 4–5 px.
    let config = DetectConfig {
        min_roundness: 0.3,
        min_area_px: 20,
        ..DetectConfig::default()
    };
    let sets: Vec<_> = DetectStream::all_cameras(&mut source, &config)
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(sets.len(), 402);
    let blobs: Vec<Vec<(f64, f64)>> = sets
        .iter()
        .map(|s| {
            s.cameras[0]
                .as_ref()
                .unwrap()
                .blobs
                .iter()
                .map(|b| (b.center.x, b.center.y))
                .collect()
        })
        .collect();
    let five = blobs.iter().filter(|b| b.len() == 5).count();
    let more = blobs.iter().filter(|b| b.len() > 5).count();
    eprintln!("frames with five blobs: {five} of 402, with more: {more}");
    // Most frames show all five (the others lose one to occlusion or merging), none more.
    assert!(
        five * 100 >= 402 * 85,
        "five markers in {five} of 402 frames"
    );
    assert_eq!(more, 0);
    // Frame to frame, each centre's nearest centre in the next frame is a different marker's
    // (a one-to-one map) in every pair, and almost always lies closer than half the gap to the
    // nearest other marker, so the markers can be followed without ambiguity (measured: 332 of
    // 338 pairs; the others are the fastest moves of the hand, up to 18 px per frame).
    let distance = |a: &(f64, f64), b: &(f64, f64)| (a.0 - b.0).hypot(a.1 - b.1);
    let (mut pairs, mut one_to_one, mut followed) = (0, 0, 0);
    for pair in blobs.windows(2) {
        let (now, next) = (&pair[0], &pair[1]);
        if now.len() != 5 || next.len() != 5 {
            continue;
        }
        pairs += 1;
        let nearest: Vec<usize> = now
            .iter()
            .map(|a| {
                (0..5)
                    .min_by(|&i, &j| distance(a, &next[i]).total_cmp(&distance(a, &next[j])))
                    .unwrap()
            })
            .collect();
        let mut targets = nearest.clone();
        targets.sort_unstable();
        targets.dedup();
        let unambiguous = now.iter().zip(&nearest).all(|(a, &j)| {
            let gap = now
                .iter()
                .filter(|b| *b != a)
                .map(|b| distance(a, b))
                .fold(f64::INFINITY, f64::min);
            distance(a, &next[j]) < 0.5 * gap
        });
        one_to_one += usize::from(targets.len() == 5);
        followed += usize::from(targets.len() == 5 && unambiguous);
    }
    eprintln!("followed {followed} of {pairs} consecutive five-marker pairs");
    assert!(pairs > 300);
    assert_eq!(one_to_one, pairs);
    assert!(followed * 100 >= pairs * 95, "{followed} of {pairs}");
}

/// What `ffmpeg -pix_fmt gray` makes of `video`: every frame's bytes, one after another.
fn ffmpeg_gray(video: &Path) -> Vec<u8> {
    let output = Command::new("ffmpeg")
        .args(["-nostdin", "-v", "error", "-i"])
        .arg(video)
        .args(["-map", "0:v:0", "-fps_mode", "passthrough"])
        .args(["-f", "rawvideo", "-pix_fmt", "gray", "-"])
        .output()
        .unwrap();
    assert!(output.status.success(), "ffmpeg -pix_fmt gray on {video:?}");
    output.stdout
}

#[test]
fn luma_planes_decode_to_what_ffmpegs_gray_conversion_gives() {
    // 8-bit planar YUV videos are decoded to their luma plane and, in limited range, expanded
    // here; FFmpeg's own conversion to gray is the truth, byte for byte, for each pixel format
    // and range, and for formats that keep FFmpeg's conversion (RGB, 10-bit).
    if !teachcam_testdata::ffmpeg("video") {
        return;
    }
    let root = tempfile::tempdir().unwrap();
    let cases: [(&str, &[&str], teachcam::source::video::GrayFrom); 6] = {
        use teachcam::source::video::GrayFrom::{Converted, Luma};
        [
            (
                "yuv420p.avi",
                &["-c:v", "mpeg4", "-q:v", "3", "-pix_fmt", "yuv420p"],
                Luma { limited: true },
            ),
            (
                "yuv444p.mkv",
                &["-c:v", "libx264", "-crf", "18", "-pix_fmt", "yuv444p"],
                Luma { limited: true },
            ),
            (
                "yuvj420p.mp4",
                &["-c:v", "libx264", "-crf", "18", "-pix_fmt", "yuvj420p"],
                Luma { limited: false },
            ),
            (
                "pc.mkv",
                &[
                    "-c:v",
                    "libx264",
                    "-crf",
                    "18",
                    "-pix_fmt",
                    "yuv420p",
                    "-color_range",
                    "pc",
                ],
                Luma { limited: false },
            ),
            ("rgb.mov", &["-c:v", "png", "-pix_fmt", "rgb24"], Converted),
            (
                "ten.mkv",
                &["-c:v", "ffv1", "-pix_fmt", "yuv420p10le"],
                Converted,
            ),
        ]
    };
    for (name, codec, expected_way) in cases {
        let video = root.path().join(name);
        // A moving test pattern with noise: every luma level from black to white occurs.
        let status = Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-f", "lavfi", "-i"])
            .arg("testsrc2=size=160x120:rate=25:duration=0.4,noise=alls=20:allf=t")
            .args(codec)
            .arg(&video)
            .status()
            .unwrap();
        assert!(status.success(), "encoding {name}");
        let info = teachcam::source::video::probe(&video, "cam0").unwrap();
        assert_eq!(info.gray, expected_way, "{name}: {info:?}");
        let mut reader = teachcam::source::video::VideoReader::start(&video, info, 1).unwrap();
        let mut ours = Vec::new();
        while let Some(frame) = reader.next_frame() {
            match frame.unwrap() {
                teachcam::io::recording::GrayFrame::Eight(image) => ours.extend(image.into_raw()),
                teachcam::io::recording::GrayFrame::Sixteen(image) => {
                    ours.extend(image.into_raw().iter().flat_map(|s| s.to_le_bytes()));
                }
            }
        }
        let truth = if name == "ten.mkv" {
            let output = Command::new("ffmpeg")
                .args(["-nostdin", "-v", "error", "-i"])
                .arg(&video)
                .args(["-f", "rawvideo", "-pix_fmt", "gray16le", "-"])
                .output()
                .unwrap();
            output.stdout
        } else {
            ffmpeg_gray(&video)
        };
        assert_eq!(
            ours.len(),
            10 * 160 * 120 * if name == "ten.mkv" { 2 } else { 1 },
            "{name}"
        );
        let differing = ours.iter().zip(&truth).filter(|(a, b)| a != b).count();
        assert_eq!(ours.len(), truth.len(), "{name}");
        assert_eq!(
            differing, 0,
            "{name}: {differing} samples differ from ffmpeg -pix_fmt gray"
        );
    }
}
