//! KUKA KRL: a `.src` file with the motion (`LIN` to `E6POS` points, `$VEL.CP` per move from
//! the recorded timing, `C_DIS` blending within the path tolerance) and a `.dat` file with the
//! points, the tool (`$TOOL`) and the base (`$BASE`).
//!
//! Conventions (KUKA System Software, "Programming for system integrators"): positions in
//! millimetres; orientations as `A, B, C` in degrees, the Z-Y-X Euler angles with
//! `R = Rz(A) Ry(B) Rx(C)`; `$VEL.CP` in m/s; `$APO.CDIS` in millimetres. The points carry no
//! `S`/`T` (status and turn): they belong to a KUKA arm's own kinematics, and `LIN` ignores them.

use std::fmt::Write as _;

use crate::geometry::Pose;
use crate::robot::program::Program;
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

/// The KRL files of a program.
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
            frame_literal(&m.target.wobj_from_tcp)
        );
    }
    let _ = writeln!(dat, "ENDDAT");

    let mut src = String::new();
    let _ = writeln!(src, "&ACCESS RVP\n&REL 1\nDEF {name}( )");
    let _ = writeln!(
        src,
        "  ; Written by teachcam: {} moves, path tolerance {:.3} mm.",
        program.moves.len(),
        program.tolerance.position_tolerance
    );
    let _ = writeln!(src, "  BAS(#INITMOV,0)");
    let _ = writeln!(src, "  $TOOL=TOOL_TEACHCAM\n  $BASE=BASE_TEACHCAM");
    let _ = writeln!(src, "  $ORI_TYPE=#VAR");
    let _ = writeln!(
        src,
        "  $APO.CDIS={}",
        number(program.tolerance.position_tolerance, 3)
    );
    if !program.moves.is_empty() {
        let _ = writeln!(src, "  $VEL.CP=0.1\n  LIN XP1");
    }
    let last = program.moves.len().saturating_sub(1);
    for (i, m) in program.moves.iter().enumerate().skip(1) {
        let speed = (m.tcp_speed / 1000.0).clamp(MIN_CP_SPEED_M_S, MAX_CP_SPEED_M_S);
        let blend = if i == last { "" } else { " C_DIS" };
        let _ = writeln!(
            src,
            "  $VEL.CP={}\n  LIN XP{}{blend}",
            number(speed, 6),
            i + 1
        );
    }
    let _ = writeln!(src, "END");
    KrlProgram { src, dat }
}

/// `{X x,Y y,Z z,A a,B b,C c}` with A, B, C the Z-Y-X Euler angles in degrees.
fn frame_literal(pose: &Pose) -> String {
    let t = pose.translation.vector;
    let (c, b, a) = pose.rotation.euler_angles();
    format!(
        "{{X {},Y {},Z {},A {},B {},C {}}}",
        number(t.x, 3),
        number(t.y, 3),
        number(t.z, 3),
        number(a.to_degrees(), 5),
        number(b.to_degrees(), 5),
        number(c.to_degrees(), 5)
    )
}
