//! The robot's joints along the path against their limits: the figure of the report and the
//! per-axis lines `check` prints, from one [`CheckReport`].
//!
//! Angles are drawn as a share of each axis's range (0 % its lowest angle, 100 % its highest)
//! and speeds as a share of each axis's maximum speed, so that the six axes share one scale
//! and one limit line; the time axis is the played one (the demonstration's times multiplied
//! by the time scale, which the caption states).

use crate::robot::check::CheckReport;

use super::{Axis, FigureBody, FigureId, FigureSlot, Mark, Panel, Role, Series, Shape, Style};

/// Heading of the joints figure.
pub const JOINTS_TITLE: &str = "Joint angles and speeds against the limits";

/// One line per axis, e.g. "axis 1: peak 123 deg/s, 49 % of 250 deg/s; angles -20..35 deg
/// of -165..165": what `check` prints and the figure's caption lists.
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

/// The joints figure: angles (share of range) and speeds (share of the limit) over the played
/// time, one series per axis, the limits marked. `Err` says why it cannot be drawn.
///
/// # Errors
/// When no frame has joints.
pub fn joints(check: &CheckReport) -> Result<FigureSlot, String> {
    if check.frames.iter().all(|f| f.joints.is_none()) {
        return Err(format!(
            "no frame of the path is within the {}'s reach and joint ranges",
            check.robot.name
        ));
    }
    let x: Vec<f64> = check.frames.iter().map(|f| f.target.time_s).collect();
    let series = |value: &dyn Fn(usize, &crate::robot::check::FrameCheck) -> Option<f64>| {
        (0..6)
            .map(|axis| Series {
                label: format!("axis {}", axis + 1),
                role: Role::Component(axis as u8),
                x: None,
                y: check.frames.iter().map(|f| value(axis, f)).collect(),
                style: Style::Line,
            })
            .collect::<Vec<_>>()
    };
    let angles = series(&|axis, f| {
        let limit = check.robot.limits[axis];
        f.joints
            .map(|j| 100.0 * (j.0[axis] - limit.min) / (limit.max - limit.min))
    });
    // A frame's speed is the one since the previous frame; the first has none.
    let speeds = series(&|axis, f| {
        f.joints
            .map(|_| 100.0 * f.joint_speed[axis] / check.robot.limits[axis].max_speed)
    });
    let line = |y: f64, label: &str| Mark::HorizontalLine {
        y,
        label: label.to_string(),
    };
    let time = || Axis::linear("time, played", "s");
    let panels = vec![
        Panel {
            title: "joint angles, share of each axis's range".into(),
            x_axis: time(),
            y_axis: Axis::linear("angle (0 = lowest, 100 = highest)", "%"),
            x: x.clone(),
            series: angles,
            marks: vec![line(0.0, "range"), line(100.0, "range")],
            shape: Shape::Wide,
        },
        Panel {
            title: "joint speeds, share of each axis's maximum".into(),
            x_axis: time(),
            y_axis: Axis::linear("speed", "% of limit"),
            x,
            series: speeds,
            marks: vec![line(100.0, "speed limit")],
            shape: Shape::Wide,
        },
    ];
    Ok(FigureSlot {
        id: FigureId::Joints,
        title: JOINTS_TITLE.into(),
        caption: format!(
            "The {}'s joints along the path as `teachcam check` chose them, over the played time ({}). Angles as a share of each axis's range, speeds as a share of its data-sheet maximum: {}.",
            check.robot.name,
            check.timing.describe(&check.robot.name),
            joint_lines(check).join("; ")
        ),
        body: FigureBody::Plots { panels },
    })
}
