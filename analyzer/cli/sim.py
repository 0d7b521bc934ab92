"""``gimbalscope sim``: simulated gimbals answering on a serial port per the
protocol (ACK/NAK/NIC §1.4.2, results §1.4.3 with Table 3 addressing, values per
Tables 4-18), with protocol faults to inject; a simulated controller driving them
(``--controller PORT``); or both on a virtual link of its own (``--pty``), whose two
lines ``live`` taps.

The gimbals follow rate changes (Table 4): ``C0``…``C7`` is ACKed at the old rate,
then the port runs at the new one (docs/time.md, "Rate changes"); ``--ignore-rate``
is firmware that ACKs and keeps its rate.

``--pty`` is the demo's link (pseudo-terminals paced at the baud, a tap port per
direction) without the demo's tap: what a new user needs to try ``live`` on a
machine without serial ports, in two commands and no socat."""

from __future__ import annotations

import argparse
import shlex
import signal
import sys
import threading

from dissectors.event import format_address

from ..simulation.bus import GimbalBus
from ..simulation.controller import SimController
from ..simulation.gimbal import Faults, GimbalModel
from ..simulation.link import VirtualLink
from .common import Subcommands, UsageError, non_negative_float, parse_address, positive_int, probability

DEFAULT_ADDRESS = (1, 1, 1)
# what only gimbals do: refused when the command runs a controller alone
GIMBAL_OPTIONS = {"drop_acks": "--drop-acks", "late": "--late", "wrong_baud": "--wrong-baud",
                  "ignore_rate": "--ignore-rate"}


def register(sub: Subcommands) -> None:
    p = sub.add_parser("sim", help="simulated gimbals, a simulated controller, or both on pseudo-terminals",
                       description="Answer as gimbals on PORT (a device name or pyserial URL), drive gimbals "
                                   "as a controller does from --controller PORT, or run both on "
                                   "pseudo-terminals of its own (--pty) and print the live command that taps "
                                   "them. The gimbals follow rate changes (C0..C7, Table 4): the ACK goes at "
                                   "the old rate, then the port runs at the new one.")
    p.add_argument("port", metavar="PORT", nargs="?", help="the port the simulated gimbals answer on")
    p.add_argument("--controller", metavar="PORT",
                   help="a simulated controller on PORT drives the gimbals (--address): it waits for ACKs, "
                        "retransmits on NAK or timeout, polls and sweeps")
    p.add_argument("--pty", action="store_true",
                   help="a controller and the gimbals on pseudo-terminals paced at --baud; prints the "
                        "'gimbalscope live' command that taps line A (controller→device) and line B "
                        "(device→controller)")
    p.add_argument("--address", action="append", default=[], type=parse_address, metavar="G.P.D",
                   help="a gimbal's address (repeatable; default 1.1.1)")
    p.add_argument("--baud", type=positive_int, default=9600,
                   help="line rate in bit/s at the start (default 9600); rate-set commands change it")
    p.add_argument("--drop-acks", type=probability, default=0.0, metavar="P", help="probability of not answering")
    p.add_argument("--late", type=probability, default=0.0, metavar="P",
                   help="probability of answering 0.8 s late")
    p.add_argument("--init-seconds", type=non_negative_float, default=3.0, metavar="S",
                   help="how long IX takes (default 3; a controller waits a second longer)")
    p.add_argument("--wrong-baud", type=positive_int, metavar="RATE",
                   help="fault: answer at RATE while the line runs at --baud (a misconfigured gimbal)")
    p.add_argument("--ignore-rate", action="store_true",
                   help="fault: ACK a rate change (C0..C7) but keep the old rate, so nothing is answered after")
    p.set_defaults(run=run)


def check_roles(args: argparse.Namespace) -> None:
    """One clear line for a command line that asks for no simulation, or for two
    that cannot go together."""
    if args.pty and (args.port or args.controller):
        raise UsageError("--pty makes its own ports: give it without PORT and --controller")
    if not (args.port or args.controller or args.pty):
        raise UsageError("nothing to simulate: give PORT (gimbals), --controller PORT, or --pty (both, "
                         "on pseudo-terminals, to try gimbalscope live)")
    if args.controller and not args.port:
        given = [option for name, option in GIMBAL_OPTIONS.items() if vars(args)[name]]
        if given:
            raise UsageError(f"{given[0]} is a fault of the simulated gimbals: give PORT for them, "
                             "or use --pty")


def rate_text(args: argparse.Namespace) -> str:
    rate = f"{args.baud} baud"
    if args.wrong_baud:
        rate += f" (answers sent at {args.wrong_baud})"
    return rate


def start_line(addresses: list[tuple[int, int, int]], args: argparse.Namespace) -> str:
    """What the simulator says when it starts: without it a silent terminal looks hung."""
    names = ", ".join(map(format_address, addresses))
    noun = "gimbal" if len(addresses) == 1 else "gimbals"
    if args.pty:
        return (f"gimbalscope: sim: a controller driving {noun} {names} over pseudo-terminals at "
                f"{rate_text(args)} (Ctrl-C stops); tap line A (controller→device) and line B "
                "(device→controller) with:")
    roles = []
    if args.port:
        roles.append(f"{noun} {names} answering on {args.port}")
    if args.controller:
        driven = ("it" if len(addresses) == 1 else "them") if args.port else f"{noun} {names}"
        roles.append(f"a controller driving {driven} on {args.controller}")
    return f"gimbalscope: sim: {', '.join(roles)} at {rate_text(args)} (Ctrl-C stops)"


def tap_command(link: VirtualLink, baud: int) -> str:
    """The ``live`` command that taps the virtual link: a user copies it, a script reads it."""
    argv = ["gimbalscope", "live", *link.tap_ports] + (["--baud", str(baud)] if baud != 9600 else [])
    return shlex.join(argv)


def check_ports(args: argparse.Namespace) -> None:
    """One clear line (CaptureError, exit 2) for a port that is missing, busy or not
    a serial port, before anything starts."""
    from ..sources.serialport import open_port
    for port in (args.port, args.controller):
        if port:
            open_port(port, args.baud, 8, "N", 1).close()


def build(args: argparse.Namespace) -> tuple[list[GimbalBus | SimController], VirtualLink | None]:
    """The simulator's threads (gimbals, controller) and the virtual link they talk
    over with --pty."""
    addresses = args.address or [DEFAULT_ADDRESS]
    faults = Faults(drop_ack=args.drop_acks, late=args.late, ignore_rate=args.ignore_rate)
    gimbals = [GimbalModel(a, serial=f"SN{k:04d}", init_seconds=args.init_seconds, faults=faults)
               for k, a in enumerate(addresses, 1)]
    link = VirtualLink(baud=args.baud) if args.pty else None
    gimbal_port = link.device_port if link else args.port
    controller_port = link.controller_port if link else args.controller
    threads: list[GimbalBus | SimController] = []
    if gimbal_port:
        threads.append(GimbalBus(gimbal_port, gimbals, args.baud, wrong_baud=args.wrong_baud))
    if controller_port:
        # it waits for IX's result a little longer than the simulated gimbals take
        threads.append(SimController(controller_port, addresses, baud=args.baud,
                                     ix_patience=args.init_seconds + 1.0))
    return threads, link


def run(args: argparse.Namespace) -> int:
    check_roles(args)
    check_ports(args)
    threads, link = build(args)
    done = threading.Event()
    # handlers before the start line: whoever reads it may stop us at once
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: done.set())
    for thread in threads:
        thread.start()
    print(start_line(args.address or [DEFAULT_ADDRESS], args), file=sys.stderr, flush=True)
    if link is not None:
        print(tap_command(link, args.baud), flush=True)
    while not done.wait(0.2):
        if not all(thread.is_alive() for thread in threads):
            break
    for thread in threads:
        thread.stop()
    for thread in threads:
        thread.join(timeout=1.0)
    if link is not None:
        link.close()
    return 0
