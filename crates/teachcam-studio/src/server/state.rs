//! The studio's shared state: what the pipeline thread has seen, the controls the page set,
//! the take under review and the recording in progress.
//!
//! One mutex guards [`Live`]; the pipeline thread holds it for a few microseconds per frame
//! (counters, the take's new sample), the handlers to read a snapshot. The newest live frame
//! travels apart, through a [`watch`] channel that keeps only the last one.

use std::collections::VecDeque;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};
use std::time::Instant;

use axum::body::Bytes;
use teachcam::geometry::FrameIndex;
use teachcam::source::sim::SimExposure;
use teachcam::trajectory::{Sample, Status, Trajectory};
use tokio::sync::watch;

use super::recorder::Recorder;
use super::{Event, StudioConfig, StudioError};

/// The most samples the rolling take of a live source keeps: two minutes at 30 Hz.
pub const MAX_TAKE_SAMPLES: usize = 3600;

/// How the source's exposure can be changed.
#[derive(Debug, Clone)]
pub enum ExposureControl {
    /// The simulator: a scale of the rendered levels, applied at once.
    Sim(SimExposure),
    /// V4L2 cameras: the manual exposure in milliseconds, applied by reopening them.
    Camera,
    /// A recording: its exposure is what it was.
    Unsupported,
}

/// The controls the page sets.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Controls {
    /// A fixed detection threshold in the images' units, `None` for the detector's automatic
    /// one.
    pub threshold: Option<u32>,
    /// The cameras' manual exposure, ms (V4L2 sources), `None`: the driver's.
    pub exposure_ms: Option<f64>,
    /// Bumped on every change the pipeline must restart for.
    pub generation: u64,
}

/// One camera's latest counts, for the status.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct CameraCounts {
    /// The camera's name.
    pub name: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Blobs detected in its last frame.
    pub blobs: usize,
}

/// The frames the source dropped between the last one tracked (`(frame, time_s)`) and `next`,
/// as explicit gaps one frame period apart.
pub fn gaps_between(
    (last_frame, last_time_s): (usize, f64),
    next: FrameIndex,
    fps: f64,
) -> impl Iterator<Item = Sample> {
    (last_frame + 1..next.0).map(move |missing| {
        Sample::gap(
            FrameIndex(missing),
            last_time_s + (missing - last_frame) as f64 / fps,
        )
    })
}

/// The take under review: the samples of the last recording, of the last whole pass of a
/// recording played, or the last [`MAX_TAKE_SAMPLES`] of a live source.
#[derive(Debug, Clone, Default)]
pub struct Take {
    /// The samples, in frame order, gaps explicit.
    pub samples: VecDeque<Sample>,
    /// True once the take is complete (a recording stopped, a pass ended): new frames no
    /// longer change it.
    pub frozen: bool,
}

impl Take {
    /// Adds a tracked sample, with explicit gaps for the frames the source dropped.
    pub fn push(&mut self, sample: Sample, fps: f64) {
        if self.frozen {
            return;
        }
        if let Some((last_frame, last_time_s)) = self.samples.back().map(|s| (s.frame.0, s.time_s))
        {
            if sample.frame.0 <= last_frame {
                // A new pass of a recording or a restarted source: a new take.
                self.samples.clear();
            } else {
                self.samples
                    .extend(gaps_between((last_frame, last_time_s), sample.frame, fps));
            }
        }
        self.samples.push_back(sample);
        while self.samples.len() > MAX_TAKE_SAMPLES {
            self.samples.pop_front();
        }
    }

    /// How many of the take's frames have each status: the last whole pass of a recording
    /// (the pass so far during the first), `{"ok": N, "degraded": N, "outlier": N, "lost": N}`.
    #[must_use]
    pub fn statuses(&self) -> serde_json::Value {
        let count = |status: Status| self.samples.iter().filter(|s| s.status == status).count();
        serde_json::json!({
            "ok": count(Status::Ok),
            "degraded": count(Status::Degraded),
            "outlier": count(Status::Outlier),
            "lost": count(Status::Lost),
        })
    }

    /// The take as a trajectory whose frames count from 0 and whose time starts at 0.
    #[must_use]
    pub fn trajectory(&self) -> Trajectory {
        let first = self
            .samples
            .front()
            .map_or((0, 0.0), |s| (s.frame.0, s.time_s));
        Trajectory {
            samples: self
                .samples
                .iter()
                .map(|s| {
                    let mut s = *s;
                    s.frame = FrameIndex(s.frame.0 - first.0);
                    s.time_s -= first.1;
                    s
                })
                .collect(),
        }
    }
}

/// What the pipeline thread has seen and the page has set.
#[derive(Debug, Default)]
pub struct Live {
    /// Frame sets tracked so far.
    pub frames: u64,
    /// Of those, sets with a pose.
    pub posed: u64,
    /// Sets the source dropped because the pipeline was behind (current source).
    pub dropped: usize,
    /// Times of the last frames tracked, for the rate.
    pub recent: VecDeque<Instant>,
    /// The last frame's status (`ok`, `degraded`, `outlier`, `lost`) and reason.
    pub status: Option<(String, String)>,
    /// Per camera, the last frame's counts.
    pub cameras: Vec<CameraCounts>,
    /// The controls.
    pub controls: Controls,
    /// The take under review.
    pub take: Take,
    /// The recording in progress.
    pub recorder: Option<Recorder>,
    /// The recordings written, newest last.
    pub written: Vec<PathBuf>,
    /// The pipeline's last error, if it has one (cleared by the next good frame).
    pub error: Option<String>,
    /// Times a recording source has been played to its end.
    pub passes: usize,
    /// The source's nominal rate, Hz.
    pub source_fps: f64,
}

impl Live {
    /// Frames per second tracked over the last second or so.
    #[must_use]
    pub fn fps(&self) -> f64 {
        match (self.recent.front(), self.recent.back()) {
            (Some(first), Some(last)) if self.recent.len() > 1 => {
                let span = last.duration_since(*first).as_secs_f64();
                if span > 0.0 {
                    (self.recent.len() - 1) as f64 / span
                } else {
                    0.0
                }
            }
            _ => 0.0,
        }
    }

    /// Notes a frame tracked now.
    pub fn tick(&mut self, now: Instant) {
        self.recent.push_back(now);
        while self.recent.len() > 2 && now.duration_since(self.recent[0]).as_secs_f64() > 1.0 {
            self.recent.pop_front();
        }
    }
}

/// The studio: its configuration, token, state and pipeline thread (cheap to clone).
#[derive(Clone)]
pub struct Studio {
    inner: Arc<Inner>,
}

impl std::fmt::Debug for Studio {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Studio")
            .field("source", &self.inner.config.source.to_string())
            .finish_non_exhaustive()
    }
}

struct Inner {
    config: StudioConfig,
    token: String,
    address: OnceLock<SocketAddr>,
    live: Mutex<Live>,
    frames: watch::Sender<Option<Bytes>>,
    shutting_down: AtomicBool,
    stopped: watch::Sender<bool>,
    pipeline: Mutex<Option<std::thread::JoinHandle<()>>>,
    exposure: ExposureControl,
    events: Arc<dyn Fn(Event) + Send + Sync>,
    calibration: Mutex<super::calibrate::Job>,
}

impl Studio {
    /// Opens the source and starts the pipeline thread.
    ///
    /// # Errors
    /// [`StudioError::Pipeline`] when the source cannot be opened or lacks a rig camera.
    pub fn start(
        config: StudioConfig,
        events: Arc<dyn Fn(Event) + Send + Sync>,
    ) -> Result<Self, StudioError> {
        let opened = super::pipeline::open(&config)?;
        let (frames, _) = watch::channel(None);
        let (stopped, _) = watch::channel(false);
        let studio = Self {
            inner: Arc::new(Inner {
                token: super::security::new_token(),
                address: OnceLock::new(),
                live: Mutex::new(Live::default()),
                frames,
                shutting_down: AtomicBool::new(false),
                stopped,
                pipeline: Mutex::new(None),
                exposure: opened.exposure.clone(),
                events,
                config,
                calibration: Mutex::new(super::calibrate::Job::default()),
            }),
        };
        let thread = {
            let studio = studio.clone();
            std::thread::Builder::new()
                .name("studio-pipeline".into())
                .spawn(move || super::pipeline::run(&studio, opened))
                .map_err(|source| StudioError::Io {
                    what: "cannot start the pipeline thread".into(),
                    source,
                })?
        };
        *studio
            .inner
            .pipeline
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(thread);
        Ok(studio)
    }

    /// The Calibrate tab's calibration (never held across an await).
    pub fn calibration(&self) -> MutexGuard<'_, super::calibrate::Job> {
        self.inner
            .calibration
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The configuration it was started with.
    #[must_use]
    pub fn config(&self) -> &StudioConfig {
        &self.inner.config
    }

    /// The token every state-changing request carries.
    #[must_use]
    pub fn token(&self) -> &str {
        &self.inner.token
    }

    /// Records the address the server listens on (for the Origin checks).
    pub fn set_address(&self, address: SocketAddr) {
        let _ = self.inner.address.set(address);
    }

    /// The address the server listens on, once bound.
    #[must_use]
    pub fn address(&self) -> Option<SocketAddr> {
        self.inner.address.get().copied()
    }

    /// The page's address with the token.
    #[must_use]
    pub fn url(&self, address: SocketAddr) -> String {
        let host = if address.ip().is_unspecified() {
            SocketAddr::new(std::net::Ipv4Addr::LOCALHOST.into(), address.port())
        } else {
            address
        };
        format!("http://{host}/?token={}", self.inner.token)
    }

    /// The shared state, locked.
    pub fn live(&self) -> MutexGuard<'_, Live> {
        self.inner
            .live
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The live frames' channel (newest frame only).
    #[must_use]
    pub fn frames(&self) -> &watch::Sender<Option<Bytes>> {
        &self.inner.frames
    }

    /// How exposure is controlled on this source.
    #[must_use]
    pub fn exposure(&self) -> &ExposureControl {
        &self.inner.exposure
    }

    /// Tells the caller of [`super::run`] something.
    pub fn announce(&self, event: Event) {
        (self.inner.events)(event);
    }

    /// True once the studio is stopping.
    #[must_use]
    pub fn is_shutting_down(&self) -> bool {
        self.inner.shutting_down.load(Ordering::SeqCst)
    }

    /// A receiver that turns true when the studio stops (ends the WebSockets).
    #[must_use]
    pub fn stopped(&self) -> watch::Receiver<bool> {
        self.inner.stopped.subscribe()
    }

    /// Asks the pipeline and the WebSockets to stop.
    pub fn shut_down(&self) {
        self.inner.shutting_down.store(true, Ordering::SeqCst);
        self.inner.stopped.send_replace(true);
    }

    /// Stops, waits for the pipeline thread, and finishes a recording in progress.
    pub fn finish(&self) {
        self.shut_down();
        let thread = self
            .inner
            .pipeline
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .take();
        if let Some(thread) = thread {
            let _ = thread.join();
        }
        let recorder = self.live().recorder.take();
        if let Some(recorder) = recorder
            && let Ok(done) = recorder.finish()
        {
            self.announce(Event::Wrote {
                path: done.folder,
                summary: done.summary,
            });
        }
    }
}

impl Drop for Inner {
    fn drop(&mut self) {
        self.shutting_down.store(true, Ordering::SeqCst);
    }
}
