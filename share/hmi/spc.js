// The quality engineer's SPC page (docs/hmi.md, "SPC"; formulas in docs/spc.md):
// an overview of every characteristic of a program (Cpk, Ppk, yield, rule
// violations, coloured by capability band, sortable); for the chosen one the
// individuals and moving-range charts with their limits from the baseline,
// the gaps where a cycle had no value, the run rules in words with their
// points marked, the histogram over the tolerance zone, capability and yield;
// and a Pareto of failing landmarks and fault codes over a period. Chart.js
// from Debian's libjs-chart.js. A load that fails clears every chart and says
// why at the top: nothing of an earlier selection stays on screen.
"use strict";
hg.nav("/spc");

const charts = {};
const RED = "#c62828", BLUE = "#2f5f8f", GREY = "#8a949c", GREEN = "#1b8a3a", AMBER = "#b26a00";
const $ = (id) => document.getElementById(id);

// What the tests read (tests/integration/spc_browser.py).
window.hgSpc = { loads: 0, busy: 0, shown: null, error: "", overview: [], pareto: null };

// docs/spc.md, "Run rules": each rule in words.
const RULES = {
  nelson_1: ["Nelson 1", "a point beyond the 3σ control limit"],
  nelson_2: ["Nelson 2", "nine points in a row on one side of the centre line"],
  nelson_3: ["Nelson 3", "six points in a row steadily increasing or decreasing"],
  nelson_4: ["Nelson 4", "fourteen points in a row alternating up and down"],
  nelson_5: ["Nelson 5", "two of three points in a row beyond 2σ on the same side"],
  nelson_6: ["Nelson 6", "four of five points in a row beyond 1σ on the same side"],
  nelson_7: ["Nelson 7", "fifteen points in a row within 1σ of the centre line"],
  nelson_8: ["Nelson 8", "eight points in a row beyond 1σ, none within it"],
  we_1: ["Western Electric 1", "a point beyond the 3σ control limit"],
  we_2: ["Western Electric 2", "two of three points in a row beyond 2σ on the same side"],
  we_3: ["Western Electric 3", "four of five points in a row beyond 1σ on the same side"],
  we_4: ["Western Electric 4", "eight points in a row on one side of the centre line"],
};
const DIRECTION = { up: "above the centre line", down: "below the centre line" };
const GAP_WORDS = { not_found: "the landmark's edge was not found in the frames",
  not_observable: "no view saw the landmark", absent: "the cycle's result does not list the landmark" };

function ruleWords(v, s) {
  const [name, words] = RULES[v.rule] || [v.rule, ""];
  const first = s.points[v.points[0]], last = s.points[v.points[v.points.length - 1]];
  const where = v.points.length > 1 ? `cycles ${first.cycle + 1}–${last.cycle + 1} (${first.serial} … ${last.serial})`
    : `cycle ${last.cycle + 1} (${last.serial})`;
  const side = v.direction === "up" || v.direction === "down"
    ? (v.rule.endsWith("_3") && v.rule.startsWith("nelson") ? (v.direction === "up" ? ", increasing" : ", decreasing")
      : ", " + DIRECTION[v.direction]) : "";
  return `${name}: ${words}${side} — ${where}`;
}

function band(index) {
  if (typeof index !== "number") return "band-none";
  return index >= 1.67 ? "band-excellent" : index >= 1.33 ? "band-capable" : index >= 1.0 ? "band-marginal" : "band-incapable";
}

function line(label, y, x0, x1, colour, dash) {
  return { label, data: [{ x: x0, y }, { x: x1, y }], borderColor: colour, borderDash: dash,
    pointRadius: 0, borderWidth: 1.5, fill: false, type: "line" };
}

function draw(id, config) {
  if (charts[id]) charts[id].destroy();
  charts[id] = new Chart($(id), config);
}

function clearCharts() {
  for (const id of ["chart-i", "chart-mr", "chart-hist"]) if (charts[id]) { charts[id].destroy(); delete charts[id]; }
  for (const id of ["capability", "limits", "rules"]) $(id).replaceChildren();
  $("chart-title").textContent = "";
  $("gaps-note").textContent = "";
  $("charts").hidden = true;
  hgSpc.shown = null;
}

function showError(message) {
  $("error").textContent = message;
  $("error").hidden = !message;
  hgSpc.error = message;
}

function linear(title, extra = {}) { return { type: "linear", title: { display: true, text: title }, ...extra }; }

function individuals(s) {
  const involved = new Set(s.rules ? s.rules.violations.flatMap((v) => v.points) : []);
  const pts = s.points.map((p) => ({ x: p.cycle + 1, y: p.value_mm, serial: p.serial, rules: p.rules, index: p.index }));
  const x0 = 1, x1 = Math.max(2, s.points.length + s.gaps.length);
  const datasets = [{ label: s.id, data: pts, type: "line", borderColor: BLUE, borderWidth: 1, spanGaps: false,
    pointBackgroundColor: pts.map((p) => (p.rules.length ? RED : BLUE)),
    pointBorderColor: pts.map((p) => (involved.has(p.index) ? RED : BLUE)),
    pointBorderWidth: pts.map((p) => (involved.has(p.index) ? 3 : 1)),
    pointRadius: pts.map((p) => (p.rules.length ? 6 : involved.has(p.index) ? 5 : 3)),
    segment: { borderDash: (ctx) => (ctx.p1.parsed.x - ctx.p0.parsed.x > 1 ? [3, 4] : undefined) } }];
  if (s.i_chart) {
    datasets.push(line("CL", s.i_chart.centre_mm, x0, x1, GREEN), line("UCL", s.i_chart.ucl_mm, x0, x1, RED, [6, 4]),
      line("LCL", s.i_chart.lcl_mm, x0, x1, RED, [6, 4]));
  }
  // The tolerance zone is the histogram's: drawn here it would squeeze a capable process into a line.
  // The gaps: a grey cross on the lower control limit (or the lowest value) at each cycle without a value.
  const floor = s.i_chart ? s.i_chart.lcl_mm : Math.min(...s.points.map((p) => p.value_mm));
  if (s.gaps.length)
    datasets.push({ label: "no value (gap)", type: "scatter", data: s.gaps.map((g) => ({ x: g.cycle + 1, y: floor, gap: g })),
      pointStyle: "crossRot", pointRadius: 8, borderColor: AMBER, borderWidth: 2, backgroundColor: AMBER });
  draw("chart-i", { type: "line", data: { datasets }, options: { animation: false, parsing: false,
    scales: { x: linear("cycle", { min: x0, max: x1 }), y: linear(s.values === "deviation_mm" ? "deviation mm" : "bracket middle mm") },
    plugins: { tooltip: { callbacks: { label: (c) => c.raw.gap ? `cycle ${c.raw.x} (${c.raw.gap.serial}): no value — ${GAP_WORDS[c.raw.gap.reason] || c.raw.gap.reason}`
      : c.raw.serial !== undefined ? `${c.raw.serial}: ${c.raw.y.toFixed(4)} mm ${c.raw.rules.map((r) => (RULES[r] || [r])[0]).join(", ")}`
        : `${c.dataset.label} ${c.raw.y.toFixed(4)}` } } } } });
}

function movingRange(s) {
  const shown = s.points.filter((p) => p.moving_range_mm !== null);
  const pts = shown.map((p) => ({ x: p.cycle + 1, y: p.moving_range_mm }));
  const x0 = 1, x1 = Math.max(2, s.points.length + s.gaps.length);
  const datasets = [{ label: "MR", data: pts, type: "line", borderColor: BLUE, borderWidth: 1, pointRadius: 2,
    pointBackgroundColor: shown.map((p) => (p.mr_above_ucl ? RED : BLUE)),
    segment: { borderDash: (ctx) => (ctx.p1.parsed.x - ctx.p0.parsed.x > 1 ? [3, 4] : undefined) } }];
  if (s.mr_chart) datasets.push(line("MR̄", s.mr_chart.centre_mm, x0, x1, GREEN), line("UCL", s.mr_chart.ucl_mm, x0, x1, RED, [6, 4]));
  draw("chart-mr", { type: "line", data: { datasets }, options: { animation: false, parsing: false,
    scales: { x: linear("cycle", { min: x0, max: x1 }), y: linear("moving range mm") } } });
}

function histogram(s) {
  const e = s.histogram.edges_mm;
  const bars = s.histogram.counts.map((c, i) => ({ x: (e[i] + e[i + 1]) / 2, y: c }));
  const top = Math.max(1, ...s.histogram.counts);
  const limit = (label, x, colour) => ({ label, data: [{ x, y: 0 }, { x, y: top }], type: "line", borderColor: colour,
    borderDash: [4, 3], pointRadius: 0 });
  const datasets = [{ label: "values", data: bars, backgroundColor: "#7da3c8", barPercentage: 1, categoryPercentage: 1 }];
  if (s.zone_mm[0] !== null) datasets.push(limit("LSL", s.zone_mm[0], RED));
  if (s.zone_mm[1] !== null) datasets.push(limit("USL", s.zone_mm[1], RED));
  draw("chart-hist", { type: "bar", data: { datasets },
    options: { animation: false, parsing: false, scales: { x: linear("mm"), y: { beginAtZero: true, title: { display: true, text: "count" } } } } });
}

function facts(id, rows) {
  const dl = $(id);
  dl.replaceChildren();
  for (const [k, v, cls] of rows) dl.append(hg.el("dt", { text: k }), hg.el("dd", { text: v, class: cls || "" }));
}

function num(v, digits = 2) { return typeof v === "number" ? v.toFixed(digits) : "—"; }

function gapsNote(s) {
  if (!s.gaps.length) return "";
  const reasons = {};
  for (const g of s.gaps) reasons[g.reason] = (reasons[g.reason] || 0) + 1;
  const words = Object.entries(reasons).map(([r, n]) => `${n} × ${GAP_WORDS[r] || r}`).join("; ");
  return `${s.gaps.length} of ${s.points.length + s.gaps.length} cycles have no value (crosses on the chart): ${words}. ` +
    "No moving range spans a gap; the run rules read the values in order.";
}

function rulesList(s) {
  const list = $("rules");
  list.replaceChildren();
  for (const v of s.rules.violations) list.append(hg.el("li", { class: "violation", "data-rule": v.rule, text: ruleWords(v, s) }));
  if (!s.rules.violations.length)
    list.append(hg.el("li", { class: "ok", text: `No rule violated (${s.rules.set === "nelson" ? "Nelson's eight tests" : "the four Western Electric rules"}).` }));
  if (s.rules.not_tested) list.append(hg.el("li", { class: "muted", text: "Not tested: " + s.rules.not_tested }));
}

function showChart(s) {
  clearCharts();
  if (!s.evaluated) {
    showError(`${s.id}: not charted — ${s.not_evaluated}.`);
    return;
  }
  $("charts").hidden = false;
  $("chart-title").textContent = `${s.id}: ${s.values === "deviation_mm" ? "deviation" : "voxel bracket middle"}, ${s.n} values`;
  $("gaps-note").textContent = gapsNote(s);
  individuals(s);
  movingRange(s);
  histogram(s);
  const c = s.capability;
  facts("capability", [["Values", `${s.n} (${s.values})`], ["Zone mm", `[${hg.mm(s.zone_mm[0])}, ${hg.mm(s.zone_mm[1])}]`],
    ["Mean mm", hg.mm(c.mean_mm)], ["Cp", num(c.cp)], ["Cpk", num(c.cpk), band(c.cpk)], ["Pp", num(c.pp)], ["Ppk", num(c.ppk), band(c.ppk)],
    ["Yield", `${(100 * s.yield.fraction).toFixed(1)} % (${s.yield.within} of ${s.yield.n})`]]);
  facts("limits", [["Baseline", `${s.baseline.used} values${s.baseline.short ? " (fewer than asked)" : ""}`],
    ["CL mm", hg.mm(s.i_chart.centre_mm)], ["UCL / LCL mm", `${hg.mm(s.i_chart.ucl_mm)} / ${hg.mm(s.i_chart.lcl_mm)}`],
    ["σ within mm", hg.mm(s.i_chart.sigma_within_mm, 5)], ["MR̄ / UCL mm", `${hg.mm(s.mr_chart.centre_mm)} / ${hg.mm(s.mr_chart.ucl_mm)}`]]);
  rulesList(s);
  hgSpc.shown = { id: s.id, cycles: s.points.map((p) => p.cycle), values: s.points.map((p) => p.value_mm),
    gaps: s.gaps.map((g) => g.cycle), violations: s.rules.violations.map((v) => ({ rule: v.rule, points: v.points })) };
}

// ---- the overview of every characteristic ----

const overviewSort = { key: "cpk", ascending: true };

function overviewRows(body) {
  return body.landmarks.map((s) => ({ id: s.id, n: s.n, gaps: s.gaps.length,
    cpk: s.evaluated ? s.capability.cpk : null, ppk: s.evaluated ? s.capability.ppk : null,
    yield: s.evaluated ? 100 * s.yield.fraction : null, violations: s.evaluated ? s.rules.violations.length : null,
    note: s.evaluated ? (s.values === "deviation_mm" ? "" : "voxel bracket middles") : "not charted: " + s.not_evaluated }));
}

function showOverview() {
  const { key, ascending } = overviewSort;
  const rows = [...hgSpc.overview].sort((a, b) => {
    const x = a[key], y = b[key];
    if (x === y) return a.id < b.id ? -1 : 1;
    if (x === null) return 1;
    if (y === null) return -1;
    return (x < y ? -1 : 1) * (ascending ? 1 : -1);
  });
  const body = $("overview").tBodies[0];
  body.replaceChildren(...rows.map((r) => {
    const tr = hg.el("tr", { "data-landmark": r.id, class: r.id === $("f-landmark").value ? "selected" : "" });
    tr.append(hg.el("td", { text: r.id }), hg.el("td", { class: "num", text: String(r.n) }),
      hg.el("td", { class: "num" + (r.gaps ? " warn" : ""), text: String(r.gaps) }),
      hg.el("td", { class: "num " + band(r.cpk), text: num(r.cpk) }), hg.el("td", { class: "num " + band(r.ppk), text: num(r.ppk) }),
      hg.el("td", { class: "num", text: r.yield === null ? "—" : r.yield.toFixed(1) }),
      hg.el("td", { class: "num" + (r.violations ? " warn" : ""), text: r.violations === null ? "—" : String(r.violations) }),
      hg.el("td", { class: "muted", text: r.note }));
    tr.addEventListener("click", () => { $("f-landmark").value = r.id; load(); });
    return tr;
  }));
  for (const th of $("overview").tHead.rows[0].cells)
    th.className = (th.classList.contains("num") ? "num " : "") + (th.dataset.key === key ? (ascending ? "sorted-up" : "sorted-down") : "");
}

// ---- loading ----

// Only the latest load draws: an earlier selection's answer arriving late must not replace it.
let latestLoad = 0;
async function load() {
  const mine = ++latestLoad;
  hgSpc.busy++;
  try {
    const program = $("f-program").value;
    if (!program) throw new Error("no part program has production cycles yet");
    const params = new URLSearchParams({ program, baseline: $("f-baseline").value, rules: $("f-rules").value, limit: $("f-limit").value });
    $("overview-title").textContent = `Every characteristic of program ${program}`;
    const body = await hg.get("/api/spc?" + params.toString());
    if (mine !== latestLoad) return;
    const select = $("f-landmark");
    const chosen = select.value;
    select.replaceChildren(...body.landmark_ids.map((id) => hg.el("option", { value: id, text: id })));
    if (!body.landmark_ids.length) throw new Error(`program ${program} has no production cycles in the selection`);
    select.value = body.landmark_ids.includes(chosen) ? chosen : body.landmark_ids[0];
    showError("");
    hgSpc.overview = overviewRows(body);
    showOverview();
    showChart(body.landmarks.find((s) => s.id === select.value));
  } catch (e) {
    if (mine !== latestLoad) return;
    clearCharts();
    showError(e.message);
  } finally {
    hgSpc.loads++;
    hgSpc.busy--;
  }
}

// ---- Pareto ----

function paretoChart(id, bars, label, colour) {
  draw(id, { type: "bar", data: { labels: bars.map((b) => b.label), datasets: [
    { label: "count", data: bars.map((b) => b.count), backgroundColor: colour, yAxisID: "y", order: 2 },
    { label: "cumulative %", data: bars.map((b) => 100 * b.cumulative_share), type: "line", borderColor: GREY,
      pointRadius: 3, yAxisID: "share", order: 1 }] },
  options: { animation: false, scales: { x: { title: { display: true, text: label } },
    y: { beginAtZero: true, title: { display: true, text: "count" }, ticks: { precision: 0 } },
    share: { position: "right", min: 0, max: 100, title: { display: true, text: "cumulative %" } } } } });
}

function paretoTable(id, head, rows) {
  const table = $(id);
  table.replaceChildren(hg.el("tr", {}, ...head.map((h) => hg.el("th", { text: h }))));
  for (const r of rows) table.append(hg.el("tr", {}, ...r.map((c, i) => hg.el("td", { class: i ? "num" : "", text: c }))));
  if (!rows.length) table.append(hg.el("tr", {}, hg.el("td", { class: "muted", text: "none in the period" })));
}

async function loadPareto() {
  hgSpc.busy++;
  try {
    const params = new URLSearchParams();
    if (!$("p-all").checked && $("f-program").value) params.set("program", $("f-program").value);
    if ($("p-since").value) params.set("since", $("p-since").value);
    if ($("p-until").value) params.set("until", $("p-until").value);
    const p = await hg.get("/api/pareto?" + params.toString());
    $("pareto-error").hidden = true;
    $("pareto-scope").textContent = `${p.program === null ? "Every program" : "Program " + p.program}, ` +
      `${p.since ? "from " + p.since : "from the first cycle"} ${p.until ? "until " + p.until : "to now"}: ${p.cycles} PLC cycles, ` +
      `${p.failed_cycles} failed, ${p.faulted_cycles} ended by a fault.`;
    const status = (m) => Object.entries(m).map(([k, n]) => `${n} ${k.replace(/_/g, " ")}`).join(", ");
    paretoChart("pareto-landmarks", p.landmarks.map((b) => ({ ...b, label: b.id })), "landmark", RED);
    paretoChart("pareto-faults", p.faults.map((b) => ({ ...b, label: `${b.code} ${b.name}` })), "fault code", AMBER);
    paretoTable("pareto-landmark-table", ["Landmark", "Failed", "Cumulative %", "How"],
      p.landmarks.map((b) => [b.id, String(b.count), (100 * b.cumulative_share).toFixed(1), status(b.by_status)]));
    paretoTable("pareto-fault-table", ["Fault", "Cycles", "Cumulative %", "What happened"],
      p.faults.map((b) => [`${b.code} ${b.name}`, String(b.count), (100 * b.cumulative_share).toFixed(1), b.sentence]));
    hgSpc.pareto = p;
  } catch (e) {
    for (const id of ["pareto-landmarks", "pareto-faults"]) if (charts[id]) { charts[id].destroy(); delete charts[id]; }
    for (const id of ["pareto-landmark-table", "pareto-fault-table"]) $(id).replaceChildren();
    $("pareto-scope").textContent = "";
    $("pareto-error").textContent = e.message;
    $("pareto-error").hidden = false;
    hgSpc.pareto = null;
  } finally {
    hgSpc.busy--;
  }
}

async function start() {
  const programs = await hg.get("/api/programs");
  const select = $("f-program");
  for (const p of programs.programs) select.append(hg.el("option", { value: p.number, text: String(p.number) }));
  select.addEventListener("change", () => { $("f-landmark").replaceChildren(); load(); loadPareto(); });
  $("filters").addEventListener("submit", (ev) => { ev.preventDefault(); load(); });
  $("pareto-filters").addEventListener("submit", (ev) => { ev.preventDefault(); loadPareto(); });
  for (const th of $("overview").tHead.rows[0].cells)
    th.addEventListener("click", () => {
      overviewSort.ascending = overviewSort.key === th.dataset.key ? !overviewSort.ascending : true;
      overviewSort.key = th.dataset.key;
      showOverview();
    });
  await Promise.all([load(), loadPareto()]);
}
hgSpc.busy++;
start().catch((e) => { clearCharts(); showError(e.message); }).finally(() => { hgSpc.busy--; hgSpc.ready = true; });
