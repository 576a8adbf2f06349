"""Time ezc3d reading the 2.25 MB Vicon C3D file (the reference for benches/c3d.rs).

Run: /work/pyref/bin/python scripts/reference/c3d_bench_ezc3d.py
Prints the median of 30 reads, and of 30 reads without analog data if ezc3d offers it.
"""

import pathlib
import statistics
import time

import ezc3d

PATH = pathlib.Path(__file__).resolve().parents[2].parent / "shared" / "data" / "c3d" / "ezc3d_Vicon.c3d"


def median_ms(fn, runs=30):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1000 * statistics.median(times)


print("ezc3d.c3d(vicon) median ms:", round(median_ms(lambda: ezc3d.c3d(str(PATH))), 3))
print(
    "ezc3d.c3d(vicon, extract_forceplat_data=False) median ms:",
    round(median_ms(lambda: ezc3d.c3d(str(PATH), extract_forceplat_data=False)), 3),
)
