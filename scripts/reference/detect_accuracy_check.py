"""Accuracy of `teachcam detect` output against a simulated recording's exact projections.

For every marker view marked isolated and fully visible in projections.csv: the distance to
the nearest detected centre (missed when none within 2 px). For every other marker view
(touching another image, or partly hidden): blobs within its radius whose centre is more than
0.1 px off are counted as wrong centres (the detector must reject or split, not guess).

Usage: python scripts/reference/detect_accuracy_check.py REC/projections.csv detections.csv
"""
import csv
import sys

import numpy as np

projections, detections = sys.argv[1], sys.argv[2]
found = {}
for r in csv.DictReader(open(detections)):
    found.setdefault((r["camera"], int(r["frame"])), []).append((float(r["x_px"]), float(r["y_px"])))
errors, missed, wrong, crowded = [], 0, 0, 0
for r in csv.DictReader(open(projections)):
    key = (r["camera"], int(r["frame"]))
    truth = np.array([float(r["x_px"]), float(r["y_px"])])
    d = np.array([np.hypot(x - truth[0], y - truth[1]) for x, y in found.get(key, [])] or [np.inf])
    if r["isolated"] == "1" and float(r["visible_fraction"]) >= 1.0:
        if d.min() < 2.0:
            errors.append(d.min())
        else:
            missed += 1
    else:
        crowded += 1
        wrong += int(((d > 0.1) & (d < float(r["radius_px"]))).sum())
e = np.array(errors)
print(
    f"isolated: {len(e) + missed} marker views, missed {missed}, mean {e.mean():.4f} px, "
    f"p99 {np.percentile(e, 99):.4f} px, max {e.max():.4f} px; "
    f"crowded or hidden: {crowded} views, wrong centres {wrong}"
)
