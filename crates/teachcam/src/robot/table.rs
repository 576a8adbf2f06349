//! CSV tables of a checked path: the joints (`check --joints-out`, CONTRACT.md "Robot frames")
//! and the TCP poses with their joints (`export csv`).
//!
//! ```text
//! frame,j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg,time_s,<configuration>,ok
//! frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,j1_deg,...,j6_deg,<configuration>
//! ```
//! Joint angles in degrees in the maker's convention (ABB: as in a `jointtarget`; KUKA: A1–A6
//! as the pendant shows them; UR: `movej`'s angles in degrees). The configuration columns are
//! the maker's: ABB `cf1,cf4,cf6,cfx` (`confdata`), KUKA `s,t` (Status and Turn), UR
//! `configuration` (0..7, [`crate::robot::kinematics::ArmConfiguration::code`]). TCP poses are
//! `wobj_from_tcp`. A frame without a joint solution keeps its row with the joint
//! fields empty, as trajectory gaps do.

use std::fmt::Write as _;

use crate::geometry::Quat;
use crate::robot::check::{CheckReport, FrameCheck};
use crate::robot::kinematics::{Maker, Robot, confdata, status_turn};
use crate::robot::program::Program;

/// The joints table of a check (`--joints-out`).
#[must_use]
pub fn joints_csv(report: &CheckReport) -> String {
    let mut out = format!(
        "frame,j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg,time_s,{},ok\n",
        configuration_header(report.robot.maker)
    );
    for f in &report.frames {
        let _ = write!(out, "{}", f.target.frame.0);
        push_joints(&mut out, f);
        let _ = write!(out, ",{:.6}", f.target.time_s);
        push_conf(&mut out, &report.robot, f);
        let _ = writeln!(out, ",{}", u8::from(f.passes()));
    }
    out
}

/// The TCP poses and joints of a checked path, every frame (not simplified).
#[must_use]
pub fn poses_csv(report: &CheckReport) -> String {
    let mut out = format!(
        "frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,j1_deg,j2_deg,j3_deg,j4_deg,j5_deg,j6_deg,{}\n",
        configuration_header(report.robot.maker)
    );
    let mut previous: Option<Quat> = None;
    for f in &report.frames {
        let pose = &f.target.wobj_from_tcp;
        let t = pose.translation.vector;
        let q = Quat::from_rotation(&pose.rotation);
        let q = previous.map_or(q, |p| q.continuous_with(&p));
        previous = Some(q);
        let _ = write!(
            out,
            "{},{:.6},{:.4},{:.4},{:.4},{:.9},{:.9},{:.9},{:.9}",
            f.target.frame.0, f.target.time_s, t.x, t.y, t.z, q.w, q.x, q.y, q.z
        );
        push_joints(&mut out, f);
        push_conf(&mut out, &report.robot, f);
        out.push('\n');
    }
    out
}

/// The TCP poses of a program's moves (the simplified path), for a dialect-free export.
#[must_use]
pub fn program_csv(program: &Program) -> String {
    let mut out = String::from(
        "frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,tcp_speed_mm_s,orientation_speed_deg_s\n",
    );
    for m in &program.moves {
        let pose = &m.target.wobj_from_tcp;
        let t = pose.translation.vector;
        let q = Quat::from_rotation(&pose.rotation);
        let _ = writeln!(
            out,
            "{},{:.6},{:.4},{:.4},{:.4},{:.9},{:.9},{:.9},{:.9},{:.4},{:.4}",
            m.target.frame.0,
            m.target.time_s,
            t.x,
            t.y,
            t.z,
            q.w,
            q.x,
            q.y,
            q.z,
            m.tcp_speed,
            m.orientation_speed.to_degrees()
        );
    }
    out
}

fn push_joints(out: &mut String, f: &FrameCheck) {
    match f.joints {
        Some(j) => {
            for d in j.to_degrees() {
                let _ = write!(out, ",{d:.6}");
            }
        }
        None => out.push_str(",,,,,,"),
    }
}

/// The names of the maker's configuration columns.
fn configuration_header(maker: Maker) -> &'static str {
    match maker {
        Maker::Abb => "cf1,cf4,cf6,cfx",
        Maker::Kuka => "s,t",
        Maker::UniversalRobots => "configuration",
    }
}

fn push_conf(out: &mut String, robot: &Robot, f: &FrameCheck) {
    let (Some(joints), Some(configuration)) = (f.joints, f.configuration) else {
        out.push_str(match robot.maker {
            Maker::Abb => ",,,,",
            Maker::Kuka => ",,",
            Maker::UniversalRobots => ",",
        });
        return;
    };
    let _ = match robot.maker {
        Maker::Abb => {
            let c = confdata(&joints, &configuration);
            write!(out, ",{},{},{},{}", c.cf1, c.cf4, c.cf6, c.cfx)
        }
        Maker::Kuka => {
            let st = status_turn(robot, &joints, &configuration);
            write!(out, ",{},{}", st.status, st.turn)
        }
        Maker::UniversalRobots => write!(out, ",{}", configuration.code()),
    };
}
