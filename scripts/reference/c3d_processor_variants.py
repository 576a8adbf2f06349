"""DEC and MIPS variants of two real Intel C3D files, for the reader's processor tests.

The C3D User Guide defines three processor formats (byte 4 of the parameter section: 84 Intel,
85 DEC, 86 MIPS). None of the real files in ../shared/data/c3d is DEC or MIPS, so this script
re-encodes every word of an Intel file: integers little-endian (DEC) or big-endian (MIPS);
floats as VAX F_floating (DEC: the IEEE bits of 4*x with the two 16-bit halves swapped) or
big-endian IEEE (MIPS). Header words past the 12th (event times and labels) are zeroed. The
integer file is cut to its first 30 frames (header word 5 and POINT:FRAMES updated) to stay
small. ezc3d then reads each DEC variant, and its points must equal the original's: that
checks this converter independently of teachcam (ezc3d 1.7.2 does not read MIPS files).

Run: /work/pyref/bin/python scripts/reference/c3d_processor_variants.py
Writes crates/teachcam/tests/data/c3d/<stem>_{dec,mips}.c3d.
"""

import pathlib
import struct

import ezc3d
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "c3d"
OUT = ROOT / "crates" / "teachcam" / "tests" / "data" / "c3d"


def enc_i16(v, proc):
    return struct.pack(">h" if proc == "mips" else "<h", v)


def enc_u16(v, proc):
    return struct.pack(">H" if proc == "mips" else "<H", v)


def enc_f32(v, proc):
    if proc == "mips":
        return struct.pack(">f", v)
    if v == 0.0:
        return b"\0\0\0\0"
    le = struct.pack("<f", np.float32(v) * np.float32(4.0))
    return bytes([le[2], le[3], le[0], le[1]])


def convert(src, proc, keep_frames=None):
    b = bytearray(src.read_bytes())
    p_block = b[0]
    out = bytearray(b)
    # Header: words 2-6 u16, 7-8 float, 9-10 u16, 11-12 float; the rest zeroed.
    h = struct.unpack_from("<5HfHHf", b, 2)
    first, last = h[2], h[3]
    if keep_frames is not None:
        last = first + keep_frames - 1
    words = list(h)
    words[3] = last
    out[2:512] = bytes(510)
    o = 2
    for i, w in enumerate(words):
        if i in (5, 8):
            out[o : o + 4] = enc_f32(w, proc)
            o += 4
        else:
            out[o : o + 2] = enc_u16(w, proc)
            o += 2
    # Parameter section.
    start = (p_block - 1) * 512
    out[start + 3] = {"dec": 85, "mips": 86}[proc]
    pos = start + 4
    groups = {}
    while True:
        nl = struct.unpack_from("b", b, pos)[0]
        if nl == 0:
            break
        gid = struct.unpack_from("b", b, pos + 1)[0]
        name = b[pos + 2 : pos + 2 + abs(nl)].decode()
        off_at = pos + 2 + abs(nl)
        off = struct.unpack_from("<h", b, off_at)[0]
        out[off_at : off_at + 2] = enc_i16(off, proc)
        q = off_at + 2
        if gid < 0:
            groups[-gid] = name
        else:
            t = struct.unpack_from("b", b, q)[0]
            nd = b[q + 1]
            dims = list(b[q + 2 : q + 2 + nd])
            d = q + 2 + nd
            n = int(np.prod(dims)) if dims else 1
            is_frames = name == "FRAMES" and keep_frames is not None
            for k in range(n):
                at = d + k * abs(t)
                if t == 2:
                    v = struct.unpack_from("<h", b, at)[0]
                    if is_frames:
                        v = keep_frames
                    out[at : at + 2] = enc_i16(v, proc)
                elif t == 4:
                    v = struct.unpack_from("<f", b, at)[0]
                    if is_frames:
                        v = float(keep_frames)
                    out[at : at + 4] = enc_f32(v, proc)
        if off == 0:
            break
        pos = off_at + off
    # Data: every word in the storage's type.
    scale = h[5]
    data_start = (h[6] - 1) * 512
    points, analog = h[0], h[1]
    word = 4 if scale < 0 else 2
    frame_bytes = (points * 4 + analog) * word
    frames = keep_frames if keep_frames is not None else (len(b) - data_start) // frame_bytes
    end = data_start + frames * frame_bytes
    for at in range(data_start, end, word):
        if word == 4:
            out[at : at + 4] = enc_f32(struct.unpack_from("<f", b, at)[0], proc)
        else:
            out[at : at + 2] = enc_i16(struct.unpack_from("<h", b, at)[0], proc)
    return bytes(out[: end + (-end % 512)]) if keep_frames is not None else bytes(out)


def main():
    for stem, keep in (("c3dorg_sample01_Eb015pi", 30), ("ezc3d_Optotrak", None)):
        original = ezc3d.c3d(str(DATA / f"{stem}.c3d"))["data"]["points"]
        for proc in ("dec", "mips"):
            path = OUT / f"{stem}_{proc}.c3d"
            path.write_bytes(convert(DATA / f"{stem}.c3d", proc, keep))
            if proc == "mips":
                # ezc3d 1.7.2: "MIPS processor type not supported yet". The MIPS variant is the
                # DEC one's integers byte-swapped and floats in plain big-endian IEEE.
                print(stem, proc, path.stat().st_size, "bytes; not readable by ezc3d")
                continue
            seen = ezc3d.c3d(str(path))["data"]["points"]
            n = seen.shape[2]
            assert n == (keep or original.shape[2]), (stem, proc, n)
            same = np.allclose(seen, original[:, :, :n], equal_nan=True, rtol=1e-7, atol=0)
            print(stem, proc, path.stat().st_size, "bytes; ezc3d reads the original's points:", same)
            assert same


if __name__ == "__main__":
    main()
