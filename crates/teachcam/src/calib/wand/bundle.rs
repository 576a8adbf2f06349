//! The wand as a [`Body`] of the rig bundle adjustment ([`crate::calib::bundle`]): a frame's
//! wand is 5 DOF (a collinear wand has no roll), marker 0 at `s` and the unit axis `d`, marker
//! k at `s + p_k d`, the positions `p_k` exact (they fix the scale).

use nalgebra::{SMatrix, SVector, Unit, Vector3};

use super::super::bundle::Body;
use crate::geometry::Point3;

/// One frame's wand: marker 0's position and the axis towards marker 2, reference frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct WandPose {
    /// Marker 0, millimetres.
    pub start: Point3,
    /// Unit axis.
    pub axis: Unit<Vector3<f64>>,
}

impl WandPose {
    /// Marker at `position_mm` along the axis.
    pub fn marker(&self, position_mm: f64) -> Point3 {
        self.start + self.axis.into_inner() * position_mm
    }
}

/// Two unit vectors completing `axis` to an orthonormal basis (a fixed function of the axis,
/// so the Jacobian and the retraction use the same one).
fn basis(axis: &Unit<Vector3<f64>>) -> (Vector3<f64>, Vector3<f64>) {
    let a = axis.into_inner();
    let helper = if a.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = a.cross(&helper).normalize();
    let e2 = a.cross(&e1);
    (e1, e2)
}

/// The wand's marker positions along its axis from marker 0, millimetres.
pub(super) struct WandBody {
    pub positions_mm: Vec<f64>,
}

impl Body<5> for WandBody {
    type Pose = WandPose;

    /// The step is `δs` (3), then the axis' tilts along the two basis vectors.
    fn marker(&self, pose: &WandPose, marker: usize) -> (Point3, SMatrix<f64, 3, 5>) {
        let p = self.positions_mm[marker];
        let (e1, e2) = basis(&pose.axis);
        let mut d = SMatrix::<f64, 3, 5>::zeros();
        d.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&nalgebra::Matrix3::identity());
        d.column_mut(3).copy_from(&(e1 * p));
        d.column_mut(4).copy_from(&(e2 * p));
        (pose.marker(p), d)
    }

    fn retract(&self, pose: &WandPose, step: &SVector<f64, 5>) -> WandPose {
        let (e1, e2) = basis(&pose.axis);
        WandPose {
            start: pose.start + Vector3::new(step[0], step[1], step[2]),
            axis: Unit::new_normalize(pose.axis.into_inner() + e1 * step[3] + e2 * step[4]),
        }
    }
}
