//! One camera's video file, decoded by FFmpeg into gray frames.
//!
//! `ffprobe` reads the stream's size, rate and bit depth (nothing is decoded before the size is
//! checked against [`super::MAX_FRAME_PIXELS`]); then `ffmpeg` decodes the first video stream
//! to raw gray samples on its standard output (`-f rawvideo -pix_fmt gray`, or `gray16le` for
//! sources deeper than 8 bits), every decoded frame kept in order (`-fps_mode passthrough`, so
//! a variable-rate file is neither padded nor thinned), and each frame is exactly
//! `width × height` samples read from the pipe. Any container and codec FFmpeg reads works;
//! there is no codec of our own.
//!
//! An 8-bit planar YUV video (what MPEG-4, H.264 and most cameras write) already holds its gray
//! picture: the luma plane. FFmpeg's own conversion to gray (swscale) took more CPU than the
//! decoding (a 640×480 MPEG-4 file: 1.63 s against 0.79 s for the plane alone), so such
//! videos are decoded to their luma plane (`-vf extractplanes=y`) and, in limited ("TV")
//! range, expanded here to full range with the table swscale's conversion amounts to,
//! `round((Y − 16) · 255 / 219)`: the frames are byte for byte what `-pix_fmt gray` gives
//! (tests/video.rs compares them for several pixel formats and both ranges).

use std::io::{ErrorKind, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

use image::{GrayImage, ImageBuffer};
use serde::Deserialize;

use super::{SourceError, check_frame_limit};
use crate::io::recording::GrayFrame;

/// What `ffprobe` says of a video's first video stream.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoInfo {
    /// `(width, height)`, pixels.
    pub size: (u32, u32),
    /// Average frame rate, when the container states one.
    pub fps: Option<f64>,
    /// Frame count, when the container states one.
    pub frames: Option<usize>,
    /// More than 8 bits per sample (decoded to 16-bit gray).
    pub deep: bool,
    /// How the gray frames are made.
    pub gray: GrayFrom,
}

/// How a video's gray frames are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GrayFrom {
    /// FFmpeg converts the decoded frames (`-pix_fmt gray` or `gray16le`).
    Converted,
    /// The luma plane of an 8-bit planar YUV video, as FFmpeg decodes it; `limited` when its
    /// range is limited (16–235) and it is expanded to full range here.
    Luma { limited: bool },
}

/// 8-bit planar YUV formats in limited range unless the stream says otherwise.
const YUV_PLANAR: [&str; 6] = [
    "yuv420p", "yuv422p", "yuv444p", "yuv440p", "yuv411p", "yuv410p",
];
/// The same in full range (JPEG's "J" formats).
const YUV_FULL_PLANAR: [&str; 5] = ["yuvj420p", "yuvj422p", "yuvj444p", "yuvj440p", "yuvj411p"];

impl GrayFrom {
    /// The way for a stream of `pix_fmt` in `color_range` (ffprobe's words).
    fn of(pix_fmt: &str, color_range: Option<&str>, deep: bool) -> Self {
        if deep {
            Self::Converted
        } else if YUV_FULL_PLANAR.contains(&pix_fmt) {
            Self::Luma { limited: false }
        } else if YUV_PLANAR.contains(&pix_fmt) {
            Self::Luma {
                limited: color_range != Some("pc"),
            }
        } else {
            Self::Converted
        }
    }
}

/// Limited-range luma to full-range gray in place: `round((Y − 16) · 255 / 219)`, clamped (no
/// value lies at a half: 255 / 219 = 85 / 73 and 2 · 85 · k is never 73 modulo 146).
/// Arithmetic rather than a table, so that the compiler makes it 16 samples a step.
fn expand_limited_range(samples: &mut [u8]) {
    for sample in samples {
        let v = u16::from((*sample).clamp(16, 235)) - 16;
        *sample = ((v * 255 + 109) / 219) as u8;
    }
}

/// The pipe's capacity asked for: room for a few frames, so that FFmpeg and the reading thread
/// wake each other once a frame or less rather than every 64 KiB (Linux's default; an
/// unprivileged process may ask up to `/proc/sys/fs/pipe-max-size`, 1 MiB by default).
#[cfg(target_os = "linux")]
const PIPE_BYTES: usize = 1 << 20;

#[derive(Debug, Deserialize)]
struct ProbeOutput {
    #[serde(default)]
    streams: Vec<ProbeStream>,
}

#[derive(Debug, Deserialize)]
struct ProbeStream {
    width: Option<u32>,
    height: Option<u32>,
    avg_frame_rate: Option<String>,
    nb_frames: Option<String>,
    bits_per_raw_sample: Option<String>,
    pix_fmt: Option<String>,
    color_range: Option<String>,
}

fn run_error(program: &str, path: &Path, error: &std::io::Error) -> SourceError {
    if error.kind() == ErrorKind::NotFound {
        SourceError::FfmpegMissing {
            program: program.to_string(),
        }
    } else {
        SourceError::Video {
            path: path.to_path_buf(),
            message: format!("cannot run {program}: {error}"),
        }
    }
}

/// `"30000/1001"` as a number; `None` for `0/0` and the like.
fn ratio(text: &str) -> Option<f64> {
    let (n, d) = text.split_once('/').unwrap_or((text, "1"));
    let value = n.trim().parse::<f64>().ok()? / d.trim().parse::<f64>().ok()?;
    (value.is_finite() && value > 0.0).then_some(value)
}

/// Reads a video's stream information with `ffprobe`.
///
/// # Errors
/// [`SourceError::FfmpegMissing`] without ffprobe; [`SourceError::Video`] when the file has no
/// readable video stream; [`SourceError::TooLarge`] above the frame limit (`camera` names it).
pub fn probe(path: &Path, camera: &str) -> Result<VideoInfo, SourceError> {
    // A command opens a recording several times (learning its limits, then tracking): one
    // ffprobe a file, its answer kept while the file is unchanged (ffprobe's start-up alone
    // is 0.1–0.2 s).
    static PROBED: Mutex<Vec<(PathBuf, FileStamp, VideoInfo)>> = Mutex::new(Vec::new());
    let stamp = FileStamp::of(path);
    if let Some(stamp) = &stamp
        && let Ok(probed) = PROBED.lock()
        && let Some((_, _, info)) = probed.iter().find(|(p, s, _)| p == path && s == stamp)
    {
        check_frame_limit(camera, info.size)?;
        return Ok(info.clone());
    }
    let info = probe_afresh(path, camera)?;
    if let (Some(stamp), Ok(mut probed)) = (stamp, PROBED.lock()) {
        probed.retain(|(p, _, _)| p != path);
        probed.push((path.to_path_buf(), stamp, info.clone()));
    }
    Ok(info)
}

/// A file's length and modification time: a file probed before and unchanged since.
#[derive(Debug, Clone, PartialEq)]
struct FileStamp {
    len: u64,
    modified: std::time::SystemTime,
}

impl FileStamp {
    fn of(path: &Path) -> Option<Self> {
        let metadata = std::fs::metadata(path).ok()?;
        Some(Self {
            len: metadata.len(),
            modified: metadata.modified().ok()?,
        })
    }
}

fn probe_afresh(path: &Path, camera: &str) -> Result<VideoInfo, SourceError> {
    let output = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-show_entries"])
        .arg("stream=width,height,avg_frame_rate,nb_frames,bits_per_raw_sample,pix_fmt,color_range")
        .args(["-of", "json"])
        .arg(path)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| run_error("ffprobe", path, &e))?;
    let video_error = |message: String| SourceError::Video {
        path: path.to_path_buf(),
        message,
    };
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        return Err(video_error(format!(
            "not a video FFmpeg can read: {}",
            first_line(&stderr)
        )));
    }
    let parsed: ProbeOutput = serde_json::from_slice(&output.stdout)
        .map_err(|e| video_error(format!("unexpected ffprobe output: {e}")))?;
    let stream = parsed
        .streams
        .into_iter()
        .next()
        .ok_or_else(|| video_error("no video stream".to_string()))?;
    let (Some(width), Some(height)) = (stream.width, stream.height) else {
        return Err(video_error("video stream without a frame size".to_string()));
    };
    if width == 0 || height == 0 {
        return Err(video_error(format!("frame size {width}x{height}")));
    }
    check_frame_limit(camera, (width, height))?;
    let bits = stream
        .bits_per_raw_sample
        .as_deref()
        .and_then(|b| b.parse::<u32>().ok());
    let pix_fmt = stream.pix_fmt.unwrap_or_default();
    let deep =
        bits.is_some_and(|b| b > 8) || ["10", "12", "14", "16"].iter().any(|d| pix_fmt.contains(d));
    Ok(VideoInfo {
        size: (width, height),
        fps: stream.avg_frame_rate.as_deref().and_then(ratio),
        frames: stream.nb_frames.as_deref().and_then(|n| n.parse().ok()),
        deep,
        gray: GrayFrom::of(&pix_fmt, stream.color_range.as_deref(), deep),
    })
}

fn first_line(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("no message")
        .to_string()
}

/// What the thread reading FFmpeg's output hands on.
enum Piece {
    /// The next whole frame.
    Frame(GrayFrame),
    /// The output ended cleanly between frames.
    End,
    /// The output ended inside a frame: `filled` of `expected` bytes.
    Cut { filled: usize, expected: usize },
    /// Reading the pipe failed.
    Failed(String),
}

/// Bytes of frames read ahead per video at most, and their number at least and at most:
/// enough for FFmpeg to keep decoding while a batch of frames is detected (a 640×480 frame:
/// 64 frames; 1280×1024: 25; a 16-bit 45 MP frame: 2).
const READ_AHEAD_BYTES: usize = 32 << 20;
const READ_AHEAD_FRAMES: (usize, usize) = (2, 64);

/// A running decoder of one video. A thread of its own reads FFmpeg's output, so that FFmpeg
/// decodes on while the frames read before are detected (read in turn with the detection,
/// each FFmpeg stopped on a full pipe half of the time: notes/speed.md).
#[derive(Debug)]
pub struct VideoReader {
    path: PathBuf,
    info: VideoInfo,
    child: Child,
    frames: Receiver<Piece>,
    stderr: Option<JoinHandle<String>>,
    frames_read: usize,
    ended: bool,
}

impl VideoReader {
    /// Starts decoding a probed video with `threads` decoder threads (FFmpeg's `-threads`;
    /// [`decoder_threads`] shares the machine's cores between the videos read at once).
    ///
    /// # Errors
    /// [`SourceError::FfmpegMissing`] without ffmpeg, [`SourceError::Video`] otherwise.
    pub fn start(path: &Path, info: VideoInfo, threads: usize) -> Result<Self, SourceError> {
        let gray: &[&str] = match info.gray {
            GrayFrom::Luma { .. } => &["-vf", "extractplanes=y"],
            GrayFrom::Converted if info.deep => &["-pix_fmt", "gray16le"],
            GrayFrom::Converted => &["-pix_fmt", "gray"],
        };
        let mut child = Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-threads"])
            .arg(threads.max(1).to_string())
            .arg("-i")
            .arg(path)
            .args([
                "-map",
                "0:v:0",
                "-fps_mode",
                "passthrough",
                "-f",
                "rawvideo",
            ])
            .args(gray)
            .arg("-")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| run_error("ffmpeg", path, &e))?;
        let video_error = |message: &str| SourceError::Video {
            path: path.to_path_buf(),
            message: message.to_string(),
        };
        let stdout = child
            .stdout
            .take()
            .ok_or_else(|| video_error("ffmpeg gave no output pipe"))?;
        // Best effort: the default capacity works, only slower.
        #[cfg(target_os = "linux")]
        let _ = rustix::pipe::fcntl_setpipe_size(&stdout, PIPE_BYTES);
        // Drained on its own thread so that a chatty decoder never blocks on a full pipe.
        let stderr = child.stderr.take().map(|mut pipe| {
            std::thread::spawn(move || {
                let mut text = String::new();
                let _ = pipe.read_to_string(&mut text);
                text
            })
        });
        let (width, height) = info.size;
        let samples = width as usize * height as usize;
        let frame_bytes = samples * if info.deep { 2 } else { 1 };
        let depth =
            (READ_AHEAD_BYTES / frame_bytes.max(1)).clamp(READ_AHEAD_FRAMES.0, READ_AHEAD_FRAMES.1);
        let (sender, frames) = sync_channel(depth);
        let deep = info.deep;
        let expand = info.gray == (GrayFrom::Luma { limited: true });
        // The thread ends at the output's end, on an error, or when the reader is dropped
        // (its channel closes; FFmpeg is killed, which ends the pipe).
        std::thread::spawn(move || read_frames(stdout, (width, height), deep, expand, &sender));
        Ok(Self {
            path: path.to_path_buf(),
            info,
            child,
            frames,
            stderr,
            frames_read: 0,
            ended: false,
        })
    }

    /// The stream information.
    #[must_use]
    pub fn info(&self) -> &VideoInfo {
        &self.info
    }

    /// Frames decoded so far.
    #[must_use]
    pub fn frames_read(&self) -> usize {
        self.frames_read
    }

    /// The next frame; `None` at the end of the video.
    ///
    /// # Errors
    /// [`SourceError::Video`] when FFmpeg fails or stops inside a frame, with its message.
    pub fn next_frame(&mut self) -> Option<Result<GrayFrame, SourceError>> {
        if self.ended {
            return None;
        }
        let piece = self
            .frames
            .recv()
            .unwrap_or_else(|_| Piece::Failed("the reading thread stopped".to_string()));
        match piece {
            Piece::Frame(frame) => {
                self.frames_read += 1;
                Some(Ok(frame))
            }
            Piece::End => {
                self.ended = true;
                match self.finish() {
                    Ok(()) => None,
                    Err(e) => Some(Err(e)),
                }
            }
            Piece::Cut { filled, expected } => {
                self.ended = true;
                let _ = self.finish();
                Some(Err(self.error(&format!(
                    "frame {} ends after {filled} of {expected} bytes",
                    self.frames_read
                ))))
            }
            Piece::Failed(message) => {
                self.ended = true;
                let _ = self.child.kill();
                let _ = self.finish();
                Some(Err(
                    self.error(&format!("reading ffmpeg's output: {message}"))
                ))
            }
        }
    }

    fn error(&self, message: &str) -> SourceError {
        SourceError::Video {
            path: self.path.clone(),
            message: message.to_string(),
        }
    }

    /// Waits for ffmpeg and turns a failure into an error carrying its first message line.
    fn finish(&mut self) -> Result<(), SourceError> {
        let status = self
            .child
            .wait()
            .map_err(|e| self.error(&format!("waiting for ffmpeg: {e}")))?;
        let stderr = self
            .stderr
            .take()
            .and_then(|h| h.join().ok())
            .unwrap_or_default();
        if status.success() {
            Ok(())
        } else {
            Err(self.error(&format!(
                "ffmpeg failed after {} frames: {}",
                self.frames_read,
                first_line(&stderr)
            )))
        }
    }
}

/// Reads frames of `size` (16-bit little-endian samples when `deep`) from FFmpeg's output
/// until it ends, fails or `sender`'s receiver is gone; `expand`: limited-range luma, made
/// full-range gray. Each frame is read into a buffer of its exact size, not zeroed first
/// (`read_to_end` fills the spare capacity).
/// Decoder threads for each of `videos` videos read at once: the machine's cores shared
/// between them, at least one each. Frame-threaded decoders (MPEG-4, H.264) spend CPU on
/// handing frames between threads; with more decoders than cores that is pure loss (notes/speed.md).
#[must_use]
pub fn decoder_threads(videos: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    (cores / videos.max(1)).max(1)
}

fn read_frames(
    mut stdout: ChildStdout,
    size: (u32, u32),
    deep: bool,
    expand: bool,
    sender: &SyncSender<Piece>,
) {
    let (width, height) = size;
    let samples = width as usize * height as usize;
    let expected = samples * if deep { 2 } else { 1 };
    loop {
        let mut bytes = Vec::with_capacity(expected);
        let piece = match (&mut stdout).take(expected as u64).read_to_end(&mut bytes) {
            Err(e) => Piece::Failed(e.to_string()),
            Ok(0) => Piece::End,
            Ok(filled) if filled < expected => Piece::Cut { filled, expected },
            Ok(_) => {
                let frame = if deep {
                    let samples: Vec<u16> = bytes
                        .chunks_exact(2)
                        .map(|b| u16::from_le_bytes([b[0], b[1]]))
                        .collect();
                    ImageBuffer::from_raw(width, height, samples).map(GrayFrame::Sixteen)
                } else {
                    if expand {
                        expand_limited_range(&mut bytes);
                    }
                    GrayImage::from_raw(width, height, bytes).map(GrayFrame::Eight)
                };
                match frame {
                    Some(frame) => Piece::Frame(frame),
                    None => Piece::Failed("frame buffer of the wrong length".to_string()),
                }
            }
        };
        let last = !matches!(piece, Piece::Frame(_));
        if sender.send(piece).is_err() || last {
            return;
        }
    }
}

impl Drop for VideoReader {
    fn drop(&mut self) {
        if !self.ended {
            // Stopped early (an error elsewhere, Ctrl-C): end the decoder, reap it.
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_rates_read_as_ffprobe_writes_them() {
        assert_eq!(ratio("30/1"), Some(30.0));
        assert!((ratio("30000/1001").unwrap() - 29.97).abs() < 1e-3);
        assert_eq!(ratio("0/0"), None);
        assert_eq!(ratio("20"), Some(20.0));
    }
}
