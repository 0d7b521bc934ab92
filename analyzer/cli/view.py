"""``gimbalscope view INPUT…``: open any capture (socat log, raw dumps, MCAP) in
the TUI: the event list, detail tree (fields per Tables 4-18), hex, timeline,
statistics and plots. Everything is loaded in the background; the first screen
shows at once."""

from __future__ import annotations

import argparse

from ..screen import has_screen
from .common import Subcommands, UsageError, add_filter_arg, add_input_args, build_filter, open_inputs


def register(sub: Subcommands) -> None:
    p = sub.add_parser("view", help="open a capture in the TUI",
                       description="Open a capture (see INPUT) in the TUI.")
    add_input_args(p)
    add_filter_arg(p, "start with this filter")
    p.add_argument("--keymap", metavar="FILE.toml", help="TUI key bindings: binding id = \"keys\"")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..tui.run import keymap_from, open_tui

    # a mistake in what was typed (keymap, filter) is reported before the terminal
    # check, so it can be fixed in one go, and before the screen opens
    keymap = keymap_from(args)
    build_filter(args.filter)
    if not has_screen():
        raise UsageError("view needs a terminal (for scripts: gimbalscope decode)")
    capture = open_inputs(args)
    return open_tui(capture, args, mode="view", keymap=keymap)
