//! `teachcam strokes`: the strokes of a take, where the tip leaves the work surface or pauses.

use std::path::PathBuf;

use anyhow::Context as _;
use nalgebra::UnitQuaternion;
use teachcam::io::trajectory::read_trajectory;
use teachcam::robot::tcp_targets;

use super::check::StrokeArgs;
use crate::Rejected;

/// List the strokes of a take: the runs of frames where the brush's tip is on the work surface,
/// cut where it pauses.
///
/// The work surface is the world's xy-plane (z = 0 of the trajectory, which is the work
/// object's frame: `--wobj` moves both together). The tip is on it while |z| <= --lift-mm; a
/// pause is a run slower than --pause-speed-mm-s (speeds over 0.2 s) lasting --pause-s or
/// more; the stroke before it ends on its first frame, the next starts on its last. `check`
/// and `export` use the same strokes: each is approached and retracted along the tool's axis.
/// Poses `track` flagged `outlier` are left out (as `check` does). A take with no stroke exits
/// 1, naming the tip's lowest height.
///
/// Columns: stroke (from 1), start and end time (s), first and last frame, the tip's path
/// length (mm), its mean speed (mm/s) and what ends the stroke (lift, pause, end).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam strokes smooth.csv
  teachcam strokes smooth.csv --lift-mm 5 --pause-s 1 --json
  teachcam strokes smooth.csv --from 0.5 --to 3"#)]
pub struct Args {
    /// Trajectory CSV (from `track` or `smooth`).
    pub trajectory: PathBuf,
    #[command(flatten)]
    pub strokes: StrokeArgs,
    /// Print the strokes as one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Run the command.
#[expect(clippy::print_stdout, reason = "the listing is the command's output")]
pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut trajectory = read_trajectory(&args.trajectory).rejected()?;
    trajectory.drop_outliers();
    let take_s = (
        trajectory.samples.first().map_or(0.0, |s| s.time_s),
        trajectory.samples.last().map_or(0.0, |s| s.time_s),
    );
    let targets = tcp_targets(&trajectory, &UnitQuaternion::identity());
    let (_, strokes) = args
        .strokes
        .strokes(&targets, take_s)
        .with_context(|| args.trajectory.display().to_string())?;
    if args.json {
        let list: Vec<serde_json::Value> = strokes
            .iter()
            .enumerate()
            .map(|(i, s)| {
                serde_json::json!({
                    "index": i + 1,
                    "start_s": s.start_s,
                    "end_s": s.end_s,
                    "first_frame": s.first.0,
                    "last_frame": s.last.0,
                    "length_mm": s.length_mm,
                    "mean_speed_mm_s": s.mean_speed_mm_s,
                    "ends": s.end.label(),
                })
            })
            .collect();
        println!(
            "{}",
            serde_json::json!({
                "strokes": list,
                "lift_mm": args.strokes.lift_mm,
                "pause_s": args.strokes.pause_s,
                "pause_speed_mm_s": args.strokes.pause_speed_mm_s,
            })
        );
        return Ok(());
    }
    println!("stroke  start_s    end_s  first   last  length_mm  mean_speed_mm_s  ends");
    for (i, s) in strokes.iter().enumerate() {
        println!(
            "{:>6} {:>8.3} {:>8.3} {:>6} {:>6} {:>10.1} {:>16.1}  {}",
            i + 1,
            s.start_s,
            s.end_s,
            s.first.0,
            s.last.0,
            s.length_mm,
            s.mean_speed_mm_s,
            s.end.label()
        );
    }
    Ok(())
}
