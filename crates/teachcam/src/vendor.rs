//! Marker exports of other trackers in, and our trajectory out in a tracker's layout.
//!
//! - **OptiTrack Motive CSV** (format 1.2x, "Markers" export): a metadata line of key/value
//!   pairs (`Export Frame Rate`, `Length Units`), a blank line, header rows keyed in column 2
//!   (`Type`, `Name`, `ID`, `Parent`), a property row (`Position`, `Rotation`, ...) and an axis
//!   row starting `Frame,Time (Seconds)`; then one row per frame, an empty cell where a marker
//!   was not seen. Every `Marker` column triple with property `Position` and axes X, Y, Z is a
//!   marker; `Rigid Body Marker` columns (the solver's model, not a measurement) and rigid-body
//!   columns are skipped. Units as `Length Units` says (Motive's default, metres, when absent).
//! - **Qualisys TSV** (QTM "3D data" export): `KEY<TAB>value` lines (`NO_OF_FRAMES`,
//!   `FREQUENCY`, `MARKER_NAMES`, ...), an optional column header (`Frame Time m1 X m1 Y ...`),
//!   then one row per frame: optional frame number and time, then X Y Z per marker in
//!   millimetres. QTM writes a marker it did not see as `0 0 0`, so exact zeros are a gap.
//! - **teachcam's own 3-D markers** (`teachcam track --markers-out`): header
//!   `frame,marker,x_mm,y_mm,z_mm,...`, one row per identified marker per frame; a marker
//!   absent from a frame is a gap. Labels are `M0`, `M1`, ... by marker id; the rate is given.
//! - **Out**: a trajectory as a Motive-like rigid-body CSV (rotation X, Y, Z, W; position;
//!   mean marker error), millimetres, which Motive-reading scripts take as a rigid-body export.
//!
//! Both readers return [`PointData`], the same marker trajectories a C3D file gives, so
//! everything downstream (tool from a static stretch, identification, export) is shared.

use std::fmt::Write as _;
use std::path::Path;

use crate::c3d::{PointData, PointSample};
use crate::geometry::Point3;
use crate::io::{FileError, read_text, write_atomically};
use crate::trajectory::Trajectory;

/// Reads an OptiTrack Motive marker CSV export.
///
/// # Errors
/// [`FileError`] naming the file and line: no axis row, no marker columns, a frame rate or
/// unit it cannot use, a cell that is not a number.
pub fn read_motive_csv(path: &Path) -> Result<PointData, FileError> {
    parse_motive_csv(path, &read_text(path)?)
}

/// Parses the text of a Motive CSV export; `path` only names the file in errors.
///
/// # Errors
/// As [`read_motive_csv`].
pub fn parse_motive_csv(path: &Path, text: &str) -> Result<PointData, FileError> {
    let owned: Vec<Vec<String>> = text.lines().map(split_csv_line).collect();
    let rows: Vec<Vec<&str>> = owned
        .iter()
        .map(|r| r.iter().map(String::as_str).collect())
        .collect();
    let meta = rows
        .first()
        .ok_or_else(|| FileError::invalid(path, "empty file"))?;
    if meta.first() != Some(&"Format Version") {
        return Err(FileError::invalid_line(
            path,
            1,
            "not a Motive CSV export (no \"Format Version\" in the first cell)",
        ));
    }
    let value_of = |key: &str| {
        meta.iter()
            .position(|c| c.eq_ignore_ascii_case(key))
            .and_then(|i| meta.get(i + 1))
            .copied()
    };
    let rate_text = value_of("Export Frame Rate")
        .or_else(|| value_of("Capture Frame Rate"))
        .ok_or_else(|| FileError::invalid_line(path, 1, "no Export or Capture Frame Rate"))?;
    let rate_hz: f64 = rate_text
        .parse()
        .ok()
        .filter(|r: &f64| r.is_finite() && *r > 0.0)
        .ok_or_else(|| {
            FileError::invalid_line(path, 1, format!("frame rate {rate_text:?} is not a rate"))
        })?;
    let units = match value_of("Length Units").unwrap_or("Meters") {
        "Millimeters" => "mm",
        "Centimeters" => "cm",
        "Meters" => "m",
        other => {
            return Err(FileError::invalid_line(
                path,
                1,
                format!("Length Units {other:?} is not Millimeters, Centimeters or Meters"),
            ));
        }
    };
    let axis_row = rows
        .iter()
        .position(|r| r.first() == Some(&"Frame"))
        .ok_or_else(|| FileError::invalid(path, "no axis row starting \"Frame\""))?;
    let header_row = |key: &str| rows[..axis_row].iter().find(|r| r.get(1) == Some(&key));
    let types = header_row("Type").ok_or_else(|| FileError::invalid(path, "no Type row"))?;
    let names = header_row("Name").ok_or_else(|| FileError::invalid(path, "no Name row"))?;
    // The property row has empty first two cells and sits just above the axis row.
    let properties = rows[..axis_row]
        .last()
        .filter(|r| r.first() == Some(&"") && r.get(1) == Some(&""));
    let axes = &rows[axis_row];

    let mut labels = Vec::new();
    let mut columns = Vec::new();
    let mut col = 2;
    while col + 2 < axes.len() {
        let is_marker = types.get(col) == Some(&"Marker")
            && properties.is_none_or(|p| p.get(col) == Some(&"Position"))
            && axes[col..col + 3] == ["X", "Y", "Z"]
            && names.get(col) == names.get(col + 2);
        if is_marker {
            labels.push(names.get(col).copied().unwrap_or_default().to_string());
            columns.push(col);
            col += 3;
        } else {
            col += 1;
        }
    }
    if labels.is_empty() {
        return Err(FileError::invalid_line(
            path,
            axis_row + 1,
            "no Marker columns with Position X, Y, Z",
        ));
    }
    let time_column = axes.get(1).is_some_and(|c| c.starts_with("Time"));
    let mut frames = Vec::new();
    for (i, row) in rows.iter().enumerate().skip(axis_row + 1) {
        if row.iter().all(|c| c.is_empty()) {
            continue;
        }
        let line = i + 1;
        let markers = columns
            .iter()
            .zip(&labels)
            .map(|(&c, label)| xyz_cells(path, line, row, c, label))
            .collect::<Result<Vec<_>, _>>()?;
        frames.push(ExportRow {
            line,
            frame: Some(frame_number(
                path,
                line,
                row.first().copied().unwrap_or(""),
            )?),
            time_s: if time_column {
                Some(time_cell(path, line, row.get(1).copied().unwrap_or(""))?)
            } else {
                None
            },
            markers,
        });
    }
    let frames = frames_by_number(path, frames, rate_hz, labels.len())?;
    PointData::new(labels, rate_hz, units.to_string(), &frames)
        .map_err(|e| FileError::invalid(path, e.to_string()))
}

/// One data row of a tracker's export: its line, the frame number and time it states (when
/// the export has those columns) and its markers.
struct ExportRow {
    line: usize,
    frame: Option<usize>,
    time_s: Option<f64>,
    markers: Vec<Option<PointSample>>,
}

/// Largest frames × markers grid an export may ask for (an hour at 100 Hz of a 25-marker
/// tool; about 500 MB): a corrupted frame number must not exhaust memory.
const MAX_GRID_SAMPLES: usize = 10_000_000;

/// The rows of an export as one row per frame, placed by the frame numbers the file states:
/// a frame number missing from the file is a gap there (all markers `None`), rows out of
/// order are put in frame order, a frame number given twice is refused naming both lines, and
/// a time that disagrees with its frame number by half a frame or more (`(time - time₀)·rate`
/// against `frame - frame₀`) is refused. Rows without frame numbers are taken in file order.
///
/// # Errors
/// [`FileError::InvalidLine`] naming the line.
fn frames_by_number(
    path: &Path,
    mut rows: Vec<ExportRow>,
    rate_hz: f64,
    markers: usize,
) -> Result<Vec<Vec<Option<PointSample>>>, FileError> {
    if rows.iter().any(|r| r.frame.is_none()) {
        return Ok(rows.into_iter().map(|r| r.markers).collect());
    }
    // Stable: of two rows with one frame number, the earlier line comes first.
    rows.sort_by_key(|r| r.frame);
    for pair in rows.windows(2) {
        if pair[0].frame == pair[1].frame {
            return Err(FileError::invalid_line(
                path,
                pair[1].line.max(pair[0].line),
                format!(
                    "frame {} appears again (also on line {})",
                    pair[1].frame.unwrap_or(0),
                    pair[1].line.min(pair[0].line)
                ),
            ));
        }
    }
    let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
        return Ok(Vec::new());
    };
    let first_frame = first.frame.unwrap_or(0);
    let span = last.frame.unwrap_or(0) - first_frame + 1;
    if span.saturating_mul(markers.max(1)) > MAX_GRID_SAMPLES {
        return Err(FileError::invalid_line(
            path,
            last.line,
            format!(
                "frames {first_frame}..={} x {markers} markers is more than {MAX_GRID_SAMPLES} samples",
                first_frame + span - 1
            ),
        ));
    }
    if let Some(first_time_s) = first.time_s {
        for row in &rows {
            let (Some(frame), Some(time_s)) = (row.frame, row.time_s) else {
                continue;
            };
            let expected_s = first_time_s + (frame - first_frame) as f64 / rate_hz;
            // Both times are finite (time_cell) and the rate positive.
            if (time_s - expected_s).abs() * rate_hz >= 0.5 {
                return Err(FileError::invalid_line(
                    path,
                    row.line,
                    format!(
                        "frame {frame} is at {time_s} s, but frame {first_frame} at {first_time_s} s and {rate_hz} Hz put it at {expected_s:.6} s"
                    ),
                ));
            }
        }
    }
    let mut grid = vec![vec![None; markers]; span];
    for row in rows {
        grid[row.frame.unwrap_or(0) - first_frame] = row.markers;
    }
    Ok(grid)
}

/// A frame number cell: a whole number (Motive and QTM write integers; `12.0` is taken).
fn frame_number(path: &Path, line: usize, cell: &str) -> Result<usize, FileError> {
    let value: f64 = cell.parse().unwrap_or(f64::NAN);
    if value.is_finite() && value >= 0.0 && value.fract() == 0.0 && value < 1e15 {
        Ok(value as usize)
    } else {
        Err(FileError::invalid_line(
            path,
            line,
            format!("frame {cell:?} is not a frame number"),
        ))
    }
}

/// A time cell, seconds: a finite number.
fn time_cell(path: &Path, line: usize, cell: &str) -> Result<f64, FileError> {
    cell.parse()
        .ok()
        .filter(|t: &f64| t.is_finite())
        .ok_or_else(|| {
            FileError::invalid_line(path, line, format!("time {cell:?} is not a number"))
        })
}

/// The cells of one CSV line, trimmed; a double-quoted cell may hold commas and `""` for a
/// quote (Motive quotes names and ids). Records never span lines in these exports.
fn split_csv_line(line: &str) -> Vec<String> {
    let mut cells = Vec::new();
    let mut cell = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cell.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => cells.push(std::mem::take(&mut cell).trim().to_string()),
            _ => cell.push(c),
        }
    }
    cells.push(cell.trim().to_string());
    cells
}

/// A sample from three cells starting at `col`: a gap when any is empty or missing.
fn xyz_cells(
    path: &Path,
    line: usize,
    row: &[&str],
    col: usize,
    label: &str,
) -> Result<Option<PointSample>, FileError> {
    let mut xyz = [0.0; 3];
    for (k, v) in xyz.iter_mut().enumerate() {
        let cell = row.get(col + k).copied().unwrap_or("");
        if cell.is_empty() {
            return Ok(None);
        }
        *v = cell
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| {
                FileError::invalid_line(
                    path,
                    line,
                    format!("{label} {}: {cell:?} is not a number", ["X", "Y", "Z"][k]),
                )
            })?;
    }
    Ok(Some(PointSample {
        position: Point3::new(xyz[0], xyz[1], xyz[2]),
        residual: 0.0,
        camera_mask: 0,
    }))
}

/// Reads a Qualisys QTM 3D TSV export.
///
/// # Errors
/// [`FileError`] naming the file and line: no `FREQUENCY` or `MARKER_NAMES`, a row with the
/// wrong number of cells, a cell that is not a number.
pub fn read_qualisys_tsv(path: &Path) -> Result<PointData, FileError> {
    parse_qualisys_tsv(path, &read_text(path)?)
}

/// Parses the text of a Qualisys TSV export; `path` only names the file in errors.
///
/// # Errors
/// As [`read_qualisys_tsv`].
pub fn parse_qualisys_tsv(path: &Path, text: &str) -> Result<PointData, FileError> {
    let mut rate_hz = None;
    let mut labels: Option<Vec<String>> = None;
    let mut has_time = false;
    let mut frames = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let cells: Vec<&str> = line.split('\t').map(str::trim).collect();
        let first = cells.first().copied().unwrap_or("");
        if first.is_empty() && cells.len() <= 1 {
            continue;
        }
        let starts_with_number = first.parse::<f64>().is_ok();
        if !starts_with_number {
            match first {
                "FREQUENCY" => {
                    let text = cells.get(1).copied().unwrap_or("");
                    rate_hz = Some(
                        text.parse::<f64>()
                            .ok()
                            .filter(|r| r.is_finite() && *r > 0.0)
                            .ok_or_else(|| {
                                FileError::invalid_line(
                                    path,
                                    line_no,
                                    format!("FREQUENCY {text:?} is not a rate"),
                                )
                            })?,
                    );
                }
                "MARKER_NAMES" => {
                    labels = Some(
                        cells[1..]
                            .iter()
                            .filter(|c| !c.is_empty())
                            .map(|c| (*c).to_string())
                            .collect(),
                    );
                }
                "Frame" => has_time = cells.get(1) == Some(&"Time"),
                _ => {}
            }
            continue;
        }
        let labels = labels
            .as_ref()
            .ok_or_else(|| FileError::invalid_line(path, line_no, "data before MARKER_NAMES"))?;
        let numbers: Vec<&str> = cells.iter().copied().filter(|c| !c.is_empty()).collect();
        let offset = if has_time || numbers.len() == 3 * labels.len() + 2 {
            2
        } else {
            0
        };
        if numbers.len() != offset + 3 * labels.len() {
            return Err(FileError::invalid_line(
                path,
                line_no,
                format!(
                    "{} cells, expected {} ({} markers x 3{})",
                    numbers.len(),
                    offset + 3 * labels.len(),
                    labels.len(),
                    if offset == 2 { " + frame and time" } else { "" }
                ),
            ));
        }
        let markers = labels
            .iter()
            .enumerate()
            .map(|(m, label)| {
                let sample = xyz_cells(path, line_no, &numbers, offset + 3 * m, label)?;
                // QTM writes an unseen marker as exactly (0, 0, 0).
                Ok(sample.filter(|s| s.position != Point3::origin()))
            })
            .collect::<Result<Vec<_>, FileError>>()?;
        let (frame, time_s) = if offset == 2 {
            (
                Some(frame_number(path, line_no, numbers[0])?),
                Some(time_cell(path, line_no, numbers[1])?),
            )
        } else {
            (None, None)
        };
        frames.push(ExportRow {
            line: line_no,
            frame,
            time_s,
            markers,
        });
    }
    let rate_hz = rate_hz.ok_or_else(|| FileError::invalid(path, "no FREQUENCY line"))?;
    let labels = labels.ok_or_else(|| FileError::invalid(path, "no MARKER_NAMES line"))?;
    let frames = frames_by_number(path, frames, rate_hz, labels.len())?;
    PointData::new(labels, rate_hz, "mm".into(), &frames)
        .map_err(|e| FileError::invalid(path, e.to_string()))
}

/// Reads the identified 3-D markers `teachcam track --markers-out` writes, at `rate_hz`.
///
/// # Errors
/// [`FileError`] naming the file and line: a missing column, a cell that is not a number, a
/// frame or marker number beyond 10^7, or more than 10^7 samples in all (a corrupted file,
/// refused before allocating).
pub fn read_markers_csv(path: &Path, rate_hz: f64) -> Result<PointData, FileError> {
    parse_markers_csv(path, &read_text(path)?, rate_hz)
}

/// Largest frame or marker number [`parse_markers_csv`] accepts.
const MAX_MARKERS_CSV_INDEX: usize = 10_000_000;

/// Parses the text of a `--markers-out` file; `path` only names the file in errors.
///
/// # Errors
/// As [`read_markers_csv`].
pub fn parse_markers_csv(path: &Path, text: &str, rate_hz: f64) -> Result<PointData, FileError> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(FileError::invalid(path, format!("frame rate {rate_hz} Hz")));
    }
    let mut lines = text.lines().enumerate();
    let header: Vec<&str> = lines
        .next()
        .map(|(_, l)| l.split(',').map(str::trim).collect())
        .unwrap_or_default();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| FileError::invalid_line(path, 1, format!("no column {name:?}")))
    };
    let columns = [
        column("frame")?,
        column("marker")?,
        column("x_mm")?,
        column("y_mm")?,
        column("z_mm")?,
    ];
    if columns[3] != columns[2] + 1 || columns[4] != columns[2] + 2 {
        return Err(FileError::invalid_line(
            path,
            1,
            "x_mm, y_mm, z_mm must be adjacent columns, in that order",
        ));
    }
    let mut rows: Vec<(usize, usize, Point3)> = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let cell = |k: usize| cells.get(columns[k]).copied().unwrap_or("");
        let index = |k: usize| {
            cell(k)
                .parse::<usize>()
                .ok()
                .filter(|v| *v < MAX_MARKERS_CSV_INDEX)
                .ok_or_else(|| {
                    FileError::invalid_line(
                        path,
                        i + 1,
                        format!(
                            "{}: {:?} is not a frame or marker number",
                            header[columns[k]],
                            cell(k)
                        ),
                    )
                })
        };
        let (frame, marker) = (index(0)?, index(1)?);
        let Some(sample) = xyz_cells(path, i + 1, &cells, columns[2], &format!("M{marker}"))?
        else {
            return Err(FileError::invalid_line(path, i + 1, "empty coordinate"));
        };
        rows.push((frame, marker, sample.position));
    }
    let frames = rows.iter().map(|r| r.0 + 1).max().unwrap_or(0);
    let markers = rows.iter().map(|r| r.1 + 1).max().unwrap_or(0);
    if frames.saturating_mul(markers) > MAX_GRID_SAMPLES {
        return Err(FileError::invalid(
            path,
            format!("{frames} frames x {markers} markers is more than {MAX_GRID_SAMPLES} samples"),
        ));
    }
    let mut grid = vec![vec![None; markers]; frames];
    for (frame, marker, position) in rows {
        grid[frame][marker] = Some(PointSample {
            position,
            residual: 0.0,
            camera_mask: 0,
        });
    }
    let labels = (0..markers).map(|k| format!("M{k}")).collect();
    PointData::new(labels, rate_hz, "mm".into(), &grid)
        .map_err(|e| FileError::invalid(path, e.to_string()))
}

/// The text of a Motive-like rigid-body CSV for a trajectory of the tool `name`: rotation
/// `X, Y, Z, W` (Motive's order) of `world_from_tool`, position in millimetres, and the
/// registration residual as `Mean Marker Error`; empty cells for a frame without a pose.
#[must_use]
pub fn motive_rigid_body_csv(trajectory: &Trajectory, name: &str) -> String {
    let rate = trajectory.sample_rate_hz().unwrap_or(0.0);
    let n = trajectory.len();
    let mut out = String::new();
    // Infallible: writing to a String.
    let _ = writeln!(
        out,
        "Format Version,1.23,Take Name,{name},Capture Frame Rate,{rate:.6},Export Frame Rate,\
         {rate:.6},Total Frames in Take,{n},Total Exported Frames,{n},Rotation Type,Quaternion,\
         Length Units,Millimeters,Coordinate Space,Global"
    );
    out.push('\n');
    let repeat = |cell: &str| [cell; 8].join(",");
    let _ = writeln!(out, ",Type,{}", repeat("Rigid Body"));
    let _ = writeln!(out, ",Name,{}", repeat(name));
    let _ = writeln!(out, ",ID,{}", repeat("1"));
    let _ = writeln!(
        out,
        ",,Rotation,Rotation,Rotation,Rotation,Position,Position,Position,Mean Marker Error"
    );
    out.push_str("Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,\n");
    for (sample, q) in trajectory
        .samples
        .iter()
        .zip(trajectory.continuous_quaternions())
    {
        let _ = write!(out, "{},{:.6}", sample.frame.0, sample.time_s);
        match (&sample.pose, q) {
            (Some(pose), Some(q)) => {
                let t = pose.world_from_tool.translation.vector;
                let _ = writeln!(
                    out,
                    ",{:.9},{:.9},{:.9},{:.9},{:.6},{:.6},{:.6},{:.6}",
                    q.x, q.y, q.z, q.w, t.x, t.y, t.z, pose.rms_mm
                );
            }
            _ => out.push_str(",,,,,,,,\n"),
        }
    }
    out
}

/// Writes [`motive_rigid_body_csv`] to `path` whole or not at all.
///
/// # Errors
/// [`FileError::Write`].
pub fn write_motive_rigid_body_csv(
    path: &Path,
    trajectory: &Trajectory,
    name: &str,
) -> Result<(), FileError> {
    write_atomically(path, motive_rigid_body_csv(trajectory, name).as_bytes())
}
