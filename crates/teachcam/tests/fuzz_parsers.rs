//! Mutation fuzzing of every file parser (issue 15): real files (`../shared/data`, this repo's
//! test data, simulator output) are mutated (numbers made NaN, infinite, huge or empty; lines
//! deleted, duplicated, swapped; fields dropped; bytes flipped; files truncated; image headers
//! resized) and each mutant is read. The law: no panic, and either an error on one line, or a
//! value that is finite and consistent (checked per format below).
//!
//! Seeded and bounded in the normal suite: `TEACHCAM_FUZZ_CASES` mutants per parser (default
//! 150), `TEACHCAM_FUZZ_SEED` (default 15). To run longer:
//! `TEACHCAM_FUZZ_CASES=20000 TEACHCAM_FUZZ_SEED=$RANDOM cargo test --release -p teachcam --test fuzz_parsers`.
//! A failing mutant is written to `target/fuzz-failures/` and named in the failure.

#![allow(
    clippy::unwrap_used,
    clippy::print_stderr,
    reason = "a test fails loudly on a broken fixture and says what it ran"
)]

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use teachcam::camera::Camera;
use teachcam::sim::{Scenario, build_scene};

fn cases() -> usize {
    std::env::var("TEACHCAM_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(150)
}

fn seed() -> u64 {
    std::env::var("TEACHCAM_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(15)
}

/// Values a mutated number becomes: the ones that broke parsers before (R2-R6).
const BAD_NUMBERS: [&str; 14] = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "",
    "abc",
    "1e400",
    "99999999999999999999",
    "-1",
];

/// One text mutation.
fn mutate_text(text: &str, rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        lines.push(String::new());
    }
    let n = lines.len();
    let i = rng.random_range(0..n);
    match rng.random_range(0..9) {
        // A number token replaced.
        0..=2 => {
            let line = &lines[i];
            let spans: Vec<(usize, usize)> = number_spans(line);
            if let Some(&(a, b)) = spans.get(rng.random_range(0..spans.len().max(1))) {
                let bad = BAD_NUMBERS[rng.random_range(0..BAD_NUMBERS.len())];
                lines[i] = format!("{}{bad}{}", &line[..a], &line[b..]);
            }
        }
        3 => {
            lines.remove(i);
        }
        4 => {
            let copy = lines[i].clone();
            lines.insert(i, copy);
        }
        5 => {
            let j = rng.random_range(0..n);
            lines.swap(i, j);
        }
        // A field dropped.
        6 => {
            let separator = if lines[i].contains('\t') { '\t' } else { ',' };
            let mut fields: Vec<&str> = lines[i].split(separator).collect();
            if fields.len() > 1 {
                fields.remove(rng.random_range(0..fields.len()));
            }
            lines[i] = fields.join(&separator.to_string());
        }
        // A control character, quote or separator inserted.
        7 => {
            let line = &lines[i];
            let at = (0..=line.len())
                .filter(|k| line.is_char_boundary(*k))
                .nth(rng.random_range(0..=line.chars().count()))
                .unwrap_or(0);
            let inserted =
                ["\u{0}", "\u{1b}[31m", "\"", ",", "\t", "\r", "{", "]"][rng.random_range(0..8)];
            lines[i] = format!("{}{inserted}{}", &line[..at], &line[at..]);
        }
        _ => {
            let mut bytes = lines.join("\n").into_bytes();
            return mutate_bytes(&mut bytes, rng);
        }
    }
    let mut out = lines.join("\n");
    out.push('\n');
    out.into_bytes()
}

/// Byte ranges of the numbers of a line.
fn number_spans(line: &str) -> Vec<(usize, usize)> {
    let bytes = line.as_bytes();
    let mut spans = Vec::new();
    let mut k = 0;
    while k < bytes.len() {
        if bytes[k].is_ascii_digit()
            || (bytes[k] == b'-' && bytes.get(k + 1).is_some_and(u8::is_ascii_digit))
        {
            let a = k;
            k += 1;
            while k < bytes.len() && (bytes[k].is_ascii_digit() || b".eE+-".contains(&bytes[k])) {
                k += 1;
            }
            spans.push((a, k));
        } else {
            k += 1;
        }
    }
    spans
}

/// One binary mutation: flip, overwrite with an extreme, insert, delete or truncate.
fn mutate_bytes(bytes: &mut Vec<u8>, rng: &mut ChaCha8Rng) -> Vec<u8> {
    if bytes.is_empty() {
        return vec![rng.random()];
    }
    let i = rng.random_range(0..bytes.len());
    match rng.random_range(0..6) {
        0 | 1 => bytes[i] ^= 1 << rng.random_range(0..8),
        2 => {
            // A float NaN, an infinity, 0xFFFF or zero over the next four bytes.
            let extreme: [[u8; 4]; 4] = [
                f32::NAN.to_le_bytes(),
                f32::INFINITY.to_le_bytes(),
                [0xFF, 0xFF, 0xFF, 0x7F],
                [0, 0, 0, 0],
            ];
            let e = extreme[rng.random_range(0..4)];
            for (k, b) in e.iter().enumerate() {
                if let Some(slot) = bytes.get_mut(i + k) {
                    *slot = *b;
                }
            }
        }
        3 => bytes.insert(i, rng.random()),
        4 => {
            bytes.remove(i);
        }
        _ => bytes.truncate(i),
    }
    bytes.clone()
}

/// Reads every mutant of `seeds` with `read` and holds it to the law; `check` judges a value
/// read successfully.
fn fuzz<T, E: std::fmt::Display>(
    name: &str,
    seeds: &[(&str, Vec<u8>)],
    binary: bool,
    read: impl Fn(&Path) -> Result<T, E>,
    check: impl Fn(&T) -> Result<(), String>,
) {
    assert!(!seeds.is_empty(), "{name}: no seed file");
    let dir = tempfile::tempdir().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed() ^ fnv(name));
    let (mut accepted, mut refused) = (0, 0);
    for case in 0..cases() {
        let (file_name, seed_bytes) = &seeds[case % seeds.len()];
        let mut bytes = seed_bytes.clone();
        // Zero mutations now and then: the seed itself must pass the law too.
        for _ in 0..rng.random_range(0..=3) {
            bytes = if binary {
                mutate_bytes(&mut bytes, &mut rng)
            } else {
                mutate_text(&String::from_utf8_lossy(&bytes), &mut rng)
            };
        }
        let path = dir.path().join(file_name);
        std::fs::write(&path, &bytes).unwrap();
        let verdict = match catch_unwind(AssertUnwindSafe(|| read(&path))) {
            Err(_) => Some("panicked".to_string()),
            Ok(Err(e)) => {
                refused += 1;
                let message = e.to_string();
                message
                    .contains('\n')
                    .then(|| format!("error message is not one line: {message:?}"))
            }
            Ok(Ok(value)) => {
                accepted += 1;
                check(&value).err()
            }
        };
        if let Some(why) = verdict {
            let kept = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
                .join("fuzz-failures")
                .join(format!("{name}-{case}-{file_name}"));
            std::fs::create_dir_all(kept.parent().unwrap()).unwrap();
            std::fs::write(&kept, &bytes).unwrap();
            panic!(
                "{name}: mutant {case} of {file_name}: {why} (kept as {})",
                kept.display()
            );
        }
    }
    eprintln!("{name}: {accepted} mutants accepted and checked, {refused} refused");
}

fn fnv(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

fn finite(values: &[f64], what: &str) -> Result<(), String> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => Err(format!("accepted a non-finite {what}: {v}")),
        None => Ok(()),
    }
}

fn check_camera(c: &Camera) -> Result<(), String> {
    let i = &c.intrinsics;
    finite(&[i.fx, i.fy, i.cx, i.cy], "intrinsic")?;
    if !(i.fx > 0.0 && i.fy > 0.0) {
        return Err(format!("accepted a focal length fx {} fy {}", i.fx, i.fy));
    }
    let d = &c.distortion;
    finite(&[d.k1, d.k2, d.p1, d.p2, d.k3], "distortion coefficient")?;
    if c.image_size.width == 0 || c.image_size.height == 0 {
        return Err("accepted an empty image size".into());
    }
    let t = c.camera_from_world.translation.vector;
    finite(&[t.x, t.y, t.z], "camera position")?;
    let q = c.camera_from_world.rotation.quaternion();
    finite(&[q.w, q.i, q.j, q.k], "camera rotation")
}

/// The paper scene's files as the simulator writes them.
struct Simulated {
    _dir: tempfile::TempDir,
    rig: Vec<u8>,
    tool: Vec<u8>,
    truth: Vec<u8>,
    camera_json: Vec<u8>,
    ros_yaml: Vec<u8>,
}

fn simulated() -> Simulated {
    let scene = build_scene(Scenario::Paper, 1);
    let dir = tempfile::tempdir().unwrap();
    let path = |n: &str| dir.path().join(n);
    teachcam::io::rig::write_rig(&path("rig.json"), &scene.rig).unwrap();
    teachcam::io::tool::write_tool(&path("tool.json"), &scene.tool).unwrap();
    let mut truth = scene.truth.clone();
    truth.samples.truncate(25);
    teachcam::io::trajectory::write_trajectory(&path("truth.csv"), &truth).unwrap();
    let camera = &scene.rig.cameras[0];
    teachcam::io::camera_file::write_camera_json(&path("camera.json"), camera, 0.1).unwrap();
    teachcam::io::camera_file::write_ros_yaml(&path("ros.yaml"), camera).unwrap();
    let read = |n: &str| std::fs::read(path(n)).unwrap();
    Simulated {
        rig: read("rig.json"),
        tool: read("tool.json"),
        truth: read("truth.csv"),
        camera_json: read("camera.json"),
        ros_yaml: read("ros.yaml"),
        _dir: dir,
    }
}

fn repo_data(path: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(path),
    )
    .unwrap()
}

#[test]
fn rig_json() {
    let sim = simulated();
    fuzz(
        "rig",
        &[("rig.json", sim.rig)],
        false,
        teachcam::io::rig::read_rig,
        |rig| {
            if rig.cameras.is_empty() {
                return Err("accepted a rig without cameras".into());
            }
            rig.cameras.iter().try_for_each(check_camera)
        },
    );
}

#[test]
fn camera_json_and_opencv_ros_yaml() {
    let sim = simulated();
    fuzz(
        "camera",
        &[
            ("camera.json", sim.camera_json),
            ("ros.yaml", sim.ros_yaml),
            ("opencv.yaml", repo_data("calib_opencv_left.yaml")),
        ],
        false,
        teachcam::io::camera_file::read_camera,
        |c| {
            if let Some(rms) = c.rms_px {
                finite(&[rms], "rms_px")?;
            }
            check_camera(&c.camera)
        },
    );
}

#[test]
fn tool_json() {
    let sim = simulated();
    fuzz(
        "tool",
        &[("tool.json", sim.tool)],
        false,
        teachcam::io::tool::read_tool,
        |tool| {
            if tool.markers_in_tool.len() < 3 {
                return Err("accepted a tool of fewer than 3 markers".into());
            }
            for m in &tool.markers_in_tool {
                finite(&[m.x, m.y, m.z], "marker coordinate")?;
            }
            if !(tool.marker_diameter_mm.is_finite() && tool.marker_diameter_mm > 0.0) {
                return Err(format!(
                    "accepted a marker diameter {}",
                    tool.marker_diameter_mm
                ));
            }
            let t = tool.tool_from_tcp.translation.vector;
            finite(&[t.x, t.y, t.z], "tip")
        },
    );
}

#[test]
fn trajectory_csv() {
    let sim = simulated();
    fuzz(
        "trajectory",
        &[("raw.csv", sim.truth)],
        false,
        teachcam::io::trajectory::read_trajectory,
        |trajectory| {
            let mut previous: Option<(usize, f64)> = None;
            for s in &trajectory.samples {
                finite(&[s.time_s], "time")?;
                if let Some((frame, time)) = previous
                    && !(s.frame.0 > frame && s.time_s > time)
                {
                    return Err(format!(
                        "accepted frame {} at {} s after frame {frame} at {time} s",
                        s.frame.0, s.time_s
                    ));
                }
                previous = Some((s.frame.0, s.time_s));
                if let Some(p) = &s.pose {
                    let t = p.world_from_tool.translation.vector;
                    let q = p.world_from_tool.rotation.quaternion();
                    let tip = p.tip_in_world;
                    finite(
                        &[t.x, t.y, t.z, q.w, q.i, q.j, q.k, tip.x, tip.y, tip.z],
                        "pose",
                    )?;
                    finite(&[p.rms_mm], "rms_mm")?;
                }
                if let Some(std) = s.tip_std_mm {
                    finite(&[std], "tip_std_mm")?;
                }
            }
            Ok(())
        },
    );
}

/// A recording folder of three cameras with two tiny frames each; `recording.json` mutated.
#[test]
fn recording_json() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("rec");
    for camera in ["cam0", "cam1", "cam2"] {
        std::fs::create_dir_all(root.join(camera)).unwrap();
        for frame in 0..2 {
            teachcam::io::recording::write_png(
                &root
                    .join(camera)
                    .join(teachcam::io::recording::frame_file_name(frame)),
                &image::GrayImage::new(8, 6),
            )
            .unwrap();
        }
    }
    let recording_json = root.join("recording.json");
    fuzz(
        "recording",
        &[("recording.json", b"{\n  \"fps\": 30.0\n}\n".to_vec())],
        false,
        |path| {
            std::fs::copy(path, &recording_json).unwrap();
            teachcam::io::recording::open_recording(&root, None)
        },
        |recording| {
            if !(recording.fps.is_finite() && recording.fps > 0.0) {
                return Err(format!("accepted fps {}", recording.fps));
            }
            // A frame time must be representable and distinct (R6: fps 1e-320 gave inf).
            let last = (recording.frame_count().max(1) - 1) as f64 / recording.fps;
            finite(&[1.0 / recording.fps, last], "frame time")
        },
    );
}

fn check_points(points: &teachcam::c3d::PointData) -> Result<(), String> {
    if !(points.rate_hz.is_finite() && points.rate_hz > 0.0) {
        return Err(format!("accepted a rate of {} Hz", points.rate_hz));
    }
    for f in 0..points.frame_count() {
        for m in 0..points.marker_count() {
            if let Some(s) = points.sample(teachcam::geometry::FrameIndex(f), m) {
                let p = s.position;
                finite(&[p.x, p.y, p.z, s.residual], "marker sample")?;
            }
        }
    }
    Ok(())
}

#[test]
fn motive_csv() {
    fuzz(
        "motive",
        &[("take.csv", repo_data("vendor/motive_markers.csv"))],
        false,
        teachcam::vendor::read_motive_csv,
        check_points,
    );
}

#[test]
fn qualisys_tsv() {
    fuzz(
        "qualisys",
        &[("take.tsv", repo_data("vendor/qualisys.tsv"))],
        false,
        teachcam::vendor::read_qualisys_tsv,
        check_points,
    );
}

/// The identified markers CSV of `track --markers-out` (the detections `import markers` reads).
#[test]
fn markers_csv() {
    let text = "frame,marker,x_mm,y_mm,z_mm,views,residual_px\n\
                0,0,1.000000,2.000000,300.000000,3,0.0100\n\
                0,1,41.000000,2.000000,300.000000,3,0.0120\n\
                0,2,1.000000,52.000000,300.000000,2,0.0090\n\
                1,0,1.100000,2.000000,300.000000,3,0.0110\n\
                1,1,41.100000,2.000000,300.000000,3,0.0100\n\
                2,2,1.200000,52.000000,300.000000,3,0.0100\n";
    fuzz(
        "markers",
        &[("markers.csv", text.as_bytes().to_vec())],
        false,
        |path| teachcam::vendor::read_markers_csv(path, 30.0),
        check_points,
    );
}

#[test]
fn c3d_files() {
    let mut seeds = vec![
        ("a.c3d", repo_data("c3d/teachcam_written.c3d")),
        ("b.c3d", repo_data("c3d/ezc3d_Optotrak_dec.c3d")),
        ("c.c3d", repo_data("c3d/c3dorg_sample01_Eb015pi_mips.c3d")),
    ];
    if let Some(dir) = teachcam_testdata::shared_data("c3d") {
        seeds.push((
            "d.c3d",
            std::fs::read(dir.join("ezc3d_Optotrak.c3d")).unwrap(),
        ));
        seeds.push((
            "e.c3d",
            std::fs::read(dir.join("ktk_racing_probing_acromion_R.c3d")).unwrap(),
        ));
    }
    fuzz("c3d", &seeds, true, teachcam::c3d::read_file, |c3d| {
        check_points(&c3d.points)
    });
}

/// A PNG frame whose bytes, or whose header's width and height, are mutated; read with the
/// size the rig expects, so an accepted frame must have it (R1).
#[test]
fn png_frames() {
    let mut image = image::GrayImage::new(40, 30);
    for (x, y, p) in image.enumerate_pixels_mut() {
        let r2 = (f64::from(x) - 20.0).powi(2) + (f64::from(y) - 15.0).powi(2);
        *p = image::Luma([if r2 < 36.0 { 250 } else { 10 }]);
    }
    let dir = tempfile::tempdir().unwrap();
    let seed_path = dir.path().join("seed.png");
    teachcam::io::recording::write_png(&seed_path, &image).unwrap();
    let seed = std::fs::read(&seed_path).unwrap();
    // The same frame with its header claiming other sizes (IHDR width at 16..20, height at
    // 20..24): 3 rows shorter, 640x480, 20000x20000.
    let resized = |w: u32, h: u32| {
        let mut b = seed.clone();
        b[16..20].copy_from_slice(&w.to_be_bytes());
        b[20..24].copy_from_slice(&h.to_be_bytes());
        b
    };
    // Valid PNGs of other sizes.
    let encoded = |w: u32, h: u32| {
        let path = dir.path().join(format!("{w}x{h}.png"));
        teachcam::io::recording::write_png(&path, &image::GrayImage::new(w, h)).unwrap();
        std::fs::read(&path).unwrap()
    };
    let mut seeds = vec![
        ("000000.png", seed.clone()),
        ("000005.png", encoded(40, 27)),
        ("000006.png", encoded(640, 480)),
        ("000001.png", resized(40, 27)),
        ("000002.png", resized(640, 480)),
        ("000003.png", resized(20_000, 20_000)),
    ];
    if let Some(blob) = teachcam_testdata::shared_data("blob") {
        seeds.push((
            "000004.png",
            std::fs::read(blob.join("detect_blob.png")).unwrap(),
        ));
    }
    fuzz(
        "png",
        &seeds,
        true,
        |path| teachcam::io::recording::read_frame(path, Some((40, 30))),
        |frame| {
            if frame.dimensions() == (40, 30) {
                Ok(())
            } else {
                Err(format!(
                    "accepted a {:?} frame where 40x30 was expected",
                    frame.dimensions()
                ))
            }
        },
    );
}
