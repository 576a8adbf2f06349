"""Reference numbers for the C3D reader tests, extracted with ezc3d (an independent reader).

Run: /work/pyref/bin/python scripts/reference/c3d_reference.py
Writes crates/teachcam/tests/data/c3d/<file>.json for each of the real files in
../shared/data/c3d: header and POINT parameters as stored, the first, middle and last
frames (null where ezc3d reports the sample invalid), residuals of those frames and, over the
whole trial, the count of invalid samples and the sum of valid coordinates per marker.
"""

import json
import struct
import pathlib

import ezc3d
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "c3d"
OUT = ROOT / "crates" / "teachcam" / "tests" / "data" / "c3d"


def frame_points(points, frame):
    out = []
    for marker in range(points.shape[1]):
        xyz = points[:3, marker, frame]
        out.append(None if np.any(np.isnan(xyz)) else [float(v) for v in xyz])
    return out


def residual_words(raw, c, frame):
    """The fourth word of every point in a frame, read straight from the bytes (Intel files
    only), decoded as the C3D User Guide says: negative = invalid; otherwise the low byte is the
    residual in |POINT:SCALE| units and the high byte the camera mask. ezc3d 1.7.2 swaps the two
    bytes (its residual for a point seen by cameras 2-6 is the mask 0x3E times the scale), so
    the residuals and masks here come from this decoding, not from ezc3d."""
    header = c["header"]
    points = header["points"]["size"]
    scale = float(c["parameters"]["POINT"]["SCALE"]["value"][0])
    is_float = scale < 0
    word = 4 if is_float else 2
    analog_words = struct.unpack_from("<H", raw, 4)[0]
    start = (int(c["parameters"]["POINT"]["DATA_START"]["value"][0]) - 1) * 512
    frame_bytes = (points * 4 + analog_words) * word
    out = []
    for m in range(points):
        at = start + frame * frame_bytes + (m * 4 + 3) * word
        if is_float:
            value = struct.unpack_from("<f", raw, at)[0]
            if not value >= 0:
                out.append(None)
                continue
            w = int(round(value)) & 0xFFFF
        else:
            w = struct.unpack_from("<h", raw, at)[0]
            if w < 0:
                out.append(None)
                continue
        out.append({"residual": (w & 0xFF) * abs(scale), "camera_mask": w >> 8})
    return out


def pyc3d_first_words(path):
    """First-frame residual and camera mask as py-c3d 0.6.0 (a second independent reader)
    reports them (it follows the User Guide: residual in the low byte, cameras in the high
    byte; invalid = residual -1). None when py-c3d cannot read the file (the ktk_racing files:
    empty ANALOG:SCALE)."""
    try:
        import c3d as pyc3d

        with open(path, "rb") as handle:
            reader = pyc3d.Reader(handle)
            for _, points, _ in reader.read_frames():
                return [
                    None if p[3] < 0 else {"residual": float(p[3]), "camera_mask": int(p[4])}
                    for p in points
                ]
    except Exception:  # noqa: BLE001 - any failure means "no second opinion"
        return None
    return None


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    for path in sorted(DATA.glob("*.c3d")):
        c = ezc3d.c3d(str(path))
        point = c["parameters"]["POINT"]
        points = c["data"]["points"]
        residuals = c["data"]["meta_points"]["residuals"][0]
        frames = points.shape[2]
        middle = frames // 2
        valid = ~np.isnan(points[0])
        labels = list(point["LABELS"]["value"])
        for extra in ("LABELS2", "LABELS3"):
            if extra in point:
                labels += list(point[extra]["value"])
        used = int(point["USED"]["value"][0])
        raw = path.read_bytes()
        record = {
            "file": path.name,
            "processor": int(raw[(raw[0] - 1) * 512 + 3]) - 83,
            "used": used,
            "labels": labels[:used],
            "rate_hz": float(point["RATE"]["value"][0]),
            "scale": float(point["SCALE"]["value"][0]),
            "units": str(point["UNITS"]["value"][0]),
            "frames": int(frames),
            "header_first_frame": int(c["header"]["points"]["first_frame"]),
            "header_last_frame": int(c["header"]["points"]["last_frame"]),
            "middle_frame": int(middle),
            "first_frame": frame_points(points, 0),
            "middle": frame_points(points, middle),
            "last": frame_points(points, frames - 1),
            "first_words": residual_words(raw, c, 0),
            "middle_words": residual_words(raw, c, middle),
            "pyc3d_first_words": pyc3d_first_words(path),
            "ezc3d_first_residuals": [float(r) for r in residuals[:, 0]],
            "invalid_per_marker": [int(frames - valid[m].sum()) for m in range(used)],
            "valid_sum_per_marker": [
                [float(np.nansum(points[axis, m, :])) for axis in range(3)] for m in range(used)
            ],
        }
        (OUT / (path.stem + ".json")).write_text(json.dumps(record, indent=1) + "\n")
        print(path.name, frames, used, record["invalid_per_marker"][:6])


if __name__ == "__main__":
    main()
