//! `teachcam simulate`: write a simulated recording with its ground truth.

use std::path::PathBuf;

use anyhow::Context;
use teachcam::sim::{Scenario, build_scene, write_scene};

use crate::progress::Progress;

/// Write a simulated recording with its ground truth.
///
/// Writes one folder per camera of 8-bit PNG frames, `recording.json`,
/// `rig.json`, `tool.json`, the true trajectory `truth.csv` and the exact projection of every
/// marker centre in every view `projections.csv`.
///
/// Scenarios: `paper` (the paper's three-camera rig and four-sphere brush, a 4 s painter's stroke
/// at 30 Hz), `static` (the brush at rest, 100 frames), `occluded` (markers hidden in some views,
/// glints, a glint touching a marker), `four-cameras`.
///
/// Example: `teachcam simulate --scenario paper --out rec`
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scenario name: paper, static, occluded or four-cameras.
    #[arg(long, default_value = "paper")]
    pub scenario: String,
    /// Output folder (created; files in it are replaced).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of the image noise and the random glints: the same seed gives the same files.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write only the first N frames of the scenario.
    #[arg(long)]
    pub frames: Option<usize>,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let scenario = Scenario::from_name(&args.scenario).with_context(|| {
        let names: Vec<&str> = Scenario::ALL.iter().map(|s| s.name()).collect();
        format!(
            "unknown scenario '{}' (choose from {})",
            args.scenario,
            names.join(", ")
        )
    })?;
    let mut scene = build_scene(scenario, args.seed);
    if let Some(frames) = args.frames {
        if frames == 0 {
            anyhow::bail!("--frames must be at least 1");
        }
        scene.truth.samples.truncate(frames);
    }
    let progress = Progress::new("simulate", scene.truth.len() as u64);
    write_scene(&scene, &args.out, args.seed, &|| progress.tick())
        .with_context(|| format!("writing the simulation to {}", args.out.display()))?;
    progress.finish();
    eprintln!(
        "wrote {} frames x {} cameras of scenario '{}' to {}",
        scene.truth.len(),
        scene.rig.len(),
        scenario.name(),
        args.out.display()
    );
    Ok(())
}
