"""JSON Lines output: one event object per line, the lines ``decode --format
jsonl`` prints (the event contract, docs/json-lines.md). Times are the events' ``t`` and
``t_end``, seconds from the capture's start (docs/time.md, "Message times")."""

from __future__ import annotations

from typing import BinaryIO

from dissectors.event import Event

from ..info import CaptureInfo
from ..outfile import write_error
from ..output import JsonLinesSink
from ..runner import Listener


class JsonLinesWriter(Listener):
    def __init__(self, path: str, info: CaptureInfo, *, file: BinaryIO | None = None) -> None:
        self.info = info
        self._own = file is None
        try:
            self._file = file if file is not None else open(path, "wb")
        except OSError as e:
            raise write_error(path, e) from None
        self._sink = JsonLinesSink(self._file, name=path)

    def on_events(self, events: list[Event]) -> None:
        sink = self._sink
        for ev in events:
            sink(ev)

    def on_stop(self) -> None:
        self._sink.close()
        if self._own:
            self._file.close()
