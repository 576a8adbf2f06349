//! `teachcam replay`: a program teachcam wrote, played as a controller would.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use teachcam::io::trajectory::read_trajectory;
use teachcam::robot::Cell;
use teachcam::robot::replay::parse::{ProgramText, parse_krl, parse_rapid, parse_urscript};
use teachcam::robot::replay::{Deviation, Replay, ReplayConfig, deviation, replay};

use super::check::{parse_pose, resolve_robot};
use crate::Rejected;

/// Play a robot program teachcam wrote (RAPID .mod/.modx, KRL .src with its .dat, URScript
/// .script) as a controller would, and report what the robot does.
///
/// Linear moves run at their programmed TCP (and orientation) speeds, corners are blended
/// within their zones (RAPID zonedata, KRL $APO.CDIS, URScript r), joint moves interpolate
/// every axis together at the slowest of their programmed speed and each axis's limit;
/// accelerations are not modelled. Prints the duration, each joint's peak speed against its
/// limit and, with --trajectory, how far the played path strays from the demonstration (for
/// every demonstrated TCP position, its distance to the played path). Exits 1 when a joint
/// exceeds its speed limit or a sample is out of reach.
///
/// The cell is the program's own (its tooldata/wobjdata, $TOOL/$BASE, set_tcp/wobj); --wobj
/// and --tcp replace it (the robot's real cell).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam replay stroke.mod --robot irb120 --trajectory smooth.csv
  teachcam replay stroke.src --robot kr6-r700 --json
  teachcam replay stroke.script --robot ur5e --wobj "350,0,100,1,0,0,0""#)]
pub struct Args {
    /// The program (.mod, .modx, .src, .script).
    pub program: PathBuf,
    /// Robot: irb120, kr6-r700, kr6-r900, ur5e, ur10e, or a robot file (.json).
    #[arg(long)]
    pub robot: String,
    /// Work object in the robot's base frame, "x,y,z,qw,qx,qy,qz" (default: the program's).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::pose)]
    pub wobj: Option<String>,
    /// Tool centre point in the flange frame, "x,y,z,qw,qx,qy,qz" (default: the program's).
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::pose)]
    pub tcp: Option<String>,
    /// The demonstration (trajectory CSV) to measure the played path against.
    #[arg(long)]
    pub trajectory: Option<PathBuf>,
    /// Print the result as one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Reads the program by its extension (KRL: the .dat beside the .src).
pub fn read_program(path: &Path) -> anyhow::Result<ProgramText> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    let read = |p: &Path| {
        std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))
    };
    let parsed = match extension.as_str() {
        "mod" | "modx" => parse_rapid(&read(path)?),
        "src" => parse_krl(&read(path)?, &read(&path.with_extension("dat"))?),
        "script" => parse_urscript(&read(path)?),
        _ => anyhow::bail!(
            "{}: a program ends in .mod or .modx (RAPID), .src (KRL) or .script (URScript)",
            path.display()
        ),
    };
    parsed
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
        .rejected()
}

/// The replay's report as JSON.
fn json(
    robot: &teachcam::robot::kinematics::Robot,
    program: &ProgramText,
    played: &Replay,
    deviation: Option<&Deviation>,
) -> serde_json::Value {
    let ratios = played.speed_ratios(robot);
    let joints: Vec<serde_json::Value> = (0..6)
        .map(|i| {
            serde_json::json!({
                "axis": i + 1,
                "peak_deg_s": played.peak_joint_speed[i].to_degrees(),
                "limit_deg_s": robot.limits[i].max_speed.to_degrees(),
                "ratio": ratios[i],
                "at_s": played.peak_time_s[i],
            })
        })
        .collect();
    serde_json::json!({
        "dialect": program.dialect.label(),
        "robot": robot.name,
        "moves": program.moves.len(),
        "duration_s": played.duration_s,
        "samples": played.samples.len(),
        "unreachable_samples": played.unreachable,
        "joints": joints,
        "deviation_mm": deviation.map(|d| serde_json::json!({
            "max": d.max_mm,
            "rms": d.rms_mm,
            "points": d.points,
        })),
    })
}

/// Run the command.
#[expect(clippy::print_stdout, reason = "the report is the command's output")]
pub fn run(args: &Args) -> anyhow::Result<()> {
    let robot = resolve_robot(&args.robot)?;
    let program = read_program(&args.program)?;
    let cell = Cell {
        base_from_wobj: match &args.wobj {
            Some(text) => parse_pose(text, "--wobj")?,
            None => program.cell.base_from_wobj,
        },
        flange_from_tcp: match &args.tcp {
            Some(text) => parse_pose(text, "--tcp")?,
            None => program.cell.flange_from_tcp,
        },
    };
    let demonstration = match &args.trajectory {
        Some(path) => {
            let mut trajectory = read_trajectory(path).rejected()?;
            trajectory.drop_outliers();
            let points: Vec<_> = trajectory
                .samples
                .iter()
                .filter_map(|s| s.pose.map(|p| p.tip_in_world))
                .collect();
            Some(points)
        }
        None => None,
    };
    let played = replay(&robot, &cell, &program, &ReplayConfig::default())
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.program.display()))
        .rejected()?;
    let deviation = demonstration
        .as_deref()
        .and_then(|points| deviation(&played, points));
    let ratios = played.speed_ratios(&robot);
    if args.json {
        println!("{}", json(&robot, &program, &played, deviation.as_ref()));
    } else {
        println!(
            "{} program, {} moves on the {}: {:.2} s",
            program.dialect.label(),
            program.moves.len(),
            robot.name,
            played.duration_s
        );
        for (axis, ratio) in ratios.iter().enumerate() {
            println!(
                "axis {}: peak {:.1} deg/s of {:.0} deg/s ({:.0}%) at {:.2} s",
                axis + 1,
                played.peak_joint_speed[axis].to_degrees(),
                robot.limits[axis].max_speed.to_degrees(),
                100.0 * ratio,
                played.peak_time_s[axis]
            );
        }
        if let Some(d) = &deviation {
            println!(
                "deviation from the demonstration: max {:.3} mm, rms {:.3} mm over {} points",
                d.max_mm, d.rms_mm, d.points
            );
        }
    }
    let worst = (0..6)
        .max_by(|a, b| ratios[*a].total_cmp(&ratios[*b]))
        .unwrap_or(0);
    if played.unreachable > 0 {
        return Err(anyhow::anyhow!(
            "{}: {} of {} samples out of the {}'s reach",
            args.program.display(),
            played.unreachable,
            played.samples.len(),
            robot.name
        ))
        .rejected();
    }
    if ratios[worst] > 1.0 {
        return Err(anyhow::anyhow!(
            "{}: axis {} reaches {:.0} deg/s at {:.2} s, over its {:.0} deg/s limit",
            args.program.display(),
            worst + 1,
            played.peak_joint_speed[worst].to_degrees(),
            played.peak_time_s[worst],
            robot.limits[worst].max_speed.to_degrees()
        ))
        .rejected();
    }
    Ok(())
}
