"""Reference numbers for teachcam's calibration tests, from OpenCV.

Run: /work/pyref/bin/python scripts/reference/calib_opencv.py
Writes crates/teachcam/tests/data/calib_opencv_reference.json:
- corners: cv2.findChessboardCorners + cv2.cornerSubPix((11,11), (-1,-1), EPS+COUNT 30, 0.001)
  for every OpenCV stereo image and every caliscope frame (null when not found);
- calibrate_left/right: cv2.calibrateCamera on those corners (square 25 mm, default flags);
- stereo: cv2.stereoCalibrate with CALIB_FIX_INTRINSIC on the left/right pairs;
- timing_ms: median wall time of findChessboardCorners+cornerSubPix on left01.jpg and of
  calibrateCamera on the 13 left views, on this machine.
"""
import glob, json, os, time
import cv2
import numpy as np

ROOT = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.normpath(os.path.join(ROOT, "../../../shared/data/calib"))
OUT = os.path.normpath(os.path.join(ROOT, "../../crates/teachcam/tests/data/calib_opencv_reference.json"))
PATTERN = (9, 6)
SQUARE_MM = 25.0
CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
cv2.setNumThreads(1)


def corners_of(path):
    gray = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    found, corners = cv2.findChessboardCorners(gray, PATTERN)
    if not found:
        return gray, None
    corners = cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), CRITERIA)
    return gray, corners.reshape(-1, 2)


def board():
    obj = np.zeros((PATTERN[0] * PATTERN[1], 3), np.float32)
    obj[:, :2] = np.mgrid[0:PATTERN[0], 0:PATTERN[1]].T.reshape(-1, 2) * SQUARE_MM
    return obj


def calibrate(corner_list, size):
    obj = [board() for _ in corner_list]
    img = [c.reshape(-1, 1, 2).astype(np.float32) for c in corner_list]
    rms, K, dist, rvecs, tvecs, _, _, per_view = cv2.calibrateCameraExtended(obj, img, size, None, None)
    return {
        "rms_px": rms, "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2],
        "distortion": dist.ravel().tolist(), "per_view_rms_px": per_view.ravel().tolist(),
    }, K, dist


def main():
    out = {"pattern_inner": list(PATTERN), "square_mm": SQUARE_MM, "corners": {}}
    stereo_dir = os.path.join(DATA, "opencv-stereo-9x6")
    names = sorted(os.path.basename(p) for p in glob.glob(os.path.join(stereo_dir, "*.jpg")))
    for name in names:
        _, c = corners_of(os.path.join(stereo_dir, name))
        out["corners"]["opencv-stereo-9x6/" + name] = None if c is None else c.tolist()
    cal_dir = os.path.join(DATA, "caliscope-4cam-chessboard-9x6")
    for p in sorted(glob.glob(os.path.join(cal_dir, "*.jpg"))):
        _, c = corners_of(p)
        out["corners"]["caliscope-4cam-chessboard-9x6/" + os.path.basename(p)] = None if c is None else c.tolist()

    lefts = [n for n in names if n.startswith("left")]
    pairs = [(l, "right" + l[4:]) for l in lefts]
    lc = [np.array(out["corners"]["opencv-stereo-9x6/" + l], np.float32) for l in lefts]
    rc = [np.array(out["corners"]["opencv-stereo-9x6/" + r], np.float32) for _, r in pairs]
    out["calibrate_left"], KL, DL = calibrate(lc, (640, 480))
    out["calibrate_left"]["views"] = lefts
    out["calibrate_right"], KR, DR = calibrate(rc, (640, 480))
    ret = cv2.stereoCalibrate(
        [board() for _ in lc], [c.reshape(-1, 1, 2) for c in lc], [c.reshape(-1, 1, 2) for c in rc],
        KL, DL, KR, DR, (640, 480), flags=cv2.CALIB_FIX_INTRINSIC)
    rms, R, T = ret[0], ret[5], ret[6]
    out["stereo"] = {"rms_px": rms, "rotation": R.tolist(), "translation_mm": T.ravel().tolist(),
                     "baseline_mm": float(np.linalg.norm(T))}

    # Zhang's data, his model (k1, k2; no tangential, no k3, no skew in OpenCV).
    zdir = os.path.join(DATA, "zhang-msr-1998")
    model = np.loadtxt(os.path.join(zdir, "Model.txt")).reshape(-1, 2)
    zobj = np.hstack([model, np.zeros((len(model), 1))]).astype(np.float32)
    zimg = [np.loadtxt(os.path.join(zdir, "data%d.txt" % i)).reshape(-1, 1, 2).astype(np.float32) for i in range(1, 6)]
    zflags = cv2.CALIB_FIX_K3 | cv2.CALIB_ZERO_TANGENT_DIST
    zr = cv2.calibrateCamera([zobj] * 5, zimg, (640, 480), None, None, flags=zflags)
    out["zhang_opencv"] = {"rms_px": zr[0], "fx": zr[1][0, 0], "fy": zr[1][1, 1], "cx": zr[1][0, 2],
                           "cy": zr[1][1, 2], "distortion": zr[2].ravel().tolist()}

    # Timing, one thread, median of repeats.
    gray = cv2.imread(os.path.join(stereo_dir, "left01.jpg"), cv2.IMREAD_GRAYSCALE)
    def t_corners():
        f, c = cv2.findChessboardCorners(gray, PATTERN)
        cv2.cornerSubPix(gray, c, (11, 11), (-1, -1), CRITERIA)
    def t_calib():
        calibrate(lc, (640, 480))
    timing = {}
    for key, fn, n in (("find_corners_left01", t_corners, 30), ("calibrate_13_left", t_calib, 10)):
        ts = []
        for _ in range(n):
            t0 = time.perf_counter(); fn(); ts.append((time.perf_counter() - t0) * 1e3)
        timing[key] = float(np.median(ts))
    out["timing_ms"] = timing
    out["opencv_version"] = cv2.__version__
    with open(OUT, "w") as f:
        json.dump(out, f, indent=1)
    print(json.dumps({k: out[k] for k in ("calibrate_left", "calibrate_right", "stereo", "zhang_opencv", "timing_ms")}, indent=1))
    print({k: (v is not None) for k, v in out["corners"].items()})


if __name__ == "__main__":
    main()


def write_filestorage():
    """tests/data/calib_opencv_left.yaml: cv2.FileStorage's own YAML of the left camera."""
    with open(OUT) as f:
        ref = json.load(f)
    c = ref["calibrate_left"]
    K = np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]], np.float64)
    path = os.path.join(os.path.dirname(OUT), "calib_opencv_left.yaml")
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", np.array(c["distortion"], np.float64).reshape(1, 5))
    fs.write("avg_reprojection_error", c["rms_px"])
    fs.release()


if __name__ == "__main__":
    write_filestorage()
