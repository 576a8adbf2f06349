//! Frames shared by the vision system and the robot (paper §V: their overlap is "the main
//! source of systematic error"): the work object from points known in both frames, and the
//! tool centre point by pivot calibration.
//!
//! Alignment model (the SVD registration of [`crate::register`]: Arun, Huang and Blostein
//! 1987; Umeyama 1991; scale fixed to 1): points touched by the robot's TCP (`p_i` in the base
//! frame) and seen by the cameras (`w_i` in the vision world = work-object frame) satisfy
//! `p_i = base_from_wobj * w_i + e_i`; the least-squares rotation is `R = U diag(1, 1, det(U Vᵀ)) Vᵀ` from the SVD of the cross-covariance
//! `Σ (p_i − p̄)(w_i − w̄)ᵀ = U S Vᵀ`, and `t = p̄ − R w̄`.
//!
//! Pivot model: the tip rests on one point while the tool turns, so for every pose
//! `world_from_tool_k * tip_in_tool = pivot_in_world`, i.e. `[R_k  −I] [tip; pivot] = −t_k`,
//! solved by linear least squares (normal equations, 6x6). Its conditioning is the tool's rotation spread: with
//! rotations about one axis only, the tip's position along that axis is undetermined.

use std::ops::AddAssign;

use nalgebra::{Matrix3, Matrix6, Vector6};

use crate::geometry::{Point3, Pose};
use crate::register::{RegisterError, Scale, register};

/// Why frames could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FramesError {
    /// The two point lists differ in length.
    #[error("{vision} points seen by the cameras but {robot} touched by the robot")]
    CountMismatch {
        /// Points in the vision frame.
        vision: usize,
        /// Points in the robot frame.
        robot: usize,
    },
    /// Fewer than three point pairs.
    #[error("{count} point pairs; aligning two frames needs at least 3")]
    TooFewPoints {
        /// Pairs given.
        count: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {index} is not finite")]
    NotFinite {
        /// 0-based index of the pair or pose.
        index: usize,
    },
    /// The points are (nearly) on one line: the rotation about it is unknown.
    #[error("the points are collinear: touch at least 3 points not on one line")]
    Collinear,
    /// The best rigid fit leaves residuals no calibration target allows.
    #[error(
        "the points do not fit one rigid motion: rms residual {rms_mm:.2} mm, beyond {limit_mm:.2} mm (1 % of the points' spread, at least 1 mm); worst point {worst} at {worst_mm:.2} mm{hint}"
    )]
    FitTooPoor {
        /// RMS residual of the rigid fit, millimetres.
        rms_mm: f64,
        /// The largest RMS accepted, millimetres.
        limit_mm: f64,
        /// 0-based index of the point farthest off.
        worst: usize,
        /// Its residual, millimetres.
        worst_mm: f64,
        /// What the points look like instead ("; ..."), or empty.
        hint: String,
    },
    /// Too few poses for a pivot calibration.
    #[error("{count} poses; a pivot calibration needs at least 3")]
    TooFewPoses {
        /// Poses given.
        count: usize,
    },
    /// The tool did not turn enough about two independent axes.
    #[error(
        "the tool turned too little ({spread_deg:.1}° about its least-turned axis, at least {min_deg:.1}° needed): rotate it more while the tip rests on the point"
    )]
    TooLittleRotation {
        /// The rotation spread found, degrees.
        spread_deg: f64,
        /// The minimum asked for, degrees.
        min_deg: f64,
    },
}

/// The result of aligning the vision frame with the robot's base.
#[derive(Debug, Clone, PartialEq)]
pub struct Alignment {
    /// The work object (vision world) in the robot's base frame: RAPID's `wobjdata.uframe`.
    pub base_from_wobj: Pose,
    /// Distance between each robot point and its aligned vision point, millimetres.
    pub residuals_mm: Vec<f64>,
    /// RMS of the residuals, millimetres.
    pub rms_mm: f64,
}

/// Aligns the vision frame with the robot's base from point pairs.
///
/// # Errors
/// [`FramesError`]: mismatched counts, fewer than 3 pairs, non-finite or collinear points.
pub fn align_frames(
    points_in_wobj: &[Point3],
    points_in_base: &[Point3],
) -> Result<Alignment, FramesError> {
    for (i, (a, b)) in points_in_wobj.iter().zip(points_in_base).enumerate() {
        if !a
            .coords
            .iter()
            .chain(b.coords.iter())
            .all(|v| v.is_finite())
        {
            return Err(FramesError::NotFinite { index: i });
        }
    }
    let registration =
        register(points_in_wobj, points_in_base, Scale::Fixed).map_err(|e| match e {
            RegisterError::CountMismatch { model, measured } => FramesError::CountMismatch {
                vision: model,
                robot: measured,
            },
            RegisterError::TooFewPoints { count } => FramesError::TooFewPoints { count },
            RegisterError::Collinear | RegisterError::NotFinite => FramesError::Collinear,
        })?;
    let base_from_wobj = registration.measured_from_model;
    let residuals_mm: Vec<f64> = points_in_wobj
        .iter()
        .zip(points_in_base)
        .map(|(a, b)| (base_from_wobj * a - b).norm())
        .collect();
    let limit_mm = fit_limit_mm(points_in_wobj);
    if registration.rms_mm > limit_mm {
        let (worst, worst_mm) =
            residuals_mm
                .iter()
                .copied()
                .enumerate()
                .fold(
                    (0, 0.0),
                    |best, (i, r)| if r > best.1 { (i, r) } else { best },
                );
        return Err(FramesError::FitTooPoor {
            rms_mm: registration.rms_mm,
            limit_mm,
            worst,
            worst_mm,
            hint: poor_fit_hint(points_in_wobj, points_in_base, limit_mm),
        });
    }
    Ok(Alignment {
        base_from_wobj,
        residuals_mm,
        rms_mm: registration.rms_mm,
    })
}

/// The largest RMS residual an alignment may leave: 1 % of the points' spread (RMS distance
/// from their centroid), at least 1 mm. A TCP touching points on a calibration target is good
/// to a few tenths of a millimetre and the cameras to a tenth; a unit mix-up or a mirrored
/// frame leaves residuals of the order of the spread itself.
fn fit_limit_mm(points: &[Point3]) -> f64 {
    let n = points.len().max(1) as f64;
    let centroid = points
        .iter()
        .fold(nalgebra::Vector3::zeros(), |s, p| s + p.coords)
        / n;
    let spread = (points
        .iter()
        .map(|p| (p.coords - centroid).norm_squared())
        .sum::<f64>()
        / n)
        .sqrt();
    (0.01 * spread).max(1.0)
}

/// What two point sets that fit no rigid motion look like: a unit mix-up (they fit with a
/// scale) or a mirror image (they fit once one axis is flipped); empty when neither.
fn poor_fit_hint(points_in_wobj: &[Point3], points_in_base: &[Point3], limit_mm: f64) -> String {
    if let Ok(scaled) = register(points_in_wobj, points_in_base, Scale::Free)
        && scaled.rms_mm <= limit_mm
        && scaled.scale.is_finite()
        && scaled.scale > 0.0
    {
        let s = scaled.scale;
        let near = |target: f64| (s / target).ln().abs() < 0.05;
        let units = if near(1e-3) {
            "the robot's points look like metres and the cameras' millimetres"
        } else if near(1e3) {
            "the cameras' points look like metres and the robot's millimetres"
        } else if near(1.0 / 25.4) {
            "the robot's points look like inches and the cameras' millimetres"
        } else if near(25.4) {
            "the cameras' points look like inches and the robot's millimetres"
        } else {
            "the two sets differ in scale"
        };
        return format!("; they fit with a scale of {s:.6}: {units} (give both in millimetres)");
    }
    let flipped: Vec<Point3> = points_in_wobj
        .iter()
        .map(|p| Point3::new(p.x, p.y, -p.z))
        .collect();
    if let Ok(mirrored) = register(&flipped, points_in_base, Scale::Fixed)
        && mirrored.rms_mm <= limit_mm
    {
        return format!(
            "; they fit as a mirror image (rms {:.2} mm with one axis flipped): one of the frames is left-handed, or two columns are swapped",
            mirrored.rms_mm
        );
    }
    String::new()
}

/// Options of [`pivot_calibration`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PivotConfig {
    /// The smallest rotation spread accepted about the tool's least-turned axis, radians.
    /// Default 10°: the tip error is about the marker-position noise divided by the spread in
    /// radians, so 10° multiplies 0.05 mm of noise into about 0.3 mm.
    pub min_rotation_spread: f64,
}

impl Default for PivotConfig {
    fn default() -> Self {
        Self {
            min_rotation_spread: 10f64.to_radians(),
        }
    }
}

/// The result of a pivot calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Pivot {
    /// The tip in the tool frame (the TCP), millimetres.
    pub tip_in_tool: Point3,
    /// The point the tip rested on, in the world frame.
    pub pivot_in_world: Point3,
    /// Distance of each pose's tip from the pivot, millimetres.
    pub residuals_mm: Vec<f64>,
    /// RMS of the residuals, millimetres.
    pub rms_mm: f64,
    /// The rotation spread about the least-turned axis, radians.
    pub rotation_spread: f64,
}

/// Pivot calibration from the tool's poses while its tip rests on one point.
///
/// # Errors
/// [`FramesError`]: fewer than 3 poses, a non-finite pose, or too little rotation.
pub fn pivot_calibration(
    world_from_tool: &[Pose],
    config: &PivotConfig,
) -> Result<Pivot, FramesError> {
    let n = world_from_tool.len();
    if n < 3 {
        return Err(FramesError::TooFewPoses { count: n });
    }
    for (i, pose) in world_from_tool.iter().enumerate() {
        let finite = pose.translation.vector.iter().all(|v| v.is_finite())
            && pose.rotation.coords.iter().all(|v| v.is_finite());
        if !finite {
            return Err(FramesError::NotFinite { index: i });
        }
    }
    // Spread: the smallest singular value of the stacked centred rotations `R_k - R̄`, per
    // pose, from the 3x3 Gram matrix. For small turns R ≈ I + [ω]×, this is the RMS angle
    // about the least-excited axis.
    let matrices: Vec<Matrix3<f64>> = world_from_tool
        .iter()
        .map(|p| p.rotation.to_rotation_matrix().into_inner())
        .collect();
    let mean = matrices.iter().sum::<Matrix3<f64>>() / n as f64;
    let gram: Matrix3<f64> = matrices
        .iter()
        .map(|m| (m - mean).transpose() * (m - mean))
        .sum();
    let smallest = gram
        .symmetric_eigenvalues()
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let rotation_spread = (smallest.max(0.0) / n as f64).sqrt();
    if rotation_spread < config.min_rotation_spread {
        return Err(FramesError::TooLittleRotation {
            spread_deg: rotation_spread.to_degrees(),
            min_deg: config.min_rotation_spread.to_degrees(),
        });
    }
    // Normal equations of [R_k  -I] x = -t_k, accumulated as 3x3 blocks:
    // AᵀA = [[n I, -Σ R_kᵀ], [-Σ R_k, n I]], Aᵀb = [-Σ R_kᵀ t_k, Σ t_k]. Well conditioned once
    // the spread check has passed, so a 6x6 solve loses no accuracy that matters.
    let sum_r: Matrix3<f64> = matrices.iter().sum();
    let mut normal = Matrix6::zeros();
    normal
        .fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(Matrix3::identity() * n as f64));
    normal
        .fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(Matrix3::identity() * n as f64));
    normal
        .fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-sum_r.transpose()));
    normal.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-sum_r));
    let mut rhs = Vector6::zeros();
    for (pose, m) in world_from_tool.iter().zip(&matrices) {
        let t = pose.translation.vector;
        let top = -(m.transpose() * t);
        rhs.fixed_rows_mut::<3>(0).add_assign(&top);
        rhs.fixed_rows_mut::<3>(3).add_assign(&t);
    }
    let solution =
        normal
            .cholesky()
            .map(|c| c.solve(&rhs))
            .ok_or(FramesError::TooLittleRotation {
                spread_deg: rotation_spread.to_degrees(),
                min_deg: config.min_rotation_spread.to_degrees(),
            })?;
    let tip_in_tool = Point3::new(solution[0], solution[1], solution[2]);
    let pivot_in_world = Point3::new(solution[3], solution[4], solution[5]);
    let residuals_mm: Vec<f64> = world_from_tool
        .iter()
        .map(|p| (p * tip_in_tool - pivot_in_world).norm())
        .collect();
    let rms_mm = (residuals_mm.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt();
    Ok(Pivot {
        tip_in_tool,
        pivot_in_world,
        residuals_mm,
        rms_mm,
        rotation_spread,
    })
}

/// Point pairs for [`align_frames`]: the same physical points in the work-object (vision) frame
/// and in the robot's base frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointPairs {
    /// Points as the cameras saw them, in the work-object frame.
    pub in_wobj: Vec<Point3>,
    /// The same points touched by the robot's TCP, in its base frame.
    pub in_base: Vec<Point3>,
}

/// The header of a point-pairs CSV.
pub const POINT_PAIRS_HEADER: [&str; 6] = [
    "x_wobj_mm",
    "y_wobj_mm",
    "z_wobj_mm",
    "x_base_mm",
    "y_base_mm",
    "z_base_mm",
];

/// Parses a point-pairs CSV: the header [`POINT_PAIRS_HEADER`], then one pair per line.
///
/// # Errors
/// A lowercase message naming the 1-based line and the column.
pub fn parse_point_pairs(text: &str) -> Result<PointPairs, String> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim_end_matches('\r')));
    let header_ok = lines.next().is_some_and(|(_, h)| {
        h.split(',').map(str::trim).collect::<Vec<_>>() == POINT_PAIRS_HEADER
    });
    if !header_ok {
        return Err(format!(
            "line 1: header must be {}",
            POINT_PAIRS_HEADER.join(",")
        ));
    }
    let mut pairs = PointPairs::default();
    for (line, row) in lines {
        if row.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != 6 {
            return Err(format!("line {line}: {} fields, expected 6", fields.len()));
        }
        let mut v = [0.0; 6];
        for (c, (slot, field)) in v.iter_mut().zip(&fields).enumerate() {
            *slot = field
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    format!(
                        "line {line}: {}: '{field}' is not a finite number",
                        POINT_PAIRS_HEADER[c]
                    )
                })?;
        }
        pairs.in_wobj.push(Point3::new(v[0], v[1], v[2]));
        pairs.in_base.push(Point3::new(v[3], v[4], v[5]));
    }
    Ok(pairs)
}
