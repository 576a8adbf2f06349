//! Zero-phase Butterworth low-pass: design as `scipy.signal.butter(..., output="sos")`,
//! forward-backward filtering as `scipy.signal.sosfiltfilt`, whose numbers are those of
//! `filtfilt(*butter(N, fc, fs=fs), x)` wherever that transfer-function form is itself stable.
//!
//! Design (Butterworth 1930; scipy's `buttap` → `lp2lp_zpk` → `bilinear_zpk` → `zpk2sos`): the
//! analog prototype of order `N` has poles `p_k = -exp(iπ(2k - N + 1)/(2N))`, `k = 0..N`, and
//! no zeros; it is scaled to the pre-warped cut-off `Ω = 2·fs·tan(π·fc/fs)` and mapped to the
//! z-plane by the bilinear transform `z = (2fs + s)/(2fs - s)`, which adds `N` zeros at
//! `z = -1`. The gain makes `H(1) = 1`. The poles are kept as second-order sections (a
//! conjugate pair and two zeros at `-1` each; for odd `N` one first-order section), ordered as
//! scipy's `zpk2sos` orders them: the pair closest to the unit circle last, the gain in the
//! first. The polynomial `Σ a_k z^-k` of all poles at once loses every digit at high order and
//! low cut-off (order 12 at 6 Hz sampled at 1000 Hz: its roots leave the unit circle and a
//! constant comes out at 1e92 mm); each section's poles stay where the design put them.
//!
//! Filtering: `sosfiltfilt` runs each section's direct-form-II-transposed recursion (`sosfilt`)
//! forward and then backward, so the phase cancels and the magnitude is `|H|²`. The signal is
//! first extended at both ends by `3·(2·sections + 1 - first-order sections)` = `3·(N+1)`
//! samples of odd extension (`2·x₀ - x[k]`, the same padding as `filtfilt`'s), and each pass
//! starts from the steady state of a step (`sosfilt_zi`) scaled by the first sample. The first
//! sample is subtracted before and added after filtering: the filter is linear with unit gain
//! at zero frequency, so the numbers are the same, and a constant comes out exactly constant
//! instead of carrying the rounding of the poles' recursion.
//!
//! What is refused rather than computed: a design whose sections are not stable in double
//! precision or whose gain at zero frequency is not 1; a record shorter than the padding
//! (scipy refuses it too); and a record shorter than the filter's memory, the number of
//! samples its step response needs to settle within [`SETTLING_TOLERANCE`] of its final value
//! (a cut-off far below what the record can resolve gives an output made of the padding, not
//! of the data); any output that is not finite.
//!
//! The cut-off `fc` is, as in scipy, that of the single pass: the forward-backward result is at
//! `|H|² = 1/2` (−6 dB) there. [`winter_corrected_cutoff_hz`] gives the single-pass cut-off
//! that puts the two-pass −3 dB point at the frequency asked for (Winter, *Biomechanics and
//! Motor Control of Human Movement*, 4th ed., §3.4.4.3).

use nalgebra::Complex;

/// One second-order section `(b₀ + b₁z⁻¹ + b₂z⁻²) / (1 + a₁z⁻¹ + a₂z⁻²)`, `a[0] = 1`; a
/// first-order section has `b₂ = a₂ = 0`. The rows of scipy's `sos` array.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// Numerator `b₀, b₁, b₂`.
    pub b: [f64; 3],
    /// Denominator `1, a₁, a₂`.
    pub a: [f64; 3],
}

impl Section {
    /// `Σb / Σa`: the section's gain at zero frequency.
    fn dc_gain(&self) -> f64 {
        self.b.iter().sum::<f64>() / self.a.iter().sum::<f64>()
    }

    /// The largest modulus of the section's poles, the roots of `z² + a₁z + a₂`.
    fn pole_radius(&self) -> f64 {
        let [_, a1, a2] = self.a;
        let discriminant = a1 * a1 - 4.0 * a2;
        if discriminant < 0.0 {
            a2.sqrt()
        } else {
            (a1.abs() + discriminant.sqrt()) / 2.0
        }
    }

    /// scipy's `lfilter_zi` of the section: the direct-form-II-transposed state after a long
    /// run of ones, `z₁ = b₂ - a₂·g`, `z₀ = b₁ - a₁·g + z₁` with `g` the section's gain.
    fn steady_state(&self) -> [f64; 2] {
        let gain = self.dc_gain();
        let z1 = self.b[2] - self.a[2] * gain;
        [self.b[1] - self.a[1] * gain + z1, z1]
    }

    /// One step of the direct-form-II-transposed recursion (scipy's `sosfilt`).
    fn step(&self, state: &mut [f64; 2], input: f64) -> f64 {
        let output = self.b[0] * input + state[0];
        state[0] = self.b[1] * input - self.a[1] * output + state[1];
        state[1] = self.b[2] * input - self.a[2] * output;
        output
    }
}

/// A digital Butterworth low-pass as a cascade of [`Section`]s.
#[derive(Debug, Clone, PartialEq)]
pub struct Butterworth {
    /// The sections, applied in order; the first carries the gain.
    pub sections: Vec<Section>,
    /// Order `N` of the design.
    pub order: usize,
    /// The single-pass cut-off it was designed for, Hz.
    pub cutoff_hz: f64,
    /// The sampling rate it was designed for, Hz.
    pub sample_rate_hz: f64,
}

/// How many samples a filter's step response needs to settle, as far as it was followed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SettlingLength {
    /// It stays within the tolerance from this many samples on.
    Samples(usize),
    /// It had not settled after this many samples (it was followed no further).
    MoreThan(usize),
}

impl std::fmt::Display for SettlingLength {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Samples(n) => write!(f, "{n}"),
            Self::MoreThan(n) => write!(f, "more than {n}"),
        }
    }
}

/// Why a low-pass filter cannot be designed or applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FilterError {
    /// Order zero, or beyond what is accepted.
    #[error("filter order {order} is outside 1..={MAX_ORDER}")]
    BadOrder {
        /// The order asked for.
        order: usize,
    },
    /// The cut-off is not strictly between 0 and the Nyquist frequency.
    #[error(
        "cut-off {cutoff_hz} Hz must be a number above 0 and below the Nyquist frequency {nyquist_hz} Hz"
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
    /// The design cannot be held in double precision: a section's pole on or outside the unit
    /// circle, or a gain at zero frequency that is not 1.
    #[error(
        "the order-{order} low-pass at {cutoff_hz} Hz (sampled at {sample_rate_hz} Hz) cannot be held in double precision (pole radius {pole_radius}, gain at 0 Hz {dc_gain}): raise the cut-off or lower the order"
    )]
    Unstable {
        /// The filter's order.
        order: usize,
        /// Its cut-off, Hz.
        cutoff_hz: f64,
        /// The sampling rate, Hz.
        sample_rate_hz: f64,
        /// The largest modulus of a section's poles (stable below 1).
        pole_radius: f64,
        /// The cascade's gain at zero frequency (1 by design).
        dc_gain: f64,
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
    /// The filter's memory is longer than the record: the output would be made of the padding.
    #[error(
        "the record holds {samples} samples, but the order-{order} low-pass at {cutoff_hz} Hz (sampled at {sample_rate_hz} Hz) needs {needed} for its step response to settle within 1 %: raise the cut-off or give a longer record"
    )]
    CutoffBelowRecord {
        /// Samples in the record.
        samples: usize,
        /// The filter's order.
        order: usize,
        /// Its cut-off, Hz.
        cutoff_hz: f64,
        /// The sampling rate, Hz.
        sample_rate_hz: f64,
        /// The step response's settling length.
        needed: SettlingLength,
    },
    /// A sample is NaN or infinite.
    #[error("sample {index} is not finite ({value})")]
    NotFinite {
        /// Index of the sample.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// The filter produced a number that is not finite (a guard: a stable design with a
    /// settled response over finite data does not).
    #[error("filtered sample {index} is not finite ({value})")]
    NotFiniteOutput {
        /// Index of the sample.
        index: usize,
        /// Its value.
        value: f64,
    },
}

/// Highest order accepted. A Butterworth's roll-off is `20·N` dB per decade; beyond 12 the
/// sections' poles crowd the unit circle at any low cut-off and the step response rings for
/// longer than a demonstration lasts.
pub const MAX_ORDER: usize = 12;

/// Fraction of the final value within which the step response counts as settled (the 1 %
/// settling time of control engineering).
pub const SETTLING_TOLERANCE: f64 = 0.01;

/// Largest departure of the designed cascade's gain at zero frequency from 1. The design's
/// rounding is near 1e-15 at ordinary cut-offs; at 1e-9 the gain is held to well below the
/// 1e-9 the outputs are compared to scipy's at.
const DC_GAIN_TOLERANCE: f64 = 1e-9;

/// Time constants of the slowest pole the step response must stay within the tolerance for,
/// after its last excursion, before it counts as settled: the envelope then falls by `e⁻¹⁰`,
/// and for the least damped Butterworth pole (order 12) the window spans about ten periods of
/// its ringing.
const SETTLED_TIME_CONSTANTS: f64 = 10.0;

impl Butterworth {
    /// The low-pass of order `order` and single-pass −3 dB cut-off `cutoff_hz` at
    /// `sample_rate_hz`: the sections of `scipy.signal.butter(order, cutoff_hz, fs=...,
    /// output="sos")`.
    ///
    /// # Errors
    /// [`FilterError::BadOrder`], [`FilterError::BadSampleRate`], [`FilterError::BadCutoff`]
    /// (at or above Nyquist, at or below zero, not finite), [`FilterError::Unstable`].
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
        let fs2 = Complex::new(2.0 * fs, 0.0);
        let poles: Vec<Complex<f64>> = poles_analog.iter().map(|p| (fs2 + p) / (fs2 - p)).collect();
        let denominator: Complex<f64> = poles_analog.iter().map(|p| fs2 - p).product();
        let gain = gain_analog * (Complex::new(1.0, 0.0) / denominator).re;
        let mut sections = sections_of(&poles);
        if let Some(first) = sections.first_mut() {
            for b in &mut first.b {
                *b *= gain;
            }
        }
        let filter = Self {
            sections,
            order,
            cutoff_hz,
            sample_rate_hz,
        };
        let pole_radius = filter.pole_radius();
        let dc_gain = filter.dc_gain();
        let coefficients_finite = filter
            .sections
            .iter()
            .all(|s| s.b.iter().chain(&s.a).all(|c| c.is_finite()));
        if !(coefficients_finite && pole_radius < 1.0 && (dc_gain - 1.0).abs() <= DC_GAIN_TOLERANCE)
        {
            return Err(FilterError::Unstable {
                order,
                cutoff_hz,
                sample_rate_hz,
                pole_radius,
                dc_gain,
            });
        }
        Ok(filter)
    }

    /// The filter's order.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// scipy's default `sosfiltfilt` padding, `3·(2·sections + 1 - first-order sections)`:
    /// `3·(N + 1)`, the same as `filtfilt`'s `3·max(len(a), len(b))`.
    #[must_use]
    pub fn padding(&self) -> usize {
        let first_order = self.sections.iter().filter(|s| s.a[2] == 0.0).count();
        let first_order_b = self.sections.iter().filter(|s| s.b[2] == 0.0).count();
        3 * (2 * self.sections.len() + 1 - first_order.min(first_order_b))
    }

    /// The cascade's gain at zero frequency, the product of the sections' (1 by design).
    #[must_use]
    pub fn dc_gain(&self) -> f64 {
        self.sections.iter().map(Section::dc_gain).product()
    }

    /// The largest modulus of the sections' poles: the filter is stable below 1, and its
    /// slowest transient decays as `radius^n`.
    #[must_use]
    pub fn pole_radius(&self) -> f64 {
        self.sections
            .iter()
            .map(Section::pole_radius)
            .fold(0.0, f64::max)
    }

    /// The cascade's state after a long run of ones: scipy's `sosfilt_zi`, each section's
    /// `lfilter_zi` scaled by the gain of the sections before it.
    #[must_use]
    pub fn steady_state(&self) -> Vec<[f64; 2]> {
        let mut scale = 1.0;
        self.sections
            .iter()
            .map(|s| {
                let [z0, z1] = s.steady_state();
                let state = [scale * z0, scale * z1];
                scale *= s.dc_gain();
                state
            })
            .collect()
    }

    /// Runs the cascade over `signal` in place (scipy's `sosfilt`), starting from the steady
    /// state scaled by `initial`.
    /// `signal` is any walk over the samples: forward, or backward for the second pass of
    /// `filtfilt` (no reversed copy).
    fn filter_from_steady_state<'a>(
        &self,
        signal: impl Iterator<Item = &'a mut f64>,
        initial: f64,
    ) {
        let mut state: Vec<[f64; 2]> = self
            .steady_state()
            .iter()
            .map(|z| [z[0] * initial, z[1] * initial])
            .collect();
        for x in signal {
            let mut value = *x;
            for (section, z) in self.sections.iter().zip(&mut state) {
                value = section.step(z, value);
            }
            *x = value;
        }
    }

    /// How many samples the single-pass step response needs to stay within
    /// [`SETTLING_TOLERANCE`] of its final value, or [`SettlingLength::MoreThan`]`(follow)`
    /// if its last excursion comes later than `follow` samples. It counts as settled once it
    /// has stayed within for [`SETTLED_TIME_CONSTANTS`] time constants of the slowest pole
    /// after its last excursion (or, for a pole so slow that this is longer, for ten times
    /// `follow`).
    #[must_use]
    pub fn settling_length(&self, follow: usize) -> SettlingLength {
        let final_value = self.dc_gain();
        // Time constant `-1 / ln r` in samples; `ln r < 0` for a stable design.
        let time_constant = -1.0 / self.pole_radius().ln();
        let settled_after = (SETTLED_TIME_CONSTANTS * time_constant)
            .clamp(1.0, 10.0 * follow as f64 + 1.0) as usize;
        let mut state = vec![[0.0; 2]; self.sections.len()];
        let mut settled_from = 0usize;
        for n in 0.. {
            if settled_from > follow {
                return SettlingLength::MoreThan(follow);
            }
            if n - settled_from >= settled_after {
                break;
            }
            let mut value = 1.0;
            for (section, z) in self.sections.iter().zip(&mut state) {
                value = section.step(z, value);
            }
            if (value - final_value).abs() > SETTLING_TOLERANCE * final_value.abs() {
                settled_from = n + 1;
            }
        }
        SettlingLength::Samples(settled_from)
    }

    /// Zero-phase filtering: the numbers of `scipy.signal.sosfiltfilt(sos, signal)` with the
    /// default `padtype="odd"` and padding ([`Self::padding`]), which are those of
    /// `filtfilt(b, a, signal)` where the transfer function is stable.
    ///
    /// # Errors
    /// [`FilterError::NotFinite`], [`FilterError::TooShort`] when `signal.len() <= padding`,
    /// [`FilterError::CutoffBelowRecord`] when the step response needs more samples than
    /// the signal has, [`FilterError::NotFiniteOutput`].
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
        // Followed up to twice the record, so that the message says by how much it is short.
        let needed = self.settling_length(2 * len);
        if !matches!(needed, SettlingLength::Samples(n) if n <= len) {
            return Err(FilterError::CutoffBelowRecord {
                samples: len,
                order: self.order,
                cutoff_hz: self.cutoff_hz,
                sample_rate_hz: self.sample_rate_hz,
                needed,
            });
        }
        let offset = signal[0];
        let centred = |k: usize| signal[k] - offset;
        let (first, last) = (0.0, centred(len - 1));
        let mut extended = Vec::with_capacity(len + 2 * edge);
        extended.extend((1..=edge).rev().map(|k| 2.0 * first - centred(k)));
        extended.extend((0..len).map(centred));
        extended.extend((1..=edge).map(|k| 2.0 * last - centred(len - 1 - k)));
        let x0 = extended[0];
        self.filter_from_steady_state(extended.iter_mut(), x0);
        let y0 = extended[extended.len() - 1];
        self.filter_from_steady_state(extended.iter_mut().rev(), y0);
        // The padding dropped in place: no second buffer.
        extended.copy_within(edge..edge + len, 0);
        extended.truncate(len);
        for v in &mut extended {
            *v += offset;
        }
        if let Some((index, &value)) = extended.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(FilterError::NotFiniteOutput { index, value });
        }
        Ok(extended)
    }

    /// `|H(e^{iω})|` at `frequency_hz`, single pass: the product of the sections' responses.
    #[must_use]
    pub fn magnitude(&self, frequency_hz: f64, sample_rate_hz: f64) -> f64 {
        let omega = 2.0 * std::f64::consts::PI * frequency_hz / sample_rate_hz;
        let eval = |c: &[f64; 3]| -> Complex<f64> {
            c.iter()
                .enumerate()
                .map(|(k, v)| Complex::new(0.0, -omega * k as f64).exp() * *v)
                .sum()
        };
        self.sections
            .iter()
            .map(|s| (eval(&s.b) / eval(&s.a)).norm())
            .product()
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

/// The unit-gain sections of poles `poles` (conjugate pairs and at most one real pole) with
/// all zeros at `-1`, in the order of scipy's `zpk2sos` (pairing `"nearest"`). For an odd
/// order a pole and a zero at the origin are added first. Then, from the last section to the
/// first: the pole closest to the unit circle, with its conjugate (or, if real, the real pole
/// next closest to the unit circle), and the two zeros nearest that pole.
fn sections_of(poles: &[Complex<f64>]) -> Vec<Section> {
    let origin = Complex::new(0.0, 0.0);
    let mut left: Vec<Complex<f64>> = poles.iter().copied().filter(|p| p.im > 0.0).collect();
    left.extend(poles.iter().copied().filter(|p| p.im == 0.0));
    let mut zeros = vec![-1.0; poles.len()];
    if poles.len() % 2 == 1 {
        left.push(origin);
        zeros.push(0.0);
    }
    let from_circle = |p: &Complex<f64>| (1.0 - p.norm()).abs();
    let mut sections = Vec::with_capacity(left.len());
    while let Some(i) = argmin(left.iter().map(from_circle)) {
        let p1 = left.remove(i);
        let p2 = if p1.im == 0.0 {
            let reals = left.iter().map(|p| {
                if p.im == 0.0 {
                    from_circle(p)
                } else {
                    f64::INFINITY
                }
            });
            match argmin(reals) {
                Some(j) if left[j].im == 0.0 => left.remove(j),
                _ => origin,
            }
        } else {
            p1.conj()
        };
        let mut nearest_zero =
            || argmin(zeros.iter().map(|z| (p1 - z).norm())).map_or(0.0, |k| zeros.remove(k));
        let (z1, z2) = (nearest_zero(), nearest_zero());
        let sum = p1 + p2;
        let product = p1 * p2;
        sections.push(Section {
            b: [1.0, -(z1 + z2), z1 * z2],
            a: [1.0, -sum.re, product.re],
        });
    }
    // Built from the last section to the first.
    sections.reverse();
    sections
}

/// Index of the first smallest value (numpy's `argmin`), `None` for no values.
fn argmin(values: impl Iterator<Item = f64>) -> Option<usize> {
    values
        .enumerate()
        .fold(None, |best: Option<(usize, f64)>, (i, v)| match best {
            Some((_, b)) if b <= v => best,
            _ => Some((i, v)),
        })
        .map(|(i, _)| i)
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
        assert_eq!(Butterworth::lowpass(5, 5.0, 100.0).unwrap().padding(), 18);
        assert!(matches!(
            f.filtfilt(&[0.0; 15]),
            Err(FilterError::TooShort { padding: 15, .. })
        ));
        assert!(f.filtfilt(&[0.0; 100]).is_ok());
        let mut x = vec![1.0; 40];
        x[7] = f64::NAN;
        assert!(matches!(
            f.filtfilt(&x),
            Err(FilterError::NotFinite { index: 7, .. })
        ));
    }

    #[test]
    fn a_constant_stays_constant_at_every_order_and_cut_off_accepted() {
        let constant = 180.8026;
        let x = vec![constant; 3000];
        for order in 1..=MAX_ORDER {
            for (fc, fs) in [(6.0, 1000.0), (2.0, 1000.0), (6.0, 2000.0), (10.0, 30.0)] {
                let f = Butterworth::lowpass(order, fc, fs).unwrap();
                let y = f.filtfilt(&x).unwrap();
                let worst = y.iter().map(|v| (v - constant).abs()).fold(0.0, f64::max);
                assert!(
                    worst <= 1e-9,
                    "order {order}, {fc} Hz at {fs} Hz: {worst:e}"
                );
            }
        }
    }

    #[test]
    fn a_cut_off_the_record_cannot_hold_is_refused_naming_the_lengths() {
        // 700 samples at 30 Hz: an order-8 low-pass at 0.1 Hz rings for 1040 samples (the
        // last excursion beyond 1 % of `scipy.signal.sosfilt(sos, ones)`, measured), 35 s.
        let f = Butterworth::lowpass(8, 0.1, 30.0).unwrap();
        let e = f.filtfilt(&vec![1.0; 700]).unwrap_err();
        assert_eq!(
            e,
            FilterError::CutoffBelowRecord {
                samples: 700,
                order: 8,
                cutoff_hz: 0.1,
                sample_rate_hz: 30.0,
                needed: SettlingLength::Samples(1040),
            }
        );
        assert!(
            e.to_string()
                .starts_with("the record holds 700 samples, but the order-8 low-pass at 0.1 Hz"),
            "{e}"
        );
        assert!(f.filtfilt(&vec![1.0; 1040]).is_ok());
        // Far below: it never settles within twice the record.
        let f = Butterworth::lowpass(2, 0.001, 30.0).unwrap();
        assert!(matches!(
            f.filtfilt(&vec![1.0; 300]),
            Err(FilterError::CutoffBelowRecord {
                needed: SettlingLength::MoreThan(600),
                ..
            })
        ));
        // At 1e-9 Hz the poles' distance to the unit circle is below what `1 + a₁ + a₂` holds:
        // the gain at 0 Hz is not 1 and the design is refused before any record.
        assert!(matches!(
            Butterworth::lowpass(2, 1e-9, 30.0),
            Err(FilterError::Unstable { .. })
        ));
    }

    #[test]
    fn settling_length_is_where_the_step_response_stays_within_one_percent() {
        // First order, `[k, k, 0] / [1, -r, 0]` with `k = (1 - r)/2`: the step response's
        // error is `e[0] = 1 - k`, `e[n] = r·e[n-1]`, so `e[n] = (1 + r)/2 · rⁿ`, within 1 %
        // from the first `n` with `(1 + r)/2 · rⁿ <= 0.01`.
        let f = Butterworth::lowpass(1, 1.0, 100.0).unwrap();
        let r = -f.sections[0].a[1];
        let expected = ((0.02 / (1.0 + r)).ln() / r.ln()).ceil() as usize;
        let SettlingLength::Samples(n) = f.settling_length(10_000) else {
            panic!("not settled");
        };
        assert_eq!(n, expected);
    }
}
