"""Shared by the benchmarks: run one ``gimbalscope`` command in a child process and
report its wall time and peak resident memory."""

from __future__ import annotations

import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# VmHWM, not ru_maxrss: Linux carries ru_maxrss over from the parent across fork
_MEASURED = ("import sys; from analyzer.cli.main import main; rc = main(sys.argv[1:]); sys.stdout.flush(); "
             "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]; "
             "print(hwm, file=sys.stderr); sys.exit(rc)")


def run_measured(args: list[str]) -> tuple[float, float]:
    """Seconds and peak RSS (MB) of ``gimbalscope ARGS`` with its output discarded."""
    t = time.perf_counter()
    with open(os.devnull, "wb") as null:
        proc = subprocess.run([sys.executable, "-c", _MEASURED, *args], stdout=null, stderr=subprocess.PIPE,
                              text=True, cwd=ROOT, check=False)
    dt = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    return dt, int(proc.stderr.strip().splitlines()[-1]) / 1024
