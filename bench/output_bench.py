#!/usr/bin/env python3
"""What the text output's colour and the progress bar cost (issue: progress and
colour).

Builds the synthetic capture of bench/decode_bench.py (>= 1M events by default,
two raw dumps) and prints:

  (a) `gimbalscope decode` as text to a file, `--color never` against `--color
      always` (the same escape codes a terminal gets): seconds each and the
      ratio. Target: colour <= 1.3x plain.
  (b) `gimbalscope stats` with standard error on a pseudo-terminal and the bar
      shown from the start (GIMBALSCOPE_PROGRESS_DELAY=0), against standard
      error to /dev/null (no bar): seconds each and the overhead.

Wall-clock figures: run it on a quiet machine, or repeat it.

    python3 bench/output_bench.py [--events 1000000] [--keep DIR]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from bench.decode_bench import build, size_mb

CLI = [sys.executable, "-m", "analyzer"]
TARGET_RATIO = 1.3


def _env(**extra: str) -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""), **extra)
    env.pop("NO_COLOR", None)   # colour as a terminal gets it
    return env


def timed(args: list[str], stdout, stderr, env: dict[str, str]) -> float:
    t = time.perf_counter()
    subprocess.run(CLI + args, stdout=stdout, stderr=stderr, env=env, check=True)
    return time.perf_counter() - t


def decode_to_file(paths: list[str], color: str, out: str) -> float:
    with open(out, "w") as f:
        return timed(["decode", *paths, "--baud", "115200", "--color", color], f, subprocess.DEVNULL, _env())


def stats_with_bar(paths: list[str]) -> tuple[float, int]:
    """Seconds of `stats` with standard error on a pseudo-terminal, bar shown at
    once; and how many bytes the bar wrote there."""
    master, slave = os.openpty()
    written = [0]

    def drain() -> None:
        while True:
            try:
                data = os.read(master, 1 << 16)
            except OSError:
                return
            if not data:
                return
            written[0] += len(data)

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    try:
        seconds = timed(["stats", *paths, "--baud", "115200"], subprocess.DEVNULL, slave,
                        _env(GIMBALSCOPE_PROGRESS_DELAY="0"))
    finally:
        os.close(slave)
        reader.join(5)
        os.close(master)
    return seconds, written[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--events", type=int, default=1_000_000)
    ap.add_argument("--keep", metavar="DIR", help="build the capture in DIR and keep it (reused if there)")
    args = ap.parse_args()
    out = args.keep or tempfile.mkdtemp(prefix="gimbalscope-bench-")
    os.makedirs(out, exist_ok=True)
    paths = [os.path.join(out, "ctl.bin"), os.path.join(out, "dev.bin")]
    if not all(os.path.exists(p) for p in paths):
        print(f"building a capture of about {args.events} events ...", flush=True)
        paths = build(args.events, out)["two raw dumps"]
    print(f"capture: two raw dumps, {size_mb(paths):.1f} MB")

    text = os.path.join(out, "decoded.txt")
    plain = decode_to_file(paths, "never", text)
    colour = decode_to_file(paths, "always", text)
    ratio = colour / plain
    print(f"(a) decode text, --color never:  {plain:7.2f} s")
    print(f"    decode text, --color always: {colour:7.2f} s   ratio {ratio:.2f}x "
          f"({'meets' if ratio <= TARGET_RATIO else 'misses'} the {TARGET_RATIO}x target)")

    quiet = timed(["stats", *paths, "--baud", "115200"], subprocess.DEVNULL, subprocess.DEVNULL, _env())
    barred, written = stats_with_bar(paths)
    print(f"(b) stats, no bar (stderr not a terminal): {quiet:7.2f} s")
    print(f"    stats, bar from the start on a pty:    {barred:7.2f} s   overhead "
          f"{(barred / quiet - 1) * 100:+.1f}% ({written} bytes of bar drawn)")
    if not args.keep:
        for name in os.listdir(out):
            os.unlink(os.path.join(out, name))
        os.rmdir(out)


if __name__ == "__main__":
    main()
