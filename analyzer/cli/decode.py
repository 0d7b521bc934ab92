"""``gimbalscope decode``: one line per event, like tshark, or JSON Lines.

Follows the event contract of docs/json-lines.md (frames per Table 1, fields per
Tables 4-18 via the command table in dissectors/commands.py).
"""

from __future__ import annotations

import argparse

from ..info import CaptureInfo
from ..listeners import EventPrinter
from ..writers import FORMATS, open_format
from .common import Subcommands, add_filter_arg, add_input_args, build_filter, open_inputs, run_tap

COLOR = {"auto": None, "always": True, "never": False}   # --color: None = when standard output is a terminal


def register(sub: Subcommands) -> None:
    p = sub.add_parser("decode", help="print every event of a capture",
                       description="Decode a capture: one line per event, or JSON Lines.")
    add_input_args(p)
    p.add_argument("--format", choices=tuple(FORMATS), default="text")
    add_filter_arg(p, 'show only matching events, e.g. \'status == "nak" or problems\'')
    p.add_argument("--color", choices=("auto", "always", "never"), default="auto")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    keep = build_filter(args.filter)
    capture = open_inputs(args)
    info = CaptureInfo.of(capture, command="decode")
    # the writer of the format, to standard output, as convert picks one for a file
    options = {"color": COLOR[args.color]} if args.format == "text" else {}
    writer = open_format(args.format, info, **options)
    # no bar when the lines go to the terminal: they show the progress themselves
    run_tap(capture, "decode", EventPrinter(writer, keep), info=info, progress=True, streams_stdout=True,
            check=True)
    return 0
