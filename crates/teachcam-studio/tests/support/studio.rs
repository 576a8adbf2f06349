//! A studio on the simulated source, served on a loopback port by the test's runtime.
//!
//! Test support: a failure here is a failed test, so it panics with what went wrong.
#![allow(clippy::expect_used, clippy::unwrap_used, dead_code)]

use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;

use teachcam::sim::Scenario;
use teachcam::source::sim::SimConfig;
use teachcam::source::{SourceConfig, SourceSpec};
use teachcam_studio::server::{Event, Model, Studio, StudioConfig, api};

/// The studio's configuration for the paper's simulated rig, `cached_frames` rendered ahead
/// (fewer: faster to start, a shorter back-and-forth stroke), recordings into `out`.
pub fn sim_config(out: &Path, cached_frames: usize) -> StudioConfig {
    let sim = SimConfig {
        cached_frames,
        ..SimConfig::default()
    };
    let scene = teachcam::source::sim::scene(Scenario::Paper, &sim);
    StudioConfig {
        source: SourceSpec::Sim(Scenario::Paper),
        source_config: SourceConfig {
            sim,
            ..SourceConfig::default()
        },
        model: Model::Track {
            rig: scene.rig,
            tool: scene.tool,
        },
        truth: None,
        out: out.to_path_buf(),
        listen: SocketAddr::from(([127, 0, 0, 1], 0)),
        token_everywhere: false,
        wand: None,
    }
}

/// A studio started and served; its events collected.
pub struct Served {
    pub studio: Studio,
    pub address: SocketAddr,
    pub events: Arc<std::sync::Mutex<Vec<Event>>>,
}

impl Served {
    /// The page's address with the token.
    pub fn url(&self) -> String {
        self.studio.url(self.address)
    }
}

/// Starts `config` and serves it on a loopback port (inside a tokio runtime).
pub async fn serve(config: StudioConfig) -> Served {
    let events = Arc::new(std::sync::Mutex::new(Vec::new()));
    let sink = Arc::clone(&events);
    let studio = Studio::start(config, Arc::new(move |e| sink.lock().unwrap().push(e)))
        .expect("the studio starts");
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("a loopback port");
    let address = listener.local_addr().unwrap();
    studio.set_address(address);
    let app = api::router(studio.clone());
    tokio::spawn(async move { axum::serve(listener, app).await });
    Served {
        studio,
        address,
        events,
    }
}
