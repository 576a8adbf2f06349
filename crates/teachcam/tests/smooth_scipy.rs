//! Smoothing against stored SciPy/NumPy numbers (`scripts/reference/smooth_scipy.py`,
//! `tests/data/smooth/scipy_reference.json`).

use serde_json::Value;
use teachcam::smooth::bezier::de_casteljau;
use teachcam::smooth::bspline::{LeastSquaresBSpline, clamped_uniform_knots};
use teachcam::smooth::butterworth::{Butterworth, SettlingLength};
use teachcam::smooth::spectrum::amplitude_spectrum;
use teachcam::smooth::spline::{CubicSpline, SplineEnds};

#[expect(
    clippy::expect_used,
    reason = "test fixture: a missing reference is a broken checkout"
)]
fn reference() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/smooth/scipy_reference.json"
    );
    let text = std::fs::read_to_string(path).expect("stored reference present in the repo");
    serde_json::from_str(&text).expect("reference is JSON")
}

#[expect(
    clippy::expect_used,
    reason = "test fixture: the stored file's shape is fixed"
)]
fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// Largest `|a - b|` relative to the largest `|b|` of the series.
fn relative_error(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / scale
}

#[test]
fn butterworth_filtfilt_matches_scipy_filtfilt_to_1e9() {
    // The contract's numbers: `filtfilt(*butter(N, fc, fs=fs), x)`, computed here in
    // second-order sections.
    let r = reference();
    let cases = r["lowpass"].as_array().unwrap();
    assert_eq!(cases.len(), 18);
    for case in cases {
        let fs = case["fs_hz"].as_f64().unwrap();
        let order = case["order"].as_u64().unwrap() as usize;
        let fc = case["cutoff_hz"].as_f64().unwrap();
        let filter = Butterworth::lowpass(order, fc, fs).unwrap();
        let label = format!("order {order}, {fc} Hz at {fs} Hz");
        let y = filter.filtfilt(&numbers(&case["x"])).unwrap();
        let expected = numbers(&case["y"]);
        let error = relative_error(&y, &expected);
        eprintln!("filtfilt {label}: relative error {error:.1e}");
        assert!(error < 1e-9, "filtfilt {label}: relative error {error:e}");
    }
}

#[expect(
    clippy::expect_used,
    reason = "test fixture: a missing reference is a broken checkout"
)]
fn sos_reference() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/smooth/scipy_sos_reference.json"
    );
    let text = std::fs::read_to_string(path).expect("stored reference present in the repo");
    serde_json::from_str(&text).expect("reference is JSON")
}

#[test]
fn butterworth_sections_and_sosfiltfilt_match_scipy_where_the_transfer_function_fails() {
    // `scripts/reference/smooth_sos_scipy.py`: ordinary designs, odd orders, and the designs of
    // ../shared/repro/R2 whose (b, a) form is unstable or loses digits (order 12 at 6 Hz and
    // order 8 at 2 Hz sampled at 1000 Hz, order 8 at 6 Hz at 2000 Hz, order 10 at 1 Hz at
    // 100 Hz): there scipy's `filtfilt` gives up to 1e157 for a constant and `sosfiltfilt`
    // stays right.
    let r = sos_reference();
    let cases = r["lowpass_sos"].as_array().unwrap();
    assert_eq!(cases.len(), 16);
    let mut unstable_ba = 0;
    for case in cases {
        let fs = case["fs_hz"].as_f64().unwrap();
        let order = case["order"].as_u64().unwrap() as usize;
        let fc = case["cutoff_hz"].as_f64().unwrap();
        let label = format!("order {order}, {fc} Hz at {fs} Hz");
        let filter = Butterworth::lowpass(order, fc, fs).unwrap();
        let sos: Vec<Vec<f64>> = case["sos"]
            .as_array()
            .unwrap()
            .iter()
            .map(numbers)
            .collect();
        assert_eq!(filter.sections.len(), sos.len(), "{label}");
        for (section, row) in filter.sections.iter().zip(&sos) {
            let ours: Vec<f64> = section.b.iter().chain(&section.a).copied().collect();
            assert!(
                relative_error(&ours, row) < 1e-12,
                "sos {label}: {ours:?} vs {row:?}"
            );
        }
        let zi: Vec<f64> = case["zi"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(numbers)
            .collect();
        let ours: Vec<f64> = filter.steady_state().into_iter().flatten().collect();
        // sosfilt_zi solves a 2x2 system per section, the closed form here divides by the
        // section's `Σa`, which is small near the unit circle: both round at about 1e-12 there.
        assert!(
            relative_error(&ours, &zi) < 1e-10,
            "zi {label}: {ours:?} vs {zi:?}"
        );
        let settling = case["settling"].as_u64().unwrap() as usize;
        assert_eq!(
            filter.settling_length(20_000),
            SettlingLength::Samples(settling),
            "settling {label}"
        );
        let x = numbers(&case["x"]);
        let y = filter.filtfilt(&x).unwrap();
        let error = relative_error(&y, &numbers(&case["y_sos"]));
        eprintln!("sosfiltfilt {label}: relative error {error:.1e}");
        assert!(
            error < 1e-9,
            "sosfiltfilt {label}: relative error {error:e}"
        );
        if case.get("y_ba").is_some() {
            assert!(
                relative_error(&y, &numbers(&case["y_ba"])) < 1e-9,
                "filtfilt {label}"
            );
        } else {
            unstable_ba += 1;
        }
        // A constant stays constant to 1e-9 mm (scipy's own sosfiltfilt is off by up to 7e-10).
        let constant = vec![180.8026; x.len()];
        let worst = filter
            .filtfilt(&constant)
            .unwrap()
            .iter()
            .map(|v| (v - 180.8026f64).abs())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-9, "constant {label}: {worst:e}");
    }
    assert_eq!(unstable_ba, 5, "cases where filtfilt's (b, a) form fails");
}

#[test]
fn cubic_spline_matches_scipy_natural_and_not_a_knot() {
    let r = reference();
    for case in r["cubic_spline"].as_array().unwrap() {
        let ends = match case["bc_type"].as_str().unwrap() {
            "natural" => SplineEnds::Natural,
            _ => SplineEnds::NotAKnot,
        };
        let s = CubicSpline::new(&numbers(&case["x"]), &numbers(&case["y"]), ends).unwrap();
        let xq = numbers(&case["xq"]);
        let value: Vec<f64> = xq.iter().map(|&x| s.value(x)).collect();
        let d1: Vec<f64> = xq.iter().map(|&x| s.derivative(x)).collect();
        let d2: Vec<f64> = xq.iter().map(|&x| s.second_derivative(x)).collect();
        assert!(
            relative_error(&value, &numbers(&case["value"])) < 1e-12,
            "{ends:?} value"
        );
        assert!(
            relative_error(&d1, &numbers(&case["d1"])) < 1e-11,
            "{ends:?} d1"
        );
        assert!(
            relative_error(&d2, &numbers(&case["d2"])) < 1e-10,
            "{ends:?} d2"
        );
    }
}

#[test]
fn least_squares_bspline_matches_scipy_make_lsq_spline() {
    let r = reference();
    for case in r["lsq_bspline"].as_array().unwrap() {
        let degree = case["degree"].as_u64().unwrap() as usize;
        let count = case["control_points"].as_u64().unwrap() as usize;
        let t = numbers(&case["t"]);
        let fit = LeastSquaresBSpline::new(&t, degree, count).unwrap();
        let knots = clamped_uniform_knots(t[0], t[t.len() - 1], degree, count);
        assert!(relative_error(&knots, &numbers(&case["knots"])) < 1e-15);
        assert_eq!(fit.knots(), knots.as_slice());
        let y = numbers(&case["y"]);
        let c = fit.coefficients(&y);
        let e = relative_error(&c, &numbers(&case["coefficients"]));
        assert!(e < 1e-9, "degree {degree}: coefficients {e:e}");
        eprintln!("lsq degree {degree}: coefficients {e:.1e}");
        let e = relative_error(&fit.fit(&y), &numbers(&case["fitted"]));
        assert!(e < 1e-10, "degree {degree}: fitted {e:e}");
    }
}

#[test]
fn de_casteljau_matches_bernstein_sum() {
    let r = reference();
    let b = &r["bezier"];
    let control = numbers(&b["control"]);
    let value: Vec<f64> = numbers(&b["u"])
        .iter()
        .map(|&u| de_casteljau(&control, u))
        .collect();
    assert!(relative_error(&value, &numbers(&b["value"])) < 1e-12);
}

#[test]
fn amplitude_spectrum_matches_numpy_rfft() {
    let r = reference();
    let s = &r["spectrum"];
    let spectrum = amplitude_spectrum(&numbers(&s["x"]), s["fs_hz"].as_f64().unwrap());
    assert!(relative_error(&spectrum.frequency_hz, &numbers(&s["frequency_hz"])) < 1e-14);
    assert!(relative_error(&spectrum.amplitude, &numbers(&s["amplitude"])) < 1e-12);
}
