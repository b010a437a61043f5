// One result (docs/hmi.md, "Results"): every landmark with its status,
// deviation, uncertainty, bracket and zone, and its views with the overlay (view_viewer.js).
"use strict";
hg.nav("/results");

async function show() {
  const id = new URLSearchParams(location.search).get("id");
  try {
    if (!/^[0-9]+$/.test(id || "")) throw new Error("no result id given");
    const r = await hg.get(`/api/results/${id}`);
    document.getElementById("title").textContent = `Result ${r.id}`;
    // The printable record of this part and its PDF (docs/hmi.md, "Part record").
    document.getElementById("record-link").href = `/record?id=${r.id}`;
    const v = document.getElementById("verdict");
    v.textContent = r.verdict.toUpperCase();
    v.className = "verdict " + r.verdict;
    const facts = document.getElementById("facts");
    // The release the part was judged with (docs/commissioning.md, "Release"); none for a draft.
    const release = r.program_version == null ? "none (draft)"
      : `version ${r.program_version}, verification ${String(r.program_sha256).slice(0, 12)}…`;
    // The part's temperature at the trigger, its deviations referred to 20 °C with it (docs/mastering.md).
    const temperature = r.temperature_c == null ? "none read" : `${r.temperature_c.toFixed(2)} °C`;
    const rows = [["Serial", r.serial || "(none)"], ["Time (UTC)", r.time], ["Program", r.program], ["Part", r.part],
      ["Program release", release], ["Purpose", r.purpose], ["Part temperature", temperature],
      ["Cycle", r.cycle_ms + " ms"], ["Fault code", r.fault_code],
      ["Trigger", (r.manual ? "maintenance" : "PLC") + ", seq " + r.trigger_seq],
      ["Landmarks failed", `${r.landmarks_failed} of ${r.landmarks_total}`]];
    for (const [k, val] of rows) facts.append(hg.el("dt", { text: k }), hg.el("dd", { text: String(val) }));
    document.getElementById("landmarks").replaceChildren(hg.landmarkTable(r.landmarks));
    document.getElementById("images").replaceChildren(ViewViewer.views(r));
  } catch (e) {
    document.getElementById("error").textContent = e.message;
  }
}
show();
