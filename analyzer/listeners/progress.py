"""A progress bar on standard error for commands that read capture files
(``decode``, ``stats``, ``convert``, ``recover``, and any later one): bytes read
of the inputs' size on disk, with the rate and the time left.

One piece for every command: ``ReadProgress`` is a context manager (``recover``
uses it so), and ``ProgressListener`` the same as a tap runner's listener
(``cli/common.run_tap`` attaches it). The bytes are counted where the input files
are opened (``analyzer.sources.meter.READS``), never per read, so the bar costs
the work nothing but a thread waking a few times a second.

When it shows (docs/cli.md, "Progress and warnings"):

- only when standard error is a terminal, and only after ``DELAY`` seconds
  (``GIMBALSCOPE_PROGRESS_DELAY`` sets another delay, 0 for tests): short runs
  never flash one. It is transient: gone when the work ends.
- not when the command's own output streams to the same terminal (``decode``
  printing lines on it): the lines show the progress, and a bar between them
  would only flicker.
- not when an input has no size (standard input from a pipe, a FIFO): there is
  no total to show a share of (``pv tap.log | gimbalscope decode -`` shows one).

Warnings printed while the bar shows go above it (Rich redirects standard
error to its console while the bar is live), so nothing is garbled.
"""

from __future__ import annotations

import os
import sys
import threading
from typing import TYPE_CHECKING, Protocol, Self, TextIO

from ..runner import Listener, TapRunner
from ..sources.meter import READS

if TYPE_CHECKING:
    from rich.progress import Progress, TaskID

DELAY = 3.0                                # seconds of work before a bar appears
DELAY_ENV = "GIMBALSCOPE_PROGRESS_DELAY"   # another delay in seconds (tests: 0)
REFRESH = 0.25                             # seconds between updates of the bar


class Meter(Protocol):
    """What a bar shows: the bytes of the whole (None: not known) and those done.
    ``READS`` (this process's input files) is one; an export's pool and its Spark
    tasks have their own."""

    def total(self) -> int | None: ...

    def done(self) -> int: ...


def delay() -> float:
    """``DELAY``, or the environment's; a value that is no number is ignored."""
    try:
        value = float(os.environ.get(DELAY_ENV, DELAY))
    except ValueError:
        return DELAY
    return value if value >= 0 else DELAY


def _is_terminal(stream: TextIO | None) -> bool:
    try:
        return stream is not None and stream.isatty()
    except (OSError, ValueError):
        return False


def wanted(streams_stdout: bool = False) -> bool:
    """Should a bar be shown: standard error is a terminal, and the command does
    not print its output as it goes (``streams_stdout``) to a terminal."""
    if not _is_terminal(sys.stderr):
        return False
    return not (streams_stdout and _is_terminal(sys.stdout))


class ReadProgress:
    """A transient Rich progress bar of ``meter`` (bytes read of the total), shown
    after ``delay`` seconds if the work has not ended; ``with ReadProgress():``
    or ``start()`` and ``stop()``. Does nothing when not ``enabled``."""

    def __init__(self, enabled: bool = True, meter: Meter = READS, wait: float | None = None,
                 label: str = "reading") -> None:
        self.enabled = enabled
        self.meter = meter
        self.wait = delay() if wait is None else wait
        self.label = label
        self.shown = False                 # a bar was shown
        self._ended = threading.Event()
        self._lock = threading.Lock()      # the bar is opened, updated and closed by two threads
        self._bar: tuple[Progress, TaskID] | None = None   # once shown: Rich's progress and its one task
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if not self.enabled or self._thread is not None:
            return
        if self.wait == 0:
            self._open_bar()               # at once, before any work: tests see it for certain
        self._thread = threading.Thread(target=self._run, name="progress", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._ended.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        self._close()

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _run(self) -> None:
        if self._bar is None:
            if self._ended.wait(self.wait):
                return                     # ended before the delay: no bar
            self._open_bar()
            if self._bar is None:
                return
        while not self._ended.wait(REFRESH):
            self._update()

    def _open_bar(self) -> None:
        total = self.meter.total()
        if not total:
            return                         # a pipe, or nothing to read: no share to show
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            DownloadColumn,
            Progress,
            TextColumn,
            TimeRemainingColumn,
            TransferSpeedColumn,
        )
        progress = Progress(TextColumn("{task.description}"), BarColumn(), DownloadColumn(),
                            TransferSpeedColumn(), TimeRemainingColumn(),
                            console=Console(file=sys.stderr), transient=True, auto_refresh=False,
                            redirect_stdout=False)
        task = progress.add_task(self.label, total=total, completed=self.meter.done())
        with self._lock:
            if self._ended.is_set():
                return
            progress.start()
            self._bar = progress, task
            self.shown = True

    def _update(self) -> None:
        with self._lock:
            if self._bar is not None:
                progress, task = self._bar
                progress.update(task, completed=self.meter.done())
                progress.refresh()

    def _close(self) -> None:
        with self._lock:
            bar, self._bar = self._bar, None
            if bar is not None:
                progress, task = bar
                progress.update(task, completed=self.meter.done())
                progress.stop()


class ProgressListener(Listener):
    """``ReadProgress`` for the length of a tap runner's run."""

    def __init__(self, progress: ReadProgress) -> None:
        self.progress = progress

    def on_start(self, runner: TapRunner) -> None:
        self.progress.start()

    def on_stop(self) -> None:
        self.progress.stop()
