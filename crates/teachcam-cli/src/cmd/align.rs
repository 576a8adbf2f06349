//! `teachcam align`: the work object in the robot's base from points known in both frames.

use std::path::PathBuf;

use anyhow::Context;
use teachcam::io::read_text;
use teachcam::robot::frames::{align_frames, parse_point_pairs};
use teachcam::robot::pose_text;

use crate::Rejected;

/// Align the vision frame with the robot's base from points known in both.
///
/// The vision frame (the work object) is aligned with the robot's base frame from three or
/// more points touched by the robot's TCP and seen by the cameras. Prints the `--wobj` value for
/// `check` and `export`, and each point's residual: the paper's main source of systematic error.
///
/// The CSV has the header `x_wobj_mm,y_wobj_mm,z_wobj_mm,x_base_mm,y_base_mm,z_base_mm` and one
/// point per line.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam align touched.csv"#)]
pub struct Args {
    /// Point pairs CSV.
    pub points: PathBuf,
}

/// Run the command.
#[expect(clippy::print_stdout, reason = "the alignment is the command's output")]
pub fn run(args: &Args) -> anyhow::Result<()> {
    let text = read_text(&args.points).rejected()?;
    let pairs = parse_point_pairs(&text)
        .map_err(|m| anyhow::anyhow!("{}: {m}", args.points.display()))
        .rejected()?;
    let alignment = align_frames(&pairs.in_wobj, &pairs.in_base)
        .with_context(|| format!("{}", args.points.display()))
        .rejected()?;
    for (i, r) in alignment.residuals_mm.iter().enumerate() {
        println!("point {i}: residual {r:.3} mm");
    }
    println!("rms residual {:.3} mm", alignment.rms_mm);
    println!("--wobj \"{}\"", pose_text(&alignment.base_from_wobj));
    Ok(())
}
