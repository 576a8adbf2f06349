//! `teachcam report`: one self-contained HTML page of a run's figures.
//!
//! Parse the flags, find the inputs, then the library makes the model
//! (`teachcam::report::build_report`) and `teachcam_studio::report_page` the page.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use teachcam::geometry::{Pose, parse_pose};
use teachcam::io::rig::read_rig;
use teachcam::io::tool::read_tool;
use teachcam::io::trajectory::read_trajectory;
use teachcam::report::{Absent, Header, InputFile, ReportInputs, build_report, summary_from_json};

use super::check::{CellArgs, StrokeArgs, checked_path, resolve_trajectory};
use crate::Rejected;
use teachcam::report::joints::CheckedJoints;

/// Write an HTML report of a run: one self-contained page of interactive figures.
///
/// Reads what is there: the tracked trajectory (required), the smoothed one, the simulator's
/// truth, the rig, the tool, the recording, the work object's placement and the demo's
/// `run.json`. Each input has a flag; without it, RUN_DIR is searched under the names the demo
/// writes and the names of the README's pipeline:
///
///   --raw        raw.csv
///   --smoothed   smoothed.csv, smooth.csv
///   --recording  recording/, rec/
///   --rig        rig.json, RECORDING/rig.json
///   --tool       tool.json, RECORDING/tool.json
///   --truth      RECORDING/truth.csv, truth.csv
///   --wobj       run.json's "wobj"
///   --robot      run.json's "robot"
///   --tcp        run.json's "tcp"
///
/// Figures: trajectory components raw / smoothed / truth with the residual (paper Figs. 3
/// and 8), the windowed amplitude spectrum with the cut-off (Fig. 7), per-frame tip_std and
/// status, the smoothing comparison (Figs. 4-6), the tip path to scale, the path on the robot
/// with its reach, each robot axis's angle and speed against its limits (with --robot: the
/// smoothed path checked as `teachcam check SMOOTHED --robot R --wobj W --tcp T --tool TOOL`
/// checks it, strokes and time scale included), the tip error, the uncertainty map and what the cameras see. A figure whose
/// input is missing is a line saying so, on the page and on stderr.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam report teachcam-demo
  teachcam report . --wobj "350,0,100,0,1,0,0" -o report.html
  teachcam report . --robot irb120 --wobj "350,0,100,0,1,0,0" --tcp "0,0,200,0,1,0,0""#)]
pub struct Args {
    /// The run's folder (as written by `teachcam demo`, or the README's pipeline folder).
    pub run_dir: PathBuf,
    /// Output HTML file (default RUN_DIR/report.html).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// The tracked trajectory (default RUN_DIR/raw.csv).
    #[arg(long)]
    pub raw: Option<PathBuf>,
    /// The smoothed trajectory (default RUN_DIR/smoothed.csv or smooth.csv; without one, the
    /// raw trajectory is smoothed at --cutoff).
    #[arg(long)]
    pub smoothed: Option<PathBuf>,
    /// The recording folder, for the camera views (default RUN_DIR/recording or RUN_DIR/rec).
    #[arg(long)]
    pub recording: Option<PathBuf>,
    /// The rig (default RUN_DIR/rig.json, else RECORDING/rig.json).
    #[arg(long)]
    pub rig: Option<PathBuf>,
    /// The tool (default RUN_DIR/tool.json, else RECORDING/tool.json).
    #[arg(long)]
    pub tool: Option<PathBuf>,
    /// The simulator's truth (default RECORDING/truth.csv, else RUN_DIR/truth.csv).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Work object in the robot's base frame, for the path on the robot (default: from
    /// RUN_DIR/run.json).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::pose)]
    pub wobj: Option<String>,
    /// Robot the smoothed path is checked on, for the joint figure: a name or a robot file as
    /// `check --robot` takes (default: from RUN_DIR/run.json; without one, no joint figure).
    #[arg(long)]
    pub robot: Option<String>,
    /// Tool centre point in the maker's flange frame, "x,y,z,qw,qx,qy,qz" (mm), as `check
    /// --tcp` (default: from RUN_DIR/run.json, else the flange itself).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::pose)]
    pub tcp: Option<String>,
    /// The rotation about the tool's axis is free, as `check --free-tool-axis`.
    #[arg(long)]
    pub free_tool_axis: bool,
    /// The low-pass cut-off marked on the spectrum (and used when there is no smoothed
    /// trajectory), Hz.
    #[arg(long, default_value_t = 10.0, value_parser = crate::flags::positive)]
    pub cutoff: f64,
}

impl Args {
    /// The report of `run_dir` with every input at its default.
    #[must_use]
    pub fn of(run_dir: PathBuf) -> Self {
        Self {
            run_dir,
            output: None,
            raw: None,
            smoothed: None,
            recording: None,
            rig: None,
            tool: None,
            truth: None,
            wobj: None,
            robot: None,
            tcp: None,
            free_tool_axis: false,
            cutoff: 10.0,
        }
    }
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let (output, missing) = write_report(args)?;
    crate::announce::wrote(
        &[output],
        &if missing == 0 {
            "every figure".to_string()
        } else {
            format!("{missing} figures missing, each with its reason")
        },
    );
    Ok(())
}

/// Where an input is: the flag's path, else the first of `candidates` that exists.
/// `Err` says what was looked for.
fn find(
    flag: Option<&PathBuf>,
    flag_name: &str,
    candidates: &[PathBuf],
    is_dir: bool,
) -> Result<Result<PathBuf, Absent>> {
    if let Some(path) = flag {
        let exists = if is_dir {
            path.is_dir()
        } else {
            path.is_file()
        };
        anyhow::ensure!(
            exists,
            "{flag_name} {}: no such {}",
            path.display(),
            if is_dir { "folder" } else { "file" }
        );
        return Ok(Ok(path.clone()));
    }
    let found = candidates
        .iter()
        .find(|c| if is_dir { c.is_dir() } else { c.is_file() });
    Ok(found.cloned().ok_or_else(|| {
        let names: Vec<String> = candidates.iter().map(|c| c.display().to_string()).collect();
        Absent(format!("no {} ({flag_name})", names.join(" or ")))
    }))
}

/// Reads an input that was found; a file that exists but is wrong is rejected data.
fn read<T, E: Into<anyhow::Error>>(
    found: &Result<PathBuf, Absent>,
    read: impl Fn(&Path) -> std::result::Result<T, E>,
) -> Result<Result<T, Absent>> {
    match found {
        Ok(path) => read(path).map(Ok).map_err(Into::into).rejected(),
        Err(absent) => Ok(Err(absent.clone())),
    }
}

fn input_file(role: &str, found: &Result<PathBuf, Absent>) -> InputFile {
    match found {
        Ok(path) => InputFile {
            role: role.into(),
            path: Some(path.display().to_string()),
            note: String::new(),
        },
        Err(Absent(what)) => InputFile {
            role: role.into(),
            path: None,
            note: what.clone(),
        },
    }
}

/// Writes the report; returns where, and how many figures are missing.
pub fn write_report(args: &Args) -> Result<(PathBuf, usize)> {
    let dir = &args.run_dir;
    // An --output named wrong is a usage error before any input is read; the default
    // lies in the run's folder, which reading raw.csv shows to exist.
    if let Some(output) = &args.output {
        teachcam::io::check_outputs(
            &[teachcam::io::Output {
                path: output,
                format: "an HTML page",
                extensions: &["html", "htm"],
            }],
            &[],
        )?;
    }
    let raw_path = args.raw.clone().unwrap_or_else(|| dir.join("raw.csv"));
    let raw = read_trajectory(&raw_path).rejected()?;
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| dir.join("report.html"));
    let recording_found = find(
        args.recording.as_ref(),
        "--recording",
        &[dir.join("recording"), dir.join("rec")],
        true,
    )?;
    let recording_dir = recording_found
        .as_ref()
        .map_or_else(|_| dir.join("recording"), Clone::clone);
    let smoothed_found = find(
        args.smoothed.as_ref(),
        "--smoothed",
        &[dir.join("smoothed.csv"), dir.join("smooth.csv")],
        false,
    )?;
    let truth_found = find(
        args.truth.as_ref(),
        "--truth",
        &[recording_dir.join("truth.csv"), dir.join("truth.csv")],
        false,
    )?;
    let rig_found = find(
        args.rig.as_ref(),
        "--rig",
        &[dir.join("rig.json"), recording_dir.join("rig.json")],
        false,
    )?;
    let tool_found = find(
        args.tool.as_ref(),
        "--tool",
        &[dir.join("tool.json"), recording_dir.join("tool.json")],
        false,
    )?;
    let run_json_path = dir.join("run.json");
    let run_json: Option<serde_json::Value> = if run_json_path.is_file() {
        let text = teachcam::io::read_text(&run_json_path).rejected()?;
        Some(
            serde_json::from_str(&text)
                .with_context(|| format!("{}: not JSON", run_json_path.display()))
                .rejected()?,
        )
    } else {
        None
    };
    let wobj_text = args.wobj.clone().or_else(|| {
        run_json
            .as_ref()
            .and_then(|j| j["wobj"].as_str().map(str::to_string))
    });
    let base_from_wobj: Result<Pose, Absent> = match &wobj_text {
        Some(text) => Ok(parse_pose(text).context("--wobj").rejected()?),
        None => Err(Absent(format!(
            "no work object's placement (--wobj, or \"wobj\" in {})",
            run_json_path.display()
        ))),
    };

    let smoothed = read(&smoothed_found, read_trajectory)?;
    let truth = read(&truth_found, read_trajectory)?;
    let rig = read(&rig_found, read_rig)?;
    let tool = read(&tool_found, read_tool)?;
    let mut inputs = vec![
        input_file("raw trajectory", &Ok(raw_path.clone())),
        input_file("smoothed trajectory", &smoothed_found),
        input_file("truth", &truth_found),
        input_file("rig", &rig_found),
        input_file("tool", &tool_found),
        input_file("recording", &recording_found),
    ];
    if run_json.is_some() {
        inputs.push(input_file("run summary", &Ok(run_json_path.clone())));
    }
    if let Some(text) = &wobj_text {
        inputs.push(InputFile {
            role: "work object (base frame)".into(),
            path: Some(text.clone()),
            note: String::new(),
        });
    }
    let from_run = |key: &str| {
        run_json
            .as_ref()
            .and_then(|j| j[key].as_str().map(str::to_string))
    };
    let robot = args.robot.clone().or_else(|| from_run("robot"));
    let joints = match &robot {
        Some(robot) => {
            inputs.push(InputFile {
                role: "robot".into(),
                path: Some(robot.clone()),
                note: String::new(),
            });
            let cell = CellArgs {
                robot: Some(robot.clone()),
                wobj: wobj_text.clone().unwrap_or_else(|| IDENTITY.into()),
                tcp: args
                    .tcp
                    .clone()
                    .or_else(|| from_run("tcp"))
                    .unwrap_or_else(|| IDENTITY.into()),
                tool: tool_found.as_ref().ok().cloned(),
                free_tool_axis: args.free_tool_axis,
                ..CellArgs::default()
            };
            checked_joints(&raw, smoothed.as_ref().ok(), args.cutoff, &cell)?
        }
        None => Err(Absent(format!(
            "no robot (--robot, or \"robot\" in {})",
            run_json_path.display()
        ))),
    };
    let recording_path = recording_found.as_deref().map_err(Clone::clone);
    let report = build_report(&ReportInputs {
        header: Header::now(inputs),
        raw: &raw,
        smoothed: smoothed.as_ref().map_err(Clone::clone),
        truth: truth.as_ref().map_err(Clone::clone),
        rig: rig.as_ref().map_err(Clone::clone),
        tool: tool.as_ref().map_err(Clone::clone),
        recording: recording_path,
        base_from_wobj: base_from_wobj.as_ref().map_err(Clone::clone),
        joints: joints.as_ref().map_err(Clone::clone),
        cutoff_hz: args.cutoff,
        study_seed: 1,
        extra_summary: run_json
            .as_ref()
            .map(|j| summary_from_json(&j["summary"]))
            .unwrap_or_default(),
    });
    let mut missing = 0;
    for slot in &report.figures {
        if let Some(reason) = slot.missing_reason() {
            missing += 1;
            crate::announce::say(&format!("report: {}: missing: {reason}", slot.title));
        }
    }
    let page = teachcam_studio::report_page::render(&report)?;
    teachcam::io::write_atomically(&output, page.as_bytes())?;
    Ok((output, missing))
}

/// The identity pose, `check`'s default work object and TCP.
const IDENTITY: &str = "0,0,0,1,0,0,0";

/// The smoothed trajectory (the file, else the raw one smoothed at `cutoff_hz` as the
/// report's figures are) checked on the cell's robot as `check` checks it. A robot, pose or
/// tool given wrong is an error (exit 2 or 1, as `check`'s); a path that cannot be checked is
/// an absent figure with the reason.
fn checked_joints(
    raw: &teachcam::trajectory::Trajectory,
    smoothed: Option<&teachcam::trajectory::Trajectory>,
    cutoff_hz: f64,
    cell: &CellArgs,
) -> Result<Result<CheckedJoints, Absent>> {
    let trajectory = match smoothed {
        Some(s) => s.clone(),
        None => match teachcam::report::smooth_for_review(raw, cutoff_hz) {
            Ok(s) => s,
            Err(e) => {
                return Ok(Err(Absent(format!(
                    "the raw trajectory cannot be smoothed for the check: {e}"
                ))));
            }
        },
    };
    if trajectory.samples.iter().all(|s| s.pose.is_none()) {
        return Ok(Err(Absent("the trajectory has no pose to check".into())));
    }
    let resolved = resolve_trajectory(trajectory, cell)?;
    let path = match checked_path(&resolved, &StrokeArgs::default()) {
        Ok(path) => path,
        Err(e) => return Ok(Err(Absent(format!("the path cannot be checked: {e}")))),
    };
    let strokes = path.target_ranges();
    Ok(Ok(CheckedJoints::new(
        path.report,
        &strokes,
        resolved.config.speed_fraction,
    )))
}
