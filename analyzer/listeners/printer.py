"""Printing what the runner hears: events on standard output (a writer of
``--format``, text or JSON Lines: analyzer/writers, ``FORMATS``), notes on
standard error."""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

from dissectors.event import Event

from ..outfile import one_line
from ..runner import DOCTOR, ERROR, INFO, Listener, Note, TapRunner

if TYPE_CHECKING:
    from ..writers.base import EventLines

REPEATS = 3   # warnings of one kind said in full before the rest are counted


class EventPrinter(Listener):
    """Every event to ``writer`` (a ``TextWriter`` or ``JsonLinesWriter``), those
    ``keep`` accepts when a filter is given; ``pace(event)`` may wait before each
    (``replay`` at the recorded pace). ``seen`` counts every event heard."""

    def __init__(self, writer: EventLines, keep: Callable[[Event], bool] | None = None,
                 pace: Callable[[Event], None] | None = None) -> None:
        self.writer = writer
        self.keep = keep
        self.pace = pace
        self.seen = 0

    def on_start(self, runner: TapRunner) -> None:
        self.writer.on_start(runner)

    def on_events(self, events: list[Event]) -> None:
        self.seen += len(events)
        write, keep, pace = self.writer.write, self.keep, self.pace
        if keep is None and pace is None:
            for ev in events:
                write(ev)
            return
        for ev in events:
            if pace is not None:
                pace(ev)
            if keep is None or keep(ev):
                write(ev)

    def on_stop(self) -> None:
        self.writer.on_stop()


class NotePrinter(Listener):
    """Notes on standard error, one line each: ``gimbalscope: warning: …`` for the
    capture's warnings, ``gimbalscope: doctor: …`` for findings (unless
    ``findings=False``: ``gimbalscope doctor`` prints them its own way), and plain
    ``gimbalscope: …`` status lines (a recording written).

    ``quiet`` (``-q``) leaves out warnings; errors, findings and status lines are
    still said. Warnings that differ only in their numbers (times, offsets, counts: the
    same ``warning_kind``) are said ``repeats`` times in full; the rest of each
    kind is one line at the end: ``… and N more like this: <the first>``.
    """

    def __init__(self, findings: bool = True, quiet: bool = False, repeats: int = REPEATS) -> None:
        self.findings = findings
        self.quiet = quiet
        self.repeats = repeats
        self._kinds: dict[str, list] = {}   # kind → [times heard, the first one's text]

    def on_note(self, note: Note) -> None:
        if note.origin == DOCTOR:
            if not self.findings:
                return
            line = note.text
        elif note.level == INFO:
            line = note.text
        elif note.level == ERROR:
            line = f"error: {note.text}"
        else:
            if self.quiet or not self._first_times(note.text):
                return
            line = f"warning: {note.text}"
        _say(line)

    def _first_times(self, text: str) -> bool:
        """Count ``text`` in its kind: is it among the first ``repeats``?"""
        kind = warning_kind(text)
        seen = self._kinds.get(kind)
        if seen is None:
            seen = self._kinds[kind] = [0, text]
        seen[0] += 1
        return seen[0] <= self.repeats

    def on_stop(self) -> None:
        for count, first in self._kinds.values():
            if count > self.repeats:
                _say(f"warning: … and {count - self.repeats} more like this: {first}")
        self._kinds.clear()


def _say(line: str) -> None:
    print(f"gimbalscope: {one_line(line)}", file=sys.stderr, flush=True)


# a number as warnings write them: 12, -3, 12.5, 0x94, 1,024, 08:35:52
_NUMBER = re.compile(r"0x[0-9a-fA-F]+|\d+(?:[.,:]\d+)*")


def warning_kind(text: str) -> str:
    """What ``text`` says with its numbers left out: warnings that differ only in
    times, offsets or counts are of one kind (collapsed by ``NotePrinter``)."""
    return _NUMBER.sub("#", text)
