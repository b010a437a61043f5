// The line engineer's page (docs/hmi.md, "Maintenance"): calibration status
// and history, the last camera snapshot, the part programs and their view
// plans for everyone; the state-changing actions (a snapshot among them) only
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
window.hgMaintenance = { snapshotShown: null };
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

async function show() {
  try {
    const c = await hg.get("/api/calibration");
    say("calibration", c.calibration ? JSON.stringify(c.calibration, null, 2)
      : "No calibration has run since the daemon started; the history below holds the station file's.");
    showHistory(c.history);
    showSnapshot((await hg.get("/api/snapshot")).snapshot);
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
document.getElementById("logout").addEventListener("click", async () => { await hg.post("/api/logout", {}, csrf); await session(); });
show();
