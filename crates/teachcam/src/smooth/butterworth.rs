//! Zero-phase Butterworth low-pass: design as `scipy.signal.butter`, forward-backward filtering
//! as `scipy.signal.filtfilt` with its default padding.
//!
//! Design (Butterworth 1930; scipy's `buttap` → `lp2lp_zpk` → `bilinear_zpk` → `zpk2tf`): the
//! analog prototype of order `N` has poles `p_k = -exp(iπ(2k - N + 1)/(2N))`, `k = 0..N`, and
//! no zeros; it is scaled to the pre-warped cut-off `Ω = 2·fs·tan(π·fc/fs)` and mapped to the
//! z-plane by the bilinear transform `z = (2fs + s)/(2fs - s)`, which adds `N` zeros at
//! `z = -1`. The gain makes `H(1) = 1`.
//!
//! Filtering: `filtfilt` runs the direct-form-II-transposed recursion (`lfilter`) forward and
//! then backward, so the phase cancels and the magnitude is `|H|²`. The signal is first
//! extended at both ends by `3·(N+1)` samples of odd extension (`2·x₀ - x[k]`), and each pass
//! starts from the steady state of a step (`lfilter_zi`) scaled by the first sample, exactly
//! as scipy does, so that the output matches `filtfilt(*butter(N, fc, fs=fs), x)`.
//!
//! The cut-off `fc` is, as in scipy, that of the single pass: the forward-backward result is at
//! `|H|² = 1/2` (−6 dB) there. [`winter_corrected_cutoff_hz`] gives the single-pass cut-off
//! that puts the two-pass −3 dB point at the frequency asked for (Winter, *Biomechanics and
//! Motor Control of Human Movement*, 4th ed., §3.4.4.3).

use nalgebra::Complex;

/// A digital IIR filter `H(z) = Σ b_k z^-k / Σ a_k z^-k` with `a[0] = 1`.
#[derive(Debug, Clone, PartialEq)]
pub struct Butterworth {
    /// Numerator coefficients, `N + 1` of them.
    pub b: Vec<f64>,
    /// Denominator coefficients, `N + 1` of them, `a[0] = 1`.
    pub a: Vec<f64>,
}

/// Why a low-pass filter cannot be designed or applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FilterError {
    /// Order zero, or so high that the design loses its accuracy.
    #[error("filter order {order} is outside 1..={MAX_ORDER}")]
    BadOrder {
        /// The order asked for.
        order: usize,
    },
    /// The cut-off is not strictly between 0 and the Nyquist frequency.
    #[error(
        "cut-off {cutoff_hz} Hz must be above 0 and below the Nyquist frequency {nyquist_hz} Hz"
    )]
    BadCutoff {
        /// The cut-off asked for.
        cutoff_hz: f64,
        /// Half the sampling rate.
        nyquist_hz: f64,
    },
    /// The sampling rate is not a positive finite number.
    #[error("sampling rate {sample_rate_hz} Hz is not a positive number")]
    BadSampleRate {
        /// The rate given.
        sample_rate_hz: f64,
    },
    /// The signal is not longer than the padding (scipy refuses the same case).
    #[error(
        "{samples} samples are too few for the order-{order} filter: its padding needs more than {padding}"
    )]
    TooShort {
        /// Samples in the signal.
        samples: usize,
        /// The filter's order.
        order: usize,
        /// `3·(order + 1)`, scipy's default `padlen`.
        padding: usize,
    },
    /// A sample is NaN or infinite.
    #[error("sample {index} is not finite ({value})")]
    NotFinite {
        /// Index of the sample.
        index: usize,
        /// Its value.
        value: f64,
    },
}

/// Highest order accepted: beyond it the transfer-function form loses digits (scipy warns too).
pub const MAX_ORDER: usize = 12;

impl Butterworth {
    /// The low-pass of order `order` and single-pass −3 dB cut-off `cutoff_hz` at
    /// `sample_rate_hz`: the coefficients of `scipy.signal.butter(order, cutoff_hz, fs=...)`.
    ///
    /// # Errors
    /// [`FilterError::BadOrder`], [`FilterError::BadSampleRate`], [`FilterError::BadCutoff`]
    /// (at or above Nyquist, at or below zero, not finite).
    pub fn lowpass(order: usize, cutoff_hz: f64, sample_rate_hz: f64) -> Result<Self, FilterError> {
        if order == 0 || order > MAX_ORDER {
            return Err(FilterError::BadOrder { order });
        }
        if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
            return Err(FilterError::BadSampleRate { sample_rate_hz });
        }
        let nyquist_hz = sample_rate_hz / 2.0;
        if !(cutoff_hz.is_finite() && cutoff_hz > 0.0 && cutoff_hz < nyquist_hz) {
            return Err(FilterError::BadCutoff {
                cutoff_hz,
                nyquist_hz,
            });
        }
        // scipy normalises to fs = 2 (Wn = fc / nyquist) before pre-warping; the same steps
        // in the same order keep the coefficients equal to the last bits.
        let wn = cutoff_hz / nyquist_hz;
        let fs = 2.0;
        let warped = 2.0 * fs * (std::f64::consts::PI * wn / fs).tan();
        let n = order as f64;
        let poles_analog: Vec<Complex<f64>> = (0..order)
            .map(|k| {
                let m = -(n - 1.0) + 2.0 * k as f64;
                let angle = std::f64::consts::PI * m / (2.0 * n);
                -Complex::new(0.0, angle).exp() * warped
            })
            .collect();
        let gain_analog = warped.powi(order as i32);
        let fs2 = 2.0 * fs;
        let poles: Vec<Complex<f64>> = poles_analog
            .iter()
            .map(|p| (Complex::new(fs2, 0.0) + p) / (Complex::new(fs2, 0.0) - p))
            .collect();
        let denominator: Complex<f64> = poles_analog
            .iter()
            .map(|p| Complex::new(fs2, 0.0) - p)
            .product();
        let gain = gain_analog * (Complex::new(1.0, 0.0) / denominator).re;
        let zeros = vec![Complex::new(-1.0, 0.0); order];
        let b = poly(&zeros).iter().map(|c| gain * c.re).collect();
        let a = poly(&poles).iter().map(|c| c.re).collect();
        Ok(Self { b, a })
    }

    /// The filter's order.
    #[must_use]
    pub fn order(&self) -> usize {
        self.a.len() - 1
    }

    /// scipy's default `filtfilt` padding, `3·max(len(a), len(b))`.
    #[must_use]
    pub fn padding(&self) -> usize {
        3 * self.a.len().max(self.b.len())
    }

    /// The filter state (direct form II transposed) after a long run of ones: scipy's
    /// `lfilter_zi`. In direct form II transposed, with `y = H(1) = Σb/Σa`, the state is
    /// `z_{N-1} = b_N - a_N·y`, `z_i = b_{i+1} - a_{i+1}·y + z_{i+1}`.
    #[must_use]
    pub fn steady_state(&self) -> Vec<f64> {
        let order = self.order();
        let gain = self.b.iter().sum::<f64>() / self.a.iter().sum::<f64>();
        let mut zi = vec![0.0; order];
        let mut next = 0.0;
        for i in (0..order).rev() {
            next += self.b[i + 1] - self.a[i + 1] * gain;
            zi[i] = next;
        }
        zi
    }

    /// Runs the recursion over `signal` in place (scipy's `lfilter`, direct form II
    /// transposed), starting from `state`.
    fn filter_with_state(&self, signal: &mut [f64], mut state: Vec<f64>) {
        let order = self.order();
        for x in signal.iter_mut() {
            let input = *x;
            let output = self.b[0] * input + state[0];
            for i in 0..order - 1 {
                state[i] = self.b[i + 1] * input + state[i + 1] - self.a[i + 1] * output;
            }
            state[order - 1] = self.b[order] * input - self.a[order] * output;
            *x = output;
        }
    }

    /// Zero-phase filtering: the numbers of `scipy.signal.filtfilt(b, a, signal)` with the
    /// default `padtype="odd"`, `padlen=3·max(len(a), len(b))`.
    ///
    /// # Errors
    /// [`FilterError::TooShort`] when `signal.len() <= padding`, [`FilterError::NotFinite`].
    pub fn filtfilt(&self, signal: &[f64]) -> Result<Vec<f64>, FilterError> {
        if let Some((index, &value)) = signal.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(FilterError::NotFinite { index, value });
        }
        let edge = self.padding();
        let len = signal.len();
        if len <= edge {
            return Err(FilterError::TooShort {
                samples: len,
                order: self.order(),
                padding: edge,
            });
        }
        let (first, last) = (signal[0], signal[len - 1]);
        let mut extended = Vec::with_capacity(len + 2 * edge);
        extended.extend((1..=edge).rev().map(|k| 2.0 * first - signal[k]));
        extended.extend_from_slice(signal);
        extended.extend((1..=edge).map(|k| 2.0 * last - signal[len - 1 - k]));
        let zi = self.steady_state();
        let scaled = |x0: f64| zi.iter().map(|z| z * x0).collect::<Vec<_>>();
        let x0 = extended[0];
        self.filter_with_state(&mut extended, scaled(x0));
        extended.reverse();
        let y0 = extended[0];
        self.filter_with_state(&mut extended, scaled(y0));
        extended.reverse();
        Ok(extended[edge..edge + len].to_vec())
    }

    /// `|H(e^{iω})|` at `frequency_hz`, single pass.
    #[must_use]
    pub fn magnitude(&self, frequency_hz: f64, sample_rate_hz: f64) -> f64 {
        let omega = 2.0 * std::f64::consts::PI * frequency_hz / sample_rate_hz;
        let eval = |c: &[f64]| -> Complex<f64> {
            c.iter()
                .enumerate()
                .map(|(k, v)| Complex::new(0.0, -omega * k as f64).exp() * *v)
                .sum()
        };
        (eval(&self.b) / eval(&self.a)).norm()
    }
}

/// The single-pass cut-off whose forward-backward (squared) response is −3 dB at
/// `wanted_cutoff_hz`: Winter's correction, generalised to order `order`. For a Butterworth,
/// `|H|² = 1/(1 + (Ω/Ωc)^{2N})` in the pre-warped variable `Ω = tan(πf/fs)`, and two passes
/// reach `1/√2` where `(Ω/Ωc)^{2N} = √2 - 1`, so `Ωc = Ω / (√2 - 1)^{1/(2N)}`
/// (for `N = 2`: Winter's factor 0.802).
#[must_use]
pub fn winter_corrected_cutoff_hz(wanted_cutoff_hz: f64, order: usize, sample_rate_hz: f64) -> f64 {
    let correction = (std::f64::consts::SQRT_2 - 1.0).powf(1.0 / (2.0 * order as f64));
    let warped = (std::f64::consts::PI * wanted_cutoff_hz / sample_rate_hz).tan() / correction;
    sample_rate_hz / std::f64::consts::PI * warped.atan()
}

/// Coefficients of `Π (x - r_k)`, highest power first (numpy's `poly`).
fn poly(roots: &[Complex<f64>]) -> Vec<Complex<f64>> {
    let mut c = vec![Complex::new(1.0, 0.0)];
    for r in roots {
        let mut next = c.clone();
        next.push(Complex::new(0.0, 0.0));
        for (k, ck) in c.iter().enumerate() {
            next[k + 1] -= ck * r;
        }
        c = next;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn winter_factor_for_order_two_is_0_802() {
        // Winter's table: correction factor 0.802 for a second-order filter passed twice.
        let c = (std::f64::consts::SQRT_2 - 1.0).powf(0.25);
        assert!((c - 0.802).abs() < 5e-4, "{c}");
    }

    #[test]
    fn winter_correction_puts_two_pass_response_at_minus_3_db() {
        for order in [2, 4] {
            for (fc, fs) in [(6.0, 100.0), (3.0, 30.0), (12.0, 30.0)] {
                let design = winter_corrected_cutoff_hz(fc, order, fs);
                let f = Butterworth::lowpass(order, design, fs).unwrap();
                let two_pass = f.magnitude(fc, fs).powi(2);
                assert!((two_pass - 0.5f64.sqrt()).abs() < 1e-9, "{two_pass}");
                // Without the correction, two passes give -6 dB at fc.
                let plain = Butterworth::lowpass(order, fc, fs).unwrap();
                assert!((plain.magnitude(fc, fs).powi(2) - 0.5).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn refuses_cutoff_at_nyquist_and_short_signals() {
        assert!(matches!(
            Butterworth::lowpass(2, 50.0, 100.0),
            Err(FilterError::BadCutoff { .. })
        ));
        assert!(matches!(
            Butterworth::lowpass(2, f64::NAN, 100.0),
            Err(FilterError::BadCutoff { .. })
        ));
        assert!(matches!(
            Butterworth::lowpass(0, 5.0, 100.0),
            Err(FilterError::BadOrder { .. })
        ));
        let f = Butterworth::lowpass(4, 5.0, 100.0).unwrap();
        assert_eq!(f.padding(), 15);
        assert!(matches!(
            f.filtfilt(&[0.0; 15]),
            Err(FilterError::TooShort { padding: 15, .. })
        ));
        assert!(f.filtfilt(&[0.0; 16]).is_ok());
        let mut x = vec![1.0; 40];
        x[7] = f64::NAN;
        assert!(matches!(
            f.filtfilt(&x),
            Err(FilterError::NotFinite { index: 7, .. })
        ));
    }
}
