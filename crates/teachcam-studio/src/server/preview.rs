//! The live view's frames: each camera's image shrunk for the page, with what the pipeline
//! found in it.
//!
//! A preview pixel is the brightest of the `k × k` block it covers (`k` the smallest whole
//! factor that brings the width within [`PREVIEW_WIDTH`]): a marker a few pixels across stays
//! visible at a quarter of the size, where an average would dim it into the background. 16-bit
//! frames keep their top 8 bits.
//!
//! One WebSocket message per frame set, binary:
//! ```text
//! u32 (little-endian) n | n bytes of JSON (frame, status, pose, per camera: size, scale,
//!                       |   blobs [x, y, r] and labels [x, y, marker] in full-size pixels)
//!                       | then each camera's preview pixels, width × height bytes, rig order
//! ```

use axum::body::Bytes;
use serde_json::{Value, json};
use teachcam::io::recording::GrayFrame;
use teachcam::pipeline::TrackedFrame;
use teachcam::source::CameraFrame;

use teachcam::camera::Rig;
use teachcam::detect::{Background, DetectConfig, DetectedSet, GrayView, estimate_background};

/// The widest preview sent, pixels: enough to aim a camera and see its markers, small enough
/// for three cameras at 30 Hz over loopback (3 × 320 × 256 bytes a frame).
pub const PREVIEW_WIDTH: u32 = 320;

/// A camera's image shrunk by a whole factor.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Preview {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// The factor: a preview pixel covers `scale × scale` image pixels.
    pub scale: u32,
    /// 8-bit levels, row after row.
    pub pixels: Vec<u8>,
}

/// The frame shrunk to at most `max_width` columns, each pixel the brightest of its block.
#[must_use]
pub fn preview(frame: &GrayFrame, max_width: u32) -> Preview {
    match frame {
        GrayFrame::Eight(image) => shrink(
            image.width(),
            image.height(),
            image.as_raw(),
            max_width,
            |v| v,
        ),
        GrayFrame::Sixteen(image) => shrink(
            image.width(),
            image.height(),
            image.as_raw(),
            max_width,
            |v: u16| (v >> 8) as u8,
        ),
    }
}

fn shrink<P: Copy + Ord + Default>(
    width: u32,
    height: u32,
    pixels: &[P],
    max_width: u32,
    to_byte: impl Fn(P) -> u8,
) -> Preview {
    let scale = width.div_ceil(max_width.max(1)).max(1);
    let (w, h) = (width.div_ceil(scale), height.div_ceil(scale));
    let (width, scale_us) = (width as usize, scale as usize);
    let mut row_max = vec![P::default(); w as usize];
    let mut out = Vec::with_capacity((w * h) as usize);
    for block_row in pixels.chunks(width * scale_us) {
        row_max.fill(P::default());
        for row in block_row.chunks_exact(width) {
            for (m, block) in row_max.iter_mut().zip(row.chunks(scale_us)) {
                if let Some(&b) = block.iter().max()
                    && b > *m
                {
                    *m = b;
                }
            }
        }
        out.extend(row_max.iter().map(|&v| to_byte(v)));
    }
    Preview {
        width: w,
        height: h,
        scale,
        pixels: out,
    }
}

/// Rounds for the page (a tenth of a micrometre or a thousandth of a pixel is plenty).
fn round(value: f64, decimals: i32) -> f64 {
    let f = 10f64.powi(decimals);
    (value * f).round() / f
}

/// The pose part of a live message, `null` without a pose.
fn pose_json(frame: &TrackedFrame) -> Value {
    match &frame.track.outcome {
        Ok(pose) => {
            let t = pose.world_from_tool.translation.vector;
            let q = pose.world_from_tool.rotation.quaternion();
            let tip = pose.tip_in_world;
            json!({
                "position_mm": [round(t.x, 3), round(t.y, 3), round(t.z, 3)],
                "quaternion": [round(q.w, 6), round(q.i, 6), round(q.j, 6), round(q.k, 6)],
                "tip_mm": [round(tip.x, 3), round(tip.y, 3), round(tip.z, 3)],
                "markers": pose.markers,
                "rms_mm": round(pose.rms_mm, 4),
            })
        }
        Err(_) => Value::Null,
    }
}

/// The binary message of one tracked set (module docs); `images` in rig order, `None` where a
/// camera's frame is not at hand.
#[must_use]
pub fn live_message(
    rig: &Rig,
    frame: &TrackedFrame,
    images: &[Option<&CameraFrame>],
    fps: f64,
) -> Bytes {
    let mut pixels: Vec<u8> = Vec::new();
    let mut cameras = Vec::new();
    for ((id, camera), image) in rig.iter().zip(images) {
        let detections = frame.detections.of(&camera.name);
        let shrunk = image
            .and_then(|f| f.decode(&camera.name, None).ok())
            .map(|i| preview(&i, PREVIEW_WIDTH));
        let blobs: Vec<[f64; 3]> = detections
            .iter()
            .flat_map(|d| &d.blobs)
            .map(|b| {
                [
                    round(b.center.x, 2),
                    round(b.center.y, 2),
                    round(b.radius_px, 2),
                ]
            })
            .collect();
        let labels: Vec<Value> = frame
            .track
            .labels
            .iter()
            .filter_map(|(marker, &point)| {
                let px = frame.track.points.get(point)?.views.get(&id)?;
                Some(json!([round(px.x, 2), round(px.y, 2), marker.0]))
            })
            .collect();
        let (width, height, scale) = shrunk
            .as_ref()
            .map_or((0, 0, 1), |p| (p.width, p.height, p.scale));
        if let Some(p) = &shrunk {
            pixels.extend_from_slice(&p.pixels);
        }
        cameras.push(json!({
            "name": camera.name,
            "image_width": camera.image_size.width,
            "image_height": camera.image_size.height,
            "width": width,
            "height": height,
            "scale": scale,
            "blobs": blobs,
            "labels": labels,
        }));
    }
    let header = json!({
        "frame": frame.detections.index,
        "time_s": round(frame.detections.time_s, 6),
        "status": frame.status().name(),
        "reason": frame.track.reason(),
        "tool": pose_json(frame),
        "tip_std_mm": frame.tip_std_mm.map(|s| round(s, 4)),
        "fps": round(fps, 2),
        "cameras": cameras,
    })
    .to_string();
    let mut message = Vec::with_capacity(4 + header.len() + pixels.len());
    message.extend_from_slice(&(header.len() as u32).to_le_bytes());
    message.extend_from_slice(header.as_bytes());
    message.extend_from_slice(&pixels);
    Bytes::from(message)
}

/// What the detector measured of one camera's frame: its background level and noise (robust
/// σ), the automatic threshold they give, the threshold in use, and the size and roundness
/// limits blobs were held to.
fn measured_json(image: Option<&GrayFrame>, config: &DetectConfig) -> Value {
    let Some(image) = image else {
        return Value::Null;
    };
    let contrast = match config.threshold {
        teachcam::detect::Threshold::AboveBackground(c) => c,
        _ => 0.0,
    };
    let (background, auto, above, full_scale): (Background, u32, u32, u32) = match image {
        GrayFrame::Eight(i) => {
            let b = estimate_background(GrayView::new(i));
            (
                b,
                b.auto_threshold::<u8>(),
                b.threshold_above::<u8>(contrast),
                255,
            )
        }
        GrayFrame::Sixteen(i) => {
            let b = estimate_background(GrayView::new(i));
            (
                b,
                b.auto_threshold::<u16>(),
                b.threshold_above::<u16>(contrast),
                65535,
            )
        }
    };
    json!({
        "background": round(background.level, 2),
        "noise_std": round(background.noise_std, 3),
        "auto_threshold": auto,
        "threshold": match config.threshold {
            teachcam::detect::Threshold::Auto => auto,
            teachcam::detect::Threshold::Fixed(t) => t,
            teachcam::detect::Threshold::AboveBackground(_) => above,
        },
        "full_scale": full_scale,
        "min_area_px": config.min_area_px,
        "max_area_px": config.max_area_px,
        "min_roundness": config.min_roundness,
    })
}

/// The binary message of one set looked at without a rig: the same layout as
/// [`live_message`] (no pose, no labels, status `view-only`), each camera with what the
/// detector measured of its frame (`measured`).
#[must_use]
pub fn view_message(
    names: &[String],
    set: &DetectedSet,
    images: &[Option<&CameraFrame>],
    config: &DetectConfig,
    reason: &str,
    fps: f64,
) -> Bytes {
    let mut pixels: Vec<u8> = Vec::new();
    let mut cameras = Vec::new();
    for ((name, detections), image) in names.iter().zip(&set.cameras).zip(images) {
        let decoded = image.and_then(|f| f.decode(name, None).ok());
        let shrunk = decoded.as_ref().map(|i| preview(i, PREVIEW_WIDTH));
        let blobs: Vec<[f64; 3]> = detections
            .iter()
            .flat_map(|d| &d.blobs)
            .map(|b| {
                [
                    round(b.center.x, 2),
                    round(b.center.y, 2),
                    round(b.radius_px, 2),
                ]
            })
            .collect();
        let (width, height, scale) = shrunk
            .as_ref()
            .map_or((0, 0, 1), |p| (p.width, p.height, p.scale));
        if let Some(p) = &shrunk {
            pixels.extend_from_slice(&p.pixels);
        }
        let (image_width, image_height) = decoded.as_ref().map_or((0, 0), |i| i.dimensions());
        cameras.push(json!({
            "name": name,
            "image_width": image_width,
            "image_height": image_height,
            "width": width,
            "height": height,
            "scale": scale,
            "blobs": blobs,
            "labels": [],
            "measured": measured_json(decoded.as_deref(), config),
        }));
    }
    let header = json!({
        "frame": set.index,
        "time_s": round(set.time_s, 6),
        "status": "view-only",
        "reason": reason,
        "tool": null,
        "tip_std_mm": null,
        "fps": round(fps, 2),
        "cameras": cameras,
    })
    .to_string();
    let mut message = Vec::with_capacity(4 + header.len() + pixels.len());
    message.extend_from_slice(&(header.len() as u32).to_le_bytes());
    message.extend_from_slice(header.as_bytes());
    message.extend_from_slice(&pixels);
    Bytes::from(message)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_block_keeps_its_brightest_pixel_and_ragged_edges_count() {
        // 5 × 3 image, factor 2 (max width 3): blocks of 2 × 2, the last column and row alone.
        let raw: Vec<u8> = vec![
            1, 2, 3, 4, 5, //
            6, 90, 8, 9, 10, //
            11, 12, 13, 14, 200,
        ];
        let image = image::GrayImage::from_raw(5, 3, raw).unwrap();
        let p = preview(&GrayFrame::Eight(image), 3);
        assert_eq!((p.width, p.height, p.scale), (3, 2, 2));
        assert_eq!(p.pixels, vec![90, 9, 10, 12, 14, 200]);
    }

    #[test]
    fn sixteen_bit_frames_keep_their_top_byte_and_small_ones_stay_whole() {
        let image =
            image::ImageBuffer::<image::Luma<u16>, _>::from_raw(2, 1, vec![0x1234_u16, 0xff00])
                .unwrap();
        let p = preview(&GrayFrame::Sixteen(image), 320);
        assert_eq!((p.width, p.height, p.scale), (2, 1, 1));
        assert_eq!(p.pixels, vec![0x12, 0xff]);
    }
}
