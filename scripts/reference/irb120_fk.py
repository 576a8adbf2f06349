"""Reference forward kinematics of the ABB IRB 120-3/0.58, for teachcam's robot tests.

Two independent formulations, cross-checked here and stored as JSON:
1. the ROS-Industrial URDF chain (abb_irb120_support, irb120_3_58_macro.xacro): joint origins
   (0,0,0) z, (0,0,290) y, (0,0,270) y, (0,0,70) x, (302,0,0) y, (72,0,0) x, then tool0 turned
   by rpy (0, pi/2, 0); ROS-I ABB joints are the controller's joints.
2. a standard Denavit-Hartenberg table (d, a, alpha, theta offset) of the same arm, whose
   z axes may point against ABB's: the joint signs that reproduce the URDF are found by the
   script (and printed), which cross-checks the URDF's reading of the geometry.
Output: crates/teachcam/tests/data/robot/irb120_fk.json with joints in degrees and tool0 as
x, y, z (mm) and qw, qx, qy, qz.
Run: /work/pyref/bin/python scripts/reference/irb120_fk.py
"""
import itertools
import json
import pathlib

import numpy as np
from scipy.spatial.transform import Rotation


def rot(axis, angle):
    return Rotation.from_rotvec(np.asarray(axis, float) * angle).as_matrix()


def urdf_fk(q):
    chain = [((0, 0, 0), (0, 0, 1)), ((0, 0, 290), (0, 1, 0)), ((0, 0, 270), (0, 1, 0)),
             ((0, 0, 70), (1, 0, 0)), ((302, 0, 0), (0, 1, 0)), ((72, 0, 0), (1, 0, 0))]
    T = np.eye(4)
    for (origin, axis), angle in zip(chain, q):
        step = np.eye(4)
        step[:3, 3] = origin
        step[:3, :3] = rot(axis, angle)
        T = T @ step
    tool0 = np.eye(4)
    tool0[:3, :3] = Rotation.from_euler("xyz", [0, np.pi / 2, 0]).as_matrix()
    return T @ tool0


def dh_fk(q, signs):
    # (theta offset, d, a, alpha), millimetres
    rows = [(0, 290, 0, -np.pi / 2), (-np.pi / 2, 0, 270, 0), (0, 0, 70, -np.pi / 2),
            (0, 302, 0, np.pi / 2), (0, 0, 0, -np.pi / 2), (np.pi, 72, 0, 0)]
    T = np.eye(4)
    for (offset, d, a, alpha), angle, s in zip(rows, q, signs):
        th = s * angle + offset
        ct, st, ca, sa = np.cos(th), np.sin(th), np.cos(alpha), np.sin(alpha)
        T = T @ np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                          [0, sa, ca, d], [0, 0, 0, 1]])
    return T


rng = np.random.default_rng(120)
limits = np.radians([[-165, 165], [-110, 110], [-110, 70], [-160, 160], [-120, 120], [-400, 400]])
samples = [np.zeros(6), np.radians([30, 0, 0, 0, 0, 0]), np.radians([0, 30, 0, 0, 0, 0]),
           np.radians([0, 0, 30, 0, 0, 0]), np.radians([0, 0, 0, 0, 30, 0]),
           np.radians([0, 0, 0, 30, 30, 0]), np.radians([0, 0, 0, 0, 30, 30])]
samples += [rng.uniform(limits[:, 0], limits[:, 1]) for _ in range(40)]

# Find the DH joint signs that agree with the URDF in position (flange) over all samples.
found = None
for signs in itertools.product([1, -1], repeat=6):
    if all(np.allclose(dh_fk(q, signs)[:3, 3], urdf_fk(q)[:3, 3], atol=1e-9) for q in samples):
        found = signs
        break
assert found is not None, "DH table and URDF chain disagree on the flange position"
print("DH joint signs reproducing the URDF chain:", found)

out = []
for q in samples:
    T = urdf_fk(q)
    x, y, z, w = Rotation.from_matrix(T[:3, :3]).as_quat()
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    out.append({"joints_deg": list(np.degrees(q)), "position_mm": list(T[:3, 3]),
                "quaternion_wxyz": [w, x, y, z]})
path = pathlib.Path(__file__).resolve().parents[2] / "crates/teachcam/tests/data/robot/irb120_fk.json"
path.write_text(json.dumps({"source": "scripts/reference/irb120_fk.py", "poses": out}, indent=1) + "\n")
print("home tool0", out[0])
print("J2=30", out[2]["position_mm"], "J3=30", out[3]["position_mm"])
