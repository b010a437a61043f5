#!/usr/bin/env python3
"""Ad hoc defect census of a triangle mesh (binary/ASCII STL, OFF): the "as
exported" column of README.md. Needs numpy (Debian: python3-numpy); not run
by CI. Usage: mesh-census.py FILE...

Prints one JSON object per file: triangles, bbox, and the defects as the file
is written (nothing repaired):
  zero_area      triangles whose area is 0 in double precision (collinear or
                 repeated corners), of which repeated_corner
  needles        triangles with area > 0 but min height < 1e-6 * part size
  near_dup_vertices  pairs of distinct vertices closer than 1e-6 * size
  open_edges     undirected edges used by one triangle (after exact merge)
  nonmanifold_edges  edges used by more than two triangles
  misoriented_edges  directed edges used twice the same way
  t_junctions    vertices lying strictly inside an open edge (within 1e-9 size)
  self_intersections  triangle pairs that intersect other than at their shared
                 corners/edge (float64, tolerance 1e-9 * size)
  volume         signed volume (mm^3)
  shells         edge-connected components
"""
import json
import struct
import sys
from collections import defaultdict

import numpy as np


def read_stl(path):
    data = open(path, "rb").read()
    if len(data) >= 84:
        n = struct.unpack_from("<I", data, 80)[0]
        if 84 + 50 * n == len(data):
            rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                                count=n, offset=84)
            pts = rec["v"].reshape(-1, 3).astype(np.float64)
            return pts, np.arange(3 * n).reshape(-1, 3), "binary STL"
    verts = []
    for line in data.decode().splitlines():
        t = line.split()
        if t and t[0] == "vertex":
            verts.append([float(x) for x in t[1:4]])
    pts = np.array(verts)
    return pts, np.arange(len(pts)).reshape(-1, 3), "ASCII STL"


def read_off(path):
    toks = []
    for line in open(path):
        line = line.split("#")[0]
        toks.extend(line.split())
    assert toks[0].endswith("OFF")
    nv, nf = int(toks[1]), int(toks[2])
    i = 4
    pts = np.array([[float(toks[i + 3 * k + j]) for j in range(3)] for k in range(nv)])
    i += 3 * nv
    tris = []
    polys = 0
    for _ in range(nf):
        k = int(toks[i])
        idx = [int(x) for x in toks[i + 1:i + 1 + k]]
        i += 1 + k
        # skip optional colour values: assume none beyond k when next token count fits
        if k != 3:
            polys += 1
        for j in range(1, k - 1):
            tris.append([idx[0], idx[j], idx[j + 1]])
    return pts, np.array(tris), "OFF" + (f" ({polys} polygons fan-split)" if polys else "")


def merge_exact(pts, tris):
    uniq, inv = np.unique(pts, axis=0, return_inverse=True)
    return uniq, inv.reshape(-1)[tris]


def seg_tri(p, q, a, b, c, eps):
    """Segment pq strictly crosses triangle abc (interior of both)."""
    n = np.cross(b - a, c - a)
    nn = np.linalg.norm(n)
    if nn == 0:
        return False
    n = n / nn
    dp, dq = np.dot(p - a, n), np.dot(q - a, n)
    if (dp > eps and dq > eps) or (dp < -eps and dq < -eps):
        return False
    if abs(dp) <= eps and abs(dq) <= eps:
        return False  # coplanar: handled elsewhere
    t = dp / (dp - dq)
    if t <= 1e-9 or t >= 1 - 1e-9:
        return False
    x = p + t * (q - p)
    for u, v in ((a, b), (b, c), (c, a)):
        if np.dot(np.cross(v - u, x - u), n) <= eps * np.linalg.norm(v - u):
            return False
    return True


def tri_tri(T, U, shared, eps):
    if len(shared) >= 2:
        return False
    if len(shared) == 1:
        # only the edges opposite the shared corner can cross the other triangle
        s = shared[0]
        ti = [k for k in range(3) if k != s[0]]
        ui = [k for k in range(3) if k != s[1]]
        return seg_tri(T[ti[0]], T[ti[1]], *U, eps) or seg_tri(U[ui[0]], U[ui[1]], *T, eps)
    for k in range(3):
        if seg_tri(T[k], T[(k + 1) % 3], *U, eps) or seg_tri(U[k], U[(k + 1) % 3], *T, eps):
            return True
    return False


def census(path):
    pts, tris, fmt = (read_off if path.endswith(".off") else read_stl)(path)
    raw_vertices = len(pts)
    P, F = merge_exact(pts, tris)
    lo, hi = P.min(0), P.max(0)
    size = float(np.linalg.norm(hi - lo))
    A, B, C = P[F[:, 0]], P[F[:, 1]], P[F[:, 2]]
    cr = np.cross(B - A, C - A)
    area2 = np.linalg.norm(cr, axis=1)
    rep = (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])
    zero = area2 == 0
    longest = np.maximum.reduce([np.linalg.norm(B - A, axis=1), np.linalg.norm(C - B, axis=1),
                                 np.linalg.norm(A - C, axis=1)])
    height = np.where(longest > 0, area2 / np.where(longest > 0, longest, 1), 0)
    needles = (~zero) & (height < 1e-6 * size)
    thin = (~zero) & (height < 1e-3)  # thinner than 1 um

    # near-duplicate vertices
    tol = 1e-6 * size
    keys = np.floor(P / max(tol, 1e-12)).astype(np.int64)
    grid = defaultdict(list)
    for i, k in enumerate(map(tuple, keys)):
        grid[k].append(i)
    near = 0
    for i, k in enumerate(map(tuple, keys)):
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for j in grid.get((k[0] + dx, k[1] + dy, k[2] + dz), ()):
                        if j > i and np.linalg.norm(P[i] - P[j]) < tol:
                            near += 1

    # edges
    good = ~rep
    directed = defaultdict(int)
    undirected = defaultdict(int)
    for f in F[good]:
        for k in range(3):
            a, b = int(f[k]), int(f[(k + 1) % 3])
            directed[(a, b)] += 1
            undirected[(min(a, b), max(a, b))] += 1
    open_edges = [e for e, n in undirected.items() if n == 1]
    nonman = sum(1 for n in undirected.values() if n > 2)
    misor = sum(1 for (a, b), n in directed.items() if n >= 2 or (a, b) in directed and (b, a) not in directed and
                undirected[(min(a, b), max(a, b))] == 2)
    # T-junctions: a vertex strictly inside an open edge
    tj = 0
    open_v = sorted({v for e in open_edges for v in e})
    for a, b in open_edges:
        pa, pb = P[a], P[b]
        d = pb - pa
        L = np.linalg.norm(d)
        for v in open_v:
            if v in (a, b):
                continue
            t = np.dot(P[v] - pa, d) / (L * L)
            if 1e-9 < t < 1 - 1e-9 and np.linalg.norm(np.cross(P[v] - pa, d)) / L < 1e-9 * size:
                tj += 1
    # shells
    parent = list(range(len(P)))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for f in F:
        for k in (1, 2):
            ra, rb = find(int(f[0])), find(int(f[k]))
            if ra != rb:
                parent[ra] = rb
    shells = len({find(int(v)) for v in np.unique(F)})

    # self-intersections: grid broad phase on triangle boxes
    eps = 1e-9 * size
    idx = np.nonzero(~zero)[0]
    tlo = np.minimum.reduce([A, B, C])
    thi = np.maximum.reduce([A, B, C])
    cell = size / 64
    cells = defaultdict(list)
    for t in idx:
        c0 = np.floor((tlo[t] - lo) / cell).astype(int)
        c1 = np.floor((thi[t] - lo) / cell).astype(int)
        for x in range(c0[0], c1[0] + 1):
            for y in range(c0[1], c1[1] + 1):
                for z in range(c0[2], c1[2] + 1):
                    cells[(x, y, z)].append(t)
    seen = set()
    hits = []
    for members in cells.values():
        for i in range(len(members)):
            for j in range(i + 1, len(members)):
                s, t = members[i], members[j]
                if (s, t) in seen:
                    continue
                seen.add((s, t))
                if np.any(thi[s] < tlo[t] - eps) or np.any(thi[t] < tlo[s] - eps):
                    continue
                shared = [(p, q) for p in range(3) for q in range(3) if F[s, p] == F[t, q]]
                T = P[F[s]]
                U = P[F[t]]
                if tri_tri(T, U, shared, eps):
                    hits.append((int(s), int(t)))
    vol = float(np.sum(np.einsum("ij,ij->i", A, np.cross(B, C))) / 6.0)
    out = {
        "file": path.split("/")[-1], "format": fmt, "triangles": int(len(F)),
        "vertices_written": raw_vertices, "vertices_distinct": int(len(P)),
        "bbox_min": [round(float(x), 4) for x in lo], "bbox_max": [round(float(x), 4) for x in hi],
        "extent": [round(float(x), 3) for x in hi - lo],
        "zero_area": int(zero.sum()), "repeated_corner": int(rep.sum()),
        "needles_h_lt_1e-6size": int(needles.sum()), "thin_h_lt_1um": int(thin.sum()),
        "min_height_nonzero": float(height[~zero].min()) if (~zero).any() else None,
        "near_dup_vertices": near, "open_edges": len(open_edges), "nonmanifold_edges": nonman,
        "misoriented_edges": misor, "t_junctions": tj, "self_intersecting_pairs": len(hits),
        "first_intersections": hits[:3], "volume": round(vol, 3), "shells": shells,
    }
    return out


if __name__ == "__main__":
    for p in sys.argv[1:]:
        print(json.dumps(census(p)))
