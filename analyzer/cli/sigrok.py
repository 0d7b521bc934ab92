"""``gimbalscope sigrok install [--dir D]``: the sigrok protocol decoder
``gimbal`` (generated from the command table), written into libsigrokdecode's
per-user decoders folder or into D, for PulseView and sigrok-cli
(docs/instruments.md, "The sigrok decoder").
"""

from __future__ import annotations

import argparse
import os
import sys

from ..outfile import install_into, show


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sigrok", help="sigrok: install the gimbal protocol decoder for PulseView and sigrok-cli",
                       description="sigrok interop (docs/instruments.md, 'The sigrok decoder').")
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    i = verbs.add_parser("install", help="write the protocol decoder gimbal (stacks on uart)",
                         description="Write the protocol decoder gimbal (gimbal/__init__.py and gimbal/pd.py) "
                                     "into libsigrokdecode's decoders folder for this user "
                                     "($XDG_DATA_HOME/libsigrokdecode/decoders, ~/.local/share/... by default), "
                                     "or into DIR (then run sigrok-cli with SIGROKDECODE_DIR=DIR).")
    i.add_argument("--dir", metavar="DIR", help="write the decoder into DIR/gimbal instead")
    i.set_defaults(run=run_install)


def run_install(args: argparse.Namespace) -> int:
    from ..sigrok.install import install

    written = install_into(install, args.dir)
    folder = os.path.dirname(written[0])
    env = f"SIGROKDECODE_DIR={show(args.dir)} " if args.dir is not None else ""
    print(f"gimbalscope: wrote the sigrok decoder gimbal into {show(folder)}; use it with: "
          f"{env}sigrok-cli -i CAPTURE.sr -P uart:baudrate=9600:tx=TX:rx=RX,gimbal -A gimbal "
          "(or in PulseView: add UART, then stack Gimbal on it)", file=sys.stderr)
    return 0
