#!/usr/bin/python3
"""The part record in a real browser (docs/hmi.md, "Part record"): Debian's
chromium, headless, driven by chromium-driver through selenium, against the
simulated line (tools/simline --http-port). This script is the PLC (pymodbus):
it runs a nominal and a defective part and checks the failed one's record
against the result store read here with sqlite3:

- the result page links to the record; the record shows the stored verdict,
  serial, program release (or "draft") and every landmark with its status,
  deviation and U; the annotated views load;
- printed (print media emulated over CDP), the navigation, the header bar and
  the buttons are not displayed, the views are, after a page break; chromium's
  own PDF of the page (Page.printToPDF) is A4 with the serial at the top of
  every page;
- the station's PDF (GET /api/results/{id}/record.pdf) is a download named
  after the part, A4, and holds the serial, the verdict and every landmark id
  (read with poppler's pdftotext and pdfinfo); an unknown id is a 404.

  record_browser.py --source DIR --bin DIR [--screenshots DIR]
"""
import base64
import http.client
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, outcome, test_args, free_port, maintenance, start_line, stop_line  # noqa: E402
from hmi_browser import browser, plc_cycle, request, save_at_sizes, set_viewport, stored, texts  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402
from selenium.common.exceptions import TimeoutException  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402


def run_parts(client, sock, db):
    """A nominal part and a defective one (the face pushed in: docs/contracts.md §7); their stored rows."""
    seq = client.read_holding_registers(0, 1, slave=1).registers[0]
    rows = {}
    for serial, part in (("SN-REC-001", "nominal"), ("BAD-REC-002", "face-low")):
        maintenance(sock, {"command": "sim-part", "name": part})
        seq = (seq + 1) % 65536 or 1
        plc_cycle(client, seq, serial)
        rows[serial] = stored(db, serial)
        check(rows[serial] is not None, f"{serial}: no stored row")
    check(rows["SN-REC-001"] is not None and rows["SN-REC-001"]["verdict"] == "pass", "the nominal part did not pass")
    return rows["BAD-REC-002"]


def pdf_text(data, workdir, name):
    """pdftotext -layout and pdfinfo of PDF bytes: (text, info)."""
    file = workdir / name
    file.write_bytes(data)
    text = subprocess.run(["pdftotext", "-layout", str(file), "-"], capture_output=True, text=True)
    info = subprocess.run(["pdfinfo", str(file)], capture_output=True, text=True)
    check(text.returncode == 0 and info.returncode == 0, f"{name}: poppler cannot read it: {text.stderr}{info.stderr}")
    return text.stdout, info.stdout


def pages_of(info):
    m = re.search(r"^Pages:\s+(\d+)", info, re.M)
    return int(m.group(1)) if m else 0


def record_page(driver, url, row):
    """The record as the screen shows it, against the stored row."""
    rid, serial = row["id"], row["serial"]
    driver.get(f"{url}/result?id={rid}")
    WebDriverWait(driver, 30).until(lambda d: d.execute_script(
        "return document.getElementById('record-link').getAttribute('href')") == f"/record?id={rid}")
    driver.get(f"{url}/record?id={rid}")
    try:
        WebDriverWait(driver, 30).until(
            lambda d: d.execute_script("return window.hgRecord ? window.hgRecord.shown : null") == rid)
    except TimeoutException:
        raise SystemExit(f"record {rid}: the page did not show the record within 30 s:\n"
                         f"{driver.find_element(By.TAG_NAME, 'body').text}\n{driver.get_log('browser')}")
    check(texts(driver, "#verdict") == [row["verdict"].upper()], f"record {rid}: verdict {texts(driver, '#verdict')}")
    check(texts(driver, "#f-serial") == [serial], f"record {rid}: serial {texts(driver, '#f-serial')}")
    version = "draft (no release)" if row["program_version"] is None else f"version {row['program_version']}"
    check(texts(driver, "#f-version") == [version], f"record {rid}: release {texts(driver, '#f-version')}, "
          f"stored {row['program_version']}")
    check(texts(driver, "#f-time-utc") == [row["started_utc"]], f"record {rid}: time {texts(driver, '#f-time-utc')}")
    landmarks = json.loads(row["landmarks_json"])
    shown = list(zip(texts(driver, "#landmarks tbody tr", "data-landmark"),
                     texts(driver, "#landmarks tbody tr", "data-status"),
                     texts(driver, "#landmarks tbody tr td:nth-child(3)")))

    def reading(l):
        """docs/hmi.md, "Landmark rows": the deviation ± U where it decided the landmark, else the bracket."""
        if l.get("deviation_mm") is not None and l["status"] in ("ok", "out_of_tolerance", "uncertain"):
            d = l["deviation_mm"]
            return f"{'+' if d >= 0 else '-'}{abs(d):.4f} ± {l['uncertainty_mm']:.4f} mm"
        if l.get("error_min_mm") is not None and l.get("error_max_mm") is not None:
            return f"|error| in [{l['error_min_mm']:.4f}, {l['error_max_mm']:.4f}] mm"
        return "no reading"

    expected = [(l["id"], l["status"], reading(l)) for l in landmarks]
    check(shown == expected, f"record {rid}: landmark rows {shown}, stored {expected}")
    check(any(l["status"] != "ok" for l in landmarks), f"record {rid}: the defective part has no failed landmark")
    views = sorted(p.name for p in Path(row["images_dir"]).glob("view_*.png")) if row["images_dir"] else []
    try:
        loaded = WebDriverWait(driver, 30).until(lambda d: d.execute_script(
            "const imgs = [...document.querySelectorAll('#images img')];"
            "return imgs.every(i => i.complete) ? imgs.map(i => i.naturalWidth) : false"))
    except TimeoutException:
        raise SystemExit(f"record {rid}: the views did not load within 30 s:\n{image_states(driver)}")
    check(len(views) > 0 and len(loaded) == len(views) and all(w > 0 for w in loaded),
          f"record {rid}: views loaded {loaded}, archived {views}")
    return landmarks


def image_states(driver):
    """What the page and the browser's network timing say of each view, and what the station answers for
    it fetched here: the facts a view that never loads leaves to find out why."""
    states = driver.execute_script(
        "return [...document.querySelectorAll('#images img')].map(i => { const e = performance"
        ".getEntriesByName(i.src).pop(); return {src: i.src, complete: i.complete, width: i.naturalWidth,"
        " fetched: e ? {start: e.startTime, response: e.responseStart, end: e.responseEnd, bytes: e.transferSize,"
        " status: e.responseStatus} : null}; })")
    lines = []
    for st in states:
        path = "/" + st["src"].split("/", 3)[3]
        host, port = st["src"].split("/")[2].split(":")
        con = http.client.HTTPConnection(host, int(port), timeout=10)
        try:
            con.request("GET", path)
            res = con.getresponse()
            answer = f"HTTP {res.status}, {len(res.read())} bytes"
        except OSError as e:
            answer = f"no answer: {e}"
        finally:
            con.close()
        lines.append(f"{path}: complete {st['complete']}, width {st['width']}, timing {st['fetched']}; fetched now: {answer}")
    return "\n".join(lines) + f"\nbrowser log: {driver.get_log('browser')}"


def printed(driver, row, workdir):
    """Print media emulated: no navigation, header bar or buttons, the views displayed after a page break;
    chromium's PDF of the page is A4 with the running header on every page."""
    driver.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": "print"})
    try:
        hidden = driver.execute_script(
            "return [...document.querySelectorAll('header, nav, button, .record-actions')]"
            ".map(e => getComputedStyle(e).display)")
        check(hidden and all(d == "none" for d in hidden), f"printed: navigation or buttons displayed ({hidden})")
        images = driver.execute_script(
            "return [...document.querySelectorAll('#images img')]"
            ".map(i => [getComputedStyle(i).display, i.getBoundingClientRect().width])")
        check(images and all(d != "none" and w > 0 for d, w in images), f"printed: views not displayed ({images})")
        brk = driver.execute_script("return getComputedStyle(document.querySelector('.record-views')).breakBefore")
        check(brk == "page", f"printed: the views start with break-before {brk!r}, not a new page")
        ink = driver.execute_script("return [getComputedStyle(document.body).color, "
                                    "getComputedStyle(document.body).backgroundColor]")
        check(ink == ["rgb(0, 0, 0)", "rgb(255, 255, 255)"], f"printed: body colours {ink}, not black on white")
        pdf = driver.execute_cdp_cmd("Page.printToPDF", {"preferCSSPageSize": True})
        text, info = pdf_text(base64.b64decode(pdf["data"]), workdir, "printed.pdf")
        pages = pages_of(info)
        check(pages >= 2, f"Page.printToPDF: {pages} pages, the views after a page break need two at least")
        check(re.search(r"^Page size:.*\(A4\)$", info, re.M) is not None, f"Page.printToPDF: not A4:\n{info}")
        heads = text.count(f"Serial {row['serial']}")
        running = driver.execute_script("return window.hgRecord.runningHeader")
        check(heads == pages, f"Page.printToPDF: the running header on {heads} of {pages} pages ({running})")
    finally:
        driver.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": ""})


def station_pdf(port, row, landmarks, workdir):
    rid, serial = row["id"], row["serial"]
    con = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    con.request("GET", f"/api/results/{rid}/record.pdf")
    res = con.getresponse()
    data = res.read()
    con.close()
    check(res.status == 200 and data.startswith(b"%PDF-"), f"record.pdf: HTTP {res.status}, {data[:40]!r}")
    check(res.getheader("Content-Type") == "application/pdf", f"record.pdf: Content-Type {res.getheader('Content-Type')}")
    disposition = f'attachment; filename="hullgauge-record-{rid}-{serial}.pdf"'
    check(res.getheader("Content-Disposition") == disposition,
          f"record.pdf: Content-Disposition {res.getheader('Content-Disposition')}")
    text, info = pdf_text(data, workdir, "station.pdf")
    for expected in [serial, row["verdict"].upper()] + [l["id"] for l in landmarks]:
        check(expected in text, f"record.pdf: {expected!r} missing")
    check("595.276 x 841.89 pts (A4)" in info, f"record.pdf: not A4:\n{info}")
    status, body = request(port, "GET", "/api/results/999999/record.pdf")
    check(status == 404, f"record.pdf of an unknown id: HTTP {status} {body[:80]!r}")


def screenshots_of(driver, url, row, folder):
    """The record at both sizes on screen, and as printed at 1920 x 1080."""
    ready = ("return window.hgRecord && window.hgRecord.shown !== null && "
             "[...document.querySelectorAll('#images img')].every(i => i.complete)")
    driver.get(f"{url}/record?id={row['id']}")
    save_at_sizes(driver, folder, "hmi-record", ready)
    set_viewport(driver, 1920, 1080)
    try:
        driver.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": "print"})
        driver.save_screenshot(str(folder / "hmi-record-print.png"))
        driver.execute_cdp_cmd("Emulation.setEmulatedMedia", {"media": ""})
    finally:
        driver.execute_cdp_cmd("Emulation.clearDeviceMetricsOverride", {})


def main():
    args = test_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-record-"))
    plc_port, http_port = free_port(), free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, plc_port,
                              ["--http-port", str(http_port), "--config", str(args.source / "config" / "sim-fast")])
    url = f"http://127.0.0.1:{http_port}"
    driver = browser()
    client = ModbusTcpClient("127.0.0.1", port=plc_port, timeout=10)
    try:
        check(client.connect(), "the PLC client could not connect")
        row = run_parts(client, str(workdir / "hullgauged.sock"), workdir / "results.db")
        if row is not None and check(row["verdict"] == "fail", f"the defective part: verdict {row['verdict']}"):
            landmarks = record_page(driver, url, row)
            printed(driver, row, workdir)
            station_pdf(http_port, row, landmarks, workdir)
            if args.screenshots:
                screenshots_of(driver, url, row, args.screenshots)
    finally:
        client.close()
        driver.quit()
        stop_line(line, out)
    return outcome("part record", workdir)


if __name__ == "__main__":
    sys.exit(main())
