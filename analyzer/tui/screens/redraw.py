"""What the full screens over the main one (statistics, plots, findings) share:
they are redrawn when the capture has changed, at most once a second, and
never while nothing arrives (the app calls ``capture_changed`` on the screen on
top when a batch has come or a replay has moved on)."""

from __future__ import annotations

import time

from textual.screen import Screen
from textual.timer import Timer

EVERY = 1.0   # seconds: a full screen is redrawn at most this often


class Redrawn(Screen):
    """A screen with ``redraw()``: drawn when mounted, then ``capture_changed``
    redraws it once, at most EVERY seconds after it was last drawn."""

    _drawn = 0.0
    _due: Timer | None = None

    def on_mount(self) -> None:
        self._redraw_now()

    def redraw(self) -> None:
        raise NotImplementedError

    def capture_changed(self) -> None:
        if self._due is None:
            wait = self._drawn + EVERY - time.monotonic()
            if wait <= 0:   # drawn long enough ago: now (Textual's timer of no time never fires)
                self._redraw_now()
                return
            self._due = self.set_timer(wait, self._redraw_now, name="redraw")

    def _redraw_now(self) -> None:
        self._due = None
        self._drawn = time.monotonic()
        self.redraw()
