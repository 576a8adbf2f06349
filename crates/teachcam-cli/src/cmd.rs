//! One module per subcommand.

pub mod align;
pub mod c3d;
pub mod check;
pub mod calibrate;
pub mod demo;
pub mod detect;
pub mod export;
pub mod import;
pub mod pivot;
pub mod repeatability;
pub mod simulate;
pub mod tool_check;
pub mod track;
pub mod uncertainty;
pub mod uncertainty_map;
