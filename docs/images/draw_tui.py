"""Draws docs/images/tui.svg, the picture of the TUI on the README and the docs'
home page: the real app on the sample capture ``captures/demo-socat.log``, driven
by keys as a user would, and saved as Textual draws it.

    python docs/images/draw_tui.py            # rewrites docs/images/tui.svg
    python docs/images/draw_tui.py -o x.svg   # somewhere else (the test compares the two)

What it shows: a command with a bad checksum selected (#291: its NAK, then the
controller's retransmission and that one's ACK), with the decoded rows around it,
the detail of its fields and problem, its bytes and the timeline of both lines.
The picture is the same on every run: the file is loaded whole and the wiring
doctor has had its say before it is taken, nothing on this screen shows a clock,
and the ids Rich gives the SVG's styles (a hash of the content) are replaced by
one fixed name.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import re
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)   # run from a checkout, installed or not

import analyzer
from analyzer.tui.run import make_app, stop_feed

CAPTURE = os.path.join("captures", "demo-socat.log")   # relative: the status bar shows the path as given
OUTPUT = os.path.join(ROOT, "docs", "images", "tui.svg")
SIZE = (120, 36)
TITLE = f"gimbalscope view {CAPTURE}"
# go to #297, which scrolls the rows around #291 into view, then up to #291
KEYS = ("ctrl+g", "2", "9", "7", "enter", *["up"] * 6)
# Rich names the SVG's styles after a hash of what it draws: one fixed name instead
STYLE_ID = re.compile(r"terminal-\d+")
FIXED_ID = "gimbalscope-tui"
HANG_GUARD = 120.0   # seconds: a load that never ends fails instead of hanging


async def screenshot() -> str:
    """The SVG of the app on the sample capture, once loaded, after ``KEYS``."""
    app = make_app(analyzer.open(CAPTURE), mode="view")
    try:
        async with app.run_test(size=SIZE) as pilot:
            model = app.model
            give_up = time.monotonic() + HANG_GUARD
            # loaded whole, and the doctor's findings in (they reach the status bar)
            while not (model.done and (model.findings_known or model.doctor_error)):
                if time.monotonic() > give_up:
                    raise TimeoutError(f"the TUI did not finish loading {CAPTURE} in {HANG_GUARD:.0f} s")
                await pilot.pause(0.05)
            await pilot.press("home")   # the same start however the batches arrived
            await pilot.pause(0.3)
            await pilot.press(*KEYS)
            await pilot.pause(0.5)
            svg = app.export_screenshot(title=TITLE)
    finally:
        stop_feed(app)
    return STYLE_ID.sub(FIXED_ID, svg)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Draw the TUI on the sample capture as an SVG.")
    parser.add_argument("-o", "--output", default=OUTPUT, help="where to write it (default: %(default)s)")
    args = parser.parse_args(argv)
    output = os.path.abspath(args.output)   # as given, before the move to the checkout
    os.chdir(ROOT)
    svg = asyncio.run(screenshot())
    with open(output, "w", encoding="utf-8", newline="\n") as f:
        f.write(svg)
    return 0


if __name__ == "__main__":
    sys.exit(main())
