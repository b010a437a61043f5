// The operator's line view (docs/hmi.md, "Line view"): polls /api/status
// four times a second, shows each new result as soon as it is stored, and the
// last failed part's annotated views with its failed landmarks.
"use strict";
hg.nav("/");

let shownResult = null;
let shownFailed = null;
// What the page has done, for whoever watches it (the browser tests): polls completed, the result shown.
window.hgLine = { polls: 0, shownResult: null, shownFailed: null };

function text(id, value) { document.getElementById(id).textContent = value ?? "—"; }

function showLamps(lamps) {
  for (const name of ["green", "amber", "red"]) {
    const e = document.getElementById("lamp-" + name);
    const state = lamps ? lamps[name] : "off";
    const lit = lamps && lamps.lit ? lamps.lit[name] : state !== "off";
    e.className = `lamp ${name}${lit ? " lit" : ""}${state === "blinking" ? " blinking" : ""}`;
    e.title = `${name}: ${state}`;
  }
}

function showDisk(d) {
  if (!d) return;
  const share = d.max_bytes ? Math.min(1, d.archive_bytes / d.max_bytes) : 0;
  document.getElementById("disk-bar").style.width = (100 * share).toFixed(1) + "%";
  let line = `${hg.bytes(d.archive_bytes)} of ${hg.bytes(d.max_bytes)} (${d.archive_folders} parts of ${d.max_count})`;
  if (typeof d.filesystem_free_bytes === "number")
    line += `; disk ${hg.bytes(d.filesystem_free_bytes)} free of ${hg.bytes(d.filesystem_bytes)}`;
  text("disk", line);
}

// The archive's pictures are written after the result is stored (docs/daemon.md, "Archived
// parts"): a failed part whose folder is not there yet is asked for again at the next polls.
let failedTries = 0;
let failedCheckedFor = null;
async function showFailed() {
  const list = await hg.get("/api/results?verdict=fail&limit=1");
  const last = list.results[0];
  if (!last || last.id === shownFailed) return;
  const result = await hg.get(`/api/results/${last.id}`);
  const waiting = last.has_images && !(result.image_files || []).length && ++failedTries < 40;
  if (!waiting) { shownFailed = last.id; failedTries = 0; }
  text("failed-title", `Serial ${result.serial || "(none)"} at ${result.time}: ${result.landmarks_failed} of ${result.landmarks_total} landmarks failed`);
  document.getElementById("failed-landmarks").replaceChildren(hg.landmarkTable(result.landmarks, true));
  document.getElementById("failed-images").replaceChildren(hg.images(result));
}

// The PLC's own counters (docs/plc.md) and the program the changeover made active.
function showPlc(plc) {
  const c = plc.counters;
  if (c) {
    text("count-triggers", c.triggers);
    text("count-passes", c.passes);
    text("count-fails", c.fails);
    text("count-faults", c.faults);
    text("count-missed", c.missed_triggers);
    const judged = c.passes + c.fails;
    text("count-yield", judged ? `${(100 * c.passes / judged).toFixed(1)} %` : null);
  }
  if (plc.active_program !== undefined)
    text("active-program", plc.active_program ? `${plc.active_program} (${plc.program_state})` : "none");
}

function showResult(r) {
  if (!r) return;
  const v = document.getElementById("verdict");
  v.textContent = r.verdict.toUpperCase();
  v.className = "verdict " + r.verdict;
  text("serial", r.serial || "(none)");
  text("program", r.program);
  text("cycle-ms", r.cycle_ms + " ms");
  text("time", r.time);
  text("result-id", r.id);
}

async function poll() {
  try {
    const s = await hg.get("/api/status");
    text("state", s.sequencer.state);
    text("sequencer", s.sequencer.state);
    text("plc-status", s.plc.status);
    text("done-seq", s.plc.done_seq);
    text("cycles", s.sequencer.cycles);
    text("faults", s.sequencer.faults);
    text("purpose", s.purpose);
    text("fault", s.sequencer.fault || "none");
    showLamps(s.lamps);
    showPlc(s.plc);
    showDisk(s.disk);
    if (s.last_result && s.last_result.id !== shownResult) {
      shownResult = s.last_result.id;
      showResult(s.last_result);
    }
    // Asked once per new result (any result may be the first failed one shown), and again while its pictures are awaited.
    if (s.last_result && (s.last_result.id !== failedCheckedFor || failedTries > 0)) {
      failedCheckedFor = s.last_result.id;
      await showFailed();
    }
    text("error", "");
  } catch (e) {
    text("error", "Station not answering: " + e.message);
  }
  window.hgLine.polls++;
  window.hgLine.shownResult = shownResult;
  window.hgLine.shownFailed = shownFailed;
  setTimeout(poll, 250);
}
poll();
