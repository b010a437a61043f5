// The Parts page's mesh worker (part_view.js asks it): fetches the full
// display mesh (model.stl: ten times the bytes of the light one) and parses
// it, or makes a coarser copy of a mesh for the view while it moves — off the
// page's thread, which meanwhile draws and answers the mouse.
//
// A request {id, url} or {id, coarsen: Float32Array of corners, max}; the
// answer {id, pos, nor, min, max, triangles} (PartMesh's mesh, the arrays
// transferred, not copied) or {id, error}.
"use strict";
importScripts("/assets/part_mesh.js");

async function fetchMesh(url) {
  const res = await fetch(url, { cache: "no-store" });
  if (!res.ok) {
    const body = await res.json().catch(() => ({}));
    throw new Error(body.error || `${url}: HTTP ${res.status}`);
  }
  return PartMesh.parseStl(await res.arrayBuffer());
}

self.addEventListener("message", async (ev) => {
  const { id, url, coarsen: corners, max } = ev.data;
  try {
    const m = url ? await fetchMesh(url) : PartMesh.coarsen(corners, max);
    self.postMessage(Object.assign({ id }, m), [m.pos.buffer, m.nor.buffer]);
  } catch (e) {
    self.postMessage({ id, error: e.message });
  }
});
