//! One module per subcommand.

pub mod demo;
pub mod detect;
pub mod repeatability;
pub mod simulate;
pub mod uncertainty;
