//! `teachcam live --ros2` read off the wire by Cyclone DDS (PyPI `cyclonedds`, the DDS of ROS
//! 2's default RMW), with ROS 2's topic and type names, everything on loopback: the product
//! with `ROS_LOCALHOST_ONLY=1` and `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, the reader with a
//! `CYCLONEDDS_URI` on the `lo` interface, multicast off, a loopback peer.

#![allow(clippy::print_stderr)]

use std::process::Stdio;

use serde_json::Value;

#[path = "support/run.rs"]
mod run;

/// Cyclone on loopback only: no multicast, unicast discovery to 127.0.0.1's standard ports.
const CYCLONEDDS_URI: &str = concat!(
    "<General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>",
    "<AllowMulticast>false</AllowMulticast></General>",
    "<Discovery><Peers><Peer address=\"127.0.0.1\"/></Peers>",
    "<ParticipantIndex>auto</ParticipantIndex></Discovery>"
);

/// The live run's tip positions (millimetres) from its CSV rows.
fn csv_tips(stdout: &str) -> Vec<[f64; 3]> {
    let mut lines = stdout.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (x, y, z) = (column("tip_x_mm"), column("tip_y_mm"), column("tip_z_mm"));
    lines
        .filter(|l| !l.starts_with('{'))
        .filter_map(|l| {
            let fields: Vec<&str> = l.split(',').collect();
            let value = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok());
            Some([value(x)?, value(y)?, value(z)?])
        })
        .collect()
}

/// The live run's posed rows: tip, tool origin (millimetres) and orientation `qw, qx, qy, qz`.
fn csv_poses(stdout: &str) -> Vec<([f64; 3], [f64; 3], [f64; 4])> {
    let mut lines = stdout.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let names = [
        "tip_x_mm", "tip_y_mm", "tip_z_mm", "x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz",
    ];
    let columns: Vec<usize> = names.iter().map(|n| column(n)).collect();
    lines
        .filter(|l| !l.starts_with('{'))
        .filter_map(|l| {
            let fields: Vec<&str> = l.split(',').collect();
            let v: Vec<f64> = columns
                .iter()
                .map(|&i| fields.get(i).and_then(|v| v.parse::<f64>().ok()))
                .collect::<Option<_>>()?;
            Some((
                [v[0], v[1], v[2]],
                [v[3], v[4], v[5]],
                [v[6], v[7], v[8], v[9]],
            ))
        })
        .collect()
}

/// `v` turned by the unit quaternion `q = (w, x, y, z)`, written out here (not the library's).
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let [w, x, y, z] = q;
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let u = [x, y, z];
    let uv = cross(u, v);
    let uuv = cross(u, uv);
    std::array::from_fn(|i| v[i] + 2.0 * w * uv[i] + 2.0 * uuv[i])
}

/// RViz's markers as the reader received them: each array's tip sphere is a frame's tip, and
/// its marker spheres are the paper brush's markers where that frame's pose puts them, in
/// metres (≤ 1e-6 m); 5 Hz.
fn check_markers(got: &Value, published: u64, stdout: &str) {
    let arrays = got["markers"].as_array().unwrap();
    // 8 s at 5 Hz; the first may go out before the reader matched.
    assert!(
        (38..=41).contains(&published),
        "{published} marker arrays published"
    );
    assert!(
        arrays.len() >= 25 && arrays.len() as u64 <= published,
        "{got}"
    );
    let poses = csv_poses(stdout);
    let brush = teachcam::sim::scenario::paper_brush();
    let vector = |v: &Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let mut stamps = Vec::new();
    for array in arrays {
        stamps.push(array["stamp"].as_f64().unwrap());
        let tip = vector(&array["tip"]);
        let off = |a: &[f64], b_mm: [f64; 3]| {
            (0..3)
                .map(|i| (b_mm[i] / 1000.0 - a[i]).abs())
                .fold(0.0, f64::max)
        };
        // The frame whose tip it is.
        let (row_tip, origin, q) = poses
            .iter()
            .min_by(|a, b| off(&tip, a.0).total_cmp(&off(&tip, b.0)))
            .unwrap();
        assert!(
            off(&tip, *row_tip) < 1e-6,
            "{tip:?} is no frame's tip in metres"
        );
        assert!(
            (array["diameter_m"].as_f64().unwrap() - brush.marker_diameter_mm / 1000.0).abs()
                < 1e-12
        );
        let spheres = array["spheres"].as_array().unwrap();
        assert_eq!(spheres.len(), brush.markers_in_tool.len());
        for (sphere, marker) in spheres.iter().zip(&brush.markers_in_tool) {
            let r = rotate(*q, [marker.x, marker.y, marker.z]);
            let want = std::array::from_fn(|i| r[i] + origin[i]);
            let sphere = vector(sphere);
            assert!(
                off(&sphere, want) < 1e-6,
                "{sphere:?} m against the tracked marker {want:?} mm"
            );
        }
    }
    let mut steps: Vec<f64> = stamps.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let median = steps[steps.len() / 2];
    assert!(
        (median - 0.2).abs() < 0.02,
        "markers every {median} s, not 5 Hz"
    );
    eprintln!(
        "markers: {published} arrays published, {} received, median step {median:.4} s",
        arrays.len()
    );
}

#[test]
fn cyclone_dds_receives_the_live_poses_on_loopback() {
    let test = "cyclone_dds_receives_the_live_poses_on_loopback";
    let Some(mut reader) = teachcam_testdata::ros2_command(test, "cyclonedds", "ros2/read_dds.py")
    else {
        return;
    };
    // A domain of its own, so that a concurrent run on this machine is not read.
    let domain = (1 + std::process::id() % 100).to_string();
    let reader = reader
        .args(["--seconds", "60", "--idle", "3", "--domain", &domain])
        .env("CYCLONEDDS_URI", CYCLONEDDS_URI)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let live = std::process::Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args([
            "live",
            "--source",
            "sim:paper",
            "--seconds",
            "8",
            "--ros2",
            "--json",
        ])
        .env("ROS_DOMAIN_ID", &domain)
        .env("ROS_LOCALHOST_ONLY", "1")
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .env_remove("CYCLONEDDS_URI")
        .output()
        .unwrap();
    let read = reader.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&live.stdout);
    assert!(
        live.status.success(),
        "live: {}",
        String::from_utf8_lossy(&live.stderr)
    );
    let reader_out = String::from_utf8_lossy(&read.stdout);
    assert!(
        read.status.success(),
        "the Cyclone DDS reader: {reader_out}{}",
        String::from_utf8_lossy(&read.stderr)
    );
    let summary: Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
    let got: Value = serde_json::from_str(reader_out.trim()).unwrap();
    let published = summary["ros2"]["tool"].as_u64().unwrap();
    let received = got["tool"].as_u64().unwrap();
    // 8 s at the simulator's 60 Hz, every frame posed; the reader may miss the first ones
    // while the two participants discover each other (volatile: no history for late joiners).
    assert!(published >= 400, "{summary}");
    assert!(received >= 20 * 6 && received <= published, "{got}");
    assert!(got["rate_hz"].as_f64().unwrap() >= 20.0, "{got}");
    assert_eq!(got["frame_id"], "world");
    // Metres: every received position is a frame's tip (CSV, millimetres to 4 decimals) / 1000.
    let tips = csv_tips(&stdout);
    for p in got["positions_m"].as_array().unwrap() {
        let p: Vec<f64> = p
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let nearest = tips
            .iter()
            .map(|t| {
                (0..3)
                    .map(|i| (t[i] / 1000.0 - p[i]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(f64::INFINITY, f64::min);
        assert!(
            nearest < 1e-6,
            "{p:?} is no frame's tip in metres ({nearest} m off)"
        );
    }
    // The tool moves: the sim's stroke spans about 13 cm × 12 cm.
    let extent = got["extent_m"].as_array().unwrap();
    assert!(extent[0].as_f64().unwrap() > 0.05, "{got}");
    // /tf: world → tool, and the cameras; the status of every frame.
    assert!(got["tf"].as_u64().unwrap() >= received, "{got}");
    let children = got["tf_children"].to_string();
    for child in ["teachcam_tool", "camera_cam0", "camera_cam1", "camera_cam2"] {
        assert!(children.contains(child), "{got}");
    }
    assert!(got["status"].as_u64().unwrap() >= received, "{got}");
    check_markers(&got, summary["ros2"]["markers"].as_u64().unwrap(), &stdout);
    // /tf_static is transient local: written once at the start, before the reader matched,
    // and still delivered.
    assert_eq!(
        got["tf_static_children"],
        serde_json::json!(["camera_cam0", "camera_cam1", "camera_cam2"]),
        "{got}"
    );
}

#[test]
fn a_bad_ros_variable_is_named_before_anything_starts() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(["live", "--source", "sim:paper", "--seconds", "1", "--ros2"])
        .env("ROS_DOMAIN_ID", "999")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("ROS_DOMAIN_ID=999"), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    let out = run::teachcam(&["live", "--frame-id", "map", "--seconds", "1"]);
    assert_eq!(out.status.code(), Some(2));
}
