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

pub mod frame;

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
    let tracker = Tracker::new(rig, tool, config.clone());
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

/// The pixel error per image coordinate that triangulation residuals show, pooled over
/// `points`: `σ̂² = Σ n r² / Σ (2n − 3)`, for each point seen in `n ≥ 2` views with RMS
/// reprojection residual `r` (its `2n` coordinates fit 3 unknowns). Unlike a blob's own
/// `center_std_px`, which holds its image noise only, it holds everything that moves a centre
/// off the marker's true projection where the cameras can see it: noise, detector bias,
/// calibration error. `None` without a redundant view.
#[must_use]
pub fn residual_noise_px<'a>(
    points: impl IntoIterator<Item = &'a crate::triangulate::TriangulatedPoint>,
) -> Option<f64> {
    let (squares, freedom) = points
        .into_iter()
        .filter(|p| p.views.len() >= 2 && p.residual_px.is_finite())
        .fold((0.0, 0usize), |(squares, freedom), p| {
            let n = p.views.len();
            (
                squares + n as f64 * p.residual_px * p.residual_px,
                freedom + 2 * n - 3,
            )
        });
    (freedom > 0).then(|| (squares / freedom as f64).sqrt())
}

/// One cell of an uncertainty map.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MapCell {
    /// Where the tool's origin is, world frame, millimetres.
    pub position: [f64; 3],
    /// First-order RMS tip error there with every camera, `None` where the tool is not seen
    /// well enough to be tracked.
    pub tip_rms_mm: Option<f64>,
    /// The largest first-order RMS tip error with any one camera left out, `None` where some
    /// camera is indispensable (the paper asks that the rig work with one camera missing).
    pub tip_rms_one_camera_dropped_mm: Option<f64>,
}

/// First-order tip uncertainty over a grid of tool positions at one orientation: where to
/// work, where not.
#[must_use]
pub fn uncertainty_map(
    rig: &Rig,
    tool: &Tool,
    orientation: &nalgebra::UnitQuaternion<f64>,
    positions: &[Point3],
    noise_px: f64,
) -> Vec<MapCell> {
    positions
        .par_iter()
        .map(|p| {
            let pose = crate::geometry::pose_from_parts(p.coords, *orientation);
            let tip_rms_mm = first_order(rig, tool, &pose, noise_px)
                .ok()
                .map(|u| u.tip_rms_mm);
            let dropped: Option<Vec<f64>> = (0..rig.len())
                .map(|leave_out| {
                    let mut fewer = rig.clone();
                    fewer.cameras.remove(leave_out);
                    first_order(&fewer, tool, &pose, noise_px)
                        .ok()
                        .map(|u| u.tip_rms_mm)
                })
                .collect();
            MapCell {
                position: [p.x, p.y, p.z],
                tip_rms_mm,
                tip_rms_one_camera_dropped_mm: dropped.and_then(|d| d.into_iter().reduce(f64::max)),
            }
        })
        .collect()
}

/// What a tool's marker layout promises, before any recording.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ToolDesign {
    /// The two marker pairs whose distances are closest, and that gap, millimetres: the
    /// identification safety margin.
    pub closest_distances: ClosestDistances,
    /// The gap as a multiple of the identification tolerance: below 2 the tool is refused,
    /// below 4 it is marginal.
    pub gap_over_tolerance: f64,
    /// Fitzpatrick–West–Maurer target-registration-error factor: expected RMS tip error per
    /// unit RMS marker localisation error, `sqrt((1 + Σ d_k²/(3 f_k²)) / N)`.
    pub tip_error_per_marker_error: f64,
    /// RMS distance of the markers from their centroid, millimetres.
    pub marker_spread_mm: f64,
    /// Distance from the markers' centroid to the tip, millimetres.
    pub tip_distance_mm: f64,
    /// Plain-language warnings (marginal gaps, a tip far outside the cluster).
    pub warnings: Vec<String>,
}

/// The closest pair of marker distances.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ClosestDistances {
    /// First pair of markers.
    pub pair_a: [usize; 2],
    /// Its distance, millimetres.
    pub distance_a_mm: f64,
    /// Second pair of markers.
    pub pair_b: [usize; 2],
    /// Its distance, millimetres.
    pub distance_b_mm: f64,
    /// Difference, millimetres.
    pub gap_mm: f64,
}

/// Checks a tool's layout: the identification margin (smallest difference between two marker
/// distances, against the tolerance) and the expected tip error per unit marker error
/// (Fitzpatrick, West & Maurer 1998, eq. 46).
#[must_use]
pub fn tool_design(tool: &Tool, distance_tolerance_mm: f64) -> ToolDesign {
    let m = &tool.markers_in_tool;
    let mut pairs = Vec::new();
    for i in 0..m.len() {
        for j in i + 1..m.len() {
            pairs.push(([i, j], (m[i] - m[j]).norm()));
        }
    }
    let mut closest = ClosestDistances {
        pair_a: [0, 0],
        distance_a_mm: 0.0,
        pair_b: [0, 0],
        distance_b_mm: 0.0,
        gap_mm: f64::INFINITY,
    };
    for (k, a) in pairs.iter().enumerate() {
        for b in &pairs[k + 1..] {
            let gap = (a.1 - b.1).abs();
            if gap < closest.gap_mm {
                closest = ClosestDistances {
                    pair_a: a.0,
                    distance_a_mm: a.1,
                    pair_b: b.0,
                    distance_b_mm: b.1,
                    gap_mm: gap,
                };
            }
        }
    }
    let n = m.len() as f64;
    let centroid = m.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let mut scatter = Matrix3::zeros();
    for p in m {
        let r = p.coords - centroid;
        scatter += r * r.transpose();
    }
    let eigen = scatter.symmetric_eigen();
    let tip = tool.tip_in_tool().coords - centroid;
    let total: f64 = m.iter().map(|p| (p.coords - centroid).norm_squared()).sum();
    let mut sum = 0.0;
    for k in 0..3 {
        let axis = eigen.eigenvectors.column(k);
        // d_k: distance of the tip from principal axis k; f_k: RMS distance of the markers from it.
        let d_sq = tip.norm_squared() - tip.dot(&axis).powi(2);
        let f_sq = (total - eigen.eigenvalues[k]) / n;
        if f_sq > 0.0 {
            sum += d_sq / f_sq;
        }
    }
    let factor = ((1.0 + sum / 3.0) / n).sqrt();
    let gap_over_tolerance = closest.gap_mm / distance_tolerance_mm;
    let marker_spread_mm = (total / n).sqrt();
    let tip_distance_mm = tip.norm();
    let mut warnings = Vec::new();
    if gap_over_tolerance < 2.0 {
        warnings.push(format!("distances {:?} and {:?} differ by {:.2} mm, under twice the {distance_tolerance_mm} mm tolerance: the tool will be refused", closest.pair_a, closest.pair_b, closest.gap_mm));
    } else if gap_over_tolerance < 4.0 {
        warnings.push(format!("distances {:?} and {:?} differ by only {:.2} mm: identification is marginal under noise", closest.pair_a, closest.pair_b, closest.gap_mm));
    }
    if tip_distance_mm > 2.0 * marker_spread_mm {
        warnings.push(format!("the tip is {tip_distance_mm:.0} mm from the markers' centre, {:.1}x their spread: rotation noise is amplified at the tip", tip_distance_mm / marker_spread_mm));
    }
    ToolDesign {
        closest_distances: closest,
        gap_over_tolerance,
        tip_error_per_marker_error: factor,
        marker_spread_mm,
        tip_distance_mm,
        warnings,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Scenario, build_scene};

    #[test]
    fn tool_design_matches_closed_forms() {
        // Four markers on a square of side 2a around the origin, tip on the normal axis at h:
        // f² = a² for the two in-plane axes, 2a² for the normal; d² = h² for the in-plane axes,
        // 0 for the normal: factor² = (1 + (h²/a² + h²/a²)/3) / 4.
        let (a, h) = (40.0, 150.0);
        let markers = vec![
            Point3::new(a, a, 0.0),
            Point3::new(-a, a, 0.0),
            Point3::new(-a, -a, 0.0),
            Point3::new(a, -a, 0.0),
        ];
        let tcp = crate::geometry::pose_from_parts(
            Vector3::new(0.0, 0.0, h),
            nalgebra::UnitQuaternion::identity(),
        );
        let tool = Tool::new("square".into(), 10.0, markers, tcp).unwrap();
        let design = tool_design(&tool, 0.3);
        let expected = ((1.0 + 2.0 * h * h / (a * a) / 3.0) / 4.0_f64).sqrt();
        assert!((design.tip_error_per_marker_error - expected).abs() < 1e-12);
        // A square has equal sides: the identification gap is zero and the tool is flagged.
        assert_eq!(design.closest_distances.gap_mm, 0.0);
        assert!(design.warnings[0].contains("refused"));
    }

    #[test]
    fn map_cells_outside_the_views_are_gaps() {
        let scene = build_scene(Scenario::Paper, 1);
        let rotation = scene.truth.samples[0]
            .pose
            .map(|p| p.world_from_tool.rotation)
            .unwrap_or_default();
        let cells = uncertainty_map(
            &scene.rig,
            &scene.tool,
            &rotation,
            &[Point3::new(0.0, 0.0, 180.0), Point3::new(0.0, 0.0, 5000.0)],
            0.15,
        );
        assert!(cells[0].tip_rms_mm.is_some_and(|v| v > 0.0 && v < 1.0));
        assert!(
            cells[0]
                .tip_rms_one_camera_dropped_mm
                .is_some_and(|v| v > cells[0].tip_rms_mm.unwrap_or(0.0))
        );
        assert!(cells[1].tip_rms_mm.is_none());
    }

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
