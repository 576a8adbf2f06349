//! The paper's smoothing comparison (§III, Figs. 4–8), rerun on its own trajectory model.
//!
//! Model (paper §III): a trajectory component is a sum of sinusoids `Σ A_k sin(2π f_k t + φ_k)`
//! plus white Gaussian noise of standard deviation `σ`; a second signal is the noise alone.
//! Each method smooths both; we report the RMS error against the clean signal, how much of
//! each sinusoid's amplitude survives (least-squares projection of the output on
//! `sin`/`cos` at `f_k`, divided by `A_k`), and how much of the pure noise's RMS survives.

use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::{Method, SmoothError, smooth_series};

/// One sinusoid of the clean signal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sinusoid {
    /// Amplitude, mm.
    pub amplitude_mm: f64,
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// Phase, rad.
    pub phase: f64,
}

/// The signals and methods of the study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyConfig {
    /// Sampling rate, Hz. Default 100: the rate of a fast tracking camera.
    pub sample_rate_hz: f64,
    /// Length of the signals, s. Default 5: a brush stroke; also keeps the Bezier (cubic
    /// cost) fast.
    pub duration_s: f64,
    /// The clean signal. Default: 20 mm at 0.4 Hz, 8 mm at 0.9 Hz, 3 mm at 1.6 Hz, a
    /// painter's slow strokes with faster detail, all below the 3 Hz cut-off of Fig. 8.
    pub sinusoids: Vec<Sinusoid>,
    /// Standard deviation of the white noise, mm. Default 1: the paper's accuracy, about a millimetre.
    pub noise_std_mm: f64,
    /// Methods compared, with a name for each. Default: the paper's four (spline, Bezier,
    /// NURBS as a cubic least-squares B-spline with 0.1 s knots, low-pass 3 Hz as Fig. 8).
    pub methods: Vec<(String, Method)>,
}

impl Default for StudyConfig {
    fn default() -> Self {
        let sinusoid = |amplitude_mm, frequency_hz, phase| Sinusoid {
            amplitude_mm,
            frequency_hz,
            phase,
        };
        Self {
            sample_rate_hz: 100.0,
            duration_s: 5.0,
            sinusoids: vec![
                sinusoid(20.0, 0.4, 0.3),
                sinusoid(8.0, 0.9, 1.1),
                sinusoid(3.0, 1.6, 2.0),
            ],
            noise_std_mm: 1.0,
            methods: vec![
                (
                    "spline".into(),
                    Method::Spline {
                        ends: super::SplineEnds::NotAKnot,
                    },
                ),
                (
                    "bezier".into(),
                    Method::Bezier {
                        max_control_points: 2000,
                    },
                ),
                (
                    "nurbs".into(),
                    Method::Nurbs {
                        degree: 3,
                        knot_spacing_s: 0.1,
                    },
                ),
                (
                    "lowpass".into(),
                    Method::Lowpass {
                        cutoff_hz: 3.0,
                        order: 2,
                        convention: super::CutoffConvention::SinglePass,
                    },
                ),
            ],
        }
    }
}

/// One method's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodResult {
    /// The method's name.
    pub name: String,
    /// Output on the sinusoids-plus-noise signal, mm.
    pub smoothed: Vec<f64>,
    /// Output on the noise-only signal, mm.
    pub smoothed_noise: Vec<f64>,
    /// RMS of `smoothed - clean`, mm.
    pub rms_error_mm: f64,
    /// Fraction of each sinusoid's amplitude kept, in the order of the config.
    pub amplitude_kept: Vec<f64>,
    /// RMS of the output on noise alone divided by the noise's RMS.
    pub noise_kept: f64,
}

/// The signals and each method's results.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyResult {
    /// Sample times, s.
    pub time_s: Vec<f64>,
    /// The clean signal, mm.
    pub clean: Vec<f64>,
    /// Clean plus noise, mm.
    pub noisy: Vec<f64>,
    /// The noise alone, mm (an independent draw).
    pub noise: Vec<f64>,
    /// RMS of `noisy - clean`, mm.
    pub raw_rms_error_mm: f64,
    /// One entry per method, in the config's order.
    pub methods: Vec<MethodResult>,
}

/// Runs the comparison with noise drawn from `rng`.
///
/// # Errors
/// [`SmoothError`] when a method cannot run on the signal (too short, bad parameter).
pub fn run_study<R: Rng + ?Sized>(
    config: &StudyConfig,
    rng: &mut R,
) -> Result<StudyResult, SmoothError> {
    let fs = config.sample_rate_hz;
    let n = (config.duration_s * fs).round() as usize + 1;
    let time_s: Vec<f64> = (0..n).map(|i| i as f64 / fs).collect();
    let clean: Vec<f64> = time_s
        .iter()
        .map(|t| {
            config
                .sinusoids
                .iter()
                .map(|s| {
                    s.amplitude_mm * (std::f64::consts::TAU * s.frequency_hz * t + s.phase).sin()
                })
                .sum()
        })
        .collect();
    let normal = Normal::new(0.0, config.noise_std_mm).map_err(|_| SmoothError::BadParameter {
        parameter: "noise_std_mm",
        value: config.noise_std_mm,
        reason: "a finite non-negative number",
    })?;
    let noisy: Vec<f64> = clean.iter().map(|c| c + normal.sample(rng)).collect();
    let noise: Vec<f64> = (0..n).map(|_| normal.sample(rng)).collect();
    let rms = |a: &[f64], b: &[f64]| {
        (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
    };
    let zeros = vec![0.0; n];
    let noise_rms = rms(&noise, &zeros);
    let methods = config
        .methods
        .iter()
        .map(|(name, method)| {
            let smoothed = smooth_series(&noisy, method, fs)?;
            let smoothed_noise = smooth_series(&noise, method, fs)?;
            let amplitude_kept = fitted_amplitudes(&time_s, &smoothed, &config.sinusoids)
                .iter()
                .zip(&config.sinusoids)
                .map(|(a, s)| a / s.amplitude_mm)
                .collect();
            Ok(MethodResult {
                name: name.clone(),
                rms_error_mm: rms(&smoothed, &clean),
                noise_kept: rms(&smoothed_noise, &zeros) / noise_rms,
                amplitude_kept,
                smoothed,
                smoothed_noise,
            })
        })
        .collect::<Result<Vec<_>, SmoothError>>()?;
    Ok(StudyResult {
        raw_rms_error_mm: rms(&noisy, &clean),
        time_s,
        clean,
        noisy,
        noise,
        methods,
    })
}

/// Amplitudes of the joint least-squares fit `c + Σ_k a_k sin(ω_k t) + b_k cos(ω_k t)` to `y`,
/// at the frequencies of `sinusoids` (jointly, since a few periods are not orthogonal).
fn fitted_amplitudes(time_s: &[f64], y: &[f64], sinusoids: &[Sinusoid]) -> Vec<f64> {
    let unknowns = 2 * sinusoids.len() + 1;
    let design = nalgebra::DMatrix::from_fn(time_s.len(), unknowns, |i, j| {
        if j == 0 {
            return 1.0;
        }
        let s = &sinusoids[(j - 1) / 2];
        let phase = std::f64::consts::TAU * s.frequency_hz * time_s[i];
        if j % 2 == 1 { phase.sin() } else { phase.cos() }
    });
    let rhs = nalgebra::DVector::from_column_slice(y);
    let normal = design.transpose() * &design;
    let projected = design.transpose() * rhs;
    normal.cholesky().map_or_else(
        || vec![f64::NAN; sinusoids.len()],
        |c| {
            let x = c.solve(&projected);
            (0..sinusoids.len())
                .map(|k| x[1 + 2 * k].hypot(x[2 + 2 * k]))
                .collect()
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn reproduces_the_papers_findings() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let r = run_study(&StudyConfig::default(), &mut rng).unwrap();
        let by_name = |name: &str| r.methods.iter().find(|m| m.name == name).unwrap();
        let (spline, bezier, nurbs, lowpass) = (
            by_name("spline"),
            by_name("bezier"),
            by_name("nurbs"),
            by_name("lowpass"),
        );
        // Spline interpolation keeps all the noise (Fig. 4).
        assert!((spline.rms_error_mm - r.raw_rms_error_mm).abs() < 1e-12);
        assert!((spline.noise_kept - 1.0).abs() < 1e-12);
        // Bezier removes the noise and most of the motion too (Fig. 5).
        assert!(bezier.noise_kept < 0.2, "{}", bezier.noise_kept);
        // The faster the motion, the more it is flattened: a sinusoid of period T samples
        // keeps about cos(π/T)^(N-1) of its amplitude mid-curve (see `bezier`): 0.96, 0.82 and
        // 0.53 here, more near the ends where the curve meets the samples (measured 0.65-0.67
        // for the fastest over the whole curve, depending on the noise draw).
        let kept = &bezier.amplitude_kept;
        assert!(
            kept[0] > kept[1] && kept[1] > kept[2] && kept[2] < 0.75,
            "{kept:?}"
        );
        assert!(kept[2] < lowpass.amplitude_kept[2] - 0.2);
        // Its error exceeds that of the raw, noisy signal.
        assert!(
            bezier.rms_error_mm > r.raw_rms_error_mm,
            "{}",
            bezier.rms_error_mm
        );
        // NURBS and low-pass keep the motion and reduce the noise (Figs. 6, 8).
        for m in [nurbs, lowpass] {
            assert!(
                m.rms_error_mm < r.raw_rms_error_mm,
                "{}: {}",
                m.name,
                m.rms_error_mm
            );
            assert!(m.noise_kept < 0.5, "{}: {}", m.name, m.noise_kept);
            assert!(
                m.amplitude_kept[0] > 0.98,
                "{}: {:?}",
                m.name,
                m.amplitude_kept
            );
        }
    }
}
