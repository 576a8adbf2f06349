"""OpenCV 5's multi-camera calibration on the same noisy corners as our rig calibration.

Usage: rig_opencv_multiview.py FOLDER OUT.json
  FOLDER: written by `teachcam simulate --scenario calibration --seed 1 --views 20 --out FOLDER`
  OUT:    crates/teachcam/tests/data/rig_multiview_opencv.json

1. Observations: the renderer's exact corners (`corners.csv`, every held view; the world view is
   left out, since OpenCV's world is camera 0) plus Gaussian noise of 0.025 px per coordinate
   (the detector's measured corner noise, notes/rig.md), numpy seed 8.
2. cv2.calibrateMultiview (pinhole, 5-coefficient distortion, intrinsics estimated from
   scratch) on them: camera poses relative to camera 0, intrinsics, RMS.
3. Timing, single thread (cv2.setNumThreads(1)), best and median of 5 runs.
Writes the observations, the true rig (`rig.json`) and OpenCV's result to OUT.
"""
import csv
import json
import sys
import time

import cv2
import numpy as np

cv2.setNumThreads(1)
folder, out = sys.argv[1], sys.argv[2]
rig = json.load(open(f"{folder}/rig.json"))
boards = json.load(open(f"{folder}/boards.json"))
board = boards["board"]
cols, rows, square = board["inner_cols"], board["inner_rows"], board["square_mm"]
cameras = [c["name"] for c in rig["cameras"]]
views = [v["name"] for v in boards["views"] if v["name"] != "world"]
corners = {}
for r in csv.DictReader(open(f"{folder}/corners.csv")):
    corners.setdefault((r["camera"], r["view"]), []).append((float(r["x_px"]), float(r["y_px"])))
rng = np.random.default_rng(8)
noise_px = 0.025
observations = []
for view in views:
    for camera in cameras:
        if (camera, view) in corners:
            exact = np.array(corners[(camera, view)])
            assert exact.shape == (cols * rows, 2)
            noisy = exact + rng.normal(0.0, noise_px, exact.shape)
            observations.append({"camera": camera, "view": view, "corners": noisy.round(6).tolist()})

# In metres: calibrateMultiview normalises the pattern by its squared size, and a board in
# millimetres then trips its collinearity guard ("Pattern points are collinear!").
# Translations come back in metres and are converted to millimetres below.
object_points = np.array([[c * square, r * square, 0.0] for r in range(rows) for c in range(cols)],
                         dtype=np.float32) / 1000.0
n_cam, n_view = len(cameras), len(views)
mask = np.zeros((n_cam, n_view), dtype=np.uint8)
image_points = [[np.zeros((cols * rows, 2), dtype=np.float32) for _ in views] for _ in cameras]
for o in observations:
    c, v = cameras.index(o["camera"]), views.index(o["view"])
    mask[c, v] = 1
    image_points[c][v] = np.array(o["corners"], dtype=np.float32)
sizes = [tuple(c["image_size"]) for c in rig["cameras"]]


def run():
    return cv2.calibrateMultiview(
        [object_points] * n_view, image_points, sizes, mask,
        np.zeros((n_cam, 1), dtype=np.uint8),  # CALIB_MODEL_PINHOLE
        None, None, None, None)


seconds = []
for _ in range(5):
    t0 = time.perf_counter()
    result = run()
    seconds.append(time.perf_counter() - t0)
rms, Ks, dists, Rs, Ts = result[0], result[1], result[2], result[3], result[4]
opencv = {
    "rms_px": float(rms),
    "cameras": [
        {
            "name": name,
            "fx": float(K[0][0]), "fy": float(K[1][1]), "cx": float(K[0][2]), "cy": float(K[1][2]),
            "distortion": np.asarray(d).ravel()[:5].tolist(),
            "rotation": (cv2.Rodrigues(np.asarray(R, dtype=np.float64))[0]
                         if np.asarray(R).size == 3 else np.asarray(R)).tolist(),
            "translation": (1000.0 * np.asarray(T, dtype=np.float64).ravel()).tolist(),
        }
        for name, K, d, R, T in zip(cameras, Ks, dists, Rs, Ts)
    ],
    "seconds_best": min(seconds),
    "seconds_median": sorted(seconds)[len(seconds) // 2],
}
json.dump({
    "about": __doc__.strip().splitlines()[0],
    "source": "scripts/reference/rig_opencv_multiview.py",
    "opencv_version": cv2.__version__,
    "noise_px": noise_px,
    "board": {"inner_cols": cols, "inner_rows": rows, "square_mm": square},
    "rig": rig,
    "observations": observations,
    "opencv": opencv,
}, open(out, "w"))
print(json.dumps({k: v for k, v in opencv.items()}, indent=1))
