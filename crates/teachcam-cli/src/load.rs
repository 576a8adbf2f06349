//! The user's rig and tool files and `--tcp`, read and checked for unit mistakes: every command
//! loads them here, so every command warns of a length that is likely in metres
//! ([`teachcam::io::plausible`]).

use std::path::Path;

use teachcam::camera::Rig;
use teachcam::geometry::Pose;
use teachcam::io::plausible::{rig_warning, tcp_warning, tool_warning};
use teachcam::tool::Tool;

use crate::Rejected as _;

/// The tool file, read (rejected data when it cannot be); warns of markers under 1 mm apart.
pub fn tool(path: &Path) -> anyhow::Result<Tool> {
    let tool = teachcam::io::tool::read_tool(path).rejected()?;
    if let Some(warning) = tool_warning(&tool) {
        crate::announce::warn(&format!("{}: {warning}", path.display()));
    }
    Ok(tool)
}

/// The rig file, read (rejected data when it cannot be); warns of cameras all within 50 mm of
/// the origin or one beyond 50 m.
pub fn rig(path: &Path) -> anyhow::Result<Rig> {
    let rig = teachcam::io::rig::read_rig(path).rejected()?;
    if let Some(warning) = rig_warning(&rig) {
        crate::announce::warn(&format!("{}: {warning}", path.display()));
    }
    Ok(rig)
}

/// Warns of a `--tcp` under 5 mm from the flange (and not on it).
pub fn check_tcp(flange_from_tcp: &Pose) {
    if let Some(warning) = tcp_warning(flange_from_tcp) {
        crate::announce::warn(&warning.to_string());
    }
}
