"""``gimbalscope serve [--host H] [--port P] COMMAND ARGS…``: the TUI of ``view``,
``live``, ``replay`` or ``demo`` in a browser, through Textual's web server; each
browser tab gets a session of its own (docs/tui.md, "In a browser").

The command line is checked before anything is served, as the command itself
would check it, so that a mistake is one line here rather than a session that
ends in every tab. A capture that cannot be read is refused the same way.

A session that holds something only one can hold (a live port, a file being
recorded, a Foxglove server's port) is given to one tab at a time; another tab
is told so.
"""

from __future__ import annotations

import argparse
import shlex
import socket
import sys

from ..errors import ServeError, UsageError
from ..netaddress import LOCAL_HOST, WILDCARDS, show_address, who_reaches
from .common import Subcommands, open_inputs

# the commands whose TUI can be served, as --help lists them
SERVED = ("view", "live", "replay", "demo")


DEFAULT_PORT = 8000


def register(sub: Subcommands) -> None:
    p = sub.add_parser("serve", help="serve the TUI of view, live, replay or demo to a web browser",
                       description="Serve the TUI of COMMAND (view, live, replay or demo, with its own "
                                   "arguments) over HTTP: open the address it prints in a browser; each tab runs "
                                   "a session of its own. Bound to 127.0.0.1 unless --host is given; from another "
                                   "machine, tunnel over SSH (docs/tui.md, 'In a browser').",
                       usage="gimbalscope serve [-h] [--host HOST] [--port PORT] [--public-url URL] "
                             "{view,live,replay,demo} [ARGS ...]")
    p.add_argument("--host", default=LOCAL_HOST,
                   help=f"the address to listen on (default {LOCAL_HOST}: this machine only; 0.0.0.0: every "
                        "network, with no password)")
    p.add_argument("--port", type=tcp_port, default=DEFAULT_PORT,
                   help=f"the TCP port (default {DEFAULT_PORT}; 0: any free one)")
    p.add_argument("--public-url", metavar="URL",
                   help="the address browsers reach this server by, when a proxy serves it under another "
                        "(default: the address each browser used)")
    p.add_argument("command", choices=SERVED, metavar="COMMAND", help="view, live, replay or demo")
    p.add_argument("args", nargs=argparse.REMAINDER, metavar="ARGS", help="the command's own arguments")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..tui.web_server import TuiWebServer, bind

    served = checked(args.command, args.args)
    try:
        sock = bind(args.host, args.port)
    except ServeError as e:
        raise UsageError(str(e)) from None
    line = shlex.join(["gimbalscope", args.command, *args.args])
    session = shlex.join([sys.executable, "-m", "analyzer", args.command, *args.args])
    server = TuiWebServer(session, sock, title=line, public_url=args.public_url, one_at_a_time=holds(served))
    port = server.port   # the one bound (0 asks for any free one)
    if args.host in WILDCARDS:   # no browser goes to 0.0.0.0: name this machine instead
        where = f"http://{show_address('127.0.0.1', port)}, or from elsewhere http://{show_address(socket.gethostname(), port)}"
    else:
        where = f"http://{show_address(args.host, port)}"
    print(f"gimbalscope: serving `{line}` on {where} (open it in a browser; each tab is a session of its own; "
          "Ctrl-C stops)", file=sys.stderr, flush=True)
    print(f"gimbalscope: reachable by {who_reaches(args.host)}", file=sys.stderr, flush=True)
    server.serve()
    return 0


def tcp_port(text: str) -> int:
    """``--port`` (an argparse type): 0 to 65535."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid int value: {text!r}") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r}: a TCP port is 0 to 65535")
    return port


def checked(command: str, argv: list[str]) -> argparse.Namespace:
    """``command``'s arguments parsed and checked as the command would, before
    serving: a usage mistake exits here (2, one line), a capture that cannot be
    read is a CaptureError."""
    from ..tui.run import keymap_from
    from .common import build_filter
    from .main import build_parser

    parsed = build_parser((command,)).parse_args([command, *argv])
    given = vars(parsed)
    if given.get("no_tui") or given.get("format", "text") != "text":
        raise UsageError(f"serve shows {command}'s TUI: --no-tui and --format print events instead")
    keymap_from(parsed)
    build_filter(given.get("filter"))
    if command in ("view", "replay"):
        open_inputs(parsed).source.close()
    elif command == "live":
        from .live import check_inputs

        check_inputs(parsed)
    return parsed


def holds(parsed: argparse.Namespace) -> str | None:
    """What one session holds that a second could not share, in words (None: nothing)."""
    given = vars(parsed)
    if parsed.command == "live":
        return "the live tap"
    if given.get("record"):
        return f"the recording {given['record']}"
    if given.get("foxglove"):
        return "the Foxglove server"
    return None
