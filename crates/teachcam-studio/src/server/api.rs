//! The routes: the page and its scripts, and the JSON API over the pipeline's state.
//!
//! | route | what |
//! |---|---|
//! | `GET /` | the page app ([`crate::assets`]) |
//! | `GET /api/session` | `{token_ok, message}`: whether the page's token is this studio's (open without it; always 200) |
//! | `GET /api/status` | `{source, frames, posed, fps, cameras, recording, statuses, ...}` (`statuses`: the take's frames per status) |
//! | `GET /api/scene` | the rig's cameras (frusta), the tool model, the work object frame (none of them for a view-only studio) |
//! | `GET /api/live` (WebSocket) | the newest tracked frame, binary ([`super::preview`]) |
//! | `POST /api/controls` | `{"threshold": N \| "auto", "exposure": X}` |
//! | `POST /api/record`, `POST /api/stop` | a recording folder into the output folder, with the tracked take as `take.mcap` (ROS 2 bag) |
//! | `GET /api/review?cutoff_hz=X` | `{frames, cutoff_hz, figures}`: the take's review figures at that cut-off |
//! | `GET /api/robot?robot=&wobj=&tcp=&cutoff_hz=` | the take checked on a robot, joint path |
//! | `GET /api/export/{rapid\|krl\|krl-dat\|urscript}?...` | the robot program, as a download |
//! | `GET /api/calibrate` | the Calibrate tab: the wand, the recordings offered, the calibration's stage, coverage and result |
//! | `POST /api/calibrate/start` | `{"recording": ID, "ground": ID?}`: detect and calibrate, off the async threads |
//! | `POST /api/calibrate/save` | `{"name": "rig.json", "overwrite": false}`: the rig into the output folder, asked before replacing |

use std::time::Duration;

use axum::Router;
use axum::body::Bytes;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use serde_json::{Value, json};

use super::Studio;
use super::recorder::{Recorder, next_take};
use super::security::{ApiError, MAX_BODY_BYTES, SESSION_PATH, carries_token, guard};
use super::state::ExposureControl;
use crate::assets;

/// The studio's routes over `studio`.
pub fn router(studio: Studio) -> Router {
    Router::new()
        .route(
            "/",
            get(|| async { page(assets::STUDIO_HTML, "text/html; charset=utf-8") }),
        )
        .route("/studio.js", get(|| async { page(assets::STUDIO_JS, JS) }))
        .route(
            "/studio.css",
            get(|| async { page(assets::STUDIO_CSS, CSS) }),
        )
        .route(
            "/vendor/three/three.module.js",
            get(|| async { page(assets::THREE_MODULE_JS, JS) }),
        )
        .route(
            "/vendor/three/three.core.js",
            get(|| async { page(assets::THREE_CORE_JS, JS) }),
        )
        .route(
            "/vendor/three/OrbitControls.js",
            get(|| async { page(assets::ORBIT_CONTROLS_JS, JS) }),
        )
        .route(
            "/vendor/uplot/uPlot.iife.min.js",
            get(|| async { page(assets::UPLOT_JS, JS) }),
        )
        .route(
            "/vendor/uplot/uPlot.min.css",
            get(|| async { page(assets::UPLOT_CSS, CSS) }),
        )
        .route("/review.js", get(|| async { page(assets::REVIEW_JS, JS) }))
        .route(SESSION_PATH, get(session))
        .route("/api/status", get(status))
        .route("/api/scene", get(scene))
        .route("/api/live", get(live))
        .route("/api/controls", post(controls))
        .route("/api/record", post(record))
        .route("/api/stop", post(stop))
        .route("/api/review", get(super::review::review))
        .route("/api/robot", get(super::robot::robot))
        .route("/api/export/{dialect}", get(super::robot::export))
        .route("/api/calibrate", get(super::calibrate::status))
        .route("/api/calibrate/start", post(super::calibrate::start))
        .route("/api/calibrate/save", post(super::calibrate::save))
        .fallback(not_found)
        .layer(DefaultBodyLimit::max(MAX_BODY_BYTES))
        .layer(axum::middleware::map_response(json_errors))
        .layer(axum::middleware::from_fn_with_state(studio.clone(), guard))
        .with_state(studio)
}

const JS: &str = "text/javascript; charset=utf-8";
const CSS: &str = "text/css; charset=utf-8";

fn page(body: &'static str, content_type: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
        .into_response()
}

async fn not_found(uri: axum::http::Uri) -> ApiError {
    ApiError::new(
        StatusCode::NOT_FOUND,
        format!("{}: no such page or API", uri.path()),
    )
}

/// Turns the errors axum answers itself (413 body too large, 405, a bad query) into the
/// API's JSON form.
async fn json_errors(response: Response) -> Response {
    let status = response.status();
    let is_json = response
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/json"));
    if status.is_client_error() || status.is_server_error() {
        if is_json {
            return response;
        }
        let body = axum::body::to_bytes(response.into_body(), 4096)
            .await
            .unwrap_or_default();
        let text = String::from_utf8_lossy(&body);
        let message = match text.trim() {
            "" => status.canonical_reason().unwrap_or("error").to_lowercase(),
            text => text.to_string(),
        };
        return ApiError::new(status, message).into_response();
    }
    response
}

/// The request body as JSON of type `T`, with a one-line error naming the field.
pub fn parse_body<T: serde::de::DeserializeOwned>(body: &Bytes) -> Result<T, ApiError> {
    if body.is_empty() {
        return serde_json::from_str("{}").map_err(|e| ApiError::bad_request(e.to_string()));
    }
    serde_json::from_slice(body).map_err(|e| ApiError::bad_request(format!("request body: {e}")))
}

/// What a page opened without the token is told (the token is printed, never served).
pub const NO_TOKEN_MESSAGE: &str = "This page was opened without the studio's token (a bookmark, another tab, or a studio since restarted). Open the address `teachcam studio` printed when it started, http://127.0.0.1:PORT/?token=…; a new token is made each time the studio starts.";

/// `GET /api/session`: 200 either way (a refused request would be an error in the page's
/// console), `token_ok` false with the message that says how to open the page.
async fn session(
    State(studio): State<Studio>,
    headers: axum::http::HeaderMap,
    uri: axum::http::Uri,
) -> axum::Json<Value> {
    let token_ok = carries_token(&studio, &headers, uri.query());
    axum::Json(json!({
        "token_ok": token_ok,
        "message": if token_ok { "" } else { NO_TOKEN_MESSAGE },
    }))
}

async fn status(State(studio): State<Studio>) -> axum::Json<Value> {
    axum::Json(status_json(&studio))
}

/// The status document.
#[must_use]
pub fn status_json(studio: &Studio) -> Value {
    let config = studio.config();
    let live = studio.live();
    let exposure = match studio.exposure() {
        ExposureControl::Sim(handle) => {
            json!({"supported": true, "unit": "scale", "value": handle.scale(), "max": teachcam::source::sim::SimExposure::MAX_SCALE})
        }
        ExposureControl::Camera => {
            json!({"supported": true, "unit": "ms", "value": live.controls.exposure_ms})
        }
        ExposureControl::Unsupported => {
            json!({"supported": false, "reason": "a recording's exposure is fixed"})
        }
    };
    json!({
        "source": config.source.to_string(),
        "frames": live.frames,
        "posed": live.posed,
        "dropped": live.dropped,
        "fps": (live.fps() * 100.0).round() / 100.0,
        "source_fps": live.source_fps,
        "cameras": live.cameras,
        "rig_cameras": config.tracking().map_or(0, |(rig, _)| rig.len()),
        "view_only": config.view_only(),
        "status": live.status.as_ref().map(|(s, _)| s),
        "reason": live.status.as_ref().map(|(_, r)| r),
        "threshold": live.controls.threshold.map_or(json!("auto"), |t| json!(t)),
        "exposure": exposure,
        "recording": live.recorder.is_some(),
        "recording_frames": live.recorder.as_ref().map(|r| r.queued),
        "recording_folder": live.recorder.as_ref().map(|r| r.target().display().to_string()),
        "recordings": live.written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "take_frames": live.take.samples.len(),
        "statuses": live.take.statuses(),
        "take_complete": live.take.frozen,
        "passes": live.passes,
        "error": live.error,
        "token_everywhere": config.token_everywhere,
        "version": env!("CARGO_PKG_VERSION"),
    })
}

async fn scene(State(studio): State<Studio>) -> axum::Json<Value> {
    let config = studio.config();
    let Some((rig, tool)) = config.tracking() else {
        return axum::Json(json!({
            "units": "mm",
            "cameras": [],
            "tool": null,
            "view_only": config.view_only(),
        }));
    };
    let cameras = cameras_json(rig);
    let tip = tool.tool_from_tcp.translation.vector;
    axum::Json(json!({
        "units": "mm",
        "cameras": cameras,
        "tool": {
            "name": tool.name,
            "marker_diameter_mm": tool.marker_diameter_mm,
            "markers_mm": tool.markers_in_tool.iter().map(|m| [m.x, m.y, m.z]).collect::<Vec<_>>(),
            "tip_mm": [tip.x, tip.y, tip.z],
        },
        "wobj": {"position_mm": [0.0, 0.0, 0.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
    }))
}

/// The fields of `POST /api/controls` (absent fields stay as they are).
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ControlsBody {
    /// A level in the images' units, or `"auto"`.
    threshold: Option<Value>,
    /// The simulator's exposure scale, or the cameras' exposure in ms (`null`: the driver's).
    #[serde(default, with = "serde_with_null")]
    exposure: Option<Option<f64>>,
}

/// Absent → `None`, `null` → `Some(None)`, a value → `Some(Some(v))`.
mod serde_with_null {
    use serde::{Deserialize, Deserializer};

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Option<f64>>, D::Error> {
        Option::<f64>::deserialize(d).map(Some)
    }
}

async fn controls(
    State(studio): State<Studio>,
    body: Bytes,
) -> Result<axum::Json<Value>, ApiError> {
    let body: ControlsBody = parse_body(&body)?;
    let threshold = match &body.threshold {
        None => None,
        Some(Value::String(s)) if s == "auto" => Some(None),
        Some(Value::Number(n)) => match n.as_u64() {
            Some(level @ 1..=65534) => Some(Some(level as u32)),
            _ => {
                return Err(ApiError::bad_request(format!(
                    "threshold {n}: expected a whole level from 1 to 65534, or \"auto\""
                )));
            }
        },
        Some(other) => {
            return Err(ApiError::bad_request(format!(
                "threshold {other}: expected a whole level from 1 to 65534, or \"auto\""
            )));
        }
    };
    let mut restart = false;
    if let Some(exposure) = body.exposure {
        match (studio.exposure(), exposure) {
            (ExposureControl::Sim(handle), Some(scale)) => {
                handle.set_scale(scale).ok_or_else(|| {
                    ApiError::bad_request(format!(
                        "exposure {scale}: the simulator's exposure scale must be in (0, {}]",
                        teachcam::source::sim::SimExposure::MAX_SCALE
                    ))
                })?;
            }
            (ExposureControl::Sim(_), None) => {
                return Err(ApiError::bad_request(
                    "exposure null: the simulator's exposure is a scale (1: as rendered)",
                ));
            }
            (ExposureControl::Camera, ms) => {
                if let Some(ms) = ms
                    && !(ms.is_finite() && ms > 0.0 && ms <= 10_000.0)
                {
                    return Err(ApiError::bad_request(format!(
                        "exposure {ms}: expected milliseconds in (0, 10000]"
                    )));
                }
                studio.live().controls.exposure_ms = ms;
                restart = true;
            }
            (ExposureControl::Unsupported, _) => {
                return Err(ApiError::conflict(format!(
                    "{}: a recording's exposure cannot be changed",
                    studio.config().source
                )));
            }
        }
    }
    {
        let mut live = studio.live();
        if let Some(threshold) = threshold
            && live.controls.threshold != threshold
        {
            live.controls.threshold = threshold;
            restart = true;
        }
        if restart {
            live.controls.generation += 1;
        }
    }
    Ok(axum::Json(status_json(&studio)))
}

async fn record(State(studio): State<Studio>) -> Result<axum::Json<Value>, ApiError> {
    let config = studio.config();
    let mut live = studio.live();
    if let Some(recorder) = &live.recorder {
        return Err(ApiError::conflict(format!(
            "already recording into {}",
            recorder.target().display()
        )));
    }
    let fps = if live.source_fps > 0.0 {
        live.source_fps
    } else {
        teachcam::io::recording::DEFAULT_FPS
    };
    let Some((rig, tool)) = config.tracking() else {
        return Err(ApiError::conflict(format!(
            "nothing is tracked, so nothing is recorded: {}",
            config.view_only().unwrap_or_default()
        )));
    };
    let target = next_take(&config.out);
    let recorder =
        Recorder::start(&target, rig, tool, fps).map_err(|e| ApiError::internal(e.to_string()))?;
    live.recorder = Some(recorder);
    live.take = super::state::Take::default();
    Ok(axum::Json(json!({
        "recording": true,
        "folder": target.display().to_string(),
    })))
}

async fn stop(State(studio): State<Studio>) -> Result<axum::Json<Value>, ApiError> {
    let recorder = {
        let mut live = studio.live();
        let recorder = live
            .recorder
            .take()
            .ok_or_else(|| ApiError::conflict("not recording"))?;
        live.take.frozen = true;
        recorder
    };
    let written = tokio::task::spawn_blocking(move || recorder.finish())
        .await
        .map_err(|e| ApiError::internal(format!("the recording's writer failed: {e}")))?
        .map_err(|e| ApiError::internal(e.to_string()))?;
    studio.live().written.push(written.folder.clone());
    studio.announce(super::Event::Wrote {
        path: written.folder.clone(),
        summary: written.summary.clone(),
    });
    Ok(axum::Json(json!({
        "recording": false,
        "folder": written.folder.display().to_string(),
        "frames": written.frames,
        "dropped": written.dropped,
        "mcap": written.mcap.display().to_string(),
        "tool_messages": written.tool_messages,
    })))
}

async fn live(State(studio): State<Studio>, upgrade: WebSocketUpgrade) -> Response {
    upgrade
        .max_message_size(MAX_BODY_BYTES)
        .on_upgrade(move |socket| send_frames(studio, socket))
}

/// Sends each new frame as it comes; a frame replaced before it could be sent is skipped.
async fn send_frames(studio: Studio, mut socket: WebSocket) {
    let mut frames = studio.frames().subscribe();
    let mut stopped = studio.stopped();
    // The newest frame at once, so that a page opened on a paused source shows something.
    let first = frames.borrow_and_update().clone();
    if let Some(message) = first
        && socket.send(Message::Binary(message)).await.is_err()
    {
        return;
    }
    loop {
        tokio::select! {
            changed = frames.changed() => {
                if changed.is_err() {
                    break;
                }
                let message = frames.borrow_and_update().clone();
                if let Some(message) = message
                    && socket.send(Message::Binary(message)).await.is_err()
                {
                    break;
                }
            }
            _ = stopped.changed() => break,
            incoming = socket.recv() => {
                if !matches!(incoming, Some(Ok(Message::Ping(_) | Message::Pong(_) | Message::Text(_) | Message::Binary(_)))) {
                    break;
                }
            }
            () = tokio::time::sleep(Duration::from_secs(30)) => {
                if socket.send(Message::Ping(Bytes::new())).await.is_err() {
                    break;
                }
            }
        }
    }
    let _ = socket.send(Message::Close(None)).await;
}

/// A rig's cameras as the 3-D view draws them: name, image size, intrinsics, the camera's
/// position and rotation in the world (columns: the camera's x, y, z axes), millimetres.
#[must_use]
pub fn cameras_json(rig: &teachcam::camera::Rig) -> Vec<Value> {
    rig.iter()
        .map(|(_, c)| {
            let world_from_camera = c.camera_from_world.inverse();
            let r = world_from_camera.rotation.to_rotation_matrix();
            let m = r.matrix();
            let t = world_from_camera.translation.vector;
            json!({
                "name": c.name,
                "width": c.image_size.width,
                "height": c.image_size.height,
                "fx": c.intrinsics.fx, "fy": c.intrinsics.fy,
                "cx": c.intrinsics.cx, "cy": c.intrinsics.cy,
                "position_mm": [t.x, t.y, t.z],
                "rotation": [[m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                             [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                             [m[(2, 0)], m[(2, 1)], m[(2, 2)]]],
            })
        })
        .collect()
}
