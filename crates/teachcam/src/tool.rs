//! The tracked tool: marker sphere centres and the tool centre point, in the tool's frame.
//!
//! Model (paper §II-C, §V-A): the tool frame is the frame in which the tool file gives the
//! markers; registration finds `world_from_tool` in each frame, and the tool centre point is
//! `world_from_tcp = world_from_tool * tool_from_tcp`, where `tool_from_tcp` is the tip's
//! position with the tool's axes (or `tip_rotation` when the file gives one).

use crate::geometry::{MarkerId, Point3, Pose};

/// Smallest span (largest distance between two markers) of a tool, millimetres: the smallest
/// retro-reflective markers sold are 3 mm spheres, so a layout under a millimetre across is a
/// file written in metres.
pub const MIN_TOOL_SPAN_MM: f64 = 1.0;

/// Markers closer than this to the line through two others make the layout collinear: SVD
/// registration has no unique rotation about that line (millimetres).
pub const MIN_MARKER_SPREAD_MM: f64 = 1.0;

/// A rigid tool carrying reflective spheres.
#[derive(Debug, Clone, PartialEq)]
pub struct Tool {
    /// Name from the tool file.
    pub name: String,
    /// Diameter of every marker sphere, millimetres.
    pub marker_diameter_mm: f64,
    /// Sphere centres in the tool frame, indexed by [`MarkerId`].
    pub markers_in_tool: Vec<Point3>,
    /// The tool centre point frame in the tool frame.
    pub tool_from_tcp: Pose,
}

/// Why a tool model cannot be tracked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ToolError {
    /// Fewer than three markers: no rotation can be registered.
    #[error("tool has {count} markers; registration needs at least 3")]
    TooFewMarkers {
        /// Markers given.
        count: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// Which value (`marker 2`, `tip`, `marker_diameter_mm`).
        what: String,
    },
    /// Non-positive marker diameter.
    #[error("marker_diameter_mm must be positive, got {value}")]
    BadDiameter {
        /// The value given.
        value: f64,
    },
    /// Two markers at the same place.
    #[error("{a} and {b} are {distance_mm:.3} mm apart; spheres of {diameter_mm} mm would overlap")]
    Overlapping {
        /// First marker.
        a: MarkerId,
        /// Second marker.
        b: MarkerId,
        /// Their distance.
        distance_mm: f64,
        /// The sphere diameter.
        diameter_mm: f64,
    },
    /// A layout far smaller than any marker tool: positions given in metres.
    #[error(
        "the markers span only {span_mm:.4} mm; tool files are in millimetres (were the positions given in metres? multiply them by 1000)"
    )]
    TooSmall {
        /// The largest distance between two markers.
        span_mm: f64,
    },
    /// All markers on one line.
    #[error(
        "markers are collinear (every marker within {MIN_MARKER_SPREAD_MM} mm of one line): the rotation about that line cannot be measured"
    )]
    Collinear,
}

impl Tool {
    /// A tool, checked: at least three finite, non-overlapping, non-collinear markers and a
    /// positive diameter.
    ///
    /// # Errors
    /// [`ToolError`] saying which check failed.
    pub fn new(
        name: String,
        marker_diameter_mm: f64,
        markers_in_tool: Vec<Point3>,
        tool_from_tcp: Pose,
    ) -> Result<Self, ToolError> {
        if !marker_diameter_mm.is_finite() {
            return Err(ToolError::NotFinite {
                what: "marker_diameter_mm".into(),
            });
        }
        if marker_diameter_mm <= 0.0 {
            return Err(ToolError::BadDiameter {
                value: marker_diameter_mm,
            });
        }
        if markers_in_tool.len() < 3 {
            return Err(ToolError::TooFewMarkers {
                count: markers_in_tool.len(),
            });
        }
        for (i, m) in markers_in_tool.iter().enumerate() {
            if !m.coords.iter().all(|v| v.is_finite()) {
                return Err(ToolError::NotFinite {
                    what: format!("{}", MarkerId(i)),
                });
            }
        }
        let translation = tool_from_tcp.translation.vector;
        if !translation.iter().all(|v| v.is_finite())
            || !tool_from_tcp.rotation.coords.iter().all(|v| v.is_finite())
        {
            return Err(ToolError::NotFinite { what: "tip".into() });
        }
        let span_mm = markers_in_tool
            .iter()
            .flat_map(|a| markers_in_tool.iter().map(move |b| (a - b).norm()))
            .fold(0.0, f64::max);
        if span_mm < MIN_TOOL_SPAN_MM {
            return Err(ToolError::TooSmall { span_mm });
        }
        for i in 0..markers_in_tool.len() {
            for j in i + 1..markers_in_tool.len() {
                let distance_mm = (markers_in_tool[i] - markers_in_tool[j]).norm();
                if distance_mm < marker_diameter_mm {
                    return Err(ToolError::Overlapping {
                        a: MarkerId(i),
                        b: MarkerId(j),
                        distance_mm,
                        diameter_mm: marker_diameter_mm,
                    });
                }
            }
        }
        if max_distance_from_best_line(&markers_in_tool) < MIN_MARKER_SPREAD_MM {
            return Err(ToolError::Collinear);
        }
        Ok(Self {
            name,
            marker_diameter_mm,
            markers_in_tool,
            tool_from_tcp,
        })
    }

    /// Marker sphere radius, millimetres.
    #[must_use]
    pub fn marker_radius(&self) -> f64 {
        self.marker_diameter_mm / 2.0
    }

    /// The tip (tool centre point) in the tool frame.
    #[must_use]
    pub fn tip_in_tool(&self) -> Point3 {
        Point3::from(self.tool_from_tcp.translation.vector)
    }

    /// Every marker with its id.
    pub fn markers(&self) -> impl Iterator<Item = (MarkerId, &Point3)> {
        self.markers_in_tool
            .iter()
            .enumerate()
            .map(|(i, p)| (MarkerId(i), p))
    }
}

/// Largest distance of a point from the line through the two points farthest apart: zero for
/// collinear points.
fn max_distance_from_best_line(points: &[Point3]) -> f64 {
    let mut best = (0, 0, 0.0);
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            let d = (points[i] - points[j]).norm();
            if d > best.2 {
                best = (i, j, d);
            }
        }
    }
    if best.2 == 0.0 {
        return 0.0;
    }
    let direction = (points[best.1] - points[best.0]) / best.2;
    points
        .iter()
        .map(|p| {
            let v = p - points[best.0];
            (v - direction * v.dot(&direction)).norm()
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(list: &[[f64; 3]]) -> Vec<Point3> {
        list.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect()
    }

    #[test]
    fn checks_refuse_bad_tools() {
        let id = Pose::identity();
        assert_eq!(
            Tool::new("t".into(), 10.0, pts(&[[0., 0., 0.], [50., 0., 0.]]), id),
            Err(ToolError::TooFewMarkers { count: 2 })
        );
        assert_eq!(
            Tool::new(
                "t".into(),
                10.0,
                pts(&[[0., 0., 0.], [50., 0., 0.], [100., 0.1, 0.]]),
                id
            ),
            Err(ToolError::Collinear)
        );
        assert!(matches!(
            Tool::new(
                "t".into(),
                10.0,
                pts(&[[0., 0., 0.], [5., 0., 0.], [0., 50., 0.]]),
                id
            ),
            Err(ToolError::Overlapping { .. })
        ));
        assert_eq!(
            Tool::new(
                "t".into(),
                0.0,
                pts(&[[0., 0., 0.], [50., 0., 0.], [0., 50., 0.]]),
                id
            ),
            Err(ToolError::BadDiameter { value: 0.0 })
        );
        assert!(matches!(
            Tool::new(
                "t".into(),
                10.0,
                pts(&[[0., 0., 0.], [50., f64::NAN, 0.], [0., 50., 0.]]),
                id
            ),
            Err(ToolError::NotFinite { .. })
        ));
        assert!(
            Tool::new(
                "t".into(),
                10.0,
                pts(&[[0., 0., 0.], [50., 0., 0.], [0., 50., 0.]]),
                id
            )
            .is_ok()
        );
    }
}
