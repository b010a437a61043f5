// The audit trail (docs/audit.md, "Reading and export"): every signed-in
// account reads who changed which program, file, calibration, setting or
// account, and every refused attempt; an entry opens to its before and after,
// side by side with the changed lines marked; the selection downloads as CSV.
"use strict";
hg.nav("/audit");

const $ = (id) => document.getElementById(id);
let nextBefore = null;

function query(extra = {}) {
  const q = new URLSearchParams();
  for (const [key, id] of [["since", "f-since"], ["until", "f-until"], ["who", "f-who"], ["action", "f-action"], ["outcome", "f-outcome"]]) {
    const v = $(id).value.trim();
    if (v) q.set(key, v);
  }
  for (const [k, v] of Object.entries(extra)) q.set(k, v);
  return q;
}

function showChange(e) {
  $("change").hidden = false;
  $("change-title").textContent = `${e.action} ${e.object} — ${e.who}, ${hg.localTime(e.at_unix_ms).text}`;
  const rows = $("change-rows");
  rows.replaceChildren();
  for (const r of hg.lineDiff(e.before, e.after))
    rows.append(hg.el("tr", { class: "diff-" + r.kind }, hg.el("td", { text: r.left }), hg.el("td", { text: r.right })));
  $("change").scrollIntoView({ block: "nearest" });
}

function row(e) {
  const t = hg.localTime(e.at_unix_ms);
  const tr = hg.el("tr", { class: "outcome-" + e.outcome, "data-id": String(e.id), "data-action": e.action },
    hg.el("td", { text: t.text, title: e.time }), hg.el("td", { text: e.who }), hg.el("td", { text: e.role || "—" }),
    hg.el("td", { text: e.source }), hg.el("td", { text: e.action }), hg.el("td", { text: e.object }),
    hg.el("td", { class: "outcome", text: e.outcome }), hg.el("td", { text: e.detail }));
  if (e.before || e.after) {
    tr.classList.add("has-change");
    tr.title = "show what changed";
    tr.addEventListener("click", () => showChange(e));
  }
  return tr;
}

async function load(more) {
  $("error").textContent = "";
  try {
    const extra = more && nextBefore ? { before: nextBefore } : {};
    const answer = await hg.get("/api/audit?" + query(extra));
    const tbody = document.querySelector("#trail tbody");
    if (!more) { tbody.replaceChildren(); $("change").hidden = true; }
    for (const e of answer.entries) tbody.append(row(e));
    nextBefore = answer.next_before || null;
    $("more").hidden = !nextBefore;
    $("dl-csv").href = "/api/audit?" + query({ format: "csv" });
  } catch (e) {
    document.querySelector("#trail tbody").replaceChildren();
    $("error").textContent = "The audit trail could not be read: " + e.message;
  }
}

async function session() {
  const s = await hg.get("/api/session");
  $("sign-in-card").hidden = s.signed_in;
  $("trail-view").hidden = !s.signed_in;
  $("session").textContent = s.signed_in ? "Signed in as " + hg.who(s) + "." : "";
  if (s.signed_in) await load(false);
}

$("login").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  try {
    await hg.signIn($("login-name").value.trim(), $("login-password").value);
    $("login-password").value = "";
    await session();
  } catch (e) {
    $("error").textContent = "Sign-in refused: " + e.message;
  }
});
$("filters").addEventListener("submit", (ev) => { ev.preventDefault(); load(false); });
$("more").addEventListener("click", () => load(true));
session().catch((e) => { $("error").textContent = e.message; });
