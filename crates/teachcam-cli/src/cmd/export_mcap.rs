//! `teachcam export mcap`: a trajectory as a ROS 2 take (MCAP, CDR, schemas embedded).

use anyhow::{Context, bail};
use teachcam::io::trajectory::read_trajectory;
use teachcam::io::{Output, check_outputs};
use teachcam::ros2::bag::mcap_bytes;
use teachcam::ros2::take::{Frames, joint_trajectory, tracked_take};

use super::check::{checked_path, resolve, summary};
use super::export::Args;
use crate::Rejected;

/// Writes the take; prints the robot check's summary when it fails.
#[expect(
    clippy::print_stdout,
    reason = "a failing check's summary is part of the output"
)]
pub fn run(args: &Args) -> anyhow::Result<()> {
    let output = Output {
        path: &args.output,
        format: "a ROS 2 MCAP file",
        extensions: &["mcap"],
    };
    let mut inputs = vec![args.trajectory.as_path()];
    inputs.extend(args.cell.tool.as_deref());
    inputs.extend(args.rig.as_deref());
    check_outputs(&[output], &inputs)?;
    let world = args.frame_id.clone().unwrap_or_else(|| "world".into());
    if let Some(problem) = frame_id_problem(&world) {
        bail!("--frame-id {world:?}: {problem}");
    }
    let frames = Frames {
        world,
        ..Frames::default()
    };
    let mut trajectory = read_trajectory(&args.trajectory).rejected()?;
    if trajectory.samples.iter().all(|s| s.pose.is_none()) {
        return Err(anyhow::anyhow!(
            "{}: no frame has a pose",
            args.trajectory.display()
        ))
        .rejected();
    }
    trajectory
        .samples
        .sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let rig = args.rig.as_deref().map(crate::load::rig).transpose()?;
    let tool = args
        .cell
        .tool
        .as_deref()
        .map(crate::load::tool)
        .transpose()?;
    let mut take = tracked_take(
        trajectory.samples.iter().map(|s| (s, None)),
        rig.as_ref(),
        tool.as_ref(),
        &frames,
    )
    .with_context(|| args.trajectory.display().to_string())
    .rejected()?;
    let joints = if args.cell.robot.is_some() {
        let resolved = resolve(&args.trajectory, &args.cell)?;
        // The joint path `check --joints-out` writes: the same strokes and trimming.
        let report = checked_path(&resolved, &args.strokes)?.report;
        if !report.passes() {
            print!("{}", summary(&report, resolved.gaps, &resolved.robot.name));
            if !args.force {
                return Err(anyhow::anyhow!(
                    "{}: {} of {} frames fail on the {}; no take written (--force writes the joints of the frames that have them)",
                    args.trajectory.display(),
                    report.failing().count(),
                    report.frames.len(),
                    resolved.robot.name
                ))
                .rejected();
            }
        }
        let joints = joint_trajectory(&report, &frames)
            .with_context(|| args.trajectory.display().to_string())
            .rejected()?;
        if joints.is_none() {
            return Err(anyhow::anyhow!(
                "{}: no frame has joints on the {}; no take written",
                args.trajectory.display(),
                resolved.robot.name
            ))
            .rejected();
        }
        crate::announce::say(&report.timing.describe(&report.robot.name));
        joints
    } else {
        None
    };
    let posed = take.frames.iter().filter(|m| m.tool.is_some()).count();
    let frame_count = take.frames.len();
    let points = joints.as_ref().map(|j| j.points.len());
    take.joint_trajectory = joints;
    let bytes = mcap_bytes(&take)?;
    teachcam::io::write_atomically(&args.output, &bytes)?;
    let mut what = format!("{frame_count} frames, {posed} tool poses");
    if let Some(points) = points {
        what.push_str(&format!(", a joint path of {points} points"));
    }
    crate::announce::wrote(std::slice::from_ref(&args.output), &what);
    Ok(())
}

/// What is wrong with a frame name for tf2 (`None`: nothing): not empty, no leading `/`,
/// letters, digits, `_` and `/` only.
pub(crate) fn frame_id_problem(name: &str) -> Option<&'static str> {
    if name.is_empty() {
        Some("a frame name cannot be empty")
    } else if name.starts_with('/') {
        Some("tf2 frame names do not start with '/'")
    } else if !name
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/')
    {
        Some("use letters, digits, '_' and '/' only")
    } else {
        None
    }
}
