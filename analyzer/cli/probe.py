"""``gimbalscope probe PORT``: who answers on a port (docs/talk.md). It listens
first (a line with traffic on it has a controller already: it says so and stops,
unless ``--force``), then asks ``D?`` of the wildcard and of each address of a
range, at each rate of §1.5.1 unless ``--baud`` is given.

Exit status: 0 when something answered, 1 when nothing did (with what to check
for a silent link), 2 for a mistake on the command line, a port that cannot be
opened, or traffic already on the line.
"""

from __future__ import annotations

import argparse
import sys
import time

from ..errors import UsageError
from .common import (
    STANDARD_BAUDS,
    Subcommands,
    add_quiet_arg,
    add_serial_args,
    non_negative_float,
    non_negative_int,
    options_from,
    parse_address,
)
from .live import add_record_args

DEFAULT_RANGE = "1.1.1-1.1.8"
LISTEN_SECONDS = 1.0


def register(sub: Subcommands) -> None:
    p = sub.add_parser("probe", help="find the gimbals that answer on a port, at each rate",
                       description="Listen to PORT first (traffic on it means a controller is talking: probe "
                                   "stops, unless --force), then send D? (Request ID information, which only "
                                   "asks) to the wildcard and to each address of --addresses, at each rate of "
                                   "§1.5.1 (or --baud), and list who answered. Exit 0 when something answered, "
                                   "1 when nothing did.")
    p.add_argument("port", metavar="PORT", help="the serial port (a device name or pyserial URL)")
    p.add_argument("--addresses", type=address_range, default=address_range(DEFAULT_RANGE), metavar="G.P.D-G.P.D",
                   help=f"the addresses to ask, a range of devices of one group and port (default {DEFAULT_RANGE}), "
                        "or one address")
    p.add_argument("--listen", type=non_negative_float, default=LISTEN_SECONDS, metavar="S",
                   help=f"seconds to listen for traffic before sending (default {LISTEN_SECONDS:g})")
    p.add_argument("--force", action="store_true",
                   help="probe even when the line has traffic on it (and with --record, replace FILE.mcap)")
    p.add_argument("--retries", type=non_negative_int, default=0, metavar="N",
                   help="ask each address up to N times more when nothing answers (default 0)")
    p.add_argument("--format", choices=("text", "json"), default="text")
    add_quiet_arg(p)
    # --baud: probe at that rate only (by default each of §1.5.1's, 9600 first);
    # --ack-timeout: how long each address is waited for
    add_serial_args(p, files=False)
    add_record_args(p, force=False)
    p.set_defaults(run=run, foxglove=None)


def address_range(text: str) -> list[tuple[int, int, int]]:
    """``1.1.1-1.1.20`` (or ``1.1.1-20``, or one address): devices of one group and port."""
    first, sep, last = text.partition("-")
    start = parse_address(first)
    if not sep:
        return [start]
    end = parse_address(last) if "." in last else parse_address(f"{start[0]}.{start[1]}.{last}")
    if end[:2] != start[:2] or end[2] < start[2]:
        raise argparse.ArgumentTypeError(f"{text!r}: a range of devices of one group and port, first to last "
                                         "(1.1.1-1.1.20)")
    return [(start[0], start[1], d) for d in range(start[2], end[2] + 1)]


def listen(port: str, baud: int, seconds: float) -> int:
    """Bytes heard on ``port`` in ``seconds`` (the port opened and closed here)."""
    from ..sources.serialport import open_port

    heard = 0
    with open_port(port, baud, 8, "N", 1) as ser:
        ser.timeout = 0.05
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            heard += len(ser.read(4096))
    return heard


def run(args: argparse.Namespace) -> int:
    from ..talk.probe import RATES

    if args.baud is not None and args.baud not in STANDARD_BAUDS:
        raise UsageError(f"--baud {args.baud}: probe tries the rates of §1.5.1 ({', '.join(map(str, STANDARD_BAUDS))})")
    rates = (args.baud,) if args.baud else RATES
    if args.listen > 0 and not args.force:
        heard = listen(args.port, rates[0], args.listen)
        if heard:
            raise UsageError(f"{args.port}: {heard} bytes in {args.listen:g} s before anything was sent: a "
                             "controller is talking on this line, and probing would talk over it; stop it, "
                             "or probe anyway with --force")
    found, interrupted, tried = probe(args, rates)
    report(args, found, tried)
    if interrupted:
        print("gimbalscope probe: stopped (Ctrl-C): what was found so far is above", file=sys.stderr, flush=True)
    if not any(f.answer != "garbled" for f in found):
        from .send import silence_advice
        garbled = any(f.answer == "garbled" for f in found)
        print(f"gimbalscope probe: nothing answered on {args.port}"
              + ("; something garbled came back: another rate, or two devices answering at once" if garbled else "")
              + f": {silence_advice()}", file=sys.stderr, flush=True)
        return 1
    return 0


def probe(args: argparse.Namespace, rates: tuple[int, ...]) -> tuple[list, bool, list[int]]:
    """Ask every address at every rate: (what was found, interrupted?, rates tried)."""
    from dissectors.event import format_address

    from ..capture import Capture
    from ..info import CaptureInfo
    from ..listeners import NotePrinter
    from ..runner import TapRunner
    from ..talk.conversation import Conversation, Outcome
    from ..talk.link import TalkLink
    from ..talk.probe import Found, found_in, merged, plan
    from .live import open_recorder
    from .send import run_until_done

    options = options_from(args)
    link = TalkLink(args.port, baud=rates[0], data_bits=options.data_bits, parity=options.parity,
                    stop_bits=options.stop_bits)
    capture = Capture(link, options)
    capture.inputs = (args.port,)
    info = CaptureInfo.of(capture, command="probe")
    recorder = open_recorder(capture, info, args, args.record)
    found: list[Found] = []
    tried: list[int] = []
    steps = list(plan(args.addresses, rates, retries=args.retries))
    bar = Progress(len(steps), quiet=args.quiet)

    def heard(outcome: Outcome) -> None:
        target = outcome.step.label
        if target.baud not in tried:
            tried.append(target.baud)
        hit = found_in(outcome)
        if hit is not None:
            found.append(hit)
        bar.advance(f"{target.baud} bps, {format_address(target.address)}", len(found))

    talk = Conversation(link, steps, on_outcome=heard)
    listeners = [x for x in (recorder, talk, NotePrinter()) if x is not None]
    runner = TapRunner(capture, listeners, info=info)
    try:
        interrupted = run_until_done(runner)
    finally:
        bar.close()
        link.close()
    return merged(found), interrupted, tried


class Progress:
    """A bar on standard error while probing, when it is a terminal (Rich)."""

    def __init__(self, total: int, quiet: bool) -> None:
        self._progress = None
        if quiet or not sys.stderr.isatty():
            return
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, TextColumn
        from rich.progress import Progress as RichProgress

        self._progress = RichProgress(TextColumn("probing {task.description}"), BarColumn(), MofNCompleteColumn(),
                                      TextColumn("{task.fields[found]} found"),
                                      console=Console(stderr=True), transient=True)
        self._task = self._progress.add_task("", total=total, found=0)
        self._progress.start()

    def advance(self, what: str, found: int) -> None:
        if self._progress is not None:
            self._progress.update(self._task, advance=1, description=what, found=found)

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()


def report(args: argparse.Namespace, found: list, tried: list[int]) -> None:
    if args.format == "json":
        import json
        devices = [f.json() for f in found if f.answer != "garbled"]
        garbled = [{"address": f.address, "baud": f.baud} for f in found if f.answer == "garbled"]
        print(json.dumps({"devices": devices, "rates_tried": tried, "garbled": garbled}))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"who answers on {args.port}", title_justify="left", box=None)
    for column in ("address", "rate", "answer", "identification", "ACK latency"):
        table.add_column(column, justify="right" if column == "ACK latency" else "left")
    for f in found:
        identity = f.identity
        name = (f"{identity.get('name', '')} rev {identity.get('revision', '')} s/n {identity.get('serial', '')}"
                if identity else "")
        asked = f" (asked {f.asked})" if f.asked != f.address else ""
        latency = f"{f.latency_ms:.1f} ms" if f.latency_ms is not None else ""
        table.add_row(f.address + asked, str(f.baud), f.answer, name, latency)
    Console().print(table)
    print(f"rates tried: {', '.join(map(str, tried)) or 'none'}")
