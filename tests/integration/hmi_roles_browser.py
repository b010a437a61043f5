#!/usr/bin/python3
"""Roles and the audit trail in a real browser (docs/audit.md): Debian's
chromium, headless, driven by chromium-driver through selenium, against the
simulated line (tools/simline --http-port) with accounts only (no shared
password). The trail is read here with sqlite3 and Python's csv module:

- the first administrator comes from the tool (`hullgauge users add`, the
  password from a file); the accounts file is mode 0600 and the addition is in
  the trail as the shell's user from `tool`;
- the administrator adds an operator and an engineer on the Users page;
- the operator signs in: the maintenance page offers no action, the Parts page
  no change; their session's own requests to release a part program and to
  calibrate are answered 403 naming who may, and each attempt is in the trail
  (outcome refused, who the operator, role operator);
- the engineer sets the cycles' purpose on the maintenance page: in the trail
  with before `production` and after `master`; a purpose set on the
  maintenance socket is in it as `unix:<user>` from `socket`;
- the Audit page lists the refusals and opens a change to its before and
  after; its CSV download and `hullgauge audit --format csv` hold the same
  refusals.

  hmi_roles_browser.py --source DIR --bin DIR [--screenshots DIR]
"""
import csv
import io
import json
import os
import pwd
import sqlite3
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, outcome, test_args, free_port, maintenance, start_line, stop_line  # noqa: E402
from hmi_browser import browser, texts, until  # noqa: E402

from selenium.webdriver.common.by import By  # noqa: E402

ANNA, OLGA, ERIK = ("anna", "anna-admin-pw"), ("olga", "olga-operator-pw"), ("erik", "erik-engineer-pw")


def trail(workdir, where="1", args=()):
    """The audit entries matching `where`, oldest first, as dicts."""
    with sqlite3.connect(f"file:{workdir / 'audit.sqlite'}?mode=ro", uri=True) as db:
        db.row_factory = sqlite3.Row
        return [dict(r) for r in db.execute(f"SELECT * FROM audit WHERE {where} ORDER BY id", args)]


def first_administrator(bin_dir, workdir):
    """`hullgauge users add` as the line PC's shell would run it; the password from a file."""
    secret = workdir / "anna-password"
    secret.touch(mode=0o600)
    secret.write_text(ANNA[1] + "\n")
    run = subprocess.run([str(bin_dir / "hullgauge"), "users", "add", ANNA[0], "--role", "administrator",
                          "--password-file", str(secret), "--file", str(workdir / "users.yaml"),
                          "--audit", str(workdir / "audit.sqlite")], capture_output=True, text=True)
    check(run.returncode == 0, f"hullgauge users add: exit {run.returncode}: {run.stderr}")
    mode = stat.S_IMODE(os.stat(workdir / "users.yaml").st_mode)
    check(mode == 0o600, f"users.yaml has mode {oct(mode)}, not 0600")
    check(ANNA[1] not in (workdir / "users.yaml").read_text(), "the password is in the accounts file")
    me = "unix:" + pwd.getpwuid(os.geteuid()).pw_name
    added = trail(workdir, "action = 'user.add'")
    check(len(added) == 1 and added[0]["who"] == me and added[0]["source"] == "tool"
          and added[0]["after_text"] == "role: administrator", f"the tool's addition in the trail: {added}")


def sign_in(driver, url, page, who):
    driver.get(f"{url}{page}")
    until(driver, "return !document.getElementById('login').closest('[hidden]')"
                  " && document.getElementById('login').offsetParent !== null")
    driver.find_element(By.ID, "login-name").send_keys(who[0])
    driver.find_element(By.ID, "login-password" if page != "/maintenance" else "password").send_keys(who[1])
    driver.find_element(By.CSS_SELECTOR, "#login button").click()
    until(driver, "return document.getElementById('session').textContent.includes(arguments[0])", 30,
          f"Signed in as {who[0]}")


def sign_out(driver):
    driver.execute_script("return fetch('/api/session').then(r => r.json()).then(s => fetch('/api/logout', "
                          "{method: 'POST', headers: {'Content-Type': 'application/json', 'X-CSRF-Token': s.csrf},"
                          " body: '{}'}))")


def add_accounts(driver, url):
    """The administrator adds the operator and the engineer on the Users page."""
    sign_in(driver, url, "/users", ANNA)
    until(driver, "return document.querySelectorAll('#accounts tbody tr').length === 1")
    for (name, password), role in ((OLGA, "operator"), (ERIK, "engineer")):
        driver.find_element(By.ID, "add-name").clear()
        driver.find_element(By.ID, "add-name").send_keys(name)
        driver.execute_script("document.getElementById('add-role').value = arguments[0]", role)
        driver.find_element(By.ID, "add-password").send_keys(password)
        driver.find_element(By.ID, "add-button").click()
        until(driver, "return document.querySelector(`#accounts tr[data-name='${arguments[0]}']`) !== null", 30, name)
    roles = driver.execute_script("return [...document.querySelectorAll('#accounts select.role')]"
                                  ".map(s => s.dataset.name + ':' + s.value)")
    check(sorted(roles) == ["anna:administrator", "erik:engineer", "olga:operator"], f"the accounts listed: {roles}")


def attempt(driver, path, body):
    """A change sent with the signed-in session's own cookie and CSRF token: (status, error)."""
    return driver.execute_script(
        "return (async (path, body) => {"
        "const s = await (await fetch('/api/session')).json();"
        "const r = await fetch(path, {method: 'POST', body: JSON.stringify(body),"
        " headers: {'Content-Type': 'application/json', 'X-CSRF-Token': s.csrf}});"
        "return [r.status, (await r.json()).error || ''];})(arguments[0], arguments[1]);", path, body)


def operator_refused(driver, url, workdir):
    """The operator: no actions offered; a release and a calibration refused 403, each in the trail."""
    sign_in(driver, url, "/maintenance", OLGA)
    hidden = driver.execute_script("return ['actions', 'calibrate-actions', 'settings-actions']"
                                   ".map(id => document.getElementById(id).hidden)")
    check(hidden == [True, True, True], f"the operator's maintenance page offers actions: hidden {hidden}")
    check("operator" in driver.find_element(By.ID, "session").text, "the page does not name the operator's role")
    status, error = attempt(driver, "/api/parts/bracket/release", {"revision": 1, "plc_program": 2})
    check(status == 403 and error == "operator 'olga' may not change part programs: that needs an engineer or "
          "administrator", f"an operator's release: {status} {error!r}")
    status, error = attempt(driver, "/api/maintenance", {"command": "calibrate", "pattern": "chessboard:8x5:15",
                                                         "poses": str(workdir / "poses.yaml")})
    check(status == 403 and "may not calibrate the station" in error, f"an operator's calibration: {status} {error!r}")
    refused = trail(workdir, "outcome = 'refused'")
    actions = [(e["who"], e["role"], e["action"], e["object"]) for e in refused]
    check(actions == [("olga", "operator", "program.release", "bracket"),
                      ("olga", "operator", "calibration.run", "calibrate")], f"the refusals in the trail: {actions}")
    driver.get(f"{url}/parts")
    until(driver, "return document.getElementById('session').textContent.includes('olga')")
    enabled = driver.execute_script("return [...document.querySelectorAll('.needs-sign-in')].filter(e => !e.disabled)"
                                    ".map(e => e.id || e.textContent)")
    check(enabled == [], f"the operator's Parts page leaves changes enabled: {enabled}")


def engineer_sets_purpose(driver, url, workdir, sock):
    sign_out(driver)
    sign_in(driver, url, "/maintenance", ERIK)
    until(driver, "return !document.getElementById('actions').hidden")
    driver.execute_script("document.getElementById('purpose').value = 'master'")
    driver.find_element(By.ID, "set-purpose").click()
    until(driver, "return document.getElementById('action-result').textContent.includes('master')")
    changed = trail(workdir, "action = 'setting.purpose'")
    check(len(changed) == 1 and changed[0]["who"] == "erik" and changed[0]["role"] == "engineer"
          and changed[0]["before_text"] == "production" and changed[0]["after_text"] == "master",
          f"the engineer's purpose in the trail: {changed}")
    answer = maintenance(sock, {"command": "purpose", "purpose": "production", "caller": {"who": "forged"}})
    check(answer.get("ok"), f"purpose on the socket: {answer}")
    me = "unix:" + pwd.getpwuid(os.geteuid()).pw_name
    changed = trail(workdir, "action = 'setting.purpose'")
    check(len(changed) == 2 and changed[1]["who"] == me and changed[1]["source"] == "socket"
          and changed[1]["before_text"] == "master", f"the socket's purpose in the trail: {changed[1:]}")


def audit_page(driver, url, workdir, bin_dir, screenshots):
    """The operator reads the trail: the refusals listed, a change opened; CSV from the page and the tool."""
    sign_out(driver)
    sign_in(driver, url, "/audit", OLGA)
    until(driver, "return document.querySelectorAll('#trail tbody tr').length > 0")
    driver.execute_script("document.getElementById('f-outcome').value = 'refused'")
    driver.find_element(By.ID, "search").click()
    until(driver, "return [...document.querySelectorAll('#trail tbody tr')].every(r => r.classList.contains("
                  "'outcome-refused')) && document.querySelectorAll('#trail tbody tr').length === 2")
    shown = texts(driver, "#trail tbody tr td:nth-child(5)")
    check(shown == ["calibration.run", "program.release"], f"the page's refusals: {shown}")
    body = driver.execute_script("return fetch(document.getElementById('dl-csv').href).then(r => r.text())")
    rows = list(csv.DictReader(io.StringIO(body)))
    check([(r["who"], r["action"], r["outcome"]) for r in rows] ==
          [("olga", "calibration.run", "refused"), ("olga", "program.release", "refused")], f"the page's CSV: {rows}")
    tool = subprocess.run([str(bin_dir / "hullgauge"), "audit", "--audit", str(workdir / "audit.sqlite"),
                           "--outcome", "refused", "--format", "csv"], capture_output=True, text=True)
    check(tool.returncode == 0 and list(csv.DictReader(io.StringIO(tool.stdout))) == rows,
          f"hullgauge audit --format csv differs from the page's: {tool.returncode} {tool.stderr}")
    # A change opened: the engineer's purpose, before and after side by side.
    driver.execute_script("document.getElementById('f-outcome').value = ''")
    driver.find_element(By.ID, "f-who").send_keys("erik")
    driver.find_element(By.ID, "search").click()
    until(driver, "return document.querySelector(\"#trail tr[data-action='setting.purpose']\") !== null")
    driver.find_element(By.CSS_SELECTOR, "#trail tr[data-action='setting.purpose']").click()
    until(driver, "return !document.getElementById('change').hidden")
    diff = driver.execute_script("return [...document.querySelectorAll('#change-rows tr')]"
                                 ".map(r => [r.className, ...[...r.cells].map(c => c.textContent)])")
    check(diff == [["diff-del", "production", ""], ["diff-add", "", "master"]], f"the change shown: {diff}")
    if screenshots:
        # The trail as the quality engineer reads it: every entry, a configuration file opened.
        driver.find_element(By.ID, "f-who").clear()
        driver.find_element(By.ID, "search").click()
        until(driver, "return document.querySelector(\"#trail tr[data-action='file.recorded']\") !== null")
        driver.find_element(By.CSS_SELECTOR, "#trail tr[data-action='setting.purpose']").click()
        shots(driver, screenshots, "audit")


def shots(driver, folder, name):
    for width, height in ((1920, 1080), (1280, 800)):
        driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                               {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
        try:
            driver.save_screenshot(str(folder / f"hmi-{name}-{width}x{height}.png"))
        finally:
            driver.execute_cdp_cmd("Emulation.clearDeviceMetricsOverride", {})


def main():
    args = test_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-roles-"))
    first_administrator(args.bin, workdir)
    http_port = free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, free_port(),
                              ["--http-port", str(http_port), "--config", str(args.source / "config" / "sim-fast")])
    url = f"http://127.0.0.1:{http_port}"
    driver = browser(window=(1600, 1000))
    try:
        started = trail(workdir, "action = 'file.recorded'")
        check(len(started) >= 3 and all(e["who"] == "hullgauged" for e in started),
              f"the configuration's files at start: {[(e['object'], e['who']) for e in started]}")
        add_accounts(driver, url)
        if args.screenshots:
            shots(driver, args.screenshots, "users")
        sign_out(driver)
        operator_refused(driver, url, workdir)
        engineer_sets_purpose(driver, url, workdir, str(workdir / "hullgauged.sock"))
        audit_page(driver, url, workdir, args.bin, args.screenshots)
        passwords = [p for _, p in (ANNA, OLGA, ERIK)]
        leaked = [e["action"] for e in trail(workdir) for p in passwords
                  if p in json.dumps(e)]
        check(leaked == [], f"a password in the trail: {leaked}")
    finally:
        driver.quit()
        stop_line(line, out)
    return outcome("roles and audit trail", workdir)


if __name__ == "__main__":
    sys.exit(main())
