#!/usr/bin/python3
"""The soak: thousands of cycles of the simulated line, for a build with
AddressSanitizer/LeakSanitizer/UBSan (CMake preset `soak`, label `soak`).

Starts tools/simline on config/soak (320 x 240 camera, fast simulated fixture)
with the programs of --bin (the sanitized hullgauged and fixture simulator),
runs --cycles inspections with pymodbus the way a PLC does, alternating the
nominal part and the `corner-missing` defect, and checks:

- every cycle: the trigger is acknowledged, DONE_SEQ reaches it within a
  bounded time (no stuck state) and RESULT is a verdict (pass or fail, never
  an error); STATUS is done (2) afterwards;
- the verdicts are the parts' (nominal passes, corner-missing fails);
- the daemon's resident memory is flat: VmRSS after the last cycle exceeds
  VmRSS after --rss-from cycles by at most --rss-growth-mib;
- the SQLite store (read with python's sqlite3) holds one row per cycle;
- SIGTERM stops the line with exit status 0 for both programs, and their logs
  hold no sanitizer report (LeakSanitizer runs at the daemon's exit).
--rss-csv FILE appends `cycles,vmrss_kib` every --rss-every cycles (the memory
curve of docs/daemon.md; a release build's --bin runs the same soak faster).
Every wait is bounded.
"""
import argparse
import ctypes
import json
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pymodbus.client import ModbusTcpClient

ACK_SEQ, DONE_SEQ, STATUS, RESULT = 100, 101, 102, 103
SANITIZER_MARKS = ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:", "SUMMARY: UndefinedBehavior")


def die_with_parent():
    """In the child: SIGTERM when this script ends, however it ends (a CTest timeout kills it outright),
    so the simulated line never outlives it."""
    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def maintenance(path, request):
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(10)
        s.connect(path)
        s.sendall((json.dumps(request) + "\n").encode())
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    answer = json.loads(data)
    if not answer.get("ok"):
        raise RuntimeError(f"maintenance {request['command']}: {answer.get('error')}")
    return answer


def vm_rss_kib(pid):
    for line in open(f"/proc/{pid}/status"):
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def encode_serial(text):
    raw = text.encode("ascii")[:16].ljust(16, b"\0")
    return [(raw[i] << 8) | raw[i + 1] for i in range(0, 16, 2)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    ap.add_argument("--cycles", type=int, default=2000)
    ap.add_argument("--rss-from", type=int, default=500, help="cycle after which the RSS baseline is taken")
    ap.add_argument("--rss-growth-mib", type=float, default=16.0)
    ap.add_argument("--cycle-timeout", type=float, default=20.0)
    ap.add_argument("--rss-csv", type=Path, help="write cycles,vmrss_kib to this CSV every --rss-every cycles")
    ap.add_argument("--rss-every", type=int, default=100)
    args = ap.parse_args()
    if not 0 < args.rss_from < args.cycles:
        ap.error("--rss-from must lie between 0 and --cycles")

    failures = []
    workdir = Path(tempfile.mkdtemp(prefix="hg-soak-"))
    env = dict(os.environ)
    # Sanitizer reports go to the programs' logs; any UB ends the program (and so the soak).
    # A small quarantine (the default is 256 MiB): freed memory is reused within the first cycles, so
    # what VmRSS still gains after them is the sanitizer's stack depot (docs/daemon.md, "soak").
    env.setdefault("ASAN_OPTIONS", "detect_leaks=1:quarantine_size_mb=8")
    env.setdefault("UBSAN_OPTIONS", "print_stacktrace=1:halt_on_error=1")
    out = open(workdir / "simline.out", "w")
    line = subprocess.Popen([str(args.source / "tools" / "simline"), "--bin", str(args.bin), "--workdir", str(workdir),
                             "--plc-port", str(free_port()), "--fixture-port", "0", "--log", "warn",
                             "--config", str(args.source / "config" / "soak")],
                            stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
                            preexec_fn=die_with_parent, env=env)
    started = time.monotonic()
    rss = {}
    cycles_done = 0
    try:
        deadline = time.monotonic() + 180
        while not (workdir / "simline.ready").exists():
            if line.poll() is not None or time.monotonic() > deadline:
                print((workdir / "simline.out").read_text(), file=sys.stderr)
                raise SystemExit("soak: the simulated line did not start")
            time.sleep(0.1)
        ready = dict(l.split("=", 1) for l in (workdir / "simline.ready").read_text().split())
        sock, pid = ready["socket"], int(ready["daemon_pid"])
        client = ModbusTcpClient("127.0.0.1", port=int(ready["plc_port"]), timeout=5)
        if not client.connect():
            raise SystemExit("soak: cannot connect to the daemon's PLC port")
        seq = client.read_holding_registers(0, 1, slave=1).registers[0]
        for i in range(args.cycles):
            bad = i % 2 == 1
            maintenance(sock, {"command": "sim-part", "name": "corner-missing" if bad else "nominal"})
            seq = (seq + 1) % 65536 or 1
            w = client.write_registers(0, [seq, 1] + encode_serial(f"SOAK{i:06d}"), slave=1)
            if w.isError():
                failures.append(f"cycle {i}: trigger write failed: {w}")
                break
            deadline = time.monotonic() + args.cycle_timeout
            r = client.read_holding_registers(ACK_SEQ, 4, slave=1).registers
            if r[0] != seq:
                failures.append(f"cycle {i}: trigger {seq} refused (ACK_SEQ {r[0]}, STATUS {r[2]})")
                break
            while r[1] != seq and time.monotonic() < deadline:
                time.sleep(0.002)
                r = client.read_holding_registers(ACK_SEQ, 4, slave=1).registers
            if r[1] != seq:
                failures.append(f"cycle {i}: DONE_SEQ stuck at {r[1]} (STATUS {r[2]}) {args.cycle_timeout} s "
                                f"after trigger {seq}")
                break
            cycles_done += 1
            expected = 2 if bad else 1
            if r[3] != expected or r[2] != 2:
                failures.append(f"cycle {i} ({'corner-missing' if bad else 'nominal'}): RESULT {r[3]}, STATUS "
                                f"{r[2]}; expected RESULT {expected}, STATUS 2")
                if len(failures) > 20:
                    break
            if cycles_done in (args.rss_from, args.cycles):
                rss[cycles_done] = vm_rss_kib(pid)
            if args.rss_csv and cycles_done % args.rss_every == 0:
                with open(args.rss_csv, "a") as csv:
                    csv.write(f"{cycles_done},{vm_rss_kib(pid)}\n")
            if cycles_done % 250 == 0:
                print(f"soak: {cycles_done} cycles, {time.monotonic() - started:.0f} s, VmRSS "
                      f"{vm_rss_kib(pid) / 1024:.1f} MiB", flush=True)
        client.close()
        line.send_signal(signal.SIGTERM)
        try:
            line.wait(timeout=120)
        except subprocess.TimeoutExpired:
            failures.append("the line did not stop within 120 s of SIGTERM")
    finally:
        if line.poll() is None:
            os.killpg(line.pid, signal.SIGKILL)
            line.wait()
        out.close()

    for name in ("hullgauged", "fixture-sim"):
        exit_file = workdir / f"{name}.exit"
        status = exit_file.read_text().strip() if exit_file.exists() else "unknown"
        if status != "0":
            failures.append(f"{name} exit status {status} after SIGTERM (a sanitizer report exits non-zero)")
        log = (workdir / f"{name}.log").read_text(errors="replace")
        for mark in SANITIZER_MARKS:
            if mark in log:
                failures.append(f"{name}.log holds a sanitizer report ('{mark}')")
    if cycles_done == args.cycles:
        growth = (rss[args.cycles] - rss[args.rss_from]) / 1024
        print(f"soak: VmRSS {rss[args.rss_from] / 1024:.1f} MiB after cycle {args.rss_from}, "
              f"{rss[args.cycles] / 1024:.1f} MiB after cycle {args.cycles} ({growth:+.1f} MiB)")
        if growth > args.rss_growth_mib:
            failures.append(f"VmRSS grew by {growth:.1f} MiB between cycle {args.rss_from} and {args.cycles} "
                            f"(bound {args.rss_growth_mib} MiB)")
    db_file = workdir / "results.db"
    if db_file.exists():
        db = sqlite3.connect(f"file:{db_file}?mode=ro", uri=True)
        stored = db.execute("SELECT COUNT(*) FROM inspections WHERE manual = 0").fetchone()[0]
        errors = db.execute("SELECT COUNT(*) FROM inspections WHERE verdict NOT IN ('pass', 'fail')").fetchone()[0]
        db.close()
        if stored != cycles_done or errors:
            failures.append(f"{stored} records stored ({errors} not pass/fail) for {cycles_done} cycles")
    else:
        failures.append("no result database")

    print(f"soak: {cycles_done} of {args.cycles} cycles in {time.monotonic() - started:.0f} s")
    if failures:
        for f in failures:
            print(f"FAILED: {f}", file=sys.stderr)
        print(f"work folder {workdir}", file=sys.stderr)
        return 1
    subprocess.run(["rm", "-rf", str(workdir)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
