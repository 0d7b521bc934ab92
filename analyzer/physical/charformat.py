"""A line's character format told from its characters (docs/instruments.md,
"The software UART": format).

A receiver reads a start bit, then some bits, then a stop bit. How many bits
lie between start and stop (the width, 5 to 9) shows in the stop bit: read too
few and the stop bit lands on a data bit (framing errors on half the
characters); read too many and the last bit read is the stop bit or the idle
line, always 1. Whether the last of them is a parity bit or data shows in the
characters: a parity bit agrees with the bits before it on every character
(by chance on one in 32,768 for sixteen of them), data does not. So 7E1 is told
from 8N1, and 8E1 from 8N2 and 9N1, by what the line carries, not by which
reads with fewer errors (they all read without any).

When the characters cannot tell (too few, or all alike), the protocol's own
8N1 is taken where it reads as well as any other, and the others that would
have read as well are named (``Verdict.possible``): a reading that was a guess
is said to be one.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

WIDTHS = (9, 8, 7, 6, 5)  # bits between the start and the stop bit, widest first
TOP_ONES = 12             # characters before a width whose top bit is always 1 is judged too wide
PARITY_CHARS = 16         # characters agreeing before their top bit is judged a parity bit (1 in
                          # 32,768 by chance; a test pattern of ten bytes 0x11…0xAA all "agree")
MIN_VARIETY = 4           # distinct characters below that: agreement tells nothing (all 0x00 "agree")
SPREAD = 0.02             # readings within 2 % more errors than the best read as well
TWO_STOPS_PAIRS = 4       # characters sent back to back before a second stop bit can be seen
TWO_STOPS_SHARE = 0.85    # of them spaced by two stop bits or more (a capture may start inside the first)


class LineFormat(NamedTuple):
    data_bits: int = 8
    parity: str = "N"
    stop_bits: float = 1

    @property
    def bits(self) -> int:
        """Bits sampled after the start bit: data, parity, the first stop bit."""
        return self.data_bits + (self.parity != "N") + 1

    @property
    def name(self) -> str:
        return f"{self.data_bits}{self.parity}{self.stop_bits:g}"


PROTOCOL_FORMAT = LineFormat()   # §1.5.1: 8 data bits, no parity, one stop bit


class Reading(NamedTuple):
    """The first characters read at one width, every bit as data."""
    width: int
    values: list[int]     # the characters read without a framing error
    errors: int           # framing errors and breaks
    starts: list[int]     # the ticks of every character's start bit


class Verdict(NamedTuple):
    fmt: LineFormat
    errors: int
    possible: tuple[str, ...] = ()    # other formats that read these characters as well


def tell_format(readings: list[Reading]) -> Verdict:
    """The format the readings (one a width in WIDTHS) show."""
    least = min(r.errors for r in readings)
    fair = [r for r in readings if r.errors <= least + max(1, int(SPREAD * (len(r.values) + r.errors)))]
    # a width whose top bit is always 1 has read the stop bit (or the idle line) as data
    # (every one so: the narrowest is the least too wide)
    narrow = [r for r in fair if not (len(r.values) >= TOP_ONES and _top_always_one(r))] or \
        [min(fair, key=lambda r: r.width)]
    sure = all(len(r.values) >= TOP_ONES for r in narrow)
    by_width = {r.width: r for r in narrow}
    if sure or PROTOCOL_FORMAT.bits - 1 not in by_width:
        chosen = max(narrow, key=lambda r: r.width)
    else:
        chosen = by_width[PROTOCOL_FORMAT.bits - 1]
    possible = [] if sure else [LineFormat(r.width).name for r in narrow if r is not chosen and 5 <= r.width <= 9]
    fmt, also = _parity(chosen)
    possible += also
    return Verdict(fmt, chosen.errors, tuple(p for p in possible if p != fmt.name))


def _top_always_one(r: Reading) -> bool:
    top = 1 << (r.width - 1)
    return all(v & top for v in r.values)


def _parity(r: Reading) -> tuple[LineFormat, list[str]]:
    """The format of a width's characters: its top bit a parity bit when it
    agrees with the others on (nearly) every character, else data."""
    w = r.width
    plain = LineFormat(w, "N")
    if w < 6:
        return plain, []
    values = np.asarray(r.values, dtype=np.int64)
    if values.size == 0:
        return plain, []
    low = values & ((1 << (w - 1)) - 1)
    top = (values >> (w - 1)) & 1
    ones = np.zeros_like(low)
    for i in range(w - 1):
        ones += (low >> i) & 1
    even = float(np.mean(top == (ones & 1)))        # even parity: the bit makes the ones even
    odd = 1.0 - even
    told = values.size >= PARITY_CHARS and np.unique(low).size >= MIN_VARIETY
    for parity, share in (("E", even), ("O", odd)):
        fmt = LineFormat(w - 1, parity)
        if share == 1.0 or (share >= 0.95 and values.size >= 20):
            if told or w == 9:        # nine data bits are the rarer reading: parity wins ties
                return fmt, ([] if told else [plain.name])
            return plain, [fmt.name]
    return plain, []


def stop_bits(starts: list[int], fmt: LineFormat, bit: float) -> float:
    """One stop bit or two, from characters sent back to back: with two, no
    character starts sooner than two stop bits after the one before. (A sender
    that leaves a bit of idle between characters looks the same on the wire, and
    reads the same.)"""
    if len(starts) < TWO_STOPS_PAIRS + 1:
        return fmt.stop_bits
    length = 1 + fmt.bits                              # start, data, parity, one stop bit
    spacing = np.diff(np.asarray(starts, dtype=np.float64)) / bit
    close = spacing[spacing < length + 2.5]            # back to back, or nearly
    if close.size >= TWO_STOPS_PAIRS and np.mean(close >= length + 0.75) >= TWO_STOPS_SHARE:
        return 2
    return 1
