//! `teachcam calibrate wand`: the rig's extrinsics from a wand waved through the volume, the
//! world from a marker frame lying on the work object.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use teachcam::calib::wand::{WandCalibration, WandConfig, calibrate_wand, set_ground, wand_views};
use teachcam::camera::Rig;
use teachcam::correspond::Views;
use teachcam::detect::DetectConfig;
use teachcam::io::rig::{read_cameras, write_rig};
use teachcam::io::tool::read_tool;
use teachcam::io::wand::read_wand;
use teachcam::io::{Output, check_outputs};
use teachcam::pipeline::CameraSetup;

use crate::Rejected;
use crate::recording::detect_folder;

/// The rig from a wand dance (and the world from a ground frame).
///
/// Finds the wand (three collinear markers, the middle one off centre) in every camera-frame
/// with exactly three blobs, places every camera relative to the first from the essential
/// matrices of wand correspondences scaled by the wand's length, then adjusts every camera's
/// extrinsics and every frame's wand together (intrinsics held as given; camera-frames whose
/// residual lies beyond a gate measured from the data are dropped). Without `--ground` the
/// world is the first camera's frame; with it, the frame of `--ground-tool` (a marker frame
/// with at least 3 non-collinear markers lying still on the work object in GROUND_REC).
/// Prints frames used, each camera's reprojection RMS and σ, and the wand length error of
/// independent triangulations (RMS and max, what optical trackers grade a calibration by).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam calibrate wand dance/wand --cameras dance/cameras.json --wand dance/wand.json --ground dance/ground --ground-tool dance/lframe.json -o rig.json"#)]
pub struct WandArgs {
    /// The wand dance: a recording folder (one sub-folder of frames per camera).
    pub recording: PathBuf,
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
    let output = Output {
        path: &args.output,
        format: "a rig file (JSON)",
        extensions: &["json"],
    };
    let mut inputs: Vec<&Path> = vec![&args.cameras, &args.wand];
    if let Some(t) = &args.ground_tool {
        inputs.push(t);
    }
    check_outputs(&[output], &inputs)?;
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
    let frames = detect_views(&args.recording, &cameras, wand.marker_diameter_mm, args)?;
    let config = WandConfig::default();
    let views = wand_views(&cameras, &frames, &wand, &config);
    let result = calibrate_wand(&cameras, &views.frames, &wand, &config)
        .with_context(|| format!("{}: wand calibration", args.recording.display()))
        .rejected()?;
    println!(
        "wand: {} frames, {} camera-frames with three blobs ({} not collinear beyond {:.2} px, {} with ends not told apart)",
        frames.len(),
        views.three_blobs,
        views.not_collinear,
        views.line_gate_px,
        views.ambiguous_ends
    );
    print_result(&result);
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
    write_rig(&args.output, &rig)?;
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!("{} cameras", rig.cameras.len()),
    );
    Ok(())
}

/// Frames used, per-camera residual and σ, wand length error.
fn print_result(result: &WandCalibration) {
    println!(
        "frames used {}, rejected {} (residual gate {:.3} px), {} iterations",
        result.frames_used, result.frames_rejected, result.residual_gate_px, result.iterations
    );
    for c in &result.cameras {
        println!(
            "{}: {} frames ({} camera-frames dropped), rms {:.4} px, centre ± {:.3} mm, rotation ± {:.4}° (intrinsics taken as exact)",
            c.name, c.frames, c.dropped, c.rms_px, c.centre_std_mm, c.rotation_std_deg
        );
    }
    println!(
        "wand length error: rms {:.4} mm, max {:.4} mm",
        result.length_rms_mm, result.length_max_mm
    );
    if !result.converged {
        println!("warning: the bundle adjustment stopped at its iteration limit, not at a minimum");
    }
}
