//! Frame sources: where the frames of a recording or of a live rig come from, behind one
//! interface that `detect`, `track`, `record`, `live` and the conductor ([`crate::pipeline`])
//! read.
//!
//! ```text
//! SourceSpec ─► open_source ─► FrameSource ─► FrameSet { index, time_s, exposed_at, cameras }
//!   folder:rec/   recording folder: camN/*.png or camN.<video> (FFmpeg), timestamps.csv
//!   sim:paper     the simulator's scenario, rendered ahead, delivered at --fps
//!   v4l2:/dev/video0,/dev/video2   live V4L2 cameras (Linux)
//! ```
//! A source yields one [`FrameSet`] per instant: one frame (or none) per camera, in the
//! source's camera order. Cameras that are triggered together (the simulator, a recording's
//! frame numbers) are paired by sequence; free-running cameras by timestamp, nearest within half
//! a period ([`pairing`]). A live source never blocks its cameras: when the consumer falls
//! behind, the frames it could not take are dropped and counted ([`SourceStats`]), as a camera
//! driver drops frames when no buffer is free.
//!
//! Every frame is checked before it is decoded: a PNG's header, a video's stream information
//! and a camera's negotiated format are refused above [`MAX_FRAME_PIXELS`].

pub mod folder;
pub mod pairing;
pub mod sim;
pub mod v4l2;
pub mod video;

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;
use std::time::Instant;

use crate::io::FileError;
pub use crate::io::recording::MAX_FRAME_PIXELS;
use crate::io::recording::{GrayFrame, read_frame, read_frame_pair};
use crate::sim::Scenario;

/// One camera of a source.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourceCamera {
    /// The camera's name (`cam0`, the sub-folder, the video's stem, the device), matched
    /// against the rig's cameras.
    pub name: String,
    /// `(width, height)` in pixels when the source knows it before the first frame.
    pub size: Option<(u32, u32)>,
}

/// A frame's pixels: decoded already, or a PNG file the conductor decodes in parallel.
#[derive(Debug, Clone)]
pub enum FrameData {
    /// Decoded pixels (video, camera, simulator), shared without copying.
    Decoded(Arc<GrayFrame>),
    /// A PNG file not yet read.
    Png(PathBuf),
}

/// One camera's frame.
#[derive(Debug, Clone)]
pub struct CameraFrame {
    /// The frame's number in this camera's own stream, 0-based.
    pub frame: usize,
    /// Exposure time, seconds from the start of the source.
    pub time_s: f64,
    /// Trigger sequence number, for cameras triggered together.
    pub sequence: Option<u64>,
    /// The pixels.
    pub data: FrameData,
}

impl CameraFrame {
    /// The decoded pixels, checked against `expected_size` (the rig's image size) when given.
    /// `camera` names the camera in errors.
    ///
    /// # Errors
    /// [`SourceError`] naming the camera, the frame and both sizes, or the unreadable file.
    pub fn decode(
        &self,
        camera: &str,
        expected_size: Option<(u32, u32)>,
    ) -> Result<Arc<GrayFrame>, SourceError> {
        let image = match &self.data {
            FrameData::Decoded(image) => Ok(Arc::clone(image)),
            FrameData::Png(path) => read_frame(path, None).map(Arc::new),
        };
        self.checked(camera, expected_size, image)
    }

    /// Two frames' pixels, each as [`CameraFrame::decode`] gives it (with its camera's name
    /// and size), two PNG files decoded side by side ([`read_frame_pair`]).
    ///
    /// # Errors
    /// Each frame's own, as [`CameraFrame::decode`] gives it.
    pub fn decode_pair(frames: [FrameToDecode<'_>; 2]) -> [Result<Arc<GrayFrame>, SourceError>; 2] {
        let [(a, camera_a, size_a), (b, camera_b, size_b)] = frames;
        match (&a.data, &b.data) {
            (FrameData::Png(path_a), FrameData::Png(path_b)) => {
                let [image_a, image_b] = read_frame_pair([path_a, path_b], [None, None]);
                [
                    a.checked(camera_a, size_a, image_a.map(Arc::new)),
                    b.checked(camera_b, size_b, image_b.map(Arc::new)),
                ]
            }
            _ => [a.decode(camera_a, size_a), b.decode(camera_b, size_b)],
        }
    }

    /// This frame's decoded `image`, or its error, named, and its size checked against
    /// `expected_size`.
    fn checked(
        &self,
        camera: &str,
        expected_size: Option<(u32, u32)>,
        image: Result<Arc<GrayFrame>, FileError>,
    ) -> Result<Arc<GrayFrame>, SourceError> {
        let image = image.map_err(|source| SourceError::Frame {
            camera: camera.to_string(),
            frame: self.frame,
            source,
        })?;
        let (width, height) = image.dimensions();
        if let Some(expected) = expected_size
            && (width, height) != expected
        {
            return Err(SourceError::FrameSize {
                camera: camera.to_string(),
                frame: self.frame,
                size: (width, height),
                expected,
            });
        }
        Ok(image)
    }
}

/// A frame to decode, its camera's name, and the size expected of it (the rig's).
pub type FrameToDecode<'a> = (&'a CameraFrame, &'a str, Option<(u32, u32)>);

/// The frames of all cameras at one instant.
#[derive(Debug, Clone)]
pub struct FrameSet {
    /// 0-based index of the set in the source's stream (the recording's frame number).
    pub index: usize,
    /// The set's time, seconds: the mean exposure time of its frames.
    pub time_s: f64,
    /// When the set was exposed on this machine's clock (live sources), for latency.
    pub exposed_at: Option<Instant>,
    /// One entry per camera of [`FrameSource::cameras`], in that order; `None` where the
    /// camera has no frame paired with this instant.
    pub cameras: Vec<Option<CameraFrame>>,
}

impl FrameSet {
    /// A set whose time is the mean of its frames' times.
    #[must_use]
    pub fn new(
        index: usize,
        exposed_at: Option<Instant>,
        cameras: Vec<Option<CameraFrame>>,
    ) -> Self {
        let times: Vec<f64> = cameras.iter().flatten().map(|c| c.time_s).collect();
        let time_s = times.iter().sum::<f64>() / times.len().max(1) as f64;
        Self {
            index,
            time_s,
            exposed_at,
            cameras,
        }
    }
}

/// What a source lost on the way, for the summaries of `record` and `live`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SourceStats {
    /// Frame sets exposed but not delivered because the consumer was behind.
    pub dropped_sets: usize,
    /// Per camera (source order), frames that no other camera's frame paired with.
    pub unpaired_frames: Vec<usize>,
    /// Largest spread of exposure times within a delivered set, seconds.
    pub max_pair_spread_s: f64,
}

/// A stream of frame sets.
pub trait FrameSource: Send + fmt::Debug {
    /// The cameras, in the order of [`FrameSet::cameras`].
    fn cameras(&self) -> &[SourceCamera];
    /// Nominal frames per second.
    fn fps(&self) -> f64;
    /// The number of sets when known in advance (files); `None` for live sources.
    fn len_hint(&self) -> Option<usize>;
    /// True for sources that expose frames on their own clock (cameras, the paced simulator):
    /// the consumer should take them one at a time, as they come.
    fn is_live(&self) -> bool;
    /// The next set; `None` at the end of the stream.
    fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>>;
    /// What was dropped or left unpaired so far.
    fn stats(&self) -> SourceStats;
}

/// Why a source cannot deliver frames.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The source name is not one of the known forms.
    #[error(
        "source {given:?}: {reason} (expected sim:SCENARIO, v4l2:/dev/video0,/dev/video2, folder:REC or a folder)"
    )]
    Spec {
        /// What was given.
        given: String,
        /// What is wrong.
        reason: String,
    },
    /// A recording file could not be listed or read.
    #[error(transparent)]
    File(#[from] FileError),
    /// One frame file could not be read.
    #[error("camera {camera}, frame {frame}: {source}")]
    Frame {
        /// The camera.
        camera: String,
        /// The frame.
        frame: usize,
        /// The cause.
        source: FileError,
    },
    /// A frame is not the size the rig (or the camera's first frame) says.
    #[error(
        "camera {camera}, frame {frame}: image is {}x{}, expected {}x{}",
        size.0, size.1, expected.0, expected.1
    )]
    FrameSize {
        /// The camera.
        camera: String,
        /// The frame.
        frame: usize,
        /// The frame's `(width, height)`.
        size: (u32, u32),
        /// The expected `(width, height)`.
        expected: (u32, u32),
    },
    /// A camera's frames are larger than [`MAX_FRAME_PIXELS`].
    #[error("camera {camera}: frames of {}x{} are above the limit of {MAX_FRAME_PIXELS} pixels", size.0, size.1)]
    TooLarge {
        /// The camera.
        camera: String,
        /// The `(width, height)` announced.
        size: (u32, u32),
    },
    /// The `ffmpeg` or `ffprobe` program is not installed.
    #[error(
        "{program} not found: video files are decoded by FFmpeg (install it: apt-get install ffmpeg)"
    )]
    FfmpegMissing {
        /// The program.
        program: String,
    },
    /// FFmpeg could not read a video.
    #[error("{}: {message}", path.display())]
    Video {
        /// The video file.
        path: PathBuf,
        /// What went wrong, with FFmpeg's own message.
        message: String,
    },
    /// The cameras of a recording do not have the same number of frames.
    #[error("camera {camera} has {frames} frames but camera {other} has {other_frames}")]
    FrameCount {
        /// The camera that ended first.
        camera: String,
        /// Its frames.
        frames: usize,
        /// A camera that went on.
        other: String,
        /// Its frames so far.
        other_frames: usize,
    },
    /// A camera device could not be opened or read.
    #[error("camera {device}: {message}")]
    Device {
        /// The device path.
        device: String,
        /// What went wrong.
        message: String,
    },
}

/// A source name, as given to `--source`.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceSpec {
    /// `sim:SCENARIO`: the simulator's scenario as a live source.
    Sim(Scenario),
    /// `v4l2:/dev/video0,/dev/video2`: V4L2 cameras, in this order (`cam0`, `cam1`, ...).
    V4l2(Vec<PathBuf>),
    /// `folder:REC` or a plain path: a recording folder.
    Folder(PathBuf),
}

impl FromStr for SourceSpec {
    type Err = SourceError;

    fn from_str(given: &str) -> Result<Self, Self::Err> {
        let spec_error = |reason: &str| SourceError::Spec {
            given: given.to_string(),
            reason: reason.to_string(),
        };
        if let Some(name) = given.strip_prefix("sim:") {
            let scenario = Scenario::from_name(name)
                .filter(|s| !s.is_calibration())
                .ok_or_else(|| {
                    let names: Vec<&str> = Scenario::ALL
                        .iter()
                        .filter(|s| !s.is_calibration())
                        .map(|s| s.name())
                        .collect();
                    spec_error(&format!(
                        "no simulator scenario {name:?} (scenarios: {})",
                        names.join(", ")
                    ))
                })?;
            Ok(Self::Sim(scenario))
        } else if let Some(devices) = given.strip_prefix("v4l2:") {
            let devices: Vec<PathBuf> = devices
                .split(',')
                .map(str::trim)
                .filter(|d| !d.is_empty())
                .map(PathBuf::from)
                .collect();
            if devices.is_empty() {
                return Err(spec_error("no device after v4l2:"));
            }
            Ok(Self::V4l2(devices))
        } else if let Some(folder) = given.strip_prefix("folder:") {
            if folder.is_empty() {
                return Err(spec_error("no folder after folder:"));
            }
            Ok(Self::Folder(PathBuf::from(folder)))
        } else if given.is_empty() {
            Err(spec_error("empty"))
        } else if given.contains(':') && !Path::new(given).exists() {
            Err(spec_error("unknown kind before ':'"))
        } else {
            Ok(Self::Folder(PathBuf::from(given)))
        }
    }
}

impl fmt::Display for SourceSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Sim(s) => write!(f, "sim:{}", s.name()),
            Self::V4l2(devices) => {
                let names: Vec<String> = devices.iter().map(|d| d.display().to_string()).collect();
                write!(f, "v4l2:{}", names.join(","))
            }
            Self::Folder(p) => write!(f, "folder:{}", p.display()),
        }
    }
}

/// How to open a source.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SourceConfig {
    /// Frames per second: a recording's rate (overrides `recording.json`), the simulator's
    /// rate, the rate asked of cameras. `None`: the recording's own, 60 Hz for the simulator,
    /// the camera's current rate.
    pub fps: Option<f64>,
    /// Stop after this many sets (live sources; `None`: until the consumer stops).
    pub max_sets: Option<usize>,
    /// Simulator options.
    pub sim: sim::SimConfig,
    /// Camera options.
    pub v4l2: v4l2::V4l2Config,
}

/// Opens a source.
///
/// # Errors
/// [`SourceError`] naming the folder, file, camera or device that cannot be opened.
pub fn open_source(
    spec: &SourceSpec,
    config: &SourceConfig,
) -> Result<Box<dyn FrameSource>, SourceError> {
    Ok(match spec {
        SourceSpec::Folder(root) => Box::new(folder::FolderSource::open(root, config.fps)?),
        SourceSpec::Sim(scenario) => {
            let mut sim = config.sim.clone();
            if let Some(fps) = config.fps {
                sim.fps = fps;
            }
            sim.max_sets = config.max_sets;
            Box::new(sim::SimSource::start(*scenario, &sim)?)
        }
        SourceSpec::V4l2(devices) => {
            let mut v4l2 = config.v4l2.clone();
            if config.fps.is_some() {
                v4l2.fps = config.fps;
            }
            v4l2.max_sets = config.max_sets;
            Box::new(v4l2::V4l2Source::open(devices, &v4l2)?)
        }
    })
}

/// Refuses a camera whose frames would exceed [`MAX_FRAME_PIXELS`].
pub(crate) fn check_frame_limit(camera: &str, size: (u32, u32)) -> Result<(), SourceError> {
    if u64::from(size.0) * u64::from(size.1) > MAX_FRAME_PIXELS {
        return Err(SourceError::TooLarge {
            camera: camera.to_string(),
            size,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_kind_of_source_name() {
        assert_eq!(
            "sim:paper".parse::<SourceSpec>().unwrap(),
            SourceSpec::Sim(Scenario::Paper)
        );
        assert_eq!(
            "v4l2:/dev/video0,/dev/video2"
                .parse::<SourceSpec>()
                .unwrap(),
            SourceSpec::V4l2(vec!["/dev/video0".into(), "/dev/video2".into()])
        );
        assert_eq!(
            "folder:rec/".parse::<SourceSpec>().unwrap(),
            SourceSpec::Folder("rec/".into())
        );
        assert_eq!(
            "some/rec".parse::<SourceSpec>().unwrap(),
            SourceSpec::Folder("some/rec".into())
        );
        for bad in [
            "sim:nope",
            "sim:calibration",
            "v4l2:",
            "folder:",
            "",
            "rtsp:cam",
        ] {
            let message = bad.parse::<SourceSpec>().unwrap_err().to_string();
            assert!(
                message.contains("expected sim:SCENARIO"),
                "{bad}: {message}"
            );
        }
    }
}
