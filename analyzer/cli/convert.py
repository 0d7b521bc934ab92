"""``gimbalscope convert``: captures to an MCAP recording or to JSON Lines, the
format chosen by the output's suffix (``WRITERS``).

MCAP holds what a live recording holds (the MCAP topics of analyzer/recording):
raw bytes per line, decoded events (Tables 4-18 via the command table),
transactions and foxglove.Log anomalies, with a metadata record. JSON Lines are
the lines ``decode --format jsonl`` prints.

The output is checked before any work (never over an input, ``--force`` to
replace a file) and written beside the target, renamed onto it only when whole:
a failed conversion leaves no file behind (analyzer/outfile.py).
"""

from __future__ import annotations

import argparse
import os
import socket
import time
from typing import Callable

from .. import __version__
from ..capture import Capture
from ..outfile import AtomicOutput, OutputRefused, check_output, show
from ..output import JsonLinesSink
from ..recording import McapRecorder
from .common import add_input_args, open_inputs, warn_if_empty


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("convert", help="convert captures to an MCAP recording or JSON Lines",
                       description="Convert raw dumps, a socat log or a recording to MCAP (re-dissectable, "
                                   "Foxglove-readable) or to JSON Lines; the output's suffix chooses: "
                                   + ", ".join(WRITERS) + ".")
    add_input_args(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT.mcap|OUT.jsonl")
    p.add_argument("--force", action="store_true", help="overwrite OUT if it exists")
    p.set_defaults(run=run)


def metadata_for(capture, args: argparse.Namespace) -> dict[str, str]:
    o = capture.options
    start = capture.source.start_time
    return {
        "tool": f"gimbalscope {__version__}",
        "host": socket.gethostname(),
        "inputs": " ".join(args.inputs),
        "source": capture.source.description,
        "lines": ",".join(capture.lines),
        "line_roles": "A=controller→device, B=device→controller, AB=single-line tap (both directions)",
        "baud": str(o.baud), "data_bits": str(o.data_bits), "parity": o.parity, "stop_bits": f"{o.stop_bits:g}",
        "start_time": time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(start)) if start else "unknown",
        "timed": "yes" if capture.timed else "no",
    }


def write_mcap(capture: Capture, args: argparse.Namespace, target: AtomicOutput) -> int:
    recorder = McapRecorder(args.output, metadata={}, start_time=capture.source.start_time,
                            lines=capture.lines, file=target.file)
    capture.on_chunk = recorder.raw
    seen = 0
    for ev in capture:
        seen += 1
        recorder.event(ev)
    recorder.close(metadata_for(capture, args))
    return seen


def write_jsonl(capture: Capture, args: argparse.Namespace, target: AtomicOutput) -> int:
    sink = JsonLinesSink(target.file, name=args.output)
    seen = 0
    for ev in capture:
        seen += 1
        sink(ev)
    sink.close()
    return seen


# Output suffix -> writer(capture, args, target) -> events written.
WRITERS: dict[str, Callable[[Capture, argparse.Namespace, AtomicOutput], int]] = {
    ".mcap": write_mcap,
    ".jsonl": write_jsonl,
    ".ndjson": write_jsonl,
}


def writer_for(path: str) -> Callable[[Capture, argparse.Namespace, AtomicOutput], int]:
    """The writer for ``path``'s suffix; any other suffix is refused, naming those there are."""
    suffix = os.path.splitext(path)[1].lower()
    writer = WRITERS.get(suffix)
    if writer is None:
        what = f"unknown output format {show(suffix)!r}" if suffix else "no suffix to choose the output format"
        raise OutputRefused(f"{show(path)}: {what}; use one of {', '.join(WRITERS)}")
    return writer


def run(args: argparse.Namespace) -> int:
    check_output(args.output, args.inputs, force=args.force)   # first: an output over an input is worst
    write = writer_for(args.output)
    capture = open_inputs(args)
    with AtomicOutput(args.output) as target:   # a failure on the way removes it
        seen = write(capture, args, target)
    warn_if_empty(capture, seen)
    return 0
