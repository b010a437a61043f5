#!/usr/bin/python3
"""The operator's line view and the landmark rows in a real browser (docs/hmi.md,
"Line view" and "Landmark rows"): Debian's chromium, headless, through selenium,
against the simulated line cycled by a pymodbus PLC (this script), everything
checked against what is read here independently — the result store with sqlite3,
the registers with Modbus, the zones with Python's zoneinfo:

- the verdict's rendered text at least 8 % of the viewport's height at
  1920 x 1080 and 1280 x 800 (set with CDP Emulation.setDeviceMetricsOverride),
  measured twice: the text's box and the glyphs' ink (canvas measureText) —
  normal and kiosk;
- the lamps labelled pass, busy / attention / fault, reject (docs/lamps.md) with their state in
  words as the daemon reports them; the station's state in words; the PLC
  status by its docs/plc.md name as the STATUS register holds it;
- times in the browser's local time with its zone: chromium in Europe/Berlin
  (CDP Emulation.setTimezoneOverride), the daemon in Asia/Kolkata (TZ), each
  time compared with the stored UTC converted by zoneinfo; UTC in the tooltip;
- the shift's counters against the store counted with sqlite3 from the
  daemon's local midnight (the default shift "day" from 00:00);
- the filmstrip: the last six failed parts' serials and failed landmarks as
  stored, a click opening the result;
- `?kiosk`: no navigation, no engineer's details, the full-screen button;
- a failed part's result page: every landmark row exactly one reading, a
  not_found row its voxel bracket with the words, no row both.

Screenshots of the line view (normal and kiosk, both sizes) with --screenshots DIR.

  hmi_line_view.py --source DIR --bin DIR [--screenshots DIR]
"""
import datetime
import json
import os
import sqlite3
import sys
import tempfile
import time
from pathlib import Path
from zoneinfo import ZoneInfo

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, outcome, test_args, free_port, maintenance, start_line, stop_line  # noqa: E402
from hmi_browser import SIZES, browser, plc_cycle, set_viewport, stored, texts  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402
from selenium.common.exceptions import TimeoutException  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

BROWSER_ZONE = "Europe/Berlin"
DAEMON_ZONE = "Asia/Kolkata"  # half an hour off any whole-hour zone: a shift start in the wrong zone shows
STATUS = 102
PLC_STATUS_NAMES = {0: "ready", 1: "busy", 2: "done", 3: "fault", 4: "starting", 5: "maintenance"}
STATE_WORDS = {"Starting up", "Ready for the next part", "Judging the part", "In fault",
               "Maintenance: calibration running"}
# The parts the simulated line shows (config/sim's simulation.parts), in turn: seven rejects for a
# filmstrip of six, passes between them.
PARTS = ["corner-missing", "nominal", "face-low", "corner-missing", "nominal", "face-low", "corner-missing",
         "face-low", "nominal", "corner-missing"]


def wait(driver, what, predicate, timeout_s=30):
    """Polls `predicate(driver)` under a deadline; a timeout is a failed check naming `what`."""
    try:
        return WebDriverWait(driver, timeout_s, poll_frequency=0.05).until(predicate)
    except TimeoutException:
        check(False, f"{what}: not within {timeout_s} s")
        return None


def local_text(unix_ms, zone):
    """What the page must show for a stored time: HH:MM:SS and the zone's abbreviation, the date in
    front when it is not today in that zone (common.js, hg.localTime)."""
    t = datetime.datetime.fromtimestamp(unix_ms / 1000, ZoneInfo(zone))
    text = f"{t:%H:%M:%S} {t.tzname()}"
    if t.date() != datetime.datetime.now(ZoneInfo(zone)).date():
        text = f"{t:%Y-%m-%d} {text}"
    return text


def run_cycles(client, sock, db):
    """The PLC cycles of PARTS, then a master cycle and a maintenance-triggered one (neither in the shift)."""
    seq = client.read_holding_registers(0, 1, slave=1).registers[0]
    for i, part in enumerate(PARTS):
        maintenance(sock, {"command": "sim-part", "name": part})
        seq = (seq + 1) % 65536 or 1
        plc_cycle(client, seq, f"{'BAD' if part != 'nominal' else 'SN'}-LINE-{i:02d}")
    maintenance(sock, {"command": "purpose", "purpose": "master"})
    seq = (seq + 1) % 65536 or 1
    plc_cycle(client, seq, "MASTER-LINE")
    maintenance(sock, {"command": "purpose", "purpose": "production"})
    maintenance(sock, {"command": "trigger", "program": 1, "serial": "MANUAL-LINE"})
    deadline = time.monotonic() + 60
    while stored(db, "MANUAL-LINE") is None and time.monotonic() < deadline:
        time.sleep(0.05)
    check(stored(db, "MANUAL-LINE") is not None, "the maintenance-triggered cycle was not stored")


VERDICT_HEIGHT = """
const v = document.getElementById('verdict');
const range = document.createRange(); range.selectNodeContents(v);
const box = range.getBoundingClientRect();
const style = getComputedStyle(v);
const g = document.createElement('canvas').getContext('2d');
g.font = `${style.fontWeight} ${style.fontSize} ${style.fontFamily}`;
const m = g.measureText(v.textContent);
return {box: box.height, ink: m.actualBoundingBoxAscent + m.actualBoundingBoxDescent,
        width: box.width, viewport: window.innerHeight, viewportWidth: window.innerWidth, text: v.textContent};
"""


def verdict_size(driver, label):
    for width, height in SIZES:
        set_viewport(driver, width, height)
        wait(driver, f"{label} viewport {width}x{height}",
             lambda d: d.execute_script("return [innerWidth, innerHeight]") == [width, height])
        m = driver.execute_script(VERDICT_HEIGHT)
        print(f"{label} {width}x{height}: verdict {m['text']!r} box {m['box']:.0f} px, ink {m['ink']:.0f} px "
              f"of {m['viewport']} px ({100 * m['ink'] / m['viewport']:.1f} %)", flush=True)
        check(m["box"] >= 0.08 * m["viewport"] and m["ink"] >= 0.08 * m["viewport"],
              f"{label} {width}x{height}: the verdict's text is {m['box']:.0f} px (ink {m['ink']:.0f} px), "
              f"less than 8 % of {m['viewport']} px")
        check(m["width"] <= m["viewportWidth"], f"{label} {width}x{height}: the verdict is wider than the screen")


def lamps_and_state(driver, client, status):
    labels = texts(driver, ".lamp-box .lamp-label")
    check(labels == ["pass", "busy / attention / fault", "reject"], f"lamp labels {labels}")
    words = {"on": "lit", "blinking": "blinking", "off": "off"}
    want = [words[status["lamps"][name]] for name in ("green", "amber", "red")]
    wait(driver, f"lamp states {want}", lambda d: texts(d, ".lamp-box .lamp-state") == want)
    state = texts(driver, "#station-state")[0]
    check(state in STATE_WORDS or state.startswith("Inspecting"), f"station state in words: {state!r}")
    name = PLC_STATUS_NAMES[client.read_holding_registers(STATUS, 1, slave=1).registers[0]]
    wait(driver, f"PLC status {name!r}", lambda d: texts(d, "#plc-status") == [name])


def times(driver, db):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    last_id, last_ms, last_utc = con.execute(
        "SELECT id, started_unix_ms, started_utc FROM inspections ORDER BY id DESC LIMIT 1").fetchone()
    con.close()
    wait(driver, "the newest result shown", lambda d: d.execute_script("return window.hgLine.shownResult") == last_id)
    shown = driver.execute_script("const e = document.getElementById('time'); return [e.textContent, e.title]")
    want = local_text(last_ms, BROWSER_ZONE)
    check(shown[0] == want, f"the last part's time shows {shown[0]!r}, {BROWSER_ZONE} makes it {want!r}")
    check(last_utc in shown[1], f"the time's tooltip {shown[1]!r} does not hold the stored UTC {last_utc}")


def shift(driver, db):
    """The shift "day" began at the daemon's local midnight; its counts are the store's PLC production cycles."""
    now = datetime.datetime.now(ZoneInfo(DAEMON_ZONE))
    start_ms = int(now.replace(hour=0, minute=0, second=0, microsecond=0).timestamp() * 1000)
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    counts = dict(con.execute("SELECT verdict, count(*) FROM inspections WHERE purpose = 'production' AND manual = 0 "
                              "AND started_unix_ms >= ? GROUP BY verdict", (start_ms,)).fetchall())
    con.close()
    want = [str(sum(counts.values()))] + [str(counts.get(v, 0)) for v in ("pass", "fail", "aborted", "error")]
    judged = counts.get("pass", 0) + counts.get("fail", 0)
    want.append(f"{100 * counts.get('pass', 0) / judged:.1f} %" if judged else "—")
    ids = ["#shift-cycles", "#shift-pass", "#shift-fail", "#shift-aborted", "#shift-error", "#shift-yield"]
    wait(driver, f"shift counters {want}", lambda d: [texts(d, i)[0] for i in ids] == want)
    shown = [texts(driver, i)[0] for i in ids]
    check(shown == want, f"shift counters shown {shown}, the store's {want}")
    check(texts(driver, "#shift-name") == ["day"], f"shift name {texts(driver, '#shift-name')}")
    since = texts(driver, "#shift-since")[0]
    check(since == local_text(start_ms, BROWSER_ZONE),
          f"the shift began {since!r}, {DAEMON_ZONE}'s midnight is {local_text(start_ms, BROWSER_ZONE)!r} in {BROWSER_ZONE}")


def filmstrip(driver, url, db):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    rows = con.execute("SELECT id, serial, landmarks_json FROM inspections WHERE verdict = 'fail' "
                       "ORDER BY id DESC LIMIT 6").fetchall()
    con.close()
    ids = [r[0] for r in rows]
    wait(driver, f"filmstrip {ids}", lambda d: d.execute_script("return window.hgLine.filmstrip") == ids)
    serials = texts(driver, "#filmstrip .frame-serial")
    check(serials == [r[1] for r in rows], f"filmstrip serials {serials}, the store's {[r[1] for r in rows]}")
    failed = [", ".join(l["id"] for l in json.loads(r[2]) if l["status"] != "ok") for r in rows]
    shown = texts(driver, "#filmstrip .frame-landmarks")
    check(shown == failed, f"filmstrip failed landmarks {shown}, the store's {failed}")
    loaded = wait(driver, "filmstrip pictures", lambda d: d.execute_script(
        "const i = [...document.querySelectorAll('#filmstrip img')];"
        "return i.length && i.every(x => x.complete) ? i.map(x => x.naturalWidth) : false"))
    check(bool(loaded) and all(w > 0 for w in loaded), f"filmstrip pictures {loaded}")
    return ids


def open_from_filmstrip(driver, url, result_id):
    driver.execute_script("document.querySelector(`#filmstrip a[data-result='${arguments[0]}']`).click()", result_id)
    wait(driver, f"result {result_id} opened", lambda d: d.current_url == f"{url}/result?id={result_id}")


def kiosk(driver):
    shown = driver.execute_script(
        "const vis = s => [...document.querySelectorAll(s)].some(e => e.offsetParent !== null);"
        "return {nav: vis('nav'), header: vis('header'), engineer: vis('.engineer'), button: vis('#fullscreen')}")
    check(shown == {"nav": False, "header": False, "engineer": False, "button": True},
          f"kiosk: what is visible {shown}")


def landmark_rows(driver, url, db):
    """A failed part with a not_found landmark: every row one reading, the bracket with its words."""
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    rows = con.execute("SELECT id, landmarks_json FROM inspections WHERE verdict = 'fail' ORDER BY id DESC").fetchall()
    con.close()
    chosen = next(((rid, json.loads(lj)) for rid, lj in rows if any(l["status"] == "not_found" for l in json.loads(lj))),
                  None)
    if not check(chosen is not None, "no failed part with a not_found landmark to show"):
        return
    rid, landmarks = chosen
    driver.get(f"{url}/result?id={rid}")
    wait(driver, f"result {rid}'s landmarks", lambda d: len(texts(d, "#landmarks tr[data-landmark]")) == len(landmarks))
    shown = driver.execute_script(
        "return [...document.querySelectorAll('#landmarks tr[data-landmark]')].map(r => ({id: r.dataset.landmark,"
        " status: r.dataset.status, kind: r.dataset.reading, readings: r.querySelectorAll('td.reading').length,"
        " reading: r.querySelector('td.reading').textContent, note: r.querySelector('td.note').textContent,"
        " fault: r.classList.contains('inspection-fault')}))")
    by_id = {l["id"]: l for l in landmarks}
    for row in shown:
        l = by_id[row["id"]]
        both = "±" in row["reading"] and "[" in row["reading"]
        check(row["readings"] == 1 and not both, f"landmark {row['id']}: readings {row['readings']}: {row['reading']!r}")
        check(row["status"] == l["status"], f"landmark {row['id']}: status {row['status']}, stored {l['status']}")
        deviation = l.get("deviation_mm")
        bracket = l.get("error_min_mm"), l.get("error_max_mm")
        if deviation is not None and l["status"] in ("ok", "out_of_tolerance", "uncertain"):
            check(row["kind"] == "deviation" and f"{abs(deviation):.4f}" in row["reading"],
                  f"landmark {row['id']}: shows {row['reading']!r}, stored deviation {deviation}")
        elif None not in bracket:
            want = f"[{bracket[0]:.4f}, {bracket[1]:.4f}]"
            check(row["kind"] == "bracket" and want in row["reading"],
                  f"{l['status']} landmark {row['id']}: shows {row['reading']!r}, stored bracket {want}")
            if l["status"] == "not_found":
                check("edge not found in the views" in row["note"] or "inspection fault" in row["note"],
                      f"not_found landmark {row['id']}: says {row['note']!r}")
            if deviation is not None:
                # The bracket of |error| widened by its width on each side (open above for an overflow).
                width, e = bracket[1] - bracket[0], abs(deviation)
                apart = e < bracket[0] - width or (l["status"] != "overflow" and e > bracket[1] + width)
                check(apart == ("inspection fault" in row["note"] and row["fault"]),
                      f"landmark {row['id']}: deviation {deviation} against {want}: the row says {row['note']!r}")
    print(f"result {rid}: {len(shown)} landmark rows, kinds "
          f"{sorted({r['kind'] for r in shown})}, statuses {sorted({r['status'] for r in shown})}", flush=True)


def line_view(driver, url, client, db, screenshots):
    driver.execute_cdp_cmd("Emulation.setTimezoneOverride", {"timezoneId": BROWSER_ZONE})
    driver.get(url + "/")
    wait(driver, "the line view's first poll", lambda d: d.execute_script("return window.hgLine && window.hgLine.polls > 0"))
    status = json.loads(driver.execute_script("return fetch('/api/status').then(r => r.text())"))
    lamps_and_state(driver, client, status)
    times(driver, db)
    shift(driver, db)
    ids = filmstrip(driver, url, db)
    verdict_size(driver, "line view")
    for width, height in SIZES:
        if screenshots:
            set_viewport(driver, width, height)
            driver.save_screenshot(str(screenshots / f"hmi-line-{width}x{height}.png"))
    driver.get(url + "/?kiosk")
    wait(driver, "the kiosk's filmstrip", lambda d: d.execute_script("return window.hgLine.filmstrip.length") == len(ids))
    kiosk(driver)
    verdict_size(driver, "kiosk")
    for width, height in SIZES:
        if screenshots:
            set_viewport(driver, width, height)
            driver.save_screenshot(str(screenshots / f"hmi-line-kiosk-{width}x{height}.png"))
    driver.execute_cdp_cmd("Emulation.clearDeviceMetricsOverride", {})
    open_from_filmstrip(driver, url, ids[-1])


def main():
    args = test_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-line-"))
    plc_port, http_port = free_port(), free_port()
    os.environ["TZ"] = DAEMON_ZONE  # the daemon's local time, for its shifts
    line, out, _ = start_line(args.source, args.bin, workdir, plc_port,
                              ["--http-port", str(http_port), "--config", str(args.source / "config" / "sim-fast")])
    url = f"http://127.0.0.1:{http_port}"
    sock = str(workdir / "hullgauged.sock")
    db = workdir / "results.db"
    driver = browser()
    client = ModbusTcpClient("127.0.0.1", port=plc_port, timeout=10)
    try:
        check(client.connect(), "the PLC client could not connect")
        run_cycles(client, sock, db)
        line_view(driver, url, client, db, args.screenshots)
        landmark_rows(driver, url, db)
    finally:
        client.close()
        driver.quit()
        stop_line(line, out)
    return outcome("line view", workdir)


if __name__ == "__main__":
    sys.exit(main())
