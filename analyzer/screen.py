"""Whether this process has a screen for the TUI: a terminal on standard input and
output, or a browser tab. ``gimbalscope serve`` runs each tab's session under
Textual's web driver, which speaks to the browser over pipes, so there standard
input and output are not terminals and yet the TUI is what the user asked for."""

from __future__ import annotations

import os
import sys

# what Textual's web server sets in each session's environment to choose its driver
WEB_DRIVER = "textual.drivers.web_driver:WebDriver"


def in_browser() -> bool:
    """This process draws the TUI in a browser tab (a session of ``gimbalscope serve``)."""
    return os.environ.get("TEXTUAL_DRIVER") == WEB_DRIVER


def has_screen() -> bool:
    """A terminal on both standard streams, or a browser tab."""
    return in_browser() or (sys.stdout.isatty() and sys.stdin.isatty())
