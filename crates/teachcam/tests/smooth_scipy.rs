//! Smoothing against stored SciPy/NumPy numbers (`scripts/reference/smooth_scipy.py`,
//! `tests/data/smooth/scipy_reference.json`).

use serde_json::Value;
use teachcam::smooth::bezier::de_casteljau;
use teachcam::smooth::bspline::{LeastSquaresBSpline, clamped_uniform_knots};
use teachcam::smooth::butterworth::Butterworth;
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
fn butterworth_design_and_filtfilt_match_scipy_to_1e9() {
    let r = reference();
    let cases = r["lowpass"].as_array().unwrap();
    assert_eq!(cases.len(), 18);
    for case in cases {
        let fs = case["fs_hz"].as_f64().unwrap();
        let order = case["order"].as_u64().unwrap() as usize;
        let fc = case["cutoff_hz"].as_f64().unwrap();
        let filter = Butterworth::lowpass(order, fc, fs).unwrap();
        let label = format!("order {order}, {fc} Hz at {fs} Hz");
        assert!(
            relative_error(&filter.b, &numbers(&case["b"])) < 1e-12,
            "b, {label}"
        );
        assert!(
            relative_error(&filter.a, &numbers(&case["a"])) < 1e-12,
            "a, {label}"
        );
        assert!(
            relative_error(&filter.steady_state(), &numbers(&case["zi"])) < 1e-12,
            "zi, {label}"
        );
        let y = filter.filtfilt(&numbers(&case["x"])).unwrap();
        let expected = numbers(&case["y"]);
        let error = relative_error(&y, &expected);
        eprintln!("filtfilt {label}: relative error {error:.1e}");
        assert!(error < 1e-9, "filtfilt {label}: relative error {error:e}");
    }
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
