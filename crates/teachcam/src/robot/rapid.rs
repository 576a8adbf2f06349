//! ABB RAPID: one MODULE with the tool (`tooldata`), the work object (`wobjdata`), one
//! `robtarget` per move with its `confdata`, one `speeddata` per move from the recorded timing,
//! and `MoveL` instructions in routines of bounded length called in order from `main`.
//!
//! Syntax from ABB's "Technical reference manual – RAPID Instructions, Functions and Data
//! types": `tooldata = [robhold, tframe, tload]` (the load from `--tool-mass` and `--tool-cog`, else
//! [`crate::robot::program::ToolLoad::assumed`], said in the module's comment), `loaddata = [mass, cog, aom, ix, iy, iz]`,
//! `wobjdata = [robhold, ufprog, ufmec, uframe, oframe]`,
//! `robtarget = [trans, rot (q1..q4 = qw, qx, qy, qz), robconf [cf1, cf4, cf6, cfx], extax]`,
//! `speeddata = [v_tcp mm/s, v_ori °/s, v_leax mm/s, v_reax °/s]`; the module's own `zonedata`
//! `zTeachcam` from the path tolerance, and `fine` where the brush touches down, lifts off and
//! at the end. The first target of each stroke (its approach pose) is reached with a `MoveJ`
//! at the predefined `v100` (100 mm/s), after a comment naming the stroke: a careful approach
//! from wherever the robot stands, or from the previous stroke's retract. `ConfJ \On`, `ConfL \On`
//! (each `robconf` the quadrants the checked joints take; a move whose axis 1, 4 or 6 turns
//! more than a quadrant is a `MoveJ`) and `SingArea` (`\Wrist` only where axis 5 comes near
//! zero) are set explicitly.

use std::fmt::Write as _;

use crate::geometry::{Pose, Quat};
use crate::robot::kinematics::{Joints, confdata};
use crate::robot::program::{Program, ProgramMove};

/// Options of [`rapid_module`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RapidConfig {
    /// Most `MoveL`s in one routine. Default 500: long paths are split into routines
    /// `path_1`, `path_2`, … called in order, which keeps each one quick to open on the
    /// FlexPendant and under the controller's routine size limits.
    pub max_moves_per_routine: usize,
}

impl Default for RapidConfig {
    fn default() -> Self {
        Self {
            max_moves_per_routine: 500,
        }
    }
}

/// Lowest tool mass written, kilograms: RAPID refuses a `tload` with a zero mass.
const MIN_TOOL_MASS_KG: f64 = 0.001;

/// Extra-axis values of a robot without external axes.
const NO_EXTERNAL_AXES: &str = "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]";

/// Lowest speeds written, mm/s and °/s: RAPID refuses zero speeds. A move slower than both
/// (the brush dwelling) gets its recorded duration with `\T` instead.
const MIN_TCP_SPEED: f64 = 0.01;
const MIN_ORIENTATION_SPEED_DEG_S: f64 = 0.01;

/// The RAPID module text of a program.
#[must_use]
pub fn rapid_module(program: &Program, config: &RapidConfig) -> String {
    let mut out = String::with_capacity(256 * (program.moves.len() + 8));
    let name = &program.name;
    let tool = "tTeachcam";
    let wobj = "wTeachcam";
    let _ = writeln!(out, "MODULE {name}");
    let _ = writeln!(
        out,
        "  ! Written by teachcam: {} moves, path tolerance {:.3} mm / {:.3} deg.",
        program.moves.len(),
        program.tolerance.position_tolerance,
        program.tolerance.orientation_tolerance.to_degrees()
    );
    let _ = writeln!(out, "  ! {}.", program.timing.describe(&program.robot.name));
    if let Some(line) = &program.tool_axis {
        let _ = writeln!(out, "  ! {line}.");
    }
    let tcp = &program.cell.flange_from_tcp;
    let (load, how) = program.tool_load();
    let cog = load.cog_in_flange;
    let _ = writeln!(
        out,
        "  ! Tool load {} kg at ({}, {}, {}) mm in tool0, {how}.",
        number(load.mass_kg, 3),
        number(cog.x, 1),
        number(cog.y, 1),
        number(cog.z, 1)
    );
    let _ = writeln!(
        out,
        "  PERS tooldata {tool} := [TRUE,{},[{},[{},{},{}],[1,0,0,0],0,0,0]];",
        pose_literal(tcp),
        number(load.mass_kg.max(MIN_TOOL_MASS_KG), 3),
        number(cog.x, 3),
        number(cog.y, 3),
        number(cog.z, 3)
    );
    let _ = writeln!(
        out,
        "  PERS wobjdata {wobj} := [FALSE,TRUE,\"\",{},[[0,0,0],[1,0,0,0]]];",
        pose_literal(&program.cell.base_from_wobj)
    );
    for (i, m) in program.moves.iter().enumerate() {
        let _ = writeln!(
            out,
            "  CONST robtarget {} := {};",
            target_name(i),
            robtarget_literal(m)
        );
    }
    if let Some(home) = &program.home {
        let _ = writeln!(
            out,
            "  CONST jointtarget {HOME} := [[{}],{NO_EXTERNAL_AXES}];",
            degrees_list(home)
        );
    }
    for (i, m) in program.moves.iter().enumerate().skip(1) {
        let _ = writeln!(
            out,
            "  CONST speeddata {} := [{},{},5000,1000];",
            speed_name(i),
            number(m.tcp_speed.max(MIN_TCP_SPEED), 3),
            number(
                m.orientation_speed
                    .to_degrees()
                    .max(MIN_ORIENTATION_SPEED_DEG_S),
                3
            )
        );
    }
    let zone = zone_data(program);
    if let Some((_, literal)) = &zone {
        let _ = writeln!(out, "  CONST zonedata {ZONE} := {literal};");
    }
    let zone = zone.map_or("fine", |(name, _)| name);
    let joint_moves = joint_moves(program);
    let per_routine = config.max_moves_per_routine.max(1);
    let routines: Vec<std::ops::Range<usize>> = (1..program.moves.len())
        .step_by(per_routine)
        .map(|start| start..(start + per_routine).min(program.moves.len()))
        .collect();
    let _ = writeln!(out, "\n  PROC main()");
    let (singularity, why) = sing_area(program);
    let _ = writeln!(
        out,
        "    ! Configuration monitored: every robconf is the quadrant the checked joints take there; {why}."
    );
    let _ = writeln!(
        out,
        "    ConfJ \\On;\n    ConfL \\On;\n    SingArea {singularity};"
    );
    let home = |out: &mut String| {
        if program.home.is_some() {
            let _ = writeln!(
                out,
                "    MoveAbsJ {HOME}, v100, fine, {tool}\\WObj:={wobj};"
            );
        }
    };
    home(&mut out);
    if !program.moves.is_empty() {
        if let Some(stroke) = program.stroke_comment(0) {
            let _ = writeln!(out, "    ! {stroke}.");
        }
        let _ = writeln!(
            out,
            "    MoveJ {}, v100, fine, {tool}\\WObj:={wobj};",
            target_name(0)
        );
    }
    for r in 0..routines.len() {
        let _ = writeln!(out, "    path_{};", r + 1);
    }
    home(&mut out);
    let _ = writeln!(out, "  ENDPROC");
    for (r, range) in routines.iter().enumerate() {
        let _ = writeln!(out, "\n  PROC path_{}()", r + 1);
        for i in range.clone() {
            let zone = if program.stops_at(i) { "fine" } else { zone };
            let m = &program.moves[i];
            // A move slower than the lowest speeds written (a dwell) keeps its recorded
            // duration through the instruction's time argument `\T`.
            let slow = m.tcp_speed < MIN_TCP_SPEED
                && m.orientation_speed.to_degrees() < MIN_ORIENTATION_SPEED_DEG_S;
            let time = if slow {
                format!("\\T:={}", number(m.duration_s, 4))
            } else {
                String::new()
            };
            if let Some(gap) = program.gap_crossed_by(i) {
                let _ = writeln!(out, "    ! Gap bridged by the next move: {gap}.");
            }
            if let Some(stroke) = program.stroke_comment(i) {
                // A stroke after the first: a joint move from the previous stroke's retract
                // to this one's approach.
                let _ = writeln!(out, "    ! {stroke}.");
                let _ = writeln!(
                    out,
                    "    MoveJ {}, v100, fine, {tool}\\WObj:={wobj};",
                    target_name(i)
                );
                continue;
            }
            let instruction = if let Some(axis) = joint_moves[i] {
                let _ = writeln!(
                    out,
                    "    ! Axis {axis} turns more than a quadrant from {}: a joint move reaches {}'s robconf (ConfL would stop).",
                    target_name(i - 1),
                    target_name(i)
                );
                "MoveJ"
            } else {
                "MoveL"
            };
            let _ = writeln!(
                out,
                "    {instruction} {}, {}{time}, {zone}, {tool}\\WObj:={wobj};",
                target_name(i),
                speed_name(i)
            );
        }
        let _ = writeln!(out, "  ENDPROC");
    }
    let _ = writeln!(out, "ENDMODULE");
    out
}

/// Name of the home `jointtarget` (`--home`), reached with `MoveAbsJ` first and last.
const HOME: &str = "jHome";

/// Six joint angles in degrees, 4 decimals, comma-separated (a `jointtarget`'s `robax`).
fn degrees_list(joints: &Joints) -> String {
    joints
        .0
        .iter()
        .map(|a| number(a.to_degrees(), 4))
        .collect::<Vec<_>>()
        .join(",")
}

/// RAPID's reserved words (ABB, "Technical reference manual – RAPID overview", "Reserved
/// words") and the names the module itself declares or calls: a module named after one does
/// not load or shadows what it needs. RAPID is not case sensitive.
const RAPID_RESERVED: [&str; 78] = [
    // Reserved words.
    "ALIAS",
    "AND",
    "BACKWARD",
    "CASE",
    "CONNECT",
    "CONST",
    "DEFAULT",
    "DIV",
    "DO",
    "ELSE",
    "ELSEIF",
    "ENDFOR",
    "ENDFUNC",
    "ENDIF",
    "ENDMODULE",
    "ENDPROC",
    "ENDRECORD",
    "ENDTEST",
    "ENDTRAP",
    "ENDWHILE",
    "ERROR",
    "EXIT",
    "FALSE",
    "FOR",
    "FROM",
    "FUNC",
    "GOTO",
    "IF",
    "INOUT",
    "LOCAL",
    "MOD",
    "MODULE",
    "NOSTEPIN",
    "NOT",
    "NOVIEW",
    "OR",
    "PERS",
    "PROC",
    "RAISE",
    "READONLY",
    "RECORD",
    "RETRY",
    "RETURN",
    "STEP",
    "SYSMODULE",
    "TEST",
    "THEN",
    "TO",
    "TRAP",
    "TRUE",
    "TRYNEXT",
    "UNDO",
    "VAR",
    "VIEWONLY",
    "WHILE",
    "WITH",
    "XOR",
    // Data types, instructions and predefined data the module uses.
    "BOOL",
    "CONFDATA",
    "CONFJ",
    "CONFL",
    "LOADDATA",
    "MAIN",
    "MOVEJ",
    "MOVEL",
    "NUM",
    "ORIENT",
    "POS",
    "POSE",
    "ROBTARGET",
    "SINGAREA",
    "SPEEDDATA",
    "STRING",
    "TOOLDATA",
    "WOBJDATA",
    "ZONEDATA",
    "FINE",
    "V100",
];

/// Why RAPID would refuse `name` as the module's name, `None` when it accepts it: a reserved
/// word, a name the module declares (`tTeachcam`, `wTeachcam`, `p0001`, `v0001`, `path_1`,
/// `zTeachcam`) or a predefined one it uses. `name` is already an identifier
/// ([`crate::robot::program::identifier`]).
#[must_use]
pub fn rapid_name_problem(name: &str) -> Option<String> {
    let upper = name.to_ascii_uppercase();
    let declared = ["TTEACHCAM", "WTEACHCAM", "ZTEACHCAM", "JHOME"].contains(&upper.as_str())
        || upper.starts_with("PATH_")
        || ((upper.starts_with('P') || upper.starts_with('V'))
            && upper.len() > 1
            && upper[1..].chars().all(|c| c.is_ascii_digit()));
    if RAPID_RESERVED.contains(&upper.as_str()) {
        Some(format!(
            "'{name}' is a RAPID reserved word or a name the module uses"
        ))
    } else if declared {
        Some(format!("'{name}' is a name the module declares"))
    } else {
        None
    }
}

/// Name of the i-th target: `p0001`, `p0002`, …
#[must_use]
pub fn target_name(index: usize) -> String {
    format!("p{:04}", index + 1)
}

fn speed_name(index: usize) -> String {
    format!("v{:04}", index + 1)
}

/// Name of the module's own zone.
const ZONE: &str = "zTeachcam";

/// Smallest zone radius written, mm: below it every blended move becomes `fine`.
const MIN_ZONE_MM: f64 = 0.01;

/// The module's zone, `zonedata = [finep, pzone_tcp, pzone_ori, pzone_eax, zone_ori,
/// zone_leax, zone_reax]`: the TCP zone the path tolerance (the blended corner then stays
/// within half of it from the kept target), the orientation zone the
/// orientation tolerance; `None` (every move `fine`) for a tolerance under 0.01 mm.
fn zone_data(program: &Program) -> Option<(&'static str, String)> {
    let radius = program.tolerance.position_tolerance;
    let degrees = program.tolerance.orientation_tolerance.to_degrees();
    (radius >= MIN_ZONE_MM).then(|| {
        let r = number(radius, 3);
        let o = number(degrees, 3);
        (ZONE, format!("[FALSE,{r},{r},{r},{o},{r},{o}]"))
    })
}

/// `SingArea` from the joint path: `\Wrist` when a target has axis 5 within 5° of zero (the
/// controller may then tilt the tool slightly to pass the wrist singularity rather than
/// stop), `\Off` otherwise; with the reason for the module's comment.
fn sing_area(program: &Program) -> (&'static str, String) {
    let threshold = crate::robot::check::CheckConfig::default().wrist_singularity;
    let near = program
        .moves
        .iter()
        .filter_map(|m| m.joints)
        .map(|j| j.0[4].abs())
        .fold(f64::INFINITY, f64::min);
    if near < threshold {
        (
            "\\Wrist",
            format!(
                "SingArea \\Wrist: axis 5 comes within {:.1} deg of the wrist singularity",
                near.to_degrees()
            ),
        )
    } else {
        (
            "\\Off",
            "SingArea \\Off: axis 5 stays clear of the wrist singularity".to_string(),
        )
    }
}

/// For each move, the axis (1, 4 or 6) whose quadrant changes by more than one from the
/// previous target, `None` for the moves a `MoveL` with `ConfL \On` runs (the robot takes the
/// closest configuration along a linear move; a jump of two quadrants would stop it): such a
/// move is written as a `MoveJ`, which reaches the programmed robconf.
fn joint_moves(program: &Program) -> Vec<Option<usize>> {
    let conf = |m: &ProgramMove| match (m.joints, m.configuration) {
        (Some(j), Some(c)) => Some(confdata(&j, &c)),
        _ => None,
    };
    let mut out = vec![None; program.moves.len()];
    for (slot, pair) in out.iter_mut().skip(1).zip(program.moves.windows(2)) {
        if let (Some(a), Some(b)) = (conf(&pair[0]), conf(&pair[1])) {
            *slot = [(1, a.cf1, b.cf1), (4, a.cf4, b.cf4), (6, a.cf6, b.cf6)]
                .into_iter()
                .find(|(_, p, q)| (q - p).abs() > 1)
                .map(|(axis, _, _)| axis);
        }
    }
    out
}

/// `[[x,y,z],[q1,q2,q3,q4]]` of a pose, 0.001 mm and 1e-7 in the quaternion.
fn pose_literal(pose: &Pose) -> String {
    let t = pose.translation.vector;
    let q = Quat::from_rotation(&pose.rotation);
    format!(
        "[[{},{},{}],[{},{},{},{}]]",
        number(t.x, 3),
        number(t.y, 3),
        number(t.z, 3),
        number(q.w, 7),
        number(q.x, 7),
        number(q.y, 7),
        number(q.z, 7)
    )
}

fn robtarget_literal(m: &ProgramMove) -> String {
    let pose = pose_literal(&m.target.wobj_from_tcp);
    let pose = &pose[1..pose.len() - 1];
    let conf = match (m.joints, m.configuration) {
        (Some(joints), Some(configuration)) => {
            let c = confdata(&joints, &configuration);
            format!("[{},{},{},{}]", c.cf1, c.cf4, c.cf6, c.cfx)
        }
        _ => "[0,0,0,0]".to_string(),
    };
    format!("[{pose},{conf},{NO_EXTERNAL_AXES}]")
}

/// A number with `decimals` decimals, without a negative zero.
pub(crate) fn number(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    if text.starts_with('-') && text[1..].chars().all(|c| c == '0' || c == '.') {
        text[1..].to_string()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_no_negative_zero() {
        assert_eq!(number(-0.0001, 3), "0.000");
        assert_eq!(number(-1.5, 1), "-1.5");
    }
}
