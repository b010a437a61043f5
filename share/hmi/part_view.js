// The Parts page's 3D view (docs/workbench.md): the part as the station sees
// it, in its own frame (mm, z up), with the fixture's axes, the nest, the
// landmarks as pins with their tolerance zones, the suggested candidates and
// the planned views as camera frustums. Three.js r111 from Debian's
// libjs-three (window.THREE, OrbitControls); no build step.
//
// Drawing is on demand, never a running loop: a frame is drawn when something
// changed. A CAD part of 200 000 triangles is too heavy for software WebGL
// (SwiftShader: ~4 frames/s at full resolution on two cores), so while the
// view moves the simplified mesh (model.stl?lod=1, ≤ 25 000 triangles) is
// drawn at a reduced pixel ratio that adapts to the measured frame time, and
// once the view has come to rest the full mesh is drawn once at full
// resolution — the level-of-detail scheme of CAD viewers.
"use strict";

const PartView = (() => {
  // How long the view must be still before the full mesh is drawn: long enough
  // that the gaps between wheel steps or mouse moves of one gesture do not
  // each pay a full frame, short enough that the engineer does not wait.
  const REST_AFTER_MS = 180;
  // What is drawn while the view moves, from the finest to the cheapest: the
  // light mesh (the server's ≤ 25 000 triangles; the full mesh when it is no
  // bigger) at a pixel ratio, then a coarser mesh made here from the light
  // one. The view starts at START and steps along the ladder by the time its
  // frames take (Chrome paces animation frames by the GPU's progress and
  // aligns mouse moves to them, so the time between moving frames is the
  // time a frame takes): down when the median of 8 frames is slower than
  // 36 frames/s — a margin over the 30 the engineer must get, as other work
  // on the line PC makes some frames slower — and up when it is at 55 or
  // more, but never back up to a rung found too slow in the last 30 s.
  const LADDER = [{ mesh: "light", ratio: 1 }, { mesh: "light", ratio: 0.75 }, { mesh: "light", ratio: 0.5 },
    { mesh: "light", ratio: 0.35 }, { mesh: "coarse", ratio: 0.35 }, { mesh: "coarse", ratio: 0.25 }];
  const START = 2;
  const FRAME_MS = { slow: 28, fast: 18, pause: 300, memory: 30000 };
  const COARSE_TRIANGLES = 10000;
  // A full mesh this small is itself drawn while moving.
  const LIGHT_ENOUGH = 30000;
  const COLORS = PartMarks.COLORS;

  // The mesh worker (part_mesh_worker.js) fetches and parses the full mesh
  // and makes the coarse copy: the 10 MB of a 200 000-triangle part never
  // hold up the page's thread, which draws and answers the mouse. The light
  // mesh is fetched and parsed here: on a cold start the worker is not ready
  // as soon as the page's thread is, and the first view waits for it.
  let worker = null;
  const waiting = new Map();
  let asked = 0;
  function ask(message, transfer) {
    if (!worker) {
      worker = new Worker("/assets/part_mesh_worker.js");
      worker.addEventListener("message", (ev) => {
        const w = waiting.get(ev.data.id);
        waiting.delete(ev.data.id);
        if (ev.data.error) w.reject(new Error(ev.data.error));
        else w.resolve(ev.data);
      });
      // A worker that could not start answers nothing: every question is refused.
      worker.addEventListener("error", (ev) => {
        for (const w of waiting.values()) w.reject(new Error("the mesh worker failed: " + (ev.message || "not loaded")));
        waiting.clear();
      });
    }
    const id = ++asked;
    return new Promise((resolve, reject) => {
      waiting.set(id, { resolve, reject });
      worker.postMessage(Object.assign({ id }, message), transfer || []);
    });
  }

  // A flat mesh as PartMesh makes it: non-indexed triangles, each corner with
  // its face's normal; its box as measured there.
  function geometry(m) {
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(m.pos, 3));
    g.setAttribute("normal", new THREE.BufferAttribute(m.nor, 3));
    g.boundingBox = new THREE.Box3(new THREE.Vector3(...m.min), new THREE.Vector3(...m.max));
    g.boundingSphere = g.boundingBox.getBoundingSphere(new THREE.Sphere());
    return g;
  }

  class PartView {
    constructor(container, handlers) {
      this.container = container;
      this.on = handlers || {};
      this.stats = { frames: 0, movingFrames: 0, restFrames: 0, firstFrameMs: null, fullFrameMs: null,
        lastFrameMs: null, pixelRatio: 1, level: "none", movingFps: null, rung: START, triangles: { lod: 0, full: 0 } };
      this.moving = false;
      this.dragging = false;
      this.pending = false;
      this.loading = true;
      this.token = 0;
      this.rung = START;
      this.levelOfDetail = true;  // false: the full mesh at full resolution while moving too (the baseline)
      this.intervals = [];
      this.meshes = { lod: null, full: null, coarse: null };
      this.initRenderer();
      performance.mark("parts: WebGL context");
      this.initScene();
      this.precompile();
      this.initPointer();  // before the controls: a press on a pin must not turn the view
      this.initControls();
      new ResizeObserver(() => this.resize()).observe(container);
    }

    initRenderer() {
      this.renderer = new THREE.WebGLRenderer({ antialias: false, powerPreference: "high-performance" });
      this.restRatio = window.devicePixelRatio || 1;
      this.renderer.setPixelRatio(this.restRatio);
      this.renderer.setSize(this.container.clientWidth, this.container.clientHeight);
      this.container.append(this.renderer.domElement);
      this.canvas = this.renderer.domElement;
      this.canvas.tabIndex = 0;
      this.stats.pixelRatio = this.restRatio;
    }

    initScene() {
      this.scene = new THREE.Scene();
      this.scene.background = new THREE.Color(COLORS.background);
      const aspect = Math.max(1, this.container.clientWidth) / Math.max(1, this.container.clientHeight);
      this.camera = new THREE.PerspectiveCamera(35, aspect, 0.1, 10000);
      this.camera.up.set(0, 0, 1);
      this.scene.add(new THREE.AmbientLight(0xffffff, 0.5));
      // A headlight, from a little above and right of the camera along its
      // view: the faces the engineer looks at are lit, whichever side.
      const light = new THREE.DirectionalLight(0xffffff, 0.65);
      light.position.set(0.3, 0.5, 0);
      light.target.position.set(0, 0, -1);
      this.camera.add(light, light.target);
      this.scene.add(this.camera);
      this.material = new THREE.MeshLambertMaterial({ color: COLORS.part });
      this.groups = {};
      for (const name of ["helpers", "fixture", "pins", "suggestions", "views"]) {
        this.groups[name] = new THREE.Group();
        this.scene.add(this.groups[name]);
      }
      this.raycaster = new THREE.Raycaster();
    }

    // Compiles the shaders of everything the view draws while the page waits
    // for the part (software WebGL takes a few hundred milliseconds for
    // them): one of each kind of mark, with the part's material and lights.
    precompile() {
      const tiny = new THREE.BoxBufferGeometry(1, 1, 1);
      const box = new THREE.Box3(new THREE.Vector3(), new THREE.Vector3(1, 1, 1));
      const kinds = new THREE.Group();
      kinds.add(new THREE.Mesh(tiny, this.material), PartMarks.nest(box, 1, 0), PartMarks.frame(box, 1, 0),
        new THREE.LineSegments(tiny, new THREE.LineBasicMaterial()));
      this.scene.add(kinds);
      this.renderer.compile(this.scene, this.camera);
      this.scene.remove(kinds);
      performance.mark("parts: shaders compiled");
    }

    initControls() {
      this.controls = new THREE.OrbitControls(this.camera, this.canvas);
      this.controls.screenSpacePanning = true;
      this.controls.addEventListener("change", () => this.motion());
      this.controls.addEventListener("start", () => { this.dragging = true; });
      this.controls.addEventListener("end", () => { this.dragging = false; this.restSoon(); });
    }

    // The view moved: draw the light mesh now, the full one once it is still.
    // A move made here (fit, lookAt) is drawn at rest at once.
    motion() {
      if (this.quiet) return this.requestRender();
      if (!this.moving) { this.moving = true; this.lastMovingAt = null; }
      this.restSoon();
      this.requestRender();
    }

    restSoon() {
      clearTimeout(this.restTimer);
      this.restTimer = setTimeout(() => {
        if (this.dragging) return this.restSoon();
        this.moving = false;
        this.requestRender();
      }, REST_AFTER_MS);
    }

    requestRender() {
      this.requestedAt = performance.now();
      if (this.pending) return;
      this.pending = true;
      requestAnimationFrame((t) => this.frame(t));
    }

    frame(time) {
      this.pending = false;
      // Nothing is drawn before the part's first mesh: a first draw costs
      // software WebGL hundreds of milliseconds of a cold start, and the
      // light mesh's bytes would wait behind it.
      if (this.loading) return;
      const moving = this.moving && this.meshes.lod !== null;
      const { mesh, ratio } = moving ? this.movingLevel()
        : { mesh: this.meshes.full || this.meshes.lod, ratio: this.restRatio };
      for (const m of Object.values(this.meshes)) if (m) m.visible = m === mesh;
      this.setRatio(ratio);
      this.renderer.render(this.scene, this.camera);
      this.count(moving, mesh, time);
    }

    // The mesh and pixel ratio of the ladder's rung (the baseline: full, full).
    movingLevel() {
      const full = this.meshes.full;
      if (!this.levelOfDetail) return { mesh: full || this.meshes.lod, ratio: this.restRatio };
      const rung = LADDER[this.rung];
      const light = full && this.stats.triangles.full <= LIGHT_ENOUGH ? full : this.meshes.lod;
      const mesh = rung.mesh === "coarse" && this.meshes.coarse ? this.meshes.coarse : light;
      return { mesh, ratio: Math.min(this.restRatio, rung.ratio) };
    }

    setRatio(ratio) {
      if (this.stats.pixelRatio === ratio) return;
      this.renderer.setPixelRatio(ratio);
      this.stats.pixelRatio = ratio;
    }

    // Counts the frame; while moving, the time since the last moving frame
    // (a pause of the mouse left out) feeds the ladder.
    count(moving, mesh, time) {
      const s = this.stats;
      s.frames++;
      s.lastFrameMs = performance.now();
      s.level = !mesh ? "none" : Object.keys(this.meshes).find((k) => this.meshes[k] === mesh);
      if (!mesh) return;
      if (s.firstFrameMs === null) {
        // Wait for the GPU once, so the time is that of a drawn frame, not of a queued one.
        this.renderer.getContext().finish();
        s.firstFrameMs = performance.now();
        performance.mark("parts: first frame drawn");
      }
      if (!moving) {
        s.restFrames++;
        if (mesh === this.meshes.full && s.fullFrameMs === null) s.fullFrameMs = performance.now();
        return;
      }
      s.movingFrames++;
      const interval = this.lastMovingAt === null ? null : time - this.lastMovingAt;
      this.lastMovingAt = time;
      if (interval !== null && interval < FRAME_MS.pause) this.intervals.push(interval);
      if (this.intervals.length >= 8) this.adapt();
    }

    // One step down the ladder when slow, one up when fast (no see-saw: see LADDER).
    adapt() {
      const sorted = this.intervals.slice().sort((a, b) => a - b);
      const median = sorted[Math.floor(sorted.length / 2)];
      this.intervals = [];
      const s = this.stats;
      s.movingFps = 1000 / median;
      const now = performance.now();
      if (median > FRAME_MS.slow && this.rung < LADDER.length - 1) {
        this.tooSlow = { rung: this.rung, until: now + FRAME_MS.memory };
        this.rung++;
        if (LADDER[this.rung].mesh === "coarse" && !this.meshes.coarse) this.makeCoarse();
      } else if (median < FRAME_MS.fast && this.rung > 0 &&
                 !(this.tooSlow && this.tooSlow.rung === this.rung - 1 && now < this.tooSlow.until)) {
        this.rung--;
      }
      s.rung = this.rung;
    }

    // The coarse copy of the light mesh, made by the worker from a copy of
    // its corners (the light mesh keeps being drawn meanwhile).
    async makeCoarse() {
      if (!this.meshes.lod || this.stats.triangles.lod <= COARSE_TRIANGLES || this.makingCoarse) return;
      this.makingCoarse = true;
      const token = this.token, started = performance.now();
      const pos = this.meshes.lod.geometry.attributes.position.array.slice();
      try {
        const coarse = await ask({ coarsen: pos, max: COARSE_TRIANGLES }, [pos.buffer]);
        if (token === this.token) this.setMesh("coarse", geometry(coarse));
        this.stats.coarseMs = performance.now() - started;
      } finally {
        this.makingCoarse = false;
      }
    }

    // ---- the part ----

    // A new part: its frame's marks from the API's facts (bounds, station),
    // then the light mesh (the first view), then the full one.
    async showPart(facts, fetched) {
      const token = ++this.token;
      this.clearMeshes();
      Object.assign(this.stats, { firstFrameMs: null, fullFrameMs: null, loadStartMs: fetched.startedMs,
        lodLoadedMs: null, fullLoadedMs: null, triangles: { lod: 0, full: 0 } });
      this.setContext(facts);
      this.fit();
      this.loading = true;
      const lod = geometry(await fetched.lod.finally(() => { if (token === this.token) this.loading = false; }));
      if (token !== this.token) return;
      performance.mark("parts: light mesh received");
      this.setMesh("lod", lod);
      this.stats.lodLoadedMs = performance.now();
      if (this.on.loaded) this.on.loaded("lod");
      const full = geometry(await fetched.full);
      if (token !== this.token) return;
      this.setMesh("full", full);
      this.stats.fullLoadedMs = performance.now();
      if (this.on.loaded) this.on.loaded("full");
      // The coarse mesh is made while the engineer looks, not when the view
      // first turns out too slow (by the worker: no pause of the page).
      if (this.stats.triangles.full > LIGHT_ENOUGH)
        this.makeCoarse();
    }

    setMesh(level, g) {
      const mesh = new THREE.Mesh(g, this.material);
      mesh.matrixAutoUpdate = false;
      mesh.visible = false;
      this.meshes[level] = mesh;
      this.stats.triangles[level] = g.attributes.position.count / 3;
      this.scene.add(mesh);
      this.requestRender();
    }

    clearMeshes() {
      for (const level of ["lod", "full", "coarse"]) {
        const mesh = this.meshes[level];
        if (!mesh) continue;
        this.scene.remove(mesh);
        mesh.geometry.dispose();
        this.meshes[level] = null;
      }
    }

    // The part's box (bounds_mm as [[min], [max]] or {min, max}), its size
    // (the diagonal every mark is scaled by) and the station's marks.
    setContext(facts) {
      const b = facts.bounds || [[-50, -50, 0], [50, 50, 50]];
      const [lo, hi] = Array.isArray(b) ? b : [b.min, b.max];
      this.box = new THREE.Box3(PartMarks.vec(lo), PartMarks.vec(hi));
      this.size = this.box.getSize(new THREE.Vector3()).length() || 1;
      this.centre = this.box.getCenter(new THREE.Vector3());
      const station = facts.station || {};
      const floorZ = typeof station.floor_z_mm === "number" ? station.floor_z_mm : this.box.min.z;
      this.replace("helpers", [PartMarks.frame(this.box, this.size, floorZ), PartMarks.nest(this.box, this.size, floorZ)]);
      this.gridCellMm = this.groups.helpers.children[0].userData.gridCellMm;
      this.replace("fixture", [PartMarks.fixtureAxes(station.fixture, this.centre, this.size)]);
      this.camera.near = this.size * 0.01;
      this.camera.far = this.size * 200;
      this.camera.updateProjectionMatrix();
      this.raycaster.params.Line.threshold = 0.01 * this.size;
    }

    // ---- marks ----

    replace(group, objects) {
      const g = this.groups[group];
      for (const child of g.children.slice()) {
        g.remove(child);
        child.traverse((o) => {
          if (o.geometry) o.geometry.dispose();
          if (o.material) { if (o.material.map) o.material.map.dispose(); o.material.dispose(); }
        });
      }
      for (const o of objects) if (o) g.add(o);
      this.requestRender();
    }

    setLandmarks(landmarks, selectedId) {
      if (!this.size) return;
      this.zoneScale = PartMarks.zoneScale(landmarks, this.size);
      this.replace("pins", landmarks.map((l) => PartMarks.pin(l, this.size, this.zoneScale, l.id === selectedId)));
    }

    setSuggestions(candidates, selectedIndex) {
      if (!this.size) return;
      this.replace("suggestions", candidates.map((c, k) => PartMarks.candidate(c, k, this.size, k === selectedIndex)));
    }

    setViews(views, selectedIndex) {
      if (!this.size) return;
      this.replace("views", views.map((v) => PartMarks.frustum(v, this.size, v.index === selectedIndex)));
    }

    show(group, visible) {
      this.groups[group].visible = visible;
      this.requestRender();
    }

    // ---- the camera ----

    // Looks at the part (and, with `withViews`, at the planned cameras too)
    // from the front-right, above, as a drawing's isometric view.
    fit(withViews) {
      const box = this.box.clone();
      if (withViews)
        for (const g of this.groups.views.children) for (const p of g.userData.extent) box.expandByPoint(p);
      const sphere = box.getBoundingSphere(new THREE.Sphere());
      const fov = THREE.Math.degToRad(this.camera.fov) / 2;
      const distance = 1.15 * sphere.radius / Math.sin(Math.min(fov, fov * this.camera.aspect));
      const dir = new THREE.Vector3(1, -1.4, 0.9).normalize();
      this.controls.target.copy(sphere.center);
      this.camera.position.copy(sphere.center).addScaledVector(dir, distance);
      this.update();
    }

    update() {
      this.quiet = true;
      this.controls.update();
      this.quiet = false;
    }

    // The camera's matrices as the next frame will have them (the renderer
    // updates them only when it draws; a pick may come before).
    syncCamera() {
      this.camera.updateMatrixWorld();
      this.camera.matrixWorldInverse.getInverse(this.camera.matrixWorld);
    }

    // Looks at a point of the part along `dir` (default: from where the camera is).
    lookAt(point, dir) {
      const target = PartMarks.vec(point);
      const from = dir ? PartMarks.vec(dir).normalize()
        : this.camera.position.clone().sub(this.controls.target).normalize();
      this.controls.target.copy(target);
      this.camera.position.copy(target).addScaledVector(from, 1.6 * this.size);
      this.update();
    }

    // Where a part-frame point is on the screen (CSS pixels of the page and of
    // the canvas), and whether the part hides it from the camera.
    screenOf(point) {
      const p = PartMarks.vec(point);
      this.syncCamera();
      const ndc = p.clone().project(this.camera);
      const rect = this.canvas.getBoundingClientRect();
      const x = (ndc.x + 1) / 2 * rect.width, y = (1 - ndc.y) / 2 * rect.height;
      const hit = this.pickSurface(rect.left + x, rect.top + y);
      const visible = Math.abs(ndc.z) <= 1 && x >= 0 && y >= 0 && x <= rect.width && y <= rect.height &&
        (!hit || hit.point.distanceTo(p) < 0.005 * this.size);
      return { clientX: rect.left + x, clientY: rect.top + y, canvasX: x, canvasY: y, visible };
    }

    // ---- picking ----

    raycastAt(clientX, clientY, objects, recursive) {
      const rect = this.canvas.getBoundingClientRect();
      this.syncCamera();
      const ndc = new THREE.Vector2((clientX - rect.left) / rect.width * 2 - 1, 1 - (clientY - rect.top) / rect.height * 2);
      this.raycaster.setFromCamera(ndc, this.camera);
      return this.raycaster.intersectObjects(objects, recursive);
    }

    // The part's surface under a screen point: the full mesh (the light one
    // only while the full one is still loading, or when `light` asks for it
    // during a drag), its point and face normal in the part frame.
    pickSurface(clientX, clientY, light) {
      const mesh = (light && this.meshes.lod) || this.meshes.full || this.meshes.lod;
      if (!mesh) return null;
      // The mesh asked directly: the raycaster skips a hidden object, and
      // which mesh is shown depends on whether the view is moving.
      const hits = [];
      this.raycastAt(clientX, clientY, [], false);
      mesh.raycast(this.raycaster, hits);
      const hit = hits.sort((a, b) => a.distance - b.distance)[0];
      if (!hit) return null;
      return { point: hit.point, normal: hit.face.normal.clone(), distance: hit.distance,
        mesh: mesh === this.meshes.full ? "full" : "lod" };
    }

    // A pin, a candidate or a frustum under a screen point, the nearest first;
    // one behind the part does not count.
    pickMark(clientX, clientY) {
      const groups = ["pins", "suggestions", "views"].map((g) => this.groups[g]).filter((g) => g.visible);
      const hits = this.raycastAt(clientX, clientY, groups, true).filter((h) => h.object.userData.pick);
      if (!hits.length) return null;
      const surface = this.pickSurface(clientX, clientY);
      const hit = hits[0];
      const kind = hit.object.userData.pick.kind;
      if (surface && kind !== "landmark" && surface.distance < hit.distance - 0.01 * this.size) return null;
      return hit.object.userData.pick;
    }

    // ---- the mouse ----

    // A press on a pin starts dragging it (when the page allows changes) and
    // keeps the view still; any other press is the orbit controls'. A press
    // and release without moving is a click: a mark selects, the surface picks.
    initPointer() {
      this.canvas.addEventListener("mousedown", (ev) => {
        this.down = { x: ev.clientX, y: ev.clientY };
        this.dragged = false;
        if (ev.button !== 0) return;
        const mark = this.pickMark(ev.clientX, ev.clientY);
        if (!mark || mark.kind !== "landmark" || !(this.on.canDrag && this.on.canDrag(mark.id))) return;
        ev.stopImmediatePropagation();
        ev.preventDefault();
        this.startPinDrag(mark.id, ev);
      });
      this.canvas.addEventListener("click", (ev) => {
        if (!this.down || Math.hypot(ev.clientX - this.down.x, ev.clientY - this.down.y) > 4 || this.dragged) return;
        this.click(ev.clientX, ev.clientY);
      });
    }

    click(clientX, clientY) {
      const mark = this.pickMark(clientX, clientY);
      if (mark) return this.on.select && this.on.select(mark);
      const hit = this.pickSurface(clientX, clientY);
      if (hit && this.on.surface) this.on.surface(hit);
      else if (this.on.select) this.on.select(null);
    }

    startPinDrag(id, ev) {
      const group = this.groups.pins.children.find((g) => g.userData.landmark === id);
      const drag = { id, group, from: group.position.clone(), x: ev.clientX, y: ev.clientY, moved: false };
      this.dragged = false;
      const move = (e) => {
        drag.x = e.clientX; drag.y = e.clientY;
        if (!drag.moved && Math.hypot(e.clientX - this.down.x, e.clientY - this.down.y) <= 4) return;
        drag.moved = this.dragged = true;
        if (drag.scheduled) return;
        drag.scheduled = true;
        requestAnimationFrame(() => {
          drag.scheduled = false;
          const hit = this.pickSurface(drag.x, drag.y, true);
          if (hit) { group.position.copy(hit.point); this.motion(); }
        });
      };
      const up = () => {
        document.removeEventListener("mousemove", move);
        document.removeEventListener("mouseup", up);
        if (!drag.moved) return this.on.select && this.on.select({ kind: "landmark", id });
        const hit = this.pickSurface(drag.x, drag.y);
        if (!hit) { group.position.copy(drag.from); this.requestRender(); return; }
        group.position.copy(hit.point);
        this.requestRender();
        if (this.on.dragPin) this.on.dragPin(id, hit.point.toArray());
      };
      document.addEventListener("mousemove", move);
      document.addEventListener("mouseup", up);
    }

    resize() {
      const w = this.container.clientWidth, h = this.container.clientHeight;
      if (!w || !h) return;
      this.renderer.setSize(w, h);
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
      this.requestRender();
    }
  }

  // Asks for both meshes at once, before the part's facts are read: the
  // light one is drawn first, the full one (ten times the bytes) meanwhile
  // arrives and is parsed by the worker.
  PartView.prefetch = (url) => {
    // Parsed as soon as its bytes are here: in a gap of the page's thread,
    // perhaps while the part's facts are still on their way.
    const light = fetch(url + "?lod=1", { cache: "no-store" }).then(async (res) => {
      if (res.ok) return PartMesh.parseStl(await res.arrayBuffer());
      const body = await res.json().catch(() => ({}));
      throw new Error(body.error || `${url}?lod=1: HTTP ${res.status}`);
    });
    const fetched = { startedMs: performance.now(), lod: light, full: ask({ url }) };
    fetched.lod.catch(() => null);  // reported when awaited, not as an unhandled rejection
    fetched.full.catch(() => null);
    return fetched;
  };
  return PartView;
})();
