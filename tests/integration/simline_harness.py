"""The simulated line for the end-to-end tests (docs/contracts.md §7): start
tools/simline in a work folder, wait for its ready file under a deadline,
stop it; the checks collect failures instead of stopping at the first."""
import argparse
import ctypes
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print(f"FAILED: {message}", file=sys.stderr, flush=True)
    return condition


def die_with_parent():
    """In the child: SIGTERM when this script ends, however it ends, so the line never outlives it."""
    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def ready_values(workdir):
    return dict(line.split("=", 1) for line in (workdir / "simline.ready").read_text().splitlines() if "=" in line)


def start_line(source, bin_dir, workdir, plc_port, extra=(), timeout_s=120):
    """tools/simline with `extra` options; returns (process, its output file, the ready file's values)."""
    out = open(workdir / "simline.out", "w")
    line = subprocess.Popen([str(source / "tools" / "simline"), "--bin", str(bin_dir), "--workdir", str(workdir),
                             "--plc-port", str(plc_port), "--fixture-port", "0", *extra],
                            stdout=out, stderr=subprocess.STDOUT, start_new_session=True, preexec_fn=die_with_parent)
    deadline = time.monotonic() + timeout_s
    while not (workdir / "simline.ready").exists():
        if line.poll() is not None:
            print((workdir / "simline.out").read_text(), file=sys.stderr)
            raise SystemExit(f"tools/simline exited with {line.returncode} before the line was ready")
        if time.monotonic() > deadline:
            raise SystemExit(f"the simulated line was not ready within {timeout_s} s")
        time.sleep(0.1)
    return line, out, ready_values(workdir)


def stop_line(line, out):
    """SIGTERM, a clean exit within 40 s, else SIGKILL to the whole group (a failure)."""
    try:
        if line.poll() is None:
            line.send_signal(signal.SIGTERM)
            try:
                check(line.wait(timeout=40) == 0, f"tools/simline exit status {line.returncode} after SIGTERM")
            except subprocess.TimeoutExpired:
                check(False, "tools/simline did not stop within 40 s of SIGTERM")
    finally:
        if line.poll() is None:
            os.killpg(line.pid, signal.SIGKILL)
            line.wait()
        out.close()


def password_hash_file(folder, password):
    """The crypt(3) hash of `password` in folder/hmi-password-hash (mode 0600), for tools/simline
    --hmi-password-hash-file; openssl reads the password on stdin, so neither is on a command line."""
    digest = subprocess.run(["openssl", "passwd", "-6", "-stdin"], input=password + "\n", capture_output=True,
                            text=True, check=True).stdout.strip()
    path = folder / "hmi-password-hash"
    path.touch(mode=0o600)
    path.write_text(digest + "\n")
    return path


def maintenance(path, request, timeout_s=10):
    """One request on the daemon's maintenance socket (docs/daemon.md); the answer as a dict."""
    import json
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(timeout_s)
        s.connect(path)
        s.sendall((json.dumps(request) + "\n").encode())
        data = b""
        while not data.endswith(b"\n"):
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
    return json.loads(data)


def test_args(extra=None):
    """The options every end-to-end test takes: --source, --bin, --screenshots (a folder, made here)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True, type=Path)
    ap.add_argument("--bin", required=True, type=Path)
    ap.add_argument("--screenshots", type=Path)
    if extra:
        extra(ap)
    args = ap.parse_args()
    if args.screenshots:
        args.screenshots.mkdir(parents=True, exist_ok=True)
    return args


def outcome(what, workdir):
    """The exit status of a test: 1 naming how many checks failed and where its files are, else 0."""
    if failures:
        print(f"{len(failures)} checks failed (work folder {workdir})", file=sys.stderr)
        return 1
    print(f"{what}: every check passed")
    return 0
