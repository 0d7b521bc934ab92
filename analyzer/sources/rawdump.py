"""Raw byte dumps: the bytes of one line (or of a single-line tap) with no time.

Two inputs are line A (controller→device) and line B (device→controller); one
input is a single-line tap carrying both directions interleaved (docs/decoding.md, "Wire format").
Either may be a file, a pipe or FIFO (``<(…)``), standard input, or compressed
(analyzer/sources/files.py): each is read once, at its own pace.
"""

from __future__ import annotations

import codecs
from typing import Iterator

from .base import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Reader, Source
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


def reject_text(inp: Input) -> None:
    """A raw dump of this protocol has start bytes (F8) or simple responses; a file of
    printable text without any (one line or many, with a final newline or not) is
    something else given by mistake."""
    head = inp.head
    if not head:
        return
    if any(b in head for b in (b"\xf8", b"\x06", b"\x15")):
        return
    try:
        # a head cut inside a UTF-8 character is still text
        text = codecs.getincrementaldecoder("utf-8")().decode(head, final=False)
    except UnicodeDecodeError:
        return
    if text and all(c.isprintable() or c in "\r\n\t" for c in text):
        lines = text.splitlines()
        first = lines[0][:60] if lines else ""
        raise CaptureError(f"{inp.name}: a text file that is not a socat -x -v log "
                           f"(line 1: {first!r}); raw dumps are binary")


def open_raw_dumps(inputs: list[Input], byte_time: float) -> RawDumpSource:
    return RawDumpSource(inputs)   # untimed: no byte time needed


def _any_bytes(head: bytes) -> bool:
    return True   # raw bytes have no signature: the fallback, tried last


READER = Reader("raw dump", open_raw_dumps, looks=_any_bytes, takes=(1, 2), vet=reject_text)
