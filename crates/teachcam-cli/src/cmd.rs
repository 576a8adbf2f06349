//! One module per subcommand.

pub mod demo;
pub mod detect;
pub mod repeatability;
pub mod simulate;
pub mod tool_check;
pub mod uncertainty;
pub mod uncertainty_map;
