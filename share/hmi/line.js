// The operator's line view (docs/hmi.md, "Line view"): polls /api/status four
// times a second and shows the verdict across the full width, the lamps, the
// station's state and fault in words with the action to take, the shift's
// counts, the last rejects and the last failed part. `/?kiosk` is the panel
// PC's full screen: no navigation, no engineer's details, larger type.
"use strict";
const kiosk = new URLSearchParams(location.search).has("kiosk");
if (kiosk) document.documentElement.classList.add("kiosk");
else hg.nav("/");

let shownResult = null;
let shownFailed = null;
// What the page has done, for whoever watches it (the browser tests): polls completed, the result shown,
// the result ids of the filmstrip.
window.hgLine = { polls: 0, shownResult: null, shownFailed: null, filmstrip: [], kiosk };

function text(id, value) { document.getElementById(id).textContent = value ?? "—"; }
function timeInto(id, utc) {
  const t = hg.localTime(utc);
  const e = document.getElementById(id);
  e.textContent = t.text;
  e.title = t.title;
}

// The browser may only go full screen on a user's gesture: a button offers it.
document.getElementById("fullscreen").addEventListener("click", () => {
  if (!document.fullscreenElement) document.documentElement.requestFullscreen().catch(() => {});
});

// The lamps as the operator sees them, labelled with their meaning (docs/lamps.md) and their state in words.
const lampWords = { on: "lit", blinking: "blinking", off: "off" };
function showLamps(lamps) {
  for (const name of ["green", "amber", "red"]) {
    const e = document.getElementById("lamp-" + name);
    const state = lamps && lamps[name] ? lamps[name] : "off";
    const lit = lamps && lamps.lit ? lamps.lit[name] : state !== "off";
    e.className = `lamp ${name}${lit ? " lit" : ""}${state === "blinking" ? " blinking" : ""}`;
    text(`lamp-${name}-state`, lampWords[state] || state);
    e.title = `${name}: ${lampWords[state] || state}`;
  }
}

// The sequencer's state in the operator's words (docs/daemon.md, "Maintenance socket": status).
function stateWords(seq) {
  const views = seq.views ? `: view ${seq.view + 1} of ${seq.views}` : "";
  return {
    starting: "Starting up", ready: "Ready for the next part", done: "Ready for the next part",
    moving: "Inspecting" + views, settling: "Inspecting" + views, grabbing: "Inspecting" + views,
    processing: "Judging the part", fault: "In fault", calibrating: "Maintenance: calibration running",
  }[seq.state] || seq.state;
}

// The fault in words with the action (the daemon's one table, docs/hmi.md "JSON API": fault).
function showFault(fault) {
  const box = document.getElementById("fault-box");
  box.hidden = !fault || fault.source === "none";
  if (box.hidden) return;
  const sentence = fault.sentence.charAt(0).toUpperCase() + fault.sentence.slice(1);
  text("fault-sentence", (fault.source === "station" ? "Station in fault: " : "Last part not judged: ") + sentence + ".");
  text("fault-action", fault.action);
  box.className = "fault-box " + (fault.source === "station" ? "fault-now" : "fault-last");
  box.dataset.code = fault.code;
}

function showShift(shift) {
  if (!shift) return;
  text("shift-name", shift.name);
  timeInto("shift-since", shift.started_utc);
  for (const k of ["cycles", "pass", "fail", "aborted", "error"]) text("shift-" + k, shift[k]);
  text("shift-yield", typeof shift.yield === "number" ? `${(100 * shift.yield).toFixed(1)} %` : null);
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
const fullResults = new Map(); // id -> the stored row with its image names, for the filmstrip
async function fullResult(id, refresh = false) {
  if (refresh || !fullResults.has(id)) fullResults.set(id, await hg.get(`/api/results/${id}`));
  return fullResults.get(id);
}

// The last rejects: the last six failed parts, the first annotated view of each with serial, time and
// failed landmarks; a click opens the result.
async function showFilmstrip(rows) {
  const strip = document.getElementById("filmstrip");
  const frames = [];
  for (const row of rows) {
    const r = await fullResult(row.id, row.has_images && !(fullResults.get(row.id)?.image_files || []).length);
    const a = hg.el("a", { class: "frame", href: `/result?id=${row.id}`, "data-result": row.id });
    const first = (r.image_files || [])[0];
    a.append(first ? hg.el("img", { src: `/api/results/${row.id}/images/${first}`, alt: `part ${row.serial}` })
      : hg.el("div", { class: "no-image", text: "no picture" }));
    a.append(hg.el("div", { class: "frame-serial", text: row.serial || "(no serial)" }),
      hg.timeEl("div", row.time, { class: "frame-time" }),
      hg.el("div", { class: "frame-landmarks", text: row.failed_landmarks.join(", ") || "—" }));
    frames.push(a);
  }
  if (frames.length) strip.replaceChildren(...frames);
  for (const id of fullResults.keys()) if (!rows.some((row) => row.id === id)) fullResults.delete(id);
  window.hgLine.filmstrip = rows.map((r) => r.id);
}

async function showFailed() {
  const list = await hg.get("/api/results?verdict=fail&limit=6");
  await showFilmstrip(list.results);
  const last = list.results[0];
  if (!last || last.id === shownFailed) return;
  const result = await fullResult(last.id, true);
  const waiting = last.has_images && !(result.image_files || []).length && ++failedTries < 40;
  if (!waiting) { shownFailed = last.id; failedTries = 0; }
  const when = hg.localTime(result.time);
  text("failed-title", `Serial ${result.serial || "(none)"} at ${when.text}: ${result.landmarks_failed} of ${result.landmarks_total} landmarks failed`);
  document.getElementById("failed-title").title = when.title;
  document.getElementById("failed-landmarks").replaceChildren(hg.landmarkTable(result.landmarks, true));
  document.getElementById("failed-images").replaceChildren(ViewViewer.views(result));
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
  text("plc-status", plc.status_name ?? plc.status);
}

function showResult(r) {
  if (!r) return;
  const v = document.getElementById("verdict");
  v.textContent = r.verdict.toUpperCase();
  v.className = "verdict " + r.verdict;
  document.getElementById("verdict-band").className = "verdict-band " + r.verdict;
  text("serial", r.serial || "(none)");
  text("program", r.program);
  text("cycle-ms", r.cycle_ms + " ms");
  timeInto("time", r.time);
  text("result-id", r.id);
}

async function poll() {
  try {
    const s = await hg.get("/api/status");
    text("state", s.sequencer.state);
    text("station-state", stateWords(s.sequencer));
    text("sequencer", s.sequencer.state);
    text("done-seq", s.plc.done_seq);
    text("cycles", s.sequencer.cycles);
    text("faults", s.sequencer.faults);
    text("purpose", s.purpose);
    text("fault", s.fault ? `${s.fault.code} ${s.fault.name}` : "none");
    showFault(s.fault);
    showLamps(s.lamps);
    showPlc(s.plc);
    showShift(s.shift);
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
