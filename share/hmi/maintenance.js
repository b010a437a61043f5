// The line engineer's page (docs/hmi.md, "Maintenance"): calibration status
// and history, the last camera snapshot, the station's health (a chart per
// figure with its limit, the latest figures in words, docs/health.md), the
// mastering run (its progress and the set it put in force, docs/mastering.md), the
// part programs and their view plans for everyone; the state-changing actions (a snapshot among them) only
// in a signed-in session whose role allows them (docs/audit.md), each carrying
// its CSRF token. The server checks every request; the page only leaves out
// what the role may not do.
"use strict";
hg.nav("/maintenance");

let csrf = null;

function say(id, text) { document.getElementById(id).textContent = text; }

async function session() {
  const s = await hg.get("/api/session");
  csrf = s.csrf || null;
  const may = s.signed_in ? s.may : {};
  document.getElementById("login").hidden = !s.configured || s.signed_in;
  document.getElementById("actions").hidden = !may.operate;
  document.getElementById("snapshot-actions").hidden = !may.operate;
  document.getElementById("calibrate-actions").hidden = !may.calibration;
  document.getElementById("flat-field-actions").hidden = !may.calibration;
  document.getElementById("mastering-actions").hidden = !may.calibration;
  document.getElementById("settings-actions").hidden = !may.settings;
  document.getElementById("logout-line").hidden = !s.signed_in;
  say("session", !s.configured ? "Maintenance over HTTP is not configured on this station."
    : !s.signed_in ? "Read-only: sign in for maintenance actions."
    : "Signed in as " + hg.who(s) + "." + (may.operate ? "" : " An operator watches: no maintenance actions."));
}

async function act(body) {
  try {
    const answer = await hg.post("/api/maintenance", body, csrf);
    say("action-result", JSON.stringify(answer));
  } catch (e) {
    say("action-result", "Refused: " + e.message);
  }
}

function record(r, keys) {
  if (!r) return "—";
  return keys.filter((k) => r[k] !== undefined && r[k] !== null)
    .map((k) => `${k} ${typeof r[k] === "number" ? Number(r[k].toPrecision(4)) : r[k]}`).join(", ");
}

function showHistory(history) {
  const tbody = document.querySelector("#calibration-history tbody");
  tbody.replaceChildren();
  for (const h of history || [])
    tbody.append(hg.el("tr", { "data-file": h.file }, hg.el("td", { text: h.file }),
      hg.el("td", { text: h.error ? "unreadable: " + h.error : record(h.camera, ["method", "rms_px", "views", "date"]) }),
      hg.el("td", { text: h.error ? "" : record(h.fixture, ["rms_px", "rms_mm", "axes_angle_deg", "axes_distance_mm", "views", "date"]) })));
}

function pose(v) {
  return v.rail_mm !== undefined ? `rail ${v.rail_mm} mm` : `${Number(v.rotation_deg.toFixed(1))}° / ${Number(v.declination_deg.toFixed(1))}°`;
}

// The snapshot's figures and picture; `shownSnapshot` keeps the picture from reloading on every look.
let shownSnapshot = null;
window.hgMaintenance = { snapshotShown: null, health: null };
function showSnapshot(s) {
  if (!s || s.state === undefined) return;
  say("snapshot-error", s.state === "failed" ? "Snapshot failed: " + s.error : "");
  if (s.id === undefined) { say("snapshot-facts", s.state); return; }
  const seg = s.segmentation || {};
  const dl = document.getElementById("snapshot-facts");
  dl.replaceChildren();
  for (const [k, v] of [["State", s.state], ["Frame", `${s.id} at ${s.time}`], ["Size", `${s.width} × ${s.height}, ${s.depth_bits} bit`],
    ["Pose", s.pose ? pose(s.pose) : "as it was"], ["Segmentation", `${seg.method}, threshold ${Number(seg.threshold).toFixed(0)}`],
    ["Object", `${(100 * s.object_fraction).toFixed(2)} % of the frame`],
    ["Grey", `backlight ${s.backlight_grey}, object ${s.object_grey}`], ["Grab", `${s.grab_ms.toFixed(1)} ms`]])
    dl.append(hg.el("dt", { text: k }), hg.el("dd", { text: v }));
  if (s.id !== shownSnapshot) {
    shownSnapshot = s.id;
    const img = document.getElementById("snapshot-img");
    img.src = `/api/snapshot.png?frame=${s.id}`;
    img.hidden = false;
    window.hgMaintenance.snapshotShown = s.id;
  }
}

async function grab() {
  const body = { command: "snapshot", grab: true };
  const r = document.getElementById("snap-rotation").value, d = document.getElementById("snap-declination").value;
  if (r !== "") body.rotation_deg = Number(r);
  if (d !== "") body.declination_deg = Number(d);
  try {
    let s = (await hg.post("/api/maintenance", body, csrf)).snapshot;
    showSnapshot(s);
    // The grab runs between cycles: look again until it is done (bounded: a stuck station shows its state).
    for (let i = 0; i < 120 && (s.state === "queued" || s.state === "running"); ++i) {
      await new Promise((resolve) => setTimeout(resolve, 250));
      s = (await hg.get("/api/snapshot")).snapshot;
      showSnapshot(s);
    }
  } catch (e) {
    say("snapshot-error", "Refused: " + e.message);
  }
}

// ---- the station's health (docs/health.md, "In the daemon") ----

const healthCharts = {};
const RED = "#c62828", BLUE = "#4a78a8", GREY = "#8a949c";

function capitalised(text) { return text ? text[0].toUpperCase() + text.slice(1) : text; }

// The latest figures in words with their state, the warnings highlighted.
function showHealthNow(now) {
  const list = document.getElementById("health-latest");
  list.replaceChildren();
  if (!now || !now.enabled) { say("health-reference", "The station's health is not watched (health.enabled: false)."); return; }
  const r = now.reference;
  say("health-reference", r ? `Flat-field reference taken ${hg.localTime(r.time).text} (mean level ${r.level_mean.toFixed(3)} of full scale, ${r.dust_specks} specks of its own), ${r.file}.`
    : `No flat-field reference yet (${now.reference_file}): the backlight, its uniformity and dust are not measured until one is taken.`);
  if (!now.states) { list.append(hg.el("li", { class: "unmeasured", text: "No cycle examined since the daemon started." })); return; }
  for (const st of now.states)
    list.append(hg.el("li", { "data-figure": st.figure, class: st.within === false ? "beyond" : st.within === null ? "unmeasured" : "within",
      text: (st.within === false ? "⚠ " : "") + capitalised(st.sentence) }));
}

function showFlatField(f) {
  if (!f || !f.state) { say("flat-field-state", ""); return; }
  const grabbed = f.grabbed !== undefined ? `, ${f.grabbed} of ${f.frames} frames` : "";
  say("flat-field-state", `Flat-field reference: ${f.state}${grabbed}` + (f.error ? ` — ${f.error}` : "")
    + (f.state === "done" && f.reference ? ` (taken ${hg.localTime(f.reference.time).text}, written to ${f.file})` : ""));
}

// One chart per figure: its values over the window, the limit as a line, the values beyond it in red.
function healthChart(state, rows) {
  const id = "health-chart-" + state.key;
  const points = rows.filter((r) => r[state.key] !== null).map((r) => ({ x: r.unix_ms, y: r[state.key], id: r.inspection_id }));
  const beyond = (y) => (state.magnitude ? Math.abs(y) > state.limit : state.minimum ? y < state.limit : y > state.limit);
  let box = document.getElementById("health-box-" + state.key);
  if (!box) {
    box = hg.el("div", { id: "health-box-" + state.key, "data-figure": state.figure },
      hg.el("h3", { text: capitalised(state.figure.replace("_", " ")) }), hg.el("canvas", { id, height: "130" }));
    document.getElementById("health-charts").append(box);
  }
  box.querySelector("h3").className = state.within === false ? "beyond" : "";
  box.querySelector("h3").textContent = capitalised(state.figure.replace("_", " ")) + (points.length ? "" : ": no values in the window");
  if (healthCharts[id]) healthCharts[id].destroy();
  const xs = points.map((p) => p.x);
  const x0 = xs.length ? Math.min(...xs) : Date.now() - 3600e3, x1 = xs.length ? Math.max(...xs, x0 + 1) : Date.now();
  const datasets = [{ label: state.figure, data: points, type: "line", borderColor: BLUE, borderWidth: 1,
      pointRadius: points.map((p) => (beyond(p.y) ? 4 : 2)), pointBackgroundColor: points.map((p) => (beyond(p.y) ? RED : BLUE)) },
    { label: "limit", data: [{ x: x0, y: state.limit }, { x: x1, y: state.limit }], type: "line", borderColor: RED,
      borderDash: [6, 4], pointRadius: 0, borderWidth: 1.5 }];
  // A figure judged on its size either way (the edge bias) has its limit on both sides.
  if (state.magnitude)
    datasets.push({ label: "limit below", data: [{ x: x0, y: -state.limit }, { x: x1, y: -state.limit }], type: "line",
      borderColor: RED, borderDash: [6, 4], pointRadius: 0, borderWidth: 1.5 });
  healthCharts[id] = new Chart(document.getElementById(id), { type: "line", data: { datasets },
    options: { animation: false, parsing: false, plugins: { legend: { display: false } },
      scales: { x: { type: "linear", min: x0, max: x1, ticks: { maxTicksLimit: 4, callback: (v) => hg.localTime(v).text } },
        y: { type: "linear", title: { display: true, text: state.key } } } } });
  return { figure: state.figure, points: points.length, limit: state.limit, beyond: points.filter((p) => beyond(p.y)).length };
}

async function showHealth() {
  const params = new URLSearchParams();
  const since = document.getElementById("health-since").value.trim(), until = document.getElementById("health-until").value.trim();
  if (since) params.set("since", since);
  if (until) params.set("until", until);
  try {
    const h = await hg.get("/api/health" + (params.toString() ? "?" + params : ""));
    say("health-error", "");
    showHealthNow(h.now);
    showFlatField(h.now && h.now.flat_field);
    const shown = [];
    for (const st of (h.now && h.now.states) || (h.now ? defaultStates(h.now.limits) : [])) shown.push(healthChart(st, h.rows));
    window.hgMaintenance.health = { cycles: h.cycles, charts: shown, warnings: h.now ? h.now.warnings : [] };
  } catch (e) {
    for (const id of Object.keys(healthCharts)) { healthCharts[id].destroy(); delete healthCharts[id]; }
    document.getElementById("health-charts").replaceChildren();
    document.getElementById("health-latest").replaceChildren();
    say("health-error", "Station health: " + e.message);
    window.hgMaintenance.health = { error: e.message };
  }
}

// Before the first examined cycle the charts still show the stored figures with the configured limits.
function defaultStates(limits) {
  const rules = [["backlight", "backlight", true], ["uniformity", "uniformity", false], ["dust", "dust_specks", false],
    ["focus", "edge_width_px", false], ["contrast", "contrast", true], ["noise", "noise", false],
    ["edge_bias", "edge_bias_px", false, true], ["capability", "capability", false]];
  return rules.map(([figure, key, minimum, magnitude]) =>
    ({ figure, key, minimum, magnitude: !!magnitude, limit: limits[key], within: null }));
}

async function takeFlatField() {
  const frames = Number(document.getElementById("ff-frames").value);
  try {
    let f = (await hg.post("/api/maintenance", { command: "flat-field", take: true, frames }, csrf)).flat_field;
    showFlatField(f);
    // The grabs run between cycles: look again until it is done (bounded: a stuck station shows its state).
    for (let i = 0; i < 240 && (f.state === "queued" || f.state === "running"); ++i) {
      await new Promise((resolve) => setTimeout(resolve, 250));
      f = (await hg.get("/api/health")).now.flat_field;
      showFlatField(f);
    }
    await showHealth();
  } catch (e) {
    say("flat-field-state", "Refused: " + e.message);
  }
}

// ---- the mastering run (docs/mastering.md, "The mastering run") ----

function mm(v) { return Number(v).toFixed(4); }

// The sets in force, the last run's state and progress, and the set it computed: per landmark the offset ± U_corr.
function showMastering(m) {
  window.hgMaintenance.mastering = m || null;
  if (!m) return;
  const sets = Object.entries(m.sets || {}).map(([p, id]) => `program ${p}: ${id}`);
  say("mastering-sets", (m.folder ? `Sets in force (${m.folder}): ` : "No mastering.folder: the daemon keeps no correction set. ")
    + (sets.length ? sets.join("; ") : m.folder ? "none" : ""));
  const r = m.run;
  if (!r) { say("mastering-state", "No mastering run since the daemon started."); return; }
  const at = r.state === "running" ? `, ${r.step}: master cycle ${r.cycle} of ${r.cycles}` : "";
  say("mastering-state", `Mastering run of program ${r.program} with master ${r.master} by ${r.by}: ${r.state}${at}`
    + (r.error ? ` — ${r.error}` : "") + `; the purpose back to ${r.purpose_before} at its end.`);
  const list = document.getElementById("mastering-progress");
  list.replaceChildren(...(r.progress || []).map((line) => hg.el("li", { text: line })));
  const table = document.getElementById("mastering-result");
  table.hidden = !r.set;
  if (!r.set) return;
  say("mastering-result-caption", `Correction set ${r.set.id} (${r.set.method})` + (r.state === "done" ? ", in force" : "") + `, ${r.set.file}`);
  table.querySelector("tbody").replaceChildren(...r.set.landmarks.map((l) => hg.el("tr", { "data-landmark": l.id },
    hg.el("td", { text: l.id }), hg.el("td", { class: "num offset", text: mm(l.offset_mm) }),
    hg.el("td", { class: "num uncertainty", text: mm(l.uncertainty_mm) }), hg.el("td", { class: "num", text: Number(l.gain).toFixed(5) }),
    hg.el("td", { class: "num", text: mm(l.spread_mm) }), hg.el("td", { class: "num", text: String(l.cycles) }))));
}

async function lookAtMastering() {
  const s = await hg.get("/api/status");
  showMastering(s.mastering);
  return s.mastering && s.mastering.run;
}

async function runMaster() {
  const file = document.getElementById("master-certificate").files[0];
  if (!file) { say("mastering-state", "Choose the master's certificate (YAML) first."); return; }
  const body = { command: "master", program: Number(document.getElementById("master-program").value),
    run: Number(document.getElementById("master-cycles").value), certificate: await file.text(), certificate_file: file.name };
  const material = document.getElementById("master-material").value.trim();
  if (material) body.material = material;
  try {
    let r = (await hg.post("/api/maintenance", body, csrf)).run;
    // The run follows its cycles: look again until it ends (bounded by the run's own timeouts on the daemon).
    while (r && r.state === "running") {
      await new Promise((resolve) => setTimeout(resolve, 500));
      r = await lookAtMastering();
    }
    await lookAtMastering();
  } catch (e) {
    say("mastering-state", "Refused: " + e.message);
  }
}

async function cancelMaster() {
  try {
    await hg.post("/api/maintenance", { command: "master", cancel: true }, csrf);
    await lookAtMastering();
  } catch (e) {
    say("mastering-state", "Refused: " + e.message);
  }
}

async function show() {
  try {
    const c = await hg.get("/api/calibration");
    say("calibration", c.calibration ? JSON.stringify(c.calibration, null, 2)
      : "No calibration has run since the daemon started; the history below holds the station file's.");
    showHistory(c.history);
    showSnapshot((await hg.get("/api/snapshot")).snapshot);
    await showHealth();
    await lookAtMastering();
    const p = await hg.get("/api/programs");
    const tbody = document.querySelector("#programs tbody");
    for (const prog of p.programs)
      tbody.append(hg.el("tr", {}, hg.el("td", { text: String(prog.number) }), hg.el("td", { text: prog.part }),
        hg.el("td", { text: prog.views_file }), hg.el("td", { class: "num", text: String(prog.views.length) }),
        hg.el("td", { text: prog.views.map(pose).join(" · ") }), hg.el("td", { text: prog.force ? "yes" : "no" })));
    await session();
  } catch (e) {
    say("error", e.message);
  }
}

document.getElementById("login").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  try {
    const answer = await hg.signIn(document.getElementById("login-name").value.trim(), document.getElementById("password").value);
    csrf = answer.csrf;
    document.getElementById("password").value = "";
    await session();
  } catch (e) {
    say("session", "Sign-in refused: " + e.message);
  }
});
document.getElementById("set-purpose").addEventListener("click", () => act({ command: "purpose", purpose: document.getElementById("purpose").value }));
document.getElementById("trigger").addEventListener("click", () => act({ command: "trigger",
  program: Number(document.getElementById("trigger-program").value), serial: document.getElementById("trigger-serial").value }));
document.getElementById("abort").addEventListener("click", () => act({ command: "abort" }));
document.getElementById("calibrate").addEventListener("click", () => act({ command: "calibrate",
  pattern: document.getElementById("cal-pattern").value.trim(), poses: document.getElementById("cal-poses").value.trim() }));
document.getElementById("reload").addEventListener("click", () => act({ command: "reload" }));
document.getElementById("grab").addEventListener("click", grab);
document.getElementById("flat-field").addEventListener("click", takeFlatField);
document.getElementById("master-run").addEventListener("click", runMaster);
document.getElementById("master-cancel").addEventListener("click", cancelMaster);
document.getElementById("health-window").addEventListener("submit", (ev) => { ev.preventDefault(); showHealth(); });
document.getElementById("logout").addEventListener("click", async () => { await hg.post("/api/logout", {}, csrf); await session(); });
show();
