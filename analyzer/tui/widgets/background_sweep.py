"""Sweeps too long for the screen's thread (a filter or a search over more
than ``BACKGROUND_ROWS`` rows, analyzer/formats/sweep.py) run here, in a worker
thread: the screen and the capture go on, ``Progress`` says how far it got (at
most ten messages a second, posted from the worker: it never waits for the
screen), and ``cancel()`` (Esc) stops it between steps. It draws nothing (the
status line shows the progress)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from textual.message import Message
from textual.widget import Widget
from textual.worker import get_current_worker

from ...formats.sweep import Cancelled, IsCancelled, ReportProgress
from ...words import counted

# what a sweep runs in the worker: work(progress, cancelled) -> its result
Work = Callable[[ReportProgress, IsCancelled], Any]


class BackgroundSweep(Widget):
    class Progress(Message):
        """How far the running sweep has got."""

        def __init__(self, text: str) -> None:
            super().__init__()
            self.text = text

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self.text = ""   # the running sweep's progress; "" when none runs

    def start(self, what: str, work: Work, done: Callable[[Any], None]) -> None:
        """Run ``work(progress, cancelled)`` in a worker thread (stopping any
        sweep still running), then ``done(result)`` on the screen's thread."""
        self.text = f"{what} …"
        last = [0.0]

        def progress(n: int, total: int) -> None:
            now = time.monotonic()
            if now - last[0] >= 0.1:   # a message at most ten times a second
                last[0] = now
                self.post_message(self.Progress(f"{what} {n:,} of {counted(total, 'event')} "
                                                f"({100 * n // max(1, total)}%), Esc stops"))

        def run() -> None:
            worker = get_current_worker()
            try:
                result = work(progress, lambda: worker.is_cancelled)
            except Cancelled:
                return
            self.app.call_from_thread(self._done, done, result)

        self.run_worker(run, thread=True, exclusive=True, group="sweep")

    def _done(self, done: Callable[[Any], None], result: Any) -> None:
        self.text = ""
        done(result)

    def cancel(self) -> bool:
        """Stop the running sweep; False if none runs."""
        if not self.text:
            return False
        self.workers.cancel_group(self, "sweep")
        self.text = ""
        return True

    def on_background_sweep_progress(self, message: Progress) -> None:
        if self.text:   # not stopped meanwhile: the screen shows it
            self.text = message.text
        else:
            message.stop()
