//! Cut-off suggestion by residual analysis (Winter, *Biomechanics and Motor Control of Human
//! Movement*, 4th ed., §3.4.4.4), so the user is not left to tune it by hand.
//!
//! Model: for a signal plus white noise of RMS `σ`, the residual `R(fc) = RMS(x - filtfilt_fc(x))`
//! is, at cut-offs well above the motion's band, noise only and nearly a straight line in
//! `fc` that reaches about `σ` at `fc = 0`. The line is fitted over the upper part of the band
//! (here 50 % to 90 % of Nyquist); its intercept `a` estimates the noise's RMS. The suggested
//! cut-off is the lowest `fc` at which the residual falls to `a`: below it the residual is
//! mostly removed signal, above it mostly kept noise.

use super::butterworth::{Butterworth, FilterError};

/// The residual curve and the cut-off it suggests.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualAnalysis {
    /// Cut-offs tried, Hz.
    pub cutoffs_hz: Vec<f64>,
    /// RMS residual at each cut-off, in the series' unit.
    pub residual_rms: Vec<f64>,
    /// Intercept at 0 Hz of the line fitted to the noise-only part: the noise's RMS estimate.
    pub noise_rms: f64,
    /// The lowest cut-off whose residual is at most `noise_rms`, Hz.
    pub suggested_cutoff_hz: f64,
}

/// Residual analysis of `values` for a Butterworth of `order` (single-pass cut-offs, as
/// [`Butterworth::filtfilt`]), on `steps` cut-offs evenly spaced up to 90 % of Nyquist.
///
/// # Errors
/// [`FilterError`] when the series is too short for the filter's padding, not finite, or the
/// rate or order is bad.
pub fn residual_analysis(
    values: &[f64],
    sample_rate_hz: f64,
    order: usize,
    steps: usize,
) -> Result<ResidualAnalysis, FilterError> {
    let steps = steps.max(10);
    let nyquist_hz = sample_rate_hz / 2.0;
    let cutoffs_hz: Vec<f64> = (1..=steps)
        .map(|k| 0.9 * nyquist_hz * k as f64 / steps as f64)
        .collect();
    let residual_rms = cutoffs_hz
        .iter()
        .map(|&fc| {
            let filtered = Butterworth::lowpass(order, fc, sample_rate_hz)?.filtfilt(values)?;
            let sum: f64 = values
                .iter()
                .zip(&filtered)
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            Ok((sum / values.len() as f64).sqrt())
        })
        .collect::<Result<Vec<f64>, FilterError>>()?;
    // Least-squares line over the cut-offs in the upper part of the band.
    let upper: Vec<(f64, f64)> = cutoffs_hz
        .iter()
        .zip(&residual_rms)
        .filter(|(f, _)| **f >= 0.5 * nyquist_hz)
        .map(|(f, r)| (*f, *r))
        .collect();
    let n = upper.len() as f64;
    let mean_f = upper.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_r = upper.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = upper.iter().map(|p| (p.0 - mean_f).powi(2)).sum();
    let sxy: f64 = upper.iter().map(|p| (p.0 - mean_f) * (p.1 - mean_r)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let noise_rms = mean_r - slope * mean_f;
    let suggested_cutoff_hz = cutoffs_hz
        .iter()
        .zip(&residual_rms)
        .find(|(_, r)| **r <= noise_rms)
        .map_or(cutoffs_hz[cutoffs_hz.len() - 1], |(f, _)| *f);
    Ok(ResidualAnalysis {
        cutoffs_hz,
        residual_rms,
        noise_rms,
        suggested_cutoff_hz,
    })
}
