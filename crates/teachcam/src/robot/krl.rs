//! KUKA KRL: a `.src` file with the motion and a `.dat` file with the points.
//!
//! The `.src` sets `$TOOL` (the TCP in the FLANGE frame), `$BASE` (the work object in
//! `$ROBROOT`) and `$LOAD` (the tool's mass and centre of gravity in FLANGE), approaches the
//! first point of each stroke (after a comment naming it) with a `PTP` (KUKA's practice: only a PTP honours a point's Status and Turn,
//! which pin the arm's configuration to the branch the check chose), then follows the path
//! with `LIN` moves, `$VEL.CP` per move from the recorded timing and `C_DIS` blending within
//! the path tolerance.
//!
//! Conventions (KUKA System Software 8, "Operating and Programming Instructions for System
//! Integrators"): positions in millimetres; orientations as `A, B, C` in degrees, the Z-Y-X
//! Euler angles with `R = Rz(A) Ry(B) Rx(C)`; `E6POS = {X, Y, Z, A, B, C, S, T, E1..E6}` with
//! `S` and `T` from [`status_turn`]; `$VEL.CP` in m/s; `$APO.CDIS` in millimetres; `$LOAD.M`
//! in kilograms, `$LOAD.CM` a FRAME in FLANGE. The `DEF` name must be the file's name: KSS
//! refuses to load a module whose main routine is named otherwise ([`krl_name_problem`]).

use std::fmt::Write as _;

use crate::geometry::Pose;
use crate::robot::kinematics::status_turn;
use crate::robot::program::{Program, ProgramMove};
use crate::robot::rapid::number;

/// The two files of a KRL program.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KrlProgram {
    /// The `.src` text (motion).
    pub src: String,
    /// The `.dat` text (data).
    pub dat: String,
}

/// Highest Cartesian speed written, m/s (KUKA's `$VEL.CP` upper bound is 3 m/s).
const MAX_CP_SPEED_M_S: f64 = 3.0;
/// Lowest Cartesian speed written, m/s: `$VEL.CP` must be positive.
const MIN_CP_SPEED_M_S: f64 = 0.00001;
/// Axis speed of the approach `PTP`, percent of each axis's maximum: a careful approach from
/// wherever the robot stands.
const APPROACH_AXIS_SPEED_PERCENT: u32 = 20;

/// Longest KRL name: 24 characters (KSS, "Names").
pub const MAX_KRL_NAME: usize = 24;

/// KRL's reserved words (KSS 8 "Keywords"): a routine cannot be named after one.
const KRL_KEYWORDS: [&str; 64] = [
    "AND",
    "ANIN",
    "ANOUT",
    "B_AND",
    "B_EXOR",
    "B_NOT",
    "B_OR",
    "BOOL",
    "BRAKE",
    "CASE",
    "CAST_FROM",
    "CAST_TO",
    "CHAR",
    "CIRC",
    "CIRC_REL",
    "CONST",
    "CONTINUE",
    "DECL",
    "DEF",
    "DEFAULT",
    "DEFDAT",
    "DEFFCT",
    "DELAY",
    "DO",
    "ELSE",
    "END",
    "ENDDAT",
    "ENDFCT",
    "ENDFOR",
    "ENDIF",
    "ENDLOOP",
    "ENDSWITCH",
    "ENDWHILE",
    "ENUM",
    "EXIT",
    "EXOR",
    "EXT",
    "EXTFCT",
    "FALSE",
    "FOR",
    "GLOBAL",
    "GOTO",
    "HALT",
    "IF",
    "IMPORT",
    "INT",
    "INTERRUPT",
    "IS",
    "LIN",
    "LIN_REL",
    "LOOP",
    "NOT",
    "OR",
    "PTP",
    "PTP_REL",
    "PUBLIC",
    "REAL",
    "REPEAT",
    "RETURN",
    "SIGNAL",
    "STRUC",
    "SWITCH",
    "THEN",
    "TRUE",
];

/// Why KSS would refuse `name` as a program's `DEF` name, `None` when it accepts it: ASCII
/// letters, digits and underscores, starting with a letter, at most 24 characters, not a
/// keyword.
#[must_use]
pub fn krl_name_problem(name: &str) -> Option<String> {
    if name.is_empty() {
        return Some("a KRL program needs a name".into());
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_'))
    {
        return Some(format!(
            "'{name}' has '{c}': a KRL name holds only ASCII letters, digits and underscores"
        ));
    }
    if !name.starts_with(|c: char| c.is_ascii_alphabetic()) {
        return Some(format!(
            "'{name}' must start with a letter to be a KRL name"
        ));
    }
    if name.len() > MAX_KRL_NAME {
        return Some(format!(
            "'{name}' has {} characters: KRL names have at most {MAX_KRL_NAME}",
            name.len()
        ));
    }
    let upper = name.to_ascii_uppercase();
    if KRL_KEYWORDS.contains(&upper.as_str()) {
        return Some(format!("'{name}' is a KRL keyword"));
    }
    None
}

/// The KRL files of a program (its name checked by the caller with [`krl_name_problem`]).
#[must_use]
pub fn krl_program(program: &Program) -> KrlProgram {
    let name = &program.name;
    let mut dat = String::new();
    let _ = writeln!(dat, "&ACCESS RVP\n&REL 1\nDEFDAT {name}");
    let _ = writeln!(
        dat,
        "  DECL FRAME TOOL_TEACHCAM={}",
        frame_literal(&program.cell.flange_from_tcp)
    );
    let _ = writeln!(
        dat,
        "  DECL FRAME BASE_TEACHCAM={}",
        frame_literal(&program.cell.base_from_wobj)
    );
    for (i, m) in program.moves.iter().enumerate() {
        let _ = writeln!(
            dat,
            "  DECL E6POS XP{}={}",
            i + 1,
            e6pos_literal(program, m)
        );
    }
    let _ = writeln!(dat, "ENDDAT");

    let (load, how) = program.tool_load();
    let mut src = String::new();
    let _ = writeln!(src, "&ACCESS RVP\n&REL 1\nDEF {name}( )");
    let _ = writeln!(
        src,
        "  ; Written by teachcam for the {}: {} moves, path tolerance {:.3} mm.",
        program.robot.name,
        program.moves.len(),
        program.tolerance.position_tolerance
    );
    let _ = writeln!(src, "  ; Tool load {how}.");
    let _ = writeln!(src, "  ; {}.", program.timing.describe(&program.robot.name));
    if let Some(line) = &program.tool_axis {
        let _ = writeln!(src, "  ; {line}.");
    }
    let _ = writeln!(src, "  BAS(#INITMOV,0)");
    let _ = writeln!(src, "  $TOOL=TOOL_TEACHCAM\n  $BASE=BASE_TEACHCAM");
    let cog = load.cog_in_flange;
    let _ = writeln!(
        src,
        "  $LOAD.M={}\n  $LOAD.CM={{X {},Y {},Z {},A 0,B 0,C 0}}\n  $LOAD.J={{X 0,Y 0,Z 0}}",
        number(load.mass_kg.max(0.0), 3),
        number(cog.x, 3),
        number(cog.y, 3),
        number(cog.z, 3)
    );
    let _ = writeln!(src, "  $ORI_TYPE=#VAR");
    let _ = writeln!(
        src,
        "  $APO.CDIS={}",
        number(program.tolerance.position_tolerance, 3)
    );
    let home = home_move(program);
    if !program.moves.is_empty() || home.is_some() {
        let _ = writeln!(src, "  BAS(#VEL_PTP,{APPROACH_AXIS_SPEED_PERCENT})");
    }
    if let Some(home) = &home {
        let _ = writeln!(src, "{home}");
    }
    for (i, m) in program.moves.iter().enumerate() {
        let speed = (m.tcp_speed / 1000.0).clamp(MIN_CP_SPEED_M_S, MAX_CP_SPEED_M_S);
        let blend = if program.stops_at(i) { "" } else { " C_DIS" };
        if let Some(gap) = program.gap_crossed_by(i) {
            let _ = writeln!(src, "  ; Gap bridged by the next move: {gap}.");
        }
        if let Some(stroke) = program.stroke_comment(i) {
            // Each stroke's approach (the first move, or from the previous stroke's retract)
            // is a PTP.
            let _ = writeln!(src, "  ; {stroke}.\n  PTP XP{}", i + 1);
            continue;
        }
        let _ = writeln!(
            src,
            "  $VEL.CP={}\n  LIN XP{}{blend}",
            number(speed, 6),
            i + 1
        );
    }
    if let Some(home) = &home {
        let _ = writeln!(src, "{home}");
    }
    let _ = writeln!(src, "END");
    KrlProgram { src, dat }
}

/// `X x,Y y,Z z,A a,B b,C c` with A, B, C the Z-Y-X Euler angles in degrees.
/// The joint move to `--home`, an axis-specific PTP (`PTP {A1 …,A6 …}`, degrees), `None`
/// without a home.
fn home_move(program: &Program) -> Option<String> {
    let home = program.home?;
    let axes: Vec<String> = home
        .0
        .iter()
        .enumerate()
        .map(|(i, a)| format!("A{} {}", i + 1, number(a.to_degrees(), 4)))
        .collect();
    Some(format!("  PTP {{{}}}", axes.join(",")))
}

fn frame_fields(pose: &Pose) -> String {
    let t = pose.translation.vector;
    let (c, b, a) = pose.rotation.euler_angles();
    format!(
        "X {},Y {},Z {},A {},B {},C {}",
        number(t.x, 3),
        number(t.y, 3),
        number(t.z, 3),
        number(a.to_degrees(), 5),
        number(b.to_degrees(), 5),
        number(c.to_degrees(), 5)
    )
}

fn frame_literal(pose: &Pose) -> String {
    format!("{{{}}}", frame_fields(pose))
}

/// An E6POS: the pose, Status and Turn of the joints the check chose (none for a target
/// without joints, in a forced export), no external axes.
fn e6pos_literal(program: &Program, m: &ProgramMove) -> String {
    let pose = frame_fields(&m.target.wobj_from_tcp);
    let status = match (m.joints, m.configuration) {
        (Some(joints), Some(configuration)) => {
            let st = status_turn(&program.robot, &joints, &configuration);
            format!(",S {},T {}", st.status, st.turn)
        }
        _ => String::new(),
    };
    format!("{{{pose}{status},E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}}")
}
