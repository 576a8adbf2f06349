//! A robot program independent of the dialect: the checked targets, simplified, each reached
//! by a linear move whose speeds reproduce the recorded timing.
//!
//! Model: between kept targets `a` and `b` recorded `Δt = t_b − t_a` apart, the move's TCP
//! speed is `|p_b − p_a| / Δt` and its orientation speed `angle(q_a, q_b) / Δt`; a controller
//! that honours both takes `Δt` for the move (RAPID `speeddata` `v_tcp`, `v_ori`; KRL
//! `$VEL.CP`; URScript `movel(..., v=...)`).

use crate::geometry::{Pose, Vec3};
use crate::robot::check::{CheckReport, Timing};
use crate::robot::gaps::Gap;
use crate::robot::kinematics::{
    ArmConfiguration, IkSolution, Joints, Robot, inverse_within_limits,
};
use crate::robot::rapid::number;
use crate::robot::simplify::{SimplifyConfig, simplify};
use crate::robot::{Cell, TcpTarget};

/// What a move of a program is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveKind {
    /// A point of the demonstration.
    Paint,
    /// Above the first point, along the tool's axis: reached with a joint move, left with a
    /// linear move onto the paint.
    Approach,
    /// Above the last point, along the tool's axis, reached linearly from it.
    Retract,
}

/// One move of a program: the first a joint move, the others linear.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProgramMove {
    /// What the move is for.
    pub kind: MoveKind,
    /// Where the TCP goes, in the work-object frame.
    pub target: TcpTarget,
    /// The joints the check chose there, `None` for a target the arm cannot reach (a forced
    /// export).
    pub joints: Option<Joints>,
    /// Their arm configuration.
    pub configuration: Option<ArmConfiguration>,
    /// TCP speed from the previous target, mm/s (zero for the first target).
    pub tcp_speed: f64,
    /// Orientation speed from the previous target, rad/s.
    pub orientation_speed: f64,
    /// Recorded time from the previous target, seconds.
    pub duration_s: f64,
    /// The stroke it belongs to, 0-based ([`build_stroke_program`]); its approach and retract
    /// too. The first move of a stroke is a joint move.
    pub stroke: usize,
}

/// The tool's load on the flange: RAPID's `tload`, KRL's `$LOAD`, URScript's `set_payload`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolLoad {
    /// Mass, kilograms.
    pub mass_kg: f64,
    /// Centre of gravity in the maker's flange frame, millimetres.
    pub cog_in_flange: Vec3,
}

impl ToolLoad {
    /// Mass of [`ToolLoad::assumed`]: a brush and its holder, kilograms.
    pub const ASSUMED_MASS_KG: f64 = 0.2;

    /// The load assumed when none is given: 0.2 kg (a brush and its holder) with its centre
    /// of gravity halfway along the TCP offset (a brush's mass sits on its handle). Measure
    /// the real one (ABB `LoadIdentify`, KUKA load data determination, UR payload estimation)
    /// before running fast.
    #[must_use]
    pub fn assumed(cell: &Cell) -> Self {
        Self {
            mass_kg: Self::ASSUMED_MASS_KG,
            cog_in_flange: cell.flange_from_tcp.translation.vector / 2.0,
        }
    }
}

/// A program: a name, the robot, the cell and the moves, stroke by stroke, each stroke's first
/// move (its approach) a joint move.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// Identifier of the program (a valid RAPID/KRL/URScript name).
    pub name: String,
    /// The robot it was checked on.
    pub robot: Robot,
    /// The work object and the TCP on the flange.
    pub cell: Cell,
    /// The tool's load, `None` when not given ([`Program::tool_load`] then assumes one).
    pub load: Option<ToolLoad>,
    /// The path tolerance the targets were simplified with (zones are chosen from it).
    pub tolerance: SimplifyConfig,
    /// The moves in order.
    pub moves: Vec<ProgramMove>,
    /// The time scale the demonstration is played at (the moves' speeds include it).
    pub timing: Timing,
    /// Joints (the maker's convention, radians) the program starts and ends at with a joint
    /// move (`--home`, checked by [`check_home`]), `None` for none.
    pub home: Option<Joints>,
    /// Gaps in the demonstration that straight moves cross (`--bridge-gaps`): each is said in
    /// a comment before the move that crosses it ([`Program::gap_crossed_by`]).
    pub gaps: Vec<Gap>,
    /// For a free tool axis, the line the header says it with
    /// ([`crate::robot::free_axis::FreeRoll::describe`]); `None` for the demonstrated roll.
    pub tool_axis: Option<String>,
}

/// TCP speed of the linear moves onto the first point and off the last one, mm/s: a brush
/// touching down and lifting off gently (slower still when an axis would be too fast).
pub const APPROACH_SPEED_MM_S: f64 = 50.0;

impl Program {
    /// The tool's load: the one given, else [`ToolLoad::assumed`]; with a note for the
    /// program's comment saying which.
    #[must_use]
    pub fn tool_load(&self) -> (ToolLoad, &'static str) {
        match self.load {
            Some(load) => (load, "given"),
            None => (
                ToolLoad::assumed(&self.cell),
                "assumed (0.2 kg at half the TCP offset; set --tool-mass and --tool-cog)",
            ),
        }
    }
}

impl Program {
    /// The gap the move at `index` crosses from the move before it, for the comment the
    /// dialects write before it (`None` for the first move or a move within the data).
    #[must_use]
    pub fn gap_crossed_by(&self, index: usize) -> Option<&Gap> {
        let from = self.moves.get(index.checked_sub(1)?)?.target.frame;
        let to = self.moves.get(index)?.target.frame;
        self.gaps.iter().find(|g| g.spans(from, to))
    }

    /// True when the robot must stop exactly at move `index` rather than blend through it:
    /// the last move, the paint point the approach lands on and the one the retract lifts
    /// from (the brush touches down and lifts off there), the last move of a stroke.
    #[must_use]
    pub fn stops_at(&self, index: usize) -> bool {
        let kind = |i: usize| self.moves.get(i).map(|m| m.kind);
        index + 1 >= self.moves.len()
            || (index > 0 && kind(index - 1) == Some(MoveKind::Approach))
            || kind(index + 1) == Some(MoveKind::Retract)
            || self.starts_stroke(index + 1)
    }

    /// True when move `index` starts a stroke (the first move, or one whose stroke differs
    /// from the previous move's): it is a joint move, after the stroke's comment.
    #[must_use]
    pub fn starts_stroke(&self, index: usize) -> bool {
        match (index.checked_sub(1), self.moves.get(index)) {
            (_, None) => false,
            (None, Some(_)) => true,
            (Some(before), Some(m)) => self.moves[before].stroke != m.stroke,
        }
    }

    /// The comment naming the stroke move `index` starts (`None` when it starts none):
    /// "Stroke 2 of 3: frames 45-78" (the frames its paint points come from).
    #[must_use]
    pub fn stroke_comment(&self, index: usize) -> Option<String> {
        if !self.starts_stroke(index) {
            return None;
        }
        let stroke = self.moves[index].stroke;
        let count = self.moves.last().map_or(0, |m| m.stroke + 1);
        let mut painted = self
            .moves
            .iter()
            .filter(|m| m.stroke == stroke && m.kind == MoveKind::Paint);
        let first = painted.next()?.target.frame.0;
        let last = painted.next_back().map_or(first, |m| m.target.frame.0);
        Some(format!(
            "Stroke {} of {count}: frames {first}-{last}",
            stroke + 1
        ))
    }

    /// Adds, to every stroke, an approach `distance_mm` back along the tool's axis (the TCP's
    /// z, on the side of the flange: away from the work) from its first point, and the same
    /// retract after its last one, each with the joints closest to its paint point's in the
    /// same configuration; the linear moves onto and off the paint run at
    /// [`APPROACH_SPEED_MM_S`], slower when an axis would exceed `speed_fraction` of its limit.
    /// Nothing changes for a distance of zero or an empty program.
    ///
    /// Near the edge of the reach the distance shortens, down to 40 % of the one asked.
    ///
    /// # Errors
    /// Names the pose when the arm cannot reach it within its joint ranges.
    pub fn add_approach(&mut self, distance_mm: f64, speed_fraction: f64) -> Result<(), String> {
        if distance_mm <= 0.0 || self.moves.is_empty() {
            return Ok(());
        }
        let strokes = self.moves.last().map_or(0, |m| m.stroke + 1);
        let mut moves = Vec::with_capacity(self.moves.len() + 2 * strokes);
        let mut start = 0;
        while start < self.moves.len() {
            let stroke = self.moves[start].stroke;
            let mut end = start + 1;
            while end < self.moves.len() && self.moves[end].stroke == stroke {
                end += 1;
            }
            let (first, last) = (self.moves[start], self.moves[end - 1]);
            let (first_name, last_name) = if strokes > 1 {
                (
                    format!("first point of stroke {}", stroke + 1),
                    format!("last point of stroke {}", stroke + 1),
                )
            } else {
                ("first point".to_string(), "last point".to_string())
            };
            let approach =
                self.lifted_within(&first, distance_mm, MoveKind::Approach, &first_name)?;
            let retract = self.lifted_within(&last, distance_mm, MoveKind::Retract, &last_name)?;
            // The move onto the first point now comes from the approach pose.
            let mut onto = first;
            self.timed(&mut onto, &approach, speed_fraction);
            let mut off = retract;
            self.timed(&mut off, &last, speed_fraction);
            moves.push(approach);
            moves.push(onto);
            moves.extend_from_slice(&self.moves[start + 1..end]);
            moves.push(off);
            start = end;
        }
        self.moves = moves;
        Ok(())
    }

    /// The sign of the TCP's z that points away from the work: toward the flange (the arm is
    /// always on the handle's side of the brush's tip), so `+1` for a TCP whose z runs up the
    /// handle (the paper's brush, `--tcp 0,0,200,0,1,0,0`) and `−1` for one whose z points into
    /// the work (`--tcp 0,0,200,1,0,0,0`, ABB's tools); `−1` when the flange lies across the
    /// axis.
    fn away_from_work(&self) -> f64 {
        let flange_in_tcp = self.cell.flange_from_tcp.inverse().translation.vector;
        if flange_in_tcp.z > 1e-6 { 1.0 } else { -1.0 }
    }

    /// [`Program::lifted`] at `distance_mm`, else at 80, 60 or 40 % of it (an arm near the
    /// edge of its reach); the error of the full distance when none is reachable.
    fn lifted_within(
        &self,
        at: &ProgramMove,
        distance_mm: f64,
        kind: MoveKind,
        which: &str,
    ) -> Result<ProgramMove, String> {
        match self.lifted(at, distance_mm, kind, which) {
            Ok(lifted) => Ok(lifted),
            Err(full) => [0.8, 0.6, 0.4]
                .iter()
                .find_map(|f| self.lifted(at, f * distance_mm, kind, which).ok())
                .ok_or(full),
        }
    }

    /// The pose `distance_mm` back along the tool's axis from `at`, with its joints.
    fn lifted(
        &self,
        at: &ProgramMove,
        distance_mm: f64,
        kind: MoveKind,
        which: &str,
    ) -> Result<ProgramMove, String> {
        let lift = Pose::from_parts(
            nalgebra::Translation3::new(0.0, 0.0, self.away_from_work() * distance_mm),
            nalgebra::UnitQuaternion::identity(),
        );
        let wobj_from_tcp = at.target.wobj_from_tcp * lift;
        let base_from_flange = self.cell.base_from_flange(&wobj_from_tcp);
        let reference = at.joints;
        let distance = |s: &IkSolution| {
            reference.map_or(0.0, |r| {
                (0..6)
                    .map(|i| (s.joints.0[i] - r.0[i]).abs())
                    .fold(0.0, f64::max)
            })
        };
        let closest = inverse_within_limits(&self.robot, &base_from_flange)
            .into_iter()
            .filter(|s| at.configuration.is_none_or(|c| c == s.configuration))
            .min_by(|a, b| distance(a).total_cmp(&distance(b)));
        let Some(solution) = closest else {
            let what = if kind == MoveKind::Approach {
                "approach"
            } else {
                "retract"
            };
            return Err(format!(
                "the {what} pose {distance_mm} mm along the tool's axis from the {which} is out of the {}'s reach in its configuration (a shorter --approach, or 0 for none)",
                self.robot.name
            ));
        };
        Ok(ProgramMove {
            kind,
            target: TcpTarget {
                wobj_from_tcp,
                ..at.target
            },
            joints: Some(solution.joints),
            configuration: Some(solution.configuration),
            tcp_speed: 0.0,
            orientation_speed: 0.0,
            duration_s: 0.0,
            stroke: at.stroke,
        })
    }

    /// Sets the speed and duration of the linear move `to` from `from`: the approach speed,
    /// slower when an axis would exceed `speed_fraction` of its limit.
    fn timed(&self, to: &mut ProgramMove, from: &ProgramMove, speed_fraction: f64) {
        let a = &from.target.wobj_from_tcp;
        let b = &to.target.wobj_from_tcp;
        let distance = (b.translation.vector - a.translation.vector).norm();
        let mut duration = distance / APPROACH_SPEED_MM_S;
        if let (Some(p), Some(q)) = (from.joints, to.joints) {
            for axis in 0..6 {
                let limit = self.robot.limits[axis].max_speed * speed_fraction;
                duration = duration.max((q.0[axis] - p.0[axis]).abs() / limit);
            }
        }
        let duration = duration.max(1e-3);
        to.tcp_speed = distance / duration;
        to.orientation_speed = a.rotation.angle_to(&b.rotation) / duration;
        to.duration_s = duration;
    }
}

/// Checks home joints (the maker's convention, radians) against the robot's ranges.
///
/// # Errors
/// Names the first axis outside its range, with the range, in degrees.
pub fn check_home(robot: &Robot, home: &Joints) -> Result<(), String> {
    for (axis, (angle, limit)) in home.0.iter().zip(&robot.limits).enumerate() {
        if !(angle.is_finite() && limit.contains(*angle)) {
            return Err(format!(
                "axis {} at {}° is outside the {}'s range {:.0}..{:.0}°",
                axis + 1,
                number(angle.to_degrees(), 3),
                robot.name,
                limit.min.to_degrees(),
                limit.max.to_degrees()
            ));
        }
    }
    Ok(())
}

/// Builds a program from a checked path, dropping the targets that the simplified path
/// passes within tolerance: one stroke over every frame ([`build_stroke_program`]).
#[must_use]
pub fn build_program(
    name: &str,
    cell: &Cell,
    report: &CheckReport,
    tolerance: &SimplifyConfig,
) -> Program {
    let whole = std::iter::once(0..report.frames.len()).collect::<Vec<_>>();
    build_stroke_program(name, cell, report, tolerance, &whole)
}

/// Builds a program from the checked strokes of a take (`strokes`: ranges of the report's
/// frames, in order, as [`crate::robot::check::check_strokes`] lays them out), each simplified
/// on its own (its first and last frames kept), each move timed from the previous one of its
/// stroke; the first move of each stroke has no speed (a joint move reaches it).
#[must_use]
pub fn build_stroke_program(
    name: &str,
    cell: &Cell,
    report: &CheckReport,
    tolerance: &SimplifyConfig,
    strokes: &[std::ops::Range<usize>],
) -> Program {
    let mut moves: Vec<ProgramMove> = Vec::with_capacity(report.frames.len());
    for (stroke, range) in strokes.iter().enumerate() {
        let frames = &report.frames[range.clone()];
        let targets: Vec<TcpTarget> = frames.iter().map(|f| f.target).collect();
        let mut previous: Option<TcpTarget> = None;
        for k in simplify(&targets, tolerance) {
            let frame = &frames[k];
            let (tcp_speed, orientation_speed, duration_s) = match previous {
                None => (0.0, 0.0, 0.0),
                Some(previous) => {
                    let a = &previous.wobj_from_tcp;
                    let b = &frame.target.wobj_from_tcp;
                    let dt = frame.target.time_s - previous.time_s;
                    let distance = (b.translation.vector - a.translation.vector).norm();
                    let angle = a.rotation.angle_to(&b.rotation);
                    (distance / dt, angle / dt, dt)
                }
            };
            previous = Some(frame.target);
            moves.push(ProgramMove {
                kind: MoveKind::Paint,
                target: frame.target,
                joints: frame.joints,
                configuration: frame.configuration,
                tcp_speed,
                orientation_speed,
                duration_s,
                stroke,
            });
        }
    }
    Program {
        name: identifier(name),
        robot: report.robot.clone(),
        cell: *cell,
        load: None,
        tolerance: *tolerance,
        moves,
        timing: report.timing,
        home: None,
        gaps: Vec::new(),
        tool_axis: None,
    }
}

/// Longest identifier every dialect accepts (RAPID: 32 characters; KRL: 24).
const MAX_IDENTIFIER: usize = 24;

/// A name made into an identifier all three dialects accept: ASCII letters, digits and
/// underscores, starting with a letter, at most 24 characters.
#[must_use]
pub fn identifier(name: &str) -> String {
    let mut out: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !out.starts_with(|c: char| c.is_ascii_alphabetic()) {
        out.insert_str(0, "tc_");
    }
    out.truncate(MAX_IDENTIFIER);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifiers_are_valid_in_every_dialect() {
        assert_eq!(identifier("stroke-1.mod"), "stroke_1_mod");
        assert_eq!(identifier("1st"), "tc_1st");
        assert_eq!(identifier(""), "tc_");
        assert_eq!(identifier("é").len(), 4);
        assert!(identifier(&"x".repeat(50)).len() <= MAX_IDENTIFIER);
    }
}
