//! The robot's joints along the path against their limits: the per-axis lines `check` prints,
//! from one [`CheckReport`] (speeds at the played timing, after time scaling).

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
