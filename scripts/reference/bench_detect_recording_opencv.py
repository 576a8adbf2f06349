"""OpenCV doing the work of `teachcam detect REC -o detections.csv` on a recording folder.

For every PNG of every camera sub-folder of REC (sorted by name), one thread:
1. `cv2.imread` (grey);
2. threshold: background `b` = median of every 16th pixel, noise `s` = 1.4826 x their median
   absolute deviation, `T = b + max(8 s, 255 / 32)` (teachcam's automatic threshold), then
   `cv2.threshold(THRESH_BINARY)`;
3. `cv2.connectedComponentsWithStats` (8-connected), components of fewer than 4 pixels dropped;
4. the background-subtracted, intensity-weighted centroid of each component's own pixels,
   `sum (I - b) x / sum (I - b)`, summed with `numpy.bincount` over the label image;
5. one CSV row per blob: camera, frame, x_px, y_px, radius_px (sqrt(area / pi)), area_px.

This is less than teachcam does per blob (no refined disc window, no roundness, no split of
merged blobs, no predicted noise), so the ratio favours OpenCV.

Usage: python bench_detect_recording_opencv.py REC OUT.csv [ROUNDS]
Prints JSON: frames, blobs, wall seconds of each round (the work above, interpreter start and
`import cv2` not counted), and CPU seconds.
"""
import csv
import json
import pathlib
import sys
import time

import cv2
import numpy as np


def threshold_of(grey):
    sample = grey[::16, ::16].ravel().astype(np.float64)
    background = float(np.median(sample))
    noise = 1.4826 * float(np.median(np.abs(sample - background)))
    return background, background + max(8.0 * noise, 255.0 / 32.0)


def detect(grey):
    background, threshold = threshold_of(grey)
    # THRESH_BINARY keeps values strictly above the (integer) threshold, as teachcam does.
    _, mask = cv2.threshold(grey, int(threshold), 255, cv2.THRESH_BINARY)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    inside = labels > 0
    ys, xs = np.nonzero(inside)
    lab = labels[ys, xs]
    w = grey[ys, xs].astype(np.float64) - background
    sw = np.bincount(lab, weights=w, minlength=count)
    sx = np.bincount(lab, weights=w * xs, minlength=count)
    sy = np.bincount(lab, weights=w * ys, minlength=count)
    rows = []
    for k in range(1, count):
        area = int(stats[k, cv2.CC_STAT_AREA])
        if area < 4 or sw[k] <= 0:
            continue
        rows.append((sx[k] / sw[k], sy[k] / sw[k], (area / np.pi) ** 0.5, area))
    return rows


def whole_job(root, out_csv):
    frames = 0
    blobs = 0
    with open(out_csv, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["camera", "frame", "x_px", "y_px", "radius_px", "area_px"])
        for camera in sorted(p for p in root.iterdir() if p.is_dir()):
            for index, path in enumerate(sorted(camera.glob("*.png"))):
                grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
                for x, y, radius, area in detect(grey):
                    writer.writerow([camera.name, index, f"{x:.6f}", f"{y:.6f}", f"{radius:.6f}", area])
                    blobs += 1
                frames += 1
    return frames, blobs


def main():
    root = pathlib.Path(sys.argv[1])
    out_csv = pathlib.Path(sys.argv[2])
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 1
    cv2.setNumThreads(1)
    walls, cpus = [], []
    for _ in range(rounds):
        t0, c0 = time.perf_counter(), time.process_time()
        frames, blobs = whole_job(root, out_csv)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    print(json.dumps({"opencv": cv2.__version__, "numpy": np.__version__, "frames": frames,
                      "blobs": blobs, "wall_s": walls, "cpu_s": cpus}))


if __name__ == "__main__":
    main()
