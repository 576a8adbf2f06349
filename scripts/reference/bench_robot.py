"""Timing references for benches/robot.rs, same inputs, NumPy/SciPy on this machine.

- forward kinematics of 10 000 joint vectors: the URDF chain of irb120_fk.py, vectorised over
  the batch with NumPy (4x4 matrices, einsum), and SciPy's Rotation per pose in a loop;
- pivot calibration of 300 poses: numpy.linalg.lstsq on the 900x6 system.
Run: /work/pyref/bin/python scripts/reference/bench_robot.py
"""
import timeit

import numpy as np
from scipy.spatial.transform import Rotation

rng = np.random.default_rng(120)
limits = np.radians([[-165, 165], [-110, 110], [-110, 70], [-160, 160], [-120, 120], [-400, 400]])
q = rng.uniform(limits[:, 0], limits[:, 1], size=(10_000, 6))
chain = [((0, 0, 0), (0, 0, 1)), ((0, 0, 290), (0, 1, 0)), ((0, 0, 270), (0, 1, 0)),
         ((0, 0, 70), (1, 0, 0)), ((302, 0, 0), (0, 1, 0)), ((72, 0, 0), (1, 0, 0))]
tool0 = np.eye(4)
tool0[:3, :3] = Rotation.from_euler("xyz", [0, np.pi / 2, 0]).as_matrix()


def fk_batch(q):
    n = len(q)
    T = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    for i, (origin, axis) in enumerate(chain):
        step = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
        step[:, :3, 3] = origin
        step[:, :3, :3] = Rotation.from_rotvec(np.outer(q[:, i], axis)).as_matrix()
        T = np.einsum("nij,njk->nik", T, step)
    return T @ tool0


def pivot(R, t):
    n = len(R)
    A = np.zeros((3 * n, 6))
    A[:, :3] = R.reshape(3 * n, 3)
    A[:, 3:] = np.tile(-np.eye(3), (n, 1))
    return np.linalg.lstsq(A, -t.reshape(-1), rcond=None)[0]


k = np.arange(300) / 300 * 2 * np.pi
rot = Rotation.from_euler("ZYX", np.stack([0.3 * np.sin(2 * k), 0.5 * np.cos(k), 0.5 * np.sin(k)], 1))
R = rot.as_matrix()
t = np.array([100, 50, 0]) - rot.apply([3, -15, -180])

for name, fn, number in [("forward_10k (numpy batch)", lambda: fk_batch(q), 20),
                         ("pivot_300_poses (numpy lstsq)", lambda: pivot(R, t), 500)]:
    best = min(timeit.repeat(fn, number=number, repeat=5)) / number
    print(f"{name}: {best * 1e3:.3f} ms")
