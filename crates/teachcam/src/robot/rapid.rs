//! ABB RAPID: one MODULE with the tool (`tooldata`), the work object (`wobjdata`), one
//! `robtarget` per move with its `confdata`, one `speeddata` per move from the recorded timing,
//! and `MoveL` instructions in routines of bounded length called in order from `main`.
//!
//! Syntax from ABB's "Technical reference manual – RAPID Instructions, Functions and Data
//! types": `tooldata = [robhold, tframe, tload]` (the load from `--tool-mass` and `--tool-cog`, else
//! [`crate::robot::program::ToolLoad::assumed`], said in the module's comment), `loaddata = [mass, cog, aom, ix, iy, iz]`,
//! `wobjdata = [robhold, ufprog, ufmec, uframe, oframe]`,
//! `robtarget = [trans, rot (q1..q4 = qw, qx, qy, qz), robconf [cf1, cf4, cf6, cfx], extax]`,
//! `speeddata = [v_tcp mm/s, v_ori °/s, v_leax mm/s, v_reax °/s]`; predefined `zonedata` `z0`
//! (0.3 mm), `z1` (1 mm), `z5`, `z10` and `fine`. The first target is approached with a
//! `MoveJ` at the predefined `v100` (100 mm/s): a careful approach from wherever the robot stands.

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
    let zone = zone_name(program.tolerance.position_tolerance);
    let per_routine = config.max_moves_per_routine.max(1);
    let routines: Vec<std::ops::Range<usize>> = (1..program.moves.len())
        .step_by(per_routine)
        .map(|start| start..(start + per_routine).min(program.moves.len()))
        .collect();
    let _ = writeln!(out, "\n  PROC main()");
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
            let _ = writeln!(
                out,
                "    MoveL {}, {}{time}, {zone}, {tool}\\WObj:={wobj};",
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

/// Name of the i-th target: `p0001`, `p0002`, …
#[must_use]
pub fn target_name(index: usize) -> String {
    format!("p{:04}", index + 1)
}

fn speed_name(index: usize) -> String {
    format!("v{:04}", index + 1)
}

/// The largest predefined zone whose TCP radius is within the path tolerance, else `fine`.
fn zone_name(tolerance: f64) -> &'static str {
    [("z10", 10.0), ("z5", 5.0), ("z1", 1.0), ("z0", 0.3)]
        .into_iter()
        .find(|(_, radius)| *radius <= tolerance)
        .map_or("fine", |(name, _)| name)
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
    fn zones_fit_in_the_tolerance() {
        assert_eq!(zone_name(0.1), "fine");
        assert_eq!(zone_name(0.5), "z0");
        assert_eq!(zone_name(1.0), "z1");
        assert_eq!(zone_name(7.0), "z5");
    }

    #[test]
    fn numbers_have_no_negative_zero() {
        assert_eq!(number(-0.0001, 3), "0.000");
        assert_eq!(number(-1.5, 1), "-1.5");
    }
}
