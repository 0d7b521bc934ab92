"""``gimbalscope stats``: counts, errors and latency per command and per device
(statuses per the pairing rules of spec §1.4.2-1.4.3 and docs/decoding.md)."""

from __future__ import annotations

import argparse
import sys

from ..listeners import StatsListener
from ..output import dumps
from .common import Subcommands, add_filter_arg, add_input_args, build_filter, open_inputs, run_tap
from .stored_stats import stored_stats


def register(sub: Subcommands) -> None:
    p = sub.add_parser("stats", help="summarise a capture: counts, errors, latency",
                       description="Counts, errors and latency per command and per device.")
    add_input_args(p)
    p.add_argument("--format", choices=("text", "json"), default="text")
    add_filter_arg(p, "count only matching events")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    keep = build_filter(args.filter)
    capture = open_inputs(args)
    data = stored_stats(capture, keep)   # what a recording stores, when it can be read
    if data is None:
        counter = StatsListener(keep)
        run_tap(capture, "stats", counter, progress=True, check=True)
        data = counter.stats.to_dict()
    if args.format == "json":
        sys.stdout.buffer.write(dumps(data) + b"\n")
    else:
        render(data)
    return 0


def render(data: dict) -> None:
    from rich.console import Console

    from ..formats.fit_width import FitLines
    from ..listeners.stats import counts_table, summary

    # piped, Rich takes the width from COLUMNS, else 80: the text fits it
    console = Console(highlight=False)
    console.print(FitLines(*summary(data)))
    console.print(counts_table("command", data["by_command"], "per command"))
    console.print(counts_table("device", data["by_device"], "per device (group.port.device)"))
