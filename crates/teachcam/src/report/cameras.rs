//! The figures that need the rig and the tool: the tip uncertainty over the working volume
//! and what the cameras see.

use std::path::Path;

use base64::Engine as _;
use image::{Rgb, RgbImage};

use super::{Axis, FigureBody, FigureId, FigureSlot, Image, Panel, Role, Series, Shape, Style};
use crate::camera::Rig;
use crate::detect::{DetectConfig, detect};
use crate::geometry::{Point3, Pose};
use crate::io::recording::GrayFrame;
use crate::metrology::uncertainty_map;
use crate::source::FrameSource;
use crate::source::folder::FolderSource;
use crate::tool::Tool;
use crate::trajectory::Trajectory;

/// Heading of [`FigureId::Uncertainty`].
pub const UNCERTAINTY_TITLE: &str = "Uncertainty over the working volume";
/// Heading of [`FigureId::Cameras`].
pub const CAMERAS_TITLE: &str = "What the cameras see";

/// The paper's camera repeatability (§IV-A), pixels: the noise the map is drawn at.
pub const MAP_NOISE_PX: f64 = 0.15;

/// First-order tip RMS across the working area at the stroke's middle orientation and height,
/// with every camera and with the most useful one missing.
#[must_use]
pub fn uncertainty(rig: &Rig, tool: &Tool, raw: &Trajectory) -> FigureSlot {
    let poses: Vec<Pose> = raw
        .samples
        .iter()
        .filter_map(|s| s.pose.map(|p| p.world_from_tool))
        .collect();
    let Some(middle) = poses.get(poses.len() / 2) else {
        return FigureSlot::missing(
            FigureId::Uncertainty,
            UNCERTAINTY_TITLE,
            "the raw trajectory has no pose to centre the map on".into(),
        );
    };
    let xs: Vec<f64> = (-12..=12).map(|i| f64::from(i) * 25.0).collect();
    let centre = middle.translation.vector;
    let x: Vec<f64> = xs.iter().map(|dx| centre.x + dx).collect();
    let mut series = Vec::new();
    for (k, dy) in [-200.0, -100.0, 0.0, 100.0, 200.0].into_iter().enumerate() {
        let positions: Vec<Point3> = x
            .iter()
            .map(|x| Point3::new(*x, centre.y + dy, centre.z))
            .collect();
        let cells = uncertainty_map(rig, tool, &middle.rotation, &positions, MAP_NOISE_PX);
        series.push(Series {
            label: format!("all cameras, y = {:.0} mm", centre.y + dy),
            role: Role::Component(k as u8),
            x: None,
            y: cells.iter().map(|c| c.tip_rms_mm).collect(),
            style: Style::Line,
        });
        if dy == 0.0 {
            series.push(Series {
                label: format!("worst camera dropped, y = {:.0} mm", centre.y),
                role: Role::Limit,
                x: None,
                y: cells
                    .iter()
                    .map(|c| c.tip_rms_one_camera_dropped_mm)
                    .collect(),
                style: Style::Dashed,
            });
        }
    }
    let panel = Panel {
        title: format!(
            "first-order tip RMS at {MAP_NOISE_PX} px marker noise, tool at the stroke's middle orientation, z = {:.0} mm",
            centre.z
        ),
        x_axis: Axis::linear("x of the tool origin", "mm"),
        y_axis: Axis::linear("tip RMS uncertainty", "mm"),
        x,
        series,
        marks: Vec::new(),
        shape: Shape::Wide,
    };
    FigureSlot {
        id: FigureId::Uncertainty,
        title: UNCERTAINTY_TITLE.into(),
        caption: format!(
            "Where to work: the tip uncertainty the rig gives at the paper's {MAP_NOISE_PX} px across the working area, with all {} cameras and with the most useful camera missing (the paper asks that the rig work with one camera out). Lines end where the tool leaves the views.",
            rig.len()
        ),
        body: FigureBody::Plots {
            panels: vec![panel],
        },
    }
}

/// Each camera's first frame, cropped around the markers and enlarged, with the detected
/// blobs circled and their centres crossed.
#[must_use]
pub fn camera_views(recording: &Path, rig: &Rig, tool: &Tool) -> FigureSlot {
    match views(recording, rig, tool) {
        Ok((images, notes)) if !images.is_empty() => {
            let names: Vec<&str> = images.iter().map(|i| i.label.as_str()).collect();
            let mut caption = format!(
                "The first frame of each camera ({}), cropped around the markers and enlarged {SCALE}x, with the detected blobs circled and their sub-pixel centres marked.",
                names.join(", ")
            );
            if !notes.is_empty() {
                caption.push_str(&format!(" Not shown: {}.", notes.join("; ")));
            }
            FigureSlot {
                id: FigureId::Cameras,
                title: CAMERAS_TITLE.into(),
                caption,
                body: FigureBody::Images { images },
            }
        }
        Ok((_, notes)) => FigureSlot::missing(
            FigureId::Cameras,
            CAMERAS_TITLE,
            format!(
                "no camera's first frame could be shown: {}",
                notes.join("; ")
            ),
        ),
        Err(reason) => FigureSlot::missing(FigureId::Cameras, CAMERAS_TITLE, reason),
    }
}

const SCALE: u32 = 3;

/// The images, and a note for each camera left out.
fn views(recording: &Path, rig: &Rig, tool: &Tool) -> Result<(Vec<Image>, Vec<String>), String> {
    let mut source = FolderSource::open(recording, None)
        .map_err(|e| format!("the recording cannot be read: {e}"))?;
    let first = source
        .next_set()
        .ok_or_else(|| format!("{} has no frame", recording.display()))?
        .map_err(|e| format!("the first frame cannot be read: {e}"))?;
    let mut images = Vec::new();
    let mut notes = Vec::new();
    for camera in &rig.cameras {
        let Some(frame) = source
            .cameras()
            .iter()
            .position(|c| c.name == camera.name)
            .and_then(|c| first.cameras.get(c)?.as_ref())
        else {
            notes.push(format!(
                "{}: not in the recording's first frame",
                camera.name
            ));
            continue;
        };
        let decoded = match frame.decode(&camera.name, None) {
            Ok(d) => d,
            Err(e) => {
                notes.push(e.to_string());
                continue;
            }
        };
        let config = DetectConfig::for_marker(camera, tool.marker_diameter_mm, 300.0, 3000.0);
        let (gray, blobs) = match decoded.as_ref() {
            GrayFrame::Eight(image) => (image.clone(), detect(image, &config)),
            GrayFrame::Sixteen(image) => (
                image::ImageBuffer::from_fn(image.width(), image.height(), |x, y| {
                    image::Luma([(image.get_pixel(x, y).0[0] >> 8) as u8])
                }),
                detect(image, &config),
            ),
        };
        let blobs = match blobs {
            Ok(b) if !b.is_empty() => b,
            Ok(_) => {
                notes.push(format!("{}: no blob detected", camera.name));
                continue;
            }
            Err(e) => {
                notes.push(format!("{}: {e}", camera.name));
                continue;
            }
        };
        let tile = tile(&gray, &blobs);
        let mut png = std::io::Cursor::new(Vec::new());
        if let Err(e) = tile.write_to(&mut png, image::ImageFormat::Png) {
            notes.push(format!("{}: {e}", camera.name));
            continue;
        }
        images.push(Image {
            label: format!("{} ({} blobs)", camera.name, blobs.len()),
            png_base64: base64::engine::general_purpose::STANDARD.encode(png.into_inner()),
            width_px: tile.width(),
            height_px: tile.height(),
        });
    }
    Ok((images, notes))
}

/// The crop around the blobs, enlarged [`SCALE`] times, blobs circled in red.
fn tile(image: &image::GrayImage, blobs: &[crate::detect::Blob]) -> RgbImage {
    let margin = 30.0;
    let max_x = f64::from(image.width().saturating_sub(1));
    let max_y = f64::from(image.height().saturating_sub(1));
    let fold = |f: fn(&crate::detect::Blob) -> f64, init: f64, pick: fn(f64, f64) -> f64| {
        blobs.iter().map(f).fold(init, pick)
    };
    let x0 = (fold(|b| b.center.x, f64::INFINITY, f64::min) - margin).clamp(0.0, max_x) as u32;
    let y0 = (fold(|b| b.center.y, f64::INFINITY, f64::min) - margin).clamp(0.0, max_y) as u32;
    let x1 = (fold(|b| b.center.x, 0.0, f64::max) + margin).clamp(0.0, max_x) as u32;
    let y1 = (fold(|b| b.center.y, 0.0, f64::max) + margin).clamp(0.0, max_y) as u32;
    let mut tile = RgbImage::from_fn(
        (x1.saturating_sub(x0) + 1) * SCALE,
        (y1.saturating_sub(y0) + 1) * SCALE,
        |x, y| {
            let v = image.get_pixel(x0 + x / SCALE, y0 + y / SCALE).0[0];
            Rgb([v, v, v])
        },
    );
    let red = Rgb([255, 40, 40]);
    for b in blobs {
        let cx = (b.center.x - f64::from(x0) + 0.5) * f64::from(SCALE);
        let cy = (b.center.y - f64::from(y0) + 0.5) * f64::from(SCALE);
        let r = (b.radius_px + 2.0) * f64::from(SCALE);
        for k in 0..360 {
            let a = f64::from(k).to_radians();
            put(&mut tile, cx + r * a.cos(), cy + r * a.sin(), red);
        }
        for d in -4..=4 {
            put(&mut tile, cx + f64::from(d), cy, red);
            put(&mut tile, cx, cy + f64::from(d), red);
        }
    }
    tile
}

fn put(image: &mut RgbImage, x: f64, y: f64, color: Rgb<u8>) {
    if x >= 0.0 && y >= 0.0 && (x as u32) < image.width() && (y as u32) < image.height() {
        image.put_pixel(x as u32, y as u32, color);
    }
}
