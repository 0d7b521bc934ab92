"""``gimbalscope live``: tap one or two serial lines and print events as they are
decoded (text or JSON Lines, flushed per event), optionally recording to MCAP.

Framing per Table 1, pairing per §1.4.2-1.4.3; the same decoding as ``decode``,
so live output for the same bytes equals ``decode`` of the recording.

``--record`` is written in place (not renamed at the end like other outputs), so
a killed tap leaves its file under the name given; an existing file is replaced,
but a folder, a missing folder or one of the ports is refused before the tap
starts. A recording that fails (a full disk) is said once and stopped, and the
tap goes on printing (analyzer/writers/mcap.py).

``--foxglove`` serves the same topics live to the Foxglove app
(analyzer/listeners/foxglove.py), the lean profile's with ``--lean``; an address
that cannot be served is refused before the tap starts too.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import sys
from types import FrameType
from typing import TYPE_CHECKING

from ..capture import Capture, open_live
from ..info import CaptureInfo
from ..listeners import DoctorListener, EventPrinter, NotePrinter
from ..listeners.stop_after import StopAfter
from ..netaddress import LOCAL_HOST
from ..outfile import check_output
from ..runner import Listener, TapRunner
from ..screen import has_screen
from ..writers import open_format
from ..writers.mcap import McapWriter
from ..writers.mcap_recorder import part_path
from ..writers.windows import WindowKeeper, window_path
from .common import (
    Subcommands,
    UsageError,
    add_channels_arg,
    add_fields_arg,
    add_filter_arg,
    add_permission_args,
    add_sample_stream_args,
    add_serial_args,
    build_filter,
    duration,
    fields_option,
    options_from,
    permissions,
    positive_float,
    positive_int,
)

if TYPE_CHECKING:
    from ..talk.session import TalkSession


def register(sub: Subcommands) -> None:
    p = sub.add_parser("live", help="tap serial lines live",
                       description="Tap one serial port (single-line tap) or two (line A controller→device, "
                                   "line B device→controller). Ports are device names or pyserial URLs "
                                   "(socket://, rfc2217://, loop://). The tap never writes to the line.")
    p.add_argument("ports", nargs="*", metavar="PORT", help="one or two ports")
    add_serial_args(p, files=False)
    add_samples_args(p)
    p.add_argument("--format", choices=("text", "jsonl", "csv"), default="text")
    add_fields_arg(p)
    add_filter_arg(p, "show only matching events (everything is still recorded)")
    add_record_args(p)
    add_keep_args(p)
    add_foxglove_arg(p)
    add_tui_args(p)
    add_talk_args(p)
    p.set_defaults(run=run)


def add_keep_args(p: argparse.ArgumentParser, stop_after: bool = True) -> None:
    g = p.add_argument_group("unattended: keep windows around events (docs/live.md, \"Keeping windows\")")
    g.add_argument("--keep", metavar="FILTER",
                   help="with --record DIR: keep only windows around events matching FILTER, one recording "
                        "a window in DIR (e.g. 'status == \"nak\" or \"bad checksum\" in problems')")
    g.add_argument("--before", type=duration, default=30.0, metavar="DURATION",
                   help="with --keep: kept ahead of a match (default 30s; the memory held)")
    g.add_argument("--after", type=duration, default=30.0, metavar="DURATION",
                   help="with --keep: kept beyond a match (default 30s)")
    g.add_argument("--max-windows", type=positive_int, metavar="N", help="with --keep: stop after N windows")
    if stop_after:
        g.add_argument("--stop-after", type=duration, metavar="DURATION", help="stop the tap after DURATION (e.g. 8h)")
    else:
        p.set_defaults(stop_after=None)


def check_keep(args: argparse.Namespace) -> None:
    """What --keep and its options need, refused before anything is opened."""
    if args.keep is not None:
        if not args.record:
            raise UsageError("--keep needs --record DIR: the folder its windows are written in")
        if args.rotate_mb or args.rotate_minutes:
            raise UsageError("--keep writes a file a window: --rotate-mb and --rotate-minutes do not apply")
        build_filter(args.keep, "--keep")   # a mistake in it is said before anything is opened
    elif args.max_windows is not None:
        raise UsageError("--max-windows goes with --keep")


def add_talk_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("talking from the TUI (docs/talk.md, \"From the TUI\")")
    g.add_argument("--talk", action="store_true",
                   help="one port, both directions: the TUI's : prompt sends commands on it (in send's words); "
                        "what is sent is line A, what comes back line B")
    add_permission_args(g, when="with --talk: ")


def add_samples_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("a live logic analyser (docs/instruments.md)")
    g.add_argument("--samples", metavar="FILE",
                   help="read logic samples instead of ports: - for standard input (sigrok-cli --continuous "
                        "-O binary ... | gimbalscope live --samples - --samplerate 1MHz)")
    add_sample_stream_args(g)
    add_channels_arg(g)


def add_tui_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--no-tui", action="store_true",
                   help="print events instead of opening the TUI (also when output is not a terminal)")
    p.add_argument("--keymap", metavar="FILE.toml", help="TUI key bindings: binding id = \"keys\"")


def add_record_args(p: argparse.ArgumentParser, force: bool = True) -> None:
    """--record and its options; ``force``: with --force (a command whose --force
    says more than replacing the recording adds its own)."""
    p.add_argument("--record", metavar="FILE.mcap", help="record raw bytes and events to MCAP")
    if force:
        p.add_argument("--force", action="store_true", help="with --record: replace FILE.mcap if it exists")
    p.add_argument("--rotate-mb", type=positive_float, metavar="MB", help="with --record: a new file every MB megabytes of messages (before compression)")
    p.add_argument("--rotate-minutes", type=positive_float, metavar="MIN", help="with --record: a new file every MIN minutes")
    p.add_argument("--lean", action="store_true",
                   help="with --record, and for the TUI's record key: lean recordings (no /events, raw reads "
                        "batched; about a third the size; docs/mcap.md)")
    p.add_argument("--site", metavar="NAME", help="with --record: where the tap is, kept in the recording's metadata "
                                                  "(gimbalscope export puts it in the dataset's site column)")


# the SDK's defaults (analyzer/listeners/foxglove.py), here so that parsing the
# command line does not import the SDK
FOXGLOVE_HOST, FOXGLOVE_PORT = LOCAL_HOST, 8765
_ADDRESS = re.compile(r"(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]*)(?::([0-9]{1,5}))?")


def add_foxglove_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--foxglove", nargs="?", const=(FOXGLOVE_HOST, FOXGLOVE_PORT), type=foxglove_address,
                   metavar="HOST:PORT",
                   help=f"serve the tap live to the Foxglove app over WebSocket (default "
                        f"{FOXGLOVE_HOST}:{FOXGLOVE_PORT}; HOST:PORT, :PORT, PORT or HOST; give it after the "
                        f"inputs, or as --foxglove=HOST:PORT)")


def foxglove_address(text: str) -> tuple[str, int]:
    """``--foxglove``: HOST:PORT, :PORT or PORT (this machine), HOST (port 8765); an
    IPv6 host in brackets."""
    if _names_an_input(text):
        # `--foxglove demo.mcap`: the optional address took the input, and argparse
        # would go on to say only that an input is missing
        raise argparse.ArgumentTypeError(
            f"{text!r} was taken as the server's address, and looks like an input: give --foxglove after the "
            f"inputs ({text} --foxglove), or its address as --foxglove=HOST:PORT")
    bare_port = text.isascii() and text.isdigit()
    m = _ADDRESS.fullmatch(":" + text if bare_port else text)
    if m is None or not text or int(m.group(2) or 0) > 65535:
        raise argparse.ArgumentTypeError(f"{text!r}: expected HOST:PORT, :PORT, PORT or HOST "
                                         f"(e.g. {FOXGLOVE_HOST}:{FOXGLOVE_PORT}), PORT from 0 to 65535")
    host, port = m.group(1).strip("[]"), m.group(2)
    return host or FOXGLOVE_HOST, int(port) if port else FOXGLOVE_PORT


# what inputs are named like: capture files, and the ports a tap reads
_INPUT_SUFFIXES = (".mcap", ".log", ".bin", ".pcapng", ".gz", ".zst", ".xz", ".bz2")


def _names_an_input(text: str) -> bool:
    """Is ``text`` a file, a device or an input's name rather than a host?"""
    return (os.path.exists(text) or "/" in text or text.lower().endswith(_INPUT_SUFFIXES)
            or text == "-")


def open_servers(capture: Capture, info: CaptureInfo, args: argparse.Namespace,
                 speed: float | None = None, lean: bool = False) -> list[Listener]:
    """The --foxglove server, serving from now on (so a client can connect before
    the tap starts), or nothing; an address that cannot be served is a one-line
    error before anything starts. ``speed``: the server paces the events itself
    (a replay in the TUI). ``lean``: the tap records lean (--lean), and the server
    sends the lean profile's topics."""
    address = args.foxglove
    if address is None:
        return []
    from ..listeners.foxglove import FoxgloveServer, ServeError

    try:
        return [FoxgloveServer(info, *address, speed=speed, lean=lean)]
    except ServeError as e:
        capture.source.close()
        raise UsageError(f"--foxglove {e}") from None


def open_outputs(capture: Capture, info: CaptureInfo, args: argparse.Namespace,
                 record: str | None) -> tuple[McapWriter | None, list[Listener], WindowKeeper | None]:
    """The --record writer and the --foxglove server, both checked before the tap
    starts; the server first, so a refused address leaves no recording behind.
    With --keep, the recording is windows (a listener beside the servers), and
    --stop-after a listener that ends the tap. Returns the recorder, every
    listener but the recorder, and the keeper of --keep (among those listeners)."""
    servers = open_servers(capture, info, args, lean=args.lean)
    stop: list[Listener] = [StopAfter(args.stop_after)] if args.stop_after is not None else []
    try:
        if args.keep is not None:
            keeper = open_windows(capture, info, args, record)
            return None, [*servers, keeper, *stop], keeper
        return open_recorder(capture, info, args, record), [*servers, *stop], None
    except BaseException:
        for server in servers:
            server.close()
        raise


def open_windows(capture: Capture, info: CaptureInfo, args: argparse.Namespace, folder: str | None) -> WindowKeeper:
    """The --keep windows' keeper, writing into the folder --record names (made
    if missing); a folder that cannot take them is a one-line error before the tap starts."""
    keep = build_filter(args.keep, "--keep")
    assert keep is not None and folder   # check_inputs: --keep needs --record
    try:
        if os.path.lexists(folder) and not os.path.isdir(folder):
            raise UsageError(f"--record {folder}: with --keep, --record names a folder for the windows")
        os.makedirs(folder, exist_ok=True)
        check_output(window_path(folder, 1), info.inputs if info.live else (), force=args.force, role="port")
    except OSError as e:
        capture.source.close()
        raise UsageError(f"--record {folder}: cannot make the folder ({e.strerror})") from None
    except BaseException:
        capture.source.close()
        raise
    return WindowKeeper(folder, info, keep, args.keep, before=args.before, after=args.after,
                        max_windows=args.max_windows, lean=args.lean)


def open_recorder(capture: Capture, info: CaptureInfo, args: argparse.Namespace,
                  record: str | None) -> McapWriter | None:
    """The --record writer (in parts with --rotate-*), or None; a path that cannot
    be written is a one-line error before anything starts. A failure later is
    said once (the recording stops, the tap goes on)."""
    if not record:
        return None
    mb, minutes = args.rotate_mb, args.rotate_minutes
    try:
        # a recording is never replaced silently (--force), and never written over a
        # port, into a folder or a missing folder; in parts, the first part's name counts
        first = part_path(record, 1) if mb or minutes else record
        check_output(first, info.inputs if info.live else (), force=args.force, role="port")
        return McapWriter(record, info, live=True, rotate_bytes=int(mb * 1e6) if mb else None,
                          rotate_seconds=minutes * 60 if minutes else None, lean=args.lean)
    except BaseException:
        capture.source.close()
        raise


def wants_tui(args: argparse.Namespace) -> bool:
    """The TUI unless --no-tui, JSON Lines, or output that is not a terminal (a pipe
    or a file gets the printed events, as grep and jq expect). Standard input must
    be a terminal too (a logic analyser's piped samples were moved aside for it),
    unless the screen is a browser tab (``gimbalscope serve``)."""
    return not args.no_tui and args.format == "text" and has_screen()


def tap(capture: Capture, args: argparse.Namespace, record: str | None, command: str = "live",
        talk: TalkSession | None = None) -> int:
    """Run a live capture: the TUI, or printed events (see ``wants_tui``); ``talk``:
    the port the TUI's prompt sends on (``--talk``)."""
    info = CaptureInfo.of(capture, command=command, site=args.site)
    if not wants_tui(args):
        return tap_and_print(capture, info, args, record)
    from ..tui.run import KeymapError, load_keymap, run_app

    try:
        keymap = load_keymap(args.keymap)
    except KeymapError as e:
        capture.source.close()
        raise UsageError(str(e)) from None
    recorder, servers, windows = open_outputs(capture, info, args, record)
    return run_app(capture, mode="live", ports=list(info.inputs), recorder=recorder,
                   record_path=None if windows is not None else record, record_lean=args.lean,
                   info=info, keymap=keymap, listeners=servers, talk=talk, windows=windows)


def tap_and_print(capture: Capture, info: CaptureInfo, args: argparse.Namespace, record: str | None) -> int:
    """Run a live capture to the end, printing events and notes, with the wiring
    doctor alongside (SIGINT/SIGTERM stop it cleanly)."""
    keep = build_filter(args.filter)
    sink = open_format(args.format, info, flush_each=True,   # every event as it comes
                       **fields_option(args.fields, args.format == "csv", f"--format {args.format}"))
    recorder, servers, _windows = open_outputs(capture, info, args, record)
    # the servers beside the recorder: both hear the doctor's notes after the same events
    listeners = [l for l in (recorder, *servers, DoctorListener(), EventPrinter(sink, keep), NotePrinter())
                 if l is not None]
    runner = TapRunner(capture, listeners, info=info)

    def stop(_signum: int, _frame: FrameType | None) -> None:
        runner.stop()

    old = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    if info.command == "live":   # (the demo's ports are its own simulator's, and it ends by itself)
        # Said once the ports are open and a signal stops the tap cleanly: from here on
        # no byte written to the line is missed (what a script waits for, as with tcpdump).
        print(f"gimbalscope live: listening on {capture.source.description} (until Ctrl-C)", file=sys.stderr,
              flush=True)
    # Reader threads stamp each read with the host clock; the interpreter's default
    # 5 ms thread switch interval would delay them by as much. Switch more often.
    switch = sys.getswitchinterval()
    sys.setswitchinterval(0.0002)
    try:
        runner.run()
    finally:
        sys.setswitchinterval(switch)
        for sig, handler in old.items():
            signal.signal(sig, handler)
    return 0


def check_inputs(args: argparse.Namespace) -> None:
    """What the command line must say of its inputs, refused (UsageError) before
    anything is opened; ``serve live`` checks it before serving too."""
    if args.samples is not None:
        if args.ports:
            raise UsageError("give ports or --samples, not both")
        if args.samplerate is None:
            raise UsageError("--samples needs --samplerate: the stream has no header (e.g. --samplerate 1MHz)")
    else:
        if args.samplerate is not None or args.channels is not None:
            raise UsageError("--samplerate and --channels are for --samples (a logic analyser's stream)")
        if not args.ports:
            raise UsageError("give one or two ports, or --samples - for a logic analyser's stream")
        if len(args.ports) > 2:
            raise UsageError(f"{len(args.ports)} ports given: a tap reads one port or two (line A, line B)")
    if args.talk and (args.samples is not None or len(args.ports) != 1):
        raise UsageError("--talk takes one port: what is sent on it is line A, what comes back line B")
    if not args.talk and (args.allow_motion or args.allow_config):
        raise UsageError("--allow-motion and --allow-config go with --talk (a tap never sends)")
    check_keep(args)


def run(args: argparse.Namespace) -> int:
    check_inputs(args)
    if args.samples is not None:
        return run_samples(args)
    if args.talk:
        return run_talking(args)
    capture = open_live(args.ports, options_from(args))
    return tap(capture, args, args.record)


def run_talking(args: argparse.Namespace) -> int:
    """``--talk``: the one port as both lines, the TUI's prompt sending on it."""
    from ..talk.link import TalkLink
    from ..talk.session import TalkSession

    if not wants_tui(args):
        raise UsageError("--talk sends from the TUI's : prompt: it needs the TUI (a terminal, or gimbalscope serve)")
    options = options_from(args)
    link = TalkLink(args.ports[0], baud=options.baud, data_bits=options.data_bits, parity=options.parity,
                    stop_bits=options.stop_bits)
    capture = Capture(link, options)
    capture.inputs = (args.ports[0],)
    session = TalkSession(link, permissions(args))
    return tap(capture, args, args.record, talk=session)


def run_samples(args: argparse.Namespace) -> int:
    """A logic analyser's sample stream, live."""
    from ..capture import open_samples

    samples = args.samples
    if samples == "-" and not sys.stdin.isatty() and sys.stdout.isatty() and not args.no_tui \
            and args.format == "text":
        # the TUI reads keys from standard input, which carries the samples: keep
        # the pipe on a descriptor of its own and give the TUI the terminal (as less does)
        samples = _pipe_aside_terminal_in() or samples
    capture = open_samples(samples, args.samplerate, args.unitsize or 1, options_from(args), given=args.samples)
    return tap(capture, args, args.record)


def _pipe_aside_terminal_in() -> str | None:
    """Move the standard input pipe to another descriptor and put the controlling
    terminal on standard input; the pipe's new name (/dev/fd/N), or None when
    there is no terminal (then events are printed)."""
    try:
        tty = os.open("/dev/tty", os.O_RDONLY)
    except OSError:
        return None
    pipe = os.dup(0)
    os.dup2(tty, 0)
    os.close(tty)
    sys.stdin = open(0, closefd=False)   # noqa: SIM115 - standard input from now on, never closed
    return f"/dev/fd/{pipe}"
