"""Reference numbers for the second-order-section low-pass (issue 15), computed with SciPy.

Run: python3 -m venv /tmp/venv && /tmp/venv/bin/pip install numpy scipy &&
     /tmp/venv/bin/python scripts/reference/smooth_sos_scipy.py
Writes crates/teachcam/tests/data/smooth/scipy_sos_reference.json. Tests read the stored
numbers; they never run Python.

For each case: sos = scipy.signal.butter(N, fc, fs=fs, output="sos"), zi = sosfilt_zi(sos),
y_sos = sosfiltfilt(sos, x) (default padding: odd extension, padlen = 3 * (2 * len(sos) + 1 -
min((sos[:, 2] == 0).sum(), (sos[:, 5] == 0).sum())), which is 3 * (N + 1)); y_ba =
filtfilt(*butter(N, fc, fs=fs), x) with its default padding 3 * (N + 1), stored only where the
(b, a) form is stable (every root of a inside the unit circle) and agrees with y_sos to 1e-9.
settling: samples the single-pass step response (sosfilt of ones, followed for 20 000
samples) needs to stay within 1 % of its final value, the index after its last excursion.
constant_max_dev: the largest |y - c| of sosfiltfilt and filtfilt over a constant c = 180.8026.
"""
import json
import pathlib

import numpy as np
import scipy
from scipy import signal

rng = np.random.default_rng(20261201)
out = {"scipy_version": scipy.__version__, "numpy_version": np.__version__}


def test_signal(fs, n):
    t = np.arange(n) / fs
    clean = 40.0 * np.sin(2 * np.pi * 0.7 * t + 0.3) + 12.0 * np.sin(2 * np.pi * 2.3 * t) + 180.0
    return clean + rng.normal(0.0, 1.5, n)


def settling(sos, window=20000):
    y = signal.sosfilt(sos, np.ones(window))
    final = np.prod([s[:3].sum() / s[3:].sum() for s in sos])
    outside = np.flatnonzero(np.abs(y - final) > 0.01 * abs(final))
    return int(outside[-1] + 1) if outside.size else 0


cases = []
# (fs, samples, order, cut-offs): ordinary designs (the (b, a) form is stable), odd orders for
# the first-order section, and the unstable ones of ../shared/repro/R2 (orders 8 and 12 at a
# low cut-off relative to the rate).
designs = [
    (30.0, 240, 2, [1.0, 3.0, 6.0, 10.0]),
    (30.0, 240, 3, [1.0, 6.0]),
    (100.0, 700, 4, [2.0, 10.0, 45.0]),
    (100.0, 700, 5, [5.0, 30.0]),
    (100.0, 700, 7, [3.0]),
    (1000.0, 3000, 12, [6.0]),
    (1000.0, 3000, 8, [2.0]),
    (2000.0, 3000, 8, [6.0]),
    (100.0, 3000, 10, [1.0]),
]
for fs, n, order, cutoffs in designs:
    x = test_signal(fs, n)
    for fc in cutoffs:
        sos = signal.butter(order, fc, fs=fs, output="sos")
        b, a = signal.butter(order, fc, fs=fs)
        y_sos = signal.sosfiltfilt(sos, x)
        y_ba = signal.filtfilt(b, a, x)
        stable = bool(np.all(np.abs(np.roots(a)) < 1.0))
        agrees = bool(np.max(np.abs(y_ba - y_sos)) <= 1e-9 * np.max(np.abs(y_sos)))
        c = np.full(n, 180.8026)
        dev_sos = float(np.max(np.abs(signal.sosfiltfilt(sos, c) - 180.8026)))
        dev_ba = float(np.max(np.abs(signal.filtfilt(b, a, c) - 180.8026)))
        case = {"fs_hz": fs, "order": order, "cutoff_hz": fc, "sos": sos.tolist(),
                "zi": signal.sosfilt_zi(sos).tolist(), "ba_stable": stable,
                "ba_agrees": agrees, "settling": settling(sos),
                "constant_max_dev": {"sos": dev_sos, "ba": dev_ba},
                "x": x.tolist(), "y_sos": y_sos.tolist()}
        if stable and agrees:
            case["y_ba"] = y_ba.tolist()
        print(f"order {order:2d} {fc:5} Hz at {fs:6} Hz: (b, a) stable {stable}, agrees {agrees}, "
              f"settling {case['settling']}, constant dev sos {dev_sos:.1e} ba {dev_ba:.1e}")
        cases.append(case)
out["lowpass_sos"] = cases

path = pathlib.Path(__file__).resolve().parents[2] / "crates/teachcam/tests/data/smooth/scipy_sos_reference.json"
path.write_text(json.dumps(out))
print("wrote", path)
