//! `teachcam track`: the tool's trajectory from a recording (paper §II); the library's batch
//! run ([`teachcam::pipeline::batch`]) with its files written.

use std::path::{Path, PathBuf};

use teachcam::io::detections::read_detections;
use teachcam::io::recording::DEFAULT_FPS;
use teachcam::io::{Output, check_outputs};
use teachcam::pipeline::PipelineError;
use teachcam::pipeline::batch::{TrackFiles, TrackInput, TrackOptions, TrackRun, track};
use teachcam::source::folder::{RecordingClock, recording_clock};
use teachcam::trajectory::{Status, Trajectory};

use crate::Rejected;
use crate::flags::detection::{DetectFlags, GateFlags};
use crate::progress::Progress;

/// Below this fraction of frames posed, `track` points to `teachcam doctor`.
const DOCTOR_BELOW: f64 = 0.9;

pub mod time_offsets;

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
    /// Print the gates measured from the recording as a table with the reason of each (one line
    /// otherwise; the gates file is written either way).
    #[arg(long)]
    pub verbose: bool,
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

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (run, written) = track_to_files(args)?;
    let trajectory = &run.trajectory;
    crate::announce::wrote(&written, &status_counts(trajectory));
    let posed = trajectory
        .samples
        .iter()
        .filter(|s| s.pose.is_some())
        .count();
    if (posed as f64) < DOCTOR_BELOW * trajectory.len() as f64 {
        crate::announce::say(&format!(
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
        ));
    }
    Ok(())
}

/// "N of M frames tracked (a ok, b degraded, c outlier, d lost)".
#[must_use]
pub fn status_counts(trajectory: &Trajectory) -> String {
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
    format!(
        "{posed} of {} frames tracked ({} ok, {} degraded, {} outlier, {} lost)",
        trajectory.len(),
        count(Status::Ok),
        count(Status::Degraded),
        count(Status::Outlier),
        count(Status::Lost),
    )
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

/// Tracks the recording and writes the trajectory and the optional files, all or none;
/// returns the run and the files written. Prints the gates on stderr and nothing else but a
/// progress bar on a terminal.
pub fn track_to_files(args: &Args) -> anyhow::Result<(TrackRun, Vec<PathBuf>)> {
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
    let rig = crate::load::rig(&args.rig)?;
    let tool = crate::load::tool(&args.tool)?;
    let options = TrackOptions {
        detect: args.detect.options(),
        gates: args.gates.overrides(),
        time_offsets: args
            .time_offsets
            .as_ref()
            .map(|arg| time_offsets::resolve(arg, &rig))
            .transpose()?,
    };
    let detections;
    let clock: RecordingClock;
    let input = match &args.detections {
        Some(path) => {
            detections = read_detections(path).rejected()?;
            clock = if args.recording.exists() {
                recording_clock(&args.recording, args.detect.fps).rejected()?
            } else {
                RecordingClock {
                    fps: args.detect.fps.unwrap_or(DEFAULT_FPS),
                    frames: None,
                    timestamps: None,
                }
            };
            TrackInput::Detections {
                detections: &detections,
                clock: &clock,
            }
        }
        None => TrackInput::Recording(&args.recording),
    };
    let progress = Progress::new("detect", 0);
    let run = track(input, &rig, &tool, &options, &|| progress.tick()).map_err(|e| {
        let e =
            match (e, &args.detections) {
                (PipelineError::Detections(message), Some(path)) => PipelineError::Detections(
                    format!("{}: {message} ({})", path.display(), args.rig.display()),
                ),
                (e, _) => e,
            };
        crate::recording::pipeline_error(e, &args.tool)
    })?;
    progress.finish();
    if args.detections.is_none() {
        say_stamp_offsets(&args.recording, args.detect.fps)?;
    }
    if let Some(limits) = &run.detect_limits {
        crate::announce::say(&limits.summary());
    }
    for out in &run.cameras_out {
        crate::announce::warn(&out.to_string());
    }
    if let Some(synchronised) = &run.synchronised {
        crate::announce::say(&time_offsets::summary(&rig, synchronised));
    }
    if !args.verbose {
        let written_to = gates_json.as_deref().map_or(String::new(), |path| {
            format!(", written to {}", path.display())
        });
        crate::announce::say(&format!(
            "{} (the table with reasons: --verbose{written_to})",
            run.gates.summary()
        ));
    } else if !crate::announce::quiet() {
        crate::announce::say(run.gates.to_string().trim_end());
        crate::announce::say(&match &run.step_gate {
            Some(gate) => format!(
                "  {:<24} {:>8.3} mm  {}",
                "tip step per frame", gate.value, gate.reason
            ),
            None => format!(
                "  {:<24} none: too few steps between ok frames",
                "tip step per frame"
            ),
        });
    }
    let written = run.write(
        &rig,
        &TrackFiles {
            trajectory: &args.output,
            markers: args.markers_out.as_deref(),
            diagnostics: args.diagnostics.as_deref(),
            gates: gates_json.as_deref(),
            time_offsets: args.time_offsets_out.as_deref(),
        },
    )?;
    Ok((run, written))
}

/// The cameras whose `timestamps.csv` stamps lie a tenth of a period or more from the others':
/// frame `i` of every camera stays set `i` (row `i` of the trajectory), the set's time the
/// mean, so the offset is said rather than acted on.
fn say_stamp_offsets(recording: &Path, fps: Option<f64>) -> anyhow::Result<()> {
    let clock = recording_clock(recording, fps).rejected()?;
    let period_s = 1.0 / clock.fps;
    for (camera, offset) in clock.stamp_offsets() {
        if offset.abs() >= 0.1 * period_s {
            crate::announce::warn(&format!(
                "{}: camera {camera}'s times lie {:+.3} ms ({:+.2} of a frame period) from the other cameras'; frame i of every camera is kept as row i (its time the cameras' mean)",
                recording
                    .join(teachcam::io::recording::TIMESTAMPS_FILE)
                    .display(),
                1e3 * offset,
                offset / period_s
            ));
        }
    }
    Ok(())
}
