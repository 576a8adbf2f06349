//! `teachcam doctor`: why a recording tracks badly, and what to do about it.

use std::fmt::Write as _;
use std::path::PathBuf;

use teachcam::correspond::Views;
use teachcam::detect::DetectConfig;
use teachcam::doctor::{DoctorConfig, Report, diagnose};
use teachcam::pipeline::CameraSetup;
use teachcam::pipeline::recording::{DetectOptions, ROUNDNESS_SAMPLE_FRAMES, gates_from_sample};
use teachcam::pipeline::rules::FrameInput;
use teachcam::track::Tracker;
use teachcam::track::gates::{GateOverrides, ROUNDNESS_FLOOR, roundness_gate, sample_frames};
use teachcam::track::merged::{BlobShape, Shapes};

use crate::recording::detect_folder;

/// Say where a recording's frames are lost, what the data shows, and what to do.
///
/// Detects every frame's blobs (keeping blobs of any roundness, to see what the detector's
/// roundness cut drops), tracks them as `track` does with its defaults (gates measured from
/// the recording), and reports: lost
/// frames per stage (detect, correspond, identify, register); per camera the blobs' diameters
/// and roundness; per camera pair the epipolar distance of unambiguous blob matches (made
/// without the tracker's tolerance); triangulation and registration residuals; and findings
/// with advice: a camera that disagrees with the others (recalibrate it), a pair that
/// disagrees, marker images too small (move closer), blobs less round than the cut (a
/// `--min-roundness` value), a tool whose distances are not in the data.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam doctor rec --rig rec/rig.json --tool rec/tool.json
  teachcam doctor rec --rig rec/rig.json --tool rec/tool.json --json > doctor.json"#)]
pub struct Args {
    /// Recording folder: one sub-folder of PNG frames or one video file per rig camera.
    pub recording: PathBuf,
    /// Camera rig (default RECORDING/rig.json).
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// Tool model (default RECORDING/tool.json).
    #[arg(long)]
    pub tool: Option<PathBuf>,
    /// Print the report as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Nearest distance from a camera to a marker, millimetres.
    #[arg(long, default_value_t = DetectOptions::default().near_mm, value_parser = crate::flags::positive)]
    pub near: f64,
    /// Farthest distance from a camera to a marker, millimetres.
    #[arg(long, default_value_t = DetectOptions::default().far_mm, value_parser = crate::flags::positive)]
    pub far: f64,
}

/// Run the command.
#[expect(clippy::print_stdout, reason = "the report is the command's output")]
pub fn run(args: &Args) -> anyhow::Result<()> {
    let report = doctor(args)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report_text(&report));
    }
    Ok(())
}

/// The file given, else the recording's own; without either, one line saying what is missing
/// and what can be done without it (a usage error: exit 2).
fn beside(
    given: Option<&PathBuf>,
    recording: &std::path::Path,
    name: &str,
    flag: &str,
) -> anyhow::Result<PathBuf> {
    if let Some(path) = given {
        return Ok(path.clone());
    }
    let path = recording.join(name);
    if path.is_file() {
        return Ok(path);
    }
    Err(anyhow::anyhow!(
        "{} has no {name} and no {flag} was given: doctor tracks the tool with a calibrated rig and its tool model (without them, `teachcam studio {}` shows the frames, the detections and the detector's measured levels, and `teachcam detect` writes the detections)",
        recording.display(),
        recording.display()
    ))
}

/// Detects, tracks and diagnoses the recording.
///
/// # Errors
/// Rejected data when a file cannot be read or does not fit the rig; a usage error for
/// `--near` ≥ `--far`.
pub fn doctor(args: &Args) -> anyhow::Result<Report> {
    if args.near >= args.far {
        anyhow::bail!(
            "--near {} and --far {}: near must be less than far",
            args.near,
            args.far
        );
    }
    let rig_path = beside(args.rig.as_ref(), &args.recording, "rig.json", "--rig")?;
    let tool_path = beside(args.tool.as_ref(), &args.recording, "tool.json", "--tool")?;
    let rig = crate::load::rig(&rig_path)?;
    let tool = crate::load::tool(&tool_path)?;
    let recording = detect_folder(&args.recording, None, |_| {
        Ok(rig
            .cameras
            .iter()
            .map(|camera| CameraSetup {
                name: camera.name.clone(),
                detect: DetectConfig {
                    min_roundness: 0.0,
                    ..DetectConfig::for_marker(camera, tool.marker_diameter_mm, args.near, args.far)
                },
                size: Some((camera.image_size.width, camera.image_size.height)),
            })
            .collect())
    })?;
    let blobs = recording.blobs_by_camera(&rig);
    // The gates `track` would measure: roundness from the blobs above its lowest floor, the
    // others from a sample of the frames so gated. (`track` detects its roundness sample with
    // that floor, which may split a merged blob that is left whole here.)
    let roundness: Vec<f64> = sample_frames(blobs.len(), ROUNDNESS_SAMPLE_FRAMES)
        .into_iter()
        .flat_map(|f| blobs[f].values().flatten().map(|b| b.roundness))
        .filter(|r| *r >= ROUNDNESS_FLOOR)
        .collect();
    let min_roundness = roundness_gate(&roundness, None);
    let kept_roundness = min_roundness.value;
    let kept = |blobs: &[teachcam::detect::Blob]| -> Vec<teachcam::detect::Blob> {
        blobs
            .iter()
            .filter(|b| b.roundness >= kept_roundness)
            .cloned()
            .collect()
    };
    let views: Vec<Views> = blobs
        .iter()
        .map(|frame| {
            frame
                .iter()
                .map(|(id, blobs)| (*id, kept(blobs).iter().map(|b| b.center).collect()))
                .collect()
        })
        .collect();
    let shapes: Vec<Shapes> = blobs
        .iter()
        .map(|frame| {
            frame
                .iter()
                .map(|(id, blobs)| (*id, kept(blobs).iter().map(BlobShape::of).collect()))
                .collect()
        })
        .collect();
    let frames: Vec<FrameInput> = views
        .iter()
        .zip(&shapes)
        .map(|(views, shapes)| FrameInput {
            views: views.clone(),
            shapes: shapes.clone(),
            blob_noise_px: Vec::new(),
        })
        .collect();
    let gates = gates_from_sample(
        &rig,
        &tool,
        &frames,
        min_roundness,
        &GateOverrides::default(),
    );
    let tracker = Tracker::new(&rig, &tool, gates.track_config());
    let tracks = tracker.track_recording(&views, &shapes);
    let config = DoctorConfig {
        min_roundness: kept_roundness,
        ..DoctorConfig::default()
    };
    Ok(diagnose(&rig, &tool, &blobs, &tracks, &config))
}

fn spread(s: Option<teachcam::doctor::Spread>, unit: &str) -> String {
    s.map_or_else(
        || "none".to_string(),
        |s| {
            format!(
                "{:.2} {unit} (p10 {:.2}, p90 {:.2}, n {})",
                s.median, s.p10, s.p90, s.count
            )
        },
    )
}

/// The report as the screen shows it.
fn report_text(report: &Report) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "frames: {} posed of {} ({:.0} %)",
        report.posed,
        report.frames,
        100.0 * report.posed as f64 / report.frames.max(1) as f64
    );
    for (stage, count) in &report.lost {
        let _ = writeln!(out, "  lost {count:>6}  {}", stage.meaning());
    }
    let _ = writeln!(out, "cameras:");
    for c in &report.cameras {
        let _ = writeln!(
            out,
            "  {}: blobs/frame {} ({} seen, {} in the tool's points); diameter {}; roundness {}; {:.0} % under the roundness cut{}",
            c.camera,
            c.blobs_per_frame.map_or(0.0, |s| s.median),
            c.blobs_seen,
            c.blobs_used,
            spread(c.diameter_px, "px"),
            spread(c.roundness, ""),
            100.0 * c.below_roundness_cut,
            c.predicted_diameter_px.map_or(String::new(), |d| format!(
                "; the marker should image {d:.1} px at {:.0} mm",
                c.distance_mm.unwrap_or(0.0)
            )),
        );
    }
    let _ = writeln!(
        out,
        "camera pairs (epipolar distance of unambiguous matches):"
    );
    for p in &report.pairs {
        let _ = writeln!(
            out,
            "  {}-{}: {}{}",
            p.a,
            p.b,
            spread(p.epipolar_px, "px"),
            if p.disagrees { "  DISAGREE" } else { "" }
        );
    }
    let _ = writeln!(
        out,
        "triangulation residual: {}",
        spread(report.triangulation_residual_px, "px")
    );
    let _ = writeln!(
        out,
        "registration residual: {}",
        spread(report.registration_rms_mm, "mm")
    );
    if report.findings.is_empty() {
        let _ = writeln!(out, "findings: none");
    } else {
        let _ = writeln!(out, "findings:");
        for f in &report.findings {
            let _ = writeln!(out, "  - {f}");
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    #[test]
    fn empty_report_reads() {
        let report = Report {
            frames: 0,
            posed: 0,
            lost: BTreeMap::new(),
            cameras: Vec::new(),
            pairs: Vec::new(),
            triangulation_residual_px: None,
            registration_rms_mm: None,
            findings: Vec::new(),
        };
        assert!(report_text(&report).contains("findings: none"));
    }
}
