//! Recording folders (CONTRACT.md, "Recording"):
//! ```text
//! recording/
//!   recording.json        {"fps": 30.0}      (optional; default 30)
//!   timestamps.csv        camera,frame,time_s (optional; written by `teachcam record`)
//!   cam0/000000.png ...   one sub-folder per camera, named as in the rig
//!   cam1.avi              or one video file per camera, named after it (decoded by FFmpeg)
//! ```
//! Frames are 8- or 16-bit grayscale PNG (colour is converted to gray), sorted by file name;
//! every camera has the same number of frames. Videos are listed here and decoded by
//! [`crate::source`].

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use image::{DynamicImage, GrayImage, ImageBuffer, Luma};
use serde::{Deserialize, Serialize};

use super::{FileError, parse_json, read_text, write_atomically, write_json};
use crate::camera::Rig;

/// Frame rate used when a recording has no `recording.json` (the paper's 30 Hz trigger).
pub const DEFAULT_FPS: f64 = 30.0;

/// A 16-bit grayscale image.
pub type Gray16Image = ImageBuffer<Luma<u16>, Vec<u16>>;

/// A decoded frame at its own bit depth.
#[derive(Debug, Clone, PartialEq)]
pub enum GrayFrame {
    /// 8-bit samples.
    Eight(GrayImage),
    /// 16-bit samples.
    Sixteen(Gray16Image),
}

impl GrayFrame {
    /// Gives an 8-bit frame's pixel memory back to this thread's frame decoder
    /// ([`super::gray_png::recycle`]) once the frame is no longer needed.
    pub fn recycle(self) {
        if let Self::Eight(image) = self {
            super::gray_png::recycle(image.into_raw());
        }
    }

    /// `(width, height)` in pixels.
    #[must_use]
    pub fn dimensions(&self) -> (u32, u32) {
        match self {
            Self::Eight(i) => i.dimensions(),
            Self::Sixteen(i) => i.dimensions(),
        }
    }

    /// A gray frame from any decoded image: 8- and 16-bit gray kept as they are, colour and
    /// alpha converted to luma at the same depth.
    #[must_use]
    pub fn from_dynamic(image: DynamicImage) -> Self {
        match image {
            DynamicImage::ImageLuma8(i) => Self::Eight(i),
            DynamicImage::ImageLuma16(i) => Self::Sixteen(i),
            DynamicImage::ImageRgb16(_)
            | DynamicImage::ImageRgba16(_)
            | DynamicImage::ImageLumaA16(_) => Self::Sixteen(image.to_luma16()),
            other => Self::Eight(other.to_luma8()),
        }
    }
}

/// One camera's frames in a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraFrames {
    /// The sub-folder's name, which must match a camera of the rig.
    pub name: String,
    /// Frame files, sorted by name; index = frame number.
    pub frames: Vec<PathBuf>,
}

/// A recording folder of PNG cameras, listed and checked but not decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The folder.
    pub root: PathBuf,
    /// Frames per second.
    pub fps: f64,
    /// Cameras, sorted by name.
    pub cameras: Vec<CameraFrames>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RecordingFile {
    fps: f64,
}

/// `recording.json`'s rate: an object with `fps` and nothing else (an array such as `[1000]`
/// would otherwise read as a struct's fields in order; an unknown key such as `"units"` is a
/// claim teachcam would ignore).
fn read_recording_file(file: &Path) -> Result<f64, FileError> {
    let value: serde_json::Value = parse_json(file, &read_text(file)?)?;
    if !value.is_object() {
        return Err(FileError::invalid(
            file,
            format!("expected an object such as {{\"fps\": 30}}, got {value}"),
        ));
    }
    serde_json::from_value::<RecordingFile>(value)
        .map(|r| r.fps)
        .map_err(|e| FileError::invalid(file, format!("{e} (the file holds {{\"fps\": N}})")))
}

impl Recording {
    /// Number of frames (the same for every camera).
    #[must_use]
    pub fn frame_count(&self) -> usize {
        self.cameras.first().map_or(0, |c| c.frames.len())
    }

    /// Time of a frame, seconds.
    #[must_use]
    pub fn time_s(&self, frame: usize) -> f64 {
        frame as f64 / self.fps
    }

    /// The frames of the camera with this name.
    #[must_use]
    pub fn camera(&self, name: &str) -> Option<&CameraFrames> {
        self.cameras.iter().find(|c| c.name == name)
    }
}

/// File extensions read as one camera's video (any container FFmpeg reads; matched without
/// case).
pub const VIDEO_EXTENSIONS: [&str; 14] = [
    "mp4", "avi", "mkv", "mov", "webm", "m4v", "mpg", "mpeg", "ts", "ogv", "wmv", "flv", "nut",
    "y4m",
];

/// The name of the optional per-frame time file beside the frames.
pub const TIMESTAMPS_FILE: &str = "timestamps.csv";

/// Where one camera's frames are.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraMedia {
    /// PNG files, sorted by name; index = frame number.
    Images(Vec<PathBuf>),
    /// One video file, decoded in order.
    Video(PathBuf),
}

/// One camera of a listed recording.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraEntry {
    /// The camera's name (sub-folder or video file stem), matched against the rig.
    pub name: String,
    /// Its frames.
    pub media: CameraMedia,
}

/// A recording folder of image and video cameras, listed and checked but not decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingListing {
    /// The folder.
    pub root: PathBuf,
    /// Frames per second: `--fps`, else `recording.json`; `None` when neither says (the caller
    /// falls back on the videos' own rate or [`DEFAULT_FPS`]).
    pub fps: Option<f64>,
    /// Cameras, sorted by name.
    pub cameras: Vec<CameraEntry>,
    /// Each camera's frame times from `timestamps.csv`, seconds, when the file is present.
    pub timestamps: Option<BTreeMap<String, Vec<f64>>>,
}

fn read_dir_sorted(path: &Path) -> Result<Vec<PathBuf>, FileError> {
    let err = |source| FileError::Read {
        path: path.to_path_buf(),
        source,
    };
    let mut entries = Vec::new();
    for entry in std::fs::read_dir(path).map_err(err)? {
        entries.push(entry.map_err(err)?.path());
    }
    entries.sort();
    Ok(entries)
}

fn has_extension(path: &Path, extensions: &[&str]) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| extensions.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// Lists and checks a recording folder: at least one camera (a sub-folder of PNG files or a
/// video file), never both for one name, the same number of PNG frames in every image camera,
/// a valid `recording.json` and `timestamps.csv` when present. `fps_override` (the `--fps`
/// flag) wins over the file. Video frame counts are checked when the videos are opened.
///
/// # Errors
/// [`FileError`] naming the folder, the camera or the file.
pub fn list_recording(
    root: &Path,
    fps_override: Option<f64>,
) -> Result<RecordingListing, FileError> {
    let mut cameras: Vec<CameraEntry> = Vec::new();
    for path in read_dir_sorted(root)? {
        let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
            continue;
        };
        if name.starts_with('.') {
            continue;
        }
        let entry = if path.is_dir() {
            let frames: Vec<PathBuf> = read_dir_sorted(&path)?
                .into_iter()
                .filter(|f| f.is_file() && has_extension(f, &["png"]))
                .collect();
            CameraEntry {
                name,
                media: CameraMedia::Images(frames),
            }
        } else if path.is_file() && has_extension(&path, &VIDEO_EXTENSIONS) {
            let Some(stem) = path.file_stem().map(|s| s.to_string_lossy().into_owned()) else {
                continue;
            };
            CameraEntry {
                name: stem,
                media: CameraMedia::Video(path),
            }
        } else {
            continue;
        };
        if let Some(twin) = cameras.iter().find(|c| c.name == entry.name) {
            let describe = |c: &CameraEntry| match &c.media {
                CameraMedia::Images(_) => format!("{}/", c.name),
                CameraMedia::Video(p) => p
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            };
            return Err(FileError::invalid(
                root,
                format!(
                    "camera {} is given twice ({} and {}); keep one",
                    entry.name,
                    describe(twin),
                    describe(&entry)
                ),
            ));
        }
        cameras.push(entry);
    }
    cameras.sort_by(|a, b| a.name.cmp(&b.name));
    if cameras.is_empty() {
        return Err(FileError::invalid(
            root,
            "no cameras (expected cam0/, cam1/, ... with PNG frames, or videos cam0.mp4, ...)",
        ));
    }
    let image_counts: Vec<(&str, usize)> = cameras
        .iter()
        .filter_map(|c| match &c.media {
            CameraMedia::Images(frames) => Some((c.name.as_str(), frames.len())),
            CameraMedia::Video(_) => None,
        })
        .collect();
    if let Some((empty, _)) = image_counts.iter().find(|(_, n)| *n == 0) {
        return Err(FileError::invalid(
            root,
            format!("camera {empty}: no PNG frames in {empty}/"),
        ));
    }
    if let (Some((first, expected)), Some((other, n))) = (
        image_counts.first(),
        image_counts.iter().find(|(_, n)| *n != image_counts[0].1),
    ) {
        return Err(FileError::invalid(
            root,
            format!("camera {other} has {n} frames but camera {first} has {expected}"),
        ));
    }
    let fps = match fps_override {
        Some(fps) => Some(fps),
        None => {
            let file = root.join("recording.json");
            if file.exists() {
                Some(read_recording_file(&file)?)
            } else {
                None
            }
        }
    };
    if let Some(fps) = fps {
        let (field, named) = match fps_override {
            Some(_) => ("--fps", root.to_path_buf()),
            None => ("fps", root.join("recording.json")),
        };
        crate::trajectory::check_sample_rate_hz(field, fps)
            .map_err(|e| FileError::invalid(&named, e.to_string()))?;
    }
    let timestamps_path = root.join(TIMESTAMPS_FILE);
    let timestamps = if timestamps_path.is_file() {
        let times = read_timestamps(&timestamps_path)?;
        for camera in &cameras {
            let Some(camera_times) = times.get(&camera.name) else {
                return Err(FileError::invalid(
                    &timestamps_path,
                    format!("no times for camera {}", camera.name),
                ));
            };
            check_times_resolution(&timestamps_path, &camera.name, camera_times)?;
            if let Some(fps) = fps {
                check_times_against_rate(&timestamps_path, &camera.name, camera_times, fps)?;
            }
            if let CameraMedia::Images(frames) = &camera.media
                && frames.len() != camera_times.len()
            {
                return Err(FileError::invalid(
                    &timestamps_path,
                    format!(
                        "camera {} has {} frames but {} times",
                        camera.name,
                        frames.len(),
                        camera_times.len()
                    ),
                ));
            }
        }
        Some(times)
    } else {
        None
    };
    Ok(RecordingListing {
        root: root.to_path_buf(),
        fps,
        cameras,
        timestamps,
    })
}

/// Lists and checks a recording folder of PNG cameras ([`list_recording`], refusing video
/// cameras, for the commands that read PNG files only).
///
/// # Errors
/// [`FileError`] naming the folder, the camera or the file.
pub fn open_recording(root: &Path, fps_override: Option<f64>) -> Result<Recording, FileError> {
    let listing = list_recording(root, fps_override)?;
    let cameras = listing
        .cameras
        .into_iter()
        .map(|c| match c.media {
            CameraMedia::Images(frames) => Ok(CameraFrames {
                name: c.name,
                frames,
            }),
            CameraMedia::Video(path) => Err(FileError::invalid(
                &path,
                format!(
                    "camera {} is a video; this command reads PNG frames (cam0/000000.png, ...)",
                    c.name
                ),
            )),
        })
        .collect::<Result<_, _>>()?;
    Ok(Recording {
        root: listing.root,
        fps: listing.fps.unwrap_or(DEFAULT_FPS),
        cameras,
    })
}

/// Reads `timestamps.csv` (`camera,frame,time_s`): for each camera, the time of every frame,
/// seconds. Frames of a camera must be listed `0, 1, 2, …` in order with finite times that
/// never decrease.
///
/// # Errors
/// [`FileError::InvalidLine`] naming the line.
pub fn read_timestamps(path: &Path) -> Result<BTreeMap<String, Vec<f64>>, FileError> {
    let text = read_text(path)?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or_default().trim();
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    if columns.len() < 3 || columns[..3] != ["camera", "frame", "time_s"] {
        return Err(FileError::invalid_line(
            path,
            1,
            format!("header must start with camera,frame,time_s, got {header:?}"),
        ));
    }
    let mut times: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for (i, line) in lines.enumerate() {
        let number = i + 2;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let bad = |message: String| FileError::invalid_line(path, number, message);
        if fields.len() < 3 {
            return Err(bad(format!("expected 3 fields, got {}", fields.len())));
        }
        let frame: usize = fields[1]
            .parse()
            .map_err(|_| bad(format!("frame {:?} is not a frame number", fields[1])))?;
        let time_s: f64 = fields[2]
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite())
            .ok_or_else(|| bad(format!("time_s {:?} is not a finite number", fields[2])))?;
        let camera = times.entry(fields[0].to_string()).or_default();
        if frame != camera.len() {
            return Err(bad(format!(
                "camera {}: frame {frame} where frame {} was expected",
                fields[0],
                camera.len()
            )));
        }
        if let Some(&last) = camera.last()
            && time_s <= last
        {
            return Err(bad(format!(
                "camera {}: frame {frame} at {time_s} s is not later than frame {} at {last} s (times must increase{})",
                fields[0],
                frame - 1,
                if time_s == last && last.abs() > 1e9 {
                    "; these times are beyond what double precision tells apart: give seconds from the recording's start"
                } else {
                    ""
                }
            )));
        }
        camera.push(time_s);
    }
    Ok(times)
}

/// How far a camera's median frame step may stray from the recording's rate: a camera that
/// drops frames or runs at a slightly other rate stays within it; times written in
/// milliseconds (1000×) or frame numbers do not.
const RATE_FACTOR: f64 = 2.0;

/// A camera's frame times agree with the recording's rate `fps`: their median step is within
/// [`RATE_FACTOR`] of `1 / fps`.
fn check_times_against_rate(
    path: &Path,
    camera: &str,
    times: &[f64],
    fps: f64,
) -> Result<(), FileError> {
    let steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    let Some(step) = crate::stats::median(&steps) else {
        return Ok(());
    };
    let expected = 1.0 / fps;
    if step > RATE_FACTOR * expected || step < expected / RATE_FACTOR {
        return Err(FileError::invalid(
            path,
            format!(
                "camera {camera}: frames {step} s apart (median), but the recording's rate of {fps} fps puts them {expected:.6} s apart{}",
                if (step / expected / 1000.0).ln().abs() < 0.1 {
                    ": these times look like milliseconds; time_s is in seconds"
                } else {
                    ""
                }
            ),
        ));
    }
    Ok(())
}

/// The finest a frame time must be told apart, as a fraction of the frame step: a thousandth
/// of a period (33 µs at 30 fps) keeps the times' rounding far under the cameras' own jitter.
const TIME_RESOLUTION_OF_STEP: f64 = 1e-3;

/// A camera's frame times are held in double precision finely enough: the spacing of doubles
/// at the largest time is at most [`TIME_RESOLUTION_OF_STEP`] of the median frame step (times
/// such as 1e13 + i/30, seconds since some far epoch, still increase but are rounded to 2 ms).
fn check_times_resolution(path: &Path, camera: &str, times: &[f64]) -> Result<(), FileError> {
    let steps: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    let Some(step) = crate::stats::median(&steps) else {
        return Ok(());
    };
    let largest = times.iter().fold(0.0_f64, |m, t| m.max(t.abs()));
    let spacing = largest * f64::EPSILON;
    if spacing > TIME_RESOLUTION_OF_STEP * step {
        return Err(FileError::invalid(
            path,
            format!(
                "camera {camera}: times up to {largest:e} s are beyond what double precision tells apart at frames {step:.6} s apart (rounded to {spacing:.2e} s, over {TIME_RESOLUTION_OF_STEP} of a frame step): give seconds from the recording's start"
            ),
        ));
    }
    Ok(())
}

/// The text of `timestamps.csv` for each camera's frame times, seconds (microsecond digits).
#[must_use]
pub fn timestamps_text(times: &BTreeMap<String, Vec<f64>>) -> String {
    let mut text = String::from("camera,frame,time_s\n");
    for (camera, camera_times) in times {
        for (frame, time_s) in camera_times.iter().enumerate() {
            text.push_str(&format!("{camera},{frame},{time_s:.6}\n"));
        }
    }
    text
}

/// Checks that every camera of the rig has frames in the recording (extra sub-folders are
/// allowed and ignored).
///
/// # Errors
/// [`FileError::Invalid`] naming the camera without frames.
pub fn check_recording_against_rig(recording: &Recording, rig: &Rig) -> Result<(), FileError> {
    for camera in &rig.cameras {
        if recording.camera(&camera.name).is_none() {
            let found: Vec<&str> = recording.cameras.iter().map(|c| c.name.as_str()).collect();
            return Err(FileError::invalid(
                &recording.root,
                format!(
                    "rig camera {} has no sub-folder (found: {})",
                    camera.name,
                    found.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// Most pixels a frame may have: the largest machine-vision sensors in use hold about 45
/// megapixels (8192x5460); at 16 bits such a frame decodes to 90 MB, and frames decode in
/// parallel, one per thread. A header claiming more is refused before anything is decoded.
pub const MAX_FRAME_PIXELS: u64 = 50_000_000;

/// Decodes one frame, checking its size when `expected_size` is given. The size is read from
/// the PNG header first: a frame of the wrong size or over [`MAX_FRAME_PIXELS`] is refused
/// before it is decoded. An 8-bit gray frame of the plain kind `teachcam` writes is decoded by
/// [`super::gray_png`] in one pass; any other file, and any file that pass refuses, by `image`
/// (same pixels, and that decoder's error messages).
///
/// # Errors
/// [`FileError`] naming the file: unreadable, not a PNG, truncated, too large, or of the wrong
/// size.
pub fn read_frame(path: &Path, expected_size: Option<(u32, u32)>) -> Result<GrayFrame, FileError> {
    decode_frame(path, read_frame_bytes(path, expected_size))
}

thread_local! {
    /// The bytes of this thread's last frame files, reused ([`super::Spares`]): two, for a
    /// pair.
    static FILE_BYTES: std::cell::RefCell<Vec<Vec<u8>>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// Two frames, each as [`read_frame`] reads it, two plain 8-bit gray frames decoded side by
/// side ([`super::gray_png::decode_gray8_pair`]).
pub fn read_frame_pair(
    paths: [&Path; 2],
    expected_sizes: [Option<(u32, u32)>; 2],
) -> [Result<GrayFrame, FileError>; 2] {
    let [a, b] = [0, 1].map(|k| read_frame_bytes(paths[k], expected_sizes[k]));
    match (a, b) {
        (Ok((a, true)), Ok((b, true))) => {
            let [decoded_a, decoded_b] = super::gray_png::decode_gray8_pair(&a, &b);
            let frames = [
                frame_of(paths[0], &a, decoded_a),
                frame_of(paths[1], &b, decoded_b),
            ];
            super::give_spare(&FILE_BYTES, a, 2);
            super::give_spare(&FILE_BYTES, b, 2);
            frames
        }
        (a, b) => [decode_frame(paths[0], a), decode_frame(paths[1], b)],
    }
}

/// The frame of a file [`read_frame_bytes`] read, by the one-pass decoder when it is a plain
/// 8-bit gray PNG and that decoder takes it, else by the general decoder; the bytes' memory
/// kept by the thread for its next frame.
fn decode_frame(
    path: &Path,
    read: Result<(Vec<u8>, bool), FileError>,
) -> Result<GrayFrame, FileError> {
    let (bytes, plain_gray8) = read?;
    let decoded = if plain_gray8 {
        super::gray_png::decode_gray8(&bytes)
    } else {
        None
    };
    let frame = frame_of(path, &bytes, decoded);
    super::give_spare(&FILE_BYTES, bytes, 2);
    frame
}

/// A frame file's bytes, its size checked (against `expected_size` when given, and
/// [`MAX_FRAME_PIXELS`]), and whether it is a plain 8-bit gray PNG
/// ([`super::gray_png::gray8_header`]).
fn read_frame_bytes(
    path: &Path,
    expected_size: Option<(u32, u32)>,
) -> Result<(Vec<u8>, bool), FileError> {
    let mut bytes = super::take_spare(&FILE_BYTES, 0);
    std::fs::File::open(path)
        .and_then(|mut file| std::io::Read::read_to_end(&mut file, &mut bytes))
        .map_err(|source| FileError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    let plain_gray8 = super::gray_png::gray8_header(&bytes);
    let (fw, fh) = match plain_gray8 {
        Some(header) => (header.width, header.height),
        None => {
            image::ImageReader::with_format(std::io::Cursor::new(&bytes), image::ImageFormat::Png)
                .into_dimensions()
                .map_err(|e| not_png(path, &e))?
        }
    };
    if let Some((w, h)) = expected_size
        && (fw, fh) != (w, h)
    {
        return Err(FileError::invalid(
            path,
            format!("image is {fw}x{fh}, the rig says {w}x{h}"),
        ));
    }
    check_frame_pixels(path, fw, fh)?;
    Ok((bytes, plain_gray8.is_some()))
}

/// The frame of a file's `bytes`: the image the one-pass decoder gave (`decoded`), or else
/// the general decoder's.
fn frame_of(path: &Path, bytes: &[u8], decoded: Option<GrayImage>) -> Result<GrayFrame, FileError> {
    if let Some(image) = decoded {
        return Ok(GrayFrame::Eight(image));
    }
    let image = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .map_err(|e| not_png(path, &e))?;
    Ok(GrayFrame::from_dynamic(image))
}

fn not_png(path: &Path, error: &image::ImageError) -> FileError {
    FileError::invalid(path, format!("not a readable PNG: {error}"))
}

/// Refuses an image of more than [`MAX_FRAME_PIXELS`], naming its size.
fn check_frame_pixels(path: &Path, width: u32, height: u32) -> Result<(), FileError> {
    let pixels = u64::from(width) * u64::from(height);
    if pixels > MAX_FRAME_PIXELS {
        return Err(FileError::invalid(
            path,
            format!(
                "image is {width}x{height} ({:.0} megapixels), more than the {} a frame may have",
                pixels as f64 / 1e6,
                MAX_FRAME_PIXELS / 1_000_000
            ),
        ));
    }
    Ok(())
}

/// Decodes an image of any format `image` reads (a calibration photograph: PNG or JPEG),
/// its size read from the header first: one over [`MAX_FRAME_PIXELS`] is refused before it
/// is decoded.
///
/// # Errors
/// [`FileError`] naming the file: unreadable, not an image, or too large.
pub fn read_image(path: &Path) -> Result<image::DynamicImage, FileError> {
    use image::ImageDecoder as _;
    let not_image =
        |e: image::ImageError| FileError::invalid(path, format!("not a readable image: {e}"));
    let decoder = image::ImageReader::open(path)
        .and_then(image::ImageReader::with_guessed_format)
        .map_err(|source| FileError::Read {
            path: path.to_path_buf(),
            source,
        })?
        .into_decoder()
        .map_err(not_image)?;
    let (width, height) = decoder.dimensions();
    check_frame_pixels(path, width, height)?;
    image::DynamicImage::from_decoder(decoder).map_err(not_image)
}

/// Encodes an 8-bit gray image as PNG and writes it atomically.
///
/// # Errors
/// [`FileError::Write`].
pub fn write_png(path: &Path, image: &GrayImage) -> Result<(), FileError> {
    encode_png(path, |encoder| image.write_with_encoder(encoder))
}

/// Encodes a frame at its own bit depth as PNG and writes it atomically (a frame file is
/// whole or absent, never cut).
///
/// # Errors
/// [`FileError::Write`].
pub fn write_frame_png(path: &Path, frame: &GrayFrame) -> Result<(), FileError> {
    match frame {
        GrayFrame::Eight(image) => write_png(path, image),
        GrayFrame::Sixteen(image) => encode_png(path, |encoder| image.write_with_encoder(encoder)),
    }
}

/// The one PNG encoding of frames (fast deflate, Sub filter), written atomically to `path`.
fn encode_png(
    path: &Path,
    encode: impl FnOnce(image::codecs::png::PngEncoder<&mut Vec<u8>>) -> image::ImageResult<()>,
) -> Result<(), FileError> {
    let mut bytes = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new_with_quality(
        &mut bytes,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Sub,
    );
    encode(encoder).map_err(|e| FileError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })?;
    write_atomically(path, &bytes)
}

/// Writes `recording.json` with the frame rate.
///
/// # Errors
/// [`FileError::Write`].
pub fn write_recording_info(root: &Path, fps: f64) -> Result<(), FileError> {
    write_json(&root.join("recording.json"), &RecordingFile { fps })
}

/// The file name of a frame: six digits and `.png`.
#[must_use]
pub fn frame_file_name(frame: usize) -> String {
    format!("{frame:06}.png")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn make(root: &Path, cameras: &[(&str, usize)]) {
        for (name, n) in cameras {
            std::fs::create_dir_all(root.join(name)).unwrap();
            for f in 0..*n {
                write_png(
                    &root.join(name).join(frame_file_name(f)),
                    &GrayImage::new(8, 6),
                )
                .unwrap();
            }
        }
    }

    #[test]
    fn lists_a_recording_and_decodes_frames() {
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), &[("cam1", 3), ("cam0", 3)]);
        write_recording_info(dir.path(), 60.0).unwrap();
        let rec = open_recording(dir.path(), None).unwrap();
        assert_eq!(rec.fps, 60.0);
        assert_eq!(rec.cameras[0].name, "cam0");
        assert_eq!(rec.frame_count(), 3);
        assert_eq!(open_recording(dir.path(), Some(25.0)).unwrap().fps, 25.0);
        let frame = read_frame(&rec.cameras[0].frames[2], Some((8, 6))).unwrap();
        assert_eq!(frame.dimensions(), (8, 6));
        let message = read_frame(&rec.cameras[0].frames[2], Some((1280, 1024)))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("000002.png") && message.contains("8x6"),
            "{message}"
        );
    }

    #[test]
    fn frames_read_in_pairs_are_what_each_reads_alone() {
        // Plain 8-bit frames (decoded side by side), a 16-bit frame (the general decoder),
        // a missing file, a frame of the wrong size: each of a pair gives what `read_frame`
        // gives it, its error message too.
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), &[("cam0", 2), ("cam1", 2)]);
        let rec = open_recording(dir.path(), None).unwrap();
        let sixteen = dir.path().join("sixteen.png");
        Gray16Image::from_fn(4, 4, |x, _| Luma([x as u16 * 4000]))
            .save(&sixteen)
            .unwrap();
        let missing = dir.path().join("missing.png");
        let cases = [
            (rec.cameras[0].frames[0].as_path(), Some((8, 6))),
            (rec.cameras[1].frames[1].as_path(), None),
            (sixteen.as_path(), None),
            (missing.as_path(), None),
            (rec.cameras[0].frames[1].as_path(), Some((1280, 1024))),
        ];
        let alone = |(path, size): (&Path, Option<(u32, u32)>)| {
            read_frame(path, size).map_err(|e| e.to_string())
        };
        for a in cases {
            for b in cases {
                let [pair_a, pair_b] = read_frame_pair([a.0, b.0], [a.1, b.1]);
                assert_eq!(pair_a.map_err(|e| e.to_string()), alone(a));
                assert_eq!(pair_b.map_err(|e| e.to_string()), alone(b));
            }
        }
    }

    #[test]
    fn sixteen_bit_frames_keep_their_depth() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.png");
        let image = Gray16Image::from_fn(4, 4, |x, _| Luma([x as u16 * 4000]));
        image.save(&path).unwrap();
        match read_frame(&path, None).unwrap() {
            GrayFrame::Sixteen(i) => assert_eq!(i.get_pixel(3, 0).0[0], 12000),
            GrayFrame::Eight(_) => panic!("16-bit frame decoded as 8-bit"),
        }
    }

    #[test]
    fn refuses_bad_recordings_naming_camera_and_file() {
        let dir = tempfile::tempdir().unwrap();
        make(dir.path(), &[("cam0", 3), ("cam1", 2)]);
        let message = open_recording(dir.path(), None).unwrap_err().to_string();
        assert!(
            message.contains("camera cam1 has 2 frames but camera cam0 has 3"),
            "{message}"
        );

        let empty = tempfile::tempdir().unwrap();
        assert!(
            open_recording(empty.path(), None)
                .unwrap_err()
                .to_string()
                .contains("no cameras")
        );

        let bad_fps = tempfile::tempdir().unwrap();
        make(bad_fps.path(), &[("cam0", 1)]);
        std::fs::write(bad_fps.path().join("recording.json"), "{\"fps\": -3}").unwrap();
        assert!(
            open_recording(bad_fps.path(), None)
                .unwrap_err()
                .to_string()
                .contains("fps")
        );

        let truncated = dir.path().join("cam0").join(frame_file_name(1));
        let bytes = std::fs::read(&truncated).unwrap();
        std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
        let message = read_frame(&truncated, None).unwrap_err().to_string();
        assert!(
            message.contains("000001.png") && message.contains("not a readable PNG"),
            "{message}"
        );
    }
}
