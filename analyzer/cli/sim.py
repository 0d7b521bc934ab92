"""``gimbalscope sim``: simulated gimbals answering on a serial port per the
protocol (ACK/NAK/NIC §1.4.2, results §1.4.3 with Table 3 addressing, values per
Tables 4-18), with protocol faults to inject.

The gimbals follow rate changes (Table 4): ``C0``…``C7`` is ACKed at the old rate,
then the port runs at the new one (docs/time.md, "Rate changes"); ``--ignore-rate``
is firmware that ACKs and keeps its rate."""

from __future__ import annotations

import argparse
import signal
import sys
import threading

from dissectors.event import format_address

from ..simulation.bus import GimbalBus
from ..simulation.gimbal import Faults, GimbalModel
from .common import non_negative_float, positive_int, probability

DEFAULT_ADDRESS = (1, 1, 1)


def parse_address(text: str) -> tuple[int, int, int]:
    """``--address G.P.D`` (an argparse type: a bad one is refused while parsing)."""
    try:
        g, p, d = (int(x) for x in text.split("."))
        if not all(0 <= v <= 254 for v in (g, p, d)):
            raise ValueError
        return g, p, d
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected GROUP.PORT.DEVICE, each 0..254") from None


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sim", help="simulated gimbals on a serial port",
                       description="Answer as gimbals on PORT (a device name or pyserial URL). They follow "
                                   "rate changes (C0..C7, Table 4): the ACK goes at the old rate, then the "
                                   "port runs at the new one.")
    p.add_argument("port", metavar="PORT")
    p.add_argument("--address", action="append", default=[], type=parse_address, metavar="G.P.D",
                   help="a gimbal's address (repeatable; default 1.1.1)")
    p.add_argument("--baud", type=positive_int, default=9600,
                   help="line rate in bit/s at the start (default 9600); rate-set commands change it")
    p.add_argument("--drop-acks", type=probability, default=0.0, metavar="P", help="probability of not answering")
    p.add_argument("--late", type=probability, default=0.0, metavar="P",
                   help="probability of answering 0.8 s late")
    p.add_argument("--init-seconds", type=non_negative_float, default=3.0, metavar="S",
                   help="how long IX takes (default 3)")
    p.add_argument("--wrong-baud", type=positive_int, metavar="RATE",
                   help="fault: answer at RATE while the line runs at --baud (a misconfigured gimbal)")
    p.add_argument("--ignore-rate", action="store_true",
                   help="fault: ACK a rate change (C0..C7) but keep the old rate, so nothing is answered after")
    p.set_defaults(run=run)


def start_line(addresses: list[tuple[int, int, int]], args: argparse.Namespace) -> str:
    """What the simulator says when it starts: without it a silent terminal looks hung."""
    names = ", ".join(map(format_address, addresses))
    rate = f"{args.baud} baud"
    if args.wrong_baud:
        rate += f" (answers sent at {args.wrong_baud})"
    noun = "gimbal" if len(addresses) == 1 else "gimbals"
    return f"gimbalscope: sim: {noun} {names} answering on {args.port} at {rate} (Ctrl-C stops)"


def run(args: argparse.Namespace) -> int:
    addresses = args.address or [DEFAULT_ADDRESS]
    faults = Faults(drop_ack=args.drop_acks, late=args.late, ignore_rate=args.ignore_rate)
    gimbals = [GimbalModel(a, serial=f"SN{k:04d}", init_seconds=args.init_seconds, faults=faults)
               for k, a in enumerate(addresses, 1)]
    from ..sources.serialport import open_port
    open_port(args.port, args.baud, 8, "N", 1).close()   # one clear line if the port is bad
    bus = GimbalBus(args.port, gimbals, args.baud, wrong_baud=args.wrong_baud)
    done = threading.Event()
    # handlers before the start line: whoever reads it may stop us at once
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: done.set())
    bus.start()
    print(start_line(addresses, args), file=sys.stderr, flush=True)
    while not done.wait(0.2):
        if not bus.is_alive():
            break
    bus.stop()
    bus.join(timeout=1.0)
    return 0
