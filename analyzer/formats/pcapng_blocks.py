"""Reading pcapng files (the pcapng specification, draft-ietf-opsawg-pcapng):
the walk over blocks, an interface's options and its timestamp unit, shared
by the readers of gimbalscope's own pcapng (analyzer/sources/pcapngfile.py)
and of USB captures (analyzer/formats/usb.py).

A file cut inside a block is said through ``warn`` and ends the walk; a
block length that cannot be is a ``CaptureError`` (nothing after it can be
found again).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator
from typing import Protocol

from ..errors import CaptureError

MAGIC = b"\x0a\x0d\x0d\x0a"
BOM = 0x1A2B3C4D
SHB, IDB, EPB, SPB = 0x0A0D0D0A, 1, 6, 3
IF_NAME, IF_TSRESOL = 2, 9
CUT = "the file ends inside a block (cut short?): read up to there"


class Reader(Protocol):
    """What the walk reads from: a binary stream's ``read``."""

    def read(self, n: int = -1, /) -> bytes: ...


def options(body: bytes, endian: str) -> dict[int, bytes]:
    """A block's options by code (the first of each code)."""
    out: dict[int, bytes] = {}
    at = 0
    while at + 4 <= len(body):
        code, length = struct.unpack_from(endian + "HH", body, at)
        if code == 0:
            break
        out.setdefault(code, body[at + 4:at + 4 + length])
        at += 4 + length + (-length % 4)
    return out


def ts_scale(tsresol: bytes | None) -> float:
    """Seconds per timestamp unit of an interface's ``if_tsresol`` (microseconds
    when absent)."""
    if not tsresol:
        return 1e-6
    v = tsresol[0]
    return 2.0 ** -(v & 0x7F) if v & 0x80 else 10.0 ** -v


def blocks(f: Reader, name: str, warn: Callable[[str], None]) -> Iterator[tuple[int, str, bytes]]:
    """Every block of the stream ``f`` as (type, byte order, body); a cut at the
    end is said, not raised."""
    endian = "<"
    while True:
        head = f.read(12)
        if not head:
            return
        if len(head) < 12:
            warn(f"{name}: {CUT}")
            return
        kind = struct.unpack_from("<I", head, 0)[0]
        if kind == SHB:
            endian = "<" if struct.unpack_from("<I", head, 8)[0] == BOM else ">"
        kind, total = struct.unpack_from(endian + "II", head, 0)
        if total < 12 or total % 4:
            raise CaptureError(f"{name}: a pcapng block of length {total}: the file is damaged")
        rest = f.read(total - 12)
        if len(rest) < total - 12:
            warn(f"{name}: {CUT}")
            return
        yield kind, endian, head[8:] + rest[:-4]
