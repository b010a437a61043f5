#!/usr/bin/python3
"""The Parts page in a real browser (docs/workbench.md): Debian's chromium,
headless, driven by chromium-driver through selenium, against the simulated
line with its workbench (tools/simline --http-port), checking what the page
shows and does against the HTTP API read here:

- changes need a signed-in engineer; the engineer signs in on the page with
  a name, and the workbench records that name;
- a CAD model the loader refuses is refused on the page in the loader's words;
  the stepped block uploaded from the page is drawn (its light mesh first,
  then the full one);
- clicks on known faces (the page's hgParts.screenOf: where a part-frame
  point is on the screen) place landmarks the server snaps onto the edge
  beside them, and the page says so ("on an edge", the distance moved);
  dragging a pin onto a face moves the landmark there;
- the edit panel renames a landmark and changes its tolerance; a tolerance the
  loader refuses is shown in its words;
- a change made on a revision another engineer has since changed is refused
  (409) in the server's words and the page shows the draft as it now is;
- suggestions: every candidate of suggestions.json listed, the refused ones
  with their rule;
- commissioning from the page: its progress shown, then the report's rows
  the verification's landmarks, the failing cells its failing landmarks;
  a landmark a finding names removed from the page and the draft
  commissioned again, as an engineer would (the twin's verdict depends on
  where along its edge a click put a landmark); the views listed as the
  plan's, a view's frame loads;
- release as PLC program 2: the daemon runs it (a cycle triggered for
  program 2 is judged with version 1), a PLC number the daemon already uses
  is refused; a second version after a change, their difference, a
  rollback to version 1 (version 3, rolled back from 1);
- a public CAD mesh (MCAD's rounded block, tests/data/cad/README.md)
  uploaded from the page, three landmarks placed by clicks on its faces —
  each picked point within 0.05 mm of the mesh's surface and each normal
  within 1° of the face's, both computed here from the STL's triangles —,
  commissioned, released as PLC program 3 and judged by a PLC cycle that
  names the version.

  parts_browser.py --source DIR --bin DIR [--screenshots DIR]
"""
import http.client
import json
import math
import struct
import sys
import tempfile
import time
import urllib.parse
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, outcome, test_args, free_port, maintenance, password_hash_file, start_line, stop_line  # noqa: E402
from hmi_browser import browser as chromium, stored, until  # noqa: E402

from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402

PASSWORD = "parts-test-password"
ENGINEER = "Jane Doe"
PART = "stepped-block"
# Points on faces 0.8 mm beside the block's edges (the snap distance is 2 % of
# its 78 mm diagonal: 1.56 mm), the edge's point beside it and its direction,
# and a direction the face is seen from. The five edges are the ones
# commissioning proves on the simulated station (docs/commissioning.md,
# config/sim) when they lie at the edges' middles.
CLICKS = [([-29.2, -20, 15], [-30, -20, 15], [0, 0, 1], [0.3, -1, 0.4]),
          ([30, 19.2, 7.5], [30, 20, 7.5], [0, 0, 1], [1, 0.3, 0.4]),
          ([15, -19.2, 15], [15, -20, 15], [1, 0, 0], [0.2, -0.6, 1]),
          ([-0.8, 0, 30], [0, 0, 30], [0, 1, 0], [0.3, -0.2, 1]),
          ([-29.2, 0, 30], [-30, 0, 30], [0, 1, 0], [-0.3, -0.2, 1])]
# A click lands within a pixel of the point aimed at: about 0.12 mm here.
CLICK_MM = 0.5
# The public mesh: 40 x 30 x 12 mm, vertical edges R3, centred on the origin.
# Points in the middle of three flat faces, the face's outward normal and a
# direction it is seen from; at the simulated station's lens (0.16 mm a
# pixel at this size) its landmarks prove a tolerance of ±0.4 mm with the
# draft's octree at depth 7 (a voxel of 0.33 mm).
PUBLIC, PUBLIC_CAD = "rounded-block", Path("tests") / "data" / "cad" / "mcad-rounded-block.stl"
PUBLIC_CLICKS = [([-20, 5, 4], [-1, 0, 0], [-1, 0.3, 0.5]),
                 ([20, -4, 4], [1, 0, 0], [1, -0.3, 0.5]),
                 ([6, -15, 4], [0, -1, 0], [0.3, -1, 0.5])]


class Api:
    """The HMI's API as a script sees it; sign_in() gives it a session of its own."""

    def __init__(self, port):
        self.port, self.cookie, self.csrf = port, None, None

    def call(self, method, path, body=None, headers=None):
        con = http.client.HTTPConnection("127.0.0.1", self.port, timeout=120)
        h = dict(headers or {})
        if self.cookie:
            h["Cookie"] = self.cookie
        if self.csrf:
            h["X-CSRF-Token"] = self.csrf
        if isinstance(body, dict):
            body, h["Content-Type"] = json.dumps(body), "application/json"
        con.request(method, path, body=body, headers=h)
        res = con.getresponse()
        data = res.read()
        cookie = res.getheader("Set-Cookie")
        con.close()
        if cookie and cookie.startswith("hg_session="):
            self.cookie = cookie.split(";", 1)[0]
        try:
            return res.status, json.loads(data) if data else None
        except ValueError:
            return res.status, data

    def sign_in(self, name):
        status, body = self.call("POST", "/api/login", {"password": PASSWORD, "name": name})
        self.csrf = body["csrf"] if status == 200 else None
        return status

    def part(self, name=PART):
        return self.call("GET", f"/api/parts/{name}")[1]


def settled(driver, timeout_s=60):
    until(driver, "return window.hgParts && hgParts.ready && hgParts.idle()", timeout_s)


def text(driver, element_id):
    """An element's text as written (innerText would give the headings' CSS upper case)."""
    return driver.execute_script("return document.getElementById(arguments[0]).textContent.trim()", element_id)


def distance(a, b):
    return sum((x - y) ** 2 for x, y in zip(a, b)) ** 0.5


def off_line(p, point, direction):
    """How far p lies from the line through point along the unit direction, and how far along it."""
    d = [x - y for x, y in zip(p, point)]
    along = sum(x * y for x, y in zip(d, direction))
    return distance(d, [along * x for x in direction]), along


def sign_in_on_page(driver, url, api):
    status, _ = api.call("POST", "/api/parts?" + urllib.parse.urlencode({"name": "x", "file": "x.stl"}), b"solid x",
                         {"Content-Type": "application/octet-stream"})
    check(status in (401, 403), f"an upload without a session answered {status}")
    driver.get(url + "/parts")
    until(driver, "return window.hgParts && hgParts.ready")
    check("No parts yet" in text(driver, "part-message"), "an empty workspace is not said so")
    driver.find_element(By.ID, "login-name").send_keys(ENGINEER)
    driver.find_element(By.ID, "password").send_keys(PASSWORD)
    driver.find_element(By.CSS_SELECTOR, "#login button").click()
    until(driver, "return document.getElementById('login').hidden")
    check(ENGINEER in text(driver, "session"), f"signed in, the page says {text(driver, 'session')!r}")


def upload(driver, path, name=""):
    driver.find_element(By.ID, "upload-name").clear()
    if name:
        driver.find_element(By.ID, "upload-name").send_keys(name)
    driver.find_element(By.ID, "upload-file").send_keys(str(path))
    driver.find_element(By.ID, "upload-button").click()


def uploads(driver, source, api):
    upload(driver, source / "tests" / "data" / "cad" / "block-tjunction-open.stl")
    until(driver, "return document.getElementById('upload-result').textContent.startsWith('Refused')")
    words = text(driver, "upload-result")
    check("block-tjunction-open.stl" in words and "mesh" in words, f"the refused model is said as {words!r}")
    upload(driver, source / "config" / "sim" / "stepped-block.stl", PART)
    until(driver, f"return hgParts.part === '{PART}' && hgParts.state === 'full' && hgParts.idle()", 120)
    part = api.part()
    check(part and part["changed_by"] == ENGINEER, f"the part was added by {part and part['changed_by']!r}")
    stats = driver.execute_script("return hgParts.view.stats")
    check(stats["triangles"]["full"] == part["cad"]["triangles"] and stats["firstFrameMs"] is not None,
          f"the page drew {stats['triangles']} triangles, the part has {part['cad']['triangles']}")


def click_face(driver, point, looking_from):
    driver.execute_script("hgParts.lookAt(arguments[0], arguments[1])", point, looking_from)
    until(driver, "return hgParts.idle()")
    at = driver.execute_script("return hgParts.screenOf(arguments[0])", point)
    check(at["visible"], f"the face point {point} is hidden from the camera")
    canvas = driver.find_element(By.CSS_SELECTOR, "#viewer canvas")
    size = canvas.size
    ActionChains(driver).move_to_element_with_offset(canvas, at["canvasX"] - size["width"] / 2,
                                                     at["canvasY"] - size["height"] / 2).click().perform()


def place_landmarks(driver, api):
    """Each click lands on the face beside an edge; the server puts the landmark on the edge, beside the point
    the page sent, and the page says where and how far it moved."""
    for k, (point, edge, along, looking_from) in enumerate(CLICKS, 1):
        click_face(driver, point, looking_from)
        until(driver, f"return hgParts.landmarks().length === {k} && hgParts.busy === 0")
        placed, sent = driver.execute_script("return [hgParts.lastPlaced, hgParts.lastPick]")
        said = text(driver, "landmark-result")
        landmark = next(l for l in api.part()["draft"]["landmarks"] if l["id"] == placed["id"])
        off, shift = off_line(landmark["position"], edge, along)
        check(distance(sent, point) < CLICK_MM, f"a click aimed at {point} picked {sent}")
        check(landmark["on"] == "edge" and off < 1e-6 and abs(shift) < CLICK_MM,
              f"a click at {sent} placed {landmark}, not on the edge beside it at {edge}")
        check(abs(placed["moved_mm"] - distance(sent, landmark["position"])) < 1e-6,
              f"moved {placed['moved_mm']} mm from {sent} to {landmark['position']}")
        check("on an edge" in said and f"{placed['moved_mm']:.3f} mm" in said, f"the page says {said!r} of {placed}")


def drag_pin(driver, landmark_id, to):
    """The pin pressed, moved in ten steps (each to a point of the screen, not by an offset: offsets are whole
    pixels and would add up) and released over `to`."""
    settled(driver)
    at = driver.execute_script("return hgParts.screenOf(hgParts.landmarks().find(l => l.id === arguments[0]).position)",
                               landmark_id)
    end = driver.execute_script("return hgParts.screenOf(arguments[0])", to)
    canvas = driver.find_element(By.CSS_SELECTOR, "#viewer canvas")
    size = canvas.size
    offset = lambda x, y: (x - size["width"] / 2, y - size["height"] / 2)
    chain = ActionChains(driver).move_to_element_with_offset(canvas, *offset(at["canvasX"], at["canvasY"])).click_and_hold()
    for k in range(1, 11):
        chain = chain.move_to_element_with_offset(canvas, *offset(at["canvasX"] + (end["canvasX"] - at["canvasX"]) * k / 10,
                                                                  at["canvasY"] + (end["canvasY"] - at["canvasY"]) * k / 10))
    chain.release().perform()
    until(driver, "return hgParts.busy === 0 && /moved/.test(document.getElementById('landmark-result').textContent)")


def drag_and_edit(driver, api):
    first = api.part()["draft"]["landmarks"][0]
    driver.execute_script("hgParts.lookAt([-25, -20, 10], [0.3, -1, 0.4])")
    drag_pin(driver, first["id"], [-25, -20, 10])
    moved = next(l for l in api.part()["draft"]["landmarks"] if l["id"] == first["id"])
    check(moved["on"] == "face" and abs(moved["position"][1] + 20) < 1e-6 and
          distance(moved["position"], [-25, -20, 10]) < CLICK_MM, f"the pin dragged to (-25, -20, 10) is at {moved}")
    driver.execute_script("hgParts.lookAt(arguments[0], arguments[1])", CLICKS[0][0], CLICKS[0][3])
    drag_pin(driver, first["id"], CLICKS[0][0])
    back = next(l for l in api.part()["draft"]["landmarks"] if l["id"] == first["id"])
    check(back["on"] == "edge", f"the pin dragged back beside the edge is at {back}")
    last = api.part()["draft"]["landmarks"][-1]["id"]
    edit(driver, last, new_id="top-edge", tolerance="0.12")
    changed = next((l for l in api.part()["draft"]["landmarks"] if l["id"] == "top-edge"), None)
    check(changed is not None and changed["tolerance_mm"] == 0.12, f"the edit panel's change gave {changed}")
    edit(driver, "top-edge", tolerance="0")
    check(text(driver, "landmark-result").startswith("Refused"), f"a tolerance of 0 was {text(driver, 'landmark-result')!r}")
    edit(driver, "top-edge", tolerance="0.1")


def edit(driver, landmark_id, new_id=None, tolerance=None):
    driver.execute_script("document.querySelector(`#landmarks tr[data-landmark='${arguments[0]}']`).click()", landmark_id)
    until(driver, "return !document.getElementById('landmark-edit').hidden")
    if new_id:
        driver.find_element(By.ID, "lm-id").clear()
        driver.find_element(By.ID, "lm-id").send_keys(new_id)
    driver.execute_script("const z = document.getElementById('lm-zone'); z.value = 'tolerance';"
                          "z.dispatchEvent(new Event('change'))")
    driver.find_element(By.ID, "lm-tol").clear()
    driver.find_element(By.ID, "lm-tol").send_keys(tolerance)
    driver.execute_script("document.getElementById('landmark-result').textContent = ''")
    driver.find_element(By.ID, "lm-apply").click()
    until(driver, "return hgParts.busy === 0 && document.getElementById('landmark-result').textContent !== ''")


def stale_revision(driver, api):
    """Another engineer changes the draft; the page's next change is refused naming who, and shows the draft."""
    other = Api(api.port)
    check(other.sign_in("John Roe") == 200, "a second engineer could not sign in")
    part = other.part()
    status, _ = other.call("POST", f"/api/parts/{PART}/landmarks/top-edge", {"revision": part["revision"],
                                                                          "tolerance_mm": 0.1})
    check(status == 200, f"the second engineer's change answered {status}")
    edit(driver, "top-edge", tolerance="0.11")
    said = text(driver, "landmark-result")
    check("John Roe" in said and "revision" in said, f"a change on an old revision was said as {said!r}")
    until(driver, f"return hgParts.busy === 0 && document.getElementById('part-title').textContent.includes("
                  f"'revision {api.part()['revision']}')")


def suggestions(driver, api):
    driver.find_element(By.ID, "suggest").click()
    until(driver, "return hgParts.job && hgParts.job.kind === 'suggest' && hgParts.job.state !== 'running' && "
                  "hgParts.busy === 0", 180)
    candidates = (api.part()["suggestions"] or {}).get("candidates", [])
    until(driver, f"return document.querySelectorAll('#suggestions tr[data-suggestion]').length === {len(candidates)}")
    refused = driver.execute_script("return [...document.querySelectorAll('#suggestions tr.refused td:nth-child(4)')]"
                                    ".map(td => td.innerText)")
    want = [f"refused: {c['refused']}" for c in candidates if c.get("refused")]
    check(len(candidates) > 0 and refused == want, f"refused candidates shown {refused}, suggestions.json {want}")


def commission(driver, api, part=PART):
    phases = set()
    before = driver.execute_script("return hgParts.job && hgParts.job.started_at")
    driver.find_element(By.ID, "commission").click()
    until(driver, "return hgParts.job && hgParts.job.kind === 'commission' && hgParts.job.started_at !== arguments[0]",
          60, before)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:
        job = driver.execute_script("return hgParts.job")
        if job and job["kind"] == "commission":
            phases.add(job["phase"])
            if job["state"] != "running" and driver.execute_script("return hgParts.busy === 0"):
                break
        time.sleep(0.2)
    check(job and (job["state"], job["exit_status"]) in (("finished", 0), ("not_releasable", 1)),
          f"commissioning ended {job}")
    check(len(phases) >= 2, f"the progress showed the phases {phases}")
    until(driver, "return document.querySelector('#report-landmarks') !== null")
    status, v = api.call("GET", f"/api/parts/{part}/verification")
    check(v["released"] == (job["state"] == "finished"), f"the job {job['state']}, the report released={v['released']}")
    rows = driver.execute_script("return [...document.querySelectorAll('#report-landmarks tr[data-landmark]')]"
                                 ".map(r => [r.dataset.landmark, r.querySelectorAll('td.cell-fail').length])")
    check([r[0] for r in rows] == [l["id"] for l in v["landmarks"]], f"report rows {rows}")
    failing = sorted(r[0] for r in rows if r[1] > 0)
    check(failing == sorted(l["id"] for l in v["landmarks"] if not l["passed"]), f"failing rows {failing}")
    return v


def remove(driver, landmark_id):
    driver.execute_script("document.querySelector(`#landmarks tr[data-landmark='${arguments[0]}']`).click()", landmark_id)
    until(driver, "return !document.getElementById('landmark-edit').hidden")
    driver.find_element(By.ID, "lm-remove").click()
    until(driver, "return hgParts.busy === 0 && !hgParts.landmarks().some(l => l.id === arguments[0])", 60, landmark_id)


def prove(driver, api):
    """Commissioned from the page until released, dropping what the findings name as an engineer does (the
    twin's verdict on a landmark depends on where along its edge the click put it)."""
    v = commission(driver, api)
    for _ in range(2):
        if v["released"]:
            break
        for subject in sorted({f["subject"] for f in v["findings"]}):
            if any(l["id"] == subject for l in api.part()["draft"]["landmarks"]):
                remove(driver, subject)
        v = commission(driver, api)
    check(v["released"], f"the stepped block's edge landmarks were not proven releasable: {v['findings']}")
    return v


def views(driver, api):
    status, planned = api.call("GET", f"/api/parts/{PART}/views")
    shown = driver.execute_script("return [...document.querySelectorAll('#views tr[data-view]')].map(r => r.dataset.view)")
    check(shown == [str(v["index"]) for v in planned["views"]], f"views listed {shown}, planned {planned['views']}")
    driver.execute_script("document.querySelector('#views tr[data-view]').click()")
    size = until(driver, "const i = document.getElementById('view-img');"
                         "return i.complete && i.naturalWidth > 0 ? [i.naturalWidth, i.naturalHeight] : false", 180)
    cam = planned["views"][0]["camera"]
    check(size == [cam["width"], cam["height"]], f"the view's frame is {size}, the camera's {cam['width']}x{cam['height']}")


def release(driver, number):
    driver.find_element(By.ID, "plc-program").clear()
    driver.find_element(By.ID, "plc-program").send_keys(str(number))
    driver.execute_script("document.getElementById('release-result').textContent = ''")
    driver.find_element(By.ID, "release-button").click()
    until(driver, "return hgParts.busy === 0 && document.getElementById('release-result').textContent !== ''", 180)
    return text(driver, "release-result")


def released_runs(driver, api, sock, db):
    said = release(driver, 2)
    check("version 1" in said and "PLC program 2" in said, f"the release was said as {said!r}")
    maintenance(sock, {"command": "trigger", "program": 2, "serial": "WB-V1"})
    deadline = time.monotonic() + 60
    while stored(db, "WB-V1") is None and time.monotonic() < deadline:
        time.sleep(0.1)
    row = stored(db, "WB-V1")
    check(row is not None and row["program"] == 2 and row["program_version"] == 1,
          f"the cycle of program 2 was judged with {dict(row) if row else None}")
    said = release(driver, 1)
    check(said.startswith("Refused") and "1" in said, f"PLC program 1 (the daemon's) was said {said!r}")


def versions(driver, api):
    changed = api.part()["draft"]["landmarks"][0]["id"]
    edit(driver, changed, tolerance="0.12")
    if not prove(driver, api)["released"]:
        return
    said = release(driver, 2)
    if not check("version 2" in said, f"the second release was said {said!r}"):
        return
    until(driver, "return hgParts.busy === 0 && document.querySelector('#versions tr[data-version=\"2\"]') !== null")
    driver.execute_script("document.querySelector('input[name=diff-from][value=\"1\"]').click();"
                          "document.querySelector('input[name=diff-to][value=\"2\"]').click()")
    driver.find_element(By.ID, "diff").click()
    until(driver, "return hgParts.busy === 0 && document.getElementById('diff-result').textContent.includes(arguments[0])",
          60, changed)
    driver.execute_script("document.querySelector('#versions tr[data-version=\"1\"] button').click()")
    until(driver, "return hgParts.busy === 0 && document.getElementById('release-result').textContent.includes('again')")
    _, listed = api.call("GET", f"/api/parts/{PART}/versions")
    newest = max(listed["versions"], key=lambda v: v["version"])
    check(newest["version"] == 3 and newest["rolled_back_from"] == 1 and newest["in_force"],
          f"after the rollback the versions are {listed}")
    shown = driver.execute_script("return [...document.querySelectorAll('#versions tr[data-version]')]"
                                  ".map(r => r.dataset.version)")
    check(shown == ["draft", "3", "2", "1"], f"versions listed {shown}")


def triangles(stl):
    """The triangles of a binary or ASCII STL file, read here (not by the code under test)."""
    data = stl.read_bytes()
    n = struct.unpack_from("<I", data, 80)[0] if len(data) >= 84 else 0
    if len(data) == 84 + 50 * n:
        return [[struct.unpack_from("<3f", data, 84 + 50 * i + 12 * (1 + k)) for k in range(3)] for i in range(n)]
    vertices = [tuple(map(float, line.split()[1:4])) for line in data.decode().splitlines()
                if line.strip().startswith("vertex")]
    return [vertices[i:i + 3] for i in range(0, len(vertices), 3)]


def sub3(a, b):
    return [x - y for x, y in zip(a, b)]


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def closest_on_triangle(p, a, b, c):
    """The point of triangle abc nearest p (Ericson, Real-Time Collision Detection, 5.1.5)."""
    ab, ac, ap = sub3(b, a), sub3(c, a), sub3(p, a)
    d1, d2 = dot(ab, ap), dot(ac, ap)
    if d1 <= 0 and d2 <= 0:
        return list(a)
    bp = sub3(p, b)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    if d3 >= 0 and d4 <= d3:
        return list(b)
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        v = d1 / (d1 - d3)
        return [x + v * y for x, y in zip(a, ab)]
    cp = sub3(p, c)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    if d6 >= 0 and d5 <= d6:
        return list(c)
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        w = d2 / (d2 - d6)
        return [x + w * y for x, y in zip(a, ac)]
    va = d3 * d6 - d5 * d4
    if va <= 0 and d4 - d3 >= 0 and d5 - d6 >= 0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return [x + w * (y - x) for x, y in zip(b, c)]
    denom = 1 / (va + vb + vc)
    v, w = vb * denom, vc * denom
    return [x + v * y + w * z for x, y, z in zip(a, ab, ac)]


def nearest_face(mesh, p):
    """How far p lies from the mesh's surface and the unit normal (right-handed winding) of the nearest triangle."""
    best = None
    for a, b, c in mesh:
        d = distance(p, closest_on_triangle(p, a, b, c))
        if best is None or d < best[0]:
            n = cross(sub3(b, a), sub3(c, a))
            length = math.sqrt(dot(n, n))
            if length > 0:
                best = (d, [x / length for x in n])
    return best


def public_part(driver, api, source, sock, db):
    """A public CAD mesh taken from upload to a judged PLC cycle, its landmarks placed by clicks checked against
    the mesh's own triangles."""
    driver.find_element(By.ID, "upload-tolerance").clear()
    driver.find_element(By.ID, "upload-tolerance").send_keys("0.4")
    driver.find_element(By.ID, "upload-depth").clear()
    driver.find_element(By.ID, "upload-depth").send_keys("7")
    upload(driver, source / PUBLIC_CAD, PUBLIC)
    until(driver, f"return hgParts.part === '{PUBLIC}' && hgParts.state === 'full' && hgParts.idle()", 120)
    part = api.part(PUBLIC)
    if not check(part and part["draft"]["octree"]["depth"] == 7 and part["draft"]["tolerance_mm"] == 0.4,
                 f"the public part was added as {part and part['draft']}"):
        return
    mesh = triangles(source / PUBLIC_CAD)
    for k, (point, face_normal, looking_from) in enumerate(PUBLIC_CLICKS, 1):
        click_face(driver, point, looking_from)
        until(driver, f"return hgParts.landmarks().length === {k} && hgParts.busy === 0")
        placed, sent = driver.execute_script("return [hgParts.lastPlaced, hgParts.lastPick]")
        landmark = next(l for l in api.part(PUBLIC)["draft"]["landmarks"] if l["id"] == placed["id"])
        picked_off, _ = nearest_face(mesh, sent)
        off, normal = nearest_face(mesh, landmark["position"])
        angle = math.degrees(math.acos(max(-1.0, min(1.0, dot(normal, landmark["normal"])))))
        check(distance(sent, point) < CLICK_MM, f"a click aimed at {point} picked {sent}")
        check(picked_off <= 0.05, f"the picked point {sent} lies {picked_off:.4f} mm from the mesh")
        check(landmark["on"] == "face" and off <= 0.05 and angle <= 1.0,
              f"{landmark} lies {off:.4f} mm from the mesh, its normal {angle:.3f}° from the face's {normal}")
        check(dot(normal, face_normal) > math.cos(math.radians(1.0)), f"the face at {point} has the normal {normal}")
    v = commission(driver, api, PUBLIC)
    if not check(v["released"], f"the public part's face landmarks were not proven releasable: {v['findings']}"):
        return
    said = release(driver, 3)
    check("version 1" in said and "PLC program 3" in said, f"the public part's release was said as {said!r}")
    maintenance(sock, {"command": "trigger", "program": 3, "serial": "WB-PUBLIC"})
    deadline = time.monotonic() + 60
    while stored(db, "WB-PUBLIC") is None and time.monotonic() < deadline:
        time.sleep(0.1)
    row = stored(db, "WB-PUBLIC")
    check(row is not None and row["program"] == 3 and row["program_version"] == 1 and row["verdict"] == "pass",
          f"the cycle of program 3 was judged {dict(row) if row else None}")


def screenshot(driver, folder):
    """The page at 1920 x 1080 as docs/workbench.md shows it: the part with its pins and the planned views'
    frustums, a view's frame with its silhouette points, the verification report."""
    folder.mkdir(parents=True, exist_ok=True)
    # The viewport itself 1920 x 1080 (a window of that size leaves less to the page).
    driver.set_window_size(1920, 1200)
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                           {"width": 1920, "height": 1080, "deviceScaleFactor": 1, "mobile": False})
    until(driver, "return window.innerWidth === 1920 && window.innerHeight === 1080")
    # The part filling a third of the view: its pins and the nearer ends of the views' frustums.
    driver.execute_script("document.getElementById('view-close').click(); window.scrollTo(0, 0);"
                          "const v = hgParts.view; v.fit(false);"
                          "v.camera.position.sub(v.controls.target).multiplyScalar(2.2).add(v.controls.target);"
                          "v.update()")
    until(driver, "return hgParts.idle()")
    driver.save_screenshot(str(folder / "workbench-model.png"))
    driver.execute_script("document.querySelector('#views tr[data-view]').click()")
    until(driver, "const i = document.getElementById('view-img'); return i.complete && i.naturalWidth > 0", 180)
    driver.execute_script("document.getElementById('zoom-in').click(); document.getElementById('zoom-in').click();"
                          "const f = document.getElementById('view-frame');"
                          "f.scrollLeft = (f.scrollWidth - f.clientWidth) / 2; f.scrollTop = (f.scrollHeight - f.clientHeight) / 2;"
                          "document.getElementById('viewer').scrollIntoView()")
    until(driver, "return hgParts.idle()")
    driver.save_screenshot(str(folder / "workbench-view.png"))
    driver.execute_script("document.getElementById('view-close').click();"
                          "document.getElementById('prove').scrollIntoView()")
    driver.save_screenshot(str(folder / "workbench-report.png"))


def main():
    args = test_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-parts-"))
    http_port = free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, free_port(),
                              ["--http-port", str(http_port),
                               "--hmi-password-hash-file", str(password_hash_file(workdir, PASSWORD))])
    url, api = f"http://127.0.0.1:{http_port}", Api(http_port)
    sock, db = str(workdir / "hullgauged.sock"), workdir / "results.db"
    driver = chromium(flags=("--enable-unsafe-swiftshader",))
    try:
        sign_in_on_page(driver, url, api)
        uploads(driver, args.source, api)
        place_landmarks(driver, api)
        drag_and_edit(driver, api)
        stale_revision(driver, api)
        suggestions(driver, api)
        if prove(driver, api)["released"]:
            views(driver, api)
            released_runs(driver, api, sock, db)
            versions(driver, api)
        public_part(driver, api, args.source, sock, db)
        if args.screenshots:
            screenshot(driver, args.screenshots)
    finally:
        driver.quit()
        stop_line(line, out)
    return outcome("Parts page", workdir)


if __name__ == "__main__":
    sys.exit(main())
