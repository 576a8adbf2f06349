//! `teachcam live`: capture → detect → track at camera rate, poses printed as they come.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use teachcam::io::trajectory::write_trajectory;
use teachcam::pipeline::recording::DetectOptions;
use teachcam::pipeline::{StreamOptions, TrackStream, TrackedFrame};
use teachcam::source::{SourceSpec, open_source};
use teachcam::track::gates::GateOverrides;
use teachcam::trajectory::{Status, Trajectory};

use anyhow::bail;
use teachcam::ros2::take::Frames;

use super::export_mcap::frame_id_problem;
use crate::Rejected;
use crate::capture::{CameraFlags, ModelFlags, parse_source, stop_requested};
use crate::ros2_live::{Ros2Live, RosEnv};

/// Track the tool live: capture → detect → track at camera rate, printing poses as they come.
///
/// The same pipeline as `track` (the library's one conductor): the gates are learned from the
/// footage — for a recording (`folder:REC`) from the same sample `track` measures them, read
/// first; for cameras and the simulator from their first 2 seconds, those frames `degraded`
/// until then — merged blobs, mirror, labels from neighbouring frames, the temporal guard
/// (for a recording it looks 15 frames ahead; live it sees only the past), the same σ model
/// and status.
///
/// Prints one CSV row per frame set on standard output as soon as its status is final
/// (`frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,tip_x_mm,tip_y_mm,tip_z_mm,markers,rms_mm,tip_std_mm,latency_ms,status`,
/// pose fields empty where the frame has no pose), or, with `--out`, writes the trajectory CSV
/// (with its `status` column, as `track` writes it) at the end instead. `latency_ms` runs from the frame's exposure to its pose on this machine's
/// clock (for V4L2 cameras from the buffer's arrival; empty for recordings, which have no
/// exposure clock). Frames the pipeline could not take in time are dropped at the source and
/// counted.
///
/// Ends at `--seconds`, at the end of a finite source, or on Ctrl-C; `--json` then prints one
/// line `{"frames": N, "dropped": N, "latency_ms_p50": X, "latency_ms_p99": X, "statuses": {...}, ...}`.
///
/// The simulator (`sim:paper`, the default) renders its frames ahead, before the clock starts,
/// and plays them back and forth at `--fps`, so the numbers are the pipeline's, not the
/// renderer's; its rig and tool are used unless `--rig`/`--tool` are given.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam live --source sim:paper --fps 60 --seconds 2 --json
  teachcam live --source v4l2:/dev/video0,/dev/video2 --rig rig.json --tool rec/tool.json --seconds 10
  ROS_LOCALHOST_ONLY=1 teachcam live --source sim:paper --ros2    (then: ros2 topic echo /teachcam/tool)"#)]
pub struct Args {
    /// Where frames come from: sim:SCENARIO, v4l2:DEVICE[,DEVICE...], folder:REC or a folder.
    #[arg(long, default_value = "sim:paper", value_parser = parse_source)]
    pub source: SourceSpec,
    #[command(flatten)]
    pub model: ModelFlags,
    /// Stop after this many seconds.
    #[arg(long, value_parser = crate::flags::positive)]
    pub seconds: Option<f64>,
    /// End with one JSON line of counts and latency percentiles.
    #[arg(long)]
    pub json: bool,
    /// Write the trajectory CSV here at the end instead of printing rows.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Publish on ROS 2 (DDS, domain `ROS_DOMAIN_ID`): /teachcam/tool
    /// (geometry_msgs/PoseWithCovarianceStamped, tip in metres), /tf (world → teachcam_tool,
    /// world → camera_NAME), /tf_static (the cameras), /teachcam/status
    /// (diagnostic_msgs/DiagnosticArray). Honours ROS_LOCALHOST_ONLY=1 and
    /// ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (loopback only, unicast).
    #[arg(long)]
    pub ros2: bool,
    /// With --ros2: the world frame's name, every message's frame_id [default: world].
    #[arg(long, requires = "ros2")]
    pub frame_id: Option<String>,
    #[command(flatten)]
    pub camera: CameraFlags,
}

/// Latency percentiles (nearest rank) in milliseconds.
fn percentile_ms(sorted_s: &[f64], p: f64) -> Option<f64> {
    if sorted_s.is_empty() {
        return None;
    }
    let rank = ((p / 100.0) * sorted_s.len() as f64).ceil().max(1.0) as usize;
    Some(1e3 * sorted_s[rank.min(sorted_s.len()) - 1])
}

fn row(frame: &TrackedFrame) -> String {
    let mut text = format!("{},{:.6}", frame.detections.index, frame.detections.time_s);
    match &frame.track.outcome {
        Ok(pose) => {
            let t = pose.world_from_tool.translation.vector;
            let q = pose.world_from_tool.rotation.quaternion();
            let tip = pose.tip_in_world;
            let _ = write!(
                text,
                ",{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{},{:.4}",
                t.x, t.y, t.z, q.w, q.i, q.j, q.k, tip.x, tip.y, tip.z, pose.markers, pose.rms_mm
            );
        }
        Err(_) => text.push_str(",,,,,,,,,,,,"),
    }
    let _ = write!(
        text,
        ",{},{},{}",
        frame
            .tip_std_mm
            .map_or_else(String::new, |s| format!("{s:.4}")),
        frame
            .latency_s()
            .map_or_else(String::new, |l| format!("{:.3}", 1e3 * l)),
        frame.status()
    );
    text
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    // ROS 2's settings are checked before the source opens (a mistake costs no rendering).
    let ros2_settings = if args.ros2 {
        let world = args.frame_id.clone().unwrap_or_else(|| "world".into());
        if let Some(problem) = frame_id_problem(&world) {
            bail!("--frame-id {world:?}: {problem}");
        }
        let frames = Frames {
            world,
            ..Frames::default()
        };
        Some((RosEnv::from_vars(|name| std::env::var(name).ok())?, frames))
    } else {
        None
    };
    let config = args.camera.source_config(&args.source, args.seconds, None);
    let (rig, tool) = args.model.load(&args.source, &config.sim)?;
    let mut source = open_source(&args.source, &config).rejected()?;
    let tool_path = args
        .model
        .tool
        .as_deref()
        .unwrap_or(Path::new("the tool file"));
    let detect = DetectOptions {
        fps: args.camera.fps,
        ..DetectOptions::default()
    };
    let options = StreamOptions::for_source(
        &args.source,
        source.fps(),
        &rig,
        &tool,
        detect,
        GateOverrides::default(),
    )
    .map_err(|e| crate::recording::pipeline_error(e, tool_path))?;
    let lag_frames = options.lag_frames;
    let mut ros2 = match ros2_settings {
        Some((env, frames)) => Some(Ros2Live::start(env, &rig, &tool, frames)?),
        None => None,
    };
    let started = Instant::now();
    let mut latencies = Vec::new();
    let mut samples = Vec::new();
    let mut posed = 0usize;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if args.out.is_none() {
        writeln!(
            out,
            "frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,tip_x_mm,tip_y_mm,tip_z_mm,markers,rms_mm,tip_std_mm,latency_ms,status"
        )?;
    }
    let (dropped, cameras_out) = {
        let mut stream = TrackStream::new(source.as_mut(), &rig, &tool, options)
            .map_err(|e| crate::recording::pipeline_error(e, tool_path))?;
        while !stop_requested() {
            if args
                .seconds
                .is_some_and(|s| started.elapsed().as_secs_f64() >= s + 1.0)
            {
                break;
            }
            let Some(frame) = stream.next() else { break };
            let frame = frame.rejected()?;
            latencies.extend(frame.latency_s());
            if frame.sample.pose.is_some() {
                posed += 1;
            }
            if let Some(ros2) = &mut ros2 {
                ros2.publish(&frame).rejected()?;
            }
            if args.out.is_none() {
                writeln!(out, "{}", row(&frame))?;
                out.flush()?;
            }
            samples.push(frame.sample);
        }
        (stream.stats().dropped_sets, stream.cameras_out().to_vec())
    };
    for camera in &cameras_out {
        crate::announce::warn(&camera.to_string());
    }
    if let Some(published) = ros2.as_ref().map(Ros2Live::published)
        && published.failed > 0
    {
        crate::announce::warn(&format!(
            "ROS 2: DDS refused {} of the messages (the others were published)",
            published.failed
        ));
    }
    if let Some(path) = &args.out {
        write_trajectory(
            path,
            &Trajectory {
                samples: samples.clone(),
            },
        )?;
    }
    latencies.sort_by(f64::total_cmp);
    let p50 = percentile_ms(&latencies, 50.0);
    let p99 = percentile_ms(&latencies, 99.0);
    let seconds = started.elapsed().as_secs_f64();
    if args.json {
        let summary = serde_json::json!({
            "frames": samples.len(),
            "dropped": dropped,
            "posed": posed,
            "latency_ms_p50": p50,
            "latency_ms_p99": p99,
            "latency_ms_max": latencies.last().map(|l| 1e3 * l),
            "seconds": seconds,
            "source": args.source.to_string(),
            "statuses": statuses(&samples),
            "lag_frames": lag_frames,
            "ros2": ros2.as_ref().map(Ros2Live::published),
        });
        writeln!(out, "{summary}")?;
    } else {
        let fmt = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.2} ms"));
        let summary = format!(
            "{} frames ({posed} posed), {dropped} dropped in {seconds:.1} s; latency p50 {}, p99 {}",
            samples.len(),
            fmt(p50),
            fmt(p99)
        );
        match &args.out {
            Some(path) => crate::announce::wrote(std::slice::from_ref(path), &summary),
            None => crate::announce::say(&summary),
        }
    }
    Ok(())
}

/// How many samples have each status.
fn statuses(samples: &[teachcam::trajectory::Sample]) -> serde_json::Value {
    let count = |status: Status| samples.iter().filter(|s| s.status == status).count();
    serde_json::json!({
        "ok": count(Status::Ok),
        "degraded": count(Status::Degraded),
        "outlier": count(Status::Outlier),
        "lost": count(Status::Lost),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_are_nearest_rank() {
        let sorted: Vec<f64> = (1..=100).map(|i| f64::from(i) * 1e-3).collect();
        assert_eq!(percentile_ms(&sorted, 50.0), Some(50.0));
        assert_eq!(percentile_ms(&sorted, 99.0), Some(99.0));
        assert_eq!(percentile_ms(&[], 50.0), None);
    }
}
