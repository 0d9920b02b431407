#!/usr/bin/env python3
"""PSNR in dB between two PNG images of the same size (8-bit RGB or RGBA, not interlaced, as
`tetrascope render` writes them), or two Portable Float Maps (`render --reference` writes the
exact image's unrounded colours, 0..1, as OUT.reference.pfm). The peak is 255 for PNG and 1 for
PFM, so both give the same dB for the same colours; 8-bit rounding alone limits a PNG's PSNR
(images that differ by under half a level in every pixel are equal, one level in 2% of the
values is 65 dB), a PFM's is not. Pure Python + numpy (no imaging library needed).
usage: psnr.py A.png B.png | A.pfm B.pfm"""
import struct
import sys
import zlib

import numpy as np


def read_png(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG file")
    pos, idat, width = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or colour not in (2, 6) or interlace:
                raise SystemExit(f"{path}: only 8-bit RGB/RGBA, non-interlaced PNG is supported")
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8)
    stride = width * channels
    rows = raw.reshape(height, stride + 1)
    out = np.zeros((height, stride), dtype=np.int32)
    prev = np.zeros(stride, dtype=np.int32)
    for y in range(height):
        kind, line = rows[y, 0], rows[y, 1:].astype(np.int32)
        if kind == 0:
            cur = line
        elif kind == 2:
            cur = (line + prev) & 255
        else:  # sub, average, paeth need the left neighbour: per pixel
            cur = np.zeros(stride, dtype=np.int32)
            for x in range(stride):
                a = cur[x - channels] if x >= channels else 0
                b = prev[x]
                c = prev[x - channels] if x >= channels else 0
                if kind == 1:
                    p = a
                elif kind == 3:
                    p = (a + b) >> 1
                else:
                    pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                    p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                cur[x] = (line[x] + p) & 255
        out[y] = cur
        prev = cur
    return out.reshape(height, width, channels)[:, :, :3].astype(np.float64)


def read_pfm(path):
    data = open(path, "rb").read()
    fields, pos = [], 0
    while len(fields) < 4:  # "PF", width, height, scale (negative: little-endian), whitespace apart
        while pos < len(data) and data[pos:pos + 1].isspace():
            pos += 1
        end = pos
        while end < len(data) and not data[end:end + 1].isspace():
            end += 1
        if end >= len(data):
            raise SystemExit(f"{path}: truncated PFM header")
        fields.append(data[pos:end].decode("ascii"))
        pos = end
    if fields[0] != "PF":
        raise SystemExit(f"{path}: not an RGB Portable Float Map")
    width, height, scale = int(fields[1]), int(fields[2]), float(fields[3])
    if len(data) - (pos + 1) < 12 * width * height:
        raise SystemExit(f"{path}: truncated PFM ({width}x{height})")
    pixels = np.frombuffer(data[pos + 1:], dtype="<f4" if scale < 0 else ">f4", count=width * height * 3)
    return pixels.reshape(height, width, 3)[::-1].astype(np.float64)


def psnr(a, b, peak=255.0):
    if a.shape != b.shape:
        raise SystemExit(f"sizes differ: {a.shape} and {b.shape}")
    mse = np.mean((a - b) ** 2)
    return 99.0 if mse == 0 else 10 * np.log10(peak ** 2 / mse)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    if sys.argv[1].endswith(".pfm") != sys.argv[2].endswith(".pfm"):
        raise SystemExit("compare two PNGs or two PFMs")
    if sys.argv[1].endswith(".pfm"):
        print(f"{psnr(read_pfm(sys.argv[1]), read_pfm(sys.argv[2]), 1.0):.2f}")
    else:
        print(f"{psnr(read_png(sys.argv[1]), read_png(sys.argv[2])):.2f}")
