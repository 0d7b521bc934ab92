"""``gimbalscope wireshark install [--dir D]``: the Lua dissector of protocol
``gimbal`` (generated from the command table, Tables 4-18, and the problem
table) and the extcap launcher for live capture, written into Wireshark's
personal plugin and extcap folders, or into D (docs/wireshark.md).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys

from ..outfile import install_into, show
from .common import Subcommands


def register(sub: Subcommands) -> None:
    p = sub.add_parser("wireshark", help="Wireshark: install the gimbal dissector and the extcap capture",
                       description="Wireshark interop (docs/wireshark.md). Export captures for it with "
                                   "'gimbalscope export CAPTURE -o FILE.pcapng'.")
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    i = verbs.add_parser("install", help="write the dissector (gimbal.lua) and the extcap launcher",
                         description="Write the Lua dissector of protocol gimbal and the extcap launcher into "
                                     "Wireshark's personal plugin and extcap folders (as 'tshark -G folders' "
                                     "names them), or into DIR. Restart Wireshark to load them.")
    i.add_argument("--dir", metavar="DIR", help="write both files into DIR instead")
    i.set_defaults(run=run_install)


def run_install(args: argparse.Namespace) -> int:
    from ..wireshark.install import EXTCAP_NAME, LUA_NAME, install, personal_folders

    written = install_into(install, args.dir)
    for path in written:
        print(f"gimbalscope: wrote {show(path)}", file=sys.stderr)
    if args.dir is not None:
        lua = os.path.join(args.dir, LUA_NAME)
        print(f"gimbalscope: open an export with: tshark -X lua_script:{show(lua)} -r FILE.pcapng "
              f"(or copy {LUA_NAME} to Wireshark's plugin folder and {EXTCAP_NAME} to its extcap folder)",
              file=sys.stderr)
    else:
        how = personal_folders().how
        print(f"gimbalscope: installed into Wireshark's personal folders ({how}); restart Wireshark, then "
              "open a file from 'gimbalscope export CAPTURE -o FILE.pcapng' or capture on the "
              "'gimbalscope' interface", file=sys.stderr)
    if shutil.which("tshark") is None and shutil.which("wireshark") is None:
        print("gimbalscope: Wireshark is not installed here; the files are ready for when it is", file=sys.stderr)
    return 0
