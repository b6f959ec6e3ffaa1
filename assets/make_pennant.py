#!/usr/bin/env python3
"""Writes assets/pennant.gltf: a triangular pennant for the `flag` example
and the glTF tests.

Standard library only (json + struct + base64), so anyone can regenerate it:
    python3 assets/make_pennant.py

The pennant lies in the xy plane, facing +z: its hoist runs along x = 0 from
y = -0.3 m to 0.3 m and it narrows to a point at x = 1.2 m. Columns of
vertices 5 cm apart along x hold fewer vertices towards the tip, so the
triangles between them are irregular (vertices of valence 4 to 8). It has
POSITION, NORMAL, TEXCOORD_0 (u along the length, v across the hoist) and a
custom `_PIN` attribute, 1 on the hoist and 0 elsewhere, for pinning.
"""
import base64
import json
import os
import struct

LENGTH = 1.2  # m
HOIST = 0.6  # m
COLUMNS = 25  # 5 cm apart
HOIST_ROWS = 13  # vertices along the hoist, 5 cm apart


def columns():
    """Per column, its vertices as (x, y), bottom to top."""
    out = []
    for i in range(COLUMNS):
        x = LENGTH * i / (COLUMNS - 1)
        half = 0.5 * HOIST * (1.0 - x / LENGTH)
        n = max(1, round((HOIST_ROWS - 1) * (1.0 - x / LENGTH)) + 1)
        if n == 1:
            out.append([(x, 0.0)])
        else:
            out.append([(x, -half + 2 * half * k / (n - 1)) for k in range(n)])
    return out


def zipper(a, b, ia, ib, pos):
    """Triangles joining two neighbouring columns (vertex index lists `ia`,
    `ib`), advancing along whichever is lower next, facing +z."""
    tris = []
    i = j = 0
    while i < len(a) - 1 or j < len(b) - 1:
        if j == len(b) - 1 or (i < len(a) - 1 and a[i + 1][1] <= b[j + 1][1]):
            t = [ia[i], ib[j], ia[i + 1]]
            i += 1
        else:
            t = [ia[i], ib[j], ib[j + 1]]
            j += 1
        (x0, y0), (x1, y1), (x2, y2) = (pos[k] for k in t)
        if (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0) < 0:
            t = [t[0], t[2], t[1]]
        tris.append(t)
    return tris


def main():
    cols = columns()
    pos, index = [], []
    for col in cols:
        index.append(list(range(len(pos), len(pos) + len(col))))
        pos.extend(col)
    tris = []
    for c in range(COLUMNS - 1):
        tris += zipper(cols[c], cols[c + 1], index[c], index[c + 1], pos)
    n = len(pos)
    positions = b"".join(struct.pack("<3f", x, y, 0.0) for x, y in pos)
    normals = struct.pack("<3f", 0.0, 0.0, 1.0) * n
    uvs = b"".join(struct.pack("<2f", x / LENGTH, 0.5 - y / HOIST) for x, y in pos)
    pins = b"".join(struct.pack("<f", 1.0 if x == 0.0 else 0.0) for x, _ in pos)
    indices = b"".join(struct.pack("<3H", *t) for t in tris)
    indices += b"\0" * (-len(indices) % 4)
    blob, views = b"", []
    for data in (positions, normals, uvs, pins, indices):
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        blob += data
    views[4]["byteLength"] = 6 * len(tris)
    xs, ys = [p[0] for p in pos], [p[1] for p in pos]
    gltf = {
        "asset": {"version": "2.0", "generator": "bevy_cloth assets/make_pennant.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "pennant"}],
        "meshes": [
            {
                "name": "pennant",
                "primitives": [
                    {
                        "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "_PIN": 3},
                        "indices": 4,
                        "mode": 4,
                    }
                ],
            }
        ],
        "buffers": [
            {
                "byteLength": len(blob),
                "uri": "data:application/octet-stream;base64,"
                + base64.b64encode(blob).decode("ascii"),
            }
        ],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3",
             "min": [min(xs), min(ys), 0.0], "max": [max(xs), max(ys), 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": n, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": n, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5126, "count": n, "type": "SCALAR"},
            {"bufferView": 4, "componentType": 5123, "count": 3 * len(tris), "type": "SCALAR"},
        ],
    }
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pennant.gltf")
    with open(path, "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
    hoist = sum(1 for x, _ in pos if x == 0.0)
    print(f"wrote {path}: {n} vertices, {len(tris)} triangles, {hoist} on the hoist")


if __name__ == "__main__":
    main()
