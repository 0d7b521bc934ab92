"""``gimbalscope demo``: the whole picture without hardware. Virtual serial lines
(pseudo-terminals), a simulated controller driving three simulated gimbals on one
port with a few faults, and a live tap on both lines, printed (and recorded with
--record) exactly as ``live`` does."""

from __future__ import annotations

import argparse
import threading

from ..capture import Options, open_live
from ..simulation import scenario
from .common import UsageError, add_filter_arg, warn
from .live import add_record_args, add_tui_args, tap, wants_tui


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="simulated controller and gimbals on virtual lines, tapped live",
                       description="Run a simulated controller and three gimbals over pseudo-terminals and tap "
                                   "both lines; no hardware needed.")
    p.add_argument("--seconds", type=float, default=None,
                   help="how long to run (0 = until stopped); default: until you quit the TUI, "
                        "12 s when printing")
    add_record_args(p)
    p.add_argument("--format", choices=("text", "jsonl"), default="text")
    add_filter_arg(p, "show only matching events")
    p.add_argument("--clean", action="store_true", help="no injected faults")
    p.add_argument("--fault", action="append", default=[], metavar="NAME", choices=sorted(scenario.FAULTS),
                   help="a clean installation with this fault (repeatable): "
                        + "; ".join(f"{k}: {v}" for k, v in scenario.FAULTS.items()))
    add_tui_args(p)
    p.add_argument("--seed", type=int, default=5)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if args.seconds is None:
        args.seconds = 0.0 if wants_tui(args) else 12.0
    if args.seconds < 0:
        raise UsageError(f"--seconds {args.seconds:g}: must be 0 (until Ctrl-C) or more")
    try:
        site = scenario.build(set(args.fault), clean=args.clean, seed=args.seed)
    except ValueError as e:
        raise UsageError(f"--fault: {e}") from None
    capture = open_live(list(site.link.tap_ports), Options(), on_warning=warn)
    site.start()
    timer = None
    if args.seconds > 0:
        timer = threading.Timer(args.seconds, capture.source.stop)
        timer.daemon = True
        timer.start()
    try:
        return tap(capture, args, args.record)
    finally:
        if timer is not None:
            timer.cancel()
        site.stop()
