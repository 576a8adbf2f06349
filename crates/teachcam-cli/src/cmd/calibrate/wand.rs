//! `teachcam calibrate wand`: the rig's extrinsics from a wand waved through the volume, the
//! world from a marker frame lying on the work object.

use std::path::{Path, PathBuf};

use anyhow::bail;
use teachcam::calib::wand::run::{WandRun, detect_wand_views};
use teachcam::calib::wand::{WandConfig, WandError};
use teachcam::camera::Rig;
use teachcam::correspond::Views;
use teachcam::io::rig::{read_cameras, write_rig};
use teachcam::io::tool::read_tool;
use teachcam::io::wand::read_wand;
use teachcam::io::wand_points::{DltdvOrigin, PointsFormat, read_wand_points};
use teachcam::io::{Output, check_outputs, write_atomically};
use teachcam::source::FrameSource as _;
use teachcam::source::folder::FolderSource;

use crate::Rejected;
use crate::progress::Progress;

/// The rig from a wand dance (and the world from a ground frame).
///
/// Finds the wand (two or three collinear markers) in every camera-frame with exactly as many
/// blobs (or digitised points, `--detections`), places every camera relative to the first
/// from the essential matrices of wand correspondences scaled by the wand's length, then
/// adjusts every camera's extrinsics and every frame's wand together (intrinsics held as
/// given; camera-frames whose residual lies beyond a gate measured from the data are
/// dropped). The wand's ends need not be labelled: a two-marker wand's ends (and a
/// three-marker one's where the middle marker does not tell them apart) are matched across
/// cameras by which pairing triangulates best; frames where two pairings fit alike are
/// dropped and counted. Without `--ground` the
/// world is the first camera's frame; with it, the frame of `--ground-tool` (a marker frame
/// with at least 3 non-collinear markers lying still on the work object in GROUND_REC).
/// Prints frames used, each camera's reprojection RMS and σ, and the wand length of
/// independent triangulations: mean, std in % of the mean (easyWand's wand score), error
/// (what optical trackers grade a calibration by); `--report` writes them as JSON.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam calibrate wand dance/wand --cameras dance/cameras.json --wand dance/wand.json --ground dance/ground --ground-tool dance/lframe.json -o rig.json
  teachcam calibrate wand --detections wandpts-xypts.csv --cameras cameras.json --wand wand.json -o rig.json --report wand_report.json

--detections takes teachcam's detections.csv (camera,frame,x_px,y_px,radius_px[,...]; one row
per blob or digitised point, OpenCV pixels, cameras named as in --cameras) or DLTdv's xypts.csv
(pt1_cam1_X,pt1_cam1_Y,pt1_cam2_X,...; one row per frame, NaN where missing; camK = the K-th
camera of --cameras; a file saved without its header is read in that layout when it has 2
columns per camera per point), told apart by the header. No images are read: each camera's image size
comes from --cameras."#)]
pub struct WandArgs {
    /// The wand dance: a recording folder (one sub-folder of frames per camera).
    #[arg(required_unless_present = "detections", conflicts_with = "detections")]
    pub recording: Option<PathBuf>,
    /// The wand's points instead of a recording: teachcam's detections.csv or DLTdv's
    /// xypts.csv (see below).
    #[arg(long, value_name = "CSV")]
    pub detections: Option<PathBuf>,
    /// Where DLTdv's y is measured from: `top` (DLTdv8) or `bottom` (DLTdv5–7, Argus,
    /// easyWand); its pixels count from 1 either way.
    #[arg(long, value_enum, default_value_t = Origin::Top)]
    pub dltdv_origin: Origin,
    /// Also write the calibration's figures as JSON (wand length mean and std, per-camera
    /// reprojection RMS and σ, frames used, rejected, ambiguous).
    #[arg(long, value_name = "JSON")]
    pub report: Option<PathBuf>,
    /// The cameras' intrinsics: a rig file whose extrinsics, if any, are ignored.
    #[arg(long)]
    pub cameras: PathBuf,
    /// The wand: `{"name", "marker_diameter_mm", "markers_mm": [0, 160, 500]}`.
    #[arg(long)]
    pub wand: PathBuf,
    /// A recording of the ground frame lying still on the work object.
    #[arg(long, requires = "ground_tool")]
    pub ground: Option<PathBuf>,
    /// The ground frame's tool file (its frame becomes the world).
    #[arg(long, requires = "ground")]
    pub ground_tool: Option<PathBuf>,
    /// Nearest distance from a camera to a marker, millimetres (the detector's blob sizes).
    #[arg(long, default_value_t = 300.0, value_parser = crate::flags::positive)]
    pub near: f64,
    /// Farthest distance from a camera to a marker, millimetres.
    #[arg(long, default_value_t = 3000.0, value_parser = crate::flags::positive)]
    pub far: f64,
    /// Output rig file.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// DLTdv's y origin.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Origin {
    /// y down from the top edge (DLTdv8).
    Top,
    /// y up from the bottom edge (DLTdv5–7, Argus, easyWand).
    Bottom,
}

/// Detected blob centres of every frame of a recording, by rig camera (the library's
/// [`detect_wand_views`], a progress bar on a terminal).
fn detect_views(
    recording: &Path,
    rig: &Rig,
    marker_diameter_mm: f64,
    args: &WandArgs,
) -> anyhow::Result<Vec<Views>> {
    let mut source = FolderSource::open(recording, None).rejected()?;
    let progress = Progress::new("detect", source.len_hint().unwrap_or(0) as u64);
    let views = detect_wand_views(
        &mut source,
        rig,
        marker_diameter_mm,
        args.near,
        args.far,
        &mut |_| progress.tick(),
    )
    .rejected()?;
    progress.finish();
    Ok(views)
}

/// Run `calibrate wand`.
pub fn run_wand(args: &WandArgs) -> anyhow::Result<()> {
    if args.near >= args.far {
        bail!(
            "--near {} and --far {}: near must be less than far",
            args.near,
            args.far
        );
    }
    let mut outputs = vec![Output {
        path: &args.output,
        format: "a rig file (JSON)",
        extensions: &["json"],
    }];
    if let Some(report) = &args.report {
        outputs.push(Output {
            path: report,
            format: "a JSON report",
            extensions: &["json"],
        });
    }
    let mut inputs: Vec<&Path> = vec![&args.cameras, &args.wand];
    if let Some(t) = &args.ground_tool {
        inputs.push(t);
    }
    if let Some(d) = &args.detections {
        inputs.push(d);
    }
    check_outputs(&outputs, &inputs)?;
    let cameras = read_cameras(&args.cameras).rejected()?;
    if cameras.len() < 2 {
        return Err(anyhow::anyhow!(
            "{}: {} camera; a wand calibration needs at least 2",
            args.cameras.display(),
            cameras.len()
        ))
        .rejected();
    }
    let wand = read_wand(&args.wand).rejected()?;
    let ground_tool = args
        .ground_tool
        .as_deref()
        .map(read_tool)
        .transpose()
        .rejected()?;
    let (source, frames, format) = match (&args.recording, &args.detections) {
        (_, Some(path)) => {
            let origin = match args.dltdv_origin {
                Origin::Top => DltdvOrigin::Top,
                Origin::Bottom => DltdvOrigin::Bottom,
            };
            let (frames, format) = read_wand_points(path, &cameras, origin).rejected()?;
            let format = match format {
                PointsFormat::Detections => {
                    "teachcam detections (image sizes from the cameras file)".to_string()
                }
                PointsFormat::Dltdv { points } => format!(
                    "DLTdv xypts, {points} points per frame, camK = the cameras file's K-th camera ({}), y from the {} edge, pixels from 1 (image sizes from the cameras file)",
                    cameras
                        .cameras
                        .iter()
                        .map(|c| c.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                    match args.dltdv_origin {
                        Origin::Top => "top",
                        Origin::Bottom => "bottom",
                    }
                ),
            };
            println!("points: {} read as {format}", path.display());
            (path.clone(), frames, format)
        }
        (Some(folder), None) => (
            folder.clone(),
            detect_views(folder, &cameras, wand.marker_diameter_mm, args)?,
            "images".to_string(),
        ),
        (None, None) => {
            return Err(anyhow::anyhow!(
                "give the wand recording folder or --detections FILE"
            ))
            .rejected();
        }
    };
    let ground_frames = match (&args.ground, &ground_tool) {
        (Some(folder), Some(tool)) => Some(detect_views(
            folder,
            &cameras,
            tool.marker_diameter_mm,
            args,
        )?),
        _ => None,
    };
    let ground = ground_frames.as_deref().zip(ground_tool.as_ref());
    let run: WandRun = teachcam::calib::wand::run::run_wand(
        &cameras,
        &frames,
        &wand,
        ground,
        &WandConfig::default(),
    )
    .map_err(|e| {
        let what = match (&e, &args.ground) {
            (WandError::Ground { .. }, Some(folder)) => {
                format!("{}: ground frame", folder.display())
            }
            _ => format!("{}: wand calibration", source.display()),
        };
        anyhow::Error::new(e).context(what)
    })
    .rejected()?;
    for line in run.lines(&wand, frames.len()) {
        println!("{line}");
    }
    let ground_tool_name = args
        .ground_tool
        .as_deref()
        .map_or_else(String::new, |p| p.display().to_string());
    if let Some(warning) = run.ground_warning(&ground_tool_name) {
        crate::announce::warn(&warning);
    }
    let report = run.report_json(&source.display().to_string(), &format, &wand);
    let rig = run.rig;
    write_rig(&args.output, &rig)?;
    let mut written = vec![args.output.clone()];
    if let Some(path) = &args.report {
        write_atomically(path, format!("{report:#}\n").as_bytes())?;
        written.push(path.clone());
    }
    crate::announce::wrote(&written, &format!("{} cameras", rig.cameras.len()));
    Ok(())
}
