//! The robot's joints along the path against their limits: the per-axis lines `check` prints,
//! from one [`CheckReport`] (speeds at the played timing, after time scaling).

use std::ops::Range;

use super::{Axis, FigureBody, FigureId, FigureSlot, Mark, Panel, Role, Series, Shape, Style};
use crate::robot::check::CheckReport;

/// One line per axis, e.g. "axis 1: peak 123 deg/s, 49 % of 250 deg/s; angles -20..35 deg
/// of -165..165": what `check` prints.
#[must_use]
pub fn joint_lines(check: &CheckReport) -> Vec<String> {
    (0..6)
        .map(|axis| {
            let limit = check.robot.limits[axis];
            let angles: Vec<f64> = check
                .frames
                .iter()
                .filter_map(|f| f.joints.map(|j| j.0[axis].to_degrees()))
                .collect();
            let range = match (
                angles.iter().copied().reduce(f64::min),
                angles.iter().copied().reduce(f64::max),
            ) {
                (Some(low), Some(high)) => format!("angles {low:.0}..{high:.0} deg"),
                _ => "no angles".to_string(),
            };
            format!(
                "axis {}: peak {:.0} deg/s, {:.0} % of {:.0} deg/s; {range} of {:.0}..{:.0}",
                axis + 1,
                check.peak_joint_speed[axis].to_degrees(),
                100.0 * check.peak_joint_speed[axis] / limit.max_speed,
                limit.max_speed.to_degrees(),
                limit.min.to_degrees(),
                limit.max.to_degrees()
            )
        })
        .collect()
}

/// Heading of [`FigureId::Joints`].
pub const JOINTS_TITLE: &str = "Joint angles and speeds against the limits";

/// The path the robot runs as `check` checks it: the check of the strokes' targets (at one
/// time scale), the strokes as ranges of the targets checked, and the share of each axis's
/// data-sheet speed the check allows.
#[derive(Debug, Clone)]
pub struct CheckedJoints {
    /// The check, frames in stroke order, times scaled.
    pub check: CheckReport,
    /// Each stroke's targets, as ranges of the concatenated frames of `check`.
    pub strokes: Vec<Range<usize>>,
    /// The share of each axis's speed limit the path may use ([`CheckConfig::speed_fraction`]).
    ///
    /// [`CheckConfig::speed_fraction`]: crate::robot::check::CheckConfig::speed_fraction
    pub speed_fraction: f64,
}

impl CheckedJoints {
    /// The joints of `check`, made by [`check_strokes`] of `strokes` (ranges of the targets it
    /// was given), at `speed_fraction`.
    ///
    /// [`check_strokes`]: crate::robot::check::check_strokes
    #[must_use]
    pub fn new(check: CheckReport, strokes: &[Range<usize>], speed_fraction: f64) -> Self {
        let mut start = 0;
        let strokes = strokes
            .iter()
            .map(|s| {
                let frames = start..start + s.len();
                start = frames.end;
                frames
            })
            .collect();
        Self {
            check,
            strokes,
            speed_fraction,
        }
    }
}

/// The joint figure: per axis, its angle over the played time between the axis's range, and
/// its speed between ± its data-sheet limit and ± the share the check allows. A frame
/// without joints, a frame missing from the take, and the lift between strokes are gaps; the
/// speed at a stroke's first frame (none measured) is a gap. The time axis is the played
/// one: the demonstration's times multiplied by the check's time scale, said in the caption.
#[must_use]
pub fn joint_figure(joints: &CheckedJoints) -> FigureSlot {
    let check = &joints.check;
    if check.frames.iter().all(|f| f.joints.is_none()) {
        return FigureSlot::missing(
            FigureId::Joints,
            JOINTS_TITLE,
            format!(
                "the {} reaches no frame of the path with its joints in range: no joint angle to draw",
                check.robot.name
            ),
        );
    }
    let stroke_starts: Vec<usize> = joints.strokes.iter().map(|s| s.start).collect();
    // The abscissae, with a break (a gap of every series) where frames are not consecutive.
    let mut x = Vec::new();
    let mut at: Vec<Option<usize>> = Vec::new();
    for (i, f) in check.frames.iter().enumerate() {
        if let Some(prev) = i.checked_sub(1).map(|p| &check.frames[p])
            && (f.target.frame.0 != prev.target.frame.0 + 1 || stroke_starts.contains(&i))
        {
            x.push(0.5 * (prev.target.time_s + f.target.time_s));
            at.push(None);
        }
        x.push(f.target.time_s);
        at.push(Some(i));
    }
    let series = |label: String, axis: usize, value: &dyn Fn(usize) -> Option<f64>| Series {
        label,
        role: Role::Component(axis as u8),
        x: None,
        y: at.iter().map(|i| i.and_then(value)).collect(),
        style: Style::Line,
    };
    let mut panels = Vec::with_capacity(12);
    for axis in 0..6 {
        let limit = check.robot.limits[axis];
        let (low, high) = (limit.min.to_degrees(), limit.max.to_degrees());
        let angle = series(format!("axis {} angle", axis + 1), axis, &|i| {
            check.frames[i].joints.map(|j| j.0[axis].to_degrees())
        });
        let range = padded(&angle.y, &[low, high]);
        panels.push(Panel {
            title: format!("axis {} angle, range {low:.0}..{high:.0} deg", axis + 1),
            x_axis: Axis::linear("time (played)", "s"),
            y_axis: Axis {
                range: Some(range),
                ..Axis::linear(&format!("axis {} angle", axis + 1), "deg")
            },
            x: x.clone(),
            series: vec![angle],
            marks: vec![
                Mark::HorizontalLine {
                    y: low,
                    label: format!("min {low:.0} deg"),
                },
                Mark::HorizontalLine {
                    y: high,
                    label: format!("max {high:.0} deg"),
                },
            ],
            shape: Shape::Short,
        });
        let max_speed = limit.max_speed.to_degrees();
        let allowed = joints.speed_fraction * max_speed;
        let speed = series(format!("axis {} speed", axis + 1), axis, &|i| {
            let measured = i > 0
                && !stroke_starts.contains(&i)
                && check.frames[i].joints.is_some()
                && check.frames[i - 1].joints.is_some();
            measured.then(|| check.frames[i].joint_speed[axis].to_degrees())
        });
        let range = padded(&speed.y, &[-max_speed, max_speed]);
        let mut marks = vec![
            Mark::HorizontalLine {
                y: max_speed,
                label: format!("limit {max_speed:.0} deg/s"),
            },
            Mark::HorizontalLine {
                y: -max_speed,
                label: format!("limit -{max_speed:.0} deg/s"),
            },
        ];
        if joints.speed_fraction < 1.0 {
            marks.extend([
                Mark::HorizontalLine {
                    y: allowed,
                    label: format!("allowed {allowed:.0} deg/s"),
                },
                Mark::HorizontalLine {
                    y: -allowed,
                    label: format!("allowed -{allowed:.0} deg/s"),
                },
            ]);
        }
        panels.push(Panel {
            title: format!(
                "axis {} speed, limit {max_speed:.0} deg/s ({:.0} % allowed)",
                axis + 1,
                100.0 * joints.speed_fraction
            ),
            x_axis: Axis::linear("time (played)", "s"),
            y_axis: Axis {
                range: Some(range),
                ..Axis::linear(&format!("axis {} speed", axis + 1), "deg/s")
            },
            x: x.clone(),
            series: vec![speed],
            marks,
            shape: Shape::Short,
        });
    }
    let failing = check.failing().count();
    let verdict = if failing == 0 {
        "every frame passes".to_string()
    } else {
        format!("{failing} of {} frames fail", check.frames.len())
    };
    FigureSlot {
        id: FigureId::Joints,
        title: JOINTS_TITLE.into(),
        caption: format!(
            "The {} along the path as `teachcam check` checks it ({} stroke{}, {} frames; {verdict}). {}; the time axis is the played time. Angles between the axis's range (dashed), speeds between ± the data sheet's limit and ± the {:.0} % the check allows; gaps are frames without joints, frames missing from the take, and the lifts between strokes. {}.",
            check.robot.name,
            joints.strokes.len(),
            if joints.strokes.len() == 1 { "" } else { "s" },
            check.frames.len(),
            check.timing.describe(&check.robot.name),
            100.0 * joints.speed_fraction,
            joint_lines(check).join("; ")
        ),
        body: FigureBody::Plots { panels },
    }
}

/// The span of `values` and `limits` together, widened 8 % each side so that a limit line
/// is drawn inside the plot.
fn padded(values: &[Option<f64>], limits: &[f64]) -> [f64; 2] {
    let all = values.iter().flatten().chain(limits).copied();
    let (low, high) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
        (l.min(v), h.max(v))
    });
    let pad = 0.08 * (high - low).max(1e-9);
    [low - pad, high + pad]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::parse_pose;
    use crate::robot::check::{CheckConfig, TimeScale, check_strokes};
    use crate::robot::kinematics::Robot;
    use crate::robot::{Cell, tcp_targets};
    use crate::sim::{Scenario, build_scene};
    use nalgebra::UnitQuaternion;

    /// The paper's stroke on the IRB 120 as the demo places it, cut into two strokes at
    /// frame 60 and played twice as slow.
    fn two_strokes() -> (CheckedJoints, Vec<crate::robot::TcpTarget>) {
        let truth = build_scene(Scenario::Paper, 1).truth;
        let targets = tcp_targets(&truth, &UnitQuaternion::identity());
        let cell = Cell {
            base_from_wobj: parse_pose("350,0,100,1,0,0,0").unwrap(),
            flange_from_tcp: parse_pose("0,0,200,0,1,0,0").unwrap(),
        };
        let config = CheckConfig {
            time_scale: TimeScale::Fixed(2.0),
            ..CheckConfig::default()
        };
        let strokes = [0..60, 60..targets.len()];
        let robot = Robot::by_name("irb120").unwrap();
        let check = check_strokes(&robot, &cell, &targets, &strokes, &config);
        (
            CheckedJoints::new(check, &strokes, config.speed_fraction),
            targets,
        )
    }

    #[test]
    fn the_joint_figure_draws_each_axis_against_its_limits_at_the_played_time() {
        let (joints, targets) = two_strokes();
        let slot = joint_figure(&joints);
        let panels = slot.panels();
        assert_eq!(panels.len(), 12);
        let check = &joints.check;
        assert!(check.frames.iter().all(|f| f.joints.is_some()));
        for axis in 0..6 {
            let limit = check.robot.limits[axis];
            let (angle, speed) = (&panels[2 * axis], &panels[2 * axis + 1]);
            // One break, between the strokes; every frame's angle is the check's.
            assert_eq!(angle.x.len(), check.frames.len() + 1);
            let drawn: Vec<f64> = angle.series[0].y.iter().flatten().copied().collect();
            let checked: Vec<f64> = check
                .frames
                .iter()
                .map(|f| f.joints.unwrap().0[axis].to_degrees())
                .collect();
            assert_eq!(drawn, checked);
            assert_eq!(angle.series[0].y[60], None);
            // The range's limit lines, inside the plotted range.
            let lines: Vec<f64> = angle
                .marks
                .iter()
                .map(|m| match m {
                    Mark::HorizontalLine { y, .. } => *y,
                    Mark::VerticalLine { .. } => f64::NAN,
                })
                .collect();
            assert_eq!(lines, [limit.min.to_degrees(), limit.max.to_degrees()]);
            let [low, high] = angle.y_axis.range.unwrap();
            assert!(low < lines[0] && lines[1] < high);
            // Speeds: ± the data sheet's and ± 90 % of it, plotted; none at a stroke's
            // start; elsewhere the angles' finite differences over the played time.
            let max = limit.max_speed.to_degrees();
            let speed_lines: Vec<f64> = speed
                .marks
                .iter()
                .filter_map(|m| match m {
                    Mark::HorizontalLine { y, .. } => Some(*y),
                    Mark::VerticalLine { .. } => None,
                })
                .collect();
            assert_eq!(speed_lines, [max, -max, 0.9 * max, -0.9 * max]);
            let [low, high] = speed.y_axis.range.unwrap();
            assert!(low < -max && max < high);
            let y = &speed.series[0].y;
            assert_eq!((y[0], y[60], y[61]), (None, None, None));
            for i in (1..angle.x.len()).filter(|i| y[*i].is_some()) {
                let (a0, a1) = (angle.series[0].y[i - 1], angle.series[0].y[i]);
                let finite = (a1.unwrap() - a0.unwrap()) / (angle.x[i] - angle.x[i - 1]);
                assert!((y[i].unwrap() - finite).abs() < 1e-6 * (1.0 + finite.abs()));
            }
        }
        // The time axis is the played one: the recorded span twice over.
        let recorded = targets.last().unwrap().time_s - targets[0].time_s;
        let x = &panels[0].x;
        assert!((x[x.len() - 1] - x[0] - 2.0 * recorded).abs() < 1e-9);
        assert!(
            slot.caption.contains("time scale 2.00 (given)"),
            "{}",
            slot.caption
        );
    }
}
