//! A reader of ROS 2 CDR messages for the tests, written apart from the library's encoder
//! (`teachcam::ros2::cdr`): little endian after the 4-byte encapsulation header, each value
//! aligned to its size counted from the end of that header.
//!
//! Test support: a message that does not decode is a failed test, so it panics.
#![allow(clippy::expect_used)]

/// A little-endian CDR reader.
#[derive(Debug)]
pub struct Cdr<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cdr<'a> {
    /// A reader of `bytes`, after checking the little-endian encapsulation header.
    ///
    /// # Panics
    /// When the header is not `00 01 00 00`.
    #[must_use]
    pub fn new(bytes: &'a [u8]) -> Self {
        assert_eq!(
            bytes.get(..4),
            Some(&[0, 1, 0, 0][..]),
            "CDR little-endian header"
        );
        Self { bytes, at: 4 }
    }

    fn take(&mut self, size: usize) -> &[u8] {
        self.at += (size - (self.at - 4) % size) % size;
        let slice = &self.bytes[self.at..self.at + size];
        self.at += size;
        slice
    }

    /// A `uint32`.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take(4).try_into().expect("4 bytes"))
    }

    /// An `int32`.
    pub fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().expect("4 bytes"))
    }

    /// A `float64`.
    pub fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take(8).try_into().expect("8 bytes"))
    }

    /// A `string` (a `uint32` length counting its NUL, the bytes, the NUL).
    pub fn string(&mut self) -> String {
        let n = self.u32() as usize;
        let s = String::from_utf8(self.bytes[self.at..self.at + n - 1].to_vec()).expect("UTF-8");
        self.at += n;
        s
    }

    /// True when every byte was read.
    #[must_use]
    pub fn done(&self) -> bool {
        self.at == self.bytes.len()
    }
}

/// The fields of a `geometry_msgs/msg/PoseWithCovarianceStamped`.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodedPose {
    /// `header.stamp.sec`.
    pub sec: i32,
    /// `header.stamp.nanosec`.
    pub nanosec: u32,
    /// `header.frame_id`.
    pub frame_id: String,
    /// `pose.pose.position`, metres.
    pub position: [f64; 3],
    /// `pose.pose.orientation`, `x, y, z, w`.
    pub orientation: [f64; 4],
    /// `pose.covariance`, row-major.
    pub covariance: [f64; 36],
}

impl DecodedPose {
    /// The stamp in seconds.
    #[must_use]
    pub fn stamp_s(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// Decodes a `PoseWithCovarianceStamped` from its CDR bytes.
///
/// # Panics
/// When the bytes are not one such message.
#[must_use]
pub fn decode_pose(bytes: &[u8]) -> DecodedPose {
    let mut r = Cdr::new(bytes);
    let sec = r.i32();
    let nanosec = r.u32();
    let frame_id = r.string();
    let position = [r.f64(), r.f64(), r.f64()];
    let orientation = [r.f64(), r.f64(), r.f64(), r.f64()];
    let covariance = std::array::from_fn(|_| r.f64());
    assert!(r.done(), "no bytes left over");
    DecodedPose {
        sec,
        nanosec,
        frame_id,
        position,
        orientation,
        covariance,
    }
}
