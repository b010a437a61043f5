#!/usr/bin/python3
"""The web HMI in a real browser (docs/hmi.md): Debian's chromium, headless,
driven by chromium-driver through selenium, against the simulated line
(tools/simline --http-port). This script is the PLC (pymodbus): it triggers
cycles, nominal and defective parts in turn, and checks what the pages show
against the result store read here with sqlite3:

- the line view shows the PLC's counters as the registers hold them, and
  each cycle's verdict and result id within two of its
  own status polls (250 ms apart) after DONE_SEQ — counted by the page's polls,
  not by the wall clock, so a loaded machine cannot fail it; the wall-clock
  latency is printed;
- the failed part's annotated views load (naturalWidth > 0) and its failed
  landmarks are the stored ones;
- the results search finds a serial; a result page lists every landmark;
  the page's CSV download holds one row per stored landmark measurement
  (read with Python's csv module);
- the SPC chart's plotted points are the stored values of the PLC's
  production cycles (a master cycle and a maintenance-triggered one are
  left out);
- maintenance: refused without a session, the purpose set from the page
  after signing in reaches the daemon; the calibration history lists the
  station file; a camera snapshot grabbed at a pose typed on the page shows
  the silhouette the station reports (its coloured pixels counted in the
  browser); bad requests get 4xx.

  hmi_browser.py --source DIR --bin DIR [--cycles N] [--screenshots DIR]
"""
import csv
import http.client
import io
import json
import sqlite3
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, outcome, test_args, free_port, maintenance, password_hash_file, start_line, stop_line  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402
from selenium import webdriver  # noqa: E402
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.common.exceptions import TimeoutException  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402

DONE_SEQ = 101
PASSWORD = "hmi-test-password"


def encode_serial(text):
    raw = text.encode("ascii")[:16].ljust(16, b"\0")
    return [(raw[i] << 8) | raw[i + 1] for i in range(0, 16, 2)]


def browser(window=(1400, 1100), flags=()):
    """Debian's chromium, headless, through chromium-driver; `window` its size, `flags` more switches
    (the Parts page's 3D view needs --enable-unsafe-swiftshader for WebGL without a GPU)."""
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 f"--window-size={window[0]},{window[1]}", "--disable-extensions", "--no-first-run", *flags):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    driver.set_page_load_timeout(60)
    driver.set_script_timeout(60)
    return driver


def until(driver, script, timeout_s=60, *args):
    """Polls a script in the page (every 50 ms, at most timeout_s) until it answers something true; that answer."""
    return WebDriverWait(driver, timeout_s, poll_frequency=0.05).until(lambda d: d.execute_script(script, *args))


def texts(driver, css, attribute=None):
    """The text (or an attribute) of every element matching css, read in one script: the pages
    re-render their tables when an answer arrives, and an element found in one WebDriver call
    may be gone by the next (a stale element)."""
    return driver.execute_script(
        "return [...document.querySelectorAll(arguments[0])]"
        ".map(e => arguments[1] ? e.getAttribute(arguments[1]) : e.innerText.trim())", css, attribute)


def plc_cycle(client, seq, serial, timeout_s=60):
    """One PLC handshake: program 1, the serial and a new TRIGGER_SEQ in one block; wait for DONE_SEQ."""
    w = client.write_registers(0, [seq, 1] + encode_serial(serial), slave=1)
    if w.isError():
        raise RuntimeError(f"trigger write failed: {w}")
    deadline = time.monotonic() + timeout_s
    while True:
        r = client.read_holding_registers(DONE_SEQ, 1, slave=1)
        if not r.isError() and r.registers[0] == seq:
            return time.monotonic()
        if time.monotonic() > deadline:
            raise RuntimeError(f"no DONE_SEQ {seq} within {timeout_s} s")
        time.sleep(0.005)


def stored(db, serial):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    con.row_factory = sqlite3.Row
    row = con.execute("SELECT * FROM inspections WHERE serial = ? ORDER BY id DESC LIMIT 1", (serial,)).fetchone()
    con.close()
    return row


def line_view_cycles(driver, url, client, sock, db, cycles, screenshots):
    """Cycles with the line view open; returns the wall-clock latencies (s) from DONE_SEQ to the page."""
    driver.get(url + "/")
    WebDriverWait(driver, 30).until(lambda d: d.execute_script("return window.hgLine && window.hgLine.polls > 0"))
    latencies = []
    seq = client.read_holding_registers(0, 1, slave=1).registers[0]
    for i in range(cycles):
        bad = i % 2 == 1
        serial = f"{'BAD' if bad else 'SN'}-HMI-{i:03d}"
        maintenance(sock, {"command": "sim-part", "name": "face-low" if bad else "nominal"})
        seq = (seq + 1) % 65536 or 1
        done = plc_cycle(client, seq, serial)
        polls_at_done = driver.execute_script("return window.hgLine.polls")
        row = stored(db, serial)
        if not check(row is not None, f"cycle {serial}: no stored row"):
            continue
        WebDriverWait(driver, 30, poll_frequency=0.02).until(
            lambda d: d.execute_script("return window.hgLine.shownResult") == row["id"])
        shown_at = time.monotonic()
        polls = driver.execute_script("return window.hgLine.polls") - polls_at_done
        latencies.append(shown_at - done)
        # One poll may have been under way at DONE_SEQ; the next two see the stored result.
        check(polls <= 3, f"cycle {serial}: the line view took {polls} polls after DONE_SEQ to show it")
        verdict = driver.find_element(By.ID, "verdict").text.lower()
        check(verdict == row["verdict"], f"cycle {serial}: the page shows {verdict!r}, the store {row['verdict']!r}")
        check(driver.find_element(By.ID, "serial").text == serial, f"cycle {serial}: serial shown wrong")
        check(row["verdict"] == ("fail" if bad else "pass"), f"cycle {serial}: verdict {row['verdict']}")
        if bad:
            failed_part(driver, row, serial)
    plc_counters(driver, client)
    return latencies, seq


def plc_counters(driver, client):
    """The line view's PLC counters are the registers' (docs/plc.md: five u32, high word first, at 136)."""
    r = client.read_holding_registers(136, 10, slave=1).registers
    triggers, passes, fails, faults, missed = ((r[2 * k] << 16) | r[2 * k + 1] for k in range(5))
    want = [str(v) for v in (triggers, passes, fails, faults, missed)]
    ids = ["#count-triggers", "#count-passes", "#count-fails", "#count-faults", "#count-missed"]
    try:
        WebDriverWait(driver, 30).until(lambda d: [texts(d, i)[0] for i in ids] == want)
    except TimeoutException:
        pass  # reported by the check below, with what the page shows
    shown = [texts(driver, i)[0] for i in ids]
    check(shown == want, f"line view PLC counters {shown}, the registers {want}")
    check(passes + fails == triggers and passes > 0 and fails > 0, f"PLC counters {want} after the cycles")


def failed_part(driver, row, serial):
    WebDriverWait(driver, 30).until(lambda d: d.execute_script("return window.hgLine.shownFailed") == row["id"])
    images = driver.find_elements(By.CSS_SELECTOR, "#failed-images img")
    check(len(images) > 0, f"{serial}: the failed part's views are not on the line view")
    loaded = WebDriverWait(driver, 30).until(lambda d: d.execute_script(
        "const imgs = [...document.querySelectorAll('#failed-images img')];"
        "return imgs.every(i => i.complete) ? imgs.map(i => i.naturalWidth) : false"))
    check(all(w > 0 for w in loaded), f"{serial}: a failed part's view did not load ({loaded})")
    expected = sorted(l["id"] for l in json.loads(row["landmarks_json"]) if l["status"] != "ok")
    listed = sorted(texts(driver, "#failed-landmarks tr[data-landmark]", "data-landmark"))
    check(listed == expected, f"{serial}: failed landmarks listed {listed}, stored {expected}")


# The sizes of the pictures in docs/hmi.md: a line's 1080p panel and a 1280 x 800 panel PC.
SIZES = [(1920, 1080), (1280, 800)]


def set_viewport(driver, width, height):
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                           {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})


def save_at_sizes(driver, folder, stem, ready=None, before=None):
    """`stem`-WxH.png at each of SIZES: the page laid out again at that viewport (`ready` waited for, a
    JavaScript condition; `before` run first, e.g. a scroll), then the emulation cleared."""
    try:
        for width, height in SIZES:
            set_viewport(driver, width, height)
            if before:
                driver.execute_script(before)
            if ready:
                WebDriverWait(driver, 30).until(lambda d: d.execute_script(ready))
            driver.save_screenshot(str(folder / f"{stem}-{width}x{height}.png"))
    finally:
        driver.execute_cdp_cmd("Emulation.clearDeviceMetricsOverride", {})


IMAGES_LOADED = "return [...document.querySelectorAll('#images img')].every(i => i.complete)"


def search_and_result(driver, url, db, serial, screenshots):
    driver.get(url + "/results")
    box = driver.find_element(By.ID, "f-serial")
    box.send_keys(serial)
    driver.find_element(By.ID, "search").click()
    WebDriverWait(driver, 30).until(
        lambda d: texts(d, "#results td.serial") == [serial])
    if screenshots:
        driver.find_element(By.ID, "f-serial").clear()
        driver.find_element(By.ID, "search").click()
        WebDriverWait(driver, 30).until(lambda d: len(texts(d, "#results tbody tr")) > 3)
        save_at_sizes(driver, screenshots, "hmi-results")
    csv_download(driver, db)
    row = stored(db, serial)
    driver.get(f"{url}/result?id={row['id']}")
    landmarks = json.loads(row["landmarks_json"])
    WebDriverWait(driver, 30).until(
        lambda d: len(texts(d, "#landmarks tr[data-landmark]")) == len(landmarks))
    statuses = dict(zip(texts(driver, "#landmarks tr[data-landmark]", "data-landmark"),
                        texts(driver, "#landmarks tr[data-landmark]", "data-status")))
    check(statuses == {l["id"]: l["status"] for l in landmarks}, f"result {row['id']}: statuses shown {statuses}")
    if screenshots:
        save_at_sizes(driver, screenshots, "hmi-result", IMAGES_LOADED)


def csv_download(driver, db):
    """The results page's CSV link: every landmark of every stored cycle (no filter set), RFC 4180."""
    href = driver.find_element(By.ID, "dl-csv").get_attribute("href")
    status, body = request(int(href.split(":")[2].split("/")[0]), "GET", href[href.index("/api/"):])
    if not check(status == 200, f"CSV download {href}: HTTP {status}"):
        return
    rows = list(csv.DictReader(io.StringIO(body.decode("utf-8"), newline="")))
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    expected = sorted((rid, l["id"]) for rid, lj in con.execute("SELECT id, landmarks_json FROM inspections")
                      for l in json.loads(lj))
    con.close()
    got = sorted((int(r["result_id"]), r["landmark"]) for r in rows)
    check(got == expected, f"CSV download: {len(got)} landmark rows, the store holds {len(expected)}")
    check(body.count(b"\r\n") == len(rows) + 1 + sum(r["serial"].count("\r\n") for r in rows),
          "CSV download: lines not ended with CRLF")


def spc_expected(db, landmark):
    """The values the SPC chart must plot: PLC production pass/fail cycles of program 1, oldest first;
    the deviation when every such cycle has one for the landmark, else the bracket middle (docs/spc.md)."""
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    rows = con.execute("SELECT landmarks_json FROM inspections WHERE program = 1 AND purpose = 'production' "
                       "AND manual = 0 AND verdict IN ('pass', 'fail') ORDER BY id").fetchall()
    con.close()
    entries = [next(l for l in json.loads(r[0]) if l["id"] == landmark) for r in rows]
    key = "deviation_mm" if all("deviation_mm" in e for e in entries) else "error_mm"
    return [e[key] for e in entries]


def spc_page(driver, url, db, screenshots):
    driver.get(url + "/spc")
    WebDriverWait(driver, 30).until(lambda d: d.execute_script(
        "const c = Chart.getChart(document.getElementById('chart-i')); return !!c && c.data.datasets[0].data.length > 0"))
    landmark = Select(driver.find_element(By.ID, "f-landmark")).first_selected_option.get_attribute("value")
    plotted = driver.execute_script(
        "return Chart.getChart(document.getElementById('chart-i')).data.datasets[0].data.map(p => p.y)")
    expected = spc_expected(db, landmark)
    check(len(plotted) == len(expected) and all(abs(a - b) <= 1e-9 for a, b in zip(plotted, expected)),
          f"SPC {landmark}: plotted {plotted}, stored {expected}")
    if screenshots:
        driver.save_screenshot(str(screenshots / "hmi-spc.png"))


def request(port, method, path, body=None, headers=None):
    con = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    con.request(method, path, body=body, headers=headers or {})
    res = con.getresponse()
    data = res.read()
    con.close()
    return res.status, data


def maintenance_page(driver, url, port, sock, screenshots):
    status, _ = request(port, "POST", "/api/maintenance", json.dumps({"command": "purpose", "purpose": "study"}),
                        {"Content-Type": "application/json"})
    check(status == 401, f"maintenance without a session answered {status}")
    check(request(port, "GET", "/api/results?since=yesterday")[0] == 400, "a malformed since was not a 400")
    check(request(port, "POST", "/api/login", "x" * 70000, {"Content-Type": "application/json"})[0] == 413,
          "an oversized request was not a 413")
    driver.get(url + "/maintenance")
    WebDriverWait(driver, 30).until(lambda d: d.find_element(By.ID, "login").is_displayed())
    driver.find_element(By.ID, "password").send_keys(PASSWORD)
    driver.find_element(By.CSS_SELECTOR, "#login button").click()
    WebDriverWait(driver, 30).until(lambda d: d.find_element(By.ID, "actions").is_displayed())
    Select(driver.find_element(By.ID, "purpose")).select_by_visible_text("master")
    driver.find_element(By.ID, "set-purpose").click()
    deadline = time.monotonic() + 30
    while maintenance(sock, {"command": "purpose"})["purpose"] != "master" and time.monotonic() < deadline:
        time.sleep(0.05)
    check(maintenance(sock, {"command": "purpose"})["purpose"] == "master", "the purpose set on the page did not arrive")
    history = texts(driver, "#calibration-history tr[data-file]", "data-file")
    check(history[:1] == ["station.yaml"], f"calibration history lists {history}, not the station file first")
    snapshot(driver)
    if screenshots:
        save_at_sizes(driver, screenshots, "hmi-maintenance")
        driver.execute_script("document.getElementById('snapshot-facts').scrollIntoView()")
        driver.save_screenshot(str(screenshots / "hmi-snapshot.png"))


def snapshot(driver):
    """A camera frame on demand: grabbed at a pose typed on the page; the picture's silhouette (every pixel
    the overlay coloured: tinted or outlined, the backlight staying grey) read back in the browser from a
    canvas and compared with the share of object pixels the station reports."""
    driver.find_element(By.ID, "snap-rotation").send_keys("30")
    driver.find_element(By.ID, "snap-declination").send_keys("10")
    driver.find_element(By.ID, "grab").click()
    WebDriverWait(driver, 60).until(lambda d: d.execute_script(
        "const i = document.getElementById('snapshot-img');"
        "return window.hgMaintenance.snapshotShown !== null && i.complete && i.naturalWidth > 0"))
    status = json.loads(driver.execute_script(
        "return fetch('/api/snapshot').then(r => r.text())"))["snapshot"]
    check(status["state"] == "done" and status["pose"] == {"rotation_deg": 30, "declination_deg": 10},
          f"snapshot status {status}")
    coloured = driver.execute_script(
        "const i = document.getElementById('snapshot-img'); const c = document.createElement('canvas');"
        "c.width = i.naturalWidth; c.height = i.naturalHeight; const g = c.getContext('2d');"
        "g.drawImage(i, 0, 0); const d = g.getImageData(0, 0, c.width, c.height).data; let n = 0;"
        "for (let k = 0; k < d.length; k += 4) if (d[k] !== d[k + 1] || d[k + 1] !== d[k + 2]) ++n;"
        "return [c.width, c.height, n]")
    width, height, n = coloured
    check((width, height) == (1280, 960), f"snapshot {width}x{height}, the camera's frame is 1280x960")
    check(0.01 < status["object_fraction"] < 0.9 and abs(n / (width * height) - status["object_fraction"]) < 1e-9,
          f"snapshot: {n} coloured pixels of {width * height}, the station reports {status['object_fraction']}")


def main():
    args = test_args(lambda ap: ap.add_argument("--cycles", type=int, default=6))
    workdir = Path(tempfile.mkdtemp(prefix="hg-hmi-"))
    plc_port, http_port = free_port(), free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, plc_port,
                              ["--http-port", str(http_port),
                               "--hmi-password-hash-file", str(password_hash_file(workdir, PASSWORD)),
                               "--config", str(args.source / "config" / "sim-fast")])
    url = f"http://127.0.0.1:{http_port}"
    sock = str(workdir / "hullgauged.sock")
    db = workdir / "results.db"
    driver = browser()
    client = ModbusTcpClient("127.0.0.1", port=plc_port, timeout=10)
    try:
        check(client.connect(), "the PLC client could not connect")
        latencies, seq = line_view_cycles(driver, url, client, sock, db, args.cycles, args.screenshots)
        # A master cycle and a maintenance-triggered one: neither may reach the SPC chart.
        maintenance(sock, {"command": "purpose", "purpose": "master"})
        plc_cycle(client, (seq + 1) % 65536 or 1, "MASTER-1")
        maintenance(sock, {"command": "purpose", "purpose": "production"})
        maintenance(sock, {"command": "trigger", "program": 1, "serial": "MANUAL-1"})
        deadline = time.monotonic() + 60
        while stored(db, "MANUAL-1") is None and time.monotonic() < deadline:
            time.sleep(0.05)
        search_and_result(driver, url, db, "BAD-HMI-001", args.screenshots)
        spc_page(driver, url, db, args.screenshots)
        maintenance_page(driver, url, http_port, sock, args.screenshots)
        if latencies:
            print(f"line view: DONE_SEQ -> page, {len(latencies)} cycles: median "
                  f"{1000 * statistics.median(latencies):.0f} ms, max {1000 * max(latencies):.0f} ms", flush=True)
    finally:
        client.close()
        driver.quit()
        stop_line(line, out)
    return outcome("web HMI", workdir)


if __name__ == "__main__":
    sys.exit(main())
