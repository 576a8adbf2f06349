//! Metrology: how pixel noise becomes tool-tip uncertainty (paper §IV).
//!
//! Monte Carlo (paper §IV-B, GUM Supplement 1): project the markers of a tool at a known pose
//! into every camera, add Gaussian noise of σ pixels to each coordinate, and run the *real*
//! tracking chain ([`crate::track::Tracker::track_frame`]: correspondence, triangulation,
//! identification, registration); the scatter of the results is the uncertainty.
//!
//! First-order propagation of the same noise, in closed form:
//! - each triangulated point: `Σ_X = σ² (Σ_c J_cᵀ J_c)⁻¹` with `J_c` the projection Jacobian of
//!   camera `c` at the point (the Gauss–Newton normal matrix of [`crate::triangulate`]);
//! - registration (unweighted least squares over the markers, as the SVD solves it): with
//!   `x_i = R m_i + t`, a small world-frame rotation `δθ` and translation `δt` move `x_i` by
//!   `A_i [δθ; δt]`, `A_i = [-[R m_i]× | I]`; so `Σ_pose = (AᵀA)⁻¹ Aᵀ Σ_X A (AᵀA)⁻¹`;
//! - the tip `p = R p_tip + t`: `Σ_tip = B Σ_pose Bᵀ`, `B = [-[R p_tip]× | I]`.
//!
//! Rotation uncertainty is given about the world axes (the rotation vector of
//! `R_measured R_trueᵀ`), in degrees.

use nalgebra::{Matrix3, Matrix6, SMatrix, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;

use crate::camera::Rig;
use crate::correspond::Views;
use crate::geometry::{CameraId, Pixel, Point3, Pose};
use crate::tool::Tool;
use crate::track::{TrackConfig, Tracker};

/// Why an uncertainty cannot be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MetrologyError {
    /// Non-positive or non-finite pixel noise.
    #[error("pixel noise must be a positive number of pixels, got {0}")]
    BadNoise(f64),
    /// Zero trials.
    #[error("the number of trials must be at least 2")]
    TooFewTrials,
    /// Fewer than three markers are seen by two cameras at this pose.
    #[error("at this pose only {seen} markers are seen by two cameras or more; a pose needs 3")]
    NotVisible {
        /// Markers seen by at least two cameras.
        seen: usize,
    },
    /// Every trial failed.
    #[error("every one of the {trials} trials failed to track the tool")]
    AllTrialsFailed {
        /// Trials run.
        trials: usize,
    },
}

/// Standard uncertainties of a tool pose and its tip.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Uncertainty {
    /// Standard deviation of the tip along world x, y, z, millimetres.
    pub tip_std_mm: [f64; 3],
    /// RMS 3-D tip error, millimetres (`sqrt` of the trace of the tip covariance, plus bias² for
    /// Monte Carlo).
    pub tip_rms_mm: f64,
    /// Standard deviation of the tool frame's origin along world x, y, z, millimetres.
    pub position_std_mm: [f64; 3],
    /// Standard deviation of the rotation about world x, y, z, degrees.
    pub rotation_std_deg: [f64; 3],
}

/// Monte Carlo result: the uncertainty with the trial counts and the mean tip error.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MonteCarlo {
    /// The scatter of successful trials.
    pub uncertainty: Uncertainty,
    /// Trials run.
    pub trials: usize,
    /// Trials in which tracking gave no pose.
    pub failed_trials: usize,
    /// Mean tip error (bias) along world x, y, z, millimetres.
    pub tip_bias_mm: [f64; 3],
}

/// The markers' exact pixels at a pose, per camera, for markers inside the image.
#[must_use]
pub fn marker_views(
    rig: &Rig,
    tool: &Tool,
    world_from_tool: &Pose,
) -> Vec<(CameraId, usize, Pixel)> {
    let mut out = Vec::new();
    for (id, camera) in rig.iter() {
        for (m, marker) in tool.markers() {
            if let Some(px) = camera
                .project(&(world_from_tool * marker))
                .filter(|p| camera.image_size.contains(p))
            {
                out.push((id, m.0, px));
            }
        }
    }
    out
}

fn markers_seen_twice(views: &[(CameraId, usize, Pixel)], markers: usize) -> usize {
    (0..markers)
        .filter(|m| views.iter().filter(|v| v.1 == *m).count() >= 2)
        .count()
}

fn check_inputs(
    rig: &Rig,
    tool: &Tool,
    world_from_tool: &Pose,
    noise_px: f64,
) -> Result<Vec<(CameraId, usize, Pixel)>, MetrologyError> {
    if !(noise_px.is_finite() && noise_px > 0.0) {
        return Err(MetrologyError::BadNoise(noise_px));
    }
    let views = marker_views(rig, tool, world_from_tool);
    let seen = markers_seen_twice(&views, tool.markers_in_tool.len());
    if seen < 3 {
        return Err(MetrologyError::NotVisible { seen });
    }
    Ok(views)
}

/// One Monte Carlo trial's errors against the true pose.
#[derive(Debug, Clone, Copy)]
struct TrialError {
    /// Tip error, world frame, millimetres.
    tip: Vector3<f64>,
    /// Tool-origin error, world frame, millimetres.
    origin: Vector3<f64>,
    /// Rotation error vector, world frame, radians.
    rotation: Vector3<f64>,
}

/// World-frame rotation vector of `measured · trueᵀ`.
fn rotation_error(measured: &Pose, truth: &Pose) -> Vector3<f64> {
    (measured.rotation * truth.rotation.inverse()).scaled_axis()
}

fn std_of(samples: &[Vector3<f64>]) -> ([f64; 3], Vector3<f64>) {
    let n = samples.len() as f64;
    let mean = samples.iter().sum::<Vector3<f64>>() / n;
    let var = samples
        .iter()
        .map(|s| (s - mean).component_mul(&(s - mean)))
        .sum::<Vector3<f64>>()
        / (n - 1.0).max(1.0);
    ([var.x.sqrt(), var.y.sqrt(), var.z.sqrt()], mean)
}

/// Monte Carlo through the real tracking chain: `trials` noisy copies of the markers' pixels,
/// each tracked like a recorded frame. Deterministic for a seed whatever the thread count
/// (trials are drawn in fixed chunks, each from its own stream).
///
/// # Errors
/// [`MetrologyError`] for bad noise, fewer than two trials, a pose where the tool is not seen,
/// or when every trial fails.
pub fn monte_carlo(
    rig: &Rig,
    tool: &Tool,
    world_from_tool: &Pose,
    noise_px: f64,
    trials: usize,
    seed: u64,
    config: &TrackConfig,
) -> Result<MonteCarlo, MetrologyError> {
    if trials < 2 {
        return Err(MetrologyError::TooFewTrials);
    }
    let views = check_inputs(rig, tool, world_from_tool, noise_px)?;
    let tracker = Tracker::new(rig, tool, *config);
    let tip_true = world_from_tool * tool.tip_in_tool();
    let noise = Normal::new(0.0, noise_px).map_err(|_| MetrologyError::BadNoise(noise_px))?;
    const CHUNK: usize = 256;
    let chunks: Vec<Vec<Option<TrialError>>> = (0..trials.div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut rng = ChaCha8Rng::seed_from_u64(
                seed ^ (chunk as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
            );
            let count = CHUNK.min(trials - chunk * CHUNK);
            (0..count)
                .map(|_| -> Option<TrialError> {
                    let mut frame = Views::new();
                    for (camera, _, px) in &views {
                        let noisy = Pixel::new(
                            px.x + noise.sample(&mut rng),
                            px.y + noise.sample(&mut rng),
                        );
                        frame.entry(*camera).or_default().push(noisy);
                    }
                    let pose = tracker.track_frame(&frame).outcome.ok()?;
                    Some(TrialError {
                        tip: pose.tip_in_world - tip_true,
                        origin: pose.world_from_tool.translation.vector
                            - world_from_tool.translation.vector,
                        rotation: rotation_error(&pose.world_from_tool, world_from_tool),
                    })
                })
                .collect()
        })
        .collect();
    let results: Vec<_> = chunks.into_iter().flatten().collect();
    let ok: Vec<_> = results.iter().flatten().collect();
    if ok.len() < 2 {
        return Err(MetrologyError::AllTrialsFailed { trials });
    }
    let tips: Vec<Vector3<f64>> = ok.iter().map(|r| r.tip).collect();
    let origins: Vec<Vector3<f64>> = ok.iter().map(|r| r.origin).collect();
    let rotations: Vec<Vector3<f64>> = ok.iter().map(|r| r.rotation).collect();
    let (tip_std_mm, tip_mean) = std_of(&tips);
    let (position_std_mm, _) = std_of(&origins);
    let (rotation_std, _) = std_of(&rotations);
    let tip_rms_mm =
        (tips.iter().map(Vector3::norm_squared).sum::<f64>() / tips.len() as f64).sqrt();
    Ok(MonteCarlo {
        uncertainty: Uncertainty {
            tip_std_mm,
            tip_rms_mm,
            position_std_mm,
            rotation_std_deg: rotation_std.map(f64::to_degrees),
        },
        trials,
        failed_trials: results.len() - ok.len(),
        tip_bias_mm: tip_mean.into(),
    })
}

/// Covariance of each marker's triangulated position from the cameras that see it.
fn marker_covariances(
    rig: &Rig,
    tool: &Tool,
    world_from_tool: &Pose,
    views: &[(CameraId, usize, Pixel)],
    noise_px: f64,
) -> Vec<Option<Matrix3<f64>>> {
    (0..tool.markers_in_tool.len())
        .map(|m| {
            let point = world_from_tool * tool.markers_in_tool[m];
            let mut normal = Matrix3::zeros();
            let mut count = 0;
            for (camera, _, _) in views.iter().filter(|v| v.1 == m) {
                let j = rig.camera(*camera)?.projection_jacobian(&point)?;
                normal += j.transpose() * j;
                count += 1;
            }
            (count >= 2)
                .then(|| normal.try_inverse().map(|inv| inv * noise_px * noise_px))
                .flatten()
        })
        .collect()
}

/// First-order (linearised) uncertainty of the same chain as [`monte_carlo`], in closed form;
/// microseconds per pose, so it can annotate every tracked frame.
///
/// # Errors
/// [`MetrologyError`] for bad noise or a pose where the tool is not seen.
pub fn first_order(
    rig: &Rig,
    tool: &Tool,
    world_from_tool: &Pose,
    noise_px: f64,
) -> Result<Uncertainty, MetrologyError> {
    let views = check_inputs(rig, tool, world_from_tool, noise_px)?;
    let covariances = marker_covariances(rig, tool, world_from_tool, &views, noise_px);
    let rotation = world_from_tool.rotation;
    let lever = |p: &Point3| -> SMatrix<f64, 3, 6> {
        let arm = rotation * p.coords;
        let mut a = SMatrix::<f64, 3, 6>::zeros();
        a.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(-arm.cross_matrix()));
        a.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&Matrix3::identity());
        a
    };
    let (mut ata, mut middle) = (Matrix6::zeros(), Matrix6::zeros());
    for (marker, covariance) in tool.markers_in_tool.iter().zip(&covariances) {
        let Some(covariance) = covariance else {
            continue;
        };
        let a = lever(marker);
        ata += a.transpose() * a;
        middle += a.transpose() * covariance * a;
    }
    let inverse = ata
        .try_inverse()
        .ok_or(MetrologyError::NotVisible { seen: 0 })?;
    let pose_covariance = inverse * middle * inverse;
    let b = lever(&tool.tip_in_tool());
    let tip = b * pose_covariance * b.transpose();
    let diag_sqrt = |m: &Matrix3<f64>| [m[(0, 0)].sqrt(), m[(1, 1)].sqrt(), m[(2, 2)].sqrt()];
    let rotation_block: Matrix3<f64> = pose_covariance.fixed_view::<3, 3>(0, 0).into();
    let position_block: Matrix3<f64> = pose_covariance.fixed_view::<3, 3>(3, 3).into();
    Ok(Uncertainty {
        tip_std_mm: diag_sqrt(&tip),
        tip_rms_mm: tip.trace().sqrt(),
        position_std_mm: diag_sqrt(&position_block),
        rotation_std_deg: diag_sqrt(&rotation_block).map(f64::to_degrees),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Scenario, build_scene};

    #[test]
    fn bad_inputs_are_refused() {
        let scene = build_scene(Scenario::Paper, 1);
        let pose = scene.truth.samples[0]
            .pose
            .map(|p| p.world_from_tool)
            .unwrap_or_else(Pose::identity);
        let config = TrackConfig::default();
        assert_eq!(
            monte_carlo(&scene.rig, &scene.tool, &pose, 0.0, 10, 1, &config),
            Err(MetrologyError::BadNoise(0.0))
        );
        assert_eq!(
            monte_carlo(&scene.rig, &scene.tool, &pose, 0.1, 0, 1, &config),
            Err(MetrologyError::TooFewTrials)
        );
        let away = crate::geometry::pose_from_parts(Vector3::new(0.0, 0.0, 5000.0), pose.rotation);
        assert!(matches!(
            first_order(&scene.rig, &scene.tool, &away, 0.1),
            Err(MetrologyError::NotVisible { .. })
        ));
    }
}
