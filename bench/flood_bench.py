#!/usr/bin/env python3
"""Floods and huge noise (issue: floods).

(a) A live tap under a flood: ``gimbalscope live PTY --record`` on a pseudo-terminal
    while random bytes are pushed into it as fast as it takes them (or at --rate
    MB/s) for --seconds; prints the rate reached, the tap's RSS over time and at its
    peak, how long SIGTERM took to end it, and whether the recording holds every
    byte written.
(b) ``gimbalscope decode`` of a file of zero bytes (--zeros-mb): seconds and peak RSS.

    python3 bench/flood_bench.py [--seconds 20] [--rate MB/S] [--zeros-mb 100]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tty

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

# VmHWM, not ru_maxrss: Linux carries ru_maxrss over from the parent across fork
_MEASURED = ("import sys; from analyzer.cli.main import main; rc = main(sys.argv[1:]); sys.stdout.flush(); "
             "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]; "
             "print(hwm, file=sys.stderr); sys.exit(rc)")


def rss_mb(pid: int, key: str = "VmRSS") -> float | None:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith(key):
                    return int(line.split()[1]) / 1024
    except OSError:
        return None
    return None


def recorded_bytes(path: str) -> int:
    from mcap.reader import make_reader

    total = 0
    with open(path, "rb") as f:
        for _s, _c, m in make_reader(f).iter_messages(topics=["/serial/AB/raw"]):
            total += len(json.loads(m.data)["data"]) // 2
    return total


def flood(seconds: float, rate: float | None, out: str) -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    port = os.ttyname(slave)
    rec = os.path.join(out, "flood.mcap")
    with open(os.path.join(out, "flood.err"), "w") as err, open(os.devnull, "wb") as null:
        proc = subprocess.Popen([sys.executable, "-m", "analyzer", "live", port, "--format", "jsonl",
                                 "--record", rec], stdout=null, stderr=err, cwd=ROOT)
    time.sleep(1.0)
    base = rss_mb(proc.pid)
    written = 0
    done = threading.Event()

    def writer() -> None:
        nonlocal written
        block = os.urandom(1 << 16)
        t0 = time.monotonic()
        while not done.is_set():
            if rate is not None and written > rate * 1e6 * (time.monotonic() - t0):
                time.sleep(0.001)
                continue
            written += os.write(master, block[:4096])

    th = threading.Thread(target=writer, daemon=True)
    t0 = time.monotonic()
    th.start()
    samples = []
    while time.monotonic() - t0 < seconds:
        time.sleep(1.0)
        samples.append(rss_mb(proc.pid) or 0.0)
    done.set()
    th.join()
    elapsed = time.monotonic() - t0
    time.sleep(1.0)                      # let the tap read what the pty still holds
    hwm = rss_mb(proc.pid, "VmHWM")
    t_term = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=600)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    term = time.monotonic() - t_term
    err.close()
    os.close(master)
    os.close(slave)
    print(f"(a) flood: {written / 1e6:.1f} MB in {elapsed:.1f} s ({written / 1e6 / elapsed:.2f} MB/s); "
          f"RSS {base:.0f} MB at start, each second: {' '.join(f'{s:.0f}' for s in samples)} MB; "
          f"peak {hwm:.0f} MB")
    print(f"    SIGTERM to exit: {term:.2f} s (exit code {proc.returncode})")
    try:
        got = recorded_bytes(rec)
        print(f"    recording holds {got:,} of {written:,} bytes written")
    except Exception as e:   # noqa: BLE001 - a recording cut short still tells something
        print(f"    recording unreadable: {e}")
    with open(os.path.join(out, "flood.err")) as f:
        lines = [x.rstrip() for x in f if "decod" in x]
    for line in lines[-3:]:
        print(f"    stderr: {line}")


def zeros(mb: float, out: str) -> None:
    path = os.path.join(out, "zeros.bin")
    with open(path, "wb") as f:
        block = bytes(1 << 20)
        f.writelines(block for _ in range(int(mb)))
    t = time.perf_counter()
    with open(os.devnull, "wb") as null:
        proc = subprocess.run([sys.executable, "-c", _MEASURED, "decode", path, "--format", "jsonl"],
                              stdout=null, stderr=subprocess.PIPE, text=True, cwd=ROOT, check=False)
    dt = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    hwm = int(proc.stderr.strip().splitlines()[-1]) / 1024
    print(f"(b) decode of {mb:g} MB of zero bytes: {dt:.1f} s, peak RSS {hwm:.0f} MB")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=20.0, help="how long to flood (0: skip)")
    ap.add_argument("--rate", type=float, help="MB/s to push (default: as fast as the tap takes them)")
    ap.add_argument("--zeros-mb", type=float, default=100.0, help="size of the zero file (0: skip)")
    args = ap.parse_args()
    out = tempfile.mkdtemp(prefix="gimbalscope-flood-")
    if args.seconds:
        flood(args.seconds, args.rate, out)
    if args.zeros_mb:
        zeros(args.zeros_mb, out)


if __name__ == "__main__":
    main()
