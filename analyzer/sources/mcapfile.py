"""MCAP recordings as a capture source: the raw byte topics (``/serial/A/raw``,
``/serial/B/raw``, or ``/serial/AB/raw``) are read back and re-dissected, so a
newer dissector re-decodes an old recording.

A file from a killed tap has no summary section: it is read record by record up
to its last complete chunk, with a warning (``gimbalscope recover`` rewrites it).
"""

from __future__ import annotations

import json
from typing import Iterator

from mcap.reader import NonSeekingReader

from .base import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Source
from .files import open_input

RAW_TOPICS = {f"/serial/{line}/raw": line for line in (LINE_A, LINE_B, LINE_AB)}


class McapSource(Source):
    def __init__(self, path: str) -> None:
        super().__init__()
        self.path = path
        self.description = f"{path} (MCAP)"
        self.metadata: dict[str, str] = {}
        lines, timed, start = self._survey()
        self.lines = lines
        self.timed = timed
        self.start_time = start

    def _messages(self, topics: list[str]) -> Iterator[tuple[str, dict]]:
        """(line, raw message) in file order; stops with a warning at a cut end."""
        with open_input(self.path) as f:
            reader = NonSeekingReader(f)
            try:
                for _schema, channel, message in reader.iter_messages(topics=topics, log_time_order=False):
                    yield RAW_TOPICS[channel.topic], json.loads(message.data)
            except GeneratorExit:
                raise
            except Exception as e:  # the mcap reader raises several types at a cut end
                self.warn(f"{self.path}: ends early ({type(e).__name__}: {e}); read up to the last complete "
                          f"chunk (a killed recording? 'gimbalscope recover' rewrites it)")

    def _survey(self) -> tuple[tuple[str, ...], bool, float | None]:
        lines = set()
        timed = False
        seen = 0
        with open_input(self.path) as f:
            reader = NonSeekingReader(f)
            try:
                for _schema, channel, message in reader.iter_messages(log_time_order=False):
                    if channel.topic in RAW_TOPICS:
                        lines.add(RAW_TOPICS[channel.topic])
                        if seen == 0:
                            timed = json.loads(message.data).get("t") is not None
                            self.start_time = message.log_time / 1e9 - (json.loads(message.data).get("t") or 0)
                        seen += 1
                    if len(lines) == 2 or LINE_AB in lines:
                        if seen > 0:
                            break
            except Exception:
                pass   # a cut file: what was read is what there is (warned when read)
        if not lines:
            raise CaptureError(f"{self.path}: MCAP file without gimbalscope raw topics "
                               f"({', '.join(RAW_TOPICS)})")
        if LINE_AB in lines:
            return (LINE_AB,), timed, self.start_time
        return (LINE_A, LINE_B), timed, self.start_time

    def chunks(self) -> Iterator[Chunk]:
        for line, msg in self._messages(list(RAW_TOPICS)):
            yield Chunk(line, bytes.fromhex(msg["data"]), msg.get("t"))

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        for _line, msg in self._messages([f"/serial/{line}/raw"]):
            yield Chunk(line, bytes.fromhex(msg["data"]), msg.get("t"))
