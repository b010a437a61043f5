#!/usr/bin/python3
"""The SPC page for a quality engineer in a real browser (docs/spc.md,
docs/hmi.md "SPC"): Debian's chromium, headless, through selenium, against
the simulated line (tools/simline --http-port). This script is the PLC
(pymodbus): it runs nominal parts and parts with a corner missing — whose
corner landmark is then not found — and checks the page against the result
store read here with sqlite3:

- after a landmark without gaps is charted, choosing one with `not_found`
  cycles charts that landmark (no earlier chart stays): its points are the
  stored values at their cycles, a gap marker at every cycle without a
  value, and the page says how many and why;
- the run rules the server found are listed in words, each naming its
  cycles, and the points they involve are marked on the chart;
- the overview lists every characteristic with its Cpk, Ppk, yield and
  violations, each Cpk/Ppk in its capability band's colour, and sorts by a
  column when its heading is clicked;
- a load the server refuses clears every chart and card and says why at the
  top;
- the Pareto of failed landmarks and fault codes counts what the store holds
  (counted here from the stored landmarks), most first.

  spc_browser.py --source DIR --bin DIR [--screenshots DIR]
"""
import json
import sqlite3
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, outcome, test_args, free_port, maintenance, start_line, stop_line  # noqa: E402
from hmi_browser import browser, plc_cycle, until  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402
from selenium.webdriver.support.ui import Select  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402

# Nominal parts, and a part with its corner missing at cycles 5 and 9 (1-based).
PLAN = ["nominal"] * 4 + ["corner-missing"] + ["nominal"] * 3 + ["corner-missing"] + ["nominal"] * 3


def settled(driver):
    until(driver, "return window.hgSpc && hgSpc.ready && hgSpc.busy === 0")


def production(db):
    """The PLC's production pass/fail cycles of program 1, oldest first: what the charts count."""
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    rows = con.execute("SELECT serial, landmarks_json FROM inspections WHERE program = 1 AND purpose = 'production' "
                       "AND manual = 0 AND verdict IN ('pass', 'fail') ORDER BY id").fetchall()
    con.close()
    return [(serial, {l["id"]: l for l in json.loads(landmarks)}) for serial, landmarks in rows]


def expected_series(cycles, landmark):
    """Values at their cycles and the gaps (docs/spc.md, "Gaps"): a cycle whose landmark is not_found,
    not_observable or not listed has no value; the deviation when every value has one, else the bracket middle."""
    present = [(k, c[landmark]) for k, (_, c) in enumerate(cycles)
               if landmark in c and c[landmark]["status"] not in ("not_found", "not_observable")]
    gaps = [k for k, (_, c) in enumerate(cycles)
            if landmark not in c or c[landmark]["status"] in ("not_found", "not_observable")]
    key = "deviation_mm" if all("deviation_mm" in e for _, e in present) else "error_mm"
    return [k for k, _ in present], [e[key] for _, e in present], gaps


def choose(driver, landmark):
    before = driver.execute_script("return hgSpc.loads")
    Select(driver.find_element(By.ID, "f-landmark")).select_by_value(landmark)
    driver.find_element(By.CSS_SELECTOR, "#filters button[type=submit]").click()
    until(driver, "return hgSpc.loads > arguments[0] && hgSpc.busy === 0", 60, before)


def charted(driver):
    return driver.execute_script(
        "const c = Chart.getChart(document.getElementById('chart-i'));"
        "if (!c) return null;"
        "const pts = c.data.datasets[0].data, gap = c.data.datasets.find(d => d.label === 'no value (gap)');"
        "return {label: c.data.datasets[0].label, x: pts.map(p => p.x), y: pts.map(p => p.y),"
        " gaps: gap ? gap.data.map(p => p.x) : [], width: c.data.datasets[0].pointBorderWidth}")


def gaps_and_no_stale_chart(driver, db):
    cycles = production(db)
    with_gaps = [lid for lid in cycles[0][1] if expected_series(cycles, lid)[2]]
    without = [lid for lid in cycles[0][1] if not expected_series(cycles, lid)[2]]
    if not check(with_gaps and without, f"landmarks with gaps {with_gaps}, without {without}"):
        return None
    choose(driver, without[0])
    first = charted(driver)
    check(first and first["label"] == without[0], f"{without[0]} was not charted: {first}")
    landmark = with_gaps[0]
    choose(driver, landmark)
    shown = charted(driver)
    xs, ys, gaps = expected_series(cycles, landmark)
    check(shown and shown["label"] == landmark, f"after choosing {landmark} the chart is {shown and shown['label']}")
    check(shown and shown["x"] == [k + 1 for k in xs] and
          all(abs(a - b) <= 1e-9 for a, b in zip(shown["y"], ys)) and len(shown["y"]) == len(ys),
          f"{landmark}: plotted {shown}, stored cycles {xs} values {ys}")
    check(shown and shown["gaps"] == [k + 1 for k in gaps], f"{landmark}: gap markers {shown and shown['gaps']}, gaps {gaps}")
    note = driver.find_element(By.ID, "gaps-note").text
    check(f"{len(gaps)} of {len(cycles)} cycles have no value" in note and "not found" in note, f"the gaps are said {note!r}")
    check(not driver.find_element(By.ID, "error").is_displayed(), "an error is shown beside the chart")
    return landmark


def rules_in_words(driver, port_url, landmark):
    api = driver.execute_script(
        "return fetch('/api/spc?program=1&landmark=' + encodeURIComponent(arguments[0]) + '&baseline=' +"
        "document.getElementById('f-baseline').value + '&rules=nelson&limit=500').then(r => r.json())", landmark)
    s = api["landmarks"][0]
    items = driver.execute_script("return [...document.querySelectorAll('#rules li')].map(li => li.textContent)")
    violations = s["rules"]["violations"]
    if not violations:
        check(len(items) >= 1 and items[0].startswith("No rule violated"), f"no violation, the page lists {items}")
        return
    check(len(items) >= len(violations), f"{len(violations)} violations, {len(items)} listed")
    width = charted(driver)["width"]
    for v, text in zip(violations, items):
        last = s["points"][v["points"][-1]]
        check(text.startswith(("Nelson ", "Western Electric ")) and "cycle" in text and str(last["cycle"] + 1) in text
              and "_" not in text.split(":")[0], f"{v} said as {text!r}")
        check(all(width[i] == 3 for i in v["points"]), f"the points of {v['rule']} are not marked: {width}")


def overview(driver):
    rows = driver.execute_script(
        "return [...document.querySelectorAll('#overview tbody tr')].map(r => [r.dataset.landmark,"
        " r.cells[3].textContent, r.cells[3].className])")
    landmarks = driver.execute_script("return [...document.getElementById('f-landmark').options].map(o => o.value)")
    check(sorted(r[0] for r in rows) == sorted(landmarks), f"the overview lists {[r[0] for r in rows]}, the program {landmarks}")
    for lid, cpk, cls in rows:
        if cpk == "—":
            continue
        value = float(cpk)
        band = ("band-excellent" if value >= 1.67 else "band-capable" if value >= 1.33
                else "band-marginal" if value >= 1.0 else "band-incapable")
        check(band in cls, f"{lid}: Cpk {cpk} drawn as {cls}")
    header = driver.find_element(By.CSS_SELECTOR, "#overview th[data-key='id']")
    header.click()
    ids = driver.execute_script("return [...document.querySelectorAll('#overview tbody tr')].map(r => r.dataset.landmark)")
    check(ids == sorted(ids), f"sorted by landmark: {ids}")
    header.click()
    ids = driver.execute_script("return [...document.querySelectorAll('#overview tbody tr')].map(r => r.dataset.landmark)")
    check(ids == sorted(ids, reverse=True), f"sorted by landmark, descending: {ids}")


def refused_load_clears(driver):
    base = driver.find_element(By.ID, "f-baseline")
    base.clear()
    base.send_keys("1")
    driver.execute_script("document.getElementById('f-baseline').removeAttribute('min')")
    before = driver.execute_script("return hgSpc.loads")
    driver.find_element(By.CSS_SELECTOR, "#filters button[type=submit]").click()
    until(driver, "return hgSpc.loads > arguments[0] && hgSpc.busy === 0", 60, before)
    state = driver.execute_script(
        "return {chart: !!Chart.getChart(document.getElementById('chart-i')), error: document.getElementById('error').textContent,"
        " shown: !document.getElementById('error').hidden, top: document.getElementById('error').getBoundingClientRect().top,"
        " cards: document.getElementById('capability').children.length + document.getElementById('rules').children.length,"
        " charts: !document.getElementById('charts').hidden}")
    check(not state["chart"] and not state["charts"] and state["cards"] == 0, f"a refused load left {state}")
    check(state["shown"] and "baseline" in state["error"] and state["top"] < 300, f"the refusal is said {state}")
    base.clear()
    base.send_keys("25")


def pareto(driver, db):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    rows = con.execute("SELECT landmarks_json, fault_code FROM inspections WHERE program = 1 AND purpose = 'production' "
                       "AND manual = 0").fetchall()
    con.close()
    counts, faults = {}, {}
    for landmarks, code in rows:
        for l in json.loads(landmarks):
            if l.get("status", "ok") != "ok":
                counts[l["id"]] = counts.get(l["id"], 0) + 1
        if code:
            faults[code] = faults.get(code, 0) + 1
    shown = driver.execute_script(
        "return [...document.querySelectorAll('#pareto-landmark-table tr')].slice(1)"
        ".filter(r => r.cells.length > 1).map(r => [r.cells[0].textContent, +r.cells[1].textContent])")
    expected = sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))
    check([tuple(r) for r in shown] == expected, f"Pareto of landmarks {shown}, the store {expected}")
    bars = driver.execute_script("const c = Chart.getChart(document.getElementById('pareto-landmarks'));"
                                 "return c ? [c.data.labels, c.data.datasets[0].data] : null")
    check(bars == [[k for k, _ in expected], [v for _, v in expected]], f"the Pareto chart draws {bars}")
    check(sum(faults.values()) == driver.execute_script("return hgSpc.pareto.faulted_cycles"),
          f"faulted cycles: the store {faults}")


def screenshots(driver, folder, landmark):
    folder.mkdir(parents=True, exist_ok=True)
    for width, height in ((1920, 1080), (1280, 800)):
        driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                               {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
        choose(driver, landmark)
        driver.execute_script("window.scrollTo(0, 0)")
        driver.save_screenshot(str(folder / f"hmi-spc-{width}x{height}.png"))
        driver.execute_script("document.getElementById('pareto-card').scrollIntoView()")
        driver.save_screenshot(str(folder / f"hmi-spc-pareto-{width}x{height}.png"))
    driver.execute_cdp_cmd("Emulation.clearDeviceMetricsOverride", {})


def main():
    args = test_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-spc-"))
    plc_port, http_port = free_port(), free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, plc_port,
                              ["--http-port", str(http_port), "--config", str(args.source / "config" / "sim-fast")])
    url, sock, db = f"http://127.0.0.1:{http_port}", str(workdir / "hullgauged.sock"), workdir / "results.db"
    driver = browser()
    client = ModbusTcpClient("127.0.0.1", port=plc_port, timeout=10)
    try:
        check(client.connect(), "the PLC client could not connect")
        for k, part in enumerate(PLAN, 1):
            maintenance(sock, {"command": "sim-part", "name": part})
            plc_cycle(client, k, f"SPC{k:03d}")
        driver.get(url + "/spc")
        settled(driver)
        landmark = gaps_and_no_stale_chart(driver, db)
        if landmark:
            rules_in_words(driver, url, landmark)
        overview(driver)
        pareto(driver, db)
        refused_load_clears(driver)
        if args.screenshots and landmark:
            screenshots(driver, args.screenshots, landmark)
    finally:
        client.close()
        driver.quit()
        stop_line(line, out)
    return outcome("SPC page", workdir)


if __name__ == "__main__":
    sys.exit(main())
