#!/usr/bin/python3
"""The reject views in a real browser (docs/hmi.md, "Reject views"): Debian's
chromium, headless, driven by chromium-driver through selenium, against the
simulated line (tools/simline --http-port) archiving every part. This script
is the PLC (pymodbus); it runs a nominal part and defective ones and checks:

- on a failed part's result page, for every view: the failed landmarks'
  labels lie inside the image's box and overlap no other label
  (getBoundingClientRect), only failed landmarks are labelled and every
  failed landmark the view shows is (against the result store read with
  sqlite3), the legend is there; the +, − and fit buttons, the wheel and a
  drag change the view's transform, and a label keeps its size on the screen
  when zoomed;
- on the nominal part's result page, for every view: the plain frame read
  back in the page (canvas getImageData), thresholded (the part is dark on
  the bright backlight), has a silhouette edge within one pixel of every
  vertex of the drawn nominal outline;
- the line view's last failed part shows the same viewer.

  hmi_reject_views.py --source DIR --bin DIR [--screenshots DIR]
"""
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, outcome, test_args, free_port, maintenance, start_line, stop_line  # noqa: E402
from hmi_browser import browser as chromium, plc_cycle, save_at_sizes, stored  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

# Every view of the result page drawn: its overlay fetched and its frame loaded (or the annotated picture
# of a part without overlays).
VIEWS_READY = """
const figures = [...document.querySelectorAll('#images .vv-view, #failed-images .vv-view')];
return figures.length > 0 && figures.every(f => f.dataset.ready === 'true') ? figures.length : 0;
"""

# Per view: the image's box, each label's box, id and status, the landmarks the overlay holds, the legend.
LABEL_BOXES = """
const box = (r) => ({left: r.left, top: r.top, right: r.right, bottom: r.bottom});
return Promise.all([...document.querySelectorAll(arguments[0] + ' .vv-view')].map(async (f) => {
  const k = f.dataset.view;
  const overlay = await fetch(`/api/results/${arguments[1]}/views/${k}.json`).then(r => r.json());
  return {view: k, overlay: f.dataset.overlay,
    image: box(f.querySelector('img.vv-frame').getBoundingClientRect()),
    labels: [...f.querySelectorAll('.vv-label')].map(g => ({id: g.dataset.landmark, status: g.dataset.status,
      box: box(g.getBoundingClientRect())})),
    shown: overlay.landmarks.map(l => l.id),
    legend: f.querySelectorAll('.vv-legend .vv-key').length};
}));
"""

# Per view: every outline vertex's distance (pixels) to the nearest pixel of the thresholded plain frame
# that has a 4-neighbour of the other class; the frame read back from a canvas.
OUTLINE_DISTANCES = """
const done = arguments[arguments.length - 1];
Promise.all([...document.querySelectorAll('#images .vv-view')].map(async (f) => {
  const img = f.querySelector('img.vv-frame');
  await img.decode();
  const w = img.naturalWidth, h = img.naturalHeight;
  const c = document.createElement('canvas'); c.width = w; c.height = h;
  const g = c.getContext('2d'); g.drawImage(img, 0, 0);
  const d = g.getImageData(0, 0, w, h).data;
  let lo = 255, hi = 0;
  for (let i = 0; i < d.length; i += 4) { lo = Math.min(lo, d[i]); hi = Math.max(hi, d[i]); }
  const cut = (lo + hi) / 2, dark = (x, y) => d[4 * (y * w + x)] < cut;
  const edge = (x, y) => x >= 0 && y >= 0 && x < w && y < h &&
    [[1, 0], [-1, 0], [0, 1], [0, -1]].some(([a, b]) => x + a >= 0 && y + b >= 0 && x + a < w && y + b < h &&
      dark(x + a, y + b) !== dark(x, y));
  const points = [...f.querySelectorAll('.vv-outline polygon, .vv-outline polyline')]
    .flatMap(p => [...p.points].map(q => [q.x, q.y]));
  let worst = 0;
  for (const [x, y] of points) {
    let best = Infinity;
    for (let py = Math.floor(y) - 2; py <= Math.ceil(y) + 2; ++py)
      for (let px = Math.floor(x) - 2; px <= Math.ceil(x) + 2; ++px)
        if (edge(px, py)) best = Math.min(best, Math.hypot(px - x, py - y));
    worst = Math.max(worst, best);
  }
  return {view: f.dataset.view, vertices: points.length, worst, size: [w, h]};
})).then(done, (e) => done({error: String(e)}));
"""


def browser():
    """Chromium whose page is exactly 1920 x 1080 CSS px (the window's chrome takes none of it)."""
    driver = chromium(window=(1920, 1080))
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                           {"width": 1920, "height": 1080, "deviceScaleFactor": 1, "mobile": False})
    return driver


def archive_all(source, workdir):
    """A configuration overlay for tools/simline: config/sim's daemon file archiving every part."""
    overlay = workdir / "overlay"
    overlay.mkdir()
    text = (source / "config" / "sim" / "hullgauged.yaml").read_text()
    marker = "  save_failed_images: true\n"
    if not check(marker in text, "config/sim/hullgauged.yaml no longer names save_failed_images"):
        raise SystemExit(1)
    (overlay / "hullgauged.yaml").write_text(text.replace(marker, marker + "  archive_all: true\n"))
    return overlay


def wait_for_views(driver, url, row_id, page="/result?id="):
    """The page of result row_id once every view is drawn; polls the API first: the archive is written
    after the result is stored (docs/daemon.md, "Archived parts")."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        files = driver.execute_script(
            "return fetch(arguments[0]).then(r => r.json()).then(j => j.image_files || [])", f"/api/results/{row_id}")
        if files:
            break
        time.sleep(0.1)
    driver.get(f"{url}{page}{row_id}")
    return WebDriverWait(driver, 60).until(lambda d: d.execute_script(VIEWS_READY))


def inside(inner, outer):
    return (inner["left"] >= outer["left"] - 0.5 and inner["top"] >= outer["top"] - 0.5
            and inner["right"] <= outer["right"] + 0.5 and inner["bottom"] <= outer["bottom"] + 0.5)


def overlap(a, b):
    return a["left"] < b["right"] and b["left"] < a["right"] and a["top"] < b["bottom"] and b["top"] < a["bottom"]


def check_labels(driver, selector, row, what):
    """Every view's labels inside its image, pairwise apart; exactly the failed landmarks it shows."""
    failed = {l["id"]: l["status"] for l in json.loads(row["landmarks_json"]) if l["status"] != "ok"}
    check(failed, f"{what}: the stored result has no failed landmark")
    views = driver.execute_script(LABEL_BOXES, selector, row["id"])
    check(len(views) > 0, f"{what}: no views")
    labelled_anywhere = set()
    for v in views:
        name = f"{what} view {v['view']}"
        check(v["overlay"] == "true", f"{name}: drawn without its overlay")
        check(v["legend"] == 4, f"{name}: legend with {v['legend']} entries, not 4")
        ids = sorted(label["id"] for label in v["labels"])
        expected = sorted(i for i in v["shown"] if i in failed)
        check(ids == expected, f"{name}: labels {ids}, the failed landmarks it shows {expected}")
        for label in v["labels"]:
            check(failed.get(label["id"]) == label["status"],
                  f"{name}: label {label['id']} status {label['status']}, stored {failed.get(label['id'])}")
            check(inside(label["box"], v["image"]), f"{name}: label {label['id']} {label['box']} leaves the "
                  f"image {v['image']}")
        for i, a in enumerate(v["labels"]):
            for b in v["labels"][i + 1:]:
                check(not overlap(a["box"], b["box"]), f"{name}: labels {a['id']} and {b['id']} overlap")
        labelled_anywhere |= set(ids)
    check(labelled_anywhere == set(failed), f"{what}: labelled {sorted(labelled_anywhere)}, failed {sorted(failed)}")


def transform(driver):
    return driver.execute_script("return document.querySelector('#images .vv-content').style.transform")


def label_height(driver):
    return driver.execute_script(
        "const t = document.querySelector('#images .vv-label text'); return t ? t.getBoundingClientRect().height : 0")


def changed(driver, before, what):
    try:
        WebDriverWait(driver, 10).until(lambda d: transform(d) != before)
    except Exception:
        pass
    now = transform(driver)
    check(now != before, f"{what} left the transform at {before}")
    return now


def pan_and_zoom(driver):
    """The buttons, the wheel and a drag change the first view's transform; labels keep their screen size."""
    figure = driver.find_element(By.CSS_SELECTOR, "#images .vv-view")
    height = label_height(driver)
    t = transform(driver)
    figure.find_element(By.CSS_SELECTOR, "button[title='zoom in']").click()
    t = changed(driver, t, "the + button")
    zoomed = label_height(driver)
    check(height > 0 and abs(zoomed - height) < 0.15 * height,
          f"a label is {zoomed:.1f} px high zoomed in, {height:.1f} px at fit: not counter-scaled")
    figure.find_element(By.CSS_SELECTOR, "button[title='zoom out']").click()
    t = changed(driver, t, "the − button")
    driver.execute_script(
        "const s = document.querySelector('#images .vv-stage'); const r = s.getBoundingClientRect();"
        "s.dispatchEvent(new WheelEvent('wheel', {deltaY: -400, clientX: r.left + r.width / 3,"
        " clientY: r.top + r.height / 3, bubbles: true, cancelable: true}))")
    t = changed(driver, t, "the wheel")
    stage = figure.find_element(By.CSS_SELECTOR, ".vv-stage")
    ActionChains(driver).move_to_element(stage).click_and_hold().move_by_offset(120, 60).release().perform()
    t = changed(driver, t, "a drag")
    figure.find_element(By.CSS_SELECTOR, "button[title='whole view']").click()
    changed(driver, t, "the fit button")


def check_outline(driver, what):
    views = driver.execute_async_script(OUTLINE_DISTANCES)
    if not check(isinstance(views, list) and views, f"{what}: the outline could not be read ({views})"):
        return
    for v in views:
        check(v["vertices"] > 10, f"{what} view {v['view']}: {v['vertices']} outline vertices")
        check(v["worst"] <= 1.0, f"{what} view {v['view']}: an outline vertex {v['worst']:.2f} px from the "
              "silhouette's edge (at most 1)")
        print(f"{what} view {v['view']}: {v['vertices']} outline vertices, worst {v['worst']:.2f} px", flush=True)


def cycles(client, sock, db):
    """A nominal part and two defective ones; their stored rows."""
    seq = client.read_holding_registers(0, 1, slave=1).registers[0]
    rows = {}
    for part, serial in (("nominal", "NOM-RV-1"), ("corner-missing", "BAD-RV-1"), ("face-low", "BAD-RV-2")):
        maintenance(sock, {"command": "sim-part", "name": part})
        seq = (seq + 1) % 65536 or 1
        plc_cycle(client, seq, serial)
        rows[serial] = stored(db, serial)
        check(rows[serial] is not None, f"{serial}: no stored row")
    return rows


def main():
    args = test_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-rejects-"))
    plc_port, http_port = free_port(), free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, plc_port,
                              ["--http-port", str(http_port), "--config", str(args.source / "config" / "sim-fast"),
                               "--config", str(archive_all(args.source, workdir))])
    url = f"http://127.0.0.1:{http_port}"
    driver = browser()
    client = ModbusTcpClient("127.0.0.1", port=plc_port, timeout=10)
    try:
        check(client.connect(), "the PLC client could not connect")
        rows = cycles(client, str(workdir / "hullgauged.sock"), workdir / "results.db")
        if all(rows.values()):
            check(rows["NOM-RV-1"]["verdict"] == "pass", f"the nominal part: {rows['NOM-RV-1']['verdict']}")
            driver.get(url + "/")
            wait_for_views(driver, url, rows["NOM-RV-1"]["id"])
            check_outline(driver, "nominal part")
            for serial in ("BAD-RV-1", "BAD-RV-2"):
                check(rows[serial]["verdict"] == "fail", f"{serial}: {rows[serial]['verdict']}")
                wait_for_views(driver, url, rows[serial]["id"])
                check_labels(driver, "#images", rows[serial], serial)
            if args.screenshots:
                save_at_sizes(driver, args.screenshots, "hmi-reject-view",
                              before="document.querySelector('#images .vv-view').scrollIntoView()")
            pan_and_zoom(driver)
            # The line view's last failed part: the same viewer.
            driver.get(url + "/")
            WebDriverWait(driver, 60).until(lambda d: d.execute_script(VIEWS_READY))
            check_labels(driver, "#failed-images", rows["BAD-RV-2"], "line view BAD-RV-2")
    finally:
        client.close()
        driver.quit()
        stop_line(line, out)
    return outcome("reject views", workdir)


if __name__ == "__main__":
    sys.exit(main())
