"""Read the C3D file teachcam's writer produced (crates/teachcam/tests/data/c3d/
teachcam_written.c3d) with ezc3d and store what ezc3d sees, so the Rust test can check that
another reader accepts our files and reads the data we wrote.

Run: /work/pyref/bin/python scripts/reference/c3d_written_check.py
"""

import json
import pathlib

import ezc3d
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
DIR = ROOT / "crates" / "teachcam" / "tests" / "data" / "c3d"

c = ezc3d.c3d(str(DIR / "teachcam_written.c3d"))
point = c["parameters"]["POINT"]
pts = c["data"]["points"]
out = {
    "labels": list(point["LABELS"]["value"]),
    "rate_hz": float(point["RATE"]["value"][0]),
    "units": str(point["UNITS"]["value"][0]),
    "frames": int(pts.shape[2]),
    "points": [
        [
            None if np.any(np.isnan(pts[:3, m, f])) else [float(v) for v in pts[:3, m, f]]
            for m in range(pts.shape[1])
        ]
        for f in range(pts.shape[2])
    ],
}
# py-c3d 0.6.0, a second reader, decodes the residual word per the User Guide (ezc3d swaps
# its bytes): residual and camera mask of every sample, null for a gap.
import c3d as pyc3d

with open(DIR / "teachcam_written.c3d", "rb") as handle:
    out["pyc3d_words"] = [
        [None if p[3] < 0 else {"residual": float(p[3]), "camera_mask": int(p[4])} for p in points]
        for _, points, _ in pyc3d.Reader(handle).read_frames()
    ]
(DIR / "teachcam_written.json").write_text(json.dumps(out, indent=1) + "\n")
print(json.dumps(out)[:300])
