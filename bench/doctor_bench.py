#!/usr/bin/env python3
"""Wiring doctor figures (issue: wiring doctor). For each simulated fault, the
installation runs on ptys and ``gimbalscope doctor`` listens on its tap ports;
prints whether the fault's finding came, after how many seconds of traffic, and
any other warning raised. A clean run must raise none.

    python3 bench/doctor_bench.py [--seconds 10] [FAULT ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from analyzer.simulation import scenario
from tests.integration.test_doctor import EXPECTED


def run(fault: str, seconds: float) -> dict:
    site = scenario.build(set() if fault == "clean" else {fault}, clean=True)
    a, b = site.link.tap_ports
    proc = subprocess.Popen([sys.executable, "-m", "analyzer", "doctor", a, b, "--seconds", str(seconds),
                             "--format", "json"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            cwd=ROOT)
    time.sleep(0.5)
    site.start()
    out, _ = proc.communicate(timeout=seconds + 60)
    site.stop()
    return json.loads(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("faults", nargs="*", default=[*sorted(EXPECTED), "clean"])
    ap.add_argument("--seconds", type=float, default=10.0)
    args = ap.parse_args()
    print(f"{'fault':12} {'finding':24} {'found':6} {'after (s of traffic)':>21}  other warnings")
    for fault in args.faults:
        report = run(fault, args.seconds)
        raised = {f["code"]: f for f in report["findings"] if f["severity"] != "info"}
        if fault == "clean":
            print(f"{'clean':12} {'(none expected)':24} {'-':6} {'-':>21}  {', '.join(raised) or 'none'}")
            continue
        code, _consequences = EXPECTED[fault]
        hit = raised.get(code)
        after = f"{hit['after']:.1f}" if hit and hit["after"] is not None else "-"
        others = ", ".join(c for c in raised if c != code) or "none"
        print(f"{fault:12} {code:24} {'yes' if hit else 'NO':6} {after:>21}  {others}", flush=True)


if __name__ == "__main__":
    main()
