//! Amplitude spectrum of a uniformly sampled series (paper Fig. 7).
//!
//! Model: for `n` samples at `fs`, the real DFT `X_k = Σ_j x_j e^{-2πi jk/n}` at
//! `f_k = k·fs/n`, `k = 0..=n/2`; the single-sided amplitude is `2|X_k|/n`, except `|X_0|/n`
//! (the mean) and, for even `n`, `|X_{n/2}|/n`, so a sinusoid of amplitude `A` on a bin shows
//! `A`. Same numbers as `numpy.fft.rfft`, scaled so.

use realfft::RealFftPlanner;

/// Amplitudes against frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Bin frequencies, Hz, from 0 to Nyquist.
    pub frequency_hz: Vec<f64>,
    /// Single-sided amplitude at each frequency, in the series' unit.
    pub amplitude: Vec<f64>,
}

/// The single-sided amplitude spectrum of `values` sampled at `sample_rate_hz`; empty for an
/// empty series.
#[must_use]
pub fn amplitude_spectrum(values: &[f64], sample_rate_hz: f64) -> Spectrum {
    let n = values.len();
    if n == 0 {
        return Spectrum {
            frequency_hz: Vec::new(),
            amplitude: Vec::new(),
        };
    }
    single_sided(values.to_vec(), sample_rate_hz, n as f64)
}

/// The single-sided amplitudes of the real DFT of `input` (already windowed, `n ≥ 1` samples),
/// `2|X_k| / gain` except the mean and, for even `n`, Nyquist, which are `|X_k| / gain`. With
/// `gain = n` a sinusoid on a bin reads its amplitude; a window's coherent gain `Σ w_j` does
/// the same for windowed input. One function for the plain and the windowed spectrum.
pub(crate) fn single_sided(mut input: Vec<f64>, sample_rate_hz: f64, gain: f64) -> Spectrum {
    let n = input.len();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(n);
    let mut output = fft.make_output_vec();
    // Lengths match the plan by construction, so the transform cannot fail.
    let _ = fft.process(&mut input, &mut output);
    let scale = 2.0 / gain;
    let mut amplitude: Vec<f64> = output.iter().map(|c| c.norm() * scale).collect();
    amplitude[0] /= 2.0;
    if n % 2 == 0
        && let Some(last) = amplitude.last_mut()
    {
        *last /= 2.0;
    }
    let frequency_hz = (0..amplitude.len())
        .map(|k| k as f64 * sample_rate_hz / n as f64)
        .collect();
    Spectrum {
        frequency_hz,
        amplitude,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sinusoid_on_a_bin_shows_its_amplitude() {
        let fs = 100.0;
        let x: Vec<f64> = (0..400)
            .map(|i| 3.0 + 2.5 * (2.0 * std::f64::consts::PI * 5.0 * i as f64 / fs).sin())
            .collect();
        let s = amplitude_spectrum(&x, fs);
        assert_eq!(s.frequency_hz.len(), 201);
        assert!((s.amplitude[0] - 3.0).abs() < 1e-12);
        assert!((s.frequency_hz[20] - 5.0).abs() < 1e-12);
        assert!((s.amplitude[20] - 2.5).abs() < 1e-12);
        assert!(s.amplitude[21] < 1e-12);
    }
}
