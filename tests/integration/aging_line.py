#!/usr/bin/python3
"""The station's health on a simulated line that ages (docs/health.md,
"Aging line"; docs/camera.md, "Aging"): one degradation at a time — the
panel dims, dust gathers on it, the lens defocuses, a halo grows round the
part's edge — each on a fresh line (tools/simline --config config/sim-aging
with only that kind of aging, one step per cycle). This script is the PLC
(pymodbus) and the engineer (hullgauge ctl): it takes the flat-field
reference of the new line, then runs the nominal part and the face-low part
in turn, each verdict judged against what the part is, and reads every
cycle's health warnings from the PLC's HEALTH_WARNINGS (146), checked against
the result store's health rows.

For each degradation the warning that names it must come on while every
verdict is still right — before the first wrong verdict, which is run for
until it comes or the aging reaches its end — and the cycle of each is
printed: the figures docs/health.md quotes.

With --screenshots DIR, the maintenance page's health charts at the end of
each run, 1920 x 1080 (hmi-health-aging-<kind>.png: the pictures of
docs/health.md).

  aging_line.py --source DIR --bin DIR [--kinds dim,dust,defocus,halo] [--screenshots DIR]
"""
import json
import re
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, free_port, maintenance, outcome, start_line, stop_line, test_args  # noqa: E402
from hmi_browser import browser, plc_cycle, until  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402

HEALTH_WARNINGS = 146
BITS = {"backlight": 0, "uniformity": 1, "dust": 2, "focus": 3, "contrast": 4, "noise": 5, "edge_bias": 6,
        "capability": 7}
SHOWN = ("backlight", "uniformity", "dust_specks", "edge_width_px", "contrast", "noise", "edge_bias_px", "capability")

# Per degradation: the aging it gets per cycle (the rest of config/sim-aging's station
# as it is), the warning that must name it, and how many cycles it ages for at most.
KINDS = {
    "dim": ("{per_cycles: 1, dim: 0.1}", "backlight", 40),
    "dust": ("{per_cycles: 1, dust_specks: 20, speck_radius_px: [1.5, 2.5], speck_depth: [0.4, 0.8], seed: 5}", "dust", 40),
    "defocus": ("{per_cycles: 1, defocus_px: 0.4}", "focus", 40),
    "halo": ("{per_cycles: 1, halo_px: 0.25}", "edge_bias", 40),
}


def overlay(source, folder, aging):
    """config/sim-aging's station with `aging` in place of its own."""
    folder.mkdir()
    text = (source / "config" / "sim-aging" / "station.yaml").read_text()
    aged, n = re.subn(r"^(\s*)aging: \{.*\}$", lambda m: f"{m.group(1)}aging: {aging}", text, flags=re.M)
    if n != 1:
        raise SystemExit("config/sim-aging/station.yaml: no one-line `aging:` to replace")
    (folder / "station.yaml").write_text(aged)
    return folder


def flat_field(bin_dir, sock):
    """The engineer takes the new line's flat-field reference (hullgauge ctl flat-field follows it)."""
    r = subprocess.run([str(bin_dir / "hullgauge"), "ctl", "--socket", sock, "flat-field", "--wait-timeout", "120"],
                       capture_output=True, text=True, timeout=180)
    return check(r.returncode == 0, f"ctl flat-field: exit {r.returncode}: {r.stdout}{r.stderr}")


def stored_health(db, serial):
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    con.row_factory = sqlite3.Row
    row = con.execute("SELECT i.verdict, h.* FROM inspections i LEFT JOIN health h ON h.inspection_id = i.id "
                      "WHERE i.serial = ? ORDER BY i.id DESC LIMIT 1", (serial,)).fetchone()
    con.close()
    return dict(row) if row else None


def screenshot(http_port, kind, folder):
    """The maintenance page's health charts of the run, as the engineer sees them."""
    driver = browser(window=(1920, 1080))
    try:
        driver.get(f"http://127.0.0.1:{http_port}/maintenance")
        until(driver, "return window.hgMaintenance.health && window.hgMaintenance.health.charts")
        driver.execute_script("document.getElementById('health').scrollIntoView()")
        driver.save_screenshot(str(folder / f"hmi-health-aging-{kind}.png"))
    finally:
        driver.quit()


def age(args, kind, workdir):
    """One degradation on a fresh line: (cycle of the first warning naming it, of the first wrong verdict,
    cycles run, the figures of the warning's cycle)."""
    aging, figure, cycles = KINDS[kind]
    folder = workdir / kind
    folder.mkdir()
    plc_port, http_port = free_port(), free_port()
    line, out, _ = start_line(args.source, args.bin, folder, plc_port,
                              ["--http-port", str(http_port), "--config", str(args.source / "config" / "sim-aging"),
                               "--config", str(overlay(args.source, folder / "overlay", aging))])
    sock, db = str(folder / "hullgauged.sock"), folder / "results.db"
    client = ModbusTcpClient("127.0.0.1", port=plc_port, timeout=10)
    warned = wrong = None
    at_warning = {}
    run = 0
    try:
        check(client.connect(), f"{kind}: the PLC client could not connect")
        if not flat_field(args.bin, sock):
            return None, None, 0, {}
        seq = client.read_holding_registers(0, 1, slave=1).registers[0]
        for k in range(1, cycles + 1):
            bad = k % 2 == 0
            serial = f"{kind.upper()}-{k:03d}"
            maintenance(sock, {"command": "sim-part", "name": "face-low" if bad else "nominal"})
            seq = (seq + 1) % 65536 or 1
            plc_cycle(client, seq, serial)
            run = k
            bits = client.read_holding_registers(HEALTH_WARNINGS, 1, slave=1).registers[0]
            row = stored_health(db, serial)
            if not check(row is not None, f"{kind} cycle {k}: no stored row"):
                break
            named = json.loads(row["warnings"]) if row["warnings"] is not None else []
            print(f"{kind} {k:2d} {row['verdict']:4s} {named} " +
                  " ".join(f"{key}={row[key]:.4g}" if row[key] is not None else f"{key}=-" for key in SHOWN), flush=True)
            check(bits == sum(1 << BITS[w] for w in named),
                  f"{kind} cycle {k}: HEALTH_WARNINGS {bits:#x}, the stored row's warnings {named}")
            # None of these ages the panel's shape: a uniformity warning would be a false one (the
            # fringe of an edge along the rows read as a dim zone, docs/health.md "Background samples").
            check("uniformity" not in named, f"{kind} cycle {k}: uniformity warned ({row['uniformity']})")
            if warned is None and figure in named:
                warned = k
                at_warning = {key: row[key] for key in SHOWN}
            if row["verdict"] != ("fail" if bad else "pass"):
                wrong = k
                break
        if args.screenshots:
            screenshot(http_port, kind, args.screenshots)
    finally:
        client.close()
        stop_line(line, out)
    return warned, wrong, run, at_warning


def main():
    args = test_args(lambda ap: ap.add_argument("--kinds", default=",".join(KINDS)))
    workdir = Path(tempfile.mkdtemp(prefix="hg-aging-"))
    table = []
    for kind in args.kinds.split(","):
        warned, wrong, run, figures = age(args, kind, workdir)
        table.append((kind, warned, wrong, run, figures))
        check(warned is not None, f"{kind}: no {KINDS[kind][1]} warning in {run} cycles")
        check(warned is None or wrong is None or warned < wrong,
              f"{kind}: the first wrong verdict (cycle {wrong}) came before the {KINDS[kind][1]} warning ({warned})")
    print("| degradation | per cycle | warning | first at cycle | first wrong verdict | cycles run |")
    print("|---|---|---|---|---|---|")
    for kind, warned, wrong, run, figures in table:
        print(f"| {kind} | `{KINDS[kind][0]}` | {KINDS[kind][1]} | {warned} | {wrong or 'none'} | {run} |")
    for kind, warned, wrong, run, figures in table:
        print(f"{kind}: figures at the warning: {figures}")
    return outcome("aging line", workdir)


if __name__ == "__main__":
    sys.exit(main())
