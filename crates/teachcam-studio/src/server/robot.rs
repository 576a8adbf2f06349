//! The take on a robot: the library's robot check (reach, joint limits, speeds, a suggested
//! work object), the arm's links along the checked joint path for the 3-D view, and the
//! program as RAPID, KRL or URScript (the library's writers, as `teachcam export` uses them).
//!
//! The path is the take's tip trajectory, outliers dropped and smoothed by the zero-phase
//! low-pass at the review's cut-off (runs too short for the filter become gaps).

use axum::extract::{Path, Query, State};
use axum::http::header;
use axum::response::{IntoResponse, Response};
use serde_json::{Value, json};
use teachcam::geometry::{Pose, parse_pose};
use teachcam::report::smooth_for_review;
use teachcam::robot::check::{CheckConfig, CheckReport, Suggestion, issue_ranges};
use teachcam::robot::checked::{PathError, PathOptions, checked_path};
use teachcam::robot::kinematics::models::KNOWN_ROBOTS;
use teachcam::robot::kinematics::{Maker, Robot, link_points};
use teachcam::robot::krl::{krl_name_problem, krl_program};
use teachcam::robot::program::build_stroke_program;
use teachcam::robot::rapid::{RapidConfig, rapid_module};
use teachcam::robot::simplify::SimplifyConfig;
use teachcam::robot::strokes::StrokeConfig;
use teachcam::robot::urscript::{UrScriptConfig, urscript_program};
use teachcam::robot::{Cell, pose_text, tcp_targets};
use teachcam::trajectory::Trajectory;

use super::Studio;
use super::review;
use super::security::ApiError;

/// The cut-off used when the page gives none: the paper's 10 Hz.
pub const DEFAULT_CUTOFF_HZ: f64 = 10.0;

/// The most frames of the joint path sent for the 3-D view (the check covers them all).
const MAX_PATH_FRAMES: usize = 600;

/// The query of `/api/robot` and `/api/export/...`.
#[derive(Debug, Default, serde::Deserialize)]
pub struct RobotQuery {
    /// `irb120`, `kr6-r700`, `kr6-r900`, `ur5e`, `ur10e`.
    robot: Option<String>,
    /// The work object in the robot's base, `x,y,z,qw,qx,qy,qz`; absent, empty or `auto`: at
    /// the base (identity), or the check's suggested one when the path fails there.
    wobj: Option<String>,
    /// The TCP in the maker's flange frame, `x,y,z,qw,qx,qy,qz`.
    tcp: Option<String>,
    /// The smoothing cut-off, Hz.
    cutoff_hz: Option<String>,
    /// `true`: write the program even when the check fails.
    force: Option<String>,
    /// Start of the span checked, seconds of the take's time (as `export --from`).
    from_s: Option<String>,
    /// End of the span, seconds (`export --to`).
    to_s: Option<String>,
    /// A stroke ends where the tip rises this far off the work surface, mm (`--lift-mm`).
    lift_mm: Option<String>,
    /// A stroke ends where the tip pauses this long, seconds (`--pause-s`).
    pause_s: Option<String>,
    /// Speed under which the tip pauses, mm/s (`--pause-speed-mm-s`).
    pause_speed_mm_s: Option<String>,
    /// `true`: the rotation about the tool's axis is free (`--free-tool-axis`).
    free_tool_axis: Option<String>,
    /// The token, when given in the query (checked by the guard).
    #[serde(rename = "token")]
    _token: Option<String>,
}

/// A request resolved: the robot, the cell, the check.
struct Checked {
    robot: Robot,
    cell: Cell,
    report: CheckReport,
    /// The strokes as ranges of the report's frames.
    frame_ranges: Vec<std::ops::Range<usize>>,
    /// The strokes' frames (first, last) of the take.
    strokes: Vec<(usize, usize)>,
    /// The line saying the roll about the tool's axis was chosen, when it was.
    tool_axis: Option<String>,
    /// The line saying the span has no stroke (then checked whole), when it has none.
    no_stroke: Option<String>,
    gaps: usize,
    cutoff_hz: f64,
    /// How the work object was chosen, said to the user.
    placement: Placement,
}

/// Where the checked work object came from.
#[derive(Debug, Clone, PartialEq)]
enum Placement {
    /// Given in the request.
    Given,
    /// Automatic, and the default (at the robot's base) works.
    Default,
    /// Automatic: the default fails this many of so many frames, and the check's suggestion
    /// (verified to pass) is used instead.
    Suggested { failing: usize, frames: usize },
}

impl Placement {
    fn json(&self) -> Value {
        match self {
            Self::Given => json!({"from": "given", "note": ""}),
            Self::Default => {
                json!({"from": "default", "note": "the work object at the robot's base (the default) works"})
            }
            Self::Suggested { failing, frames } => json!({
                "from": "suggested",
                "note": format!("the default work object (at the robot's base) fails {failing} of {frames} frames, so the check's suggested placement is used; edit wobj to place it yourself"),
            }),
        }
    }
}

/// A cut-off from the query, checked.
pub fn cutoff(text: Option<&str>) -> Result<f64, ApiError> {
    let Some(text) = text else {
        return Ok(DEFAULT_CUTOFF_HZ);
    };
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|c| c.is_finite() && *c > 0.0)
        .ok_or_else(|| {
            ApiError::bad_request(format!(
                "cutoff_hz {text:?}: expected a positive number of Hz"
            ))
        })
}

/// The take smoothed at `cutoff_hz` as the review smooths it (outliers dropped first).
pub fn smoothed_take(studio: &Studio, cutoff_hz: f64) -> Result<Trajectory, ApiError> {
    let (take, _) = review::take(studio)?;
    smooth_for_review(&take, cutoff_hz)
        .map_err(|e| ApiError::unprocessable(format!("smoothing: {e}")))
}

fn pose_field(query: Option<&str>, field: &str) -> Result<Pose, ApiError> {
    let text = query.unwrap_or("0,0,0,1,0,0,0");
    parse_pose(text).map_err(|e| ApiError::bad_request(format!("{field} {text:?}: {e}")))
}

/// A number of the query: absent or empty is `None`; otherwise finite and, when `positive`,
/// above zero.
fn number(field: &str, text: Option<&str>, positive: bool) -> Result<Option<f64>, ApiError> {
    let Some(text) = text.map(str::trim).filter(|t| !t.is_empty()) else {
        return Ok(None);
    };
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite() && (!positive || *v > 0.0))
        .map(Some)
        .ok_or_else(|| {
            ApiError::bad_request(format!(
                "{field} {text:?}: expected {}",
                if positive {
                    "a positive number"
                } else {
                    "a number"
                }
            ))
        })
}

/// The span and strokes of the query, as `export`'s flags give them ([`PathOptions`]).
fn path_options(query: &RobotQuery) -> Result<PathOptions, ApiError> {
    let defaults = StrokeConfig::default();
    Ok(PathOptions {
        from_s: number("from_s", query.from_s.as_deref(), false)?,
        to_s: number("to_s", query.to_s.as_deref(), false)?,
        strokes: StrokeConfig {
            lift_mm: number("lift_mm", query.lift_mm.as_deref(), true)?.unwrap_or(defaults.lift_mm),
            pause_s: number("pause_s", query.pause_s.as_deref(), true)?.unwrap_or(defaults.pause_s),
            pause_speed_mm_s: number("pause_speed_mm_s", query.pause_speed_mm_s.as_deref(), true)?
                .unwrap_or(defaults.pause_speed_mm_s),
        },
        free_tool_axis: matches!(query.free_tool_axis.as_deref(), Some("true" | "1" | "on")),
    })
}

fn check(studio: &Studio, query: &RobotQuery) -> Result<Checked, ApiError> {
    let name = query.robot.as_deref().unwrap_or("irb120");
    let robot = Robot::by_name(name).ok_or_else(|| {
        ApiError::bad_request(format!(
            "robot {name:?}: unknown (known: {})",
            KNOWN_ROBOTS.join(", ")
        ))
    })?;
    let automatic = query
        .wobj
        .as_deref()
        .is_none_or(|w| w.trim().is_empty() || w.trim() == "auto");
    let mut cell = Cell {
        base_from_wobj: if automatic {
            Pose::identity()
        } else {
            pose_field(query.wobj.as_deref(), "wobj")?
        },
        flange_from_tcp: pose_field(query.tcp.as_deref(), "tcp")?,
    };
    let cutoff_hz = cutoff(query.cutoff_hz.as_deref())?;
    let trajectory = smoothed_take(studio, cutoff_hz)?;
    let Some((_, tool)) = studio.config().tracking() else {
        return Err(ApiError::conflict(format!(
            "nothing is tracked: {}",
            studio.config().view_only().unwrap_or_default()
        )));
    };
    let targets = tcp_targets(&trajectory, &tool.tool_from_tcp.rotation);
    if targets.is_empty() {
        return Err(ApiError::unprocessable(
            "no frame of the smoothed take has a pose (runs too short for the filter)",
        ));
    }
    let config = CheckConfig::default();
    let options = path_options(query)?;
    let take_s = (
        trajectory.samples.first().map_or(0.0, |s| s.time_s),
        trajectory.samples.last().map_or(0.0, |s| s.time_s),
    );
    let check_on = |cell: &Cell| {
        checked_path(&robot, cell, &targets, take_s, &options, &config).map_err(|e| match e {
            PathError::Span(span) => ApiError::bad_request(span.to_string()),
            e @ PathError::TooFewPoses => ApiError::unprocessable(e.to_string()),
        })
    };
    let mut path = check_on(&cell)?;
    let mut placement = if automatic {
        Placement::Default
    } else {
        Placement::Given
    };
    if automatic && !path.report.passes() {
        let suggested = path.report.suggestions.iter().find_map(|s| match s {
            Suggestion::UseWorkObject { base_from_wobj, .. } => Some(*base_from_wobj),
            Suggestion::SlowDown { .. } => None,
        });
        if let Some(base_from_wobj) = suggested {
            placement = Placement::Suggested {
                failing: path.report.failing().count(),
                frames: path.report.frames.len(),
            };
            cell.base_from_wobj = base_from_wobj;
            path = check_on(&cell)?;
        }
    }
    Ok(Checked {
        gaps: trajectory.len() - targets.len(),
        frame_ranges: path.frame_ranges(),
        strokes: path.strokes.iter().map(|s| (s.first.0, s.last.0)).collect(),
        tool_axis: path.tool_axis,
        no_stroke: path.no_stroke,
        report: path.report,
        robot,
        cell,
        cutoff_hz,
        placement,
    })
}

fn point(p: &teachcam::geometry::Point3) -> [f64; 3] {
    [
        (p.x * 100.0).round() / 100.0,
        (p.y * 100.0).round() / 100.0,
        (p.z * 100.0).round() / 100.0,
    ]
}

/// `GET /api/robot`: the check, the limits and margins, the suggestion, the joint path.
pub async fn robot(
    State(studio): State<Studio>,
    Query(query): Query<RobotQuery>,
) -> Result<axum::Json<Value>, ApiError> {
    let checked = tokio::task::spawn_blocking(move || check(&studio, &query))
        .await
        .map_err(|e| ApiError::internal(e.to_string()))??;
    let Checked {
        robot,
        cell,
        report,
        strokes,
        tool_axis,
        no_stroke,
        gaps,
        cutoff_hz,
        placement,
        ..
    } = &checked;
    let limits: Vec<Value> = robot
        .limits
        .iter()
        .zip(&report.peak_joint_speed)
        .map(|(l, peak)| {
            json!({
                "min_deg": l.min.to_degrees(),
                "max_deg": l.max.to_degrees(),
                "max_speed_deg_s": l.max_speed.to_degrees(),
                "peak_speed_deg_s": peak.to_degrees(),
                "speed_margin": 1.0 - peak / l.max_speed,
            })
        })
        .collect();
    let suggestions: Vec<Value> = report
        .suggestions
        .iter()
        .map(|s| match s {
            Suggestion::UseWorkObject { base_from_wobj, .. } => {
                json!({"text": s.to_string(), "wobj": pose_text(base_from_wobj)})
            }
            Suggestion::SlowDown { factor } => json!({"text": s.to_string(), "slow_down": factor}),
        })
        .collect();
    let step = report.frames.len().div_ceil(MAX_PATH_FRAMES).max(1);
    let path: Vec<Value> = report
        .frames
        .iter()
        .step_by(step)
        .map(|f| {
            let tcp = cell.base_from_wobj * f.target.wobj_from_tcp;
            let tcp_in_base = tcp.translation.vector;
            json!({
                "frame": f.target.frame.0,
                "time_s": f.target.time_s,
                "ok": f.passes(),
                "issues": f.issues.iter().filter(|i| i.is_failure()).map(ToString::to_string).collect::<Vec<_>>(),
                "joints_deg": f.joints.map(|j| j.to_degrees()),
                "links_mm": f.joints.map(|j| link_points(robot, &j).iter().map(point).collect::<Vec<_>>()),
                "tcp_mm": [tcp_in_base.x, tcp_in_base.y, tcp_in_base.z],
            })
        })
        .collect();
    let wobj = cell.base_from_wobj;
    let q = wobj.rotation.quaternion();
    Ok(axum::Json(json!({
        "robot": robot.name,
        "maker": robot.maker.label(),
        "cutoff_hz": cutoff_hz,
        "passes": report.passes(),
        "frames": report.frames.len(),
        "gaps": gaps,
        "unreachable": report.unreachable_count(),
        "failing": report.failing().count(),
        "near_singular": report.near_singular_count(),
        "issue_ranges": issue_ranges(report).iter().map(|r| json!({"text": r.to_string(), "failure": r.is_failure()})).collect::<Vec<_>>(),
        "peak_speed_ratio": report.peak_speed_ratio,
        "limits": limits,
        "suggestions": suggestions,
        "wobj": pose_text(&wobj),
        "placement": placement.json(),
        "strokes": strokes.iter().map(|(first, last)| json!({"first_frame": first, "last_frame": last})).collect::<Vec<_>>(),
        "tool_axis": tool_axis,
        "no_stroke": no_stroke,
        "wobj_frame": {"position_mm": [wobj.translation.x, wobj.translation.y, wobj.translation.z], "quaternion": [q.w, q.i, q.j, q.k]},
        "tcp": pose_text(&cell.flange_from_tcp),
        "path": path,
    })))
}

/// The program dialects the studio downloads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Dialect {
    Rapid,
    KrlSrc,
    KrlDat,
    UrScript,
}

impl Dialect {
    fn from_name(name: &str) -> Option<Self> {
        match name {
            "rapid" => Some(Self::Rapid),
            "krl" | "krl-src" => Some(Self::KrlSrc),
            "krl-dat" => Some(Self::KrlDat),
            "urscript" => Some(Self::UrScript),
            _ => None,
        }
    }

    /// The maker whose robots run it, and the file's extension.
    fn maker_and_extension(self) -> (Maker, &'static str) {
        match self {
            Self::Rapid => (Maker::Abb, "mod"),
            Self::KrlSrc => (Maker::Kuka, "src"),
            Self::KrlDat => (Maker::Kuka, "dat"),
            Self::UrScript => (Maker::UniversalRobots, "script"),
        }
    }
}

/// The program's name (a KRL DEF name: the download's file name).
const PROGRAM_NAME: &str = "teachcam_studio";

/// `GET /api/export/{dialect}`: the program for the take, as a download.
pub async fn export(
    State(studio): State<Studio>,
    Path(dialect): Path<String>,
    Query(query): Query<RobotQuery>,
) -> Result<Response, ApiError> {
    let dialect = Dialect::from_name(&dialect).ok_or_else(|| {
        ApiError::new(
            axum::http::StatusCode::NOT_FOUND,
            format!("/api/export/{dialect}: no such dialect (rapid, krl, krl-dat, urscript)"),
        )
    })?;
    let force = matches!(query.force.as_deref(), Some("true" | "1"));
    let (text, file) = tokio::task::spawn_blocking(move || -> Result<_, ApiError> {
        let checked = check(&studio, &query)?;
        let (maker, extension) = dialect.maker_and_extension();
        if checked.robot.maker != maker {
            return Err(ApiError::unprocessable(format!(
                "{extension} programs drive {} robots, and the {} is made by {}",
                maker.label(),
                checked.robot.name,
                checked.robot.maker.label()
            )));
        }
        if !checked.report.passes() && !force {
            return Err(ApiError::unprocessable(format!(
                "{} of {} frames fail on the {}; no program (force=true writes it anyway)",
                checked.report.failing().count(),
                checked.report.frames.len(),
                checked.robot.name
            )));
        }
        if let Some(problem) = krl_name_problem(PROGRAM_NAME) {
            return Err(ApiError::internal(problem));
        }
        let program = build_stroke_program(
            PROGRAM_NAME,
            &checked.cell,
            &checked.report,
            &SimplifyConfig::default(),
            &checked.frame_ranges,
        );
        let text = match dialect {
            Dialect::Rapid => rapid_module(&program, &RapidConfig::default()),
            Dialect::KrlSrc => krl_program(&program).src,
            Dialect::KrlDat => krl_program(&program).dat,
            Dialect::UrScript => urscript_program(&program, &UrScriptConfig::default()),
        };
        Ok((text, format!("{PROGRAM_NAME}.{extension}")))
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))??;
    Ok((
        [
            (
                header::CONTENT_TYPE,
                "text/plain; charset=utf-8".to_string(),
            ),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{file}\""),
            ),
        ],
        text,
    )
        .into_response())
}
