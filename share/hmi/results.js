// The results page (docs/hmi.md, "Results"): search by serial, program,
// verdict, purpose and time; pages of 50 through /api/results; each row links
// to its result page.
"use strict";
hg.nav("/results");

let nextBefore = null;
// Loads answered out of order (the page's first load and a search sent right
// after it) must not overwrite a newer selection's rows: only the latest counts.
let latestLoad = 0;

function selection() {
  const params = new URLSearchParams();
  for (const name of ["serial", "program", "verdict", "purpose", "since", "until"]) {
    const v = document.getElementById("f-" + name).value.trim();
    if (v && v !== "any") params.set(name, v);
  }
  return params;
}

function row(r) {
  const tr = hg.el("tr", { "data-id": String(r.id) });
  const link = hg.el("a", { href: `/result?id=${r.id}`, text: String(r.id) });
  tr.append(hg.el("td", {}, link), hg.el("td", { text: r.time }), hg.el("td", { class: "serial", text: r.serial }),
    hg.el("td", { text: String(r.program) }), hg.el("td", { class: r.verdict === "pass" ? "status-ok" : "status-bad", text: r.verdict }),
    hg.el("td", { text: r.purpose }), hg.el("td", { class: "num", text: String(r.cycle_ms) }),
    hg.el("td", { text: r.failed_landmarks.join(", ") }));
  return tr;
}

async function load(append) {
  const mine = ++latestLoad;
  const params = selection();
  if (append && nextBefore) params.set("before", nextBefore);
  try {
    const body = await hg.get("/api/results?" + params.toString());
    if (mine !== latestLoad) return;
    const tbody = document.querySelector("#results tbody");
    if (!append) tbody.replaceChildren();
    for (const r of body.results) tbody.append(row(r));
    nextBefore = body.next_before ?? null;
    document.getElementById("more").hidden = nextBefore === null;
    document.getElementById("error").textContent = body.results.length || append ? "" : "No results match.";
    const exportParams = selection();
    exportParams.delete("serial");
    for (const f of ["csv", "aqdef", "json"]) {
      exportParams.set("format", f);
      document.getElementById("dl-" + f).href = "/api/export?" + exportParams.toString();
    }
  } catch (e) {
    if (mine === latestLoad) document.getElementById("error").textContent = e.message;
  }
}

document.getElementById("filters").addEventListener("submit", (ev) => { ev.preventDefault(); load(false); });
document.getElementById("more").addEventListener("click", () => load(true));
const initial = new URLSearchParams(location.search);
for (const [k, v] of initial) { const e = document.getElementById("f-" + k); if (e) e.value = v; }
load(false);
