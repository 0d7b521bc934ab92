#!/usr/bin/env python3
"""Logic captures: samples a second through the software UART, and memory
(issue 28: a 10-minute two-channel capture at 1 MHz decodes at >= 20 M
samples/s with flat memory).

Makes a second of two channels at 1 MHz carrying a controller polling a gimbal
at 9600 baud (a P? command, its ACK and its result, every 50 ms), and gives it
MINUTES x 60 times over as a sigrok session written by this script (the same
zip layout sigrok writes: version, metadata, logic-1-N chunks of 4 MB), then
decodes it with ``gimbalscope decode --format jsonl`` in a child process (output
discarded) and prints samples/s,
events/s, MB/s of samples and the peak memory, at two lengths to show memory
stays flat.

    python3 bench/logic_bench.py [--minutes 10] [--keep DIR]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from bench.measure import run_measured
from tests.conftest import frame
from tests.waveforms import back_to_back, pack, uart_levels

RATE = 1_000_000
CHUNK = 4 << 20      # sigrok writes its samples in chunks of about this size
EVENTS_A_SECOND = 60   # 20 exchanges a second: command, ACK, result


def one_second() -> bytes:
    command = frame((1, 1, 1), 0, b"P?")
    result = frame((0, 1, 1), 1, b"0FA0FC18")
    a_chars, b_chars = [], []
    for k in range(20):
        t = k * 0.05
        a_chars += back_to_back(command, t + 0.001, 9600)
        b_chars += back_to_back(b"\x06", t + 0.012, 9600) + back_to_back(result, t + 0.016, 9600)
    a = uart_levels(a_chars, RATE, 9600, 1.0)
    b = uart_levels(b_chars, RATE, 9600, 1.0)
    return pack(a, b)


def write_session(path: str, seconds: int) -> None:
    second = one_second()
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as z:
        z.writestr("version", "2")
        z.writestr("metadata", "[global]\nsigrok version=0.5.2\n\n[device 1]\ncapturefile=logic-1\n"
                               "total probes=2\nsamplerate=1 MHz\ntotal analog=0\nprobe1=TX\nprobe2=RX\n"
                               "unitsize=1\n")
        per_chunk = CHUNK // len(second) or 1
        for n, start in enumerate(range(0, seconds, per_chunk), start=1):
            z.writestr(f"logic-1-{n}", second * min(per_chunk, seconds - start))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--keep", metavar="DIR", help="keep the sessions here")
    args = ap.parse_args()
    folder = args.keep or tempfile.mkdtemp(prefix="logic-bench-")
    os.makedirs(folder, exist_ok=True)
    for minutes in (args.minutes / 5, args.minutes):
        seconds = max(1, int(minutes * 60))
        path = os.path.join(folder, f"logic-{seconds}s.sr")
        if not os.path.exists(path):
            write_session(path, seconds)
        samples = seconds * RATE
        secs, peak = run_measured(["decode", path, "--format", "jsonl", "-q"])
        events = EVENTS_A_SECOND * seconds
        print(f"{seconds:5d} s of 2 channels at 1 MHz ({os.path.getsize(path) / 1e6:.1f} MB .sr): "
              f"{secs:.2f} s, {samples / secs / 1e6:.1f} M samples/s ({samples / secs / 1e6:.1f} MB/s of "
              f"samples), {events / secs:,.0f} events/s ({events:,} events), peak memory {peak:.0f} MB")
    if not args.keep:
        for name in os.listdir(folder):
            os.unlink(os.path.join(folder, name))
        os.rmdir(folder)
    return 0


if __name__ == "__main__":
    sys.exit(main())
