//! A robot program independent of the dialect: the checked targets, simplified, each reached
//! by a linear move whose speeds reproduce the recorded timing.
//!
//! Model: between kept targets `a` and `b` recorded `Δt = t_b − t_a` apart, the move's TCP
//! speed is `|p_b − p_a| / Δt` and its orientation speed `angle(q_a, q_b) / Δt`; a controller
//! that honours both takes `Δt` for the move (RAPID `speeddata` `v_tcp`, `v_ori`; KRL
//! `$VEL.CP`; URScript `movel(..., v=...)`).

use crate::robot::check::CheckReport;
use crate::robot::kinematics::{ConfData, Joints};
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
    /// ABB configuration data of those joints.
    pub confdata: Option<ConfData>,
    /// TCP speed from the previous target, mm/s (zero for the first target).
    pub tcp_speed: f64,
    /// Orientation speed from the previous target, rad/s.
    pub orientation_speed: f64,
    /// Recorded time from the previous target, seconds.
    pub duration_s: f64,
}

/// A program: a name, the cell and the moves, the first one the approach.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// Identifier of the program (a valid RAPID/KRL/URScript name).
    pub name: String,
    /// The work object and the TCP on the flange.
    pub cell: Cell,
    /// The path tolerance the targets were simplified with (zones are chosen from it).
    pub tolerance: SimplifyConfig,
    /// The moves in order.
    pub moves: Vec<ProgramMove>,
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
            confdata: frame.confdata,
            tcp_speed,
            orientation_speed,
            duration_s,
        });
    }
    Program {
        name: identifier(name),
        cell: *cell,
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
