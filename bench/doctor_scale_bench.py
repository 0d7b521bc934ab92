#!/usr/bin/env python3
"""The wiring doctor on large untimed captures (issue: floods, doctor scale).

Builds two raw dumps (no time) of about 100k, 400k and 1.6M events with
``analyzer.simulation.traffic`` (a controller polling three gimbals, with bit errors, dropped
ACKs and noise), and a dump of random bytes; runs ``gimbalscope doctor`` and, for
comparison, ``gimbalscope stats`` on each, and prints seconds and peak RSS. The
doctor must grow linearly in time and stay flat in memory.

    python3 bench/doctor_scale_bench.py [--events 100000 400000 1600000] [--random-mb 50]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from analyzer.simulation.traffic import generate
from bench.measure import run_measured

EVENTS_PER_COMMAND = 2.55   # the generator's mix: command, ACK, often a result

# VmHWM, not ru_maxrss: Linux carries ru_maxrss over from the parent across fork


def build(events: int, out: str) -> list[str]:
    tr = generate(int(events / EVENTS_PER_COMMAND) + 1, baud=115200, seed=1,
                  bit_error_rate=0.005, drop_ack_rate=0.005, noise_rate=0.005)
    paths = [os.path.join(out, f"ctl-{events}.bin"), os.path.join(out, f"dev-{events}.bin")]
    for path, line in zip(paths, "AB"):
        with open(path, "wb") as f:
            f.write(tr.line_bytes(line))
    return paths


def measure(command: str, paths: list[str]) -> tuple[float, float]:
    """Seconds and peak RSS (MB) of ``gimbalscope COMMAND PATHS`` (output discarded)."""
    return run_measured([command, *paths, "--baud", "115200", "--format", "json"])

def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--events", type=int, nargs="*", default=[100_000, 400_000, 1_600_000])
    ap.add_argument("--random-mb", type=float, default=50.0, help="size of the random dump (0: skip)")
    ap.add_argument("--no-stats", action="store_true", help="run the doctor only")
    ap.add_argument("--keep", help="write the captures here and keep them")
    args = ap.parse_args()
    out = args.keep or tempfile.mkdtemp(prefix="gimbalscope-doctor-bench-")
    os.makedirs(out, exist_ok=True)
    print(f"{'input':<28} {'doctor s':>9} {'peak RSS':>9} | {'stats s':>8} {'peak RSS':>9}", flush=True)
    inputs = [(f"two raw dumps, ~{n:,} events", lambda n=n: build(n, out)) for n in args.events]
    if args.random_mb:
        def random_dump() -> list[str]:
            path = os.path.join(out, "random.bin")
            with open(path, "wb") as f:
                f.write(os.urandom(int(args.random_mb * 1e6)))
            return [path]
        inputs.append((f"{args.random_mb:g} MB of random bytes", random_dump))
    for name, make in inputs:
        paths = make()
        dt, rss = measure("doctor", paths)
        row = f"{name:<28} {dt:>9.1f} {rss:>6.0f} MB"
        if not args.no_stats:
            sdt, srss = measure("stats", paths)
            row += f" | {sdt:>8.1f} {srss:>6.0f} MB"
        print(row, flush=True)


if __name__ == "__main__":
    main()
