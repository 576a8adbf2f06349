//! A free tool axis: for an axisymmetric tool (a round brush, a nozzle) the rotation about the
//! TCP's z does not matter to the work, so the robot may choose it per frame.
//!
//! Model: each target keeps its position and its tool axis `z_k`; its orientation becomes
//! `A_k · Rz(ψ)` with `A_k` the shortest turn taking the stroke's mean axis `c` to `z_k`
//! (composed with one taking `e_z` to `c`), so that a constant `ψ` is a tool that does not
//! spin. `ψ` is chosen per frame on a grid of [`FreeAxisConfig::step`] by dynamic programming
//! (Viterbi) over the states (ψ, joint solution), at most [`FreeAxisConfig::max_steps`] grid
//! steps a frame, minimising the sum of
//! - the check's step cost (the square of the fastest axis's share of its allowed speed at the
//!   recorded timing — a uniform time scale multiplies every step alike — plus the penalty for
//!   changing the arm configuration),
//! - a wrist term `((m − |q5|) / m)²` for axis 5 within `m` of zero,
//! - a range term `((r − d) / r)²` for an axis (not turning fully) within `r` of a limit,
//! - a smoothness term on the change of ψ, [`FreeAxisConfig::smoothness`] per grid step squared.
//!
//! No refinement below the grid: the check then runs on the chosen targets as on any others.

use std::ops::Range;

use nalgebra::{UnitQuaternion, Vector3};

use crate::geometry::Pose;
use crate::robot::check::{CheckConfig, path_candidates, step_cost, turning_axes};
use crate::robot::kinematics::{IkSolution, Robot};
use crate::robot::{Cell, TcpTarget};

/// Options of [`choose_roll`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeAxisConfig {
    /// Grid of ψ, radians. Default 10°: 36 angles, each frame's inverse kinematics solved 36
    /// times.
    pub step: f64,
    /// Most grid steps ψ may change between frames. Default 1 (10° a frame: 300°/s at 30 Hz,
    /// within axis 6's speed on every model).
    pub max_steps: usize,
    /// Axis 5 closer to zero than this is penalised, radians. Default 15°: three times the
    /// check's singularity warning (5°).
    pub wrist_margin: f64,
    /// An axis closer to a limit than this is penalised, radians. Default 10°.
    pub range_margin: f64,
    /// Cost of one grid step of ψ between frames. Default 0.01: a hundredth of a step at full
    /// speed, so ψ stays put unless the arm gains by turning.
    pub smoothness: f64,
}

impl Default for FreeAxisConfig {
    fn default() -> Self {
        Self {
            step: 10f64.to_radians(),
            max_steps: 1,
            wrist_margin: 15f64.to_radians(),
            range_margin: 10f64.to_radians(),
            smoothness: 0.01,
        }
    }
}

/// The targets with the rotation about the tool's axis chosen per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FreeRoll {
    /// The targets: same times, positions and tool axes; the roll chosen.
    pub targets: Vec<TcpTarget>,
    /// The smallest and largest turn about the tool's axis from the demonstrated orientation,
    /// radians (in −π..π).
    pub turn_range: (f64, f64),
}

impl FreeRoll {
    /// One line for `check`, `export` and the program's header.
    #[must_use]
    pub fn describe(&self) -> String {
        format!(
            "tool axis free: roll chosen per frame, range {:.0}..{:.0}° from the demonstration",
            self.turn_range.0.to_degrees(),
            self.turn_range.1.to_degrees()
        )
    }
}

/// A rotation taking `from` to `to` (unit vectors), half a turn about a perpendicular axis
/// when they are opposite.
fn turn_between(from: &Vector3<f64>, to: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::rotation_between(from, to).unwrap_or_else(|| {
        let axis = from.cross(&Vector3::x());
        let axis = if axis.norm() > 1e-6 {
            axis
        } else {
            from.cross(&Vector3::y())
        };
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), std::f64::consts::PI)
    })
}

/// The targets of `strokes` (ranges of `targets`) with the roll chosen per frame, each stroke
/// on its own; targets outside every stroke are kept as they are.
#[must_use]
pub fn choose_roll(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    strokes: &[Range<usize>],
    check: &CheckConfig,
    config: &FreeAxisConfig,
) -> FreeRoll {
    let mut out = targets.to_vec();
    let mut turn_range = (f64::INFINITY, f64::NEG_INFINITY);
    for stroke in strokes {
        let chosen = stroke_roll(robot, cell, &targets[stroke.clone()], check, config);
        for (k, rotation) in stroke.clone().zip(chosen) {
            let before = targets[k].wobj_from_tcp.rotation;
            let turn = (before.inverse() * rotation).scaled_axis().z;
            turn_range = (turn_range.0.min(turn), turn_range.1.max(turn));
            out[k].wobj_from_tcp = Pose::from_parts(targets[k].wobj_from_tcp.translation, rotation);
        }
    }
    if turn_range.0 > turn_range.1 {
        turn_range = (0.0, 0.0);
    }
    FreeRoll {
        targets: out,
        turn_range,
    }
}

/// The node cost of a solution: the wrist and range terms.
fn node_cost(robot: &Robot, turning: &[bool; 6], s: &IkSolution, config: &FreeAxisConfig) -> f64 {
    let q5 = s.joints.0[4].abs();
    let mut cost = if q5 < config.wrist_margin {
        ((config.wrist_margin - q5) / config.wrist_margin).powi(2)
    } else {
        0.0
    };
    for axis in (0..6).filter(|&a| !turning[a]) {
        let l = &robot.limits[axis];
        let d = (s.joints.0[axis] - l.min).min(l.max - s.joints.0[axis]);
        if d < config.range_margin {
            cost += ((config.range_margin - d) / config.range_margin).powi(2);
        }
    }
    cost
}

/// The chosen orientation of each target of one stroke.
fn stroke_roll(
    robot: &Robot,
    cell: &Cell,
    stroke: &[TcpTarget],
    check: &CheckConfig,
    config: &FreeAxisConfig,
) -> Vec<UnitQuaternion<f64>> {
    let demonstrated: Vec<UnitQuaternion<f64>> =
        stroke.iter().map(|t| t.wobj_from_tcp.rotation).collect();
    let axes: Vec<Vector3<f64>> = demonstrated.iter().map(|r| r * Vector3::z()).collect();
    let mean = axes.iter().sum::<Vector3<f64>>();
    let Some(mean) = mean.try_normalize(1e-9) else {
        return demonstrated;
    };
    let to_mean = turn_between(&Vector3::z(), &mean);
    let grid = ((std::f64::consts::TAU / config.step).round() as usize).max(1);
    let psi = |i: usize| i as f64 * std::f64::consts::TAU / grid as f64;
    let orientation = |k: usize, i: usize| {
        turn_between(&mean, &axes[k])
            * to_mean
            * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), psi(i))
    };
    let turning = turning_axes(robot);
    // States per frame: (grid index, solution).
    let states: Vec<Vec<(usize, IkSolution)>> = (0..stroke.len())
        .map(|k| {
            (0..grid)
                .flat_map(|i| {
                    let pose =
                        Pose::from_parts(stroke[k].wobj_from_tcp.translation, orientation(k, i));
                    path_candidates(robot, &turning, &cell.base_from_flange(&pose))
                        .into_iter()
                        .map(move |s| (i, s))
                })
                .collect()
        })
        .collect();
    if states.iter().any(Vec::is_empty) {
        // A frame the arm reaches at no roll: nothing to choose, the check says where.
        return demonstrated;
    }
    let mut cost: Vec<f64> = states[0]
        .iter()
        .map(|(_, s)| node_cost(robot, &turning, s, config))
        .collect();
    let mut back: Vec<Vec<usize>> = vec![Vec::new()];
    for k in 1..stroke.len() {
        let dt = stroke[k].time_s - stroke[k - 1].time_s;
        let mut next_cost = Vec::with_capacity(states[k].len());
        let mut next_back = Vec::with_capacity(states[k].len());
        for (i, to) in &states[k] {
            let mut best = (f64::INFINITY, 0);
            for (p, (j, from)) in states[k - 1].iter().enumerate() {
                let steps = (i + grid - j) % grid;
                let steps = steps.min(grid - steps);
                if steps > config.max_steps || cost[p] >= best.0 {
                    continue;
                }
                let c = cost[p]
                    + step_cost(robot, &turning, from, to, dt, check)
                    + config.smoothness * (steps * steps) as f64;
                if c < best.0 {
                    best = (c, p);
                }
            }
            next_cost.push(best.0 + node_cost(robot, &turning, to, config));
            next_back.push(best.1);
        }
        cost = next_cost;
        back.push(next_back);
    }
    let mut index = cost
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0, |(i, _)| i);
    if !cost[index].is_finite() {
        return demonstrated;
    }
    let mut out = vec![UnitQuaternion::identity(); stroke.len()];
    for k in (0..stroke.len()).rev() {
        out[k] = orientation(k, states[k][index].0);
        if k > 0 {
            index = back[k][index];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{FrameIndex, pose_from_parts};
    use crate::robot::check::{FrameIssue, check_path};

    /// The demo's cell: the work object 350 mm in front of the IRB 120, 100 mm up; the brush
    /// 200 mm out of the flange, its z up the handle.
    fn cell() -> Cell {
        Cell {
            base_from_wobj: pose_from_parts(
                Vector3::new(350.0, 0.0, 100.0),
                UnitQuaternion::identity(),
            ),
            flange_from_tcp: pose_from_parts(
                Vector3::new(0.0, 0.0, 200.0),
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
            ),
        }
    }

    /// A 3 s stroke along x at 3 mm over the surface, the brush leaning 25° and spinning about
    /// its own axis at 300°/s (900° in all: more than axis 6's ±400° of the IRB 120).
    fn spinning_stroke() -> Vec<TcpTarget> {
        (0..90)
            .map(|k| {
                let t = k as f64 / 30.0;
                let axis = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 20f64.to_radians())
                    * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -25f64.to_radians());
                let spin =
                    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), (300.0 * t).to_radians());
                TcpTarget {
                    frame: FrameIndex(k),
                    time_s: t,
                    wobj_from_tcp: pose_from_parts(
                        Vector3::new(-40.0 + 80.0 * t / 3.0, 0.0, 3.0),
                        axis * spin,
                    ),
                }
            })
            .collect()
    }

    #[test]
    fn a_stroke_spinning_axis_6_out_of_range_passes_with_the_roll_free() {
        let robot = Robot::irb120();
        let cell = cell();
        let targets = spinning_stroke();
        let check = CheckConfig::default();
        let demonstrated = check_path(&robot, &cell, &targets, &check);
        assert!(!demonstrated.passes());
        assert!(demonstrated.frames.iter().any(|f| {
            f.issues
                .iter()
                .any(|i| matches!(i, FrameIssue::OutsideLimits { axis: 5, .. }))
        }));
        let free = choose_roll(
            &robot,
            &cell,
            &targets,
            &std::iter::once(0..targets.len()).collect::<Vec<_>>(),
            &check,
            &FreeAxisConfig::default(),
        );
        let report = check_path(&robot, &cell, &free.targets, &check);
        let failing: Vec<_> = report.failing().take(3).map(|f| f.issues.clone()).collect();
        assert!(report.passes(), "{failing:?}");
        let mut largest_turn: f64 = 0.0;
        for (a, b) in targets.iter().zip(&free.targets) {
            let (pa, pb) = (
                a.wobj_from_tcp.translation.vector,
                b.wobj_from_tcp.translation.vector,
            );
            assert!((pa - pb).norm() <= 1e-9);
            let (za, zb) = (
                a.wobj_from_tcp.rotation * Vector3::z(),
                b.wobj_from_tcp.rotation * Vector3::z(),
            );
            assert!((za - zb).norm() <= 1e-9, "{za} {zb}");
            largest_turn =
                largest_turn.max(a.wobj_from_tcp.rotation.angle_to(&b.wobj_from_tcp.rotation));
        }
        assert!(largest_turn > 1f64.to_radians());
        assert!(
            free.describe()
                .starts_with("tool axis free: roll chosen per frame, range ")
        );
    }
}
