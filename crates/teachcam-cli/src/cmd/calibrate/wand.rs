//! `teachcam calibrate wand`: the rig's extrinsics from a wand waved through the volume, the
//! world from a marker frame lying on the work object.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use teachcam::calib::wand::{
    Wand, WandCalibration, WandConfig, WandViews, calibrate_wand, set_ground, wand_views,
};
use teachcam::camera::Rig;
use teachcam::correspond::Views;
use teachcam::detect::DetectConfig;
use teachcam::io::rig::{read_cameras, write_rig};
use teachcam::io::tool::read_tool;
use teachcam::io::wand::read_wand;
use teachcam::io::wand_points::{DltdvOrigin, PointsFormat, read_wand_points};
use teachcam::io::{Output, check_outputs, write_atomically};
use teachcam::pipeline::CameraSetup;

use crate::Rejected;
use crate::recording::detect_folder;

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

/// Detected blob centres of every frame of a recording, by rig camera.
fn detect_views(
    recording: &Path,
    rig: &Rig,
    marker_diameter_mm: f64,
    args: &WandArgs,
) -> anyhow::Result<Vec<Views>> {
    let detected = detect_folder(recording, None, |_| {
        Ok(rig
            .cameras
            .iter()
            .map(|camera| CameraSetup {
                name: camera.name.clone(),
                detect: DetectConfig::for_marker(camera, marker_diameter_mm, args.near, args.far),
                size: Some((camera.image_size.width, camera.image_size.height)),
            })
            .collect())
    })?;
    Ok(detected
        .blobs_by_camera(rig)
        .into_iter()
        .map(|frame| {
            frame
                .into_iter()
                .map(|(id, blobs)| (id, blobs.iter().map(|b| b.center).collect()))
                .collect()
        })
        .collect())
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
    let config = WandConfig::default();
    let views = wand_views(&cameras, &frames, &wand, &config);
    let result = calibrate_wand(&cameras, &views.frames, &wand, &config)
        .with_context(|| format!("{}: wand calibration", source.display()))
        .rejected()?;
    println!(
        "wand: {} markers, {} frames, {} camera-frames with {} points ({} not collinear beyond {:.2} px, {} with the ends not told apart by the image)",
        wand.markers_mm.len(),
        frames.len(),
        views.whole,
        wand.markers_mm.len(),
        views.not_collinear,
        views.line_gate_px,
        views.ends_unlabelled
    );
    print_result(&result, &wand);
    let report = report_json(&source, &format, &wand, &views, &result);
    let rig = match (&args.ground, &ground_tool) {
        (Some(folder), Some(tool)) => {
            let ground_frames = detect_views(folder, &result.rig, tool.marker_diameter_mm, args)?;
            let (rig, report) = set_ground(&result.rig, &ground_frames, tool)
                .with_context(|| format!("{}: ground frame", folder.display()))
                .rejected()?;
            println!(
                "ground: '{}' posed in {} of {} frames, origin scatter {:.3} mm, registration rms {:.3} mm; world = its frame",
                tool.name,
                report.posed,
                report.frames,
                report.scatter_mm,
                report.registration_rms_mm
            );
            if report.cameras_below.len() == rig.cameras.len() {
                crate::announce::warn(&format!(
                    "every camera is below the ground frame's x-y plane (z < 0 in the new world): {}'s z axis points into the work object; the world (and a robot's work object set from it) is upside down unless that is meant",
                    args.ground_tool
                        .as_deref()
                        .map_or_else(String::new, |p| p.display().to_string())
                ));
            }
            rig
        }
        _ => {
            println!("world: camera {}'s frame", result.rig.cameras[0].name);
            result.rig.clone()
        }
    };
    let finite = rig.cameras.iter().all(|c| {
        c.camera_from_world
            .translation
            .vector
            .iter()
            .chain(c.camera_from_world.rotation.coords.iter())
            .all(|v| v.is_finite())
    });
    if !finite {
        return Err(anyhow::anyhow!("the calibrated rig is not finite")).rejected();
    }
    if !(result.length_mean_mm.is_finite() && result.length_std_mm.is_finite()) {
        return Err(anyhow::anyhow!(
            "the wand's length could not be triangulated in any used frame"
        ))
        .rejected();
    }
    write_rig(&args.output, &rig)?;
    let mut written = vec![args.output.clone()];
    if let Some(path) = &args.report {
        write_atomically(path, format!("{report:#}\n").as_bytes())?;
        written.push(path.clone());
    }
    crate::announce::wrote(&written, &format!("{} cameras", rig.cameras.len()));
    Ok(())
}

/// The calibration's figures as JSON.
fn report_json(
    source: &Path,
    format: &str,
    wand: &Wand,
    views: &WandViews,
    result: &WandCalibration,
) -> serde_json::Value {
    serde_json::json!({
        "source": source.display().to_string(),
        "format": format,
        "wand_markers_mm": wand.markers_mm,
        "wand_length_mm": wand.length_mm(),
        "whole_views": views.whole,
        "views_ends_unlabelled": views.ends_unlabelled,
        "views_not_collinear": views.not_collinear,
        "frames_used": result.frames_used,
        "frames_rejected": result.frames_rejected,
        "frames_ambiguous": result.frames_ambiguous,
        "residual_gate_px": result.residual_gate_px,
        "length_mean_mm": result.length_mean_mm,
        "length_std_mm": result.length_std_mm,
        "length_std_percent": result.length_std_percent(),
        "length_mean_error_percent": 100.0 * (result.length_mean_mm - wand.length_mm()) / wand.length_mm(),
        "length_error_rms_mm": result.length_rms_mm,
        "length_error_max_mm": result.length_max_mm,
        "cameras": result.cameras.iter().map(|c| serde_json::json!({
            "name": c.name,
            "frames": c.frames,
            "dropped": c.dropped,
            "reprojection_rms_px": c.rms_px,
            "centre_std_mm": c.centre_std_mm,
            "rotation_std_deg": c.rotation_std_deg,
        })).collect::<Vec<_>>(),
        "iterations": result.iterations,
        "converged": result.converged,
        "intrinsics": "held as given",
    })
}

/// Frames used, per-camera residual and σ, wand length.
fn print_result(result: &WandCalibration, wand: &Wand) {
    println!(
        "frames used {}, rejected {} (residual gate {:.3} px), ambiguous {} (two pairings of the unlabelled ends fitted alike: dropped), {} iterations",
        result.frames_used,
        result.frames_rejected,
        result.residual_gate_px,
        result.frames_ambiguous,
        result.iterations
    );
    for c in &result.cameras {
        println!(
            "{}: {} frames ({} camera-frames dropped), rms {:.4} px, centre ± {:.3} mm, rotation ± {:.4}° (intrinsics taken as exact)",
            c.name, c.frames, c.dropped, c.rms_px, c.centre_std_mm, c.rotation_std_deg
        );
    }
    println!(
        "wand length: mean {:.3} mm ({:+.3} % of {} mm), std {:.3} mm = {:.4} % of the mean; error rms {:.4} mm, max {:.4} mm",
        result.length_mean_mm,
        100.0 * (result.length_mean_mm - wand.length_mm()) / wand.length_mm(),
        wand.length_mm(),
        result.length_std_mm,
        result.length_std_percent(),
        result.length_rms_mm,
        result.length_max_mm
    );
    if !result.converged {
        println!("warning: the bundle adjustment stopped at its iteration limit, not at a minimum");
    }
}
