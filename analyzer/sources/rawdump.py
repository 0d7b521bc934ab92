"""Raw byte dumps: the bytes of one line (or of a single-line tap) with no time.

Two files are line A (controller→device) and line B (device→controller); one file
is a single-line tap carrying both directions interleaved (spec/READING.md).
"""

from __future__ import annotations

from typing import Iterator

from .base import LINE_A, LINE_AB, LINE_B, Chunk, Source
from .files import open_input

BLOCK = 1 << 16


class RawDumpSource(Source):
    timed = False

    def __init__(self, paths: list[str]) -> None:
        super().__init__()
        if len(paths) not in (1, 2):
            raise ValueError("a raw capture is one file (single-line tap) or two (line A, line B)")
        self.paths = list(paths)
        self.lines = (LINE_AB,) if len(paths) == 1 else (LINE_A, LINE_B)
        self.description = " + ".join(self.paths)
        for p in self.paths:           # fail early, with the path, before any output
            open_input(p).close()

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        path = self.paths[self.lines.index(line)]
        with open_input(path) as f:
            while True:
                data = f.read(BLOCK)
                if not data:
                    return
                yield Chunk(line, data)

    def chunks(self) -> Iterator[Chunk]:
        for line in self.lines:
            yield from self.line_chunks(line)
