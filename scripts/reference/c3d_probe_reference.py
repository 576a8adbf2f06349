"""Reference for the hand-held Optotrak probe (Probe1..Probe6) of the two ktk_racing_probing
trials, computed with ezc3d + numpy independently of teachcam:

- the probe model by generalised Procrustes exactly as documented in teachcam's c3d::rigid
  (frames with all six markers valid; Kabsch/SVD alignment onto frame one, mean, align onto the
  mean, mean), written in the three-marker frame (origin Probe1, x to Probe2, Probe3 in xy);
- per frame, the RMS residual of registering that model onto the valid probe markers;
- the rigidity: std over the trial of each inter-marker distance.

Run: /work/pyref/bin/python scripts/reference/c3d_probe_reference.py
Writes crates/teachcam/tests/data/c3d/probe_<trial>.json.
"""

import json
import pathlib

import ezc3d
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "c3d"
OUT = ROOT / "crates" / "teachcam" / "tests" / "data" / "c3d"
LABELS = [f"Probe{i}" for i in range(1, 7)]


def kabsch(model, measured):
    """R, t minimising |R model + t - measured|, with the determinant correction."""
    cm, cs = model.mean(0), measured.mean(0)
    h = (measured - cs).T @ (model - cm)
    u, _, vt = np.linalg.svd(h)
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    r = u @ d @ vt
    return r, cs - r @ cm


def main():
    for trial in ("acromion_R", "olecrane_R"):
        c = ezc3d.c3d(str(DATA / f"ktk_racing_probing_{trial}.c3d"))
        labels = list(c["parameters"]["POINT"]["LABELS"]["value"])
        cols = [labels.index(l) for l in LABELS]
        pts = c["data"]["points"][:3, cols, :].transpose(2, 1, 0) * 1000.0  # frames, 6, 3 (mm)
        valid = ~np.isnan(pts).any(axis=2)
        complete = [f for f in range(pts.shape[0]) if valid[f].all()]
        shapes = pts[complete]
        mean = shapes[0].copy()
        for _ in range(2):
            aligned = []
            for s in shapes:
                r, t = kabsch(s, mean)
                aligned.append(s @ r.T + t)
            aligned = np.array(aligned)
            mean = aligned.mean(0)
        marker_rms = np.sqrt(((aligned - mean) ** 2).sum(2).mean(0))
        x = mean[1] - mean[0]
        x /= np.linalg.norm(x)
        z = np.cross(x, mean[2] - mean[0])
        z /= np.linalg.norm(z)
        y = np.cross(z, x)
        rot = np.stack([x, y, z], axis=1)  # columns: tool axes in the data frame
        model = (mean - mean[0]) @ rot  # tool-frame coordinates
        rms = []
        for f in range(pts.shape[0]):
            v = valid[f]
            if v.sum() < 3:
                rms.append(None)
                continue
            r, t = kabsch(model[v], pts[f][v])
            res = model[v] @ r.T + t - pts[f][v]
            rms.append(float(np.sqrt((res**2).sum(1).mean())))
        dist_std = []
        for i in range(6):
            for j in range(i + 1, 6):
                d = np.linalg.norm(pts[:, i] - pts[:, j], axis=1)
                dist_std.append(float(np.nanstd(d)))
        out = {
            "trial": trial,
            "frames": int(pts.shape[0]),
            "frames_complete": len(complete),
            "markers_in_tool": model.tolist(),
            "marker_rms_mm": marker_rms.tolist(),
            "rms_mm": rms,
            "markers_per_frame": [int(v.sum()) for v in valid],
            "distance_std_mm": dist_std,
        }
        (OUT / f"probe_{trial}.json").write_text(json.dumps(out, indent=1) + "\n")
        print(trial, len(complete), "max rms", max(r for r in rms if r is not None),
              "max dist std", max(dist_std))


if __name__ == "__main__":
    main()
