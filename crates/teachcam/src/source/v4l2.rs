//! Live V4L2 cameras (Linux: UVC webcams, the PS3 Eye, most USB3 machine-vision cameras).
//!
//! Each device is opened in the order given (`cam0`, `cam1`, ...), asked for 8-bit gray
//! (`GREY`), else 16-bit gray (`Y16 `), else `YUYV` (its luma kept) or Motion-JPEG (decoded to
//! gray), at the size it has now; the frame interval, manual exposure and gain are set where the
//! driver accepts them (refusals are reported in [`V4l2Source::settings`], never fatal). One
//! thread per camera dequeues buffers and stamps each frame with this machine's monotonic clock
//! when it arrives; free-running cameras are paired by those times, nearest within half a period
//! ([`super::pairing`]). A camera whose consumer falls behind drops frames at its queue, counted.
//!
//! Tried by hand only (no camera on CI): `teachcam live --source v4l2:/dev/video0 --seconds 5`
//! prints the negotiated format and poses or gaps; `v4l2-ctl --list-devices` lists devices.

use std::path::PathBuf;

use super::{FrameSet, FrameSource, SourceCamera, SourceError, SourceStats};

/// Options of live cameras.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct V4l2Config {
    /// Frame rate asked of every camera (`None`: leave the driver's).
    pub fps: Option<f64>,
    /// Manual exposure, milliseconds (`None`: leave the driver's; markers want a short one).
    pub exposure_ms: Option<f64>,
    /// Analogue gain in the driver's units (`None`: leave the driver's).
    pub gain: Option<i32>,
    /// Stop after this many sets.
    pub max_sets: Option<usize>,
}

/// Live cameras, paired by arrival time.
#[derive(Debug)]
pub struct V4l2Source {
    cameras: Vec<SourceCamera>,
    fps: f64,
    settings: Vec<String>,
    #[cfg(target_os = "linux")]
    inner: linux::Capture,
}

impl V4l2Source {
    /// What each camera was set to, and which settings its driver refused, one line each.
    #[must_use]
    pub fn settings(&self) -> &[String] {
        &self.settings
    }
}

#[cfg(not(target_os = "linux"))]
impl V4l2Source {
    /// V4L2 exists on Linux only.
    ///
    /// # Errors
    /// Always [`SourceError::Device`].
    pub fn open(devices: &[PathBuf], _config: &V4l2Config) -> Result<Self, SourceError> {
        Err(SourceError::Device {
            device: devices
                .first()
                .map_or_else(String::new, |d| d.display().to_string()),
            message: "V4L2 cameras are available on Linux only".to_string(),
        })
    }
}

#[cfg(target_os = "linux")]
impl V4l2Source {
    /// Opens and starts every camera.
    ///
    /// # Errors
    /// [`SourceError::Device`] naming the device that cannot be opened or gives no usable
    /// format; [`SourceError::TooLarge`] above the frame limit.
    pub fn open(devices: &[PathBuf], config: &V4l2Config) -> Result<Self, SourceError> {
        let (inner, cameras, fps, settings) = linux::Capture::start(devices, config)?;
        Ok(Self {
            cameras,
            fps,
            settings,
            inner,
        })
    }
}

impl FrameSource for V4l2Source {
    fn cameras(&self) -> &[SourceCamera] {
        &self.cameras
    }

    fn fps(&self) -> f64 {
        self.fps
    }

    fn len_hint(&self) -> Option<usize> {
        None
    }

    fn is_live(&self) -> bool {
        true
    }

    fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>> {
        #[cfg(target_os = "linux")]
        {
            self.inner.next_set()
        }
        #[cfg(not(target_os = "linux"))]
        {
            None
        }
    }

    fn stats(&self) -> SourceStats {
        #[cfg(target_os = "linux")]
        {
            self.inner.stats()
        }
        #[cfg(not(target_os = "linux"))]
        {
            SourceStats::default()
        }
    }
}

#[cfg(target_os = "linux")]
mod linux {
    use std::path::{Path, PathBuf};
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};
    use std::time::Instant;

    use image::{GrayImage, ImageBuffer};
    use linuxvideo::controls::Cid;
    use linuxvideo::format::{Format, PixFormat, PixelFormat};
    use linuxvideo::{BufType, Device, Fract};

    use super::super::pairing::{PairBy, Pairer};
    use super::super::{
        CameraFrame, FrameData, FrameSet, SourceCamera, SourceError, SourceStats, check_frame_limit,
    };
    use super::V4l2Config;
    use crate::io::recording::GrayFrame;

    const GREY: PixelFormat = PixelFormat::from_fourcc(*b"GREY");
    const Y16: PixelFormat = PixelFormat::from_fourcc(*b"Y16 ");

    /// Frames per camera the queue holds before dropping (a driver's buffer count).
    const QUEUE_FRAMES: usize = 4;

    #[derive(Debug)]
    enum Message {
        Frame(usize, CameraFrame),
        Failed(usize, String),
    }

    #[derive(Debug)]
    pub(super) struct Capture {
        frames: Receiver<Message>,
        pairer: Pairer,
        start: Instant,
        next_index: usize,
        max_sets: Option<usize>,
        dropped: Arc<AtomicUsize>,
        names: Vec<String>,
    }

    fn device_error(device: &Path, message: impl std::fmt::Display) -> SourceError {
        SourceError::Device {
            device: device.display().to_string(),
            message: message.to_string(),
        }
    }

    /// The format a driver agreed to.
    #[derive(Debug, Clone, Copy)]
    struct Negotiated {
        width: u32,
        height: u32,
        stride: u32,
        pixel_format: PixelFormat,
    }

    /// Gray samples of one buffer in the negotiated format.
    fn to_gray(format: &Negotiated, data: &[u8]) -> Option<GrayFrame> {
        let (w, h) = (format.width, format.height);
        let stride = format.stride.max(1) as usize;
        let pixel_format = format.pixel_format;
        if pixel_format == GREY {
            let mut samples = Vec::with_capacity(w as usize * h as usize);
            for row in data.chunks(stride).take(h as usize) {
                samples.extend_from_slice(row.get(..w as usize)?);
            }
            GrayImage::from_raw(w, h, samples).map(GrayFrame::Eight)
        } else if pixel_format == Y16 {
            let mut samples = Vec::with_capacity(w as usize * h as usize);
            for row in data.chunks(stride).take(h as usize) {
                let row = row.get(..2 * w as usize)?;
                samples.extend(
                    row.chunks_exact(2)
                        .map(|b| u16::from_le_bytes([b[0], b[1]])),
                );
            }
            ImageBuffer::from_raw(w, h, samples).map(GrayFrame::Sixteen)
        } else if pixel_format == PixelFormat::YUYV {
            let mut samples = Vec::with_capacity(w as usize * h as usize);
            for row in data.chunks(stride).take(h as usize) {
                let row = row.get(..2 * w as usize)?;
                samples.extend(row.iter().step_by(2));
            }
            GrayImage::from_raw(w, h, samples).map(GrayFrame::Eight)
        } else if pixel_format == PixelFormat::MJPG || pixel_format == PixelFormat::JPEG {
            image::load_from_memory_with_format(data, image::ImageFormat::Jpeg)
                .ok()
                .map(|i| GrayFrame::Eight(i.to_luma8()))
        } else {
            None
        }
    }

    /// Opens one device, negotiates a gray-convertible format and applies the settings.
    fn open_device(
        device: &Path,
        config: &V4l2Config,
        settings: &mut Vec<String>,
    ) -> Result<(linuxvideo::stream::ReadStream, Negotiated, Option<f64>), SourceError> {
        let mut dev = Device::open(device).map_err(|e| device_error(device, e))?;
        let Format::VideoCapture(current) = dev
            .format(BufType::VIDEO_CAPTURE)
            .map_err(|e| device_error(device, e))?
        else {
            return Err(device_error(device, "not a video capture device"));
        };
        let offered: Vec<PixelFormat> = dev
            .formats(BufType::VIDEO_CAPTURE)
            .filter_map(Result::ok)
            .map(|f| f.pixel_format())
            .collect();
        let wanted = [GREY, Y16, PixelFormat::YUYV, PixelFormat::MJPG]
            .into_iter()
            .find(|f| offered.contains(f))
            .ok_or_else(|| {
                device_error(
                    device,
                    format!("offers none of GREY, Y16, YUYV, MJPG (offers {offered:?})"),
                )
            })?;
        let name = device.display();
        if let Some(ms) = config.exposure_ms {
            // V4L2_EXPOSURE_MANUAL = 1; the absolute exposure is in units of 100 µs.
            let manual = dev.write_control_raw(Cid::EXPOSURE_AUTO, 1);
            let absolute =
                dev.write_control_raw(Cid::EXPOSURE_ABSOLUTE, (ms * 10.0).round() as i32);
            settings.push(match (manual, absolute) {
                (Ok(()), Ok(())) => format!("{name}: exposure {ms} ms"),
                (m, a) => format!(
                    "{name}: exposure not set ({})",
                    m.err()
                        .or(a.err())
                        .map_or_else(String::new, |e| e.to_string())
                ),
            });
        }
        if let Some(gain) = config.gain {
            settings.push(match dev.write_control_raw(Cid::GAIN, gain) {
                Ok(()) => format!("{name}: gain {gain}"),
                Err(e) => format!("{name}: gain not set ({e})"),
            });
        }
        let capture = dev
            .video_capture(PixFormat::new(current.width(), current.height(), wanted))
            .map_err(|e| device_error(device, e))?;
        let agreed = capture.format();
        let format = Negotiated {
            width: agreed.width(),
            height: agreed.height(),
            stride: agreed.bytes_per_line(),
            pixel_format: agreed.pixel_format(),
        };
        check_frame_limit(&name.to_string(), (format.width, format.height))?;
        let mut fps = None;
        if let Some(asked) = config.fps {
            let denominator = 1000;
            let numerator = (f64::from(denominator) / asked).round().max(1.0) as u32;
            match capture.set_frame_interval(Fract::new(numerator, denominator)) {
                Ok(got) if got.numerator() > 0 => {
                    let rate = f64::from(got.denominator()) / f64::from(got.numerator());
                    settings.push(format!("{name}: {rate:.2} Hz (asked {asked} Hz)"));
                    fps = Some(rate);
                }
                Ok(_) => settings.push(format!("{name}: frame rate not reported")),
                Err(e) => settings.push(format!("{name}: frame rate not set ({e})")),
            }
        }
        settings.push(format!(
            "{name}: {}x{} {:?}",
            format.width, format.height, format.pixel_format
        ));
        let stream = capture.into_stream().map_err(|e| device_error(device, e))?;
        Ok((stream, format, fps))
    }

    fn run_camera(
        camera: usize,
        mut stream: linuxvideo::stream::ReadStream,
        format: Negotiated,
        start: Instant,
        sender: SyncSender<Message>,
        dropped: Arc<AtomicUsize>,
    ) {
        for frame in 0.. {
            let result = stream.dequeue(|buffer| {
                let arrived = Instant::now();
                Ok((to_gray(&format, &buffer), buffer.is_error(), arrived))
            });
            let message = match result {
                Ok((Some(image), false, arrived)) => Message::Frame(
                    camera,
                    CameraFrame {
                        frame,
                        time_s: arrived.duration_since(start).as_secs_f64(),
                        sequence: None,
                        data: FrameData::Decoded(Arc::new(image)),
                    },
                ),
                Ok((_, true, _)) => {
                    dropped.fetch_add(1, Ordering::Relaxed);
                    continue;
                }
                Ok((None, false, _)) => {
                    Message::Failed(camera, "a frame could not be read as gray".to_string())
                }
                Err(e) => Message::Failed(camera, e.to_string()),
            };
            let failed = matches!(message, Message::Failed(..));
            match sender.try_send(message) {
                Ok(()) => {}
                Err(TrySendError::Full(_)) => {
                    dropped.fetch_add(1, Ordering::Relaxed);
                }
                Err(TrySendError::Disconnected(_)) => return,
            }
            if failed {
                return;
            }
        }
    }

    impl Capture {
        pub(super) fn start(
            devices: &[PathBuf],
            config: &V4l2Config,
        ) -> Result<(Self, Vec<SourceCamera>, f64, Vec<String>), SourceError> {
            let mut settings = Vec::new();
            let mut opened = Vec::new();
            for device in devices {
                opened.push(open_device(device, config, &mut settings)?);
            }
            let fps = opened
                .iter()
                .filter_map(|(_, _, fps)| *fps)
                .fold(None, |slowest: Option<f64>, f| {
                    Some(slowest.map_or(f, |s| s.min(f)))
                })
                .or(config.fps)
                .unwrap_or(30.0);
            let cameras: Vec<SourceCamera> = opened
                .iter()
                .enumerate()
                .map(|(c, (_, format, _))| SourceCamera {
                    name: format!("cam{c}"),
                    size: Some((format.width, format.height)),
                })
                .collect();
            let names = devices.iter().map(|d| d.display().to_string()).collect();
            let (sender, frames) = sync_channel(QUEUE_FRAMES * devices.len().max(1));
            let dropped = Arc::new(AtomicUsize::new(0));
            let start = Instant::now();
            for (camera, (stream, format, _)) in opened.into_iter().enumerate() {
                let sender = sender.clone();
                let dropped = Arc::clone(&dropped);
                std::thread::spawn(move || {
                    run_camera(camera, stream, format, start, sender, dropped)
                });
            }
            let capture = Self {
                frames,
                pairer: Pairer::new(
                    cameras.len(),
                    PairBy::Timestamp {
                        period_s: 1.0 / fps,
                    },
                ),
                start,
                next_index: 0,
                max_sets: config.max_sets,
                dropped,
                names,
            };
            Ok((capture, cameras, fps, settings))
        }

        pub(super) fn next_set(&mut self) -> Option<Result<FrameSet, SourceError>> {
            if self.max_sets.is_some_and(|m| self.next_index >= m) {
                return None;
            }
            loop {
                if let Some(set) = self.pairer.pop() {
                    let first_s = set
                        .iter()
                        .flatten()
                        .map(|f| f.time_s)
                        .fold(f64::INFINITY, f64::min);
                    let exposed_at =
                        self.start + std::time::Duration::from_secs_f64(first_s.max(0.0));
                    let index = self.next_index;
                    self.next_index += 1;
                    return Some(Ok(FrameSet::new(index, Some(exposed_at), set)));
                }
                match self.frames.recv().ok()? {
                    Message::Frame(camera, frame) => self.pairer.push(camera, frame),
                    Message::Failed(camera, message) => {
                        return Some(Err(SourceError::Device {
                            device: self.names.get(camera).cloned().unwrap_or_default(),
                            message,
                        }));
                    }
                }
            }
        }

        pub(super) fn stats(&self) -> SourceStats {
            SourceStats {
                dropped_sets: self.dropped.load(Ordering::Relaxed),
                ..self.pairer.stats().clone()
            }
        }
    }
}
