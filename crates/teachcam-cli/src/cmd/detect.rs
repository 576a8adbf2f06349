//! `teachcam detect`: marker blobs with sub-pixel centres in every frame of a recording.

use std::path::{Path, PathBuf};

use anyhow::Context;
use teachcam::camera::Rig;
use teachcam::detect::{CenterMethod, DetectConfig, Threshold};
use teachcam::io::{Output, check_outputs, write_atomically};
use teachcam::pipeline::CameraSetup;
use teachcam::pipeline::recording::{DetectOptions as LibraryDetectOptions, DetectedRecording};
use teachcam::source::SourceCamera;

use crate::Rejected;
use crate::recording::detect_folder;

/// Find the marker blobs in every frame of a recording and write their sub-pixel centres.
///
/// Each frame is thresholded (automatically from its background and noise unless
/// `--threshold` is given), its 8-connected bright regions are measured, and the regions that
/// are too small, too large or cut by the image border are left out. A region that is not
/// round (markers whose images merged) is split when its markers come apart at half contrast
/// with 2 px between their edges, and left out otherwise. Frames run in parallel.
///
/// Output columns: `camera,frame,x_px,y_px,radius_px,area_px,roundness,center_std_px,peak`
/// (camera = the sub-folder's or video's name, frame = 0-based index, centre in OpenCV pixels, radius of
/// the equal-flux disc, predicted centre noise per axis), every number to the last bit so that
/// `teachcam track --detections` tracks these very blobs.
///
/// With `--rig` and a marker size (`--tool` or `--marker-diameter`), the size limits follow from
/// each camera's focal length and `--near`/`--far`, and the `refined` centre is moved from the
/// centre of the sphere's elliptical image to the projection of the sphere's centre.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam detect rec -o detections.csv --rig rec/rig.json --tool rec/tool.json"#)]
pub struct Args {
    /// Recording folder: one sub-folder of PNG frames or one video file per camera.
    pub recording: PathBuf,
    /// Output CSV file (written whole or not at all).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Detector options.
    #[command(flatten)]
    pub options: DetectOptions,
}

/// Detector options shared by the commands that detect blobs.
#[derive(Debug, clap::Args)]
pub struct DetectOptions {
    /// Centre estimate: `refined` (background-subtracted centroid over a disc holding the
    /// blurred edge, most accurate), `centroid` (over the blob's own pixels) or
    /// `smallest-circle` (the paper's: centre of the smallest enclosing circle).
    #[arg(long, default_value = "refined")]
    pub method: CenterMethod,
    /// Fixed threshold in the images' units: a pixel is foreground when strictly above it.
    /// Default: background median + max(8 noise std, full scale / 32), per frame.
    #[arg(long)]
    pub threshold: Option<u32>,
    /// Smallest blob kept, pixels (default 4, or from the rig and marker size).
    #[arg(long)]
    pub min_area: Option<usize>,
    /// Largest blob kept, pixels (default 40000, or from the rig and marker size).
    #[arg(long)]
    pub max_area: Option<usize>,
    /// Smallest roundness kept, 0..1 (1 = disc; two touching equal discs have 0.5).
    #[arg(long, default_value_t = 0.75, value_parser = crate::flags::unit_interval)]
    pub min_roundness: f64,
    /// Camera rig (rig.json): size limits and sphere-centre correction per camera.
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// Tool model (tool.json), for its marker diameter.
    #[arg(long, conflicts_with = "marker_diameter")]
    pub tool: Option<PathBuf>,
    /// Marker sphere diameter, millimetres.
    #[arg(long, value_parser = crate::flags::positive)]
    pub marker_diameter: Option<f64>,
    /// Nearest distance from a camera to a marker, millimetres (with --rig).
    #[arg(long, default_value_t = LibraryDetectOptions::default().near_mm, value_parser = crate::flags::positive)]
    pub near: f64,
    /// Farthest distance from a camera to a marker, millimetres (with --rig).
    #[arg(long, default_value_t = LibraryDetectOptions::default().far_mm, value_parser = crate::flags::positive)]
    pub far: f64,
    /// Shot noise of the camera: noise variance per image unit of signal (1 / gain in
    /// electrons per unit). Only the predicted centre noise (`center_std_px`) uses it.
    #[arg(long, default_value_t = 0.0, value_parser = crate::flags::non_negative)]
    pub shot_noise: f64,
}

/// Every camera of the recording, in the recording's order, with its detector configuration.
///
/// # Errors
/// Rejected data when a file cannot be read or the rig lacks a camera of the recording; a
/// usage error when a number is out of range.
pub fn configs(args: &DetectOptions, cameras: &[SourceCamera]) -> anyhow::Result<Vec<CameraSetup>> {
    if !(args.min_roundness.is_finite() && (0.0..=1.0).contains(&args.min_roundness)) {
        return Err(anyhow::anyhow!(
            "--min-roundness must be within 0..1, got {}",
            args.min_roundness
        ));
    }
    if !(args.near.is_finite() && args.far.is_finite() && 0.0 < args.near && args.near < args.far) {
        return Err(anyhow::anyhow!(
            "--near and --far must satisfy 0 < near < far, got {} and {}",
            args.near,
            args.far
        ));
    }
    if !(args.shot_noise.is_finite() && args.shot_noise >= 0.0) {
        return Err(anyhow::anyhow!(
            "--shot-noise must be a non-negative number, got {}",
            args.shot_noise
        ));
    }
    let diameter_mm = match (&args.tool, args.marker_diameter) {
        (Some(tool), _) => Some(crate::load::tool(tool)?.marker_diameter_mm),
        (None, Some(d)) if d.is_finite() && d > 0.0 => Some(d),
        (None, Some(d)) => {
            return Err(anyhow::anyhow!(
                "--marker-diameter must be a positive number of millimetres, got {d}"
            ));
        }
        (None, None) => None,
    };
    let rig: Option<Rig> = args.rig.as_deref().map(crate::load::rig).transpose()?;
    cameras
        .iter()
        .map(|frames| {
            let mut cfg = match (&rig, diameter_mm) {
                (Some(rig), Some(d)) => {
                    let camera = rig
                        .cameras
                        .iter()
                        .find(|c| c.name == frames.name)
                        .with_context(|| {
                            format!(
                                "recording camera {} is not in the rig {}",
                                frames.name,
                                args.rig.as_deref().unwrap_or(Path::new("")).display()
                            )
                        })
                        .rejected()?;
                    DetectConfig::for_marker(camera, d, args.near, args.far)
                }
                _ => DetectConfig::default(),
            };
            cfg.method = args.method;
            cfg.min_roundness = args.min_roundness;
            cfg.shot_noise_per_level = args.shot_noise;
            if let Some(t) = args.threshold {
                cfg.threshold = Threshold::Fixed(t);
            }
            if let Some(a) = args.min_area {
                cfg.min_area_px = a;
            }
            if let Some(a) = args.max_area {
                cfg.max_area_px = a;
            }
            Ok(CameraSetup {
                name: frames.name.clone(),
                detect: cfg,
                size: None,
            })
        })
        .collect()
}

/// The CSV text of the detections.
fn csv_text(recording: &DetectedRecording) -> String {
    teachcam::io::detections::detections_csv(
        recording
            .sets
            .iter()
            .flat_map(|s| s.cameras.iter().flatten()),
    )
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut inputs: Vec<&Path> = Vec::new();
    inputs.extend(args.options.rig.as_deref());
    inputs.extend(args.options.tool.as_deref());
    check_outputs(&[Output::csv(&args.output)], &inputs)?;
    let recording = detect_folder(&args.recording, None, |cameras| {
        configs(&args.options, cameras)
    })?;
    write_atomically(&args.output, csv_text(&recording).as_bytes())?;
    let blobs: usize = recording
        .sets
        .iter()
        .flat_map(|s| s.cameras.iter().flatten())
        .map(|c| c.blobs.len())
        .sum();
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!(
            "{blobs} blobs in {} frames x {} cameras",
            recording.sets.len(),
            recording.cameras.len()
        ),
    );
    Ok(())
}
