//! One module per subcommand.

pub mod calibrate;
pub mod demo;
pub mod simulate;
pub mod tool_check;
pub mod uncertainty;
pub mod uncertainty_map;
