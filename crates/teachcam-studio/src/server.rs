//! The studio's web server: one frame pipeline on a thread of its own, an HTTP + WebSocket API
//! over it, and the page app served from the binary.
//!
//! ```text
//! FrameSource ─► Feed (paced, looped, last set kept) ─► TrackStream ─► pipeline thread
//!                                                                      ├─► Shared (status, take, controls, recorder)
//!                                                                      └─► watch<LiveMessage> ─► WebSocket /api/live
//! axum on tokio: /api/status, /api/scene, /api/controls, /api/record, /api/stop,
//!                /api/review, /api/robot, /api/export/{dialect}, /api/calibrate[/start|/save],
//!                the page and its scripts
//! ```
//! The core library is synchronous: the pipeline thread runs the library's conductor
//! ([`teachcam::pipeline::TrackStream`]) exactly as `teachcam live` does and never re-implements
//! a step. The live view keeps only the newest frame ([`tokio::sync::watch`]): a slow browser
//! skips frames instead of queueing them. Security is in [`security`]: loopback unless told
//! otherwise, a token, Origin checks on every state-changing request, bounded bodies, and no
//! path that reaches the filesystem.

pub mod api;
pub mod calibrate;
pub mod pipeline;
pub mod preview;
pub mod recorder;
pub mod review;
pub mod robot;
pub mod security;
pub mod state;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use teachcam::camera::Rig;
use teachcam::source::{SourceConfig, SourceSpec};
use teachcam::tool::Tool;
use teachcam::trajectory::Trajectory;

pub use state::Studio;

/// How to start the studio.
#[derive(Debug, Clone)]
pub struct StudioConfig {
    /// Where frames come from.
    pub source: SourceSpec,
    /// How to open it (rate, simulator and camera options).
    pub source_config: SourceConfig,
    /// What the frames are tracked with, or why they are only looked at.
    pub model: Model,
    /// The ground truth of a simulated recording (`truth.csv`), shown beside the review.
    pub truth: Option<Trajectory>,
    /// The folder recordings are written into (`take-001`, ...), created on the first record.
    pub out: PathBuf,
    /// Address to listen on; port 0 picks a free one.
    pub listen: SocketAddr,
    /// Whether every API request must carry the token (given `--listen`): off loopback anyone
    /// on the network could otherwise read the cameras.
    pub token_everywhere: bool,
    /// What the Calibrate tab calibrates with (`None`: the tab says how to give it).
    pub wand: Option<calibrate::WandSetup>,
}

/// What the frames are tracked with.
#[derive(Debug, Clone)]
pub enum Model {
    /// A rig and a tool: every set is tracked.
    Track {
        /// The rig the frames are tracked with.
        rig: Rig,
        /// The tracked tool.
        tool: Tool,
    },
    /// No rig (a recording without `rig.json`): the studio shows each camera's frames, its
    /// detections and what the detector measured of the images, and tracks nothing.
    ViewOnly {
        /// Why, said to the user (what is missing and how to give it).
        reason: String,
    },
}

impl StudioConfig {
    /// The rig and tool, when the frames are tracked.
    #[must_use]
    pub fn tracking(&self) -> Option<(&Rig, &Tool)> {
        match &self.model {
            Model::Track { rig, tool } => Some((rig, tool)),
            Model::ViewOnly { .. } => None,
        }
    }

    /// Why the studio only looks at the frames, when it does.
    #[must_use]
    pub fn view_only(&self) -> Option<&str> {
        match &self.model {
            Model::Track { .. } => None,
            Model::ViewOnly { reason } => Some(reason),
        }
    }
}

/// What the server tells its caller, who prints it.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Listening: the page's address with its token.
    Listening {
        /// `http://127.0.0.1:PORT/?token=...`.
        url: String,
    },
    /// A recording folder was written.
    Wrote {
        /// The folder.
        path: PathBuf,
        /// What it holds.
        summary: String,
    },
}

/// Why the studio could not run.
#[derive(Debug, thiserror::Error)]
pub enum StudioError {
    /// The frame source or pipeline could not start.
    #[error(transparent)]
    Pipeline(#[from] teachcam::pipeline::PipelineError),
    /// The address could not be bound, or the runtime failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// Starts the studio and serves until `stop` answers true (Ctrl-C in the command), then stops
/// the pipeline, finishes a recording in progress and returns. `events` hears the address and
/// every recording written.
///
/// # Errors
/// [`StudioError`] when the source cannot be opened or the address cannot be bound.
pub fn run(
    config: StudioConfig,
    stop: impl Fn() -> bool + Send + 'static,
    events: impl Fn(Event) + Send + Sync + 'static,
) -> Result<(), StudioError> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|source| StudioError::Io {
            what: "cannot start the async runtime".into(),
            source,
        })?;
    let events: Arc<dyn Fn(Event) + Send + Sync> = Arc::new(events);
    let studio = Studio::start(config.clone(), Arc::clone(&events))?;
    let serving = studio.clone();
    runtime.block_on(async move {
        let studio = serving;
        let listener = tokio::net::TcpListener::bind(config.listen)
            .await
            .map_err(|source| StudioError::Io {
                what: format!("cannot listen on {}", config.listen),
                source,
            })?;
        let address = listener.local_addr().map_err(|source| StudioError::Io {
            what: "cannot read the bound address".into(),
            source,
        })?;
        studio.set_address(address);
        events(Event::Listening {
            url: studio.url(address),
        });
        let app = api::router(studio.clone());
        let shutdown = {
            let studio = studio.clone();
            async move {
                while !stop() {
                    tokio::time::sleep(Duration::from_millis(100)).await;
                }
                studio.shut_down();
            }
        };
        axum::serve(
            listener,
            app.into_make_service_with_connect_info::<SocketAddr>(),
        )
        .with_graceful_shutdown(shutdown)
        .await
        .map_err(|source| StudioError::Io {
            what: "the server failed".into(),
            source,
        })
    })?;
    studio.finish();
    Ok(())
}
