"""Independent solver for the wand bundle adjustment (issue 16): scipy.optimize.least_squares.

Reads crates/teachcam/tests/data/wand_observations.csv (frame,camera,marker,u,v: distorted
pixels, markers in wand order) and wand_observations_rig.json (the true rig in camera 0's
frame: the intrinsics, held; the extrinsics, perturbed, are only the start), solves for the
extrinsics of cameras 1..N-1 (camera 0 fixed: the gauge) and every frame's wand (marker 0 and
two spherical angles of the axis; markers at 0/160/500 mm along it: the scale) minimising the
sum of squared reprojection errors with OpenCV's distortion model written out here, and writes
crates/teachcam/tests/data/wand_bundle_scipy.json.

Run: python3 -m venv /work/team/venv-refine && /work/team/venv-refine/bin/pip install numpy scipy
     /work/team/venv-refine/bin/python scripts/reference/wand_bundle_scipy.py
"""
import json
import pathlib

import numpy as np
import scipy
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix
from scipy.spatial.transform import Rotation

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "crates/teachcam/tests/data"
POSITIONS = np.array([0.0, 160.0, 500.0])

rig = json.loads((DATA / "wand_observations_rig.json").read_text())["cameras"]
rows = np.loadtxt(DATA / "wand_observations.csv", delimiter=",", skiprows=1)
frames = sorted(set(rows[:, 0].astype(int)))
frame_index = {f: i for i, f in enumerate(frames)}
cam = rows[:, 1].astype(int)
marker = rows[:, 2].astype(int)
frame = np.array([frame_index[int(f)] for f in rows[:, 0]])
uv = rows[:, 3:5]
n_cams, n_frames = len(rig), len(frames)


def project(c, points):
    """OpenCV's pinhole + [k1, k2, p1, p2, k3] projection of camera-frame points."""
    k1, k2, p1, p2, k3 = rig[c]["distortion"]
    x, y = points[:, 0] / points[:, 2], points[:, 1] / points[:, 2]
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([rig[c]["fx"] * xd + rig[c]["cx"], rig[c]["fy"] * yd + rig[c]["cy"]], axis=1)


def unpack(x):
    poses = [(np.eye(3), np.zeros(3))]
    for c in range(1, n_cams):
        p = x[6 * (c - 1): 6 * c]
        poses.append((Rotation.from_rotvec(p[:3]).as_matrix(), p[3:]))
    w = x[6 * (n_cams - 1):].reshape(n_frames, 5)
    theta, phi = w[:, 3], w[:, 4]
    axis = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], 1)
    return poses, w[:, :3], axis


def residuals(x):
    poses, start, axis = unpack(x)
    world = start[frame] + axis[frame] * POSITIONS[marker][:, None]
    out = np.empty_like(uv)
    for c in range(n_cams):
        sel = cam == c
        r, t = poses[c]
        out[sel] = project(c, world[sel] @ r.T + t) - uv[sel]
    return out.ravel()


# Start: the true extrinsics turned by 0.5 deg and moved by 10 mm (a seeded draw), each frame's
# wand from a linear (DLT, distortion ignored) triangulation of its end markers.
rng = np.random.default_rng(16)
x0 = []
start_poses = [(np.eye(3), np.zeros(3))]
for c in range(1, n_cams):
    r = np.array(rig[c]["rotation"])
    t = np.array(rig[c]["translation"])
    turn = Rotation.from_rotvec(np.deg2rad(0.5) * (v := rng.normal(size=3)) / np.linalg.norm(v))
    r = turn.as_matrix() @ r
    t = t + 10.0 * (d := rng.normal(size=3)) / np.linalg.norm(d)
    start_poses.append((r, t))
    x0 += list(Rotation.from_matrix(r).as_rotvec()) + list(t)


def triangulate(f, k):
    a = []
    for c in range(n_cams):
        sel = (frame == f) & (cam == c) & (marker == k)
        if not sel.any():
            continue
        u, v = uv[sel][0]
        kmat = np.array([[rig[c]["fx"], 0, rig[c]["cx"]], [0, rig[c]["fy"], rig[c]["cy"]], [0, 0, 1]])
        r, t = start_poses[c]
        p = kmat @ np.hstack([r, t[:, None]])
        a += [u * p[2] - p[0], v * p[2] - p[1]]
    x = np.linalg.svd(np.array(a))[2][-1]
    return x[:3] / x[3]


for f in range(n_frames):
    s, e = triangulate(f, 0), triangulate(f, 2)
    d = (e - s) / np.linalg.norm(e - s)
    x0 += list(s) + [np.arccos(np.clip(d[2], -1, 1)), np.arctan2(d[1], d[0])]
x0 = np.array(x0)

sparsity = lil_matrix((2 * len(uv), len(x0)), dtype=int)
for i in range(len(uv)):
    rows_i = [2 * i, 2 * i + 1]
    if cam[i] > 0:
        for j in range(6):
            sparsity[rows_i, 6 * (cam[i] - 1) + j] = 1
    for j in range(5):
        sparsity[rows_i, 6 * (n_cams - 1) + 5 * frame[i] + j] = 1

solution = least_squares(residuals, x0, jac_sparsity=sparsity, method="trf", x_scale="jac",
                         ftol=1e-14, xtol=1e-14, gtol=1e-14, max_nfev=2000, jac="3-point")
poses, start, axis = unpack(solution.x)
r = solution.fun.reshape(-1, 2)
out = {
    "solver": f"scipy {scipy.__version__} least_squares trf, 3-point finite differences",
    "observations": int(len(uv)),
    "frames": n_frames,
    "status": int(solution.status),
    "cost": float(np.sum(solution.fun**2)),
    "reprojection_rms_px": float(np.sqrt(np.mean(np.sum(r * r, axis=1)))),
    "cameras": [
        {
            "name": rig[c]["name"],
            "rotation": poses[c][0].tolist(),
            "translation": poses[c][1].tolist(),
            "centre_mm": (-poses[c][0].T @ poses[c][1]).tolist(),
        }
        for c in range(n_cams)
    ],
}
(DATA / "wand_bundle_scipy.json").write_text(json.dumps(out, indent=1) + "\n")
print(json.dumps({k: v for k, v in out.items() if k != "cameras"}))
for c in out["cameras"]:
    print(c["name"], np.round(c["centre_mm"], 4))
