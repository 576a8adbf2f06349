//! A dense Levenberg–Marquardt solver on nalgebra, on a manifold.
//!
//! Minimises `C(x) = Σ rᵢ(x)²`. Each step solves the damped normal equations
//! `(JᵀJ + λ diag(JᵀJ)) δ = -Jᵀr` (Marquardt's scaling, so parameters in pixels and in
//! radians are damped alike), moves by `x ⊞ δ` (the problem's retraction: rotations are
//! updated by `exp(δω) R`), and adapts `λ` with Nielsen's rule from the gain ratio
//! `ρ = (C(x) - C(x ⊞ δ)) / (predicted decrease)` (Madsen, Nielsen & Tingleff 2004,
//! *Methods for non-linear least squares problems*, §3.2). Problems assemble `JᵀJ` and
//! `Jᵀr` themselves, so a sparse Jacobian is never stored densely.

use nalgebra::{DMatrix, DVector};

/// Options of [`minimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct LmConfig {
    /// Iterations at most; 200 is far beyond the 5–20 a calibration takes from Zhang's start.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction; 1e-12 lets the
    /// estimate settle to well below the corner noise.
    pub relative_cost_tolerance: f64,
    /// Stop when the step is shorter than this fraction of the parameter vector; 1e-12.
    pub relative_step_tolerance: f64,
    /// Initial damping relative to the largest diagonal entry of `JᵀJ`; 1e-3 (Madsen et al.).
    pub initial_damping: f64,
}

impl Default for LmConfig {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            relative_cost_tolerance: 1e-12,
            relative_step_tolerance: 1e-12,
            initial_damping: 1e-3,
        }
    }
}

/// The normal equations of a problem at a point.
#[derive(Debug, Clone, PartialEq)]
pub struct NormalEquations {
    /// `JᵀJ`.
    pub jtj: DMatrix<f64>,
    /// `Jᵀr`.
    pub jtr: DVector<f64>,
    /// `Σ r²`.
    pub cost: f64,
}

impl NormalEquations {
    /// Zeros for `n` parameters.
    #[must_use]
    pub fn zeros(n: usize) -> Self {
        Self {
            jtj: DMatrix::zeros(n, n),
            jtr: DVector::zeros(n),
            cost: 0.0,
        }
    }

    /// Adds one residual row given as sparse `(column, derivative)` pairs.
    pub fn add_row(&mut self, residual: f64, row: &[(usize, f64)]) {
        self.cost += residual * residual;
        for &(i, di) in row {
            self.jtr[i] += di * residual;
            for &(j, dj) in row {
                self.jtj[(i, j)] += di * dj;
            }
        }
    }
}

/// A least-squares problem on a manifold.
pub trait LeastSquares {
    /// A point of the search space (intrinsics, poses...).
    type State: Clone;
    /// Number of free parameters (the length of a step).
    fn parameter_count(&self) -> usize;
    /// `Σ r²` at `state`; `None` where the residuals are undefined (a point behind a camera).
    fn cost(&self, state: &Self::State) -> Option<f64>;
    /// The normal equations at `state`; `None` where the residuals are undefined.
    fn normal_equations(&self, state: &Self::State) -> Option<NormalEquations>;
    /// `state ⊞ step`.
    fn retract(&self, state: &Self::State, step: &DVector<f64>) -> Self::State;
}

/// How a minimisation went.
#[derive(Debug, Clone, PartialEq)]
pub struct LmReport {
    /// Iterations run.
    pub iterations: usize,
    /// `Σ r²` at the start.
    pub initial_cost: f64,
    /// `Σ r²` at the end.
    pub final_cost: f64,
    /// True when a tolerance was met before the iteration limit.
    pub converged: bool,
    /// `JᵀJ` at the solution (for covariances).
    pub jtj: DMatrix<f64>,
}

/// Why a minimisation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LmError {
    /// The residuals are undefined or not finite at the start.
    #[error("the residuals are not finite at the starting point")]
    BadStart,
}

/// Levenberg–Marquardt from `start`.
///
/// # Errors
/// [`LmError::BadStart`] when the residuals cannot be evaluated at `start`.
pub fn minimize<P: LeastSquares>(
    problem: &P,
    start: P::State,
    config: &LmConfig,
) -> Result<(P::State, LmReport), LmError> {
    let n = problem.parameter_count();
    let mut state = start;
    let mut equations = problem
        .normal_equations(&state)
        .filter(|e| e.cost.is_finite())
        .ok_or(LmError::BadStart)?;
    let initial_cost = equations.cost;
    let max_diagonal = (0..n).map(|i| equations.jtj[(i, i)]).fold(0.0f64, f64::max);
    let mut lambda = config.initial_damping;
    let mut nu = 2.0;
    let mut converged = false;
    let mut iterations = 0;
    // Floor for a zero diagonal entry (a parameter nothing depends on), so the damped system
    // stays positive definite.
    let floor = 1e-12 * max_diagonal.max(f64::MIN_POSITIVE);
    while iterations < config.max_iterations {
        iterations += 1;
        let mut damped = equations.jtj.clone();
        for i in 0..n {
            damped[(i, i)] += lambda * equations.jtj[(i, i)].max(floor);
        }
        let Some(cholesky) = damped.cholesky() else {
            lambda *= nu;
            nu *= 2.0;
            if lambda > 1e20 {
                break;
            }
            continue;
        };
        let step = -cholesky.solve(&equations.jtr);
        let candidate = problem.retract(&state, &step);
        let new_cost = problem.cost(&candidate).filter(|c| c.is_finite());
        // Predicted decrease of the linear model: δᵀ(λ D δ - Jᵀr).
        let mut predicted = 0.0;
        for i in 0..n {
            predicted +=
                step[i] * (lambda * equations.jtj[(i, i)].max(floor) * step[i] - equations.jtr[i]);
        }
        match new_cost {
            Some(cost) if cost < equations.cost => {
                let rho = (equations.cost - cost) / predicted.max(f64::MIN_POSITIVE);
                let decrease = equations.cost - cost;
                let old_cost = equations.cost;
                state = candidate;
                let Some(next) = problem.normal_equations(&state) else {
                    break;
                };
                equations = next;
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                let step_small =
                    step.norm() <= config.relative_step_tolerance * (1.0 + step.len() as f64);
                if decrease <= config.relative_cost_tolerance * old_cost || step_small {
                    converged = true;
                    break;
                }
            }
            _ => {
                lambda *= nu;
                nu *= 2.0;
                if lambda > 1e20 {
                    // No step lowers the cost: at a minimum to machine precision.
                    converged = true;
                    break;
                }
            }
        }
    }
    let final_cost = equations.cost;
    Ok((
        state,
        LmReport {
            iterations,
            initial_cost,
            final_cost,
            converged,
            jtj: equations.jtj,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rosenbrock as residuals `(10 (y - x²), 1 - x)`: the minimum (1, 1) from (-1.2, 1).
    struct Rosenbrock;

    impl LeastSquares for Rosenbrock {
        type State = DVector<f64>;
        fn parameter_count(&self) -> usize {
            2
        }
        fn cost(&self, s: &DVector<f64>) -> Option<f64> {
            Some((10.0 * (s[1] - s[0] * s[0])).powi(2) + (1.0 - s[0]).powi(2))
        }
        fn normal_equations(&self, s: &DVector<f64>) -> Option<NormalEquations> {
            let mut e = NormalEquations::zeros(2);
            e.add_row(10.0 * (s[1] - s[0] * s[0]), &[(0, -20.0 * s[0]), (1, 10.0)]);
            e.add_row(1.0 - s[0], &[(0, -1.0)]);
            Some(e)
        }
        fn retract(&self, s: &DVector<f64>, step: &DVector<f64>) -> DVector<f64> {
            s + step
        }
    }

    #[test]
    fn rosenbrock_reaches_its_minimum() {
        let start = DVector::from_vec(vec![-1.2, 1.0]);
        let (x, report) =
            minimize(&Rosenbrock, start, &LmConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        assert!(report.converged);
        assert!(
            (x[0] - 1.0).abs() < 1e-8 && (x[1] - 1.0).abs() < 1e-8,
            "{x}"
        );
        assert!(report.final_cost < 1e-20);
    }
}
