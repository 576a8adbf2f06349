//! `teachcam record` and `teachcam live` on the simulated rig: a recording any command reads,
//! a live run's summary, Ctrl-C ending a recording cleanly, and the flags a user can get wrong.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use std::process::{Command, Stdio};

use teachcam::io::recording::{list_recording, read_timestamps};
use teachcam::io::trajectory::read_trajectory;

#[path = "support/run.rs"]
mod run;
use run::teachcam;

fn stderr(output: &std::process::Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn a_recorded_simulation_is_a_recording_that_track_reads() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let rec_s = rec.to_str().unwrap();
    // 10 Hz: three 1280×1024 PNG encodings per set stay well within a loaded machine's means.
    let out = teachcam(&[
        "record",
        "--source",
        "sim:paper",
        "--fps",
        "10",
        "--frames",
        "12",
        "--out",
        rec_s,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let summary = stderr(&out);
    assert!(
        summary.contains("12 frames per camera (cam0 12, cam1 12, cam2 12)"),
        "{summary}"
    );

    let listing = list_recording(&rec, None).unwrap();
    assert_eq!(listing.fps, Some(10.0));
    let times = read_timestamps(&rec.join("timestamps.csv")).unwrap();
    for camera in ["cam0", "cam1", "cam2"] {
        let t = &times[camera];
        assert_eq!(t.len(), 12);
        // The simulated rig is triggered at 10 Hz: frame times are whole periods apart (more
        // than one where a set was dropped), the same for every camera.
        for (i, time_s) in t.iter().enumerate() {
            let periods = time_s * 10.0;
            assert!(
                (periods - periods.round()).abs() < 1e-4,
                "{camera} {i}: {time_s}"
            );
            assert_eq!(*time_s, times["cam0"][i]);
        }
    }

    let traj = dir.path().join("raw.csv");
    let out = teachcam(&[
        "track",
        rec_s,
        "--rig",
        rec.join("rig.json").to_str().unwrap(),
        "--tool",
        rec.join("tool.json").to_str().unwrap(),
        "-o",
        traj.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let trajectory = read_trajectory(&traj).unwrap();
    assert_eq!(trajectory.samples.len(), 12);
    assert!(trajectory.samples.iter().all(|s| s.pose.is_some()));
}

#[test]
fn ctrl_c_ends_a_recording_with_whole_frames_and_a_valid_folder() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let child = Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(["record", "--source", "sim:paper", "--fps", "30", "--out"])
        .arg(&rec)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Rendering ahead takes a few seconds; then frames are written at 30 Hz, into a staging
    // folder beside `rec` (`.rec.teachcam-tmp-PID`): `rec` appears whole, on stop.
    let started = std::time::Instant::now();
    let staged_frame = || {
        std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(Result::ok)
            .any(|e| e.path().join("cam2").join("000003.png").exists())
    };
    while !staged_frame() {
        if started.elapsed().as_secs() > 120 {
            let _ = Command::new("kill").arg(child.id().to_string()).status();
            panic!("no frames written in 120 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    assert!(!rec.exists(), "the recording appears only when it is whole");
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("(stopped by signal)"),
        "{}",
        stderr(&out)
    );
    // Every camera has the same frames, each a whole PNG, and a time for each.
    let listing = list_recording(&rec, None).unwrap();
    let times = listing.timestamps.unwrap();
    for camera in &listing.cameras {
        let teachcam::io::recording::CameraMedia::Images(frames) = &camera.media else {
            panic!("record writes PNG folders");
        };
        assert_eq!(frames.len(), times[&camera.name].len());
        for frame in frames {
            teachcam::io::recording::read_frame(frame, Some((1280, 1024))).unwrap();
        }
    }
}

/// One HTTP/1.1 GET over loopback; the response's status line and body.
fn http_get(port: u16, path: &str) -> (String, String) {
    use std::io::{Read, Write};
    let mut stream = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut response = String::new();
    stream.read_to_string(&mut response).unwrap();
    let (head, body) = response.split_once("\r\n\r\n").unwrap_or((&response, ""));
    (
        head.lines().next().unwrap_or_default().to_string(),
        body.to_string(),
    )
}

/// `teachcam studio` prints its address, answers `/api/status` with `source` and `frames`,
/// and ends cleanly (status 0) on Ctrl-C.
#[test]
fn studio_serves_its_status_and_ends_on_ctrl_c() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args(["studio", "--out"])
        .arg(dir.path().join("takes"))
        .current_dir(dir.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let url = line
        .strip_prefix("teachcam studio: http://127.0.0.1:")
        .unwrap_or_else(|| panic!("the first line is the address: {line:?}"));
    let (port, rest) = url.split_once('/').unwrap();
    let port: u16 = port.parse().unwrap();
    assert!(rest.trim_end().starts_with("?token="), "{line}");
    let mut frames = 0;
    let started = std::time::Instant::now();
    while frames < 3 {
        assert!(started.elapsed().as_secs() < 60, "no frames tracked");
        std::thread::sleep(std::time::Duration::from_millis(100));
        let (status, body) = http_get(port, "/api/status");
        assert!(status.contains(" 200 "), "{status}");
        let status: serde_json::Value = serde_json::from_str(&body).unwrap();
        assert_eq!(status["source"], "sim:paper", "{status}");
        frames = status["frames"].as_u64().unwrap();
    }
    let (status, _) = http_get(port, "/nothing-here");
    assert!(status.contains(" 404 "), "{status}");
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        !dir.path().join("takes").exists(),
        "nothing recorded, nothing written"
    );
}

#[test]
fn live_on_the_simulator_ends_with_its_json_summary() {
    let dir = tempfile::tempdir().unwrap();
    let traj = dir.path().join("live.csv");
    let out = teachcam(&[
        "live",
        "--source",
        "sim:paper",
        "--fps",
        "30",
        "--seconds",
        "1",
        "--json",
        "--out",
        traj.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let summary: serde_json::Value = serde_json::from_str(stdout.lines().last().unwrap()).unwrap();
    assert_eq!(summary["frames"], 30);
    assert_eq!(summary["dropped"], 0);
    assert!(summary["latency_ms_p50"].as_f64().unwrap() > 0.0);
    assert!(
        summary["latency_ms_p99"].as_f64().unwrap() >= summary["latency_ms_p50"].as_f64().unwrap()
    );
    assert_eq!(read_trajectory(&traj).unwrap().samples.len(), 30);
}

#[test]
fn wrong_flags_are_usage_errors_naming_the_flag() {
    for args in [
        &["live", "--source", "sim:nope"][..],
        &["live", "--source", "rtsp:cam"][..],
        &["live", "--fps", "0"][..],
        &["live", "--seconds=-1"][..],
        &["record", "--out", "x", "--frames", "0"][..],
        &["record", "--out", "x", "--fps", "nan"][..],
    ] {
        let out = teachcam(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        let message = stderr(&out);
        assert!(message.contains("--"), "{args:?}: {message}");
    }
    let out = teachcam(&[
        "live",
        "--source",
        "v4l2:/dev/teachcam-no-such-camera",
        "--seconds",
        "1",
    ]);
    assert_ne!(out.status.code(), Some(0));
    assert!(
        stderr(&out).contains("--rig and --tool"),
        "{}",
        stderr(&out)
    );
}

/// SIGTERM (a service manager's stop) ends `live` as Ctrl-C does, after the frame set in hand
/// and with its summary, but with SIGTERM's status, 143, and a line saying so (it was 130 and
/// silent before: second campaign).
#[test]
fn live_ends_on_sigterm_with_its_status_and_a_line() {
    let child = Command::new(env!("CARGO_BIN_EXE_teachcam"))
        .args([
            "live",
            "--source",
            "sim:paper",
            "--fps",
            "30",
            "--seconds",
            "120",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_secs(3));
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let started = std::time::Instant::now();
    let out = child.wait_with_output().unwrap();
    assert!(
        started.elapsed().as_secs() < 60,
        "live went on after SIGTERM"
    );
    assert_eq!(out.status.code(), Some(143), "{}", stderr(&out));
    assert!(stderr(&out).contains("SIGTERM"), "{}", stderr(&out));
}
