#!/usr/bin/python3
"""The web HMI under slow clients (docs/hmi.md, "Bounded"): 50 connections
trickle requests at the HMI — 25 send their head one header line every
0.5 s, 25 a POST whose body comes a byte every 0.5 s — and start again
whenever the HMI gives up on them, for the whole run. Meanwhile a real
browser (Debian's chromium, headless, through chromium-driver) keeps the line
view open while a PLC (pymodbus) runs cycles, and a plain client asks for
the line view's data four times a second. What must hold:

- every slow request is answered 408 at the HMI's request deadline
  (`http.request_timeout_s`) and costs its own slot only;
- the browser shows every cycle's verdict and result id within three of its
  own status polls after DONE_SEQ (counted polls, as tests/integration/
  hmi_browser.py);
- the HMI answers the plain client within 1 s, every time;
- the PLC's register reads take at most 100 ms at the 99th percentile (the
  maximum is printed).

  hmi_slow_clients.py --source DIR --bin DIR [--cycles N] [--clients N]
"""
import argparse
import http.client
import socket
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, failures, free_port, start_line, stop_line  # noqa: E402
from hmi_browser import browser, stored  # noqa: E402

from pymodbus.client import ModbusTcpClient  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

DONE_SEQ = 101
TRICKLE_S = 0.5


def percentile(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(round(p / 100 * (len(values) - 1))))] if values else 0.0


class Trickler(threading.Thread):
    """One slow client: a request sent a piece every TRICKLE_S, again each time the HMI closes it."""

    def __init__(self, port, kind, stop):
        super().__init__(daemon=True)
        self.port, self.kind, self.stop = port, kind, stop
        self.answers = {}  # status line's code -> count
        self.connections = 0
        self.held_s = []  # how long each connection was held before the HMI answered

    def pieces(self):
        if self.kind == "head":
            yield b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n"
            for i in range(1000):
                yield f"X-Slow-{i}: {'a' * 20}\r\n".encode()
        else:
            yield (b"POST /api/login HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                   b"Content-Length: 1000\r\n\r\n")
            for _ in range(1000):
                yield b" "

    def run(self):
        while not self.stop.is_set():
            try:
                s = socket.create_connection(("127.0.0.1", self.port), timeout=5)
            except OSError:
                self.stop.wait(TRICKLE_S)
                continue
            self.connections += 1
            opened = time.monotonic()
            s.settimeout(0.01)
            reply = b""
            try:
                for piece in self.pieces():
                    s.sendall(piece)
                    if self.stop.wait(TRICKLE_S):
                        break
                    try:
                        data = s.recv(4096)
                    except socket.timeout:
                        continue
                    reply += data
                    break  # answered, or closed without an answer (b"")
            except OSError:
                pass  # closed by the HMI while sending
            s.close()
            if reply.startswith(b"HTTP/1.1 "):
                code = reply[9:12].decode(errors="replace")
                self.answers[code] = self.answers.get(code, 0) + 1
                self.held_s.append(time.monotonic() - opened)


class StatusPoller(threading.Thread):
    """A plain client asking for the line view's data four times a second; each answer's time."""

    def __init__(self, port, stop):
        super().__init__(daemon=True)
        self.port, self.stop = port, stop
        self.latencies, self.errors = [], []

    def run(self):
        while not self.stop.is_set():
            t0 = time.monotonic()
            try:
                c = http.client.HTTPConnection("127.0.0.1", self.port, timeout=10)
                c.request("GET", "/api/status")
                r = c.getresponse()
                r.read()
                c.close()
                if r.status != 200:
                    self.errors.append(f"status {r.status}")
            except OSError as e:
                self.errors.append(str(e))
            self.latencies.append(time.monotonic() - t0)
            self.stop.wait(0.25)


class TimedPlc:
    """A PLC over pymodbus that times every register read."""

    def __init__(self, port):
        self.client = ModbusTcpClient("127.0.0.1", port=port, timeout=10)
        check(self.client.connect(), "the PLC client could not connect")
        self.latencies = []

    def read(self, address, count):
        t0 = time.monotonic()
        r = self.client.read_holding_registers(address, count, slave=1)
        self.latencies.append(time.monotonic() - t0)
        if r.isError():
            raise RuntimeError(f"read {address}+{count}: {r}")
        return r.registers

    def cycle(self, seq, serial, timeout_s=60):
        raw = serial.encode("ascii")[:16].ljust(16, b"\0")
        w = self.client.write_registers(0, [seq, 1] + [(raw[i] << 8) | raw[i + 1] for i in range(0, 16, 2)],
                                        slave=1)
        if w.isError():
            raise RuntimeError(f"trigger write failed: {w}")
        deadline = time.monotonic() + timeout_s
        while self.read(DONE_SEQ, 1)[0] != seq:
            if time.monotonic() > deadline:
                raise RuntimeError(f"no DONE_SEQ {seq} within {timeout_s} s")
            time.sleep(0.005)


def cycles_in_the_browser(driver, url, plc, db, cycles):
    """The PLC's cycles with the line view open: each one shown within three of the page's polls."""
    driver.get(url + "/")
    WebDriverWait(driver, 30).until(lambda d: d.execute_script("return window.hgLine && window.hgLine.polls > 0"))
    seq = plc.read(0, 1)[0]
    for i in range(cycles):
        serial = f"SLOW-HMI-{i:03d}"
        seq = (seq + 1) % 65536 or 1
        plc.cycle(seq, serial)
        polls_at_done = driver.execute_script("return window.hgLine.polls")
        row = stored(db, serial)
        if not check(row is not None, f"cycle {serial}: no stored row"):
            continue
        WebDriverWait(driver, 30, poll_frequency=0.02).until(
            lambda d: d.execute_script("return window.hgLine.shownResult") == row["id"])
        polls = driver.execute_script("return window.hgLine.polls") - polls_at_done
        check(polls <= 3, f"cycle {serial}: the line view took {polls} polls after DONE_SEQ to show it")
        check(driver.find_element(By.ID, "serial").text == serial, f"cycle {serial}: serial shown wrong")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    ap.add_argument("--cycles", type=int, default=12)
    ap.add_argument("--clients", type=int, default=50)
    args = ap.parse_args()
    workdir = Path(tempfile.mkdtemp(prefix="hg-hmi-slow-"))
    plc_port, http_port = free_port(), free_port()
    line, out, _ = start_line(args.source, args.bin, workdir, plc_port,
                              ["--http-port", str(http_port), "--config", str(args.source / "config" / "sim-fast")])
    url = f"http://127.0.0.1:{http_port}"
    stop = threading.Event()
    tricklers = [Trickler(http_port, "head" if i % 2 == 0 else "body", stop) for i in range(args.clients)]
    poller = StatusPoller(http_port, stop)
    driver = browser()
    plc = TimedPlc(plc_port)
    try:
        for t in tricklers:
            t.start()
        # Every slow client connected and under way before the browser and the PLC start.
        deadline = time.monotonic() + 30
        while sum(t.connections > 0 for t in tricklers) < len(tricklers) and time.monotonic() < deadline:
            time.sleep(0.05)
        check(all(t.connections > 0 for t in tricklers), "not every slow client connected")
        poller.start()
        plc.latencies.clear()
        cycles_in_the_browser(driver, url, plc, workdir / "results.db", args.cycles)
        # At least one full request deadline (5 s) with every slow client held, whatever the cycles took.
        until = time.monotonic() + 6
        while time.monotonic() < until:
            time.sleep(0.1)
    finally:
        stop.set()
        for t in tricklers:
            t.join(timeout=5)
        poller.join(timeout=15)
        plc.client.close()
        driver.quit()
        stop_line(line, out)

    answers = {}
    for t in tricklers:
        for code, n in t.answers.items():
            answers[code] = answers.get(code, 0) + n
    held = [s for t in tricklers for s in t.held_s]
    check(answers.get("408", 0) >= len(tricklers), f"slow clients: answers {answers}, expected a 408 for each")
    check(set(answers) <= {"408"}, f"slow clients: answers other than 408: {answers}")
    check(not poller.errors, f"the HMI failed the plain client: {poller.errors[:3]}")
    worst_hmi = max(poller.latencies, default=float("inf"))
    check(worst_hmi <= 1.0, f"the HMI answered the plain client in {worst_hmi * 1000:.0f} ms at worst")
    p99_plc = percentile(plc.latencies, 99)
    check(p99_plc <= 0.1, f"the PLC's reads took {p99_plc * 1000:.1f} ms at the 99th percentile")
    print(f"{len(tricklers)} slow clients, {sum(t.connections for t in tricklers)} connections, answers {answers}, "
          f"held {statistics.median(held) if held else 0:.1f} s median; HMI to the plain client: "
          f"{len(poller.latencies)} requests, median {1000 * statistics.median(poller.latencies):.1f} ms, "
          f"max {1000 * worst_hmi:.1f} ms; PLC: {len(plc.latencies)} reads, median "
          f"{1000 * statistics.median(plc.latencies):.1f} ms, p99 {1000 * p99_plc:.1f} ms, "
          f"max {1000 * max(plc.latencies):.1f} ms", flush=True)
    if failures:
        print(f"{len(failures)} checks failed (work folder {workdir})", file=sys.stderr)
        return 1
    print("web HMI under slow clients: every check passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
