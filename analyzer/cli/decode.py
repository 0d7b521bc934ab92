"""``gimbalscope decode``: one line per event, like tshark, or JSON Lines.

Follows the event contract of docs/json-lines.md (frames per Table 1, fields per
Tables 4-18 via the command table in dissectors/commands.py).
"""

from __future__ import annotations

import argparse

from ..listeners import EventPrinter
from ..output import JsonLinesSink, TextSink
from .common import add_filter_arg, add_input_args, build_filter, open_inputs, run_tap


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("decode", help="print every event of a capture",
                       description="Decode a capture: one line per event, or JSON Lines.")
    add_input_args(p)
    p.add_argument("--format", choices=("text", "jsonl"), default="text")
    add_filter_arg(p, 'show only matching events, e.g. \'status == "nak" or problems\'')
    p.add_argument("--color", choices=("auto", "always", "never"), default="auto")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    keep = build_filter(args.filter)
    capture = open_inputs(args)
    if args.format == "jsonl":
        sink = JsonLinesSink()
    else:
        sink = TextSink(color={"auto": None, "always": True, "never": False}[args.color])
    # no bar when the lines go to the terminal: they show the progress themselves
    run_tap(capture, "decode", EventPrinter(sink, keep), progress=True, streams_stdout=True)
    return 0
