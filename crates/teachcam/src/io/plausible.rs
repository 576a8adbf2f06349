//! Plausibility of the lengths a user gives: the unit mistakes that pass every format check.
//!
//! Every length of teachcam is in millimetres. A file or flag written in metres still parses,
//! and gives a wrong answer without an error: a TCP of `0,0,0.2` is 0.2 mm out of the flange, a
//! tool whose markers are 0.06 apart cannot be a tool, a rig in metres puts every camera within
//! a few millimetres of the work object. These checks find such values and say what was likely
//! meant; they are warnings (the value may be meant), printed by every command that loads the
//! file or flag, one line each.

use std::fmt;

use crate::camera::Rig;
use crate::geometry::Pose;
use crate::tool::Tool;

/// A TCP this close to the flange, and not on it, is likely given in metres, millimetres: the
/// shortest brush, gripper or probe reaches tens of millimetres out.
pub const TCP_MIN_MM: f64 = 5.0;

/// Markers this close together are likely given in metres, millimetres: marker spheres are
/// 3 mm and more across, so their centres are at least that far apart.
pub const MARKER_SPACING_MIN_MM: f64 = 1.0;

/// Every camera within this distance of the world origin: the rig is likely in metres,
/// millimetres (cameras film the work object from 0.3 m and more).
pub const CAMERAS_NEAR_MM: f64 = 50.0;

/// A camera farther than this from the world origin: the rig is likely in micrometres or its
/// translations are not millimetres, millimetres (no marker tracker films from 50 m).
pub const CAMERAS_FAR_MM: f64 = 50_000.0;

/// A value that is likely in the wrong unit.
#[derive(Debug, Clone, PartialEq)]
pub enum UnitWarning {
    /// The TCP is closer to the flange than [`TCP_MIN_MM`], and not on it.
    TcpNearFlange {
        /// Its distance from the flange, millimetres.
        distance_mm: f64,
    },
    /// Two markers of a tool are closer than [`MARKER_SPACING_MIN_MM`].
    MarkersClose {
        /// The tool's name.
        tool: String,
        /// The two closest markers, by index.
        markers: (usize, usize),
        /// Their distance, millimetres.
        spacing_mm: f64,
    },
    /// Every camera (two or more) is within [`CAMERAS_NEAR_MM`] of the world origin.
    CamerasNearOrigin {
        /// The farthest camera.
        camera: String,
        /// Its distance from the origin, millimetres.
        distance_mm: f64,
    },
    /// A camera is farther than [`CAMERAS_FAR_MM`] from the world origin.
    CameraFar {
        /// The camera.
        camera: String,
        /// Its distance from the origin, millimetres.
        distance_mm: f64,
    },
}

impl fmt::Display for UnitWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TcpNearFlange { distance_mm } => write!(
                f,
                "the TCP is {distance_mm} mm from the flange (under {TCP_MIN_MM} mm): is it in metres? \
                 --tcp is in millimetres (a tip 0.2 m out is 0,0,200)"
            ),
            Self::MarkersClose {
                tool,
                markers: (a, b),
                spacing_mm,
            } => write!(
                f,
                "tool '{tool}': markers {a} and {b} are {spacing_mm} mm apart (under \
                 {MARKER_SPACING_MIN_MM} mm): are the markers in metres? tool files are in millimetres"
            ),
            Self::CamerasNearOrigin {
                camera,
                distance_mm,
            } => write!(
                f,
                "every camera centre is within {distance_mm:.3} mm of the world origin (farthest: \
                 {camera}; under {CAMERAS_NEAR_MM} mm): is the rig in metres? rig files are in \
                 millimetres, as tool files are"
            ),
            Self::CameraFar {
                camera,
                distance_mm,
            } => write!(
                f,
                "camera {camera}'s centre is {:.1} m from the world origin (over {} m): is the rig in \
                 micrometres? rig files are in millimetres",
                distance_mm / 1000.0,
                CAMERAS_FAR_MM / 1000.0
            ),
        }
    }
}

/// A TCP (`flange_from_tcp`, `--tcp`) off the flange by less than [`TCP_MIN_MM`]; the flange
/// itself (an offset of 0, the default) is not a mistake.
#[must_use]
pub fn tcp_warning(flange_from_tcp: &Pose) -> Option<UnitWarning> {
    let distance_mm = flange_from_tcp.translation.vector.norm();
    (distance_mm > 0.0 && distance_mm < TCP_MIN_MM)
        .then_some(UnitWarning::TcpNearFlange { distance_mm })
}

/// A tool whose two closest markers are under [`MARKER_SPACING_MIN_MM`] apart.
#[must_use]
pub fn tool_warning(tool: &Tool) -> Option<UnitWarning> {
    let m = &tool.markers_in_tool;
    let mut closest: Option<((usize, usize), f64)> = None;
    for i in 0..m.len() {
        for j in i + 1..m.len() {
            let d = (m[i] - m[j]).norm();
            if closest.is_none_or(|(_, c)| d < c) {
                closest = Some(((i, j), d));
            }
        }
    }
    let (markers, spacing_mm) = closest?;
    (spacing_mm < MARKER_SPACING_MIN_MM).then(|| UnitWarning::MarkersClose {
        tool: tool.name.clone(),
        markers,
        spacing_mm,
    })
}

/// A rig whose cameras are all near the world origin (two or more cameras), or one of them
/// far from it.
#[must_use]
pub fn rig_warning(rig: &Rig) -> Option<UnitWarning> {
    let distances: Vec<(&str, f64)> = rig
        .cameras
        .iter()
        .map(|c| (c.name.as_str(), c.center_in_world().coords.norm()))
        .collect();
    let (camera, distance_mm) = distances
        .iter()
        .copied()
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    if distance_mm > CAMERAS_FAR_MM {
        return Some(UnitWarning::CameraFar {
            camera: camera.to_string(),
            distance_mm,
        });
    }
    (distances.len() >= 2 && distance_mm < CAMERAS_NEAR_MM).then(|| {
        UnitWarning::CamerasNearOrigin {
            camera: camera.to_string(),
            distance_mm,
        }
    })
}
