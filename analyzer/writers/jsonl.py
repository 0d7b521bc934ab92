"""JSON Lines output: one event object per line (the event contract,
docs/json-lines.md), to a file (``convert -o OUT.jsonl``) or to standard output
(``decode``, ``live`` and ``replay`` with ``--format jsonl``): the same lines
either way. Times are the events' ``t`` and ``t_end``, seconds from the
capture's start (docs/time.md, "Message times")."""

from __future__ import annotations

import os
from typing import IO

from dissectors.event import Event

from ..info import CaptureInfo
from ..output import dumps_line
from .base import EventLines


class JsonLinesWriter(EventLines):
    """Lines are written in blocks of ``BLOCK`` events; ``flush_each`` (live taps)
    writes and flushes every event. ``write(event)`` writes one (the printer's
    call, after its filter)."""

    BLOCK = 512
    file: IO[bytes]   # the target's: a path's, the given file or standard output (never None)

    def __init__(self, path: str | os.PathLike | None = None, info: CaptureInfo | None = None, *,
                 file: IO[bytes] | None = None, flush_each: bool = False, atomic: bool = True) -> None:
        self.flush_each = flush_each
        self._lines: list[bytes] = []
        self._block = 1 if flush_each else self.BLOCK   # events per write
        super().__init__(path, info, file=file, atomic=atomic)

    def write(self, ev: Event) -> None:
        lines = self._lines
        lines.append(dumps_line(ev.to_dict()))
        if len(lines) >= self._block:
            self._write(self.flush_each)

    def _write(self, flush: bool) -> None:
        lines = self._lines
        if self.broken:
            lines.clear()
            return
        with self.writes:
            self.file.write(b"".join(lines))
            self.count += len(lines)
            lines.clear()
            if flush:
                self.file.flush()

    def finish(self) -> None:
        self._write(False)   # closing the target flushes it
