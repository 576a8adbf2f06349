"""OpenCV timing of the work `benches/detect.rs` and `teachcam detect` do, on the same frames.

1. Per frame (single thread, cv2.setNumThreads(1)): threshold (THRESH_BINARY at 28, where
   teachcam's automatic threshold lands on these frames: background 12 + 8 x noise 2) +
   connectedComponentsWithStats (8-connected; its centroids are the binary centroids), on the
   criterion frames with 4, 16 and 50 markers. Median wall time of 300 runs after 20 warm-up
   runs, and CPU time per frame (process_time; compare with `--example detect_cpu`, which
   matters on a loaded machine).
2. The whole job of `teachcam detect REC -o detections.csv`: for every PNG of every camera,
   imread (grey) + the same detection, rows written to a CSV. Wall time, one process, and
   again with OpenCV's own threads (default setNumThreads).

Frames: `cargo run --release -p teachcam --example detect_frames -- DIR` first.
Usage: /work/pyref/bin/python scripts/reference/bench_detect_opencv.py DIR
Prints JSON.
"""
import csv
import json
import pathlib
import statistics
import sys
import time

import cv2

THRESHOLD = 28


def detect(grey):
    _, mask = cv2.threshold(grey, THRESHOLD, 255, cv2.THRESH_BINARY)
    count, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    return stats[1:], centroids[1:]


def per_frame(root):
    out = {}
    for path in sorted((root / "single").glob("markers_*.png")):
        grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        for _ in range(20):
            detect(grey)
        times = []
        cpu0 = time.process_time()
        for _ in range(300):
            t0 = time.perf_counter()
            stats, _ = detect(grey)
            times.append(time.perf_counter() - t0)
        cpu_ms = (time.process_time() - cpu0) / 300 * 1e3
        out[path.stem] = {"median_us": statistics.median(times) * 1e6, "cpu_ms_per_frame": cpu_ms, "blobs": len(stats)}
    return out


def whole_job(root, out_csv):
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    frames = 0
    with open(out_csv, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["camera", "frame", "x_px", "y_px", "radius_px"])
        for camera in sorted(p for p in (root / "rec").iterdir() if p.is_dir()):
            for index, path in enumerate(sorted(camera.glob("*.png"))):
                grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
                stats, centroids = detect(grey)
                for (x, y), area in zip(centroids, stats[:, cv2.CC_STAT_AREA]):
                    writer.writerow([camera.name, index, f"{x:.4f}", f"{y:.4f}", f"{(area / 3.141592653589793) ** 0.5:.4f}"])
                frames += 1
    return {"frames": frames, "wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - cpu0}


def main():
    root = pathlib.Path(sys.argv[1])
    default_threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    result = {"opencv": cv2.__version__, "threshold": THRESHOLD, "per_frame_single_thread": per_frame(root)}
    result["whole_job_single_thread"] = whole_job(root, root / "opencv_detections.csv")
    cv2.setNumThreads(default_threads)
    result["whole_job_opencv_threads"] = whole_job(root, root / "opencv_detections.csv")
    result["opencv_threads"] = default_threads
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
