//! Words of a C3D file in the three processor formats.
//!
//! | processor | byte 4 of the parameter section | integers       | floats                 |
//! |-----------|---------------------------------|----------------|------------------------|
//! | Intel     | 84                              | little-endian  | IEEE 754, little-endian |
//! | DEC       | 85                              | little-endian  | VAX F_floating         |
//! | MIPS/SGI  | 86                              | big-endian     | IEEE 754, big-endian   |
//!
//! VAX F_floating (DEC) stores two 16-bit little-endian words, the high word first:
//! sign (1 bit), exponent e (8 bits, bias 128) and fraction f (23 bits) of
//! `(-1)^s · 0.1f₂ · 2^(e-128)` = `(-1)^s · (0.5 + f/2²⁴) · 2^(e-128)`; `e = 0` is zero.
//! Source: the C3D User Guide (c3d.org, 2008), chapter "The C3D file format", and
//! DEC's VAX Architecture Reference Manual, §1.3.

use super::C3dError;

/// The processor (byte order and float format) a C3D file was written for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Processor {
    /// Intel x86: little-endian integers, IEEE floats.
    Intel,
    /// DEC VAX / PDP-11: little-endian integers, VAX F_floating floats.
    Dec,
    /// MIPS / SGI: big-endian integers and IEEE floats.
    Mips,
}

impl Processor {
    /// The processor named by byte 4 of the parameter section (`83 + type`).
    pub(crate) fn from_code(code: u8) -> Result<Self, C3dError> {
        match code {
            84 => Ok(Self::Intel),
            85 => Ok(Self::Dec),
            86 => Ok(Self::Mips),
            found => Err(C3dError::BadProcessor { found }),
        }
    }

    /// Byte 4 of the parameter section for this processor.
    pub(crate) fn code(self) -> u8 {
        match self {
            Self::Intel => 84,
            Self::Dec => 85,
            Self::Mips => 86,
        }
    }

    /// A 16-bit unsigned integer from two bytes.
    pub(crate) fn u16(self, b: [u8; 2]) -> u16 {
        match self {
            Self::Intel | Self::Dec => u16::from_le_bytes(b),
            Self::Mips => u16::from_be_bytes(b),
        }
    }

    /// A 16-bit signed integer from two bytes.
    pub(crate) fn i16(self, b: [u8; 2]) -> i16 {
        match self {
            Self::Intel | Self::Dec => i16::from_le_bytes(b),
            Self::Mips => i16::from_be_bytes(b),
        }
    }

    /// A 32-bit float from four bytes.
    pub(crate) fn f32(self, b: [u8; 4]) -> f32 {
        match self {
            Self::Intel => f32::from_le_bytes(b),
            Self::Mips => f32::from_be_bytes(b),
            Self::Dec => vax_f_to_f32(b),
        }
    }
}

/// A VAX F_floating value (as the bytes lie in the file) as an IEEE float.
fn vax_f_to_f32(b: [u8; 4]) -> f32 {
    let bits =
        u32::from(b[1]) << 24 | u32::from(b[0]) << 16 | u32::from(b[3]) << 8 | u32::from(b[2]);
    let exponent = (bits >> 23) & 0xff;
    if exponent == 0 {
        // Zero, or a "reserved operand" when the sign is set: neither is a number here.
        return if bits >> 31 == 0 { 0.0 } else { f32::NAN };
    }
    let fraction = f64::from(bits & 0x007f_ffff);
    let magnitude = (0.5 + fraction / f64::from(1u32 << 24)) * 2f64.powi(exponent as i32 - 128);
    let value = if bits >> 31 == 1 {
        -magnitude
    } else {
        magnitude
    };
    // |value| < 2^127 fits f32; the fraction has 24 significant bits, so the cast is exact.
    value as f32
}

/// A cursor over a byte slice that reads words in a processor's format and turns running off
/// the end into [`C3dError::Truncated`] naming what was being read.
#[derive(Debug, Clone)]
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    pub(crate) pos: usize,
    processor: Processor,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8], pos: usize, processor: Processor) -> Self {
        Self {
            bytes,
            pos,
            processor,
        }
    }

    /// The next `n` bytes.
    pub(crate) fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], C3dError> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&end| end <= self.bytes.len());
        let Some(end) = end else {
            return Err(C3dError::Truncated {
                what,
                offset: self.pos,
                needed: n,
                len: self.bytes.len(),
            });
        };
        let out = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(out)
    }

    pub(crate) fn u8(&mut self, what: &'static str) -> Result<u8, C3dError> {
        Ok(self.take(1, what)?[0])
    }

    pub(crate) fn i8(&mut self, what: &'static str) -> Result<i8, C3dError> {
        Ok(i8::from_ne_bytes([self.u8(what)?]))
    }

    pub(crate) fn u16(&mut self, what: &'static str) -> Result<u16, C3dError> {
        let b = self.take(2, what)?;
        Ok(self.processor.u16([b[0], b[1]]))
    }

    pub(crate) fn i16(&mut self, what: &'static str) -> Result<i16, C3dError> {
        let b = self.take(2, what)?;
        Ok(self.processor.i16([b[0], b[1]]))
    }

    pub(crate) fn f32(&mut self, what: &'static str) -> Result<f32, C3dError> {
        let b = self.take(4, what)?;
        Ok(self.processor.f32([b[0], b[1], b[2], b[3]]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// VAX F encodings from the VAX Architecture Reference Manual's examples: 1.0 is
    /// `0x4080_0000` as a longword (bytes `80 40 00 00`), 0.5 is `0x4000_0000`, -2.5 is `0xC120_0000`.
    #[test]
    fn vax_f_known_values() {
        assert_eq!(vax_f_to_f32([0x80, 0x40, 0x00, 0x00]), 1.0);
        assert_eq!(vax_f_to_f32([0x00, 0x40, 0x00, 0x00]), 0.5);
        assert_eq!(vax_f_to_f32([0x20, 0xc1, 0x00, 0x00]), -2.5);
        assert_eq!(vax_f_to_f32([0x00, 0x00, 0x00, 0x00]), 0.0);
        assert!(vax_f_to_f32([0x00, 0x80, 0x00, 0x00]).is_nan());
    }

    #[test]
    fn mips_is_big_endian() {
        assert_eq!(Processor::Mips.i16([0xff, 0xfe]), -2);
        assert_eq!(Processor::Mips.f32(1.5f32.to_be_bytes()), 1.5);
        assert_eq!(Processor::Dec.i16([0xfe, 0xff]), -2);
    }
}
