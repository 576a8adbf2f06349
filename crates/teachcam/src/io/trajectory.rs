//! Trajectory CSV (CONTRACT.md, "Trajectory"), written by `track`, `smooth` and `simulate`
//! (`truth.csv`), read by `smooth`, `export` and `check`.
//!
//! ```text
//! frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,tip_x_mm,tip_y_mm,tip_z_mm,markers,rms_mm,filled,tip_std_mm,status,cameras
//! ```
//! The first fourteen columns are the contract's, in order; `filled` (1 where the smoother
//! filled a gap), `tip_std_mm` and `status` (`ok`, `degraded`, `outlier`, `lost`:
//! [`Status`]) follow; other columns are allowed and ignored. A frame without a pose keeps its
//! row with every pose field empty and status `lost`. Files written before `status` existed
//! still read: their status is `ok` where a pose is and `lost` where none is. Nothing that is
//! not finite is ever written.

use std::ops::Range;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use super::decimal::{TextBuffer, parse_f64};
use super::{FileError, read_line_chunks, write_atomically_with};
use crate::geometry::{FrameIndex, Point3, Quat, pose_from_parts};
use crate::trajectory::{PoseSource, Sample, Status, ToolPose, Trajectory};

/// The contract's columns, in order.
pub const CONTRACT_COLUMNS: [&str; 14] = [
    "frame", "time_s", "x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz", "tip_x_mm", "tip_y_mm",
    "tip_z_mm", "markers", "rms_mm",
];

/// Columns this writer adds after the contract's.
pub const EXTRA_COLUMNS: [&str; 4] = ["filled", "tip_std_mm", "status", "cameras"];

/// Tolerance on `|q| - 1` for quaternions read from CSV: written numbers are rounded, and other
/// tools print six decimals.
const CSV_QUATERNION_TOLERANCE: f64 = 1e-5;

/// Writes a trajectory CSV whole, after checking that every number in it is finite. The text
/// goes to the file a few blocks of rows at a time ([`write_trajectory_csv`]); it is never
/// held whole.
///
/// # Errors
/// [`FileError::Invalid`] naming the first frame and field that is not finite (nothing is
/// written then); [`FileError::Write`].
pub fn write_trajectory(path: &Path, trajectory: &Trajectory) -> Result<(), FileError> {
    check_finite(trajectory).map_err(|reason| FileError::invalid(path, reason))?;
    write_atomically_with(path, |file| write_trajectory_csv(file, trajectory))
}

/// The CSV text of a trajectory for `path`, after checking that every number in it is finite.
///
/// # Errors
/// [`FileError::Invalid`] naming `path`, the first frame and field that is not finite.
pub fn trajectory_text(path: &Path, trajectory: &Trajectory) -> Result<String, FileError> {
    check_finite(trajectory).map_err(|reason| FileError::invalid(path, reason))?;
    Ok(trajectory_csv(trajectory))
}

/// The first field of a trajectory that is not finite, as a message naming the frame.
///
/// # Errors
/// The message.
pub fn check_finite(trajectory: &Trajectory) -> Result<(), String> {
    // The samples checked side by side; the first in order is named.
    let first = trajectory.samples.par_iter().find_map_first(|s| {
        let pose = s.pose.as_ref().map(|p| {
            let t = p.world_from_tool.translation.vector;
            let q = p.world_from_tool.rotation.quaternion();
            [
                ("x_mm", t.x),
                ("y_mm", t.y),
                ("z_mm", t.z),
                ("qw", q.w),
                ("qx", q.i),
                ("qy", q.j),
                ("qz", q.k),
                ("tip_x_mm", p.tip_in_world.x),
                ("tip_y_mm", p.tip_in_world.y),
                ("tip_z_mm", p.tip_in_world.z),
                ("rms_mm", p.rms_mm),
            ]
        });
        let mut fields = std::iter::once(("time_s", s.time_s))
            .chain(pose.into_iter().flatten())
            .chain(s.tip_std_mm.map(|v| ("tip_std_mm", v)));
        let (name, value) = fields.find(|(_, v)| !v.is_finite())?;
        Some(format!(
            "frame {}: {name} is {value}, not a finite number; nothing written",
            s.frame.0
        ))
    });
    first.map_or(Ok(()), Err)
}

/// The CSV text of a trajectory.
#[must_use]
pub fn trajectory_csv(trajectory: &Trajectory) -> String {
    let mut out = Vec::with_capacity(160 * (trajectory.len() + 1));
    // Writing to a Vec cannot fail.
    let _ = write_trajectory_csv(&mut out, trajectory);
    // Every byte pushed is ASCII.
    String::from_utf8(out).unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned())
}

/// Rows formatted by one thread before the text is written: about 300 KB.
const ROWS_PER_BLOCK: usize = 2048;

/// Writes the CSV text of a trajectory to `out`: blocks of [`ROWS_PER_BLOCK`] rows formatted
/// side by side, one per thread, each in its own reused buffer, then written in order. The
/// text is never held whole.
///
/// # Errors
/// What `out` returns.
pub fn write_trajectory_csv(
    out: &mut impl std::io::Write,
    trajectory: &Trajectory,
) -> std::io::Result<()> {
    let mut header = Vec::new();
    push_header(&mut header);
    out.write_all(&header)?;
    let quaternions = trajectory.continuous_quaternions();
    let rows: Vec<(&Sample, Option<&Quat>)> = trajectory
        .samples
        .iter()
        .zip(quaternions.iter().map(Option::as_ref))
        .collect();
    let threads = rayon::current_num_threads().max(1);
    let mut buffers: Vec<Vec<u8>> = vec![Vec::with_capacity(ROWS_PER_BLOCK * 180); threads];
    for batch in rows.chunks(threads * ROWS_PER_BLOCK) {
        buffers
            .par_iter_mut()
            .zip(batch.par_chunks(ROWS_PER_BLOCK))
            .for_each(|(buffer, block)| {
                buffer.clear();
                let mut text = TextBuffer::new(buffer);
                for (sample, q) in block {
                    push_row(&mut text, sample, *q);
                }
            });
        let blocks = batch.len().div_ceil(ROWS_PER_BLOCK);
        for buffer in &buffers[..blocks] {
            out.write_all(buffer)?;
        }
    }
    Ok(())
}

fn push_header(out: &mut Vec<u8>) {
    out.extend_from_slice(CONTRACT_COLUMNS.join(",").as_bytes());
    for c in EXTRA_COLUMNS {
        out.push(b',');
        out.extend_from_slice(c.as_bytes());
    }
    out.push(b'\n');
}

/// One row: millimetres with 6 decimals, quaternions and seconds with 9 (nanoseconds: distinct
/// and uniform up to `trajectory::MAX_SAMPLE_RATE_HZ`), exactly as `format!("{:.6}")` and
/// `format!("{:.9}")` write them ([`TextBuffer::fixed`]).
fn push_row(line: &mut TextBuffer<'_>, sample: &Sample, q: Option<&Quat>) {
    line.integer(sample.frame.0);
    line.byte(b',');
    line.fixed(sample.time_s, 9);
    match (&sample.pose, q) {
        (Some(p), Some(q)) => {
            let t = p.world_from_tool.translation.vector;
            let tip = p.tip_in_world;
            let numbers = [
                (t.x, 6),
                (t.y, 6),
                (t.z, 6),
                (q.w, 9),
                (q.x, 9),
                (q.y, 9),
                (q.z, 9),
                (tip.x, 6),
                (tip.y, 6),
                (tip.z, 6),
            ];
            for (value, decimals) in numbers {
                line.byte(b',');
                line.fixed(value, decimals);
            }
            line.byte(b',');
            line.integer(p.markers);
            line.byte(b',');
            line.fixed(p.rms_mm, 6);
        }
        _ => line.bytes(b",,,,,,,,,,,,"),
    }
    line.bytes(if sample.source == PoseSource::Filled {
        b",1,"
    } else {
        b",0,"
    });
    if let Some(std) = sample.tip_std_mm {
        line.fixed(std, 6);
    }
    let status = match sample.pose {
        Some(_) if sample.status == Status::Lost => Status::Degraded,
        Some(_) => sample.status,
        None => Status::Lost,
    };
    line.byte(b',');
    line.bytes(status.name().as_bytes());
    line.byte(b',');
    if let (Some(_), Some(cameras)) = (sample.pose, sample.cameras) {
        line.integer(cameras);
    }
    line.byte(b'\n');
}

/// Reads and checks a trajectory CSV: the contract's header, frames strictly increasing,
/// times finite and strictly increasing, pose fields all present or all empty, unit quaternions.
/// The file is read a piece at a time, never held whole.
///
/// # Errors
/// [`FileError::Read`]; [`FileError::Invalid`] when it is not UTF-8;
/// [`FileError::InvalidLine`] naming the line and the column.
pub fn read_trajectory(path: &Path) -> Result<Trajectory, FileError> {
    let size_bytes = std::fs::metadata(path).map_or(0, |m| m.len());
    let mut reader = TrajectoryReader::new(path, usize::try_from(size_bytes).unwrap_or(0));
    read_line_chunks(path, |first_line, text| {
        reader.lines_side_by_side(first_line, text)
    })?;
    reader.finish()
}

/// Parses trajectory CSV text; `path` only names the source in errors.
///
/// # Errors
/// As [`read_trajectory`].
pub fn parse_trajectory(path: &Path, text: &str) -> Result<Trajectory, FileError> {
    let mut reader = TrajectoryReader::new(path, text.len());
    reader.lines(1, text)?;
    reader.finish()
}

/// Where the optional columns are, from the header.
#[derive(Debug, Clone, Copy)]
struct Layout {
    columns: usize,
    filled: Option<usize>,
    std: Option<usize>,
    status: Option<usize>,
    cameras: Option<usize>,
}

/// A trajectory CSV read a piece of whole lines at a time. Fields are slices of the text (one
/// list per piece) and numbers are read by [`parse_f64`]: nothing is allocated per row.
#[derive(Debug)]
struct TrajectoryReader<'p> {
    path: &'p Path,
    /// Bytes of the whole text, to size `samples` from the first row's length.
    size_bytes: usize,
    layout: Option<Layout>,
    samples: Vec<Sample>,
}

impl<'p> TrajectoryReader<'p> {
    fn new(path: &'p Path, size_bytes: usize) -> Self {
        Self {
            path,
            size_bytes,
            layout: None,
            samples: Vec::new(),
        }
    }

    /// Reads the lines of `text`, the first numbered `first_line`; returns how many there were.
    fn lines(&mut self, first_line: usize, text: &str) -> Result<usize, FileError> {
        let path = self.path;
        let mut count = 0;
        let mut fields: Vec<&str> = Vec::with_capacity(self.layout.map_or(0, |l| l.columns));
        for row in text.lines() {
            let line = first_line + count;
            count += 1;
            let row = row.trim_end_matches('\r');
            let Some(layout) = self.layout else {
                let layout = header_layout(row).ok_or_else(|| {
                    FileError::invalid_line(
                        path,
                        line,
                        format!("header must start with {}", CONTRACT_COLUMNS.join(",")),
                    )
                })?;
                self.layout = Some(layout);
                continue;
            };
            if row.trim().is_empty() {
                continue;
            }
            if self.samples.capacity() == 0 {
                // Rows are about as long as the first: one allocation in the common case.
                self.samples.reserve(self.size_bytes / (row.len() + 1) + 1);
            }
            let sample = row_sample(row, &layout, &mut fields)
                .map_err(|m| FileError::invalid_line(path, line, m))?;
            if let Some(previous) = self.samples.last() {
                if sample.frame <= previous.frame {
                    return Err(FileError::invalid_line(
                        path,
                        line,
                        format!(
                            "frame {} does not follow frame {}",
                            sample.frame.0, previous.frame.0
                        ),
                    ));
                }
                if sample.time_s <= previous.time_s {
                    return Err(FileError::invalid_line(
                        path,
                        line,
                        format!(
                            "time_s {} does not increase (previous {})",
                            sample.time_s, previous.time_s
                        ),
                    ));
                }
            }
            self.samples.push(sample);
        }
        Ok(count)
    }

    /// As [`Self::lines`], the rows parsed side by side, each sample written in place at the
    /// end of `samples` (a part's own samples copied there afterwards took a quarter of the
    /// reading: the copy, and the new memory's page faults, one thread at a time). The rows
    /// are found first, in one part of the text per thread. On any error, in a row or in the
    /// order of frames and times, the text is read again by [`Self::lines`], so the error is
    /// the one a reading in order meets first.
    fn lines_side_by_side(&mut self, first_line: usize, text: &str) -> Result<usize, FileError> {
        let Some(layout) = self.layout else {
            return self.lines(first_line, text);
        };
        let mut offset = 0;
        let parts: Vec<(usize, &str)> = split_at_lines(text, rayon::current_num_threads())
            .into_iter()
            .map(|part| {
                offset += part.len();
                (offset - part.len(), part)
            })
            .collect();
        let parts: Vec<(Vec<Range<usize>>, usize)> = parts
            .into_par_iter()
            .map(|(offset, part)| row_ranges(offset, part))
            .collect();
        let count = parts.iter().map(|(_, lines)| lines).sum();
        let rows: Vec<Range<usize>> = parts.into_iter().flat_map(|(rows, _)| rows).collect();
        let start = self.samples.len();
        let failed = AtomicBool::new(false);
        self.samples.par_extend(rows.into_par_iter().map_init(
            || Vec::with_capacity(layout.columns),
            |fields, range| {
                row_sample(text[range].trim_end_matches('\r'), &layout, fields).unwrap_or_else(
                    |_| {
                        failed.store(true, Ordering::Relaxed);
                        Sample::gap(FrameIndex(0), 0.0)
                    },
                )
            },
        ));
        let increasing = self.samples[start.saturating_sub(1)..]
            .par_windows(2)
            .all(|pair| pair[1].frame > pair[0].frame && pair[1].time_s > pair[0].time_s);
        if failed.load(Ordering::Relaxed) || !increasing {
            self.samples.truncate(start);
            return self.lines(first_line, text);
        }
        Ok(count)
    }

    fn finish(self) -> Result<Trajectory, FileError> {
        if self.layout.is_none() {
            return Err(FileError::invalid(self.path, "empty file: no header"));
        }
        Ok(Trajectory {
            samples: self.samples,
        })
    }
}

/// `text` cut after line breaks into at most `parts` pieces of about equal length.
fn split_at_lines(text: &str, parts: usize) -> Vec<&str> {
    let mut pieces = Vec::with_capacity(parts);
    let mut rest = text;
    for remaining in (2..=parts).rev() {
        let target = rest.len() / remaining;
        let Some(at) = rest.as_bytes()[target..].iter().position(|&b| b == b'\n') else {
            break;
        };
        if target + at + 1 == rest.len() {
            break;
        }
        // After a one-byte line break: a character boundary.
        let (piece, tail) = rest.split_at(target + at + 1);
        pieces.push(piece);
        rest = tail;
    }
    pieces.push(rest);
    pieces
}

/// The byte ranges of the rows of `part` that are not blank, shifted by `offset` (where the
/// part starts in the text), and how many lines it has, as [`TrajectoryReader::lines`]
/// counts and cuts them (`str::lines`).
fn row_ranges(offset: usize, part: &str) -> (Vec<Range<usize>>, usize) {
    let mut rows = Vec::with_capacity(part.len() / 64);
    let (mut at, mut lines) = (offset, 0);
    for piece in part.split_inclusive('\n') {
        lines += 1;
        let line = piece
            .strip_suffix('\n')
            .map_or(piece, |l| l.strip_suffix('\r').unwrap_or(l));
        // A row starts with its frame number; only a line starting otherwise may be blank.
        let maybe_blank = line.as_bytes().first().is_none_or(|b| !b.is_ascii_digit());
        if !(maybe_blank && line.trim().is_empty()) {
            rows.push(at..at + line.len());
        }
        at += piece.len();
    }
    (rows, lines)
}

/// The layout a header gives, or `None` when it does not start with the contract's columns.
fn header_layout(header: &str) -> Option<Layout> {
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    if columns.len() < CONTRACT_COLUMNS.len()
        || columns[..CONTRACT_COLUMNS.len()] != CONTRACT_COLUMNS
    {
        return None;
    }
    let position = |name: &str| columns.iter().position(|c| *c == name);
    Some(Layout {
        columns: columns.len(),
        filled: position("filled"),
        std: position("tip_std_mm"),
        status: position("status"),
        cameras: position("cameras"),
    })
}

/// The sample of one row that is not blank (its line end cut), `fields` its fields' scratch;
/// the error message names the column.
fn row_sample<'a>(
    row: &'a str,
    layout: &Layout,
    fields: &mut Vec<&'a str>,
) -> Result<Sample, String> {
    split_fields(row, fields);
    if fields.len() != layout.columns {
        return Err(format!(
            "{} fields, header has {}",
            fields.len(),
            layout.columns
        ));
    }
    parse_row(fields, layout)
}

/// `row`'s comma-separated fields, trimmed, into `fields` (emptied first).
fn split_fields<'a>(row: &'a str, fields: &mut Vec<&'a str>) {
    fields.clear();
    let mut start = 0;
    for (i, b) in row.bytes().enumerate() {
        if b == b',' {
            // A comma is one byte: `start..i` lies on character boundaries.
            fields.push(trimmed(&row[start..i]));
            start = i + 1;
        }
    }
    fields.push(trimmed(&row[start..]));
}

/// `field` without the white space around it, looked for only when its first or last byte
/// may be some (every white space character is a byte up to a space, or not ASCII).
fn trimmed(field: &str) -> &str {
    let plain = |b: &u8| (b'!'..=b'~').contains(b);
    let bytes = field.as_bytes();
    if bytes.first().is_some_and(plain) && bytes.last().is_some_and(plain) {
        field
    } else {
        field.trim()
    }
}

fn number(fields: &[&str], column: usize) -> Result<f64, String> {
    let name = CONTRACT_COLUMNS.get(column).copied().unwrap_or("column");
    let value = parse_f64(fields[column])
        .ok_or_else(|| format!("{name}: '{}' is not a number", fields[column]))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(format!("{name}: {value} is not finite"))
    }
}

fn parse_row(fields: &[&str], layout: &Layout) -> Result<Sample, String> {
    let (filled_column, std_column, status_column) = (layout.filled, layout.std, layout.status);
    let frame: usize = fields[0]
        .parse()
        .map_err(|_| format!("frame: '{}' is not a frame number", fields[0]))?;
    let time_s = number(fields, 1)?;
    let pose_fields = &fields[2..14];
    let empty = pose_fields.iter().filter(|f| f.is_empty()).count();
    let pose = match empty {
        12 => None,
        0 => {
            let mut v = [0.0; 12];
            for (c, value) in (2..14).zip(&mut v) {
                *value = number(fields, c)?;
            }
            let rotation = Quat {
                w: v[3],
                x: v[4],
                y: v[5],
                z: v[6],
            };
            let norm = rotation
                .to_array()
                .iter()
                .map(|c| c * c)
                .sum::<f64>()
                .sqrt();
            if (norm - 1.0).abs() > CSV_QUATERNION_TOLERANCE {
                return Err(format!("qw,qx,qy,qz has norm {norm:.7}, not 1"));
            }
            let rotation = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                v[3], v[4], v[5], v[6],
            ));
            let markers: usize = fields[12]
                .parse()
                .map_err(|_| format!("markers: '{}' is not a count", fields[12]))?;
            Some(ToolPose {
                world_from_tool: pose_from_parts(
                    nalgebra::Vector3::new(v[0], v[1], v[2]),
                    rotation,
                ),
                tip_in_world: Point3::new(v[7], v[8], v[9]),
                markers,
                rms_mm: v[11],
            })
        }
        _ => {
            let missing: Vec<&str> = pose_fields
                .iter()
                .zip(&CONTRACT_COLUMNS[2..])
                .filter(|(f, _)| f.is_empty())
                .map(|(_, c)| *c)
                .collect();
            return Err(format!(
                "pose fields must be all present or all empty; empty: {}",
                missing.join(",")
            ));
        }
    };
    let source = match filled_column.map(|c| fields[c]) {
        None | Some("" | "0") => PoseSource::Measured,
        Some("1") => PoseSource::Filled,
        Some(other) => return Err(format!("filled: '{other}' is not 0 or 1")),
    };
    let tip_std_mm = match std_column.map(|c| fields[c]) {
        None | Some("") => None,
        Some(text) => Some(
            parse_f64(text)
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| format!("tip_std_mm: '{text}' is not a non-negative number"))?,
        ),
    };
    let status = match status_column.map(|c| fields[c]) {
        None | Some("") if pose.is_some() => Status::Ok,
        None | Some("") => Status::Lost,
        Some(text) => {
            let status = Status::from_name(text)
                .ok_or_else(|| format!("status: '{text}' is not ok, degraded, outlier or lost"))?;
            match (status, pose.is_some()) {
                (Status::Lost, true) => {
                    return Err("status: 'lost' on a row with a pose".into());
                }
                (Status::Ok | Status::Degraded | Status::Outlier, false) => {
                    return Err(format!("status: '{text}' on a row without a pose"));
                }
                _ => status,
            }
        }
    };
    let cameras = match layout.cameras.map(|c| fields[c]) {
        None | Some("") => None,
        Some(_) if pose.is_none() => return Err("cameras: a count on a row without a pose".into()),
        Some(text) => Some(
            text.parse::<usize>()
                .map_err(|_| format!("cameras: '{text}' is not a count"))?,
        ),
    };
    Ok(Sample {
        frame: FrameIndex(frame),
        time_s,
        pose,
        source,
        tip_std_mm,
        status,
        cameras,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};
    use proptest::prelude::*;

    fn sample(i: usize, angle: f64) -> Sample {
        let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle);
        let world_from_tool = pose_from_parts(Vector3::new(i as f64, 2.5, -3.25), rotation);
        Sample::measured(
            FrameIndex(i),
            i as f64 / 30.0,
            ToolPose {
                world_from_tool,
                tip_in_world: Point3::new(1.0, 2.0, 3.0),
                markers: 4,
                rms_mm: 0.01,
            },
        )
    }

    #[test]
    fn round_trip_keeps_gaps_and_quaternion_continuity() {
        // A rotation past 180 degrees: qw changes sign along the way and the file keeps continuity.
        let mut samples: Vec<Sample> = (0..40).map(|i| sample(i, 0.3 + i as f64 * 0.1)).collect();
        samples[5].pose = None;
        samples[6].source = PoseSource::Filled;
        samples[7].tip_std_mm = Some(0.05);
        samples[8].status = Status::Outlier;
        samples[9].status = Status::Degraded;
        let t = Trajectory { samples };
        let text = trajectory_csv(&t);
        let back = parse_trajectory(Path::new("t.csv"), &text).unwrap();
        assert_eq!(back.len(), 40);
        assert!(back.samples[5].pose.is_none());
        let statuses: Vec<Status> = back.samples[4..10].iter().map(|s| s.status).collect();
        use Status::{Degraded, Lost, Ok, Outlier};
        assert_eq!(statuses, [Ok, Lost, Ok, Ok, Outlier, Degraded]);
        assert_eq!(back.samples[6].source, PoseSource::Filled);
        assert_eq!(back.samples[7].tip_std_mm, Some(0.05));
        for (a, b) in t.samples.iter().zip(&back.samples) {
            if let (Some(a), Some(b)) = (a.pose, b.pose) {
                assert!(
                    (a.world_from_tool.translation.vector - b.world_from_tool.translation.vector)
                        .norm()
                        < 1e-6
                );
                assert!(
                    a.world_from_tool
                        .rotation
                        .angle_to(&b.world_from_tool.rotation)
                        < 1e-8
                );
            }
        }
        let qw: Vec<f64> = text
            .lines()
            .skip(1)
            .filter_map(|l| l.split(',').nth(5)?.parse().ok())
            .collect();
        assert!(
            qw.iter().any(|w| *w < 0.0),
            "continuity should carry qw below zero past 180 degrees"
        );
        assert!(qw.windows(2).all(|w| (w[0] - w[1]).abs() < 0.1));
    }

    #[test]
    fn files_without_a_status_column_still_read() {
        let header = CONTRACT_COLUMNS.join(",");
        let text = format!("{header}\n0,0.0,1,2,3,1,0,0,0,4,5,6,4,0.01\n1,0.1,,,,,,,,,,,,\n");
        let t = parse_trajectory(Path::new("old.csv"), &text).unwrap();
        assert_eq!(t.samples[0].status, Status::Ok);
        assert_eq!(t.samples[1].status, Status::Lost);
    }

    #[test]
    fn a_status_that_contradicts_the_row_is_refused() {
        let header = format!("{},status", CONTRACT_COLUMNS.join(","));
        for (row, needle) in [
            (
                "0,0.0,1,2,3,1,0,0,0,4,5,6,4,0.01,lost",
                "'lost' on a row with a pose",
            ),
            ("0,0.0,,,,,,,,,,,,,ok", "'ok' on a row without a pose"),
            ("0,0.0,1,2,3,1,0,0,0,4,5,6,4,0.01,fine", "'fine' is not ok"),
        ] {
            let message = parse_trajectory(Path::new("t.csv"), &format!("{header}\n{row}\n"))
                .unwrap_err()
                .to_string();
            assert!(message.contains(needle), "{needle} not in {message}");
        }
    }

    #[test]
    fn nothing_that_is_not_finite_is_written() {
        let mut t = Trajectory {
            samples: (0..3).map(|i| sample(i, 0.1)).collect(),
        };
        t.samples[1].tip_std_mm = Some(f64::NAN);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let message = write_trajectory(&path, &t).unwrap_err().to_string();
        assert!(message.contains("frame 1: tip_std_mm is NaN"), "{message}");
        assert!(!path.exists());
        t.samples[1].tip_std_mm = None;
        if let Some(p) = &mut t.samples[2].pose {
            p.tip_in_world.z = f64::INFINITY;
        }
        let message = write_trajectory(&path, &t).unwrap_err().to_string();
        assert!(message.contains("frame 2: tip_z_mm is inf"), "{message}");
    }

    #[test]
    fn refuses_bad_rows_with_line_and_column() {
        let header = format!("{}\n", CONTRACT_COLUMNS.join(","));
        let good = "0,0.0,1,2,3,1,0,0,0,4,5,6,4,0.01";
        let cases = [
            ("frame,time\n".to_string(), ":1:"),
            (
                format!("{header}{good}\n0,0.1,1,2,3,1,0,0,0,4,5,6,4,0.01\n"),
                ":3: frame 0 does not follow",
            ),
            (
                format!("{header}{good}\n1,0.0,1,2,3,1,0,0,0,4,5,6,4,0.01\n"),
                ":3: time_s",
            ),
            (
                format!("{header}0,0.0,1,2,NaN,1,0,0,0,4,5,6,4,0.01\n"),
                ":2: z_mm",
            ),
            (
                format!("{header}0,0.0,1,2,3,1,1,0,0,4,5,6,4,0.01\n"),
                ":2: qw,qx,qy,qz has norm",
            ),
            (
                format!("{header}0,0.0,1,2,3,1,0,0,0,4,5,6,,0.01\n"),
                ":2: pose fields must be all present",
            ),
            (
                format!("{header}0,0.0,1,2,3,1,0,0,0,4,5,6\n"),
                ":2: 12 fields",
            ),
            (
                format!("{header}x,0.0,1,2,3,1,0,0,0,4,5,6,4,0.01\n"),
                ":2: frame",
            ),
        ];
        for (text, needle) in cases {
            let message = parse_trajectory(Path::new("t.csv"), &text)
                .unwrap_err()
                .to_string();
            assert!(message.contains(needle), "{needle} not in {message}");
        }
    }

    fn rows_text(rows: usize) -> String {
        let t = Trajectory {
            samples: (0..rows)
                .map(|i| sample(i, 0.3 + i as f64 * 0.01))
                .collect(),
        };
        trajectory_csv(&t)
    }

    #[test]
    fn a_file_read_in_pieces_and_parts_is_the_text_parsed_in_order() {
        // 20,000 rows, about 3 MB: several 1 MiB pieces, each read in parts side by side.
        let text = rows_text(20_000);
        assert!(text.len() > 2 * (1 << 20));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        std::fs::write(&path, &text).unwrap();
        let read = read_trajectory(&path).unwrap();
        assert_eq!(read, parse_trajectory(&path, &text).unwrap());
        assert_eq!(read.len(), 20_000);
        // A bad row far into the file is named by its line, as a reading in order names it.
        let mut lines: Vec<&str> = text.lines().collect();
        lines[15_000] = "x,0.0,1,2,3,1,0,0,0,4,5,6,4,0.01,0,,ok,";
        std::fs::write(&path, lines.join("\n")).unwrap();
        let message = read_trajectory(&path).unwrap_err().to_string();
        assert!(message.contains(":15001: frame: 'x'"), "{message}");
    }

    #[test]
    fn parts_read_side_by_side_give_the_errors_of_a_reading_in_order() {
        // Every row in turn made bad (a frame that does not follow, a time that does not
        // increase, a number that is not one), so that one of them falls at the start of a
        // part, where only the join can see it.
        let text = rows_text(40);
        let lines: Vec<&str> = text.lines().collect();
        let path = Path::new("t.csv");
        let in_order = |text: &str| {
            let mut reader = TrajectoryReader::new(path, text.len());
            reader.lines(1, text).map(|_| reader.samples)
        };
        let side_by_side = |text: &str| {
            let (header, rows) = text.split_at(text.find('\n').unwrap() + 1);
            let mut reader = TrajectoryReader::new(path, text.len());
            reader.lines(1, header).unwrap();
            reader.lines_side_by_side(2, rows).map(|_| reader.samples)
        };
        assert_eq!(side_by_side(&text).unwrap(), in_order(&text).unwrap());
        for bad in 2..lines.len() {
            for replacement in [
                lines[bad - 1].to_string(),
                lines[bad].replacen(",0.", ",-1.", 1),
                lines[bad].replacen(",4,", ",4.5,", 1),
            ] {
                let mut changed = lines.clone();
                changed[bad] = &replacement;
                let changed = changed.join("\n");
                let expected = in_order(&changed).unwrap_err().to_string();
                assert_eq!(side_by_side(&changed).unwrap_err().to_string(), expected);
            }
        }
    }

    #[test]
    fn blank_lines_and_line_ends_of_every_kind_are_read_side_by_side_as_in_order() {
        // The rows are found before they are parsed side by side: blank lines (white space
        // of any kind) are left out, CR LF ends cut as `str::lines` cuts them, a last line
        // without a break kept, and the lines counted as a reading in order counts them.
        let text = rows_text(60);
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        for (at, blank) in [
            (5, ""),
            (9, "   "),
            (17, "\t\r"),
            (30, " \u{a0}"),
            (44, "\u{3000}"),
        ] {
            lines.insert(at, blank.to_string());
        }
        for at in [3, 20, 21, 50] {
            lines[at].push('\r');
        }
        let path = Path::new("t.csv");
        for ending in ["", "\n", "\r\n", "\n\n"] {
            let text = lines.join("\n") + ending;
            let mut in_order = TrajectoryReader::new(path, text.len());
            let count = in_order.lines(1, &text).unwrap();
            let (header, rows) = text.split_at(text.find('\n').unwrap() + 1);
            for threads in [1, 2, 3, 7] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let mut reader = TrajectoryReader::new(path, text.len());
                reader.lines(1, header).unwrap();
                let side_count = pool.install(|| reader.lines_side_by_side(2, rows)).unwrap();
                assert_eq!(side_count + 1, count, "{ending:?}, {threads} threads");
                assert_eq!(
                    reader.samples, in_order.samples,
                    "{ending:?}, {threads} threads"
                );
            }
            assert_eq!(in_order.samples.len(), 60);
        }
    }

    #[test]
    fn cut_at_line_breaks_into_parts_of_about_equal_length() {
        let text = "a\nbb\nccc\ndddd\neeeee\n";
        for parts in 1..8 {
            let pieces = split_at_lines(text, parts);
            assert_eq!(pieces.concat(), text);
            assert!(pieces.len() <= parts);
            assert!(pieces.iter().all(|p| p.ends_with('\n')));
        }
        // The cut comes after the line that holds the middle byte.
        assert_eq!(split_at_lines(text, 2), ["a\nbb\nccc\ndddd\n", "eeeee\n"]);
    }

    proptest! {
        #[test]
        fn parser_never_panics(text in "\\PC{0,300}") {
            let _ = parse_trajectory(Path::new("t.csv"), &text);
        }

        #[test]
        fn parser_never_panics_on_mangled_rows(row in "[0-9.,eNa-]{0,120}") {
            let text = format!("{}\n{row}\n", CONTRACT_COLUMNS.join(","));
            let _ = parse_trajectory(Path::new("t.csv"), &text);
        }

        #[test]
        fn a_field_is_trimmed_as_str_trim_trims_it(
            field in "[ \t\u{a0}\u{2003}\u{85}]{0,2}[0-9.e \u{a0}-]{0,8}[ \t\r\u{a0}\u{3000}]{0,2}"
        ) {
            prop_assert_eq!(trimmed(&field), field.trim());
        }
    }
}
