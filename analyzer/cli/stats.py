"""``gimbalscope stats``: counts, errors and latency per command and per device
(statuses per the pairing rules of spec §1.4.2-1.4.3 and docs/decoding.md)."""

from __future__ import annotations

import argparse
import sys

from dissectors.event import P_CHECKSUM, P_NOISE, P_TRUNCATED, STATUSES

from ..listeners import StatsListener
from ..output import dumps, fmt_seconds
from .common import add_filter_arg, add_input_args, build_filter, open_inputs, run_tap


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("stats", help="summarise a capture: counts, errors, latency",
                       description="Counts, errors and latency per command and per device.")
    add_input_args(p)
    p.add_argument("--format", choices=("text", "json"), default="text")
    add_filter_arg(p, "count only matching events")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    keep = build_filter(args.filter)
    capture = open_inputs(args)
    counter = StatsListener(keep)
    run_tap(capture, "stats", counter, progress=True, check=True)
    data = counter.stats.to_dict()
    if args.format == "json":
        sys.stdout.buffer.write(dumps(data) + b"\n")
    else:
        render(data)
    return 0


# what a noise event is, by its problem category (the deframer's: docs/decoding.md)
_NOISE_NAMES = {P_NOISE: ("noise run", "noise runs"), P_CHECKSUM: ("broken frame", "broken frames"),
                P_TRUNCATED: ("truncated frame", "truncated frames")}


def _broken(data: dict) -> str:
    """Checksum errors count every event with a checksum problem (the problems
    line's `bad checksum` and `bad length byte`); say which are not frames."""
    n = data["broken_frames"]
    if not n:
        return ""
    frames = data["checksum_errors"] - n
    return f" ({frames} in frames, {n} in {'a broken frame' if n == 1 else 'broken frames'} shown as noise)"


def _noise_kinds(data: dict) -> str:
    """Noise events are unframed bytes (the problems line's `noise`) and frames
    broken or cut short: say how many of each when they are not all noise runs."""
    kinds = data["noise"]["by_problem"]
    if set(kinds) <= {P_NOISE}:
        return ""
    parts = []
    for cat, n in kinds.items():
        one, many = _NOISE_NAMES.get(cat, (cat, cat))
        parts.append(f"{n} {one if n == 1 else many}")
    return " (" + ", ".join(parts) + ")"


def _lat(d: dict) -> list[str]:
    if not d["count"]:
        return ["", "", "", ""]
    return [fmt_seconds(d[k]) for k in ("min", "median", "p95", "max")]


def render(data: dict) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console(highlight=False, width=None if sys.stdout.isatty() else 150)
    dur = data["duration"]
    s = data["status"]
    console.print(f"[bold]{data['events']}[/] events, {data['commands']} commands"
                  + (f" over {dur:.3f} s" if dur is not None else " (no time in this capture)")
                  + "  bytes: " + ", ".join(f"line {k} {v}" for k, v in data["bytes"].items()))
    console.print("  ".join(f"{status} {s[status]}" for status in STATUSES) + "  "
                  f"retransmissions {data['retransmissions']}  orphans {data['orphans']}")
    console.print(f"checksum errors {data['checksum_errors']}{_broken(data)}  "
                  f"noise {data['noise']['events']} events / {data['noise']['bytes']} bytes{_noise_kinds(data)}")
    for rate in data.get("rate_changes", ()):
        by = f" (ACKed rate-set #{rate['request']})" if rate.get("request") is not None else ""
        console.print(f"link rate {rate['previous_baud']} → {rate['baud']} bps at #{rate['number']}{by}")
    if data["problems"]:
        console.print("problems (events per category): "
                      + ", ".join(f"{k} {v}" for k, v in data["problems"].items()))
    for title, key in (("per command", "by_command"), ("per device (group.port.device)", "by_device")):
        table = Table(title=title, title_justify="left")
        for col in ("", "count", "ok", "nak", "nic", "no_ack", "no_res", "pend", "retx", "cksum",
                    "ACK min", "median", "p95", "max", "result med", "max"):
            table.add_column(col, justify="left" if not col else "right")
        for name, c in data[key].items():
            res = c["result_latency"]
            table.add_row(name, *(str(c[k]) for k in ("commands", *STATUSES, "retransmissions", "checksum_errors")),
                          *_lat(c["ack_latency"]),
                          fmt_seconds(res["median"]) if res["count"] else "",
                          fmt_seconds(res["max"]) if res["count"] else "")
        console.print(table)
