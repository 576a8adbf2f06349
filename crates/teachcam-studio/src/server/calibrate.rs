//! The Calibrate tab: a wand dance (the recording the studio was given, or one recorded here
//! with Record) calibrated by the library's `calibrate wand` ([`teachcam::calib::wand::run`]:
//! the same detection, views, adjustment and ground frame as the command), each camera's
//! coverage filled as the frames are detected, the result shown and the rig saved into the
//! output folder under a name the page confirms (an existing file only when told to
//! overwrite it). The work runs on tokio's blocking pool; the page polls `GET
//! /api/calibrate`. No path comes from the page: a recording is chosen by its id in the list
//! this module offers, a rig file by a plain name inside the output folder.

use std::path::{Path, PathBuf};

use axum::body::Bytes;
use axum::extract::State;
use serde_json::{Value, json};
use teachcam::calib::wand::run::{Coverage, WandRun, detect_wand_views, run_wand};
use teachcam::calib::wand::{Wand, WandConfig};
use teachcam::camera::Rig;
use teachcam::correspond::Views;
use teachcam::source::FrameSource as _;
use teachcam::source::folder::FolderSource;
use teachcam::tool::Tool;

use super::Studio;
use super::api::{cameras_json, parse_body};
use super::security::ApiError;

/// Cells across and down of each camera's coverage.
pub const COVERAGE_COLUMNS: usize = 8;
/// Cells down.
pub const COVERAGE_ROWS: usize = 6;

/// What the Calibrate tab calibrates with, given when the studio starts.
#[derive(Debug, Clone)]
pub struct WandSetup {
    /// The cameras' intrinsics (their extrinsics, if any, are ignored).
    pub cameras: Rig,
    /// The wand.
    pub wand: Wand,
    /// A wand dance given at start (`--wand-recording`).
    pub recording: Option<PathBuf>,
    /// The ground frame's marker layout (`--ground-tool`): its frame becomes the world.
    pub ground_tool: Option<Tool>,
    /// A recording of the ground frame given at start (`--ground`).
    pub ground: Option<PathBuf>,
    /// Nearest distance from a camera to a marker, millimetres (the detector's blob sizes).
    pub near_mm: f64,
    /// Farthest distance, millimetres.
    pub far_mm: f64,
}

/// Where a calibration stands.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// Nothing started.
    #[default]
    Idle,
    /// Detecting the wand dance's frames.
    Detecting,
    /// Detecting the ground frame's recording.
    DetectingGround,
    /// The adjustment runs.
    Calibrating,
    /// Calibrated: the result can be saved.
    Done,
    /// Failed: the error says why.
    Failed,
}

/// The calibration in progress or done.
#[derive(Debug, Default)]
pub struct Job {
    stage: Stage,
    recording: Option<String>,
    ground: Option<String>,
    frames_done: usize,
    frames_total: Option<usize>,
    coverage: Vec<Coverage>,
    result: Option<Value>,
    rig: Option<Rig>,
    error: Option<String>,
    saved: Vec<String>,
}

/// A recording the tab offers: its id, what it is and where.
struct Offered {
    id: String,
    what: &'static str,
    path: PathBuf,
}

/// The recordings the tab can calibrate from: the ones given at start, then those recorded in
/// this session.
fn offered(studio: &Studio, setup: &WandSetup) -> Vec<Offered> {
    let mut list = Vec::new();
    if let Some(path) = &setup.recording {
        list.push(Offered {
            id: "wand".into(),
            what: "the wand dance given (--wand-recording)",
            path: path.clone(),
        });
    }
    if let Some(path) = &setup.ground {
        list.push(Offered {
            id: "ground".into(),
            what: "the ground frame given (--ground)",
            path: path.clone(),
        });
    }
    for path in &studio.live().written {
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        list.push(Offered {
            id: name,
            what: "recorded in this session",
            path: path.clone(),
        });
    }
    list
}

/// Why there is no Calibrate tab: how to start the studio with one.
pub const NO_WAND_MESSAGE: &str = "no wand given: start the studio with --wand WAND.json (and --wand-cameras CAMERAS.json when it does not track with a rig; --wand-recording DIR for a dance already filmed; --ground-tool LFRAME.json and --ground DIR for the world)";

/// `GET /api/calibrate`: what can be calibrated, and the calibration's state.
pub async fn status(State(studio): State<Studio>) -> axum::Json<Value> {
    let Some(setup) = studio.config().wand.clone() else {
        return axum::Json(json!({"available": false, "reason": NO_WAND_MESSAGE}));
    };
    let recordings: Vec<Value> = offered(&studio, &setup)
        .iter()
        .map(|o| json!({"id": o.id, "what": o.what, "path": o.path.display().to_string()}))
        .collect();
    let job = studio.calibration();
    axum::Json(json!({
        "available": true,
        "wand": {"name": setup.wand.name, "markers_mm": setup.wand.markers_mm, "length_mm": setup.wand.length_mm()},
        "cameras": setup.cameras.cameras.iter().map(|c| c.name.clone()).collect::<Vec<_>>(),
        "ground_tool": setup.ground_tool.as_ref().map(|t| t.name.clone()),
        "world": match &setup.ground_tool {
            Some(tool) => format!("the ground frame '{tool}' lying on the work object sets the world (choose its recording)", tool = tool.name),
            None => "no ground frame (--ground-tool): the world is the first camera's frame".to_string(),
        },
        "recordings": recordings,
        "out": studio.config().out.display().to_string(),
        "stage": job.stage,
        "recording": job.recording,
        "ground": job.ground,
        "frames_done": job.frames_done,
        "frames_total": job.frames_total,
        "coverage": job.coverage,
        "result": job.result,
        "error": job.error,
        "saved": job.saved,
    }))
}

/// The body of `POST /api/calibrate/start`.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct StartBody {
    /// The wand dance's id among the offered recordings.
    recording: String,
    /// The ground frame's recording's id, when the world is to be set.
    ground: Option<String>,
}

/// `POST /api/calibrate/start`: detects the chosen dance (coverage filled frame by frame),
/// the ground frame's recording, and calibrates, off the async threads.
pub async fn start(
    State(studio): State<Studio>,
    body: Bytes,
) -> Result<axum::Json<Value>, ApiError> {
    let body: StartBody = parse_body(&body)?;
    let setup = studio
        .config()
        .wand
        .clone()
        .ok_or_else(|| ApiError::conflict(NO_WAND_MESSAGE))?;
    let list = offered(&studio, &setup);
    let find = |id: &str| {
        list.iter()
            .find(|o| o.id == id)
            .map(|o| o.path.clone())
            .ok_or_else(|| {
                ApiError::bad_request(format!(
                    "recording {id:?}: not offered (offered: {})",
                    list.iter()
                        .map(|o| o.id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })
    };
    let recording = find(&body.recording)?;
    let ground = match (&body.ground, &setup.ground_tool) {
        (Some(id), Some(tool)) => Some((find(id)?, tool.clone())),
        (Some(_), None) => {
            return Err(ApiError::bad_request(
                "a ground frame's recording needs its marker layout: start the studio with --ground-tool",
            ));
        }
        (None, _) => None,
    };
    {
        let mut job = studio.calibration();
        if matches!(
            job.stage,
            Stage::Detecting | Stage::DetectingGround | Stage::Calibrating
        ) {
            return Err(ApiError::conflict("a calibration is already running"));
        }
        let saved = std::mem::take(&mut job.saved);
        *job = Job {
            stage: Stage::Detecting,
            recording: Some(body.recording.clone()),
            ground: body.ground.clone(),
            coverage: setup
                .cameras
                .cameras
                .iter()
                .map(|c| Coverage::new(c, COVERAGE_COLUMNS, COVERAGE_ROWS))
                .collect(),
            saved,
            ..Job::default()
        };
    }
    let worker = studio.clone();
    tokio::task::spawn_blocking(move || {
        let outcome = calibrate(&worker, &setup, &recording, ground.as_ref());
        let mut job = worker.calibration();
        match outcome {
            Ok((run, frames)) => {
                job.result = Some(result_json(&run, &setup.wand, frames));
                job.rig = Some(run.rig);
                job.stage = Stage::Done;
            }
            Err(message) => {
                job.error = Some(message);
                job.stage = Stage::Failed;
            }
        }
    });
    Ok(axum::Json(json!({"stage": Stage::Detecting})))
}

/// The work of a calibration, on a blocking thread: the dance detected frame by frame into the
/// job's coverage, the ground frame's recording, the library's wand calibration.
fn calibrate(
    studio: &Studio,
    setup: &WandSetup,
    recording: &Path,
    ground: Option<&(PathBuf, Tool)>,
) -> Result<(WandRun, usize), String> {
    let markers = setup.wand.markers_mm.len();
    let detect = |folder: &Path, diameter_mm: f64, each: &mut dyn FnMut(&Views)| {
        let mut source =
            FolderSource::open(folder, None).map_err(|e| format!("{}: {e}", folder.display()))?;
        studio.calibration().frames_total = source.len_hint();
        detect_wand_views(
            &mut source,
            &setup.cameras,
            diameter_mm,
            setup.near_mm,
            setup.far_mm,
            each,
        )
        .map_err(|e| format!("{}: {e}", folder.display()))
    };
    let frames = detect(recording, setup.wand.marker_diameter_mm, &mut |views| {
        let mut job = studio.calibration();
        job.frames_done += 1;
        for (id, points) in views {
            if let Some(c) = job.coverage.get_mut(id.0) {
                c.add(points, markers);
            }
        }
    })?;
    let ground_frames = match ground {
        Some((folder, tool)) => {
            {
                let mut job = studio.calibration();
                job.stage = Stage::DetectingGround;
                job.frames_done = 0;
            }
            Some(detect(folder, tool.marker_diameter_mm, &mut |_| {
                studio.calibration().frames_done += 1;
            })?)
        }
        None => None,
    };
    studio.calibration().stage = Stage::Calibrating;
    let ground = ground_frames.as_deref().zip(ground.map(|(_, tool)| tool));
    let run = run_wand(
        &setup.cameras,
        &frames,
        &setup.wand,
        ground,
        &WandConfig::default(),
    )
    .map_err(|e| format!("{}: wand calibration: {e}", recording.display()))?;
    Ok((run, frames.len()))
}

/// The result as the page shows it: per-camera RMS, the wand length and its error, the lines
/// `calibrate wand` prints, and the rig's cameras for the 3-D view.
fn result_json(run: &WandRun, wand: &Wand, frames: usize) -> Value {
    let calibration = &run.calibration;
    let ground_tool = run.ground.as_ref().map_or("", |(name, _)| name.as_str());
    json!({
        "cameras": calibration.cameras.iter().map(|c| json!({
            "name": c.name,
            "frames": c.frames,
            "dropped": c.dropped,
            "rms_px": c.rms_px,
            "centre_std_mm": c.centre_std_mm,
            "rotation_std_deg": c.rotation_std_deg,
        })).collect::<Vec<_>>(),
        "frames": frames,
        "frames_used": calibration.frames_used,
        "frames_rejected": calibration.frames_rejected,
        "length_mm": wand.length_mm(),
        "length_mean_mm": calibration.length_mean_mm,
        "length_std_mm": calibration.length_std_mm,
        "length_error_percent": run.length_error_percent(wand),
        "length_error_rms_mm": calibration.length_rms_mm,
        "length_error_max_mm": calibration.length_max_mm,
        "converged": calibration.converged,
        "world": run.world(),
        "warning": run.ground_warning(ground_tool),
        "lines": run.lines(wand, frames),
        "rig": cameras_json(&run.rig),
    })
}

/// The body of `POST /api/calibrate/save`.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SaveBody {
    /// The file's name inside the output folder (`rig.json`).
    name: String,
    /// Replace a file of that name (the page asks first).
    #[serde(default)]
    overwrite: bool,
}

/// `POST /api/calibrate/save`: the calibrated rig written into the output folder as `name`
/// (`saved: true`); an existing file is left alone unless `overwrite` (`saved: false, exists:
/// true`: the page asks).
pub async fn save(
    State(studio): State<Studio>,
    body: Bytes,
) -> Result<axum::Json<Value>, ApiError> {
    let body: SaveBody = parse_body(&body)?;
    let plain = !body.name.is_empty()
        && body.name.len() <= 100
        && body.name.ends_with(".json")
        && !body.name.starts_with('.')
        && body
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
    if !plain {
        return Err(ApiError::bad_request(format!(
            "{:?}: a rig file's name is letters, digits, '.', '_' or '-', ending in .json (it is saved in the output folder)",
            body.name
        )));
    }
    let rig = studio
        .calibration()
        .rig
        .clone()
        .ok_or_else(|| ApiError::conflict("nothing calibrated yet: press Calibrate first"))?;
    let out = studio.config().out.clone();
    let path = out.join(&body.name);
    if path.exists() && !body.overwrite {
        // A question, not an error: the page asks before replacing the file.
        return Ok(axum::Json(json!({
            "saved": false,
            "exists": true,
            "path": path.display().to_string(),
            "message": format!("{} exists: overwrite it, or choose another name", path.display()),
        })));
    }
    let written = path.clone();
    tokio::task::spawn_blocking(move || {
        std::fs::create_dir_all(&out)
            .map_err(|e| format!("cannot create {}: {e}", out.display()))?;
        teachcam::io::rig::write_rig(&written, &rig).map_err(|e| e.to_string())
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))?
    .map_err(ApiError::internal)?;
    let text = path.display().to_string();
    studio.calibration().saved.push(text.clone());
    Ok(axum::Json(json!({"saved": true, "path": text})))
}
