//! Trajectory smoothing (paper §III): the paper's four methods, rotations on SO(3), gaps.
//!
//! Model: a trajectory component is a sum of sinusoids plus white measurement noise (paper
//! §III). Each run of frames (a measured segment, merged across short gaps, see [`gaps`]) is
//! turned into six uniform series: the position `x, y, z` (mm) and the unrolled rotation
//! (rad, see [`rotation`]). One linear smoother is applied to each series:
//! - [`Method::Lowpass`]: zero-phase Butterworth, scipy's `filtfilt(*butter(N, fc, fs=fs), x)`
//!   ([`butterworth`]); `fc` is the single-pass cut-off, as in scipy; Winter's two-pass
//!   correction is an option ([`CutoffConvention`]). The paper's choice (10 Hz for painting).
//! - [`Method::Spline`]: cubic spline interpolation ([`spline`]): it passes through every
//!   sample, so it only fills gaps and removes no noise (the paper's Fig. 4).
//! - [`Method::Bezier`]: the Bezier curve with the samples as control points ([`bezier`]): it
//!   removes the noise and flattens the motion too (Fig. 5).
//! - [`Method::Nurbs`]: least-squares B-spline of a chosen degree and knot spacing ([`bspline`]),
//!   evaluated back at the original times (Fig. 6), so nothing is re-sampled.
//!
//! The rotation is rolled back onto the measured rotations, and the tip is recomputed from the
//! smoothed pose: `tip_in_world = world_from_tool · tip_in_tool`. [`spectrum`] gives the
//! amplitude spectrum (Fig. 7) and [`cutoff`] suggests a cut-off by Winter's residual analysis.

pub mod bezier;
pub mod bspline;
pub mod butterworth;
pub mod cutoff;
pub mod gaps;
pub mod rotation;
pub mod spectrum;
pub mod spline;
pub mod study;

use nalgebra::{UnitQuaternion, Vector3};
use rayon::prelude::*;

use crate::geometry::{Point3, pose_from_parts};
use crate::trajectory::{
    PoseSource, Sample, SampleRateError, Status, ToolPose, Trajectory, check_sample_rate_hz,
};
use butterworth::{Butterworth, FilterError};
use spline::{CubicSpline, SplineEnds};

/// Which frequency the low-pass cut-off names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CutoffConvention {
    /// The cut-off of one pass (scipy's `butter` + `filtfilt`): the zero-phase result is at
    /// −6 dB there. The contract's convention.
    #[default]
    SinglePass,
    /// Winter's correction: the design cut-off is raised so that the zero-phase (two-pass)
    /// result is at −3 dB at the cut-off given.
    WinterTwoPass,
}

/// A smoothing method with its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    /// Zero-phase Butterworth low-pass.
    Lowpass {
        /// Cut-off frequency, Hz.
        cutoff_hz: f64,
        /// Filter order `N` (each pass); scipy's padding is `3·(N + 1)` samples.
        order: usize,
        /// What the cut-off means.
        convention: CutoffConvention,
    },
    /// Cubic spline interpolation through every sample.
    Spline {
        /// End conditions.
        ends: SplineEnds,
    },
    /// Bezier curve with every sample of a run as a control point.
    Bezier {
        /// Longest run accepted: the cost grows as the cube of its length.
        max_control_points: usize,
    },
    /// Least-squares B-spline (NURBS with unit weights).
    Nurbs {
        /// Polynomial degree.
        degree: usize,
        /// Spacing of the uniform interior knots, seconds: motion faster than about
        /// `1 / (2 · spacing)` Hz is smoothed away.
        knot_spacing_s: f64,
    },
}

impl Method {
    /// The low-pass the paper used for painting: 10 Hz, order 2, scipy's convention.
    pub const PAPER_LOWPASS: Method = Method::Lowpass {
        cutoff_hz: 10.0,
        order: 2,
        convention: CutoffConvention::SinglePass,
    };
}

/// What to do with a run too short for the method (the low-pass's padding or its step
/// response's settling length, or fewer samples than NURBS control points).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ShortRuns {
    /// Refuse the trajectory, naming the run's frames.
    #[default]
    Reject,
    /// Turn the run into a gap (empty rows): explicit, never unsmoothed data in a smoothed file.
    Gap,
}

/// How to smooth a trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothConfig {
    /// The method and its parameters. Default: [`Method::PAPER_LOWPASS`] (paper §VI: 10 Hz).
    pub method: Method,
    /// Gaps of at most this many frames are filled (and marked filled); longer ones stay gaps.
    /// Default 10: a tenth of a second at 100 Hz, a third at 30 Hz, the length of a brief
    /// occlusion of the brush by the hand.
    pub max_gap_frames: usize,
    /// The tip in the tool frame, mm; `None` recovers it from the samples as
    /// `world_from_tool⁻¹ · tip_in_world`. Default `None`: the trajectory file has what is needed.
    pub tip_in_tool: Option<Point3>,
    /// Largest spread of the recovered `tip_in_tool` across samples, mm. Default 0.01: the
    /// trajectory CSV writes 6 decimals, so rounding moves it by far less.
    pub tip_tolerance_mm: f64,
    /// Largest departure of a time step from the mean step, as a fraction of the step. Default
    /// 1e-3: the CSV's microsecond rounding is 1e-4 of a 100 Hz step; a dropped or doubled
    /// frame is 1.
    pub time_step_tolerance: f64,
    /// Runs too short for the method. Default [`ShortRuns::Reject`]: the user decides.
    pub short_runs: ShortRuns,
}

impl Default for SmoothConfig {
    fn default() -> Self {
        Self {
            method: Method::PAPER_LOWPASS,
            max_gap_frames: 10,
            tip_in_tool: None,
            tip_tolerance_mm: 0.01,
            time_step_tolerance: 1e-3,
            short_runs: ShortRuns::Reject,
        }
    }
}

/// Why a trajectory cannot be smoothed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SmoothError {
    /// No pose at all, or fewer than two samples.
    #[error(
        "trajectory has {samples} samples and {poses} poses: a filter or spectrum needs at least 2 samples with poses"
    )]
    Empty {
        /// Samples.
        samples: usize,
        /// Samples with a pose.
        poses: usize,
    },
    /// Frame numbers skip: a row is missing.
    #[error(
        "frame {next} follows frame {previous}: one row per frame is needed (gaps as empty rows)"
    )]
    MissingRow {
        /// The frame before.
        previous: usize,
        /// The frame after.
        next: usize,
    },
    /// Time steps are not uniform: the filters assume one sampling rate.
    #[error(
        "frame {frame}: time step {step_s:.6} s differs from the mean step {mean_step_s:.6} s (timestamps must be uniform and increasing)"
    )]
    NonUniformTime {
        /// The frame whose step is off.
        frame: usize,
        /// Its step from the previous frame.
        step_s: f64,
        /// The mean step over the trajectory.
        mean_step_s: f64,
    },
    /// The sampling rate the time steps imply is outside the accepted range.
    #[error(transparent)]
    SampleRate(#[from] SampleRateError),
    /// A pose number is NaN or infinite.
    #[error("frame {frame}: {field} is not finite")]
    NotFinite {
        /// The frame.
        frame: usize,
        /// Which field.
        field: &'static str,
    },
    /// A smoothed number came out NaN or infinite (a guard: every output is checked before
    /// it is returned).
    #[error("frame {frame}: smoothed {field} is not finite")]
    NotFiniteResult {
        /// The frame.
        frame: usize,
        /// Which field.
        field: &'static str,
    },
    /// The tip is not at one place in the tool frame across samples.
    #[error(
        "frame {frame}: tip is {deviation_mm:.4} mm from where frame {first_frame} puts it in the tool frame (tolerance {tolerance_mm} mm); give the tool file"
    )]
    InconsistentTip {
        /// The frame that disagrees.
        frame: usize,
        /// The first frame with a pose.
        first_frame: usize,
        /// Distance between the two tips in the tool frame.
        deviation_mm: f64,
        /// The tolerance.
        tolerance_mm: f64,
    },
    /// The low-pass cannot be designed or applied to a run.
    #[error("frames {first_frame}..={last_frame}: {cause}")]
    Filter {
        /// First frame of the run.
        first_frame: usize,
        /// Last frame of the run.
        last_frame: usize,
        /// The cause (in the message, not chained, so it is said once).
        cause: FilterError,
    },
    /// The least-squares B-spline cannot be fitted to a run.
    #[error("frames {first_frame}..={last_frame}: {cause}")]
    Nurbs {
        /// First frame of the run.
        first_frame: usize,
        /// Last frame of the run.
        last_frame: usize,
        /// The cause (in the message, not chained, so it is said once).
        cause: bspline::BSplineError,
    },
    /// A parameter of the method is out of range.
    #[error("{parameter} = {value} is out of range: {reason}")]
    BadParameter {
        /// The parameter.
        parameter: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        reason: &'static str,
    },
    /// A run is too long for the Bezier curve's cubic cost.
    #[error(
        "frames {first_frame}..={last_frame}: {samples} samples as Bezier control points exceed the limit of {max}"
    )]
    BezierTooLong {
        /// First frame of the run.
        first_frame: usize,
        /// Last frame of the run.
        last_frame: usize,
        /// Samples in the run.
        samples: usize,
        /// The limit.
        max: usize,
    },
}

/// The checked timing of a trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Sampling rate, Hz.
    pub sample_rate_hz: f64,
}

/// Checks that frames are consecutive and times uniform; returns the sampling rate.
///
/// # Errors
/// [`SmoothError::Empty`], [`SmoothError::MissingRow`], [`SmoothError::NonUniformTime`],
/// [`SmoothError::SampleRate`].
pub fn check_timing(
    trajectory: &Trajectory,
    time_step_tolerance: f64,
) -> Result<Timing, SmoothError> {
    let samples = &trajectory.samples;
    let empty = || SmoothError::Empty {
        samples: samples.len(),
        poses: samples.iter().filter(|s| s.pose.is_some()).count(),
    };
    let (Some(first), Some(last)) = (samples.first(), samples.last()) else {
        return Err(empty());
    };
    if samples.len() < 2 {
        return Err(empty());
    }
    // One pass over the samples (they are large: the pass is the memory's time): a missing
    // row anywhere is named before a time step that is not uniform.
    let mean_step_s = (last.time_s - first.time_s) / (samples.len() - 1) as f64;
    let mut not_uniform = None;
    for w in samples.windows(2) {
        if w[1].frame.0 != w[0].frame.0 + 1 {
            return Err(SmoothError::MissingRow {
                previous: w[0].frame.0,
                next: w[1].frame.0,
            });
        }
        let step_s = w[1].time_s - w[0].time_s;
        let uniform = (step_s - mean_step_s).abs() <= time_step_tolerance * mean_step_s;
        if !(step_s.is_finite() && step_s > 0.0 && uniform) && not_uniform.is_none() {
            not_uniform = Some(SmoothError::NonUniformTime {
                frame: w[1].frame.0,
                step_s,
                mean_step_s,
            });
        }
    }
    if let Some(error) = not_uniform {
        return Err(error);
    }
    let rate_hz = snapped_rate_hz(1.0 / mean_step_s, last.time_s - first.time_s);
    Ok(Timing {
        sample_rate_hz: check_sample_rate_hz("the sampling rate of time_s", rate_hz)?,
    })
}

/// The sampling rate from the time span, snapped to a multiple of 0.001 Hz (30, 29.97, 100,
/// 119.88) when the difference is within what the file's microsecond rounding of the two end
/// times allows (`1e-6 s / span`, relative). Otherwise the rounding would leak into the filter
/// coefficients at about 1e-8 and move the output away from `butter(N, fc, fs=30)`.
fn snapped_rate_hz(rate_hz: f64, span_s: f64) -> f64 {
    let snapped = (rate_hz * 1000.0).round() / 1000.0;
    if (snapped - rate_hz).abs() <= rate_hz * 1e-6 / span_s {
        snapped
    } else {
        rate_hz
    }
}

/// Smooths a trajectory: every run (segments merged across gaps of at most
/// `config.max_gap_frames`) through `config.method`, gaps inside runs filled and marked
/// [`PoseSource::Filled`] (with `markers` and `rms_mm` 0: nothing was measured), longer gaps
/// kept. Frames, times, marker counts and residuals are kept; the tip is recomputed from the
/// smoothed pose.
///
/// # Errors
/// [`SmoothError`] naming the frame or the run: non-uniform or missing frames, non-finite
/// numbers, a tip that moves in the tool frame, a run too short for the filter's padding, a
/// cut-off at or above Nyquist.
pub fn smooth(trajectory: &Trajectory, config: &SmoothConfig) -> Result<Trajectory, SmoothError> {
    smooth_owned(trajectory.clone(), config)
}

/// [`smooth`] of a trajectory the caller gives up: the result is written over its samples, so
/// a file-to-file job holds one trajectory, not two.
///
/// # Errors
/// As [`smooth`].
pub fn smooth_owned(
    mut trajectory: Trajectory,
    config: &SmoothConfig,
) -> Result<Trajectory, SmoothError> {
    let timing = check_timing(&trajectory, config.time_step_tolerance)?;
    check_finite(&trajectory)?;
    let frames = trajectory.samples.first().map_or(0, |s| s.frame.0)
        ..trajectory.samples.last().map_or(0, |s| s.frame.0);
    check_method(&config.method, timing.sample_rate_hz, frames)?;
    let tip_in_tool = match config.tip_in_tool {
        Some(tip) => tip,
        None => recover_tip_in_tool(&trajectory, config.tip_tolerance_mm)?,
    };
    // Runs do not overlap, and each is read whole before it is written.
    for run in gaps::runs(&trajectory, config.max_gap_frames) {
        let samples = &mut trajectory.samples[run];
        match smooth_run(samples, &config.method, timing.sample_rate_hz, &tip_in_tool) {
            Ok(()) => {}
            Err(e) if config.short_runs == ShortRuns::Gap && is_too_short(&e) => {
                for s in samples {
                    *s = Sample::gap(s.frame, s.time_s);
                }
            }
            Err(e) => return Err(e),
        }
    }
    if let Some((frame, field)) = first_not_finite(&trajectory) {
        return Err(SmoothError::NotFiniteResult { frame, field });
    }
    Ok(trajectory)
}

/// The six uniform series of a run, gaps filled: positions (mm) and unrolled rotation (rad),
/// with the rotation each sample's correction is applied to.
#[derive(Debug, Clone)]
pub struct RunSeries {
    /// `x, y, z` (mm), then the unrolled rotation vector `rx, ry, rz` (rad), one value per
    /// sample of the run.
    pub columns: [Vec<f64>; 6],
    /// The measured rotation (or, at a filled frame, the rotation interpolated from the
    /// unrolled path).
    pub rotations: Vec<UnitQuaternion<f64>>,
}

/// Builds the series of a run whose first and last samples have a pose; inner gaps are filled
/// by cubic splines with `fill_ends` over the measured samples.
#[must_use]
pub fn run_series(samples: &[Sample], fill_ends: SplineEnds) -> RunSeries {
    // The measured samples' indices, rotations and positions in one pass over the samples.
    let mut measured: Vec<usize> = Vec::with_capacity(samples.len());
    let mut measured_rotations = Vec::with_capacity(samples.len());
    let mut columns: [Vec<f64>; 6] = std::array::from_fn(|_| Vec::with_capacity(samples.len()));
    for (i, sample) in samples.iter().enumerate() {
        if let Some(pose) = &sample.pose {
            measured.push(i);
            measured_rotations.push(pose.world_from_tool.rotation);
            for (column, &value) in columns[..3]
                .iter_mut()
                .zip(&pose.world_from_tool.translation.vector)
            {
                column.push(value);
            }
        }
    }
    let unrolled = rotation::unroll(&measured_rotations);
    for v in &unrolled {
        for (column, &value) in columns[3..].iter_mut().zip(v) {
            column.push(value);
        }
    }
    if measured.len() == samples.len() {
        return RunSeries {
            columns,
            rotations: measured_rotations,
        };
    }
    let times: Vec<f64> = measured.iter().map(|&i| samples[i].time_s).collect();
    let splines: Vec<Option<CubicSpline>> = columns
        .iter()
        .map(|y| CubicSpline::new(&times, y, fill_ends).ok())
        .collect();
    let mut filled: [Vec<f64>; 6] = Default::default();
    let mut filled_rotations = Vec::with_capacity(samples.len());
    let mut next_measured = 0;
    for (i, sample) in samples.iter().enumerate() {
        if next_measured < measured.len() && measured[next_measured] == i {
            for (f, c) in filled.iter_mut().zip(&columns) {
                f.push(c[next_measured]);
            }
            filled_rotations.push(measured_rotations[next_measured]);
            next_measured += 1;
        } else {
            // A run starts with a pose, so a previous measured sample exists.
            let previous = next_measured.saturating_sub(1);
            for (f, (s, c)) in filled.iter_mut().zip(splines.iter().zip(&columns)) {
                f.push(s.as_ref().map_or(c[previous], |s| s.value(sample.time_s)));
            }
            let k = filled[3].len() - 1;
            let v = Vector3::new(filled[3][k], filled[4][k], filled[5][k]);
            filled_rotations
                .push(measured_rotations[previous] * rotation::exp(&(v - unrolled[previous])));
        }
    }
    RunSeries {
        columns: filled,
        rotations: filled_rotations,
    }
}

/// Applies `method` to one uniform series sampled at `sample_rate_hz`.
///
/// # Errors
/// [`SmoothError::Filter`], [`SmoothError::Nurbs`], [`SmoothError::BezierTooLong`], with the
/// frames given as 0 and `len - 1` (the caller renames them).
pub fn smooth_series(
    values: &[f64],
    method: &Method,
    sample_rate_hz: f64,
) -> Result<Vec<f64>, SmoothError> {
    let last_frame = values.len().saturating_sub(1);
    match *method {
        Method::Lowpass {
            cutoff_hz,
            order,
            convention,
        } => {
            let filter =
                design_lowpass(cutoff_hz, order, convention, sample_rate_hz).map_err(|source| {
                    SmoothError::Filter {
                        first_frame: 0,
                        last_frame,
                        cause: source,
                    }
                })?;
            filter
                .filtfilt(values)
                .map_err(|source| SmoothError::Filter {
                    first_frame: 0,
                    last_frame,
                    cause: source,
                })
        }
        // On a uniform run, the interpolating spline at the sample times is the samples.
        Method::Spline { .. } => Ok(values.to_vec()),
        Method::Bezier { max_control_points } => {
            if values.len() > max_control_points {
                return Err(SmoothError::BezierTooLong {
                    first_frame: 0,
                    last_frame,
                    samples: values.len(),
                    max: max_control_points,
                });
            }
            Ok(bezier::bezier_at_samples(values))
        }
        Method::Nurbs {
            degree,
            knot_spacing_s,
        } => {
            let fit = nurbs_fit(values.len(), degree, knot_spacing_s, sample_rate_hz).map_err(
                |source| SmoothError::Nurbs {
                    first_frame: 0,
                    last_frame,
                    cause: source,
                },
            )?;
            Ok(fit.fit(values))
        }
    }
}

/// The Butterworth filter for a cut-off under a convention.
///
/// # Errors
/// [`FilterError`] as [`Butterworth::lowpass`].
pub fn design_lowpass(
    cutoff_hz: f64,
    order: usize,
    convention: CutoffConvention,
    sample_rate_hz: f64,
) -> Result<Butterworth, FilterError> {
    // Check the cut-off as given first, so the error names the user's number.
    Butterworth::lowpass(order, cutoff_hz, sample_rate_hz)?;
    let design_hz = match convention {
        CutoffConvention::SinglePass => cutoff_hz,
        CutoffConvention::WinterTwoPass => {
            butterworth::winter_corrected_cutoff_hz(cutoff_hz, order, sample_rate_hz)
        }
    };
    Butterworth::lowpass(order, design_hz, sample_rate_hz)
}

fn nurbs_fit(
    samples: usize,
    degree: usize,
    knot_spacing_s: f64,
    sample_rate_hz: f64,
) -> Result<bspline::LeastSquaresBSpline, bspline::BSplineError> {
    let times: Vec<f64> = (0..samples).map(|i| i as f64 / sample_rate_hz).collect();
    let duration_s = times.last().copied().unwrap_or(0.0);
    // `as` saturates, and so does the sum: a tiny spacing asks for more control points than
    // samples and is refused as underdetermined, before anything is allocated.
    let spans = (duration_s / knot_spacing_s).ceil().max(1.0) as usize;
    bspline::LeastSquaresBSpline::new(&times, degree, spans.saturating_add(degree))
}

fn check_method(
    method: &Method,
    sample_rate_hz: f64,
    frames: std::ops::Range<usize>,
) -> Result<(), SmoothError> {
    match *method {
        Method::Lowpass {
            cutoff_hz,
            order,
            convention,
        } => design_lowpass(cutoff_hz, order, convention, sample_rate_hz)
            .map(|_| ())
            .map_err(|source| SmoothError::Filter {
                first_frame: frames.start,
                last_frame: frames.end,
                cause: source,
            }),
        Method::Nurbs {
            degree,
            knot_spacing_s,
        } => {
            if !(knot_spacing_s.is_finite() && knot_spacing_s > 0.0) {
                return Err(SmoothError::BadParameter {
                    parameter: "knot_spacing_s",
                    value: knot_spacing_s,
                    reason: "a positive number of seconds",
                });
            }
            if degree == 0 {
                return Err(SmoothError::BadParameter {
                    parameter: "degree",
                    value: 0.0,
                    reason: "at least 1",
                });
            }
            Ok(())
        }
        Method::Spline { .. } | Method::Bezier { .. } => Ok(()),
    }
}

/// Smooths one run in place; on an error the samples are untouched.
fn smooth_run(
    samples: &mut [Sample],
    method: &Method,
    sample_rate_hz: f64,
    tip_in_tool: &Point3,
) -> Result<(), SmoothError> {
    let first_frame = samples.first().map_or(0, |s| s.frame.0);
    let last_frame = samples.last().map_or(0, |s| s.frame.0);
    // Gaps are filled by the spline the user chose, or scipy's default ends otherwise.
    let fill_ends = match method {
        Method::Spline { ends } => *ends,
        _ => SplineEnds::NotAKnot,
    };
    let series = run_series(samples, fill_ends);
    let smoothed: Vec<Vec<f64>> = series
        .columns
        .par_iter()
        .map(|c| smooth_series(c, method, sample_rate_hz))
        .collect::<Result<_, _>>()
        .map_err(|e| rename_frames(e, first_frame, last_frame))?;
    let [_, _, _, rx, ry, rz] = &series.columns;
    samples.par_iter_mut().enumerate().for_each(|(i, sample)| {
        let rotation = rotation::corrected(
            &series.rotations[i],
            &Vector3::new(rx[i], ry[i], rz[i]),
            &Vector3::new(smoothed[3][i], smoothed[4][i], smoothed[5][i]),
        );
        let world_from_tool = pose_from_parts(
            Vector3::new(smoothed[0][i], smoothed[1][i], smoothed[2][i]),
            rotation,
        );
        let (markers, rms_mm, source, status, cameras) = match &sample.pose {
            Some(p) => (
                p.markers,
                p.rms_mm,
                sample.source,
                sample.status,
                sample.cameras,
            ),
            None => (0, 0.0, PoseSource::Filled, Status::Degraded, None),
        };
        *sample = Sample {
            frame: sample.frame,
            time_s: sample.time_s,
            pose: Some(ToolPose {
                world_from_tool,
                tip_in_world: world_from_tool * tip_in_tool,
                markers,
                rms_mm,
            }),
            source,
            tip_std_mm: sample.tip_std_mm,
            status,
            cameras,
        };
    });
    Ok(())
}

fn is_too_short(error: &SmoothError) -> bool {
    matches!(
        error,
        SmoothError::Filter {
            cause: FilterError::TooShort { .. } | FilterError::CutoffBelowRecord { .. },
            ..
        } | SmoothError::Nurbs {
            cause: bspline::BSplineError::Underdetermined { .. },
            ..
        }
    )
}

fn rename_frames(error: SmoothError, first: usize, last: usize) -> SmoothError {
    match error {
        SmoothError::Filter { cause: source, .. } => SmoothError::Filter {
            first_frame: first,
            last_frame: last,
            cause: source,
        },
        SmoothError::Nurbs { cause: source, .. } => SmoothError::Nurbs {
            first_frame: first,
            last_frame: last,
            cause: source,
        },
        SmoothError::BezierTooLong { samples, max, .. } => SmoothError::BezierTooLong {
            first_frame: first,
            last_frame: last,
            samples,
            max,
        },
        other => other,
    }
}

fn check_finite(trajectory: &Trajectory) -> Result<(), SmoothError> {
    match first_not_finite(trajectory) {
        Some((frame, field)) => Err(SmoothError::NotFinite { frame, field }),
        None => Ok(()),
    }
}

/// The first frame and field holding a NaN or an infinity (the samples checked side by side).
fn first_not_finite(trajectory: &Trajectory) -> Option<(usize, &'static str)> {
    trajectory.samples.par_iter().find_map_first(|s| {
        if !s.time_s.is_finite() {
            return Some((s.frame.0, "time_s"));
        }
        let p = s.pose.as_ref()?;
        let t = p.world_from_tool.translation.vector;
        let q = p.world_from_tool.rotation.quaternion();
        let checks = [
            ("x_mm, y_mm, z_mm", t.iter().all(|v| v.is_finite())),
            ("qw, qx, qy, qz", q.coords.iter().all(|v| v.is_finite())),
            (
                "tip_x_mm, tip_y_mm, tip_z_mm",
                p.tip_in_world.iter().all(|v| v.is_finite()),
            ),
        ];
        let (field, _) = checks.iter().find(|(_, ok)| !ok)?;
        Some((s.frame.0, *field))
    })
}

/// The tip in the tool frame, `world_from_tool⁻¹ · tip_in_world`, from the first sample with a
/// pose, checked against every other sample.
///
/// # Errors
/// [`SmoothError::Empty`] without poses, [`SmoothError::InconsistentTip`].
pub fn recover_tip_in_tool(
    trajectory: &Trajectory,
    tolerance_mm: f64,
) -> Result<Point3, SmoothError> {
    let first_pose = trajectory
        .samples
        .iter()
        .find_map(|s| s.pose.as_ref().map(|p| (s.frame, p)));
    let Some((first_frame, first)) = first_pose else {
        return Err(SmoothError::Empty {
            samples: trajectory.len(),
            poses: 0,
        });
    };
    let tip_in_tool = first
        .world_from_tool
        .inverse_transform_point(&first.tip_in_world);
    // Every other pose checked side by side; the first in order beyond the tolerance is named.
    let beyond = trajectory.samples.par_iter().find_map_first(|s| {
        let p = s.pose.as_ref()?;
        let here = p.world_from_tool.inverse_transform_point(&p.tip_in_world);
        let deviation_mm = (here - tip_in_tool).norm();
        (deviation_mm > tolerance_mm).then_some((s.frame.0, deviation_mm))
    });
    if let Some((frame, deviation_mm)) = beyond {
        return Err(SmoothError::InconsistentTip {
            frame,
            first_frame: first_frame.0,
            deviation_mm,
            tolerance_mm,
        });
    }
    Ok(tip_in_tool)
}

/// Names of the six smoothed components of a run, with units: the position, then the unrolled
/// rotation vector.
pub const COMPONENTS: [&str; 6] = ["x_mm", "y_mm", "z_mm", "rx_rad", "ry_rad", "rz_rad"];

/// The amplitude spectra of the six components over the longest measured segment.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentSpectra {
    /// First frame of the segment analysed.
    pub first_frame: usize,
    /// Last frame of the segment analysed.
    pub last_frame: usize,
    /// Sampling rate, Hz.
    pub sample_rate_hz: f64,
    /// Bin frequencies, Hz.
    pub frequency_hz: Vec<f64>,
    /// Amplitude of each of [`COMPONENTS`] at each frequency (mm or rad).
    pub amplitude: [Vec<f64>; 6],
}

/// The longest measured segment (no gap) as uniform series.
fn longest_segment(
    trajectory: &Trajectory,
    time_step_tolerance: f64,
) -> Result<(Timing, std::ops::Range<usize>, RunSeries), SmoothError> {
    let timing = check_timing(trajectory, time_step_tolerance)?;
    check_finite(trajectory)?;
    let segment = trajectory
        .segments()
        .into_iter()
        .max_by_key(|r| (r.len(), std::cmp::Reverse(r.start)))
        .ok_or(SmoothError::Empty {
            samples: trajectory.len(),
            poses: 0,
        })?;
    // A segment has no gap: nothing is filled.
    let series = run_series(&trajectory.samples[segment.clone()], SplineEnds::NotAKnot);
    Ok((timing, segment, series))
}

/// Amplitude spectrum (paper Fig. 7) of each component over the longest gap-free segment,
/// taken as `method` says (the report's: detrended, Hann-windowed).
///
/// # Errors
/// As [`check_timing`], or no pose at all.
pub fn trajectory_spectrum(
    trajectory: &Trajectory,
    time_step_tolerance: f64,
    method: crate::report::spectrum::SpectrumMethod,
) -> Result<ComponentSpectra, SmoothError> {
    let (timing, segment, series) = longest_segment(trajectory, time_step_tolerance)?;
    let spectra: Vec<spectrum::Spectrum> = series
        .columns
        .iter()
        .map(|c| crate::report::spectrum::spectrum_with(c, timing.sample_rate_hz, method))
        .collect();
    let frequency_hz = spectra[0].frequency_hz.clone();
    let mut amplitude: [Vec<f64>; 6] = Default::default();
    for (a, s) in amplitude.iter_mut().zip(spectra) {
        *a = s.amplitude;
    }
    Ok(ComponentSpectra {
        first_frame: trajectory.samples[segment.start].frame.0,
        last_frame: trajectory.samples[segment.end - 1].frame.0,
        sample_rate_hz: timing.sample_rate_hz,
        frequency_hz,
        amplitude,
    })
}

/// A cut-off chosen by residual analysis of the positions.
#[derive(Debug, Clone, PartialEq)]
pub struct CutoffSuggestion {
    /// The largest of the three position components' suggestions, Hz: the most dynamic axis
    /// decides, so no axis is over-smoothed.
    pub cutoff_hz: f64,
    /// The analysis of `x`, `y` and `z`.
    pub per_axis: [cutoff::ResidualAnalysis; 3],
}

/// Cut-offs tried by [`suggest_cutoff`]: steps of 0.2 % of the sampling rate (0.2 Hz at 100 Hz).
pub const SUGGESTION_STEPS: usize = 225;

/// Samples analysed by [`suggest_cutoff`]: the first 30,000 of the longest segment (five minutes
/// at 100 Hz) say as much about the noise as an hour, at a fraction of the cost.
pub const SUGGESTION_MAX_SAMPLES: usize = 30_000;

/// Suggests a low-pass cut-off for `trajectory` by residual analysis ([`cutoff`]) of `x`, `y`,
/// `z` over the longest gap-free segment (single-pass cut-offs, order `order`).
///
/// # Errors
/// As [`check_timing`], or a segment too short for the filter.
pub fn suggest_cutoff(
    trajectory: &Trajectory,
    order: usize,
    time_step_tolerance: f64,
) -> Result<CutoffSuggestion, SmoothError> {
    let (timing, segment, series) = longest_segment(trajectory, time_step_tolerance)?;
    let filter_error = |source| SmoothError::Filter {
        first_frame: trajectory.samples[segment.start].frame.0,
        last_frame: trajectory.samples[segment.end - 1].frame.0,
        cause: source,
    };
    let analyse = |c: &Vec<f64>| {
        let head = &c[..c.len().min(SUGGESTION_MAX_SAMPLES)];
        cutoff::residual_analysis(head, timing.sample_rate_hz, order, SUGGESTION_STEPS)
    };
    let per_axis = [
        analyse(&series.columns[0]).map_err(filter_error)?,
        analyse(&series.columns[1]).map_err(filter_error)?,
        analyse(&series.columns[2]).map_err(filter_error)?,
    ];
    let cutoff_hz = per_axis
        .iter()
        .map(|a| a.suggested_cutoff_hz)
        .fold(0.0, f64::max);
    Ok(CutoffSuggestion {
        cutoff_hz,
        per_axis,
    })
}
