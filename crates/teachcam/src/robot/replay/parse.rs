//! Reading back the programs teachcam writes: RAPID modules, KRL `.src`/`.dat` pairs and
//! URScript programs, into the moves a controller would run.
//!
//! Only what the writers emit is understood (the cell, targets, speeds, zones, joint and
//! linear moves, the routines `main` calls); any other instruction is refused naming its line,
//! so a program edited by hand is never replayed wrongly without a word.

use std::collections::BTreeMap;

use nalgebra::{Translation3, UnitQuaternion, Vector3};

use crate::geometry::{Pose, pose_from_parts};
use crate::robot::Cell;
use crate::robot::kinematics::Joints;

/// The three dialects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dialect {
    /// ABB RAPID.
    Rapid,
    /// KUKA KRL.
    Krl,
    /// Universal Robots URScript.
    UrScript,
}

impl Dialect {
    /// The dialect's name, for messages.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::Rapid => "RAPID",
            Self::Krl => "KRL",
            Self::UrScript => "URScript",
        }
    }
}

/// How a move interpolates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// Every axis from its start to its end angle, all arriving together (`MoveJ`, `PTP`,
    /// `movej`).
    Joint,
    /// The TCP on a straight line, the orientation interpolated (`MoveL`, `LIN`, `movel`).
    Linear,
}

/// Which of the arm's solutions a target asks for: RAPID's `robconf`, KRL's Status and Turn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Branch {
    /// `[cf1, cf4, cf6, cfx]`.
    Abb([i32; 4]),
    /// `S`, `T`.
    Kuka {
        /// Status.
        status: u8,
        /// Turn.
        turn: u8,
    },
}

/// How fast a move is programmed to go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Speed {
    /// TCP speed, mm/s, and the orientation speed, rad/s (RAPID's `v_ori`; `None` where the
    /// dialect's orientation follows the position).
    Tcp {
        /// mm/s.
        tcp: f64,
        /// rad/s.
        orientation: Option<f64>,
    },
    /// The move takes this long (RAPID `\T`, seconds).
    Time(f64),
    /// Joint move: the leading axis at this fraction of its maximum speed (KRL `BAS(#VEL_PTP)`).
    AxisFraction(f64),
    /// Joint move: the leading axis at this speed, rad/s (URScript `movej(v=...)`).
    AxisSpeed(f64),
}

/// Where a move goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// The TCP in the work object, with the solution asked for.
    Pose {
        /// The TCP in the work object's frame.
        wobj_from_tcp: Pose,
        /// `robconf` or Status/Turn, when the target has one.
        branch: Option<Branch>,
    },
    /// Joint angles (URScript `movej([...])`).
    Joints(Joints),
}

/// One move as the program states it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProgrammedMove {
    /// Joint or linear.
    pub motion: Motion,
    /// Where it goes.
    pub target: Target,
    /// How fast.
    pub speed: Speed,
    /// Blending radius around the target, mm (0: the robot stops there, `fine`).
    pub zone_mm: f64,
    /// The line of the program it comes from (1-based).
    pub line: usize,
}

/// A program read back: its dialect, the cell it declares and its moves in order.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramText {
    /// The dialect.
    pub dialect: Dialect,
    /// The work object and TCP the program sets.
    pub cell: Cell,
    /// The moves in the order the controller runs them.
    pub moves: Vec<ProgrammedMove>,
}

/// Why a program could not be read.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("line {line}: {message}")]
pub struct ParseError {
    /// The line (1-based; 0 for the program as a whole).
    pub line: usize,
    /// What is wrong there.
    pub message: String,
}

fn error(line: usize, message: impl Into<String>) -> ParseError {
    ParseError {
        line,
        message: message.into(),
    }
}

/// Every number in `text`, in order (RAPID's `9E+09` included).
fn numbers(text: &str) -> Vec<f64> {
    let mut out = Vec::new();
    let mut token = String::new();
    let flush = |token: &mut String, out: &mut Vec<f64>| {
        if let Ok(v) = token.parse::<f64>() {
            out.push(v);
        }
        token.clear();
    };
    for c in text.chars() {
        let part_of_number = c.is_ascii_digit()
            || c == '.'
            || ((c == '-' || c == '+') && (token.is_empty() || token.ends_with(['E', 'e'])))
            || ((c == 'E' || c == 'e') && !token.is_empty());
        if part_of_number {
            token.push(c);
        } else {
            flush(&mut token, &mut out);
        }
    }
    flush(&mut token, &mut out);
    out
}

fn quaternion(
    line: usize,
    w: f64,
    x: f64,
    y: f64,
    z: f64,
) -> Result<UnitQuaternion<f64>, ParseError> {
    let q = nalgebra::Quaternion::new(w, x, y, z);
    let norm = q.norm();
    if !(norm.is_finite() && (norm - 1.0).abs() < 1e-3) {
        return Err(error(
            line,
            format!("quaternion of norm {norm}: expected a unit quaternion"),
        ));
    }
    Ok(UnitQuaternion::from_quaternion(q))
}

/// `[[x,y,z],[q1,q2,q3,q4]]` at the start of `values`.
fn rapid_pose(line: usize, values: &[f64]) -> Result<Pose, ParseError> {
    if values.len() < 7 {
        return Err(error(line, "expected a pose [[x,y,z],[q1,q2,q3,q4]]"));
    }
    let q = quaternion(line, values[3], values[4], values[5], values[6])?;
    Ok(pose_from_parts(
        Vector3::new(values[0], values[1], values[2]),
        q,
    ))
}

/// The value after `:=` of a declaration, without the final `;`.
fn declared_value(text: &str) -> Option<&str> {
    let (_, value) = text.split_once(":=")?;
    Some(value.trim().trim_end_matches(';'))
}

/// The name declared by `CONST type name := ...` / `PERS type name := ...`.
fn declared_name(text: &str) -> Option<&str> {
    let before = text.split_once(":=")?.0;
    before.split_whitespace().nth(2)
}

/// RAPID's predefined `speeddata` `vN` (v_tcp = N mm/s, v_ori 500 deg/s) and `zonedata`.
fn rapid_predefined_speed(name: &str) -> Option<Speed> {
    let tcp: f64 = name.strip_prefix('v')?.parse().ok()?;
    Some(Speed::Tcp {
        tcp,
        orientation: Some(500f64.to_radians()),
    })
}

fn rapid_predefined_zone(name: &str) -> Option<f64> {
    if name.eq_ignore_ascii_case("fine") {
        return Some(0.0);
    }
    let radius: f64 = name.strip_prefix('z')?.parse().ok()?;
    Some(if radius == 0.0 { 0.3 } else { radius })
}

/// Reads a RAPID module written by teachcam.
///
/// # Errors
/// A line the reader does not understand, a target, speed or zone used but not declared, a
/// routine called but not defined.
pub fn parse_rapid(text: &str) -> Result<ProgramText, ParseError> {
    let mut tool: Option<Pose> = None;
    let mut wobj: Option<Pose> = None;
    let mut targets: BTreeMap<String, (Pose, Branch)> = BTreeMap::new();
    let mut speeds: BTreeMap<String, Speed> = BTreeMap::new();
    let mut zones: BTreeMap<String, f64> = BTreeMap::new();
    let mut routines: BTreeMap<String, Vec<(usize, String)>> = BTreeMap::new();
    let mut current: Option<String> = None;
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let t = raw.trim();
        if t.is_empty() || t.starts_with('!') {
            continue;
        }
        let lower = t.to_ascii_lowercase();
        if let Some(rest) = lower.strip_prefix("proc ") {
            let name = rest
                .split('(')
                .next()
                .unwrap_or_default()
                .trim()
                .to_string();
            routines.insert(name.clone(), Vec::new());
            current = Some(name);
        } else if lower.starts_with("endproc") {
            current = None;
        } else if let Some(name) = &current {
            if let Some(body) = routines.get_mut(name) {
                body.push((line, t.to_string()));
            }
        } else if lower.starts_with("module") || lower.starts_with("endmodule") {
        } else if lower.starts_with("pers tooldata") || lower.starts_with("const tooldata") {
            let values = numbers(declared_value(t).unwrap_or_default());
            tool = Some(rapid_pose(line, &values)?);
        } else if lower.starts_with("pers wobjdata") || lower.starts_with("const wobjdata") {
            let value = declared_value(t).unwrap_or_default();
            let values = numbers(value);
            // [robhold, ufprog, ufmec "", uframe, oframe]: the booleans are no numbers.
            if values.len() < 14 {
                return Err(error(
                    line,
                    "expected wobjdata [robhold,ufprog,ufmec,uframe,oframe]",
                ));
            }
            wobj = Some(rapid_pose(line, &values[..7])? * rapid_pose(line, &values[7..14])?);
        } else if lower.starts_with("const robtarget") || lower.starts_with("pers robtarget") {
            let name = declared_name(t).unwrap_or_default().to_string();
            let values = numbers(declared_value(t).unwrap_or_default());
            if values.len() < 11 {
                return Err(error(
                    line,
                    format!("robtarget {name}: expected [trans,rot,robconf,extax]"),
                ));
            }
            let pose = rapid_pose(line, &values)?;
            let conf = [values[7], values[8], values[9], values[10]].map(|v| v as i32);
            targets.insert(name, (pose, Branch::Abb(conf)));
        } else if lower.starts_with("const speeddata") || lower.starts_with("pers speeddata") {
            let name = declared_name(t).unwrap_or_default().to_string();
            let values = numbers(declared_value(t).unwrap_or_default());
            if values.len() < 2 || !(values[0] > 0.0 && values[1] > 0.0) {
                return Err(error(
                    line,
                    format!("speeddata {name}: expected positive [v_tcp,v_ori,...]"),
                ));
            }
            speeds.insert(
                name,
                Speed::Tcp {
                    tcp: values[0],
                    orientation: Some(values[1].to_radians()),
                },
            );
        } else if lower.starts_with("const zonedata") || lower.starts_with("pers zonedata") {
            let name = declared_name(t).unwrap_or_default().to_string();
            let value = declared_value(t).unwrap_or_default();
            let fine = value.to_ascii_uppercase().contains("TRUE");
            let values = numbers(value);
            let Some(&radius) = values.first() else {
                return Err(error(
                    line,
                    format!("zonedata {name}: expected [finep,pzone_tcp,...]"),
                ));
            };
            zones.insert(name, if fine { 0.0 } else { radius });
        } else {
            return Err(error(
                line,
                format!("'{t}': not a declaration teachcam writes"),
            ));
        }
    }
    let cell = Cell {
        base_from_wobj: wobj.ok_or_else(|| error(0, "no wobjdata"))?,
        flange_from_tcp: tool.ok_or_else(|| error(0, "no tooldata"))?,
    };
    let mut moves = Vec::new();
    let mut stack = vec!["main".to_string()];
    run_rapid_routine("main", &routines, &mut stack, &mut |line, instruction| {
        let lower = instruction.to_ascii_lowercase();
        let motion = if lower.starts_with("movel ") {
            Motion::Linear
        } else if lower.starts_with("movej ") {
            Motion::Joint
        } else if lower.starts_with("confj")
            || lower.starts_with("confl")
            || lower.starts_with("singarea")
        {
            return Ok(());
        } else {
            return Err(error(
                line,
                format!("'{instruction}': not an instruction teachcam writes"),
            ));
        };
        let arguments: Vec<&str> = instruction[6..]
            .trim_end_matches(';')
            .split(',')
            .map(str::trim)
            .collect();
        if arguments.len() < 3 {
            return Err(error(line, "expected Move target, speed, zone, tool"));
        }
        let (pose, branch) = *targets
            .get(arguments[0])
            .ok_or_else(|| error(line, format!("robtarget {} is not declared", arguments[0])))?;
        let (speed_name, time) = match arguments[1].split_once("\\T:=") {
            Some((name, time)) => (name, time.parse::<f64>().ok()),
            None => (arguments[1], None),
        };
        let speed = match time {
            Some(t) if t > 0.0 => Speed::Time(t),
            Some(_) => return Err(error(line, "\\T must be a positive time")),
            None => speeds
                .get(speed_name)
                .copied()
                .or_else(|| rapid_predefined_speed(speed_name))
                .ok_or_else(|| error(line, format!("speeddata {speed_name} is not declared")))?,
        };
        let zone_mm = zones
            .get(arguments[2])
            .copied()
            .or_else(|| rapid_predefined_zone(arguments[2]))
            .ok_or_else(|| error(line, format!("zonedata {} is not declared", arguments[2])))?;
        moves.push(ProgrammedMove {
            motion,
            target: Target::Pose {
                wobj_from_tcp: pose,
                branch: Some(branch),
            },
            speed,
            zone_mm,
            line,
        });
        Ok(())
    })?;
    Ok(ProgramText {
        dialect: Dialect::Rapid,
        cell,
        moves,
    })
}

/// Runs routine `name`'s lines through `each`, a call `path_1;` running that routine in place.
fn run_rapid_routine(
    name: &str,
    routines: &BTreeMap<String, Vec<(usize, String)>>,
    stack: &mut Vec<String>,
    each: &mut dyn FnMut(usize, &str) -> Result<(), ParseError>,
) -> Result<(), ParseError> {
    let body = routines
        .get(name)
        .ok_or_else(|| error(0, format!("no PROC {name}")))?;
    for (line, instruction) in body {
        let bare = instruction.trim_end_matches(';').trim();
        let is_call =
            !bare.is_empty() && bare.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if is_call {
            let callee = bare.to_ascii_lowercase();
            if stack.contains(&callee) {
                return Err(error(*line, format!("{bare} calls itself")));
            }
            stack.push(callee.clone());
            run_rapid_routine(&callee, routines, stack, each)?;
            stack.pop();
        } else {
            each(*line, instruction)?;
        }
    }
    Ok(())
}

/// The fields `X 1,Y 2,...` of a KRL aggregate `{...}` by name.
fn krl_fields(text: &str) -> BTreeMap<String, f64> {
    let inner = text.trim().trim_start_matches('{').trim_end_matches('}');
    inner
        .split(',')
        .filter_map(|field| {
            let mut parts = field.split_whitespace();
            let key = parts.next()?.to_ascii_uppercase();
            let value = parts.next()?.parse().ok()?;
            Some((key, value))
        })
        .collect()
}

/// A KRL FRAME/E6POS pose: millimetres and `A, B, C` degrees, `R = Rz(A) Ry(B) Rx(C)`.
fn krl_pose(line: usize, fields: &BTreeMap<String, f64>) -> Result<Pose, ParseError> {
    let get = |k: &str| {
        fields
            .get(k)
            .copied()
            .ok_or_else(|| error(line, format!("expected field {k}")))
    };
    let rotation = UnitQuaternion::from_euler_angles(
        get("C")?.to_radians(),
        get("B")?.to_radians(),
        get("A")?.to_radians(),
    );
    Ok(Pose::from_parts(
        Translation3::new(get("X")?, get("Y")?, get("Z")?),
        rotation,
    ))
}

/// Reads a KRL program written by teachcam: its `.src` and the `.dat` beside it.
///
/// # Errors
/// A line not understood, a point used but not declared in the `.dat`, no `$TOOL`/`$BASE`.
pub fn parse_krl(src: &str, dat: &str) -> Result<ProgramText, ParseError> {
    let mut points: BTreeMap<String, (Pose, Option<Branch>)> = BTreeMap::new();
    let mut frames: BTreeMap<String, Pose> = BTreeMap::new();
    for (index, raw) in dat.lines().enumerate() {
        let line = index + 1;
        let t = raw.trim();
        let upper = t.to_ascii_uppercase();
        let Some(rest) = upper.strip_prefix("DECL ") else {
            continue;
        };
        let Some((head, value)) = t[5..].split_once('=') else {
            return Err(error(line, format!(".dat: '{t}' has no value")));
        };
        let mut head = head.split_whitespace();
        let (kind, name) = (
            head.next().unwrap_or_default(),
            head.next().unwrap_or_default(),
        );
        let fields = krl_fields(value);
        let pose =
            krl_pose(line, &fields).map_err(|e| error(line, format!(".dat: {}", e.message)))?;
        if rest.starts_with("FRAME") {
            frames.insert(name.to_ascii_uppercase(), pose);
        } else if kind.eq_ignore_ascii_case("E6POS") || kind.eq_ignore_ascii_case("POS") {
            let branch = match (fields.get("S"), fields.get("T")) {
                (Some(&s), Some(&t)) => Some(Branch::Kuka {
                    status: s as u8,
                    turn: t as u8,
                }),
                _ => None,
            };
            points.insert(name.to_ascii_uppercase(), (pose, branch));
        }
    }
    let mut tool = None;
    let mut base = None;
    let mut velocity_m_s: Option<f64> = None;
    let mut ptp_fraction = 1.0;
    let mut cdis_mm = 0.0;
    let mut moves = Vec::new();
    for (index, raw) in src.lines().enumerate() {
        let line = index + 1;
        let t = raw.split(';').next().unwrap_or_default().trim();
        let upper = t.to_ascii_uppercase();
        if t.is_empty() || t.starts_with('&') || upper.starts_with("DEF ") || upper == "END" {
            continue;
        }
        let value = || {
            t.split_once('=')
                .map(|(_, v)| v.trim().to_string())
                .unwrap_or_default()
        };
        if upper.starts_with("$TOOL=") || upper.starts_with("$BASE=") {
            let name = value().to_ascii_uppercase();
            let frame = *frames
                .get(&name)
                .ok_or_else(|| error(line, format!("{name} is not declared in the .dat")))?;
            if upper.starts_with("$TOOL") {
                tool = Some(frame);
            } else {
                base = Some(frame);
            }
        } else if upper.starts_with("$VEL.CP=") {
            let v: f64 = value()
                .parse()
                .map_err(|_| error(line, "$VEL.CP: expected m/s"))?;
            velocity_m_s = Some(v);
        } else if upper.starts_with("$APO.CDIS=") {
            cdis_mm = value()
                .parse()
                .map_err(|_| error(line, "$APO.CDIS: expected mm"))?;
        } else if upper.starts_with("BAS(#VEL_PTP,") {
            let percent = numbers(t).first().copied().unwrap_or(100.0);
            ptp_fraction = percent / 100.0;
        } else if upper.starts_with("BAS(")
            || upper.starts_with("$LOAD")
            || upper.starts_with("$ORI_TYPE")
        {
        } else if upper.starts_with("PTP ") || upper.starts_with("LIN ") {
            let mut words = t.split_whitespace().skip(1);
            let name = words.next().unwrap_or_default().to_ascii_uppercase();
            let blended = words
                .next()
                .is_some_and(|w| w.eq_ignore_ascii_case("C_DIS"));
            let (pose, branch) = *points
                .get(&name)
                .ok_or_else(|| error(line, format!("point {name} is not declared in the .dat")))?;
            let linear = upper.starts_with("LIN");
            let speed = if linear {
                let v = velocity_m_s.ok_or_else(|| error(line, "LIN before any $VEL.CP"))?;
                Speed::Tcp {
                    tcp: v * 1000.0,
                    orientation: None,
                }
            } else {
                Speed::AxisFraction(ptp_fraction)
            };
            moves.push(ProgrammedMove {
                motion: if linear {
                    Motion::Linear
                } else {
                    Motion::Joint
                },
                target: Target::Pose {
                    wobj_from_tcp: pose,
                    branch,
                },
                speed,
                zone_mm: if blended { cdis_mm } else { 0.0 },
                line,
            });
        } else {
            return Err(error(
                line,
                format!("'{t}': not an instruction teachcam writes"),
            ));
        }
    }
    Ok(ProgramText {
        dialect: Dialect::Krl,
        cell: Cell {
            base_from_wobj: base.ok_or_else(|| error(0, "no $BASE"))?,
            flange_from_tcp: tool.ok_or_else(|| error(0, "no $TOOL"))?,
        },
        moves,
    })
}

/// `p[x, y, z, rx, ry, rz]` (metres, rotation vector) at the start of `text`, in mm.
fn ur_pose(line: usize, text: &str) -> Result<Pose, ParseError> {
    let start = text
        .find("p[")
        .ok_or_else(|| error(line, "expected a pose p[...]"))?;
    let end = text[start..]
        .find(']')
        .ok_or_else(|| error(line, "unclosed p["))?
        + start;
    let v = numbers(&text[start + 2..end]);
    if v.len() != 6 {
        return Err(error(line, "a pose p[x, y, z, rx, ry, rz] has six numbers"));
    }
    Ok(pose_from_parts(
        Vector3::new(v[0], v[1], v[2]) * 1000.0,
        UnitQuaternion::from_scaled_axis(Vector3::new(v[3], v[4], v[5])),
    ))
}

/// The value of a keyword argument `key=...` of a call.
fn ur_argument(text: &str, key: &str) -> Option<f64> {
    let at = text.find(&format!("{key}="))?;
    numbers(&text[at + key.len() + 1..]).first().copied()
}

/// Reads a URScript program written by teachcam.
///
/// # Errors
/// A line not understood, a move before `wobj` and `set_tcp`.
pub fn parse_urscript(text: &str) -> Result<ProgramText, ParseError> {
    let mut tool = None;
    let mut wobj = None;
    let mut moves = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let t = raw.split('#').next().unwrap_or_default().trim();
        if t.is_empty() || t.starts_with("def ") || t == "end" || t.ends_with("()") {
            continue;
        }
        if t.starts_with("set_tcp(") {
            tool = Some(ur_pose(line, t)?);
        } else if t.starts_with("wobj =") || t.starts_with("wobj=") {
            wobj = Some(ur_pose(line, t)?);
        } else if t.starts_with("set_payload(") {
        } else if let Some(rest) = t.strip_prefix("movej(") {
            let end = rest
                .find(']')
                .ok_or_else(|| error(line, "movej: expected [q1, ..., q6]"))?;
            let q = numbers(&rest[..end]);
            let Ok(q) = <[f64; 6]>::try_from(q) else {
                return Err(error(line, "movej: expected six joint angles"));
            };
            let v = ur_argument(&rest[end..], "v").unwrap_or(1.05);
            moves.push(ProgrammedMove {
                motion: Motion::Joint,
                target: Target::Joints(Joints(q)),
                speed: Speed::AxisSpeed(v),
                zone_mm: ur_argument(&rest[end..], "r").unwrap_or(0.0) * 1000.0,
                line,
            });
        } else if let Some(rest) = t.strip_prefix("movel(") {
            if !rest.starts_with("pose_trans(wobj,") {
                return Err(error(line, "movel: expected pose_trans(wobj, p[...])"));
            }
            let pose = ur_pose(line, rest)?;
            let after = &rest[rest.find(']').unwrap_or(0)..];
            let v = ur_argument(after, "v").unwrap_or(0.25);
            if v.is_nan() || v <= 0.0 {
                return Err(error(line, "movel: v must be positive"));
            }
            moves.push(ProgrammedMove {
                motion: Motion::Linear,
                target: Target::Pose {
                    wobj_from_tcp: pose,
                    branch: None,
                },
                speed: Speed::Tcp {
                    tcp: v * 1000.0,
                    orientation: None,
                },
                zone_mm: ur_argument(after, "r").unwrap_or(0.0) * 1000.0,
                line,
            });
        } else {
            return Err(error(
                line,
                format!("'{t}': not an instruction teachcam writes"),
            ));
        }
    }
    Ok(ProgramText {
        dialect: Dialect::UrScript,
        cell: Cell {
            base_from_wobj: wobj.ok_or_else(|| error(0, "no wobj = p[...]"))?,
            flange_from_tcp: tool.ok_or_else(|| error(0, "no set_tcp"))?,
        },
        moves,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_every_literal() {
        assert_eq!(
            numbers("[[1,-2.5,3E+02],[9E+09]]"),
            vec![1.0, -2.5, 300.0, 9e9]
        );
        assert_eq!(numbers("v0002, z1"), vec![2.0, 1.0]);
    }
}
