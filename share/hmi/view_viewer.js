// The reject views (docs/hmi.md, "Reject views"): each archived view of a part full size, with pan and
// zoom (wheel, drag, the +, − and fit buttons), its plain frame under an SVG overlay the daemon's
// view_<k>.json describes — the nominal CAD outline at the measured seat, the failed landmarks labelled
// with their reading against the zone, the passed ones as small unlabelled marks, a legend. A part
// archived before the overlays existed (no view_<k>.json) shows its annotated picture instead.
// Shared by the result page and the line view's last failed part. Plain browser JavaScript.
"use strict";

const ViewViewer = (() => {
  const SVG = "http://www.w3.org/2000/svg";
  const FONT = "DejaVu Sans, Arial, sans-serif";
  const LABEL_PX = 13;           // a label's font on the screen, whatever the zoom
  const MARGIN_PX = 3;           // between a label and the image's edge, screen pixels
  const DISTANCES_PX = [14, 26, 42, 64, 92, 130, 180, 240]; // label from its point, screen pixels
  const ANGLES = 16;             // candidate directions per distance
  const ARROW_PX = 28;           // the measuring direction's arrow, screen pixels

  function svg(tag, attrs = {}) {
    const e = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
    return e;
  }

  // Text widths from a canvas (the same font as the SVG text): placement works before the view is shown.
  const measure = (() => {
    const ctx = document.createElement("canvas").getContext("2d");
    ctx.font = `100px ${FONT}`;
    return (text) => ctx.measureText(text).width / 100;  // per pixel of font size
  })();

  const signed = (v, digits) => (v < 0 ? "−" : "+") + Math.abs(v).toFixed(digits);
  function zoneText(l) {
    if (Array.isArray(l.limits_mm)) return `[${signed(l.limits_mm[0], 3)}, ${signed(l.limits_mm[1], 3)}]`;
    return typeof l.tolerance_mm === "number" ? `±${l.tolerance_mm.toFixed(3)}` : "";
  }
  // A failed landmark's label: its one reading (hg.landmarkReading, docs/hmi.md "Landmark rows") against
  // the zone — the deviation where it decided the landmark, else the bracket's reason.
  function labelText(l) {
    const r = hg.landmarkReading(l);
    if (r.kind === "deviation") return `${l.id} ${signed(l.deviation_mm, 3)} mm (${zoneText(l)})`;
    if (r.kind === "bracket")
      return `${l.id} |error| ${l.error_min_mm.toFixed(3)}–${l.error_max_mm.toFixed(3)} mm (${zoneText(l)}): ${r.note}`;
    return `${l.id}: ${r.note}`;
  }
  const failed = (l) => l.status !== "ok";

  const overlaps = (a, b) => a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;

  // Greedy placement (image pixels): around each point, at growing distances, the directions nearest its
  // measuring direction first (outwards, off the part); the first box inside the image that overlaps no
  // placed label and no obstacle (a failed point, its direction arrow) wins. `scale` is screen pixels per
  // image pixel: the labels' sizes are the screen's.
  function place(items, size, scale) {
    const margin = MARGIN_PX / scale, placed = [];
    const obstacles = items.flatMap((it) => {
      const r = 5 / scale, boxes = [{ x: it.p[0] - r, y: it.p[1] - r, w: 2 * r, h: 2 * r }];
      if (it.dir) {
        const tip = [it.p[0] + it.dir[0] * ARROW_PX / scale, it.p[1] + it.dir[1] * ARROW_PX / scale];
        boxes.push({ x: Math.min(it.p[0], tip[0]) - r, y: Math.min(it.p[1], tip[1]) - r,
          w: Math.abs(tip[0] - it.p[0]) + 2 * r, h: Math.abs(tip[1] - it.p[1]) + 2 * r });
      }
      return boxes;
    });
    const inside = (b) => b.x >= -0.5 + margin && b.y >= -0.5 + margin &&
      b.x + b.w <= size[0] - 0.5 - margin && b.y + b.h <= size[1] - 0.5 - margin;
    for (const it of items) {
      const w = it.w / scale, h = it.h / scale;
      const prefer = it.dir ? Math.atan2(it.dir[1], it.dir[0]) : -Math.PI / 4;
      const angles = [...Array(ANGLES).keys()].map((i) => prefer + (i % 2 ? -1 : 1) * Math.ceil(i / 2) * 2 * Math.PI / ANGLES);
      let box = null;
      for (const d of DISTANCES_PX) {
        for (const a of angles) {
          const cx = it.p[0] + Math.cos(a) * (d / scale + w / 2), cy = it.p[1] + Math.sin(a) * (d / scale + h / 2);
          const b = { x: cx - w / 2, y: cy - h / 2, w, h };
          if (inside(b) && !placed.some((q) => overlaps(q, b)) && !obstacles.some((q) => overlaps(q, b))) { box = b; break; }
        }
        if (box) break;
      }
      // Nowhere free: inside the image at least, beside its point.
      if (!box) box = { x: Math.min(Math.max(it.p[0] + 8 / scale, margin - 0.5), size[0] - 0.5 - margin - w),
        y: Math.min(Math.max(it.p[1] - h / 2, margin - 0.5), size[1] - 0.5 - margin - h), w, h };
      placed.push(box);
      it.box = box;
    }
  }

  // The nearest point of box `b` to `p`: where the leader line meets the label.
  const nearest = (b, p) => [Math.min(Math.max(p[0], b.x), b.x + b.w), Math.min(Math.max(p[1], b.y), b.y + b.h)];

  // The marks, arrows and labels in the screen's pixels over the stage, for the transform `t` ({s, x, y}):
  // placed in the image, drawn at a constant size on the screen whatever the zoom.
  function drawMarks(layer, view, t) {
    layer.replaceChildren();
    const at = (p) => [t.x + t.s * (p[0] + 0.5), t.y + t.s * (p[1] + 0.5)];
    for (const l of view.landmarks.filter((x) => !failed(x))) {
      const [x, y] = at(l.pixel);
      layer.append(svg("circle", { class: "vv-pass", cx: x, cy: y, r: 2.5, "data-landmark": l.id }));
    }
    const items = view.landmarks.filter(failed).map((l) => {
      const text = labelText(l);
      return { l, text, p: l.pixel, dir: l.direction, w: measure(text) * LABEL_PX + 8, h: LABEL_PX * 1.5 };
    });
    place(items, view.image_size, t.s);
    for (const it of items) {
      const p = at(it.p);
      if (it.dir) {
        const tip = [p[0] + it.dir[0] * ARROW_PX, p[1] + it.dir[1] * ARROW_PX];
        const n = [-it.dir[1] * 4, it.dir[0] * 4], base = [tip[0] - it.dir[0] * 8, tip[1] - it.dir[1] * 8];
        layer.append(svg("line", { class: "vv-direction", x1: p[0], y1: p[1], x2: base[0], y2: base[1] }),
          svg("polygon", { class: "vv-arrowhead", points: [tip, [base[0] + n[0], base[1] + n[1]],
            [base[0] - n[0], base[1] - n[1]]].map((q) => q.join(",")).join(" ") }));
      }
      const corner = at([it.box.x, it.box.y]);
      const box = { x: corner[0], y: corner[1], w: it.w, h: it.h };
      const end = nearest(box, p);
      layer.append(svg("line", { class: "vv-leader", x1: p[0], y1: p[1], x2: end[0], y2: end[1] }));
      layer.append(svg("circle", { class: "vv-fail", cx: p[0], cy: p[1], r: 4, "data-landmark": it.l.id }));
      const g = svg("g", { class: "vv-label", "data-landmark": it.l.id, "data-status": it.l.status });
      g.append(svg("rect", { x: box.x, y: box.y, width: box.w, height: box.h, rx: 2 }));
      const text = svg("text", { x: box.x + 4, y: box.y + box.h / 2, "font-size": LABEL_PX, "font-family": FONT,
        "dominant-baseline": "central" });
      text.textContent = it.text;
      g.append(text);
      layer.append(g);
    }
  }

  function outlineLayer(view) {
    const g = svg("g", { class: "vv-outline" });
    for (const line of view.outline) {
      const points = line.points.map((p) => p.join(",")).join(" ");
      g.append(svg(line.closed ? "polygon" : "polyline", { points }));
    }
    return g;
  }

  function legend(view) {
    const item = (cls, text) => hg.el("span", { class: "vv-key" }, hg.el("i", { class: cls }), text);
    return hg.el("div", { class: "vv-legend" },
      item("vv-key-outline", `nominal outline (CAD at the ${view.seat === "measured" ? "measured" : "nominal"} seat)`),
      item("vv-key-fail", "failed landmark: reading (zone)"), item("vv-key-pass", "passed landmark"),
      item("vv-key-direction", "measuring direction (outward)"));
  }

  // Pan and zoom of one view: `state` {s, x, y} is the content's transform (screen px per image px, offset).
  function interact(stage, content, view, redraw) {
    const [w, h] = view.image_size;
    const state = { s: 1, x: 0, y: 0, fit: 1 };
    const apply = () => {
      content.style.transform = `translate(${state.x}px, ${state.y}px) scale(${state.s})`;
      stage.dataset.scale = state.s.toFixed(4);
      redraw(state);
    };
    const fit = () => {
      const r = stage.getBoundingClientRect();
      if (!r.width || !r.height) return;
      state.fit = state.s = Math.min(r.width / w, r.height / h);
      state.x = (r.width - w * state.s) / 2;
      state.y = (r.height - h * state.s) / 2;
      apply();
    };
    const zoomAt = (factor, cx, cy) => {
      const s = Math.min(Math.max(state.s * factor, state.fit / 2), 40);
      state.x = cx - (cx - state.x) * s / state.s;
      state.y = cy - (cy - state.y) * s / state.s;
      state.s = s;
      apply();
    };
    stage.addEventListener("wheel", (e) => {
      e.preventDefault();
      const r = stage.getBoundingClientRect();
      zoomAt(Math.exp(-e.deltaY * 0.0015), e.clientX - r.left, e.clientY - r.top);
    }, { passive: false });
    let drag = null;
    stage.addEventListener("pointerdown", (e) => {
      drag = { x: e.clientX - state.x, y: e.clientY - state.y };
      stage.setPointerCapture(e.pointerId);
    });
    stage.addEventListener("pointermove", (e) => {
      if (!drag) return;
      state.x = e.clientX - drag.x;
      state.y = e.clientY - drag.y;
      apply();
    });
    const release = () => { drag = null; };
    stage.addEventListener("pointerup", release);
    stage.addEventListener("pointercancel", release);
    const centre = () => { const r = stage.getBoundingClientRect(); return [r.width / 2, r.height / 2]; };
    // Fitted again when the page changes the stage's width (not while the operator looks closer).
    let width = 0;
    new ResizeObserver(() => {
      const now = stage.getBoundingClientRect().width;
      if (Math.abs(now - width) > 0.5) { width = now; fit(); }
    }).observe(stage);
    return { fit, zoomIn: () => zoomAt(1.5, ...centre()), zoomOut: () => zoomAt(1 / 1.5, ...centre()) };
  }

  function button(text, title, action) {
    const b = hg.el("button", { type: "button", class: "vv-button", title, text });
    b.addEventListener("click", action);
    return b;
  }

  // View `k` drawn into `figure` from its overlay.
  function draw(figure, result, k, view) {
    const [w, h] = view.image_size;
    const img = figure.querySelector("img");
    img.className = "vv-frame";
    img.src = `/api/results/${result.id}/images/frame_${k}.png`;
    img.width = w;
    img.height = h;
    // The outline scales with the frame (a thin line at any zoom); the marks and labels are the screen's.
    const overlay = svg("svg", { class: "vv-overlay", width: w, height: h, viewBox: `-0.5 -0.5 ${w} ${h}` });
    overlay.append(outlineLayer(view));
    const content = hg.el("div", { class: "vv-content" }, img, overlay);
    content.style.width = w + "px";
    content.style.height = h + "px";
    const marks = svg("svg", { class: "vv-marks" });
    const stage = hg.el("div", { class: "vv-stage" }, content, marks);
    stage.style.aspectRatio = `${w} / ${h}`;
    const control = interact(stage, content, view, (t) => drawMarks(marks, view, t));
    const bar = hg.el("div", { class: "vv-toolbar" }, hg.el("span", { class: "vv-title", text: `View ${k + 1}` }),
      button("+", "zoom in", control.zoomIn), button("−", "zoom out", control.zoomOut), button("fit", "whole view", control.fit));
    figure.replaceChildren(bar, stage, legend(view));
    figure.dataset.overlay = "true";
    img.addEventListener("load", () => { figure.dataset.ready = "true"; }, { once: true });
    control.fit();
  }

  // One view: the annotated picture at once (what an older part keeps), the overlaid frame once its
  // overlay is in.
  async function load(figure, result, k, name) {
    try {
      const res = await fetch(`/api/results/${result.id}/views/${k}.json`, { cache: "no-store" });
      if (res.ok) return draw(figure, result, k, await res.json());
    } catch (e) {
      figure.dataset.error = e.message;
    }
    figure.dataset.overlay = "false";
    const img = figure.querySelector("img");
    if (img.complete) figure.dataset.ready = "true";
    else img.addEventListener("load", () => { figure.dataset.ready = "true"; }, { once: true });
  }

  // Every archived view of `result` (its image_files: view_<k>.png).
  function views(result) {
    const box = hg.el("div", { class: "view-viewer" });
    for (const name of result.image_files || []) {
      const k = Number(/^view_([0-9]+)\.png$/.exec(name)?.[1]);
      if (!Number.isInteger(k)) continue;
      const figure = hg.el("figure", { class: "vv-view", "data-view": k },
        hg.el("img", { class: "vv-annotated", src: `/api/results/${result.id}/images/${name}`, alt: name, title: name }));
      box.append(figure);
      load(figure, result, k, name);
    }
    if (!box.children.length) box.append(hg.el("p", { class: "muted", text: "No images archived for this part." }));
    return box;
  }

  return { views, place, labelText };
})();
