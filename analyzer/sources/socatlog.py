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
``length × byte_time`` earlier (``--baud``).
"""

from __future__ import annotations

import re
import time
from typing import Iterator

from .base import LINE_A, LINE_B, CaptureError, Chunk, Source
from .files import open_input

HEADER = re.compile(
    rb"^([<>]) (\d{4}/\d\d/\d\d \d\d:\d\d:\d\d)\.(\d+)\s+length=(\d+) from=(\d+) to=(\d+)\s*$")
DIAGNOSTIC = re.compile(rb"^\d{4}/\d\d/\d\d \d\d:\d\d:\d\d socat\[\d+\] ")
HEX_COLUMNS = 49


def looks_like_socat(head: bytes) -> bool:
    """Is this the start of a socat -x log? (first non-diagnostic line is a header)"""
    for line in head.splitlines()[:50]:
        if not line.strip() or DIAGNOSTIC.match(line):
            continue
        return HEADER.match(line) is not None
    return False


class SocatLogSource(Source):
    timed = True
    lines = (LINE_A, LINE_B)

    def __init__(self, path: str, byte_time: float) -> None:
        super().__init__()
        self.path = path
        self.byte_time = byte_time
        self.description = f"{path} (socat -x log)"
        self._nanoseconds = self._fraction_unit()
        self._epoch_cache: dict[bytes, float] = {}

    def _fraction_unit(self) -> bool:
        """True when 9-digit fractions are real nanoseconds (see module doc)."""
        seen = 0
        with open_input(self.path) as f:
            for line in f:
                m = HEADER.match(line)
                if m is None:
                    continue
                frac = m.group(3)
                if len(frac) == 9 and int(frac) >= 1_000_000:
                    return True
                seen += 1
                if seen >= 2000:
                    break
        return False

    def _epoch(self, m: re.Match) -> tuple[int, float]:
        """(whole epoch seconds, fraction) kept apart so relative times stay exact."""
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
        bt = self.byte_time
        t0: tuple[int, float] | None = None
        line_no = 0
        current: tuple[str, float, int, int] | None = None   # line, t_first, length, lineno
        data = bytearray()
        expected_from = {LINE_A: 0, LINE_B: 0}
        with open_input(self.path) as f:
            def finish_chunk():
                nonlocal t0
                line, (sec, frac), length, at = current
                if len(data) != length:
                    self.warn(f"{self.path}:{at}: chunk says length={length} but carries "
                              f"{len(data)} bytes (log cut short?)")
                first = frac - length * bt   # the first byte started this long before the read
                if t0 is None:
                    t0 = (sec, first)
                    self.start_time = sec + first
                return Chunk(line, bytes(data), round((sec - t0[0]) + (first - t0[1]), 9))

            for raw_line in f:
                line_no += 1
                first = raw_line[:1]
                if first == b" " and current is not None:
                    # hex sits in the first 49 columns; fromhex skips the spaces
                    try:
                        data += bytes.fromhex(raw_line[:HEX_COLUMNS].decode("ascii"))
                    except (ValueError, UnicodeDecodeError):
                        self.warn(f"{self.path}:{line_no}: not a socat hex line, skipped")
                    continue
                m = HEADER.match(raw_line) if first in (b">", b"<") else None
                if m is not None:
                    if current is not None:
                        yield finish_chunk()
                    data = bytearray()
                    length = int(m.group(4))
                    line = LINE_A if first == b">" else LINE_B
                    frm = int(m.group(5))
                    if frm != expected_from[line]:
                        self.warn(f"{self.path}:{line_no}: line {line} jumps from byte "
                                  f"{expected_from[line]} to {frm}: bytes missing from the log")
                    expected_from[line] = int(m.group(6)) + 1
                    current = (line, self._epoch(m), length, line_no)
                    continue
                stripped = raw_line.strip()
                if not stripped or stripped == b"--" or DIAGNOSTIC.match(raw_line):
                    continue
                if current is None and line_no <= 50:
                    raise CaptureError(f"{self.path}:{line_no}: not a socat -x -v log "
                                       f"(expected a '> YYYY/MM/DD hh:mm:ss.ffffff  length=…' header)")
                if current is not None and len(data) == 0:
                    raise CaptureError(f"{self.path}:{line_no}: socat log without hex dump; "
                                       f"record it with socat -x -v")
                self.warn(f"{self.path}:{line_no}: not socat -x -v output, skipped")
            if current is not None:
                yield finish_chunk()
