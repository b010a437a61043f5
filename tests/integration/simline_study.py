#!/usr/bin/python3
"""A type-1 gauge study on the simulated line (docs/study.md).

Starts tools/simline (config/sim with config/sim-fast and, laid over both, a
copy of the stepped block's part program with `inspection.deviation: true`
written out — the study is about the sub-voxel deviation whatever the
default — into this test's work folder), tags the next cycles master through
the PLC's CYCLE_PURPOSE register (11 = 1, with tools/plc-client; the
maintenance socket must then report it), runs --cycles inspections of the
nominal part — every part seated at random by the simulated line — and two
production cycles after them (`hullgauge ctl purpose production`), stops the
line and runs `hullgauge study type1 --json` on its result store.

The study is then recomputed here, independently, from the numbers this
script reads itself from the SQLite file (the python sqlite3 module): per
landmark the pass/fail cycles tagged master, `deviation_mm` when every cycle
has it (else `error_mm`), T from `limits_mm` or ±`tolerance_mm`, x̄, s (n − 1),
Cg = 0.2·T / 6s, Cgk = (0.1·T − |x̄|) / 3s; the tool's figures must agree to
1e-9 relative, the cycle count must be --cycles (no production cycle), and
every landmark the deviation measured in every cycle must have been studied
on it (at least 8 of the 10: a seat can leave a landmark without a clean
outline edge, docs/inspection.md, and that landmark falls back to the
bracket middle — printed with the cycles that lacked it).
Every wait is bounded; ports are free ports on 127.0.0.1.
"""
import argparse
import json
import math
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, failures, free_port, start_line, stop_line  # noqa: E402


def deviation_overlay(source, folder):
    """config/sim's stepped-block.yaml with the sub-voxel deviation on, in a folder of its own."""
    folder.mkdir(parents=True)
    text = (source / "config" / "sim" / "stepped-block.yaml").read_text()
    if "inspection:" in text:
        raise SystemExit("config/sim/stepped-block.yaml has an inspection section: adapt this test")
    (folder / "stepped-block.yaml").write_text(text.rstrip("\n") + "\ninspection:\n  deviation: true\n")
    return folder


def ratio(a, b):
    """a / b, with s = 0 (every value equal) unbounded by the sign of a (docs/study.md)."""
    if b > 0:
        return a / b
    return math.inf if a > 0 else (-math.inf if a < 0 else 0.0)


def number(v):
    """The tool's JSON number, or its "inf" / "-inf"."""
    return float(v) if isinstance(v, str) else v


def expected_study(db_file):
    """Per landmark id: (n, source, mean, s, T, Cg, Cgk) from the master cycles as stored."""
    db = sqlite3.connect(f"file:{db_file}?mode=ro", uri=True)
    rows = [json.loads(text) for (text,) in db.execute(
        "SELECT landmarks_json FROM inspections WHERE purpose = 'master' AND verdict IN ('pass', 'fail') "
        "ORDER BY id")]
    db.close()
    out = {}
    for landmark in rows[0]:
        entries = [next(l for l in row if l["id"] == landmark["id"]) for row in rows]
        with_deviation = all(isinstance(e.get("deviation_mm"), (int, float)) for e in entries)
        key = "deviation_mm" if with_deviation else "error_mm"
        x = [e[key] for e in entries]
        limits = landmark.get("limits_mm")
        T = limits[1] - limits[0] if limits else 2 * landmark["tolerance_mm"]
        n = len(x)
        mean = sum(x) / n
        s = math.sqrt(sum((v - mean) ** 2 for v in x) / (n - 1))
        missing = sum(1 for e in entries if not isinstance(e.get("deviation_mm"), (int, float)))
        out[landmark["id"]] = (n, key, mean, s, T, ratio(0.2 * T, 6 * s), ratio(0.1 * T - abs(mean), 3 * s), missing)
    return out


def close(a, b):
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= 1e-9 * max(1.0, abs(b))


def compare(study, expected, cycles):
    check(study["selection"]["cycles"] == cycles, f"study took {study['selection']['cycles']} cycles, ran {cycles}")
    check({l["id"] for l in study["landmarks"]} == set(expected), "the study's landmarks are the records'")
    print(f"{'landmark':<14} {'n':>3} {'mean mm':>10} {'s mm':>9} {'Cg':>8} {'Cgk':>8}  (recomputed Cg, Cgk)")
    on_deviation = 0
    for l in study["landmarks"]:
        n, key, mean, s, T, cg, cgk, missing = expected[l["id"]]
        print(f"{l['id']:<14} {l['n']:>3} {l['mean_mm']:>10.5f} {l['stddev_mm']:>9.5f} {number(l['cg']):>8.3f} "
              f"{number(l['cgk']):>8.3f}  ({cg:.3f}, {cgk:.3f})", flush=True)
        on_deviation += key == "deviation_mm"
        if missing:
            print(f"  {l['id']}: no deviation in {missing} of {n} cycles: studied on the bracket middle", flush=True)
        check(l["values"] == key and l["n"] == n and l["evaluated"], f"{l['id']}: {l}")
        for field, value in (("mean_mm", mean), ("stddev_mm", s), ("tolerance_mm", T), ("cg", cg), ("cgk", cgk)):
            check(close(number(l[field]), value), f"{l['id']}: {field} {l[field]}, recomputed {value}")
        # Known to a voxel (the bracket middle) a landmark is never capable (docs/study.md).
        capable = key == "deviation_mm" and cg >= 1.33 and cgk >= 1.33
        check(l["capable"] == capable, f"{l['id']}: capable {l['capable']}")
    check(on_deviation >= 8, f"only {on_deviation} of {len(study['landmarks'])} landmarks studied on deviation_mm")


def run(args, workdir, sock, plc_port):
    plc_client = ["/usr/bin/python3", str(args.source / "tools" / "plc-client"), "--port", str(plc_port)]
    hullgauge = str(args.bin / "hullgauge")

    # Master cycles from now on: the PLC writes CYCLE_PURPOSE, the maintenance socket reports it.
    wrote = subprocess.run(plc_client + ["write", "11", "1"], capture_output=True, text=True, timeout=20)
    check(wrote.returncode == 0 and json.loads(wrote.stdout)["exception"] == 0, f"write CYCLE_PURPOSE: {wrote}")
    status = subprocess.run([hullgauge, "ctl", "--socket", sock, "purpose"], capture_output=True, text=True,
                            timeout=20)
    check(status.stdout == "purpose: master\n", f"ctl purpose after the PLC's write: {status.stdout!r}")

    for n, purpose in ((args.cycles, "master"), (2, "production")):
        if purpose == "production":
            subprocess.run([hullgauge, "ctl", "--socket", sock, "purpose", "production"], check=True, timeout=20,
                           capture_output=True)
        ran = subprocess.run(plc_client + ["cycles", str(n), "--bad-every", "0", "--timeout", "60"],
                             capture_output=True, text=True, timeout=60 * n + 60)
        check(ran.returncode == 0, f"plc-client cycles ({purpose}) exit {ran.returncode}: {ran.stderr}")
        print(f"{purpose}: {n} cycles", flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    ap.add_argument("--cycles", type=int, default=30)
    args = ap.parse_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-study-"))
    plc_port = free_port()
    overlays = ["--config", str(args.source / "config" / "sim-fast"),
                "--config", str(deviation_overlay(args.source, workdir / "overlay"))]
    line, line_out, _ = start_line(args.source, args.bin, workdir, plc_port, overlays, timeout_s=90)
    try:
        run(args, workdir, str(workdir / "hullgauged.sock"), plc_port)
    finally:
        stop_line(line, line_out)

    db_file = workdir / "results.db"
    study = subprocess.run([str(args.bin / "hullgauge"), "study", "type1", "--store", str(db_file), "--json"],
                           capture_output=True, text=True, timeout=60)
    if check(study.returncode == 0, f"study type1 exit {study.returncode}: {study.stderr}"):
        compare(json.loads(study.stdout), expected_study(db_file), args.cycles)
        text = subprocess.run([str(args.bin / "hullgauge"), "study", "type1", "--store", str(db_file)],
                              capture_output=True, text=True, timeout=60)
        print(text.stdout, flush=True)

    if failures:
        print(f"{len(failures)} checks failed; work folder {workdir}", file=sys.stderr)
        return 1
    print(f"type-1 study of {args.cycles} master cycles: Cg and Cgk of every landmark as recomputed")
    subprocess.run(["rm", "-rf", str(workdir)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
