"""One tap runner: reads a capture and fans what it sees out to listeners.

Every command that reads a capture (``live``, ``demo``, ``doctor``, ``convert``,
``decode``, ``stats``, ``replay``, ``view``, the TUI) builds a ``TapRunner`` with the
listeners it needs and calls ``run()``. The pattern is python-can's ``Notifier``
and ``Listener``: the runner owns the capture, listeners only hear from it.

A listener hears, in this order:

- ``on_start(runner)`` once, before anything is read;
- ``on_chunk(chunk, offset)`` for every chunk of raw bytes read, before the
  events decoded from it (recordings keep raw bytes);
- ``on_events(events)`` for every step of the capture, in wire order; a live tap's
  idle ticks give empty lists, so listeners regain control while the line is quiet;
- ``on_note(note)`` for every warning of the capture and every note another
  listener posts (the doctor's findings), each with a level;
- ``on_stop()`` once at the end, even when reading failed.

A listener never touches the capture. What it may read while running is the
runner's state (``lines``, ``latest``, ``skew``, ``skew_from``, ``swapped``,
``echoed``, ``unsettled()``, ``info``); what it wants changed is a request to the
runner (``post``, ``request_swap``, ``add_listener``, ``remove_listener``, ``stop``),
which other threads may make too: requests are carried out between steps.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from dissectors.event import Event

from .capture import Capture
from .formats.marks import Mark
from .info import CaptureInfo
from .lines import LineFault
from .sources import Chunk

if TYPE_CHECKING:
    from .physical.report import LineReport

# Note levels, most severe first (the doctor's finding severities are the same words)
ERROR = "error"
WARNING = "warning"
INFO = "info"

# Note origins
CAPTURE = "capture"       # the capture's warnings (a port lost, the skew estimate)
DOCTOR = "doctor"         # the wiring doctor's findings
RECORDING = "recording"   # a recording about itself (written, stopped)
RUNNER = "runner"         # the runner's own word (lines swapped)


@dataclass(frozen=True)
class Note:
    """Something to tell the user beside the events: a capture warning (a port
    lost, a skew estimate), a doctor finding (``finding`` set), the runner's own
    word (lines swapped). ``t`` is the capture time it concerns, when known."""
    text: str
    level: str = WARNING
    t: float | None = None
    finding: Any = None       # an analyzer.analysis.doctor.Finding for the doctor's notes
    origin: str = CAPTURE     # who says it: CAPTURE, DOCTOR, RECORDING, RUNNER


class Listener:
    """Base class of everything fed by a ``TapRunner``; override what you need."""

    def on_start(self, runner: TapRunner) -> None:
        pass

    def on_chunk(self, chunk: Chunk, offset: int) -> None:
        pass

    def on_events(self, events: list[Event]) -> None:
        pass

    def on_note(self, note: Note) -> None:
        pass

    def on_mark(self, mark: Mark) -> None:
        """An event marked (or unmarked) by whoever watches the run (the TUI's ``m``, ``M``)."""

    def on_stop(self) -> None:
        pass

    @property
    def announcement(self) -> str | None:
        """What the listener says of itself as it starts that is for the screen
        only ("serving Foxglove on …": nothing serves once the screen has closed)."""
        return None

    def close(self) -> None:
        """Release what the listener holds though no run feeds it (a server that
        serves from the moment it is made, its run refused or its screen closed):
        whoever made it says so. Most hold nothing until they run."""


def _hears_chunks(listener: Listener) -> bool:
    # a listener that keeps the default on_chunk costs nothing per chunk
    return type(listener).on_chunk is not Listener.on_chunk


class TapRunner:
    """Runs ``capture`` to its end (or ``stop()``), feeding ``listeners`` in order:
    a listener that reads another's results (the TUI feed reads the doctor's
    findings) comes after it."""

    def __init__(self, capture: Capture, listeners: Iterable[Listener] = (), *,
                 info: CaptureInfo | None = None) -> None:
        self._capture = capture
        self.info = info or CaptureInfo.of(capture)
        self._set_listeners(list(listeners))
        self._requests: queue.SimpleQueue = queue.SimpleQueue()
        self._stopping = threading.Event()
        self._warnings_said = 0
        self.running = False
        self.events = 0                     # events delivered so far
        self.echoed: list[Event] = []       # line A commands whose echo on B was dropped, this step

    # ------------------------------------------------------------- state
    @property
    def lines(self) -> tuple[str, ...]:
        return self._capture.lines

    @property
    def live(self) -> bool:
        return self._capture.source.live

    @property
    def latest(self) -> float | None:
        """The latest wire time seen, idle ticks included."""
        return self._capture.latest

    @property
    def skew(self) -> float:
        """Seconds line B's times are moved later (analyzer/analysis/skew.py)."""
        return self._capture.skew

    @property
    def skew_from(self) -> float | None:
        """Line B events from this time on carry the current skew correction."""
        return self._capture.skew_from

    @property
    def serial_settings(self) -> str:
        """The link's settings now, ``115200 8N1``: the rate follows rate changes
        (docs/time.md, "Rate changes")."""
        o = self._capture.options
        return f"{self._capture.baud} {o.data_bits}{o.parity}{o.stop_bits:g}"

    @property
    def physical(self) -> dict[str, LineReport] | None:
        """A logic capture's lines as its software UART measures them (line →
        ``analyzer.physical.report.LineReport``, kept up to date while reading);
        None for captures of bytes."""
        return self._capture.source.physical

    @property
    def faults(self) -> list[LineFault] | None:
        """The line's own errors as the source tells them (``analyzer.lines.LineFault``,
        naming the lines as wired; a list that grows while reading, each told before
        the chunk holding its byte); None for a source that cannot see them."""
        return self._capture.source.faults

    @property
    def swapped(self) -> bool:
        """The lines are read the other way round (``--swap-lines``, the TUI's key)."""
        return self._capture.swap_lines

    @property
    def ack_timeout(self) -> float:
        return self._capture.options.timeouts.ack

    def unsettled(self) -> list[Event]:
        """Events pairing still holds; call from a listener (the runner's thread)."""
        return self._capture.unsettled()

    def line_states(self) -> dict[str, str]:
        """A live tap's state per line (open, lost, reconnecting); empty for files."""
        return dict(self._capture.source.state)

    # ----------------------------------------------------------- requests
    def post(self, text: str, level: str = WARNING, *, finding: Any = None, origin: str = RUNNER) -> None:
        """Tell every listener something (from the runner's thread: at once;
        from another thread: at the next step)."""
        note = Note(text, level, self.latest, finding, origin)
        if threading.current_thread() is self._thread:
            self._tell(note)
        else:
            self._requests.put(("note", note))

    def mark(self, mark: Mark) -> None:
        """Tell every listener an event was marked (from any thread: at the next step)."""
        self._requests.put(("mark", mark))

    def request_swap(self) -> None:
        """Read line A as B and B as A from the next step on (a two-line tap)."""
        self._requests.put(("swap", None))

    def add_listener(self, listener: Listener) -> None:
        """Feed ``listener`` too: before ``run()``, from the start; while running,
        from the next step (it hears ``on_start`` then)."""
        if not self.running:
            self._set_listeners([*self.listeners, listener])
        else:
            self._requests.put(("add", listener))

    def remove_listener(self, listener: Listener) -> None:
        """Stop feeding ``listener`` at the next step (it hears ``on_stop`` then)."""
        self._requests.put(("remove", listener))

    def stop(self) -> None:
        """End the run: a live source stops reading (what it has read is still
        decoded); a file stops at the next step. Safe from any thread or a signal."""
        self._stopping.set()
        self._capture.source.stop()

    # ---------------------------------------------------------------- run
    _thread: threading.Thread | None = None

    def run(self) -> int:
        """Read the capture to its end; the number of events. Whatever stops it,
        every listener hears ``on_stop`` and the source is closed; a failure of
        the source, then of a listener's ``on_stop``, is raised after that."""
        cap = self._capture
        self._thread = threading.current_thread()
        self.running = True
        live = self.live
        # a live tap may gain a listener of chunks while it runs (the TUI's record key)
        on_chunk = self._fan_chunk if self._chunk_hooks or live else None
        try:
            for listener in self.listeners:
                listener.on_start(self)
            self._say_warnings()
            self._handle_requests()   # asked for at the start: before anything is read
            for batch in cap.batches(on_chunk=on_chunk):
                echo = cap.echo
                self.echoed = echo.take_echoed() if echo is not None else []
                self.events += len(batch)
                for listener in self.listeners:
                    listener.on_events(batch)
                self._say_warnings()
                self._handle_requests()
                if self._stopping.is_set() and not live:
                    break
        except BaseException:
            self.running = False
            self._finish(raise_failure=False)   # the run's own failure is the one to tell
            raise
        self.running = False
        self._finish(raise_failure=True)
        return self.events

    def _set_listeners(self, listeners: list[Listener]) -> None:
        """The listeners, and which of them hear chunks (a new list each time: the
        chunk hook may be iterating the old one)."""
        self.listeners = listeners
        self._chunk_hooks = [l.on_chunk for l in listeners if _hears_chunks(l)]

    def _fan_chunk(self, chunk: Chunk, offset: int) -> None:
        for hook in self._chunk_hooks:
            hook(chunk, offset)

    def _tell(self, note: Note) -> None:
        for listener in self.listeners:
            listener.on_note(note)

    def _say_warnings(self) -> None:
        """The capture's new warnings, as notes (sources warn from reader threads
        too: they are collected and told here, in the runner's thread)."""
        warnings = self._capture.warnings
        while self._warnings_said < len(warnings):
            text = warnings[self._warnings_said]
            self._warnings_said += 1
            self._tell(Note(text, WARNING, self.latest))

    def _handle_requests(self) -> None:
        while True:
            try:
                what, arg = self._requests.get_nowait()
            except queue.Empty:
                return
            if what == "note":
                self._tell(arg)
            elif what == "swap":
                self._swap()
            elif what == "mark":
                for listener in self.listeners:
                    listener.on_mark(arg)
            elif what == "add" and arg not in self.listeners:
                self._set_listeners([*self.listeners, arg])
                arg.on_start(self)
            elif what == "remove" and arg in self.listeners:
                self._set_listeners([l for l in self.listeners if l is not arg])
                arg.on_stop()

    def _swap(self) -> None:
        cap = self._capture
        if tuple(cap.lines) != ("A", "B"):
            self._tell(Note("swapping needs a two-line tap", INFO, self.latest, origin=RUNNER))
            return
        cap.swap_lines = not cap.swap_lines
        names = self.info.line_names
        text = (f"lines swapped: {names['A']} is read as line B, {names['B']} as line A" if cap.swap_lines
                else "lines as given again")
        self._tell(Note(text, WARNING, self.latest, origin=RUNNER))

    def _finish(self, raise_failure: bool) -> None:
        """Close the source, settle the info, and stop every listener; the first
        failure of a listener is raised after all have heard ``on_stop``."""
        cap = self._capture
        cap.source.close()
        self._say_warnings()
        self._handle_requests()   # notes posted as the run ended
        if self.info.start_time is None and cap.source.start_time is not None:
            # a socat log learns its start time from its first line
            self.info = replace(self.info, start_time=cap.source.start_time)
        failure: BaseException | None = None
        for listener in self.listeners:
            try:
                listener.on_stop()
            except BaseException as e:   # noqa: BLE001 - every listener stops; the first failure is raised after
                failure = failure or e
        if failure is not None and raise_failure:
            raise failure
