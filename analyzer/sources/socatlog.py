"""socat ``-x -v`` hex logs: the common software tap of a serial link.

``socat -x -v PTY,… /dev/ttyUSB0,… 2> tap.log`` writes, per chunk it forwards::

    > 2026/11/21 08:35:52.000321418  length=9 from=0 to=8
     f8 01 01 01 00 02 50 3f 92                       ......P?.
    --

``>`` chunks travel from the first address to the second (line A, controller→
device, when the controller is on the first address); ``<`` the other way
(line B). Hex sits in the first 49 columns, the text column after it (absent with
``-x`` alone, which also drops the ``--`` separators).

Timestamps, as Debian's socat 1.7.4 really writes them: local time, and the
fraction printed with 9 digits but holding *microseconds* (``.000321418`` is
0.321418 s). A file whose fractions ever reach 1 000 000 carries real
nanoseconds (newer socat) and is read that way. The time is when socat read the
chunk, about when its last byte arrived, so the first byte started
``length × byte_time`` earlier (``--baud``). The time unit is decided from the
first 2000 headers, read with the head used for detection, so the log is read
once (it may be a pipe or compressed: analyzer/sources/files.py).

A log is often cut, edited or shared with other output: a stray line, a garbled
header or one with an impossible date loses only what it spoils. Each kind of
problem is one warning at the end, counted, with the line of its first
occurrence, and decoding goes on (after a bad header, at the next good one).
Only a file that does not start like a socat log at all is an error.
"""

from __future__ import annotations

import re
import time
from typing import Callable, Iterator

from .base import LINE_A, LINE_B, CaptureError, Chunk, Reader, Source
from .files import HEAD, Input

HEADER = re.compile(
    rb"^([<>]) (\d{4}/\d\d/\d\d \d\d:\d\d:\d\d)\.(\d+)\s+length=(\d+) from=(\d+) to=(\d+)\s*$")
DIAGNOSTIC = re.compile(rb"^\d{4}/\d\d/\d\d \d\d:\d\d:\d\d socat\[\d+\] ")
HEX_COLUMNS = 49
UNIT_HEADERS = 2000       # headers that decide the fraction's unit
UNIT_HEAD_MAX = 1 << 20   # bytes read at most to find them
START_LINES = 50          # a log shows its first header within these lines

# kinds of problem, as said when there are several: "tap.log: 3 lines ... (first at line 152: ...)"
PLURALS = {
    "stray": "lines that are not socat -x -v output skipped",
    "hex": "hex lines that do not parse skipped",
    "garbled": "garbled chunk headers skipped, with their chunks",
    "time": "headers with an impossible date or time skipped, with their chunks",
    "length": "chunks whose bytes differ from their length=",
    "jump": "jumps in a line's byte count",
}
DETAILED = {"time", "length", "jump"}   # kinds whose first case says more than the count


def looks_like_socat(head: bytes) -> bool:
    """Is this the start of a socat -x log? (first non-diagnostic line is a header)"""
    for line in head.splitlines()[:START_LINES]:
        if not line.strip() or DIAGNOSTIC.match(line):
            continue
        return HEADER.match(line) is not None
    return False


def nanosecond_fractions(head: bytes) -> bool:
    """True when 9-digit fractions are real nanoseconds (see module doc): one of the
    first ``UNIT_HEADERS`` headers reaches 1 000 000."""
    seen = 0
    for line in head.splitlines():
        m = HEADER.match(line)
        if m is None:
            continue
        frac = m.group(3)
        if len(frac) == 9 and int(frac) >= 1_000_000:
            return True
        seen += 1
        if seen >= UNIT_HEADERS:
            break
    return False


class _Tally:
    """Problems counted by kind and said once each, at the end: the first one with
    its line number, and how many there were."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.kinds: dict[str, list] = {}   # kind -> [count, line of the first, its text]

    def add(self, kind: str, line_no: int, text: str) -> None:
        entry = self.kinds.get(kind)
        if entry is None:
            self.kinds[kind] = [1, line_no, text]
        else:
            entry[0] += 1

    def report(self, warn: Callable[[str], None]) -> None:
        for kind, (count, line_no, text) in self.kinds.items():
            if count == 1:
                warn(f"{self.name}:{line_no}: {text}")
            elif kind in DETAILED:
                warn(f"{self.name}: {count} {PLURALS[kind]} (first at line {line_no}: {text})")
            else:
                warn(f"{self.name}: {count} {PLURALS[kind]} (first at line {line_no})")


class SocatLogSource(Source):
    timed = True
    lines = (LINE_A, LINE_B)

    def __init__(self, source: str | Input, byte_time: float) -> None:
        super().__init__()
        self.input = source if isinstance(source, Input) else Input(source)
        self.path = self.input.path
        self.name = self.input.name
        self.byte_time = byte_time
        self.description = self.input.describe("socat -x log")
        self._nanoseconds = nanosecond_fractions(self._unit_head())
        self._epoch_cache: dict[bytes, int] = {}
        self.on_close(self.input.close)

    def _unit_head(self) -> bytes:
        """The head, read further until it holds ``UNIT_HEADERS`` headers (or 1 MiB)."""
        size = max(HEAD, len(self.input.head))
        head = self.input.head
        while not self.input.complete and size < UNIT_HEAD_MAX and head.count(b"length=") < UNIT_HEADERS:
            size *= 2
            head = self.input.read_head(size)
        return head

    def _epoch(self, m: re.Match) -> tuple[int, float]:
        """(whole epoch seconds, fraction) kept apart so relative times stay exact;
        ValueError or OverflowError for a date or time that cannot be."""
        key = m.group(2)
        base = self._epoch_cache.get(key)
        if base is None:
            base = int(time.mktime(time.strptime(key.decode("ascii"), "%Y/%m/%d %H:%M:%S")))
            if len(self._epoch_cache) > 4096:
                self._epoch_cache.clear()
            self._epoch_cache[key] = base
        frac = m.group(3)
        if len(frac) == 9 and not self._nanoseconds:
            return base, int(frac) / 1e6
        return base, int(frac) / 10 ** len(frac)

    def chunks(self) -> Iterator[Chunk]:
        tally = _Tally(self.name)
        try:
            yield from self._parse(self.input.stream(), tally)
        except OSError as e:   # a disk or USB stick failing under the log
            raise CaptureError(f"{self.name}: cannot read: {e.strerror or e}") from None
        tally.report(self.warn)
        if self.input.problem:
            self.warn(self.input.problem)

    def _parse(self, f, tally: _Tally) -> Iterator[Chunk]:
        """The chunks of the log ``f``; problems go to ``tally`` (see module doc)."""
        bt = self.byte_time
        name = self.name
        t0: tuple[int, float] | None = None
        line_no = 0
        headers = 0          # chunk headers seen (good or not)
        hex_seen = False     # a hex line was read: the log was made with -x
        current: tuple[str, tuple[int, float], int, int] | None = None   # line, time, length, lineno
        data = bytearray()
        expected_from = {LINE_A: 0, LINE_B: 0}

        def finish_chunk() -> Chunk | None:
            """The chunk collected so far (None when it carries no bytes)."""
            nonlocal t0, current
            line, (sec, frac), length, at = current
            current = None
            if len(data) != length:
                tally.add("length", at, f"chunk says length={length} but carries {len(data)} bytes "
                                        f"(log cut short?)")
            if not data:
                return None
            first = frac - length * bt   # the first byte started this long before the read
            if t0 is None:
                t0 = (sec, first)
                self.start_time = sec + first
            return Chunk(line, bytes(data), round((sec - t0[0]) + (first - t0[1]), 9))

        for raw_line in f:
            line_no += 1
            first = raw_line[:1]
            if first == b" ":
                if current is not None:
                    # hex sits in the first 49 columns; fromhex skips the spaces
                    try:
                        data += bytes.fromhex(raw_line[:HEX_COLUMNS].decode("ascii"))
                        hex_seen = True
                    except (ValueError, UnicodeDecodeError):
                        tally.add("hex", line_no, "not a socat hex line, skipped")
                # else: the hex of a chunk whose header was bad or lost, skipped with it
                continue
            if first == b">" or first == b"<":
                if current is not None:
                    chunk = finish_chunk()
                    if chunk is not None:
                        yield chunk
                m = HEADER.match(raw_line)
                if m is None:
                    if headers == 0 and line_no <= START_LINES:
                        raise self._not_socat(line_no)
                    tally.add("garbled", line_no, "garbled chunk header, skipped with its chunk")
                    continue
                headers += 1
                line = LINE_A if first == b">" else LINE_B
                frm = int(m.group(5))
                if frm != expected_from[line]:
                    tally.add("jump", line_no, f"line {line} jumps from byte {expected_from[line]} to {frm}: "
                                               f"bytes missing from the log")
                expected_from[line] = int(m.group(6)) + 1
                try:
                    stamp = self._epoch(m)
                except (ValueError, OverflowError):
                    when = m.group(2).decode("ascii")
                    tally.add("time", line_no, f"header with an impossible date or time ({when}), "
                                               f"skipped with its chunk")
                    continue
                data = bytearray()
                current = (line, stamp, int(m.group(4)), line_no)
                continue
            stripped = raw_line.strip()
            if not stripped or DIAGNOSTIC.match(raw_line):
                continue
            if stripped == b"--":
                if current is not None:
                    chunk = finish_chunk()
                    if chunk is not None:
                        yield chunk
                continue
            if headers == 0 and line_no <= START_LINES:
                raise self._not_socat(line_no)
            if current is not None and not data and not hex_seen:
                raise CaptureError(f"{name}:{line_no}: socat log without hex dump; record it with socat -x -v")
            tally.add("stray", line_no, "not socat -x -v output, skipped")
            if current is not None and len(data) >= current[2]:
                # the chunk is whole: hex lines before the next header belong to a
                # header this line replaced, and would spoil it
                chunk = finish_chunk()
                if chunk is not None:
                    yield chunk
        if current is not None:
            chunk = finish_chunk()
            if chunk is not None:
                yield chunk

    def _not_socat(self, line_no: int) -> CaptureError:
        return CaptureError(f"{self.name}:{line_no}: not a socat -x -v log "
                            f"(expected a '> YYYY/MM/DD hh:mm:ss.ffffff  length=…' header)")


def open_socat_log(inputs: list[Input], byte_time: float) -> SocatLogSource:
    inp, = inputs
    return SocatLogSource(inp, byte_time)


READER = Reader(
    "socat -x -v log", open_socat_log, looks=looks_like_socat,
    crowded="a socat log carries both lines; give it on its own",
)
