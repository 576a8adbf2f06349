//! `teachcam uncertainty`: Monte Carlo tool-tip uncertainty at a pose (paper §IV-B).

use std::path::PathBuf;

use anyhow::Context;
use teachcam::geometry::parse_pose;
use teachcam::metrology::{first_order, monte_carlo};
use teachcam::track::TrackConfig;

use crate::Rejected;

/// Tool-tip uncertainty at a pose, by Monte Carlo through the tracking chain.
///
/// The markers are projected into every camera, Gaussian pixel
/// noise is added, and each noisy copy runs through the real tracking chain (correspondence,
/// triangulation, identification, registration). Prints JSON: `tip_std_mm` (x, y, z), `tip_rms_mm`,
/// `position_std_mm`, `rotation_std_deg` (about world x, y, z), `failed_trials`, `tip_bias_mm`,
/// and the closed-form first-order propagation of the same noise under `first_order`.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam uncertainty --rig rec/rig.json --tool rec/tool.json --pose "0,0,190,1,0,0,0" --pixel-noise 0.15 --trials 10000
  teachcam uncertainty --rig rec/rig.json --tool rec/tool.json --pose "0,0,190,1,0,0,0" --pixel-noise 0.15 --camera-dropped cam1"#)]
pub struct Args {
    /// Camera rig (rig.json).
    #[arg(long)]
    pub rig: PathBuf,
    /// Tool model (tool.json).
    #[arg(long)]
    pub tool: PathBuf,
    /// The tool's pose in the world, `x,y,z,qw,qx,qy,qz` (mm, unit quaternion): T_world_tool as
    /// in a trajectory row.
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::pose)]
    pub pose: String,
    /// Standard deviation of the marker centres, pixels per axis (the paper measured 0.15).
    #[arg(long, default_value_t = 0.15, value_parser = crate::flags::positive)]
    pub pixel_noise: f64,
    /// Number of Monte Carlo trials.
    #[arg(long, default_value_t = 10_000, value_parser = crate::flags::trials)]
    pub trials: usize,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Leave this camera out (the paper's rig must work with one camera missing).
    #[arg(long)]
    pub camera_dropped: Option<String>,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut rig = crate::load::rig(&args.rig)?;
    let tool = crate::load::tool(&args.tool)?;
    let pose = parse_pose(&args.pose).context("--pose")?;
    if let Some(name) = &args.camera_dropped {
        let before = rig.cameras.len();
        rig.cameras.retain(|c| &c.name != name);
        if rig.cameras.len() == before {
            return Err(anyhow::anyhow!(
                "--camera-dropped: the rig has no camera named '{name}'"
            ))
            .rejected();
        }
    }
    let config = TrackConfig::default();
    let mc = monte_carlo(
        &rig,
        &tool,
        &pose,
        args.pixel_noise,
        args.trials,
        args.seed,
        &config,
    )
    .rejected()?;
    let fo = first_order(&rig, &tool, &pose, args.pixel_noise).rejected()?;
    let u = &mc.uncertainty;
    let report = serde_json::json!({
        "pixel_noise_px": args.pixel_noise,
        "trials": mc.trials,
        "failed_trials": mc.failed_trials,
        "tip_std_mm": u.tip_std_mm,
        "tip_rms_mm": u.tip_rms_mm,
        "tip_bias_mm": mc.tip_bias_mm,
        "position_std_mm": u.position_std_mm,
        "rotation_std_deg": u.rotation_std_deg,
        "first_order": fo,
        "cameras": rig.cameras.iter().map(|c| c.name.clone()).collect::<Vec<_>>(),
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
