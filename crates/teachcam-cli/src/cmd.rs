//! One module per subcommand.

pub mod align;
pub mod c3d;
pub mod calibrate;
pub mod check;
pub mod demo;
pub mod detect;
pub mod doctor;
pub mod export;
pub mod export_mcap;
pub mod import;
pub mod live;
pub mod pivot;
pub mod record;
pub mod repeatability;
pub mod replay;
pub mod report;
pub mod simulate;
pub mod smooth;
pub mod smoothing_study;
pub mod spectrum;
pub mod strokes;
pub mod studio;
pub mod tool_check;
pub mod track;
pub mod uncertainty;
pub mod uncertainty_map;
