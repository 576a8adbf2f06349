//! `teachcam calibrate intrinsics|rig|wand|refine`: chessboard photographs to a camera or a
//! whole rig; a wand dance to a rig ([`wand`]); a rig refined from any recording ([`refine`]).

mod refine;
mod wand;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow, bail};
use rayon::prelude::*;
use teachcam::calib::chessboard::{CornerConfig, find_chessboard_corners, gray_like_opencv};
use teachcam::calib::intrinsics::{IntrinsicsConfig, calibrate_intrinsics};
use teachcam::calib::rig::{
    BundleIntrinsics, RigCalibration, RigConfig, RigObservation, WorldFrame, calibrate_rig,
    views_of_camera,
};
use teachcam::calib::{BoardView, Chessboard};
use teachcam::camera::{Camera, ImageSize};
use teachcam::geometry::{CameraId, Pixel};
use teachcam::io::camera_file::{
    read_camera, write_camera_json, write_opencv_yaml, write_ros_yaml,
};
use teachcam::io::rig::write_rig;
use teachcam::io::{Output, check_outputs};

use crate::Rejected;

/// Calibrate cameras from photographs of a chessboard.
///
/// `intrinsics` calibrates one camera (Zhang's method, then Levenberg–Marquardt with OpenCV's
/// 5-coefficient distortion); `rig` puts every camera of a rig in one world frame set by a board
/// lying on the work object, then adjusts them all together.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam calibrate rig --pattern chessboard --inner 9x6 --square 50 boards --world world -o rig.json
  teachcam calibrate intrinsics --pattern chessboard --inner 9x6 --square 50 boards/cam0/*.png -o camera.json"#)]
pub struct Args {
    #[command(subcommand)]
    pub command: Calibrate,
}

/// What to calibrate.
#[derive(Debug, clap::Subcommand)]
pub enum Calibrate {
    Intrinsics(IntrinsicsArgs),
    Rig(RigArgs),
    Wand(wand::WandArgs),
    Refine(refine::RefineArgs),
}

/// The calibration target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Pattern {
    /// A chessboard; corners are the inner corners where four squares meet.
    Chessboard,
}

/// The target options shared by both subcommands.
#[derive(Debug, clap::Args)]
pub struct PatternArgs {
    /// The calibration target.
    #[arg(long, value_enum, default_value_t = Pattern::Chessboard)]
    pub pattern: Pattern,
    /// Inner corners, `COLSxROWS` as OpenCV's `patternSize` (a board of 10x7 squares is `9x6`).
    #[arg(long, value_parser = parse_inner)]
    pub inner: (usize, usize),
    /// Side of one square, millimetres.
    #[arg(long, value_parser = crate::flags::positive)]
    pub square: f64,
}

/// Output format of a single camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CameraFormat {
    /// By the output's extension: `.json` → camera.json, `.yaml`/`.yml` → OpenCV YAML.
    Auto,
    /// The contract's camera.json (one rig camera object with `rms_px`).
    Json,
    /// OpenCV `FileStorage` YAML (`camera_matrix`, `distortion_coefficients`).
    Opencv,
    /// ROS `camera_info` YAML.
    Ros,
}

/// One camera's intrinsics and distortion from chessboard photographs.
///
/// Corners are found in each image (images without a complete board are named and skipped), Zhang's closed form, then
/// Levenberg–Marquardt over fx, fy, cx, cy, k1, k2, p1, p2, k3 and every board pose. Prints the
/// RMS reprojection error per image and names outlier images.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam calibrate intrinsics --pattern chessboard --inner 9x6 --square 50 boards/cam0/*.png -o camera.json
  teachcam calibrate intrinsics --pattern chessboard --inner 9x6 --square 50 boards/cam0/*.png --format opencv -o camera.yaml"#)]
pub struct IntrinsicsArgs {
    #[command(flatten)]
    pub pattern: PatternArgs,
    /// Photographs of the board (8-bit; colour is converted to grey as OpenCV does).
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Output camera file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value_t = CameraFormat::Auto)]
    pub format: CameraFormat,
    /// Camera name written to the file (default: the output file's stem).
    #[arg(long)]
    pub name: Option<String>,
    /// Keep k3 = 0 (OpenCV's CALIB_FIX_K3).
    #[arg(long)]
    pub fix_k3: bool,
    /// Keep p1 = p2 = 0 (CALIB_ZERO_TANGENT_DIST).
    #[arg(long)]
    pub fix_tangential: bool,
    /// Keep fy/fx at the closed form's ratio (CALIB_FIX_ASPECT_RATIO).
    #[arg(long)]
    pub fix_aspect_ratio: bool,
}

/// All cameras of a rig in one world frame, then a bundle adjustment.
///
/// `IMAGES` holds one sub-folder per camera, named as
/// the camera; images with the same file stem in several sub-folders show the same board
/// placement at the same instant. The world frame is the board of `--world` (lying on the work
/// object: x along its rows of corners, y along its columns, z into the board, origin at its
/// first corner). Each camera's intrinsics come from `--intrinsics NAME=FILE` (camera.json,
/// OpenCV or ROS YAML) or, when not given, from its own images. Then a bundle adjustment of all
/// cameras and board poses that refines every camera's intrinsics too (each camera with at least
/// 3 images), so the printed standard errors include their uncertainty; prints per camera the
/// residual and the standard errors of its centre, its rotation and its principal point, which
/// limits the rotation (σ falls as one over the root of the camera's image count: about 40
/// images per camera give 0.006° at 0.025 px of corner noise).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam calibrate rig --pattern chessboard --inner 9x6 --square 50 boards --world world -o rig.json
  teachcam calibrate rig --pattern chessboard --inner 9x6 --square 50 boards --world world --intrinsics cam0=camera.json -o rig.json
  teachcam calibrate rig --pattern chessboard --inner 9x6 --square 50 boards --world-camera cam0 -o rig-cam0.json"#)]
#[command(group(clap::ArgGroup::new("world_frame").required(true).multiple(false)))]
pub struct RigArgs {
    #[command(flatten)]
    pub pattern: PatternArgs,
    /// Folder with one sub-folder of images per camera.
    pub images: PathBuf,
    /// File stem of the view whose board sets the world frame (the board lying on the work
    /// object; `teachcam simulate --scenario calibration` names it `world`).
    #[arg(long, group = "world_frame")]
    pub world: Option<String>,
    /// Or: this camera's frame is the world frame.
    #[arg(long, group = "world_frame")]
    pub world_camera: Option<String>,
    /// Known intrinsics of a camera, `NAME=FILE`; repeat per camera.
    #[arg(long, value_parser = parse_assignment)]
    pub intrinsics: Vec<(String, PathBuf)>,
    /// Accepted for compatibility: refining the intrinsics is now the default.
    #[arg(long, conflicts_with = "fix_intrinsics")]
    pub refine_intrinsics: bool,
    /// Hold every camera's intrinsics fixed in the bundle adjustment (OpenCV's
    /// CALIB_FIX_INTRINSIC). Those calibrated here from the camera's own images carry their
    /// covariance into the printed σ; those from `--intrinsics` files are taken as exact, and
    /// the printed σ are then conditional on them (said so).
    #[arg(long)]
    pub fix_intrinsics: bool,
    /// Output rig file.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// A camera with fewer images keeps its intrinsics fixed in the bundle adjustment: Zhang's
/// method needs 3 views to determine them.
const MIN_IMAGES_TO_REFINE: usize = 3;

/// A rotation σ above this, degrees, puts 3σ above the 0.02° the rig is meant to reach
/// (issue 8), so the camera needs more images.
const ROTATION_STD_GOAL_DEG: f64 = 0.02 / 3.0;

fn parse_inner(text: &str) -> Result<(usize, usize), String> {
    let (cols, rows) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected COLSxROWS such as 9x6, got '{text}'"))?;
    let parse = |t: &str| t.trim().parse::<usize>().ok().filter(|v| *v >= 2);
    match (parse(cols), parse(rows)) {
        (Some(c), Some(r)) => Ok((c, r)),
        _ => Err(format!(
            "expected COLSxROWS with both at least 2, got '{text}'"
        )),
    }
}

fn parse_assignment(text: &str) -> Result<(String, PathBuf), String> {
    let (name, file) = text
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=FILE, got '{text}'"))?;
    Ok((name.to_owned(), PathBuf::from(file)))
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    match &args.command {
        Calibrate::Intrinsics(a) => run_intrinsics(a),
        Calibrate::Rig(a) => run_rig(a),
        Calibrate::Wand(a) => wand::run_wand(a),
        Calibrate::Refine(a) => refine::run_refine(a),
    }
}

fn board_of(pattern: &PatternArgs) -> anyhow::Result<Chessboard> {
    if !(pattern.square.is_finite() && pattern.square > 0.0) {
        bail!(
            "--square must be a positive length in millimetres, got {}",
            pattern.square
        );
    }
    let (inner_cols, inner_rows) = pattern.inner;
    Ok(Chessboard {
        inner_cols,
        inner_rows,
        square_mm: pattern.square,
    })
}

/// Corners of every image, in parallel, with the image size; `Err` per image that has no board.
type Found = (PathBuf, Result<(ImageSize, Vec<Pixel>), String>);

fn find_all(images: &[PathBuf], board: &Chessboard) -> Vec<Found> {
    let config = CornerConfig::default();
    images
        .par_iter()
        .map(|path| {
            let result = teachcam::io::recording::read_image(path)
                .map_err(|e| match std::error::Error::source(&e) {
                    Some(cause) => format!("{e}: {cause}"),
                    None => e.to_string(),
                })
                .and_then(|image| {
                    let gray = gray_like_opencv(&image);
                    let size = ImageSize {
                        width: gray.width(),
                        height: gray.height(),
                    };
                    find_chessboard_corners(&gray, board, &config)
                        .map(|corners| (size, corners))
                        .map_err(|e| e.to_string())
                });
            (path.clone(), result)
        })
        .collect()
}

/// Refuses, before any work, an image that is not there or not of a format read here.
fn check_image_file(path: &Path) -> anyhow::Result<()> {
    if !path.is_file() {
        return Err(anyhow!("{}: no such image file", path.display())).rejected();
    }
    match image::ImageFormat::from_path(path) {
        Ok(image::ImageFormat::Png | image::ImageFormat::Jpeg) => Ok(()),
        _ => Err(anyhow!(
            "{}: not an image teachcam reads (expected a .png, .jpg or .jpeg file)",
            path.display()
        ))
        .rejected(),
    }
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// Refuses, before any corner is searched, a `--world` view, a `--world-camera` or an
/// `--intrinsics` camera that the folder does not hold, listing what it holds.
fn check_rig_names(args: &RigArgs, folders: &[PathBuf]) -> anyhow::Result<()> {
    let cameras: Vec<String> = folders.iter().map(|f| file_name(f)).collect();
    let listed = |names: &[String]| -> String {
        const SHOWN: usize = 12;
        let mut text = names[..names.len().min(SHOWN)].join(", ");
        if names.len() > SHOWN {
            text.push_str(&format!(", … ({} in all)", names.len()));
        }
        text
    };
    for (name, file) in &args.intrinsics {
        if !cameras.contains(name) {
            return Err(anyhow!(
                "--intrinsics {name}={}: no camera sub-folder {name} in {} (cameras: {})",
                file.display(),
                args.images.display(),
                listed(&cameras)
            ))
            .rejected();
        }
    }
    if let Some(camera) = &args.world_camera
        && !cameras.contains(camera)
    {
        return Err(anyhow!(
            "--world-camera {camera}: no camera sub-folder of that name in {} (cameras: {})",
            args.images.display(),
            listed(&cameras)
        ))
        .rejected();
    }
    if let Some(world) = &args.world {
        let mut views: Vec<String> = folders
            .iter()
            .filter_map(|f| std::fs::read_dir(f).ok())
            .flatten()
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| p.is_file())
            .filter_map(|p| Some(p.file_stem()?.to_string_lossy().into_owned()))
            .collect();
        views.sort();
        views.dedup();
        if !views.contains(world) {
            return Err(anyhow!(
                "--world {world}: no image of that stem in {}'s camera folders (views: {})",
                args.images.display(),
                listed(&views)
            ))
            .rejected();
        }
    }
    Ok(())
}

/// Keeps the first image's size in `size` and refuses an image of another size, naming both
/// files: one camera's images are all of one size (its intrinsics hold for that size only).
fn one_size(
    size: &mut Option<(ImageSize, PathBuf)>,
    image_size: ImageSize,
    path: &Path,
) -> anyhow::Result<()> {
    match size {
        Some((first, first_path)) if *first != image_size => Err(anyhow!(
            "{}: {}x{} pixels, but {} is {}x{}",
            path.display(),
            image_size.width,
            image_size.height,
            first_path.display(),
            first.width,
            first.height
        ))
        .rejected(),
        Some(_) => Ok(()),
        None => {
            *size = Some((image_size, path.to_path_buf()));
            Ok(())
        }
    }
}

fn run_intrinsics(args: &IntrinsicsArgs) -> anyhow::Result<()> {
    let output = Output {
        path: &args.output,
        format: "a camera file (JSON or YAML)",
        extensions: &["json", "yaml", "yml"],
    };
    let inputs: Vec<&Path> = args.images.iter().map(PathBuf::as_path).collect();
    check_outputs(&[output], &inputs)?;
    let board = board_of(&args.pattern)?;
    for path in &args.images {
        check_image_file(path)?;
    }
    let found = find_all(&args.images, &board);
    let mut views = Vec::new();
    let mut size: Option<(ImageSize, PathBuf)> = None;
    for (path, result) in found {
        match result {
            Ok((image_size, corners)) => {
                one_size(&mut size, image_size, &path)?;
                views.push(BoardView {
                    name: file_name(&path),
                    corners,
                });
            }
            Err(message) => println!("{}: skipped: {message}", path.display()),
        }
    }
    let Some((image_size, _)) = size else {
        return Err(anyhow!(
            "no image shows a complete {}x{} chessboard",
            board.inner_cols,
            board.inner_rows
        ))
        .rejected();
    };
    let config = IntrinsicsConfig {
        fix_k3: args.fix_k3,
        fix_tangential: args.fix_tangential,
        fix_aspect_ratio: args.fix_aspect_ratio,
        ..IntrinsicsConfig::default()
    };
    let result = calibrate_intrinsics(&board.corners_in_board(), &views, image_size, &config)
        .context("calibration")
        .rejected()?;
    let mut camera = result.camera.clone();
    camera.name = args.name.clone().unwrap_or_else(|| {
        args.output
            .file_stem()
            .map_or_else(|| "camera".to_owned(), |s| s.to_string_lossy().into_owned())
    });
    for view in &result.views {
        let flag = if result.outlier_views.contains(&view.name) {
            "  (outlier)"
        } else {
            ""
        };
        println!("{}: rms {:.4} px{flag}", view.name, view.rms_px);
    }
    let i = camera.intrinsics;
    let se = result.standard_errors;
    println!(
        "fx {:.3} ± {:.3}, fy {:.3} ± {:.3}, cx {:.3} ± {:.3}, cy {:.3} ± {:.3} px; distortion {:?}",
        i.fx,
        se[0],
        i.fy,
        se[1],
        i.cx,
        se[2],
        i.cy,
        se[3],
        camera.distortion.to_opencv()
    );
    println!(
        "rms {:.4} px over {} images",
        result.rms_px,
        result.views.len()
    );
    // One standard error above 5 % of the focal length: the views do not pin the camera down.
    if se[0] > 0.05 * i.fx || se[1] > 0.05 * i.fy {
        println!(
            "warning: the focal length is poorly determined (± {:.0} px): add views with the board tilted and filling more of the image",
            se[0].max(se[1])
        );
    }
    let format = match args.format {
        CameraFormat::Auto => match args.output.extension().and_then(|e| e.to_str()) {
            Some("yaml" | "yml") => CameraFormat::Opencv,
            _ => CameraFormat::Json,
        },
        other => other,
    };
    match format {
        CameraFormat::Opencv => write_opencv_yaml(&args.output, &camera, result.rms_px)?,
        CameraFormat::Ros => write_ros_yaml(&args.output, &camera)?,
        CameraFormat::Json | CameraFormat::Auto => {
            write_camera_json(&args.output, &camera, result.rms_px)?
        }
    }
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!("camera {} from {} images", camera.name, result.views.len()),
    );
    Ok(())
}

fn run_rig(args: &RigArgs) -> anyhow::Result<()> {
    let output = Output {
        path: &args.output,
        format: "a rig file (JSON)",
        extensions: &["json"],
    };
    let inputs: Vec<&Path> = args.intrinsics.iter().map(|(_, p)| p.as_path()).collect();
    check_outputs(&[output], &inputs)?;
    let board = board_of(&args.pattern)?;
    // Camera sub-folders, sorted by name; each camera's images sorted by file name.
    let mut folders: Vec<PathBuf> = std::fs::read_dir(&args.images)
        .with_context(|| format!("cannot read the folder {}", args.images.display()))
        .rejected()?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    if folders.is_empty() {
        return Err(anyhow!("{}: no camera sub-folders", args.images.display())).rejected();
    }
    check_rig_names(args, &folders)?;
    let known: BTreeMap<&str, &PathBuf> = args
        .intrinsics
        .iter()
        .map(|(n, p)| (n.as_str(), p))
        .collect();
    let corners = board.corners_in_board();
    let mut cameras: Vec<Camera> = Vec::new();
    let mut config = RigConfig::default();
    let mut observations = Vec::new();
    for (c, folder) in folders.iter().enumerate() {
        let name = file_name(folder);
        let mut images: Vec<PathBuf> = std::fs::read_dir(folder)
            .with_context(|| format!("cannot read the folder {}", folder.display()))
            .rejected()?
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| p.is_file())
            .collect();
        images.sort();
        let mut size: Option<(ImageSize, PathBuf)> = None;
        for (path, result) in find_all(&images, &board) {
            match result {
                Ok((image_size, found)) => {
                    one_size(&mut size, image_size, &path)?;
                    let view = path
                        .file_stem()
                        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
                    observations.push(RigObservation {
                        camera: CameraId(c),
                        view,
                        corners: found,
                    });
                }
                Err(message) => println!("{}: skipped: {message}", path.display()),
            }
        }
        let views = views_of_camera(&observations, CameraId(c));
        let (camera, fixed) = if let Some(file) = known.get(name.as_str()) {
            let mut camera = read_camera(file).rejected()?.camera;
            if let Some((image_size, path)) = &size
                && camera.image_size != *image_size
            {
                return Err(anyhow!(
                    "--intrinsics {name}={}: calibrated for {}x{} pixels, but {} is {}x{}",
                    file.display(),
                    camera.image_size.width,
                    camera.image_size.height,
                    path.display(),
                    image_size.width,
                    image_size.height
                ))
                .rejected();
            }
            camera.name = name.clone();
            (camera, BundleIntrinsics::Fixed)
        } else {
            let Some((image_size, _)) = size else {
                return Err(anyhow!("camera {name}: no image shows a complete board")).rejected();
            };
            let result =
                calibrate_intrinsics(&corners, &views, image_size, &IntrinsicsConfig::default())
                    .with_context(|| format!("camera {name}: intrinsics"))
                    .rejected()?;
            println!(
                "{name}: intrinsics from {} images, rms {:.4} px",
                views.len(),
                result.rms_px
            );
            let mut camera = result.camera;
            camera.name = name.clone();
            // A singular fit has no covariance to propagate: then held as exact, and said so.
            let fixed = if result.covariance.iter().all(|v| v.is_finite()) {
                BundleIntrinsics::FixedWithCovariance(Box::new(result.covariance))
            } else {
                BundleIntrinsics::Fixed
            };
            (camera, fixed)
        };
        let treatment = if args.fix_intrinsics || views.len() < MIN_IMAGES_TO_REFINE {
            fixed
        } else {
            BundleIntrinsics::Refined
        };
        config.intrinsics.insert(CameraId(c), treatment);
        cameras.push(camera);
    }
    for name in known.keys() {
        if !cameras.iter().any(|c| c.name == *name) {
            return Err(anyhow!("--intrinsics {name}: no sub-folder of that name")).rejected();
        }
    }
    let world = match (&args.world, &args.world_camera) {
        (Some(view), _) => WorldFrame::Board(view.clone()),
        (None, Some(name)) => {
            let c = cameras
                .iter()
                .position(|c| &c.name == name)
                .ok_or_else(|| anyhow!("--world-camera {name}: no camera of that name"))
                .rejected()?;
            WorldFrame::Camera(CameraId(c))
        }
        (None, None) => bail!("give --world VIEW or --world-camera NAME"),
    };
    let result = calibrate_rig(&corners, &cameras, &observations, &world, &config)
        .context("rig calibration")
        .rejected()?;
    print_rig_result(&result);
    if let Some(view) = &args.world {
        println!("{}", world_in_words(&board, view));
    }
    if let Some(hint) = transposed_inner_hint(&board, &observations) {
        println!("{hint}");
    }
    if !result.converged {
        println!("warning: the bundle adjustment stopped at its iteration limit, not at a minimum");
    }
    write_rig(&args.output, &result.rig)?;
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!("{} cameras", result.rig.cameras.len()),
    );
    Ok(())
}

/// The world frame a `--world` view sets, in words (CONTRACT: the work surface's xy-plane,
/// z into it).
fn world_in_words(board: &Chessboard, view: &str) -> String {
    format!(
        "world frame: the board of view '{view}': origin at its first inner corner, x along its rows of {} corners (--inner's first number), y along its columns of {} corners, z = x × y into the board (away from the cameras that see it)",
        board.inner_cols, board.inner_rows
    )
}

/// A warning when `--inner` looks transposed: its first number (corners per row, the world's
/// x) is the smaller, and in three quarters or more of the photographs (three at least) those
/// rows run closer to the image's vertical than its horizontal, i.e. the board was
/// photographed with its longer side across while it was described with the shorter one
/// first. The corners are found either way, with the same RMS; only the world's axes and
/// origin change, so a word is all that can be said.
fn transposed_inner_hint(board: &Chessboard, observations: &[RigObservation]) -> Option<String> {
    let (cols, rows) = (board.inner_cols, board.inner_rows);
    if cols >= rows || observations.len() < 3 {
        return None;
    }
    let upright = observations
        .iter()
        .filter(|o| {
            let (Some(first), Some(last)) = (o.corners.first(), o.corners.get(cols - 1)) else {
                return false;
            };
            (last.y - first.y).abs() > (last.x - first.x).abs()
        })
        .count();
    (4 * upright >= 3 * observations.len()).then(|| {
        format!(
            "warning: --inner {cols}x{rows}: in {upright} of {} photographs the board's rows of {cols} corners run up and down the image and its columns of {rows} across: a {rows}x{cols} board given transposed? The world's x runs along --inner's first number and its origin is the first inner corner of that order; give --inner {rows}x{cols} if the rows of {rows} corners were meant",
            observations.len()
        )
    })
}

/// Per camera: residual, views, σ of centre, rotation and principal point; then what the σ
/// assume and which cameras need more images.
fn print_rig_result(result: &RigCalibration) {
    for camera in &result.cameras {
        let intrinsics = camera.intrinsics_std.map_or_else(
            || ", intrinsics fixed".to_owned(),
            |se| format!(", cx ± {:.2} px, cy ± {:.2} px", se[2], se[3]),
        );
        println!(
            "{}: {} views, rms {:.4} px, centre ± {:.3} mm, rotation ± {:.4}°{intrinsics}",
            camera.name, camera.views, camera.rms_px, camera.centre_std_mm, camera.rotation_std_deg
        );
    }
    println!("rms {:.4} px", result.rms_px);
    if !result.conditional_on.is_empty() {
        println!(
            "note: the σ above take the fixed intrinsics of {} as exact and are too small by their own uncertainty; drop --fix-intrinsics to include it",
            result.conditional_on.join(", ")
        );
    }
    for camera in &result.cameras {
        if camera.rotation_std_deg > ROTATION_STD_GOAL_DEG {
            println!(
                "hint: {}: rotation ± {:.4}° (3σ above 0.02°), set by its principal point: add images of the board in this camera (σ falls as 1/√images)",
                camera.name, camera.rotation_std_deg
            );
        }
    }
}
