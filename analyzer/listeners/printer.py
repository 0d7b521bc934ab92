"""Printing what the runner hears: events on standard output (text or JSON Lines,
analyzer/output.py), notes on standard error."""

from __future__ import annotations

import sys
from typing import Callable

from dissectors.event import Event

from ..runner import DOCTOR, INFO, Listener, Note

Sink = Callable[[Event], None]


class EventPrinter(Listener):
    """Every event to ``sink`` (a ``TextSink`` or ``JsonLinesSink``), those ``keep``
    accepts when a filter is given; ``pace(event)`` may wait before each
    (``replay`` at the recorded pace). ``seen`` counts every event heard."""

    def __init__(self, sink, keep: Callable[[Event], bool] | None = None,
                 pace: Callable[[Event], None] | None = None) -> None:
        self.sink = sink
        self.keep = keep
        self.pace = pace
        self.seen = 0

    def on_events(self, events: list[Event]) -> None:
        self.seen += len(events)
        sink, keep, pace = self.sink, self.keep, self.pace
        if keep is None and pace is None:
            for ev in events:
                sink(ev)
            return
        for ev in events:
            if pace is not None:
                pace(ev)
            if keep is None or keep(ev):
                sink(ev)

    def on_stop(self) -> None:
        self.sink.close()


class NotePrinter(Listener):
    """Notes on standard error, one line each: ``gimbalscope: warning: …`` for the
    capture's warnings, ``gimbalscope: doctor: …`` for findings (unless
    ``findings=False``: ``gimbalscope doctor`` prints them its own way), and plain
    ``gimbalscope: …`` status lines (a recording written)."""

    def __init__(self, findings: bool = True) -> None:
        self.findings = findings

    def on_note(self, note: Note) -> None:
        if note.origin == DOCTOR:
            if not self.findings:
                return
            line = note.text
        elif note.level == INFO:
            line = note.text
        else:
            line = f"warning: {note.text}"
        print(f"gimbalscope: {line}", file=sys.stderr, flush=True)
