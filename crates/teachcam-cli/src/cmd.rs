//! One module per subcommand.

pub mod align;
pub mod check;
pub mod demo;
pub mod export;
pub mod pivot;
pub mod simulate;
