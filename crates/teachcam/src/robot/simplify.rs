//! Fewer robot targets, the path kept within a tolerance: a 30 Hz recording gives 1800 targets
//! a minute, most of which a linear move between their neighbours already passes within a
//! fraction of a millimetre.
//!
//! Model: Ramer–Douglas–Peucker on poses. Between two kept targets the robot moves linearly
//! (`MoveL`, `LIN`, `movel`): position on the segment, orientation slerped in proportion to
//! the position along it (in proportion to time on a segment shorter than a micrometre). A
//! dropped target must lie within `position_tolerance` of the segment and within
//! `orientation_tolerance` of the slerped orientation at its projection; otherwise the target
//! farthest off (relative to the tolerances) is kept and both halves are simplified again.

use crate::geometry::Vec3;
use crate::robot::TcpTarget;

/// Options of [`simplify`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimplifyConfig {
    /// Largest distance of a dropped target from the simplified path, millimetres. Default
    /// 0.5 mm: well under a brush stroke's width and under ABB's `z1` zone.
    pub position_tolerance: f64,
    /// Largest orientation error at a dropped target, radians. Default 0.5°: at the brush's
    /// 180 mm lever, 1.6 mm of bristle tip, the same order as the position tolerance.
    pub orientation_tolerance: f64,
}

impl Default for SimplifyConfig {
    fn default() -> Self {
        Self {
            position_tolerance: 0.5,
            orientation_tolerance: 0.5f64.to_radians(),
        }
    }
}

/// The indices of the targets to keep, increasing; always the first and the last.
#[must_use]
pub fn simplify(targets: &[TcpTarget], config: &SimplifyConfig) -> Vec<usize> {
    if targets.len() <= 2 {
        return (0..targets.len()).collect();
    }
    let mut keep = vec![false; targets.len()];
    keep[0] = true;
    keep[targets.len() - 1] = true;
    let mut stack = vec![(0, targets.len() - 1)];
    while let Some((first, last)) = stack.pop() {
        if last <= first + 1 {
            continue;
        }
        let mut worst = (1.0, None);
        for k in first + 1..last {
            let error = relative_error(&targets[first], &targets[last], &targets[k], config);
            if error > worst.0 {
                worst = (error, Some(k));
            }
        }
        if let Some(k) = worst.1 {
            keep[k] = true;
            stack.push((first, k));
            stack.push((k, last));
        }
    }
    keep.iter()
        .enumerate()
        .filter_map(|(i, &k)| k.then_some(i))
        .collect()
}

/// The larger of the position and orientation errors of `middle` off the linear move from
/// `start` to `end`, each divided by its tolerance (so > 1 means out of tolerance).
#[must_use]
pub fn relative_error(
    start: &TcpTarget,
    end: &TcpTarget,
    middle: &TcpTarget,
    config: &SimplifyConfig,
) -> f64 {
    let a: Vec3 = start.wobj_from_tcp.translation.vector;
    let b: Vec3 = end.wobj_from_tcp.translation.vector;
    let p: Vec3 = middle.wobj_from_tcp.translation.vector;
    let along = b - a;
    let length_sq = along.norm_squared();
    let s = if length_sq > 1e-6 {
        ((p - a).dot(&along) / length_sq).clamp(0.0, 1.0)
    } else {
        let span = end.time_s - start.time_s;
        if span > 0.0 {
            ((middle.time_s - start.time_s) / span).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let position_error = (a + along * s - p).norm();
    let expected = start
        .wobj_from_tcp
        .rotation
        .try_slerp(&end.wobj_from_tcp.rotation, s, 1e-12)
        .unwrap_or(start.wobj_from_tcp.rotation);
    let orientation_error = expected.angle_to(&middle.wobj_from_tcp.rotation);
    (position_error / config.position_tolerance)
        .max(orientation_error / config.orientation_tolerance)
}
