#!/usr/bin/env python3
"""What serving Foxglove costs a live tap (``--foxglove``).

Feeds two pseudo-terminals with saturated 115200-baud traffic (as item 4 of
bench/mcap_bench.py does) into ``gimbalscope live A B``: plain, with ``--foxglove``
and no client, and with ``--foxglove`` and a WebSocket client subscribed to every
channel, draining what comes. Prints, for each, the tap's CPU as a share of one
core, events/s and (with the client) messages/s received. Target: under 20% of
one core serving.

    python3 bench/foxglove_bench.py [--seconds 10] [--record]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import tty

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from mcap_bench import BAUD, cpu_seconds, saturated
from websockets.sync.client import connect

SETTLE = 1.5   # seconds for the tap (and the client) to start before the traffic


class Drain:
    """A Foxglove WebSocket client subscribed to every channel, counting what comes."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.messages = 0
        self.bytes = 0
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        end = time.monotonic() + 30
        while True:
            try:
                ws = connect(f"ws://127.0.0.1:{self.port}", subprotocols=["foxglove.sdk.v1"], max_size=None)
                break
            except OSError:
                if time.monotonic() > end:
                    raise
                time.sleep(0.05)
        with ws:
            subs = 0
            try:
                for msg in ws:
                    if isinstance(msg, bytes):
                        self.messages += 1
                        self.bytes += len(msg)
                        continue
                    op = json.loads(msg)
                    if op["op"] == "advertise":
                        new = [{"id": subs + k + 1, "channelId": ch["id"]} for k, ch in enumerate(op["channels"])]
                        subs += len(new)
                        ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
            except Exception:   # noqa: BLE001, S110 - the tap stopped: the connection is gone
                pass


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def feed(tr, line: str, fd: int, stop: threading.Event) -> None:
    """Each line's bytes back to back at 115200 baud: saturated."""
    bt = 10 / BAUD
    start = time.monotonic()
    for w in (w for w in tr.writes if w.line == line):
        if stop.is_set():
            return
        delay = start + w.t + len(w.data) * bt - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        os.write(fd, w.data)


def live(seconds: float, extra: list[str], tmp: str, serve: bool, watch: bool = True) -> dict:
    """The tap's CPU share, events/s, and what a client received (``serve`` and ``watch``)."""
    ptys = []
    for _ in range(2):
        m, s = os.openpty()
        tty.setraw(s)
        ptys.append((m, s, os.ttyname(s)))
    out = os.path.join(tmp, "events.jsonl")
    port = free_port()
    args = [sys.executable, "-m", "analyzer", "live", ptys[0][2], ptys[1][2], "--baud", str(BAUD), "--format",
            "jsonl", *extra] + (["--foxglove", f"127.0.0.1:{port}"] if serve else [])
    with open(out, "wb") as sink:
        proc = subprocess.Popen(args, stdout=sink, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    client = Drain(port) if serve and watch else None
    time.sleep(SETTLE)
    tr = saturated(int(seconds * 1500) + 100, seed=3)
    stop = threading.Event()
    threads = [threading.Thread(target=feed, args=(tr, line, ptys[k][0], stop), daemon=True)
               for k, line in enumerate("AB")]
    cpu0, wall0 = cpu_seconds(proc.pid), time.monotonic()
    received0 = client.messages if client else 0
    for th in threads:
        th.start()
    time.sleep(seconds)
    cpu1, wall1 = cpu_seconds(proc.pid), time.monotonic()
    received = (client.messages - received0) if client else 0
    stop.set()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    if proc.returncode != 0:
        raise SystemExit(err)
    with open(out, "rb") as f:
        events = sum(1 for _ in f)
    for m, s, _ in ptys:
        os.close(m)
        os.close(s)
    wall = wall1 - wall0
    return {"cpu": (cpu1 - cpu0) / wall, "events": events / wall, "messages": received / wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--record", action="store_true", help="also record (--record) in both runs")
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="gimbalscope-foxglove-bench-")
    extra = ["--record", os.path.join(tmp, "rec.mcap")] if args.record else []
    what = "live --record" if args.record else "live"
    plain = live(args.seconds, extra, tmp, serve=False)
    unwatched = live(args.seconds, extra, tmp, serve=True, watch=False)
    served = live(args.seconds, extra, tmp, serve=True)
    print(f"two saturated {BAUD}-baud ptys, {args.seconds:.0f} s each:")
    print(f"  {what}:                        {plain['cpu']:.1%} of one core, {plain['events']:,.0f} events/s")
    print(f"  {what} --foxglove, no client:  {unwatched['cpu']:.1%} of one core, "
          f"{unwatched['events']:,.0f} events/s")
    print(f"  {what} --foxglove, a client:   {served['cpu']:.1%} of one core, {served['events']:,.0f} events/s, "
          f"{served['messages']:,.0f} messages/s to a client subscribed to everything (target < 20%)")


if __name__ == "__main__":
    main()
