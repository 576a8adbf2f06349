//! Universal Robots URScript: one `def … end` function that sets the TCP, holds the work
//! object as a pose and moves linearly (`movel`) through every target at the recorded speeds,
//! blending within the path tolerance.
//!
//! Conventions (URScript manual): poses `p[x, y, z, rx, ry, rz]` in metres with the orientation
//! as a rotation vector (axis times angle, radians); `movel(pose, a, v, t, r)` with `v` in m/s,
//! `a` in m/s² and the blend radius `r` in metres; `pose_trans(wobj, target)` composes the work
//! object with a target given in it, like RAPID's `\WObj`.

use std::fmt::Write as _;

use crate::geometry::Pose;
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

/// The URScript text of a program.
#[must_use]
pub fn urscript_program(program: &Program, config: &UrScriptConfig) -> String {
    let mut out = String::new();
    let name = &program.name;
    let _ = writeln!(out, "def {name}():");
    let _ = writeln!(
        out,
        "  # Written by teachcam: {} moves, path tolerance {:.3} mm.",
        program.moves.len(),
        program.tolerance.position_tolerance
    );
    let _ = writeln!(
        out,
        "  set_tcp({})",
        pose_literal(&program.cell.flange_from_tcp)
    );
    let _ = writeln!(
        out,
        "  wobj = {}",
        pose_literal(&program.cell.base_from_wobj)
    );
    let a = number(config.acceleration_m_s2, 3);
    // Blend radius: the path tolerance, and never more than the segment allows (r = 0 at the end).
    let blend = number(program.tolerance.position_tolerance / 1000.0, 6);
    let last = program.moves.len().saturating_sub(1);
    for (i, m) in program.moves.iter().enumerate() {
        let pose = pose_literal(&m.target.wobj_from_tcp);
        if i == 0 {
            let _ = writeln!(out, "  movel(pose_trans(wobj, {pose}), a={a}, v=0.1)");
            continue;
        }
        let v = number((m.tcp_speed / 1000.0).max(MIN_SPEED_M_S), 6);
        let r = if i == last {
            "0".to_string()
        } else {
            blend.clone()
        };
        let _ = writeln!(
            out,
            "  movel(pose_trans(wobj, {pose}), a={a}, v={v}, r={r})"
        );
    }
    let _ = writeln!(out, "end\n{name}()");
    out
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
