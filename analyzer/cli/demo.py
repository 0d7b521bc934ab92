"""``gimbalscope demo``: the whole picture without hardware. Virtual serial lines
(pseudo-terminals), a simulated controller driving three simulated gimbals on one
port with a few faults, and a live tap on both lines, printed (and recorded with
--record) exactly as ``live`` does."""

from __future__ import annotations

import argparse
import threading

from ..capture import Options, open_live
from ..simulation import scenario
from .common import Subcommands, UsageError, add_fields_arg, add_filter_arg, non_negative_float, non_negative_int
from .live import add_foxglove_arg, add_keep_args, add_record_args, add_tui_args, check_keep, tap, wants_tui


def fault_help() -> str:
    # argparse expands %-codes in help text: the descriptions' "1%" must be "1%%"
    return "; ".join(f"{k}: {v}" for k, v in scenario.FAULTS.items()).replace("%", "%%")


def register(sub: Subcommands) -> None:
    p = sub.add_parser("demo", help="simulated controller and gimbals on virtual lines, tapped live",
                       description="Run a simulated controller and three gimbals over pseudo-terminals and tap "
                                   "both lines; no hardware needed.")
    p.add_argument("--seconds", type=non_negative_float, default=None,
                   help="how long to run (0 = until stopped); default: until you quit the TUI, "
                        "12 s when printing")
    add_record_args(p)
    add_keep_args(p, stop_after=False)   # --seconds says how long a demo runs
    add_foxglove_arg(p)
    p.add_argument("--format", choices=("text", "jsonl", "csv"), default="text")
    add_fields_arg(p)
    add_filter_arg(p, "show only matching events")
    p.add_argument("--clean", action="store_true", help="no injected faults")
    p.add_argument("--fault", action="append", default=[], metavar="NAME", choices=sorted(scenario.FAULTS),
                   help="a clean installation with this fault (repeatable): " + fault_help())
    add_tui_args(p)
    p.add_argument("--seed", type=non_negative_int, default=5, help="the faults' random seed (default 5)")
    p.add_argument("--rate-change", type=rate_change, metavar="RATE@S",
                   help="the controller switches the link to RATE (a rate of Table 4) after S seconds, "
                        "e.g. 115200@3; the tap follows it (docs/time.md, \"Rate changes\")")
    p.set_defaults(run=run)


def rate_change(text: str) -> tuple[int, float]:
    """``--rate-change 115200@3``."""
    from ..simulation.controller import rate_set_payload
    rate, sep, seconds = text.partition("@")
    try:
        value = (int(rate), non_negative_float(seconds) if sep else 2.0)
        rate_set_payload(value[0])
    except (ValueError, argparse.ArgumentTypeError) as e:
        raise argparse.ArgumentTypeError(f"{text!r}: {e}" if isinstance(e, ValueError) and rate.isdigit()
                                         else f"{text!r}: expected RATE@SECONDS, e.g. 115200@3") from None
    return value


def run(args: argparse.Namespace) -> int:
    check_keep(args)
    if args.seconds is None:
        args.seconds = 0.0 if wants_tui(args) else 12.0
    try:
        site = scenario.build(set(args.fault), clean=args.clean, seed=args.seed, rate_change=args.rate_change)
    except ValueError as e:
        raise UsageError(f"--fault: {e}") from None
    capture = open_live(list(site.link.tap_ports), Options())
    site.start()
    timer = None
    if args.seconds > 0:
        timer = threading.Timer(args.seconds, capture.source.stop)
        timer.daemon = True
        timer.start()
    try:
        # the doctor's advice names what "demo" takes (no --swap-lines: it picks its ports)
        return tap(capture, args, args.record, command="demo")
    finally:
        if timer is not None:
            timer.cancel()
        site.stop()
