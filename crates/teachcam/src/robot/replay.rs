//! Replay: a program teachcam wrote, read back ([`parse`]) and played as a controller would,
//! to measure what the robot will do rather than what the check predicted.
//!
//! Model of the controller (stated, not any maker's planner):
//! - a **linear move** runs the TCP on a straight line at its programmed speed, the
//!   orientation slerped along with the position; its duration is the longest of distance /
//!   TCP speed and angle / orientation speed (RAPID's `v_ori`), or its `\T`;
//! - a **zone** of radius `r` at a target (RAPID `zonedata`, KRL `C_DIS`, URScript `r`) cuts the
//!   corner between two linear moves: the path leaves the first line `r'` before the target
//!   and joins the second `r'` after it on a quadratic Bézier whose control point is the
//!   target, `r' = min(r, half of either segment)` as the controllers shrink overlapping zones;
//!   the blend takes the time the two cut pieces took. Its largest distance from the target is
//!   `r' · sin(θ/2) / 2` for a corner of turning angle θ: at most half the zone;
//! - a **joint move** interpolates every axis linearly in time, all arriving together, at the
//!   slowest of its programmed speed and every axis's limit; the first move of a program starts
//!   where the robot stands and is not played (the replay starts on its target);
//! - accelerations are not modelled (speed changes are instantaneous): the peak joint speeds
//!   are those of the programmed path at its programmed speeds.
//!
//! Every sample's joints are the inverse-kinematics solution within the joint ranges closest
//! to the previous sample's (a controller follows its axes continuously); joint speeds are the
//! differences of consecutive samples over their time step.

pub mod parse;

use crate::geometry::{Point3, Pose, Vec3, pose_from_parts};
use crate::robot::Cell;
use crate::robot::kinematics::{
    IkSolution, Joints, Robot, confdata, inverse_within_limits, status_turn,
};
use parse::{Branch, Motion, ProgramText, Speed, Target};

/// Options of [`replay`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplayConfig {
    /// Time between samples, seconds. Default 0.004 s: the path interpolation period of ABB's
    /// controllers (URScript's is 0.002 s, KUKA's 0.012 s); finer changes the peaks by less than
    /// a percent on teachcam's programs.
    pub sample_period_s: f64,
}

impl Default for ReplayConfig {
    fn default() -> Self {
        Self {
            sample_period_s: 0.004,
        }
    }
}

/// One sample of a replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplaySample {
    /// Seconds from the program's first target.
    pub time_s: f64,
    /// The TCP in the work object's frame.
    pub wobj_from_tcp: Pose,
    /// The joints there, `None` where the arm cannot reach within its ranges.
    pub joints: Option<Joints>,
}

/// What a replay measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    /// Every sample, in time order.
    pub samples: Vec<ReplaySample>,
    /// Time from the first target to the end, seconds.
    pub duration_s: f64,
    /// Each axis's highest speed, rad/s.
    pub peak_joint_speed: [f64; 6],
    /// When each axis reached it, seconds.
    pub peak_time_s: [f64; 6],
    /// Samples the arm cannot reach.
    pub unreachable: usize,
}

impl Replay {
    /// Each axis's peak speed as a fraction of its limit.
    #[must_use]
    pub fn speed_ratios(&self, robot: &Robot) -> [f64; 6] {
        std::array::from_fn(|i| self.peak_joint_speed[i] / robot.limits[i].max_speed)
    }
}

/// Why a program cannot be replayed.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ReplayError {
    /// The program has no move.
    #[error("the program has no move")]
    Empty,
    /// A joint-move target the arm cannot reach in the solution it asks for.
    #[error("line {line}: the target is out of the {robot}'s reach within its joint ranges")]
    Unreachable {
        /// The program's line.
        line: usize,
        /// The robot.
        robot: String,
    },
}

/// One piece of the played path.
enum Piece {
    /// A straight line from `a` to `b`.
    Line { a: Pose, b: Pose, duration_s: f64 },
    /// A corner blend: quadratic Bézier `a`, `control`, `b`, the orientation slerped.
    Blend {
        a: Pose,
        control: Vec3,
        b: Pose,
        duration_s: f64,
    },
    /// A joint move to `joints`, else to `pose` in `branch` (its duration from the start
    /// joints, known when played).
    Joint {
        joints: Option<Joints>,
        pose: Pose,
        branch: Option<Branch>,
        speed: Speed,
        line: usize,
    },
}

/// The pose a fraction `s` along the line from `a` to `b`.
fn along(a: &Pose, b: &Pose, s: f64) -> Pose {
    let p = a.translation.vector.lerp(&b.translation.vector, s);
    pose_from_parts(p, a.rotation.slerp(&b.rotation, s))
}

/// A linear move's duration from its speed.
fn linear_duration(a: &Pose, b: &Pose, speed: Speed) -> f64 {
    let distance = (b.translation.vector - a.translation.vector).norm();
    let angle = a.rotation.angle_to(&b.rotation);
    match speed {
        Speed::Time(t) => t,
        Speed::Tcp { tcp, orientation } => {
            let by_angle = orientation.map_or(0.0, |w| angle / w);
            (distance / tcp).max(by_angle)
        }
        // A linear move never carries a joint speed; take the axes' own pace.
        Speed::AxisFraction(_) | Speed::AxisSpeed(_) => 0.0,
    }
}

/// The solution within the joint ranges closest to `near` (max-norm), among those that match
/// `branch` when some do.
fn closest(
    robot: &Robot,
    base_from_flange: &Pose,
    near: Option<&Joints>,
    branch: Option<Branch>,
) -> Option<IkSolution> {
    let solutions = inverse_within_limits(robot, base_from_flange);
    let matches = |s: &IkSolution| match branch {
        None => true,
        Some(Branch::Abb(conf)) => {
            let c = confdata(&s.joints, &s.configuration);
            [c.cf1, c.cf4, c.cf6, c.cfx] == conf
        }
        Some(Branch::Kuka { status, turn }) => {
            let st = status_turn(robot, &s.joints, &s.configuration);
            st.status == status && st.turn == turn
        }
    };
    let distance = |s: &IkSolution| {
        near.map_or(0.0, |q| {
            (0..6)
                .map(|i| (s.joints.0[i] - q.0[i]).abs())
                .fold(0.0, f64::max)
        })
    };
    let by_distance = |a: &&IkSolution, b: &&IkSolution| distance(a).total_cmp(&distance(b));
    solutions
        .iter()
        .filter(|s| matches(s))
        .min_by(by_distance)
        .or_else(|| solutions.iter().min_by(by_distance))
        .copied()
}

/// The pose of a target: the program's, or the forward kinematics of its joints.
fn target_pose(robot: &Robot, cell: &Cell, target: &Target) -> Pose {
    match target {
        Target::Pose { wobj_from_tcp, .. } => *wobj_from_tcp,
        Target::Joints(q) => {
            cell.base_from_wobj.inverse()
                * crate::robot::kinematics::forward(robot, q)
                * cell.flange_from_tcp
        }
    }
}

/// The pieces of the path from the program's first target on.
fn pieces(robot: &Robot, cell: &Cell, program: &ProgramText) -> Vec<Piece> {
    let poses: Vec<Pose> = program
        .moves
        .iter()
        .map(|m| target_pose(robot, cell, &m.target))
        .collect();
    let mut out = Vec::new();
    // How far the current linear move starts after its start point (cut by the last blend).
    let mut start_cut = 0.0;
    for i in 1..program.moves.len() {
        let m = &program.moves[i];
        let (a, b) = (poses[i - 1], poses[i]);
        if m.motion == Motion::Joint {
            let (joints, branch) = match m.target {
                Target::Joints(q) => (Some(q), None),
                Target::Pose { branch, .. } => (None, branch),
            };
            out.push(Piece::Joint {
                joints,
                pose: b,
                branch,
                speed: m.speed,
                line: m.line,
            });
            start_cut = 0.0;
            continue;
        }
        let length = (b.translation.vector - a.translation.vector).norm();
        let duration = linear_duration(&a, &b, m.speed);
        let next = program
            .moves
            .get(i + 1)
            .filter(|n| n.motion == Motion::Linear && m.zone_mm > 0.0);
        let end_cut = next.map_or(0.0, |_| {
            let c = poses[i + 1];
            let next_length = (c.translation.vector - b.translation.vector).norm();
            m.zone_mm.min(length / 2.0).min(next_length / 2.0)
        });
        let fraction = |d: f64| if length > 0.0 { d / length } else { 0.0 };
        let (s0, s1) = (fraction(start_cut), 1.0 - fraction(end_cut));
        out.push(Piece::Line {
            a: along(&a, &b, s0),
            b: along(&a, &b, s1),
            duration_s: duration * (s1 - s0),
        });
        if let Some(n) = next
            && end_cut > 0.0
        {
            let c = poses[i + 1];
            let next_length = (c.translation.vector - b.translation.vector).norm();
            let next_duration = linear_duration(&b, &c, n.speed);
            let exit = end_cut / next_length;
            out.push(Piece::Blend {
                a: along(&a, &b, s1),
                control: b.translation.vector,
                b: along(&b, &c, exit),
                duration_s: duration * fraction(end_cut) + next_duration * exit,
            });
            start_cut = end_cut;
        } else {
            start_cut = 0.0;
        }
    }
    out
}

/// Plays a program on a robot in a cell (the program's own, or the one the user gives).
///
/// # Errors
/// [`ReplayError::Empty`]; [`ReplayError::Unreachable`] for a joint-move target.
pub fn replay(
    robot: &Robot,
    cell: &Cell,
    program: &ProgramText,
    config: &ReplayConfig,
) -> Result<Replay, ReplayError> {
    let first = program.moves.first().ok_or(ReplayError::Empty)?;
    let start_pose = target_pose(robot, cell, &first.target);
    let start_joints = match first.target {
        Target::Joints(q) => Some(q),
        Target::Pose { branch, .. } => {
            closest(robot, &cell.base_from_flange(&start_pose), None, branch).map(|s| s.joints)
        }
    };
    let mut samples = vec![ReplaySample {
        time_s: 0.0,
        wobj_from_tcp: start_pose,
        joints: start_joints,
    }];
    let dt = config.sample_period_s.max(1e-4);
    for piece in pieces(robot, cell, program) {
        let previous = *samples.last().unwrap_or(&samples[0]);
        let t0 = previous.time_s;
        match piece {
            Piece::Line { a, b, duration_s } => {
                sample(robot, cell, &mut samples, t0, duration_s, dt, |s| {
                    along(&a, &b, s)
                });
            }
            Piece::Blend {
                a,
                control,
                b,
                duration_s,
            } => {
                let (pa, pb) = (a.translation.vector, b.translation.vector);
                sample(robot, cell, &mut samples, t0, duration_s, dt, |u| {
                    let p = pa * (1.0 - u).powi(2) + control * (2.0 * u * (1.0 - u)) + pb * u * u;
                    pose_from_parts(p, a.rotation.slerp(&b.rotation, u))
                });
            }
            Piece::Joint {
                joints,
                pose,
                branch,
                speed,
                line,
            } => {
                let end = match joints {
                    Some(q) => q,
                    None => {
                        closest(
                            robot,
                            &cell.base_from_flange(&pose),
                            previous.joints.as_ref(),
                            branch,
                        )
                        .ok_or_else(|| ReplayError::Unreachable {
                            line,
                            robot: robot.name.clone(),
                        })?
                        .joints
                    }
                };
                let start = previous.joints.unwrap_or(end);
                let distance =
                    (previous.wobj_from_tcp.translation.vector - pose.translation.vector).norm();
                let mut duration = match speed {
                    Speed::Tcp { tcp, orientation } => {
                        let angle = previous.wobj_from_tcp.rotation.angle_to(&pose.rotation);
                        (distance / tcp).max(orientation.map_or(0.0, |w| angle / w))
                    }
                    Speed::Time(t) => t,
                    Speed::AxisFraction(_) | Speed::AxisSpeed(_) => 0.0,
                };
                for axis in 0..6 {
                    let limit = robot.limits[axis].max_speed;
                    let programmed = match speed {
                        Speed::AxisFraction(f) => limit * f.clamp(1e-3, 1.0),
                        Speed::AxisSpeed(v) => v.min(limit),
                        Speed::Tcp { .. } | Speed::Time(_) => limit,
                    };
                    duration = duration.max((end.0[axis] - start.0[axis]).abs() / programmed);
                }
                let steps = (duration / dt).ceil().max(1.0) as usize;
                for k in 1..=steps {
                    let s = k as f64 / steps as f64;
                    let q = Joints(std::array::from_fn(|i| {
                        start.0[i] + s * (end.0[i] - start.0[i])
                    }));
                    let flange = crate::robot::kinematics::forward(robot, &q);
                    samples.push(ReplaySample {
                        time_s: t0 + s * duration,
                        wobj_from_tcp: cell.base_from_wobj.inverse()
                            * flange
                            * cell.flange_from_tcp,
                        joints: Some(q),
                    });
                }
            }
        }
    }
    let mut peak_joint_speed = [0.0; 6];
    let mut peak_time_s = [0.0; 6];
    for pair in samples.windows(2) {
        let (Some(p), Some(q)) = (pair[0].joints, pair[1].joints) else {
            continue;
        };
        let step = pair[1].time_s - pair[0].time_s;
        if step <= 0.0 {
            continue;
        }
        for axis in 0..6 {
            let speed = (q.0[axis] - p.0[axis]).abs() / step;
            if speed > peak_joint_speed[axis] {
                peak_joint_speed[axis] = speed;
                peak_time_s[axis] = pair[1].time_s;
            }
        }
    }
    let unreachable = samples.iter().filter(|s| s.joints.is_none()).count();
    Ok(Replay {
        duration_s: samples.last().map_or(0.0, |s| s.time_s),
        samples,
        peak_joint_speed,
        peak_time_s,
        unreachable,
    })
}

/// Samples `path(s)`, `s` in (0, 1], over `duration_s` from `t0` every `dt` or less, each with
/// the joints closest to the previous sample's.
fn sample(
    robot: &Robot,
    cell: &Cell,
    samples: &mut Vec<ReplaySample>,
    t0: f64,
    duration_s: f64,
    dt: f64,
    path: impl Fn(f64) -> Pose,
) {
    let steps = (duration_s / dt).ceil().max(1.0) as usize;
    for k in 1..=steps {
        let s = k as f64 / steps as f64;
        let wobj_from_tcp = path(s);
        let near = samples.iter().rev().find_map(|p| p.joints);
        let joints = closest(
            robot,
            &cell.base_from_flange(&wobj_from_tcp),
            near.as_ref(),
            None,
        )
        .map(|solution| solution.joints);
        samples.push(ReplaySample {
            time_s: t0 + s * duration_s.max(0.0),
            wobj_from_tcp,
            joints,
        });
    }
}

/// How far a played path strays from the demonstration: for every demonstrated TCP position,
/// its distance to the played path (the polyline of the samples), mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deviation {
    /// The largest distance, mm.
    pub max_mm: f64,
    /// Root mean square of the distances, mm.
    pub rms_mm: f64,
    /// Demonstrated positions compared.
    pub points: usize,
}

/// The [`Deviation`] of `demonstration` (TCP positions in the work object) from a replay;
/// `None` without points or with fewer than two samples.
#[must_use]
pub fn deviation(replay: &Replay, demonstration: &[Point3]) -> Option<Deviation> {
    if demonstration.is_empty() || replay.samples.len() < 2 {
        return None;
    }
    let path: Vec<Vec3> = replay
        .samples
        .iter()
        .map(|s| s.wobj_from_tcp.translation.vector)
        .collect();
    let distance = |p: &Vec3| {
        path.windows(2)
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let ab = b - a;
                let length2 = ab.norm_squared();
                let s = if length2 > 0.0 {
                    ((p - a).dot(&ab) / length2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (a + ab * s - p).norm()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let distances: Vec<f64> = demonstration.iter().map(|p| distance(&p.coords)).collect();
    let max_mm = distances.iter().copied().fold(0.0, f64::max);
    let rms_mm = (distances.iter().map(|d| d * d).sum::<f64>() / distances.len() as f64).sqrt();
    Some(Deviation {
        max_mm,
        rms_mm,
        points: distances.len(),
    })
}
