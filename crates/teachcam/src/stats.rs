//! Robust summaries of samples that every stage measuring its limits from the data shares:
//! the median, the normal-consistent median absolute deviation and the root mean square.
//!
//! Model. For a sample `x`, `σ̂ = 1.4826 · median(|x − median(x)|)` estimates the standard
//! deviation of its normal part whatever a minority of outliers does (Rousseeuw & Croux 1993).
//! Non-finite values are left out of every summary.

/// `σ / MAD` for a normal distribution.
const MAD_TO_SIGMA: f64 = 1.4826;

/// Median and normal-consistent MAD of a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustScale {
    /// The median.
    pub median: f64,
    /// `1.4826 · median(|x − median|)`.
    pub sigma: f64,
    /// Values used (finite ones).
    pub count: usize,
}

/// The median of finite values, `None` for none.
#[must_use]
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// Median and σ̂ of the finite values, `None` for none.
#[must_use]
pub fn robust_scale(values: &[f64]) -> Option<RobustScale> {
    let m = median(values)?;
    let deviations: Vec<f64> = values
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| (x - m).abs())
        .collect();
    Some(RobustScale {
        median: m,
        sigma: MAD_TO_SIGMA * median(&deviations)?,
        count: deviations.len(),
    })
}

/// Root mean square of `values`; 0 for none.
#[must_use]
pub fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len().max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summaries_match_hand_computed_values() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[4.0, 1.0, f64::NAN, 2.0, 3.0]), Some(2.5));
        assert_eq!(median(&[]), None);
        // |x − 3| = 2, 1, 0, 1, 97: MAD 1.
        let s = robust_scale(&[1.0, 2.0, 3.0, 4.0, 100.0]).expect("values");
        assert_eq!((s.median, s.count), (3.0, 5));
        assert!((s.sigma - 1.4826).abs() < 1e-12);
        assert!((rms(&[3.0, 4.0]) - 12.5_f64.sqrt()).abs() < 1e-12);
        assert_eq!(rms(&[]), 0.0);
    }
}
