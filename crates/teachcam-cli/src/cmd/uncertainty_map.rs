//! `teachcam uncertainty-map`: first-order tip uncertainty over a grid of the working volume.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use teachcam::geometry::{Point3, parse_pose};
use teachcam::io::write_atomically;
use teachcam::metrology::uncertainty_map;

/// Tip uncertainty over a grid of the working volume: where to work, where not.
///
/// Computed over a horizontal grid of tool positions at one orientation, with all cameras
/// and with the worst single camera left out: where to work, where not. Writes CSV
/// `x_mm,y_mm,z_mm,tip_rms_mm,tip_rms_one_camera_dropped_mm` (empty where the tool cannot be
/// tracked).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam uncertainty-map --rig rec/rig.json --tool rec/tool.json --pose "0,0,180,1,0,0,0" --half-width 300 --step 25 -o map.csv"#)]
pub struct Args {
    /// Camera rig (rig.json).
    #[arg(long)]
    pub rig: PathBuf,
    /// Tool model (tool.json).
    #[arg(long)]
    pub tool: PathBuf,
    /// Centre of the grid and the tool's orientation everywhere, `x,y,z,qw,qx,qy,qz`.
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::pose)]
    pub pose: String,
    /// Half the grid's side in x and y, millimetres.
    #[arg(long, default_value_t = 300.0, value_parser = crate::flags::non_negative)]
    pub half_width: f64,
    /// Grid spacing, millimetres.
    #[arg(long, default_value_t = 25.0, value_parser = crate::flags::positive)]
    pub step: f64,
    /// Marker-centre noise, pixels per axis.
    #[arg(long, default_value_t = 0.15, value_parser = crate::flags::positive)]
    pub pixel_noise: f64,
    /// Output CSV.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    teachcam::io::check_outputs(
        &[teachcam::io::Output::csv(&args.output)],
        &[&args.rig, &args.tool],
    )?;
    let rig = crate::load::rig(&args.rig)?;
    let tool = crate::load::tool(&args.tool)?;
    let centre = parse_pose(&args.pose).context("--pose")?;
    if !(args.step > 0.0 && args.half_width >= 0.0 && args.half_width / args.step <= 500.0) {
        anyhow::bail!(
            "--half-width/--step must be at most 500 (got {} and {})",
            args.half_width,
            args.step
        );
    }
    let steps = (args.half_width / args.step).floor() as i64;
    let c = centre.translation.vector;
    let positions: Vec<Point3> = (-steps..=steps)
        .flat_map(|j| (-steps..=steps).map(move |i| (i, j)))
        .map(|(i, j)| Point3::new(c.x + i as f64 * args.step, c.y + j as f64 * args.step, c.z))
        .collect();
    let cells = uncertainty_map(&rig, &tool, &centre.rotation, &positions, args.pixel_noise);
    let mut csv = String::from("x_mm,y_mm,z_mm,tip_rms_mm,tip_rms_one_camera_dropped_mm\n");
    let field = |v: Option<f64>| v.map(|v| format!("{v:.5}")).unwrap_or_default();
    for cell in &cells {
        let [x, y, z] = cell.position;
        let _ = writeln!(
            csv,
            "{x:.3},{y:.3},{z:.3},{},{}",
            field(cell.tip_rms_mm),
            field(cell.tip_rms_one_camera_dropped_mm)
        );
    }
    write_atomically(&args.output, csv.as_bytes())?;
    let tracked = cells.iter().filter(|c| c.tip_rms_mm.is_some()).count();
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!("{tracked} of {} grid positions trackable", cells.len()),
    );
    Ok(())
}
