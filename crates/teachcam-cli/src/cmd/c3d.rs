//! `teachcam c3d`: inspect C3D motion-capture files.

use std::io::Write as _;
use std::path::PathBuf;

use anyhow::Context as _;
use serde::Serialize;
use teachcam::c3d::{self, Processor};
use teachcam::geometry::FrameIndex;
use teachcam::io::{Output, check_outputs};

use crate::Rejected as _;

/// Inspect C3D files written by Vicon, Qualisys, OptiTrack, NDI and others.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam c3d export raw.csv --tool rec/tool.json --measured markers.csv -o brush.c3d
  teachcam c3d info brush.c3d"#)]
pub struct Args {
    #[command(subcommand)]
    pub command: C3dCommand,
}

/// What to do with the C3D file.
#[derive(Debug, clap::Subcommand)]
pub enum C3dCommand {
    /// Print JSON describing the file: labels, rate, frames, units and the first frame.
    Info(InfoArgs),
    /// Write a trajectory's tool markers and tip as a C3D file (for Mokka, ezc3d, Vicon).
    Export(ExportArgs),
    /// Build a `tool.json` from a rigid cluster of labelled markers over a stretch of frames.
    Tool(ToolArgs),
}

/// Build a `tool.json` from labelled markers: their mean shape over `--frames` (every frame
/// aligned onto the mean first, so a slowly moving cluster works too), in the tool frame with
/// its origin at the first marker, x towards the second and the third in the xy-plane. Prints
/// JSON with the frames used and each marker's RMS scatter about its mean, millimetres.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam c3d tool brush.c3d --markers brush:M0,brush:M1,brush:M2,brush:M3 -o probe.json"#)]
pub struct ToolArgs {
    /// The C3D file.
    pub file: PathBuf,
    /// Labels of the tool's markers, comma-separated (at least 3; the first three set the frame).
    #[arg(long, value_delimiter = ',', required = true)]
    pub markers: Vec<String>,
    /// Frames (0-based, `START..END`, END excluded) to average over.
    #[arg(long, default_value = "0..", value_parser = crate::flags::parse_frames)]
    pub frames: std::ops::Range<usize>,
    /// A marker whose mean position becomes the tool centre point (default: the origin).
    #[arg(long)]
    pub tip: Option<String>,
    /// The tool's name (default: the file's stem).
    #[arg(long)]
    pub name: Option<String>,
    /// Marker sphere diameter written to the tool, millimetres.
    #[arg(long, default_value_t = c3d::ToolFromDataConfig::default().marker_diameter_mm, value_parser = crate::flags::positive)]
    pub marker_diameter_mm: f64,
    /// The tool file to write.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Write the tool's markers (`<tool>:M0`, ...; registered, or measured with `--measured`) and
/// tip (`<tool>:tip`) in every frame of a trajectory as a C3D file (Intel, float storage, millimetres; residual = the registration
/// RMS in steps of 0.001 mm). Frames without a pose are gaps.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam c3d export raw.csv --tool rec/tool.json --measured markers.csv -o brush.c3d
  teachcam c3d export raw.csv --tool rec/tool.json -o registered.c3d"#)]
pub struct ExportArgs {
    /// The trajectory CSV.
    pub trajectory: PathBuf,
    /// The tool (`tool.json`) whose markers to place.
    #[arg(long)]
    pub tool: PathBuf,
    /// The measured markers (`teachcam track --markers-out`) to write instead of the
    /// registered ones; the tip stays the registered tip.
    #[arg(long)]
    pub measured: Option<PathBuf>,
    /// The C3D file to write.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Residual step of exported files, millimetres: registration residuals are 0.01–1 mm, and a
/// byte of 0.001 mm steps holds up to 0.255 mm (larger residuals are stored as 0.255).
const EXPORT_RESIDUAL_STEP_MM: f64 = 0.001;

/// Print a JSON summary of a C3D file on stdout: `labels`, `rate_hz`, `frames`, `units`,
/// `first_frame` (one `[x, y, z]` per label in the file's units, `null` where the sample is
/// invalid), and how the file stores its data.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam c3d info brush.c3d
  teachcam c3d info brush.c3d > brush.json"#)]
pub struct InfoArgs {
    /// The C3D file.
    pub file: PathBuf,
}

/// What `c3d info` prints.
#[derive(Debug, Serialize)]
struct Info {
    file: String,
    labels: Vec<String>,
    rate_hz: f64,
    frames: usize,
    /// What the header and parameters declare (more than `frames` when the file holds fewer).
    frames_declared: usize,
    /// Number of the first frame as the file counts.
    first_frame_number: usize,
    units: String,
    processor: &'static str,
    storage: &'static str,
    scale: f64,
    first_frame: Vec<Option<[f64; 3]>>,
    /// Frames without a valid sample, per label.
    gaps: Vec<usize>,
}

/// Run `teachcam c3d ...`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    match &args.command {
        C3dCommand::Info(info) => run_info(info),
        C3dCommand::Export(export) => run_export(export),
        C3dCommand::Tool(tool) => run_tool(tool),
    }
}

fn run_tool(args: &ToolArgs) -> anyhow::Result<()> {
    let output = Output {
        path: &args.output,
        format: "a tool file (JSON)",
        extensions: &["json"],
    };
    check_outputs(&[output], &[&args.file])?;
    let points = c3d::read_file(&args.file).rejected()?.points;
    let named = |e: c3d::C3dError| {
        let e = anyhow::Error::from(e).context(args.file.display().to_string());
        anyhow::Error::new(crate::DataRejected(e))
    };
    let columns = points.marker_indices(&args.markers).map_err(named)?;
    let tip = match &args.tip {
        Some(label) => Some(points.marker_indices(&[label]).map_err(named)?[0]),
        None => None,
    };
    let config = c3d::ToolFromDataConfig {
        name: args.name.clone().unwrap_or_else(|| {
            args.file
                .file_stem()
                .map_or("tool".into(), |s| s.to_string_lossy().into_owned())
        }),
        marker_diameter_mm: args.marker_diameter_mm,
    };
    let built =
        c3d::tool_from_data(&points, &columns, args.frames.clone(), tip, &config).map_err(named)?;
    teachcam::io::tool::write_tool(&args.output, &built.tool)?;
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!(
            "tool '{}' of {} markers from {} frames",
            built.tool.name,
            built.tool.markers_in_tool.len(),
            built.frames_used
        ),
    );
    let summary = serde_json::json!({
        "tool": args.output.display().to_string(),
        "frames_used": built.frames_used,
        "markers": args.markers,
        "marker_rms_mm": built.marker_rms_mm,
    });
    print_json(&summary)
}

/// Pretty JSON on stdout; a reader that stopped early (`| head`) is not an error.
fn print_json<T: Serialize>(value: &T) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    let mut stdout = std::io::stdout().lock();
    match writeln!(stdout, "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}

fn run_export(args: &ExportArgs) -> anyhow::Result<()> {
    let output = Output {
        path: &args.output,
        format: "C3D",
        extensions: &["c3d"],
    };
    let mut inputs = vec![args.trajectory.as_path(), args.tool.as_path()];
    inputs.extend(args.measured.as_deref());
    check_outputs(&[output], &inputs)?;
    let trajectory = teachcam::io::trajectory::read_trajectory(&args.trajectory).rejected()?;
    let tool = crate::load::tool(&args.tool)?;
    let points = match &args.measured {
        None => c3d::points_from_trajectory(&trajectory, &tool),
        Some(path) => {
            let rate_hz = trajectory.sample_rate_hz().unwrap_or(1.0);
            let measured = teachcam::vendor::read_markers_csv(path, rate_hz).rejected()?;
            c3d::points_from_trajectory_and_measured(&trajectory, &tool, &measured)
        }
    };
    let points = points
        .map_err(anyhow::Error::from)
        .with_context(|| args.trajectory.display().to_string())
        .rejected()?;
    c3d::write_file(&args.output, &points, EXPORT_RESIDUAL_STEP_MM)?;
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!(
            "{} markers x {} frames",
            points.marker_count(),
            points.frame_count()
        ),
    );
    Ok(())
}

fn run_info(args: &InfoArgs) -> anyhow::Result<()> {
    let file = c3d::read_file(&args.file).rejected()?;
    let points = &file.points;
    let scale = file
        .parameters
        .get("POINT", "SCALE")
        .and_then(c3d::Parameter::first_number)
        .unwrap_or(f64::from(file.header.scale));
    let first_frame = (0..points.marker_count())
        .map(|m| {
            points
                .sample(FrameIndex(0), m)
                .map(|s| [s.position.x, s.position.y, s.position.z])
        })
        .collect();
    let gaps = (0..points.marker_count())
        .map(|m| {
            (0..points.frame_count())
                .filter(|&f| points.sample(FrameIndex(f), m).is_none())
                .count()
        })
        .collect();
    let info = Info {
        file: args.file.display().to_string(),
        labels: points.labels.clone(),
        rate_hz: points.rate_hz,
        frames: points.frame_count(),
        frames_declared: file.declared_frames,
        first_frame_number: points.first_frame_number,
        units: points.units.clone(),
        processor: match file.processor {
            Processor::Intel => "intel",
            Processor::Dec => "dec",
            Processor::Mips => "mips",
        },
        storage: if scale < 0.0 { "float" } else { "integer" },
        scale,
        first_frame,
        gaps,
    };
    print_json(&info)
}
