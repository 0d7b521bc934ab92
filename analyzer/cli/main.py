"""Entry point of the ``gimbalscope`` console command: dispatches subcommands and
turns every expected failure into one line on stderr and a non-zero exit."""

from __future__ import annotations

import argparse
import os
import signal
import sys

from .. import __version__
from ..sources import CaptureError
from . import convert, decode, demo, doctor, live, recover, replay, sim, stats, view
from .common import UsageError

EXIT_INPUT = 2


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage mistake is one line (and exit 2), like every other error."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_INPUT, f"gimbalscope: error: {message} (see: {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="gimbalscope",
                      description="Protocol analyzer for servo pan-tilt gimbals (serial command set rev 1.9).")
    p.add_argument("--version", action="version", version=f"gimbalscope {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    decode.register(sub)
    stats.register(sub)
    doctor.register(sub)
    demo.register(sub)
    live.register(sub)
    sim.register(sub)
    replay.register(sub)
    view.register(sub)
    convert.register(sub)
    recover.register(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "run", None):
        parser.print_help()
        return EXIT_INPUT
    try:
        return args.run(args)
    except (CaptureError, UsageError) as e:
        print(f"gimbalscope: error: {e}", file=sys.stderr)
        return EXIT_INPUT
    except BrokenPipeError:
        # the reader went away (| head): not an error. Point stdout at /dev/null so
        # the interpreter's final flush does not complain either.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        return 128 + signal.SIGINT


if __name__ == "__main__":
    sys.exit(main())
