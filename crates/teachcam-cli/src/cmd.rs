//! One module per subcommand.

pub mod c3d;
pub mod demo;
pub mod import;
pub mod simulate;
pub mod tool_check;
pub mod uncertainty;
pub mod uncertainty_map;
