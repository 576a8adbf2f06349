//! `teachcam track`: the tool's trajectory from a recording (paper §II).

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use teachcam::correspond::Views;
use teachcam::detect::{CenterMethod, DetectConfig, RoundnessChoices, Threshold};
use teachcam::identify::{IdentifyConfig, check_identifiable};
use teachcam::io::detections::read_detections;
use teachcam::io::recording::DEFAULT_FPS;
use teachcam::io::trajectory::trajectory_text;
use teachcam::io::{Output, OutputSet, check_outputs};
use teachcam::pipeline::{CameraDetections, CameraSetup, DetectedSet};
use teachcam::source::folder::{RecordingClock, recording_clock};
use teachcam::sync::ResampleIssue;
use teachcam::track::gates::{
    Gate, GateOverrides, ROUNDNESS_FLOOR, measure_gates, roundness_gate, sample_frames,
};
use teachcam::track::merged::{BlobShape, Shapes};
use teachcam::track::uncertainty::tip_std_mm;
use teachcam::track::{FrameTrack, Tracker, guard_in_time, trajectory_from_tracks};
use teachcam::trajectory::{Status, Trajectory};

use crate::Rejected;
use crate::cmd::detect::{DetectedRecording, detect_folder, sampled_sets};

pub use teachcam::track::uncertainty::rms;

/// The gates measured from [`GATE_SAMPLE_FRAMES`] frames spread over the recording
/// (`views[i]` and `shapes[i]` are frame `i`'s), as `track` and `doctor` measure them.
pub fn measure_gates_from_sample(
    rig: &teachcam::camera::Rig,
    tool: &teachcam::tool::Tool,
    views: &[Views],
    shapes: &[Shapes],
    min_roundness: Gate,
    overrides: &GateOverrides,
) -> teachcam::track::gates::Gates {
    let sample = sample_frames(views.len(), GATE_SAMPLE_FRAMES);
    let sampled: Vec<Views> = sample.iter().map(|&f| views[f].clone()).collect();
    let sampled_shapes: Vec<Shapes> = sample.iter().map(|&f| shapes[f].clone()).collect();
    measure_gates(
        rig,
        tool,
        &sampled,
        &sampled_shapes,
        min_roundness,
        overrides,
    )
}

/// Frames whose blobs (detected at the lowest floor) measure the roundness gate.
pub const ROUNDNESS_SAMPLE_FRAMES: usize = 60;

/// Frames tracked in the first pass that measures the other gates.
pub const GATE_SAMPLE_FRAMES: usize = 300;

/// Below this fraction of frames posed, `track` points to `teachcam doctor`.
const DOCTOR_BELOW: f64 = 0.9;

mod time_offsets;

/// Track the tool through a recording: its pose in every frame.
///
/// Detects the marker blobs in every camera, matches them across cameras (the paper's
/// trinocular loop; with two cameras, blobs near one epipolar line are paired every possible
/// way and the tool's distances choose), triangulates (leaving out a view that disagrees with
/// three or more), identifies the tool's markers by their distances, and registers the tool
/// (SVD, scale 1).
///
/// Gates: a first pass over a sample of frames measures what this rig and these images give
/// (blob roundness, epipolar residuals per camera pair, triangulation and registration
/// residuals, marker distance errors) and sets every limit from it (median ± k·MAD, with floors
/// and ceilings). They are printed on stderr, written to `<diagnostics stem>.gates.json`
/// beside `--diagnostics`, and each can be fixed by its flag.
///
/// Writes the contract's trajectory CSV: one row per frame, pose fields empty where the frame
/// has no pose, `tip_std_mm` (the frame's first-order tip uncertainty, scaled to the pixel
/// error the recording's residuals show and grown with the frame's own residuals beyond the
/// typical ones) and `status`: ok, degraded (a view dropped, fewer markers than the tool has),
/// outlier (pose written, a registration or marker residual beyond the gate) or lost (no pose); the reason
/// is in `--diagnostics`.
///
/// Exit status: 0 when the tool was tracked, 1 for rejected data, 2 for usage, 3 when the tool
/// was not found in any frame (nothing is written then).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam track rec --rig rec/rig.json --tool rec/tool.json -o raw.csv --markers-out markers.csv
  teachcam track rec --rig rec/rig.json --tool rec/tool.json -o raw.csv --diagnostics diag.csv
  teachcam track rec --detections detections.csv --rig rec/rig.json --tool rec/tool.json -o raw-from-detections.csv"#)]
pub struct Args {
    /// Recording folder: one sub-folder of PNG frames or one video file (`cam0.avi`, any
    /// format FFmpeg reads) per rig camera; `timestamps.csv` beside them gives frame times.
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
    /// Also write per-frame diagnostics
    /// (`frame,status,reason,points,markers,views_per_marker,max_residual_px,combinations,reflections`) and
    /// the gates beside it (`<stem>.gates.json`).
    #[arg(long)]
    pub diagnostics: Option<PathBuf>,
    #[command(flatten)]
    pub detect: DetectFlags,
    /// Gates fixed by hand (default: measured from the recording).
    #[command(flatten)]
    pub gates: GateFlags,
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
    /// Track these blobs (`teachcam detect`'s CSV) instead of detecting the images, so that
    /// detection is tuned once. The recording folder, where present, still gives the rate
    /// (`recording.json`, `--fps`), the frame times (`timestamps.csv`) and the frame count;
    /// every camera of the file must be a rig camera and every frame within the recording.
    /// The blobs are tracked as detected (`--min-roundness` leaves out the less round ones).
    #[arg(long, conflicts_with_all = ["method", "threshold", "near", "far"])]
    pub detections: Option<PathBuf>,
}

/// The gates a user can fix; each one left out is measured from the recording.
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct GateFlags {
    /// Smallest blob roundness kept, 0..1 (1 = disc; two touching equal discs score 0.5).
    #[arg(long, value_parser = crate::flags::unit_interval)]
    pub min_roundness: Option<f64>,
    /// Largest distance of a blob from an epipolar line, pixels (every camera pair).
    #[arg(long, value_parser = crate::flags::positive)]
    pub epipolar_tolerance: Option<f64>,
    /// Largest RMS triangulation residual of a marker, pixels.
    #[arg(long, value_parser = crate::flags::positive)]
    pub max_residual_px: Option<f64>,
    /// Tolerance on marker distances for identification, millimetres.
    #[arg(long, value_parser = crate::flags::positive)]
    pub distance_tolerance: Option<f64>,
    /// Largest registration RMS of an `ok` pose, millimetres (up to 3 times it: `outlier`).
    #[arg(long, value_parser = crate::flags::positive)]
    pub max_registration_rms: Option<f64>,
}

impl GateFlags {
    /// The gates these flags fix (clap has checked their values).
    #[must_use]
    pub fn overrides(&self) -> GateOverrides {
        GateOverrides {
            min_roundness: self.min_roundness,
            epipolar_tolerance_px: self.epipolar_tolerance,
            max_residual_px: self.max_residual_px,
            distance_tolerance_mm: self.distance_tolerance,
            max_registration_rms_mm: self.max_registration_rms,
        }
    }
}

/// The tool was not found in any frame (exit status 3).
#[derive(Debug)]
pub struct ToolNotFound(pub String);

impl std::fmt::Display for ToolNotFound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ToolNotFound {}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (trajectory, written) = track_to_files(args)?;
    let trajectory = &trajectory;
    let count = |status: Status| {
        trajectory
            .samples
            .iter()
            .filter(|s| s.status == status)
            .count()
    };
    let posed = trajectory
        .samples
        .iter()
        .filter(|s| s.pose.is_some())
        .count();
    crate::announce::wrote(
        &written,
        &format!(
            "{posed} of {} frames tracked ({} ok, {} degraded, {} outlier, {} lost)",
            trajectory.len(),
            count(Status::Ok),
            count(Status::Degraded),
            count(Status::Outlier),
            count(Status::Lost),
        ),
    );
    if (posed as f64) < DOCTOR_BELOW * trajectory.len() as f64 {
        eprintln!(
            "fewer than {:.0} % of the frames posed: see `teachcam doctor {} --rig {} --tool {}`{}",
            100.0 * DOCTOR_BELOW,
            args.recording.display(),
            args.rig.display(),
            args.tool.display(),
            if args.diagnostics.is_none() {
                " or --diagnostics"
            } else {
                ""
            }
        );
    }
    Ok(())
}

/// Blob centres of each frame (rig camera ids), their shapes and each frame's blobs'
/// predicted noise.
pub fn views_of(
    rig: &teachcam::camera::Rig,
    recording: &DetectedRecording,
) -> (Vec<Views>, Vec<Shapes>, Vec<Vec<f64>>) {
    let by_camera = recording.blobs_by_camera(rig);
    let shapes = by_camera
        .iter()
        .map(|frame| {
            frame
                .iter()
                .map(|(id, blobs)| (*id, blobs.iter().map(BlobShape::of).collect()))
                .collect()
        })
        .collect();
    let views = by_camera
        .iter()
        .map(|frame| {
            frame
                .iter()
                .map(|(id, blobs)| (*id, blobs.iter().map(|b| b.center).collect()))
                .collect()
        })
        .collect();
    let noise = by_camera
        .iter()
        .map(|frame| frame.values().flatten().map(|b| b.center_std_px).collect())
        .collect();
    (views, shapes, noise)
}

/// Where the gates are written beside the diagnostics: `<stem>.gates.json`.
#[must_use]
pub fn gates_path(diagnostics: &Path) -> PathBuf {
    let stem = diagnostics.file_stem().map_or_else(
        || "diagnostics".into(),
        |s| s.to_string_lossy().into_owned(),
    );
    diagnostics.with_file_name(format!("{stem}.gates.json"))
}

/// Detects, measures the gates, tracks and writes the trajectory and the optional files, all
/// or none; returns the trajectory and the files written. Prints the gates on stderr and
/// nothing else but a progress bar on a terminal.
pub fn track_to_files(args: &Args) -> anyhow::Result<(Trajectory, Vec<PathBuf>)> {
    let gates_json = args.diagnostics.as_deref().map(gates_path);
    let mut outputs = vec![Output::csv(&args.output)];
    outputs.extend(args.markers_out.as_deref().map(Output::csv));
    outputs.extend(args.diagnostics.as_deref().map(Output::csv));
    outputs.extend(gates_json.as_deref().map(|path| Output {
        path,
        format: "JSON",
        extensions: &["json"],
    }));
    outputs.extend(args.time_offsets_out.as_deref().map(|path| Output {
        path,
        format: "time offsets JSON",
        extensions: &["json"],
    }));
    let mut inputs = vec![args.rig.as_path(), args.tool.as_path()];
    inputs.extend(args.detections.as_deref());
    check_outputs(&outputs, &inputs)?;
    let overrides = args.gates.overrides();
    let rig = crate::load::rig(&args.rig)?;
    let tool = crate::load::tool(&args.tool)?;
    if let Some(tolerance) = overrides.distance_tolerance_mm {
        check_identifiable(
            &tool,
            &IdentifyConfig {
                distance_tolerance_mm: tolerance,
            },
        )
        .with_context(|| format!("{}", args.tool.display()))
        .rejected()?;
    }
    let (recording, min_roundness) = match &args.detections {
        Some(path) => recording_from_detections(args, path, &rig, overrides.min_roundness)?,
        None => {
            let detected = detect_for_tracking(
                &args.recording,
                &rig,
                &tool,
                &args.detect,
                overrides.min_roundness,
            )?;
            (detected.recording, detected.min_roundness)
        }
    };
    let frame_count = recording.sets.len();
    let (mut views, shapes, noise) = views_of(&rig, &recording);
    let synchronised = match &args.time_offsets {
        Some(arg) => {
            let synchronised = time_offsets::synchronise(arg, &rig, views, recording.fps)?;
            crate::announce::say(&time_offsets::summary(&rig, &synchronised));
            views = synchronised.frames.clone();
            Some(synchronised)
        }
        None => None,
    };

    // Resampled blobs (time offsets) no longer sit where their shapes were measured.
    let shapes = if synchronised.is_some() {
        vec![Shapes::new(); frame_count]
    } else {
        shapes
    };
    // The other gates from a sample of the detected frames.
    let gates = measure_gates_from_sample(&rig, &tool, &views, &shapes, min_roundness, &overrides);
    if !crate::announce::quiet() {
        eprint!("{gates}");
    }
    let config = gates.track_config();
    check_identifiable(&tool, &config.identify)
        .with_context(|| format!("{}", args.tool.display()))
        .rejected()?;

    let tracker = Tracker::new(&rig, &tool, config);
    let mut tracks = tracker.track_recording(&views, &shapes);
    let stds = tip_std_mm(&rig, &tool, &tracks, &noise);
    crate::announce::say(&match guard_in_time(&mut tracks, &stds) {
        Some(gate) => format!(
            "  {:<24} {:>8.3} mm  {}",
            "tip step per frame", gate.value, gate.reason
        ),
        None => format!(
            "  {:<24} none: too few steps between ok frames",
            "tip step per frame"
        ),
    });
    let times: Vec<f64> = recording.sets.iter().map(|s| s.time_s).collect();
    let mut trajectory = trajectory_from_tracks(&tracks, &times);
    if let Some(synchronised) = &synchronised {
        // A frame whose blobs could not all be moved to the common time is degraded.
        for (sample, issues) in trajectory.samples.iter_mut().zip(&synchronised.issues) {
            if sample.status == Status::Ok && !issues.is_empty() {
                sample.status = Status::Degraded;
            }
        }
    }
    if trajectory.samples.iter().all(|s| s.pose.is_none()) {
        return Err(anyhow::Error::new(ToolNotFound(not_found_message(
            &tool.name, &tracks,
        ))));
    }
    for (sample, std) in trajectory.samples.iter_mut().zip(stds) {
        sample.tip_std_mm = std;
    }
    let outputs = OutputSet::new();
    outputs.add(
        &args.output,
        trajectory_text(&args.output, &trajectory)?.as_bytes(),
    )?;
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
    if let Some(path) = &gates_json {
        let json = serde_json::to_string_pretty(&gates).context("gates as JSON")?;
        outputs.add(path, json.as_bytes())?;
    }
    let written = outputs.commit()?;
    Ok((trajectory, written))
}

/// The recording as `detect` saw it, from its detections file (`--detections`): one set per
/// frame of the recording, each rig camera's blobs of that frame (those below a given
/// `--min-roundness` left out), times and rate from the recording folder where it exists.
fn recording_from_detections(
    args: &Args,
    path: &Path,
    rig: &teachcam::camera::Rig,
    min_roundness: Option<f64>,
) -> anyhow::Result<(DetectedRecording, Gate)> {
    let detections = read_detections(path).rejected()?;
    let names: Vec<&str> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
    if let Some(stranger) = detections.cameras.keys().find(|c| rig.id_of(c).is_none()) {
        return Err(anyhow::anyhow!(
            "{}: camera {stranger} is not in the rig {} (its cameras: {})",
            path.display(),
            args.rig.display(),
            names.join(", ")
        ))
        .rejected();
    }
    let clock = if args.recording.exists() {
        recording_clock(&args.recording, args.detect.fps).rejected()?
    } else {
        RecordingClock {
            fps: args.detect.fps.unwrap_or(DEFAULT_FPS),
            frames: None,
            timestamps: None,
        }
    };
    let frames = clock.frames.unwrap_or_else(|| detections.frame_count());
    let beyond = detections
        .cameras
        .iter()
        .filter_map(|(camera, by_frame)| Some((camera, *by_frame.keys().next_back()?)))
        .find(|(_, last)| *last >= frames);
    if let Some((camera, frame)) = beyond {
        return Err(anyhow::anyhow!(
            "{}: camera {camera} frame {frame} is beyond the recording {} ({frames} frames: 0 to {})",
            path.display(),
            args.recording.display(),
            frames.saturating_sub(1)
        ))
        .rejected();
    }
    let gate = match min_roundness {
        Some(_) => roundness_gate(&[], min_roundness),
        None => Gate {
            value: detections
                .cameras
                .values()
                .flat_map(|f| f.values().flatten())
                .map(|b| b.roundness)
                .fold(f64::INFINITY, f64::min)
                .min(1.0),
            reason: format!("as detected ({}: its least round blob)", path.display()),
        },
    };
    let sets = (0..frames)
        .map(|frame| {
            let time_s = clock.time_s(frame, &names);
            let cameras = names
                .iter()
                .map(|camera| {
                    Some(CameraDetections {
                        camera: (*camera).to_string(),
                        frame,
                        time_s,
                        blobs: detections
                            .blobs(camera, frame)
                            .iter()
                            .filter(|b| b.roundness >= gate.value)
                            .cloned()
                            .collect(),
                    })
                })
                .collect();
            DetectedSet {
                index: frame,
                time_s,
                exposed_at: None,
                cameras,
            }
        })
        .collect();
    let recording = DetectedRecording {
        cameras: names.iter().map(|c| (*c).to_string()).collect(),
        fps: clock.fps,
        sets,
        len_hint: Some(frames),
    };
    Ok((recording, gate))
}

/// The detector's options `track` and `calibrate refine` share.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct DetectFlags {
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
}

/// A recording detected for tracking, with the roundness gate it was detected with.
pub struct DetectedForTracking {
    /// Every frame's blobs.
    pub recording: DetectedRecording,
    /// The roundness gate (measured from a sample unless overridden).
    pub min_roundness: teachcam::track::gates::Gate,
}

/// Detects every frame of a recording for tracking `tool` through `rig`: the roundness gate
/// from a sample detected with the lowest floor (unless `min_roundness` overrides it), every
/// frame's blobs at it. `track` and `calibrate refine` both read recordings through this.
///
/// # Errors
/// `--near` not below `--far` (usage); the recording unreadable.
pub fn detect_for_tracking(
    recording: &Path,
    rig: &teachcam::camera::Rig,
    tool: &teachcam::tool::Tool,
    flags: &DetectFlags,
    min_roundness: Option<f64>,
) -> anyhow::Result<DetectedForTracking> {
    if flags.near >= flags.far {
        anyhow::bail!(
            "--near {} and --far {}: near must be less than far",
            flags.near,
            flags.far
        );
    }
    let setups = |min_roundness: f64| -> Vec<CameraSetup> {
        rig.cameras
            .iter()
            .map(|camera| {
                let mut detect = DetectConfig::for_marker(
                    camera,
                    tool.marker_diameter_mm,
                    flags.near,
                    flags.far,
                );
                detect.method = flags.method;
                detect.min_roundness = min_roundness;
                if let Some(t) = flags.threshold {
                    detect.threshold = Threshold::Fixed(t);
                }
                // Only the rig's cameras, in the rig's order, every frame of the rig's size.
                CameraSetup {
                    name: camera.name.clone(),
                    detect,
                    size: Some((camera.image_size.width, camera.image_size.height)),
                }
            })
            .collect()
    };

    let (recording, min_roundness) = match min_roundness {
        Some(_) => {
            let gate = roundness_gate(&[], min_roundness);
            let detected = detect_folder(recording, flags.fps, |_| Ok(setups(gate.value)))?;
            (detected, gate)
        }
        None => {
            // One pass at the lowest floor, each frame's blobs kept for every stricter one: the
            // gate from a sample of them, then every frame at the gate, each decoded once.
            let choices: DetectedRecording<RoundnessChoices> =
                detect_folder(recording, flags.fps, |_| Ok(setups(ROUNDNESS_FLOOR)))?;
            let sample: BTreeSet<usize> = sampled_sets(choices.len_hint, ROUNDNESS_SAMPLE_FRAMES)
                .into_iter()
                .collect();
            let roundness: Vec<f64> = choices
                .sets
                .iter()
                .filter(|s| sample.contains(&s.index))
                .filter_map(|s| s.at(ROUNDNESS_FLOOR))
                .flat_map(|s| s.cameras.into_iter().flatten())
                .flat_map(|c| c.blobs.into_iter().map(|b| b.roundness))
                .collect();
            let gate = roundness_gate(&roundness, None);
            let detected = match choices.at(gate.value) {
                Some(detected) => detected,
                // A gate below the floor (none is measured so): detect again with it.
                None => detect_folder(recording, flags.fps, |_| Ok(setups(gate.value)))?,
            };
            (detected, gate)
        }
    };
    Ok(DetectedForTracking {
        recording,
        min_roundness,
    })
}

/// "tool 'x' not found in any of N frames", with the most common reasons.
pub fn not_found_message(tool: &str, tracks: &[FrameTrack]) -> String {
    let mut reasons: std::collections::BTreeMap<String, usize> = std::collections::BTreeMap::new();
    for t in tracks {
        *reasons.entry(t.reason()).or_default() += 1;
    }
    let mut common: Vec<(String, usize)> = reasons.into_iter().collect();
    common.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let listed: Vec<String> = common
        .iter()
        .take(3)
        .map(|(reason, n)| format!("{n} x {reason}"))
        .collect();
    format!(
        "tool '{tool}' not found in any of {} frames ({}); is it the right tool file? see `teachcam doctor`",
        tracks.len(),
        listed.join("; ")
    )
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
    let mut out = String::from(
        "frame,status,reason,points,markers,views_per_marker,max_residual_px,combinations,reflections",
    );
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
        let status = match track.status() {
            Status::Ok if !issues.is_empty() => Status::Degraded,
            status => status,
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
            "{frame},{status},{},{},{},{},{max_residual:.4},{},{}",
            track.reason().replace(',', ";"),
            track.points.len(),
            track.labels.len(),
            views.join(" "),
            track.combinations,
            track.reflections
        );
        if resampling.is_some() {
            let _ = write!(out, ",{}", issues.join(" | "));
        }
        out.push('\n');
    }
    out
}
