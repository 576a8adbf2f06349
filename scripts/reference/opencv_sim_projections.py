"""Independent check of the simulator's files: project the markers of `tool.json`, placed by
`truth.csv`, through the cameras of `rig.json` with OpenCV's projectPoints.

Usage: teachcam simulate --scenario paper --seed 1 --out /tmp/sim-paper
       python opencv_sim_projections.py /tmp/sim-paper
Writes crates/teachcam/tests/data/opencv_sim_paper_projections.json (every 10th frame).
"""
import csv
import json
import pathlib
import sys

import cv2
import numpy as np

root = pathlib.Path(sys.argv[1])
rig = json.loads((root / "rig.json").read_text())
tool = json.loads((root / "tool.json").read_text())
markers = np.array(tool["markers"], dtype=float)
rows = list(csv.DictReader(open(root / "truth.csv")))
out = []
for row in rows:
    frame = int(row["frame"])
    if frame % 10:
        continue
    q = [float(row[k]) for k in ("qw", "qx", "qy", "qz")]
    w, x, y, z = q
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    t = np.array([float(row[k]) for k in ("x_mm", "y_mm", "z_mm")])
    world = (R @ markers.T).T + t
    for cam in rig["cameras"]:
        K = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1.0]])
        rvec, _ = cv2.Rodrigues(np.array(cam["rotation"], dtype=float))
        px, _ = cv2.projectPoints(world.reshape(-1, 1, 3), rvec, np.array(cam["translation"], dtype=float),
                                  K, np.array(cam["distortion"], dtype=float))
        for m, p in enumerate(px.reshape(-1, 2)):
            out.append(dict(camera=cam["name"], frame=frame, marker=m, x_px=p[0], y_px=p[1]))
path = pathlib.Path(__file__).resolve().parents[2] / "crates/teachcam/tests/data/opencv_sim_paper_projections.json"
path.write_text(json.dumps(dict(opencv_version=cv2.__version__, seed=1, scenario="paper", projections=out), indent=0))
print("wrote", len(out), "projections to", path)
