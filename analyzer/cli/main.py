"""Entry point of the ``gimbalscope`` console command: dispatches subcommands and
turns every expected failure into one line on stderr and a non-zero exit: 2 for
bad input or usage, 1 for an output that could not be written."""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import signal
import sys
from collections.abc import Sequence
from contextlib import AbstractContextManager, nullcontext

from .. import worker_process
from ..docs import page
from ..errors import DatasetError, UsageError
from ..extras import missing_extra
from ..outfile import OutputError, one_line
from ..output import StdoutError, flush_stdout, stdout_error
from ..sources import CaptureError, formats
from ..sources.meter import READS
from ..version import __version__

EXIT_INPUT = 2
EXIT_OUTPUT = 1

# Errors only a write can give. Every file gimbalscope writes turns them into an
# OutputError naming it, so one escaping bare came from a report printed straight
# to standard output.
WRITE_ONLY_ERRORS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)

# the subcommands, one module each (named as the command), in the order --help lists them
COMMANDS = ("decode", "stats", "doctor", "demo", "live", "sim", "probe", "send", "replay", "view", "convert",
            "export", "query", "serve", "report", "recover", "foxglove", "wireshark", "sigrok", "saleae", "diff")
# the process a command will start, started before the command's modules are
# imported (worker_process.prepared): view's decoding process then imports while
# the screen's modules do, and its first rows come with the first screen (docs/tui.md)
PREPARED = {"view": "analyzer.tui.decode_process"}


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage mistake is one line (and exit 2), like every other error."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_INPUT, f"gimbalscope: error: {message} (see: {self.prog} --help)\n")


def build_parser(commands: Sequence[str] = COMMANDS) -> argparse.ArgumentParser:
    """The command line of ``commands`` (all of them unless told)."""
    p = OneLineParser(prog="gimbalscope",
                      description="Protocol analyzer for servo pan-tilt gimbals (serial command set rev 1.9).",
                      epilog=f"Captures read: {', '.join(formats())}; live: serial ports (device names, "
                             "pyserial URLs) and logic sample streams. Logic analysers and USB captures: "
                             f"{page('instruments.md')}")
    p.add_argument("--version", action="version", version=f"gimbalscope {__version__}")
    # no command (or a group without its subcommand) runs nothing; commands without -q are not quiet
    p.set_defaults(run=None, quiet=False)
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    for name in commands:
        importlib.import_module(f"{__package__}.{name}").register(sub)
    return p


def commands_of(argv: Sequence[str]) -> Sequence[str]:
    """The commands ``argv`` needs parsed: the one it names first, else all of
    them (for --help, --version, or a mistake). A command's module is imported
    only to run it: the others' added over a tenth of a second to every start,
    and ``view``'s first screen waits on its start (docs/tui.md)."""
    return argv[:1] if argv[:1] and argv[0] in COMMANDS else COMMANDS


def error(message: str) -> None:
    """The one line a failure prints (undecodable bytes and control characters escaped)."""
    if sys.stderr is None:   # with stderr closed there is nowhere to say it
        return
    try:
        print(f"gimbalscope: error: {one_line(message)}", file=sys.stderr, flush=True)
    except OSError:
        pass   # nor with stderr on a full disk


def quiet_stdout() -> None:
    """Point standard output at /dev/null: what is still buffered for it (a reader
    gone, a full disk) then goes nowhere, and the interpreter's final flush does
    not report the failure a second time."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


def early_process(commands: Sequence[str]) -> AbstractContextManager[None]:
    """The process the command will start, started now if it has one (``PREPARED``)."""
    module = PREPARED.get(commands[0]) if len(commands) == 1 else None
    return worker_process.prepared(module) if module else nullcontext()


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    commands = commands_of(argv)
    with early_process(commands):
        return run_command(argv, commands)


def run_command(argv: list[str], commands: Sequence[str]) -> int:
    """Parse ``argv`` (``commands``' command line) and run its command."""
    # here, not at the top: its imports are the command's, made after its early process started
    from .common import set_quiet

    parser = build_parser(commands)
    args = parser.parse_args(argv)
    if args.run is None:
        parser.print_help()
        return EXIT_INPUT
    if sys.stdout is None:   # started with `>&-`: say so before doing any work
        error("standard output is closed")
        return EXIT_OUTPUT
    set_quiet(args.quiet)
    READS.clear()   # the progress bar counts this command's inputs
    try:
        code = args.run(args)
        flush_stdout()   # a full disk behind stdout is reported here, not at exit
        return code
    except (CaptureError, UsageError, DatasetError) as e:
        error(str(e))
        return EXIT_INPUT
    except StdoutError as e:
        error(str(e))
        quiet_stdout()
        return EXIT_OUTPUT
    except OutputError as e:
        error(str(e))
        return e.exit_code
    except BrokenPipeError:
        # the reader went away (| head): not an error
        quiet_stdout()
        return 0
    except OSError as e:
        if e.filename is not None or e.errno not in WRITE_ONLY_ERRORS:
            raise
        error(str(stdout_error(e)))
        quiet_stdout()
        return EXIT_OUTPUT
    except KeyboardInterrupt:
        return 128 + signal.SIGINT
    except ImportError as e:
        # an optional part of the install (the fleet extra) that is not there
        hint = missing_extra(e, args.command)
        if hint is None:
            raise
        error(hint)
        return EXIT_INPUT


if __name__ == "__main__":
    sys.exit(main())
