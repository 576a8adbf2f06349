//! The path the robot runs, as `check`, `export`, `export mcap`, `report --robot` and the
//! studio's Robot & export tab all check it: the targets within a span of the take, cut into
//! strokes (where the tip leaves the work surface or pauses), the roll about the tool's axis
//! chosen where it is free, and each stroke checked on its own at one time scale.

use std::ops::Range;

use super::check::{CheckConfig, CheckReport, check_strokes};
use super::free_axis::{FreeAxisConfig, choose_roll};
use super::kinematics::Robot;
use super::strokes::{
    Span, Stroke, StrokeConfig, TrimError, find_strokes, lowest_height_mm, whole_take,
};
use super::{Cell, TcpTarget};

/// Which part of a take is checked and how it splits into strokes (`--from`, `--to`,
/// `--lift-mm`, `--pause-s`, `--pause-speed-mm-s`, `--free-tool-axis`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PathOptions {
    /// Start of the span, seconds of the take's time (`None`: its start).
    pub from_s: Option<f64>,
    /// End of the span, seconds (`None`: its end).
    pub to_s: Option<f64>,
    /// Where strokes are cut.
    pub strokes: StrokeConfig,
    /// The rotation about the tool's axis is free: chosen per frame ([`choose_roll`]).
    pub free_tool_axis: bool,
}

/// Why a path cannot be checked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PathError {
    /// The span asked for lies outside the take or is empty.
    #[error(transparent)]
    Span(#[from] TrimError),
    /// Fewer than two frames of the span have a pose.
    #[error("fewer than two frames with a pose in the span checked")]
    TooFewPoses,
}

/// A path as the robot runs it, checked.
#[derive(Debug, Clone)]
pub struct CheckedPath {
    /// The targets within the span, the roll chosen where the tool's axis is free.
    pub targets: Vec<TcpTarget>,
    /// Their strokes.
    pub strokes: Vec<Stroke>,
    /// The line saying the roll was chosen, when it was.
    pub tool_axis: Option<String>,
    /// When the span never touches the work surface: the line saying so (it is then checked
    /// whole, as one stroke).
    pub no_stroke: Option<String>,
    /// Each stroke checked on its own, at one time scale.
    pub report: CheckReport,
}

impl CheckedPath {
    /// The strokes as ranges of [`CheckedPath::targets`].
    #[must_use]
    pub fn target_ranges(&self) -> Vec<Range<usize>> {
        stroke_ranges(&self.strokes)
    }

    /// The strokes as ranges of the report's frames (the strokes' frames in order), as
    /// [`crate::robot::program::build_stroke_program`] takes them.
    #[must_use]
    pub fn frame_ranges(&self) -> Vec<Range<usize>> {
        let mut at = 0;
        self.strokes
            .iter()
            .map(|s| {
                let frames = at..at + s.targets.len();
                at = frames.end;
                frames
            })
            .collect()
    }
}

/// The strokes' ranges of targets.
#[must_use]
pub fn stroke_ranges(strokes: &[Stroke]) -> Vec<Range<usize>> {
    strokes.iter().map(|s| s.targets.clone()).collect()
}

/// The line saying a span has no stroke: where it is and how low the tip came.
#[must_use]
pub fn no_stroke_line(span: &Span, trimmed: &[TcpTarget], lift_mm: f64) -> String {
    let lowest = lowest_height_mm(trimmed).map_or_else(
        || "no frame has a pose".to_string(),
        |h| format!("the tip's lowest height is {h:.1} mm"),
    );
    format!(
        "no stroke in {:.3}-{:.3} s: the tip never comes within --lift-mm {lift_mm} of the work surface (the world's xy-plane) for two frames; {lowest}",
        span.from_s, span.to_s
    )
}

/// The targets of a take running `take_s` (first and last times of every frame) within the
/// span of `options`, cut into strokes (a span that never touches the work surface is
/// checked whole, said in [`CheckedPath::no_stroke`]), the roll chosen where the tool's axis
/// is free, and their check.
///
/// # Errors
/// [`PathError::Span`] for a span outside the take or empty; [`PathError::TooFewPoses`] when
/// fewer than two frames of the span have a pose.
pub fn checked_path(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    take_s: (f64, f64),
    options: &PathOptions,
    config: &CheckConfig,
) -> Result<CheckedPath, PathError> {
    let span = Span::within(take_s.0, take_s.1, options.from_s, options.to_s)?;
    let trimmed = span.trim(targets);
    let mut strokes = find_strokes(&trimmed, &options.strokes);
    let mut no_stroke = None;
    if strokes.is_empty() {
        no_stroke = Some(no_stroke_line(&span, &trimmed, options.strokes.lift_mm));
        strokes = vec![whole_take(&trimmed).ok_or(PathError::TooFewPoses)?];
    }
    let ranges = stroke_ranges(&strokes);
    let (targets, tool_axis) = if options.free_tool_axis {
        let free = choose_roll(
            robot,
            cell,
            &trimmed,
            &ranges,
            config,
            &FreeAxisConfig::default(),
        );
        let line = free.describe();
        (free.targets, Some(line))
    } else {
        (trimmed, None)
    };
    let report = check_strokes(robot, cell, &targets, &ranges, config);
    Ok(CheckedPath {
        targets,
        strokes,
        tool_axis,
        no_stroke,
        report,
    })
}
