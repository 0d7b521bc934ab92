#!/usr/bin/env python3
"""Make the sample captures in this folder (see README.md here).

    python captures/make_samples.py            # raw dumps + a socat log recorded live

The raw dumps come from the synthetic conversation in analyzer/simulation/traffic.py; the
socat log is that conversation played in real time through real socat between
two pseudo-terminals, each side written with pyserial.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from analyzer.simulation.traffic import generate  # noqa: E402


def raw_dumps() -> None:
    tr = generate(400, seed=7, bit_error_rate=0.02, drop_ack_rate=0.02, noise_rate=0.02)
    with open(os.path.join(HERE, "demo-ctl.bin"), "wb") as f:
        f.write(tr.line_bytes("A"))
    with open(os.path.join(HERE, "demo-dev.bin"), "wb") as f:
        f.write(tr.line_bytes("B"))
    with open(os.path.join(HERE, "demo-bus.bin"), "wb") as f:
        f.write(tr.single_line())


def socat_log(seconds: float = 8.0) -> None:
    import serial

    socat = shutil.which("socat")
    if socat is None:
        print("socat not installed: demo-socat.log not remade", file=sys.stderr)
        return
    tr = generate(10_000, seed=11, bit_error_rate=0.03, drop_ack_rate=0.03, noise_rate=0.02)
    writes = [w for w in sorted(tr.writes, key=lambda w: w.t) if w.t < seconds]
    tmp = tempfile.mkdtemp()
    a, b = os.path.join(tmp, "ctl"), os.path.join(tmp, "dev")
    log = os.path.join(HERE, "demo-socat.log")
    with open(log, "wb") as err:
        proc = subprocess.Popen([socat, "-x", "-v", f"PTY,link={a},raw,echo=0", f"PTY,link={b},raw,echo=0"],
                                stderr=err)
    try:
        while not (os.path.exists(a) and os.path.exists(b)):
            time.sleep(0.01)
        ports = {"A": serial.Serial(a, 9600), "B": serial.Serial(b, 9600)}
        other = {"A": "B", "B": "A"}
        start = time.monotonic()
        for w in writes:
            # a write lands when its last byte would have arrived on a 9600-baud wire
            due = start + w.t + len(w.data) * tr.bt
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            ports[w.line].write(w.data)
            ports[w.line].flush()
            ports[other[w.line]].reset_input_buffer()   # nobody listens on the far ends
        time.sleep(0.3)
    finally:
        proc.terminate()
        proc.wait(5)


if __name__ == "__main__":
    raw_dumps()
    socat_log()
    print("wrote", ", ".join(sorted(f for f in os.listdir(HERE) if f.startswith("demo-"))))
