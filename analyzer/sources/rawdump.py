"""Raw byte dumps: the bytes of one line (or of a single-line tap) with no time.

Two inputs are line A (controller→device) and line B (device→controller); one
input is a single-line tap carrying both directions interleaved (docs/decoding.md, "Wire format").
Either may be a file, a pipe or FIFO (``<(…)``), standard input, or compressed
(analyzer/sources/files.py): each is read once, at its own pace.

Time (docs/time.md): a dump has none, so events carry none and pairing goes by
order. The capture still has a start, for the times of a recording's messages:
``--start-time``, else the file's modification time (when its last byte was
written) less the capture's duration at the baud rate (the bytes as if back to
back: an upper bound on how long the capture ran); ``time_origin`` says which.
"""

from __future__ import annotations

import codecs
import os
import time
from collections.abc import Iterator, Sequence

from ..errors import CaptureError
from ..lines import LINE_A, LINE_AB, LINE_B, Chunk
from .base import Reader, ReadSettings, Source
from .files import BLOCK, Input
from .foreign import foreign_format


class RawDumpSource(Source):
    timed = False
    input_per_line = True   # one file or port per line (CaptureInfo.line_names)

    def __init__(self, inputs: Sequence[str | Input], settings: ReadSettings | None = None) -> None:
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
        self.start_time, self.time_origin = _start(self.inputs, settings)
        for i in self.inputs:
            what = foreign_format(i.head)
            if what is not None:
                self.warn_later(f"{i.name}: starts like {what}, not a serial capture; decoded as raw bytes all the same")

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        inp = self.inputs[self.lines.index(line)]
        for data in inp.blocks(BLOCK):
            yield Chunk(line, data)
        if inp.problem:
            self.warn(inp.problem)

    def chunks(self) -> Iterator[Chunk]:
        for line in self.lines:
            yield from self.line_chunks(line)


def _start(inputs: list[Input], settings: ReadSettings | None) -> tuple[float, str]:
    """(epoch of the first byte, where it came from): see the module doc."""
    if settings is not None and settings.start_time is not None:
        return settings.start_time, "--start-time"
    byte_time = settings.byte_time if settings is not None else 10 / 9600
    ends, longest, unknown = [], 0, []
    for inp in inputs:
        try:
            st = os.stat(inp.path) if inp.regular else None
        except OSError:
            st = None
        if st is None:
            unknown.append("a pipe")
            continue
        ends.append(st.st_mtime)
        if inp.compression:
            unknown.append("compressed")
        else:
            longest = max(longest, st.st_size)
    if not ends:   # nothing on disk: it is being read now
        return time.time(), "time of reading (a pipe has no modification time)"
    start = max(ends) - longest * byte_time
    if unknown:
        return start, f"file modification time ({', '.join(sorted(set(unknown)))}: duration unknown)"
    return start, "file modification time less the capture's duration"


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


def open_raw_dumps(inputs: list[Input], settings: ReadSettings) -> RawDumpSource:
    return RawDumpSource(inputs, settings)


def _any_bytes(head: bytes) -> bool:
    return True   # raw bytes have no signature: the fallback, tried last


READER = Reader("raw dump", open_raw_dumps, looks=_any_bytes, takes=(1, 2), vet=reject_text,
                given_as=" of one line, or two (line A, line B)")
