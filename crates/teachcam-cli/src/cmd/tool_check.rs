//! `teachcam tool-check`: what a tool's marker layout promises before any recording.

use std::path::PathBuf;

use teachcam::identify::IdentifyConfig;
use teachcam::metrology::tool_design;

use crate::Rejected;

/// Check a tool's marker layout before recording with it.
///
/// Reports the identification margin (the two marker distances closest to
/// each other, against the identification tolerance), the expected tip error per unit marker
/// error (Fitzpatrick–West–Maurer), and warnings. Prints JSON; exits 1 when the tool would be
/// refused by `track`.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam tool-check rec/tool.json"#)]
pub struct Args {
    /// Tool model (tool.json).
    pub tool: PathBuf,
    /// Identification tolerance on marker distances, millimetres (as `track` uses).
    #[arg(long, default_value_t = IdentifyConfig::default().distance_tolerance_mm, value_parser = crate::flags::positive)]
    pub tolerance_mm: f64,
}

/// Run the command.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let tool = crate::load::tool(&args.tool)?;
    let design = tool_design(&tool, args.tolerance_mm);
    println!("{}", serde_json::to_string_pretty(&design)?);
    let config = IdentifyConfig {
        distance_tolerance_mm: args.tolerance_mm,
    };
    teachcam::identify::check_identifiable(&tool, &config).rejected()
}
