//! The parameter section: groups and typed parameters.
//!
//! Layout (C3D User Guide, "The parameter section"), after a 4-byte section header
//! `[_, _, blocks, 83 + processor]`, a sequence of records:
//! ```text
//! i8  name length (negative: locked; 0: end of section)
//! i8  id (negative: a group with that number; positive: a parameter of group `id`)
//! ..  name (ASCII)
//! i16 offset from this word to the next record (0: last record)
//! group:      u8 description length, description
//! parameter:  i8 type (-1 char, 1 byte, 2 int16, 4 float), u8 dimension count,
//!             u8 dimensions, data (column-major, first dimension fastest),
//!             u8 description length, description
//! ```

use super::C3dError;
use super::bytes::{Processor, Reader};

/// The values of one parameter, in the type the file stores.
#[derive(Debug, Clone, PartialEq)]
pub enum ParameterData {
    /// Characters; the first dimension is the string length.
    Char(Vec<u8>),
    /// Signed bytes.
    Byte(Vec<i8>),
    /// 16-bit integers (signed in the file; some writers mean them unsigned).
    Int(Vec<i16>),
    /// 32-bit floats.
    Float(Vec<f32>),
}

/// One parameter of a group.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// Name, upper case as stored.
    pub name: String,
    /// Free text.
    pub description: String,
    /// Dimensions, first fastest; empty for a scalar.
    pub dimensions: Vec<usize>,
    /// The values.
    pub data: ParameterData,
}

impl Parameter {
    /// The values as floats (integers and bytes widened), or `None` for characters.
    pub fn numbers(&self) -> Option<Vec<f64>> {
        match &self.data {
            ParameterData::Char(_) => None,
            ParameterData::Byte(v) => Some(v.iter().map(|&x| f64::from(x)).collect()),
            ParameterData::Int(v) => Some(v.iter().map(|&x| f64::from(x)).collect()),
            ParameterData::Float(v) => Some(v.iter().map(|&x| f64::from(x)).collect()),
        }
    }

    /// The first value as a float, or `None` when there is none or it is text.
    pub fn first_number(&self) -> Option<f64> {
        self.numbers().and_then(|v| v.first().copied())
    }

    /// The first value as an unsigned 16-bit count: C3D writers store counts above 32767 in
    /// a signed `int16` word, so a negative value is read back as `value + 65536`.
    pub fn first_count(&self) -> Option<usize> {
        match &self.data {
            ParameterData::Int(v) => v.first().map(|&x| usize::from(x as u16)),
            ParameterData::Byte(v) => v.first().map(|&x| usize::from(x as u8)),
            ParameterData::Float(v) => v
                .first()
                .filter(|x| x.is_finite() && **x >= 0.0)
                .map(|&x| x.round() as usize),
            ParameterData::Char(_) => None,
        }
    }

    /// The values as strings, one per column of a character array, trailing blanks and NULs
    /// trimmed; `None` when the parameter is not text.
    pub fn strings(&self) -> Option<Vec<String>> {
        let ParameterData::Char(bytes) = &self.data else {
            return None;
        };
        let trim = |s: &[u8]| {
            String::from_utf8_lossy(s)
                .trim_end_matches([' ', '\0'])
                .to_string()
        };
        match self.dimensions.first() {
            None => Some(vec![trim(bytes)]),
            Some(0) => Some(Vec::new()),
            Some(&len) => Some(bytes.chunks(len).map(trim).collect()),
        }
    }
}

/// A named group of parameters (`POINT`, `ANALOG`, `TRIAL`, ...).
#[derive(Debug, Clone, PartialEq)]
pub struct Group {
    /// The group number (positive) that its parameters refer to.
    pub id: u8,
    /// Name, upper case as stored.
    pub name: String,
    /// Free text.
    pub description: String,
    /// Parameters in file order.
    pub parameters: Vec<Parameter>,
}

/// All groups of a file, in file order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Parameters {
    /// The groups.
    pub groups: Vec<Group>,
}

impl Parameters {
    /// The parameter `group:name` (names compared case-insensitively).
    pub fn get(&self, group: &str, name: &str) -> Option<&Parameter> {
        self.groups
            .iter()
            .find(|g| g.name.eq_ignore_ascii_case(group))?
            .parameters
            .iter()
            .find(|p| p.name.eq_ignore_ascii_case(name))
    }
}

/// Parse the records of a parameter section starting `4` bytes after `start` and ending at
/// `end` (exclusive, clamped by the caller to the file).
pub(crate) fn parse(
    bytes: &[u8],
    start: usize,
    end: usize,
    processor: Processor,
) -> Result<Parameters, C3dError> {
    let section = &bytes[..end];
    let mut groups: Vec<Group> = Vec::new();
    // Parameters may precede their group's record; keep them until the end.
    let mut orphans: Vec<(u8, Parameter)> = Vec::new();
    let mut pos = start + 4;
    loop {
        let mut r = Reader::new(section, pos, processor);
        let record = r.pos;
        let name_len = r.i8("parameter name length")?;
        if name_len == 0 {
            break;
        }
        let id = r.i8("parameter group id")?;
        let name_bytes = r.take(usize::from(name_len.unsigned_abs()), "parameter name")?;
        let name = String::from_utf8_lossy(name_bytes).trim().to_string();
        let offset_at = r.pos;
        let next = r.i16("parameter offset")?;
        let record_name = name.clone();
        let bad = move |reason: String| C3dError::BadParameter {
            offset: record,
            name: record_name.clone(),
            reason,
        };
        if id == 0 {
            return Err(bad("group id is 0".into()));
        }
        if id < 0 {
            let description = read_description(&mut r)?;
            let id = id.unsigned_abs();
            if groups.iter().any(|g| g.id == id) {
                return Err(bad(format!("group number {id} appears twice")));
            }
            groups.push(Group {
                id,
                name,
                description,
                parameters: Vec::new(),
            });
        } else {
            let kind = r.i8("parameter type")?;
            let width = match kind {
                -1 | 1 => 1,
                2 => 2,
                4 => 4,
                other => return Err(bad(format!("unknown type {other} (not -1, 1, 2 or 4)"))),
            };
            let ndims = r.u8("parameter dimension count")?;
            let dims = r.take(usize::from(ndims), "parameter dimensions")?;
            let dimensions: Vec<usize> = dims.iter().map(|&d| usize::from(d)).collect();
            // At most 255^7 values are declared; the bytes must be in the section before any
            // allocation, so a corrupted dimension cannot ask for more memory than the file has.
            let count = dimensions
                .iter()
                .try_fold(1usize, |acc, &d| acc.checked_mul(d))
                .ok_or_else(|| bad("dimensions overflow".into()))?;
            let raw = r.take(count.saturating_mul(width), "parameter data")?;
            let data = match kind {
                -1 => ParameterData::Char(raw.to_vec()),
                1 => ParameterData::Byte(raw.iter().map(|&b| i8::from_ne_bytes([b])).collect()),
                2 => ParameterData::Int(
                    raw.chunks_exact(2)
                        .map(|c| processor.i16([c[0], c[1]]))
                        .collect(),
                ),
                _ => ParameterData::Float(
                    raw.chunks_exact(4)
                        .map(|c| processor.f32([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
            };
            let description = read_description(&mut r)?;
            orphans.push((
                id.unsigned_abs(),
                Parameter {
                    name,
                    description,
                    dimensions,
                    data,
                },
            ));
        }
        if next == 0 {
            break;
        }
        // The offset counts from its own word; some writers leave it short or long by a few
        // bytes, but it must move forward and stay in the section.
        let target = offset_at as i64 + i64::from(next);
        if target <= record as i64 {
            return Err(bad(format!(
                "offset {next} to the next record points backwards"
            )));
        }
        if target as usize >= section.len() {
            // An offset past the section ends the list, as in other C3D readers.
            break;
        }
        pos = target as usize;
    }
    for (id, parameter) in orphans {
        let Some(group) = groups.iter_mut().find(|g| g.id == id) else {
            return Err(C3dError::BadParameter {
                offset: start,
                name: parameter.name,
                reason: format!("belongs to group {id}, which does not exist"),
            });
        };
        group.parameters.push(parameter);
    }
    Ok(Parameters { groups })
}

fn read_description(r: &mut Reader<'_>) -> Result<String, C3dError> {
    // A record may end exactly at the section's end without its description byte.
    let Ok(len) = r.u8("description length") else {
        return Ok(String::new());
    };
    let bytes = r.take(usize::from(len), "parameter description")?;
    Ok(String::from_utf8_lossy(bytes).trim_end().to_string())
}
