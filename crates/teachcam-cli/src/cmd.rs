//! One module per subcommand.

pub mod c3d;
pub mod demo;
pub mod detect;
pub mod import;
pub mod repeatability;
pub mod simulate;
pub mod tool_check;
pub mod track;
pub mod uncertainty;
pub mod uncertainty_map;
