"""``gimbalscope send PORT COMMAND --to G.P.D [FIELD=VALUE …]``: one command,
encoded from the command table, sent on PORT; its answer waited for with the
protocol's timeouts and printed as ``decode`` prints it (docs/talk.md).

Exit status: 0 when the gimbal ACKed (and sent its result, when one is due),
1 for a NAK, a NIC or no answer, 2 for a mistake on the command line, a refused
command (one that moves the gimbal or changes its configuration, without
``--allow-motion`` / ``--allow-config``) or a port that cannot be opened.
"""

from __future__ import annotations

import argparse
import signal
import sys
from collections.abc import Sequence
from types import FrameType
from typing import TYPE_CHECKING

from ..errors import UsageError
from .common import (
    Subcommands,
    add_fields_arg,
    add_permission_args,
    add_quiet_arg,
    add_serial_args,
    destination,
    fields_option,
    non_negative_int,
    options_from,
    permissions,
)
from .live import add_record_args

if TYPE_CHECKING:
    from ..runner import TapRunner
    from ..talk.conversation import Outcome


def silence_advice() -> str:
    """The doctor's advice for a link where nothing answers, worded for talking to it."""
    from ..analysis.findings import DEAD_LINK, FINDINGS

    return FINDINGS[DEAD_LINK].phrase("check_talking")


def register(sub: Subcommands) -> None:
    p = sub.add_parser("send", help="send one command to a gimbal and show its answer",
                       description="Encode COMMAND (a code of the command table: docs/fields.md) with its "
                                   "fields (FIELD=VALUE, in the field's unit: azimuth_deg=10), send it on PORT "
                                   "to --to, wait for the ACK/NAK/NIC and the result with the protocol's "
                                   "timeouts, and print the exchange as decode does. Commands that move the "
                                   "gimbal or change its configuration are refused unless allowed. Exit 0 for "
                                   "an ACK (and the result when due), 1 for NAK, NIC or no answer.")
    p.add_argument("port", metavar="PORT", help="the serial port the gimbal is on (a device name or pyserial URL)")
    p.add_argument("command", metavar="COMMAND", nargs="?", help="a command code of the table: P, D?, Pnn, C …")
    p.add_argument("values", metavar="FIELD=VALUE", nargs="*", help="the command's fields, by name")
    p.add_argument("--to", type=destination, metavar="G.P.D",
                   help="the gimbal's address (group.port.device; 255 is the wildcard at any level)")
    p.add_argument("--raw", metavar="HEX", help="send these bytes as given (a whole frame; spaces allowed)")
    p.add_argument("--retries", type=non_negative_int, default=0, metavar="N",
                   help="send again up to N times on a NAK or no answer, as a controller would (default 0)")
    add_permission_args(p)
    p.add_argument("--format", choices=("text", "json", "jsonl"), default="text",
                   help="text, or JSON Lines (json and jsonl are the same: one event a line)")
    add_fields_arg(p)
    add_quiet_arg(p)
    add_serial_args(p, files=False)
    add_record_args(p)
    p.set_defaults(run=run, foxglove=None, filter=None)
    p.__class__ = type("SendParser", (FieldsAnywhere, type(p)), {})


class FieldsAnywhere(argparse.ArgumentParser):
    """FIELD=VALUE words may follow options (``P --to 1.1.3 azimuth_deg=10``), which
    argparse would refuse once the positionals are taken: they are gathered here,
    where they would have gone before the options."""

    def parse_known_args(self, args: Sequence[str] | None = None,  # type: ignore[override]
                         namespace: argparse.Namespace | None = None) -> tuple[argparse.Namespace, list[str]]:
        parsed, extras = super().parse_known_args(args, namespace)
        words = [a for a in extras if not a.startswith("-")]   # FIELD=VALUE, or a mistake field_values names
        parsed.values = [*(parsed.values or []), *words]
        return parsed, [a for a in extras if a not in words]


def frame_to_send(args: argparse.Namespace) -> bytes:
    """The frame the command line asks for, refused as a UsageError (one line, exit 2)
    when it may not or cannot be sent (analyzer/talk/request.py)."""
    from ..talk.request import Asked, TalkError, field_values, frame_for

    try:
        return frame_for(Asked(args.command, field_values(args.values), args.to, args.raw, permissions(args)))
    except TalkError as e:
        raise UsageError(str(e)) from None


def run(args: argparse.Namespace) -> int:
    from ..capture import Capture
    from ..info import CaptureInfo
    from ..listeners import EventPrinter, NotePrinter
    from ..runner import TapRunner
    from ..talk.conversation import Conversation, Step
    from ..talk.link import TalkLink
    from ..writers import open_format
    from .live import open_recorder

    data = frame_to_send(args)   # a refused or mistyped command opens no port
    options = options_from(args)
    link = TalkLink(args.port, baud=options.baud, data_bits=options.data_bits, parity=options.parity,
                    stop_bits=options.stop_bits)
    capture = Capture(link, options)
    capture.inputs = (args.port,)
    info = CaptureInfo.of(capture, command="send")
    fmt = "jsonl" if args.format == "json" else args.format
    sink = open_format(fmt, info, flush_each=True, **fields_option(args.fields, False, f"--format {args.format}"))
    recorder = open_recorder(capture, info, args, args.record)
    talk = Conversation(link, [Step(data, retries=args.retries)])
    listeners = [x for x in (recorder, EventPrinter(sink), talk, NotePrinter()) if x is not None]
    runner = TapRunner(capture, listeners, info=info)
    interrupted = run_until_done(runner)
    link.close()
    if not talk.outcomes:
        print("gimbalscope send: stopped before an answer" if interrupted else
              f"gimbalscope send: {args.port}: the port went away before an answer", file=sys.stderr, flush=True)
        return 1
    outcome = talk.outcomes[0]
    print(f"gimbalscope send: {describe(outcome)}", file=sys.stderr, flush=True)
    return 0 if outcome.ok else 1


def run_until_done(runner: TapRunner) -> bool:
    """Run until the conversation ends, or Ctrl-C/SIGTERM; True when interrupted."""
    stopped = []

    def stop(_signum: int, _frame: FrameType | None) -> None:
        stopped.append(True)
        runner.stop()

    old = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        runner.run()
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
    return bool(stopped)


def describe(outcome: Outcome) -> str:
    """One line for people: who answered what, how fast, after how many tries."""
    from dissectors.event import NO_ACK, NO_RESULT, OK, ST_NAK, ST_NIC

    shake = outcome.handshake
    latency = f" in {shake.latency * 1000:.1f} ms" if shake is not None and shake.latency is not None else ""
    tries = f" (try {outcome.tries} of {outcome.step.retries + 1})" if outcome.tries > 1 else ""
    status = outcome.status
    if status == OK:
        result = " and its result" if outcome.result is not None else ""
        return f"ACK{latency}{result}{tries}"
    if status == ST_NAK:
        return f"NAK{latency}: the gimbal refused the command{tries}"
    if status == ST_NIC:
        return f"NIC: the gimbal does not implement this command{tries}"
    if status == NO_RESULT:
        return f"ACK{latency} but no result in time{tries}"
    garbled = f"; {outcome.garbled} garbled frames came back (another rate?)" if outcome.garbled else ""
    if status == NO_ACK:
        return f"no answer{tries}{garbled}: {silence_advice()}"
    return f"{status}{tries}"
