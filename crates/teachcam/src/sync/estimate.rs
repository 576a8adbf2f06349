//! The offsets' estimate: a coarse search per camera against the reference, then Gauss–Newton
//! over all cameras' offsets on the epipolar residuals of matched blobs, and the σ.
//!
//! Residual of a match between cameras `a` and `b` in frame `f`: the signed distance, in `b`'s
//! ideal pixels, of `b`'s track at `f − δ_b / T` from the epipolar line of `a`'s track at
//! `f − δ_a / T` (`T` the frame period). Matches are made afresh at every iteration: mutual
//! nearest to each other's epipolar line, within the cap, with the runner-up clearly farther.
//! The Gauss–Newton normal equations are Huber-weighted (scale from the residuals' MAD), their
//! inverse scaled by the residual variance gives the curvature σ, and the scatter of the
//! offsets fitted on contiguous segments of the recording inflates it by the Birge ratio
//! `√(χ²/(K−1))` when the segments disagree more than that σ allows (drift, systematic
//! interpolation error).

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::tracks::{BlobTrack, Stencil, TrackSample, nearest_two};
use super::{CameraOffset, SyncConfig, SyncError, SyncEstimate};
use crate::geometry::{CameraId, Pixel};

/// One camera's tracks in ideal pixels, with the tracks that cover each frame.
#[derive(Debug)]
pub(super) struct CameraTracks {
    pub(super) tracks: Vec<BlobTrack>,
    covering: Vec<Vec<usize>>,
    interpolation_points: usize,
}

impl CameraTracks {
    pub(super) fn new(
        tracks: Vec<BlobTrack>,
        frame_count: usize,
        interpolation_points: usize,
    ) -> Self {
        let mut covering = vec![Vec::new(); frame_count];
        for (i, t) in tracks.iter().enumerate() {
            for frame in covering
                .iter_mut()
                .take(t.last_frame() + 1)
                .skip(t.first_frame)
            {
                frame.push(i);
            }
        }
        Self {
            tracks,
            covering,
            interpolation_points,
        }
    }

    /// Every track's position at the fractional frame `at`, with the track's index: only
    /// exact samples and those interpolated through the most points, centred, so that every residual carries the same order of
    /// interpolation error whatever the offset.
    fn samples(&self, at: f64) -> Vec<(usize, Pixel)> {
        if at.is_nan() || at < 0.0 {
            return Vec::new();
        }
        let Some(candidates) = self.covering.get(at.floor() as usize) else {
            return Vec::new();
        };
        candidates
            .iter()
            .filter_map(|&i| Some((i, self.sample(i, at)?.position)))
            .collect()
    }

    fn sample(&self, track: usize, at: f64) -> Option<TrackSample> {
        let most = self.interpolation_points;
        let sample = self.tracks.get(track)?.sample(at, most)?;
        let consistent = match sample.stencil {
            Stencil::Exact => true,
            Stencil::Polynomial { points, centred } => points == most && centred,
        };
        consistent.then_some(sample)
    }
}

/// Signed distance of `to` (ideal pixel) from the epipolar line of `from`, pixels.
fn signed_distance(fundamental: &Matrix3<f64>, from: &Pixel, to: &Pixel) -> Option<f64> {
    let l = fundamental * Vector3::new(from.x, from.y, 1.0);
    let norm = l.x.hypot(l.y);
    let d = (l.x * to.x + l.y * to.y + l.z) / norm;
    (norm > f64::EPSILON && d.is_finite()).then_some(d)
}

/// A blob of camera `a` and one of camera `b` that show one marker in `frame`.
#[derive(Debug, Clone, Copy)]
struct Match {
    a: CameraId,
    track_a: usize,
    b: CameraId,
    track_b: usize,
    frame: usize,
}

/// Everything the estimate reads.
pub(super) struct Problem<'a> {
    pub(super) cameras: &'a BTreeMap<CameraId, CameraTracks>,
    pub(super) fundamental: Vec<Vec<Matrix3<f64>>>,
    pub(super) frame_count: usize,
    pub(super) reference: CameraId,
    pub(super) config: &'a SyncConfig,
}

/// Fractional frame index at which a camera shows the common time of frame `frame`.
fn local_frame(frame: usize, offset_periods: f64) -> f64 {
    frame as f64 - offset_periods
}

impl Problem<'_> {
    fn f(&self, a: CameraId, b: CameraId) -> &Matrix3<f64> {
        &self.fundamental[a.0][b.0]
    }

    /// The coarse cost of camera `camera` against the reference at an offset (periods): every
    /// reference blob's distance to the nearest of the camera's interpolated blobs from its
    /// epipolar line, capped; a blob with no candidate counts the cap.
    fn coarse_cost(&self, camera: CameraId, offset_periods: f64) -> f64 {
        let cap = self.config.cost_cap_px;
        let (Some(reference), Some(other)) =
            (self.cameras.get(&self.reference), self.cameras.get(&camera))
        else {
            return f64::INFINITY;
        };
        let fundamental = self.f(self.reference, camera);
        (0..self.frame_count)
            .map(|frame| {
                let candidates = other.samples(local_frame(frame, offset_periods));
                reference
                    .samples(frame as f64)
                    .iter()
                    .map(|(_, x)| {
                        let d = candidates
                            .iter()
                            .filter_map(|(_, y)| signed_distance(fundamental, x, y))
                            .map(f64::abs)
                            .fold(cap, f64::min);
                        d * d
                    })
                    .sum::<f64>()
            })
            .sum()
    }

    /// The grid point of least coarse cost, periods.
    pub(super) fn coarse_offset(&self, camera: CameraId) -> f64 {
        let max = self.config.max_offset_periods;
        let step = self.config.search_step_periods;
        let steps = (2.0 * max / step).round() as i64;
        (0..=steps)
            .map(|i| -max + i as f64 * step)
            .map(|offset| (offset, self.coarse_cost(camera, offset)))
            .fold((0.0, f64::INFINITY), |best, candidate| {
                if candidate.1 < best.1 {
                    candidate
                } else {
                    best
                }
            })
            .0
    }

    /// Matches of every camera pair at the given offsets (periods).
    fn associate(&self, offsets: &BTreeMap<CameraId, f64>, frames: &[usize]) -> Vec<Match> {
        let cap = self.config.cost_cap_px;
        let ratio = self.config.ambiguity_ratio;
        let ids: Vec<CameraId> = self.cameras.keys().copied().collect();
        let mut matches = Vec::new();
        for (i, &a) in ids.iter().enumerate() {
            for &b in &ids[i + 1..] {
                for &frame in frames {
                    let at_a = local_frame(frame, offsets.get(&a).copied().unwrap_or(0.0));
                    let at_b = local_frame(frame, offsets.get(&b).copied().unwrap_or(0.0));
                    let samples_a = self.cameras[&a].samples(at_a);
                    let samples_b = self.cameras[&b].samples(at_b);
                    let distance = |x: &Pixel, y: &Pixel| {
                        signed_distance(self.f(a, b), x, y).map_or(f64::INFINITY, f64::abs)
                    };
                    for (ia, (track_a, x)) in samples_a.iter().enumerate() {
                        let forward: Vec<f64> =
                            samples_b.iter().map(|(_, y)| distance(x, y)).collect();
                        let Some((ib, d, second)) = nearest_two(forward.into_iter()) else {
                            continue;
                        };
                        let back: Vec<f64> = samples_a
                            .iter()
                            .map(|(_, x)| distance(x, &samples_b[ib].1))
                            .collect();
                        let Some((back_a, _, back_second)) = nearest_two(back.into_iter()) else {
                            continue;
                        };
                        if back_a == ia
                            && d < cap
                            && d <= ratio * second
                            && d <= ratio * back_second
                        {
                            matches.push(Match {
                                a,
                                track_a: *track_a,
                                b,
                                track_b: samples_b[ib].0,
                                frame,
                            });
                        }
                    }
                }
            }
        }
        matches
    }

    /// The match's epipolar residual at the offsets, and the same from the lower-order
    /// interpolation (whose difference estimates the residual's interpolation error).
    fn residual(&self, m: &Match, offsets: &BTreeMap<CameraId, f64>) -> Option<(f64, f64)> {
        let at_a = local_frame(m.frame, offsets.get(&m.a).copied().unwrap_or(0.0));
        let at_b = local_frame(m.frame, offsets.get(&m.b).copied().unwrap_or(0.0));
        let x = self.cameras.get(&m.a)?.sample(m.track_a, at_a)?;
        let y = self.cameras.get(&m.b)?.sample(m.track_b, at_b)?;
        let f = self.f(m.a, m.b);
        Some((
            signed_distance(f, &x.position, &y.position)?,
            signed_distance(f, &x.lower_order, &y.lower_order)?,
        ))
    }
}

/// The linearised least-squares system at some offsets.
struct Normal {
    /// `Σ w J Jᵀ` over the residuals.
    information: DMatrix<f64>,
    /// `Σ w J r`.
    gradient: DVector<f64>,
    /// `Σ w J e`, `e` each residual's interpolation error estimate: `information⁻¹ ·
    /// systematic` is the offsets' shift that error could cause.
    systematic: DVector<f64>,
    /// `Σ w r²`.
    weighted_square_sum: f64,
    /// Residuals used.
    count: usize,
    /// Residuals that involve each unknown camera.
    per_camera: Vec<usize>,
    /// Per unknown camera, `Σ J²` and `Σ r²` over its residuals (unweighted).
    per_camera_squares: Vec<(f64, f64)>,
    /// The residuals' plain RMS, pixels.
    rms_px: f64,
}

/// One residual: its value, its interpolation error estimate, its derivatives by unknown, and
/// its camera pair.
type Row = (f64, f64, Vec<(usize, f64)>, [CameraId; 2]);

/// Robust scale floor, pixels: below the detector's best repeatability (0.01 px), so that an
/// exact simulated scene does not weight every residual down to nothing.
const MIN_SCALE_PX: f64 = 1e-3;

/// Huber's threshold in robust scales (95 % efficiency on Gaussian residuals).
const HUBER_K: f64 = 1.345;

impl Problem<'_> {
    fn normal(
        &self,
        unknowns: &[CameraId],
        offsets: &BTreeMap<CameraId, f64>,
        matches: &[Match],
    ) -> Normal {
        let n = unknowns.len();
        let h = 1e-3;
        let mut rows: Vec<Row> = Vec::new();
        for m in matches {
            let Some((r, r_lower)) = self.residual(m, offsets) else {
                continue;
            };
            let mut jacobian = Vec::new();
            let mut complete = true;
            for camera in [m.a, m.b] {
                let Some(k) = unknowns.iter().position(|c| *c == camera) else {
                    continue;
                };
                let mut plus = offsets.clone();
                let mut minus = offsets.clone();
                *plus.entry(camera).or_insert(0.0) += h;
                *minus.entry(camera).or_insert(0.0) -= h;
                match (self.residual(m, &plus), self.residual(m, &minus)) {
                    (Some((p, _)), Some((q, _))) => jacobian.push((k, (p - q) / (2.0 * h))),
                    _ => complete = false,
                }
            }
            if complete {
                rows.push((r, r - r_lower, jacobian, [m.a, m.b]));
            }
        }
        let mut absolute: Vec<f64> = rows.iter().map(|r| r.0.abs()).collect();
        absolute.sort_by(f64::total_cmp);
        let median = absolute.get(absolute.len() / 2).copied().unwrap_or(0.0);
        let scale = (1.4826 * median).max(MIN_SCALE_PX);
        let mut information = DMatrix::zeros(n, n);
        let mut gradient = DVector::zeros(n);
        let mut systematic = DVector::zeros(n);
        let mut weighted_square_sum = 0.0;
        let mut per_camera = vec![0; n];
        let mut per_camera_squares = vec![(0.0, 0.0); n];
        let mut square_sum = 0.0;
        for (r, interpolation_error, jacobian, pair) in &rows {
            let w = if r.abs() <= HUBER_K * scale {
                1.0
            } else {
                HUBER_K * scale / r.abs()
            };
            for &(i, ji) in jacobian {
                gradient[i] += w * ji * r;
                systematic[i] += w * ji * interpolation_error;
                for &(j, jj) in jacobian {
                    information[(i, j)] += w * ji * jj;
                }
            }
            for (k, camera) in unknowns.iter().enumerate() {
                if pair.contains(camera) {
                    per_camera[k] += 1;
                    per_camera_squares[k].1 += r * r;
                }
            }
            for &(k, jk) in jacobian {
                per_camera_squares[k].0 += jk * jk;
            }
            weighted_square_sum += w * r * r;
            square_sum += r * r;
        }
        Normal {
            information,
            gradient,
            systematic,
            weighted_square_sum,
            count: rows.len(),
            per_camera,
            per_camera_squares,
            rms_px: (square_sum / rows.len().max(1) as f64).sqrt(),
        }
    }

    /// Gauss–Newton from `start` (periods), matches remade at each iteration over `frames`.
    fn refine(
        &self,
        unknowns: &[CameraId],
        start: &BTreeMap<CameraId, f64>,
        frames: &[usize],
    ) -> (BTreeMap<CameraId, f64>, Vec<Match>) {
        let mut offsets = start.clone();
        let mut matches = self.associate(&offsets, frames);
        for _ in 0..MAX_ITERATIONS {
            let normal = self.normal(unknowns, &offsets, &matches);
            let Some(step) = normal
                .information
                .clone()
                .cholesky()
                .map(|c| c.solve(&normal.gradient))
            else {
                break;
            };
            let largest = step.amax();
            // Keep each step within a tenth of a period: the residuals are linear in the offset
            // only while the interpolation stays in one interval.
            let shrink = if largest > MAX_STEP_PERIODS {
                MAX_STEP_PERIODS / largest
            } else {
                1.0
            };
            for (k, camera) in unknowns.iter().enumerate() {
                *offsets.entry(*camera).or_insert(0.0) -= shrink * step[k];
            }
            matches = self.associate(&offsets, frames);
            if largest < CONVERGED_PERIODS {
                break;
            }
        }
        (offsets, matches)
    }
}

/// Gauss–Newton iterations: it converges in 3–5 from the coarse grid.
const MAX_ITERATIONS: usize = 30;
/// Largest step per iteration, periods.
const MAX_STEP_PERIODS: f64 = 0.1;
/// A step below this is convergence, periods (3 ns at 30 Hz).
const CONVERGED_PERIODS: f64 = 1e-7;

/// The estimate: coarse search, joint refinement, σ, refusals.
pub(super) fn estimate(
    problem: &Problem<'_>,
    frame_period_s: f64,
) -> Result<SyncEstimate, SyncError> {
    let config = problem.config;
    let unknowns: Vec<CameraId> = problem
        .cameras
        .keys()
        .copied()
        .filter(|c| *c != problem.reference)
        .collect();
    let start: BTreeMap<CameraId, f64> = unknowns
        .iter()
        .map(|c| (*c, problem.coarse_offset(*c)))
        .collect();
    let all_frames: Vec<usize> = (0..problem.frame_count).collect();
    let (offsets, matches) = problem.refine(&unknowns, &start, &all_frames);
    let normal = problem.normal(&unknowns, &offsets, &matches);
    let zero: BTreeMap<CameraId, f64> = BTreeMap::new();
    let unshifted = problem.normal(&unknowns, &zero, &matches);
    let dof = normal.count.saturating_sub(unknowns.len()).max(1);
    let variance = normal.weighted_square_sum / dof as f64;
    let covariance = normal
        .information
        .clone()
        .try_inverse()
        .map(|inverse| inverse * variance);
    let inflation = segment_inflation(problem, &unknowns, &offsets, covariance.as_ref());
    let systematic = normal
        .information
        .clone()
        .cholesky()
        .map(|c| c.solve(&normal.systematic));
    let mut result = BTreeMap::new();
    result.insert(
        problem.reference,
        CameraOffset {
            offset_s: 0.0,
            sigma_s: 0.0,
            matches: matches
                .iter()
                .filter(|m| m.a == problem.reference || m.b == problem.reference)
                .count(),
        },
    );
    for (k, camera) in unknowns.iter().enumerate() {
        let count = normal.per_camera[k];
        if count < config.min_matches {
            return Err(SyncError::TooFewMatches {
                camera: *camera,
                matches: count,
                needed: config.min_matches,
            });
        }
        // A static tool's blobs still "move" by their noise; timing needs motion well above it.
        let (jacobian_squares, residual_squares) = normal.per_camera_squares[k];
        let motion_px = (jacobian_squares / count as f64).sqrt();
        let residual_px = (residual_squares / count as f64).sqrt();
        // NaN (no residuals) refuses too.
        if motion_px.is_nan() || motion_px <= config.min_motion_ratio * residual_px {
            return Err(SyncError::TooLittleMotion {
                camera: *camera,
                motion_px,
                residual_px,
            });
        }
        // Statistical σ (inflated by the segments' scatter) and the interpolation's
        // systematic shift, in quadrature.
        let sigma_periods = covariance
            .as_ref()
            .zip(systematic.as_ref())
            .map(|(c, b)| (c[(k, k)].max(0.0) * inflation[k].powi(2) + b[k].powi(2)).sqrt())
            .filter(|s| s.is_finite())
            .unwrap_or(f64::INFINITY);
        if sigma_periods > config.max_sigma_periods {
            return Err(SyncError::NoTimingInformation {
                camera: *camera,
                sigma_ms: sigma_periods * frame_period_s * 1e3,
                limit_ms: config.max_sigma_periods * frame_period_s * 1e3,
            });
        }
        let offset_periods = offsets.get(camera).copied().unwrap_or(0.0);
        let edge = config.max_offset_periods - config.search_step_periods;
        if offset_periods.abs() > edge {
            return Err(SyncError::AtSearchEdge {
                camera: *camera,
                offset_ms: offset_periods * frame_period_s * 1e3,
                limit_ms: config.max_offset_periods * frame_period_s * 1e3,
            });
        }
        result.insert(
            *camera,
            CameraOffset {
                offset_s: offset_periods * frame_period_s,
                sigma_s: sigma_periods * frame_period_s,
                matches: count,
            },
        );
    }
    Ok(SyncEstimate {
        reference: problem.reference,
        offsets: result,
        residual_rms_px: normal.rms_px,
        unshifted_residual_rms_px: unshifted.rms_px,
        matches: normal.count,
    })
}

/// Per unknown camera, the Birge ratio `max(1, √(χ²/(K−1)))` of the offsets fitted on `K`
/// contiguous segments against the whole recording's, each weighed by its own curvature σ.
fn segment_inflation(
    problem: &Problem<'_>,
    unknowns: &[CameraId],
    offsets: &BTreeMap<CameraId, f64>,
    covariance: Option<&DMatrix<f64>>,
) -> Vec<f64> {
    let n = unknowns.len();
    let segments = problem.config.segments.min(problem.frame_count / 8).max(1);
    if covariance.is_none() || segments < 2 {
        return vec![1.0; n];
    }
    let mut chi2 = vec![0.0; n];
    let mut used = vec![0usize; n];
    for s in 0..segments {
        let frames: Vec<usize> = (s * problem.frame_count / segments
            ..(s + 1) * problem.frame_count / segments)
            .collect();
        let (segment_offsets, matches) = problem.refine(unknowns, offsets, &frames);
        let normal = problem.normal(unknowns, &segment_offsets, &matches);
        let dof = normal.count.saturating_sub(n);
        if dof < problem.config.min_matches {
            continue;
        }
        let variance = normal.weighted_square_sum / dof as f64;
        let Some(inverse) = normal.information.try_inverse() else {
            continue;
        };
        for (k, camera) in unknowns.iter().enumerate() {
            let var = inverse[(k, k)] * variance;
            let d = segment_offsets.get(camera).copied().unwrap_or(0.0)
                - offsets.get(camera).copied().unwrap_or(0.0);
            if var > 0.0 && var.is_finite() && d.is_finite() {
                chi2[k] += d * d / var;
                used[k] += 1;
            }
        }
    }
    chi2.iter()
        .zip(&used)
        .map(|(c, &u)| {
            if u >= 2 {
                (c / (u - 1) as f64).sqrt().max(1.0)
            } else {
                1.0
            }
        })
        .collect()
}
