//! The whole of `calibrate wand`, as the command and the studio's Calibrate tab run it: the
//! wand's blobs detected in a recording ([`detect_wand_views`]), where they fell on each
//! camera's image ([`Coverage`]), the calibration and the world from a ground frame
//! ([`run_wand`]), and its figures as lines and JSON ([`WandRun`]).

use serde::Serialize;

use super::{
    GroundReport, Wand, WandCalibration, WandConfig, WandError, WandViews, calibrate_wand,
    set_ground, wand_views,
};
use crate::camera::{Camera, Rig};
use crate::correspond::Views;
use crate::detect::{Blob, DetectConfig};
use crate::geometry::{CameraId, Pixel};
use crate::pipeline::{CameraSetup, DetectStream, PipelineError};
use crate::source::FrameSource;
use crate::tool::Tool;

/// The detector's setup for each of `cameras` seeing markers of `marker_diameter_mm` between
/// `near_mm` and `far_mm` (blob sizes from the focal length; each frame's size checked).
#[must_use]
pub fn wand_setups(
    cameras: &Rig,
    marker_diameter_mm: f64,
    near_mm: f64,
    far_mm: f64,
) -> Vec<CameraSetup> {
    cameras
        .cameras
        .iter()
        .map(|camera| CameraSetup {
            name: camera.name.clone(),
            detect: DetectConfig::for_marker(camera, marker_diameter_mm, near_mm, far_mm),
            size: Some((camera.image_size.width, camera.image_size.height)),
        })
        .collect()
}

/// Every set of `source` detected with [`wand_setups`]: per frame, each camera's blob centres
/// (cameras `cameras` lacks left out). `each` hears every frame's views as it is detected
/// (the studio fills its coverage from it; the command ticks its progress bar).
///
/// # Errors
/// [`PipelineError`] naming the camera, frame or file that cannot be read or has another size.
pub fn detect_wand_views(
    source: &mut dyn FrameSource,
    cameras: &Rig,
    marker_diameter_mm: f64,
    near_mm: f64,
    far_mm: f64,
    each: &mut dyn FnMut(&Views),
) -> Result<Vec<Views>, PipelineError> {
    let setups = wand_setups(cameras, marker_diameter_mm, near_mm, far_mm);
    let mut stream = DetectStream::<Vec<Blob>>::detecting(source, setups)?;
    let ids: Vec<Option<CameraId>> = stream
        .camera_names()
        .iter()
        .map(|c| cameras.id_of(c))
        .collect();
    let mut frames = Vec::new();
    for set in &mut stream {
        let set = set?;
        let views: Views = ids
            .iter()
            .zip(&set.cameras)
            .filter_map(|(id, c)| {
                Some(((*id)?, c.as_ref()?.blobs.iter().map(|b| b.center).collect()))
            })
            .collect();
        each(&views);
        frames.push(views);
    }
    Ok(frames)
}

/// Where a camera's wand samples have fallen: its image cut into `columns × rows` cells, each
/// counting the marker images of the camera-frames that showed the whole wand (exactly as many
/// blobs as it has markers), before the calibration's gates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Coverage {
    /// The camera's name.
    pub camera: String,
    /// Its image width, pixels.
    pub width_px: u32,
    /// Its image height, pixels.
    pub height_px: u32,
    /// Cells across.
    pub columns: usize,
    /// Cells down.
    pub rows: usize,
    /// Marker images per cell, row by row from the top left.
    pub counts: Vec<u32>,
    /// Camera-frames that showed the whole wand.
    pub views: usize,
}

impl Coverage {
    /// An empty coverage of `camera`'s image.
    #[must_use]
    pub fn new(camera: &Camera, columns: usize, rows: usize) -> Self {
        Self {
            camera: camera.name.clone(),
            width_px: camera.image_size.width,
            height_px: camera.image_size.height,
            columns,
            rows,
            counts: vec![0; columns * rows],
            views: 0,
        }
    }

    /// Counts a camera-frame's points when they are a whole wand of `markers` markers; points
    /// outside the image are left out. True when counted.
    pub fn add(&mut self, points: &[Pixel], markers: usize) -> bool {
        if points.len() != markers {
            return false;
        }
        self.views += 1;
        for p in points {
            let (u, v) = (
                p.x / f64::from(self.width_px),
                p.y / f64::from(self.height_px),
            );
            if (0.0..1.0).contains(&u) && (0.0..1.0).contains(&v) {
                let cell = (v * self.rows as f64) as usize * self.columns
                    + (u * self.columns as f64) as usize;
                self.counts[cell] += 1;
            }
        }
        true
    }

    /// The share of cells holding at least one sample.
    #[must_use]
    pub fn filled(&self) -> f64 {
        let filled = self.counts.iter().filter(|c| **c > 0).count();
        filled as f64 / self.counts.len().max(1) as f64
    }
}

/// The coverage of every camera of `cameras` over `frames` (as [`detect_wand_views`] gives
/// them) for a wand of `markers` markers.
#[must_use]
pub fn wand_coverage(
    cameras: &Rig,
    frames: &[Views],
    markers: usize,
    columns: usize,
    rows: usize,
) -> Vec<Coverage> {
    let mut coverage: Vec<Coverage> = cameras
        .cameras
        .iter()
        .map(|c| Coverage::new(c, columns, rows))
        .collect();
    for views in frames {
        for (id, points) in views {
            if let Some(c) = coverage.get_mut(id.0) {
                c.add(points, markers);
            }
        }
    }
    coverage
}

/// A wand calibration run whole: the views kept, the calibration, the rig written (in the
/// ground frame's world when one was given) and how the ground was set.
#[derive(Debug, Clone, PartialEq)]
pub struct WandRun {
    /// What [`wand_views`] kept and why it left the rest.
    pub views: WandViews,
    /// The calibration (world = the first camera's frame).
    pub calibration: WandCalibration,
    /// The rig to write: in the ground frame's world, else the first camera's.
    pub rig: Rig,
    /// How the ground frame set the world, when one was given.
    pub ground: Option<(String, GroundReport)>,
}

/// The rig's extrinsics from a wand dance (`frames`: every frame's blob centres by camera of
/// `cameras`, whose intrinsics are used as they are), then the world from a ground frame
/// (`ground`: its recording's views and its tool) when given. The rig and the wand's length
/// are checked finite.
///
/// # Errors
/// [`WandError`]: from [`calibrate_wand`], [`WandError::Ground`] from [`set_ground`], and
/// [`WandError::Bundle`] for a rig or wand length that is not finite.
pub fn run_wand(
    cameras: &Rig,
    frames: &[Views],
    wand: &Wand,
    ground: Option<(&[Views], &Tool)>,
    config: &WandConfig,
) -> Result<WandRun, WandError> {
    let views = wand_views(cameras, frames, wand, config);
    let calibration = calibrate_wand(cameras, &views.frames, wand, config)?;
    if !(calibration.length_mean_mm.is_finite() && calibration.length_std_mm.is_finite()) {
        return Err(WandError::Bundle {
            message: "the wand's length could not be triangulated in any used frame".into(),
        });
    }
    let (rig, ground) = match ground {
        Some((ground_frames, tool)) => {
            let (rig, report) = set_ground(&calibration.rig, ground_frames, tool)?;
            (rig, Some((tool.name.clone(), report)))
        }
        None => (calibration.rig.clone(), None),
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
        return Err(WandError::Bundle {
            message: "the calibrated rig is not finite".into(),
        });
    }
    Ok(WandRun {
        views,
        calibration,
        rig,
        ground,
    })
}

impl WandRun {
    /// The wand length's mean error, in % of its true length.
    #[must_use]
    pub fn length_error_percent(&self, wand: &Wand) -> f64 {
        100.0 * (self.calibration.length_mean_mm - wand.length_mm()) / wand.length_mm()
    }

    /// What `calibrate wand` prints: the views kept, frames used, each camera's residual and
    /// σ, the wand's length, then the world.
    #[must_use]
    pub fn lines(&self, wand: &Wand, frames: usize) -> Vec<String> {
        let (views, result) = (&self.views, &self.calibration);
        let mut lines = vec![
            format!(
                "wand: {} markers, {frames} frames, {} camera-frames with {} points ({} not collinear beyond {:.2} px, {} with the ends not told apart by the image)",
                wand.markers_mm.len(),
                views.whole,
                wand.markers_mm.len(),
                views.not_collinear,
                views.line_gate_px,
                views.ends_unlabelled
            ),
            format!(
                "frames used {}, rejected {} (residual gate {:.3} px), ambiguous {} (two pairings of the unlabelled ends fitted alike: dropped), {} iterations",
                result.frames_used,
                result.frames_rejected,
                result.residual_gate_px,
                result.frames_ambiguous,
                result.iterations
            ),
        ];
        for c in &result.cameras {
            lines.push(format!(
                "{}: {} frames ({} camera-frames dropped), rms {:.4} px, centre ± {:.3} mm, rotation ± {:.4}° (intrinsics taken as exact)",
                c.name, c.frames, c.dropped, c.rms_px, c.centre_std_mm, c.rotation_std_deg
            ));
        }
        lines.push(format!(
            "wand length: mean {:.3} mm ({:+.3} % of {} mm), std {:.3} mm = {:.4} % of the mean; error rms {:.4} mm, max {:.4} mm",
            result.length_mean_mm,
            self.length_error_percent(wand),
            wand.length_mm(),
            result.length_std_mm,
            result.length_std_percent(),
            result.length_rms_mm,
            result.length_max_mm
        ));
        if !result.converged {
            lines.push(
                "warning: the bundle adjustment stopped at its iteration limit, not at a minimum"
                    .into(),
            );
        }
        lines.push(self.world());
        lines
    }

    /// Where the world is: the ground frame's (how well it was posed) or the first camera's.
    #[must_use]
    pub fn world(&self) -> String {
        match &self.ground {
            Some((tool, report)) => format!(
                "ground: '{tool}' posed in {} of {} frames, origin scatter {:.3} mm, registration rms {:.3} mm; world = its frame",
                report.posed, report.frames, report.scatter_mm, report.registration_rms_mm
            ),
            None => format!(
                "world: camera {}'s frame",
                self.calibration.rig.cameras[0].name
            ),
        }
    }

    /// A warning when every camera is below the ground frame's x-y plane (its z points into
    /// the work object: the world, and a work object set from it, upside down).
    #[must_use]
    pub fn ground_warning(&self, ground_tool: &str) -> Option<String> {
        let (_, report) = self.ground.as_ref()?;
        (report.cameras_below.len() == self.rig.cameras.len()).then(|| {
            format!(
                "every camera is below the ground frame's x-y plane (z < 0 in the new world): {ground_tool}'s z axis points into the work object; the world (and a robot's work object set from it) is upside down unless that is meant"
            )
        })
    }

    /// The calibration's figures as JSON (`calibrate wand --report`).
    #[must_use]
    pub fn report_json(&self, source: &str, format: &str, wand: &Wand) -> serde_json::Value {
        let (views, result) = (&self.views, &self.calibration);
        serde_json::json!({
            "source": source,
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
            "length_mean_error_percent": self.length_error_percent(wand),
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
}
