//! `teachcam track`: the tool's trajectory from a recording (paper §II).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use teachcam::correspond::Views;
use teachcam::detect::{CenterMethod, DetectConfig, Threshold};
use teachcam::identify::check_identifiable;
use teachcam::io::recording::{check_recording_against_rig, open_recording, read_frame};
use teachcam::io::trajectory::trajectory_csv;
use teachcam::io::{Output, OutputSet, check_outputs, rig::read_rig, tool::read_tool};
use teachcam::metrology::{first_order, residual_noise_px};
use teachcam::sync::ResampleIssue;
use teachcam::track::{FrameTrack, TrackConfig, Tracker};
use teachcam::trajectory::Trajectory;

use crate::Rejected;
use crate::cmd::detect::detect_recording;

mod time_offsets;

/// Track the tool through a recording: its pose in every frame.
///
/// Detects the marker blobs in every camera, match them
/// across cameras (the paper's trinocular loop), triangulate, identify the tool's markers by
/// their distances, and register the tool (SVD, scale 1). Writes the contract's trajectory CSV:
/// one row per frame, pose fields empty where the frame has no pose, plus `tip_std_mm`, the
/// first-order tip uncertainty of the frame: its blobs' predicted centre noise, scaled to the
/// pixel error the recording's triangulation residuals show (which also holds detector bias and
/// calibration error).
///
/// Example: `teachcam track rec --rig rec/rig.json --tool rec/tool.json -o raw.csv --diagnostics diag.csv`
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Recording folder: one sub-folder of PNG frames per rig camera.
    pub recording: PathBuf,
    /// Camera rig (rig.json).
    #[arg(long)]
    pub rig: PathBuf,
    /// Tool model (tool.json).
    #[arg(long)]
    pub tool: PathBuf,
    /// Output trajectory CSV.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write the identified 3-D markers per frame:
    /// `frame,marker,x_mm,y_mm,z_mm,views,residual_px`.
    #[arg(long)]
    pub markers_out: Option<PathBuf>,
    /// Also write per-frame diagnostics: `frame,status,reason,points,markers,views_per_marker,max_residual_px`.
    #[arg(long)]
    pub diagnostics: Option<PathBuf>,
    /// Frames per second (overrides recording.json; default 30).
    #[arg(long, value_parser = crate::flags::fps)]
    pub fps: Option<f64>,
    /// Centre estimate: refined (default), centroid or smallest-circle (the paper's).
    #[arg(long, default_value = "refined")]
    pub method: CenterMethod,
    /// Fixed detection threshold in the images' units (default: automatic per frame).
    #[arg(long)]
    pub threshold: Option<u32>,
    /// Nearest distance from a camera to a marker, millimetres.
    #[arg(long, default_value_t = 300.0, value_parser = crate::flags::positive)]
    pub near: f64,
    /// Farthest distance from a camera to a marker, millimetres.
    #[arg(long, default_value_t = 3000.0, value_parser = crate::flags::positive)]
    pub far: f64,
    /// Largest distance of a blob from an epipolar line, pixels.
    #[arg(long, default_value_t = TrackConfig::default().correspond.epipolar_tolerance_px, value_parser = crate::flags::positive)]
    pub epipolar_tolerance: f64,
    /// Tolerance on marker distances for identification, millimetres.
    #[arg(long, default_value_t = TrackConfig::default().identify.distance_tolerance_mm, value_parser = crate::flags::positive)]
    pub distance_tolerance: f64,
    /// Unsynchronised cameras: `auto` estimates each camera's time offset from the blobs (on
    /// the first camera's clock; refused with a message when the tool barely moves), or give
    /// them, seconds, `cam1=0.0093,cam2=-0.0131` (frame k of a camera exposed at k/fps +
    /// offset) or as a JSON file written by `--time-offsets-out`. Blobs are moved to common
    /// frame times before correspondence; frames where some could not be are listed in the
    /// diagnostics' `resampling` column.
    #[arg(long)]
    pub time_offsets: Option<time_offsets::TimeOffsetsArg>,
    /// Also write the offsets applied: `{"cam0": 0.0, "cam1": 0.0093, ...}`, seconds.
    #[arg(long, requires = "time_offsets")]
    pub time_offsets_out: Option<PathBuf>,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (trajectory, written) = track_to_files(args)?;
    let tracked = trajectory
        .samples
        .iter()
        .filter(|s| s.pose.is_some())
        .count();
    crate::announce::wrote(
        &written,
        &format!("{tracked} of {} frames tracked", trajectory.len()),
    );
    Ok(())
}

/// Detects, tracks and writes the trajectory and the optional files, all or none; returns the
/// trajectory and the files written. Prints nothing but a progress bar on a terminal.
pub fn track_to_files(args: &Args) -> anyhow::Result<(Trajectory, Vec<PathBuf>)> {
    let mut outputs = vec![Output::csv(&args.output)];
    outputs.extend(args.markers_out.as_deref().map(Output::csv));
    outputs.extend(args.diagnostics.as_deref().map(Output::csv));
    outputs.extend(args.time_offsets_out.as_deref().map(|path| Output {
        path,
        format: "time offsets JSON",
        extensions: &["json"],
    }));
    check_outputs(&outputs, &[&args.rig, &args.tool])?;
    let rig = read_rig(&args.rig).rejected()?;
    let tool = read_tool(&args.tool).rejected()?;
    let mut config = TrackConfig::default();
    config.correspond.epipolar_tolerance_px = args.epipolar_tolerance;
    config.identify.distance_tolerance_mm = args.distance_tolerance;
    check_identifiable(&tool, &config.identify)
        .with_context(|| format!("{}", args.tool.display()))
        .rejected()?;
    if args.near >= args.far {
        anyhow::bail!(
            "--near {} and --far {}: near must be less than far",
            args.near,
            args.far
        );
    }
    let mut recording = open_recording(&args.recording, args.fps).rejected()?;
    check_recording_against_rig(&recording, &rig).rejected()?;
    // Only the rig's cameras, in the rig's order, each checked for its image size.
    recording.cameras = rig
        .cameras
        .iter()
        .filter_map(|c| recording.camera(&c.name).cloned())
        .collect();
    for (camera, frames) in rig.cameras.iter().zip(&recording.cameras) {
        let expected = (camera.image_size.width, camera.image_size.height);
        if let Some(first) = frames.frames.first() {
            read_frame(first, Some(expected))
                .with_context(|| format!("camera {}", camera.name))
                .rejected()?;
        }
    }
    let configs: Vec<DetectConfig> = rig
        .cameras
        .iter()
        .map(|camera| {
            let mut cfg =
                DetectConfig::for_marker(camera, tool.marker_diameter_mm, args.near, args.far);
            cfg.method = args.method;
            if let Some(t) = args.threshold {
                cfg.threshold = Threshold::Fixed(t);
            }
            cfg
        })
        .collect();
    let detections = detect_recording(&recording, &configs)?;

    let frame_count = recording.frame_count();
    let mut views: Vec<Views> = vec![Views::new(); frame_count];
    let mut noise: Vec<Vec<f64>> = vec![Vec::new(); frame_count];
    for d in &detections {
        let Some(id) = rig.id_of(&d.camera) else {
            continue;
        };
        views[d.frame].insert(id, d.blobs.iter().map(|b| b.center).collect());
        noise[d.frame].extend(d.blobs.iter().map(|b| b.center_std_px));
    }
    let synchronised = match &args.time_offsets {
        Some(arg) => {
            let synchronised = time_offsets::synchronise(arg, &rig, views, recording.fps)?;
            crate::announce::say(&time_offsets::summary(&rig, &synchronised));
            views = synchronised.frames.clone();
            Some(synchronised)
        }
        None => None,
    };
    let tracker = Tracker::new(&rig, &tool, config);
    let (mut trajectory, tracks) = tracker.track_all(&views, recording.fps);
    // The blobs' own σ hold image noise only; the markers' triangulation residuals show the
    // whole pixel error (on the paper scene 0.0085 px against a predicted 0.0030 px), so the
    // per-frame σ keep their relative sizes and take the residuals' scale.
    let predicted_px = rms(&noise.concat());
    let shown_px = residual_noise_px(
        tracks
            .iter()
            .flat_map(|t| t.labels.values().map(|&p| &t.points[p])),
    );
    let scale = match shown_px {
        Some(shown) if predicted_px > 0.0 => shown / predicted_px,
        _ => 1.0,
    };
    for (sample, frame_noise) in trajectory.samples.iter_mut().zip(&noise) {
        let Some(pose) = sample.pose else { continue };
        let frame_px = scale * rms(frame_noise);
        if frame_px > 0.0 {
            sample.tip_std_mm = first_order(&rig, &tool, &pose.world_from_tool, frame_px)
                .ok()
                .map(|u| u.tip_rms_mm);
        }
    }
    let outputs = OutputSet::new();
    outputs.add(&args.output, trajectory_csv(&trajectory).as_bytes())?;
    if let Some(path) = &args.markers_out {
        outputs.add(path, markers_csv(&tracks).as_bytes())?;
    }
    if let Some(path) = &args.diagnostics {
        let issues = synchronised.as_ref().map(|s| s.issues.as_slice());
        outputs.add(path, diagnostics_csv(&tracks, issues).as_bytes())?;
    }
    if let (Some(path), Some(synchronised)) = (&args.time_offsets_out, &synchronised) {
        let json = time_offsets::offsets_json(&rig, &synchronised.offsets)?;
        outputs.add(path, json.as_bytes())?;
    }
    let written = outputs.commit()?;
    Ok((trajectory, written))
}

/// Root mean square of `values`; 0 for none.
pub(crate) fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len().max(1) as f64).sqrt()
}

fn markers_csv(tracks: &[FrameTrack]) -> String {
    let mut out = String::from("frame,marker,x_mm,y_mm,z_mm,views,residual_px\n");
    for (frame, track) in tracks.iter().enumerate() {
        for (marker, point) in &track.labels {
            let p = &track.points[*point];
            let _ = writeln!(
                out,
                "{frame},{},{:.6},{:.6},{:.6},{},{:.4}",
                marker.0,
                p.position.x,
                p.position.y,
                p.position.z,
                p.views.len(),
                p.residual_px
            );
        }
    }
    out
}

/// The per-frame diagnostics; with time offsets, a last column `resampling` lists what could
/// not be moved to the common time, and such a frame's status is `degraded`.
fn diagnostics_csv(tracks: &[FrameTrack], resampling: Option<&[Vec<ResampleIssue>]>) -> String {
    let mut out =
        String::from("frame,status,reason,points,markers,views_per_marker,max_residual_px");
    out.push_str(if resampling.is_some() {
        ",resampling\n"
    } else {
        "\n"
    });
    for (frame, track) in tracks.iter().enumerate() {
        let issues: Vec<String> = resampling
            .and_then(|r| r.get(frame))
            .map(|issues| {
                issues
                    .iter()
                    .map(|i| i.to_string().replace(',', ";"))
                    .collect()
            })
            .unwrap_or_default();
        let (status, reason) = match &track.outcome {
            Ok(_) if !issues.is_empty() => ("degraded", String::new()),
            Ok(_) => ("tracked", String::new()),
            Err(lost) => ("lost", lost.to_string().replace(',', ";")),
        };
        let views: Vec<String> = track
            .views_per_marker()
            .iter()
            .map(|(m, v)| format!("{}:{v}", m.0))
            .collect();
        let max_residual = track
            .points
            .iter()
            .map(|p| p.residual_px)
            .fold(0.0, f64::max);
        let _ = write!(
            out,
            "{frame},{status},{reason},{},{},{},{max_residual:.4}",
            track.points.len(),
            track.labels.len(),
            views.join(" ")
        );
        if resampling.is_some() {
            let _ = write!(out, ",{}", issues.join(" | "));
        }
        out.push('\n');
    }
    out
}
