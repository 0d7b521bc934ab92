"""``gimbalscope sigrok install [--dir D] [--for CAPTURE]``: the sigrok protocol
decoder ``gimbal`` (generated from the command table), written into
libsigrokdecode's per-user decoders folder or into D, for PulseView and
sigrok-cli; ``gimbalscope sigrok command CAPTURE``: the sigrok-cli command that
shows a capture through it (docs/instruments.md, "The sigrok decoder").

What was done goes to standard error; the command to run goes to standard
output, with what it was made of as ``#`` comments, so that it can be pasted or
run as it is (``eval "$(gimbalscope sigrok command cap.sr)"``).
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import TYPE_CHECKING

from ..errors import UsageError
from ..outfile import install_into, one_line, show
from .common import Subcommands, add_channels_arg, add_character_args, add_quiet_arg, warn

if TYPE_CHECKING:
    from ..sigrok.command import SigrokCommand


def register(sub: Subcommands) -> None:
    p = sub.add_parser("sigrok", help="sigrok: install the gimbal protocol decoder for PulseView and sigrok-cli, "
                                      "and print the sigrok-cli command for a capture",
                       description="sigrok interop (docs/instruments.md, 'The sigrok decoder').")
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    i = verbs.add_parser("install", help="write the protocol decoder gimbal (stacks on uart)",
                         description="Write the protocol decoder gimbal (gimbal/__init__.py and gimbal/pd.py) "
                                     "into libsigrokdecode's decoders folder for this user "
                                     "($XDG_DATA_HOME/libsigrokdecode/decoders, ~/.local/share/... by default), "
                                     "or into DIR (then run sigrok-cli with SIGROKDECODE_DIR=DIR).")
    i.add_argument("--dir", metavar="DIR", help="write the decoder into DIR/gimbal instead")
    i.add_argument("--for", dest="capture", metavar="CAPTURE",
                   help="then print the sigrok-cli command for CAPTURE (as gimbalscope sigrok command does)")
    _capture_args(i)
    i.set_defaults(run=run_install)
    c = verbs.add_parser("command", help="print the sigrok-cli command that shows a capture through gimbal",
                         description="Print the sigrok-cli command that shows CAPTURE (a .sr session or a VCD) "
                                     "through the decoder gimbal: the uart decoder given the capture's channel "
                                     "names, and each line's rate, format (data bits, parity, stop bits) and idle "
                                     "level as gimbalscope measures them. The command goes to standard output, "
                                     "what it was made of after it as # comments.")
    c.add_argument("capture", metavar="CAPTURE", help="a sigrok session (.sr) or a VCD")
    c.add_argument("--dir", metavar="DIR",
                   help="the decoder was installed with --dir DIR: the command sets SIGROKDECODE_DIR=DIR")
    _capture_args(c)
    c.set_defaults(run=run_command)


READING = ("channels", "baud", "data_bits", "parity", "stop_bits")   # how the capture is read, when given


def _capture_args(p: argparse.ArgumentParser) -> None:
    add_quiet_arg(p)
    add_channels_arg(p)
    add_character_args(p, measured=True)


def run_install(args: argparse.Namespace) -> int:
    from ..sigrok.command import generic, generic_hints
    from ..sigrok.install import install

    if args.capture is None and any(vars(args)[key] is not None for key in READING):
        raise UsageError("--channels, --baud, --data-bits, --parity and --stop-bits go with --for CAPTURE")
    # the capture first: one that cannot be read installs nothing
    found = _command_for(args) if args.capture is not None else None
    written = install_into(install, args.dir)
    folder = show(os.path.dirname(written[0]))
    if found is None:
        print(f"gimbalscope: wrote the sigrok decoder gimbal into {folder}; use it with: {generic(args.dir).text} "
              "(or in PulseView: add UART, then stack Gimbal on it)", file=sys.stderr, flush=True)
        for hint in generic_hints():
            print(f"# {hint}")
        return 0
    print(f"gimbalscope: wrote the sigrok decoder gimbal into {folder}; the command for "
          f"{show(args.capture)}:", file=sys.stderr, flush=True)
    _print(found)
    return 0


def run_command(args: argparse.Namespace) -> int:
    _print(_command_for(args))
    return 0


def _command_for(args: argparse.Namespace) -> SigrokCommand:
    from ..sigrok.command import command_for

    cmd, warnings = command_for(args.capture, decoders=args.dir, **{key: vars(args)[key] for key in READING})
    for message in warnings:
        warn(message)
    return cmd


def _print(cmd: SigrokCommand) -> None:
    print(one_line(cmd.text))
    for note in cmd.notes:
        print(f"# {one_line(note)}")
