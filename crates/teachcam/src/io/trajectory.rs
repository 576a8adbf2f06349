//! Trajectory CSV (CONTRACT.md, "Trajectory"), written by `track`, `smooth` and `simulate`
//! (`truth.csv`), read by `smooth`, `export` and `check`.
//!
//! ```text
//! frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,tip_x_mm,tip_y_mm,tip_z_mm,markers,rms_mm,filled,tip_std_mm,status
//! ```
//! The first fourteen columns are the contract's, in order; `filled` (1 where the smoother
//! filled a gap), `tip_std_mm` and `status` (`ok`, `degraded`, `outlier`, `lost`:
//! [`Status`]) follow; other columns are allowed and ignored. A frame without a pose keeps its
//! row with every pose field empty and status `lost`. Files written before `status` existed
//! still read: their status is `ok` where a pose is and `lost` where none is. Nothing that is
//! not finite is ever written.

use std::fmt::Write as _;
use std::path::Path;

use super::{FileError, read_text, write_atomically};
use crate::geometry::{FrameIndex, Point3, Quat, pose_from_parts};
use crate::trajectory::{PoseSource, Sample, Status, ToolPose, Trajectory};

/// The contract's columns, in order.
pub const CONTRACT_COLUMNS: [&str; 14] = [
    "frame", "time_s", "x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz", "tip_x_mm", "tip_y_mm",
    "tip_z_mm", "markers", "rms_mm",
];

/// Columns this writer adds after the contract's.
pub const EXTRA_COLUMNS: [&str; 3] = ["filled", "tip_std_mm", "status"];

/// Tolerance on `|q| - 1` for quaternions read from CSV: written numbers are rounded, and other
/// tools print six decimals.
const CSV_QUATERNION_TOLERANCE: f64 = 1e-5;

/// Writes a trajectory CSV whole, after checking that every number in it is finite.
///
/// # Errors
/// [`FileError::Invalid`] naming the first frame and field that is not finite (nothing is
/// written then); [`FileError::Write`].
pub fn write_trajectory(path: &Path, trajectory: &Trajectory) -> Result<(), FileError> {
    write_atomically(path, trajectory_text(path, trajectory)?.as_bytes())
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
    for s in &trajectory.samples {
        let mut fields = vec![("time_s", s.time_s)];
        if let Some(p) = &s.pose {
            let t = p.world_from_tool.translation.vector;
            let q = p.world_from_tool.rotation.quaternion();
            fields.extend([
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
            ]);
        }
        fields.extend(s.tip_std_mm.map(|v| ("tip_std_mm", v)));
        if let Some((name, value)) = fields.iter().find(|(_, v)| !v.is_finite()) {
            return Err(format!(
                "frame {}: {name} is {value}, not a finite number; nothing written",
                s.frame.0
            ));
        }
    }
    Ok(())
}

/// The CSV text of a trajectory.
#[must_use]
pub fn trajectory_csv(trajectory: &Trajectory) -> String {
    let mut out = String::with_capacity(160 * (trajectory.len() + 1));
    out.push_str(&CONTRACT_COLUMNS.join(","));
    for c in EXTRA_COLUMNS {
        out.push(',');
        out.push_str(c);
    }
    out.push('\n');
    let quaternions = trajectory.continuous_quaternions();
    for (sample, q) in trajectory.samples.iter().zip(quaternions) {
        // Nanoseconds: distinct and uniform up to `trajectory::MAX_SAMPLE_RATE_HZ`.
        let _ = write!(out, "{},{:.9}", sample.frame.0, sample.time_s);
        match (&sample.pose, q) {
            (Some(p), Some(q)) => {
                let t = p.world_from_tool.translation.vector;
                let _ = write!(
                    out,
                    ",{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.9},{:.6},{:.6},{:.6},{},{:.6}",
                    t.x,
                    t.y,
                    t.z,
                    q.w,
                    q.x,
                    q.y,
                    q.z,
                    p.tip_in_world.x,
                    p.tip_in_world.y,
                    p.tip_in_world.z,
                    p.markers,
                    p.rms_mm
                );
            }
            _ => out.push_str(",,,,,,,,,,,,"),
        }
        let filled = u8::from(sample.source == PoseSource::Filled);
        let _ = write!(out, ",{filled},");
        if let Some(std) = sample.tip_std_mm {
            let _ = write!(out, "{std:.6}");
        }
        let status = match sample.pose {
            Some(_) if sample.status == Status::Lost => Status::Degraded,
            Some(_) => sample.status,
            None => Status::Lost,
        };
        let _ = writeln!(out, ",{status}");
    }
    out
}

/// Reads and checks a trajectory CSV: the contract's header, frames strictly increasing,
/// times finite and strictly increasing, pose fields all present or all empty, unit quaternions.
///
/// # Errors
/// [`FileError::InvalidLine`] naming the line and the column.
pub fn read_trajectory(path: &Path) -> Result<Trajectory, FileError> {
    let text = read_text(path)?;
    parse_trajectory(path, &text)
}

/// Parses trajectory CSV text; `path` only names the source in errors.
///
/// # Errors
/// As [`read_trajectory`].
pub fn parse_trajectory(path: &Path, text: &str) -> Result<Trajectory, FileError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')));
    let (_, header) = lines
        .next()
        .ok_or_else(|| FileError::invalid(path, "empty file: no header"))?;
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    if columns.len() < CONTRACT_COLUMNS.len()
        || columns[..CONTRACT_COLUMNS.len()] != CONTRACT_COLUMNS
    {
        return Err(FileError::invalid_line(
            path,
            1,
            format!("header must start with {}", CONTRACT_COLUMNS.join(",")),
        ));
    }
    let filled_column = columns.iter().position(|c| *c == "filled");
    let std_column = columns.iter().position(|c| *c == "tip_std_mm");
    let status_column = columns.iter().position(|c| *c == "status");
    let mut samples: Vec<Sample> = Vec::new();
    for (line, row) in lines {
        if row.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != columns.len() {
            return Err(FileError::invalid_line(
                path,
                line,
                format!("{} fields, header has {}", fields.len(), columns.len()),
            ));
        }
        let sample = parse_row(&fields, filled_column, std_column, status_column)
            .map_err(|m| FileError::invalid_line(path, line, m))?;
        if let Some(previous) = samples.last() {
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
        samples.push(sample);
    }
    Ok(Trajectory { samples })
}

fn number(fields: &[&str], column: usize) -> Result<f64, String> {
    let name = CONTRACT_COLUMNS.get(column).copied().unwrap_or("column");
    let value: f64 = fields[column]
        .parse()
        .map_err(|_| format!("{name}: '{}' is not a number", fields[column]))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(format!("{name}: {value} is not finite"))
    }
}

fn parse_row(
    fields: &[&str],
    filled_column: Option<usize>,
    std_column: Option<usize>,
    status_column: Option<usize>,
) -> Result<Sample, String> {
    let frame: usize = fields[0]
        .parse()
        .map_err(|_| format!("frame: '{}' is not a frame number", fields[0]))?;
    let time_s = number(fields, 1)?;
    let pose_fields = &fields[2..14];
    let empty = pose_fields.iter().filter(|f| f.is_empty()).count();
    let pose = match empty {
        12 => None,
        0 => {
            let v: Vec<f64> = (2..14)
                .map(|c| number(fields, c))
                .collect::<Result<_, _>>()?;
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
            text.parse::<f64>()
                .ok()
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
    Ok(Sample {
        frame: FrameIndex(frame),
        time_s,
        pose,
        source,
        tip_std_mm,
        status,
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
    }
}
