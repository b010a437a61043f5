#!/usr/bin/env python3
"""The file operations of make-cad-data.sh (standard library only).

  scale-off SRC DST FACTOR NOTE...    an OFF file with every vertex coordinate
                                      multiplied by FACTOR, its faces copied
                                      line for line, NOTE as '#' comment lines
  tjunction SRC DST needle|open       a binary STL with T-junctions made on
                                      three sharp edges (see tjunction())
  concat DST HEADER SRC...            the facets of binary STLs written into
                                      one binary STL without a union
  sort STL                            the facets of a binary STL in place in
                                      the order of their corners' coordinates
                                      (OpenSCAD writes the same facets in an
                                      order that varies from run to run)
"""
import struct
import sys

RECORD = struct.Struct("<12fH")


def read_stl(path):
    data = open(path, "rb").read()
    (n,) = struct.unpack_from("<I", data, 80)
    if 84 + 50 * n != len(data):
        sys.exit(f"{path}: not a binary STL")
    return [list(RECORD.unpack_from(data, 84 + 50 * i)) for i in range(n)]


def write_stl(path, header, records):
    h = header.encode("ascii")
    if len(h) > 80:
        sys.exit(f"header longer than 80 bytes: {header}")
    with open(path, "wb") as out:
        out.write(h.ljust(80, b" "))
        out.write(struct.pack("<I", len(records)))
        for r in records:
            out.write(RECORD.pack(*r))


def scale_off(src, dst, factor, note):
    lines = open(src).read().split("\n")
    k = 0
    while not lines[k].strip() or lines[k].lstrip().startswith("#"):
        k += 1
    if lines[k].strip() != "OFF":
        sys.exit(f"{src}: not an OFF file")
    k += 1
    while not lines[k].strip() or lines[k].lstrip().startswith("#"):
        k += 1
    nv = int(lines[k].split()[0])
    out = ["OFF"] + ["# " + n for n in note] + [lines[k]]
    k += 1
    done = 0
    while done < nv:
        t = lines[k].split()
        k += 1
        if not t or t[0].startswith("#"):
            continue
        out.append(" ".join(repr(float(x) * factor) for x in t[:3]))
        done += 1
    out.extend(line for line in lines[k:] if line.strip())
    with open(dst, "w") as f:
        f.write("\n".join(out) + "\n")


def corners(r):
    return [tuple(r[3:6]), tuple(r[6:9]), tuple(r[9:12])]


def tjunction(src, dst, mode):
    """Three T-junctions on the sharp edges where the top face (z = max)
    meets the flat walls x = max, y = max and x = min: the top-face triangle
    on each such edge is split at the edge's midpoint m (the midpoints are
    exact in binary32), the wall triangle keeps the whole edge, as when a CAD
    system meshes the two faces independently. 'needle' then closes each
    junction with the zero-area triangle (a, b, m) that an exporter writes to
    keep the shell watertight, with a zero normal; 'open' leaves it out."""
    recs = read_stl(src)
    pts = [p for r in recs for p in corners(r)]
    zmax = max(p[2] for p in pts)
    xmax = max(p[0] for p in pts)
    xmin = min(p[0] for p in pts)
    ymax = max(p[1] for p in pts)
    walls = [(0, xmax), (1, ymax), (0, xmin)]
    out = list(recs)
    made = []
    for axis, value in walls:
        # the top-face triangle holding an edge on the top of this wall
        best = None
        for i, r in enumerate(out):
            c = corners(r)
            if r[2] < 0.999 or not all(p[2] == zmax for p in c):
                continue
            for j in range(3):
                a, b = c[j], c[(j + 1) % 3]
                if a[axis] == value and b[axis] == value:
                    best = (i, j)
        if best is None:
            sys.exit(f"{src}: no top-face edge on the wall {'xy'[axis]} = {value}")
        i, j = best
        c = corners(out[i])
        a, b, o = c[j], c[(j + 1) % 3], c[(j + 2) % 3]
        m = tuple((x + y) / 2 for x, y in zip(a, b))
        if struct.unpack("<3f", struct.pack("<3f", *m)) != m:
            sys.exit(f"{src}: the midpoint of {a} {b} is not exact in binary32")
        n = out[i][0:3]
        out[i] = n + list(a) + list(m) + list(o) + [0]
        out.append(n + list(m) + list(b) + list(o) + [0])
        made.append((a, b, m))
    if mode == "needle":
        for a, b, m in made:
            out.append([0.0, 0.0, 0.0] + list(a) + list(b) + list(m) + [0])
    header = ("hullgauge: mcad-rounded-block.stl, 3 T-junctions"
              + (" closed by zero-area triangles" if mode == "needle" else " left open"))
    write_stl(dst, header, out)


def concat(dst, header, srcs):
    recs = []
    for s in srcs:
        recs.extend(read_stl(s))
    write_stl(dst, header, recs)


def sort_stl(path):
    data = open(path, "rb").read()
    recs = read_stl(path)
    recs.sort(key=lambda r: (r[3:12], r[0:3]))
    with open(path, "wb") as out:
        out.write(data[:84])
        for r in recs:
            out.write(RECORD.pack(*r))


def main(argv):
    if argv[1] == "scale-off":
        scale_off(argv[2], argv[3], float(argv[4]), argv[5:])
    elif argv[1] == "tjunction":
        tjunction(argv[2], argv[3], argv[4])
    elif argv[1] == "sort":
        sort_stl(argv[2])
    elif argv[1] == "concat":
        concat(argv[2], argv[3], argv[4:])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv)
