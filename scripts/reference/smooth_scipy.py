"""Reference numbers for teachcam's smoothing tests (issue 5), computed with SciPy.

Run: /work/pyref/bin/python scripts/reference/smooth_scipy.py
Writes crates/teachcam/tests/data/smooth/scipy_reference.json. Tests read the stored numbers;
they never run Python.

- lowpass: scipy.signal.butter(N, fc, fs=fs) (b, a) and filtfilt(b, a, x) with scipy's default
  padding (odd extension, padlen = 3 * max(len(a), len(b)), initial state from lfilter_zi).
- cubic_spline: scipy.interpolate.CubicSpline with bc_type 'natural' and 'not-a-knot', values
  and first and second derivatives at query points, on non-uniform abscissae.
- lsq_bspline: scipy.interpolate.make_lsq_spline with clamped knots, interior knots uniform in
  time, evaluated back at the data abscissae.
- bezier: Bernstein-polynomial sums (an independent formula from de Casteljau's algorithm).
- spectrum: numpy.fft.rfft single-sided amplitude.
"""
import json
import pathlib

import numpy as np
import scipy
from scipy import interpolate, signal, special

rng = np.random.default_rng(20261123)
out = {"scipy_version": scipy.__version__, "numpy_version": np.__version__}


def test_signal(fs, n):
    t = np.arange(n) / fs
    clean = 40.0 * np.sin(2 * np.pi * 0.7 * t + 0.3) + 12.0 * np.sin(2 * np.pi * 2.3 * t) + 5.0
    return t, clean + rng.normal(0.0, 1.5, n)


lowpass = []
for fs, n, cutoffs in [(30.0, 240, [1.0, 3.0, 6.0, 10.0]), (100.0, 700, [2.0, 5.0, 10.0, 30.0, 45.0])]:
    t, x = test_signal(fs, n)
    for order in (2, 4):
        for fc in cutoffs:
            b, a = signal.butter(order, fc, fs=fs)
            y = signal.filtfilt(b, a, x)
            lowpass.append({"fs_hz": fs, "order": order, "cutoff_hz": fc, "b": b.tolist(),
                            "a": a.tolist(), "zi": signal.lfilter_zi(b, a).tolist(),
                            "x": x.tolist(), "y": y.tolist()})
out["lowpass"] = lowpass

x = np.cumsum(rng.uniform(0.2, 1.0, 25))
y = np.sin(x) * 10 + rng.normal(0, 0.3, x.size)
xq = np.linspace(x[0], x[-1], 97)
splines = []
for bc in ("natural", "not-a-knot"):
    cs = interpolate.CubicSpline(x, y, bc_type=bc)
    splines.append({"bc_type": bc, "x": x.tolist(), "y": y.tolist(), "xq": xq.tolist(),
                    "value": cs(xq).tolist(), "d1": cs(xq, 1).tolist(), "d2": cs(xq, 2).tolist()})
out["cubic_spline"] = splines

lsq = []
fs = 50.0
t, yv = test_signal(fs, 300)
for degree, control_points in [(3, 20), (5, 31), (2, 12)]:
    interior = np.linspace(t[0], t[-1], control_points - degree + 1)[1:-1]
    knots = np.r_[[t[0]] * (degree + 1), interior, [t[-1]] * (degree + 1)]
    spl = interpolate.make_lsq_spline(t, yv, knots, k=degree)
    lsq.append({"degree": degree, "control_points": control_points, "t": t.tolist(),
                "y": yv.tolist(), "knots": knots.tolist(), "coefficients": spl.c.tolist(),
                "fitted": spl(t).tolist()})
out["lsq_bspline"] = lsq

control = rng.normal(0, 1, 40).tolist()
u = np.linspace(0, 1, 33)
n = len(control) - 1
bern = np.array([[special.comb(n, i) * uu**i * (1 - uu) ** (n - i) for i in range(n + 1)] for uu in u])
out["bezier"] = {"control": control, "u": u.tolist(), "value": (bern @ np.array(control)).tolist()}

fs = 100.0
t, xs = test_signal(fs, 1000)
amp = np.abs(np.fft.rfft(xs)) * 2.0 / xs.size
amp[0] /= 2.0
if xs.size % 2 == 0:
    amp[-1] /= 2.0
out["spectrum"] = {"fs_hz": fs, "x": xs.tolist(), "frequency_hz": np.fft.rfftfreq(xs.size, 1 / fs).tolist(),
                   "amplitude": amp.tolist()}

path = pathlib.Path(__file__).resolve().parents[2] / "crates/teachcam/tests/data/smooth/scipy_reference.json"
path.write_text(json.dumps(out, indent=None))
print(f"wrote {path}")
