#!/usr/bin/python3
"""`hullgauge export` in its three formats (docs/export.md) on a result store.

The store is written here with the python sqlite3 module in the daemon's
layout of docs/daemon.md ("Results", schema version 3): two part programs,
production cycles that pass and fail, a master and a study cycle, an aborted
cycle without landmarks, a cycle of the simulated line and a maintenance-
triggered one; landmarks with a sub-voxel deviation, on the bracket middle
only, with asymmetric limits, and not observable; serials with a comma, a
quote, a line break and a character outside ASCII.

`hullgauge export` then writes AQDEF, CSV and JSON, and each file is read
back here by a reader of its own, not the writer's code:
- the DFQ file by a parser written from the Q-DAS ASCII transfer format's
  field definitions (K-field lines `Kxxxx/i value`, CR LF, ISO 8859-1;
  K0001 opens a value of characteristic i, the K00xx fields after it belong
  to it): one characteristic per landmark (its id as K2001: the store's
  landmarks keep their zones), landmark a holding values of both methods;
  every stored measurement must be there, in the characteristic of its
  landmark with its tolerance zone as K2110/K2111, its value, its method in
  K0009, K0002 0 (129 for an excluded cycle), the cycle's start as K0004
  (UTC), its serial as K0014, K0015 0 or 10 (master and study cycles); a
  landmark without a value only as a placeholder (K0002 255); with
  --include-simulated the simulated cycle's values count (K0002 0) and say so;
- the CSV file by Python's csv module (RFC 4180): one row per landmark
  measurement, a serial with comma, quote and line break read back whole;
- the JSON file by json: the stored rows, oldest first.
The selection options (--program, --serial, --verdict, --purpose, --since,
--until: the HMI's download filters) and the refusals (a bad --format,
--since, --verdict, --program or --serial, no store: exit 2 naming it, the
--out file not created) are checked on the same store.
"""
import argparse
import csv
import datetime
import io
import json
import re
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print(f"FAILED: {message}", file=sys.stderr, flush=True)
    return condition


# The columns of docs/daemon.md ("Results"), schema version 3.
SCHEMA = """
CREATE TABLE inspections (
    id INTEGER PRIMARY KEY AUTOINCREMENT, started_utc TEXT NOT NULL, started_unix_ms INTEGER NOT NULL,
    trigger_seq INTEGER NOT NULL, manual INTEGER NOT NULL, serial TEXT NOT NULL, program INTEGER NOT NULL,
    part TEXT NOT NULL, verdict TEXT NOT NULL, fault_code INTEGER NOT NULL, cycle_ms INTEGER NOT NULL,
    landmarks_failed INTEGER NOT NULL, landmarks_total INTEGER NOT NULL, landmarks_json TEXT NOT NULL,
    timing_json TEXT NOT NULL, images_dir TEXT NOT NULL DEFAULT '', alignment_json TEXT NOT NULL DEFAULT 'null',
    simulation_json TEXT NOT NULL DEFAULT 'null', purpose TEXT NOT NULL DEFAULT 'production');
PRAGMA user_version=3;
"""

T0_MS = 1_780_000_000_000  # 2026-05-28T20:26:40Z


def landmark(lid, status, error, tolerance, deviation=None, limits=None, uncertainty=None, decision=None):
    entry = {"id": lid, "status": status, "error_min_mm": max(0.0, error - 0.0625),
             "error_max_mm": error + 0.0625, "error_mm": error, "tolerance_mm": tolerance}
    if deviation is not None:
        entry["deviation_mm"] = deviation
        entry["uncertainty_mm"] = uncertainty if uncertainty is not None else 0.004
        entry["decision"] = decision or "conforms"
    if limits is not None:
        entry["limits_mm"] = limits
    return entry


def bracket_landmarks(a_dev, b_err, c_status="ok"):
    """Program 7: a with a deviation (±0.1), b on the bracket only with limits [-0.05, 0.15], c."""
    return [landmark("a", "ok", 0.0625, 0.1, deviation=a_dev),
            landmark("b", "ok", b_err, 0.1, limits=[-0.05, 0.15]),
            landmark("c", c_status, 0.0, 0.2, deviation=None if c_status != "ok" else 0.001)]


def cycles():
    """(minutes after T0, serial, program, part, verdict, purpose, manual, simulation, landmarks)."""
    return [
        (0, "SN-1", 7, "bracket-42", "pass", "production", 0, None, bracket_landmarks(0.0123, 0.0625)),
        (1, 'SN,"2"\nb', 7, "bracket-42", "fail", "production", 0, None,
         bracket_landmarks(0.1504, 0.1875, c_status="not_observable")),
        (2, "MASTER-1", 7, "bracket-42", "pass", "master", 0, None, bracket_landmarks(-0.002, 0.0625)),
        (3, "STUDY-1", 7, "bracket-42", "pass", "study", 0, None, bracket_landmarks(0.004, 0.0625)),
        (4, "SN-5", 7, "bracket-42", "aborted", "production", 0, None, []),
        (5, "SIM-6", 7, "bracket-42", "pass", "production", 0, {"part": "nominal", "seat": None},
         bracket_landmarks(0.0007, 0.0625)),
        (6, "SN-7", 7, "bracket-42", "pass", "production", 1, None, bracket_landmarks(-0.0111, 0.0625)),
        # Landmark a on the bracket only here: one characteristic holds both methods' values.
        (7, "Prüf-8", 7, "bracket-42", "pass", "production", 0, None, bracket_landmarks(None, 0.0625)),
        (8, "CAP-1", 9, "cap", "pass", "production", 0, None,
         [landmark("rim", "ok", 0.0625, 0.3, deviation=0.05), landmark("lip", "not_found", 0.0, 0.3)]),
        (9, "CAP-2", 9, "cap", "error", "production", 0, None, [landmark("rim", "ok", 0.0625, 0.3, deviation=-0.04)]),
    ]


def make_store(path):
    db = sqlite3.connect(path)
    db.executescript(SCHEMA)
    for minutes, serial, program, part, verdict, purpose, manual, simulation, landmarks in cycles():
        ms = T0_MS + minutes * 60_000
        utc = datetime.datetime.fromtimestamp(ms / 1000, datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.000Z")
        failed = sum(1 for l in landmarks if l["status"] != "ok")
        db.execute("INSERT INTO inspections (started_utc, started_unix_ms, trigger_seq, manual, serial, program, part,"
                   " verdict, fault_code, cycle_ms, landmarks_failed, landmarks_total, landmarks_json, timing_json,"
                   " simulation_json, purpose) VALUES (?, ?, ?, ?, ?, ?, ?, ?, 0, 900, ?, ?, ?, '{}', ?, ?)",
                   (utc, ms, minutes + 1, manual, serial, program, part, verdict, failed, len(landmarks),
                    json.dumps(landmarks), json.dumps(simulation), purpose))
    db.commit()
    db.close()


def stored_rows(path):
    """The rows as this test reads them from the SQLite file itself, oldest first."""
    db = sqlite3.connect(path)
    rows = []
    for (rid, ms, manual, serial, program, part, verdict, landmarks, simulation, purpose) in db.execute(
            "SELECT id, started_unix_ms, manual, serial, program, part, verdict, landmarks_json, simulation_json,"
            " purpose FROM inspections ORDER BY id"):
        rows.append({"id": rid, "ms": ms, "manual": bool(manual), "serial": serial, "program": program,
                     "part": part, "verdict": verdict, "landmarks": json.loads(landmarks),
                     "simulation": json.loads(simulation), "purpose": purpose})
    db.close()
    return rows


def excluded(row, include_simulated=False):
    """docs/export.md: aborted and error verdicts, master and study cycles, simulated (unless included),
    maintenance-triggered."""
    return (row["verdict"] not in ("pass", "fail") or row["purpose"] != "production"
            or (row["simulation"] is not None and not include_simulated) or row["manual"])


def zone(entry):
    if entry.get("limits_mm") is not None:
        return tuple(entry["limits_mm"])
    return (-entry["tolerance_mm"], entry["tolerance_mm"])


def value(entry):
    """(value, source) per docs/export.md, or None for a landmark without one."""
    if entry["status"] in ("not_found", "not_observable", "not_inspected"):
        return None
    if isinstance(entry.get("deviation_mm"), (int, float)):
        return entry["deviation_mm"], "deviation_mm"
    return entry["error_mm"], "error_mm"


def latin1_text(text, limit):
    """K-field text as the transfer format carries it: 8-bit, no control characters, the field's length."""
    out = "".join(" " if ord(c) < 0x20 or 0x7F <= ord(c) < 0xA0 else (c if ord(c) <= 0xFF else "?") for c in text)
    return out[:limit]


# ------------------------------------------------------------------ an independent DFQ reader

K_LINE = re.compile(r"^K(\d{4})(?:/(\d+))? (.*)$")


def parse_dfq(raw):
    """Parts, characteristics and values of a DFQ file in the K-field form.

    Returns (k0100, parts): parts is a list of {"fields": {key: text}, "chars": [char]}, each char
    {"index": i, "fields": {key: text}, "values": [{key: text}]}.
    """
    check(raw.endswith(b"\r\n"), "the DFQ file does not end with CR LF")
    text = raw.decode("iso-8859-1")
    lines = text.split("\r\n")[:-1]
    check(all("\n" not in l and "\r" not in l for l in lines), "a DFQ line holds a bare CR or LF")
    k0100 = None
    parts, chars = [], {}
    for number, line in enumerate(lines, 1):
        m = K_LINE.match(line)
        if not check(m is not None, f"DFQ line {number} is no K-field line: {line!r}"):
            continue
        key, index, val = "K" + m.group(1), m.group(2), m.group(3)
        if key == "K0100":
            k0100 = int(val)
            continue
        check(index is not None, f"DFQ line {number}: {key} without an index")
        i = int(index)
        level = key[1]
        if level == "1":  # part fields: /i is the part
            while len(parts) < i:
                parts.append({"fields": {}, "chars": []})
            parts[i - 1]["fields"][key] = val
        elif level == "2":  # characteristic fields: belong to the part named last
            if i not in chars:
                chars[i] = {"index": i, "fields": {}, "values": []}
                parts[-1]["chars"].append(chars[i])
            chars[i]["fields"][key] = val
        elif level == "0":  # value fields: K0001 opens a value of characteristic i
            if not check(i in chars, f"DFQ line {number}: a value of undefined characteristic {i}"):
                continue
            if key == "K0001":
                chars[i]["values"].append({})
            elif not check(chars[i]["values"], f"DFQ line {number}: {key} before any K0001/{i}"):
                continue
            check(key not in chars[i]["values"][-1], f"DFQ line {number}: {key}/{i} twice in one value")
            chars[i]["values"][-1][key] = val
    check(k0100 == len(chars), f"K0100 {k0100} but {len(chars)} characteristics defined")
    return k0100, parts


def check_dfq(raw, rows, include_simulated=False):
    _, parts = parse_dfq(raw)
    programs = []
    for r in rows:
        if r["program"] not in programs:
            programs.append(r["program"])
    check([p["fields"].get("K1001") for p in parts] == [str(p) for p in programs],
          f"parts {[p['fields'].get('K1001') for p in parts]}, programs {programs}")
    measured = 0
    for part in parts:
        program = int(part["fields"]["K1001"])
        mine = [r for r in rows if r["program"] == program]
        check(part["fields"].get("K1002") == mine[0]["part"], f"program {program}: K1002 {part['fields'].get('K1002')}")
        for c in part["chars"]:
            f = c["fields"]
            check(f.get("K2142") == "mm" and f.get("K2101") == "0",
                  f"characteristic {c['index']}: unit {f.get('K2142')}, nominal {f.get('K2101')}")
            check(len(c["values"]) == len(mine),
                  f"characteristic {f.get('K2001')}: {len(c['values'])} values for {len(mine)} cycles")
        # One characteristic per landmark: the store's landmarks keep their zones, whatever the method.
        ids = list(dict.fromkeys(e["id"] for r in mine for e in r["landmarks"]))
        check([c["fields"].get("K2001") for c in part["chars"]] == ids,
              f"program {program}: characteristics {[c['fields'].get('K2001') for c in part['chars']]}, landmarks {ids}")
        for n, row in enumerate(mine):
            for entry in row["landmarks"]:
                measured += check_measurement(part, n, row, entry, include_simulated)
        if program == 7:
            a_methods = {m for c in part["chars"] if c["fields"].get("K2001") == "a" for v in c["values"]
                         for m in ("deviation_mm", "error_mm") if f"method {m} " in v.get("K0009", "")}
            check(a_methods == {"deviation_mm", "error_mm"}, f"landmark a's one characteristic holds {a_methods}")
    written = sum(1 for p in parts for c in p["chars"] for v in c["values"] if v.get("K0002") != "255")
    check(written == measured, f"{written} values in the DFQ file, {measured} measurements stored")
    return measured


def check_measurement(part, n, row, entry, include_simulated):
    """The n-th value of the characteristics of `entry`'s landmark: the measurement once, else placeholders."""
    lid = entry["id"]
    mine = [c for c in part["chars"] if c["fields"]["K2001"] == lid or c["fields"]["K2001"].startswith(lid + "~")]
    name = f"result {row['id']} landmark {lid}"
    if not check(mine, f"{name}: no characteristic"):
        return 0
    found = [c for c in mine if c["values"][n].get("K0002") != "255"]
    expected = value(entry)
    if expected is None:
        check(not found, f"{name}: a value for a landmark {entry['status']}")
        return 0
    if not check(len(found) == 1, f"{name}: {len(found)} values"):
        return 0
    c = found[0]
    v = c["values"][n]
    lo, hi = zone(entry)
    check(abs(float(c["fields"]["K2110"]) - lo) < 1e-9 and abs(float(c["fields"]["K2111"]) - hi) < 1e-9,
          f"{name}: limits {c['fields']['K2110']} {c['fields']['K2111']}, stored {lo} {hi}")
    check(f"method {expected[1]} " in v.get("K0009", ""), f"{name}: K0009 {v.get('K0009')!r} for {expected[1]}")
    check(abs(float(v["K0001"]) - expected[0]) <= 5e-7, f"{name}: K0001 {v['K0001']}, stored {expected[0]}")
    check(v["K0002"] == ("129" if excluded(row, include_simulated) else "0"), f"{name}: K0002 {v['K0002']}")
    when = datetime.datetime.fromtimestamp(row["ms"] / 1000, datetime.timezone.utc).strftime("%d.%m.%Y/%H:%M:%S")
    check(v.get("K0004") == when, f"{name}: K0004 {v.get('K0004')}, started {when} UTC")
    check(v.get("K0014") == latin1_text(row["serial"], 40), f"{name}: K0014 {v.get('K0014')!r}")
    check(v.get("K0015") == ("0" if row["purpose"] == "production" else "10"), f"{name}: K0015 {v.get('K0015')}")
    check(("excluded: " in v["K0009"]) == excluded(row, include_simulated), f"{name}: K0009 {v['K0009']!r}")
    sim_included = row["simulation"] is not None and include_simulated
    check(("simulated, included" in v["K0009"]) == sim_included, f"{name}: K0009 {v['K0009']!r}")
    return 1


# ------------------------------------------------------------------ CSV and JSON

COLUMNS = ["result_id", "time", "serial", "program", "part", "purpose", "verdict", "landmark", "status", "value_mm",
           "value_source", "deviation_mm", "uncertainty_mm", "error_mm", "lower_mm", "upper_mm", "decision",
           "excluded", "exclusion_reason", "program_version", "program_sha256", "simulated"]


def check_csv(raw, rows):
    table = list(csv.reader(io.StringIO(raw.decode("utf-8"), newline="")))
    # Every record ends with CR LF (RFC 4180, 2.1); a bare LF only inside a quoted serial (2.6).
    bare = raw.count(b"\n") - raw.count(b"\r\n")
    check(raw.endswith(b"\r\n") and bare == sum(cells[2].count("\n") for cells in table[1:]),
          f"CSV records not ended by CR LF ({bare} bare line feeds)")
    check(table[0] == COLUMNS, f"CSV header {table[0]}")
    expected = [(r, e) for r in rows for e in (r["landmarks"] or [None])]
    check(len(table) - 1 == len(expected), f"{len(table) - 1} CSV rows for {len(expected)} landmark measurements")
    for cells, (r, e) in zip(table[1:], expected):
        got = dict(zip(COLUMNS, cells))
        name = f"CSV result {r['id']} landmark {e and e['id']}"
        check(len(cells) == len(COLUMNS), f"{name}: {len(cells)} cells")
        check(got["result_id"] == str(r["id"]) and got["serial"] == r["serial"] and got["program"] == str(r["program"]),
              f"{name}: {got['result_id']} {got['serial']!r} {got['program']}")
        iso = datetime.datetime.fromtimestamp(r["ms"] / 1000, datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.000Z")
        check(got["time"] == iso, f"{name}: time {got['time']}, started {iso}")
        check(got["excluded"] == ("true" if excluded(r) else "false") and bool(got["exclusion_reason"]) == excluded(r),
              f"{name}: excluded {got['excluded']} ({got['exclusion_reason']})")
        # A store of schema version 3 recorded no program release: the last two cells are empty.
        check(got["program_version"] == "" and got["program_sha256"] == "",
              f"{name}: release {got['program_version']!r} {got['program_sha256']!r}")
        check(got["simulated"] == ("true" if r["simulation"] is not None else "false"),
              f"{name}: simulated {got['simulated']!r}, stored simulation {r['simulation']!r}")
        if e is None:
            check(all(got[k] == "" for k in COLUMNS[7:17]), f"{name}: landmark cells of a cycle without landmarks")
            continue
        check(got["landmark"] == e["id"] and got["status"] == e["status"], f"{name}: {got['landmark']} {got['status']}")
        v = value(e)
        if v is None:
            check(got["value_mm"] == "" and got["value_source"] == "", f"{name}: a value {got['value_mm']}")
        else:
            check(float(got["value_mm"]) == v[0] and got["value_source"] == v[1],
                  f"{name}: value {got['value_mm']} {got['value_source']}, stored {v}")
        lo, hi = zone(e)
        check(float(got["lower_mm"]) == lo and float(got["upper_mm"]) == hi, f"{name}: zone {got['lower_mm']}..")
        check(float(got["error_mm"]) == e["error_mm"], f"{name}: error_mm {got['error_mm']}")


def check_json(raw, rows):
    doc = json.loads(raw.decode("utf-8"))
    check(doc.get("format") == "hullgauge-results" and doc.get("version") == 1, f"JSON header {doc.get('format')}")
    check(re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", doc.get("exported", "")) is not None,
          f"JSON exported {doc.get('exported')}")
    results = doc.get("results", [])
    check([r["id"] for r in results] == [r["id"] for r in rows], f"JSON ids {[r['id'] for r in results]}")
    for got, r in zip(results, rows):
        check(got["serial"] == r["serial"] and got["landmarks"] == r["landmarks"] and got["purpose"] == r["purpose"],
              f"JSON result {r['id']} differs from the stored row")


# ------------------------------------------------------------------ the command

def export(hullgauge, store, fmt, out, *options):
    return subprocess.run([hullgauge, "export", "--store", str(store), "--format", fmt, "--out", str(out), *options],
                          capture_output=True, timeout=60)


def check_selection(hullgauge, store, rows, work):
    out = work / "sel.json"
    for options, keep in [(["--program", "9"], lambda r: r["program"] == 9),
                          (["--verdict", "fail"], lambda r: r["verdict"] == "fail"),
                          (["--serial", "SN-"], lambda r: "SN-" in r["serial"]),
                          (["--verdict", "pass", "--program", "7", "--purpose", "production"],
                           lambda r: r["verdict"] == "pass" and r["program"] == 7 and r["purpose"] == "production"),
                          (["--purpose", "master"], lambda r: r["purpose"] == "master"),
                          (["--since", "2026-05-28T20:29:40", "--until", "2026-05-28T20:31"],
                           lambda r: T0_MS + 3 * 60_000 <= r["ms"] < T0_MS + 4 * 60_000 + 20_000)]:
        run = export(hullgauge, store, "json", out, *options)
        if check(run.returncode == 0, f"export {options}: exit {run.returncode} {run.stderr!r}"):
            ids = [r["id"] for r in json.loads(out.read_text())["results"]]
            check(ids == [r["id"] for r in rows if keep(r)], f"export {options}: ids {ids}")


def check_refusals(hullgauge, store, work):
    out = work / "refused.dfq"
    for fmt, options, store_file, named in [("xml", [], store, ["--format", "'xml'"]),
                                            ("aqdef", ["--since", "2026-02-30"], store, ["--since", "2026-02-30"]),
                                            ("csv", ["--verdict", "good"], store,
                                             ["--verdict: 'good' is not one of any, pass, fail, aborted, error"]),
                                            ("csv", ["--program", "0"], store,
                                             ["--program: '0' is not a whole number in 1..65535"]),
                                            ("csv", ["--serial", "x" * 65], store,
                                             ["--serial: longer than 64 characters"]),
                                            ("aqdef", [], work / "none.db", ["no database at", "none.db"])]:
        run = export(hullgauge, store_file, fmt, out, *options)
        err = run.stderr.decode("utf-8", "replace")
        check(run.returncode == 2, f"export --format {fmt} {options}: exit {run.returncode}, not 2")
        for n in named:
            check(n in err, f"export --format {fmt} {options}: the message does not name {n!r}: {err!r}")
        check(not out.exists(), f"export --format {fmt} {options}: {out} was created")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hullgauge", required=True, help="the hullgauge program")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="hg-export-") as tmp:
        work = Path(tmp)
        store = work / "results.db"
        make_store(store)
        rows = stored_rows(store)
        files = {}
        for fmt in ("aqdef", "csv", "json"):
            out = work / f"all.{fmt}"
            run = export(args.hullgauge, store, fmt, out)
            if check(run.returncode == 0, f"export --format {fmt}: exit {run.returncode} {run.stderr!r}"):
                files[fmt] = out.read_bytes()
        measured = check_dfq(files["aqdef"], rows) if "aqdef" in files else 0
        # The demo's data tried in a statistics program: the simulated cycle counts, and says so.
        run = export(args.hullgauge, store, "aqdef", work / "sim.dfq", "--include-simulated")
        if check(run.returncode == 0, f"export --include-simulated: exit {run.returncode} {run.stderr!r}"):
            check_dfq((work / "sim.dfq").read_bytes(), rows, include_simulated=True)
        if "csv" in files:
            check_csv(files["csv"], rows)
        if "json" in files:
            check_json(files["json"], rows)
        check_selection(args.hullgauge, store, rows, work)
        check_refusals(args.hullgauge, store, work)
        check(sorted(p.name for p in work.iterdir()) == ["all.aqdef", "all.csv", "all.json", "results.db", "sel.json",
                                                            "sim.dfq"],
              f"files left in the folder: {sorted(p.name for p in work.iterdir())}")
    if failures:
        print(f"{len(failures)} checks failed", file=sys.stderr)
        return 1
    print(f"export: {len(rows)} cycles, {measured} measurements in AQDEF as stored; CSV and JSON read back")
    return 0


if __name__ == "__main__":
    sys.exit(main())
