//! `detections.csv` (CONTRACT.md, "Detections"): one row per blob,
//! `camera,frame,x_px,y_px,radius_px` then the detector's other measures
//! (`area_px,roundness,center_std_px,peak`). `teachcam detect` writes it and `teachcam track
//! --detections` reads it back, so detection is tuned once. Numbers are written in Rust's
//! shortest round-trip form, so that a blob read back is the blob detected, to the last bit.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use super::{FileError, read_text};
use crate::detect::CameraDetections;
use crate::detect::{Blob, PixelBox};
use crate::geometry::Pixel;

/// The contract's columns, in this order, at the start of the header.
pub const DETECTIONS_COLUMNS: [&str; 5] = ["camera", "frame", "x_px", "y_px", "radius_px"];

/// The columns `teachcam detect` writes after the contract's.
pub const DETECTOR_COLUMNS: [&str; 4] = ["area_px", "roundness", "center_std_px", "peak"];

/// A detections file read: each camera's blobs by frame (0-based, the camera's own frame
/// number), in the file's order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Detections {
    /// Camera name → frame → blobs.
    pub cameras: BTreeMap<String, BTreeMap<usize, Vec<Blob>>>,
}

impl Detections {
    /// One past the largest frame number of any camera (0 when the file has no rows).
    #[must_use]
    pub fn frame_count(&self) -> usize {
        self.cameras
            .values()
            .filter_map(|frames| frames.keys().next_back())
            .map(|last| last + 1)
            .max()
            .unwrap_or(0)
    }

    /// Camera `camera`'s blobs in `frame` (none when the file has no row for them).
    #[must_use]
    pub fn blobs(&self, camera: &str, frame: usize) -> &[Blob] {
        self.cameras
            .get(camera)
            .and_then(|frames| frames.get(&frame))
            .map_or(&[], Vec::as_slice)
    }
}

/// The CSV text of detected frames, in the order given.
#[must_use]
pub fn detections_csv<'a>(frames: impl IntoIterator<Item = &'a CameraDetections>) -> String {
    let mut text = format!(
        "{},{}\n",
        DETECTIONS_COLUMNS.join(","),
        DETECTOR_COLUMNS.join(",")
    );
    for f in frames {
        let camera = csv_field(&f.camera);
        for b in &f.blobs {
            // Writing to a String cannot fail.
            let _ = writeln!(
                text,
                "{camera},{},{},{},{},{},{},{},{}",
                f.frame,
                b.center.x,
                b.center.y,
                b.radius_px,
                b.area_px,
                b.roundness,
                b.center_std_px,
                b.peak
            );
        }
    }
    text
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A CSV line's fields (`"..."` quoting with `""` for a quote).
fn fields(line: &str) -> Vec<String> {
    let mut fields = Vec::new();
    let mut field = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                field.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => fields.push(std::mem::take(&mut field)),
            c => field.push(c),
        }
    }
    fields.push(field);
    fields
}

/// Reads a detections file.
///
/// # Errors
/// [`FileError`] naming the file, and the line and column it refuses: a header without the
/// contract's columns, a row of another length, a field that is not a number (or not finite,
/// or negative where a size is).
pub fn read_detections(path: &Path) -> Result<Detections, FileError> {
    parse_detections(path, &read_text(path)?)
}

/// Parses the text of a detections file; `path` names it in errors.
///
/// # Errors
/// As [`read_detections`].
pub fn parse_detections(path: &Path, text: &str) -> Result<Detections, FileError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')));
    let (_, header) = lines
        .next()
        .ok_or_else(|| FileError::invalid(path, "empty file: no header"))?;
    let columns: Vec<String> = fields(header)
        .iter()
        .map(|c| c.trim().to_string())
        .collect();
    if columns.len() < DETECTIONS_COLUMNS.len()
        || columns[..DETECTIONS_COLUMNS.len()] != DETECTIONS_COLUMNS
    {
        return Err(FileError::invalid_line(
            path,
            1,
            format!("header must start with {}", DETECTIONS_COLUMNS.join(",")),
        ));
    }
    let column = |name: &str| columns.iter().position(|c| c == name);
    let [area, roundness, std, peak] = DETECTOR_COLUMNS.map(column);
    let mut detections = Detections::default();
    for (line, row) in lines {
        if row.trim().is_empty() {
            continue;
        }
        let fields = fields(row);
        if fields.len() != columns.len() {
            return Err(FileError::invalid_line(
                path,
                line,
                format!("{} fields, header has {}", fields.len(), columns.len()),
            ));
        }
        let number = |i: usize| -> Result<f64, FileError> {
            let value: f64 = fields[i].trim().parse().map_err(|_| {
                FileError::invalid_line(
                    path,
                    line,
                    format!("{}: '{}' is not a number", columns[i], fields[i]),
                )
            })?;
            if value.is_finite() {
                Ok(value)
            } else {
                Err(FileError::invalid_line(
                    path,
                    line,
                    format!("{}: {value} is not finite", columns[i]),
                ))
            }
        };
        let count = |i: usize| -> Result<usize, FileError> {
            fields[i].trim().parse().map_err(|_| {
                FileError::invalid_line(
                    path,
                    line,
                    format!(
                        "{}: '{}' is not a whole number of 0 or more",
                        columns[i], fields[i]
                    ),
                )
            })
        };
        let frame = count(1)?;
        let center = Pixel::new(number(2)?, number(3)?);
        let radius_px = number(4)?;
        if radius_px < 0.0 {
            return Err(FileError::invalid_line(
                path,
                line,
                format!("radius_px: {radius_px} is negative"),
            ));
        }
        let peak = peak.map(count).transpose()?.unwrap_or(0);
        let reach = radius_px.ceil();
        let blob = Blob {
            center,
            area_px: match area {
                Some(i) => count(i)?,
                None => (std::f64::consts::PI * radius_px * radius_px).round() as usize,
            },
            radius_px,
            roundness: roundness.map(number).transpose()?.unwrap_or(1.0),
            center_std_px: std.map(number).transpose()?.unwrap_or(0.0),
            bounding_box: PixelBox {
                x_min: (center.x - reach).max(0.0) as u32,
                y_min: (center.y - reach).max(0.0) as u32,
                x_max: (center.x + reach).max(0.0) as u32,
                y_max: (center.y + reach).max(0.0) as u32,
            },
            peak: u32::try_from(peak).unwrap_or(u32::MAX),
            mean: peak as f64,
        };
        detections
            .cameras
            .entry(fields[0].clone())
            .or_default()
            .entry(frame)
            .or_default()
            .push(blob);
    }
    Ok(detections)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blob(x: f64, y: f64) -> Blob {
        Blob {
            center: Pixel::new(x, y),
            area_px: 50,
            radius_px: 3.989_422_804_014_327,
            roundness: 0.951_234_567_8,
            center_std_px: 0.012_345_678_9,
            bounding_box: PixelBox {
                x_min: 0,
                y_min: 0,
                x_max: 1,
                y_max: 1,
            },
            peak: 255,
            mean: 200.0,
        }
    }

    #[test]
    fn blobs_read_back_as_written_to_the_last_bit() {
        let frames = [
            CameraDetections {
                camera: "cam,0".into(),
                frame: 0,
                time_s: 0.0,
                blobs: vec![blob(10.123_456_789_012_3, 0.1 + 0.2)],
            },
            CameraDetections {
                camera: "cam1".into(),
                frame: 7,
                time_s: 0.0,
                blobs: vec![blob(1e-9, 1_279.999_999_999), blob(5.0, 6.0)],
            },
        ];
        let text = detections_csv(&frames);
        let read = parse_detections(Path::new("d.csv"), &text).unwrap();
        assert_eq!(read.frame_count(), 8);
        for f in &frames {
            let back = read.blobs(&f.camera, f.frame);
            assert_eq!(back.len(), f.blobs.len());
            for (a, b) in back.iter().zip(&f.blobs) {
                assert_eq!(a.center, b.center);
                assert_eq!(a.radius_px, b.radius_px);
                assert_eq!(a.roundness, b.roundness);
                assert_eq!(a.center_std_px, b.center_std_px);
                assert_eq!((a.area_px, a.peak), (b.area_px, b.peak));
            }
        }
    }

    #[test]
    fn the_contract_columns_alone_are_enough_and_bad_rows_are_named() {
        let read = parse_detections(
            Path::new("d.csv"),
            "camera,frame,x_px,y_px,radius_px\ncam0,3,1.5,2.5,4\n",
        )
        .unwrap();
        let b = &read.blobs("cam0", 3)[0];
        assert_eq!((b.center.x, b.center.y, b.roundness), (1.5, 2.5, 1.0));
        let header = parse_detections(Path::new("d.csv"), "camera,x_px\n").unwrap_err();
        assert!(
            header
                .to_string()
                .contains("d.csv:1: header must start with camera,frame")
        );
        let row = parse_detections(
            Path::new("d.csv"),
            "camera,frame,x_px,y_px,radius_px\ncam0,-1,1,2,3\n",
        )
        .unwrap_err();
        assert!(row.to_string().contains("d.csv:2: frame: '-1'"), "{row}");
    }
}
