#!/usr/bin/env python3
"""Wireshark export figures (issue: Wireshark interop). Prints:

  1. the pcapng writer alone (analyzer/formats/pcapng.py) against the Python
     pcapng package's writer, when it is installed: packets/s for the same
     packets (the reason this one is written by hand)
  2. `gimbalscope export LOG -o F.pcapng` of a socat log of saturated
     115200-baud traffic against `decode --format jsonl` of it: events/s,
     bytes per packet, peak memory
  3. `decode F.pcapng` (reading it back), and tshark reading the file with the
     dissector (`-T fields`), events/s, when tshark is installed

    python3 bench/pcapng_bench.py [--events 250000]
"""

from __future__ import annotations

import argparse
import io
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "bench"))

from export_bench import make_logs
from measure import run_measured


def writer_rate(packets: int) -> None:
    from analyzer.formats.pcapng import PcapngStream
    data = bytes(60)
    stream = PcapngStream(io.BytesIO(), "bench")
    iface = stream.add_interface(252, "A")
    t = time.perf_counter()
    for i in range(packets):
        stream.packet(iface, 1_700_000_000_000_000_000 + i * 1000, data, "bad checksum" if i % 10 == 0 else None)
    ours = packets / (time.perf_counter() - t)
    print(f"pcapng writer (ours): {ours:,.0f} packets/s")
    try:
        from pcapng import FileWriter, blocks
    except ImportError:
        print("pcapng package: not installed (pip install python-pcapng to compare)")
        return
    shb = blocks.SectionHeader(options={"shb_userappl": "bench"})
    shb.new_member(blocks.InterfaceDescription, link_type=252, options={"if_name": "A", "if_tsresol": b"\x09"})
    writer = FileWriter(io.BytesIO(), shb)
    n = min(packets, 50_000)
    t = time.perf_counter()
    for i in range(n):
        epb = shb.new_member(blocks.EnhancedPacket)
        epb.interface_id = 0
        epb.timestamp_high, epb.timestamp_low = divmod(1_700_000_000_000_000_000 + i * 1000, 1 << 32)
        epb.packet_data = data
        if i % 10 == 0:
            epb.options["opt_comment"] = "bad checksum"
        writer.write_block(epb)
    print(f"pcapng package writer: {n / (time.perf_counter() - t):,.0f} packets/s")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--events", type=int, default=250_000)
    args = ap.parse_args()
    writer_rate(200_000)
    work = tempfile.mkdtemp(prefix="gimbalscope-pcapng-bench-")
    try:
        log = make_logs(work, 1, args.events)[0]
        out = os.path.join(work, "out.pcapng")
        dt_jsonl, rss_jsonl = run_measured(["decode", log, "--format", "jsonl", "--baud", "115200"])
        dt_pcap, rss_pcap = run_measured(["export", log, "-o", out, "--baud", "115200", "-q"])
        import analyzer
        n = sum(1 for ev in analyzer.open(log, baud=115200) if ev.kind != "rate")
        size = os.path.getsize(out)
        print(f"decode --format jsonl: {n / dt_jsonl:,.0f} events/s ({dt_jsonl:.1f} s, peak {rss_jsonl:.0f} MB)")
        print(f"export -o F.pcapng:    {n / dt_pcap:,.0f} events/s ({dt_pcap:.1f} s, peak {rss_pcap:.0f} MB), "
              f"{size / n:.1f} bytes/packet, {n:,} packets")
        dt_back, rss_back = run_measured(["decode", out, "--format", "jsonl"])
        print(f"decode F.pcapng --format jsonl: {n / dt_back:,.0f} events/s ({dt_back:.1f} s, peak {rss_back:.0f} MB)")
        tshark = shutil.which("tshark")
        if tshark:
            home = os.path.join(work, "home")
            env = dict(os.environ, HOME=home)
            subprocess.run([sys.executable, "-m", "analyzer", "wireshark", "install"], env=env, cwd=ROOT,
                           check=True, capture_output=True)
            t = time.perf_counter()
            subprocess.run([tshark, "-r", out, "-T", "fields", "-e", "gimbal.kind", "-e", "gimbal.azimuth_deg"],
                           env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            dt = time.perf_counter() - t
            print(f"tshark -T fields with the dissector: {n / dt:,.0f} events/s ({dt:.1f} s)")
        else:
            print("tshark: not installed")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
