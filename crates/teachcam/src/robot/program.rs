//! A robot program independent of the dialect: the checked targets, simplified, each reached
//! by a linear move whose speeds reproduce the recorded timing.
//!
//! Model: between kept targets `a` and `b` recorded `Δt = t_b − t_a` apart, the move's TCP
//! speed is `|p_b − p_a| / Δt` and its orientation speed `angle(q_a, q_b) / Δt`; a controller
//! that honours both takes `Δt` for the move (RAPID `speeddata` `v_tcp`, `v_ori`; KRL
//! `$VEL.CP`; URScript `movel(..., v=...)`).

use crate::geometry::Vec3;
use crate::robot::check::CheckReport;
use crate::robot::kinematics::{ArmConfiguration, Joints, Robot};
use crate::robot::simplify::{SimplifyConfig, simplify};
use crate::robot::{Cell, TcpTarget};

/// One linear move of a program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProgramMove {
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

/// A program: a name, the robot, the cell and the moves, the first one the approach.
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
}

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

/// Builds a program from a checked path, dropping the targets that the simplified path
/// passes within tolerance.
#[must_use]
pub fn build_program(
    name: &str,
    cell: &Cell,
    report: &CheckReport,
    tolerance: &SimplifyConfig,
) -> Program {
    let targets: Vec<TcpTarget> = report.frames.iter().map(|f| f.target).collect();
    let kept = simplify(&targets, tolerance);
    let mut moves: Vec<ProgramMove> = Vec::with_capacity(kept.len());
    for &k in &kept {
        let frame = &report.frames[k];
        let (tcp_speed, orientation_speed, duration_s) = match moves.last() {
            None => (0.0, 0.0, 0.0),
            Some(previous) => {
                let a = &previous.target.wobj_from_tcp;
                let b = &frame.target.wobj_from_tcp;
                let dt = frame.target.time_s - previous.target.time_s;
                let distance = (b.translation.vector - a.translation.vector).norm();
                let angle = a.rotation.angle_to(&b.rotation);
                (distance / dt, angle / dt, dt)
            }
        };
        moves.push(ProgramMove {
            target: frame.target,
            joints: frame.joints,
            configuration: frame.configuration,
            tcp_speed,
            orientation_speed,
            duration_s,
        });
    }
    Program {
        name: identifier(name),
        robot: report.robot.clone(),
        cell: *cell,
        load: None,
        tolerance: *tolerance,
        moves,
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
