//! Cubic spline interpolation (paper §III-A), the numbers of `scipy.interpolate.CubicSpline`.
//!
//! Model: on each interval `[x_i, x_{i+1}]` of length `h_i` a cubic, with values, slopes and
//! second derivatives `M_i` continuous at the knots:
//! `h_{i-1} M_{i-1} + 2(h_{i-1} + h_i) M_i + h_i M_{i+1} = 6 (Δ_i - Δ_{i-1})`, `Δ_i` the
//! slope of the chord. Ends: *natural* (`M_0 = M_{n-1} = 0`) or *not-a-knot* (the third
//! derivative is continuous at `x_1` and `x_{n-2}`; with three points a single parabola, with
//! two a line, as scipy does). The spline passes through every sample, so it cannot remove
//! noise (the paper's finding); it fills gaps and evaluates between samples.

/// End conditions of a cubic spline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SplineEnds {
    /// Zero second derivative at both ends.
    Natural,
    /// Third derivative continuous across the second and second-to-last knots (scipy's
    /// default).
    #[default]
    NotAKnot,
}

/// Why a spline cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SplineError {
    /// Fewer than two samples.
    #[error("a cubic spline needs at least 2 samples, got {count}")]
    TooFew {
        /// Samples given.
        count: usize,
    },
    /// Abscissae and values differ in length.
    #[error("{x} abscissae for {y} values")]
    LengthMismatch {
        /// Abscissae.
        x: usize,
        /// Values.
        y: usize,
    },
    /// Abscissae not strictly increasing or not finite, or a value not finite.
    #[error("sample {index}: abscissa {x} and value {y} must be finite, abscissae increasing")]
    BadSample {
        /// Index of the sample.
        index: usize,
        /// Its abscissa.
        x: f64,
        /// Its value.
        y: f64,
    },
}

/// A cubic spline through `(x_i, y_i)`, stored as knots, values and second derivatives.
#[derive(Debug, Clone, PartialEq)]
pub struct CubicSpline {
    x: Vec<f64>,
    y: Vec<f64>,
    second: Vec<f64>,
}

impl CubicSpline {
    /// The interpolating spline with the given ends.
    ///
    /// # Errors
    /// [`SplineError`] for fewer than two samples, unequal lengths, non-finite numbers or
    /// abscissae that do not increase.
    pub fn new(x: &[f64], y: &[f64], ends: SplineEnds) -> Result<Self, SplineError> {
        if x.len() != y.len() {
            return Err(SplineError::LengthMismatch {
                x: x.len(),
                y: y.len(),
            });
        }
        let n = x.len();
        if n < 2 {
            return Err(SplineError::TooFew { count: n });
        }
        for i in 0..n {
            let increasing = i == 0 || x[i] > x[i - 1];
            if !(x[i].is_finite() && y[i].is_finite() && increasing) {
                return Err(SplineError::BadSample {
                    index: i,
                    x: x[i],
                    y: y[i],
                });
            }
        }
        let second = match (ends, n) {
            (_, 2) => vec![0.0; 2],
            (SplineEnds::NotAKnot, 3) => {
                // One parabola through three points: constant second derivative.
                let d0 = (y[1] - y[0]) / (x[1] - x[0]);
                let d1 = (y[2] - y[1]) / (x[2] - x[1]);
                vec![2.0 * (d1 - d0) / (x[2] - x[0]); 3]
            }
            _ => second_derivatives(x, y, ends),
        };
        Ok(Self {
            x: x.to_vec(),
            y: y.to_vec(),
            second,
        })
    }

    /// Value at `at` (the end cubics extend beyond the knots).
    #[must_use]
    pub fn value(&self, at: f64) -> f64 {
        let (i, h, a, b) = self.locate(at);
        let (m0, m1) = (self.second[i], self.second[i + 1]);
        m0 * a.powi(3) / (6.0 * h)
            + m1 * b.powi(3) / (6.0 * h)
            + (self.y[i] / h - m0 * h / 6.0) * a
            + (self.y[i + 1] / h - m1 * h / 6.0) * b
    }

    /// First derivative at `at`.
    #[must_use]
    pub fn derivative(&self, at: f64) -> f64 {
        let (i, h, a, b) = self.locate(at);
        let (m0, m1) = (self.second[i], self.second[i + 1]);
        -m0 * a * a / (2.0 * h) + m1 * b * b / (2.0 * h) + (self.y[i + 1] - self.y[i]) / h
            - (m1 - m0) * h / 6.0
    }

    /// Second derivative at `at`.
    #[must_use]
    pub fn second_derivative(&self, at: f64) -> f64 {
        let (i, h, a, b) = self.locate(at);
        (self.second[i] * a + self.second[i + 1] * b) / h
    }

    /// Interval index `i`, its length, and the distances `x_{i+1} - at`, `at - x_i`.
    fn locate(&self, at: f64) -> (usize, f64, f64, f64) {
        let n = self.x.len();
        let i = self.x.partition_point(|&v| v <= at).clamp(1, n - 1) - 1;
        let h = self.x[i + 1] - self.x[i];
        (i, h, self.x[i + 1] - at, at - self.x[i])
    }
}

/// Second derivatives at the knots for `n >= 3` (natural) or `n >= 4` (not-a-knot): the
/// tridiagonal system in the interior unknowns `M_1..M_{n-2}`, solved by the Thomas algorithm;
/// not-a-knot eliminates `M_0` and `M_{n-1}` into the first and last rows.
fn second_derivatives(x: &[f64], y: &[f64], ends: SplineEnds) -> Vec<f64> {
    let n = x.len();
    let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let chord: Vec<f64> = (0..n - 1).map(|i| (y[i + 1] - y[i]) / h[i]).collect();
    let m = n - 2;
    let mut sub = vec![0.0; m];
    let mut diag = vec![0.0; m];
    let mut sup = vec![0.0; m];
    let mut rhs = vec![0.0; m];
    for k in 0..m {
        let i = k + 1;
        sub[k] = h[i - 1];
        diag[k] = 2.0 * (h[i - 1] + h[i]);
        sup[k] = h[i];
        rhs[k] = 6.0 * (chord[i] - chord[i - 1]);
    }
    if ends == SplineEnds::NotAKnot {
        // M_0 = ((h0 + h1) M_1 - h0 M_2) / h1, and symmetrically at the end.
        let (h0, h1) = (h[0], h[1]);
        diag[0] += h0 * (h0 + h1) / h1;
        sup[0] -= h0 * h0 / h1;
        let (ha, hb) = (h[n - 3], h[n - 2]);
        diag[m - 1] += hb * (ha + hb) / ha;
        sub[m - 1] -= hb * hb / ha;
    }
    let interior = solve_tridiagonal(&sub, &diag, &sup, &rhs);
    let mut second = vec![0.0; n];
    second[1..n - 1].copy_from_slice(&interior);
    if ends == SplineEnds::NotAKnot {
        let (h0, h1) = (h[0], h[1]);
        second[0] = ((h0 + h1) * second[1] - h0 * second[2]) / h1;
        let (ha, hb) = (h[n - 3], h[n - 2]);
        second[n - 1] = ((ha + hb) * second[n - 2] - hb * second[n - 3]) / ha;
    }
    second
}

/// Thomas algorithm; `sub[0]` and `sup[m-1]` are ignored.
fn solve_tridiagonal(sub: &[f64], diag: &[f64], sup: &[f64], rhs: &[f64]) -> Vec<f64> {
    let m = diag.len();
    let mut c = vec![0.0; m];
    let mut d = vec![0.0; m];
    c[0] = sup[0] / diag[0];
    d[0] = rhs[0] / diag[0];
    for k in 1..m {
        let denominator = diag[k] - sub[k] * c[k - 1];
        c[k] = sup[k] / denominator;
        d[k] = (rhs[k] - sub[k] * d[k - 1]) / denominator;
    }
    let mut out = vec![0.0; m];
    out[m - 1] = d[m - 1];
    for k in (0..m - 1).rev() {
        out[k] = d[k] - c[k] * out[k + 1];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproduces_cubics_exactly_with_not_a_knot_ends() {
        // Not-a-knot reproduces any cubic: a closed-form check independent of scipy.
        let f = |x: f64| 0.5 * x.powi(3) - 2.0 * x * x + x - 3.0;
        let x = [0.0, 0.4, 1.1, 1.5, 2.7, 3.0, 4.2];
        let y: Vec<f64> = x.iter().map(|&v| f(v)).collect();
        let s = CubicSpline::new(&x, &y, SplineEnds::NotAKnot).unwrap();
        for q in [0.1, 0.77, 2.0, 3.9, 4.5] {
            assert!((s.value(q) - f(q)).abs() < 1e-12);
            assert!((s.derivative(q) - (1.5 * q * q - 4.0 * q + 1.0)).abs() < 1e-11);
            assert!((s.second_derivative(q) - (3.0 * q - 4.0)).abs() < 1e-10);
        }
    }

    #[test]
    fn refuses_bad_samples() {
        assert!(CubicSpline::new(&[0.0], &[1.0], SplineEnds::Natural).is_err());
        assert!(CubicSpline::new(&[0.0, 0.0, 1.0], &[1.0, 2.0, 3.0], SplineEnds::Natural).is_err());
        assert!(CubicSpline::new(&[0.0, 1.0], &[1.0, f64::NAN], SplineEnds::Natural).is_err());
    }
}
