//! `teachcam demo`: the paper's setup, simulated, through the whole pipeline.

use std::path::PathBuf;

/// Simulate a painter's stroke seen by the paper's three-camera rig and run the pipeline on it.
///
/// Example: `teachcam demo --out demo-run`
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Folder for the recording, trajectories, robot program and report.
    #[arg(long, default_value = "teachcam-demo")]
    pub out: PathBuf,
}

/// Run the demo.
pub fn run(args: &Args) -> anyhow::Result<()> {
    println!(
        "teachcam demo: output folder {} (pipeline under construction)",
        args.out.display()
    );
    Ok(())
}
