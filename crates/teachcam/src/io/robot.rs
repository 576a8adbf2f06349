//! Robot files: another arm's geometry, joint ranges and speeds (`check --robot FILE.json`,
//! CONTRACT.md "Robot frames").
//!
//! ```json
//! {"name": "kr6-r700-ceiling", "maker": "kuka",
//!  "opw": {"a1_mm": 25, "a2_mm": -35, "b_mm": 0, "c1_mm": 400, "c2_mm": 315, "c3_mm": 365,
//!          "c4_mm": 80, "offsets_deg": [0, -90, 0, 0, 0, 0],
//!          "sign_corrections": [-1, 1, 1, -1, 1, -1]},
//!  "joints": [{"min_deg": -170, "max_deg": 170, "max_speed_deg_s": 360}, ... six of them]}
//! ```
//! `maker` is `abb`, `kuka` or `ur` (it sets the flange frame, the joint conventions' meaning
//! and which dialect may drive the arm). Exactly one of `opw` (a spherical wrist, the
//! parameters of ROS-Industrial's `opw_kinematics` with `θ_i = s_i q_i − o_i`; `b_mm` must be
//! 0) or `dh` (a UR-like arm: `{"d1_mm", "a2_mm", "a3_mm", "d4_mm", "d5_mm", "d6_mm"}`, UR's
//! DH table, [`crate::robot::kinematics::ur`]).

use std::path::Path;

use serde::Deserialize;

use super::{FileError, parse_json, read_text};
use crate::robot::kinematics::{Arm, AxisLimit, Maker, OpwParameters, Robot, UrParameters};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RobotFile {
    name: String,
    maker: MakerName,
    #[serde(default)]
    opw: Option<OpwFile>,
    #[serde(default)]
    dh: Option<DhFile>,
    joints: Vec<JointFile>,
    /// The heaviest load the maker allows on the flange, kg.
    #[serde(default)]
    max_payload_kg: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(rename_all = "lowercase")]
enum MakerName {
    Abb,
    Kuka,
    Ur,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OpwFile {
    a1_mm: f64,
    a2_mm: f64,
    b_mm: f64,
    c1_mm: f64,
    c2_mm: f64,
    c3_mm: f64,
    c4_mm: f64,
    offsets_deg: [f64; 6],
    sign_corrections: [f64; 6],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DhFile {
    d1_mm: f64,
    a2_mm: f64,
    a3_mm: f64,
    d4_mm: f64,
    d5_mm: f64,
    d6_mm: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JointFile {
    min_deg: f64,
    max_deg: f64,
    max_speed_deg_s: f64,
}

/// Reads and checks a robot file.
///
/// # Errors
/// [`FileError`] naming the file and the field: unreadable, not JSON, an unknown key, neither
/// or both of `opw` and `dh`, a length that is not finite (or not positive where the arm needs
/// it), a lateral offset `b_mm`, a sign correction other than ±1, not six joints, a joint
/// whose range is empty or wider than ±720°, or a speed that is not positive.
pub fn read_robot(path: &Path) -> Result<Robot, FileError> {
    parse_robot(path, &read_text(path)?)
}

/// [`read_robot`] on text already read; `path` names it in errors.
///
/// # Errors
/// As [`read_robot`].
pub fn parse_robot(path: &Path, text: &str) -> Result<Robot, FileError> {
    let file: RobotFile = parse_json(path, text)?;
    let bad = |message: String| FileError::invalid(path, message);
    let positive = |value: f64, field: &str| {
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(bad(format!("{field} {value}: must be a positive length")))
        }
    };
    let finite = |value: f64, field: &str| {
        if value.is_finite() {
            Ok(value)
        } else {
            Err(bad(format!("{field}: must be a finite number")))
        }
    };
    let arm = match (&file.opw, &file.dh) {
        (Some(o), None) => {
            if o.b_mm != 0.0 {
                return Err(bad(format!(
                    "opw.b_mm {}: a lateral offset is not supported (must be 0)",
                    o.b_mm
                )));
            }
            for (i, s) in o.sign_corrections.iter().enumerate() {
                if *s != 1.0 && *s != -1.0 {
                    return Err(bad(format!(
                        "opw.sign_corrections[{i}] {s}: must be 1 or -1"
                    )));
                }
            }
            for (i, d) in o.offsets_deg.iter().enumerate() {
                finite(*d, &format!("opw.offsets_deg[{i}]"))?;
            }
            Arm::SphericalWrist(OpwParameters {
                a1: finite(o.a1_mm, "opw.a1_mm")?,
                a2: finite(o.a2_mm, "opw.a2_mm")?,
                b: 0.0,
                c1: finite(o.c1_mm, "opw.c1_mm")?,
                c2: positive(o.c2_mm, "opw.c2_mm")?,
                c3: positive(o.c3_mm, "opw.c3_mm")?,
                c4: finite(o.c4_mm, "opw.c4_mm")?,
                offsets: o.offsets_deg.map(f64::to_radians),
                sign_corrections: o.sign_corrections,
            })
        }
        (None, Some(d)) => {
            let nonzero = |value: f64, field: &str| {
                if value.is_finite() && value != 0.0 {
                    Ok(value)
                } else {
                    Err(bad(format!("{field} {value}: must be a non-zero length")))
                }
            };
            Arm::Ur(UrParameters {
                d1: finite(d.d1_mm, "dh.d1_mm")?,
                a2: nonzero(d.a2_mm, "dh.a2_mm")?,
                a3: nonzero(d.a3_mm, "dh.a3_mm")?,
                d4: finite(d.d4_mm, "dh.d4_mm")?,
                d5: finite(d.d5_mm, "dh.d5_mm")?,
                d6: finite(d.d6_mm, "dh.d6_mm")?,
            })
        }
        (None, None) => {
            return Err(bad(
                "needs \"opw\" (a spherical wrist) or \"dh\" (a UR-like arm)".into(),
            ));
        }
        (Some(_), Some(_)) => {
            return Err(bad("has both \"opw\" and \"dh\": give one".into()));
        }
    };
    if file.joints.len() != 6 {
        return Err(bad(format!(
            "joints: {} given, six expected (axis 1 to 6)",
            file.joints.len()
        )));
    }
    let mut limits = [AxisLimit::from_degrees(0.0, 0.0, 0.0); 6];
    for (i, j) in file.joints.iter().enumerate() {
        let range_ok = j.min_deg.is_finite()
            && j.max_deg.is_finite()
            && j.min_deg < j.max_deg
            && j.min_deg >= -720.0
            && j.max_deg <= 720.0;
        if !range_ok {
            return Err(bad(format!(
                "joints[{i}]: range {}..{} deg must be finite, increasing and within ±720",
                j.min_deg, j.max_deg
            )));
        }
        if !(j.max_speed_deg_s.is_finite() && j.max_speed_deg_s > 0.0) {
            return Err(bad(format!(
                "joints[{i}].max_speed_deg_s {}: must be positive",
                j.max_speed_deg_s
            )));
        }
        limits[i] = AxisLimit::from_degrees(j.min_deg, j.max_deg, j.max_speed_deg_s);
    }
    if file.name.trim().is_empty() {
        return Err(bad("name: must not be empty".into()));
    }
    if let Some(kg) = file.max_payload_kg {
        if !(kg.is_finite() && kg > 0.0) {
            return Err(bad(format!("max_payload_kg {kg}: must be positive")));
        }
    }
    Ok(Robot {
        name: file.name,
        maker: match file.maker {
            MakerName::Abb => Maker::Abb,
            MakerName::Kuka => Maker::Kuka,
            MakerName::Ur => Maker::UniversalRobots,
        },
        arm,
        limits,
        max_payload_kg: file.max_payload_kg,
        wrist_inertia: None,
    })
}
