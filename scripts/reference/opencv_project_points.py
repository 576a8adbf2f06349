"""Reference pixels from OpenCV's projectPoints for the camera law harness.

Run with a Python that has numpy and opencv-python(-headless); writes
crates/teachcam/tests/data/opencv_project_points.json. The tests read only that file.
"""
import json
import pathlib

import cv2
import numpy as np

rng = np.random.default_rng(20261123)
cameras = [
    # the paper's camera: 12 mm lens, 6.7 um pixels, mild barrel distortion
    dict(name="paper", size=[1280, 1024], fx=1791.0, fy=1791.0, cx=639.5, cy=511.5,
         dist=[-0.08, 0.05, 0.0, 0.0, 0.0]),
    # OpenCV's sample webcam, strong distortion with tangential terms and k3
    dict(name="webcam", size=[640, 480], fx=535.9, fy=536.1, cx=342.3, cy=235.5,
         dist=[-0.265, -0.047, 0.0012, -0.0003, 0.25]),
    # pincushion, non-square pixels, off-centre principal point
    dict(name="pincushion", size=[1920, 1200], fx=2400.0, fy=2390.0, cx=1000.0, cy=580.0,
         dist=[0.12, -0.3, 0.002, 0.001, 0.4]),
]
out = []
for cam in cameras:
    rvec = rng.normal(size=3) * 0.5
    tvec = rng.normal(size=3) * 100.0
    R, _ = cv2.Rodrigues(rvec)
    K = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1.0]])
    w, h = cam["size"]
    # points in front of the camera whose pinhole image fills the frame (and a margin)
    z = rng.uniform(500.0, 2000.0, size=200)
    u = rng.uniform(-0.05 * w, 1.05 * w, size=200)
    v = rng.uniform(-0.05 * h, 1.05 * h, size=200)
    pc = np.stack([(u - cam["cx"]) / cam["fx"] * z, (v - cam["cy"]) / cam["fy"] * z, z], axis=1)
    pw = (R.T @ (pc - tvec).T).T
    px, _ = cv2.projectPoints(pw.reshape(-1, 1, 3), rvec, tvec, K, np.array(cam["dist"]))
    out.append(dict(camera=cam, rotation=R.tolist(), translation=tvec.tolist(),
                    points_in_world=pw.tolist(), pixels=px.reshape(-1, 2).tolist()))
path = pathlib.Path(__file__).resolve().parents[2] / "crates/teachcam/tests/data/opencv_project_points.json"
path.write_text(json.dumps(dict(opencv_version=cv2.__version__, cases=out), indent=1))
print("wrote", path)
