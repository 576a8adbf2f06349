//! `teachcam smooth`, `spectrum` and `smoothing-study` end to end: files, exit codes, messages.

use std::path::Path;
use std::process::Output;

use nalgebra::{UnitQuaternion, Vector3};
use teachcam::geometry::{FrameIndex, Point3, pose_from_parts};
use teachcam::io::trajectory::{read_trajectory, write_trajectory};
use teachcam::smooth::butterworth::Butterworth;
use teachcam::trajectory::{Sample, ToolPose, Trajectory};

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// 30 s at 100 Hz: slow motion plus a deterministic 0.5 mm wiggle at 31 Hz.
fn write_input(path: &Path, frames: usize) -> Vec<f64> {
    let tip_in_tool = Point3::new(0.0, -15.0, -180.0);
    let x: Vec<f64> = (0..frames)
        .map(|i| {
            let t = i as f64 / 100.0;
            100.0 * (0.3 * t).sin() + 0.5 * (std::f64::consts::TAU * 31.0 * t).sin()
        })
        .collect();
    let samples = x
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let world_from_tool = pose_from_parts(
                Vector3::new(*v, 20.0, 300.0),
                UnitQuaternion::from_euler_angles(0.1, 0.002 * i as f64, -0.3),
            );
            Sample::measured(
                FrameIndex(i),
                i as f64 / 100.0,
                ToolPose {
                    world_from_tool,
                    tip_in_world: world_from_tool * tip_in_tool,
                    markers: 4,
                    rms_mm: 0.01,
                },
            )
        })
        .collect();
    write_trajectory(path, &Trajectory { samples }).unwrap();
    // What the file holds, as the reader sees it (6 decimals).
    read_trajectory(path)
        .unwrap()
        .samples
        .iter()
        .map(|s| s.pose.unwrap().world_from_tool.translation.x)
        .collect()
}

#[test]
fn smooth_lowpass_writes_scipy_positions_and_refuses_bad_files() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("raw.csv");
    let output = dir.path().join("smooth.csv");
    let x = write_input(&input, 3000);
    let o = teachcam(&[
        "smooth",
        input.to_str().unwrap(),
        "--method",
        "lowpass",
        "--cutoff",
        "10",
        "--order",
        "4",
        "-o",
        output.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let expected = Butterworth::lowpass(4, 10.0, 100.0)
        .unwrap()
        .filtfilt(&x)
        .unwrap();
    let smoothed = read_trajectory(&output).unwrap();
    for (s, e) in smoothed.samples.iter().zip(&expected) {
        let p = s.pose.unwrap();
        // The file has 6 decimals.
        assert!((p.world_from_tool.translation.x - e).abs() < 1e-6);
        let tip = p.world_from_tool * Point3::new(0.0, -15.0, -180.0);
        assert!((tip - p.tip_in_world).norm() < 1e-5);
    }

    // Non-uniform time: line 1 + frame 1501, exit status 1, no output written.
    let text = std::fs::read_to_string(&input).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut fields: Vec<String> = lines[1501].split(',').map(String::from).collect();
    fields[1] = "15.004000".into();
    lines[1501] = fields.join(",");
    let bad = dir.path().join("uneven.csv");
    std::fs::write(&bad, lines.join("\n")).unwrap();
    let refused = dir.path().join("refused.csv");
    let o = teachcam(&[
        "smooth",
        bad.to_str().unwrap(),
        "--cutoff",
        "10",
        "-o",
        refused.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("frame 1500") && stderr(&o).contains("uneven.csv"),
        "{}",
        stderr(&o)
    );
    assert!(!refused.exists());

    // Cut-off at Nyquist.
    let o = teachcam(&[
        "smooth",
        input.to_str().unwrap(),
        "--cutoff",
        "50",
        "-o",
        refused.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("Nyquist"), "{}", stderr(&o));

    // Too short for the padding of an order-4 filter (15 samples).
    let short = dir.path().join("short.csv");
    write_input(&short, 12);
    let o = teachcam(&[
        "smooth",
        short.to_str().unwrap(),
        "--order",
        "4",
        "-o",
        refused.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("padding"), "{}", stderr(&o));

    // A cut-off that is not a number is a usage error.
    let o = teachcam(&[
        "smooth",
        input.to_str().unwrap(),
        "--cutoff",
        "ten",
        "-o",
        refused.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!refused.exists());
}

#[test]
fn auto_cutoff_spectrum_and_study_write_their_files() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("raw.csv");
    write_input(&input, 3000);
    let output = dir.path().join("auto.csv");
    let o = teachcam(&[
        "smooth",
        input.to_str().unwrap(),
        "--cutoff",
        "auto",
        "-o",
        output.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("suggests a cut-off"), "{}", stderr(&o));

    let csv = dir.path().join("spectrum.csv");
    let o = teachcam(&[
        "spectrum",
        input.to_str().unwrap(),
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("frequency_hz,x_mm,y_mm,z_mm,rx_rad,ry_rad,rz_rad\n"));
    assert_eq!(text.lines().count(), 1 + 1501);
    // The 0.5 mm wiggle at 31 Hz sits on bin 930 of 3000 samples at 100 Hz; the slow 100 mm
    // motion is not on a bin and leaks about 1e-2 mm into it (measured 0.491).
    let bin: Vec<f64> = text
        .lines()
        .nth(1 + 930)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(
        (bin[0] - 31.0).abs() < 1e-9 && (bin[1] - 0.5).abs() < 0.02,
        "{bin:?}"
    );

    let png = dir.path().join("spectrum.png");
    let o = teachcam(&[
        "spectrum",
        input.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));

    let study = dir.path().join("study");
    let o = teachcam(&["smoothing-study", "--out", study.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        std::fs::read(study.join("study.png"))
            .unwrap()
            .starts_with(b"\x89PNG")
    );
    assert!(
        std::fs::read_to_string(study.join("study.csv"))
            .unwrap()
            .starts_with("time_s,clean_mm,noisy_mm")
    );
}

/// Real data: OptiTrack, wheelchair basketball sprint, the 4-marker `ArmL` cluster at 120 Hz
/// (`shared/data/c3d/ktk_basket_sprint_optitrack.c3d`), imported by `teachcam import`, with 73
/// gaps of 1 to 71 frames. No ground truth: the checks are what smoothing must not do.
#[test]
fn real_optitrack_arm_cluster_is_smoothed_gaps_filled_and_motion_kept() {
    let Some(data) = teachcam_testdata::shared_data("c3d") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("arm.csv");
    let c3d = data.join("ktk_basket_sprint_optitrack.c3d");
    let o = teachcam(&[
        "import",
        "c3d",
        c3d.to_str().unwrap(),
        "--markers",
        "ArmL:Marker1,ArmL:Marker2,ArmL:Marker3,ArmL:Marker4",
        "-o",
        raw.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));

    // Isolated frames are shorter than the filter's padding: refused by default, gaps on request.
    let smoothed = |cutoff: &str| {
        let out = dir.path().join(format!("arm_{cutoff}.csv"));
        let o = teachcam(&[
            "smooth",
            raw.to_str().unwrap(),
            "--cutoff",
            cutoff,
            "--short-runs",
            "gap",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        read_trajectory(&out).unwrap()
    };
    let o = teachcam(&[
        "smooth",
        raw.to_str().unwrap(),
        "--cutoff",
        "6",
        "-o",
        dir.path().join("x.csv").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("padding"), "{}", stderr(&o));

    let input = read_trajectory(&raw).unwrap();
    let rms_change = |t: &Trajectory| {
        let d: Vec<f64> = input
            .samples
            .iter()
            .zip(&t.samples)
            .filter_map(|(a, b)| {
                let (a, b) = (a.pose?, b.pose?);
                Some(
                    (a.world_from_tool.translation.vector - b.world_from_tool.translation.vector)
                        .norm_squared(),
                )
            })
            .collect();
        (d.iter().sum::<f64>() / d.len() as f64).sqrt()
    };
    let at_6 = smoothed("6");
    let at_20 = smoothed("20");
    let filled = at_6
        .samples
        .iter()
        .zip(&input.samples)
        .filter(|(s, r)| s.source == teachcam::trajectory::PoseSource::Filled && r.pose.is_none())
        .count();
    let poses = |t: &Trajectory| t.samples.iter().filter(|s| s.pose.is_some()).count();
    // Measured: 2980 raw poses, 204 filled, 3173 after smoothing; RMS change 1.87 mm at 6 Hz
    // while the cluster travels 12 m; registration RMS up to 2 mm.
    assert!(filled > 100 && poses(&at_6) > poses(&input), "{filled}");
    let (change_6, change_20) = (rms_change(&at_6), rms_change(&at_20));
    assert!(
        change_6 < 3.0 && change_20 < change_6,
        "{change_6} {change_20}"
    );
    for s in &at_6.samples {
        if let Some(p) = s.pose {
            assert!((p.world_from_tool.rotation.quaternion().norm() - 1.0).abs() < 1e-12);
        }
    }
}
