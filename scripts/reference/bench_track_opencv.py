"""The reference for the tracking benchmark: one frame from blob centres to the tool's pose,
done the way an OpenCV/NumPy user would, on the same scene as `cargo bench --bench track`.

OpenCV has no multi-camera correspondence search, so this side is GIVEN the correspondences
(an advantage): per marker, cv2.undistortPoints in each camera, cv2.triangulatePoints on the
first two cameras that see it, then a NumPy SVD (Kabsch) registration of the tool model.

Usage: teachcam simulate --scenario paper --out /tmp/sim-paper
       python bench_track_opencv.py /tmp/sim-paper
"""
import csv
import json
import pathlib
import sys
import time

import cv2
import numpy as np

cv2.setNumThreads(1)
root = pathlib.Path(sys.argv[1])
rig = json.loads((root / "rig.json").read_text())
tool = json.loads((root / "tool.json").read_text())
model = np.array(tool["markers"], dtype=float)
rows = [r for r in csv.DictReader(open(root / "projections.csv")) if r["frame"] == "30"]
cams = []
for cam in rig["cameras"]:
    K = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1.0]])
    R = np.array(cam["rotation"], dtype=float)
    t = np.array(cam["translation"], dtype=float).reshape(3, 1)
    P = np.hstack([R, t])
    px = np.array([[float(r["x_px"]), float(r["y_px"])] for r in rows if r["camera"] == cam["name"]])
    cams.append((K, np.array(cam["distortion"], dtype=float), P, px))


def frame():
    normalized = [cv2.undistortPoints(px.reshape(-1, 1, 2), K, d).reshape(-1, 2) for K, d, _, px in cams]
    X = cv2.triangulatePoints(cams[0][2], cams[1][2], normalized[0].T, normalized[1].T)
    X = (X[:3] / X[3]).T
    mc, xc = model.mean(0), X.mean(0)
    H = (X - xc).T @ (model - mc)
    U, S, Vt = np.linalg.svd(H)
    D = np.diag([1, 1, np.sign(np.linalg.det(U @ Vt))])
    Rot = U @ D @ Vt
    return Rot, xc - Rot @ mc


frame()
n = 20000
best = float("inf")
for _ in range(5):
    start = time.perf_counter()
    for _ in range(n):
        frame()
    best = min(best, (time.perf_counter() - start) / n)
print(json.dumps({"opencv": cv2.__version__, "numpy": np.__version__, "frame_us": best * 1e6}))
