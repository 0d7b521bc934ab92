"""Raw byte dumps: the bytes of one line (or of a single-line tap) with no time.

Two inputs are line A (controller→device) and line B (device→controller); one
input is a single-line tap carrying both directions interleaved (docs/decoding.md, "Wire format").
Either may be a file, a pipe or FIFO (``<(…)``), standard input, or compressed
(analyzer/sources/files.py): each is read once, at its own pace.
"""

from __future__ import annotations

from typing import Iterator

from .base import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Source
from .files import BLOCK, Input


class RawDumpSource(Source):
    timed = False

    def __init__(self, inputs: list[str | Input]) -> None:
        super().__init__()
        if len(inputs) not in (1, 2):
            raise ValueError("a raw capture is one file (single-line tap) or two (line A, line B)")
        # opened now: a bad path fails early, with its name, before any output
        self.inputs = [i if isinstance(i, Input) else Input(i) for i in inputs]
        self.paths = [i.path for i in self.inputs]
        self.lines = (LINE_AB,) if len(inputs) == 1 else (LINE_A, LINE_B)
        self.description = " + ".join(i.describe() for i in self.inputs)
        for i in self.inputs:
            self.on_close(i.close)

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        inp = self.inputs[self.lines.index(line)]
        f = inp.stream()
        while True:
            try:
                data = f.read(BLOCK)
            except OSError as e:
                raise CaptureError(f"{inp.name}: cannot read: {e.strerror or e}") from None
            if not data:
                break
            yield Chunk(line, data)
        if inp.problem:
            self.warn(inp.problem)

    def chunks(self) -> Iterator[Chunk]:
        for line in self.lines:
            yield from self.line_chunks(line)
