// What the Parts page's 3D view draws around and on the part (docs/workbench.md):
// the floor grid and the part frame's axes, the fixture's axes, the nest,
// landmark pins with their tolerance zones, suggested candidates and the
// planned views' camera frustums. Each builder returns a THREE.Object3D sized
// from the part's bounding-box diagonal; `userData.pick` names what a click on
// it selects. Three.js r111 (window.THREE).
"use strict";

const PartMarks = (() => {
  const COLORS = { part: 0x9aa7b4, pin: 0xc62828, pinSelected: 0xffb300, zone: 0x2e7d32, chosen: 0x1e88e5,
    refused: 0x9e9e9e, frustum: 0x2e7d32, frustumSelected: 0xff6f00, rotation: 0xd48806, declination: 0x7b1fa2,
    rail: 0x00897b, nest: 0x8d6e63, background: 0xeef1f4, axes: [0xd32f2f, 0x388e3c, 0x1565c0] };
  const UP = new THREE.Vector3(0, 1, 0);

  function vec(a) { return new THREE.Vector3(a[0], a[1], a[2]); }

  // 1, 2 or 5 times a power of ten, the largest not above x.
  function niceBelow(x) {
    const p = Math.pow(10, Math.floor(Math.log10(x)));
    return [5, 2, 1].map((m) => m * p).find((v) => v <= x) || p;
  }

  // Text that faces the camera and is never hidden by the part; `height` in mm.
  function label(text, color, height) {
    const canvas = document.createElement("canvas");
    const ctx = canvas.getContext("2d");
    const font = "bold 40px DejaVu Sans, Arial, sans-serif";
    ctx.font = font;
    canvas.width = Math.ceil(ctx.measureText(text).width) + 16;
    canvas.height = 56;
    ctx.font = font;  // resizing the canvas reset it
    ctx.fillStyle = "rgba(255,255,255,0.8)";
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    ctx.fillStyle = "#" + new THREE.Color(color).getHexString();
    ctx.textBaseline = "middle";
    ctx.fillText(text, 8, canvas.height / 2);
    const texture = new THREE.CanvasTexture(canvas);
    texture.minFilter = THREE.LinearFilter;  // no mipmaps: WebGL 1 would resize the canvas to a power of two
    texture.generateMipmaps = false;
    const material = new THREE.SpriteMaterial({ map: texture, depthTest: false });
    const sprite = new THREE.Sprite(material);
    sprite.scale.set(height * canvas.width / canvas.height, height, 1);
    sprite.renderOrder = 10;
    return sprite;
  }

  // An arrow from `from` along `dir`, `length` long, as solid geometry (WebGL
  // draws lines one pixel wide: too thin to read on a part).
  function arrow(from, dir, length, radius, color) {
    const material = new THREE.MeshLambertMaterial({ color });
    const group = new THREE.Group();
    const head = Math.min(length * 0.35, radius * 6);
    const shaft = new THREE.Mesh(new THREE.CylinderBufferGeometry(radius, radius, length - head, 10), material);
    shaft.position.y = (length - head) / 2;
    const cone = new THREE.Mesh(new THREE.ConeBufferGeometry(radius * 2.6, head, 14), material);
    cone.position.y = length - head / 2;
    group.add(shaft, cone);
    group.position.copy(from);
    group.quaternion.setFromUnitVectors(UP, dir.clone().normalize());
    return group;
  }

  // The floor's grid at floor_z (a GridHelper lies in x-z: turned into x-y) and
  // the part frame's axes at its origin.
  function frame(box, size, floorZ) {
    const group = new THREE.Group();
    const span = Math.max(box.max.x - box.min.x, box.max.y - box.min.y) + size;
    const cell = niceBelow(span / 12);
    const cells = Math.ceil(span / cell);
    const grid = new THREE.GridHelper(cells * cell, cells, 0x9aa4ad, 0xc9d0d6);
    grid.rotation.x = Math.PI / 2;
    grid.position.set(Math.round((box.min.x + box.max.x) / 2 / cell) * cell,
      Math.round((box.min.y + box.max.y) / 2 / cell) * cell, floorZ - 0.001 * size);
    group.add(grid);
    const axes = new THREE.AxesHelper(0.3 * size);
    axes.renderOrder = 5;
    group.add(axes);
    ["x", "y", "z"].forEach((name, k) => {
      const tip = label(name, COLORS.axes[k], 0.035 * size);
      tip.position.setComponent(k, 0.34 * size);
      group.add(tip);
    });
    group.userData.gridCellMm = cell;
    return group;
  }

  // An axis of the fixture as an arrow through its point, drawn where it
  // passes the part (the part's centre projected on it), with its name.
  function axisArrow(axis, name, color, centre, size) {
    if (!axis) return null;
    const dir = vec(Array.isArray(axis) ? axis : axis.direction).normalize();
    const point = Array.isArray(axis) || !axis.point ? new THREE.Vector3() : vec(axis.point);
    const mid = point.clone().addScaledVector(dir, centre.clone().sub(point).dot(dir));
    const length = 0.9 * size;  // its name stays in the first view
    const from = mid.clone().addScaledVector(dir, -length / 2);
    const group = new THREE.Group();
    group.add(arrow(from, dir, length, 0.004 * size, color));
    const tip = label(name, color, 0.035 * size);
    tip.position.copy(mid).addScaledVector(dir, length / 2 + 0.04 * size);
    group.add(tip);
    group.userData.axis = { name, point: point.toArray(), direction: dir.toArray() };
    return group;
  }

  function fixtureAxes(fixture, centre, size) {
    const group = new THREE.Group();
    if (!fixture) return group;
    const axes = [[fixture.rotation_axis, "rotation axis", COLORS.rotation],
      [fixture.declination_axis, "declination axis", COLORS.declination], [fixture.rail_axis, "rail", COLORS.rail]];
    for (const [axis, name, color] of axes) {
      const drawn = axisArrow(axis, name, color, centre, size);
      if (drawn) group.add(drawn);
    }
    return group;
  }

  // The nest: a plate whose top is the floor the part rests on, under its footprint.
  function nest(box, size, floorZ) {
    const margin = 0.08 * size, thick = 0.02 * size;
    const w = box.max.x - box.min.x + 2 * margin, d = box.max.y - box.min.y + 2 * margin;
    const material = new THREE.MeshLambertMaterial({ color: COLORS.nest, transparent: true, opacity: 0.45,
      depthWrite: false });
    const plate = new THREE.Mesh(new THREE.BoxBufferGeometry(w, d, thick), material);
    plate.position.set((box.min.x + box.max.x) / 2, (box.min.y + box.max.y) / 2, floorZ - thick / 2);
    return plate;
  }

  // A landmark's zone along its normal, in mm of offset: [lower, upper].
  function zoneOf(l) {
    if (Array.isArray(l.limits_mm)) return l.limits_mm;
    return typeof l.tolerance_mm === "number" ? [-l.tolerance_mm, l.tolerance_mm] : [0, 0];
  }

  // How much the tolerance zones are exaggerated so that the widest is seen:
  // about 4 % of the part's size, a round factor the legend states.
  function zoneScale(landmarks, size) {
    const widest = Math.max(0, ...landmarks.map((l) => zoneOf(l)[1] - zoneOf(l)[0]));
    if (!(widest > 0)) return 1;
    return Math.max(1, niceBelow(0.04 * size / widest));
  }

  // A pin: a sphere on the surface (what a click picks and a drag moves), an
  // arrow along the normal and the zone as a translucent cylinder along it.
  function pin(l, size, scale, selected) {
    const group = new THREE.Group();
    const normal = vec(l.normal || [0, 0, 1]).normalize();
    const color = selected ? COLORS.pinSelected : COLORS.pin;
    const ball = new THREE.Mesh(new THREE.SphereBufferGeometry(0.012 * size, 16, 12),
      new THREE.MeshLambertMaterial({ color }));
    ball.userData.pick = { kind: "landmark", id: l.id };
    group.add(ball);
    group.add(arrow(new THREE.Vector3(), normal, 0.08 * size, 0.0035 * size, color));
    const [lo, hi] = zoneOf(l);
    const height = Math.max((hi - lo) * scale, 0.002 * size);
    const zone = new THREE.Mesh(new THREE.CylinderBufferGeometry(0.022 * size, 0.022 * size, height, 24, 1),
      new THREE.MeshLambertMaterial({ color: COLORS.zone, transparent: true, opacity: 0.35, depthWrite: false }));
    zone.quaternion.setFromUnitVectors(UP, normal);
    zone.position.copy(normal).multiplyScalar((lo + hi) / 2 * scale);
    group.add(zone);
    const tag = label(l.id, color, 0.03 * size);
    tag.position.copy(normal).multiplyScalar(0.1 * size);
    group.add(tag);
    group.position.copy(vec(l.position));
    group.userData.landmark = l.id;
    return group;
  }

  // A suggested candidate: blue when the suggestion would choose it, grey when
  // a rule refused it.
  function candidate(c, index, size, selected) {
    const refused = c.chosen === false || !!c.rule;
    const color = selected ? COLORS.pinSelected : refused ? COLORS.refused : COLORS.chosen;
    const group = new THREE.Group();
    const mark = new THREE.Mesh(new THREE.OctahedronBufferGeometry(0.014 * size),
      new THREE.MeshLambertMaterial({ color, transparent: refused, opacity: refused ? 0.7 : 1 }));
    mark.userData.pick = { kind: "suggestion", index };
    group.add(mark);
    if (c.normal) group.add(arrow(new THREE.Vector3(), vec(c.normal), 0.06 * size, 0.003 * size, color));
    group.position.copy(vec(c.position));
    return group;
  }

  // A planned view as its camera's frustum: the centre, the rays through the
  // four image corners to the working distance, the image's rectangle there
  // (its top edge marked), and the view's index. A telecentric camera's lines
  // of sight are parallel: its frustum is a box from the lens's front.
  function frustum(view, size, selected) {
    const cam = view.camera;
    const R = cam.rotation, centre = vec(cam.centre), wd = cam.working_distance_mm;
    const telecentric = cam.projection === "telecentric";
    const turn = (d) => new THREE.Vector3(R[0][0] * d[0] + R[0][1] * d[1] + R[0][2] * d[2],
      R[1][0] * d[0] + R[1][1] * d[1] + R[1][2] * d[2],
      R[2][0] * d[0] + R[2][1] * d[1] + R[2][2] * d[2]);
    const at = (u, v, depth = wd) => {
      const x = (u - cam.cx) / cam.fx, y = (v - cam.cy) / cam.fy;
      if (telecentric) return turn([x, y, depth]).add(centre);
      return turn([x, y, 1]).multiplyScalar(depth).add(centre);
    };
    const corners = [at(0, 0), at(cam.width, 0), at(cam.width, cam.height), at(0, cam.height)];
    const front = telecentric
      ? [at(0, 0, 0), at(cam.width, 0, 0), at(cam.width, cam.height, 0), at(0, cam.height, 0)]
      : corners.map(() => centre);
    const top = at(cam.width / 2, -0.12 * cam.height);
    const points = [];
    corners.forEach((c, k) => points.push(front[k], c, c, corners[(k + 1) % 4]));
    points.push(corners[0], top, top, corners[1]);
    const color = selected ? COLORS.frustumSelected : COLORS.frustum;
    const lines = new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(points),
      new THREE.LineBasicMaterial({ color }));
    lines.userData.pick = { kind: "view", index: view.index };
    const group = new THREE.Group();
    group.add(lines);
    const tag = label(String(view.index), color, 0.06 * size);
    tag.position.copy(centre);
    group.add(tag);
    group.userData.extent = [centre, ...corners];
    return group;
  }

  return { COLORS, vec, niceBelow, label, arrow, frame, fixtureAxes, nest, zoneOf, zoneScale, pin, candidate,
    frustum };
})();
