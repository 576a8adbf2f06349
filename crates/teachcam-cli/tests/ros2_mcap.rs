//! `teachcam export mcap`: a take read back by the `mcap` crate (messages decoded here from
//! the CDR bytes) and by ROS 2's own Python readers (`mcap-ros2-support`, decoding from the
//! schemas the file embeds), against the trajectory CSV and `check --joints-out`.

use std::f64::consts::{PI, TAU};
use std::ffi::OsString;
use std::path::Path;
use std::process::Output;

use nalgebra::{UnitQuaternion, Vector3};
use teachcam::geometry::{FrameIndex, Point3, pose_from_parts};
use teachcam::io::trajectory::{read_trajectory, write_trajectory};
use teachcam::trajectory::{Sample, Status, ToolPose, Trajectory};
use teachcam_testdata::cdr::decode_pose;

#[path = "support/run.rs"]
mod run;
use run::teachcam;

const WOBJ: &str = "350,0,150,1,0,0,0";
const TCP: &str = "0,0,150,1,0,0,0";
/// The tool frame's origin sits this far behind the tip, along the tool's z.
const LEVER_MM: f64 = 120.0;

/// A 4 s stroke at 30 Hz (sums of sinusoids; the brush down), with a gap (frames 40–44), a
/// degraded and an outlier frame, and a tip uncertainty that varies per frame.
fn write_stroke(path: &Path) {
    let samples = (0..120)
        .map(|k| {
            let t = f64::from(k) / 30.0;
            if (40..45).contains(&k) {
                return Sample::gap(FrameIndex(k as usize), t);
            }
            let tip = Vector3::new(
                60.0 * (TAU * 0.4 * t).sin(),
                40.0 * (TAU * 0.25 * t + 1.0).sin(),
                5.0 + 4.0 * (TAU * 0.7 * t).sin(),
            );
            let rotation = UnitQuaternion::from_euler_angles(0.2 * (TAU * 0.3 * t).sin(), 0.1, 0.3)
                * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), PI);
            let origin = tip - rotation * Vector3::new(0.0, 0.0, LEVER_MM);
            let mut sample = Sample::measured(
                FrameIndex(k as usize),
                t,
                ToolPose {
                    world_from_tool: pose_from_parts(origin, rotation),
                    tip_in_world: Point3::from(tip),
                    markers: 4,
                    rms_mm: 0.05,
                },
            );
            sample.tip_std_mm = Some(0.02 + 0.01 * (t * 3.0).sin().abs());
            sample.status = match k {
                70 => Status::Degraded,
                90 => Status::Outlier,
                _ => Status::Ok,
            };
            sample
        })
        .collect();
    write_trajectory(path, &Trajectory { samples }).unwrap();
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

fn export(trajectory: &Path, output: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "export",
        "mcap",
        trajectory.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    teachcam(&args)
}

#[test]
fn a_take_reads_back_with_one_pose_per_posed_frame() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory);
    let take = dir.path().join("take.mcap");
    let out = export(&trajectory, &take, &["--frame-id", "paint_booth"]);
    assert!(out.status.success(), "{}", text(&out));

    let bytes = std::fs::read(&take).unwrap();
    let read = read_trajectory(&trajectory).unwrap();
    let posed: Vec<&Sample> = read.samples.iter().filter(|s| s.pose.is_some()).collect();
    let mut tool = Vec::new();
    let mut counts = std::collections::BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        let channel = &message.channel;
        assert_eq!(channel.message_encoding, "cdr");
        let schema = channel.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "ros2msg");
        *counts.entry(channel.topic.clone()).or_insert(0) += 1;
        if channel.topic == "/teachcam/tool" {
            assert_eq!(schema.name, "geometry_msgs/msg/PoseWithCovarianceStamped");
            let text = std::str::from_utf8(&schema.data).unwrap();
            assert!(text.starts_with("std_msgs/Header header\nPoseWithCovariance pose\n"));
            assert!(text.contains("\nMSG: geometry_msgs/msg/PoseWithCovariance\n"));
            tool.push((message.log_time, decode_pose(&message.data)));
        }
    }
    assert_eq!(tool.len(), posed.len(), "{counts:?}");
    assert_eq!(counts["/teachcam/status"], read.samples.len());
    assert_eq!(counts["/tf"], posed.len());
    assert!(!counts.contains_key("/teachcam/joint_trajectory"));
    // Without a tool file the markers are the tip's sphere alone, at 5 Hz.
    assert_eq!(counts["/teachcam/markers"], 20, "{counts:?}");
    for (sample, (log_time, pose)) in posed.iter().zip(&tool) {
        let tip = sample.pose.unwrap().tip_in_world;
        for (got, mm) in pose.position.iter().zip([tip.x, tip.y, tip.z]) {
            assert!((got - mm / 1000.0).abs() <= 1e-12, "{got} against {mm} mm");
        }
        assert!((pose.stamp_s() - sample.time_s).abs() <= 1e-9);
        assert_eq!(*log_time, (sample.time_s * 1e9).round() as u64);
        assert_eq!(pose.frame_id, "paint_booth");
        let std_m = sample.tip_std_mm.unwrap() / 1000.0;
        assert!((pose.covariance[0] - std_m * std_m).abs() <= 1e-12 * std_m * std_m);
        // Rotation: the tip's σ over the 120 mm lever (the lever read back from the CSV's
        // rounded columns: 1e-4 mm in 120 mm).
        let rot = (sample.tip_std_mm.unwrap() / LEVER_MM).powi(2);
        assert!((pose.covariance[35] - rot).abs() <= 1e-5 * rot);
        assert_eq!(pose.covariance[1], 0.0);
    }
}

#[test]
fn ros2_readers_decode_the_take_as_the_csvs_say() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory);
    let tool = dir.path().join("tool.json");
    teachcam::io::tool::write_tool(&tool, &teachcam::sim::scenario::paper_brush()).unwrap();
    let joints = dir.path().join("joints.csv");
    let out = teachcam(&[
        "check",
        trajectory.to_str().unwrap(),
        "--robot",
        "irb120",
        "--wobj",
        WOBJ,
        "--tcp",
        TCP,
        "--tool",
        tool.to_str().unwrap(),
        "--joints-out",
        joints.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let take = dir.path().join("take.mcap");
    let rig = dir.path().join("rig.json");
    teachcam::io::rig::write_rig(&rig, &teachcam::sim::scenario::paper_rig()).unwrap();
    let out = export(
        &trajectory,
        &take,
        &[
            "--robot",
            "irb120",
            "--wobj",
            WOBJ,
            "--tcp",
            TCP,
            "--rig",
            rig.to_str().unwrap(),
            "--tool",
            tool.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", text(&out));
    let cameras = teachcam::sim::scenario::paper_rig()
        .cameras
        .len()
        .to_string();
    let args: Vec<OsString> = vec![
        take.into(),
        trajectory.into(),
        joints.into(),
        "--cameras".into(),
        cameras.into(),
        "--tool".into(),
        tool.into(),
    ];
    let test = "ros2_readers_decode_the_take_as_the_csvs_say";
    let Some(result) =
        teachcam_testdata::ros2_script(test, "mcap_ros2", "ros2/read_mcap.py", &args)
    else {
        return;
    };
    let summary = result.unwrap_or_else(|e| panic!("the ROS 2 readers refuse the take: {e}"));
    // 120 frames less the 5-frame gap; the outlier keeps its pose but not its joints.
    assert!(summary.contains("\"tool_messages\": 115"), "{summary}");
    assert!(summary.contains("\"joint_points\": 114"), "{summary}");
    // 5 Hz over 4 s of posed frames at 30 Hz: frames 0, 6, ... 36, then 45 (the first after
    // the gap), 51, ... 117: 7 + 13.
    assert!(summary.contains("\"marker_arrays\": 20"), "{summary}");
}

#[test]
fn mistakes_are_named_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let trajectory = dir.path().join("stroke.csv");
    write_stroke(&trajectory);
    // A wrong extension, a frame name tf2 refuses: usage (2).
    for (output, extra, needle) in [
        ("take.csv", &[][..], "mcap"),
        ("take.mcap", &["--frame-id", "/world"][..], "--frame-id"),
    ] {
        let path = dir.path().join(output);
        let out = export(&trajectory, &path, extra);
        assert_eq!(out.status.code(), Some(2), "{}", text(&out));
        assert!(text(&out).contains(needle), "{}", text(&out));
        assert!(!path.exists());
    }
    // A robot that cannot reach it: rejected (1), no take.
    let path = dir.path().join("take.mcap");
    let out = export(
        &trajectory,
        &path,
        &[
            "--robot",
            "irb120",
            "--wobj",
            "2000,0,150,1,0,0,0",
            "--tcp",
            TCP,
        ],
    );
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("no take written"), "{}", text(&out));
    assert!(!path.exists());
    // A trajectory without a pose: rejected (1).
    let empty = dir.path().join("empty.csv");
    let samples = (0..5)
        .map(|k| Sample::gap(FrameIndex(k), k as f64 / 30.0))
        .collect();
    write_trajectory(&empty, &Trajectory { samples }).unwrap();
    let out = export(&empty, &path, &[]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("no frame has a pose"), "{}", text(&out));
    assert!(!path.exists());
}
