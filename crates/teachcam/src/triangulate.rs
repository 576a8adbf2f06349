//! Triangulation: the 3-D point seen by several cameras.
//!
//! Linear step: the point closest to all viewing rays in the least-squares sense,
//! `Σ (I - dᵢdᵢᵀ) X = Σ (I - dᵢdᵢᵀ) cᵢ` for rays from centres `cᵢ` along unit `dᵢ` (the
//! multi-view midpoint). Refinement: Gauss–Newton on the reprojection error in pixels through
//! the full lens model, which is the maximum-likelihood estimate under isotropic pixel noise
//! (Hartley & Zisserman, *Multiple View Geometry*, §12.3). The per-point RMS reprojection
//! residual is kept: it is the stage's evidence that the views belong together.
//!
//! Outlier views ([`triangulate_leaving_one_out`]): a point seen by three or more cameras whose
//! residual is beyond the gate is triangulated again without each view in turn; when leaving
//! one out brings the residual within the gate, that view is the one that disagrees (a merged
//! or reflected blob, a camera off its calibration) and is dropped.

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Vector3};

use crate::camera::{Rig, pixel_difference};
use crate::geometry::{CameraId, Pixel, Point3};

/// Options of the triangulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangulateConfig {
    /// Largest RMS reprojection residual of an accepted point, pixels: well above the
    /// residual of true matches (detection noise, ≤ 0.1 px; calibration error, ≤ 0.3 px) and
    /// below what a wrong match leaves.
    pub max_residual_px: f64,
    /// Gauss–Newton iterations (it converges in 2–3 from the linear start).
    pub iterations: usize,
    /// Smallest angle between two viewing rays, radians: nearly parallel rays give a point
    /// with no depth information (2°).
    pub min_ray_angle: f64,
}

impl Default for TriangulateConfig {
    fn default() -> Self {
        Self {
            max_residual_px: 1.0,
            iterations: 5,
            min_ray_angle: 2_f64.to_radians(),
        }
    }
}

/// A triangulated point with its evidence.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangulatedPoint {
    /// The point, world frame, millimetres.
    pub position: Point3,
    /// The pixel seen by each camera used.
    pub views: BTreeMap<CameraId, Pixel>,
    /// RMS reprojection residual over the views, pixels.
    pub residual_px: f64,
}

/// Why views do not make a point.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TriangulateError {
    /// Fewer than two usable views.
    #[error("{count} usable views; triangulation needs 2")]
    TooFewViews {
        /// Views that could be unprojected.
        count: usize,
    },
    /// The rays are (nearly) parallel.
    #[error("viewing rays are within {angle_deg:.2} degrees of parallel")]
    ParallelRays {
        /// Largest angle between two rays, degrees.
        angle_deg: f64,
    },
    /// The point lands behind a camera.
    #[error("the point is behind {camera}")]
    BehindCamera {
        /// The camera.
        camera: CameraId,
    },
    /// The views do not agree on one point.
    #[error("reprojection residual {residual_px:.3} px exceeds {max_px} px")]
    Residual {
        /// RMS residual found.
        residual_px: f64,
        /// The limit.
        max_px: f64,
    },
}

/// Triangulates one point from its pixels in several cameras.
///
/// # Errors
/// [`TriangulateError`] when the views do not define a point or do not agree on one.
pub fn triangulate(
    rig: &Rig,
    views: &BTreeMap<CameraId, Pixel>,
    config: &TriangulateConfig,
) -> Result<TriangulatedPoint, TriangulateError> {
    let rays: Vec<_> = views
        .iter()
        .filter_map(|(id, px)| rig.camera(*id)?.unproject(px).ok())
        .collect();
    if rays.len() < 2 {
        return Err(TriangulateError::TooFewViews { count: rays.len() });
    }
    let mut widest = 0.0_f64;
    for (i, a) in rays.iter().enumerate() {
        for b in &rays[i + 1..] {
            widest = widest.max(a.direction.dot(&b.direction).clamp(-1.0, 1.0).acos());
        }
    }
    if widest < config.min_ray_angle {
        return Err(TriangulateError::ParallelRays {
            angle_deg: widest.to_degrees(),
        });
    }
    let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
    for ray in &rays {
        let d = ray.direction.into_inner();
        let projector = Matrix3::identity() - d * d.transpose();
        a += projector;
        b += projector * ray.origin.coords;
    }
    let Some(solution) = a.lu().solve(&b) else {
        return Err(TriangulateError::ParallelRays {
            angle_deg: widest.to_degrees(),
        });
    };
    let mut position = Point3::from(solution);
    for _ in 0..config.iterations {
        let (mut normal, mut gradient) = (Matrix3::zeros(), Vector3::zeros());
        for (id, px) in views {
            let Some(camera) = rig.camera(*id) else {
                continue;
            };
            let (Some(projected), Some(jacobian)) = (
                camera.project(&position),
                camera.projection_jacobian(&position),
            ) else {
                return Err(TriangulateError::BehindCamera { camera: *id });
            };
            let residual = pixel_difference(&projected, px);
            normal += jacobian.transpose() * jacobian;
            gradient += jacobian.transpose() * residual;
        }
        let Some(step) = normal.lu().solve(&gradient) else {
            break;
        };
        position -= step;
        if step.norm() < 1e-9 {
            break;
        }
    }
    let mut squared = 0.0;
    for (id, px) in views {
        let Some(camera) = rig.camera(*id) else {
            continue;
        };
        let projected = camera
            .project(&position)
            .ok_or(TriangulateError::BehindCamera { camera: *id })?;
        squared += pixel_difference(&projected, px).norm_squared();
    }
    let residual_px = (squared / views.len() as f64).sqrt();
    if residual_px > config.max_residual_px {
        return Err(TriangulateError::Residual {
            residual_px,
            max_px: config.max_residual_px,
        });
    }
    Ok(TriangulatedPoint {
        position,
        views: views.clone(),
        residual_px,
    })
}

/// A point from [`triangulate_leaving_one_out`], and the view it dropped.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustPoint {
    /// The point from the views kept.
    pub point: TriangulatedPoint,
    /// The camera whose view was left out, if one was.
    pub dropped: Option<CameraId>,
    /// The residual with every view, pixels, when a view was dropped.
    pub residual_with_all_px: Option<f64>,
}

/// [`triangulate`]; when the residual is beyond the gate and three or more views remain, the
/// view whose removal leaves the smallest residual is dropped if that brings the residual
/// within the gate (see the module docs).
///
/// # Errors
/// As [`triangulate`] with every view, when no single view explains the misfit.
pub fn triangulate_leaving_one_out(
    rig: &Rig,
    views: &BTreeMap<CameraId, Pixel>,
    config: &TriangulateConfig,
) -> Result<RobustPoint, TriangulateError> {
    let all = match triangulate(rig, views, config) {
        Ok(point) => {
            return Ok(RobustPoint {
                point,
                dropped: None,
                residual_with_all_px: None,
            });
        }
        Err(e) => e,
    };
    let TriangulateError::Residual { residual_px, .. } = all else {
        return Err(all);
    };
    if views.len() < 3 {
        return Err(all);
    }
    let best = views
        .keys()
        .filter_map(|left_out| {
            let mut kept = views.clone();
            kept.remove(left_out);
            triangulate(rig, &kept, config)
                .ok()
                .map(|point| (*left_out, point))
        })
        .min_by(|a, b| a.1.residual_px.total_cmp(&b.1.residual_px));
    match best {
        Some((camera, point)) => Ok(RobustPoint {
            point,
            dropped: Some(camera),
            residual_with_all_px: Some(residual_px),
        }),
        None => Err(all),
    }
}
