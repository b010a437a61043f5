// The part record (docs/hmi.md, "Part record"): one inspected part on a page
// made for printing — the facts, the release it was judged with, the verdict,
// every landmark and the annotated views — with the station's PDF of the same
// record (GET /api/results/{id}/record.pdf). The landmark rows follow the
// rule every page shares (docs/hmi.md, "Landmark rows"; hg.landmarkReading).
"use strict";
hg.nav("/results");


// What the test reads: the result shown, once everything is on the page.
window.hgRecord = { shown: null };

const pad = (n) => String(n).padStart(2, "0");

// The start time in this browser's zone, with the zone's name and its offset from UTC.
function localTime(ms) {
  const d = new Date(ms);
  const minutes = -d.getTimezoneOffset();
  const offset = `${minutes < 0 ? "-" : "+"}${pad(Math.floor(Math.abs(minutes) / 60))}:${pad(Math.abs(minutes) % 60)}`;
  const zone = Intl.DateTimeFormat().resolvedOptions().timeZone || "local";
  return `${d.getFullYear()}-${pad(d.getMonth() + 1)}-${pad(d.getDate())} ${pad(d.getHours())}:` +
    `${pad(d.getMinutes())}:${pad(d.getSeconds())} ${zone} (UTC${offset})`;
}

function facts(r) {
  const rows = [];
  if (r.station) rows.push(["Station", r.station, "station"]);
  rows.push(["Serial", r.serial || "(none)", "serial"], ["Part", r.part, "part"], ["Program", r.program, "program"],
    ["Program version", r.program_version == null ? "draft (no release)" : `version ${r.program_version}`, "version"]);
  if (r.program_sha256) rows.push(["Program SHA-256", r.program_sha256, "sha256"]);
  rows.push(["Time (UTC)", r.time, "time-utc"], ["Time (this browser)", localTime(r.started_unix_ms), "time-local"],
    ["Purpose", r.purpose, "purpose"], ["Trigger", `${r.manual ? "maintenance" : "PLC"}, sequence ${r.trigger_seq}`, "trigger"],
    ["Verdict", r.verdict, "verdict-text"], ["Fault code", r.fault_code === 0 ? "0 (none)" : r.fault_code, "fault"],
    ["Cycle time", `${r.cycle_ms} ms`, "cycle"], ["Landmarks failed", `${r.landmarks_failed} of ${r.landmarks_total}`, "failed"]);
  const dl = document.getElementById("facts");
  for (const [k, v, id] of rows)
    dl.append(hg.el("dt", { text: k }), hg.el("dd", { id: "f-" + id, class: id === "sha256" ? "mono" : "", text: String(v) }));
}

// The seat the station measured in the nest (docs/alignment.md), when the cycle measured one.
function alignment(a) {
  if (!a || typeof a !== "object") return;
  const rows = a.measured === false ? [["Seat", "not measured" + (a.message ? ": " + a.message : "")]]
    : [["Seat shift", `${hg.mm(a.shift_mm)} mm (U ${hg.mm(a.shift_uncertainty_mm)} mm)`],
      ["Seat rotation", `${hg.mm(a.rotation_deg, 3)}° (U ${hg.mm(a.rotation_uncertainty_deg, 3)}°)`]];
  if (a.measured !== false && typeof a.residual_px === "number") rows.push(["Residual", `${hg.mm(a.residual_px, 2)} px`]);
  if (a.measured !== false && typeof a.within_limits === "boolean")
    rows.push(["Within the nest's limits", a.within_limits ? "yes" : "no"]);
  const dl = document.getElementById("alignment");
  for (const [k, v] of rows) dl.append(hg.el("dt", { text: k }), hg.el("dd", { text: v }));
  document.getElementById("alignment-section").hidden = false;
}

// Every landmark with one reading (docs/hmi.md, "Landmark rows", the rule every page shares):
// its deviation with U and decision, or its voxel bracket with why, and an inspection fault named.
function landmarkTable(landmarks) {
  const table = hg.el("table", { class: "landmarks" });
  const head = hg.el("tr");
  for (const [h, cls] of [["Landmark", ""], ["Status", ""], ["Reading", "num"], ["Decision or reason", ""], ["Zone mm", "num"]])
    head.append(hg.el("th", { class: cls, text: h }));
  table.append(hg.el("thead", {}, head));
  const body = hg.el("tbody");
  for (const l of landmarks) {
    const r = hg.landmarkReading(l);
    const zone = l.limits_mm ? `[${hg.mm(l.limits_mm[0])}, ${hg.mm(l.limits_mm[1])}]` : `±${hg.mm(l.tolerance_mm)}`;
    const tr = hg.el("tr", { "data-landmark": l.id, "data-status": l.status, "data-reading": r.kind,
      class: r.fault ? "inspection-fault" : "" });
    tr.append(hg.el("td", { text: l.id }),
      hg.el("td", { class: hg.statusClass(l.status), text: hg.statusWords[l.status] || l.status }),
      hg.el("td", { class: "num", text: r.text }),
      hg.el("td", { text: r.fault || r.note }),
      hg.el("td", { class: "num", text: zone }));
    body.append(tr);
  }
  table.append(body);
  return table;
}

function views(r) {
  const box = hg.el("div", { class: "record-images" });
  for (const name of r.image_files || [])
    box.append(hg.el("figure", {}, hg.el("img", { src: `/api/results/${r.id}/images/${name}`, alt: name }),
      hg.el("figcaption", { text: name })));
  if (!box.children.length) box.append(hg.el("p", { class: "muted", text: "No images archived for this part." }));
  return box;
}

// The station, serial and time at the top of every printed page: CSS paged media's margin boxes
// (a browser without them prints the first page's facts only). A constructed style sheet, not a
// <style> element: the HMI's Content-Security-Policy refuses inline styles (docs/hmi.md, "Security").
function runningHeader(r) {
  const css = (s) => '"' + String(s).replace(/[\\"]/g, "\\$&").replace(/\n/g, " ") + '"';
  const box = "font: 8pt 'DejaVu Sans', Arial, sans-serif; color: #000;";
  const sheet = new CSSStyleSheet();
  sheet.replaceSync(`@media print { @page {
    @top-left { content: ${css(r.station ? "Station " + r.station : "")}; ${box} }
    @top-center { content: ${css("Serial " + (r.serial || "(none)"))}; ${box} font-weight: bold; }
    @top-right { content: ${css(r.time)}; ${box} }
    @bottom-right { content: "page " counter(page) " of " counter(pages); ${box} } } }`);
  document.adoptedStyleSheets = [...document.adoptedStyleSheets, sheet];
  window.hgRecord.runningHeader = [...sheet.cssRules].map((rule) => rule.cssText).join("\n");
}

async function show() {
  const id = new URLSearchParams(location.search).get("id");
  try {
    if (!/^[0-9]+$/.test(id || "")) throw new Error("no result id given");
    const r = await hg.get(`/api/results/${id}`);
    document.title = `hullgauge — part record ${r.id} ${r.serial}`;
    document.getElementById("title").textContent = `Part record ${r.id}`;
    document.getElementById("subtitle").textContent = `${r.part}, serial ${r.serial || "(none)"}`;
    const v = document.getElementById("verdict");
    v.textContent = r.verdict.toUpperCase();
    v.className = "record-verdict " + r.verdict;
    document.getElementById("pdf").href = `/api/results/${r.id}/record.pdf`;
    document.getElementById("result-link").href = `/result?id=${r.id}`;
    facts(r);
    alignment(r.alignment);
    document.getElementById("landmarks-title").textContent = `Landmarks (${r.landmarks.length})`;
    document.getElementById("landmarks").replaceChildren(landmarkTable(r.landmarks));
    document.getElementById("images").replaceChildren(views(r));
    runningHeader(r);
    window.hgRecord.shown = r.id;
  } catch (e) {
    document.getElementById("error").textContent = e.message;
  }
}
document.getElementById("print").addEventListener("click", () => window.print());
show();
