"""``--stop-after DURATION``: a tap that ends by itself, as dumpcap's
``-a duration:N``, so that an unattended capture of a night or a week stops when
it should, its recording finished as a Ctrl-C would finish it."""

from __future__ import annotations

import threading

from ..runner import Listener, TapRunner


class StopAfter(Listener):
    """Stops the run ``seconds`` after it starts (by the clock: a silent line stops too)."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self._timer: threading.Timer | None = None

    def on_start(self, runner: TapRunner) -> None:
        self._timer = threading.Timer(self.seconds, runner.stop)
        self._timer.daemon = True
        self._timer.start()

    def on_stop(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
