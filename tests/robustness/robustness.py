#!/usr/bin/python3
"""The robustness suite: faults and hostile clients against the real daemon on
the simulated line (docs/fault-matrix.md).

  robustness.py --source S --bin B [--out FILE] [--only NAME ...]

Each scenario starts from a running line (tools/simline with config/sim-fast),
does one kind of harm, and checks what the PLC and the operator see, that the
daemon keeps serving, how long recovery takes and that nothing recorded is
lost. Every wait is bounded. The rows of the fault matrix (fault, what the PLC
sees, recovery, anything lost) go to --out as Markdown; docs/fault-matrix.md
holds one run of it. Exit status 0 when every check held, 1 otherwise.
"""
import argparse
import ctypes
import json
import os
import signal
import socket
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from pymodbus.client import ModbusTcpClient
from pymodbus.diag_message import ReturnQueryDataRequest
from pymodbus.exceptions import ModbusException
from pymodbus.file_message import ReadFifoQueueRequest, ReadFileRecordRequest, FileRecord
from pymodbus.mei_message import ReadDeviceInformationRequest
from pymodbus.pdu import ExceptionResponse

TRIGGER_SEQ, ACK_SEQ, DONE_SEQ, STATUS, RESULT, FAULT_CODE = 0, 100, 101, 102, 103, 104

failures = []
matrix = []  # rows: fault, PLC sees, recovery, lost


def check(condition, message):
    if not condition:
        failures.append(message)
        print(f"FAILED: {message}", file=sys.stderr, flush=True)
    return condition


def row(fault, plc_sees, recovery, lost):
    matrix.append((fault, plc_sees, recovery, lost))
    print(f"| {fault} | {plc_sees} | {recovery} | {lost} |", flush=True)


def die_with_parent():
    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def encode_serial(text):
    raw = text.encode("ascii")[:16].ljust(16, b"\0")
    return [(raw[i] << 8) | raw[i + 1] for i in range(0, 16, 2)]


class Line:
    """tools/simline in a work folder of its own, stopped (and killed if need be) at the end."""

    def __init__(self, args, extra_config=(), results_dir=None, extra_args=(), env=None):
        self.args = args
        self.workdir = Path(tempfile.mkdtemp(prefix="hg-robust-"))
        self.results = Path(results_dir) if results_dir else self.workdir
        self.plc_port = free_port()
        self.out = open(self.workdir / "simline.out", "w")
        configs = []
        for c in [args.source / "config" / "sim-fast", *extra_config]:
            configs += ["--config", str(c)]
        self.proc = subprocess.Popen(
            [str(args.source / "tools" / "simline"), "--bin", str(args.bin), "--workdir", str(self.workdir),
             "--plc-port", str(self.plc_port), "--fixture-port", "0", "--results", str(self.results), *configs,
             *extra_args],
            stdout=self.out, stderr=subprocess.STDOUT, start_new_session=True, preexec_fn=die_with_parent,
            env={**os.environ, **(env or {})})
        deadline = time.monotonic() + 90
        while not (self.workdir / "simline.ready").exists():
            if self.proc.poll() is not None:
                raise SystemExit(f"tools/simline exited ({self.proc.returncode}):\n" +
                                 (self.workdir / "simline.out").read_text())
            if time.monotonic() > deadline:
                raise SystemExit("the simulated line was not ready within 90 s")
            time.sleep(0.1)
        ready = dict(l.split("=", 1) for l in (self.workdir / "simline.ready").read_text().split())
        self.daemon_pid = int(ready["daemon_pid"])
        self.socket = str(self.workdir / "hullgauged.sock")

    def alive(self):
        try:
            os.kill(self.daemon_pid, 0)
            return True
        except ProcessLookupError:
            return False

    def rss_kib(self):
        for line in Path(f"/proc/{self.daemon_pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
        return 0

    def stored_rows(self):
        db = sqlite3.connect(f"file:{self.results / 'results.db'}?mode=ro", uri=True)
        try:
            return db.execute("SELECT trigger_seq, verdict FROM inspections WHERE manual = 0 ORDER BY id").fetchall()
        finally:
            db.close()

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=40)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.out.close()
        if not failures:
            subprocess.run(["rm", "-rf", str(self.workdir)])


class Plc:
    """A PLC over pymodbus that times every request it makes."""

    def __init__(self, port, connect_deadline_s=30):
        self.latencies = []
        deadline = time.monotonic() + connect_deadline_s
        while True:
            self.client = ModbusTcpClient("127.0.0.1", port=port, timeout=3)
            try:
                if self.client.connect() and not self.client.read_holding_registers(STATUS, 1, slave=1).isError():
                    break
            except ModbusException:
                pass  # refused: every slot taken

            self.client.close()
            if time.monotonic() > deadline:
                raise RuntimeError(f"the PLC was not served within {connect_deadline_s} s")
            time.sleep(0.2)
        self.connected_at = time.monotonic()

    def read(self, address, count):
        t0 = time.monotonic()
        r = self.client.read_holding_registers(address, count, slave=1)
        self.latencies.append(time.monotonic() - t0)
        if r.isError():
            raise RuntimeError(f"read {address}+{count}: {r}")
        return r.registers

    def cycle(self, serial, timeout_s=30, program=1):
        """One inspection the way a PLC runs it; (seq, result, fault code, cycle s as the PLC saw it)."""
        seq = (self.read(TRIGGER_SEQ, 1)[0] + 1) % 65536 or 1
        t0 = time.monotonic()
        w = self.client.write_registers(TRIGGER_SEQ, [seq, program] + encode_serial(serial), slave=1)
        if w.isError():
            raise RuntimeError(f"trigger write: {w}")
        deadline = t0 + timeout_s
        while True:
            r = self.read(ACK_SEQ, 5)
            if r[1] == seq:
                return seq, r[3], r[4], time.monotonic() - t0
            if time.monotonic() > deadline:
                raise RuntimeError(f"no result for trigger {seq} within {timeout_s} s (status {r[2]})")
            time.sleep(0.005)

    def close(self):
        self.client.close()


def percentile(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(round(p / 100 * (len(values) - 1))))] if values else 0.0


def scenario_slow_clients(args):
    """8 idle connections and a client trickling a byte every 0.3 s while the PLC runs 20 cycles."""
    line = Line(args)
    try:
        plc = Plc(line.plc_port)
        baseline = [plc.cycle(f"BASE{i:04d}")[3] for i in range(args.cycles)]
        plc.close()
        idle = []
        for _ in range(8):  # plc.max_clients of config/sim
            s = socket.create_connection(("127.0.0.1", line.plc_port), timeout=5)
            idle.append(s)
        t_full = time.monotonic()
        plc = Plc(line.plc_port, connect_deadline_s=30)
        waited = plc.connected_at - t_full
        stop = threading.Event()
        trickled = {"bytes": 0, "reconnects": 0}

        def trickle():
            frame = bytes([0, 1, 0, 0, 0, 6, 1, 3, 0, 102, 0, 1])
            s = None
            while not stop.is_set():
                try:
                    if s is None:
                        s = socket.create_connection(("127.0.0.1", line.plc_port), timeout=2)
                        trickled["reconnects"] += 1
                    s.sendall(frame[trickled["bytes"] % len(frame):][:1])
                    trickled["bytes"] += 1
                except OSError:
                    s = None
                stop.wait(0.3)
            if s:
                s.close()

        t = threading.Thread(target=trickle, daemon=True)
        t.start()
        plc.latencies.clear()
        loaded = []
        for i in range(args.cycles):
            seq, result, fault, seconds = plc.cycle(f"SLOW{i:04d}")
            check(result == 1 and fault == 0, f"slow clients: cycle {seq} result {result} fault {fault}")
            loaded.append(seconds)
        stop.set()
        t.join(timeout=5)
        for s in idle:
            s.close()
        worst = max(plc.latencies)
        ratio = statistics.median(loaded) / statistics.median(baseline)
        # A served loop answers in milliseconds; a loop waiting on a trickled frame in seconds.
        check(worst < 1.0, f"slow clients: a PLC read took {worst * 1000:.0f} ms")
        check(ratio < 1.5, f"slow clients: cycles took {ratio:.2f} times as long")
        check(waited < 20, f"slow clients: the PLC waited {waited:.1f} s for a slot")
        check(line.alive(), "slow clients: the daemon died")
        row("8 idle connections fill `plc.max_clients`",
            f"its connect served once the oldest idle one yields (`plc.yield_after_s` 5 s): after {waited:.1f} s",
            "—", "nothing")
        row("a client trickles a request a byte every 0.3 s, 8 idle clients connected",
            f"{len(plc.latencies)} reads: median {statistics.median(plc.latencies) * 1000:.1f} ms, "
            f"p99 {percentile(plc.latencies, 99) * 1000:.1f} ms, max {worst * 1000:.1f} ms; "
            f"cycle median {statistics.median(loaded):.2f} s vs {statistics.median(baseline):.2f} s alone "
            f"({(ratio - 1) * 100:+.1f} %)",
            f"trickler dropped after `plc.frame_timeout_s` ({trickled['reconnects']} connections)", "nothing")
        plc.close()
        check(len(line.stored_rows()) == 2 * args.cycles, "slow clients: not every cycle was stored")
    finally:
        line.stop()


def exception_code(response):
    return response.exception_code if isinstance(response, ExceptionResponse) else None


def scenario_modbus_conformance(args):
    """Function codes HMIs and scanners probe: 08, 20, 24 answer exception 01; 43/14 names the device."""
    line = Line(args)
    try:
        plc = Plc(line.plc_port)
        c = plc.client
        answers = {
            "08 diagnostics": exception_code(c.execute(ReturnQueryDataRequest(0x1234, unit=1))),
            "20 read file record": exception_code(c.execute(ReadFileRecordRequest(
                [FileRecord(reference_type=6, file_number=1, record_number=0, record_length=2)], unit=1))),
            "24 read FIFO queue": exception_code(c.execute(ReadFifoQueueRequest(100, unit=1))),
            "01 read coils": exception_code(c.read_coils(0, 1, slave=1)),
            "04 read input registers": exception_code(c.read_input_registers(0, 1, slave=1)),
        }
        for name, code in answers.items():
            check(code == 1, f"conformance: FC {name} answered {code}, expected exception 01")
        info = c.execute(ReadDeviceInformationRequest(read_code=1, object_id=0, unit=1))
        objects = getattr(info, "information", {}) or {}
        check(objects.get(0) == b"hullgauge" and objects.get(1) == b"hullgauged" and objects.get(2),
              f"conformance: device identification {objects}")
        check(plc.read(STATUS, 1)[0] in (0, 2), "conformance: the connection did not survive the probes")
        row("function codes 01, 04, 08, 20, 24 from a scanner",
            "exception 01 each, the connection stays", "—", "nothing")
        row("FC 43/14 read device identification",
            f"vendor {objects.get(0, b'?').decode()}, product {objects.get(1, b'?').decode()}, "
            f"revision {objects.get(2, b'?').decode()}", "—", "nothing")
        plc.close()
    finally:
        line.stop()


def scenario_duplicate_keys(args):
    """A configuration that names a key twice is refused naming the key and its line."""
    work = Path(tempfile.mkdtemp(prefix="hg-robust-keys-"))
    try:
        src = (args.source / "config" / "sim" / "stepped-block.yaml").read_text()
        (work / "stepped-block.stl").symlink_to(args.source / "config" / "sim" / "stepped-block.stl")
        doubled = src.replace("octree:\n", "octree:\n  depth: 3\n", 1)
        check(doubled != src, "duplicate keys: the sample part program has no octree section")
        part = work / "stepped-block.yaml"
        part.write_text(doubled)
        r = subprocess.run([str(args.bin / "hullgauge"), "check-part", "--part", str(part)], capture_output=True,
                           text=True, timeout=60)
        line_no = doubled.splitlines().index("  depth: 3") + 1
        second = [i + 1 for i, l in enumerate(doubled.splitlines()) if l.strip().startswith("depth:")][-1]
        check(r.returncode == 2, f"duplicate keys: check-part exit {r.returncode}: {r.stderr}")
        check(f":{second}: octree.depth: duplicate key 'depth' (first given at line {line_no})" in r.stderr,
              f"duplicate keys: message {r.stderr.strip()!r}")
        row("a part program names `octree.depth` twice", "`check-part` exit 2: "
            f"`{r.stderr.strip().replace(str(work) + '/', '')}`", "—", "nothing (refused before use)")
    finally:
        subprocess.run(["rm", "-rf", str(work)])

COMMAND, LAST_REJECT_REASON = 10, 111


def ask(sock_path, request, timeout_s=5):
    """One maintenance request (a JSON line) and its answer, parsed; the raw line when it is not JSON."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(timeout_s)
        s.connect(sock_path)
        s.sendall((request if isinstance(request, str) else json.dumps(request)).encode() + b"\n")
        data = b""
        while not data.endswith(b"\n"):
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
    return json.loads(data)


def cube_ply(bad_index=None):
    """A closed 20 mm cube as ASCII PLY; `bad_index` replaces one face's vertex index."""
    v = [(x, y, z) for z in (0, 20) for y in (-10, 10) for x in (-10, 10)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    if bad_index is not None:
        tris[3] = (tris[3][0], bad_index, tris[3][2])
    head = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property float x", "property float y",
            "property float z", f"element face {len(tris)}", "property list uchar int vertex_indices", "end_header"]
    return "\n".join(head + [f"{x} {y} {z}" for x, y, z in v] + [f"3 {a} {b} {c}" for a, b, c in tris]) + "\n"


def cube_program(mesh, position="[0, 0, 20]"):
    return (f"part: cube\nmesh: {mesh}\noctree: {{depth: 5, adjacency_depth: 3}}\n"
            f"landmarks:\n  - {{id: top, position: {position}, tolerance_mm: 0.4}}\n")


def scenario_bad_program(args):
    """Part programs that crashed the daemon at trigger time: refused at --check and reload, FAULT 30 after."""
    line = Line(args)
    cfg = line.workdir / "config"
    daemon_yaml = cfg / "hullgauged.yaml"
    original = daemon_yaml.read_text()
    log = line.workdir / "hullgauged.log"
    try:
        (cfg / "cube.ply").write_text(cube_ply())
        (cfg / "cube-bad-face.ply").write_text(cube_ply(bad_index=1000000))
        (cfg / "cube-ok.yaml").write_text(cube_program("cube.ply"))
        bad = {"a PLY face index past the vertices (1000000 of 8)": (cube_program("cube-bad-face.ply"), "face 4"),
               "a landmark coordinate of 1e308": (cube_program("cube.ply", "[1e308, 0, 20]"), "position")}
        with_program_2 = original.replace(
            "programs:\n", "programs:\n  2: {part: cube-2.yaml, views: stepped-block-views.yaml}\n", 1)
        check(with_program_2 != original, "bad program: no programs section to extend")
        plc = Plc(line.plc_port)
        for what, (text, field) in bad.items():
            (cfg / "cube-2.yaml").write_text(text)
            daemon_yaml.write_text(with_program_2)
            t0 = time.monotonic()
            r = subprocess.run([str(args.bin / "hullgauged"), "--config", str(daemon_yaml), "--check"],
                               capture_output=True, text=True, timeout=60)
            check_s = time.monotonic() - t0
            check(r.returncode == 2 and field in r.stderr, f"bad program ({what}): --check {r.stderr.strip()!r}")
            refusals = log.read_text().count("reload refused")
            os.kill(line.daemon_pid, signal.SIGHUP)
            deadline = time.monotonic() + 30
            while log.read_text().count("reload refused") == refusals and time.monotonic() < deadline:
                time.sleep(0.05)
            refused = log.read_text().count("reload refused") > refusals
            check(refused, f"bad program ({what}): the reload was not refused")
            seq = (plc.read(TRIGGER_SEQ, 1)[0] + 1) % 65536 or 1
            plc.client.write_registers(TRIGGER_SEQ, [seq, 2] + encode_serial("BAD"), slave=1)
            reject = plc.read(LAST_REJECT_REASON, 1)[0]
            check(reject == 2, f"bad program ({what}): trigger of program 2 reject reason {reject}, expected 2")
            _, result, fault, _ = plc.cycle("AFTERBAD")
            check(result == 1 and fault == 0, f"bad program ({what}): program 1 result {result} fault {fault}")
            reason = r.stderr.strip().replace(str(cfg) + "/", "")
            row(f"a part program with {what}",
                f"`hullgauged --check` exit 2 in {check_s:.1f} s: `{reason}`; SIGHUP reload refused, program 2 "
                "unknown (LAST_REJECT_REASON 2), program 1 passes", "—", "nothing (the running configuration kept)")
        # A program valid at reload, broken on disk before its first trigger: FAULT 30 at the trigger.
        (cfg / "cube-2.yaml").write_text(cube_program("cube.ply"))
        daemon_yaml.write_text(with_program_2)
        reloads = log.read_text().count("configuration reloaded")
        os.kill(line.daemon_pid, signal.SIGHUP)
        deadline = time.monotonic() + 30
        while log.read_text().count("configuration reloaded") == reloads and time.monotonic() < deadline:
            time.sleep(0.05)
        check(log.read_text().count("configuration reloaded") > reloads, "bad program: the good reload was refused")
        for what, (text, _) in bad.items():
            (cfg / "cube-2.yaml").write_text(text)
            _, result, fault, seconds = plc.cycle("FAULT30", program=2)
            check(result == 3 and fault == 30, f"bad program at trigger ({what}): result {result} fault {fault}")
            check(line.alive(), f"bad program at trigger ({what}): the daemon died")
            t0 = time.monotonic()
            _, result, fault, _ = plc.cycle("AFTER30")
            check(result == 1 and fault == 0, f"bad program at trigger ({what}): next part {result}/{fault}")
            row(f"a part program broken on disk after the reload ({what}), then triggered",
                f"RESULT 3, FAULT 30 (program-load) after {seconds:.2f} s; the daemon serves on",
                f"the next part of program 1 passes ({time.monotonic() - t0:.2f} s)", "nothing")
            # The loader keeps nothing of a failed load: the next trigger loads again.
            (cfg / "cube-2.yaml").write_text(cube_program("cube.ply"))
        plc.close()
        check(line.alive(), "bad program: the daemon died")
    finally:
        line.stop()


def scenario_stale_abort(args):
    """COMMAND = 1 written while idle, then a trigger 0-100 ms later: the part runs."""
    line = Line(args)
    try:
        plc = Plc(line.plc_port)
        results = []
        for delay_ms in (0, 25, 50, 75, 100):
            w = plc.client.write_registers(COMMAND, [1], slave=1)
            check(not w.isError(), f"stale abort: COMMAND write {w}")
            time.sleep(delay_ms / 1000)  # the stimulus: the gap between the abort and the trigger
            _, result, fault, _ = plc.cycle(f"ABORT{delay_ms:03d}")
            results.append((delay_ms, result, fault))
            check(result == 1 and fault == 0, f"stale abort at {delay_ms} ms: result {result} fault {fault}")
        answer = ask(line.socket, {"command": "abort"})
        check(answer.get("ok") and answer.get("aborted") is False, f"stale abort: ctl abort while idle {answer}")
        _, result, fault, _ = plc.cycle("CTLABORT")
        check(result == 1 and fault == 0, f"stale abort after ctl abort: result {result} fault {fault}")
        passed = sum(1 for _, r, f in results if r == 1 and f == 0)
        row("COMMAND = 1 while idle, trigger 0/25/50/75/100 ms later; `ctl abort` while idle",
            f"{passed} of 5 parts run to RESULT 1; the idle abort is dropped (`ctl abort` answers `aborted: false`)",
            "—", "nothing")
        plc.close()
    finally:
        line.stop()


def scenario_maintenance_clients(args):
    """20 idle maintenance clients while `ctl status` answers; /dev/zero as a poses file."""
    line = Line(args)
    try:
        idle = []
        for _ in range(20):
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.connect(line.socket)
            idle.append(s)
        times = []
        for _ in range(5):
            t0 = time.monotonic()
            r = subprocess.run([str(args.bin / "hullgauge"), "ctl", "--socket", line.socket, "status"],
                               capture_output=True, text=True, timeout=30)
            times.append(time.monotonic() - t0)
            check(r.returncode == 0, f"maintenance: ctl status exit {r.returncode}: {r.stderr.strip()}")
        for s in idle:
            s.close()
        worst = max(times)
        check(worst < 2.0, f"maintenance: ctl status took {worst:.2f} s with 20 idle clients")
        row("20 idle clients on the maintenance socket",
            f"— (`ctl status` answers in {statistics.median(times) * 1000:.0f} ms median, "
            f"{worst * 1000:.0f} ms max of 5)", "idle clients closed after 1 s", "nothing")
        duplicate = ask(line.socket, '{"command": "status", "command": "abort"}')
        check(duplicate.get("ok") is False and "duplicate key 'command'" in duplicate.get("error", ""),
              f"maintenance: duplicate key answer {duplicate}")
        rss0 = line.rss_kib()
        t0 = time.monotonic()
        answer = ask(line.socket, {"command": "calibrate", "pattern": "chessboard:8x5:10", "poses": "/dev/zero"})
        took = time.monotonic() - t0
        rss1 = line.rss_kib()
        check(answer.get("ok") is False, f"maintenance: /dev/zero poses accepted {answer}")
        check(took < 5.0, f"maintenance: /dev/zero poses answered after {took:.2f} s")
        check(abs(rss1 - rss0) < 8 * 1024, f"maintenance: RSS {rss0} -> {rss1} KiB")
        serial = ask(line.socket, {"command": "trigger", "program": 1, "serial": "A\u001b[2J"})
        check(serial.get("ok") is False and "serial" in serial.get("error", ""), f"maintenance: ESC serial {serial}")
        row("`ctl calibrate --poses /dev/zero`",
            f"— (refused in {took * 1000:.0f} ms: `{answer.get('error')}`; RSS {rss0 / 1024:.0f} → "
            f"{rss1 / 1024:.0f} MiB)", "—", "nothing")
        row("a maintenance request naming `command` twice; a manual serial with ESC",
            f"— (`{duplicate.get('error')}`; `{serial.get('error')}`)", "—", "nothing")
        check(line.alive(), "maintenance: the daemon died")
    finally:
        line.stop()


SCENARIOS = {
    "slow_clients": scenario_slow_clients,
    "modbus_conformance": scenario_modbus_conformance,
    "duplicate_keys": scenario_duplicate_keys,
    "bad_program": scenario_bad_program,
    "stale_abort": scenario_stale_abort,
    "maintenance_clients": scenario_maintenance_clients,
}


class PlantBroker:
    """mosquitto on a free port of 127.0.0.1 and a subscriber (paho) to the station's topics."""

    def __init__(self, folder):
        import paho.mqtt.client as mqtt
        self.port = free_port()
        conf = folder / "mosquitto.conf"
        conf.write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n" +
                        ("user root\n" if os.geteuid() == 0 else ""))
        self.log = open(folder / "mosquitto.log", "w")
        self.proc = subprocess.Popen(["mosquitto", "-c", str(conf)], stdout=self.log, stderr=subprocess.STDOUT,
                                     preexec_fn=die_with_parent)
        deadline = time.monotonic() + 10
        while True:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise RuntimeError("mosquitto did not listen within 10 s")
                time.sleep(0.05)
        self.messages = []
        self.lock = threading.Lock()
        subscribed = threading.Event()
        self.client = mqtt.Client(client_id="robustness-plant")
        self.client.on_connect = lambda c, u, f, rc: c.subscribe("hullgauge/sim/#", qos=1)
        self.client.on_subscribe = lambda c, u, mid, q: subscribed.set()
        self.client.on_message = self.on_message
        self.client.connect("127.0.0.1", self.port)
        self.client.loop_start()
        if not subscribed.wait(10):
            raise RuntimeError("the subscriber was not subscribed within 10 s")

    def on_message(self, client, userdata, message):
        with self.lock:
            self.messages.append((message.topic, message.payload))

    def count(self):
        with self.lock:
            return len(self.messages)

    def kinds_since(self, first):
        """topic's last part ("result", "state", "counters") -> messages, from index `first` on."""
        kinds = {}
        with self.lock:
            for topic, _ in self.messages[first:]:
                kind = topic.rsplit("/", 1)[-1]
                kinds[kind] = kinds.get(kind, 0) + 1
        return kinds

    def connections(self):
        """The station's connections the broker logged (its log: `New client connected ... as <id>`)."""
        self.log.flush()
        text = (Path(self.log.name)).read_text()
        return sum(1 for l in text.splitlines() if "New client connected" in l and "robustness-plant" not in l)

    def results_since(self, first):
        """cycle id -> copies received, of the result messages from index `first` on."""
        copies = {}
        with self.lock:
            for topic, payload in self.messages[first:]:
                if topic.endswith("/result"):
                    cid = json.loads(payload)["cycle_id"]
                    copies[cid] = copies.get(cid, 0) + 1
        return copies

    def close(self):
        self.client.loop_stop()
        self.client.disconnect()
        self.proc.terminate()
        self.proc.wait(timeout=10)
        self.log.close()


def fill(path, leave_bytes=0):
    """Grows the file at `path` until its volume has `leave_bytes` free (0: until ENOSPC)."""
    chunk = b"\0" * (1 << 20)
    with open(path, "ab") as f:
        while True:
            free = os.statvfs(path).f_bavail * os.statvfs(path).f_frsize
            if free <= leave_bytes:
                return
            try:
                f.write(chunk[:max(4096, min(len(chunk), free - leave_bytes))])
                f.flush()
                os.fsync(f.fileno())
            except OSError:
                return


def scenario_disk_full(args):
    """The results volume (a 64 MiB tmpfs) filled: images give way to verdicts; a store that takes
    no writes costs the plant link no storm and the journal no flood."""
    if os.geteuid() != 0:
        row("the results volume full (a small tmpfs)", "not run: mounting a tmpfs needs root", "—", "—")
        return
    volume = Path(tempfile.mkdtemp(prefix="hg-robust-volume-"))
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64m", "tmpfs", str(volume)], check=True)
    overlay = Path(tempfile.mkdtemp(prefix="hg-robust-overlay-"))
    config = (args.source / "config" / "sim" / "hullgauged.yaml").read_text()
    config = config.replace("  retention: {max_count: 200, max_age_days: 7, max_bytes: 268435456}",
                            "  archive_all: true\n"
                            "  retention: {max_count: 100000, max_age_days: 7, max_bytes: 1e12, min_free_mb: 12}")
    (overlay / "hullgauged.yaml").write_text(config)
    broker = PlantBroker(overlay)
    line = None
    try:
        line = Line(args, [args.source / "config" / "sim-fast", overlay], results_dir=volume,
                    extra_args=["--mqtt", f"mqtt://127.0.0.1:{broker.port}"])
        plc = Plc(line.plc_port)
        log = line.workdir / "hullgauged.log"
        filler = volume / "filler"
        # 1. Less and less room: every part archived; the oldest folders give way.
        fill(filler, leave_bytes=20 << 20)
        first = [plc.cycle(f"ROOM{i:03d}") for i in range(12)]
        check(all(r[1] == 1 and r[2] == 0 for r in first), f"disk full: results while images gave way {first}")
        gave_way = "removed the oldest" in log.read_text()
        check(gave_way, "disk full: the archive never made room")
        # 2. The volume full to the last byte while archived folders remain: they go, the verdicts stay.
        fill(filler)
        second = [plc.cycle(f"FULL{i:03d}") for i in range(4)]
        check(all(r[1] == 1 and r[2] == 0 for r in second), f"disk full: a verdict lost to images {second}")
        # 3. Nothing left to drop: the record cannot be written (FAULT 42); the plant link stays calm.
        for folder in (volume / "images").iterdir():
            subprocess.run(["rm", "-rf", str(folder)])
        fill(filler)
        lines_before = len(log.read_text().splitlines())
        messages_before = broker.count()
        third = [plc.cycle(f"NONE{i:03d}") for i in range(4)]
        check(all(r[1] == 3 and r[2] == 42 for r in third), f"disk full: nothing to drop gives FAULT 42 {third}")
        during = log.read_text().splitlines()[lines_before:]
        kinds = broker.kinds_since(messages_before)
        sent = kinds.get("result", 0) + kinds.get("counters", 0)
        check(len(during) <= 12 * len(third), f"disk full: {len(during)} log lines for {len(third)} cycles")
        check(sent <= 2 * len(third), f"disk full: {sent} result and counter messages for {len(third)} cycles")
        check(kinds.get("state", 0) <= 4 * len(third), f"disk full: {kinds.get('state', 0)} state messages")
        # 4. Room again: verdicts, and every stored result out once, marked published.
        filler.unlink()
        fourth = [plc.cycle(f"BACK{i:03d}") for i in range(3)]
        check(all(r[1] == 1 and r[2] == 0 for r in fourth), f"disk full: after room came back {fourth}")
        stored = line.stored_rows()
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            copies = broker.results_since(0)
            db = sqlite3.connect(f"file:{volume / 'results.db'}?mode=ro", uri=True)
            waiting = db.execute("SELECT COUNT(*) FROM inspections WHERE published_unix_ms IS NULL").fetchone()[0]
            db.close()
            if len(copies) >= len(stored) and waiting == 0:
                break
            time.sleep(0.2)
        check(len(copies) == len(stored) and waiting == 0,
              f"disk full: {len(copies)} results out of {len(stored)} stored, {waiting} not marked published")
        most = max(copies.values(), default=0)
        check(most <= 2, f"disk full: a result went out {most} times")
        connections = broker.connections()
        check(connections <= 1, f"disk full: the station connected {connections} times")
        check(line.alive(), "disk full: the daemon died")
        row("the results volume fills up (a 64 MiB tmpfs, every part archived, `min_free_mb` 12)",
            f"{len(first)} + {len(second)} parts RESULT 1: the oldest archived folders gave way to the new ones, "
            "and to the records once the volume was full to the last byte",
            "—", "images only, oldest first")
        row("the results volume full with nothing left to drop",
            f"RESULT 3, FAULT 42 ({len(third)} parts); {len(during)} journal lines, {sent} result and counter "
            f"and {kinds.get('state', 0)} state messages for them; {connections} connection to the broker in all", f"the next parts RESULT 1 once there is room; every stored result "
            f"published (at most {most}× each)", "the parts' records while the volume was full")
        plc.close()
    finally:
        if line:
            line.stop()
        broker.close()
        subprocess.run(["umount", str(volume)])
        subprocess.run(["rm", "-rf", str(volume), str(overlay)])


SCENARIOS["disk_full"] = scenario_disk_full


class NotifySocket:
    """A NOTIFY_SOCKET as systemd's: every message the daemon sends, with its arrival time."""

    def __init__(self, path):
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(str(path))
        self.sock.settimeout(0.1)
        self.messages = []
        self.lock = threading.Lock()
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self.receive, daemon=True)
        self.thread.start()

    def receive(self):
        while not self.stopped.is_set():
            try:
                text = self.sock.recv(4096).decode(errors="replace")
            except socket.timeout:
                continue
            with self.lock:
                self.messages.append((time.monotonic(), text))

    def times(self, field, since=0.0):
        with self.lock:
            return [t for t, text in self.messages if t >= since and field in text.split("\n")]

    def close(self):
        self.stopped.set()
        self.thread.join(timeout=5)
        self.sock.close()


def scenario_reload_large_mesh(args):
    """SIGHUP with a program whose mesh is a 2 GB STL: refused naming the limit, the watchdog pinged throughout."""
    folder = Path(tempfile.mkdtemp(prefix="hg-robust-notify-"))
    notify = NotifySocket(folder / "notify.sock")
    line = Line(args, env={"NOTIFY_SOCKET": str(folder / "notify.sock"), "WATCHDOG_USEC": "1000000"})
    cfg = line.workdir / "config"
    log = line.workdir / "hullgauged.log"
    try:
        deadline = time.monotonic() + 10
        while len(notify.times("WATCHDOG=1")) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        check(len(notify.times("WATCHDOG=1")) >= 2, "large mesh: the daemon does not ping the watchdog")
        # A binary STL whose facet count matches its 2.15 GB (sparse: it takes no disk).
        facets = 43_000_000
        with open(cfg / "huge.stl", "wb") as f:
            f.write(b"hullgauge robustness: a large mesh".ljust(80, b" ") + facets.to_bytes(4, "little"))
            f.truncate(84 + 50 * facets)
        (cfg / "cube-2.yaml").write_text(cube_program("huge.stl"))
        daemon_yaml = cfg / "hullgauged.yaml"
        daemon_yaml.write_text(daemon_yaml.read_text().replace(
            "programs:\n", "programs:\n  2: {part: cube-2.yaml, views: stepped-block-views.yaml}\n", 1))
        rss_before = line.rss_kib()
        t0 = time.monotonic()
        os.kill(line.daemon_pid, signal.SIGHUP)
        deadline = t0 + 60
        while "reload refused" not in log.read_text() and time.monotonic() < deadline:
            time.sleep(0.05)
        refused_s = time.monotonic() - t0
        text = log.read_text()
        refusal = next((l for l in text.splitlines() if "reload refused" in l), "")
        check("mesh size limit" in refusal, f"large mesh: the refusal does not name the limit: {refusal!r}")
        # The pings from a second before the SIGHUP to two seconds after the refusal.
        until = time.monotonic() + 2
        while time.monotonic() < until:
            time.sleep(0.05)
        pings = notify.times("WATCHDOG=1", since=t0 - 1)
        gaps = [b - a for a, b in zip(pings, pings[1:])]
        longest = max(gaps, default=float("inf"))
        check(longest <= 2.0, f"large mesh: the watchdog's longest gap was {longest:.2f} s")
        rss_after = line.rss_kib()
        check(rss_after - rss_before < 64 * 1024, f"large mesh: RSS {rss_before >> 10} -> {rss_after >> 10} MiB")
        plc = Plc(line.plc_port)
        _, result, fault, _ = plc.cycle("AFTERHUGE")
        check(result == 1 and fault == 0, f"large mesh: the next part {result}/{fault}")
        plc.close()
        reason = refusal.split("reload refused, keeping the running configuration: ", 1)[-1]
        reason = reason.replace(str(cfg) + "/", "")
        row("SIGHUP with a part program whose mesh is a 2.15 GB STL",
            f"refused in {refused_s:.1f} s: `{reason}`; watchdog pings every 0.5 s throughout (longest gap "
            f"{longest:.2f} s, WatchdogSec 1 s), RSS {rss_before >> 10} → {rss_after >> 10} MiB",
            "— (the running configuration kept; the next part passes)", "nothing")
    finally:
        line.stop()
        notify.close()
        subprocess.run(["rm", "-rf", str(folder)])


SCENARIOS["reload_large_mesh"] = scenario_reload_large_mesh


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--cycles", type=int, default=20)
    ap.add_argument("--only", nargs="*", choices=sorted(SCENARIOS))
    args = ap.parse_args()
    for name in args.only or SCENARIOS:
        print(f"== {name}", flush=True)
        t0 = time.monotonic()
        try:
            SCENARIOS[name](args)
        except Exception as e:  # noqa: BLE001 - one scenario's surprise must not hide the others
            check(False, f"{name}: {type(e).__name__}: {e}")
        print(f"== {name}: {time.monotonic() - t0:.1f} s", flush=True)
    if args.out:
        lines = ["| fault | what the PLC sees | recovery | lost |", "|---|---|---|---|"]
        lines += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in matrix]
        args.out.write_text("\n".join(lines) + "\n")
    if failures:
        print(f"{len(failures)} checks failed", file=sys.stderr)
        return 1
    print(f"robustness: {len(matrix)} faults, every check held")
    return 0


if __name__ == "__main__":
    sys.exit(main())
