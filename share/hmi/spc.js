// The quality engineer's SPC page (docs/hmi.md, "SPC"; formulas in docs/spc.md):
// individuals and moving-range charts with their limits from the baseline,
// the run rules flagged, the histogram over the tolerance zone, capability
// and yield, from /api/spc. Chart.js from Debian's libjs-chart.js.
"use strict";
hg.nav("/spc");

const charts = {};
const RED = "#c62828", BLUE = "#2f5f8f", GREY = "#8a949c", GREEN = "#1b8a3a";

function line(label, y, n, colour, dash) {
  return { label, data: [{ x: 0, y }, { x: Math.max(n - 1, 1), y }], borderColor: colour, borderDash: dash,
    pointRadius: 0, borderWidth: 1.5, fill: false, type: "line" };
}

function draw(id, config) {
  if (charts[id]) charts[id].destroy();
  charts[id] = new Chart(document.getElementById(id), config);
}

function linear(title) { return { type: "linear", title: { display: true, text: title } }; }

function individuals(s) {
  const pts = s.points.map((p) => ({ x: p.index, y: p.value_mm, serial: p.serial, rules: p.rules }));
  const flagged = (p) => p.rules.length > 0;
  const n = pts.length;
  const datasets = [{ label: s.id, data: pts, type: "line", borderColor: BLUE, borderWidth: 1,
    pointBackgroundColor: pts.map((p) => (flagged(p) ? RED : BLUE)), pointRadius: pts.map((p) => (flagged(p) ? 5 : 3)) }];
  if (s.i_chart) {
    datasets.push(line("CL", s.i_chart.centre_mm, n, GREEN), line("UCL", s.i_chart.ucl_mm, n, RED, [6, 4]),
      line("LCL", s.i_chart.lcl_mm, n, RED, [6, 4]));
  }
  datasets.push(line("USL", s.zone_mm[1], n, GREY, [2, 2]), line("LSL", s.zone_mm[0], n, GREY, [2, 2]));
  draw("chart-i", { type: "line", data: { datasets }, options: { animation: false, parsing: false,
    scales: { x: linear("cycle"), y: linear(s.values === "deviation_mm" ? "deviation mm" : "bracket middle mm") },
    plugins: { tooltip: { callbacks: { label: (c) => c.raw.serial !== undefined
      ? `${c.raw.serial}: ${c.raw.y.toFixed(4)} mm ${c.raw.rules.join(" ")}` : `${c.dataset.label} ${c.raw.y.toFixed(4)}` } } } } });
}

function movingRange(s) {
  const pts = s.points.filter((p) => p.moving_range_mm !== null).map((p) => ({ x: p.index, y: p.moving_range_mm }));
  const n = s.points.length;
  const datasets = [{ label: "MR", data: pts, type: "line", borderColor: BLUE, borderWidth: 1, pointRadius: 2,
    pointBackgroundColor: s.points.filter((p) => p.moving_range_mm !== null).map((p) => (p.mr_above_ucl ? RED : BLUE)) }];
  if (s.mr_chart) datasets.push(line("MR̄", s.mr_chart.centre_mm, n, GREEN), line("UCL", s.mr_chart.ucl_mm, n, RED, [6, 4]));
  draw("chart-mr", { type: "line", data: { datasets }, options: { animation: false, parsing: false,
    scales: { x: linear("cycle"), y: linear("moving range mm") } } });
}

function histogram(s) {
  const e = s.histogram.edges_mm;
  const bars = s.histogram.counts.map((c, i) => ({ x: (e[i] + e[i + 1]) / 2, y: c }));
  const top = Math.max(1, ...s.histogram.counts);
  const limit = (label, x, colour) => ({ label, data: [{ x, y: 0 }, { x, y: top }], type: "line", borderColor: colour,
    borderDash: [4, 3], pointRadius: 0 });
  draw("chart-hist", { type: "bar", data: { datasets: [
    { label: "values", data: bars, backgroundColor: "#7da3c8", barPercentage: 1, categoryPercentage: 1 },
    limit("LSL", s.zone_mm[0], RED), limit("USL", s.zone_mm[1], RED)] },
  options: { animation: false, parsing: false, scales: { x: linear("mm"), y: { beginAtZero: true, title: { display: true, text: "count" } } } } });
}

function facts(id, rows) {
  const dl = document.getElementById(id);
  dl.replaceChildren();
  for (const [k, v] of rows) dl.append(hg.el("dt", { text: k }), hg.el("dd", { text: v }));
}

function num(v, digits = 2) { return typeof v === "number" ? v.toFixed(digits) : "—"; }

function show(s) {
  if (!s.evaluated) {
    document.getElementById("error").textContent = `${s.id}: ${s.not_evaluated}`;
    return;
  }
  individuals(s);
  movingRange(s);
  histogram(s);
  const c = s.capability;
  facts("capability", [["Values", `${s.n} (${s.values})`], ["Zone mm", `[${hg.mm(s.zone_mm[0])}, ${hg.mm(s.zone_mm[1])}]`],
    ["Mean mm", hg.mm(c.mean_mm)], ["Cp", num(c.cp)], ["Cpk", num(c.cpk)], ["Pp", num(c.pp)], ["Ppk", num(c.ppk)],
    ["Yield", `${(100 * s.yield.fraction).toFixed(1)} % (${s.yield.within} of ${s.yield.n})`]]);
  facts("limits", s.i_chart ? [["Baseline", `${s.baseline.used} values${s.baseline.short ? " (fewer than asked)" : ""}`],
    ["CL mm", hg.mm(s.i_chart.centre_mm)], ["UCL / LCL mm", `${hg.mm(s.i_chart.ucl_mm)} / ${hg.mm(s.i_chart.lcl_mm)}`],
    ["σ within mm", hg.mm(s.i_chart.sigma_within_mm, 5)], ["MR̄ / UCL mm", `${hg.mm(s.mr_chart.centre_mm)} / ${hg.mm(s.mr_chart.ucl_mm)}`]]
    : [["Limits", "fewer than 2 values"]]);
  const list = document.getElementById("rules");
  list.replaceChildren();
  for (const v of s.rules.violations)
    list.append(hg.el("li", { text: `${v.rule} at point ${v.point} (${s.points[v.point].serial})` }));
  if (!s.rules.violations.length) list.append(hg.el("li", { class: "muted", text: `none (${s.rules.set})` }));
  if (s.rules.not_tested) list.append(hg.el("li", { class: "muted", text: s.rules.not_tested }));
}

// Only the latest load draws: an earlier selection's answer arriving late must not replace it.
let latestLoad = 0;
async function load() {
  const mine = ++latestLoad;
  const program = document.getElementById("f-program").value;
  if (!program) return;
  const params = new URLSearchParams({ program, baseline: document.getElementById("f-baseline").value,
    rules: document.getElementById("f-rules").value, limit: document.getElementById("f-limit").value });
  const landmark = document.getElementById("f-landmark").value;
  if (landmark) params.set("landmark", landmark);
  try {
    const body = await hg.get("/api/spc?" + params.toString());
    if (mine !== latestLoad) return;
    const select = document.getElementById("f-landmark");
    if (!select.options.length) {
      for (const id of body.landmark_ids) select.append(hg.el("option", { value: id, text: id }));
      if (!body.landmark_ids.length) throw new Error("no production cycles of program " + program + " yet");
      return load();
    }
    document.getElementById("error").textContent = "";
    show(body.landmarks[0]);
  } catch (e) {
    if (mine === latestLoad) document.getElementById("error").textContent = e.message;
  }
}

async function start() {
  const programs = await hg.get("/api/programs");
  const select = document.getElementById("f-program");
  for (const p of programs.programs) select.append(hg.el("option", { value: p.number, text: String(p.number) }));
  select.addEventListener("change", () => { document.getElementById("f-landmark").replaceChildren(); load(); });
  document.getElementById("filters").addEventListener("submit", (ev) => { ev.preventDefault(); load(); });
  await load();
}
start().catch((e) => { document.getElementById("error").textContent = e.message; });
