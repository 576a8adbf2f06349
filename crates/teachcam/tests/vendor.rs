//! Motive CSV and Qualisys TSV readers on small exports laid out as the vendors write them
//! (`tests/data/vendor/`, values chosen by hand), the Motive-like writer, and bad input.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use teachcam::c3d::PointData;
use teachcam::geometry::{FrameIndex, Point3, Pose, pose_from_parts};
use teachcam::trajectory::{Sample, ToolPose, Trajectory};
use teachcam::vendor;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/vendor")
        .join(name)
}

fn position(points: &PointData, frame: usize, marker: usize) -> Option<[f64; 3]> {
    points
        .sample(FrameIndex(frame), marker)
        .map(|s| [s.position.x, s.position.y, s.position.z])
}

#[test]
fn motive_markers_only_position_columns_of_type_marker() {
    let points =
        vendor::read_motive_csv(&fixture("motive_markers.csv")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(points.labels, ["Probe:Marker1", "Unlabeled 1001"]);
    assert_eq!(
        points.rate_hz, 120.0,
        "the export rate, not the capture rate"
    );
    assert_eq!(points.units, "mm");
    assert_eq!(points.frame_count(), 3);
    assert_eq!(position(&points, 0, 0), Some([1.5, 2.5, 3.5]));
    assert_eq!(position(&points, 0, 1), Some([-10.25, 20.5, 1000.125]));
    assert_eq!(position(&points, 1, 0), None, "empty cells are a gap");
    assert_eq!(position(&points, 1, 1), Some([-10.5, 21.0, 1000.0]));
    assert_eq!(position(&points, 2, 0), Some([1.75, 2.75, 3.75]));
    assert_eq!(
        position(&points, 2, 1),
        None,
        "trailing empty cells are a gap"
    );
}

#[test]
fn qualisys_zeros_are_gaps() {
    let points =
        vendor::read_qualisys_tsv(&fixture("qualisys.tsv")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(points.labels, ["WandTop", "WandBottom"]);
    assert_eq!(points.rate_hz, 200.0);
    assert_eq!(points.units, "mm");
    assert_eq!(points.frame_count(), 3);
    assert_eq!(position(&points, 0, 0), Some([120.5, -30.25, 850.0]));
    assert_eq!(position(&points, 0, 1), None);
    assert_eq!(position(&points, 1, 1), Some([10.0, 0.0, 0.0]));
    assert_eq!(position(&points, 2, 1), Some([11.0, 1.0, -1.0]));
}

#[test]
fn qualisys_without_column_header_or_time() {
    let text = "FREQUENCY\t100\nMARKER_NAMES\ta\tb\n1.0\t2.0\t3.0\t4.0\t5.0\t6.0\n";
    let points =
        vendor::parse_qualisys_tsv(Path::new("x.tsv"), text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(position(&points, 0, 1), Some([4.0, 5.0, 6.0]));
}

fn error(result: Result<PointData, teachcam::io::FileError>) -> String {
    match result {
        Ok(_) => panic!("accepted bad input"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_exports_name_file_and_line() {
    let good = std::fs::read_to_string(fixture("motive_markers.csv")).unwrap_or_default();
    let path = Path::new("take.csv");
    let bad = good.replace("1000.125", "10x0");
    assert_eq!(
        error(vendor::parse_motive_csv(path, &bad)),
        "take.csv:9: Unlabeled 1001 Z: \"10x0\" is not a number"
    );
    let bad = good.replace("Millimeters", "Furlongs");
    assert!(error(vendor::parse_motive_csv(path, &bad)).contains("take.csv:1: Length Units"));
    let bad = good.replace("Frame,Time", "Frm,Time");
    assert!(error(vendor::parse_motive_csv(path, &bad)).contains("no axis row"));
    assert!(error(vendor::parse_motive_csv(path, "hello\n")).contains("not a Motive CSV"));

    let path = Path::new("trial.tsv");
    let text = "FREQUENCY\t100\nMARKER_NAMES\ta\tb\n1.0\t2.0\t3.0\t4.0\t5.0\n";
    assert_eq!(
        error(vendor::parse_qualisys_tsv(path, text)),
        "trial.tsv:3: 5 cells, expected 6 (2 markers x 3)"
    );
    let text = "MARKER_NAMES\ta\n1\t2\t3\n";
    assert!(error(vendor::parse_qualisys_tsv(path, text)).contains("no FREQUENCY"));
    let text = "FREQUENCY\t100\n1\t2\t3\n";
    assert!(error(vendor::parse_qualisys_tsv(path, text)).contains("trial.tsv:2: data before"));
}

fn pose(x: f64, angle: f64) -> Pose {
    pose_from_parts(
        nalgebra::Vector3::new(x, 20.0, 30.0),
        nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::z_axis(), angle),
    )
}

#[test]
fn motive_rigid_body_out() {
    let samples = (0..3)
        .map(|f| {
            let time_s = f as f64 / 100.0;
            if f == 1 {
                return Sample::gap(FrameIndex(f), time_s);
            }
            let world_from_tool = pose(10.0 * f as f64, 0.5);
            Sample::measured(
                FrameIndex(f),
                time_s,
                ToolPose {
                    world_from_tool,
                    tip_in_world: Point3::origin(),
                    markers: 4,
                    rms_mm: 0.25,
                },
            )
        })
        .collect();
    let text = vendor::motive_rigid_body_csv(&Trajectory { samples }, "brush");
    let lines: Vec<&str> = text.lines().collect();
    assert!(
        lines[0].contains("Export Frame Rate,100.000000"),
        "{}",
        lines[0]
    );
    assert!(lines[0].contains("Length Units,Millimeters"));
    assert_eq!(lines[6], "Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,");
    // Rotation of 0.5 rad about z: (x, y, z, w) = (0, 0, sin 0.25, cos 0.25).
    let row: Vec<f64> = lines[7]
        .split(',')
        .map(|c| c.parse().unwrap_or(f64::NAN))
        .collect();
    let want = [
        0.0,
        0.0,
        0.0,
        0.0,
        0.25f64.sin(),
        0.25f64.cos(),
        0.0,
        20.0,
        30.0,
        0.25,
    ];
    for (g, w) in row.iter().zip(want) {
        assert!((g - w).abs() < 1e-8, "{row:?}");
    }
    assert_eq!(lines[8], "1,0.010000,,,,,,,,");
    assert!(lines[9].starts_with("2,0.020000,"));
    assert_eq!(lines.len(), 10);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Any edit of a valid export: a result or an error naming the file, never a panic.
    #[test]
    fn mutated_exports_never_panic(
        edits in proptest::collection::vec((0usize..4000, proptest::char::any()), 1..10),
        cut in 0usize..4000,
    ) {
        for (name, is_motive) in [("motive_markers.csv", true), ("qualisys.tsv", false)] {
            let mut text: Vec<char> = std::fs::read_to_string(fixture(name))
                .unwrap_or_default()
                .chars()
                .collect();
            for &(at, c) in &edits {
                let at = at % text.len();
                text[at] = c;
            }
            text.truncate(cut % (text.len() + 1));
            let text: String = text.into_iter().collect();
            let path = Path::new(name);
            let result = if is_motive {
                vendor::parse_motive_csv(path, &text)
            } else {
                vendor::parse_qualisys_tsv(path, &text)
            };
            if let Err(e) = result {
                prop_assert!(e.to_string().starts_with(name));
            }
        }
    }
}

#[test]
fn markers_csv_gaps_and_errors() {
    let path = Path::new("m.csv");
    let text = "frame,marker,x_mm,y_mm,z_mm,views,residual_px\n0,0,1,2,3,3,0.1\n0,2,4,5,6,2,0.1\n2,1,7,8,9,3,0.1\n";
    let points = vendor::parse_markers_csv(path, text, 30.0).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(points.labels, ["M0", "M1", "M2"]);
    assert_eq!(points.frame_count(), 3);
    assert_eq!(position(&points, 0, 2), Some([4.0, 5.0, 6.0]));
    assert_eq!(
        position(&points, 1, 0),
        None,
        "a frame without rows is a gap"
    );
    assert_eq!(position(&points, 2, 1), Some([7.0, 8.0, 9.0]));
    let huge = "frame,marker,x_mm,y_mm,z_mm\n9999999,9999999,1,2,3\n";
    assert!(
        error(vendor::parse_markers_csv(path, huge, 30.0)).contains("more than 10000000 samples")
    );
    let bad = "frame,marker,x_mm,y_mm,z_mm\n0,a,1,2,3\n";
    assert_eq!(
        error(vendor::parse_markers_csv(path, bad, 30.0)),
        "m.csv:2: marker: \"a\" is not a frame or marker number"
    );
    assert!(error(vendor::parse_markers_csv(path, "frame,x_mm\n", 30.0)).contains("no column"));
    assert!(error(vendor::parse_markers_csv(path, text, 0.0)).contains("frame rate"));
}

#[test]
fn motive_quoted_names_may_hold_commas() {
    let text = "Format Version,1.23,Export Frame Rate,100,Length Units,Meters\n\n\
,Type,Marker,Marker,Marker\n\
,Name,\"Wand, tip\",\"Wand, tip\",\"Wand, tip\"\n\
,ID,\"1,2\",\"1,2\",\"1,2\"\n\
,,Position,Position,Position\n\
Frame,Time (Seconds),X,Y,Z\n\
0,0.0,0.5,0.25,1.0\n";
    let points =
        vendor::parse_motive_csv(Path::new("q.csv"), text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(points.labels, ["Wand, tip"]);
    assert_eq!(points.units, "m");
    assert_eq!(position(&points, 0, 0), Some([0.5, 0.25, 1.0]));
}
