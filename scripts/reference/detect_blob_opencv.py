"""Reference numbers for detection on OpenCV's detect_blob.png, computed with OpenCV.

Grey = max(R, G, B) of the RGBA file (the Rust test builds the same grey image), foreground =
grey > 100 (THRESH_BINARY), 8-connected components (connectedComponentsWithStats). Per
component: area, bounding box, binary centroid, intensity-weighted centroid (weights = grey)
with the sums it comes from (so a test can subtract any background level b:
c = (Σ I x − b n c̄) / (Σ I − b n)), and minEnclosingCircle of the component's pixel centres.

Run: /work/pyref/bin/python scripts/reference/detect_blob_opencv.py
Writes crates/teachcam/tests/data/detect_blob_opencv.json.
"""
import json
import pathlib

import cv2
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
SOURCE = ROOT.parent / "shared" / "data" / "blob" / "detect_blob.png"
OUT = ROOT / "crates" / "teachcam" / "tests" / "data" / "detect_blob_opencv.json"
THRESHOLD = 100

rgba = cv2.imread(str(SOURCE), cv2.IMREAD_UNCHANGED)
grey = rgba[:, :, :3].max(axis=2)
_, mask = cv2.threshold(grey, THRESHOLD, 255, cv2.THRESH_BINARY)
count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
components = []
for label in range(1, count):
    ys, xs = np.nonzero(labels == label)
    w = grey[ys, xs].astype(np.float64)
    (mx, my), mr = cv2.minEnclosingCircle(np.stack([xs, ys], axis=1).astype(np.float32))
    x, y, bw, bh, area = (int(v) for v in stats[label])
    components.append(
        {
            "area": area,
            "bbox": [x, y, x + bw - 1, y + bh - 1],
            "centroid": [float(centroids[label][0]), float(centroids[label][1])],
            "weighted_centroid": [float((w * xs).sum() / w.sum()), float((w * ys).sum() / w.sum())],
            "intensity_sums": [float(w.sum()), float((w * xs).sum()), float((w * ys).sum())],
            "min_enclosing_circle": [float(mx), float(my), float(mr)],
        }
    )
components.sort(key=lambda c: (c["bbox"][1], c["bbox"][0]))
OUT.write_text(
    json.dumps(
        {"source": "shared/data/blob/detect_blob.png", "grey": "max(R,G,B)", "threshold": THRESHOLD,
         "opencv": cv2.__version__, "components": components},
        indent=1,
    )
    + "\n"
)
print(f"{len(components)} components -> {OUT}")
