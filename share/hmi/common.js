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
  statusClass(s) { return s === "ok" ? "status-ok" : s === "uncertain" ? "status-uncertain" : "status-bad"; },
  nav(active) {
    const pages = [["/", "Line"], ["/results", "Results"], ["/spc", "SPC"], ["/parts", "Parts"], ["/maintenance", "Maintenance"]];
    const nav = document.querySelector("nav");
    for (const [href, label] of pages)
      nav.append(hg.el("a", { href, class: href === active ? "active" : "", text: label }));
  },
  // The landmark table of one result: status, the measured value and its zone.
  landmarkTable(landmarks, onlyFailed = false) {
    const table = hg.el("table", { class: "landmarks" });
    const head = hg.el("tr");
    for (const h of ["Landmark", "Status", "Deviation mm", "U mm", "Error bracket mm", "Zone mm", "Decision"])
      head.append(hg.el("th", { text: h }));
    table.append(head);
    for (const l of landmarks) {
      if (onlyFailed && l.status === "ok") continue;
      const zone = l.limits_mm ? `[${hg.mm(l.limits_mm[0])}, ${hg.mm(l.limits_mm[1])}]` : `±${hg.mm(l.tolerance_mm)}`;
      const tr = hg.el("tr", { "data-landmark": l.id });
      tr.append(hg.el("td", { text: l.id }), hg.el("td", { class: hg.statusClass(l.status), text: l.status }),
        hg.el("td", { class: "num", text: hg.mm(l.deviation_mm) }), hg.el("td", { class: "num", text: hg.mm(l.uncertainty_mm) }),
        hg.el("td", { class: "num", text: `[${hg.mm(l.error_min_mm)}, ${hg.mm(l.error_max_mm)}]` }),
        hg.el("td", { class: "num", text: zone }), hg.el("td", { text: l.decision || "" }));
      table.append(tr);
    }
    return table;
  },
  images(result) {
    const box = hg.el("div", { class: "images" });
    for (const name of result.image_files || [])
      box.append(hg.el("img", { src: `/api/results/${result.id}/images/${name}`, alt: name, title: name }));
    if (!box.children.length) box.append(hg.el("p", { class: "muted", text: "No images archived for this part." }));
    return box;
  },
};
