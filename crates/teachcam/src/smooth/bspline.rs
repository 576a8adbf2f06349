//! B-spline least-squares fitting (paper §III-C, "NURBS fitting"), evaluated back at the
//! samples' own times, so no re-sampling is forced on the user.
//!
//! Model: `s(t) = Σ_j c_j N_{j,p}(t)` with `n` control points `c_j` and the B-spline basis
//! `N_{j,p}` of degree `p` on a clamped knot vector: `p + 1` knots at each end of the time
//! span and `n - p - 1` interior knots uniform in time. The coefficients minimise
//! `Σ_i (s(t_i) - y_i)²`. With all weights equal to one, a NURBS is this B-spline; the rational
//! weights add nothing to a least-squares fit of a function of time. The basis is Cox–de Boor
//! (Piegl & Tiller, *The NURBS Book*, A2.2); the normal equations `AᵀA c = Aᵀy` are banded
//! (bandwidth `p + 1`) and solved by a banded Cholesky factorisation, once for all columns.
//! It matches `scipy.interpolate.make_lsq_spline(t, y, knots, k=p)` with the same knots.

/// Why a least-squares B-spline cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BSplineError {
    /// Degree zero, or fewer control points than `degree + 1`.
    #[error(
        "degree {degree} with {control_points} control points: need degree >= 1 and at least degree + 1 control points"
    )]
    BadShape {
        /// Degree asked for.
        degree: usize,
        /// Control points asked for.
        control_points: usize,
    },
    /// Fewer samples than control points, or the samples leave a knot span empty
    /// (Schoenberg–Whitney): the fit is not unique.
    #[error(
        "{samples} samples cannot determine {control_points} control points of degree {degree}"
    )]
    Underdetermined {
        /// Samples given.
        samples: usize,
        /// Control points asked for.
        control_points: usize,
        /// Degree asked for.
        degree: usize,
    },
    /// Times not finite or not increasing.
    #[error("sample {index}: time {time_s} is not finite or does not increase")]
    BadTime {
        /// Index of the sample.
        index: usize,
        /// Its time.
        time_s: f64,
    },
}

/// A clamped knot vector with uniform interior knots over `[start, end]`.
#[must_use]
pub fn clamped_uniform_knots(
    start: f64,
    end: f64,
    degree: usize,
    control_points: usize,
) -> Vec<f64> {
    let interior = control_points - degree - 1;
    let mut knots = vec![start; degree + 1];
    knots.extend((1..=interior).map(|k| start + (end - start) * k as f64 / (interior + 1) as f64));
    knots.extend(std::iter::repeat_n(end, degree + 1));
    knots
}

/// The knot span `s` with `knots[s] <= t < knots[s+1]` (the last span for `t` at the end), and
/// the `degree + 1` basis functions `N_{s-p..=s}` non-zero there (Cox–de Boor).
fn span_and_basis(knots: &[f64], degree: usize, t: f64, basis: &mut [f64]) -> usize {
    let control_points = knots.len() - degree - 1;
    let span =
        (knots.partition_point(|&k| k <= t).saturating_sub(1)).clamp(degree, control_points - 1);
    let mut left = vec![0.0; degree + 1];
    let mut right = vec![0.0; degree + 1];
    basis[0] = 1.0;
    for j in 1..=degree {
        left[j] = t - knots[span + 1 - j];
        right[j] = knots[span + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = basis[r] / (right[r + 1] + left[j - r]);
            basis[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        basis[j] = saved;
    }
    span
}

/// A least-squares B-spline fit on fixed sample times: the factorised normal equations, reused
/// for every column fitted on the same times.
#[derive(Debug, Clone)]
pub struct LeastSquaresBSpline {
    degree: usize,
    knots: Vec<f64>,
    /// Per sample: first non-zero basis index and the `degree + 1` basis values.
    rows: Vec<(usize, Vec<f64>)>,
    /// Banded Cholesky factor `L` of `AᵀA`: `lower[i][d] = L[i][i - d]`.
    lower: Vec<Vec<f64>>,
}

impl LeastSquaresBSpline {
    /// Prepares the fit of `control_points` coefficients of degree `degree` on clamped uniform
    /// knots over the span of `times_s`.
    ///
    /// # Errors
    /// [`BSplineError`] for a bad degree/count, times that do not increase, or too few samples.
    pub fn new(
        times_s: &[f64],
        degree: usize,
        control_points: usize,
    ) -> Result<Self, BSplineError> {
        if degree == 0 || control_points <= degree {
            return Err(BSplineError::BadShape {
                degree,
                control_points,
            });
        }
        for (index, &time_s) in times_s.iter().enumerate() {
            if !time_s.is_finite() || (index > 0 && time_s <= times_s[index - 1]) {
                return Err(BSplineError::BadTime { index, time_s });
            }
        }
        let underdetermined = BSplineError::Underdetermined {
            samples: times_s.len(),
            control_points,
            degree,
        };
        let (Some(&start), Some(&end)) = (times_s.first(), times_s.last()) else {
            return Err(underdetermined);
        };
        if times_s.len() < control_points {
            return Err(underdetermined);
        }
        let knots = clamped_uniform_knots(start, end, degree, control_points);
        let width = degree + 1;
        let mut normal = vec![vec![0.0; width]; control_points];
        let mut rows = Vec::with_capacity(times_s.len());
        let mut basis = vec![0.0; width];
        for &t in times_s {
            let span = span_and_basis(&knots, degree, t, &mut basis);
            let first = span - degree;
            for r in 0..width {
                for c in 0..=r {
                    normal[first + r][r - c] += basis[r] * basis[c];
                }
            }
            rows.push((first, basis.clone()));
        }
        let lower = banded_cholesky(normal, width).ok_or(underdetermined)?;
        Ok(Self {
            degree,
            knots,
            rows,
            lower,
        })
    }

    /// The knot vector.
    #[must_use]
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// The fitted control points for the values `y` at the prepared times.
    ///
    /// # Panics
    /// Never on data; `y` must have one value per prepared time (checked by the caller).
    #[must_use]
    pub fn coefficients(&self, y: &[f64]) -> Vec<f64> {
        let n = self.lower.len();
        let width = self.degree + 1;
        let mut rhs = vec![0.0; n];
        for ((first, basis), value) in self.rows.iter().zip(y) {
            for (r, b) in basis.iter().enumerate() {
                rhs[first + r] += b * value;
            }
        }
        // L z = rhs, then Lᵀ c = z.
        for i in 0..n {
            let mut sum = rhs[i];
            for d in 1..width.min(i + 1) {
                sum -= self.lower[i][d] * rhs[i - d];
            }
            rhs[i] = sum / self.lower[i][0];
        }
        for i in (0..n).rev() {
            let mut sum = rhs[i];
            for d in 1..width.min(n - i) {
                sum -= self.lower[i + d][d] * rhs[i + d];
            }
            rhs[i] = sum / self.lower[i][0];
        }
        rhs
    }

    /// The fitted curve at the prepared times.
    #[must_use]
    pub fn fit(&self, y: &[f64]) -> Vec<f64> {
        let c = self.coefficients(y);
        self.rows
            .iter()
            .map(|(first, basis)| basis.iter().zip(&c[*first..]).map(|(b, c)| b * c).sum())
            .collect()
    }
}

/// Cholesky factor of a symmetric positive-definite band matrix given by its lower band
/// (`band[i][d] = A[i][i-d]`); `None` when it is not positive definite.
fn banded_cholesky(mut band: Vec<Vec<f64>>, width: usize) -> Option<Vec<Vec<f64>>> {
    let n = band.len();
    let scale = band.iter().map(|r| r[0]).fold(0.0, f64::max);
    for i in 0..n {
        for d in (0..width.min(i + 1)).rev() {
            let j = i - d;
            let mut sum = band[i][d];
            for k in 1..width - d {
                if k > j {
                    break;
                }
                sum -= band[i][d + k] * band[j][k];
            }
            if d == 0 {
                if sum <= 1e-13 * scale {
                    return None;
                }
                band[i][0] = sum.sqrt();
            } else {
                band[i][d] = sum / band[j][0];
            }
        }
    }
    Some(band)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_polynomials_of_its_degree() {
        // A least-squares spline reproduces any polynomial of degree <= p exactly.
        let t: Vec<f64> = (0..80).map(|i| i as f64 * 0.05).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|x| 2.0 - x + 0.3 * x * x - 0.1 * x.powi(3))
            .collect();
        let fit = LeastSquaresBSpline::new(&t, 3, 9).unwrap().fit(&y);
        for (a, b) in fit.iter().zip(&y) {
            assert!((a - b).abs() < 1e-10, "{a} {b}");
        }
    }

    #[test]
    fn refuses_underdetermined_fits() {
        let t: Vec<f64> = (0..5).map(f64::from).collect();
        assert!(matches!(
            LeastSquaresBSpline::new(&t, 3, 8),
            Err(BSplineError::Underdetermined { .. })
        ));
        assert!(LeastSquaresBSpline::new(&t, 0, 3).is_err());
        assert!(LeastSquaresBSpline::new(&[0.0, 1.0, 1.0, 2.0], 1, 2).is_err());
    }
}
