#!/usr/bin/python3
"""Writes the simulated line's parts as binary STL (run once; the files are committed).

  make-meshes.py [FOLDER [SCALE]]   (SCALE 0.25: config/sim-telecentric's quarter-size block)

The part is a stepped block: an L profile in the x-z plane extruded along y
(y from -20 to 20 mm), standing on the turntable (z = 0). Every variant is a
prism of its profile, so each is closed and outward-oriented by construction.

  nominal         tall block x in [-30, 0] (z up to 30), step x in [0, 30] (z up to 15)
  face-low        the step's top face 0.7 mm low (z = 14.3)
  corner-missing  the tall block's outer top edge chamfered 5 mm x 5 mm
"""
import struct
import sys
from pathlib import Path

Y0_MM, Y1_MM = -20.0, 20.0


def profile(step_top=15.0, chamfer=0.0):
    # Counter-clockwise seen from +y... the orientation is fixed below by the signed area.
    pts = [(-30.0, 0.0), (30.0, 0.0), (30.0, step_top), (0.0, step_top), (0.0, 30.0)]
    if chamfer > 0:
        pts += [(-30.0 + chamfer, 30.0), (-30.0, 30.0 - chamfer)]
    else:
        pts += [(-30.0, 30.0)]
    return pts


def signed_area(p):
    return 0.5 * sum(p[i][0] * p[(i + 1) % len(p)][1] - p[(i + 1) % len(p)][0] * p[i][1] for i in range(len(p)))


def ear_clip(p):
    """Triangulates a simple counter-clockwise polygon (x, z) by ear clipping."""
    idx = list(range(len(p)))
    tris = []

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    while len(idx) > 3:
        for k in range(len(idx)):
            i0, i1, i2 = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            a, b, c = p[i0], p[i1], p[i2]
            if cross(a, b, c) <= 1e-12:
                continue
            inside = any(cross(a, b, p[j]) >= 0 and cross(b, c, p[j]) >= 0 and cross(c, a, p[j]) >= 0
                         for j in idx if j not in (i0, i1, i2))
            if not inside:
                tris.append((i0, i1, i2))
                idx.pop(k)
                break
        else:
            raise RuntimeError("polygon is not simple")
    tris.append(tuple(idx))
    return tris


def prism(p, scale=1.0):
    """Triangles (v0, v1, v2) of the profile p (x, z) extruded along y, outward counter-clockwise,
    every length times `scale`."""
    if signed_area(p) < 0:
        p = p[::-1]
    p = [(scale * x, scale * z) for x, z in p]
    Y0, Y1 = scale * Y0_MM, scale * Y1_MM
    # In (x, z) counter-clockwise means the polygon normal is x cross z = -y: that is the y = Y0 cap's outward side.
    front = lambda q: (q[0], Y0, q[1])
    back = lambda q: (q[0], Y1, q[1])
    out = []
    for a, b, c in ear_clip(p):
        out.append((front(p[a]), front(p[b]), front(p[c])))
        out.append((back(p[a]), back(p[c]), back(p[b])))
    n = len(p)
    for i in range(n):
        a, b = p[i], p[(i + 1) % n]
        out.append((front(a), back(a), back(b)))
        out.append((front(a), back(b), front(b)))
    return out


def normal(t):
    u = [t[1][i] - t[0][i] for i in range(3)]
    v = [t[2][i] - t[0][i] for i in range(3)]
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    length = sum(c * c for c in n) ** 0.5
    return tuple(c / length for c in n)


def write_stl(path, tris, name):
    with open(path, "wb") as f:
        f.write(name.encode("ascii").ljust(80, b"\0")[:80])
        f.write(struct.pack("<I", len(tris)))
        for t in tris:
            f.write(struct.pack("<3f", *normal(t)))
            for v in t:
                f.write(struct.pack("<3f", *v))
            f.write(struct.pack("<H", 0))


def main():
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent
    s = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    write_stl(out / "stepped-block.stl", prism(profile(), s), "stepped-block nominal")
    write_stl(out / "stepped-block-face-low.stl", prism(profile(step_top=14.3), s), "stepped-block face-low")
    write_stl(out / "stepped-block-corner-missing.stl", prism(profile(chamfer=5.0), s), "stepped-block corner-missing")


if __name__ == "__main__":
    main()
