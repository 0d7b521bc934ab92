"""Options every subcommand shares (inputs, serial settings, timeouts), and the
one-line error handling: bad input never shows a traceback."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import Any, Protocol, TypeVar

from dissectors.event import parse_address as address_of

from ..analysis.filter import FilterError, Predicate, compile_filter
from ..analysis.pairing import Timeouts
from ..capture import Capture, Options
from ..capture import open as open_capture
from ..errors import UsageError
from ..info import CaptureInfo
from ..listeners import NotePrinter
from ..listeners.wiring_check import WiringCheck
from ..outfile import OutputRefused, one_line
from ..runner import Listener, TapRunner
from ..sources import registry
from ..talk.safety import Allowed

STANDARD_BAUDS = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)  # §1.5.1


class Subcommands(Protocol):
    """What a subcommand's ``register`` adds its parser to: the main parser's
    ``add_subparsers()`` (argparse names its class only privately)."""

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser: ...


class ArgumentHolder(Protocol):
    """What options are added to: a parser, or a group of its options."""

    def add_argument(self, *name_or_flags: str, **kwargs: Any) -> argparse.Action: ...


# Numeric option types for argparse (``type=``): a bad value is refused while the
# command line is parsed, as one line naming the option ("argument --frame-gap:
# '-1': must be a finite number above 0"). float() takes "nan" and "inf", which
# would pass every range check and hang or crash later, so each type says finite.

Number = TypeVar("Number", int, float)


def _number(text: str, kind: type[Number], in_range: Callable[[Number], bool], wanted: str) -> Number:
    """Parse ``text`` as ``kind``; refuse it unless finite and ``in_range``."""
    try:
        value = kind(text)
    except ValueError:   # argparse's own wording for a plain type
        raise argparse.ArgumentTypeError(f"invalid {kind.__name__} value: {text!r}") from None
    if (kind is float and not math.isfinite(value)) or not in_range(value):
        raise argparse.ArgumentTypeError(f"{text!r}: must be {wanted}")
    return value


def positive_float(text: str) -> float:
    """Timeouts, frame gaps, rotation sizes, pace factors."""
    return _number(text, float, lambda v: v > 0, "a finite number above 0")


def non_negative_float(text: str) -> float:
    """Durations where 0 means something (until stopped, at once)."""
    return _number(text, float, lambda v: v >= 0, "a finite number, 0 or more")


_DURATION_UNITS = {"ms": 0.001, "s": 1.0, "m": 60.0, "min": 60.0, "h": 3600.0, "d": 86400.0}


def duration(text: str) -> float:
    """A time span in seconds: ``30s``, ``500ms``, ``5m``, ``2h``, ``1d``, or a bare number of seconds."""
    wanted = "a duration, 0 or more: 30s, 500ms, 5m, 2h, 1d, or seconds"
    number = text.strip().lower()
    unit = next((u for u in sorted(_DURATION_UNITS, key=len, reverse=True) if number.endswith(u)), "")
    try:
        value = _number(number[:len(number) - len(unit)] if unit else number, float, lambda v: v >= 0, wanted)
    except argparse.ArgumentTypeError:   # "3x" is no float: say what a duration is, for the text given
        raise argparse.ArgumentTypeError(f"{text!r}: must be {wanted}") from None
    return value * _DURATION_UNITS.get(unit, 1.0)


def probability(text: str) -> float:
    return _number(text, float, lambda v: 0 <= v <= 1, "a probability from 0 to 1")


def positive_int(text: str) -> int:
    """Baud rates."""
    return _number(text, int, lambda v: v > 0, "a whole number above 0")


def non_negative_int(text: str) -> int:
    return _number(text, int, lambda v: v >= 0, "a whole number, 0 or more")


def command_timeout(text: str) -> tuple[str, float]:
    """``--timeout IX=90``: a command id and its result timeout in seconds."""
    cmd, sep, secs = text.partition("=")
    try:
        if sep and cmd:
            return cmd, positive_float(secs)
    except argparse.ArgumentTypeError:
        pass
    raise argparse.ArgumentTypeError(f"{text!r}: expected CMD=SECONDS, seconds a finite number above 0, e.g. IX=90")


def parse_address(text: str, top: int = 254) -> tuple[int, int, int]:
    """``G.P.D``, each 0..``top`` (an argparse type: a bad one is refused while parsing).
    Gimbals have addresses up to 254; 255 is the wildcard a controller may send to."""
    try:
        return address_of(text, top)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected GROUP.PORT.DEVICE, each 0..{top}") from None


def destination(text: str) -> tuple[int, int, int]:
    """``--to G.P.D``: a gimbal's address, or 255 (the wildcard) at any level."""
    return parse_address(text, top=255)


def add_permission_args(g: ArgumentHolder, when: str = "") -> None:
    """``--allow-motion`` and ``--allow-config``: what may be sent beyond asking and
    stopping (docs/talk.md, "What may be sent"); ``when``: the help's condition."""
    g.add_argument("--allow-motion", action="store_true", help=f"{when}allow commands that move the gimbal or its lens")
    g.add_argument("--allow-config", action="store_true",
                   help=f"{when}allow commands that change the gimbal's address, rate, settings or outputs")


def permissions(args: argparse.Namespace) -> Allowed:
    """What ``add_permission_args``' options allow."""
    return Allowed(motion=args.allow_motion, config=args.allow_config)


def add_input_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("inputs", nargs="+", metavar="INPUT", help=registry.input_help())
    add_quiet_arg(p)
    add_serial_args(p)


# The serial and pairing options and their defaults. The parser's defaults are None,
# so an option given on the command line is told from one left at its default: a
# recording's own settings win over defaults, and lose to options given
# (docs/time.md, "Recordings"). Per-command timeouts (--timeout, a list) are read separately.
DEFAULTS = {key: value for key, value in Options().settings().items() if key != "timeouts"}
# the time and instrument options: only for commands that read capture files
FILE_OPTIONS = ("tz", "start_time", "channels", "adapter", "usb_device", "samplerate", "unitsize")


def add_serial_args(p: argparse.ArgumentParser, files: bool = True) -> None:
    """The serial, time and pairing options; ``files``: the command reads capture
    files (the time options are about files)."""
    g = p.add_argument_group("serial settings (byte timing; the port settings of a live tap; a recording "
                             "brings its own, which these override)")
    add_character_args(g)
    g.add_argument("--swap-lines", action="store_const", const=True,
                   help="the two ports/inputs were given the other way round: read the first as line B")
    g.add_argument("--no-follow-rate", dest="follow_rate", action="store_const", const=False,
                   help="keep the rate fixed when the controller changes it (C0-C7, Table 4; by default "
                        "decoding and a live tap follow an ACKed change)")
    if files:
        add_time_args(p)
        add_instrument_args(p)
        p.add_argument("--redecode", action="store_true",
                       help="decode a recording's raw bytes even when it carries its decoded columns "
                            "(by default they are read instead: docs/mcap.md, \"Stored columns\")")
    else:
        # what options_from reads of the file options, unset (a command may still add some of them)
        p.set_defaults(**dict.fromkeys(FILE_OPTIONS), redecode=False)
    _pairing_args(p.add_argument_group("pairing"))


def add_character_args(g: ArgumentHolder, measured: bool = False) -> None:
    """``--baud``, ``--data-bits``, ``--parity``, ``--stop-bits``; ``measured``:
    for a logic capture alone, whose software UART measures what is not given."""
    default = {"baud": "measured", "data_bits": "measured", "parity": "measured", "stop_bits": "measured"} \
        if measured else {"baud": "9600, §1.5.1", "data_bits": "8", "parity": "N", "stop_bits": "1"}
    g.add_argument("--baud", type=positive_int, help=f"line rate in bit/s at the start (default {default['baud']})")
    g.add_argument("--data-bits", type=int, choices=(5, 6, 7, 8), help=f"(default {default['data_bits']})")
    g.add_argument("--parity", choices=("N", "E", "O", "M", "S"), help=f"(default {default['parity']})")
    g.add_argument("--stop-bits", type=float, choices=(1, 1.5, 2), help=f"(default {default['stop_bits']})")


def add_channels_arg(g: ArgumentHolder) -> None:
    g.add_argument("--channels", type=channels, metavar="A=CH,B=CH",
                   help="the logic channels of line A and line B, by name or number (default: the first two "
                        "that toggle); A=CH alone: a single line carrying both directions")


def channels(text: str) -> dict[str, str]:
    """``--channels A=TX,B=RX``: the logic channel (a name or number as the file
    gives it) of each line; ``A=D0`` alone is a single-line capture."""
    out: dict[str, str] = {}
    for part in text.split(","):
        line, sep, name = part.partition("=")
        line = line.strip().upper()
        if not sep or line not in ("A", "B", "AB") or not name.strip() or line in out:
            raise argparse.ArgumentTypeError(
                f"{text!r}: expected A=CHANNEL,B=CHANNEL (a channel's name or number), e.g. A=TX,B=RX")
        out[line] = name.strip()
    if "AB" in out and len(out) > 1:
        raise argparse.ArgumentTypeError(f"{text!r}: AB (one line carrying both directions) goes alone")
    return out


def usb_device(text: str) -> str:
    """``--usb-device 3.7``: bus 3, device 7 (as lsusb and the listing say)."""
    bus, sep, dev = text.partition(".")
    if not (sep and bus.isdigit() and dev.isdigit()):
        raise argparse.ArgumentTypeError(f"{text!r}: expected BUS.DEVICE, e.g. 3.7")
    return f"{int(bus)}.{int(dev)}"


def add_instrument_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("instruments: logic analysers and USB captures (docs/instruments.md)")
    add_channels_arg(g)
    g.add_argument("--adapter", choices=("ftdi", "cp210x", "ch34x"),
                   help="a USB capture's serial adapter (default: from the enumeration or the traffic)")
    g.add_argument("--usb-device", type=usb_device, metavar="BUS.DEV",
                   help="which serial adapter of a USB capture that holds several")
    add_sample_stream_args(g)


def add_sample_stream_args(g: ArgumentHolder) -> None:
    """A bare stream of logic samples has no header: its rate and sample size are given."""
    g.add_argument("--samplerate", type=samplerate, metavar="RATE",
                   help="the input is a bare stream of logic samples (sigrok-cli -O binary) taken at RATE, "
                        "e.g. 1MHz, 500k, 250000")
    g.add_argument("--unitsize", type=int, choices=(1, 2, 4),
                   help="a sample stream's bytes a sample (channel N at bit N; default 1: eight channels)")


def samplerate(text: str) -> float:
    """``--samplerate 1MHz``: samples a second."""
    from ..sources.sigrok import parse_samplerate
    try:
        rate = parse_samplerate(text)
    except ValueError:
        rate = 0
    if rate <= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a rate such as 1MHz, 500k or 250000")
    return rate


def add_time_args(p: argparse.ArgumentParser) -> None:
    c = p.add_argument_group("time (docs/time.md)")
    c.add_argument("--tz", type=zone, metavar="ZONE",
                   help="the time zone a socat log's stamps are in, e.g. Europe/Berlin (default: this machine's)")
    c.add_argument("--start-time", type=iso_time, metavar="ISO8601",
                   help="when a raw dump's first byte was sent, e.g. 2026-11-21T08:35:52Z (default: the "
                        "file's modification time less the capture's duration at the baud rate)")


def _pairing_args(t: ArgumentHolder) -> None:
    t.add_argument("--ack-timeout", type=positive_float, metavar="S",
                   help="seconds a command waits for its ACK/NAK (default 0.5)")
    t.add_argument("--result-timeout", type=positive_float, metavar="S",
                   help="seconds an ACKed command waits for its result (default 2; IX 60)")
    t.add_argument("--timeout", action="append", type=command_timeout, metavar="CMD=S",
                   help="result timeout for one command id, e.g. --timeout IX=90 (repeatable)")
    t.add_argument("--frame-gap", type=positive_float, metavar="S",
                   help="silence that cuts a frame short (default max(50 ms, 20 characters))")


def zone(text: str) -> str:
    """``--tz``: an IANA zone name this machine knows."""
    from ..sources.socatlog import time_zone
    try:
        time_zone(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return text


def iso_time(text: str) -> float:
    """``--start-time``: ISO 8601, as epoch seconds; without a zone it is UTC."""
    import datetime
    try:
        when = datetime.datetime.fromisoformat(text.strip())   # "Z" too, since Python 3.11
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected an ISO 8601 time such as "
                                         "2026-11-21T08:35:52Z") from None
    if when.tzinfo is None:
        when = when.replace(tzinfo=datetime.UTC)
    return when.timestamp()


def add_filter_arg(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--filter", "-Y", metavar="EXPR", help=help)


def add_fields_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--fields", metavar="COLUMNS",
                   help="CSV: the columns, comma-separated, in their order (default: every event column, "
                        "then every field of the command table; docs/json-lines.md, \"CSV\")")


def fields_option(fields: str | None, csv: bool, where: str) -> dict[str, str]:
    """The writer option of ``--fields`` (CSV only: given for another format, one
    line saying so); an unknown column is the writer's one line, said before any
    input is read."""
    if fields is None:
        return {}
    if not csv:
        raise UsageError(f"--fields chooses the columns of CSV, not of {where}")
    from ..writers.csv_table import chosen_columns
    try:
        chosen_columns(fields)
    except OutputRefused as e:
        raise UsageError(str(e)) from None
    return {"fields": fields}


def build_filter(expr: str | None, option: str = "--filter") -> Predicate | None:
    """Compile --filter (or another ``option`` taking a filter); a bad expression
    is one line naming the option and the column."""
    if expr is None:
        return None
    try:
        return compile_filter(expr)
    except FilterError as e:
        raise UsageError(f"{option} {e} in: {e.pointer()}") from None


def options_from(args: argparse.Namespace) -> Options:
    """The capture options; the numbers were checked by their argparse types.
    ``Options.explicit`` names those given on the command line."""
    parsed = vars(args)
    given = {key for key in DEFAULTS if parsed[key] is not None}
    per_command = args.timeout or []
    if per_command:
        given.add("timeouts")
    value = {key: parsed[key] if key in given else default for key, default in DEFAULTS.items()}
    if "baud" in given and value["baud"] not in STANDARD_BAUDS:
        warn(f"--baud {value['baud']} is not a rate of §1.5.1 ({', '.join(map(str, STANDARD_BAUDS))})")
    timeouts = Timeouts(ack=value["ack_timeout"], result=value["result_timeout"],
                        result_by_command=dict(per_command))
    return Options(baud=value["baud"], data_bits=value["data_bits"], parity=value["parity"],
                   stop_bits=value["stop_bits"], frame_gap=value["frame_gap"], timeouts=timeouts,
                   swap_lines=value["swap_lines"], follow_rate=value["follow_rate"],
                   tz=args.tz, start_time=args.start_time, channels=args.channels, adapter=args.adapter,
                   usb_device=args.usb_device, samplerate=args.samplerate, unitsize=args.unitsize or 1,
                   redecode=args.redecode, explicit=frozenset(given))


# -q/--quiet: warnings are not said (set by cli/main.py for the command running;
# errors are still one line, exit codes do not change)
_quiet = False


def set_quiet(quiet: bool) -> None:
    global _quiet
    _quiet = bool(quiet)


def quiet() -> bool:
    """Was -q given: warnings are not said."""
    return _quiet


def add_quiet_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("-q", "--quiet", action="store_true",
                   help="say no warnings (errors are still said, exit codes are the same)")


def warn(msg: str) -> None:
    if _quiet:
        return
    print(f"gimbalscope: warning: {one_line(msg)}", file=sys.stderr, flush=True)


def progress_listener(streams_stdout: bool = False) -> Listener:
    """The progress bar as a listener, for any command that reads capture files
    (``export`` too): shown only when ``progress.wanted``."""
    from ..listeners.progress import ProgressListener, ReadProgress, wanted
    return ProgressListener(ReadProgress(enabled=wanted(streams_stdout)))


def open_inputs(args: argparse.Namespace) -> Capture:
    """The capture the inputs name; its warnings reach the runner's listeners."""
    return open_capture(*args.inputs, options=options_from(args))


def run_tap(capture: Capture, command: str, *listeners: Listener, info: CaptureInfo | None = None,
            notes: bool = True, findings: bool = True, say_empty: bool = True,
            progress: bool = False, streams_stdout: bool = False, check: bool = False) -> TapRunner:
    """Run ``capture`` to its end through ``listeners``, the capture's warnings
    printed on standard error (``notes``; none with -q), with the doctor's findings
    among them (``findings``); an empty capture is said (``say_empty``). With
    ``progress``, a bar of the bytes read shows on a terminal when the work is
    long (analyzer/listeners/progress.py); ``streams_stdout``: the command prints as it
    goes, so no bar when that is to a terminal. ``check``: say at the end what the
    wiring signs show at error level (analyzer/listeners/wiring_check.py)."""
    if check:
        # first: its warnings are posted as it stops, before the writers close
        listeners = (WiringCheck(), *listeners)
    if progress:
        listeners = (progress_listener(streams_stdout), *listeners)
    if notes:
        listeners = (*listeners, NotePrinter(findings=findings, quiet=_quiet))
    runner = TapRunner(capture, listeners, info=info or CaptureInfo.of(capture, command=command))
    runner.run()
    if say_empty and runner.events == 0:
        warn(f"{runner.info.source}: no bytes in this capture")
    return runner
