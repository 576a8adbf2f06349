"""The work object that places the Optotrak probe trial within an IRB 120's reach, for the
`probe_trajectory_exports_to_rapid` CLI test: the first pose of the probe's trajectory
(`teachcam import c3d ktk_racing_probing_acromion_R.c3d --markers Probe1,...,Probe6 -o
traj.csv`) is put at (350, 0, 300) mm in the robot base, tool z pointing down:
base_from_wobj = base_from_tool_target * world_from_tool(frame 0)^-1. This is a placement, not
an expected value: the test only checks that a program is written.

Run: /work/pyref/bin/python scripts/reference/c3d_probe_wobj.py traj.csv
Prints "x,y,z,qw,qx,qy,qz" for --wobj.
"""

import csv
import sys

import numpy as np
from scipy.spatial.transform import Rotation

row = next(csv.DictReader(open(sys.argv[1])))
p = np.array([float(row[k]) for k in ("x_mm", "y_mm", "z_mm")])
world_from_tool = Rotation.from_quat([float(row[k]) for k in ("qx", "qy", "qz", "qw")])
target = Rotation.from_euler("x", 180, degrees=True)
rotation = target * world_from_tool.inv()
translation = np.array([350.0, 0.0, 300.0]) - rotation.apply(p)
x, y, z, w = rotation.as_quat()
if w < 0:
    x, y, z, w = -x, -y, -z, -w
print(f"{translation[0]:.3f},{translation[1]:.3f},{translation[2]:.3f},{w:.9f},{x:.9f},{y:.9f},{z:.9f}")
