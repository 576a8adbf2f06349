//! What `record`, `live` and `studio` share: the camera flags (`--fps`, `--exposure-ms`,
//! `--gain`) and the model flags (`--rig`, `--tool`) as flattened clap structs, the source
//! configuration built from them, the rig and tool to track a source with, and Ctrl-C or
//! SIGTERM as a request to stop after the frame set in hand.

use std::path::PathBuf;

use teachcam::camera::Rig;
use teachcam::source::{SourceConfig, SourceSpec};
use teachcam::tool::Tool;

/// True once Ctrl-C or SIGTERM asked `record`, `live` or `studio` to stop after the frame set
/// in hand (`signals`).
pub fn stop_requested() -> bool {
    crate::signals::stop_requested()
}

/// A `--source` value.
pub fn parse_source(text: &str) -> Result<SourceSpec, String> {
    text.parse()
        .map_err(|e: teachcam::source::SourceError| e.to_string())
}

/// How to run the cameras (the simulator's rate, a recording's playback rate).
#[derive(Debug, Clone, clap::Args)]
pub struct CameraFlags {
    /// Frames per second (the simulator's rate, the rate asked of cameras, a recording's rate).
    #[arg(long, value_parser = crate::flags::fps)]
    pub fps: Option<f64>,
    /// Cameras: manual exposure, milliseconds (where the driver allows).
    #[arg(long, value_parser = crate::flags::positive)]
    pub exposure_ms: Option<f64>,
    /// Cameras: analogue gain in the driver's units (where the driver allows).
    #[arg(long)]
    pub gain: Option<i32>,
}

impl CameraFlags {
    /// The source configuration: these flags, and a cap of `max_sets` sets or `seconds` of
    /// the source's rate, whichever comes first.
    pub fn source_config(
        &self,
        spec: &SourceSpec,
        seconds: Option<f64>,
        max_sets: Option<usize>,
    ) -> SourceConfig {
        let mut config = SourceConfig {
            fps: self.fps,
            ..SourceConfig::default()
        };
        config.v4l2.exposure_ms = self.exposure_ms;
        config.v4l2.gain = self.gain;
        let rate = match spec {
            SourceSpec::Sim(_) => Some(self.fps.unwrap_or(config.sim.fps)),
            _ => self.fps,
        };
        let from_seconds = seconds
            .zip(rate)
            .map(|(s, r)| (s * r).round().max(1.0) as usize);
        config.max_sets = match (max_sets, from_seconds) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        config
    }
}

/// The rig and tool a source is tracked with.
#[derive(Debug, Clone, clap::Args)]
pub struct ModelFlags {
    /// Camera rig (rig.json); the scenario's for sim sources, REC/rig.json for a recording.
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// Tool model (tool.json); the scenario's for sim sources, REC/tool.json for a recording.
    #[arg(long)]
    pub tool: Option<PathBuf>,
}

impl ModelFlags {
    /// The rig and tool: the files given, else a recording folder's own `rig.json` and
    /// `tool.json`, else the simulator scenario's.
    pub fn load(
        &self,
        source: &SourceSpec,
        sim: &teachcam::source::sim::SimConfig,
    ) -> anyhow::Result<(Rig, Tool)> {
        let beside = |name: &str, given: &Option<PathBuf>| match (given, source) {
            (Some(path), _) => Some(path.clone()),
            (None, SourceSpec::Folder(folder)) => Some(folder.join(name)),
            (None, _) => None,
        };
        let (rig, tool) = (
            beside("rig.json", &self.rig),
            beside("tool.json", &self.tool),
        );
        Ok(match (source, rig, tool) {
            (_, Some(rig), Some(tool)) => (crate::load::rig(&rig)?, crate::load::tool(&tool)?),
            (SourceSpec::Sim(scenario), rig, tool) => {
                let scene = teachcam::source::sim::scene(*scenario, sim);
                (
                    rig.as_deref()
                        .map(crate::load::rig)
                        .transpose()?
                        .unwrap_or(scene.rig),
                    tool.as_deref()
                        .map(crate::load::tool)
                        .transpose()?
                        .unwrap_or(scene.tool),
                )
            }
            _ => anyhow::bail!("--rig and --tool are needed for a camera or recording source"),
        })
    }
}
