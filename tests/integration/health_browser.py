#!/usr/bin/python3
"""The station's health on the maintenance page in a real browser
(docs/health.md, "In the daemon"; docs/hmi.md, "Maintenance"): Debian's
chromium, headless, through selenium, against the simulated line
(tools/simline --http-port) with a focus limit of 1.2 px that its edges
(1.67 px wide) exceed. This script is the PLC (pymodbus). Checked against
the result store read here with sqlite3 and the PLC's registers:

- an engineer signed in takes the flat-field reference with the page's
  button; the simulated line empties its nest for the grabs (sim-part none),
  the page says it is done, the file is written beside the station file and
  the part is back in the nest;
- after PLC cycles the page charts every figure: its plotted points are the
  stored values of the cycles that measured it, the limit is drawn at the
  configured value;
- the latest figures are said in words: the backlight about 1.00 of the
  reference and within its limit, focus beyond its limit — highlighted, its
  chart's title too — as HEALTH_WARNINGS (146) says with bit 3, the
  backlight's, contrast's and noise's bits clear;
- a refused window (a malformed `since`) says why and clears the charts.

  health_browser.py --source DIR --bin DIR [--screenshots DIR]
"""
import re
import sqlite3
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, free_port, maintenance, outcome, password_hash_file, start_line, stop_line, test_args  # noqa: E402
from hmi_browser import PASSWORD, browser, plc_cycle, until  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402

HEALTH_WARNINGS = 146
FOCUS_LIMIT_PX = 1.2
FIGURES = {"backlight": "backlight", "uniformity": "uniformity", "dust": "dust_specks", "focus": "edge_width_px",
           "contrast": "contrast", "noise": "noise", "edge_bias": "edge_bias_px", "capability": "capability"}


def overlay(source, folder):
    """config/sim's daemon configuration with a focus limit its edges exceed (tools/simline --config)."""
    folder.mkdir()
    text = (source / "config" / "sim" / "hullgauged.yaml").read_text()
    (folder / "hullgauged.yaml").write_text(text + f"health:\n  limits: {{max_edge_width_px: {FOCUS_LIMIT_PX}}}\n")
    return folder


def stored(db):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    con.row_factory = sqlite3.Row
    rows = [dict(r) for r in con.execute("SELECT * FROM health ORDER BY unix_ms, inspection_id")]
    con.close()
    return rows


def take_reference(driver, url, workdir, sock):
    driver.get(url + "/maintenance")
    until(driver, "return document.getElementById('login').offsetParent !== null")
    driver.find_element(By.ID, "password").send_keys(PASSWORD)
    driver.find_element(By.CSS_SELECTOR, "#login button").click()
    until(driver, "return !document.getElementById('flat-field-actions').hidden")
    frames = driver.find_element(By.ID, "ff-frames")
    frames.clear()
    frames.send_keys("3")
    driver.find_element(By.ID, "flat-field").click()
    until(driver, "return /Flat-field reference: (done|failed)/.test(document.getElementById('flat-field-state').textContent)", 120)
    said = driver.find_element(By.ID, "flat-field-state").text
    check(said.startswith("Flat-field reference: done"), f"the page says {said!r}")
    check((workdir / "config" / "flat-field.json").is_file(), "no flat-field.json beside the station file")
    check(maintenance(sock, {"command": "status"})["simulated_part"] == "nominal",
          "the part is not back in the nest after the grabs")


def charts(driver, db):
    rows = stored(db)
    check(len(rows) >= 3, f"{len(rows)} health rows stored")
    drawn = driver.execute_script(
        "return [...document.querySelectorAll('#health-charts canvas')].map(c => { const ch = Chart.getChart(c);"
        " return {id: c.id, y: ch.data.datasets[0].data.map(p => p.y), x: ch.data.datasets[0].data.map(p => p.x),"
        " limit: ch.data.datasets[1].data.map(p => p.y)}; })")
    check(len(drawn) == len(FIGURES), f"{len(drawn)} charts drawn, {len(FIGURES)} figures")
    limits = maintenance_limits(driver)
    for chart in drawn:
        key = chart["id"].removeprefix("health-chart-")
        values = [(r["unix_ms"], r[key]) for r in rows if r[key] is not None]
        check(chart["x"] == [t for t, _ in values] and all(abs(a - b) < 1e-9 for a, b in zip(chart["y"], [v for _, v in values])),
              f"{key}: plotted {list(zip(chart['x'], chart['y']))}, stored {values}")
        check(set(chart["limit"]) == {limits[key]}, f"{key}: limit drawn at {chart['limit']}, configured {limits[key]}")
    check(limits["edge_width_px"] == FOCUS_LIMIT_PX, f"the focus limit is {limits['edge_width_px']}")
    # The simulated camera without a halo: the aligned parts' silhouettes are the CAD's, the bias
    # well within its limit, and its chart has the limit on both sides.
    biases = [r["edge_bias_px"] for r in rows if r["edge_bias_px"] is not None]
    check(biases and all(abs(b) < limits["edge_bias_px"] / 2 for b in biases), f"edge bias without a halo: {biases}")
    below = driver.execute_script("const ch = Chart.getChart('health-chart-edge_bias_px');"
                                  " return ch.data.datasets[2] ? ch.data.datasets[2].data.map(p => p.y) : null")
    check(below is not None and set(below) == {-limits["edge_bias_px"]}, f"edge bias: lower limit drawn at {below}")


def maintenance_limits(driver):
    return driver.execute_script("return fetch('/api/health').then(r => r.json()).then(h => h.now.limits)")


def words(driver, client):
    items = driver.execute_script(
        "return [...document.querySelectorAll('#health-latest li')].map(li => [li.dataset.figure, li.className, li.textContent])")
    by = {figure: (cls, text) for figure, cls, text in items}
    cls, text = by.get("backlight", ("", ""))
    check(cls == "within" and re.fullmatch(r"Backlight (0\.99|1\.00|1\.01) of the reference — within limit 0\.80", text),
          f"the backlight is said {text!r} ({cls})")
    cls, text = by.get("focus", ("", ""))
    check(cls == "beyond" and text.startswith("⚠ Focus: edge width") and f"above limit {FOCUS_LIMIT_PX:.2f}" in text,
          f"focus is said {text!r} ({cls})")
    title = driver.execute_script("const h = document.querySelector('#health-box-edge_width_px h3'); return [h.className, h.textContent]")
    check(title[0] == "beyond", f"the focus chart's title is {title}")
    r = client.read_holding_registers(HEALTH_WARNINGS, 1, slave=1)
    bits = None if r.isError() else r.registers[0]
    # Focus (bit 3) beyond its limit; the backlight (0), contrast (4) and noise (5) within theirs.
    check(bits is not None and bits & 0b111001 == 1 << 3, f"HEALTH_WARNINGS {bits}: focus is bit 3")


def refused_window(driver):
    driver.find_element(By.ID, "health-since").send_keys("yesterday")
    driver.find_element(By.CSS_SELECTOR, "#health-window button").click()
    until(driver, "return window.hgMaintenance.health && window.hgMaintenance.health.error")
    state = driver.execute_script(
        "return {error: document.getElementById('health-error').textContent,"
        " charts: document.querySelectorAll('#health-charts canvas').length}")
    check("since" in state["error"] and state["charts"] == 0, f"a refused window left {state}")


def main():
    args = test_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-health-"))
    plc_port, http_port = free_port(), free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, plc_port,
                              ["--http-port", str(http_port), "--hmi-password-hash-file",
                               str(password_hash_file(workdir, PASSWORD)),
                               "--config", str(args.source / "config" / "sim-fast"),
                               "--config", str(overlay(args.source, workdir / "overlay"))])
    url, sock, db = f"http://127.0.0.1:{http_port}", str(workdir / "hullgauged.sock"), workdir / "results.db"
    driver = browser()
    client = ModbusTcpClient("127.0.0.1", port=plc_port, timeout=10)
    try:
        check(client.connect(), "the PLC client could not connect")
        plc_cycle(client, 1, "HEALTH-1")  # before the reference: the backlight is not measured
        take_reference(driver, url, workdir, sock)
        for k in range(2, 6):
            plc_cycle(client, k, f"HEALTH-{k}")
        driver.get(url + "/maintenance")
        until(driver, "return window.hgMaintenance.health && window.hgMaintenance.health.charts")
        charts(driver, db)
        words(driver, client)
        if args.screenshots:
            driver.execute_script("document.getElementById('health').scrollIntoView()")
            driver.save_screenshot(str(args.screenshots / "hmi-health.png"))
        refused_window(driver)
    finally:
        client.close()
        driver.quit()
        stop_line(line, out)
    return outcome("station health page", workdir)


if __name__ == "__main__":
    sys.exit(main())
