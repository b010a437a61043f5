"""tools/demo and tools/simline as a new user runs them (docs/contracts.md §7):

- a demo run gives every part its own serial across its batches, and leaves no
  work folder behind however it ends: served and stopped with Ctrl-C (SIGINT to
  its process group, exit 0), SIGTERM in the middle of a batch (exit 143, its
  PLC client and the line stopped), a line that cannot start (exit 1);
- tools/simline takes the HMI's password hash from a file: neither the hash nor
  the password is on any process's command line while the line runs, the
  daemon accepts the password and refuses another; the old option that took
  the hash on the command line, and a file without a hash, are refused (exit 2).

Each demo runs with TMPDIR set to a folder of the test's own, so "no work
folder left" is that folder being empty.
"""
import argparse
import http.client
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from simline_harness import check, failures, free_port, password_hash_file, start_line, stop_line  # noqa: E402

SERIAL = re.compile(r"^  ((?:SN|BAD)(\d{6})) ")


class Demo:
    """tools/demo in a session of its own, its output read line by line as it comes."""

    def __init__(self, source, bin_dir, tmp, *args):
        env = dict(os.environ, HULLGAUGE_BIN=str(bin_dir), TMPDIR=str(tmp))
        self.process = subprocess.Popen([str(source / "tools" / "demo"), "--no-build", *args], cwd=source, env=env,
                                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
        self.lines = []
        self.rest = b""

    def until(self, pattern, timeout_s):
        """Reads lines until one matches `pattern` (the match) or the demo ends or the deadline passes (None)."""
        deadline = time.monotonic() + timeout_s
        fd = self.process.stdout.fileno()
        os.set_blocking(fd, False)
        while time.monotonic() < deadline:
            try:
                chunk = os.read(fd, 65536)
            except BlockingIOError:
                chunk = None
            if chunk:
                *done, self.rest = (self.rest + chunk).split(b"\n")
                for raw in done:
                    line = raw.decode(errors="replace")
                    self.lines.append(line)
                    if m := re.search(pattern, line):
                        return m
            elif chunk == b"" and self.process.poll() is not None:
                return None
            else:
                time.sleep(0.05)
        return None

    def finish(self, timeout_s):
        """The exit status within `timeout_s` (the rest of its output kept), else SIGKILL and None."""
        try:
            os.set_blocking(self.process.stdout.fileno(), True)
            out, _ = self.process.communicate(timeout=timeout_s)
            self.lines += (self.rest + out).decode(errors="replace").splitlines()
            return self.process.returncode
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.communicate()
            return None

    def text(self):
        return "\n".join(self.lines)


def daemon_pid(workdir):
    ready = Path(workdir) / "simline.ready"
    values = dict(line.split("=", 1) for line in ready.read_text().splitlines() if "=" in line)
    return int(values["daemon_pid"])


def gone(pid, timeout_s=30):
    """The process has ended (polled under a deadline): /proc has no such pid or only its zombie."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            if Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] == "Z":
                return True
        except OSError:
            return True
        time.sleep(0.1)
    return False


def empty(folder):
    return not any(folder.iterdir())


def served_and_interrupted(source, bin_dir, tmp):
    demo = Demo(source, bin_dir, tmp, "--cycles", "4", "--serve")
    ready = demo.until(r"work folder (\S+)\)", 180)
    if not check(ready is not None, f"the demo did not start:\n{demo.text()}"):
        demo.finish(5)
        return
    pid = daemon_pid(ready.group(1))
    served = demo.until(r"^demo: serving", 300)
    check(served is not None, f"the demo did not reach serving:\n{demo.text()}")
    # Ctrl-C: SIGINT to the terminal's foreground process group, the demo and every child.
    os.killpg(demo.process.pid, signal.SIGINT)
    status = demo.finish(60)
    check(status == 0, f"the served demo ended with {status} after Ctrl-C:\n{demo.text()}")
    serials = [m.group(1) for m in map(SERIAL.match, demo.lines) if m]
    numbers = sorted(int(m.group(2)) for m in map(SERIAL.match, demo.lines) if m)
    check(numbers == [0, 1, 2, 3], f"the 4 parts of two batches numbered 0..3, not {serials}")
    check(len(set(serials)) == len(serials), f"a serial given twice: {serials}")
    check(gone(pid), f"the daemon {pid} still runs after the demo ended")
    check(empty(tmp), f"left behind after Ctrl-C: {sorted(p.name for p in tmp.iterdir())}")
    print(f"served demo: serials {serials}, exit {status}, nothing left in {tmp}", flush=True)


def terminated_mid_batch(source, bin_dir, tmp):
    demo = Demo(source, bin_dir, tmp, "--cycles", "40")
    ready = demo.until(r"work folder (\S+)\)", 180)
    if not check(ready is not None, f"the demo did not start:\n{demo.text()}"):
        demo.finish(5)
        return
    pid = daemon_pid(ready.group(1))
    # The first verdict printed: the PLC client is inside its batch.
    check(demo.until(r"^  (SN|BAD)\d{6} ", 300) is not None, f"no verdict from the demo:\n{demo.text()}")
    started = time.monotonic()
    demo.process.send_signal(signal.SIGTERM)  # the demo alone, as `kill PID` does
    status = demo.finish(60)
    check(status == 143, f"the demo ended with {status} after SIGTERM, not 143:\n{demo.text()}")
    check(gone(pid), f"the daemon {pid} still runs after the demo was terminated")
    check(empty(tmp), f"left behind after SIGTERM: {sorted(p.name for p in tmp.iterdir())}")
    print(f"terminated demo: exit {status} {time.monotonic() - started:.1f} s after SIGTERM, nothing left", flush=True)


def failed_start(source, tmp):
    nothing = Path(tempfile.mkdtemp(prefix="hg-demo-nobin-"))
    demo = Demo(source, nothing, tmp, "--cycles", "2")
    status = demo.finish(120)
    nothing.rmdir()
    check(status == 1, f"a demo without programs ended with {status}, not 1:\n{demo.text()}")
    check("did not start" in demo.text(), f"the failed start is not named:\n{demo.text()}")
    check(empty(tmp), f"left behind after a failed start: {sorted(p.name for p in tmp.iterdir())}")
    print(f"failed demo: exit {status}, nothing left", flush=True)


def command_lines():
    """Every process's command line as the system shows it (ps reads the same files)."""
    out = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit():
            try:
                out.append((proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace"))
            except OSError:
                pass
    return out


def login(port, password):
    con = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    con.request("POST", "/api/login", body=json.dumps({"password": password, "name": "demo-tools"}),
                headers={"Content-Type": "application/json"})
    status = con.getresponse().status
    con.close()
    return status


def simline_secret(source, bin_dir, folder):
    password = "pw-" + os.urandom(8).hex()
    hash_file = password_hash_file(folder, password)
    digest = hash_file.read_text().strip()
    http_port = free_port()
    workdir = folder / "line"
    workdir.mkdir()
    line, out, _ = start_line(source, bin_dir, workdir, free_port(),
                              ["--http-port", str(http_port), "--hmi-password-hash-file", str(hash_file)])
    try:
        shown = [c for c in command_lines() if digest in c or password in c]
        check(not shown, f"the secret is on a command line: {shown}")
        check(login(http_port, password) == 200, "the password in the hash file does not sign in")
        check(login(http_port, password + "x") in (401, 403), "another password signs in")
    finally:
        stop_line(line, out)

    simline = str(source / "tools" / "simline")
    old = subprocess.run([simline, "--bin", str(bin_dir), "--http-port", str(free_port()), "--hmi-password-hash",
                          digest], capture_output=True, text=True, timeout=60)
    check(old.returncode == 2 and "--hmi-password-hash-file" in old.stderr,
          f"the hash on the command line: exit {old.returncode}, {old.stderr!r}")
    not_hash = folder / "not-a-hash"
    not_hash.write_text(password + "\n")
    bad = subprocess.run([simline, "--bin", str(bin_dir), "--http-port", str(free_port()), "--hmi-password-hash-file",
                          str(not_hash)], capture_output=True, text=True, timeout=60)
    check(bad.returncode == 2 and "not a crypt(3) hash" in bad.stderr and password not in bad.stderr,
          f"a file without a hash: exit {bad.returncode}, {bad.stderr!r}")
    missing = subprocess.run([simline, "--bin", str(bin_dir), "--http-port", str(free_port()),
                              "--hmi-password-hash-file", str(folder / "none")], capture_output=True, text=True,
                             timeout=60)
    check(missing.returncode == 2 and str(folder / "none") in missing.stderr,
          f"a missing file: exit {missing.returncode}, {missing.stderr!r}")
    print("simline: the hash read from a file, on no command line; the password signs in", flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="hg-demo-tools-"))
    try:
        simline_secret(args.source, args.bin, folder)
        failed_start(args.source, Path(tempfile.mkdtemp(dir=folder)))
        terminated_mid_batch(args.source, args.bin, Path(tempfile.mkdtemp(dir=folder)))
        served_and_interrupted(args.source, args.bin, Path(tempfile.mkdtemp(dir=folder)))
    finally:
        subprocess.run(["rm", "-rf", str(folder)], check=False)
    if failures:
        print(f"{len(failures)} check(s) failed", file=sys.stderr)
        return 1
    print("demo tools: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
