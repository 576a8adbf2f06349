//! One module per subcommand.

pub mod demo;
pub mod smooth;
pub mod smoothing_study;
pub mod spectrum;
