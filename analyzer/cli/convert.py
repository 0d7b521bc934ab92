"""``gimbalscope convert``: raw dumps and socat logs to an MCAP recording.

Writes what a live recording holds (the MCAP topics of analyzer/recording):
raw bytes per line, decoded events (Tables 4-18 via the command table),
transactions and foxglove.Log anomalies, with a metadata record.
"""

from __future__ import annotations

import argparse
import os
import socket
import time

from .. import __version__
from ..recording import McapRecorder, RecordingError
from .common import UsageError, add_input_args, open_inputs, warn_if_empty


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("convert", help="convert captures to an MCAP recording",
                       description="Convert raw dumps or a socat log to MCAP (re-dissectable, Foxglove-readable).")
    add_input_args(p)
    p.add_argument("-o", "--output", required=True, metavar="OUT.mcap")
    p.add_argument("--force", action="store_true", help="overwrite OUT.mcap if it exists")
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


def run(args: argparse.Namespace) -> int:
    out = args.output
    if os.path.exists(out) and not args.force:
        raise UsageError(f"{out}: exists (use --force to overwrite)")
    capture = open_inputs(args)
    try:
        recorder = McapRecorder(out, metadata={}, start_time=capture.source.start_time, lines=capture.lines)
    except RecordingError as e:
        raise UsageError(str(e)) from None
    capture.on_chunk = recorder.raw
    seen = 0
    try:
        for ev in capture:
            seen += 1
            recorder.event(ev)
    finally:
        recorder.close(metadata_for(capture, args))
    warn_if_empty(capture, seen)
    return 0
