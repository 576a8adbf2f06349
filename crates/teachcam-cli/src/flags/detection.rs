//! The detector's and the gates' flags, shared by the commands that detect blobs (`detect`,
//! `track`, `calibrate refine`/`wand`, `repeatability`, `doctor`): each turned into the
//! library's options here, once.

use std::path::{Path, PathBuf};

use anyhow::Context;
use teachcam::camera::Rig;
use teachcam::detect::{CenterMethod, DetectConfig, Threshold};
use teachcam::pipeline::CameraSetup;
use teachcam::pipeline::recording::DetectOptions as LibraryDetectOptions;
use teachcam::source::SourceCamera;
use teachcam::track::gates::GateOverrides;

use crate::Rejected;

/// Detector options shared by the commands that detect blobs.
#[derive(Debug, clap::Args)]
pub struct DetectorFlags {
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
    /// Smallest roundness kept, 0..1 (1 = disc; two touching equal discs have 0.5). Default:
    /// measured from the recording (`detect`), 0.75 (`repeatability`).
    #[arg(long, value_parser = crate::flags::unit_interval)]
    pub min_roundness: Option<f64>,
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
pub fn configs(args: &DetectorFlags, cameras: &[SourceCamera]) -> anyhow::Result<Vec<CameraSetup>> {
    if let Some(r) = args.min_roundness
        && !(r.is_finite() && (0.0..=1.0).contains(&r))
    {
        return Err(anyhow::anyhow!(
            "--min-roundness must be within 0..1, got {r}"
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
            if let Some(r) = args.min_roundness {
                cfg.min_roundness = r;
            }
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
    #[arg(long, default_value_t = LibraryDetectOptions::default().near_mm, value_parser = crate::flags::positive)]
    pub near: f64,
    /// Farthest distance from a camera to a marker, millimetres.
    #[arg(long, default_value_t = LibraryDetectOptions::default().far_mm, value_parser = crate::flags::positive)]
    pub far: f64,
}

impl From<&LibraryDetectOptions> for DetectFlags {
    fn from(options: &LibraryDetectOptions) -> Self {
        Self {
            fps: options.fps,
            method: options.method,
            threshold: options.threshold,
            near: options.near_mm,
            far: options.far_mm,
        }
    }
}

impl DetectFlags {
    /// The library's detector options these flags give.
    #[must_use]
    pub fn options(&self) -> LibraryDetectOptions {
        LibraryDetectOptions {
            fps: self.fps,
            method: self.method,
            threshold: self.threshold,
            near_mm: self.near,
            far_mm: self.far,
        }
    }
}
