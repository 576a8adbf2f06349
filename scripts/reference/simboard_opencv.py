"""Independent checks of `teachcam simulate --scenario calibration` output with OpenCV.

Usage: simboard_opencv.py FOLDER   (a folder written by `teachcam simulate --scenario calibration`)

1. Corners: cv2.findChessboardCorners + cornerSubPix (11x11, as OpenCV's tutorial) on every
   rendered image, compared one to one with the renderer's truth `corners.csv`: checks the
   rendered geometry, the corner order (OpenCV's) and the accuracy the images allow.
2. Timing for the renderer's benchmark: cv2.warpPerspective of a 4x supersampled board
   texture into a 1280x1024 image plus a 4x4 area downsample (pinhole only, no distortion),
   the nearest OpenCV operation to rendering one view.
Prints a JSON summary on stdout.
"""
import csv
import glob
import json
import sys
import time

import cv2

cv2.setNumThreads(1)
import numpy as np

folder = sys.argv[1]
truth = {}
for r in csv.DictReader(open(f"{folder}/corners.csv")):
    truth.setdefault((r["camera"], r["view"]), []).append((float(r["x_px"]), float(r["y_px"])))
found_count, worst, mean_errors, seconds = 0, [], [], 0.0
files = sorted(glob.glob(f"{folder}/cam*/*.png"))
order_mismatches = 0
for f in files:
    img = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
    t0 = time.perf_counter()
    found, c = cv2.findChessboardCorners(img, (9, 6))
    if found:
        c = cv2.cornerSubPix(img, c, (11, 11), (-1, -1),
                             (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001))
    seconds += time.perf_counter() - t0
    cam, view = f.split("/")[-2], f.split("/")[-1][:-4]
    if not found:
        continue
    found_count += 1
    d = np.linalg.norm(c.reshape(-1, 2) - np.array(truth[(cam, view)]), axis=1)
    if d.max() > 1.0:
        order_mismatches += 1
        continue
    worst.append(float(d.max()))
    mean_errors.append(float(d.mean()))

# Timing: warp a 4x supersampled board texture (10x7 squares + margin) into 4x the image.
s = 40
texture = np.full((7 * s + 2 * s, 10 * s + 2 * s), 205, np.uint8)
for j in range(7):
    for i in range(10):
        if (i + j) % 2 == 0:
            texture[s + j * s:s + (j + 1) * s, s + i * s:s + (i + 1) * s] = 27
H = np.array([[3.2, 0.6, 800.0], [-0.4, 3.0, 900.0], [0.0004, 0.0002, 1.0]])
runs = []
for _ in range(20):
    t0 = time.perf_counter()
    big = cv2.warpPerspective(texture, H, (1280 * 4, 1024 * 4), flags=cv2.INTER_LINEAR)
    small = cv2.resize(big, (1280, 1024), interpolation=cv2.INTER_AREA)
    runs.append(time.perf_counter() - t0)
print(json.dumps({
    "images": len(files),
    "found_by_opencv": found_count,
    "order_mismatches": order_mismatches,
    "max_corner_error_px": max(worst),
    "median_of_per_image_max_px": float(np.median(worst)),
    "mean_corner_error_px": float(np.mean(mean_errors)),
    "opencv_find_plus_subpix_s_per_image": seconds / len(files),
    "opencv_warp_supersampled_view_s_median": float(np.median(runs)),
    "opencv_threads": cv2.getNumThreads(),
}, indent=1))
