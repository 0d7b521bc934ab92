"""``gimbalscope replay``: play an MCAP recording back at its recorded pace
(``--speed 2`` twice as fast, ``--speed max`` without waiting), re-dissecting
its raw byte topics like ``decode`` (Table 1 framing, Tables 4-18 fields).
``--foxglove`` serves it to the Foxglove app as it plays (analyzer/listeners/foxglove.py)."""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

from dissectors.event import Event

from ..capture import Capture
from ..info import CaptureInfo
from ..listeners import EventPrinter
from ..outfile import show
from ..writers import open_format
from .common import (
    Subcommands,
    UsageError,
    add_fields_arg,
    add_filter_arg,
    add_quiet_arg,
    add_serial_args,
    build_filter,
    fields_option,
    open_inputs,
    run_tap,
)
from .live import add_foxglove_arg, add_tui_args, open_servers, wants_tui


def speed(text: str) -> float:
    if text == "max":
        return 0.0
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not (value > 0 and math.isfinite(value)):   # "nan" and "inf" parse as floats
        raise argparse.ArgumentTypeError(f"{text!r}: a factor above 0 (2 = twice as fast) or 'max'")
    return value


def register(sub: Subcommands) -> None:
    p = sub.add_parser("replay", help="play an MCAP recording back at its pace",
                       description="Replay an MCAP recording, or the parts of one (in any order): events "
                                   "at their recorded pace.")
    p.add_argument("inputs", nargs="+", metavar="FILE.mcap")
    add_quiet_arg(p)
    add_serial_args(p)
    p.add_argument("--speed", type=speed, default=1.0, metavar="N|max", help="pace factor (default 1) or max")
    p.add_argument("--format", choices=("text", "jsonl", "csv"), default="text")
    add_fields_arg(p)
    add_filter_arg(p, "show only matching events")
    add_foxglove_arg(p)
    add_tui_args(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    keep = build_filter(args.filter)
    capture = open_inputs(args)
    from ..sources.mcapfile import McapSource  # here: every other command starts without it
    from ..sources.mcapparts import McapPartsSource

    if not isinstance(capture.source, (McapSource, McapPartsSource)):
        raise UsageError(f"{show(args.inputs[0])}: replay takes an MCAP recording (use decode for other captures)")
    info = CaptureInfo.of(capture, command="replay")
    if wants_tui(args):
        return replay_in_tui(capture, info, args)
    servers = open_servers(capture, info, args)
    sink = open_format(args.format, info, flush_each=True,   # every event as it comes
                       **fields_option(args.fields, args.format == "csv", f"--format {args.format}"))
    # the server after the printer: it is paced as the printer is
    run_tap(capture, "replay", EventPrinter(sink, keep, pace=pacer(args.speed)), *servers, info=info)
    return 0


def replay_in_tui(capture: Capture, info: CaptureInfo, args: argparse.Namespace) -> int:
    """The TUI reads the file flat out and paces the screen: a --foxglove server
    paces what it sends itself."""
    from ..tui.run import keymap_from, open_tui

    keymap = keymap_from(args)   # a bad keymap is refused before anything serves
    servers = open_servers(capture, info, args, speed=args.speed)
    return open_tui(capture, args, mode="replay", speed=args.speed, keymap=keymap, info=info, listeners=servers)


def pacer(speed: float) -> Callable[[Event], None] | None:
    """Waits until each event's recorded time, ``speed`` times faster (None: no waiting)."""
    if not speed:
        return None
    start = time.monotonic()

    def pace(ev: Event) -> None:
        if ev.t is not None:
            delay = start + ev.t / speed - time.monotonic()
            if delay > 0:
                time.sleep(delay)
    return pace
