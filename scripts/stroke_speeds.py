"""Speeds and heights of the paper's stroke (the simulator's `painter_stroke`, sim/scenario.rs),
for the defaults of `robot::strokes` (notes/robot-path.md). Pure Python, no dependencies.

Prints the tip's speed (mean, 5th percentile, slowest, fastest, mm/s) and height (mm) over the
stroke's 4 s sampled at 300 Hz, and the longest time spent under a few pause speeds."""
import math

X = [(80, 0.31, 0.0), (15, 1.13, 0.7), (3, 1.9, 2.0)]
Y = [(55, 0.47, 0.5), (12, 1.71, 1.1)]
Z = [(3, 0.83, 0.2), (1, 1.6, 0.0)]


def wave(ws, t):
    return sum(a * math.sin(2 * math.pi * f * t + p) for a, f, p in ws)


dt = 1 / 300.0
speeds, heights = [], []
for k in range(1201):
    t = k * dt
    v = [(wave(w, t + dt / 2) - wave(w, t - dt / 2)) / dt for w in (X, Y, Z)]
    speeds.append(math.sqrt(sum(c * c for c in v)))
    heights.append(4 + wave(Z, t))
ordered = sorted(speeds)
print(f"speed mm/s: mean {sum(speeds) / len(speeds):.1f}, p5 {ordered[len(ordered) // 20]:.1f}, "
      f"min {ordered[0]:.1f}, max {ordered[-1]:.1f}")
print(f"height mm: {min(heights):.2f} .. {max(heights):.2f}")
for threshold in (5, 10, 20, 30):
    run = best = 0
    for v in speeds:
        run = run + 1 if v < threshold else 0
        best = max(best, run)
    print(f"longest under {threshold} mm/s: {best * dt:.3f} s")
