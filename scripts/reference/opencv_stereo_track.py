"""The OpenCV peer of issue 14: a two-camera marker tracker as a user of OpenCV writes it
(SimpleBlobDetector, undistortPoints, triangulatePoints, brute-force correspondence by
epipolar distance, the triangle's distances to label), run on a recording folder of PNG frames.

Writes one row per frame it poses: frame, then the three markers' world positions in the tool
file's order (x0,y0,z0,x1,...), millimetres.

Usage: teachcam simulate --scenario stereo-ir --out /tmp/sir
       python opencv_stereo_track.py /tmp/sir > opencv_stereo_ir.csv
"""
import itertools
import json
import pathlib
import sys

import cv2
import numpy as np

root = pathlib.Path(sys.argv[1])
rig = json.loads((root / "rig.json").read_text())
tool = json.loads((root / "tool.json").read_text())
model = np.array(tool["markers"], dtype=float)
pairs = list(itertools.combinations(range(len(model)), 2))
model_d = np.array([np.linalg.norm(model[i] - model[j]) for i, j in pairs])
EPIPOLAR_PX, DISTANCE_MM = 2.0, 10.0

cams = []
for cam in rig["cameras"][:2]:
    K = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1.0]])
    R, t = np.array(cam["rotation"], float), np.array(cam["translation"], float).reshape(3, 1)
    files = sorted((root / cam["name"]).glob("*.png"))
    cams.append((K, np.array(cam["distortion"], float), R, t, K @ np.hstack([R, t]), files))
(K0, _, R0, t0, P0, _), (K1, _, R1, t1, P1, _) = cams
R10, t10 = R1 @ R0.T, t1 - R1 @ R0.T @ t0
tx = np.array([[0, -t10[2, 0], t10[1, 0]], [t10[2, 0], 0, -t10[0, 0]], [-t10[1, 0], t10[0, 0], 0]])
F = np.linalg.inv(K1).T @ tx @ R10 @ np.linalg.inv(K0)

params = cv2.SimpleBlobDetector_Params()
params.blobColor, params.minThreshold, params.maxThreshold = 255, 40, 255
params.minArea, params.maxArea = 3, 2000
params.filterByCircularity, params.filterByConvexity = False, False
params.filterByInertia, params.minInertiaRatio = True, 0.3
detector = cv2.SimpleBlobDetector_create(params)


def blobs(cam, index):
    K, d, _, _, _, files = cam
    image = cv2.imread(str(files[index]), cv2.IMREAD_GRAYSCALE)
    px = np.array([k.pt for k in detector.detect(image)], float).reshape(-1, 1, 2)
    return cv2.undistortPoints(px, K, d, P=K).reshape(-1, 2) if len(px) else px.reshape(-1, 2)


def epipolar_px(a, b):
    line1, line0 = F @ np.append(a, 1), F.T @ np.append(b, 1)
    return 0.5 * (abs(np.append(b, 1) @ line1) / np.hypot(*line1[:2])
                  + abs(np.append(a, 1) @ line0) / np.hypot(*line0[:2]))


print("frame," + ",".join(f"{c}{m}_mm" for m in range(len(model)) for c in "xyz"))
for frame in range(len(cams[0][5])):
    b0, b1 = blobs(cams[0], frame), blobs(cams[1], frame)
    scored = sorted((epipolar_px(a, b), i, j) for i, a in enumerate(b0) for j, b in enumerate(b1))
    used0, used1, matches = set(), set(), []
    for e, i, j in scored:  # brute force: closest to its epipolar line first, each blob once
        if e < EPIPOLAR_PX and i not in used0 and j not in used1:
            used0.add(i), used1.add(j), matches.append((i, j))
    if len(matches) < len(model):
        continue
    x = cv2.triangulatePoints(P0, P1, b0[[i for i, _ in matches]].T, b1[[j for _, j in matches]].T)
    points = (x[:3] / x[3]).T
    best = None
    for labelled in itertools.permutations(range(len(points)), len(model)):
        d = np.array([np.linalg.norm(points[labelled[i]] - points[labelled[j]]) for i, j in pairs])
        error = np.abs(d - model_d).max()
        if best is None or error < best[0]:
            best = (error, labelled)
    if best[0] > DISTANCE_MM:
        continue
    print(f"{frame}," + ",".join(f"{v:.3f}" for m in best[1] for v in points[m]))
