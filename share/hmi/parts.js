// The Parts page (docs/workbench.md): the engineer's workbench from a CAD
// model to a released part program — the part in 3D with the fixture and the
// nest, landmarks placed and moved with the mouse, suggestions, the planned
// views as the camera sees them, the proof on the twin and the numbered
// releases. Every change goes through /api/parts and needs a signed-in
// engineer; each names the draft revision it was made on, and one made on an
// older revision (another engineer changed the draft) is refused 409 in the
// server's words and the part is read again.
"use strict";
hg.nav("/parts");

const $ = (id) => document.getElementById(id);
const state = { csrf: null, signedIn: false, who: null, name: null, part: null, selected: null,
  suggestions: [], selectedSuggestion: null, views: [], selectedView: null, versions: [], jobTimer: null };

performance.mark("parts: script");

// What a browser test or tools/bench-parts-view reads and drives:
//   ready        the part's facts, meshes, views, report and versions shown
//   state        "empty" | "loading" | "lod" (the light mesh drawn) | "full" | "error"
//   part, busy   the part shown; API requests under way
//   frames       frames drawn (view.stats: movingFrames, restFrames, firstFrameMs,
//                fullFrameMs, level, pixelRatio, rung, triangles)
//   idle()       nothing requested, the view at rest with nothing left to draw
//   landmarks()  the draft's landmarks as the page has them
//   screenOf(p)  where part-frame point p is on the screen: {clientX, clientY,
//                canvasX, canvasY, visible} (visible: not hidden by the part)
//   clickAt(p)   a click there through the view's own mouse handling
//   lookAt(p, d) the camera looking at p from direction d (drawn at rest)
//   lastPick     the surface point the page last sent for a landmark (part frame)
//   lastPlaced   the server's `placed` of the last landmark added or moved
//   lastError    the last refusal's words; job: the last job read
//   view         the PartView (view.levelOfDetail = false: the full mesh while moving too)
const hook = window.hgParts = {
  ready: false, state: "empty", part: null, busy: 0, lastPlaced: null, lastError: null, view: null,
  get frames() { return hook.view ? hook.view.stats.frames : 0; },
  landmarks() { return state.part ? JSON.parse(JSON.stringify(state.part.draft.landmarks)) : []; },
  // Where a part-frame point is on the screen (and whether the part hides it).
  screenOf(point) { return hook.view.screenOf(point); },
  // A click there through the view's own mouse handling (as a hand's).
  clickAt(point) {
    const at = hook.view.screenOf(point);
    for (const type of ["mousedown", "mouseup", "click"])
      hook.view.canvas.dispatchEvent(new MouseEvent(type, { bubbles: true, cancelable: true, view: window,
        clientX: at.clientX, clientY: at.clientY, button: 0, buttons: type === "mousedown" ? 1 : 0 }));
    return at;
  },
  lookAt(point, dir) { hook.view.lookAt(point, dir); },
  idle() { return hook.busy === 0 && hook.view && !hook.view.moving && !hook.view.pending; },
  select(name) { return selectPart(name); },
};

function say(id, text, cls) {
  const e = $(id);
  e.textContent = text;
  if (cls !== undefined) e.className = cls;
}

function base() { return "/api/parts/" + encodeURIComponent(state.name); }

// The part the address names is asked for before anything else is set up
// (the 3D view's WebGL context takes a while to create): the first view is
// what the engineer waits for.
let early = (() => {
  const name = new URLSearchParams(location.search).get("part");
  if (!name) return null;
  const url = "/api/parts/" + encodeURIComponent(name);
  const part = hg.get(url);
  part.catch(() => null);
  return { name, part, meshes: PartView.prefetch(url + "/model.stl") };
})();

// What was asked for early, once, when it is what is wanted now.
function takeEarly() {
  const e = early && early.name === state.name ? early : null;
  early = null;
  return e;
}

// ---- the API: every call counted for the test hook; changes with the CSRF token ----

async function api(call) {
  hook.busy++;
  try { return await call(); } finally { hook.busy--; }
}

async function get(path) { return api(() => hg.get(path)); }

// A change. On 409 the server's words are shown where `where` says, and the
// part read again so that the engineer sees the draft as it now is.
async function change(path, body, where) {
  try {
    return await api(() => hg.post(path, body, state.csrf));
  } catch (e) {
    hook.lastError = e.message;
    say(where, "Refused: " + e.message, "error");
    if (e.status === 409 && state.name) await reloadPart();
    if (e.status === 401 || (e.status === 403 && /CSRF/.test(e.message))) await session();
    return null;
  }
}

// ---- signing in ----

async function session() {
  const s = await get("/api/session");
  state.csrf = s.csrf || null;
  // Changes need the right to change part programs (docs/audit.md); an operator signed in only reads.
  state.mayChange = !!s.signed_in && !!s.may && !!s.may.programs;
  state.who = s.name || null;
  $("login").hidden = !s.configured || s.signed_in;
  $("logout").hidden = !s.signed_in;
  say("session", !s.configured ? "Changes over HTTP are not configured on this station."
    : !s.signed_in ? "Read-only: sign in to change parts."
    : `Signed in as ${hg.who(s)}.` + (state.mayChange ? "" : " Only an engineer or administrator changes parts."));
  say("who", s.signed_in ? s.name || "" : "");
  for (const e of document.querySelectorAll(".needs-sign-in")) e.disabled = !state.mayChange;
}

$("login").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const body = { password: $("password").value };
  if ($("login-name").value.trim()) body.name = $("login-name").value.trim();
  try {
    await api(() => hg.post("/api/login", body));
    $("password").value = "";
    await session();
  } catch (e) {
    say("session", "Sign-in refused: " + e.message);
  }
});
$("logout").addEventListener("click", async () => {
  await api(() => hg.post("/api/logout", {}, state.csrf)).catch(() => null);
  await session();
});

// ---- the parts ----

async function listParts() {
  const { parts } = await get("/api/parts");
  const tbody = document.querySelector("#parts tbody");
  tbody.replaceChildren();
  for (const p of parts) {
    const released = p.released_version ? `v${p.released_version}, PLC ${p.plc_program}` : "—";
    const tr = hg.el("tr", { "data-part": p.name, class: p.name === state.name ? "selected" : "" },
      hg.el("td", { text: p.name + (p.job && p.job.state === "running" ? ` (${p.job.kind}…)` : "") }),
      hg.el("td", { class: "num", text: String(p.revision) }), hg.el("td", { text: released }));
    tr.addEventListener("click", () => selectPart(p.name));
    tbody.append(tr);
  }
  return parts;
}

async function selectPart(name) {
  state.name = name;
  state.selected = state.selectedSuggestion = state.selectedView = null;
  history.replaceState(null, "", "/parts?part=" + encodeURIComponent(name));
  for (const tr of document.querySelectorAll("#parts tr[data-part]"))
    tr.classList.toggle("selected", tr.dataset.part === name);
  $("view-panel").hidden = true;
  // What was said about the part before is not said of this one.
  for (const id of ["landmark-result", "suggest-state", "suggestion-detail", "job-state", "release-result", "part-message"])
    say(id, "", "muted");
  $("diff-result").replaceChildren();
  $("progress").style.width = "0";
  clearTimeout(state.jobTimer);
  hook.job = null;
  hook.ready = false;
  hook.part = name;
  await loadPart(true);
}

// The part: its facts, landmarks and suggestions at once, the meshes (light
// first), the views, the report and the versions after.
async function loadPart(withMeshes) {
  hook.state = "loading";
  try {
    const e = takeEarly();
    const fetched = !withMeshes ? null : e ? e.meshes : PartView.prefetch(base() + "/model.stl");
    const part = await (e ? api(() => e.part) : get(base()));
    performance.mark("parts: facts received");
    showPart(part);
    const meshes = fetched ? showMeshes(part, fetched) : Promise.resolve();
    await Promise.all([meshes, loadViews(), loadReport(), loadVersions()]);
    if (part.job && part.job.state === "running") watchJob();
    hook.ready = true;
  } catch (e) {
    hook.state = "error";
    hook.lastError = e.message;
    say("part-message", e.message, "error");
  }
}

async function reloadPart() {
  const part = await get(base());
  showPart(part);
  await Promise.all([loadViews(), loadReport(), loadVersions()]);
}

// The light mesh first (the first view), then the full one; the marks are
// drawn as soon as the part's frame is set up.
async function showMeshes(part, fetched) {
  const view = hook.view;
  say("view-status", `loading ${part.cad ? part.cad.triangles.toLocaleString("en") + " triangles" : "the part"}…`);
  const full = view.showPart({ bounds: part.cad && part.cad.bounds_mm, station: part.station }, fetched);
  drawMarks();
  await full;
  say("view-status", `${view.stats.triangles.full.toLocaleString("en")} triangles; while moving ` +
    `${view.stats.triangles.lod.toLocaleString("en")}`);
}

function drawMarks() {
  const view = hook.view;
  view.setLandmarks(state.part.draft.landmarks, state.selected);
  view.setSuggestions(state.suggestions, state.selectedSuggestion);
  view.setViews(state.views, state.selectedView);
  legend();
}

// Everything shown of the part except the meshes and what has its own request.
function showPart(part) {
  state.part = part;
  say("part-title", `${part.name} — revision ${part.revision}`);
  const row = document.querySelector(`#parts tr[data-part="${CSS.escape(part.name)}"] td.num`);
  if (row) row.textContent = String(part.revision);
  say("part-message", "", "muted");
  const facts = $("part-facts");
  facts.replaceChildren();
  const cad = part.cad || {};
  const released = part.released ? `v${part.released.version}, PLC program ${part.released.plc_program}, by ${part.released.released_by}` : "not released";
  for (const [k, v] of [["CAD", `${cad.file} (${cad.kind}, ${(cad.triangles || 0).toLocaleString("en")} triangles)`],
    ["Changed", `${part.changed_by}, ${part.changed_at}: ${part.change}`], ["Octree", octree(part.draft)],
    ["Released", released]])
    facts.append(hg.el("dt", { text: k }), hg.el("dd", { text: v }));
  if (part.released && part.released.plc_program && !$("plc-program").value) $("plc-program").value = part.released.plc_program;
  showLandmarks();
  showSuggestions();
  legend();
}

function octree(draft) {
  const o = (draft && draft.octree) || {};
  return `depth ${o.depth}, adjacency depth ${o.adjacency_depth}; new landmarks ±${draft && draft.tolerance_mm} mm`;
}

function legend() {
  const part = state.part, view = hook.view;
  const play = part && part.draft.alignment;
  const scale = part && part.draft.landmarks.length ? `× ${view.zoneScale || 1}` : "—";
  const lines = [[`tolerance zones drawn ${scale}`, "zone"],
    [`grid ${view.gridCellMm || "—"} mm`, ""],
    [play ? `nest play ±${play.max_shift_mm} mm, ±${play.max_rotation_deg}°` : "nest play —", "nest"],
    ["landmark", "pin"], ["suggested", "chosen"], ["refused", "refused"], ["view", "frustum"]];
  $("legend").replaceChildren(...lines.map(([t, cls]) => hg.el("div", {}, hg.el("span", { class: "swatch " + cls }), t)));
}

// ---- landmarks ----

function zoneText(l) {
  return Array.isArray(l.limits_mm) ? `[${l.limits_mm[0]}, ${l.limits_mm[1]}]` : `±${l.tolerance_mm}`;
}

function showLandmarks() {
  const landmarks = state.part.draft.landmarks;
  if (state.selected && !landmarks.some((l) => l.id === state.selected)) state.selected = null;
  hook.view.setLandmarks(landmarks, state.selected);
  const tbody = document.querySelector("#landmarks tbody");
  tbody.replaceChildren();
  for (const l of landmarks) {
    const tr = hg.el("tr", { "data-landmark": l.id, class: l.id === state.selected ? "selected" : "" },
      hg.el("td", { text: l.id }), hg.el("td", { text: l.on || "" }), hg.el("td", { class: "num", text: zoneText(l) }));
    tr.addEventListener("click", () => selectLandmark(l.id, true));
    tbody.append(tr);
  }
  if (!landmarks.length) tbody.append(hg.el("tr", {}, hg.el("td", { colspan: "3", class: "muted", text: "None yet: click on the part, or adopt a suggestion." })));
  showEditor();
}

function selectLandmark(id, look) {
  state.selected = id;
  showLandmarks();
  const l = state.part.draft.landmarks.find((x) => x.id === id);
  if (look && l) hook.view.lookAt(l.position, l.normal);
}

function showEditor() {
  const l = state.selected && state.part.draft.landmarks.find((x) => x.id === state.selected);
  $("landmark-edit").hidden = !l;
  if (!l) return;
  say("lm-where", `on a ${l.on || "face"} at (${l.position.map((x) => PartsReport.num(x, 5)).join(", ")}), ` +
    `normal (${l.normal.map((x) => PartsReport.num(x, 3)).join(", ")})`);
  $("lm-id").value = l.id;
  const limits = Array.isArray(l.limits_mm);
  $("lm-zone").value = limits ? "limits" : "tolerance";
  $("lm-tol").value = limits ? "" : l.tolerance_mm;
  $("lm-lo").value = limits ? l.limits_mm[0] : "";
  $("lm-hi").value = limits ? l.limits_mm[1] : "";
  zoneInputs();
}

function zoneInputs() {
  const limits = $("lm-zone").value === "limits";
  $("lm-tol-row").hidden = limits;
  $("lm-limits-row").hidden = !limits;
}

function placedText(placed, verb) {
  if (!placed) return verb;
  const moved = typeof placed.moved_mm === "number" ? placed.moved_mm.toFixed(3) : "—";
  return `${placed.id} ${verb} on ${placed.on === "edge" ? "an edge" : "a " + placed.on}, ${moved} mm from the point given`;
}

// A click on the surface: the server puts the landmark on the surface (on a
// sharp edge within the snap distance) and says where it landed.
async function addLandmark(hit) {
  if (!$("click-adds").checked) return;
  if (!state.mayChange) return say("landmark-result", "Sign in as an engineer to add landmarks.", "error");
  const position = hit.point.toArray();
  hook.lastPick = position;
  const answer = await change(base() + "/landmarks", { revision: state.part.revision, position }, "landmark-result");
  if (!answer) return;
  hook.lastPlaced = answer.placed || null;
  state.selected = answer.placed ? answer.placed.id : state.selected;
  showPart(answer);
  say("landmark-result", placedText(answer.placed, "placed"), "muted");
}

async function moveLandmark(id, position) {
  hook.lastPick = position;
  const answer = await change(`${base()}/landmarks/${encodeURIComponent(id)}`, { revision: state.part.revision, position },
    "landmark-result");
  if (!answer) return showLandmarks();  // the pin back where the draft has it
  hook.lastPlaced = answer.placed || null;
  showPart(answer);
  say("landmark-result", placedText(answer.placed, "moved"), "muted");
}

async function editLandmark(ev) {
  ev.preventDefault();
  const l = state.part.draft.landmarks.find((x) => x.id === state.selected);
  if (!l) return;
  const body = { revision: state.part.revision };
  const id = $("lm-id").value.trim();
  if (id && id !== l.id) body.new_id = id;
  if ($("lm-zone").value === "limits") body.limits_mm = [Number($("lm-lo").value), Number($("lm-hi").value)];
  else body.tolerance_mm = Number($("lm-tol").value);
  const answer = await change(`${base()}/landmarks/${encodeURIComponent(l.id)}`, body, "landmark-result");
  if (!answer) return;
  state.selected = body.new_id || l.id;
  showPart(answer);
  say("landmark-result", `${state.selected} changed.`, "muted");
}

async function removeLandmark() {
  const id = state.selected;
  const answer = await change(`${base()}/landmarks/${encodeURIComponent(id)}/remove`, { revision: state.part.revision },
    "landmark-result");
  if (!answer) return;
  state.selected = null;
  showPart(answer);
  say("landmark-result", `${id} removed.`, "muted");
}

$("landmark-edit").addEventListener("submit", editLandmark);
$("lm-remove").addEventListener("click", removeLandmark);
$("lm-zone").addEventListener("change", zoneInputs);

// ---- suggestions ----

// suggestions.json's candidates: the list itself or under `candidates`.
function candidates(s) {
  if (!s) return [];
  return Array.isArray(s) ? s : Array.isArray(s.candidates) ? s.candidates : [];
}

// suggestions.json: a refused candidate names its rule in `refused`.
function refused(c) { return !!(c.refused || c.rule) || c.chosen === false; }
function ruleOf(c) { return c.refused || c.rule || ""; }
function featureOf(c) { return c.name || c.feature || ""; }
function whyOf(c) { return c.comment || c.why || ""; }

function showSuggestions() {
  state.suggestions = candidates(state.part.suggestions);
  hook.view.setSuggestions(state.suggestions, state.selectedSuggestion);
  const tbody = document.querySelector("#suggestions tbody");
  tbody.replaceChildren();
  state.suggestions.forEach((c, k) => {
    const adopt = hg.el("button", { class: "needs-sign-in", text: "Adopt" });
    adopt.disabled = !state.mayChange;
    adopt.addEventListener("click", (ev) => { ev.stopPropagation(); adoptSuggestion(c); });
    const tr = hg.el("tr", { "data-suggestion": String(k), title: [featureOf(c), whyOf(c)].filter(Boolean).join(": "),
      class: [refused(c) ? "refused" : "chosen", k === state.selectedSuggestion ? "selected" : ""].join(" ") },
    hg.el("td", { text: String(k + 1) }), hg.el("td", { text: c.kind || "" }),
    hg.el("td", { text: c.position.map((x) => PartsReport.num(x, 4)).join(", ") }),
    hg.el("td", { text: refused(c) ? "refused: " + ruleOf(c) : "chosen" + (c.id ? " as " + c.id : "") }),
    hg.el("td", {}, adopt));
    tr.addEventListener("click", () => selectSuggestion(k));
    tbody.append(tr);
  });
  const s = state.part.suggestions;
  const notes = s && Array.isArray(s.notes) && s.notes.length ? "; " + s.notes.join("; ") : "";
  say("suggest-state", s ? `${state.suggestions.filter((c) => !refused(c)).length} chosen, ` +
    `${state.suggestions.filter(refused).length} refused` + (s.refused_by_rule ? ` (${s.refused_by_rule})` : "") + notes
    : "none yet");
}

function selectSuggestion(k) {
  state.selectedSuggestion = k;
  showSuggestions();
  const c = state.suggestions[k];
  if (!c) return say("suggestion-detail", "");
  say("suggestion-detail", `${c.kind || "candidate"} ${k + 1}${refused(c) ? ", refused by " + ruleOf(c) : ", chosen"}: ` +
    [featureOf(c), whyOf(c)].filter(Boolean).join(". "), refused(c) ? "refused-text" : "muted");
}

async function adoptSuggestion(c) {
  const answer = await change(base() + "/landmarks", { revision: state.part.revision, position: c.position }, "landmark-result");
  if (!answer) return;
  hook.lastPlaced = answer.placed || null;
  state.selected = answer.placed ? answer.placed.id : null;
  showPart(answer);
  say("landmark-result", placedText(answer.placed, "adopted"), "muted");
}

$("suggest").addEventListener("click", () => startJob("suggest", {}));

// ---- views ----

async function loadViews() {
  state.views = [];
  const tbody = document.querySelector("#views tbody");
  tbody.replaceChildren();
  if (!state.part.plan) {
    say("views-note", "No plan yet: commissioning plans the views.");
  } else {
    try {
      state.views = (await get(base() + "/views")).views || [];
      say("views-note", "Click a frustum or a row for the twin's frame of the view.");
    } catch (e) {
      say("views-note", e.message);
    }
  }
  for (const v of state.views) {
    const tr = hg.el("tr", { "data-view": String(v.index), class: v.index === state.selectedView ? "selected" : "" },
      hg.el("td", { text: String(v.index) }), hg.el("td", { text: PartsReport.pose(v.pose) }),
      hg.el("td", { text: (v.landmarks || []).join(", ") }));
    tr.addEventListener("click", () => selectView(v.index));
    tbody.append(tr);
  }
  hook.view.setViews(state.views, state.selectedView);
}

function selectView(index) {
  state.selectedView = index;
  for (const tr of document.querySelectorAll("#views tr[data-view]"))
    tr.classList.toggle("selected", Number(tr.dataset.view) === index);
  hook.view.setViews(state.views, index);
  const v = state.views.find((x) => x.index === index);
  say("view-title", `View ${index}: ${PartsReport.pose(v && v.pose)}; landmarks ${((v && v.landmarks) || []).join(", ")}`);
  $("view-panel").hidden = false;
  zoom.scale = null;
  const img = $("view-img");
  say("view-note", "rendering the twin's frame…", "muted");
  img.src = `${base()}/views/${index}.png?revision=${state.part.revision}`;
}

// The frame's zoom: fitted to the panel's width at first, then by the buttons or the wheel.
const zoom = { scale: null };
function setZoom(scale) {
  const img = $("view-img");
  if (!img.naturalWidth) return;
  // Fit: the whole frame in the panel, never enlarged.
  const frame = $("view-frame");
  const fit = Math.min(1, frame.clientWidth / img.naturalWidth, frame.clientHeight / img.naturalHeight);
  zoom.scale = Math.min(8, Math.max(fit / 2, scale === null ? fit : scale));
  img.style.width = Math.round(img.naturalWidth * zoom.scale) + "px";
  say("zoom-level", `${Math.round(zoom.scale * 100)} %`);
}
// The server renders a view's frame the first time it is asked for (the
// twin, seconds); a frame it could not render is said in its words.
$("view-img").addEventListener("load", () => { say("view-note", ""); setZoom(zoom.scale); });
$("view-img").addEventListener("error", async () => {
  const words = await fetch($("view-img").src).then((r) => r.json()).then((b) => b.error).catch(() => null);
  say("view-note", "The frame could not be shown: " + (words || "the server did not answer with a picture"), "error");
});
$("zoom-in").addEventListener("click", () => setZoom(zoom.scale * 1.5));
$("zoom-out").addEventListener("click", () => setZoom(zoom.scale / 1.5));
$("zoom-fit").addEventListener("click", () => setZoom(null));
$("view-close").addEventListener("click", () => { $("view-panel").hidden = true; });
$("view-frame").addEventListener("wheel", (ev) => {
  ev.preventDefault();
  setZoom(zoom.scale * (ev.deltaY < 0 ? 1.25 : 0.8));
}, { passive: false });

// ---- jobs: suggesting and commissioning ----

async function startJob(kind, body) {
  const where = kind === "suggest" ? "suggest-state" : "job-state";
  const answer = await change(`${base()}/${kind}`, body, where);
  if (!answer) return;
  if (answer.kind && answer.state) showJob(answer);  // the job as started (202), before the first look
  watchJob();
}

// Reads the job twice a second while it runs; when it ends, the part, its
// views and its report are read again.
function watchJob() {
  clearTimeout(state.jobTimer);
  const name = state.name;
  const look = async () => {
    if (state.name !== name) return;
    let job = null;
    try { job = await get(base() + "/job"); } catch (e) { say("job-state", e.message, "error"); }
    showJob(job);
    if (job && job.state === "running") state.jobTimer = setTimeout(look, 500);
    else if (state.name === name) { await reloadPart(); await listParts(); }
  };
  look();
}

// A commissioning job shows under "Prove on the twin" with its progress; a
// suggestion job beside its button. Either keeps both buttons until it ends
// (one job a part).
function showJob(job) {
  const running = !!job && job.state === "running";
  $("cancel").hidden = !running;
  $("commission").disabled = running || !state.mayChange;
  $("suggest").disabled = running || !state.mayChange;
  hook.job = job;
  if (!job) return;
  // A verification that does not release the draft: the report says why, not a fault.
  const notReleasable = job.state === "not_releasable";
  const status = running ? `${job.phase} ${job.done} / ${job.total}` : notReleasable ? "verified, not releasable"
    : `${job.state}${job.exit_status !== null && job.exit_status !== undefined ? " (exit status " + job.exit_status + ")" : ""}`;
  const cls = job.state === "failed" || job.state === "cancelled" ? "error" : "muted";
  if (job.kind === "suggest")
    return say("suggest-state", running ? `suggesting… ${job.phase || ""}` : status + (job.message && job.state !== "finished" ? ": " + job.message : ""), cls);
  const share = job.total ? Math.min(1, job.done / job.total) : 0;
  $("progress").style.width = (job.state === "finished" ? 100 : 100 * share).toFixed(1) + "%";
  say("job-state", `${job.kind} by ${job.started_by} at ${job.started_at}: ${status}` +
    (job.message ? " — " + job.message : ""), cls);
}

$("commission").addEventListener("click", () => startJob("commission", { seats: Number($("seats").value) || 20 }));
$("cancel").addEventListener("click", async () => {
  await change(base() + "/job/cancel", {}, "job-state");
});

// ---- the report ----

async function loadReport() {
  const box = $("report");
  if (!state.part.verified) {
    box.replaceChildren(hg.el("p", { class: "muted", text: "Not commissioned yet: the twin's verification comes here." }));
    return;
  }
  try {
    const v = await get(base() + "/verification");
    box.replaceChildren(PartsReport.report(v, state.part));
  } catch (e) {
    box.replaceChildren(hg.el("p", { class: "error", text: e.message }));
  }
}

// ---- release, versions, rollback ----

$("release").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const plc = Number($("plc-program").value);
  const answer = await change(base() + "/release", { revision: state.part.revision, plc_program: plc }, "release-result");
  if (!answer) return;
  showPart(answer);
  say("release-result", (answer.released ? `Released as version ${answer.released.version}, PLC program ` +
    `${answer.released.plc_program}` : "Released") + reloaded(answer.reload), answer.reload && !answer.reload.ok ? "error" : "status-ok");
  await Promise.all([loadVersions(), listParts()]);
});

// The daemon reads its programs again after a release or rollback; if it
// could not, the version is kept but the station still runs the old one.
function reloaded(reload) {
  if (!reload) return ".";
  return reload.ok === false ? `; the station did not load it: ${reload.error || "the daemon refused the reload"}`
    : ": the station runs it from its next cycle.";
}

async function loadVersions() {
  let versions = [];
  try { versions = (await get(base() + "/versions")).versions || []; } catch (e) { say("release-result", e.message, "error"); }
  state.versions = versions;
  const tbody = document.querySelector("#versions tbody");
  tbody.replaceChildren(...PartsReport.versionRows(versions, { rollback }));
  for (const b of tbody.querySelectorAll(".needs-sign-in")) b.disabled = !state.mayChange;
}

async function rollback(version) {
  const answer = await change(base() + "/rollback", { version }, "release-result");
  if (!answer) return;
  showPart(answer);
  say("release-result", `Version ${version} is in force again` +
    (answer.released ? ` as version ${answer.released.version}` : "") + reloaded(answer.reload),
  answer.reload && !answer.reload.ok ? "error" : "status-ok");
  await Promise.all([loadVersions(), listParts()]);
}

$("diff").addEventListener("click", async () => {
  const from = document.querySelector("input[name=diff-from]:checked");
  const to = document.querySelector("input[name=diff-to]:checked");
  if (!from || !to) return say("release-result", "Choose a version to compare from and one to compare to.", "error");
  try {
    const d = await get(`${base()}/diff?from=${encodeURIComponent(from.value)}&to=${encodeURIComponent(to.value)}`);
    $("diff-result").replaceChildren(PartsReport.diff(d));
  } catch (e) {
    $("diff-result").replaceChildren(hg.el("p", { class: "error", text: e.message }));
  }
});

// ---- upload ----

$("upload-file").addEventListener("change", () => {
  const f = $("upload-file").files[0];
  if (f && !$("upload-name").value) $("upload-name").placeholder = f.name.replace(/\.[^.]*$/, "");
});

// The CAD file's bytes as they are (application/octet-stream); a refused
// model is refused in the loader's words.
$("upload").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const file = $("upload-file").files[0];
  if (!file) return say("upload-result", "Choose a CAD file first.", "error");
  // Without a name the server names the part after the file (`part add`).
  const query = new URLSearchParams({ file: file.name });
  if ($("upload-name").value.trim()) query.set("name", $("upload-name").value.trim());
  if ($("upload-tolerance").value) query.set("tolerance", $("upload-tolerance").value);
  if ($("upload-depth").value) query.set("depth", $("upload-depth").value);
  say("upload-result", `uploading ${file.name} (${hg.bytes(file.size)})…`, "muted");
  const res = await api(() => fetch("/api/parts?" + query, { method: "POST", body: file, credentials: "same-origin",
    headers: { "Content-Type": "application/octet-stream", "X-CSRF-Token": state.csrf || "" } }))
    .catch((e) => ({ ok: false, status: 0, json: async () => ({ error: "the upload did not reach the station: " + e.message }) }));
  const answer = await res.json().catch(() => ({ error: "HTTP " + res.status }));
  if (!res.ok) {
    hook.lastError = answer.error;
    return say("upload-result", "Refused: " + (answer.error || "HTTP " + res.status), "error");
  }
  say("upload-result", `${answer.name} added: ${(answer.cad.triangles || 0).toLocaleString("en")} triangles.`, "muted");
  $("upload-name").value = "";
  await listParts();
  await selectPart(answer.name);
});

// ---- the 3D view's controls ----

function onSelect(mark) {
  if (!mark) return;
  if (mark.kind === "landmark") selectLandmark(mark.id, false);
  else if (mark.kind === "suggestion") selectSuggestion(mark.index);
  else if (mark.kind === "view") selectView(mark.index);
}

function initView() {
  hook.view = new PartView($("viewer"), {
    select: onSelect,
    surface: addLandmark,
    dragPin: moveLandmark,
    canDrag: () => state.mayChange,
    loaded: (level) => { hook.state = level; },
  });
  $("fit").addEventListener("click", () => hook.view.fit(false));
  $("fit-all").addEventListener("click", () => hook.view.fit(true));
  for (const [box, group] of [["show-views", "views"], ["show-suggestions", "suggestions"], ["show-fixture", "fixture"]])
    $(box).addEventListener("change", () => hook.view.show(group, $(box).checked));
}

// The part the address names is asked for at once, beside the session and
// the list: the first view is what the engineer waits for.
async function start() {
  try {
    initView();
    const wanted = new URLSearchParams(location.search).get("part");
    const opened = wanted ? selectPart(wanted) : null;
    const [, parts] = await Promise.all([session(), listParts(), opened]);
    if (opened && state.name === wanted && hook.state !== "error") return;
    const first = parts.find((p) => p.name === wanted) || parts[0];
    if (first) await selectPart(first.name);
    else { hook.ready = true; say("part-message", "No parts yet: add a CAD model.", "muted"); }
  } catch (e) {
    hook.lastError = e.message;
    say("error", e.message);
  }
}
start();
