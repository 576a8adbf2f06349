#!/usr/bin/env python3
"""Small 8-bit gray PNG files written by OpenCV and PIL, for `tests/png_writers.rs`.

    python scripts/reference/png_writer_fixtures.py crates/teachcam/tests/data/png_writers

One 240x80 frame-like image (noise around 20 with sigma 3, two bright discs, a ramp and a
flat band) written by
- OpenCV (`cv2.imwrite`) with no parameter (its default: level 1, Sub filter) and with
  IMWRITE_PNG_COMPRESSION 0, 1, 3, 6, 9;
- PIL (`Image.save(compress_level=...)`) at 1, 6, 9.
The test decodes each with teachcam's fast path and with `image` and wants the same pixels
(and the fast path taking every file). Made with opencv-python-headless 5.1.0 and Pillow 13.0.0.
"""

import sys
from pathlib import Path

import cv2
import numpy as np
from PIL import Image


def frame() -> np.ndarray:
    rng = np.random.default_rng(31)
    image = np.clip(rng.normal(20, 3, (80, 240)), 0, 255).astype(np.uint8)
    cv2.circle(image, (50, 40), 9, 250, -1)
    cv2.circle(image, (170, 30), 5, 180, -1)
    image[60:70, :] = np.arange(240, dtype=np.uint16).astype(np.uint8)  # a ramp
    image[72:76, :] = 7  # flat: long matches
    return image


def main() -> int:
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    image = frame()
    cv2.imwrite(str(out / "opencv_default.png"), image)
    for level in [0, 1, 3, 6, 9]:
        cv2.imwrite(str(out / f"opencv_level{level}.png"), image, [cv2.IMWRITE_PNG_COMPRESSION, level])
    for level in [1, 6, 9]:
        Image.fromarray(image).save(out / f"pil_level{level}.png", compress_level=level)
    print(f"written to {out} (OpenCV {cv2.__version__})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
