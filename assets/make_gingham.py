#!/usr/bin/env python3
"""Writes assets/gingham.png: a 128x128 red-and-white gingham tile.

Standard library only (zlib + struct), so anyone can regenerate it:
    python3 assets/make_gingham.py
Gingham: stripes of one colour run both ways over white; where two stripes
cross the colour is full, where one crosses white it is half strength.
"""
import os
import struct
import zlib

SIZE = 128
STRIPE = 16  # pixels per stripe: 8 checks across the tile
RED = (196, 38, 48)
WHITE = (250, 247, 240)


def mix(a, b, t):
    return tuple(round(x + (y - x) * t) for x, y in zip(a, b))


def pixel(x, y):
    across = (x // STRIPE) % 2 == 0
    down = (y // STRIPE) % 2 == 0
    strength = (across + down) / 2.0
    # A faint woven grain: every other thread a touch darker.
    grain = 0.04 if (x + y) % 2 == 0 else 0.0
    return mix(mix(WHITE, RED, strength), (0, 0, 0), grain)


def png(width, height, rows):
    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + bytes(c for p in row for c in p) for row in rows)
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


if __name__ == "__main__":
    rows = [[pixel(x, y) for x in range(SIZE)] for y in range(SIZE)]
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "gingham.png")
    with open(out, "wb") as f:
        f.write(png(SIZE, SIZE, rows))
    print(f"wrote {out}")
