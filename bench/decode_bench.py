#!/usr/bin/env python3
"""Decode throughput and memory (issue: dissection).

Builds a large synthetic capture (>= 1M events by default: a controller polling
three gimbals at 115200 baud with bit errors, dropped ACKs and noise), writes it
as two raw dumps, a single-line dump and a socat log, then prints for each:

  (a) deframe + dissect + pair through the Python API (iterating
      `analyzer.open(*paths, baud=115200)` in a child process): events/s, MB/s, peak RSS
  (b) `gimbalscope decode --format jsonl > /dev/null`: events/s, MB/s, peak RSS

and peak memory at two capture sizes, to show it stays flat.
Targets on a 2-core machine: (a) >= 400k events/s, (b) >= 200k events/s (two raw dumps).

It says whether the deframer's C loop (dissectors/_deframe.c) was in use;
GIMBALSCOPE_PURE=1 measures the pure-Python loop instead.

    python3 bench/decode_bench.py [--events 1000000] [--keep DIR]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from analyzer.simulation.traffic import generate
from bench.measure import run_measured
from dissectors.deframer import COMPILED

EVENTS_PER_COMMAND = 2.55   # measured mix of the generator: command, ACK, often a result


def build(events: int, out: str, seed: int = 1) -> dict[str, list[str]]:
    tr = generate(int(events / EVENTS_PER_COMMAND) + 1, baud=115200, seed=seed,
                  bit_error_rate=0.005, drop_ack_rate=0.005, noise_rate=0.005)
    paths = {"two raw dumps": [os.path.join(out, "ctl.bin"), os.path.join(out, "dev.bin")],
             "single-line dump": [os.path.join(out, "bus.bin")],
             "socat log": [os.path.join(out, "tap.log")]}
    with open(paths["two raw dumps"][0], "wb") as f:
        f.write(tr.line_bytes("A"))
    with open(paths["two raw dumps"][1], "wb") as f:
        f.write(tr.line_bytes("B"))
    with open(paths["single-line dump"][0], "wb") as f:
        f.write(tr.single_line())
    with open(paths["socat log"][0], "w") as f:
        f.write(tr.socat_log())
    return paths


def size_mb(paths: list[str]) -> float:
    return sum(os.path.getsize(p) for p in paths) / 1e6


# the API run, in a child process of its own: its peak RSS is decoding's alone
_API = ("import sys, time, analyzer; t = time.perf_counter(); n = 0\n"
        "for _ev in analyzer.open(*sys.argv[1:], baud=115200):\n    n += 1\n"
        "dt = time.perf_counter() - t\n"
        "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]\n"
        "print(n, dt, hwm)")


def api_run(paths: list[str]) -> tuple[int, float, float]:
    """Events, seconds and peak RSS (MB) of iterating ``analyzer.open(*paths)``."""
    proc = subprocess.run([sys.executable, "-c", _API, *paths], capture_output=True, text=True, cwd=ROOT,
                          check=False)
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    n, dt, hwm = proc.stdout.split()
    return int(n), float(dt), int(hwm) / 1024


def cli_run(paths: list[str]) -> tuple[float, float]:
    """Seconds and peak RSS (MB) of `gimbalscope decode --format jsonl > /dev/null`."""
    return run_measured(["decode", *paths, "--baud", "115200", "--format", "jsonl"])

def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--events", type=int, default=1_000_000)
    ap.add_argument("--keep", help="write the captures here and keep them")
    args = ap.parse_args()
    out = args.keep or tempfile.mkdtemp(prefix="gimbalscope-bench-")
    os.makedirs(out, exist_ok=True)
    t = time.perf_counter()
    paths = build(args.events, out)
    print(f"built captures of ~{args.events:,} events in {time.perf_counter() - t:.1f} s in {out}", flush=True)
    print(f"deframing loop: {'C (dissectors/_deframe.c)' if COMPILED else 'pure Python'}; "
          "targets (two raw dumps): (a) >= 400,000 events/s, (b) >= 200,000 events/s")
    print(f"{'input':<18} {'events':>10} {'MB':>6} | {'(a) API ev/s':>13} {'MB/s':>6} {'peak RSS':>9} | "
          f"{'(b) jsonl ev/s':>14} {'MB/s':>6} {'peak RSS':>9}")
    for name, p in paths.items():
        n, dt, api_rss = api_run(p)
        cdt, rss = cli_run(p)
        mb = size_mb(p)
        print(f"{name:<18} {n:>10,} {mb:>6.1f} | {n / dt:>13,.0f} {mb / dt:>6.2f} {api_rss:>6.0f} MB | "
              f"{n / cdt:>14,.0f} {mb / cdt:>6.2f} {rss:>6.0f} MB", flush=True)
    # memory flat in capture size: peak RSS of the CLI on a quarter-size capture
    small = tempfile.mkdtemp(prefix="gimbalscope-bench-small-")
    small_paths = build(args.events // 4, small, seed=2)
    for name in ("two raw dumps", "socat log"):
        _, rss_small = cli_run(small_paths[name])
        _, rss_big = cli_run(paths[name])
        print(f"peak RSS, {name}: {rss_small:.0f} MB at {args.events // 4:,} events, "
              f"{rss_big:.0f} MB at {args.events:,} events")
    print(f"this process: peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB "
          "(includes building the captures in memory)")


if __name__ == "__main__":
    main()
