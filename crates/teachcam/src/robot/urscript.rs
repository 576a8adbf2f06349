//! Universal Robots URScript: one `def … end` function that sets the TCP (`set_tcp`) and the
//! payload (`set_payload`), holds the work object as a pose, moves to the first target's joint
//! solution of each stroke with `movej` after a comment naming the stroke (the arm starts in
//! the configuration the check chose) and then
//! linearly (`movel`) through every target at the recorded speeds, blending within the path
//! tolerance.
//!
//! Conventions (URScript manual, e-Series): poses `p[x, y, z, rx, ry, rz]` in metres with the
//! orientation as a rotation vector (axis times angle, radians); `movej(q, a, v)` with joint
//! angles in radians, `a` in rad/s², `v` in rad/s; `movel(pose, a, v, t, r)` with `v` in m/s,
//! `a` in m/s² and the blend radius `r` in metres; `set_payload(m, cog)` in kg and metres in
//! the tool flange frame; `pose_trans(wobj, target)` composes the work object with a target
//! given in it, like RAPID's `\WObj`. [`URSCRIPT_FUNCTIONS`] lists every function written.

use std::fmt::Write as _;

use crate::geometry::Pose;
use crate::robot::kinematics::Joints;
use crate::robot::program::Program;
use crate::robot::rapid::number;

/// Options of [`urscript_program`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UrScriptConfig {
    /// Tool acceleration of every `movel`, m/s². Default 1.2 m/s²: URScript's own default.
    pub acceleration_m_s2: f64,
}

impl Default for UrScriptConfig {
    fn default() -> Self {
        Self {
            acceleration_m_s2: 1.2,
        }
    }
}

/// Lowest speed written, m/s: `movel` needs a positive speed.
const MIN_SPEED_M_S: f64 = 0.00001;

/// Joint speed and acceleration of the approach `movej`, rad/s and rad/s²: a careful approach
/// from wherever the arm stands (URScript's defaults are 1.05 rad/s and 1.4 rad/s²).
const APPROACH_SPEED_RAD_S: f64 = 0.5;
const APPROACH_ACCELERATION_RAD_S2: f64 = 1.4;

/// Every URScript function the writer calls, with the fewest and most arguments the URScript
/// manual allows it: a test checks every generated call against this table, and the table
/// against the manual's signatures.
pub const URSCRIPT_FUNCTIONS: [(&str, usize, usize); 5] = [
    // movej(q, a=1.4, v=1.05, t=0, r=0)
    ("movej", 1, 5),
    // movel(pose, a=1.2, v=0.25, t=0, r=0)
    ("movel", 1, 5),
    // pose_trans(p_from, p_from_to)
    ("pose_trans", 2, 2),
    // set_payload(m, cog)
    ("set_payload", 1, 2),
    // set_tcp(pose)
    ("set_tcp", 1, 1),
];

/// URScript's reserved words (URScript manual, "Keywords"; the language follows Python's) and
/// the names the program itself uses: a program named after one does not compile or calls
/// the wrong thing. URScript is case sensitive.
const URSCRIPT_RESERVED: [&str; 37] = [
    "and", "as", "assert", "break", "class", "continue", "def", "del", "elif", "else", "end",
    "enum", "except", "exec", "False", "finally", "for", "from", "global", "halt", "if", "import",
    "in", "is", "kill", "lambda", "local", "not", "or", "pass", "raise", "return", "run", "thread",
    "True", "while", "wobj",
];

/// Why the controller would refuse `name` as the program's `def` name, `None` when it accepts
/// it: a keyword, `p` (a pose literal's prefix), `wobj` (the program's variable) or a function
/// the program calls ([`URSCRIPT_FUNCTIONS`]). `name` is already an identifier.
#[must_use]
pub fn urscript_name_problem(name: &str) -> Option<String> {
    if URSCRIPT_RESERVED.contains(&name) || name == "p" {
        Some(format!(
            "'{name}' is a URScript keyword or a name the program uses"
        ))
    } else if URSCRIPT_FUNCTIONS.iter().any(|(f, _, _)| *f == name) {
        Some(format!("'{name}' is a URScript function the program calls"))
    } else {
        None
    }
}

/// The URScript text of a program.
#[must_use]
pub fn urscript_program(program: &Program, config: &UrScriptConfig) -> String {
    let mut out = String::new();
    let name = &program.name;
    let _ = writeln!(out, "def {name}():");
    let _ = writeln!(
        out,
        "  # Written by teachcam for the {}: {} moves, path tolerance {:.3} mm.",
        program.robot.name,
        program.moves.len(),
        program.tolerance.position_tolerance
    );
    let (load, how) = program.tool_load();
    let _ = writeln!(out, "  # Payload {how}.");
    let _ = writeln!(out, "  # {}.", program.timing.describe(&program.robot.name));
    if let Some(line) = &program.tool_axis {
        let _ = writeln!(out, "  # {line}.");
    }
    let _ = writeln!(
        out,
        "  set_tcp({})",
        pose_literal(&program.cell.flange_from_tcp)
    );
    let cog = load.cog_in_flange / 1000.0;
    let _ = writeln!(
        out,
        "  set_payload({}, [{}, {}, {}])",
        number(load.mass_kg.max(0.0), 3),
        number(cog.x, 6),
        number(cog.y, 6),
        number(cog.z, 6)
    );
    let _ = writeln!(
        out,
        "  wobj = {}",
        pose_literal(&program.cell.base_from_wobj)
    );
    let a = number(config.acceleration_m_s2, 3);
    // Blend radius: the path tolerance, and never more than the segment allows (r = 0 at the end).
    let blend = number(program.tolerance.position_tolerance / 1000.0, 6);
    let home = program.home.map(|joints| joint_move(&joints));
    if let Some(home) = &home {
        let _ = writeln!(out, "{home}");
    }
    for (i, m) in program.moves.iter().enumerate() {
        let pose = pose_literal(&m.target.wobj_from_tcp);
        if let Some(stroke) = program.stroke_comment(i) {
            // Each stroke's approach (the first move, or from the previous stroke's retract)
            // is a joint move.
            let _ = writeln!(out, "  # {stroke}.");
            match m.joints {
                Some(joints) => {
                    let _ = writeln!(out, "{}", joint_move(&joints));
                }
                // A forced export of an unreachable first target: no joints to go to.
                None => {
                    let _ = writeln!(out, "  movel(pose_trans(wobj, {pose}), a={a}, v=0.1)");
                }
            }
            continue;
        }
        let v = number((m.tcp_speed / 1000.0).max(MIN_SPEED_M_S), 6);
        let r = if program.stops_at(i) {
            "0".to_string()
        } else {
            blend.clone()
        };
        if let Some(gap) = program.gap_crossed_by(i) {
            let _ = writeln!(out, "  # Gap bridged by the next move: {gap}.");
        }
        let _ = writeln!(
            out,
            "  movel(pose_trans(wobj, {pose}), a={a}, v={v}, r={r})"
        );
    }
    if let Some(home) = &home {
        let _ = writeln!(out, "{home}");
    }
    let _ = writeln!(out, "end\n{name}()");
    out
}

/// A careful `movej` to `joints` (radians), at [`APPROACH_SPEED_RAD_S`].
fn joint_move(joints: &Joints) -> String {
    let q: Vec<String> = joints.0.iter().map(|v| number(*v, 6)).collect();
    format!(
        "  movej([{}], a={}, v={})",
        q.join(", "),
        number(APPROACH_ACCELERATION_RAD_S2, 3),
        number(APPROACH_SPEED_RAD_S, 3)
    )
}

/// `p[x, y, z, rx, ry, rz]`: metres (micrometre resolution) and a rotation vector (radians).
fn pose_literal(pose: &Pose) -> String {
    let t = pose.translation.vector / 1000.0;
    let r = pose.rotation.scaled_axis();
    format!(
        "p[{}, {}, {}, {}, {}, {}]",
        number(t.x, 7),
        number(t.y, 7),
        number(t.z, 7),
        number(r.x, 7),
        number(r.y, 7),
        number(r.z, 7)
    )
}
