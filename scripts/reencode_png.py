#!/usr/bin/env python3
"""Re-encode a teachcam recording's PNG frames with another program's PNG writer.

Used to measure `teachcam track`/`detect` on frames other programs wrote (issue 31):
the pixels stay the same, only the PNG file (its filters, its zlib stream, its chunks) changes.

    python scripts/reencode_png.py SRC DST --writer opencv --level 1
    python scripts/reencode_png.py SRC DST --writer pil --level 6
    python scripts/reencode_png.py SRC DST --writer ffmpeg

SRC is a recording folder (`teachcam simulate --out SRC`); DST gets the same tree: every
`*.png` re-encoded, every other file copied. Writers:
- opencv: `cv2.imwrite(path, img, [cv2.IMWRITE_PNG_COMPRESSION, level])` (OpenCV's default
  is level 1; giving a level also sets zlib's default strategy, as OpenCV documents),
  or no parameter at all with `--level default` (OpenCV's own default: level 1, Z_RLE strategy
  up to 4.x, its current choice in 5.x);
- pil: `Image.save(path, compress_level=level)` (PIL's default is 6);
- ffmpeg: `ffmpeg -i src.png -pred mixed dst.png` style re-encode with FFmpeg's PNG encoder
  (`-pred` given by `--pred`, default FFmpeg's own: none).

Needs opencv-python-headless and pillow (a scratch venv); ffmpeg on PATH for that writer.
"""

import argparse
import shutil
import subprocess
import sys
from pathlib import Path


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    parser.add_argument("src", type=Path)
    parser.add_argument("dst", type=Path)
    parser.add_argument("--writer", choices=["opencv", "pil", "ffmpeg"], default="opencv")
    parser.add_argument("--level", default="1", help="zlib level 0-9, or 'default'")
    parser.add_argument("--pred", default=None, help="FFmpeg's -pred (none, sub, up, avg, paeth, mixed)")
    args = parser.parse_args()

    if args.writer == "opencv":
        import cv2
    else:
        cv2 = None
    if args.writer == "pil":
        from PIL import Image
    else:
        Image = None

    count = 0
    for path in sorted(args.src.rglob("*")):
        rel = path.relative_to(args.src)
        out = args.dst / rel
        if path.is_dir():
            out.mkdir(parents=True, exist_ok=True)
            continue
        out.parent.mkdir(parents=True, exist_ok=True)
        if path.suffix.lower() != ".png":
            shutil.copyfile(path, out)
            continue
        if args.writer == "opencv":
            image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            params = [] if args.level == "default" else [cv2.IMWRITE_PNG_COMPRESSION, int(args.level)]
            if not cv2.imwrite(str(out), image, params):
                print(f"{path}: OpenCV could not write {out}", file=sys.stderr)
                return 1
        elif args.writer == "pil":
            with Image.open(path) as image:
                level = 6 if args.level == "default" else int(args.level)
                image.save(out, compress_level=level)
        else:
            command = ["ffmpeg", "-nostdin", "-v", "error", "-y", "-i", str(path)]
            if args.pred:
                command += ["-pred", args.pred]
            if args.level != "default":
                command += ["-compression_level", args.level]
            subprocess.run(command + [str(out)], check=True)
        count += 1
    print(f"{count} PNG files re-encoded with {args.writer} (level {args.level}) into {args.dst}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
