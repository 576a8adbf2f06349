//! The CDR encoding ROS 2 puts on the wire and in bags (OMG CDR, little endian, with the
//! 4-byte encapsulation header `00 01 00 00`): primitives aligned to their size from the end of
//! the header, strings as a `uint32` length counting the closing NUL, then the bytes and the
//! NUL; sequences as a `uint32` count, then the elements; fixed arrays as their elements only.

/// A CDR little-endian message being written.
#[derive(Debug, Clone)]
pub struct CdrWriter {
    bytes: Vec<u8>,
}

/// The encapsulation header of little-endian plain CDR (`CDR_LE`).
const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl CdrWriter {
    /// An empty message (its encapsulation header only).
    #[must_use]
    pub fn new() -> Self {
        Self {
            bytes: CDR_LE.to_vec(),
        }
    }

    /// The encoded message.
    #[must_use]
    pub fn finish(self) -> Vec<u8> {
        self.bytes
    }

    /// Pads with zeros to a multiple of `size` from the end of the encapsulation header.
    fn align(&mut self, size: usize) {
        let offset = self.bytes.len() - CDR_LE.len();
        let padding = (size - offset % size) % size;
        self.bytes.extend(std::iter::repeat_n(0, padding));
    }

    /// A `byte` / `uint8`.
    pub fn u8(&mut self, value: u8) {
        self.bytes.push(value);
    }

    /// An `int32`.
    pub fn i32(&mut self, value: i32) {
        self.align(4);
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// A `uint32`.
    pub fn u32(&mut self, value: u32) {
        self.align(4);
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// A `float32`.
    pub fn f32(&mut self, value: f32) {
        self.align(4);
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// A `bool` (one byte, 0 or 1).
    pub fn bool(&mut self, value: bool) {
        self.u8(u8::from(value));
    }

    /// A `float64`.
    pub fn f64(&mut self, value: f64) {
        self.align(8);
        self.bytes.extend_from_slice(&value.to_le_bytes());
    }

    /// A `string` (UTF-8; a NUL inside would end it early for the reader, so it is dropped).
    pub fn string(&mut self, value: &str) {
        let clean: Vec<u8> = value.bytes().filter(|&b| b != 0).collect();
        self.length(clean.len() + 1);
        self.bytes.extend_from_slice(&clean);
        self.bytes.push(0);
    }

    /// The element count of a sequence (`T[]`), before its elements.
    pub fn length(&mut self, count: usize) {
        self.u32(u32::try_from(count).unwrap_or(u32::MAX));
    }

    /// A `float64[]` sequence.
    pub fn f64_sequence(&mut self, values: &[f64]) {
        self.length(values.len());
        for &v in values {
            self.f64(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_are_aligned_from_the_end_of_the_header() {
        let mut w = CdrWriter::new();
        w.u8(7);
        w.f64(1.0);
        w.string("ab");
        w.i32(-2);
        let bytes = w.finish();
        let mut expected = vec![0, 1, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0];
        expected.extend_from_slice(&1.0f64.to_le_bytes());
        expected.extend_from_slice(&[3, 0, 0, 0, b'a', b'b', 0, 0]);
        expected.extend_from_slice(&(-2i32).to_le_bytes());
        assert_eq!(bytes, expected);
    }
}
