// The Parts page's tables of proof and release (docs/workbench.md): the
// verification report of the twin (verification.json, docs/commissioning.md
// "The report") with its failing cells explained in the findings' words, the
// released versions and the difference between two of them.
"use strict";

const PartsReport = (() => {
  const el = hg.el;
  const TESTS = { capability: "capability", observable: "observable", false_reject: "false rejects",
    defect: "seeded defect", prediction: "U prediction", in_frame: "part in frame", seating: "seating" };

  function num(v, digits = 4) { return typeof v === "number" ? String(Number(v.toPrecision(digits))) : "—"; }

  function pose(p) {
    if (!p) return "—";
    if (p.rail_mm !== undefined && p.rotation_deg === undefined) return `rail ${num(p.rail_mm)} mm`;
    return `${num(p.rotation_deg, 3)}° / ${num(p.declination_deg, 3)}°`;
  }

  // The findings by subject and test, for the cells they explain.
  function findingsBySubject(findings) {
    const by = {};
    for (const f of findings || []) ((by[f.subject] = by[f.subject] || {})[f.test] = f);
    return by;
  }

  function explain(f) { return f ? `${f.what}; fix: ${f.fix}` : ""; }

  // A cell failing its test is marked and carries the finding in its
  // tooltip; one the numbers fail without a finding of its own (a
  // consequence of another: a landmark the station cannot prove is never
  // accepted) says what the numbers say.
  function cell(text, finding, failing, why) {
    const td = el("td", { class: "num", text });
    if (finding || failing) {
      td.classList.add("cell-fail");
      td.title = finding ? explain(finding) : why;
      td.dataset.test = finding ? finding.test : "numbers";
    }
    return td;
  }

  function summary(v, part) {
    const dl = el("dl", { class: "kv" });
    const rows = [
      ["Verdict", v.released ? "releasable: every test passed" : "not releasable: see the findings below"],
      ["Nominal part", `accepted in ${v.nominal_passed} of ${v.nominal_cycles} cycles (false reject rate ${num(100 * v.false_reject_rate, 3)} %)`],
      ["Seats", `${v.seats}, play ±${num(v.seat_play && v.seat_play.shift_mm)} mm, ±${num(v.seat_play && v.seat_play.rotation_deg)}°; seating faults ${v.seating_faults}`],
      ["Defects seeded", `${(v.defect_multiples || []).join(", ")} × tolerance; release needs ${v.release_multiple} × caught`],
      ["Cycle time", v.cycle_time_s ? `planned ${num(v.cycle_time_s.planned, 3)} s, on the twin ${num(v.cycle_time_s.twin_median, 3)} s median` : "—"],
    ];
    if (part && part.verified && (part.verified.stale || part.verified.revision !== part.revision))
      rows.unshift(["Stale", `this report is of revision ${part.verified.revision}; the draft is at ${part.revision}: commission again before releasing`]);
    for (const [k, text] of rows) {
      const cls = k === "Verdict" ? (v.released ? "status-ok" : "status-bad") : k === "Stale" ? "error" : "";
      dl.append(el("dt", { text: k }), el("dd", { class: cls, text }));
    }
    return dl;
  }

  function landmarkRow(l, v, found) {
    const f = found[l.id] || {};
    const tol = l.tolerance_mm;
    const caught = l.smallest_caught_multiple;
    const caughtText = typeof caught === "number" ? `${num(caught)} × (${num(caught * tol)} mm)` : "none caught";
    const tr = el("tr", { "data-landmark": l.id });
    const seats = `${l.seats} seats`;
    tr.append(el("td", { text: l.id }), el("td", { class: "num", text: "±" + num(tol) }),
      cell(`${l.observable_seats} / ${l.seats}`, f.observable, l.observable_seats < l.seats,
        `not observable at ${l.seats - l.observable_seats} of ${seats}`),
      cell(`${l.accepted_seats} / ${l.seats}`, null, l.accepted_seats < l.seats,
        `the nominal part not accepted at ${l.seats - l.accepted_seats} of ${seats}`),
      cell(String(l.false_rejects), f.false_reject, l.false_rejects > 0, `the nominal part rejected at ${l.false_rejects} of ${seats}`),
      cell(num(l.predicted_u_mm), f.capability, false, ""),
      cell(`${num(l.measured_u_max_mm)} (${num(l.measured_u_median_mm)})`, f.prediction, false, ""),
      cell(num(l.u_ratio, 3), f.prediction, l.u_ratio > v.uncertainty_ratio_limit,
        `U measured is ${num(l.u_ratio, 3)} × the prediction, above ${num(v.uncertainty_ratio_limit)}`),
      cell(caughtText, f.defect, !(caught <= v.release_multiple),
        `the release multiple ${num(v.release_multiple)} × tolerance is not reliably caught`),
      el("td", { class: l.passed ? "status-ok" : "status-bad", text: l.passed ? "passed" : "fails" }));
    return tr;
  }

  function landmarkTable(v, found) {
    const table = el("table", { id: "report-landmarks" });
    const head = el("tr");
    for (const h of ["Landmark", "Tolerance mm", "Observable seats", "Accepted seats", "False rejects",
      "U predicted mm", "U measured max (median) mm", "U ratio", "Smallest defect caught", "Verdict"])
      head.append(el("th", { text: h }));
    table.append(el("thead", {}, head));
    const body = el("tbody");
    for (const l of v.landmarks || []) body.append(landmarkRow(l, v, found));
    table.append(body);
    return table;
  }

  function viewTable(v, found) {
    const table = el("table", { id: "report-views" });
    const head = el("tr");
    for (const h of ["View", "Pose", "Planned landmarks", "Smallest frame margin px"]) head.append(el("th", { text: h }));
    table.append(el("thead", {}, head));
    const body = el("tbody");
    for (const view of v.views || []) {
      const f = (found[view.id] || {}).in_frame;
      body.append(el("tr", { "data-view": view.id }, el("td", { text: view.id }), el("td", { text: pose(view.pose) }),
        el("td", { text: (view.landmarks || []).join(", ") }),
        cell(num(view.min_frame_margin_px, 3), f, view.min_frame_margin_px < 1)));
    }
    table.append(body);
    return table;
  }

  function findingList(findings) {
    if (!findings || !findings.length) return el("p", { class: "status-ok", text: "No findings: every landmark and view passed every test." });
    const ul = el("ul", { class: "findings", id: "findings" });
    for (const f of findings)
      ul.append(el("li", { "data-subject": f.subject, "data-test": f.test },
        el("strong", { text: `${f.subject} — ${TESTS[f.test] || f.test}: ` }), `${f.what}. `,
        el("em", { text: `Fix: ${f.fix}.` })));
    return ul;
  }

  // The whole report of a verification (docs/commissioning.md, "The report").
  function report(v, part) {
    const found = findingsBySubject(v.findings);
    return el("div", {}, summary(v, part), el("h3", { text: "Landmarks" }),
      el("p", { class: "muted", text: "A marked cell fails its release test; hover it for the finding. U: the expanded measurement uncertainty; the ratio is measured over predicted (limit " + num(v.uncertainty_ratio_limit) + ")." }),
      landmarkTable(v, found), el("h3", { text: "Findings" }), findingList(v.findings),
      el("h3", { text: "Views" }), viewTable(v, found));
  }

  // ---- versions and their difference ----

  function versionRow(v, handlers, checked) {
    const tr = el("tr", { "data-version": String(v.version) });
    const radio = (name) => {
      const r = el("input", { type: "radio", name, value: String(v.version) });
      r.checked = checked[name] === String(v.version);
      return el("td", {}, r);
    };
    const roll = el("button", { class: "needs-sign-in", text: "Roll back to it" });
    roll.addEventListener("click", () => handlers.rollback(v.version));
    tr.append(radio("diff-from"), radio("diff-to"), el("td", { class: "num", text: String(v.version) }),
      el("td", { text: v.released_by || "" }), el("td", { text: v.released_at || "" }),
      el("td", { class: v.in_force ? "status-ok" : "", text: v.in_force ? "in force" : "" }),
      el("td", { text: v.rolled_back_from ? "v" + v.rolled_back_from : "" }), el("td", {}, v.in_force ? "" : roll));
    return tr;
  }

  // The draft, then the versions, newest first, to compare any two.
  function versionRows(versions, handlers) {
    const sorted = versions.slice().sort((a, b) => b.version - a.version);
    const checked = { "diff-from": sorted[1] ? String(sorted[1].version) : sorted[0] ? String(sorted[0].version) : "",
      "diff-to": sorted.length > 1 ? String(sorted[0].version) : "draft" };
    const rows = sorted.map((v) => versionRow(v, handlers, checked));
    const draft = versionRow({ version: "draft", in_force: true }, handlers, checked);
    draft.querySelector("td:nth-child(3)").textContent = "draft";
    draft.querySelector("td:nth-child(5)").textContent = "being edited";
    draft.querySelector("td:nth-child(6)").textContent = "";
    return [draft, ...rows];
  }

  // One changed landmark as `hullgauge part diff --json` gives it: moved by,
  // normal turned by (0 when not), its zone before and after as text.
  function landmarkChange(c) {
    const parts = [];
    if (c.moved_mm > 0) parts.push(`moved ${num(c.moved_mm)} mm`);
    if (c.normal_turned_deg > 0) parts.push(`normal turned ${num(c.normal_turned_deg, 3)}°`);
    for (const key of ["tolerance", "tolerance_mm", "limits_mm"])
      if (c[key] && typeof c[key] === "object" && "from" in c[key])
        parts.push(`zone ${zoneText(c[key].from)} → ${zoneText(c[key].to)}`);
    if (c.best_views_changed) parts.push("best views changed");
    const known = ["id", "moved_mm", "normal_turned_deg", "tolerance", "tolerance_mm", "limits_mm", "best_views_changed"];
    for (const [k, val] of Object.entries(c)) if (!known.includes(k)) parts.push(`${k}: ${JSON.stringify(val)}`);
    return `${c.id}: ${parts.join(", ") || "changed"}`;
  }

  function zoneText(z) {
    if (typeof z === "string") return z;
    if (Array.isArray(z)) return `[${z.join(", ")}]`;
    return typeof z === "number" ? "±" + z : JSON.stringify(z);
  }

  function listSection(title, items, text) {
    if (!items || !items.length) return null;
    const ul = el("ul");
    for (const i of items) ul.append(el("li", { text: text(i) }));
    return el("div", {}, el("h4", { text: title }), ul);
  }

  function describeLandmark(l) {
    if (typeof l !== "object") return String(l);
    const zone = l.limits_mm ? `limits [${l.limits_mm.join(", ")}]` : l.tolerance_mm !== undefined ? `±${l.tolerance_mm}` : "";
    return `${l.id}${l.position ? " at (" + l.position.map((x) => num(x)).join(", ") + ")" : ""} ${zone}`.trim();
  }

  function value(v) { return typeof v === "string" ? v : v === null || v === undefined ? "—" : JSON.stringify(v); }

  // Settings changed: [{key, from, to}] (a key absent on one side is null there).
  function settingChanges(s) {
    if (!s) return [];
    if (Array.isArray(s)) return s.map((c) => `${c.key}: ${value(c.from)} → ${value(c.to)}`);
    return Object.entries(s).map(([k, c]) => c && typeof c === "object" && "from" in c
      ? `${k}: ${value(c.from)} → ${value(c.to)}` : `${k}: ${value(c)}`);
  }

  // A diff answer (docs/workbench.md: landmarks added, removed and changed,
  // settings changed, views added and removed) in words; what this page does
  // not know is shown as it came.
  function diff(d) {
    const box = el("div", { class: "diff" }, el("p", {}, el("strong", { text: `${d.from} → ${d.to}` })));
    const lm = d.landmarks || {};
    const views = d.views || {};  // null when a side was never planned
    const sections = [listSection("Landmarks added", lm.added, describeLandmark),
      listSection("Landmarks removed", lm.removed, describeLandmark),
      listSection("Landmarks changed", lm.changed, landmarkChange),
      listSection("Settings changed", settingChanges(d.settings), String),
      listSection("Views added", views.added, (v) => typeof v === "object" ? pose(v.pose || v) : String(v)),
      listSection("Views removed", views.removed, (v) => typeof v === "object" ? pose(v.pose || v) : String(v))];
    for (const s of sections) if (s) box.append(s);
    if (d.views === null) box.append(el("p", { class: "muted", text: "Views: not compared (one side has no plan yet)." }));
    const known = new Set(["part", "from", "to", "landmarks", "settings", "views"]);
    const rest = Object.fromEntries(Object.entries(d).filter(([k]) => !known.has(k)));
    if (Object.keys(rest).length) box.append(el("pre", { text: JSON.stringify(rest, null, 2) }));
    if (box.querySelectorAll("li").length === 0 && box.children.length <= 2)
      box.append(el("p", { class: "muted", text: "No difference." }));
    return box;
  }

  return { report, versionRows, diff, pose, num };
})();
