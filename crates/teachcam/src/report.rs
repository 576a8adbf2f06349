//! What a run's report and the studio's review show, computed once: a report model of figures
//! (series of numbers, axes with units, marks), a summary of typed values and a header.
//! Front ends draw it (the report page, the studio); none recomputes a figure.
//!
//! Model: a report is `header + summary + [FigureSlot]`. A slot is a figure that could be
//! made (plot panels, or camera images) or a line saying why it could not ("no truth.csv:
//! ..."), so a front end never drops a figure silently. A panel is series over one shared
//! abscissa (time, frequency) or, for paths, series with their own `x`; its axes carry labels
//! and units; an equal-aspect panel gives square ranges so that a circle is drawn a circle.
//! Everything is plain data that serialises to JSON (serde), for a page to inline.
//!
//! Figures (paper Figs. 3-8 and §IV): trajectory components raw / smoothed / truth with the
//! residual raw − smoothed; the detrended, windowed amplitude spectrum with the cut-off
//! ([`spectrum`]); per-frame `tip_std_mm` and status; the paper's smoothing comparison; the
//! tip path to scale in three views and on the robot with its reach; the tip error against
//! the simulator's truth; the uncertainty over the working volume; what the cameras see.
//! [`review`] re-smooths at another cut-off and gives the review figures back (the studio's
//! slider).

pub mod cameras;
pub mod figures;
pub mod joints;
pub mod spectrum;
pub mod summary;

use std::path::Path;

use serde::Serialize;

use crate::camera::Rig;
use crate::geometry::Pose;
use crate::smooth::{CutoffConvention, Method, ShortRuns, SmoothConfig, SmoothError, smooth};
use crate::tool::Tool;
use crate::trajectory::Trajectory;

pub use summary::{SummaryItem, SummaryValue, summary_from_json};

/// Reach of the IRB 120 from axis 1 to the wrist centre, millimetres (ABB data sheet).
pub const IRB120_REACH_MM: f64 = 580.0;

/// Which figure a slot holds: a stable name for pages, tests and the studio.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FigureId {
    /// Trajectory components raw / smoothed / truth, with the residual raw − smoothed.
    Components,
    /// The detrended, windowed amplitude spectrum with the cut-off.
    Spectrum,
    /// Per-frame `tip_std_mm` and status.
    Quality,
    /// The paper's smoothing comparison (Figs. 4-6).
    SmoothingStudy,
    /// The tip path in three views, to scale.
    Paths,
    /// The tip path on the robot, seen from above, with its reach.
    Robot,
    /// Each axis's angle and speed along the checked path against its limits.
    Joints,
    /// The tip error against the simulator's truth.
    TipError,
    /// The tip uncertainty over the working volume.
    Uncertainty,
    /// Each camera's first frame with the detected blobs.
    Cameras,
}

impl FigureId {
    /// Every figure of a report, in the page's order.
    pub const ALL: [FigureId; 10] = [
        FigureId::Components,
        FigureId::Spectrum,
        FigureId::Quality,
        FigureId::SmoothingStudy,
        FigureId::Paths,
        FigureId::Robot,
        FigureId::Joints,
        FigureId::TipError,
        FigureId::Uncertainty,
        FigureId::Cameras,
    ];

    /// The figures [`review`] gives back.
    pub const REVIEW: [FigureId; 3] = [FigureId::Components, FigureId::Spectrum, FigureId::Quality];

    /// The name in JSON (`tip_error`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Components => "components",
            Self::Spectrum => "spectrum",
            Self::Quality => "quality",
            Self::SmoothingStudy => "smoothing_study",
            Self::Paths => "paths",
            Self::Robot => "robot",
            Self::Joints => "joints",
            Self::TipError => "tip_error",
            Self::Uncertainty => "uncertainty",
            Self::Cameras => "cameras",
        }
    }
}

/// One figure, or why it is missing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FigureSlot {
    /// Which figure.
    pub id: FigureId,
    /// Heading.
    pub title: String,
    /// What the figure shows and how to read it (with the numbers measured on this run).
    pub caption: String,
    /// The figure's content.
    #[serde(flatten)]
    pub body: FigureBody,
}

impl FigureSlot {
    /// A slot saying why its figure is missing.
    #[must_use]
    pub fn missing(id: FigureId, title: &str, reason: String) -> Self {
        Self {
            id,
            title: title.to_string(),
            caption: String::new(),
            body: FigureBody::Missing { reason },
        }
    }

    /// The reason, for a missing figure.
    #[must_use]
    pub fn missing_reason(&self) -> Option<&str> {
        match &self.body {
            FigureBody::Missing { reason } => Some(reason),
            _ => None,
        }
    }

    /// The panels, for a figure of plots (empty otherwise).
    #[must_use]
    pub fn panels(&self) -> &[Panel] {
        match &self.body {
            FigureBody::Plots { panels } => panels,
            _ => &[],
        }
    }
}

/// What a slot holds.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FigureBody {
    /// Plot panels, drawn top to bottom.
    Plots {
        /// The panels.
        panels: Vec<Panel>,
    },
    /// Images side by side (camera views).
    Images {
        /// The images.
        images: Vec<Image>,
    },
    /// The figure could not be made.
    Missing {
        /// Why, and what would make it (a file, a flag).
        reason: String,
    },
}

/// One plot: axes, series and marks.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Panel {
    /// Title above the plot.
    pub title: String,
    /// Horizontal axis.
    pub x_axis: Axis,
    /// Vertical axis.
    pub y_axis: Axis,
    /// The abscissae every series without its own `x` shares, increasing (time, frequency).
    pub x: Vec<f64>,
    /// The series, drawn in order (later ones on top).
    pub series: Vec<Series>,
    /// Lines and labels drawn over the plot.
    pub marks: Vec<Mark>,
    /// How the panel is shaped.
    pub shape: Shape,
}

/// An axis: what it shows, in which unit, on which scale.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Axis {
    /// What the axis shows (`tip x`, `frequency`).
    pub label: String,
    /// Its unit (`mm`, `Hz`, `deg`), empty for a count or a category.
    pub unit: String,
    /// Linear or logarithmic.
    pub scale: Scale,
    /// Named positions for a categorical axis (status: 0 = ok ... 3 = lost); empty for a
    /// numeric axis.
    pub ticks: Vec<Tick>,
    /// Fixed range `[min, max]`; `None` to fit the data.
    pub range: Option<[f64; 2]>,
}

impl Axis {
    /// A linear axis fitted to its data.
    #[must_use]
    pub fn linear(label: &str, unit: &str) -> Self {
        Self {
            label: label.to_string(),
            unit: unit.to_string(),
            scale: Scale::Linear,
            ticks: Vec::new(),
            range: None,
        }
    }

    /// A base-10 logarithmic axis fitted to its (positive) data.
    #[must_use]
    pub fn log(label: &str, unit: &str) -> Self {
        Self {
            scale: Scale::Log,
            ..Self::linear(label, unit)
        }
    }
}

/// Scale of an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    /// Linear.
    Linear,
    /// Base-10 logarithmic: every value of its series is positive or absent.
    Log,
}

/// A named position on a categorical axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tick {
    /// Where.
    pub value: f64,
    /// Its name.
    pub label: String,
}

/// How a panel is shaped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Shape {
    /// As wide as the page, of ordinary height.
    Wide,
    /// As wide as the page, low (a residual under its component).
    Short,
    /// To scale: one millimetre is as long across as up. `x_range` and `y_range` have equal
    /// spans and hold every point; the front end widens one of them for its plot's pixel
    /// aspect and keeps them equal under zoom.
    EqualAspect {
        /// Horizontal range, in the x axis' unit.
        x_range: [f64; 2],
        /// Vertical range, in the y axis' unit (the same span as `x_range`).
        y_range: [f64; 2],
    },
}

/// One line or set of points.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// What the series is, for its colour and style.
    pub role: Role,
    /// Its own abscissae (a path), or `None` to use the panel's `x`.
    pub x: Option<Vec<f64>>,
    /// One value per abscissa; `None` is a gap (no pose at that frame), never joined across.
    pub y: Vec<Option<f64>>,
    /// How it is drawn.
    pub style: Style,
}

/// What a series is: a front end colours by it, so raw is raw in every figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// Measured by tracking.
    Raw,
    /// After smoothing.
    Smoothed,
    /// The simulator's truth.
    Truth,
    /// A difference (raw − smoothed).
    Residual,
    /// A predicted uncertainty.
    Predicted,
    /// A limit (the robot's reach).
    Limit,
    /// A reference drawing (the robot's base).
    Reference,
    /// The first, second, third... of several like series (x, y, z).
    Component(u8),
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Style {
    /// A line through the points.
    Line,
    /// A dashed line.
    Dashed,
    /// Points only.
    Points,
    /// Steps (a categorical value held until the next frame).
    Steps,
}

/// A mark drawn over a panel.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Mark {
    /// A vertical line at `x` (the cut-off).
    VerticalLine {
        /// Where, in the x axis' unit.
        x: f64,
        /// Its label.
        label: String,
    },
    /// A horizontal line at `y`.
    HorizontalLine {
        /// Where, in the y axis' unit.
        y: f64,
        /// Its label.
        label: String,
    },
}

/// An image of a figure (a camera's view), PNG.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Image {
    /// What it shows (the camera's name).
    pub label: String,
    /// The PNG file, base64.
    pub png_base64: String,
    /// Width, pixels.
    pub width_px: u32,
    /// Height, pixels.
    pub height_px: u32,
}

/// The report's header: when, by what, from which files.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Header {
    /// When the report was made, `YYYY-MM-DD HH:MM UTC`.
    pub created_utc: String,
    /// The teachcam version that made it.
    pub teachcam_version: String,
    /// Each input, found or not.
    pub inputs: Vec<InputFile>,
}

impl Header {
    /// A header made now by this version of teachcam.
    #[must_use]
    pub fn now(inputs: Vec<InputFile>) -> Self {
        Self {
            created_utc: utc_text(std::time::SystemTime::now()),
            teachcam_version: env!("CARGO_PKG_VERSION").to_string(),
            inputs,
        }
    }
}

/// One input of a report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InputFile {
    /// What it is (`raw trajectory`, `truth`).
    pub role: String,
    /// Where it was read, or `None` when it was not found.
    pub path: Option<String>,
    /// What was looked for when it was not found; empty when found.
    pub note: String,
}

/// A report: header, summary and every figure slot, in [`FigureId::ALL`]'s order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// When, by what, from which files.
    pub header: Header,
    /// The run's numbers, formatted for people.
    pub summary: Vec<SummaryItem>,
    /// One slot per figure.
    pub figures: Vec<FigureSlot>,
}

/// An input that was not given: what was looked for (`no truth.csv in run/recording`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Absent(pub String);

/// An input of a report: given, or absent with what was looked for.
pub type Input<'a, T> = Result<&'a T, Absent>;

/// What a report is made from. Only the raw trajectory is required; each absent input turns
/// the figures that need it into slots saying so.
#[derive(Debug, Clone)]
pub struct ReportInputs<'a> {
    /// The header (dates, version, the input files).
    pub header: Header,
    /// The tracked trajectory.
    pub raw: &'a Trajectory,
    /// The smoothed trajectory; when absent the raw one is smoothed here at `cutoff_hz`.
    pub smoothed: Input<'a, Trajectory>,
    /// The simulator's truth.
    pub truth: Input<'a, Trajectory>,
    /// The rig (uncertainty map, camera views).
    pub rig: Input<'a, Rig>,
    /// The tool (uncertainty map, camera views).
    pub tool: Input<'a, Tool>,
    /// The recording folder (camera views).
    pub recording: Input<'a, Path>,
    /// The work object in the robot's base frame (the path on the robot).
    pub base_from_wobj: Input<'a, Pose>,
    /// The path checked on a robot (the joint figure).
    pub joints: Input<'a, joints::CheckedJoints>,
    /// The low-pass cut-off to mark on the spectrum (and to smooth at when no smoothed
    /// trajectory is given), Hz.
    pub cutoff_hz: f64,
    /// Seed of the smoothing comparison's noise.
    pub study_seed: u64,
    /// Numbers from elsewhere (the demo's run.json), shown after the report's own unless
    /// they repeat one of its keys.
    pub extra_summary: Vec<SummaryItem>,
}

/// The paper's low-pass at `cutoff_hz` (order 2, scipy's convention), short runs turned into
/// gaps: what the review and the report smooth with.
#[must_use]
pub fn lowpass_config(cutoff_hz: f64) -> SmoothConfig {
    SmoothConfig {
        method: Method::Lowpass {
            cutoff_hz,
            order: 2,
            convention: CutoffConvention::SinglePass,
        },
        short_runs: ShortRuns::Gap,
        ..SmoothConfig::default()
    }
}

/// `raw` smoothed as `teachcam smooth --method lowpass --cutoff HZ` does by default: outliers
/// dropped first, then the paper's low-pass at `cutoff_hz`.
///
/// # Errors
/// [`SmoothError`] as [`smooth`] (a cut-off at or above Nyquist, non-uniform time...).
pub fn smooth_for_review(raw: &Trajectory, cutoff_hz: f64) -> Result<Trajectory, SmoothError> {
    let mut kept = raw.clone();
    kept.drop_outliers();
    smooth(&kept, &lowpass_config(cutoff_hz))
}

/// The review figures at another cut-off, for the studio's slider: components with the
/// residual, the spectrum with the cut-off marked, `tip_std_mm` and status
/// ([`FigureId::REVIEW`], in that order). About 10 ms for 3,000 frames.
///
/// # Errors
/// [`SmoothError`] when `raw` cannot be smoothed at `cutoff_hz`.
pub fn review(
    raw: &Trajectory,
    cutoff_hz: f64,
    truth: Option<&Trajectory>,
) -> Result<Vec<FigureSlot>, SmoothError> {
    let smoothed = smooth_for_review(raw, cutoff_hz)?;
    let how = format!("low-pass {} Hz (order 2, zero phase)", short(cutoff_hz));
    Ok(vec![
        figures::components(raw, &smoothed, &how, truth),
        figures::spectrum(raw, truth, cutoff_hz),
        figures::quality(raw),
    ])
}

/// The whole report. Never fails: a figure that cannot be made is a slot saying why.
#[must_use]
pub fn build_report(inputs: &ReportInputs) -> Report {
    let smoothed_here;
    let (smoothed, how): (Result<&Trajectory, String>, String) = match &inputs.smoothed {
        Ok(s) => (
            Ok(*s),
            "smoothed (the smoothed trajectory file)".to_string(),
        ),
        Err(Absent(what)) => {
            smoothed_here = smooth_for_review(inputs.raw, inputs.cutoff_hz);
            let how = format!(
                "smoothed here: low-pass {} Hz, as `teachcam smooth` does ({what})",
                short(inputs.cutoff_hz)
            );
            match &smoothed_here {
                Ok(s) => (Ok(s), how),
                Err(e) => (
                    Err(format!("{what}, and the raw one cannot be smoothed: {e}")),
                    how,
                ),
            }
        }
    };
    let truth = inputs.truth.as_ref().ok().copied();
    let components = match &smoothed {
        Ok(s) => figures::components(inputs.raw, s, &how, truth),
        Err(reason) => FigureSlot::missing(
            FigureId::Components,
            figures::COMPONENTS_TITLE,
            reason.clone(),
        ),
    };
    let smoothed = smoothed.ok();
    let mut slots = vec![
        components,
        figures::spectrum(inputs.raw, truth, inputs.cutoff_hz),
        figures::quality(inputs.raw),
        figures::smoothing_study(inputs.study_seed),
        figures::paths(inputs.raw, smoothed),
        figures::robot(
            inputs.raw,
            smoothed,
            inputs.base_from_wobj.as_ref().ok().copied(),
        )
        .unwrap_or_else(|reason| {
            FigureSlot::missing(
                FigureId::Robot,
                figures::ROBOT_TITLE,
                reason_for(&inputs.base_from_wobj, reason),
            )
        }),
        match &inputs.joints {
            Ok(j) => joints::joint_figure(j),
            Err(Absent(what)) => FigureSlot::missing(
                FigureId::Joints,
                joints::JOINTS_TITLE,
                format!("{what}: the joint figure needs the robot the path is checked on"),
            ),
        },
        match &inputs.truth {
            Ok(t) => figures::tip_error(t, inputs.raw, smoothed),
            Err(Absent(what)) => FigureSlot::missing(
                FigureId::TipError,
                figures::TIP_ERROR_TITLE,
                format!("{what}: the tip-error figure needs the simulator's truth"),
            ),
        },
        match (&inputs.rig, &inputs.tool) {
            (Ok(rig), Ok(tool)) => cameras::uncertainty(rig, tool, inputs.raw),
            (rig, tool) => FigureSlot::missing(
                FigureId::Uncertainty,
                cameras::UNCERTAINTY_TITLE,
                format!(
                    "{}: the uncertainty map needs the rig and the tool",
                    absent_list(&[rig.as_ref().err(), tool.as_ref().err()])
                ),
            ),
        },
        match (&inputs.recording, &inputs.rig, &inputs.tool) {
            (Ok(recording), Ok(rig), Ok(tool)) => cameras::camera_views(recording, rig, tool),
            (recording, rig, tool) => FigureSlot::missing(
                FigureId::Cameras,
                cameras::CAMERAS_TITLE,
                format!(
                    "{}: the camera views need the recording, the rig and the tool",
                    absent_list(&[
                        recording.as_ref().err(),
                        rig.as_ref().err(),
                        tool.as_ref().err()
                    ])
                ),
            ),
        },
    ];
    slots.sort_by_key(|s| FigureId::ALL.iter().position(|id| *id == s.id));
    let mut summary = summary::run_summary(inputs, smoothed);
    for item in &inputs.extra_summary {
        if !summary.iter().any(|s| s.key == item.key) {
            summary.push(item.clone());
        }
    }
    Report {
        header: inputs.header.clone(),
        summary,
        figures: slots,
    }
}

/// The reason a figure is missing: what was absent, else what went wrong.
fn reason_for<T>(input: &Input<T>, otherwise: String) -> String {
    match input {
        Err(Absent(what)) => format!("{what}: {otherwise}"),
        Ok(_) => otherwise,
    }
}

/// The absent inputs, joined by `; `.
fn absent_list(absent: &[Option<&Absent>]) -> String {
    absent
        .iter()
        .flatten()
        .map(|a| a.0.as_str())
        .collect::<Vec<_>>()
        .join("; ")
}

/// A number as short as it can be written without losing digits that matter (`10`, `2.5`).
#[must_use]
pub fn short(value: f64) -> String {
    let text = format!("{value:.3}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// `YYYY-MM-DD HH:MM UTC` of a system time (proleptic Gregorian calendar; Hinnant's
/// days-to-civil algorithm).
#[must_use]
pub fn utc_text(time: std::time::SystemTime) -> String {
    let seconds = time
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let days = (seconds / 86_400) as i64;
    let of_day = seconds % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02} UTC",
        of_day / 3600,
        of_day % 3600 / 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pose_from_parts;
    use crate::sim::{Scenario, build_scene};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// The paper's stroke with 0.02 mm of white noise on the tool's position (the tip moves
    /// with it), and its truth.
    fn noisy_stroke() -> (Trajectory, Trajectory) {
        let truth = build_scene(Scenario::Paper, 1).truth;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let normal = Normal::new(0.0, 0.02).unwrap();
        let mut raw = truth.clone();
        for s in &mut raw.samples {
            let p = s.pose.as_mut().unwrap();
            let tip_in_tool = p.world_from_tool.inverse_transform_point(&p.tip_in_world);
            let mut t = p.world_from_tool.translation.vector;
            for c in 0..3 {
                t[c] += normal.sample(&mut rng);
            }
            p.world_from_tool = pose_from_parts(t, p.world_from_tool.rotation);
            p.tip_in_world = p.world_from_tool * tip_in_tool;
            s.tip_std_mm = Some(0.02);
        }
        raw.samples[50].status = crate::trajectory::Status::Degraded;
        (raw, truth)
    }

    fn panel<'a>(slots: &'a [FigureSlot], id: FigureId, title_starts: &str) -> &'a Panel {
        slots
            .iter()
            .find(|s| s.id == id)
            .unwrap()
            .panels()
            .iter()
            .find(|p| p.title.starts_with(title_starts))
            .unwrap()
    }

    #[test]
    fn the_residual_is_raw_minus_smoothed_frame_by_frame() {
        let (raw, truth) = noisy_stroke();
        let slots = review(&raw, 10.0, Some(&truth)).unwrap();
        assert_eq!(
            slots.iter().map(|s| s.id).collect::<Vec<_>>(),
            FigureId::REVIEW.to_vec()
        );
        let smoothed = smooth_for_review(&raw, 10.0).unwrap();
        let residual = panel(&slots, FigureId::Components, "residual of tip y");
        let drawn = &residual.series[0].y;
        assert_eq!(drawn.len(), raw.len());
        for ((d, r), s) in drawn.iter().zip(&raw.samples).zip(&smoothed.samples) {
            let expected = r.pose.unwrap().tip_in_world.y - s.pose.unwrap().tip_in_world.y;
            assert_eq!(*d, Some(expected));
        }
        // Raw, smoothed and truth are all drawn, each with every frame.
        let values = panel(&slots, FigureId::Components, "tip y");
        let labels: Vec<&str> = values.series.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(labels, ["truth", "raw", "smoothed"]);
        assert!(
            values
                .series
                .iter()
                .all(|s| s.y.iter().all(Option::is_some))
        );
        // The residual is the part of the 0.02 mm white noise the filter removes, beside what
        // it takes of the motion (independent of the noise). The zero-phase order-2 digital
        // Butterworth passes |H|² = 1 / (1 + (tan(πf/fs) / tan(πfc/fs))⁴) (bilinear
        // transform), so (1 − |H|²) leaves sqrt(mean over 0..15 Hz of (1 − |H|²)²) = 0.529 of
        // the noise's RMS at fc = 10 Hz, fs = 30 Hz: 0.0106 mm, ± 30 % for 120 samples.
        let truth_smoothed = smooth_for_review(&truth, 10.0).unwrap();
        let motion = figures::rms(
            truth
                .samples
                .iter()
                .zip(&truth_smoothed.samples)
                .map(|(t, s)| t.pose.unwrap().tip_in_world.y - s.pose.unwrap().tip_in_world.y),
        )
        .unwrap();
        let r = figures::rms(drawn.iter().flatten().copied()).unwrap();
        let low = (0.7f64 * 0.0106).hypot(motion);
        let high = (1.3f64 * 0.0106).hypot(motion);
        assert!((low..high).contains(&r), "{r} with the motion's {motion}");
    }

    #[test]
    fn the_spectrum_marks_the_cutoff_and_the_truth_floor_lies_under_the_noise() {
        let (raw, truth) = noisy_stroke();
        let slot = figures::spectrum(&raw, Some(&truth), 10.0);
        let p = &slot.panels()[0];
        assert_eq!(p.y_axis.scale, Scale::Log);
        assert!(matches!(&p.marks[0], Mark::VerticalLine { x, .. } if *x == 10.0));
        assert!(
            p.series
                .iter()
                .all(|s| s.y.iter().flatten().all(|v| *v > 0.0))
        );
        // White noise of σ = 0.02 mm over n = 120 Hann-windowed samples: each bin's amplitude
        // is Rayleigh with mean sqrt(π/4) · 2σ · sqrt(Σw²) / Σw = σ · sqrt(π · 1.5 / n) = 0.0040 mm
        // (median 0.94 of that). The truth's floor, windowed, is its own motion's leak
        // (measured 1.75e-4 mm above 10 Hz): a twentieth of the noise's.
        let median_above = |s: &Series| {
            spectrum::median_above(
                &p.x,
                &s.y.iter().map(|v| v.unwrap_or(0.0)).collect::<Vec<_>>(),
                10.0,
            )
            .unwrap()
        };
        let expected = 0.02 * (std::f64::consts::PI * 1.5 / 120.0).sqrt() * 0.94;
        for s in &p.series[..3] {
            let m = median_above(s);
            assert!(
                (0.6 * expected..1.6 * expected).contains(&m),
                "{}: {m}",
                s.label
            );
        }
        for s in &p.series[3..] {
            assert!(median_above(s) < 0.1 * expected, "{}", s.label);
        }
    }

    #[test]
    fn paths_are_drawn_to_scale_and_hold_every_point() {
        let (raw, _) = noisy_stroke();
        let wobj = crate::geometry::parse_pose("350,0,100,0,1,0,0").unwrap();
        let slots = [
            figures::paths(&raw, None),
            figures::robot(&raw, None, Some(&wobj)).unwrap(),
        ];
        for panel in slots.iter().flat_map(FigureSlot::panels) {
            let Shape::EqualAspect { x_range, y_range } = panel.shape else {
                panic!("{} is not to scale", panel.title);
            };
            let span = x_range[1] - x_range[0];
            assert!((span - (y_range[1] - y_range[0])).abs() < 1e-9 * span);
            for s in &panel.series {
                for (x, y) in s.x.as_ref().unwrap().iter().zip(&s.y) {
                    if let Some(y) = y {
                        assert!((x_range[0]..=x_range[1]).contains(x), "{}", panel.title);
                        assert!((y_range[0]..=y_range[1]).contains(y), "{}", panel.title);
                    }
                }
            }
        }
        // The reach circle is a circle of the data sheet's radius about axis 1.
        let reach = &slots[1].panels()[0].series[1];
        for (x, y) in reach.x.as_ref().unwrap().iter().zip(&reach.y) {
            assert!((x.hypot(y.unwrap()) - IRB120_REACH_MM).abs() < 1e-9);
        }
    }

    #[test]
    fn a_missing_input_leaves_a_slot_that_says_why() {
        let (raw, _) = noisy_stroke();
        let inputs = ReportInputs {
            header: Header::now(Vec::new()),
            raw: &raw,
            smoothed: Err(Absent("no smoothed.csv".into())),
            truth: Err(Absent("no truth.csv in run/recording".into())),
            rig: Err(Absent("no rig.json".into())),
            tool: Err(Absent("no tool.json".into())),
            recording: Err(Absent("no recording folder".into())),
            base_from_wobj: Err(Absent("no work object (--wobj)".into())),
            joints: Err(Absent("no robot (--robot)".into())),
            cutoff_hz: 10.0,
            study_seed: 1,
            extra_summary: Vec::new(),
        };
        let report = build_report(&inputs);
        assert_eq!(
            report.figures.iter().map(|s| s.id).collect::<Vec<_>>(),
            FigureId::ALL.to_vec()
        );
        let reason = |id: FigureId| {
            report
                .figures
                .iter()
                .find(|s| s.id == id)
                .unwrap()
                .missing_reason()
                .map(str::to_string)
        };
        assert_eq!(
            reason(FigureId::TipError).as_deref(),
            Some("no truth.csv in run/recording: the tip-error figure needs the simulator's truth")
        );
        assert!(
            reason(FigureId::Uncertainty)
                .unwrap()
                .starts_with("no rig.json; no tool.json")
        );
        assert!(
            reason(FigureId::Cameras)
                .unwrap()
                .contains("no recording folder")
        );
        assert!(
            reason(FigureId::Robot)
                .unwrap()
                .starts_with("no work object (--wobj)")
        );
        // The rest are drawn, the components from a trajectory smoothed here.
        for id in [
            FigureId::Components,
            FigureId::Spectrum,
            FigureId::Quality,
            FigureId::SmoothingStudy,
            FigureId::Paths,
        ] {
            assert_eq!(reason(id), None, "{id:?}");
        }
        let components = &report.figures[0];
        assert!(components.caption.contains("smoothed here: low-pass 10 Hz"));
        // The summary is typed and worded.
        let frames = report.summary.iter().find(|s| s.key == "frames").unwrap();
        assert_eq!(frames.text, "120 frames");
        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(json["figures"][7]["kind"], "missing");
        assert_eq!(json["figures"][0]["kind"], "plots");
    }

    #[test]
    fn utc_text_counts_days_as_the_calendar_does() {
        let at = |s: u64| utc_text(std::time::UNIX_EPOCH + std::time::Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01 00:00 UTC");
        // 2000-02-29 12:34 UTC (a leap day in a century year divisible by 400).
        assert_eq!(at(951_827_640), "2000-02-29 12:34 UTC");
        // 2026-12-02 07:30 UTC.
        assert_eq!(at(1_796_196_600), "2026-12-02 07:30 UTC");
    }
}
