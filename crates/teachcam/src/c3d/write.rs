//! Writing marker trajectories as a C3D file: Intel processor, float storage, no analog data.
//!
//! ```text
//! block 1       header (word 150 = 12345: the label/range section is absent but the 4-character
//!               event labels are declared, as Vicon and ezc3d write it)
//! block 2..     parameters: POINT (USED, SCALE, RATE, DATA_START, FRAMES, LABELS[2..],
//!               DESCRIPTIONS, UNITS), ANALOG (USED = 0, RATE, GEN_SCALE, SCALE, OFFSET, LABELS,
//!               UNITS), TRIAL (ACTUAL_START_FIELD, ACTUAL_END_FIELD as two 16-bit words)
//! block d..     per frame, per marker: x, y, z, residual word as 32-bit floats; a gap is
//!               (0, 0, 0, -1); the file is padded to whole blocks
//! ```
//! `|POINT:SCALE|` is the residual step: the residual is stored as a byte in those units.

use std::path::Path;

use super::{BLOCK_BYTES, C3dError, KEY, PointData};

/// Largest marker count a C3D header word holds.
const MAX_MARKERS: usize = 65535;

/// Labels per `POINT:LABELS*` parameter: a dimension is one byte.
const LABELS_PER_PARAMETER: usize = 255;

/// The C3D bytes of `points`; `residual_step` (file units, > 0) is the resolution of the stored
/// residuals (`|POINT:SCALE|`); residuals above `255 * residual_step` are stored as 255 steps.
///
/// # Errors
/// [`C3dError::Unwritable`] for more than 65535 markers, a label longer than 255 bytes, a
/// non-positive rate or residual step.
pub fn to_bytes(points: &PointData, residual_step: f64) -> Result<Vec<u8>, C3dError> {
    let unwritable = |reason: String| C3dError::Unwritable { reason };
    let markers = points.marker_count();
    if markers > MAX_MARKERS {
        return Err(unwritable(format!("{markers} markers, at most 65535")));
    }
    if !(points.rate_hz.is_finite() && points.rate_hz > 0.0) {
        return Err(unwritable(format!("frame rate {} Hz", points.rate_hz)));
    }
    if !(residual_step.is_finite() && residual_step > 0.0) {
        return Err(unwritable(format!("residual step {residual_step}")));
    }
    if points.units.len() > 255 {
        return Err(unwritable("units longer than 255 bytes".into()));
    }
    if let Some(long) = points.labels.iter().find(|l| l.len() > 255) {
        return Err(unwritable(format!(
            "label {long:?} is longer than 255 bytes"
        )));
    }
    let frames = points.frame_count();
    let scale = -(residual_step as f32);
    let rate = points.rate_hz as f32;
    let header_last = u16::try_from(frames).unwrap_or(u16::MAX);
    let frames_word = header_last as i16;

    // The parameter section needs the data start block, which depends on its own length:
    // build it once with a placeholder, then again with the block it fits in.
    let mut data_start_block = 3;
    let section = loop {
        let section = parameter_section(points, scale, rate, frames, frames_word, data_start_block);
        let blocks = section.len().div_ceil(BLOCK_BYTES);
        if 2 + blocks == data_start_block {
            break section;
        }
        data_start_block = 2 + blocks;
    };

    let mut out = vec![0u8; BLOCK_BYTES];
    out[0] = 2;
    out[1] = KEY;
    let mut put16 = |at: usize, v: u16| out[at..at + 2].copy_from_slice(&v.to_le_bytes());
    put16(2, markers as u16);
    put16(4, 0);
    put16(6, 1);
    put16(8, header_last);
    put16(10, 0);
    put16(16, data_start_block as u16);
    // One analog sample per frame at ANALOG:RATE = POINT:RATE, of zero channels: readers that
    // check header word 10 against ANALOG:RATE / POINT:RATE (py-c3d) accept the file.
    put16(18, 1);
    put16(298, 12345);
    out[12..16].copy_from_slice(&scale.to_le_bytes());
    out[20..24].copy_from_slice(&rate.to_le_bytes());
    out.extend_from_slice(&section);
    out.resize((data_start_block - 1) * BLOCK_BYTES, 0);

    out.reserve(frames * markers * 16 + BLOCK_BYTES);
    let step = f64::from(scale.abs());
    for frame in 0..frames {
        for marker in 0..markers {
            let sample = points.sample(crate::geometry::FrameIndex(frame), marker);
            let words: [f32; 4] = match sample {
                Some(s) => {
                    let residual = (s.residual / step).round().clamp(0.0, 255.0) as u16;
                    let word = u16::from(s.camera_mask & 0x7f) << 8 | residual;
                    [
                        s.position.x as f32,
                        s.position.y as f32,
                        s.position.z as f32,
                        f32::from(word),
                    ]
                }
                None => [0.0, 0.0, 0.0, -1.0],
            };
            for w in words {
                out.extend_from_slice(&w.to_le_bytes());
            }
        }
    }
    out.resize(out.len().div_ceil(BLOCK_BYTES) * BLOCK_BYTES, 0);
    Ok(out)
}

/// Write `points` to `path` whole or not at all ([`crate::io::write_atomically`]); see
/// [`to_bytes`].
///
/// # Errors
/// The errors of [`to_bytes`], and [`C3dError::Write`] when the file cannot be written.
pub fn write_file(path: &Path, points: &PointData, residual_step: f64) -> Result<(), C3dError> {
    let bytes = to_bytes(points, residual_step)?;
    crate::io::write_atomically(path, &bytes).map_err(C3dError::Write)
}

/// A parameter value to encode.
enum Value<'a> {
    Int(&'a [i16]),
    Float(&'a [f32]),
    /// Strings padded to the longest (at least 1), dimensions `[len, count]`.
    Strings(&'a [String]),
    /// One string, dimension `[len]`.
    Text(&'a str),
}

fn parameter_section(
    points: &PointData,
    scale: f32,
    rate: f32,
    frames: usize,
    frames_word: i16,
    data_start_block: usize,
) -> Vec<u8> {
    let mut s = vec![0x01, KEY, 0, super::Processor::Intel.code()];
    let mut records: Vec<Vec<u8>> = Vec::new();
    let mut group = |id: i8, name: &str, description: &str| {
        let mut r = vec![name.len() as u8, (-id) as u8];
        r.extend_from_slice(name.as_bytes());
        r.extend_from_slice(&[0, 0]);
        r.push(description.len() as u8);
        r.extend_from_slice(description.as_bytes());
        records.push(r);
    };
    group(1, "POINT", "3-D point parameters");
    group(2, "ANALOG", "Analog data parameters");
    group(3, "TRIAL", "Trial parameters");

    let markers = points.marker_count();
    let used = [markers as u16 as i16];
    let data_start = [data_start_block as i16];
    let frames_value = [frames_word];
    let start_field = [1i16, 0];
    let end_field = [
        (frames & 0xffff) as u16 as i16,
        ((frames >> 16) & 0xffff) as u16 as i16,
    ];
    let descriptions: Vec<String> = vec![String::new(); markers];
    let mut params: Vec<(i8, String, Value<'_>)> = vec![
        (1, "USED".into(), Value::Int(&used)),
        (
            1,
            "SCALE".into(),
            Value::Float(std::slice::from_ref(&scale)),
        ),
        (1, "RATE".into(), Value::Float(std::slice::from_ref(&rate))),
        (1, "DATA_START".into(), Value::Int(&data_start)),
        (1, "FRAMES".into(), Value::Int(&frames_value)),
    ];
    let chunks: Vec<&[String]> = if markers == 0 {
        vec![&[]]
    } else {
        points.labels.chunks(LABELS_PER_PARAMETER).collect()
    };
    for (i, chunk) in chunks.iter().enumerate() {
        let name = if i == 0 {
            "LABELS".to_string()
        } else {
            format!("LABELS{}", i + 1)
        };
        params.push((1, name, Value::Strings(chunk)));
    }
    let description_chunks: Vec<&[String]> = if markers == 0 {
        vec![&[]]
    } else {
        descriptions.chunks(LABELS_PER_PARAMETER).collect()
    };
    for (i, chunk) in description_chunks.iter().enumerate() {
        let name = if i == 0 {
            "DESCRIPTIONS".to_string()
        } else {
            format!("DESCRIPTIONS{}", i + 1)
        };
        params.push((1, name, Value::Strings(chunk)));
    }
    params.extend([
        (1, "UNITS".into(), Value::Text(&points.units)),
        (2, "USED".into(), Value::Int(&[0])),
        (2, "RATE".into(), Value::Float(std::slice::from_ref(&rate))),
        (2, "GEN_SCALE".into(), Value::Float(&[1.0])),
        (2, "SCALE".into(), Value::Float(&[])),
        (2, "OFFSET".into(), Value::Int(&[])),
        (2, "LABELS".into(), Value::Strings(&[])),
        (2, "UNITS".into(), Value::Strings(&[])),
        (3, "ACTUAL_START_FIELD".into(), Value::Int(&start_field)),
        (3, "ACTUAL_END_FIELD".into(), Value::Int(&end_field)),
    ]);
    for (id, name, value) in &params {
        records.push(parameter_record(*id, name, value));
    }

    let last = records.len() - 1;
    for (i, mut r) in records.into_iter().enumerate() {
        let name_len = usize::from(r[0]);
        // The offset counts from its own word to the next record; the last one is 0.
        let offset = if i == last {
            0
        } else {
            (r.len() - 2 - name_len) as i16
        };
        r[2 + name_len..4 + name_len].copy_from_slice(&offset.to_le_bytes());
        s.extend_from_slice(&r);
    }
    // A zero name length after the last record ends the section for readers that look for it.
    s.extend_from_slice(&[0, 0]);
    let blocks = s.len().div_ceil(BLOCK_BYTES);
    s[2] = blocks as u8;
    s.resize(blocks * BLOCK_BYTES, 0);
    s
}

fn parameter_record(id: i8, name: &str, value: &Value<'_>) -> Vec<u8> {
    let mut r = vec![name.len() as u8, id as u8];
    r.extend_from_slice(name.as_bytes());
    r.extend_from_slice(&[0, 0]);
    match value {
        Value::Int(v) => {
            if v.len() == 1 {
                r.extend_from_slice(&[2, 0]);
            } else {
                r.extend_from_slice(&[2, 1, v.len() as u8]);
            }
            v.iter().for_each(|x| r.extend_from_slice(&x.to_le_bytes()));
        }
        Value::Float(v) => {
            if v.len() == 1 {
                r.extend_from_slice(&[4, 0]);
            } else {
                r.extend_from_slice(&[4, 1, v.len() as u8]);
            }
            v.iter().for_each(|x| r.extend_from_slice(&x.to_le_bytes()));
        }
        Value::Strings(v) => {
            let len = v.iter().map(String::len).max().unwrap_or(0).max(1);
            r.extend_from_slice(&[0xff, 2, len as u8, v.len() as u8]);
            for label in *v {
                r.extend_from_slice(label.as_bytes());
                r.resize(r.len() + len - label.len(), b' ');
            }
        }
        Value::Text(t) => {
            r.extend_from_slice(&[0xff, 1, t.len() as u8]);
            r.extend_from_slice(t.as_bytes());
        }
    }
    r.push(0);
    r
}
