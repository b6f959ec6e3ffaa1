#!/usr/bin/env python3
"""Checks an example's screenshot: present, not blank, and showing cloth.

    check_screenshot.py FILE.png red|blue [MIN_PERCENT]

"Showing cloth" means at least MIN_PERCENT (default 1) of the pixels have
the cloth's dominant colour: red (R exceeds G and B by 80, more than the
wooden table does) or blue (B exceeds R by 40 and G by 15). "Not blank" means the image has more than 16
distinct colours. Standard library only (a minimal PNG decoder for the
8-bit RGB/RGBA, non-interlaced images Bevy writes).
"""
import struct
import sys
import zlib


def decode(path):
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG")
    pos, idat, width, height, channels = 8, b"", 0, 0, 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos : pos + 8])
        body = data[pos + 8 : pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or colour not in (2, 6) or interlace:
                raise SystemExit(f"{path}: unsupported PNG (depth {depth}, colour type {colour})")
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1 : (y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - channels] if x >= channels else 0
            b = prev[x]
            c = prev[x - channels] if x >= channels else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[x] = (line[x] + pred) & 255
        rows.append(line)
        prev = line
    return width, height, channels, rows


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    path, colour = sys.argv[1], sys.argv[2]
    minimum = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0
    width, height, channels, rows = decode(path)
    distinct, hits = set(), 0
    for line in rows:
        for x in range(0, width * channels, channels):
            r, g, b = line[x], line[x + 1], line[x + 2]
            if len(distinct) <= 16:
                distinct.add((r, g, b))
            if colour == "red" and r > g + 80 and r > b + 80:
                hits += 1
            elif colour == "blue" and b > r + 40 and b > g + 15:
                hits += 1
    percent = 100.0 * hits / (width * height)
    print(f"{path}: {width}x{height}, cloth-coloured ({colour}) {percent:.2f} %")
    if len(distinct) <= 16:
        raise SystemExit(f"{path}: blank (only {len(distinct)} colours)")
    if percent < minimum:
        raise SystemExit(f"{path}: no cloth visible ({percent:.2f} % < {minimum} % {colour} pixels)")


if __name__ == "__main__":
    main()
