"""``gimbalscope saleae install [--dir D]``: the Saleae Logic 2 extension
``Gimbal`` (a High Level Analyzer generated from the command table), written as
an extension folder under the user's data folder or into D, for Logic 2's
Extensions panel (docs/instruments.md, "The Saleae analyzer").

What was done, and how to load it, is one line on standard error.
"""

from __future__ import annotations

import argparse
import os
import sys

from ..outfile import install_into, show
from .common import Subcommands


def register(sub: Subcommands) -> None:
    p = sub.add_parser("saleae", help="Saleae Logic 2: install the Gimbal analyzer (stacks on Async Serial)",
                       description="Saleae Logic 2 interop (docs/instruments.md, 'The Saleae analyzer').")
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    i = verbs.add_parser("install", help="write the extension Gimbal, a High Level Analyzer on Async Serial",
                         description="Write the Logic 2 extension Gimbal (extension.json, gimbal_hla.py and "
                                     "README.md) into the folder Gimbal under gimbalscope's data folder for this "
                                     "user ($XDG_DATA_HOME/gimbalscope/saleae, ~/.local/share/... by default), or "
                                     "under DIR. Load it once in Logic 2: Extensions panel, the ⋮ menu, Load "
                                     "Existing Extension, then choose its extension.json.")
    i.add_argument("--dir", metavar="DIR", help="write the extension into DIR/Gimbal instead")
    i.set_defaults(run=run_install)


def run_install(args: argparse.Namespace) -> int:
    from ..saleae.install import install

    written = install_into(install, args.dir)
    manifest = show(written[0])
    print(f"gimbalscope: wrote the Saleae Logic 2 extension Gimbal into {show(os.path.dirname(written[0]))}; "
          f"load it in Logic 2: Extensions panel → ⋮ → Load Existing Extension → {manifest}, then add Gimbal "
          "on each line's Async Serial analyzer", file=sys.stderr, flush=True)
    return 0
