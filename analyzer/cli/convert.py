"""``gimbalscope convert``: captures to an MCAP recording or to JSON Lines, the
format chosen by the output's suffix (the writer registry, analyzer/writers).

MCAP holds what a live recording holds (the MCAP topics of analyzer/writers/mcap_recorder.py):
raw bytes per line, decoded events (Tables 4-18 via the command table),
transactions and foxglove.Log anomalies, with a metadata record. JSON Lines are
the lines ``decode --format jsonl`` prints.

The output is checked before any work (never over an input, ``--force`` to
replace a file) and written beside the target, renamed onto it only when whole:
a failed conversion leaves no file behind (the writer base, analyzer/writers/base.py).
"""

from __future__ import annotations

import argparse
import os
import sys

from ..errors import UsageError
from ..info import CaptureInfo
from ..outfile import check_output, show
from ..writers import WRITERS, open_writer, writer_class
from .common import Subcommands, add_fields_arg, add_input_args, fields_option, open_inputs, run_tap


def register(sub: Subcommands) -> None:
    p = sub.add_parser("convert", help="convert a capture to MCAP, JSON Lines, pcapng or CSV (" + ", ".join(WRITERS) + ")",
                       description="Convert a capture (any input decode reads: see INPUT) to MCAP "
                                   "(re-dissectable, Foxglove-readable), JSON Lines, pcapng (Wireshark) or CSV; the "
                                   "output's suffix chooses: " + ", ".join(WRITERS) + ".")
    add_input_args(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT" + "|OUT".join(WRITERS))
    p.add_argument("--force", action="store_true", help="overwrite OUT if it exists")
    p.add_argument("--lean", action="store_true",
                   help="MCAP: a lean recording (no /events, raw reads batched; about a third the size; "
                        "docs/mcap.md)")
    p.add_argument("--site", metavar="NAME", help="where the capture was made, kept in a recording's metadata "
                                                   "(gimbalscope export puts it in the dataset's site column)")
    add_fields_arg(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    check_output(args.output, args.inputs, force=args.force)   # first: an output over an input is worst
    writer_class(args.output)                                    # then: a format we write
    suffix = os.path.splitext(args.output)[1].lower()
    options: dict[str, object] = dict(fields_option(args.fields, suffix == ".csv", show(args.output)))
    if args.lean:
        if suffix != ".mcap":
            raise UsageError(f"--lean is for MCAP recordings (.mcap), not {show(args.output)}")
        options["lean"] = True
    capture = open_inputs(args)
    info = CaptureInfo.of(capture, command="convert", site=args.site)
    with open_writer(args.output, info, **options) as writer:   # the file takes its name only if the run ends well
        run_tap(capture, "convert", writer, info=info, progress=True, check=True)
    # said as export, report and recover say what they wrote (standard output may be piped on)
    print(f"gimbalscope: {writer.summary()}", file=sys.stderr)
    return 0
