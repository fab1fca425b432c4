#!/usr/bin/env python3
"""Writes the PNG seed corpus (tests/fuzz/corpus/png/): small images of each
kind the reader meets. psrig's fast path: 8/16-bit grey and RGB, each PNG
filter type, one or several IDAT chunks, stored or compressed, with
ancillary chunks. OpenCV's fallback: palette, tRNS, grey+alpha, RGBA,
1/2/4-bit grey, Adam7 interlacing. Standard library only (zlib); rerun it
to regenerate: python3 tests/fuzz/tools/make_png_seeds.py. The psrig-*.png
seeds come from psrig's own writer: write_psrig_png_seeds.cpp."""
import os
import struct
import sys
import zlib

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "corpus", "png")


def chunk(kind, payload):
    return (struct.pack(">I", len(payload)) + kind + payload +
            struct.pack(">I", zlib.crc32(kind + payload) & 0xFFFFFFFF))


def paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else b if pb <= pc else c


def filter_row(kind, row, prev, bpp):
    out = bytearray()
    for i, x in enumerate(row):
        a = row[i - bpp] if i >= bpp else 0
        b = prev[i]
        c = prev[i - bpp] if i >= bpp else 0
        pred = [0, a, b, (a + b) >> 1, paeth(a, b, c)][kind]
        out.append((x - pred) & 0xFF)
    return bytes(out)


def png(width, height, depth, colour, rows, filters=(0,), idat_pieces=1, level=6,
        extra=b"", interlace=0, pre=b""):
    """rows: raw scanlines (bytes) without filter bytes; non-interlaced only
    unless interlace=1, where `rows` is the already-serialised raw stream."""
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[colour]
    bpp = max(1, channels * depth // 8)
    if interlace:
        raw = rows
    else:
        raw = bytearray()
        prev = bytes(len(rows[0]))
        for r, row in enumerate(rows):
            kind = filters[r % len(filters)]
            raw.append(kind)
            raw += filter_row(kind, row, prev, bpp)
            prev = row
        raw = bytes(raw)
    data = zlib.compress(raw, level)
    step = max(1, -(-len(data) // idat_pieces))
    idats = b"".join(chunk(b"IDAT", data[i:i + step]) for i in range(0, len(data), step))
    header = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, interlace)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + pre + extra + idats +
            chunk(b"IEND", b""))


def gradient(width, height, channels, depth):
    rows = []
    for y in range(height):
        row = bytearray()
        for x in range(width):
            for c in range(channels):
                v = (x * 37 + y * 91 + c * 53) % (1 << depth)
                row += v.to_bytes(depth // 8, "big")
        rows.append(bytes(row))
    return rows


def write(name, data):
    with open(os.path.join(OUT, name), "wb") as f:
        f.write(data)


def main():
    os.makedirs(OUT, exist_ok=True)
    w, h = 7, 5
    text = chunk(b"tEXt", b"Software\x00psrig fuzz seed") + chunk(b"gAMA", struct.pack(">I", 45455))
    write("grey8-none.png", png(w, h, 8, 0, gradient(w, h, 1, 8)))
    write("grey8-all-filters.png", png(w, h, 8, 0, gradient(w, h, 1, 8), filters=(0, 1, 2, 3, 4)))
    write("grey16-paeth-3-idat.png", png(w, h, 16, 0, gradient(w, h, 1, 16), filters=(4,), idat_pieces=3))
    write("rgb8-sub-up-text.png", png(w, h, 8, 2, gradient(w, h, 3, 8), filters=(1, 2), extra=text))
    write("rgb16-average-stored.png", png(w, h, 16, 2, gradient(w, h, 3, 16), filters=(3,), level=0))
    write("rgb16-all-filters.png", png(w, h, 16, 2, gradient(w, h, 3, 16), filters=(4, 3, 2, 1, 0)))
    write("grey8-1x1.png", png(1, 1, 8, 0, [b"\x80"]))
    # OpenCV's side.
    palette = chunk(b"PLTE", bytes(range(0, 48)))
    write("palette8.png", png(w, h, 8, 3, [bytes((x + y) % 16 for x in range(w)) for y in range(h)], pre=palette))
    write("palette8-trns.png", png(w, h, 8, 3, [bytes((x + y) % 16 for x in range(w)) for y in range(h)],
                                   pre=palette + chunk(b"tRNS", bytes([0, 128, 255]))))
    write("grey8-trns.png", png(w, h, 8, 0, gradient(w, h, 1, 8), pre=chunk(b"tRNS", b"\x00\x25")))
    write("grey-alpha8.png", png(w, h, 8, 4, gradient(w, h, 2, 8), filters=(1,)))
    write("rgba16.png", png(w, h, 16, 6, gradient(w, h, 4, 16), filters=(2,)))
    write("grey1.png", png(16, 3, 1, 0, [b"\xa5\x5a"] * 3))
    write("grey4.png", png(4, 2, 4, 0, [b"\x01\x23", b"\x45\x67"]))
    # Adam7, 2x2 grey 8-bit: passes 1 (0,0), 6 (1,0), 7 (row 1: both pixels).
    write("grey8-adam7.png", png(2, 2, 8, 0, b"\x00\x10" + b"\x00\x20" + b"\x00\x30\x40", interlace=1))


if __name__ == "__main__":
    sys.exit(main())
