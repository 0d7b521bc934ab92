"""``gimbalscope decode``: one line per event, like tshark, or JSON Lines.

Follows the event contract of docs/json-lines.md (frames per Table 1, fields per
Tables 4-18 via the command table in dissectors/commands.py).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from ..formats.marks import MarksError, notes_of
from ..info import CaptureInfo
from ..listeners import EventPrinter
from ..writers import FORMATS, open_format
from .common import (
    Subcommands,
    add_fields_arg,
    add_filter_arg,
    add_input_args,
    build_filter,
    fields_option,
    open_inputs,
    run_tap,
    warn,
)

COLOR = {"auto": None, "always": True, "never": False}   # --color: None = when standard output is a terminal


def register(sub: Subcommands) -> None:
    p = sub.add_parser("decode", help="print every event of a capture",
                       description="Decode a capture: one line per event, JSON Lines or CSV.")
    add_input_args(p)
    p.add_argument("--format", choices=tuple(FORMATS), default="text")
    add_filter_arg(p, 'show only matching events, e.g. \'status == "nak" or problems\'')
    add_fields_arg(p)
    p.add_argument("--color", choices=("auto", "always", "never"), default="auto")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    keep = build_filter(args.filter)
    fields = fields_option(args.fields, args.format == "csv", f"--format {args.format}")
    capture = open_inputs(args)
    info = CaptureInfo.of(capture, command="decode")
    # the writer of the format, to standard output, as convert picks one for a file
    options: dict[str, object] = {"color": COLOR[args.color], "marks": _marks(capture.inputs)} \
        if args.format == "text" else {}
    options.update(fields)
    writer = open_format(args.format, info, **options)
    # no bar when the lines go to the terminal: they show the progress themselves
    run_tap(capture, "decode", EventPrinter(writer, keep), info=info, progress=True, streams_stdout=True,
            check=True)
    return 0


def _marks(inputs: Sequence[str]) -> dict[int, str]:
    """The capture's marks and notes (analyzer/formats/marks.py); one that does not read is said."""
    try:
        return notes_of(inputs)
    except MarksError as e:
        warn(f"{e}: decoding without its marks")
        return {}
