"""A software UART: one line's edges in, its characters out, with their wire
times and the receiver's errors (docs/instruments.md, "The software UART").

It reads as a hardware UART does: a start bit is an edge from the idle level,
each bit is sampled at its middle, the stop bit must be back at idle (else a
framing error; all bits at the active level, a break). What a hardware UART
is told, it finds out: the bit time and the idle level from the edges
(``bitrate``), the character format from which one decodes without errors, and
a change of rate from a run of framing errors after a silence. It also counts
what only a waveform shows: glitches (pulses under a quarter bit, removed before
decoding, as a receiver's majority vote would) and characters whose edges fall
off the bit grid (two senders driving the line at once).

Incremental: ``feed`` takes a block of edges known up to a tick, decodes every
character whose stop bit is inside it and keeps the rest; ``finish`` ends the
line. The sequential part (which edge starts the next character) is a loop over
characters with a binary search; sampling the bits is vectorised over all of a
block's characters.
"""

from __future__ import annotations

from bisect import bisect_right
from typing import NamedTuple

import numpy as np

from dissectors.problems import LINE_BREAK, LINE_FRAMING, LINE_PARITY, Problem

from .bitrate import ENOUGH_EDGES, idle_level, measure_bit, named_rate
from .edges import NO_EDGES, Edges
from .report import LineReport, RateChange

OFF_GRID = 0.3         # an edge this far (in bits) from a bit boundary is off the grid
RATE_ERRORS = 4        # framing errors in a row of characters that make the rate be measured again
MAX_CHANGES = 4        # rate changes followed within one block of edges


class Char(NamedTuple):
    """A character read, or a break (``value`` None)."""
    tick: int                    # the start bit's edge
    value: int | None
    fault: Problem | None = None


class LineFormat(NamedTuple):
    data_bits: int = 8
    parity: str = "N"
    stop_bits: float = 1

    @property
    def bits(self) -> int:
        """Bits sampled after the start bit: data, parity, the first stop bit."""
        return self.data_bits + (self.parity != "N") + 1


CANDIDATES = (LineFormat(8, "N"), LineFormat(8, "E"), LineFormat(8, "O"), LineFormat(7, "E"), LineFormat(7, "O"))


class SoftUart:
    """One line's receiver. ``report`` is kept up to date as it reads."""

    def __init__(self, report: LineReport, bit: float | None = None, fmt: LineFormat | None = None) -> None:
        self.report = report
        self.rate = report.samplerate
        self.bit = bit                            # ticks a bit: given, or measured from the first edges
        self.fmt = fmt or LineFormat()
        self.fmt_given = fmt is not None
        self.idle = 1
        self.ticks = NO_EDGES                     # edges not decoded yet
        self.level = 1                            # the level before ticks[0]
        self.started = False                      # measured (or given) and decoding
        self.end = 0                              # levels are known up to here
        self._clean_upto = 0                      # ticks[:this] are past the glitch filter

    # ------------------------------------------------------------------ input
    def feed(self, edges: Edges, end: int) -> list[Char]:
        """The edges up to tick ``end``; the characters complete by then."""
        if self.ticks.size == 0:
            self.ticks, self.level = edges.ticks, edges.level
            self._clean_upto = 0
        elif edges.ticks.size:
            self.ticks = np.concatenate((self.ticks, edges.ticks))
        self.end = end
        self.report.edges += int(edges.ticks.size)
        if not self.started:
            if self.ticks.size < ENOUGH_EDGES:
                return []
            if not self.measure():
                return []
        return self.decode()

    def finish(self) -> list[Char]:
        """The end of the line: what can still be read."""
        if not self.started and not self.measure():
            return []
        return self.decode()

    # ------------------------------------------------------------------ measuring
    def measure(self) -> bool:
        """Measure the rate (unless given), the idle level and the format (unless
        given) on the edges so far; False when they show no rate."""
        r = self.report
        m = measure_bit(self.ticks[:ENOUGH_EDGES * 2])   # the start: a later change of rate is followed apart
        if m is not None:
            r.measured = self.rate / m.bit
        if self.bit is None:
            if m is None:
                return False
            self.bit = m.bit
            r.nominal = named_rate(r.measured)
        else:
            r.given = True
            r.nominal = round(self.rate / self.bit)
        self.idle, self.fmt = self._idle_and_format()
        r.inverted = self.idle == 0
        r.data_bits, r.parity = self.fmt.data_bits, self.fmt.parity
        self._filter_glitches()
        self.started = True
        return True

    def _idle_and_format(self) -> tuple[int, LineFormat]:
        """The idle level and the format that read the first characters with the
        fewest errors (ties: the level the line rests at, then the first format:
        8N1); a level the line clearly rests at through its silences is kept
        unless the other reads far better. Then 7-bit and shorter characters
        whose top bits are always 1 (a stop bit read as data)."""
        rests, sure = idle_level(self.ticks, self.level, self.end, self.bit)
        formats = (self.fmt,) if self.fmt_given else CANDIDATES
        best = None
        for idle in (rests, 1 - rests):
            self.idle = idle
            for rank, fmt in enumerate(formats):
                got = self._read(self.ticks, self.level, fmt, self.bit, self.end, probe=True)[0]
                errors = sum(1 for c in got if c.fault is not None)
                if idle != rests and sure:
                    errors = errors * 2 + 2
                elif not sure:   # a line starts and ends a capture idle, most often
                    errors += 2 * ((idle != self.level) + (idle != self._level_at(self.ticks.size)))
                key = (errors, idle != rests, rank)
                if best is None or key < best[0]:
                    best = (key, idle, fmt, got)
        _, idle, fmt, chars = best
        values = [c.value for c in chars if c.value is not None]
        if not self.fmt_given and fmt == CANDIDATES[0] and len(values) >= 12:
            for width in (5, 6, 7):
                top = 0xFF & ~((1 << width) - 1)
                if all(v & top == top for v in values):
                    return idle, LineFormat(width, "N")
        return idle, fmt

    def _filter_glitches(self) -> None:
        """Drop pulses shorter than a quarter bit, both edges (the level goes back),
        counting each once; the last edge waits until the next is known."""
        t = self.ticks
        if t.size - self._clean_upto < 1 or self.bit is None:
            return
        lo = max(self._clean_upto - 1, 0)
        d = np.diff(t[lo:])
        short = np.flatnonzero(d < self.bit / 4)
        if short.size == 0:
            self._clean_upto = t.size
            return
        keep = np.ones(t.size, dtype=bool)
        removed = 0
        for j in short.tolist():
            i = lo + j
            if keep[i] and keep[i + 1]:
                keep[i] = keep[i + 1] = False
                removed += 1
        self.report.glitches += removed
        self.ticks = t[keep]
        self._clean_upto = self.ticks.size

    # ------------------------------------------------------------------ decoding
    def decode(self) -> list[Char]:
        """Every character complete in the edges so far."""
        self._filter_glitches()
        out: list[Char] = []
        changes = 0
        while True:
            end = self.end
            chars, used, level = self._read(self.ticks, self.level, self.fmt, self.bit, end)
            # (a few changes a block at most: noise must not send it measuring forever)
            changed = self._rate_changed(chars) if changes < MAX_CHANGES else None
            if changed is None:
                self._commit(chars, out)
                self.ticks, self.level = self.ticks[used:], level
                self._clean_upto = max(0, self._clean_upto - used)
                return out
            keep, new_bit = changed
            changes += 1
            # the characters before the change stand; read the rest at the new rate
            self._commit(chars[:keep], out)
            start = chars[keep].tick
            cut = int(np.searchsorted(self.ticks, start, side="left"))
            self.level = self._level_at(cut)
            self.ticks = self.ticks[cut:]
            self._clean_upto = 0
            r = self.report
            r.rate_changes.append(RateChange(start / self.rate, self.rate / self.bit, self.rate / new_bit))
            self.bit = new_bit
            r.measured = self.rate / new_bit
            r.nominal = named_rate(r.measured)
            self._filter_glitches()

    def _level_at(self, index: int) -> int:
        """The level before edge ``index`` of the pending edges."""
        return self.level ^ (index & 1)   # each edge flips it

    def _commit(self, chars: list[Char], out: list[Char]) -> None:
        r = self.report
        for c in chars:
            if c.fault is not None:
                if c.fault.id is LINE_BREAK:
                    r.breaks += 1
                else:
                    if c.fault.id is LINE_FRAMING:
                        r.framing_errors += 1
                    else:
                        r.parity_errors += 1
                    if r.first_error is None:
                        r.first_error = c.tick / self.rate
            if c.value is not None:
                r.characters += 1
        out.extend(chars)

    def _rate_changed(self, chars: list[Char]) -> tuple[int, float] | None:
        """After a silence, a run of framing errors where there were none: the
        link's rate changed (Table 4's rate-set commands). Returns (the first
        character at the new rate, its bit time), when the edges from there
        measure a rate that reads them better."""
        if self.report.given or len(chars) < RATE_ERRORS:
            return None
        bad = [i for i, c in enumerate(chars) if c.fault is not None and c.fault.id is LINE_FRAMING]
        if len(bad) < RATE_ERRORS:
            return None
        first = bad[0]
        # back to the silence before the first error: a rate changes between messages
        gap = 2 * self.fmt.bits * self.bit
        keep = first
        while keep > 0 and chars[keep].tick - chars[keep - 1].tick < gap:
            keep -= 1
        after = chars[keep:]
        if sum(1 for c in after if c.fault is not None) < max(RATE_ERRORS, len(after) // 4):
            return None
        start = int(np.searchsorted(self.ticks, chars[keep].tick, side="left"))
        m = measure_bit(self.ticks[start:])
        if m is None or abs(m.bit - self.bit) / self.bit < 0.04:
            return None
        level = self._level_at(start)
        again = self._read(self.ticks[start:], level, self.fmt, m.bit, self.end, probe=True)[0]
        if sum(1 for c in again if c.fault is not None) * 2 >= sum(1 for c in after if c.fault is not None):
            return None
        return keep, m.bit

    def _read(self, ticks: np.ndarray, level: int, fmt: LineFormat, bit: float, end: int,
              probe: bool = False) -> tuple[list[Char], int, int]:
        """The characters whose stop bit is before ``end``: (characters, edges
        used, the level before the first edge left)."""
        idle, active = self.idle, 1 - self.idle
        n = fmt.bits
        span = (n + 0.5) * bit                 # start edge to the middle of the (first) stop bit
        if ticks.size == 0:
            return [], 0, level
        after = level ^ 1 ^ (np.arange(ticks.size) & 1)     # the level after each edge
        cand = ticks[after == active].tolist()
        starts: list[int] = []
        j = 0
        free = -1
        while j < len(cand):
            s = cand[j]
            if s + span >= end:
                break
            starts.append(s)
            free = s + span
            j = bisect_right(cand, free, j + 1)
        if not starts:
            # nothing complete: keep from the first start edge (all of them, if
            # it is still the glitch filter's to judge), drop what came before
            used = int(np.searchsorted(ticks, cand[0], side="left")) if cand else max(ticks.size - 1, 0)
            return [], used, level ^ (used & 1)
        s_arr = np.asarray(starts, dtype=np.float64)
        offs = (np.arange(n + 1) + 0.5) * bit              # the start bit's middle, then each bit's
        at = (s_arr[:, None] + offs[None, :]).astype(np.int64)
        idx = np.searchsorted(ticks, at, side="right") - 1
        lv = np.where(idx < 0, level, level ^ 1 ^ (idx & 1))
        logical = lv if idle == 1 else 1 - lv
        false_start = logical[:, 0] != 0
        data = logical[:, 1:1 + fmt.data_bits]
        values = (data << np.arange(fmt.data_bits)).sum(axis=1)
        stop = logical[:, n]
        framing = stop == 0
        if fmt.parity != "N":
            pbit = logical[:, 1 + fmt.data_bits]
            ones = data.sum(axis=1) + pbit
            parity_bad = (ones % 2 == 1) if fmt.parity == "E" else (ones % 2 == 0) if fmt.parity == "O" else \
                (pbit != 1) if fmt.parity == "M" else (pbit != 0)
        else:
            parity_bad = np.zeros(len(starts), dtype=bool)
        brk = framing & (data.sum(axis=1) == 0)
        if not probe:
            self._count_off_grid(ticks, s_arr, span, bit)
        chars: list[Char] = []
        stop_at = len(starts)
        if false_start.any():
            # a pulse that was no start bit: read again from the edge after it
            stop_at = int(np.argmax(false_start))
        for i in range(stop_at):
            s = starts[i]
            if brk[i]:
                chars.append(Char(s, None, LINE_BREAK.problem(f"line held at the active level from {s / self.rate:.6f} s")))
            elif framing[i]:
                chars.append(Char(s, int(values[i]), LINE_FRAMING.problem(
                    f"stop bit at the active level (0x{int(values[i]):02X})")))
            elif parity_bad[i]:
                chars.append(Char(s, int(values[i]), LINE_PARITY.problem(f"{fmt.parity} parity bit wrong")))
            else:
                chars.append(Char(s, int(values[i])))
        if stop_at < len(starts):
            s = starts[stop_at]
            used = int(np.searchsorted(ticks, s, side="right"))   # past the false start's edge
            level_left = level ^ (used & 1)
            more, used2, level2 = self._read(ticks[used:], level_left, fmt, bit, end, probe)
            return chars + more, used + used2, level2
        last = starts[-1] + span
        used = int(np.searchsorted(ticks, last, side="right"))
        return chars, used, level ^ (used & 1)

    def _count_off_grid(self, ticks: np.ndarray, starts: np.ndarray, span: float, bit: float) -> None:
        """Characters with an edge inside them off the bit grid by OFF_GRID bits."""
        if starts.size == 0:
            return
        inside = ticks[(ticks > starts[0]) & (ticks < starts[-1] + span)]
        if inside.size == 0:
            return
        which = np.searchsorted(starts, inside, side="right") - 1
        phase = (inside - starts[which]) / bit
        off = (phase < span / bit) & (np.abs(phase - np.rint(phase)) > OFF_GRID)
        if off.any():
            self.report.off_grid += int(np.unique(which[off]).size)
