#!/usr/bin/env python3
"""MCAP recording and live-tap figures (issue: live tap and MCAP).

Prints:
  1. events/s when recording (decode + MCAP writer, `convert` of a raw capture)
  2. bytes per event and MB per hour of recording a saturated 115200-baud pair
     of lines, the default recording and a lean one (`--lean`: target <= 50),
     and that the lean one decodes to the same events
  3. events/s when re-dissecting an MCAP, and its share of raw-dump decode speed
     (target >= 60%); each decode the fastest of three
  4. `stats`, `export` and `decode` of the recording from its stored columns
     against `--redecode` (stats and export target >= 10x; decode reads no
     columns); `--opening REC` prints this figure alone, for a given recording
  5. CPU share of `gimbalscope live A B --record` while two ptys carry saturated
     115200-baud traffic (target < 20% of one core)

    python3 bench/mcap_bench.py [--events 300000] [--live-seconds 10] [--opening REC.mcap [--runs 1] [--no-decode]]
"""

from __future__ import annotations

import argparse
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

from measure import run_measured

import analyzer
from analyzer.info import CaptureInfo
from analyzer.runner import TapRunner
from analyzer.simulation.traffic import generate
from analyzer.writers.mcap import McapWriter

BAUD = 115200
EVENTS_PER_COMMAND = 2.55


def saturated(commands: int, seed: int = 1):
    """Back-to-back traffic at 115200 baud: answers as fast as devices give them."""
    return generate(commands, baud=BAUD, seed=seed, bit_error_rate=0.002, drop_ack_rate=0.002, noise_rate=0.002,
                    think=(0.0, 0.0002), answer_delay=(0.0002, 0.0005))


def decode_rate(paths: list[str], repeat: int = 3) -> tuple[int, float]:
    """Events, and events/s of the fastest of ``repeat`` decodes (the others met
    the machine's other work: the fastest is the closest to the code's own cost)."""
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        n = sum(1 for _ in analyzer.open(*paths, baud=BAUD))
        best = min(best, time.perf_counter() - t)
    return n, n / best


def record(paths: list[str], out: str, lean: bool = False) -> tuple[int, float]:
    cap = analyzer.open(*paths, baud=BAUD)
    t = time.perf_counter()
    info = CaptureInfo.of(cap, command="bench")
    n = TapRunner(cap, [McapWriter(out, info, lean=lean)], info=info).run()   # as convert records
    return n, n / (time.perf_counter() - t)


def columns_bytes(path: str) -> int:
    """Bytes of a recording's stored columns (docs/mcap.md, "Stored columns"): their
    chunks (each holds only them), the chunks' message indexes and index entries."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    ids = {c.id for c in summary.channels.values() if c.topic == "/gimbalscope/columns"}
    total = 0
    for index in summary.chunk_indexes:
        if index.message_index_offsets and set(index.message_index_offsets) <= ids:
            total += index.chunk_length + index.message_index_length + 80   # + its chunk index record
    return total


def opening(path: str, n: int, runs: int = 3, decode: bool = True) -> None:
    """Commands on the recording, reading its stored columns against decoding its
    raw bytes (--redecode): each the fastest of ``runs``, in a process of its own."""
    print(f"4. opening the recording of {n:,} events (each the fastest of {runs}), stored columns against "
          "--redecode (targets: stats and export >= 10x; decode reads no columns):")
    folder = tempfile.mkdtemp(prefix="gimbalscope-mcap-bench-export-")
    export = ["export", "-j", "1", "-o", os.path.join(folder, "ds")]
    for args in (["stats", "--format", "json"], export, *([["decode", "--format", "jsonl"]] if decode else [])):
        stored = min(run_measured([*args, path])[0] for _ in range(runs))
        decoded = min(run_measured([*args, path, "--redecode"])[0] for _ in range(runs))
        name = "export -j 1" if args is export else " ".join(args)
        print(f"   {name}: {stored:.2f} s against {decoded:.2f} s: {decoded / stored:.1f}x", flush=True)


def cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def live_cpu(seconds: float, out: str) -> tuple[float, int]:
    """CPU share of a live tap recording two saturated lines, fed through ptys."""
    ptys = []
    for _ in range(2):
        m, s = os.openpty()
        tty.setraw(s)
        ptys.append((m, s, os.ttyname(s)))
    proc = subprocess.Popen([sys.executable, "-m", "analyzer", "live", ptys[0][2], ptys[1][2], "--baud",
                             str(BAUD), "--format", "jsonl", "--record", out],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    time.sleep(1.0)
    tr = saturated(int(seconds * 1500) + 100, seed=3)
    bt = 10 / BAUD
    stop = threading.Event()

    def feed(line: str, fd: int) -> None:
        # each line carries its bytes back to back at 115200 baud: saturated
        start = time.monotonic()
        for w in (w for w in tr.writes if w.line == line):
            if stop.is_set():
                return
            due = start + w.t + len(w.data) * bt
            d = due - time.monotonic()
            if d > 0:
                time.sleep(d)
            os.write(fd, w.data)

    threads = [threading.Thread(target=feed, args=(line, ptys[k][0]), daemon=True) for k, line in enumerate("AB")]
    cpu0, wall0 = cpu_seconds(proc.pid), time.monotonic()
    for th in threads:
        th.start()
    time.sleep(seconds)
    cpu1, wall1 = cpu_seconds(proc.pid), time.monotonic()
    stop.set()
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=30)
    events = sum(1 for _ in analyzer.open(out))
    return (cpu1 - cpu0) / (wall1 - wall0), events


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--events", type=int, default=300_000)
    ap.add_argument("--live-seconds", type=float, default=10.0)
    ap.add_argument("--opening", metavar="RECORDING",
                    help="only figure 4, on this recording (made with its columns: e.g. tui_bench's 1M or 10M one)")
    ap.add_argument("--runs", type=int, default=3, help="figure 4: each the fastest of RUNS")
    ap.add_argument("--no-decode", action="store_true", help="figure 4 without decode (which reads no columns)")
    args = ap.parse_args()
    if args.opening:
        from tui_bench import recorded_events
        opening(args.opening, recorded_events(args.opening) or 0, args.runs, not args.no_decode)
        return
    tmp = tempfile.mkdtemp(prefix="gimbalscope-mcap-bench-")
    tr = saturated(int(args.events / EVENTS_PER_COMMAND))
    ctl, dev = os.path.join(tmp, "ctl.bin"), os.path.join(tmp, "dev.bin")
    with open(ctl, "wb") as f:
        f.write(tr.line_bytes("A"))
    with open(dev, "wb") as f:
        f.write(tr.line_bytes("B"))
    log = os.path.join(tmp, "tap.log")
    with open(log, "w") as f:
        f.write(tr.socat_log())
    wire_seconds = max(w.t for w in tr.writes)
    busy = sum(len(w.data) for w in tr.writes) * 10 / BAUD / 2 / wire_seconds

    n, raw_rate = decode_rate([log])
    out = os.path.join(tmp, "rec.mcap")
    n_rec, rec_rate = record([log], out)
    _n_mcap, mcap_rate = decode_rate([out])
    size = os.path.getsize(out)
    print(f"capture: {n:,} events, {wire_seconds:.0f} s of {BAUD}-baud traffic on two lines, "
          f"each line busy {busy:.0%} of the time")
    print(f"1. recording (decode + MCAP writer): {rec_rate:,.0f} events/s")
    per_hour = size / 1e6 / wire_seconds * 3600
    print(f"2. MCAP size, default recording: {size / n_rec:.1f} bytes per event; {size / 1e6:.1f} MB for "
          f"{wire_seconds:.0f} s = {per_hour:.0f} MB per hour of this conversation running flat out; "
          f"{per_hour / busy:.0f} MB per hour if both lines were 100% busy")
    cols = columns_bytes(out)
    print(f"   of which the stored columns: {cols / n_rec:.1f} bytes per event (target <= 20): "
          f"{(size - cols) / n_rec:.1f} without them")
    lean = os.path.join(tmp, "lean.mcap")
    n_lean, lean_rate = record([log], lean, lean=True)
    lean_size = os.path.getsize(lean)
    same = [e.to_dict() for e in analyzer.open(lean)] == [e.to_dict() for e in analyzer.open(out, redecode=True)]
    print(f"   lean (--lean, no stored columns): {lean_size / n_lean:.1f} bytes per event (target <= 50); "
          f"{lean_size / 1e6 / wire_seconds * 3600:.0f} MB per hour; recording {lean_rate:,.0f} events/s; "
          f"decodes to the same events: {'yes' if same else 'NO'}")
    dump_rate = decode_rate([ctl, dev])[1]
    print(f"3. re-dissecting the MCAP (each decode the fastest of 3): {mcap_rate:,.0f} events/s; decoding the same capture from its socat "
          f"log: {raw_rate:,.0f} events/s; from raw dumps: {dump_rate:,.0f} events/s")
    print(f"   MCAP re-dissection is {mcap_rate / dump_rate:.0%} of raw-dump decode speed (target >= 60%)")
    opening(out, n_rec, args.runs)
    share, events = live_cpu(args.live_seconds, os.path.join(tmp, "live.mcap"))
    print(f"5. live --record on two saturated {BAUD}-baud ptys: {share:.0%} of one core over "
          f"{args.live_seconds:.0f} s ({events:,} events recorded; target < 20%)")


if __name__ == "__main__":
    main()
