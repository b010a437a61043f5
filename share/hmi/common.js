// Shared by every page of the web HMI (docs/hmi.md): the navigation, JSON
// fetches of the API and small formatters. Plain browser JavaScript, no build step.
"use strict";

const hg = {
  async get(path) {
    const res = await fetch(path, { headers: { Accept: "application/json" }, cache: "no-store" });
    const body = await res.json().catch(() => ({ error: "HTTP " + res.status }));
    if (!res.ok) throw hg.refusal(res, body);
    return body;
  },
  async post(path, body, csrf) {
    const headers = { "Content-Type": "application/json" };
    if (csrf) headers["X-CSRF-Token"] = csrf;
    const res = await fetch(path, { method: "POST", headers, body: JSON.stringify(body), credentials: "same-origin" });
    const answer = await res.json().catch(() => ({ error: "HTTP " + res.status }));
    if (!res.ok) throw hg.refusal(res, answer);
    return answer;
  },
  // An error answer as an Error in the server's words, with the HTTP status
  // (the Parts page reloads the draft on 409, a change made on an old revision).
  refusal(res, body) {
    const e = new Error(body.error || "HTTP " + res.status);
    e.status = res.status;
    return e;
  },
  el(tag, attrs = {}, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs)) {
      if (k === "class") e.className = v;
      else if (k === "text") e.textContent = v;
      else e.setAttribute(k, v);
    }
    for (const c of children) e.append(c);
    return e;
  },
  mm(v, digits = 4) { return typeof v === "number" ? v.toFixed(digits) : "—"; },
  bytes(n) {
    if (typeof n !== "number") return "—";
    const units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let i = 0;
    while (n >= 1024 && i < units.length - 1) { n /= 1024; i++; }
    return n.toFixed(i ? 1 : 0) + " " + units[i];
  },
  nav(active) {
    const pages = [["/", "Line"], ["/results", "Results"], ["/spc", "SPC"], ["/parts", "Parts"], ["/maintenance", "Maintenance"],
      ["/audit", "Audit"], ["/users", "Users"]];
    const nav = document.querySelector("nav");
    for (const [href, label] of pages)
      nav.append(hg.el("a", { href, class: href === active ? "active" : "", text: label }));
  },
  // Signing in with one's own account (docs/audit.md): the answer carries the session's CSRF token and role.
  signIn(name, password) {
    const body = { password };
    if (name) body.name = name;
    return hg.post("/api/login", body);
  },
  // "anna (administrator)", or the shared password's name marked as such.
  who(s) { return `${s.name} (${s.role}${s.shared ? ", shared password" : ""})`; },
  // The lines of `before` and `after` as rows of a side-by-side view, each {kind: same|del|add|change,
  // left, right}: the common head and tail kept, the middle matched by its longest common subsequence
  // when small enough (else shown as replaced whole).
  lineDiff(before, after) {
    const a = before ? before.split("\n") : [], b = after ? after.split("\n") : [];
    let head = 0;
    while (head < a.length && head < b.length && a[head] === b[head]) head++;
    let tail = 0;
    while (tail < a.length - head && tail < b.length - head && a[a.length - 1 - tail] === b[b.length - 1 - tail]) tail++;
    const rows = a.slice(0, head).map((l) => ({ kind: "same", left: l, right: l }));
    const x = a.slice(head, a.length - tail), y = b.slice(head, b.length - tail);
    if (x.length * y.length <= 4e6) {
      const L = Array.from({ length: x.length + 1 }, () => new Uint32Array(y.length + 1));
      for (let i = x.length - 1; i >= 0; i--)
        for (let j = y.length - 1; j >= 0; j--)
          L[i][j] = x[i] === y[j] ? L[i + 1][j + 1] + 1 : Math.max(L[i + 1][j], L[i][j + 1]);
      let i = 0, j = 0;
      while (i < x.length || j < y.length) {
        if (i < x.length && j < y.length && x[i] === y[j]) { rows.push({ kind: "same", left: x[i], right: y[j] }); i++; j++; }
        else if (i < x.length && (j === y.length || L[i + 1][j] >= L[i][j + 1])) rows.push({ kind: "del", left: x[i++], right: "" });
        else rows.push({ kind: "add", left: "", right: y[j++] });
      }
    } else {
      for (let k = 0; k < Math.max(x.length, y.length); k++)
        rows.push({ kind: "change", left: x[k] ?? "", right: y[k] ?? "" });
    }
    for (let k = a.length - tail; k < a.length; k++) rows.push({ kind: "same", left: a[k], right: a[k] });
    return rows;
  },
  // A time for the operator: the browser's local time with its zone ("14:03:12 CET"), the date
  // in front when it is not today; `utc` (the store's ISO text or ms since 1970) goes in the tooltip.
  localTime(utc) {
    const t = typeof utc === "number" ? new Date(utc) : new Date(Date.parse(utc));
    if (isNaN(t)) return { text: "—", title: "" };
    const zone = new Intl.DateTimeFormat("en-GB", { timeZoneName: "short" }).formatToParts(t)
      .find((p) => p.type === "timeZoneName").value;
    const pad = (n) => String(n).padStart(2, "0");
    let text = `${pad(t.getHours())}:${pad(t.getMinutes())}:${pad(t.getSeconds())} ${zone}`;
    if (t.toDateString() !== new Date().toDateString())
      text = `${t.getFullYear()}-${pad(t.getMonth() + 1)}-${pad(t.getDate())} ${text}`;
    return { text, title: "UTC " + t.toISOString() };
  },
  // An element showing a time as localTime() does.
  timeEl(tag, utc, attrs = {}) {
    const t = hg.localTime(utc);
    return hg.el(tag, { ...attrs, text: t.text, title: t.title });
  },
  // A landmark's status in words (docs/inspection.md, "Status" and "Decisions").
  statusWords: {
    ok: "in tolerance", out_of_tolerance: "out of tolerance", uncertain: "uncertain", not_found: "not found",
    overflow: "out of range", not_observable: "not observable", not_inspected: "not inspected",
  },
  // Why a landmark has no sub-voxel deviation, in plain words, by its status; one table for every page.
  noDeviationWords: {
    not_found: "edge not found in the views",
    overflow: "outside the measuring range",
    not_observable: "no view sees it",
    not_inspected: "not inspected: the inspection stopped before it",
    ok: "no sub-voxel deviation: judged on the voxel bracket",
    out_of_tolerance: "no sub-voxel deviation: judged on the voxel bracket",
    uncertain: "no sub-voxel deviation: judged on the voxel bracket",
  },
  // The decision on a measured deviation (docs/inspection.md, "Decisions").
  decisionWords: { conforms: "conforms", nonconforms: "does not conform", uncertain: "uncertain: conformance not proven" },
  statusClass(s) { return s === "ok" ? "status-ok" : s === "uncertain" ? "status-uncertain" : "status-bad"; },
  signedMm(v) { return (v >= 0 ? "+" : "-") + Math.abs(v).toFixed(4); },
  // ONE reading per landmark (docs/hmi.md, "Landmark rows"): the deviation ± U with its decision
  // where the deviation decided the landmark, else the voxel bracket of |error| with why there is no
  // decision on a deviation. Where both exist and disagree by more than the bracket's width — a
  // deviation outside the bracket widened by its own width on each side — that is a fault of the
  // inspection itself, named in the row: never two readings side by side as if both held.
  landmarkReading(l) {
    const num = (v) => typeof v === "number" && isFinite(v);
    const hasBracket = num(l.error_min_mm) && num(l.error_max_mm);
    // The bracket is of the unsigned error (docs/inspection.md, "The boundary bracket"); an overflow's is
    // open above (its upper end only the layers' reach).
    const disagreement = () => {
      if (!hasBracket || !num(l.deviation_mm)) return null;
      const width = l.error_max_mm - l.error_min_mm, e = Math.abs(l.deviation_mm);
      if (e < l.error_min_mm - width) return l.error_min_mm - e;
      if (l.status !== "overflow" && e > l.error_max_mm + width) return e - l.error_max_mm;
      return null;
    };
    const bracketText = () => `|error| in [${hg.mm(l.error_min_mm)}, ${hg.mm(l.error_max_mm)}] mm`;
    const placed = ["ok", "out_of_tolerance", "uncertain"].includes(l.status);
    if (num(l.deviation_mm) && placed) {
      const u = num(l.uncertainty_mm) ? ` ± ${l.uncertainty_mm.toFixed(4)}` : "";
      const off = disagreement();
      return { kind: "deviation", text: `${hg.signedMm(l.deviation_mm)}${u} mm`,
        note: hg.decisionWords[l.decision] || l.decision || "no decision on the deviation",
        fault: off === null ? null
          : `the voxel bracket ${bracketText()} disagrees with the deviation by ${off.toFixed(4)} mm: inspection fault` };
    }
    const why = hg.noDeviationWords[l.status] || "no deviation measured";
    if (!hasBracket) return { kind: "none", text: "no reading", note: why, fault: null };
    const off = disagreement();
    return { kind: "bracket", text: bracketText(), note: why,
      fault: off === null ? null
        : `the sub-voxel deviation ${hg.signedMm(l.deviation_mm)} mm disagrees with the voxel bracket by ${off.toFixed(4)} mm: inspection fault` };
  },
  // The landmark table of one result, the same on every page: one reading, the zone, the status in words.
  landmarkTable(landmarks, onlyFailed = false) {
    const table = hg.el("table", { class: "landmarks" });
    const head = hg.el("tr");
    for (const h of ["Landmark", "Reading", "Decision or reason", "Zone mm", "Status"])
      head.append(hg.el("th", { text: h }));
    table.append(head);
    for (const l of landmarks) {
      if (onlyFailed && l.status === "ok") continue;
      const zone = l.limits_mm ? `[${hg.mm(l.limits_mm[0])}, ${hg.mm(l.limits_mm[1])}]` : `±${hg.mm(l.tolerance_mm)}`;
      const r = hg.landmarkReading(l);
      const tr = hg.el("tr", { "data-landmark": l.id, "data-status": l.status, "data-reading": r.kind,
        class: r.fault ? "inspection-fault" : "" });
      tr.append(hg.el("td", { text: l.id }), hg.el("td", { class: "num reading", text: r.text }),
        hg.el("td", { class: "note", text: r.fault || r.note }), hg.el("td", { class: "num", text: zone }),
        hg.el("td", { class: "status " + hg.statusClass(l.status), text: hg.statusWords[l.status] || l.status }));
      table.append(tr);
    }
    return table;
  },
};
