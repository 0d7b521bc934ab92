"""A line's bit time, idle level and character format, measured from its edges
(docs/instruments.md, "The software UART").

Every interval between two edges of a UART line is a whole number of bits (the
sender's clock drifts a fraction of a bit over a character at most). The bit
time is the longest that leaves nearly every interval within a quarter bit of a
whole number of bits (shorter ones fit too: half the bit time makes every
interval an even number), refined over intervals of one to three bits, whose
count of bits cannot be mistaken, then over all of up to ten. A clock a few per
cent off is then measured to a tenth of a per cent from a few dozen characters.

The measure is the one most intervals agree on, never the shortest interval:
pulses under half a bit (glitches, ringing, a burst of oscillation as a device
powers up) fit no bit time of the line and are left out, as long as they are a
minority. On a sampled line a bit time under ``min_bit`` samples is no
measure at all (a square wave of two-sample pulses "fits" any rate); the
caller asks again without the floor to tell an analyser sampling too slowly
from a line that has not started talking yet.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# §1.5.1's rates, and the common ones above them: a measured rate is named against
# the nearest (what devices are set to), when it is within NEAR of it
# (31,250: MIDI; 250,000: DMX512; both are set by their standards, not by a divisor table)
STANDARD_RATES = (110, 150, 300, 600, 1200, 2400, 4800, 9600, 14400, 19200, 31250, 38400, 57600, 115200,
                  230400, 250000, 460800, 921600, 1000000, 2000000)
NEAR = 0.08           # a rate further than 8 % from every standard one is taken as set that way
SCALED_NEAR = 0.04    # ... and one a power of ten off a standard rate by 4 % at most, a sample rate typed wrong
FIT = 0.25            # an interval fits a bit time within a quarter bit
ENOUGH_EDGES = 48     # edges before decoding starts (about three characters); twice this are measured
MIN_EDGES = 6         # fewer: no rate can be measured (--baud decodes such a line)
SHORT_SHARE = 0.4     # pulses under half a bit beyond this share of the intervals: not this bit time
# A measure is sure when it rests on this many intervals (about two characters'
# worth) and nearly all fit: fewer, and a glitch or two could have made it.
SURE_INTERVALS = 16
SURE_FIT = 0.75    # (clean captures fit 78-85 %: a quarter-bit tolerance at a few samples a bit)


class Measured(NamedTuple):
    bit: float        # ticks a bit
    fit: float        # the share of intervals a whole number of bits long
    intervals: int    # how many were measured

    @property
    def sure(self) -> bool:
        return self.intervals >= SURE_INTERVALS and self.fit >= SURE_FIT


def measure_bit(ticks: np.ndarray, min_bit: float = 0.0) -> Measured | None:
    """The bit time of a line from its edges (ticks), or None when they do not
    show one (too few, or no bit time of at least ``min_bit`` ticks fits)."""
    if ticks.size < MIN_EDGES:
        return None
    d = np.diff(ticks).astype(np.float64)
    d = d[d > 0]
    pool = d[d >= min_bit] if min_bit else d
    if pool.size < MIN_EDGES - 1:
        return None
    # candidates: the short intervals (one bit is among the commonest in any
    # traffic), largest first; glitches are short and rare, and fail the fit
    q = np.quantile(pool, np.linspace(0.0, 0.5, 41))
    for c in sorted(set(q.tolist()), reverse=True):
        if c <= 0 or c < min_bit:
            continue
        # at this bit time, pulses under a quarter bit are glitches: without them
        # the intervals they cut are whole again (one glitch in one character
        # leaves it measurable)
        clean, glitches = without_glitches(ticks, 0, c / 4)
        d = np.diff(clean).astype(np.float64)
        d = d[d > 0]
        short = d < c / 2                # no interval of this line is under a bit: false starts
        n_short = int(np.count_nonzero(short))
        if (n_short + 2 * glitches) > SHORT_SHARE * (ticks.size - 1) or d.size < MIN_EDGES - 1:
            continue
        inside = d[~short & (d < 12.5 * c)]         # within a character; longer is idle
        if inside.size < max(MIN_EDGES - 1, (d.size - n_short) // 4):
            continue
        r = inside / c
        k = np.rint(r)
        fits = (np.abs(r - k) < FIT) & (k >= 1)
        if fits.mean() < 0.7 or np.count_nonzero(k[fits] == 1) < max(2, inside.size // 50):
            continue
        bit = _refine(inside[fits], c)
        if bit is None or bit < min_bit:
            continue
        return Measured(bit, float(fits.mean()), int(inside.size))
    return None


def _refine(fitting: np.ndarray, c: float) -> float | None:
    short = fitting[np.rint(fitting / c) <= 3]
    if short.size == 0:
        return None
    bit = short.sum() / np.rint(short / c).sum()
    for _ in range(2):
        k = np.rint(fitting / bit)
        ok = (k >= 1) & (k <= 10) & (np.abs(fitting / bit - k) < FIT)
        if not ok.any():
            break
        bit = fitting[ok].sum() / k[ok].sum()
    return float(bit)


def without_glitches(t: np.ndarray, lo: int, shortest: float) -> tuple[np.ndarray, int]:
    """``t`` without the pulses (from edge ``lo`` on) shorter than ``shortest``
    ticks: both edges of each go (the level comes back), and how many went."""
    short = np.flatnonzero(np.diff(t[lo:]) < shortest)
    if short.size == 0:
        return t, 0
    keep = np.ones(t.size, dtype=bool)
    removed = 0
    for j in short.tolist():
        i = lo + j
        if keep[i] and keep[i + 1]:
            keep[i] = keep[i + 1] = False
            removed += 1
    return t[keep], removed


def nominal_rate(rate: float) -> int | None:
    """The standard rate ``rate`` (bit/s) is nearest to, within NEAR; None if none is."""
    best = min(STANDARD_RATES, key=lambda r: abs(rate - r) / r)
    return best if abs(rate - best) / best <= NEAR else None


def power_of_ten_off(rate: float) -> int | float | None:
    """The power of ten (10, 1000, 0.01, …) that takes ``rate``, near no standard
    rate, onto one: what a sample rate typed a unit off (10 kHz for 1 MHz) does
    to every measured rate. None when ``rate`` is standard or no such power is."""
    if nominal_rate(rate) is not None:
        return None
    for exponent in (1, -1, 2, -2, 3, -3, 4, -4, 5, -5, 6, -6):   # the nearest first
        factor = 10 ** exponent
        scaled = rate * factor
        best = min(STANDARD_RATES, key=lambda r: abs(scaled - r) / r)
        # closer than NEAR: a line really set off the standard rates (MIFARE's
        # 106,000 bit/s) is not 1,000,000 typed a unit off
        if abs(scaled - best) / best <= SCALED_NEAR:
            return factor
    return None


def named_rate(rate: float) -> int:
    """The rate a line is said to run at: the standard rate ``rate`` is near
    (``nominal_rate``), else ``rate`` itself, rounded (a rate set that way)."""
    return nominal_rate(rate) or max(1, round(rate))


def idle_level(ticks: np.ndarray, level: int, end: int, bit: float, begin: int = 0) -> tuple[int, bool]:
    """The level a line rests at, and whether it is sure: the one it holds through
    its silences (stretches longer than a character, the one before the first
    edge from ``begin`` on too); with none (a line sending back to back), the
    one it holds longest, unsure."""
    if ticks.size == 0:
        return level, False
    bounds = np.concatenate(([min(begin, int(ticks[0]))], ticks, [max(end, int(ticks[-1]))]))
    spans = np.diff(bounds)                    # the time at the level before edge 0, then after each edge
    after = (level ^ (np.arange(ticks.size + 1) & 1)).astype(np.int8)
    long = spans > 12 * bit
    if long.any():
        high = int(spans[long & (after == 1)].sum())
        low = int(spans[long & (after == 0)].sum())
        return (1 if high >= low else 0), True
    high = int(spans[after == 1].sum())
    return (1 if high * 2 >= int(spans.sum()) else 0), False
