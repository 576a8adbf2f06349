//! `teachcam pivot`: the tool centre point from a recording where the tip rests on one point.

use std::path::PathBuf;

use anyhow::Context;
use teachcam::io::trajectory::read_trajectory;
use teachcam::robot::frames::{PivotConfig, pivot_calibration};

use crate::Rejected;

/// Pivot calibration of the tool centre point.
///
/// Finds the tip's position in the tool frame (the `tip` of tool.json) from a
/// tracked recording in which the tip rests on one point while the tool is turned about it.
/// Refuses a recording with too little rotation about two independent axes.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam pivot pivot.csv"#)]
pub struct Args {
    /// Trajectory CSV of the pivoting tool (from `track`); frames without a pose are skipped.
    pub trajectory: PathBuf,
    /// Smallest rotation spread accepted about the least-turned axis, degrees.
    #[arg(long, default_value_t = 10.0, value_parser = crate::flags::positive)]
    pub min_rotation_deg: f64,
}

/// Run the command.
#[expect(clippy::print_stdout, reason = "the tip is the command's output")]
pub fn run(args: &Args) -> anyhow::Result<()> {
    let trajectory = read_trajectory(&args.trajectory).rejected()?;
    let poses: Vec<_> = trajectory
        .samples
        .iter()
        .filter_map(|s| s.pose.map(|p| p.world_from_tool))
        .collect();
    let config = PivotConfig {
        min_rotation_spread: args.min_rotation_deg.to_radians(),
    };
    let pivot = pivot_calibration(&poses, &config)
        .with_context(|| format!("{}", args.trajectory.display()))
        .rejected()?;
    let t = pivot.tip_in_tool;
    let p = pivot.pivot_in_world;
    println!("tip in tool: [{:.3}, {:.3}, {:.3}] mm", t.x, t.y, t.z);
    println!("pivot in world: [{:.3}, {:.3}, {:.3}] mm", p.x, p.y, p.z);
    println!(
        "rms residual {:.3} mm over {} poses, rotation spread {:.1} deg",
        pivot.rms_mm,
        poses.len(),
        pivot.rotation_spread.to_degrees()
    );
    Ok(())
}
