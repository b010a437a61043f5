#!/usr/bin/python3
"""`hullgauge master --run N` on the simulated line (docs/mastering.md, "The command"):
the daemon's mastering run ("The mastering run"), asked for and followed by the command.

Starts tools/simline (config/sim with config/sim-fast and, laid over both, the
stepped block's program with `inspection.deviation: true` and the daemon's
configuration with `mastering.folder` in this test's work folder), judges one
production part (no set: no correction id), then runs

    hullgauge master --socket S --program 1 --master CERT.yaml --run 5

with neither --store nor --out: the daemon names its result store and its
mastering folder. Checked from outside, with the python sqlite3 module on the
SQLite file and the maintenance socket:

- exit 0, and the purpose is production again; the daemon's status names the
  run done with the set it put in force;
- exactly 5 rows of purpose master with the certificate's serial, triggered
  manually, all judged, after the production row;
- the set written to <mastering.folder>/program-1.json: per certified
  landmark one point with 5 cycles, its measured value the mean of the 5
  rows' deviation_mm (nothing was corrected while they ran), its spread their
  sample standard deviation and its offset certified − measured, to 1e-9;
- the set in force: the daemon's status names it, and the next production
  row carries its id, each certified landmark corrected by the offset;
- a master whose serial the daemon refuses (17 characters): exit 3 naming
  the serial, the purpose production again, no row with that serial;
- SIGINT while a run waits for a result: exit 3 saying it was cancelled, the
  purpose production again, the set in force unchanged.

Every wait is bounded; ports are free ports on 127.0.0.1.
"""
import argparse
import json
import math
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, failures, free_port, maintenance, start_line, stop_line  # noqa: E402

CERTIFIED = {"step-top": 0.004, "tall-top": -0.003}


def overlay(source, folder, masters):
    """config/sim's program with the deviation on, and its daemon configuration with a mastering folder."""
    folder.mkdir(parents=True)
    program = (source / "config" / "sim" / "stepped-block.yaml").read_text()
    if "inspection:" in program:
        raise SystemExit("config/sim/stepped-block.yaml has an inspection section: adapt this test")
    (folder / "stepped-block.yaml").write_text(program.rstrip("\n") + "\ninspection:\n  deviation: true\n")
    daemon = (source / "config" / "sim" / "hullgauged.yaml").read_text()
    if "mastering:" in daemon:
        raise SystemExit("config/sim/hullgauged.yaml has a mastering section: adapt this test")
    (folder / "hullgauged.yaml").write_text(daemon.rstrip("\n") + f"\nmastering:\n  folder: {masters}\n")
    return folder


def certificate(path, serial):
    lines = [f"master: {serial}", "certificate: CMM report 2026-0412", "landmarks:"]
    lines += [f"  {lid}: {{value_mm: {v}, uncertainty_mm: 0.002}}" for lid, v in CERTIFIED.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def rows(db_file, where, args=()):
    db = sqlite3.connect(f"file:{db_file}?mode=ro", uri=True)
    db.row_factory = sqlite3.Row
    out = [dict(r) for r in db.execute(f"SELECT * FROM inspections WHERE {where} ORDER BY id", args)]
    db.close()
    return out


def wait_for(what, condition, timeout_s=120):
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise SystemExit(f"not within {timeout_s} s: {what}")
        time.sleep(0.1)


def production_cycle(sock, db_file, serial):
    """A manual production trigger (ctl trigger's request) and its stored row."""
    answer = maintenance(sock, {"command": "trigger", "program": 1, "serial": serial})
    check(answer.get("ok"), f"trigger {serial}: {answer}")
    return wait_for(f"the row of {serial}", lambda: rows(db_file, "serial = ?", (serial,)))[0]


def purpose(sock):
    return maintenance(sock, {"command": "purpose"})["purpose"]


def check_set(set_file, master_rows, cycles=5):
    """The set against the master rows as stored: mean, spread and offset per certified landmark."""
    correction = json.loads(set_file.read_text())
    check(correction["program"] == 1 and correction["method"] == "one_point", f"set: {correction}")
    by_id = {l["id"]: l for l in correction["landmarks"]}
    check(set(by_id) == set(CERTIFIED), f"corrected landmarks {sorted(by_id)}, certified {sorted(CERTIFIED)}")
    offsets = {}
    for lid, certified in CERTIFIED.items():
        readings = []
        for row in master_rows:
            landmark = next(l for l in json.loads(row["landmarks_json"]) if l["id"] == lid)
            readings.append(landmark["deviation_mm"])
        n = len(readings)
        mean = sum(readings) / n
        s = math.sqrt(sum((r - mean) ** 2 for r in readings) / (n - 1))
        point = by_id[lid]["points"][0]
        print(f"{lid:<10} readings {[round(r, 5) for r in readings]}, mean {mean:.6f}, s {s:.6f}, "
              f"offset {by_id[lid]['offset_mm']:.6f}", flush=True)
        check(point["master"] == "MASTER-1" and point["cycles"] == n == cycles, f"{lid}: {point}")
        check(abs(point["measured_mm"] - mean) <= 1e-9, f"{lid}: measured {point['measured_mm']}, mean {mean}")
        check(abs(point["spread_mm"] - s) <= 1e-9, f"{lid}: spread {point['spread_mm']}, s {s}")
        check(abs(by_id[lid]["offset_mm"] - (certified - mean)) <= 1e-9, f"{lid}: offset {by_id[lid]['offset_mm']}")
        offsets[lid] = certified - mean
    return correction["id"], offsets


def run(args, workdir, sock, db_file, masters):
    hullgauge = str(args.bin / "hullgauge")
    before = production_cycle(sock, db_file, "PART-1")
    check(before["verdict"] == "pass" and before["correction_id"] == "", f"first production row: {before}")

    master = [hullgauge, "master", "--socket", sock, "--program", "1", "--timeout", "60"]
    ran = subprocess.run(master + ["--master", str(certificate(workdir / "master-1.yaml", "MASTER-1")), "--run", "5"],
                         capture_output=True, text=True, timeout=600)
    print(ran.stdout + ran.stderr, flush=True)
    check(ran.returncode == 0, f"master --run 5 exit {ran.returncode}")
    check(purpose(sock) == "production", "the purpose after the run")
    master_rows = rows(db_file, "purpose = 'master' AND serial = 'MASTER-1'")
    check(len(master_rows) == 5, f"{len(master_rows)} master rows")
    check(all(r["manual"] == 1 and r["verdict"] in ("pass", "fail") and r["id"] > before["id"] for r in master_rows),
          "the master rows: manual, judged, after the production row")
    set_file = masters / "program-1.json"
    if not check(set_file.exists(), f"{set_file} written"):
        return
    set_id, offsets = check_set(set_file, master_rows)
    status = maintenance(sock, {"command": "status"})
    check(status["mastering"]["sets"].get("1") == set_id, f"status mastering: {status['mastering']}")
    run_status = status["mastering"]["run"] or {}
    check(run_status.get("state") == "done" and run_status.get("set", {}).get("id") == set_id
          and run_status.get("results") == [r["id"] for r in master_rows], f"status mastering.run: {run_status}")

    after = production_cycle(sock, db_file, "PART-2")
    check(after["correction_id"] == set_id and after["purpose"] == "production", f"next production row: {after}")
    for l in json.loads(after["landmarks_json"]):
        if l["id"] in offsets:
            check(abs(l["deviation_mm"] - (l["raw_deviation_mm"] + offsets[l["id"]])) <= 1e-9, f"corrected: {l}")

    # A serial the daemon refuses: the run ends at its first trigger, the purpose is production again.
    refused = subprocess.run(master + ["--master", str(certificate(workdir / "long.yaml", "MASTER-0123456789")),
                                       "--run", "3"], capture_output=True, text=True, timeout=120)
    check(refused.returncode == 3 and "serial: 17 characters" in refused.stderr, f"refused serial: {refused}")
    check(purpose(sock) == "production", "the purpose after a refused trigger")
    check(not rows(db_file, "serial = 'MASTER-0123456789'"), "no row of the refused serial")

    # SIGINT while the run waits: cancelled, the purpose production again, the set in force kept.
    interrupted = subprocess.Popen(master + ["--master", str(certificate(workdir / "master-3.yaml", "MASTER-3")),
                                             "--run", "50"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for("a first MASTER-3 row", lambda: rows(db_file, "serial = 'MASTER-3'"))
        interrupted.send_signal(signal.SIGINT)
        out, err = interrupted.communicate(timeout=60)
    finally:
        if interrupted.poll() is None:
            interrupted.kill()
            interrupted.wait()
    check(interrupted.returncode == 3 and "cancelled (SIGINT)" in err, f"SIGINT: exit {interrupted.returncode}: {err}")
    check(purpose(sock) == "production", "the purpose after SIGINT")
    check(json.loads(set_file.read_text())["id"] == set_id, "the set in force after SIGINT")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    args = ap.parse_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-master-"))
    masters = workdir / "masters"
    masters.mkdir()
    plc_port = free_port()
    overlays = ["--config", str(args.source / "config" / "sim-fast"),
                "--config", str(overlay(args.source, workdir / "overlay", masters))]
    line, line_out, _ = start_line(args.source, args.bin, workdir, plc_port, overlays, timeout_s=90)
    try:
        run(args, workdir, str(workdir / "hullgauged.sock"), workdir / "results.db", masters)
    finally:
        stop_line(line, line_out)
    if failures:
        print(f"{len(failures)} checks failed; work folder {workdir}", file=sys.stderr)
        return 1
    print("hullgauge master --run: 5 master cycles, the set from them in force; refusal and SIGINT restore production")
    subprocess.run(["rm", "-rf", str(workdir)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
