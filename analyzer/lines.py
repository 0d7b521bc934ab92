"""The lines of a tap and what is read on them: the names of the lines (line A
from the controller, line B from the devices, or one line carrying both) and
``Chunk``, the bytes one read took from one line with the wire time of the first.

Every layer speaks of these: readers make chunks, the capture deframes them,
recorders write them as the raw topics, so they live at the bottom.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar, NamedTuple

if TYPE_CHECKING:
    from dissectors.problems import Problem

LINE_A = "A"    # controller → device
LINE_B = "B"    # device → controller
LINE_AB = "AB"  # single-line tap: both directions on one wire


class _ChunkFields(NamedTuple):
    line: str
    data: bytes
    t: float | None = None   # seconds since capture start of the first byte's start bit


class Chunk(_ChunkFields):
    """Bytes read from one line (a named tuple: one is made per read, so it is cheap)."""
    __slots__ = ()

    # Not a field (a NamedTuple's body holds only fields, hence the base above): why
    # the bytes are for the recording only and not to be decoded ("behind", "stopped":
    # a live tap's subclasses in analyzer/sources/serialport.py); None for every
    # ordinary chunk, read as a class attribute (no per-chunk cost).
    undecoded: ClassVar[str | None] = None


class LineFault(NamedTuple):
    """An error the receiver itself saw on a line (a framing or parity error, a
    break, an overrun: ``dissectors.problems.LINE`` and its cases), told by a
    source that sees below the bytes (a logic capture's software UART, a USB
    adapter's line status). The capture attaches it to the event holding the byte
    at ``offset`` (analyzer/capture/faults.py)."""
    line: str        # the line as the source reads it (before any swap)
    offset: int      # byte offset on that line of the byte concerned (a break: the next byte)
    problem: Problem
