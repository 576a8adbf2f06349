//! Check a path of robot targets on an arm before a program is written: reach, joint limits,
//! joint speeds and accelerations at the recorded timing, configuration changes and the wrist
//! singularity; with suggestions (slow down by a factor, a verified `--wobj` to paste).
//!
//! Model: every target has up to 16 joint solutions inside the limits ([`inverse_within_limits`]).
//! One solution per frame is chosen for the whole path at once by dynamic programming
//! (Viterbi): the cost of a step is `(max_i |Δq_i| / (v_max,i Δt))²` (the square of the fraction
//! of the fastest axis's speed it needs), plus a penalty for changing the arm configuration
//! ([`ArmConfiguration`]), so the path keeps one configuration and never flips unless it must. Speeds are
//! backward differences `(q_k − q_{k−1}) / (t_k − t_{k−1})`, accelerations their differences.

use crate::geometry::{FrameIndex, Vec3};
use std::f64::consts::TAU;

use crate::robot::kinematics::{
    ArmConfiguration, Elbow, IkSolution, Joints, Robot, Shoulder, inverse, inverse_within_limits,
    wrap,
};
use crate::robot::{Cell, TcpTarget};

/// Options of [`check_path`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckConfig {
    /// Axis 5 angles closer to zero than this are near the wrist singularity, radians.
    /// Default 5°: there, axes 4 and 6 turn by about `1 / sin q5` ≈ 11 times the TCP's
    /// angular rate, which is where ABB's path planner starts to slow down.
    pub wrist_singularity: f64,
    /// Fraction of each axis's maximum speed a path may use. Default
    /// [`DEFAULT_SPEED_FRACTION`] (0.9): a program replayed at the time scale chosen stays 10 %
    /// under each joint's data-sheet speed, a margin for the controller's blending and
    /// acceleration ramps (and for the joint path between kept targets, which differs from the
    /// frames' by up to the path tolerance).
    pub speed_fraction: f64,
    /// Maximum joint accelerations, rad/s², axis 1 to 6; `None` reports accelerations without
    /// judging them. Default `None`: ABB publishes no joint acceleration limits (they depend on
    /// the load and the pose), and its planner slows the path down rather than faulting.
    pub max_acceleration: Option<[f64; 6]>,
    /// The largest distance tried when looking for a work-object move that makes every
    /// target reachable, as a fraction of the arm's reach. Default 1.0: beyond a whole reach
    /// the stroke would be on the arm's other side.
    pub max_work_object_move_reach: f64,
    /// How the demonstration's timing is played. Default [`TimeScale::Auto`].
    pub time_scale: TimeScale,
}

/// How a path's recorded timing is played on the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeScale {
    /// Slow the whole path uniformly by the smallest factor (≥ 1, rounded up to a hundredth)
    /// that keeps every joint within its speed limit times [`CheckConfig::speed_fraction`],
    /// and its acceleration limit when given. A path within the limits keeps its timing.
    Auto,
    /// Play the path this many times slower (1: the demonstration's own timing).
    Fixed(f64),
}

/// The time scale a check applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Every recorded duration was multiplied by this (≥ 1 under [`TimeScale::Auto`]).
    pub factor: f64,
    /// The 0-based axis that sets the factor (the one closest to its limit at the recorded
    /// timing), `None` when no two consecutive frames have joints.
    pub limiting_axis: Option<usize>,
    /// True when the factor was chosen by [`TimeScale::Auto`].
    pub automatic: bool,
    /// Under a given factor too fast for the arm, the factor [`TimeScale::Auto`] finds (one
    /// that passes), for the refusal to name; `None` otherwise.
    pub fits: Option<f64>,
}

impl Timing {
    /// One line for a program's header and `check`'s summary, e.g. "time scale 1.62: axis 1
    /// of the irb120 limits the demonstration".
    #[must_use]
    pub fn describe(&self, robot: &str) -> String {
        let how = if self.automatic { "" } else { " (given)" };
        match self.limiting_axis {
            Some(axis) if self.factor > 1.0 && self.automatic => format!(
                "time scale {:.2}: axis {} of the {robot} limits the demonstration",
                self.factor,
                axis + 1
            ),
            _ if self.factor == 1.0 => {
                format!("time scale 1.00{how}: the demonstration's own timing")
            }
            _ => format!(
                "time scale {:.2}{how}: the demonstration played {:.2} times slower",
                self.factor, self.factor
            ),
        }
    }
}

/// The targets with every time since the first multiplied by `factor`.
#[must_use]
pub fn scale_time(targets: &[TcpTarget], factor: f64) -> Vec<TcpTarget> {
    let Some(start) = targets.first().map(|t| t.time_s) else {
        return Vec::new();
    };
    targets
        .iter()
        .map(|t| TcpTarget {
            time_s: start + (t.time_s - start) * factor,
            ..*t
        })
        .collect()
}

/// The default [`CheckConfig::speed_fraction`], shared by `check`, `export` and the studio.
pub const DEFAULT_SPEED_FRACTION: f64 = 0.9;

impl Default for CheckConfig {
    fn default() -> Self {
        Self {
            wrist_singularity: 5f64.to_radians(),
            speed_fraction: DEFAULT_SPEED_FRACTION,
            max_acceleration: None,
            max_work_object_move_reach: 1.0,
            time_scale: TimeScale::Auto,
        }
    }
}

/// What is wrong (or worth knowing) at one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FrameIssue {
    /// The wrist centre is beyond the arm's reach (or too close to its base).
    OutOfReach,
    /// The arm reaches the pose only with an axis outside its range.
    OutsideLimits {
        /// 0-based axis index (axis 1 is 0).
        axis: usize,
        /// Its angle in the solution closest to the limits, radians.
        angle: f64,
    },
    /// An axis would move faster than allowed since the previous frame.
    TooFast {
        /// 0-based axis index.
        axis: usize,
        /// Its speed, rad/s (signed).
        speed: f64,
        /// The allowed speed, rad/s.
        max_speed: f64,
    },
    /// An axis would accelerate harder than configured.
    TooHighAcceleration {
        /// 0-based axis index.
        axis: usize,
        /// Its acceleration, rad/s² (signed).
        acceleration: f64,
        /// The allowed acceleration, rad/s².
        max_acceleration: f64,
    },
    /// The arm configuration changes since the previous frame.
    ConfigurationChange {
        /// The previous frame's configuration ([`ArmConfiguration::code`], ABB's `cfx`).
        from: u8,
        /// This frame's.
        to: u8,
    },
    /// The target's time does not follow the previous target's: no speed can be checked.
    TimeNotIncreasing {
        /// This target's time, seconds.
        time_s: f64,
        /// The previous target's time, seconds.
        previous_s: f64,
    },
    /// Axis 5 is near zero: the wrist is near its singularity (a warning, not a failure).
    NearSingular {
        /// Axis 5's angle, radians.
        axis5: f64,
    },
}

impl FrameIssue {
    /// True when this issue stops the program on the robot; false for a warning.
    #[must_use]
    pub fn is_failure(&self) -> bool {
        !matches!(self, Self::NearSingular { .. })
    }
}

impl std::fmt::Display for FrameIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::OutOfReach => write!(f, "out of reach"),
            Self::OutsideLimits { axis, angle } => write!(
                f,
                "axis {} outside its range ({:.1}°)",
                axis + 1,
                angle.to_degrees()
            ),
            Self::TooFast {
                axis,
                speed,
                max_speed,
            } => write!(
                f,
                "axis {} too fast ({:.0}°/s, limit {:.0}°/s)",
                axis + 1,
                speed.to_degrees(),
                max_speed.to_degrees()
            ),
            Self::TooHighAcceleration {
                axis,
                acceleration,
                max_acceleration,
            } => write!(
                f,
                "axis {} accelerates too hard ({:.0}°/s², limit {:.0}°/s²)",
                axis + 1,
                acceleration.to_degrees(),
                max_acceleration.to_degrees()
            ),
            Self::ConfigurationChange { from, to } => {
                write!(
                    f,
                    "arm configuration changes (configuration {from} -> {to}: 4 shoulder back + 2 elbow behind + 1 wrist flipped)"
                )
            }
            Self::TimeNotIncreasing { time_s, previous_s } => write!(
                f,
                "time {time_s} s does not follow the previous target's {previous_s} s"
            ),
            Self::NearSingular { axis5 } => {
                write!(
                    f,
                    "near the wrist singularity (axis 5 at {:.1}°)",
                    axis5.to_degrees()
                )
            }
        }
    }
}

/// The check of one target.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameCheck {
    /// The target checked.
    pub target: TcpTarget,
    /// The joint solution chosen along the path, `None` when there is none in the limits.
    pub joints: Option<Joints>,
    /// Its arm configuration.
    pub configuration: Option<ArmConfiguration>,
    /// Joint speeds since the previous target, rad/s (zero at the first).
    pub joint_speed: [f64; 6],
    /// Joint accelerations, rad/s² (zero at the first two).
    pub joint_acceleration: [f64; 6],
    /// What is wrong here.
    pub issues: Vec<FrameIssue>,
}

impl FrameCheck {
    /// True when nothing here stops the program.
    #[must_use]
    pub fn passes(&self) -> bool {
        self.issues.iter().all(|i| !i.is_failure())
    }
}

/// What would make a failing path run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Suggestion {
    /// Play the trajectory this many times slower.
    SlowDown {
        /// Time scale, > 1.
        factor: f64,
    },
    /// Use this work object instead, verified by the whole check (reach, joint ranges,
    /// speeds at a time scale of at most [`MAX_SUGGESTED_TIME_SCALE`], no configuration change,
    /// no frame near the wrist singularity): the given one moved (the nearest translation that works), or, when no
    /// translation does, turned and placed in front of the arm (for a world whose z points
    /// into the table, as a rig calibrated from a chessboard lying on it has, or a stroke far
    /// from the arm).
    UseWorkObject {
        /// The work object in the robot's base frame, ready for `--wobj`.
        base_from_wobj: crate::geometry::Pose,
        /// The time scale the check found with it (at most [`MAX_SUGGESTED_TIME_SCALE`]
        /// under [`TimeScale::Auto`]).
        time_scale: f64,
    },
}

impl std::fmt::Display for Suggestion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::SlowDown { factor } => {
                write!(f, "slow the trajectory down by a factor of {factor:.2}")
            }
            Self::UseWorkObject {
                base_from_wobj,
                time_scale,
            } => write!(
                f,
                "--wobj \"{}\" passes the whole check: every frame in reach within the joint ranges, the joints within their speeds at time scale {time_scale:.2}, none near the wrist singularity (verified)",
                crate::robot::pose_text(base_from_wobj)
            ),
        }
    }
}

/// The check of a whole path.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    /// The robot checked on.
    pub robot: Robot,
    /// One per target, in order.
    pub frames: Vec<FrameCheck>,
    /// The largest `|speed| / allowed speed` over all axes and frames.
    pub peak_speed_ratio: f64,
    /// The largest `|acceleration| / allowed acceleration`, when limits were given.
    pub peak_acceleration_ratio: Option<f64>,
    /// The largest `|speed|` of each axis over the path, rad/s.
    pub peak_joint_speed: [f64; 6],
    /// The largest `|acceleration|` of each axis over the path, rad/s².
    pub peak_joint_acceleration: [f64; 6],
    /// What would make it run.
    pub suggestions: Vec<Suggestion>,
    /// The time scale applied: the frames' times are the scaled ones.
    pub timing: Timing,
}

impl CheckReport {
    /// True when the robot can run the whole path.
    #[must_use]
    pub fn passes(&self) -> bool {
        self.frames.iter().all(FrameCheck::passes)
    }

    /// The frames that fail.
    pub fn failing(&self) -> impl Iterator<Item = &FrameCheck> {
        self.frames.iter().filter(|f| !f.passes())
    }

    /// The frame and issue of the fastest joint over its limit (speed, or acceleration when
    /// limits were given), `None` when every joint keeps within its limits.
    #[must_use]
    pub fn speed_failure(&self) -> Option<(&FrameCheck, FrameIssue)> {
        let excess = |issue: &FrameIssue| match *issue {
            FrameIssue::TooFast {
                speed, max_speed, ..
            } => Some(speed.abs() / max_speed),
            FrameIssue::TooHighAcceleration {
                acceleration,
                max_acceleration,
                ..
            } => Some((acceleration.abs() / max_acceleration).sqrt()),
            _ => None,
        };
        self.frames
            .iter()
            .flat_map(|f| {
                f.issues
                    .iter()
                    .filter_map(move |i| Some((f, *i, excess(i)?)))
            })
            .max_by(|a, b| a.2.total_cmp(&b.2))
            .map(|(f, i, _)| (f, i))
    }

    /// One line refusing a given time scale that is too fast for the arm, naming the axis,
    /// the frame and the factor that would fit (`None` when the joints keep within their
    /// limits, or under [`TimeScale::Auto`]).
    #[must_use]
    pub fn time_scale_refusal(&self) -> Option<String> {
        if self.timing.automatic {
            return None;
        }
        let (frame, issue) = self.speed_failure()?;
        let fits = self.timing.fits.map_or_else(
            || "no time scale up to the check's cap fits; auto says the nearest".to_string(),
            |f| format!("--time-scale {f:.2} (or auto) fits"),
        );
        Some(format!(
            "--time-scale {:.2}: frame {} (t = {:.3} s): {issue} on the {}; {fits}",
            self.timing.factor, frame.target.frame.0, frame.target.time_s, self.robot.name
        ))
    }

    /// Frames with no joint solution.
    #[must_use]
    pub fn unreachable_count(&self) -> usize {
        self.frames.iter().filter(|f| f.joints.is_none()).count()
    }

    /// Frames near the wrist singularity.
    #[must_use]
    pub fn near_singular_count(&self) -> usize {
        self.frames
            .iter()
            .filter(|f| {
                f.issues
                    .iter()
                    .any(|i| matches!(i, FrameIssue::NearSingular { .. }))
            })
            .collect::<Vec<_>>()
            .len()
    }

    /// The frame index of each target with its joints, for `--joints-out`.
    pub fn joints(&self) -> impl Iterator<Item = (FrameIndex, Option<Joints>)> + '_ {
        self.frames.iter().map(|f| (f.target.frame, f.joints))
    }
}

/// Penalty added to a step's cost when the arm configuration changes: larger than any
/// feasible step (whose cost is at most 1 at full speed), so a flip is taken only when no
/// path in one configuration exists.
const CONFIGURATION_CHANGE_COST: f64 = 1e3;

/// Checks a path of targets on a robot in a cell, played at [`CheckConfig::time_scale`]: the
/// report's frames carry the scaled times, so speeds and programs follow.
///
/// Under [`TimeScale::Auto`] the path is checked at its recorded timing, then slowed by the
/// peak ratio of speed to limit (of acceleration, its square root: accelerations scale with
/// the square of the factor), and checked again; the joint solutions chosen can change with
/// the timing, so this repeats (at most four times) until the peaks are within the limits.
#[must_use]
pub fn check_path(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
) -> CheckReport {
    let mut report = check_timed(robot, cell, targets, config);
    report.suggestions = suggestions(robot, cell, targets, &report, config);
    report
}

/// Checks the strokes of a take (`strokes`: ranges of `targets`, in order) at one time scale:
/// each stroke on its own (the arm does not follow the demonstration between strokes: a
/// program lifts the brush and moves with a joint move), the report's frames the strokes'
/// frames in order. Under [`TimeScale::Auto`] the factor is the largest any stroke needs; the
/// suggestions are those of the strokes' frames taken as one path. One stroke over every
/// target is exactly [`check_path`].
#[must_use]
pub fn check_strokes(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    strokes: &[std::ops::Range<usize>],
    config: &CheckConfig,
) -> CheckReport {
    if let [only] = strokes
        && *only == (0..targets.len())
    {
        return check_path(robot, cell, targets, config);
    }
    let painted: Vec<TcpTarget> = strokes
        .iter()
        .flat_map(|s| targets[s.clone()].iter().copied())
        .collect();
    // Each stroke at its recorded timing, then at the factor the slowest one needs.
    let recorded: Vec<CheckReport> = strokes
        .iter()
        .map(|s| check_timed(robot, cell, &targets[s.clone()], config))
        .collect();
    let (factor, setter) = match config.time_scale {
        TimeScale::Fixed(factor) => (factor, None),
        TimeScale::Auto => recorded
            .iter()
            .enumerate()
            .map(|(i, r)| (r.timing.factor, Some(i)))
            .fold((1.0, None), |a, b| if b.0 > a.0 { b } else { a }),
    };
    let scaled = scale_time(targets, factor);
    let fixed = CheckConfig {
        time_scale: TimeScale::Fixed(factor),
        ..*config
    };
    let parts: Vec<CheckReport> = strokes
        .iter()
        .map(|s| check_at_timing(robot, cell, &scaled[s.clone()], &fixed, factor))
        .collect();
    let mut report = CheckReport {
        robot: robot.clone(),
        frames: parts
            .iter()
            .flat_map(|p| p.frames.iter().cloned())
            .collect(),
        peak_speed_ratio: parts.iter().map(|p| p.peak_speed_ratio).fold(0.0, f64::max),
        peak_acceleration_ratio: config.max_acceleration.map(|_| {
            parts
                .iter()
                .filter_map(|p| p.peak_acceleration_ratio)
                .fold(0.0, f64::max)
        }),
        peak_joint_speed: std::array::from_fn(|i| {
            parts
                .iter()
                .map(|p| p.peak_joint_speed[i])
                .fold(0.0, f64::max)
        }),
        peak_joint_acceleration: std::array::from_fn(|i| {
            parts
                .iter()
                .map(|p| p.peak_joint_acceleration[i])
                .fold(0.0, f64::max)
        }),
        suggestions: Vec::new(),
        timing: Timing {
            factor,
            limiting_axis: None,
            automatic: config.time_scale == TimeScale::Auto,
            fits: None,
        },
    };
    report.timing.limiting_axis = match setter {
        Some(i) => recorded[i].timing.limiting_axis,
        None => recorded
            .iter()
            .max_by(|a, b| a.peak_speed_ratio.total_cmp(&b.peak_speed_ratio))
            .and_then(|r| r.timing.limiting_axis),
    };
    if !report.timing.automatic && report.speed_failure().is_some() {
        let auto = CheckConfig {
            time_scale: TimeScale::Auto,
            ..*config
        };
        let fits = strokes
            .iter()
            .map(|s| check_timed(robot, cell, &targets[s.clone()], &auto))
            .map(|r| r.speed_failure().is_none().then_some(r.timing.factor))
            .try_fold(1.0f64, |a, f| f.map(|f| a.max(f)));
        report.timing.fits = fits;
    }
    report.suggestions = suggestions(robot, cell, &painted, &report, config);
    report
}

/// [`check_path`] without the suggestions (which run this again on each candidate).
fn check_timed(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
) -> CheckReport {
    let recorded = check_at_timing(robot, cell, targets, config, 1.0);
    let limiting_axis = limiting_axis(robot, &recorded, config);
    let (mut report, factor) = match config.time_scale {
        TimeScale::Fixed(1.0) => (recorded, 1.0),
        TimeScale::Fixed(factor) => (
            check_at_timing(robot, cell, &scale_time(targets, factor), config, factor),
            factor,
        ),
        TimeScale::Auto => auto_timing(robot, cell, targets, config, recorded),
    };
    let fits = match config.time_scale {
        TimeScale::Fixed(_) if report.speed_failure().is_some() => {
            let recorded = check_at_timing(robot, cell, targets, config, 1.0);
            let (auto, fits) = auto_timing(robot, cell, targets, config, recorded);
            auto.speed_failure().is_none().then_some(fits)
        }
        _ => None,
    };
    report.timing = Timing {
        factor,
        limiting_axis,
        automatic: config.time_scale == TimeScale::Auto,
        fits,
    };
    report
}

/// The report at the smallest factor within the limits, and the factor: slowed by the
/// recorded peak ratio, checked again, at most four times (the joint solutions chosen can
/// change with the timing).
fn auto_timing(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
    recorded: CheckReport,
) -> (CheckReport, f64) {
    let mut report = recorded;
    let mut factor = 1.0;
    for _ in 0..4 {
        let needed = needed_factor(&report);
        if needed <= 1.0 {
            break;
        }
        factor = round_up(factor * needed);
        report = check_at_timing(robot, cell, &scale_time(targets, factor), config, factor);
    }
    (report, factor)
}

/// The factor by which the checked timing must be slowed for speeds and accelerations to be
/// within their limits (≤ 1 when they are).
fn needed_factor(report: &CheckReport) -> f64 {
    let acceleration = report.peak_acceleration_ratio.unwrap_or(0.0).sqrt();
    report.peak_speed_ratio.max(acceleration)
}

/// Rounds a factor up to a hundredth, so that the factor said is one that passes.
fn round_up(factor: f64) -> f64 {
    (factor * 100.0 - 1e-9).ceil() / 100.0
}

/// The axis closest to its speed limit at the recorded timing.
fn limiting_axis(robot: &Robot, report: &CheckReport, config: &CheckConfig) -> Option<usize> {
    let measured = report
        .frames
        .windows(2)
        .any(|pair| pair[0].joints.is_some() && pair[1].joints.is_some());
    if !measured {
        return None;
    }
    (0..6).max_by(|&a, &b| {
        let ratio = |axis: usize| {
            report.peak_joint_speed[axis] / (robot.limits[axis].max_speed * config.speed_fraction)
        };
        ratio(a).total_cmp(&ratio(b))
    })
}

/// [`check_path`] at one timing, `factor` times the recorded one (`targets` already scaled).
fn check_at_timing(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
    factor: f64,
) -> CheckReport {
    let (chosen, beyond_turns) = choose_joints(robot, cell, targets, config);
    let mut frames = Vec::with_capacity(targets.len());
    let mut previous: Option<(usize, IkSolution)> = None;
    let mut previous_speed: Option<(usize, [f64; 6])> = None;
    let mut peak_speed_ratio: f64 = 0.0;
    let mut peak_acceleration_ratio: f64 = 0.0;
    for (k, target) in targets.iter().enumerate() {
        let mut issues = Vec::new();
        let mut joint_speed = [0.0; 6];
        let mut joint_acceleration = [0.0; 6];
        let Some(solution) = chosen[k] else {
            issues.push(beyond_turns[k].unwrap_or_else(|| reach_issue(robot, cell, target)));
            frames.push(FrameCheck {
                target: *target,
                joints: None,
                configuration: None,
                joint_speed,
                joint_acceleration,
                issues,
            });
            previous = None;
            previous_speed = None;
            continue;
        };
        if let Some((p, before)) = previous {
            let dt = target.time_s - targets[p].time_s;
            if dt.is_nan() || dt <= 0.0 {
                issues.push(FrameIssue::TimeNotIncreasing {
                    time_s: target.time_s,
                    previous_s: targets[p].time_s,
                });
            }
            let dt = dt.max(1e-9);
            for (axis, speed) in joint_speed.iter_mut().enumerate() {
                *speed = (solution.joints.0[axis] - before.joints.0[axis]) / dt;
                let max_speed = robot.limits[axis].max_speed * config.speed_fraction;
                let ratio = speed.abs() / max_speed;
                peak_speed_ratio = peak_speed_ratio.max(ratio);
                if ratio > 1.0 {
                    issues.push(FrameIssue::TooFast {
                        axis,
                        speed: *speed,
                        max_speed,
                    });
                }
            }
            if before.configuration != solution.configuration {
                issues.push(FrameIssue::ConfigurationChange {
                    from: before.configuration.code(),
                    to: solution.configuration.code(),
                });
            }
            if let Some((pp, speed_before)) = previous_speed {
                let dt2 = 0.5 * (target.time_s - targets[pp].time_s);
                for (axis, acceleration) in joint_acceleration.iter_mut().enumerate() {
                    *acceleration = (joint_speed[axis] - speed_before[axis]) / dt2;
                }
                if let Some(limits) = config.max_acceleration {
                    for (axis, limit) in limits.iter().enumerate() {
                        let ratio = joint_acceleration[axis].abs() / limit;
                        peak_acceleration_ratio = peak_acceleration_ratio.max(ratio);
                        if ratio > 1.0 {
                            issues.push(FrameIssue::TooHighAcceleration {
                                axis,
                                acceleration: joint_acceleration[axis],
                                max_acceleration: *limit,
                            });
                        }
                    }
                }
            }
            previous_speed = Some((p, joint_speed));
        }
        if solution.joints.0[4].abs() < config.wrist_singularity {
            issues.push(FrameIssue::NearSingular {
                axis5: solution.joints.0[4],
            });
        }
        frames.push(FrameCheck {
            target: *target,
            joints: Some(solution.joints),
            configuration: Some(solution.configuration),
            joint_speed,
            joint_acceleration,
            issues,
        });
        previous = Some((k, solution));
    }
    let mut peak_joint_speed = [0.0f64; 6];
    let mut peak_joint_acceleration = [0.0f64; 6];
    for f in &frames {
        for axis in 0..6 {
            peak_joint_speed[axis] = peak_joint_speed[axis].max(f.joint_speed[axis].abs());
            peak_joint_acceleration[axis] =
                peak_joint_acceleration[axis].max(f.joint_acceleration[axis].abs());
        }
    }
    CheckReport {
        robot: robot.clone(),
        frames,
        peak_speed_ratio,
        peak_acceleration_ratio: config.max_acceleration.map(|_| peak_acceleration_ratio),
        peak_joint_speed,
        peak_joint_acceleration,
        suggestions: Vec::new(),
        timing: Timing {
            factor,
            limiting_axis: None,
            automatic: false,
            fits: None,
        },
    }
}

/// Why a target has no solution: out of reach, or the limit broken by the least bad solution.
fn reach_issue(robot: &Robot, cell: &Cell, target: &TcpTarget) -> FrameIssue {
    let all = inverse(robot, &cell.base_from_flange(&target.wobj_from_tcp));
    let mut worst: Option<(f64, usize, f64)> = None;
    for solution in &all {
        // The solution's largest excess over a limit, and where.
        let mut excess = (0.0, 0, 0.0);
        for axis in 0..6 {
            let limit = &robot.limits[axis];
            let angle = solution.joints.0[axis];
            let over = (limit.min - angle).max(angle - limit.max);
            if over > excess.0 {
                excess = (over, axis, angle);
            }
        }
        if worst.is_none_or(|w| excess.0 < w.0) {
            worst = Some(excess);
        }
    }
    match worst {
        None => FrameIssue::OutOfReach,
        Some((_, axis, angle)) => FrameIssue::OutsideLimits { axis, angle },
    }
}

/// A preference among solutions at the first frame of a run: ABB's usual configuration
/// (wrist in front of axis 1 and of the lower arm, axis 5 positive), then angles near the
/// middle of their ranges. Small beside any step cost.
fn start_cost(robot: &Robot, solution: &IkSolution) -> f64 {
    let c = &solution.configuration;
    let configuration = f64::from(u8::from(c.shoulder == Shoulder::Back))
        + f64::from(u8::from(c.elbow == Elbow::Behind))
        + f64::from(u8::from(c.wrist_flipped));
    let centred: f64 = (0..6)
        .map(|i| {
            let l = &robot.limits[i];
            let mid = 0.5 * (l.min + l.max);
            ((solution.joints.0[i] - mid) / (l.max - l.min)).powi(2)
        })
        .sum();
    1e-3 * configuration + 1e-4 * centred
}

pub(crate) fn step_cost(
    robot: &Robot,
    turning: &[bool; 6],
    from: &IkSolution,
    to: &IkSolution,
    dt: f64,
    config: &CheckConfig,
) -> f64 {
    let mut ratio: f64 = 0.0;
    for (axis, turns) in turning.iter().enumerate() {
        // A non-increasing time (reported by the check) costs as a step in a nanosecond.
        let max_step = robot.limits[axis].max_speed * config.speed_fraction * dt.max(1e-9);
        let step = to.joints.0[axis] - from.joints.0[axis];
        let step = if *turns { wrap(step) } else { step };
        ratio = ratio.max(step.abs() / max_step);
    }
    let flip = if same_configuration(&from.configuration, &to.configuration) {
        0.0
    } else {
        CONFIGURATION_CHANGE_COST
    };
    ratio * ratio + flip
}

fn same_configuration(a: &ArmConfiguration, b: &ArmConfiguration) -> bool {
    a == b
}

/// One solution per target (or `None`), minimising the summed step costs over each run of
/// consecutive targets that have solutions.
fn choose_along_path(
    robot: &Robot,
    turning: &[bool; 6],
    targets: &[TcpTarget],
    candidates: &[Vec<IkSolution>],
    config: &CheckConfig,
) -> Vec<Option<IkSolution>> {
    let mut chosen = vec![None; targets.len()];
    let mut start = 0;
    while start < targets.len() {
        if candidates[start].is_empty() {
            start += 1;
            continue;
        }
        let mut end = start + 1;
        while end < targets.len() && !candidates[end].is_empty() {
            end += 1;
        }
        // Viterbi over start..end.
        let mut cost: Vec<f64> = candidates[start]
            .iter()
            .map(|s| start_cost(robot, s))
            .collect();
        let mut back: Vec<Vec<usize>> = Vec::with_capacity(end - start);
        back.push(Vec::new());
        for k in start + 1..end {
            let dt = targets[k].time_s - targets[k - 1].time_s;
            let mut next_cost = Vec::with_capacity(candidates[k].len());
            let mut next_back = Vec::with_capacity(candidates[k].len());
            // Predecessors cheapest first: a step never costs less than zero, so the search
            // for a target's best predecessor stops at the first whose cost alone is no
            // better; it starts from the candidate at the same index (the same branch when
            // both frames have the same candidates), whose small step makes it stop early.
            let mut order: Vec<usize> = (0..cost.len()).collect();
            order.sort_by(|&a, &b| cost[a].total_cmp(&cost[b]));
            for (j, to) in candidates[k].iter().enumerate() {
                let mut best = (f64::INFINITY, 0);
                if let Some(from) = candidates[k - 1].get(j) {
                    best = (cost[j] + step_cost(robot, turning, from, to, dt, config), j);
                }
                for &i in &order {
                    if cost[i] >= best.0 {
                        break;
                    }
                    let from = &candidates[k - 1][i];
                    let c = cost[i] + step_cost(robot, turning, from, to, dt, config);
                    if c < best.0 {
                        best = (c, i);
                    }
                }
                next_cost.push(best.0);
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
        for k in (start..end).rev() {
            chosen[k] = candidates[k].get(index).copied();
            if k > start {
                index = back[k - start][index];
            }
        }
        start = end;
    }
    chosen
}

/// The joint solution chosen for each target along the path (`None` where there is none in
/// the limits), and the issue of a target taken out because a turning axis left its range.
fn choose_joints(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
) -> (Vec<Option<IkSolution>>, Vec<Option<FrameIssue>>) {
    let turning = turning_axes(robot);
    let candidates: Vec<Vec<IkSolution>> = targets
        .iter()
        .map(|t| path_candidates(robot, &turning, &cell.base_from_flange(&t.wobj_from_tcp)))
        .collect();
    let mut chosen = choose_along_path(robot, &turning, targets, &candidates, config);
    let beyond_turns = unwrap_turning_axes(robot, &turning, &mut chosen);
    (chosen, beyond_turns)
}

/// True when the path has joints within the limits at every target: each target has a
/// solution (quick) and the chosen path keeps every turning axis in its range.
fn reachable_everywhere(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
) -> bool {
    let each = targets.iter().all(|t| {
        !inverse_within_limits(robot, &cell.base_from_flange(&t.wobj_from_tcp)).is_empty()
    });
    each && choose_joints(robot, cell, targets, config)
        .0
        .iter()
        .all(Option::is_some)
}

/// The axes whose range spans a full turn or more (every angle has a copy inside it: each
/// axis of a UR, axis 6 of the IRB 120 and of the KR 6). Along a path they move continuously,
/// so their ±360° copies are not separate candidates: the path is chosen on their wrapped
/// angles, then unwrapped and placed in the range as a whole ([`unwrap_turning_axes`]).
pub(crate) fn turning_axes(robot: &Robot) -> [bool; 6] {
    std::array::from_fn(|i| robot.limits[i].max - robot.limits[i].min >= TAU - 1e-9)
}

/// The candidates of one target: every branch, with the copies of the axes that do not turn
/// fully ([`inverse_within_limits`] on those axes), the turning axes wrapped.
pub(crate) fn path_candidates(
    robot: &Robot,
    turning: &[bool; 6],
    base_from_flange: &crate::geometry::Pose,
) -> Vec<IkSolution> {
    let mut relaxed = robot.clone();
    for (limit, turns) in relaxed.limits.iter_mut().zip(turning) {
        if *turns {
            limit.min = -std::f64::consts::PI;
            limit.max = std::f64::consts::PI;
        }
    }
    inverse_within_limits(&relaxed, base_from_flange)
}

/// Unwraps the turning axes along each run of chosen solutions and shifts each by the whole
/// turns that keep the most frames of the run inside the range (ties: the first frame nearest
/// the middle of the range). A frame still outside (a run turning further than the range) is
/// taken out, with the issue saying which axis and where.
fn unwrap_turning_axes(
    robot: &Robot,
    turning: &[bool; 6],
    chosen: &mut [Option<IkSolution>],
) -> Vec<Option<FrameIssue>> {
    let mut issues = vec![None; chosen.len()];
    let mut start = 0;
    while start < chosen.len() {
        if chosen[start].is_none() {
            start += 1;
            continue;
        }
        let mut end = start + 1;
        while end < chosen.len() && chosen[end].is_some() {
            end += 1;
        }
        for axis in (0..6).filter(|&a| turning[a]) {
            let mut angles: Vec<f64> = Vec::with_capacity(end - start);
            for solution in chosen[start..end].iter().flatten() {
                let raw = solution.joints.0[axis];
                let angle = match angles.last() {
                    Some(previous) => previous + wrap(raw - previous),
                    None => raw,
                };
                angles.push(angle);
            }
            let limit = &robot.limits[axis];
            let middle = 0.5 * (limit.min + limit.max);
            let score = |turns: i32| {
                let shift = f64::from(turns) * TAU;
                let inside = angles
                    .iter()
                    .filter(|a| limit.contains(**a + shift))
                    .count();
                (inside, -(angles[0] + shift - middle).abs())
            };
            let turns = (-3..=3)
                .max_by(|&a, &b| {
                    let (ia, da) = score(a);
                    let (ib, db) = score(b);
                    ia.cmp(&ib).then(da.total_cmp(&db))
                })
                .unwrap_or(0);
            let shift = f64::from(turns) * TAU;
            for (k, angle) in (start..end).zip(&angles) {
                let angle = angle + shift;
                if limit.contains(angle) {
                    if let Some(solution) = chosen[k].as_mut() {
                        solution.joints.0[axis] = angle;
                    }
                } else {
                    issues[k] = Some(FrameIssue::OutsideLimits { axis, angle });
                }
            }
        }
        for k in start..end {
            if issues[k].is_some() {
                chosen[k] = None;
            }
        }
        start = end;
    }
    issues
}

/// The largest time scale a suggested work object may need under [`TimeScale::Auto`]: a
/// placement that makes the demonstration play more than three times slower is not offered
/// (a path through a wrist singularity can need 35×).
pub const MAX_SUGGESTED_TIME_SCALE: f64 = 3.0;

fn suggestions(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    report: &CheckReport,
    config: &CheckConfig,
) -> Vec<Suggestion> {
    let mut out = Vec::new();
    let slow = report.timing.automatic && report.timing.factor > MAX_SUGGESTED_TIME_SCALE;
    let reachable = report.unreachable_count() == 0;
    let speed_only = reachable
        && report
            .failing()
            .flat_map(|f| f.issues.iter())
            .filter(|i| i.is_failure())
            .all(|i| {
                matches!(
                    i,
                    FrameIssue::TooFast { .. } | FrameIssue::TooHighAcceleration { .. }
                )
            });
    let placement_wanted =
        !report.passes() && !speed_only || slow || report.near_singular_count() > 0;
    if placement_wanted && !targets.is_empty() {
        if let Some(by_in_base) = work_object_move(robot, cell, targets, config) {
            let mut base_from_wobj = cell.base_from_wobj;
            base_from_wobj.translation.vector += by_in_base;
            out.push(verified(robot, cell, targets, config, base_from_wobj));
        } else if let Some(base_from_wobj) = work_object_placement(robot, cell, targets, config) {
            out.push(verified(robot, cell, targets, config, base_from_wobj));
        }
    }
    if reachable {
        let factor = needed_factor(report);
        if factor > 1.0 {
            out.push(Suggestion::SlowDown {
                factor: round_up(report.timing.factor * factor),
            });
        }
    }
    out
}

/// The suggestion of a work object [`passes_whole_check`] accepted, with its time scale.
fn verified(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
    base_from_wobj: crate::geometry::Pose,
) -> Suggestion {
    let placed = Cell {
        base_from_wobj,
        ..*cell
    };
    let time_scale = check_timed(robot, &placed, targets, config).timing.factor;
    Suggestion::UseWorkObject {
        base_from_wobj,
        time_scale,
    }
}

/// True when the whole check passes in `cell`: every frame in reach within the joint ranges,
/// the joints within their speeds at the time scale asked (under [`TimeScale::Auto`], at most
/// [`MAX_SUGGESTED_TIME_SCALE`]), no configuration change, no frame near the wrist
/// singularity. Reach alone is tried first (quick).
fn passes_whole_check(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
) -> bool {
    if !reachable_everywhere(robot, cell, targets, config) {
        return false;
    }
    let report = check_timed(robot, cell, targets, config);
    report.passes()
        && report.near_singular_count() == 0
        && !(report.timing.automatic && report.timing.factor > MAX_SUGGESTED_TIME_SCALE)
}

/// A work object, turned and placed, with which the whole check passes
/// ([`passes_whole_check`]): the current orientation composed with each of the turns a rig's world is usually
/// off by (none, half a turn about x, y or z, a quarter turn about z), the targets' centroid
/// placed at [`Robot::comfortable_point`] or up to 30 % of the reach below or 20 % above it.
/// The first that passes, `None` when none does.
fn work_object_placement(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
) -> Option<crate::geometry::Pose> {
    use nalgebra::{UnitQuaternion, Vector3};
    if targets.is_empty() {
        return None;
    }
    let half = std::f64::consts::PI;
    let quarter = std::f64::consts::FRAC_PI_2;
    let turns = [
        UnitQuaternion::identity(),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), half),
        UnitQuaternion::from_axis_angle(&Vector3::y_axis(), half),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), half),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), quarter),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -quarter),
    ];
    let centroid = targets
        .iter()
        .map(|t| t.wobj_from_tcp.translation.vector)
        .sum::<Vec3>()
        / targets.len() as f64;
    let reach = robot.max_wrist_reach();
    for turn in turns {
        let rotation = cell.base_from_wobj.rotation * turn;
        for height in [0.0, -0.1, -0.2, -0.3, 0.1, 0.2] {
            let goal = robot.comfortable_point().coords + Vec3::new(0.0, 0.0, height * reach);
            let base_from_wobj =
                crate::geometry::pose_from_parts(goal - rotation * centroid, rotation);
            let placed = Cell {
                base_from_wobj,
                ..*cell
            };
            if passes_whole_check(robot, &placed, targets, config) {
                return Some(base_from_wobj);
            }
        }
    }
    None
}

/// A translation of the work object, toward the arm's comfortable zone
/// ([`Robot::comfortable_point`]), after which the whole check passes ([`passes_whole_check`]);
/// tried in steps of 1 % of the reach along the direction from the targets' centroid to that
/// point.
fn work_object_move(
    robot: &Robot,
    cell: &Cell,
    targets: &[TcpTarget],
    config: &CheckConfig,
) -> Option<Vec3> {
    if targets.is_empty() {
        return None;
    }
    let centroid = targets
        .iter()
        .map(|t| cell.base_from_flange(&t.wobj_from_tcp).translation.vector)
        .sum::<Vec3>()
        / targets.len() as f64;
    let towards = robot.comfortable_point().coords - centroid;
    let distance = towards.norm();
    if distance < 1e-9 {
        return None;
    }
    let direction = towards / distance;
    let reach = robot.max_wrist_reach();
    let step = 0.01 * reach;
    let mut moved = step;
    while moved <= config.max_work_object_move_reach * reach {
        let by = direction * moved;
        let mut moved_cell = *cell;
        moved_cell.base_from_wobj.translation.vector += by;
        if passes_whole_check(robot, &moved_cell, targets, config) {
            return Some(by);
        }
        moved += step;
    }
    None
}

/// A run of consecutive checked frames with the same issue (the same kind, on the same axis):
/// `check`, `export` and the studio print these instead of one line a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IssueRange {
    /// The first frame of the run.
    pub first: FrameIndex,
    /// The last frame of the run.
    pub last: FrameIndex,
    /// Frames in the run.
    pub frames: usize,
    /// The run's worst issue (fastest, furthest outside, closest to the singularity); for
    /// an axis outside its range, the angle furthest outside.
    pub worst: FrameIssue,
    /// The limit the worst issue breaks, for the text: the axis's range (radians) for
    /// [`FrameIssue::OutsideLimits`].
    range: Option<(f64, f64)>,
}

impl IssueRange {
    /// True when the run stops the program (false for a warning).
    #[must_use]
    pub fn is_failure(&self) -> bool {
        self.worst.is_failure()
    }
}

impl std::fmt::Display for IssueRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.first == self.last {
            write!(f, "frame {}: ", self.first.0)?;
        } else {
            write!(f, "frames {}-{}: ", self.first.0, self.last.0)?;
        }
        let many = self.frames > 1;
        match self.worst {
            FrameIssue::OutOfReach => write!(f, "out of reach"),
            FrameIssue::OutsideLimits { axis, angle } => {
                let up_to = if many { "up to " } else { "" };
                write!(
                    f,
                    "axis {} outside its range, {up_to}{:.1}°",
                    axis + 1,
                    angle.to_degrees()
                )?;
                if let Some((min, max)) = self.range {
                    write!(f, " of {:.0}..{:.0}°", min.to_degrees(), max.to_degrees())?;
                }
                Ok(())
            }
            FrameIssue::TooFast {
                axis,
                speed,
                max_speed,
            } => write!(
                f,
                "axis {} too fast, {}{:.0}°/s of {:.0}°/s",
                axis + 1,
                if many { "up to " } else { "" },
                speed.abs().to_degrees(),
                max_speed.to_degrees()
            ),
            FrameIssue::TooHighAcceleration {
                axis,
                acceleration,
                max_acceleration,
            } => write!(
                f,
                "axis {} accelerates too hard, {}{:.0}°/s² of {:.0}°/s²",
                axis + 1,
                if many { "up to " } else { "" },
                acceleration.abs().to_degrees(),
                max_acceleration.to_degrees()
            ),
            FrameIssue::ConfigurationChange { .. } | FrameIssue::TimeNotIncreasing { .. } => {
                write!(f, "{}", self.worst)?;
                if many {
                    write!(f, " ({} times)", self.frames)?;
                }
                Ok(())
            }
            FrameIssue::NearSingular { axis5 } => write!(
                f,
                "near the wrist singularity, axis 5 {}{:.1}°",
                if many { "down to " } else { "at " },
                axis5.to_degrees()
            ),
        }
    }
}

/// What groups issues into a run: the kind and, for the per-axis kinds, the axis.
fn issue_key(issue: &FrameIssue) -> (u8, usize) {
    match issue {
        FrameIssue::OutOfReach => (0, 0),
        FrameIssue::OutsideLimits { axis, .. } => (1, *axis),
        FrameIssue::TooFast { axis, .. } => (2, *axis),
        FrameIssue::TooHighAcceleration { axis, .. } => (3, *axis),
        FrameIssue::ConfigurationChange { .. } => (4, 0),
        FrameIssue::TimeNotIncreasing { .. } => (5, 0),
        FrameIssue::NearSingular { .. } => (6, 0),
    }
}

/// How bad an issue is within its run (larger is worse).
fn issue_severity(issue: &FrameIssue, robot: &Robot) -> f64 {
    match *issue {
        FrameIssue::OutsideLimits { axis, angle } => {
            let l = &robot.limits[axis];
            (l.min - angle).max(angle - l.max)
        }
        FrameIssue::TooFast { speed, .. } => speed.abs(),
        FrameIssue::TooHighAcceleration { acceleration, .. } => acceleration.abs(),
        FrameIssue::NearSingular { axis5 } => -axis5.abs(),
        _ => 0.0,
    }
}

/// The report's issues as runs of consecutive frames (consecutive in the report: frames
/// without a pose in between do not break a run), ordered by their first frame, failures and
/// warnings alike ([`IssueRange::is_failure`]).
#[must_use]
pub fn issue_ranges(report: &CheckReport) -> Vec<IssueRange> {
    // Open runs by key: (index of the run in `out`, the report position of its last frame).
    let mut open: Vec<((u8, usize), usize, usize)> = Vec::new();
    let mut out: Vec<IssueRange> = Vec::new();
    for (position, frame) in report.frames.iter().enumerate() {
        for issue in &frame.issues {
            let key = issue_key(issue);
            let continuing = open
                .iter_mut()
                .find(|(k, _, last)| *k == key && *last + 1 == position);
            if let Some((_, run, last)) = continuing {
                let range = &mut out[*run];
                *last = position;
                range.last = frame.target.frame;
                range.frames += 1;
                if issue_severity(issue, &report.robot)
                    > issue_severity(&range.worst, &report.robot)
                {
                    range.worst = *issue;
                }
            } else {
                open.retain(|(k, _, _)| *k != key);
                open.push((key, out.len(), position));
                let range = match issue {
                    FrameIssue::OutsideLimits { axis, .. } => {
                        let l = &report.robot.limits[*axis];
                        Some((l.min, l.max))
                    }
                    _ => None,
                };
                out.push(IssueRange {
                    first: frame.target.frame,
                    last: frame.target.frame,
                    frames: 1,
                    worst: *issue,
                    range,
                });
            }
        }
    }
    out
}
