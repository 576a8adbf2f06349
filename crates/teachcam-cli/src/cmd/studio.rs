//! `teachcam studio`: the local web app (cameras, 3-D view, record, review, robot, export).

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;

use anyhow::Context;
use teachcam::io::trajectory::read_trajectory;
use teachcam::source::SourceSpec;
use teachcam_studio::server::calibrate::WandSetup;
use teachcam_studio::server::{Event, Model, StudioConfig, StudioError, run as serve};

use crate::Rejected;
use crate::capture::{CameraFlags, ModelFlags, parse_source, stop_requested};

/// Open the studio: a local web app to aim the cameras, watch the tool in 3-D, record, review
/// the smoothing, check the path on a robot and download its program.
///
/// Serves one page (no network needed: three.js and uPlot are inside the binary) at the
/// printed address, `http://127.0.0.1:PORT/?token=...`; `--open` opens it in the browser.
/// The frames come from REC (a recording folder; its rig.json and tool.json are used), from
/// `--source` (the simulator `sim:paper` by default, or cameras `v4l2:/dev/video0,...` with
/// `--rig` and `--tool`), tracked as `teachcam live` tracks them; a recording is played at its
/// rate, again and again. Record / stop writes `take-001`, `take-002`, ... into `--out`.
/// A recording without rig.json (and no `--rig`), one camera or many, opens view-only: each
/// camera's frames, its detections and the detector's measured background, noise and
/// threshold, nothing tracked.
///
/// Calibrate (with `--wand`): a wand dance (`--wand-recording`, or one recorded with Record)
/// calibrated as `teachcam calibrate wand` calibrates it, each camera's coverage filling in as
/// its frames are detected, per-camera RMS and the wand length's error shown, the rig drawn
/// in 3-D and saved into `--out` under a name the page confirms; with `--ground-tool` (and
/// its recording, `--ground` or recorded) the world is the L-frame's.
///
/// The server listens on 127.0.0.1 only. `--listen ADDR` serves other machines, and every
/// request must then carry the printed token. Ctrl-C stops it (a recording in progress is
/// finished first). `GET /api/status` answers JSON with `source` and `frames` (processed so
/// far), among others.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam studio
  teachcam studio rec --port 8080 --open
  teachcam studio --source v4l2:/dev/video0,/dev/video2 --rig rig.json --tool rec/tool.json --out takes
  teachcam studio dance/ground --wand dance/wand.json --wand-cameras dance/cameras.json --wand-recording dance/wand --ground-tool dance/lframe.json --ground dance/ground"#)]
pub struct Args {
    /// A recording folder to play (its rig.json and tool.json unless --rig/--tool).
    pub recording: Option<PathBuf>,
    /// Where frames come from when no REC is given: sim:SCENARIO, v4l2:DEVICE[,DEVICE...],
    /// folder:REC.
    #[arg(long, value_parser = parse_source, conflicts_with = "recording")]
    pub source: Option<SourceSpec>,
    #[command(flatten)]
    pub model: ModelFlags,
    #[command(flatten)]
    pub camera: CameraFlags,
    /// Port on 127.0.0.1 (0: any free one).
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Listen on this address instead (IP or IP:PORT, e.g. 0.0.0.0:8080); every request must
    /// then carry the token.
    #[arg(long)]
    pub listen: Option<String>,
    /// Open the page in the default browser.
    #[arg(long)]
    pub open: bool,
    /// Folder the recordings are written into (and the Calibrate tab's rig files).
    #[arg(long, default_value = "studio-recordings")]
    pub out: PathBuf,
    #[command(flatten)]
    pub wand: WandFlags,
}

/// The Calibrate tab's inputs: as `calibrate wand` takes them.
#[derive(Debug, clap::Args)]
pub struct WandFlags {
    /// The wand, for the Calibrate tab: `{"name", "marker_diameter_mm", "markers_mm": [0, 160,
    /// 500]}` (without it the tab says how to give it).
    #[arg(long)]
    pub wand: Option<PathBuf>,
    /// The cameras' intrinsics for the Calibrate tab: a rig file whose extrinsics are ignored
    /// (default: the rig the studio tracks with).
    #[arg(long, requires = "wand")]
    pub wand_cameras: Option<PathBuf>,
    /// A wand dance already filmed (a recording folder), offered by the Calibrate tab beside
    /// the recordings made with Record.
    #[arg(long, requires = "wand")]
    pub wand_recording: Option<PathBuf>,
    /// The ground frame's tool file: a marker frame lying on the work object whose frame
    /// becomes the world (an L-frame).
    #[arg(long, requires = "wand")]
    pub ground_tool: Option<PathBuf>,
    /// A recording of the ground frame lying still, offered by the Calibrate tab.
    #[arg(long, requires = "ground_tool")]
    pub ground: Option<PathBuf>,
}

impl WandFlags {
    /// The Calibrate tab's setup, `None` without `--wand`; `tracked` is the studio's rig.
    fn setup(&self, tracked: Option<&teachcam::camera::Rig>) -> anyhow::Result<Option<WandSetup>> {
        let Some(wand) = &self.wand else {
            return Ok(None);
        };
        let wand = teachcam::io::wand::read_wand(wand).rejected()?;
        let cameras = match (&self.wand_cameras, tracked) {
            (Some(path), _) => teachcam::io::rig::read_cameras(path).rejected()?,
            (None, Some(rig)) => rig.clone(),
            (None, None) => anyhow::bail!(
                "--wand: the studio tracks with no rig here, so give the cameras' intrinsics with --wand-cameras CAMERAS.json"
            ),
        };
        for folder in [&self.wand_recording, &self.ground].into_iter().flatten() {
            anyhow::ensure!(folder.is_dir(), "{}: no such folder", folder.display());
        }
        let ground_tool = self
            .ground_tool
            .as_deref()
            .map(teachcam::io::tool::read_tool)
            .transpose()
            .rejected()?;
        Ok(Some(WandSetup {
            cameras,
            wand,
            recording: self.wand_recording.clone(),
            ground_tool,
            ground: self.ground.clone(),
            near_mm: WAND_NEAR_MM,
            far_mm: WAND_FAR_MM,
        }))
    }
}

/// `calibrate wand`'s default nearest distance from a camera to a marker, millimetres.
const WAND_NEAR_MM: f64 = 300.0;
/// `calibrate wand`'s default farthest distance, millimetres.
const WAND_FAR_MM: f64 = 3000.0;

/// The address to bind.
fn address(args: &Args) -> anyhow::Result<SocketAddr> {
    let Some(text) = &args.listen else {
        return Ok(SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), args.port));
    };
    if let Ok(address) = text.parse::<SocketAddr>() {
        return Ok(address);
    }
    let ip: IpAddr = text.parse().map_err(|_| {
        anyhow::anyhow!("--listen {text:?}: expected an IP address or IP:PORT (0.0.0.0:8080)")
    })?;
    Ok(SocketAddr::new(ip, args.port))
}

/// Run the command.
#[expect(
    clippy::print_stdout,
    reason = "the address is the command's output, even when quiet"
)]
pub fn run(args: &Args) -> anyhow::Result<()> {
    let listen = address(args)?;
    let source = match (&args.recording, &args.source) {
        (Some(folder), _) => SourceSpec::Folder(folder.clone()),
        (None, Some(source)) => source.clone(),
        (None, None) => SourceSpec::Sim(teachcam::sim::Scenario::Paper),
    };
    let source_config = args.camera.source_config(&source, None, None);
    let folder = match &source {
        SourceSpec::Folder(folder) => Some(folder.clone()),
        _ => None,
    };
    let model = match (&source, &args.model.rig) {
        // A recording without a rig: look at its frames and detections.
        (SourceSpec::Folder(folder), None) if !folder.join("rig.json").is_file() => {
            let reason = format!(
                "{} has no rig.json (give --rig RIG.json and --tool TOOL.json to track): its frames, detections and the detector's measured levels only",
                folder.display()
            );
            crate::announce::warn(&format!("view-only: {reason}"));
            Model::ViewOnly { reason }
        }
        _ => {
            let (rig, tool) = args.model.load(&source, &source_config.sim)?;
            Model::Track { rig, tool }
        }
    };
    let truth = match folder.map(|f| f.join("truth.csv")) {
        Some(path) if path.is_file() => Some(
            read_trajectory(&path)
                .rejected()
                .with_context(|| "the recording's truth")?,
        ),
        _ => None,
    };
    let open = args.open;
    let wand = args.wand.setup(match &model {
        Model::Track { rig, .. } => Some(rig),
        Model::ViewOnly { .. } => None,
    })?;
    let config = StudioConfig {
        source,
        source_config,
        model,
        truth,
        out: args.out.clone(),
        listen,
        token_everywhere: args.listen.is_some(),
        wand,
    };
    let events = move |event: Event| match event {
        Event::Listening { url } => {
            println!("teachcam studio: {url}");
            if open {
                open_browser(&url);
            }
        }
        Event::Wrote { path, summary } => crate::announce::wrote(&[path], &summary),
    };
    match serve(config, stop_requested, events) {
        Ok(()) => Ok(()),
        Err(e @ StudioError::Pipeline(_)) => Err(anyhow::Error::new(e)).rejected(),
        Err(e) => Err(e.into()),
    }
}

/// Opens `url` in the desktop's browser (xdg-open, open, or start); says so when none is found.
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else {
        "xdg-open"
    };
    if std::process::Command::new(opener)
        .arg(url)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .is_err()
    {
        crate::announce::warn(&format!(
            "cannot open a browser ({opener} not found): open {url}"
        ));
    }
}
