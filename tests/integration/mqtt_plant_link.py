#!/usr/bin/python3
"""The plant link end to end (docs/mqtt.md, docs/contracts.md §8).

A real broker (Debian's mosquitto on 127.0.0.1 at free ports, its
configuration written here), the simulated line (tools/simline --mqtt, or a
`mqtt` section laid over config/sim for TLS and passwords), a PLC
(tools/plc-client, pymodbus) and a subscriber (paho-mqtt, a durable session
subscribed to hullgauge/#). Checked:

- one result message per cycle on hullgauge/<station>/result, valid against
  docs/schemas/mqtt-result.schema.json and equal to the store's row (the
  maintenance socket's `results`) with the station and the row's cycle id;
  the state and counters messages valid against their schemas, the counters
  those of the store; the health messages (one per cycle) valid against
  theirs, each of a stored cycle with its stored figures;
- the broker stopped for --outage-cycles cycles (default 20): the PLC gets
  every verdict, the results wait in the store (published_unix_ms NULL), and
  once the broker is back all of them arrive, in order;
- the daemon killed with SIGKILL while results wait (broker stopped first):
  after the broker and the daemon restart on the same work folder they
  arrive; every copy of a result carries the same cycle id;
- a clean stop leaves the retained state `offline`;
- TLS with a CA, a server and a client certificate made here with openssl;
  a station that trusts another CA is refused (logged), and wrong credentials
  on a password listener (mosquitto_passwd -b) are refused (logged) while
  every cycle still gives the PLC its verdict; with the right password,
  restarted on the same work folder, the refused results arrive.

The broker keeps the subscriber's session across its restart (persistence in
the test's folder), so the subscriber never races the station for the
results published while it reconnects. Every wait polls under a deadline.
"""
import argparse
import json
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import jsonschema
import paho.mqtt.client as mqtt

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, die_with_parent, failures, free_port, maintenance, start_line, stop_line  # noqa: E402

FAILING = {"nominal": 0, "face-low": 2}


def wait_until(predicate, timeout_s, what, interval_s=0.05):
    """Polls `predicate` until it is true or the deadline passes (then a failure naming `what`)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval_s)
    return check(predicate(), f"{what}: not within {timeout_s} s")


class Broker:
    """mosquitto with the listeners given (each a block of mosquitto.conf), one per port."""

    def __init__(self, folder, name, listeners):
        self.folder = folder
        self.ports = [port for port, _ in listeners]
        store = folder / f"{name}-store"
        store.mkdir(parents=True, exist_ok=True)
        lines = ["per_listener_settings true", "persistence true", f"persistence_location {store}/",
                 "autosave_interval 0", f"log_dest file {folder / (name + '.log')}", "log_type error",
                 "log_type warning", "log_type notice", "log_type information"]
        if os.geteuid() == 0:
            lines.append("user root")  # as root mosquitto would become the user mosquitto, who cannot read our keys
        for port, block in listeners:
            lines += [f"listener {port} 127.0.0.1", block]
        self.conf = folder / f"{name}.conf"
        self.conf.write_text("\n".join(lines) + "\n")
        self.process = None

    def start(self):
        self.process = subprocess.Popen(["mosquitto", "-c", str(self.conf)], stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL, start_new_session=True, preexec_fn=die_with_parent)
        for port in self.ports:
            if not wait_until(lambda: self._listens(port), 60, f"mosquitto listening on {port}"):
                raise SystemExit(f"mosquitto did not start: see {self.conf}")

    def stop(self):
        if self.process and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                check(False, "mosquitto did not stop within 10 s of SIGTERM")
                self.process.kill()
                self.process.wait()

    def _listens(self, port):
        if self.process.poll() is not None:
            raise SystemExit(f"mosquitto exited with {self.process.returncode}: see {self.conf}")
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
            return True
        except OSError:
            return False


class Subscriber:
    """A plant system: a durable session subscribed to hullgauge/# with QoS 1, recording every message."""

    def __init__(self, port, client_id):
        self.lock = threading.Lock()
        self.messages = []  # (topic, payload, retained, monotonic time)
        self.subscribed = threading.Event()
        self.client = mqtt.Client(client_id=client_id, clean_session=False)
        self.client.on_connect = lambda c, userdata, flags, rc: c.subscribe("hullgauge/#", qos=1)
        self.client.on_subscribe = lambda *a: self.subscribed.set()
        self.client.on_message = self._on_message
        self.client.reconnect_delay_set(1, 1)
        self.client.connect("127.0.0.1", port, keepalive=30)
        self.client.loop_start()
        if not self.subscribed.wait(10):
            raise SystemExit("the subscriber did not subscribe within 10 s")

    def _on_message(self, client, userdata, message):
        with self.lock:
            self.messages.append((message.topic, json.loads(message.payload), message.retain, time.monotonic()))

    def on(self, topic):
        with self.lock:
            return [payload for t, payload, _, _ in self.messages if t == topic]

    def close(self):
        self.client.loop_stop()
        self.client.disconnect()


def unique_in_order(messages):
    """The first copy of every cycle, in arrival order; a later copy must equal its first."""
    first = {}
    for m in messages:
        if m["cycle_id"] in first:
            check(first[m["cycle_id"]] == m, f"two copies of cycle {m['cycle_id']} differ")
        else:
            first[m["cycle_id"]] = m
    return list(first.values())


class Station:
    """A simulated line publishing as `name`, its PLC and its store."""

    def __init__(self, args, workdir, name, extra):
        self.args, self.workdir, self.name, self.extra = args, workdir, name, extra
        self.plc_port = free_port()
        self.topic = f"hullgauge/{name}/result"

    def start(self):
        self.workdir.mkdir(parents=True, exist_ok=True)
        (self.workdir / "simline.ready").unlink(missing_ok=True)
        self.line, self.out, self.ready = start_line(self.args.source, self.args.bin, self.workdir, self.plc_port,
                                                     ["--config", str(self.args.source / "config" / "sim-fast"),
                                                      *self.extra])
        self.socket = self.ready["socket"]

    def stop(self):
        stop_line(self.line, self.out)

    def cycles(self, n):
        """n cycles as the PLC runs them (every second part defective); every verdict checked."""
        run = subprocess.run(["/usr/bin/python3", str(self.args.source / "tools" / "plc-client"), "--port",
                              str(self.plc_port), "cycles", str(n), "--bad-every", "2", "--timeout", "30",
                              "--sim-socket", self.socket, "--variant", "face-low"],
                             capture_output=True, text=True, timeout=60 + 30 * n)
        check(run.returncode == 0, f"{self.name}: plc-client exit {run.returncode}: {run.stderr}")
        rows = [json.loads(t) for t in run.stdout.splitlines() if t.strip()]
        cycles = [r for r in rows if "summary" not in r]
        check(len(cycles) == n, f"{self.name}: the PLC got {len(cycles)} of {n} verdicts")
        for r in cycles:
            check(r["verdict"] == r["expected"] and r["consistent"],
                  f"{self.name}: cycle {r['seq']} gave the PLC {r['verdict']}, expected {r['expected']}")
            check(r["landmarks_failed"] == FAILING["face-low" if r["expected"] == "fail" else "nominal"],
                  f"{self.name}: cycle {r['seq']} LANDMARKS_FAILED {r['landmarks_failed']}")
        return cycles

    def store_rows(self):
        """(id, cycle_id, published_unix_ms) of every stored result, oldest first."""
        db = sqlite3.connect(f"file:{self.workdir / 'results.db'}?mode=ro", uri=True)
        try:
            return db.execute("SELECT id, cycle_id, published_unix_ms FROM inspections ORDER BY id").fetchall()
        finally:
            db.close()

    def waiting(self):
        return sum(1 for _, _, published in self.store_rows() if published is None)

    def connected(self):
        return bool((maintenance(self.socket, {"command": "status"}).get("mqtt") or {}).get("connected"))

    def log(self):
        return (self.workdir / "hullgauged.log").read_text(errors="replace")


def check_results(station, subscriber, schemas, expected):
    """The station's result messages: `expected` cycles, each once (copies equal), in store order,
    schema-valid, equal to the stored row with the station and the row's cycle id."""
    messages = unique_in_order(subscriber.on(station.topic))
    check(len(messages) == expected, f"{station.name}: {len(messages)} distinct results published, expected {expected}")
    rows = {r["id"]: r for r in maintenance(station.socket, {"command": "results", "limit": 1000})["results"]}
    cycle_ids = {i: c for i, c, _ in station.store_rows()}
    ids = [m.get("id") for m in messages]
    check(ids == sorted(ids), f"{station.name}: results arrived out of order: {ids}")
    for m in messages:
        errors = [e.message for e in schemas["result"].iter_errors(m)]
        check(not errors, f"{station.name}: result {m.get('id')} does not follow its schema: {errors[:3]}")
        row = dict(m)
        check(row.pop("station", None) == station.name, f"result {m.get('id')}: station {m.get('station')}")
        check(row.pop("cycle_id", None) == cycle_ids.get(m.get("id")), f"result {m.get('id')}: cycle id not the row's")
        check(row == rows.get(m.get("id")), f"{station.name}: result {m.get('id')} is not the stored row")
    return messages


def check_state_and_counters(station, subscriber, schemas):
    states = subscriber.on(f"hullgauge/{station.name}/state")
    counters = subscriber.on(f"hullgauge/{station.name}/counters")
    check(states and counters, f"{station.name}: no state or counters messages")
    for kind, messages in (("state", states), ("counters", counters)):
        for m in messages:
            errors = [e.message for e in schemas[kind].iter_errors(m)]
            check(not errors, f"{station.name}: {kind} message {m} does not follow its schema: {errors[:3]}")
    verdicts = [r[0] for r in sqlite3.connect(f"file:{station.workdir / 'results.db'}?mode=ro", uri=True).execute(
        "SELECT verdict FROM inspections")]
    want = {"cycles": len(verdicts), "passes": verdicts.count("pass"), "fails": verdicts.count("fail")}
    wait_until(lambda: {k: (subscriber.on(f"hullgauge/{station.name}/counters") or [{}])[-1].get(k) for k in want} ==
               want, 60, f"{station.name}: counters {want}")


def check_health(station, subscriber, schemas, expected):
    """The station's health messages (docs/health.md, "In the daemon"): one per cycle while connected,
    schema-valid, each naming a stored result's cycle id, its figures those of the store's health row."""
    messages = subscriber.on(f"hullgauge/{station.name}/health")
    check(len(messages) >= expected, f"{station.name}: {len(messages)} health messages, expected {expected}")
    db = sqlite3.connect(f"file:{station.workdir / 'results.db'}?mode=ro", uri=True)
    try:
        rows = {c: (b, w) for c, b, w in db.execute(
            "SELECT i.cycle_id, h.edge_width_px, h.warnings FROM health h JOIN inspections i ON i.id = h.inspection_id")}
    finally:
        db.close()
    for m in messages:
        errors = [e.message for e in schemas["health"].iter_errors(m)]
        check(not errors, f"{station.name}: health message {m} does not follow its schema: {errors[:3]}")
        stored = rows.get(m.get("cycle_id"))
        check(stored is not None and m.get("station") == station.name, f"{station.name}: health message of no stored cycle {m}")
        if stored:
            check(m["figures"]["edge_width_px"] == stored[0] and m["warnings"] == json.loads(stored[1]),
                  f"{station.name}: health message {m} is not the stored row {stored}")


def plain_line(args, folder, schemas):
    """Results, the broker's outage, kill -9 of the daemon, the clean stop."""
    port = free_port()
    broker = Broker(folder, "plain", [(port, "allow_anonymous true")])
    broker.start()
    subscriber = Subscriber(port, "hg-test-plain")
    station = Station(args, folder / "line", "gauge-7", ["--mqtt", f"mqtt://127.0.0.1:{port}", "--station-id",
                                                          "gauge-7"])
    station.start()
    try:
        station.cycles(6)
        wait_until(lambda: len(unique_in_order(subscriber.on(station.topic))) >= 6, 60, "6 results published")
        wait_until(lambda: station.waiting() == 0, 60, "every result marked published")
        check_results(station, subscriber, schemas, 6)
        check_state_and_counters(station, subscriber, schemas)
        check_health(station, subscriber, schemas, 6)

        # The broker away: the PLC gets every verdict, the results wait on disk.
        broker.stop()
        wait_until(lambda: not station.connected(), 60, "the daemon sees the broker gone")
        outage = time.monotonic()
        station.cycles(args.outage_cycles)
        print(f"broker away: {args.outage_cycles} cycles, every verdict to the PLC, in "
              f"{time.monotonic() - outage:.1f} s", flush=True)
        check(station.waiting() == args.outage_cycles,
              f"{station.waiting()} results waiting in the store after {args.outage_cycles} cycles without broker")
        started = time.monotonic()
        broker.start()
        total = 6 + args.outage_cycles
        wait_until(lambda: len(unique_in_order(subscriber.on(station.topic))) >= total, 90,
                   f"the {args.outage_cycles} queued results delivered")
        print(f"broker back: {args.outage_cycles} queued results delivered in order within "
              f"{time.monotonic() - started:.2f} s", flush=True)
        wait_until(lambda: station.waiting() == 0, 60, "the queued results marked published")
        check_results(station, subscriber, schemas, total)

        # kill -9 with results waiting: they go out after the restart, with their cycle ids.
        broker.stop()
        wait_until(lambda: not station.connected(), 60, "the daemon sees the broker gone again")
        station.cycles(5)
        check(station.waiting() == 5, f"{station.waiting()} results waiting before the kill, expected 5")
        os.kill(int(station.ready["daemon_pid"]), signal.SIGKILL)
        station.line.wait(timeout=30)
        station.out.close()
        broker.start()
        station.start()
        started = time.monotonic()
        wait_until(lambda: len(unique_in_order(subscriber.on(station.topic))) >= total + 5, 90,
                   "the results of the killed daemon delivered after its restart")
        print(f"daemon killed with 5 results waiting: delivered {time.monotonic() - started:.2f} s after the "
              f"line was ready again", flush=True)
        wait_until(lambda: station.waiting() == 0, 60, "the results of the killed daemon marked published")
        messages = check_results(station, subscriber, schemas, total + 5)
        check({m["cycle_id"] for m in messages} == {c for _, c, _ in station.store_rows()},
              "the published cycle ids are not those of the store")
        duplicates = len(subscriber.on(station.topic)) - len(messages)
        print(f"{len(messages)} results, {duplicates} delivered twice (same cycle id)", flush=True)
        check_state_and_counters(station, subscriber, schemas)
    finally:
        station.stop()
    wait_until(lambda: (subscriber.on(f"hullgauge/{station.name}/state") or [{}])[-1].get("state") == "offline", 60,
               "the state offline after the clean stop")
    subscriber.close()
    broker.stop()


def openssl(*arguments, cwd):
    subprocess.run(["openssl", *arguments], cwd=cwd, check=True, capture_output=True, timeout=60)


def make_certificates(folder):
    """A test CA, the broker's certificate for 127.0.0.1 and a client certificate; another CA that signed nothing."""
    folder.mkdir()
    for ca in ("ca", "other-ca"):
        openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", f"/CN=hullgauge test {ca}",
                "-keyout", f"{ca}.key", "-out", f"{ca}.pem", cwd=folder)
    (folder / "server.ext").write_text("subjectAltName=IP:127.0.0.1\n")
    for name, ext in (("server", ["-extfile", "server.ext"]), ("client", [])):
        openssl("req", "-newkey", "rsa:2048", "-nodes", "-subj", f"/CN=hullgauge test {name}", "-keyout",
                f"{name}.key", "-out", f"{name}.csr", cwd=folder)
        openssl("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
                "-days", "2", "-out", f"{name}.pem", *ext, cwd=folder)
    for key in folder.glob("*.key"):
        key.chmod(0o600)


def overlay(args, folder, mqtt_section):
    """A folder laid over config/sim (tools/simline --config) whose hullgauged.yaml has the mqtt section."""
    folder.mkdir(parents=True)
    base = (args.source / "config" / "sim" / "hullgauged.yaml").read_text()
    (folder / "hullgauged.yaml").write_text(base + "mqtt:\n" + "".join(f"  {line}\n" for line in mqtt_section))
    return ["--config", str(folder)]


def secured_lines(args, folder, schemas):
    """TLS with certificates; another CA refused; wrong credentials refused, then the right ones."""
    tls = folder / "tls"
    make_certificates(tls)
    (folder / "passwords").write_text("")
    subprocess.run(["mosquitto_passwd", "-b", str(folder / "passwords"), "gauge", "right-password"], check=True,
                   timeout=30)
    plain, secure, protected = free_port(), free_port(), free_port()
    broker = Broker(folder, "secured", [
        (plain, "allow_anonymous true"),
        (secure, f"allow_anonymous true\ncafile {tls / 'ca.pem'}\ncertfile {tls / 'server.pem'}\n"
                 f"keyfile {tls / 'server.key'}\nrequire_certificate true"),
        (protected, f"allow_anonymous false\npassword_file {folder / 'passwords'}"),
    ])
    broker.start()
    subscriber = Subscriber(plain, "hg-test-secured")
    common = ["retry_min_s: 0.2", "retry_max_s: 1"]
    try:
        station = Station(args, folder / "tls-line", "gauge-tls", overlay(args, folder / "tls-config", [
            f"url: mqtts://127.0.0.1:{secure}", "station_id: gauge-tls",
            f"tls: {{ca_file: {tls / 'ca.pem'}, cert_file: {tls / 'client.pem'}, key_file: {tls / 'client.key'}}}",
            *common]))
        station.start()
        try:
            station.cycles(3)
            wait_until(lambda: len(unique_in_order(subscriber.on(station.topic))) >= 3, 60, "3 results over TLS")
            check_results(station, subscriber, schemas, 3)
        finally:
            station.stop()

        station = Station(args, folder / "untrusted-line", "gauge-untrusted", overlay(args, folder / "bad-ca", [
            f"url: mqtts://127.0.0.1:{secure}", "station_id: gauge-untrusted",
            f"tls: {{ca_file: {tls / 'other-ca.pem'}, cert_file: {tls / 'client.pem'}, "
            f"key_file: {tls / 'client.key'}}}", *common]))
        station.start()
        try:
            station.cycles(2)
            wait_until(lambda: "certificate verify failed" in station.log(), 60, "the TLS failure logged")
            check(station.waiting() == 2, f"{station.waiting()} of 2 results wait behind the TLS failure")
        finally:
            station.stop()
        check(not subscriber.on(station.topic), "a station that does not trust the broker published")

        (folder / "wrong-password").write_text("not-the-password\n")
        (folder / "wrong-password").chmod(0o600)
        workdir = folder / "password-line"
        section = [f"url: mqtt://127.0.0.1:{protected}", "station_id: gauge-pw", "username: gauge",
                   f"password_file: {folder / 'wrong-password'}", *common]
        station = Station(args, workdir, "gauge-pw", overlay(args, folder / "pw-config", section))
        station.start()
        try:
            station.cycles(3)
            wait_until(lambda: "the broker refused the connection" in station.log(), 60, "the refusal logged")
            check(station.waiting() == 3, f"{station.waiting()} of 3 results wait behind the refusal")
        finally:
            station.stop()
        check(not subscriber.on(station.topic), "a station with a wrong password published")
        (folder / "wrong-password").write_text("right-password\n")
        station.start()
        try:
            wait_until(lambda: len(unique_in_order(subscriber.on(station.topic))) >= 3, 60,
                       "the refused results delivered with the right password")
            check_results(station, subscriber, schemas, 3)
        finally:
            station.stop()
    finally:
        subscriber.close()
        broker.stop()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    ap.add_argument("--outage-cycles", type=int, default=20)
    ap.add_argument("--keep", action="store_true", help="keep the work folder (the logs) after a success")
    args = ap.parse_args()
    schemas = {kind: jsonschema.Draft202012Validator(
        json.loads((args.source / "docs" / "schemas" / f"mqtt-{kind}.schema.json").read_text()))
        for kind in ("result", "state", "counters", "health")}
    folder = Path(tempfile.mkdtemp(prefix="hg-mqtt-"))
    started = time.monotonic()
    plain_line(args, folder, schemas)
    print(f"plain broker: results, outage, kill -9 and clean stop checked in {time.monotonic() - started:.1f} s",
          flush=True)
    started = time.monotonic()
    secured_lines(args, folder, schemas)
    print(f"TLS and passwords checked in {time.monotonic() - started:.1f} s", flush=True)
    if failures:
        print(f"{len(failures)} checks failed; work folder {folder}", file=sys.stderr)
        return 1
    print("plant link: every result published once per cycle id, in order, through outages, kill -9, TLS and "
          "passwords")
    if args.keep:
        print(f"work folder {folder}")
    else:
        subprocess.run(["rm", "-rf", str(folder)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
