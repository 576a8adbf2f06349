//! `teachcam import`: another tracker's marker data → the tool's trajectory CSV.

use std::ops::Range;
use std::path::{Path, PathBuf};

use anyhow::bail;
use teachcam::c3d::{self, MarkerSelection, PointData, ToolFromDataConfig, TrackMarkersConfig};
use teachcam::identify::IdentifyConfig;
use teachcam::io::tool::tool_json;
use teachcam::io::trajectory::trajectory_text;
use teachcam::io::{Output, OutputSet, check_outputs};
use teachcam::vendor;

use crate::{DataRejected, Rejected as _};

/// Turn 3-D markers (C3D, Motive CSV, Qualisys TSV, `track --markers-out`) into a tool trajectory.
///
/// Picks the tool's markers by label or by the distance-matrix identification of a
/// `tool.json`, registers the tool in every frame, and writes the trajectory CSV (`teachcam
/// smooth` and `teachcam export` take it from there).
///
/// With `--markers` and no `--tool`, the tool is built from the data itself (mean shape over
/// `--static-frames`, tool frame from the first three markers: origin at the first, x towards
/// the second, the third in the xy-plane); `--tool-out` saves it.
///
/// Found by identification, the tool needs at least one frame with all its markers and no rival
/// labelling; without one it is not in the data: nothing is written and the exit status is 3.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam import c3d brush.c3d --tool rec/tool.json -o imported.csv
  teachcam import c3d brush.c3d --markers brush:M0,brush:M1,brush:M2,brush:M3 --tool-out probe.json -o imported.csv
  teachcam import markers markers.csv --fps 30 --tool rec/tool.json -o imported.csv
  teachcam import motive take.csv --tool rec/tool.json -o imported.csv"#)]
pub struct Args {
    /// File format: c3d, motive (OptiTrack Motive CSV), qualisys (QTM TSV) or markers
    /// (`teachcam track --markers-out`).
    #[arg(value_enum)]
    pub format: Format,
    /// The marker file.
    pub file: PathBuf,
    /// The tool (`tool.json`); without `--markers` its markers are found by distance-matrix
    /// identification among all markers of each frame.
    #[arg(long)]
    pub tool: Option<PathBuf>,
    /// Labels of the tool's markers, comma-separated, in the tool's marker order.
    #[arg(long, value_delimiter = ',')]
    pub markers: Vec<String>,
    /// Frames (0-based, `START..END`, END excluded) over which to build the tool from data.
    #[arg(long, default_value = "0..", value_parser = crate::flags::parse_frames)]
    pub static_frames: Range<usize>,
    /// A marker label whose mean position becomes the tool centre point of a tool built from
    /// data (default: the first marker).
    #[arg(long)]
    pub tip: Option<String>,
    /// Where to save a tool built from data.
    #[arg(long)]
    pub tool_out: Option<PathBuf>,
    /// Identification tolerance on marker distances, millimetres.
    #[arg(long, default_value_t = 1.0, value_parser = crate::flags::positive)]
    pub identify_tolerance_mm: f64,
    /// Largest registration RMS of a pose, millimetres; worse frames become gaps.
    #[arg(long, default_value_t = TrackMarkersConfig::default().max_registration_rms_mm, value_parser = crate::flags::positive)]
    pub max_rms_mm: f64,
    /// Frames per second of a `markers` file (the other formats carry their rate).
    #[arg(long, value_parser = crate::flags::fps)]
    pub fps: Option<f64>,
    /// The trajectory CSV to write.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Below this fraction of frames with a pose, `import` warns that the tool is rarely found.
const RARELY_FOUND: f64 = 0.1;

/// Marker file formats `import` reads.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum Format {
    /// C3D (any processor, integer or float storage).
    C3d,
    /// OptiTrack Motive marker CSV export.
    Motive,
    /// Qualisys QTM 3D TSV export.
    Qualisys,
    /// The identified 3-D markers of `teachcam track --markers-out` (needs `--fps`).
    Markers,
}

/// Reads marker data in `format`; `fps` is the rate of a `markers` file.
pub fn read_points(format: Format, file: &Path, fps: Option<f64>) -> anyhow::Result<PointData> {
    let points = match format {
        Format::Markers => {
            let Some(fps) = fps else {
                bail!("a markers file needs --fps");
            };
            vendor::read_markers_csv(file, fps).map_err(anyhow::Error::from)
        }
        Format::C3d => c3d::read_file(file)
            .map(|c| c.points)
            .map_err(anyhow::Error::from),
        Format::Motive => vendor::read_motive_csv(file).map_err(anyhow::Error::from),
        Format::Qualisys => vendor::read_qualisys_tsv(file).map_err(anyhow::Error::from),
    };
    points.rejected()
}

/// Run `teachcam import`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut outputs = vec![Output::csv(&args.output)];
    if let Some(path) = &args.tool_out {
        outputs.push(Output {
            path,
            format: "a tool file (JSON)",
            extensions: &["json"],
        });
    }
    let mut inputs = vec![args.file.as_path()];
    inputs.extend(args.tool.as_deref());
    check_outputs(&outputs, &inputs)?;
    let points = read_points(args.format, &args.file, args.fps)?;
    let in_file = |e: c3d::C3dError| {
        let named = anyhow::Error::from(e).context(args.file.display().to_string());
        anyhow::Error::new(DataRejected(named))
    };
    let columns = points.marker_indices(&args.markers).map_err(in_file)?;
    let outputs = OutputSet::new();
    let (tool, selection) = match (&args.tool, columns.is_empty()) {
        (None, true) => bail!("give --tool, --markers or both (see --help)"),
        (Some(path), true) => {
            let tool = crate::load::tool(path)?;
            let identify = IdentifyConfig {
                distance_tolerance_mm: args.identify_tolerance_mm,
            };
            (tool, MarkerSelection::Identify(identify))
        }
        (Some(path), false) => {
            let tool = crate::load::tool(path)?;
            (tool, MarkerSelection::Labels(columns))
        }
        (None, false) => {
            let tip = match &args.tip {
                Some(label) => Some(points.marker_indices(&[label]).map_err(in_file)?[0]),
                None => None,
            };
            let config = ToolFromDataConfig {
                name: args
                    .file
                    .file_stem()
                    .map_or("tool".into(), |s| s.to_string_lossy().into_owned()),
                ..ToolFromDataConfig::default()
            };
            let built =
                c3d::tool_from_data(&points, &columns, args.static_frames.clone(), tip, &config)
                    .map_err(in_file)?;
            if let Some(out) = &args.tool_out {
                outputs.add(out, tool_json(out, &built.tool)?.as_bytes())?;
            }
            (built.tool, MarkerSelection::Labels(columns))
        }
    };
    let config = TrackMarkersConfig {
        max_registration_rms_mm: args.max_rms_mm,
    };
    let trajectory = c3d::track_markers(&points, &tool, &selection, &config).map_err(in_file)?;
    let found = trajectory
        .samples
        .iter()
        .filter(|s| s.pose.is_some())
        .count();
    if found == 0 {
        return Err(anyhow::Error::new(crate::ToolNotFound(format!(
            "{}: tool '{}' not found in any of {} frames (no frame holds all its {} markers at its distances); nothing written",
            args.file.display(),
            tool.name,
            trajectory.len(),
            tool.markers_in_tool.len()
        ))));
    }
    if (found as f64) < RARELY_FOUND * trajectory.len() as f64 {
        eprintln!(
            "warning: tool '{}' found in only {found} of {} frames",
            tool.name,
            trajectory.len()
        );
    }
    let text = trajectory_text(&args.output, &trajectory).rejected()?;
    outputs.add(&args.output, text.as_bytes())?;
    let written = outputs.commit()?;
    let posed: Vec<f64> = trajectory
        .samples
        .iter()
        .filter_map(|s| s.pose.map(|p| p.rms_mm))
        .collect();
    let worst = posed.iter().copied().fold(0.0, f64::max);
    crate::announce::wrote(
        &written,
        &format!(
            "{} of {} frames with a pose, registration RMS up to {worst:.3} mm",
            posed.len(),
            trajectory.len()
        ),
    );
    Ok(())
}
