"""SciPy side of the smoothing benchmark (issue 5): one hour of trajectory at 100 Hz.

Run: /work/pyref/bin/python scripts/reference/smooth_bench_scipy.py DIR
Writes DIR/hour.csv (360,000 rows, the contract's trajectory columns) if missing, then times
what a SciPy user does for the same job: load the CSV (numpy.loadtxt), filtfilt each pose and
tip column with butter(2, 10 Hz, fs=100), save (numpy.savetxt). Prints the times as JSON.
Compare with: time teachcam smooth DIR/hour.csv --method lowpass --cutoff 10 -o DIR/out.csv
"""
import json
import pathlib
import sys
import time

import numpy as np
from scipy import signal
from scipy.spatial.transform import Rotation

HEADER = "frame,time_s,x_mm,y_mm,z_mm,qw,qx,qy,qz,tip_x_mm,tip_y_mm,tip_z_mm,markers,rms_mm"


def make_input(path, fs=100.0, seconds=3600):
    rng = np.random.default_rng(7)
    n = int(fs * seconds)
    t = np.arange(n) / fs
    pos = np.stack([300 + 80 * np.sin(2 * np.pi * 0.21 * t) + 10 * np.sin(2 * np.pi * 1.3 * t),
                    50 * np.cos(2 * np.pi * 0.17 * t),
                    120 + 20 * np.sin(2 * np.pi * 0.5 * t)], axis=1) + rng.normal(0, 0.3, (n, 3))
    rotvec = np.stack([0.4 * np.sin(2 * np.pi * 0.11 * t), 0.3 * np.cos(2 * np.pi * 0.07 * t),
                       1.0 * np.sin(2 * np.pi * 0.05 * t)], axis=1) + rng.normal(0, 0.002, (n, 3))
    rot = Rotation.from_rotvec(rotvec)
    q = rot.as_quat(scalar_first=True)
    q[q[:, 0] < 0] *= -1
    tip = rot.apply(np.array([0.0, -15.0, -180.0])) + pos
    cols = np.column_stack([np.arange(n), t, pos, q, tip, np.full(n, 4), np.full(n, 0.02)])
    fmt = ["%d", "%.6f"] + ["%.6f"] * 3 + ["%.9f"] * 4 + ["%.6f"] * 3 + ["%d", "%.6f"]
    np.savetxt(path, cols, delimiter=",", header=HEADER, comments="", fmt=fmt)


def main():
    folder = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/smooth-bench")
    folder.mkdir(parents=True, exist_ok=True)
    src = folder / "hour.csv"
    if not src.exists():
        make_input(src)
    t0 = time.perf_counter()
    data = np.loadtxt(src, delimiter=",", skiprows=1)
    t1 = time.perf_counter()
    b, a = signal.butter(2, 10.0, fs=100.0)
    out = data.copy()
    for c in range(2, 12):
        out[:, c] = signal.filtfilt(b, a, data[:, c])
    q = out[:, 5:9]
    out[:, 5:9] = q / np.linalg.norm(q, axis=1, keepdims=True)
    t2 = time.perf_counter()
    np.savetxt(folder / "scipy_out.csv", out, delimiter=",", header=HEADER, comments="", fmt="%.9g")
    t3 = time.perf_counter()
    print(json.dumps({"rows": int(data.shape[0]), "load_s": t1 - t0, "filter_s": t2 - t1,
                      "save_s": t3 - t2, "total_s": t3 - t0}))


main()
