//! Every JSON file a command reads (rig, cameras, camera, tool, wand, robot, `recording.json`):
//! valid JSON of another shape at the top level, or an unknown key, is refused in one line
//! naming the file, the key and what was expected (second campaign F8: `recording.json` of
//! `[1000]` was read as 1000 fps, `"units": "m"` ignored).

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::path::{Path, PathBuf};

use teachcam::io::FileError;
use teachcam::sim::Scenario;

const ROBOT: &str = r#"{"name": "kr6-like", "maker": "kuka",
 "opw": {"a1_mm": 25, "a2_mm": -35, "b_mm": 0, "c1_mm": 400, "c2_mm": 315, "c3_mm": 365,
         "c4_mm": 80, "offsets_deg": [0, -90, 0, 0, 0, 0], "sign_corrections": [-1, 1, 1, -1, 1, -1]},
 "joints": [{"min_deg": -170, "max_deg": 170, "max_speed_deg_s": 360},
            {"min_deg": -190, "max_deg": 45, "max_speed_deg_s": 300},
            {"min_deg": -120, "max_deg": 156, "max_speed_deg_s": 360},
            {"min_deg": -185, "max_deg": 185, "max_speed_deg_s": 381},
            {"min_deg": -120, "max_deg": 120, "max_speed_deg_s": 388},
            {"min_deg": -350, "max_deg": 350, "max_speed_deg_s": 615}]}"#;

type Reader = fn(&Path) -> Result<(), FileError>;

/// Each reader, with a valid file of its kind written into `dir`.
fn files(dir: &Path) -> Vec<(&'static str, PathBuf, Reader)> {
    let rig = Scenario::Paper.rig();
    let rec = dir.join("rec");
    std::fs::create_dir_all(rec.join("cam0")).unwrap();
    let frame = image::GrayImage::new(8, 8);
    frame.save(rec.join("cam0").join("000000.png")).unwrap();
    std::fs::write(rec.join("recording.json"), "{\"fps\": 30}").unwrap();
    teachcam::io::rig::write_rig(&rec.join("rig.json"), &rig).unwrap();
    teachcam::io::tool::write_tool(
        &rec.join("tool.json"),
        &teachcam::sim::scenario::paper_brush(),
    )
    .unwrap();
    let camera = dir.join("camera.json");
    teachcam::io::camera_file::write_camera_json(&camera, &rig.cameras[0], 0.2).unwrap();
    let cameras = dir.join("cameras.json");
    teachcam::io::rig::write_cameras(&cameras, &rig).unwrap();
    let wand = dir.join("wand.json");
    teachcam::io::wand::write_wand(&wand, &teachcam::sim::wand::contract_wand()).unwrap();
    let robot = dir.join("robot.json");
    std::fs::write(&robot, ROBOT).unwrap();
    vec![
        ("rig", rec.join("rig.json"), |p| {
            teachcam::io::rig::read_rig(p).map(drop)
        }),
        ("cameras", cameras, |p| {
            teachcam::io::rig::read_cameras(p).map(drop)
        }),
        ("camera", camera, |p| {
            teachcam::io::camera_file::read_camera(p).map(drop)
        }),
        ("tool", rec.join("tool.json"), |p| {
            teachcam::io::tool::read_tool(p).map(drop)
        }),
        ("wand", wand, |p| teachcam::io::wand::read_wand(p).map(drop)),
        ("robot", robot, |p| {
            teachcam::io::robot::read_robot(p).map(drop)
        }),
        ("recording", rec.join("recording.json"), |p| {
            teachcam::io::recording::list_recording(p.parent().unwrap(), None).map(drop)
        }),
    ]
}

fn one_line(error: &FileError) -> String {
    let message = error.to_string();
    assert_eq!(message.lines().count(), 1, "{message}");
    message
}

#[test]
fn every_json_input_checks_its_top_level_shape_and_its_keys() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, path, read) in files(dir.path()) {
        let valid = std::fs::read_to_string(&path).unwrap();
        read(&path).unwrap_or_else(|e| panic!("{kind}: the valid file is refused: {e}"));
        let name = path.file_name().unwrap().to_str().unwrap();
        for shape in ["[1000]", "30", "\"mm\"", "null"] {
            std::fs::write(&path, shape).unwrap();
            let message = one_line(&read(&path).expect_err(shape));
            assert!(
                message.contains(name) && message.contains("expected"),
                "{kind} {shape}: {message}"
            );
        }
        // An unknown key at the top level: named, with what was expected.
        let object = valid.trim_start().strip_prefix('{').unwrap();
        std::fs::write(&path, format!("{{\"scale\": 1000, {object}")).unwrap();
        let message = one_line(&read(&path).expect_err("unknown key"));
        assert!(
            message.contains(name) && message.contains("`scale`"),
            "{kind}: {message}"
        );
        // `units` other than millimetres changes every length: refused, never ignored.
        let units = if valid.contains("\"units\"") {
            valid.replacen("\"mm\"", "\"m\"", 1)
        } else {
            format!("{{\"units\": \"m\", {object}")
        };
        std::fs::write(&path, units).unwrap();
        let message = one_line(&read(&path).expect_err("units"));
        assert!(
            message.contains(name) && message.contains("units"),
            "{kind}: {message}"
        );
        std::fs::write(&path, valid).unwrap();
    }
}
