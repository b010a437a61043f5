#!/usr/bin/python3
"""The mastering run from the HMI's maintenance page in a real browser
(docs/mastering.md, "The mastering run"; docs/hmi.md, "Maintenance"):
Debian's chromium, headless, driven by chromium-driver through selenium,
against the simulated line (tools/simline --http-port, config/sim-fast, the
stepped block's program with the deviation on and a mastering folder, as
simline_master.py lays them over). The accounts come from the tool
(`hullgauge users add`); the trail and the rows are read here with sqlite3.

- the cycles' purpose is set to `study` on the maintenance socket first, so
  that the run is seen to put back the purpose it found, not production;
- the operator: the Mastering card offers no action, and their session's own
  request for the run is answered 403 naming who may; the attempt is in the
  trail (`mastering.run`, refused, olga, operator);
- the engineer chooses the certificate file, 3 cycles, **Run the master**;
  the page follows the run to `done` and shows the new set: its name as the
  daemon's status names it in force, and per certified landmark the offset
  and U_corr, equal (to the 4 decimals shown, and to 1e-9 in the page's data)
  to a recomputation here from the 3 stored master rows — offset = certified −
  mean of the rows' deviation_mm, U_corr = 2·sqrt((U_c/2)² + s²/n);
- exactly 3 manual master rows with the certificate's serial; the purpose is
  `study` again; `hullgauge ctl status` prints the run done with the set;
- the trail: `mastering.run` done by erik (engineer), then `mastering.set`
  done by erik with the set file empty before and the written set after.

  mastering_browser.py --source DIR --bin DIR [--screenshots DIR]  (DIR/hmi-mastering.png: the card)
"""
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, outcome, test_args, free_port, maintenance, start_line, stop_line  # noqa: E402
from simline_master import CERTIFIED, certificate, check_set, overlay, rows  # noqa: E402
from hmi_browser import browser, texts, until  # noqa: E402
from hmi_roles_browser import attempt, sign_in, sign_out, trail  # noqa: E402

from selenium.webdriver.common.by import By  # noqa: E402

OLGA, ERIK = ("olga", "olga-operator-pw"), ("erik", "erik-engineer-pw")
CYCLES = 3
CERTIFIED_U = 0.002  # the certificate's U of every landmark (simline_master.certificate)


def add_accounts(bin_dir, workdir):
    """The operator and the engineer from the tool, each password from a file."""
    for (name, password), role in ((OLGA, "operator"), (ERIK, "engineer")):
        secret = workdir / f"{name}-password"
        secret.touch(mode=0o600)
        secret.write_text(password + "\n")
        run = subprocess.run([str(bin_dir / "hullgauge"), "users", "add", name, "--role", role, "--password-file",
                              str(secret), "--file", str(workdir / "users.yaml"),
                              "--audit", str(workdir / "audit.sqlite")], capture_output=True, text=True)
        check(run.returncode == 0, f"hullgauge users add {name}: exit {run.returncode}: {run.stderr}")


def operator_refused(driver, url, workdir, cert):
    sign_in(driver, url, "/maintenance", OLGA)
    check(driver.execute_script("return document.getElementById('mastering-actions').hidden") is True,
          "the operator's Mastering card offers the run")
    status, error = attempt(driver, "/api/maintenance", {"command": "master", "program": 1, "run": CYCLES,
                                                         "certificate": cert.read_text()})
    check(status == 403 and "olga" in error and "an engineer or administrator" in error,
          f"an operator's mastering run: {status} {error!r}")
    refused = [(e["who"], e["role"], e["action"], e["outcome"]) for e in trail(workdir, "outcome = 'refused'")]
    check(refused == [("olga", "operator", "mastering.run", "refused")], f"the refusal in the trail: {refused}")


def expected_corrections(master_rows):
    """Per certified landmark (offset, U_corr) from the rows alone (docs/mastering.md, "Uncertainty")."""
    out = {}
    for lid, certified in CERTIFIED.items():
        readings = [next(l for l in json.loads(r["landmarks_json"]) if l["id"] == lid)["deviation_mm"]
                    for r in master_rows]
        n = len(readings)
        mean = sum(readings) / n
        s = math.sqrt(sum((x - mean) ** 2 for x in readings) / (n - 1))
        out[lid] = (certified - mean, 2 * math.sqrt((CERTIFIED_U / 2) ** 2 + s * s / n))
    return out


def engineer_runs(driver, url, cert):
    sign_out(driver)
    sign_in(driver, url, "/maintenance", ERIK)
    until(driver, "return !document.getElementById('mastering-actions').hidden")
    driver.find_element(By.ID, "master-program").clear()
    driver.find_element(By.ID, "master-program").send_keys("1")
    driver.find_element(By.ID, "master-cycles").clear()
    driver.find_element(By.ID, "master-cycles").send_keys(str(CYCLES))
    driver.find_element(By.ID, "master-certificate").send_keys(str(cert))
    driver.find_element(By.ID, "master-run").click()
    # Progress first (cycle k of N), then the end: done with the set shown.
    until(driver, "const m = window.hgMaintenance.mastering; return m && m.run && m.run.cycles === arguments[0]",
          60, CYCLES)
    until(driver, "const m = window.hgMaintenance.mastering; return m && m.run && m.run.state !== 'running'"
                  " && !document.getElementById('mastering-result').hidden", 300)
    return driver.execute_script("return window.hgMaintenance.mastering")


def check_page(driver, shown, master_rows, set_id):
    run = shown["run"]
    check(run["state"] == "done" and run["set"]["id"] == set_id and shown["sets"].get("1") == set_id,
          f"the page's run: {run.get('state')} {run.get('error')} set {run.get('set', {}).get('id')}")
    check(run["progress"] == [f"master cycle {k} of {CYCLES}: {r['verdict']} (result {r['id']})"
                              for k, r in enumerate(master_rows, 1)], f"the page's progress: {run['progress']}")
    caption = driver.find_element(By.ID, "mastering-result-caption").text
    check(set_id in caption and "in force" in caption, f"the result's caption: {caption!r}")
    expected = expected_corrections(master_rows)
    data = {l["id"]: l for l in run["set"]["landmarks"]}
    cells = dict(zip(texts(driver, "#mastering-result tbody tr", "data-landmark"),
                     zip(texts(driver, "#mastering-result td.offset"), texts(driver, "#mastering-result td.uncertainty"))))
    check(set(cells) == set(CERTIFIED), f"the landmarks shown: {sorted(cells)}")
    for lid, (offset, u) in expected.items():
        print(f"{lid:<10} offset {offset:.6f} ± {u:.6f} mm; page {cells.get(lid)}", flush=True)
        check(abs(data[lid]["offset_mm"] - offset) <= 1e-9 and abs(data[lid]["uncertainty_mm"] - u) <= 1e-9,
              f"{lid}: the page's data {data[lid]}, recomputed {offset} ± {u}")
        check(cells.get(lid) == (f"{offset:.4f}", f"{u:.4f}"), f"{lid}: shown {cells.get(lid)}, recomputed "
              f"{offset:.4f} ± {u:.4f}")


def check_trail(workdir, set_file):
    runs = [(e["who"], e["role"], e["outcome"], e["object"]) for e in trail(workdir, "action = 'mastering.run'"
                                                                            " AND outcome != 'refused'")]
    check(runs == [("erik", "engineer", "done", "program 1")], f"mastering.run in the trail: {runs}")
    ends = trail(workdir, "action = 'mastering.set'")
    check(len(ends) == 1 and ends[0]["who"] == "erik" and ends[0]["outcome"] == "done"
          and ends[0]["before_text"] == "" and ends[0]["after_text"] == set_file.read_text(),
          f"mastering.set in the trail: {[(e['who'], e['outcome'], e['detail']) for e in ends]}")


def main():
    args = test_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-mastering-"))
    masters = workdir / "masters"
    masters.mkdir()
    add_accounts(args.bin, workdir)
    cert = certificate(workdir / "MASTER-1.yaml", "MASTER-1")
    http_port = free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, free_port(),
                              ["--http-port", str(http_port), "--config", str(args.source / "config" / "sim-fast"),
                               "--config", str(overlay(args.source, workdir / "overlay", masters))], timeout_s=120)
    url = f"http://127.0.0.1:{http_port}"
    sock = str(workdir / "hullgauged.sock")
    driver = browser(window=(1600, 1100))
    try:
        check(maintenance(sock, {"command": "purpose", "purpose": "study"}).get("ok"), "purpose study")
        operator_refused(driver, url, workdir, cert)
        shown = engineer_runs(driver, url, cert)
        master_rows = rows(workdir / "results.db", "purpose = 'master' AND serial = 'MASTER-1'")
        check(len(master_rows) == CYCLES and all(r["manual"] == 1 and r["verdict"] in ("pass", "fail")
                                                 for r in master_rows), f"{len(master_rows)} master rows")
        set_file = masters / "program-1.json"
        if check(set_file.exists() and len(master_rows) == CYCLES, f"{set_file} written"):
            set_id, _ = check_set(set_file, master_rows, CYCLES)
            check(maintenance(sock, {"command": "status"})["mastering"]["sets"].get("1") == set_id, "set in force")
            check_page(driver, shown, master_rows, set_id)
            check_trail(workdir, set_file)
            ctl = subprocess.run([str(args.bin / "hullgauge"), "ctl", "--socket", sock, "status"],
                                 capture_output=True, text=True)
            check(f"mastering:    done, program 1, master MASTER-1, set {set_id} in force" in ctl.stdout,
                  f"ctl status: {ctl.stdout}")
        check(maintenance(sock, {"command": "purpose"})["purpose"] == "study", "the purpose the run found, back")
        if args.screenshots:
            # The Mastering card alone, as docs/mastering.md shows it.
            driver.execute_script("document.getElementById('mastering').scrollIntoView()")
            driver.find_element(By.ID, "mastering").screenshot(str(args.screenshots / "hmi-mastering.png"))
    finally:
        driver.quit()
        stop_line(line, out)
    return outcome("mastering from the HMI", workdir)


if __name__ == "__main__":
    sys.exit(main())
