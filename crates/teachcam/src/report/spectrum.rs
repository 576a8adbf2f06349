//! The amplitude spectrum a person reads to choose a cut-off: detrended, Hann-windowed.
//!
//! Model: for `n` samples `x_j` at `fs`, remove the least-squares line `a + b·j`, multiply by
//! the periodic Hann window `w_j = ½(1 − cos(2πj/n))`, and take the real DFT
//! `X_k = Σ_j w_j (x_j − a − b·j) e^{-2πi jk/n}` at `f_k = k·fs/n`. The single-sided amplitude
//! is `2|X_k| / Σ_j w_j` (coherent gain corrected), so a sinusoid of amplitude `A` on bin `k`
//! reads `A` at `k` and `A/2` at `k ± 1` (the periodic Hann's transform is non-zero only at
//! bins 0 and ±1), and about `0.85·A` half-way between bins (Harris 1978, scalloping loss
//! 1.42 dB).
//!
//! Why: without the window, a recording that does not hold a whole number of periods (a
//! brush stroke never does) leaks its motion into every bin as `1/f`, and the start-to-end
//! offset of a stroke leaks as a ramp's `1/f` too: the spectrum of the noise-free motion then
//! has a floor of its own, which a reader takes for measurement noise. Detrending removes the
//! ramp; the window makes the leak fall as `1/f³`.

use crate::smooth::spectrum::{Spectrum, single_sided};

/// `values` less their least-squares straight line over the sample index.
#[must_use]
pub fn detrended(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    if n < 2 {
        return vec![0.0; n];
    }
    let mean_j = (n - 1) as f64 / 2.0;
    let mean_x = values.iter().sum::<f64>() / n as f64;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (j, x) in values.iter().enumerate() {
        let dj = j as f64 - mean_j;
        sxy += dj * (x - mean_x);
        sxx += dj * dj;
    }
    let slope = sxy / sxx;
    values
        .iter()
        .enumerate()
        .map(|(j, x)| x - mean_x - slope * (j as f64 - mean_j))
        .collect()
}

/// The periodic Hann window of length `n`.
#[must_use]
pub fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|j| 0.5 * (1.0 - (std::f64::consts::TAU * j as f64 / n as f64).cos()))
        .collect()
}

/// The window applied before the transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Window {
    /// The periodic Hann window (the report's, and `teachcam spectrum`'s default).
    #[default]
    Hann,
    /// No window (rectangular): the plain FFT, whose leak falls as `1/f` only.
    None,
}

/// How a spectrum is taken: the window, and whether the least-squares line is removed first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SpectrumMethod {
    /// The window.
    pub window: Window,
    /// Remove the least-squares line before windowing.
    pub detrend: bool,
}

impl Default for SpectrumMethod {
    /// Detrended and Hann-windowed: the report's spectrum.
    fn default() -> Self {
        Self {
            window: Window::Hann,
            detrend: true,
        }
    }
}

impl std::fmt::Display for SpectrumMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let window = match self.window {
            Window::Hann => "Hann-windowed",
            Window::None => "not windowed",
        };
        let trend = if self.detrend {
            "detrended"
        } else {
            "not detrended"
        };
        write!(f, "{trend}, {window}")
    }
}

/// The single-sided amplitude spectrum of `values` sampled at `sample_rate_hz`, taken as
/// `method` says (see the module's model; without the window the gain is `n`); empty for
/// fewer than 4 samples.
#[must_use]
pub fn spectrum_with(values: &[f64], sample_rate_hz: f64, method: SpectrumMethod) -> Spectrum {
    let n = values.len();
    if n < 4 {
        return Spectrum {
            frequency_hz: Vec::new(),
            amplitude: Vec::new(),
        };
    }
    let values = if method.detrend {
        detrended(values)
    } else {
        values.to_vec()
    };
    match method.window {
        Window::Hann => {
            let window = hann(n);
            let gain: f64 = window.iter().sum();
            let input: Vec<f64> = values.iter().zip(&window).map(|(x, w)| x * w).collect();
            single_sided(input, sample_rate_hz, gain)
        }
        Window::None => single_sided(values, sample_rate_hz, n as f64),
    }
}

/// The detrended, Hann-windowed single-sided amplitude spectrum of `values` sampled at
/// `sample_rate_hz` (see the module's model); empty for fewer than 4 samples.
#[must_use]
pub fn windowed_spectrum(values: &[f64], sample_rate_hz: f64) -> Spectrum {
    spectrum_with(values, sample_rate_hz, SpectrumMethod::default())
}

/// The median of the amplitudes at frequencies strictly above `above_hz`, `None` when there
/// are none: the spectrum's floor where the motion has died out.
#[must_use]
pub fn median_above(frequency_hz: &[f64], amplitude: &[f64], above_hz: f64) -> Option<f64> {
    let mut values: Vec<f64> = frequency_hz
        .iter()
        .zip(amplitude)
        .filter(|(f, a)| **f > above_hz && a.is_finite())
        .map(|(_, a)| *a)
        .collect();
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    Some(values[values.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `5 + 3t + A cos(2π f (t + dt/2))` with `f` on bin `k`: the cosine is symmetric about
    /// the record's middle, so it is orthogonal to the line and detrending removes exactly
    /// the line; the periodic Hann's transform is non-zero only at bins 0 and ±1.
    fn line_plus_cosine(n: usize, fs: f64, k: f64, amplitude: f64) -> Vec<f64> {
        let f = k * fs / n as f64;
        (0..n)
            .map(|j| {
                let t = j as f64 / fs;
                5.0 + 3.0 * t + amplitude * (std::f64::consts::TAU * f * (t + 0.5 / fs)).cos()
            })
            .collect()
    }

    #[test]
    fn a_sinusoid_on_a_bin_reads_its_amplitude_and_half_beside_it() {
        let (n, fs, k, a) = (256, 100.0, 20, 2.5);
        let s = windowed_spectrum(&line_plus_cosine(n, fs, k as f64, a), fs);
        assert_eq!(s.frequency_hz.len(), n / 2 + 1);
        assert!((s.frequency_hz[k] - k as f64 * fs / n as f64).abs() < 1e-12);
        assert!((s.amplitude[k] - a).abs() < 1e-9, "{}", s.amplitude[k]);
        assert!((s.amplitude[k - 1] - a / 2.0).abs() < 1e-9);
        assert!((s.amplitude[k + 1] - a / 2.0).abs() < 1e-9);
        for (i, v) in s.amplitude.iter().enumerate() {
            if i + 1 < k || i > k + 1 {
                assert!(*v < 1e-9, "bin {i}: {v} (the line leaked)");
            }
        }
    }

    #[test]
    fn a_sinusoid_between_bins_loses_the_hann_scalloping_and_no_more() {
        // Half a bin off: |W(½)| / W(0) = sinc(½) / (1 − ¼) = 8 / (3π) for the continuous
        // Hann window, the 1.42 dB scalloping loss (Harris 1978).
        let (n, fs, a) = (1024, 100.0, 1.0);
        let s = windowed_spectrum(&line_plus_cosine(n, fs, 40.5, a), fs);
        let peak = s.amplitude[40].max(s.amplitude[41]);
        let expected = 8.0 / (3.0 * std::f64::consts::PI);
        assert!((peak - expected).abs() < 2e-3, "{peak} against {expected}");
    }

    #[test]
    fn the_plain_method_is_the_plain_fft() {
        // No window, no detrend: the unwindowed amplitude spectrum, bin for bin.
        let x = line_plus_cosine(128, 50.0, 10.3, 1.5);
        let plain = spectrum_with(
            &x,
            50.0,
            SpectrumMethod {
                window: Window::None,
                detrend: false,
            },
        );
        let reference = crate::smooth::spectrum::amplitude_spectrum(&x, 50.0);
        assert_eq!(plain, reference);
    }

    #[test]
    fn detrending_removes_a_line_and_nothing_else() {
        let x: Vec<f64> = (0..50).map(|j| 2.0 - 0.25 * j as f64).collect();
        assert!(detrended(&x).iter().all(|v| v.abs() < 1e-12));
    }
}
