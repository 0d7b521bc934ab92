"""Wireshark's extcap interface to a live tap (docs/wireshark.md, "Live
capture"): Wireshark and tshark run this program (``gimbalscope wireshark
install`` puts a launcher in their extcap folder) to list the interface, ask
for its configuration and capture.

- ``--extcap-interfaces``: the ``gimbalscope`` interface;
- ``--extcap-dlts``: its link type (exported PDU, the ``gimbal`` dissector);
- ``--extcap-config``: port, second port (line B; none for a single-line tap),
  baud rate (Table 4's rates) and framing;
- ``--capture --fifo PATH``: taps the ports as ``gimbalscope live`` does and
  streams pcapng into the FIFO, a batch of packets at a time, until Wireshark
  stops it (SIGTERM, SIGINT, or the FIFO closed) and then exits 0.

A bad configuration (no port, a port that does not open, a framing we do not
know) is one line on standard error and exit status 1: Wireshark shows that
line in its error dialog. Never a traceback.
"""

from __future__ import annotations

import argparse
import re
import signal
import sys
from typing import BinaryIO

from dissectors.commands import BAUD_CODES
from dissectors.event import Event

from ..errors import ExtcapError
from ..formats import pdu

INTERFACE = "gimbalscope"
DISPLAY = "Gimbal serial bus, one or two serial ports"
FRAMINGS = ("8N1", "8E1", "8O1", "8N2", "7E1", "7O1", "7E2", "7N2")
_FRAMING = re.compile(r"([5-8])([NEOMS])(1|1\.5|2)")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="gimbalscope-extcap", add_help=True,
                                description="Wireshark extcap interface of gimbalscope (docs/wireshark.md)")
    p.add_argument("--extcap-interfaces", action="store_true")
    p.add_argument("--extcap-version", default=None)
    p.add_argument("--extcap-interface", default=None)
    p.add_argument("--extcap-dlts", action="store_true")
    p.add_argument("--extcap-config", action="store_true")
    p.add_argument("--extcap-capture-filter", default=None)
    p.add_argument("--capture", action="store_true")
    p.add_argument("--fifo", default=None)
    p.add_argument("--port", default="")
    p.add_argument("--port2", default="")
    p.add_argument("--baud", default="9600")
    p.add_argument("--framing", default="8N1")
    return p


def interfaces() -> list[str]:
    from ..version import __version__
    return [f"extcap {{version={__version__}}}",
            f"interface {{value={INTERFACE}}}{{display={DISPLAY}}}"]


def dlts() -> list[str]:
    return [f"dlt {{number={pdu.LINKTYPE}}}{{name=WIRESHARK_UPPER_PDU}}{{display=gimbal (gimbalscope packets)}}"]


def _ports() -> list[tuple[str, str]]:
    """Serial ports this machine has, (device, description), as pyserial lists them."""
    try:
        from serial.tools import list_ports
        return [(p.device, p.description or p.device) for p in sorted(list_ports.comports())]
    except Exception:   # noqa: BLE001 - listing is a convenience: a port can always be typed in
        return []


def _clean(text: str) -> str:
    """A value inside the protocol's braces."""
    return text.replace("{", "(").replace("}", ")").replace("\n", " ")


def config() -> list[str]:
    # ports are strings (Wireshark 4.0 has no editable list): a device name or a
    # pyserial URL; the ports this machine has are named in the tooltip
    ports = _ports()
    found = "; this machine has " + ", ".join(
        _clean(d) if desc in ("n/a", d) else f"{_clean(d)} ({_clean(desc)})" for d, desc in ports) if ports else ""
    placeholder = _clean(ports[0][0]) if ports else "/dev/ttyUSB0"
    out = [
        ("arg {number=0}{call=--port}{display=Port}{type=string}{required=true}"
         f"{{placeholder={placeholder}}}"
         "{tooltip=The serial port of line A (controller to device), or of a single-line tap: "
         f"a device name or a pyserial URL{found}}}"),
        ("arg {number=1}{call=--port2}{display=Second port}{type=string}"
         "{tooltip=The serial port of line B (device to controller); empty for a single-line tap}"),
        ("arg {number=2}{call=--baud}{display=Baud rate}{type=selector}"
         "{tooltip=The line rate at the start; a rate-set command (C0-C7) changes it}"),
        "arg {number=3}{call=--framing}{display=Framing}{type=selector}{tooltip=Data bits, parity, stop bits}",
    ]
    for baud in BAUD_CODES.values():
        default = "{default=true}" if baud == 9600 else ""
        out.append(f"value {{arg=2}}{{value={baud}}}{{display={baud}}}{default}")
    for framing in FRAMINGS:
        default = "{default=true}" if framing == "8N1" else ""
        out.append(f"value {{arg=3}}{{value={framing}}}{{display={framing}}}{default}")
    return out


def framing(text: str) -> tuple[int, str, float]:
    m = _FRAMING.fullmatch(text.strip().upper())
    if m is None:
        raise ExtcapError(f"framing {text!r}: expected data bits, parity and stop bits, like 8N1 or 7E2")
    return int(m.group(1)), m.group(2), float(m.group(3))


def capture(args: argparse.Namespace) -> int:
    """Tap the ports into the FIFO until stopped."""

    if not args.fifo:
        raise ExtcapError("--capture needs --fifo (Wireshark gives it)")
    # the FIFO first, whatever follows: Wireshark waits to open its end, and
    # reads our error line once we close ours
    try:
        fifo = open(args.fifo, "wb")   # noqa: SIM115 - closed below, after an error is said into it
    except OSError as e:
        raise ExtcapError(f"{args.fifo}: cannot open the capture FIFO: {e.strerror or e}") from None
    try:
        return _tap(args, fifo)
    except ExtcapError as e:
        # said before the FIFO closes: dumpcap ends the capture when it sees the
        # FIFO's end, with whatever this program has said on stderr by then (said
        # after, tshark printed an empty "tshark: " on a busy machine)
        _say(e)
        return 1
    finally:
        try:
            fifo.close()
        except OSError:
            pass


def _tap(args: argparse.Namespace, fifo: BinaryIO) -> int:
    from ..capture import Options, open_live
    from ..info import CaptureInfo
    from ..runner import Listener, TapRunner
    from ..sources import CaptureError
    from ..sources.serialport import open_port
    from ..writers.pcapng import PcapngWriter

    if not args.port:
        raise ExtcapError("no port given: set Port in the interface's options")
    try:
        baud = int(args.baud)
    except ValueError:
        raise ExtcapError(f"baud rate {args.baud!r}: expected a number of bits per second, like 9600") from None
    if baud <= 0:
        raise ExtcapError(f"baud rate {baud}: must be positive")
    data_bits, parity, stop_bits = framing(args.framing)
    ports = [args.port] + ([args.port2] if args.port2 else [])
    options = Options(baud=baud, data_bits=data_bits, parity=parity, stop_bits=stop_bits)
    for port in ports:   # each port once, for one clear line naming the one that fails
        try:
            open_port(port, baud, data_bits, parity, stop_bits).close()
        except CaptureError as e:
            raise ExtcapError(str(e)) from None
    cap = open_live(ports, options)
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: cap.source.stop())
    info = CaptureInfo.of(cap, command="extcap")
    writer = PcapngWriter(args.fifo, info, file=fifo, flush=True)
    fifo.flush()   # the header first: Wireshark waits for it

    class Guard(Listener):
        """The writer, stopping the tap instead of raising when the reader has gone."""
        def on_events(self, events: list[Event]) -> None:
            try:
                writer.on_events(events)
            except (BrokenPipeError, OSError):
                cap.source.stop()

    try:
        TapRunner(cap, [Guard()], info=info).run()
    except CaptureError as e:
        raise ExtcapError(str(e)) from None
    return 0


def _say(e: ExtcapError) -> None:
    """The one line Wireshark shows for a failed capture (it reads the program's stderr)."""
    print(f"gimbalscope: {e}", file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    args, _unknown = parser().parse_known_args(argv)   # newer Wireshark may pass more
    try:
        if args.extcap_interfaces:
            print("\n".join(interfaces()))
        elif args.extcap_interface not in (None, INTERFACE):
            raise ExtcapError(f"unknown interface {args.extcap_interface!r}: this program has {INTERFACE!r}")
        elif args.extcap_dlts:
            print("\n".join(dlts()))
        elif args.extcap_config:
            print("\n".join(config()))
        elif args.capture:
            return capture(args)
        else:
            raise ExtcapError("run by Wireshark: expected --extcap-interfaces, --extcap-dlts, "
                              "--extcap-config or --capture")
    except ExtcapError as e:
        _say(e)
        return 1
    except KeyboardInterrupt:
        return 0
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
