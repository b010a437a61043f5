// The Parts page's display meshes as flat-shaded triangles (part_view.js on
// the page's thread, part_mesh_worker.js off it): a binary STL (model.stl:
// part frame, mm) parsed, and a coarser copy of a mesh for the view while it
// moves. Plain arrays: no Three.js here, so the worker need not load it.
// A mesh is {pos, nor, min, max, triangles}: corners as x, y, z floats, three
// a triangle, each corner with its face's normal.
"use strict";

const PartMesh = (() => {
  // Each corner gets its face's normal, computed from the corners (an
  // exporter's stored normals may be zero or wrong).
  function faceNormals(pos) {
    const nor = new Float32Array(pos.length);
    for (let p = 0; p < pos.length; p += 9) {
      const ux = pos[p + 3] - pos[p], uy = pos[p + 4] - pos[p + 1], uz = pos[p + 5] - pos[p + 2];
      const vx = pos[p + 6] - pos[p], vy = pos[p + 7] - pos[p + 1], vz = pos[p + 8] - pos[p + 2];
      const nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      const len = Math.hypot(nx, ny, nz) || 1;
      for (let c = 0; c < 9; c += 3) { nor[p + c] = nx / len; nor[p + c + 1] = ny / len; nor[p + c + 2] = nz / len; }
    }
    return nor;
  }

  function bounds(pos) {
    const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < pos.length; i += 3)
      for (let a = 0; a < 3; a++) {
        const v = pos[i + a];
        if (v < min[a]) min[a] = v;
        if (v > max[a]) max[a] = v;
      }
    return { min, max };
  }

  function mesh(pos) {
    return Object.assign({ pos, nor: faceNormals(pos), triangles: pos.length / 9 }, bounds(pos));
  }

  function parseStl(buffer) {
    const dv = new DataView(buffer);
    const n = buffer.byteLength >= 84 ? dv.getUint32(80, true) : -1;
    if (n < 0 || 84 + 50 * n !== buffer.byteLength) throw new Error("the display mesh is not a binary STL");
    const pos = new Float32Array(n * 9);
    for (let i = 0, o = 96; i < n; i++, o += 50)
      for (let k = 0; k < 9; k++) pos[i * 9 + k] = dv.getFloat32(o + 4 * k, true);
    return mesh(pos);
  }

  // The corners merged per cell of a grid of `cell` mm laid from `min` (vertex
  // clustering): the cells' centroids, and the triangles that kept three
  // distinct corners, each once.
  function cluster(pos, min, cell) {
    const cells = new Map(), sums = [], tris = [], seen = new Set();
    const corner = new Int32Array(pos.length / 3);
    const span = 1 << 17;  // cells a side; the key stays an exact integer (< 2^53)
    for (let v = 0; v < corner.length; v++) {
      const x = pos[3 * v], y = pos[3 * v + 1], z = pos[3 * v + 2];
      const key = (Math.floor((x - min[0]) / cell) * span + Math.floor((y - min[1]) / cell)) * span +
        Math.floor((z - min[2]) / cell);
      let k = cells.get(key);
      if (k === undefined) { k = sums.length / 4; cells.set(key, k); sums.push(0, 0, 0, 0); }
      sums[4 * k] += x; sums[4 * k + 1] += y; sums[4 * k + 2] += z; sums[4 * k + 3]++;
      corner[v] = k;
    }
    const m = sums.length / 4;  // a triangle's key: its sorted corners in base m, exact while m³ < 2^53
    for (let t = 0; t < corner.length; t += 3) {
      const a = corner[t], b = corner[t + 1], c = corner[t + 2];
      if (a === b || b === c || a === c) continue;
      const lo = Math.min(a, b, c), hi = Math.max(a, b, c), mid = a + b + c - lo - hi;
      const key = m < 200000 ? (lo * m + mid) * m + hi : lo + "," + mid + "," + hi;
      if (seen.has(key)) continue;
      seen.add(key);
      tris.push(a, b, c);
    }
    return { sums, tris };
  }

  function area(pos) {
    let sum = 0;
    for (let p = 0; p < pos.length; p += 9) {
      const ux = pos[p + 3] - pos[p], uy = pos[p + 4] - pos[p + 1], uz = pos[p + 5] - pos[p + 2];
      const vx = pos[p + 6] - pos[p], vy = pos[p + 7] - pos[p + 1], vz = pos[p + 8] - pos[p + 2];
      sum += Math.hypot(uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx) / 2;
    }
    return sum;
  }

  // A coarser copy of at most `max` triangles. The first grid is guessed from
  // the surface's area (cells of 2.4 × area / max mm² fitted `max` on the
  // meshes tried), then made coarser until the copy fits.
  function coarsen(pos, max) {
    const { min } = bounds(pos);
    let cell = Math.sqrt(2.4 * area(pos) / max), c = cluster(pos, min, cell);
    while (c.tris.length / 3 > max) { cell *= 1.2; c = cluster(pos, min, cell); }
    const out = new Float32Array(c.tris.length * 3);
    for (let i = 0; i < c.tris.length; i++) {
      const k = c.tris[i], w = c.sums[4 * k + 3];
      for (let a = 0; a < 3; a++) out[3 * i + a] = c.sums[4 * k + a] / w;
    }
    return mesh(out);
  }

  return { parseStl, coarsen };
})();
