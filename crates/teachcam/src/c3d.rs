//! C3D motion-capture files: read the marker trajectories other trackers record (Vicon,
//! Qualisys, OptiTrack, NDI Optotrak) and write ours so their tools can read them.
//!
//! The format (C3D User Guide, c3d.org, 2008) is a sequence of 512-byte blocks:
//! ```text
//! block 1          header: word 1 = [parameter block, 0x50], points, analog words per frame,
//!                  first/last frame, max gap, scale (f32), data start block,
//!                  analog samples per frame, frame rate (f32), ...
//! block p..        parameter section: [_, _, block count, 83 + processor], groups, parameters
//! block d..        point data, frame after frame: per point (x, y, z, residual word), then the
//!                  frame's analog samples
//! ```
//! Words are 16-bit integers scaled by `POINT:SCALE` when the scale is positive, 32-bit floats
//! (already in `POINT:UNITS`) when it is negative. The residual word, read as a 16-bit integer
//! (floats are rounded first), is negative for an invalid sample (occluded, interpolated out);
//! otherwise its low byte is the residual in units of `|scale|` and its high byte the mask of
//! cameras that saw the marker. Byte order and float format depend on the processor
//! ([`Processor`]: Intel, DEC, MIPS).
//!
//! Where the header and the parameters disagree, the parameters win (`POINT:USED`,
//! `POINT:SCALE`, `POINT:RATE`, `POINT:DATA_START`, `POINT:FRAMES`, and `TRIAL:ACTUAL_*_FIELD`
//! for more than 65535 frames): real files leave stale values in the header (NDI's
//! Optotrak export declares 1149 frames in its header and `POINT:FRAMES` and holds 29). The
//! frame count is then checked against the bytes the file holds: a file that holds fewer
//! *whole* frames than declared is read as far as it goes ([`C3d::declared_frames`] keeps the
//! claim), as ezc3d does; one that ends inside a frame is refused as truncated.
//!
//! Coordinates stay in the file's units here; [`PointData::millimetres_per_unit`] converts at
//! the edge.

mod bytes;
mod parameters;
mod rigid;
mod write;

use std::path::{Path, PathBuf};

pub use bytes::Processor;
pub use parameters::{Group, Parameter, ParameterData, Parameters};
pub use rigid::{
    MarkerSelection, ToolFromData, ToolFromDataConfig, TrackMarkersConfig, points_from_tracks,
    points_from_trajectory, points_from_trajectory_and_measured, tool_from_data, track_markers,
};
pub use write::{to_bytes, write_file};

use crate::geometry::{FrameIndex, Point3};
use bytes::Reader;

/// Size of a C3D block, bytes.
pub const BLOCK_BYTES: usize = 512;

/// Second byte of every C3D file.
const KEY: u8 = 0x50;

/// Error reading or writing a C3D file.
#[derive(Debug, thiserror::Error)]
pub enum C3dError {
    /// The file could not be read.
    #[error("cannot read {}: {cause}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        cause: std::io::Error,
    },
    /// The output file could not be written.
    #[error(transparent)]
    Write(crate::io::FileError),
    /// An error inside a named file.
    #[error("{}: {cause}", path.display())]
    InFile {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        cause: Box<C3dError>,
    },
    /// The second byte is not the C3D key 0x50.
    #[error("not a C3D file: byte 2 is {found:#04x}, not 0x50")]
    NotC3d {
        /// The byte found.
        found: u8,
    },
    /// The file ends before something it declares.
    #[error("file is truncated: {what} needs {needed} bytes at byte {offset}, the file has {len}")]
    Truncated {
        /// What was being read.
        what: &'static str,
        /// Where it starts, bytes from the start of the file.
        offset: usize,
        /// How many bytes it needs.
        needed: usize,
        /// The file's length.
        len: usize,
    },
    /// The processor byte of the parameter section is not 84, 85 or 86.
    #[error("parameter section: processor byte is {found}, not 84 (Intel), 85 (DEC) or 86 (MIPS)")]
    BadProcessor {
        /// The byte found.
        found: u8,
    },
    /// A malformed record in the parameter section.
    #[error("parameter section: record {name:?} at byte {offset}: {reason}")]
    BadParameter {
        /// Where the record starts.
        offset: usize,
        /// The record's name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// A header or parameter value that the point data cannot be read with.
    #[error("{field}: {reason}")]
    BadValue {
        /// `GROUP:NAME` or `header word N`.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A marker label asked for is not in the file.
    #[error("no marker labelled {label:?} (the file has {available})")]
    LabelNotFound {
        /// The label asked for.
        label: String,
        /// The labels present, comma-separated.
        available: String,
    },
    /// `POINT:UNITS` is not a length unit we know.
    #[error("POINT:UNITS is {units:?}, not mm, cm, m or in")]
    UnknownUnits {
        /// The unit found.
        units: String,
    },
    /// Data given to the writer that a C3D file cannot hold.
    #[error("cannot write C3D: {reason}")]
    Unwritable {
        /// Why.
        reason: String,
    },
}

impl C3dError {
    fn in_file(self, path: &Path) -> Self {
        Self::InFile {
            path: path.to_path_buf(),
            cause: Box::new(self),
        }
    }
}

/// One marker sample of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointSample {
    /// Position in the file's units and frame (the tracker's lab frame).
    pub position: Point3,
    /// The tracker's reconstruction residual, file units (0 when the tracker writes none).
    pub residual: f64,
    /// Bit `i` set when camera `i + 1` saw the marker (bit 0 when the tracker writes none).
    pub camera_mask: u8,
}

/// Marker trajectories: a sample or a gap for every marker in every frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PointData {
    /// One label per marker, as stored (trailing blanks trimmed).
    pub labels: Vec<String>,
    /// Frames per second.
    pub rate_hz: f64,
    /// `POINT:UNITS` as stored ("mm", "m", ...).
    pub units: String,
    /// Number of the first frame as the file counts (usually 1).
    pub first_frame_number: usize,
    frame_count: usize,
    /// Frame-major: `samples[frame * labels.len() + marker]`.
    samples: Vec<Option<PointSample>>,
}

impl PointData {
    /// Trajectories from one row of samples per frame, each row as long as `labels`.
    ///
    /// # Errors
    /// [`C3dError::Unwritable`] when a row's length differs from the label count.
    pub fn new(
        labels: Vec<String>,
        rate_hz: f64,
        units: String,
        frames: &[Vec<Option<PointSample>>],
    ) -> Result<Self, C3dError> {
        if let Some((frame, row)) = frames
            .iter()
            .enumerate()
            .find(|(_, row)| row.len() != labels.len())
        {
            return Err(C3dError::Unwritable {
                reason: format!(
                    "frame {frame} has {} samples for {} labels",
                    row.len(),
                    labels.len()
                ),
            });
        }
        Ok(Self {
            labels,
            rate_hz,
            units,
            first_frame_number: 1,
            frame_count: frames.len(),
            samples: frames.iter().flatten().copied().collect(),
        })
    }

    /// Number of frames.
    pub fn frame_count(&self) -> usize {
        self.frame_count
    }

    /// Number of markers.
    pub fn marker_count(&self) -> usize {
        self.labels.len()
    }

    /// All markers of one frame (`None` past the end).
    pub fn frame(&self, frame: FrameIndex) -> Option<&[Option<PointSample>]> {
        let n = self.labels.len();
        let start = frame.0.checked_mul(n)?;
        self.samples.get(start..start.checked_add(n)?)
    }

    /// One marker in one frame; `None` for a gap or out of range.
    pub fn sample(&self, frame: FrameIndex, marker: usize) -> Option<&PointSample> {
        if marker >= self.labels.len() {
            return None;
        }
        self.frame(frame)?.get(marker)?.as_ref()
    }

    /// Column indices of the markers with these labels, in the order asked.
    ///
    /// # Errors
    /// [`C3dError::LabelNotFound`] for the first label the file does not have.
    pub fn marker_indices<S: AsRef<str>>(&self, labels: &[S]) -> Result<Vec<usize>, C3dError> {
        labels
            .iter()
            .map(|label| {
                let label = label.as_ref();
                self.labels
                    .iter()
                    .position(|l| l == label)
                    .ok_or_else(|| C3dError::LabelNotFound {
                        label: label.to_string(),
                        available: self.labels.join(", "),
                    })
            })
            .collect()
    }

    /// Millimetres per file unit (`POINT:UNITS`).
    ///
    /// # Errors
    /// [`C3dError::UnknownUnits`] for anything but mm, cm, m and in (any case).
    pub fn millimetres_per_unit(&self) -> Result<f64, C3dError> {
        match self.units.trim().to_ascii_lowercase().as_str() {
            "mm" => Ok(1.0),
            "cm" => Ok(10.0),
            "m" => Ok(1000.0),
            "in" | "inch" | "inches" => Ok(25.4),
            _ => Err(C3dError::UnknownUnits {
                units: self.units.clone(),
            }),
        }
    }
}

/// The header block as stored (values the parameters may override).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Header {
    /// Block number (1-based) where the parameter section starts.
    pub parameter_block: u8,
    /// Number of points (word 2).
    pub points: u16,
    /// Analog measurements per point frame, all channels (word 3).
    pub analog_words_per_frame: u16,
    /// First frame number (word 4).
    pub first_frame: u16,
    /// Last frame number (word 5).
    pub last_frame: u16,
    /// Point scale; negative for float storage (words 7–8).
    pub scale: f32,
    /// Block number (1-based) where the data start (word 9).
    pub data_start_block: u16,
    /// Point frame rate (words 11–12).
    pub rate_hz: f32,
}

/// A C3D file: its processor, header, parameters and marker trajectories.
#[derive(Debug, Clone, PartialEq)]
pub struct C3d {
    /// Byte order and float format of the file.
    pub processor: Processor,
    /// The header as stored.
    pub header: Header,
    /// Every group and parameter.
    pub parameters: Parameters,
    /// The marker trajectories.
    pub points: PointData,
    /// The frame count the header and parameters declare; more than
    /// `points.frame_count()` when the file holds fewer whole frames (see the module docs).
    pub declared_frames: usize,
}

/// Read a C3D file.
///
/// # Errors
/// [`C3dError::Io`] when the file cannot be read, otherwise the errors of [`read`] wrapped
/// with the path.
pub fn read_file(path: &Path) -> Result<C3d, C3dError> {
    let bytes = std::fs::read(path).map_err(|cause| C3dError::Io {
        path: path.to_path_buf(),
        cause,
    })?;
    read(&bytes).map_err(|e| e.in_file(path))
}

/// Read a C3D file held in memory.
///
/// # Errors
/// [`C3dError`] naming the header word, parameter or byte offset that is wrong: not a C3D
/// file, truncated, an unknown processor, a malformed parameter record, or point-data
/// parameters that cannot be used.
pub fn read(bytes: &[u8]) -> Result<C3d, C3dError> {
    if bytes.len() < BLOCK_BYTES {
        return Err(C3dError::Truncated {
            what: "header block",
            offset: 0,
            needed: BLOCK_BYTES,
            len: bytes.len(),
        });
    }
    if bytes[1] != KEY {
        return Err(C3dError::NotC3d { found: bytes[1] });
    }
    let parameter_block = bytes[0];
    if parameter_block == 0 {
        return Err(C3dError::BadValue {
            field: "header word 1",
            reason: "parameter block is 0 (blocks count from 1)".into(),
        });
    }
    let parameter_start = (usize::from(parameter_block) - 1) * BLOCK_BYTES;
    let section_head = Reader::new(bytes, parameter_start, Processor::Intel)
        .take(4, "parameter section header")?
        .to_vec();
    let processor = Processor::from_code(section_head[3])?;
    let header = read_header(bytes, processor)?;
    let declared_blocks = usize::from(section_head[2]).max(1);
    let section_end = (parameter_start + declared_blocks * BLOCK_BYTES).min(bytes.len());
    let parameters = parameters::parse(bytes, parameter_start, section_end, processor)?;
    let (points, declared_frames) =
        read_points(bytes, &header, &parameters, processor, section_end)?;
    Ok(C3d {
        processor,
        header,
        parameters,
        points,
        declared_frames,
    })
}

fn read_header(bytes: &[u8], processor: Processor) -> Result<Header, C3dError> {
    let mut r = Reader::new(bytes, 0, processor);
    let parameter_block = r.u8("header")?;
    r.u8("header")?;
    let points = r.u16("header")?;
    let analog_words_per_frame = r.u16("header")?;
    let first_frame = r.u16("header")?;
    let last_frame = r.u16("header")?;
    r.u16("header")?;
    let scale = r.f32("header")?;
    let data_start_block = r.u16("header")?;
    r.u16("header")?;
    let rate_hz = r.f32("header")?;
    Ok(Header {
        parameter_block,
        points,
        analog_words_per_frame,
        first_frame,
        last_frame,
        scale,
        data_start_block,
        rate_hz,
    })
}

/// A count stored as two 16-bit words, low word first (`TRIAL:ACTUAL_START_FIELD`).
fn two_word_count(parameter: Option<&Parameter>) -> Option<usize> {
    let ParameterData::Int(words) = &parameter?.data else {
        return None;
    };
    match words.as_slice() {
        [low, high, ..] => Some(usize::from(*low as u16) | usize::from(*high as u16) << 16),
        _ => None,
    }
}

/// The frame count and first frame number, parameters first (see the module docs).
fn frame_range(header: &Header, parameters: &Parameters) -> (usize, usize) {
    let header_first = usize::from(header.first_frame);
    let header_count = usize::from(header.last_frame)
        .checked_sub(header_first)
        .map_or(0, |d| d + 1);
    let trial_start = two_word_count(parameters.get("TRIAL", "ACTUAL_START_FIELD"));
    let trial_end = two_word_count(parameters.get("TRIAL", "ACTUAL_END_FIELD"));
    let trial = match (trial_start, trial_end) {
        (Some(start), Some(end)) if end >= start => Some((end - start + 1, start)),
        _ => None,
    };
    let point_frames = parameters
        .get("POINT", "FRAMES")
        .and_then(Parameter::first_count);
    match (point_frames, trial) {
        // POINT:FRAMES is a 16-bit word; the TRIAL fields hold longer trials.
        (Some(n), Some((t, start))) if t > n && n >= 32767 => (t, start),
        (Some(n), _) => (n, header_first),
        (None, Some((t, start))) => (t, start),
        (None, None) => (header_count, header_first),
    }
}

/// The marker trajectories and the frame count the file declares.
///
/// `parameter_end` is the byte where the parameter section ends: point data that would start
/// before it would read parameters (or the header) as coordinates.
fn read_points(
    bytes: &[u8],
    header: &Header,
    parameters: &Parameters,
    processor: Processor,
    parameter_end: usize,
) -> Result<(PointData, usize), C3dError> {
    let marker_count = parameters
        .get("POINT", "USED")
        .and_then(Parameter::first_count)
        .unwrap_or(usize::from(header.points));
    let scale = parameters
        .get("POINT", "SCALE")
        .and_then(Parameter::first_number)
        .unwrap_or(f64::from(header.scale));
    if !scale.is_finite() || scale == 0.0 {
        return Err(C3dError::BadValue {
            field: "POINT:SCALE",
            reason: format!("{scale} is not a usable scale (non-zero, finite)"),
        });
    }
    let rate_hz = parameters
        .get("POINT", "RATE")
        .and_then(Parameter::first_number)
        .unwrap_or(f64::from(header.rate_hz));
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(C3dError::BadValue {
            field: "POINT:RATE",
            reason: format!("{rate_hz} Hz is not a frame rate"),
        });
    }
    let data_start_block = parameters
        .get("POINT", "DATA_START")
        .and_then(Parameter::first_count)
        .filter(|&b| b > 0)
        .unwrap_or(usize::from(header.data_start_block));
    if data_start_block == 0 {
        return Err(C3dError::BadValue {
            field: "header word 9",
            reason: "data start block is 0 (blocks count from 1)".into(),
        });
    }
    if (data_start_block - 1) * BLOCK_BYTES < parameter_end {
        return Err(C3dError::BadValue {
            field: "POINT:DATA_START",
            reason: format!(
                "block {data_start_block} lies inside the header or the parameter section (which ends at block {}); the point data start after it",
                parameter_end.div_ceil(BLOCK_BYTES)
            ),
        });
    }
    let (declared_frames, first_frame_number) = frame_range(header, parameters);
    let is_float = scale < 0.0;
    let word = if is_float { 4 } else { 2 };
    let frame_bytes = (marker_count * 4 + usize::from(header.analog_words_per_frame)) * word;
    let data_start = (data_start_block - 1) * BLOCK_BYTES;
    // Check the whole extent before allocating: a corrupted count must not allocate.
    let needed = frame_bytes.saturating_mul(declared_frames);
    let held = bytes.len().saturating_sub(data_start);
    let frame_count = if needed <= held {
        declared_frames
    } else if frame_bytes > 0 && held % frame_bytes == 0 {
        // Whole frames, fewer than declared: a writer that left a stale count (see the
        // module docs). A file cut short ends inside a frame or a block.
        held / frame_bytes
    } else {
        return Err(C3dError::Truncated {
            what: "point data",
            offset: data_start,
            needed,
            len: bytes.len(),
        });
    };
    let end = data_start + frame_bytes * frame_count;
    // With no whole frame held, the data start may lie past the end of the file.
    let data = bytes.get(data_start..end).unwrap_or_default();
    let labels = labels(parameters, marker_count);
    let units = parameters
        .get("POINT", "UNITS")
        .and_then(Parameter::strings)
        .and_then(|s| s.into_iter().next())
        .unwrap_or_default();
    let mut samples = Vec::with_capacity(marker_count * frame_count);
    let abs_scale = scale.abs();
    if marker_count > 0 {
        for frame in data.chunks_exact(frame_bytes) {
            let points = &frame[..marker_count * 4 * word];
            if is_float {
                samples.extend(points.chunks_exact(16).map(|p| {
                    let w = |i: usize| processor.f32([p[i], p[i + 1], p[i + 2], p[i + 3]]);
                    decode_sample(
                        [f64::from(w(0)), f64::from(w(4)), f64::from(w(8))],
                        f64::from(w(12)).round(),
                        abs_scale,
                    )
                }));
            } else {
                samples.extend(points.chunks_exact(8).map(|p| {
                    let w = |i: usize| f64::from(processor.i16([p[i], p[i + 1]]));
                    decode_sample([w(0) * scale, w(2) * scale, w(4) * scale], w(6), abs_scale)
                }));
            }
        }
    }
    Ok((
        PointData {
            labels,
            rate_hz,
            units,
            first_frame_number,
            frame_count,
            samples,
        },
        declared_frames,
    ))
}

/// A sample from its coordinates and residual word (as an integer value); `None` when the
/// word is negative or a coordinate is not finite.
fn decode_sample(xyz: [f64; 3], residual_word: f64, abs_scale: f64) -> Option<PointSample> {
    if residual_word.is_nan() || residual_word < 0.0 || xyz.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // Only the low 16 bits are the word; a float file may hold a larger integer value.
    let word = (residual_word as i64 & 0xffff) as u16;
    if word & 0x8000 != 0 {
        return None;
    }
    Some(PointSample {
        position: Point3::new(xyz[0], xyz[1], xyz[2]),
        residual: f64::from(word & 0xff) * abs_scale,
        camera_mask: (word >> 8) as u8,
    })
}

/// `POINT:LABELS`, then `LABELS2`, `LABELS3`, ... until there is one per marker; markers
/// beyond the stored labels are called `M001`, `M002`, ... (1-based).
fn labels(parameters: &Parameters, marker_count: usize) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(marker_count);
    let mut n = 1;
    while out.len() < marker_count {
        let name = if n == 1 {
            "LABELS".to_string()
        } else {
            format!("LABELS{n}")
        };
        let Some(more) = parameters.get("POINT", &name).and_then(Parameter::strings) else {
            break;
        };
        out.extend(more);
        n += 1;
    }
    out.truncate(marker_count);
    while out.len() < marker_count {
        out.push(format!("M{:03}", out.len() + 1));
    }
    out
}
