//! Mirror images of the tool in a shiny work object: found in the recording, then left out.
//!
//! Model. A flat shiny surface (a steel plate, a lacquered panel) under the working volume
//! shows every camera the markers' mirror images. Each camera sees marker `X` reflected at
//! the plane `n·x = d`, i.e. as if it stood at `X' = X − 2 (n·X − d) n`; the epipolar geometry
//! of the mirror images is consistent, so correspondence and triangulation make real 3-D
//! points of them, behind the plane. A mirror image of a planar tool (a triangle of three
//! markers) is congruent with the tool and registers with the residual of the real one: the
//! distances cannot tell them apart, and a frame whose real tool is partly hidden would be
//! posed on the ghost, hundreds of millimetres off, with status `ok`.
//!
//! The recording itself shows the plane. In a frame where the tool and its mirror image are
//! both complete, identification finds two labellings that fit the tool equally well (a
//! rival, [`crate::track::Lost::Ambiguous`]); marker by marker, the rival's point is the
//! reflection of the chosen one's through one plane: the differences `X'ₘ − Xₘ` are parallel
//! (along `n`) and the midpoints `(Xₘ + X'ₘ)/2` lie on the plane. Two copies of a tool placed
//! by hand are related by a rotation, not by such a pure reflection. [`learn_mirror`] fits
//! the plane of each rival pair, keeps pairs that a pure reflection explains within the
//! marker noise, and accepts the plane that at least [`MIN_MIRROR_FRAMES`] frames agree on,
//! with every camera on one side of it (cameras look into a mirror from its front).
//!
//! Nothing real is seen through a mirror: a 3-D point more than the noise behind the plane
//! (on the side away from the cameras) is a reflection, and tracking leaves it out before
//! identification ([`MirrorPlane::is_behind`]). With the ghost gone, the frames it made
//! ambiguous are posed, and the frames where only the ghost was complete are gaps.
//! The plane is taken as unbounded: a tool reaching past the plate's edge and below its plane
//! would be left out too (a brush paints on the object, above it).

use std::collections::BTreeMap;

use crate::camera::Rig;
use crate::geometry::{MarkerId, Point3, Vec3};
use crate::stats::median;
use crate::track::FrameTrack;

/// Fewest frames whose rival labellings must show one plane before it is taken as a mirror:
/// one or two could be a chance arrangement of two tools; a static plate shows itself in
/// every frame where the tool and its image are both complete.
pub const MIN_MIRROR_FRAMES: usize = 5;

/// A plane the recording shows mirror images through, world frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MirrorPlane {
    /// Unit normal, pointing to the cameras' side.
    pub normal: Vec3,
    /// Offset: the plane is `normal · x = offset_mm`.
    pub offset_mm: f64,
    /// How far behind the plane a point must be to be taken as a reflection, millimetres:
    /// the marker noise the plane was fitted with.
    pub margin_mm: f64,
    /// Frames whose tool and mirror image agreed on the plane.
    pub frames: usize,
    /// RMS distance of the fitted pairs from a pure reflection through the plane, mm.
    pub rms_mm: f64,
}

impl MirrorPlane {
    /// Signed distance of `point` from the plane, positive on the cameras' side, mm.
    #[must_use]
    pub fn signed_distance_mm(&self, point: &Point3) -> f64 {
        self.normal.dot(&point.coords) - self.offset_mm
    }

    /// Whether `point` lies behind the mirror by more than the margin: a mirror image.
    #[must_use]
    pub fn is_behind(&self, point: &Point3) -> bool {
        self.signed_distance_mm(point) < -self.margin_mm
    }
}

/// The plane of a pure reflection taking each marker of `a` to the same marker of `b`, with
/// the RMS of what it leaves unexplained (the difference vectors' parts across the normal
/// and the midpoints' distances from the plane), millimetres. `None` when the two share
/// fewer than three markers or coincide.
#[must_use]
pub fn reflection_between(
    a: &BTreeMap<MarkerId, Point3>,
    b: &BTreeMap<MarkerId, Point3>,
) -> Option<(Vec3, f64, f64)> {
    let pairs: Vec<(Point3, Point3)> = a
        .iter()
        .filter_map(|(m, pa)| Some((*pa, *b.get(m)?)))
        .collect();
    if pairs.len() < 3 {
        return None;
    }
    let sum: Vec3 = pairs.iter().map(|(pa, pb)| pb - pa).sum();
    let normal = sum.try_normalize(1e-9)?;
    let offsets: Vec<f64> = pairs
        .iter()
        .map(|(pa, pb)| normal.dot(&(0.5 * (pa.coords + pb.coords))))
        .collect();
    let offset = offsets.iter().sum::<f64>() / offsets.len() as f64;
    let residual = residual_mm(&pairs, &normal, offset);
    Some((normal, offset, residual))
}

/// RMS of what a reflection through `normal · x = offset` leaves of the pairs, mm.
fn residual_mm(pairs: &[(Point3, Point3)], normal: &Vec3, offset: f64) -> f64 {
    let squares: f64 = pairs
        .iter()
        .map(|(pa, pb)| {
            let d = pb - pa;
            let across = d - normal * normal.dot(&d);
            let midpoint = normal.dot(&(0.5 * (pa.coords + pb.coords))) - offset;
            across.norm_squared() + midpoint * midpoint
        })
        .sum();
    (squares / pairs.len() as f64).sqrt()
}

/// Why no mirror was taken from a recording.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NoMirror {
    /// Too few frames showed the tool and a mirror image of it.
    #[error(
        "{frames} frames show the tool and a mirror image of it; a mirror needs {MIN_MIRROR_FRAMES}"
    )]
    TooFewFrames {
        /// Frames with a reflected rival.
        frames: usize,
    },
    /// The frames' planes do not agree.
    #[error(
        "{agreeing} of {frames} frames with a reflected rival agree on one plane; a mirror needs {MIN_MIRROR_FRAMES}"
    )]
    Disagree {
        /// Frames on the consensus plane.
        agreeing: usize,
        /// Frames with a reflected rival.
        frames: usize,
    },
    /// Cameras on both sides of the plane: it is no mirror they look into.
    #[error("cameras on both sides of the plane the rivals show: no mirror")]
    CamerasOnBothSides,
}

/// The mirror plane the tracked frames show (see the module docs), `tolerance_mm` being the
/// marker noise (identification's distance tolerance): a rival pair is a reflection when a
/// plane explains it to within it.
///
/// # Errors
/// [`NoMirror`] saying why no plane was taken.
pub fn learn_mirror(
    rig: &Rig,
    tracks: &[FrameTrack],
    tolerance_mm: f64,
) -> Result<MirrorPlane, NoMirror> {
    let pairs: Vec<Vec<(Point3, Point3)>> = tracks
        .iter()
        .filter_map(|t| {
            let rival = t.rival_in_world.as_ref()?;
            let chosen = t.markers_in_world();
            let (_, _, residual) = reflection_between(&chosen, rival)?;
            (residual <= tolerance_mm).then(|| {
                chosen
                    .iter()
                    .filter_map(|(m, a)| Some((*a, *rival.get(m)?)))
                    .collect()
            })
        })
        .collect();
    if pairs.len() < MIN_MIRROR_FRAMES {
        return Err(NoMirror::TooFewFrames {
            frames: pairs.len(),
        });
    }
    // Orient every frame's normal to the cameras' side of its own plane, then take the
    // component-wise median as the consensus.
    let centres: Vec<Point3> = rig.cameras.iter().map(|c| c.center_in_world()).collect();
    let planes: Vec<(Vec3, f64)> = pairs
        .iter()
        .filter_map(|p| {
            let (normal, offset) = fit(p)?;
            let (normal, offset) = toward(&centres, normal, offset)?;
            Some((normal, offset))
        })
        .collect();
    if planes.len() < MIN_MIRROR_FRAMES {
        return Err(NoMirror::CamerasOnBothSides);
    }
    let component = |i: usize| median(&planes.iter().map(|(n, _)| n[i]).collect::<Vec<_>>());
    let (Some(x), Some(y), Some(z)) = (component(0), component(1), component(2)) else {
        return Err(NoMirror::TooFewFrames { frames: 0 });
    };
    let Some(normal) = Vec3::new(x, y, z).try_normalize(1e-9) else {
        return Err(NoMirror::Disagree {
            agreeing: 0,
            frames: pairs.len(),
        });
    };
    let offset = median(&planes.iter().map(|(_, o)| *o).collect::<Vec<_>>()).unwrap_or(0.0);
    let agreeing: Vec<(Point3, Point3)> = pairs
        .iter()
        .filter(|p| residual_mm(p, &normal, offset) <= tolerance_mm)
        .flatten()
        .copied()
        .collect();
    let frames = pairs
        .iter()
        .filter(|p| residual_mm(p, &normal, offset) <= tolerance_mm)
        .count();
    if frames < MIN_MIRROR_FRAMES {
        return Err(NoMirror::Disagree {
            agreeing: frames,
            frames: pairs.len(),
        });
    }
    let (normal, offset) = fit(&agreeing)
        .and_then(|(n, o)| toward(&centres, n, o))
        .ok_or(NoMirror::CamerasOnBothSides)?;
    Ok(MirrorPlane {
        normal,
        offset_mm: offset,
        margin_mm: tolerance_mm,
        frames,
        rms_mm: residual_mm(&agreeing, &normal, offset),
    })
}

/// Least-squares plane of a set of reflected pairs: the normal along the mean difference
/// (each pair oriented like the first), the offset through the mean midpoint.
fn fit(pairs: &[(Point3, Point3)]) -> Option<(Vec3, f64)> {
    let first = pairs.first().map(|(a, b)| b - a)?;
    let sum: Vec3 = pairs
        .iter()
        .map(|(a, b)| {
            let d = b - a;
            if d.dot(&first) < 0.0 { -d } else { d }
        })
        .sum();
    let normal = sum.try_normalize(1e-9)?;
    let offset = pairs
        .iter()
        .map(|(a, b)| normal.dot(&(0.5 * (a.coords + b.coords))))
        .sum::<f64>()
        / pairs.len() as f64;
    Some((normal, offset))
}

/// The plane's normal and offset oriented so that every camera centre is in front; `None`
/// when cameras are on both sides.
fn toward(centres: &[Point3], normal: Vec3, offset: f64) -> Option<(Vec3, f64)> {
    let sides: Vec<f64> = centres
        .iter()
        .map(|c| normal.dot(&c.coords) - offset)
        .collect();
    if sides.iter().all(|s| *s > 0.0) {
        Some((normal, offset))
    } else if sides.iter().all(|s| *s < 0.0) {
        Some((-normal, -offset))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reflect(p: Point3, normal: &Vec3, offset: f64) -> Point3 {
        p - normal * (2.0 * (normal.dot(&p.coords) - offset))
    }

    fn triangle() -> BTreeMap<MarkerId, Point3> {
        [
            Point3::new(10.0, 0.0, 50.0),
            Point3::new(150.0, 20.0, 80.0),
            Point3::new(30.0, 90.0, 60.0),
        ]
        .into_iter()
        .enumerate()
        .map(|(i, p)| (MarkerId(i), p))
        .collect()
    }

    #[test]
    fn a_mirror_image_is_a_pure_reflection_and_a_copy_is_not() {
        let normal = Vec3::new(0.1, -0.2, 1.0).normalize();
        let real = triangle();
        let ghost: BTreeMap<MarkerId, Point3> = real
            .iter()
            .map(|(m, p)| (*m, reflect(*p, &normal, -350.0)))
            .collect();
        let (n, offset, residual) = reflection_between(&real, &ghost).unwrap();
        assert!((n.dot(&normal).abs() - 1.0).abs() < 1e-12);
        assert!((offset.abs() - 350.0).abs() < 1e-9, "{offset}");
        assert!(residual < 1e-9, "{residual}");
        // A second copy of the tool, turned by 40° and moved: no plane explains it. (Some
        // copies come close to a reflection; hence a mirror needs several frames to agree.)
        let axis = nalgebra::Unit::new_normalize(Vec3::new(1.0, 1.0, 0.3));
        let turn = nalgebra::Rotation3::from_axis_angle(&axis, 0.7);
        let copy: BTreeMap<MarkerId, Point3> = real
            .iter()
            .map(|(m, p)| (*m, turn * p + Vec3::new(80.0, -40.0, -500.0)))
            .collect();
        let (_, _, residual) = reflection_between(&real, &copy).unwrap();
        assert!(residual > 10.0, "{residual}");
    }

    #[test]
    fn behind_is_the_side_away_from_the_cameras() {
        let plane = MirrorPlane {
            normal: Vec3::z(),
            offset_mm: -350.0,
            margin_mm: 2.0,
            frames: 5,
            rms_mm: 0.1,
        };
        assert!(!plane.is_behind(&Point3::new(0.0, 0.0, 0.0)));
        assert!(!plane.is_behind(&Point3::new(0.0, 0.0, -351.0)));
        assert!(plane.is_behind(&Point3::new(0.0, 0.0, -353.0)));
        assert!((plane.signed_distance_mm(&Point3::new(5.0, 5.0, -300.0)) - 50.0).abs() < 1e-12);
    }
}
