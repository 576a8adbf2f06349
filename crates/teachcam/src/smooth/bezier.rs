//! The Bezier curve with the samples as control points (paper §III-B), by de Casteljau's
//! algorithm.
//!
//! Model: `B(u) = Σ_{i=0}^{n} C(n,i) u^i (1-u)^{n-i} P_i`, `u = (t - t_0)/(t_n - t_0)`, with
//! the `n + 1` samples `P_i` as control points. De Casteljau evaluates it by repeated linear
//! interpolation `P_i ← (1 - u) P_i + u P_{i+1}`, `n` rounds: stable, `O(n²)` per point, so the
//! whole curve at every sample time costs `O(n³)`.
//!
//! Why it flattens the motion: the Bernstein weights at `u` form a binomial distribution of
//! mean `n·u` and standard deviation `√(n u (1-u))` samples, so `B(t)` is a moving average of
//! the samples over a window that grows as `√n`. A sinusoid of period `T` samples is attenuated
//! by about `exp(-2π² n u(1-u) / T²)` (the Gaussian limit of the binomial): the more samples,
//! the flatter the curve; noise vanishes, and so does the motion. The curve passes only through
//! the first and last samples.

/// Value of the Bezier curve with control points `control` at `u` in `[0, 1]`.
#[must_use]
pub fn de_casteljau(control: &[f64], u: f64) -> f64 {
    let mut points = control.to_vec();
    let v = 1.0 - u;
    for round in 1..points.len() {
        for i in 0..points.len() - round {
            points[i] = v * points[i] + u * points[i + 1];
        }
    }
    points.first().copied().unwrap_or(f64::NAN)
}

/// The Bezier curve whose control points are `values` (one per sample, uniform in time),
/// evaluated at each sample's time: `u_i = i / (n - 1)`.
#[must_use]
pub fn bezier_at_samples(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    if n < 2 {
        return values.to_vec();
    }
    let mut points = vec![0.0; n];
    (0..n)
        .map(|i| {
            let u = i as f64 / (n - 1) as f64;
            let v = 1.0 - u;
            points.copy_from_slice(values);
            for round in 1..n {
                for k in 0..n - round {
                    points[k] = v * points[k] + u * points[k + 1];
                }
            }
            points[0]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_through_end_points_and_keeps_straight_lines() {
        // Linear precision: control points on a line give the same line.
        let line: Vec<f64> = (0..30).map(|i| 2.0 + 0.5 * i as f64).collect();
        let curve = bezier_at_samples(&line);
        for (a, b) in curve.iter().zip(&line) {
            assert!((a - b).abs() < 1e-12);
        }
        let bumpy = [0.0, 5.0, -3.0, 2.0];
        assert_eq!(de_casteljau(&bumpy, 0.0), 0.0);
        assert_eq!(de_casteljau(&bumpy, 1.0), 2.0);
    }
}
