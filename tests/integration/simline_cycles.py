#!/usr/bin/python3
"""The simulated line end to end (docs/contracts.md §6, §7).

Starts tools/simline (fixture simulator on Modbus TCP, hullgauged with the
simulated camera and config/sim, with --config laid over it: CTest uses
config/sim-fast, the same line with a faster turntable, and
config/sim-telecentric, a telecentric lens at 0.01 mm per pixel on a
quarter-size block with the same landmarks and defects), runs --cycles
inspections (CTest: 100) with the
independent PLC client tools/plc-client alternating the nominal part and a
defective variant (half the run `face-low`, half `corner-missing`), and checks:

- every verdict is the part's: nominal passes with 0 of 10 landmarks failed;
  `face-low` fails exactly step-top and step-top-back, `corner-missing` exactly
  tall-corner and tall-side (the landmarks the defects were built to move);
- every result block the PLC read was consistent (ACK_SEQ, DONE_SEQ, RESULT,
  LANDMARKS_FAILED and LANDMARK_OK_BITS of the same trigger, the OK bits those
  of the part's failing landmarks), every read while polling showed the
  previous result whole, and afterwards ACK_SEQ = DONE_SEQ = the last trigger
  with its RESULT and OK bits;
- the lamps, read from outside the daemon after every cycle (the simulated
  lamp lines in the maintenance socket's status): green alone after a pass,
  red alone after a fail, amber never lit once the result is shown;
- the SQLite store holds exactly one row per cycle with the PLC's trigger
  sequence, serial, verdict and failing landmarks;
- every part is seated at random (config/sim `simulation.seating`), and the
  views after the first two are taken at poses corrected for the seat the
  first two measured (docs/alignment.md, "Poses corrected for the seat").
  Worked out here from the station file's kinematics (docs/contracts.md §2)
  and the part's *true* seat: no corrected view sees the part farther off
  its planned direction of sight than it would have from the planned pose;
  on a nominal part every view the fixture's ranges let be corrected fully
  sees it within 0.05° of the planned direction; over the run those views
  are on average at least ten times closer than they would have been. With
  --seat-tolerance-mm (the simulated telecentric line's test), and always
  for a plan of two views, which has no view to correct, every nominal
  part's measured seat is checked against its true seat, within
  --seat-tolerance-mm at the reference point and --seat-tolerance-deg;
- SIGTERM stops the line cleanly (exit 0, no process left behind).
Every wait is bounded.
"""
import argparse
import json
import math
import os
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, failures, free_port, start_line, stop_line  # noqa: E402

LANDMARKS = ["tall-top", "tall-corner", "tall-side", "tall-foot", "riser", "step-top", "step-side", "end-front",
             "end-back", "step-top-back"]
FAILING = {"nominal": set(), "face-low": {"step-top", "step-top-back"}, "corner-missing": {"tall-corner", "tall-side"}}
RESULT_CODE = {"pass": 1, "fail": 2}


def group_gone(pgid, timeout_s):
    """Whether no process of group `pgid` is left, polled under a deadline (the group's last
    processes may still be exiting when its leader was reaped)."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)


def ok_bits(failing):
    """LANDMARK_OK_BITS word 0 for the given failing landmarks (bit i: landmark i in program order)."""
    return sum(1 << i for i, name in enumerate(LANDMARKS) if name not in failing)


def rotation(axis, deg):
    """Right-handed rotation matrix (rows) by deg about the unit axis."""
    n = math.sqrt(sum(a * a for a in axis))
    x, y, z = (a / n for a in axis)
    c, s, C = math.cos(math.radians(deg)), math.sin(math.radians(deg)), 1 - math.cos(math.radians(deg))
    return [[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
            [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
            [z * x * C - y * s, z * y * C + x * s, c + z * z * C]]


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def tmul(a, v):
    """a transposed times v."""
    return [sum(a[k][i] * v[k] for k in range(3)) for i in range(3)]


def sight(station, pose, seat):
    """Unit direction from the part's reference point back along its line of sight, in the part's frame:
    camera_from_part = camera_from_fixture · Rot(declination) · Rot(rotation) · seat (axes through the origin).
    Towards the camera centre; for a telecentric camera (docs/telecentric.md) against its optical axis."""
    fixture = station["fixture"]
    pose_r = mul(mul(fixture["camera_from_fixture"]["R"], rotation(fixture["declination_axis"], pose["declination_deg"])),
                 rotation(fixture["rotation_axis"], pose["rotation_deg"]))
    if station["camera"].get("model") == "telecentric":
        back = tmul(pose_r, [0, 0, -1])  # the nominal frame
        return tmul(seat["R"], back)
    centre = tmul(pose_r, [-v for v in fixture["camera_from_fixture"]["t"]])  # the nominal frame
    in_part = tmul(seat["R"], [c - t for c, t in zip(centre, seat["t"])])
    d = [p - q for p, q in zip(in_part, seat["centre"])]
    n = math.sqrt(sum(v * v for v in d))
    return [v / n for v in d]


def angle_deg(a, b):
    return math.degrees(math.acos(max(-1.0, min(1.0, sum(x * y for x, y in zip(a, b))))))


def true_sight_errors(station, alignment, simulation):
    """Per view, with the part's true seat: the record's view and how many degrees off the planned direction of
    sight the part was seen from the commanded pose and would have been from the planned one."""
    seat = simulation["seat"]
    drawn = {"R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [0, 0, 0], "centre": seat["centre"]}
    out = []
    for v in alignment["pose_correction"]["views"]:
        wanted = sight(station, v["planned"], drawn)
        out.append((v, angle_deg(wanted, sight(station, v["commanded"], seat)),
                    angle_deg(wanted, sight(station, v["planned"], seat))))
    return out


def seat_error(measured, true):
    """The distance between where the two seats put the reference point (mm) and the angle between them (°)."""
    c = true["centre"]
    at = lambda T: [sum(T["R"][i][j] * c[j] for j in range(3)) + T["t"][i] for i in range(3)]
    relative = [[sum(measured["R"][k][i] * true["R"][k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    cos_angle = (relative[0][0] + relative[1][1] + relative[2][2] - 1.0) / 2.0
    return math.dist(at(measured), at(true)), math.degrees(math.acos(max(-1.0, min(1.0, cos_angle))))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    ap.add_argument("--cycles", type=int, default=22)
    ap.add_argument("--config", type=Path, help="a folder laid over config/sim (tools/simline --config)")
    ap.add_argument("--seat-tolerance-mm", type=float, default=None,
                    help="judge every nominal part's measured seat against its true one: at most this far off at "
                         "the reference point (a two-view plan: always, 0.005 mm)")
    ap.add_argument("--seat-tolerance-deg", type=float, default=0.02, help="the same, the angle between them")
    args = ap.parse_args()
    if args.cycles < 4:
        ap.error("--cycles: at least 4")
    # The PLC client needs Debian's python3-pymodbus: the system interpreter, whatever runs this script.
    plc_client = ["/usr/bin/python3", str(args.source / "tools" / "plc-client")]
    hullgauge = str(args.bin / "hullgauge")

    workdir = Path(tempfile.mkdtemp(prefix="hg-simline-"))
    plc_port = free_port()
    line, line_out, _ = start_line(args.source, args.bin, workdir, plc_port,
                                   ["--config", str(args.config)] if args.config else [], timeout_s=90)
    try:
        sock = str(workdir / "hullgauged.sock")

        listed = subprocess.run([hullgauge, "ctl", "--socket", sock, "--json", "sim-part", "--list"],
                                capture_output=True, text=True, timeout=10)
        check(listed.returncode == 0, f"ctl sim-part --list: {listed.stderr}")
        check(all(name in listed.stdout for name in FAILING), f"parts listed: {listed.stdout}")

        # The PLC client alternates: cycle i of a run is defective when i is odd.
        plan = []
        for variant, n in (("face-low", args.cycles // 2), ("corner-missing", args.cycles - args.cycles // 2)):
            run = subprocess.run(plc_client + ["--port", str(plc_port), "cycles", str(n), "--bad-every", "2",
                                               "--timeout", "30", "--sim-socket", sock, "--variant", variant],
                                 capture_output=True, text=True, timeout=150)
            check(run.returncode == 0, f"plc-client ({variant}) exit {run.returncode}: {run.stderr}")
            rows = [json.loads(text) for text in run.stdout.splitlines() if text.strip()]
            cycles = [r for r in rows if "summary" not in r]
            check(len(cycles) == n, f"{variant}: {len(cycles)} of {n} cycles ran")
            for i, r in enumerate(cycles):
                part = variant if i % 2 == 1 else "nominal"
                expected = "fail" if FAILING[part] else "pass"
                check(r["verdict"] == expected, f"cycle {r['seq']} ({part}): verdict {r['verdict']}, expected {expected}")
                check(r["consistent"], f"cycle {r['seq']} ({part}): inconsistent result block {r}")
                check(r["fault_code"] == 0, f"cycle {r['seq']}: fault code {r['fault_code']}")
                check(r["landmarks_total"] == len(LANDMARKS), f"cycle {r['seq']}: LANDMARKS_TOTAL {r['landmarks_total']}")
                check(r["landmarks_failed"] == len(FAILING[part]),
                      f"cycle {r['seq']} ({part}): LANDMARKS_FAILED {r['landmarks_failed']}")
                check(0 < r["cycle_ms"] < 30000, f"cycle {r['seq']}: CYCLE_MS {r['cycle_ms']}")
                check(r["ok_bits"] == [ok_bits(FAILING[part])],
                      f"cycle {r['seq']} ({part}): LANDMARK_OK_BITS {r['ok_bits']}, expected {ok_bits(FAILING[part]):#06x}")
                check(r["inconsistent_reads"] == 0 and r["reads"] >= 1,
                      f"cycle {r['seq']}: {r['inconsistent_reads']} of {r['reads']} polling reads showed a mixed block")
                passed = expected == "pass"
                lamps = r.get("lamps") or {}
                check(lamps.get("lit") == {"green": passed, "amber": False, "red": not passed},
                      f"cycle {r['seq']} ({part}): lamps lit {lamps.get('lit')} after a {expected}")
                check((lamps.get("green"), lamps.get("amber"), lamps.get("red")) ==
                      (("on", "off", "off") if passed else ("off", "off", "on")),
                      f"cycle {r['seq']} ({part}): lamps commanded {lamps}")
                plan.append((r["seq"], r["serial"], part, expected))
            print(f"{variant}: {len(cycles)} cycles, verdicts checked", flush=True)

        # After the last cycle the registers still show its result, all of a piece.
        read = subprocess.run(plc_client + ["--port", str(plc_port), "read", "100", "21"], capture_output=True,
                              text=True, timeout=10)
        check(read.returncode == 0, f"plc-client read: {read.stderr}")
        if read.returncode == 0 and plan:
            regs = json.loads(read.stdout)
            last_seq, _, last_part, last_expected = plan[-1]
            check(regs[0] == last_seq and regs[1] == last_seq, f"ACK_SEQ {regs[0]} DONE_SEQ {regs[1]}, last {last_seq}")
            check(regs[3] == RESULT_CODE[last_expected], f"RESULT {regs[3]} after a {last_part} part")
            check(regs[20] == ok_bits(FAILING[last_part]),
                  f"LANDMARK_OK_BITS word 0 {regs[20]:#06x}, expected {ok_bits(FAILING[last_part]):#06x}")

        # SIGTERM stops the line; nothing of it is left running.
        stop_line(line, line_out)
        check(group_gone(line.pid, timeout_s=5), "processes of the simulated line survived its stop")

        # The result store: one row per cycle, the PLC's sequence, serial, verdict and failing landmarks.
        db = sqlite3.connect(f"file:{workdir / 'results.db'}?mode=ro", uri=True)
        rows = db.execute("SELECT trigger_seq, serial, verdict, landmarks_failed, landmarks_json, alignment_json, "
                          "simulation_json FROM inspections WHERE manual = 0 ORDER BY id").fetchall()
        check(len(rows) == len(plan), f"{len(rows)} rows in the result store for {len(plan)} cycles")
        overlaid = args.config / "station.yaml" if args.config else None
        station_file = overlaid if overlaid and overlaid.exists() else args.source / "config" / "sim" / "station.yaml"
        station = yaml.safe_load(station_file.read_text())
        views_file = (args.config / "stepped-block-views.yaml") if args.config else None
        if not (views_file and views_file.exists()):
            views_file = args.source / "config" / "sim" / "stepped-block-views.yaml"
        corrected_views = len(yaml.safe_load(views_file.read_text())) > 2
        judge_seats = args.seat_tolerance_mm is not None or not corrected_views
        seat_tolerance_mm = args.seat_tolerance_mm if args.seat_tolerance_mm is not None else 0.005
        after_all, before_all, seat_errors = [], [], []
        for (seq, serial, part, expected), (db_seq, db_serial, verdict, failed, landmarks, alignment,
                                            simulation) in zip(plan, rows):
            check((db_seq, db_serial, verdict) == (seq, serial, expected),
                  f"stored ({db_seq}, {db_serial}, {verdict}), PLC saw ({seq}, {serial}, {expected})")
            bad = {l["id"] for l in json.loads(landmarks) if l["status"] != "ok"}
            check(bad == FAILING[part] and failed == len(bad), f"cycle {seq} ({part}): stored failing landmarks {bad}")
            alignment, simulation = json.loads(alignment or "null"), json.loads(simulation or "null")
            if judge_seats and check(alignment and simulation and alignment.get("measured"),
                                     f"cycle {seq}: no measured seat"):
                mm, deg = seat_error(alignment, simulation["seat"])
                seat_errors.append((mm, deg))
                check(part != "nominal" or (mm <= seat_tolerance_mm and deg <= args.seat_tolerance_deg),
                      f"cycle {seq}: the nominal part's seat measured {mm * 1000:.2f} µm and {deg:.4f}° "
                      "off the true one")
            if not corrected_views:
                continue
            if not check(alignment and simulation and alignment.get("pose_correction", {}).get("applied"),
                         f"cycle {seq}: no seat-corrected poses in the record"):
                continue
            for k, (view, after, before) in enumerate(true_sight_errors(station, alignment, simulation)):
                check(view["view"] == k and (k >= 2 or not view["corrected"]),
                      f"cycle {seq}: view {k} of the first two corrected")
                if k < 2:
                    continue
                check(after <= before + 0.01, f"cycle {seq}: view {k} corrected from {before:.4f}° to {after:.4f}° off")
                if view["limited"]:
                    continue
                after_all.append(after)
                before_all.append(before)
                check(part != "nominal" or after < 0.05,
                      f"cycle {seq}: view {k} sees the nominal part {after:.4f}° off the planned direction")
        db.close()
        if judge_seats and check(seat_errors, "no measured seats to judge"):
            print(f"measured seats against the true ones, worst {max(e[0] for e in seat_errors) * 1000:.2f} µm "
                  f"and {max(e[1] for e in seat_errors):.4f}° (every part, defective ones included)", flush=True)
        if corrected_views and check(after_all, "no corrected views to judge"):
            mean_after, mean_before = sum(after_all) / len(after_all), sum(before_all) / len(before_all)
            print(f"true direction of sight off the plan, {len(after_all)} corrected views: mean {mean_after:.4f}° "
                  f"(max {max(after_all):.4f}°), from the planned poses it would have been {mean_before:.4f}°",
                  flush=True)
            check(mean_after < 0.1 * mean_before,
                  f"corrected views {mean_after:.4f}° off on average, {mean_before:.4f}° without the correction")
    finally:
        stop_line(line, line_out)

    if failures:
        print(f"{len(failures)} checks failed; work folder {workdir}", file=sys.stderr)
        return 1
    print(f"simulated line: {len(plan)} cycles, every verdict, register block and stored record right")
    subprocess.run(["rm", "-rf", str(workdir)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
