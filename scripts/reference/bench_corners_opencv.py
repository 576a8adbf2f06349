"""Times OpenCV's chessboard corner finding on given images, single thread, for BENCHMARKS.md.

Usage: /work/pyref/bin/python scripts/reference/bench_corners_opencv.py [--rounds N] IMAGE...

For each image: `cv2.findChessboardCorners(gray, (9, 6))` + `cv2.cornerSubPix(gray, corners,
(11, 11), (-1, -1), (EPS + MAX_ITER, 30, 0.001))`, the calls `calib_opencv.py` makes and that
`teachcam::calib::chessboard::find_chessboard_corners` reproduces. Decoding is not timed (the
criterion bench in `crates/teachcam/benches/calib.rs` does not time it either). Prints, per
image, whether a board was found, the best and the median wall time in ms over `rounds` x 20
calls. Run it alternately with `cargo bench -p teachcam --bench calib` on a shared machine and
compare best against best.
"""
import argparse, json, os, time
import cv2
import numpy as np

PATTERN = (9, 6)
CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)


def corners(gray):
    found, c = cv2.findChessboardCorners(gray, PATTERN)
    if found:
        c = cv2.cornerSubPix(gray, c, (11, 11), (-1, -1), CRITERIA)
    return found


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("images", nargs="+")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    out = {"opencv_version": cv2.__version__, "images": {}}
    for path in args.images:
        gray = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        times = []
        found = corners(gray)
        for _ in range(args.rounds * 20):
            t0 = time.perf_counter()
            corners(gray)
            times.append((time.perf_counter() - t0) * 1e3)
        out["images"][os.path.basename(os.path.dirname(path)) + "/" + os.path.basename(path)] = {
            "size": [gray.shape[1], gray.shape[0]],
            "found": bool(found),
            "best_ms": round(float(np.min(times)), 3),
            "median_ms": round(float(np.median(times)), 3),
        }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
