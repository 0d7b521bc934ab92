"""A software UART: one line's edges in, its characters out, with their wire
times and the receiver's errors (docs/instruments.md, "The software UART").

It reads as a hardware UART does: a start bit is an edge from the idle level
that is still at the active level half a bit later (else it was a pulse, not a
start bit), each bit is sampled at its middle, the stop bit must be back at
idle (else a framing error; all bits at the active level, a break). What a
hardware UART is told, it finds out: the bit time and the idle level from the
edges (``bitrate``), the character format from the characters (``charformat``),
and a change of rate three ways: the protocol layer's word that a rate-set
command was acknowledged (``hint_rate``), a run of framing errors after a
silence (the link slowed down), and a burst of pulses under a quarter bit that
reads as characters at a faster rate (the link sped up: such pulses are not
glitches). It also counts what only a waveform shows: glitches (pulses under a
quarter bit, removed before decoding, as a receiver's majority vote would) and
characters whose edges fall off the bit grid (two senders driving the line at
once).

Incremental: ``feed`` takes a block of edges known up to a tick, decodes every
character whose stop bit is inside it and keeps the rest; ``finish`` ends the
line. The sequential part (which edge starts the next character) is a loop over
characters with a binary search; sampling the bits is vectorised over all of a
block's characters. Nothing recurses on what the line holds: a noise burst of a
million false starts is a million turns of one loop.
"""

from __future__ import annotations

from bisect import bisect_right
from typing import NamedTuple

import numpy as np

from dissectors.problems import LINE_BREAK, LINE_FRAMING, LINE_PARITY, Problem

from .bitrate import ENOUGH_EDGES, MIN_EDGES, NEAR, Measured, idle_level, measure_bit, named_rate, without_glitches
from .charformat import WIDTHS, LineFormat, Reading, Verdict, stop_bits, tell_format
from .edges import NO_EDGES, Edges
from .report import LineReport, RateChange

OFF_GRID = 0.3         # an edge this far (in bits) from a bit boundary is off the grid
RATE_ERRORS = 4        # framing errors in a row of characters that make the rate be measured again
MAX_CHANGES = 4        # rate changes followed within one block of edges
WINDOW = 2 * ENOUGH_EDGES   # edges a rate is measured on
HOLD_EDGES = 4 * WINDOW     # edges of a run of errors held back for the next block, at most
MAX_WINDOWS = 4096     # windows tried before a line is said to show no rate (about 200,000 edges)
KEEP_WINDOWS = 4       # windows of edges kept behind the one tried next, while no rate is found
FORMAT_EDGES = 2400    # edges the format is told from (about five hundred characters: a counter
                       # sending 0x80 to 0xFF first has shown a top bit of 0 by then)
BURST_PULSES = 16      # pulses under a quarter bit before they may be a faster rate, not glitches
SAME_RATE = 0.04       # bit times this close are one rate
MIN_BIT = 1.5          # ticks: no bit time is measured from pulses of one sample


class Char(NamedTuple):
    """A character read, or a break (``value`` None)."""
    tick: int                    # the start bit's edge
    value: int | None
    fault: Problem | None = None
    off_grid: bool = False       # an edge inside it off the bit grid (two senders at once)


class SoftUart:
    """One line's receiver. ``report`` is kept up to date as it reads.

    ``min_bit``: the shortest bit time (ticks) it measures: 4 samples on a
    sampled line, where fewer cannot be read; a line whose clean traffic runs
    faster than that leaves its rate in ``too_fast`` (bit/s) and decodes nothing."""

    def __init__(self, report: LineReport, bit: float | None = None, fmt: LineFormat | None = None,
                 min_bit: float = 0.0) -> None:
        self.report = report
        self.rate = report.samplerate
        self.bit = bit                            # ticks a bit: given, or measured from the edges
        self.fmt = fmt or LineFormat()
        self.fmt_given = fmt is not None
        self.min_bit = min_bit
        self.too_fast: float | None = None
        self.idle = 1
        self.ticks = NO_EDGES                     # edges not decoded yet
        self.level = 1                            # the level before ticks[0]
        self.started = False                      # measured (or given) and decoding
        self.end = 0                              # levels are known up to here
        self._clean_upto = 0                      # ticks[:this] are past the glitch filter
        self._windows = 0                         # windows measured without finding a rate, of the edges kept
        self._dropped_windows = 0                 # ... and of the edges let go since
        self._burst_checked = -1                  # short pulses before this tick were no faster rate
        self._hint: tuple[float, float] | None = None   # (tick, bit) the protocol layer said the rate changed

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
        if not self.started and not self.measure(final=True):
            return []
        return self.decode(final=True)

    def hint_rate(self, tick: float, baud: float) -> None:
        """The protocol layer saw the link's rate change acknowledged at ``tick``
        (Table 4's rate-set commands): the edges from there are measured again."""
        if self.bit is not None and baud > 0 and abs(self.rate / baud - self.bit) / self.bit >= SAME_RATE:
            self._hint = (tick, self.rate / baud)

    @property
    def _known_bit(self) -> float:
        """The bit time in ticks, once measured or given: reading starts only then."""
        bit = self.bit
        assert bit is not None
        return bit

    # ------------------------------------------------------------------ measuring
    def measure(self, final: bool = False) -> bool:
        """Measure the rate (unless given), the idle level and the format (unless
        given) on the edges so far; False when they show no rate yet."""
        r = self.report
        if self.bit is None:
            found = self._measure_window(final)
            if found is None:
                return False
            start, m = found
            self.bit = m.bit
            r.measured = self.rate / m.bit
            r.nominal = named_rate(r.measured)
            r.measured_from, r.rate_fit, r.rate_sure = m.intervals, m.fit, m.sure
        else:
            start = 0
            clock = measure_bit(self.ticks[:WINDOW], self.min_bit)   # the clock, for the doctor
            if clock is not None:
                r.measured = self.rate / clock.bit
            r.given = True
            r.nominal = round(self.rate / self.bit)
        self.idle, verdict = self._idle_and_format(start)
        self.fmt = verdict.fmt
        r.inverted = self.idle == 0
        r.data_bits, r.parity, r.stop_bits = self.fmt
        r.possible_formats = list(verdict.possible)
        self.started = True      # (glitches are decode's to judge: a faster rate's pulses are none)
        return True

    def _measure_window(self, final: bool) -> tuple[int, Measured] | None:
        """The first window of edges that shows a rate: (its first edge, the
        measure). A line may start with what is no traffic (a device powering
        up oscillates, a probe touched on): windows slide past it. A window is
        tried once it is full (the first, from ENOUGH_EDGES on, as it fills);
        the end of the line tries the last one however full."""
        t = self.ticks
        step = WINDOW // 2
        while self._windows + self._dropped_windows < MAX_WINDOWS:
            start = self._windows * step
            full = start + WINDOW <= t.size
            if not full and not (final or start == 0) or t.size - start < MIN_EDGES:
                return None
            window = t[start:start + WINDOW]
            m = measure_bit(window, self.min_bit)
            if m is not None:
                return start, m
            if self.min_bit and self.too_fast is None:
                fast = measure_bit(window, MIN_BIT)
                # "sampled too slowly" is advice to buy a faster analyser: only
                # when many whole bits say so, never from a few glitches
                if fast is not None and fast.sure:
                    self.too_fast = self.rate / fast.bit
            if not full:
                return None
            self._windows += 1
            if self._windows > KEEP_WINDOWS:
                # edges long judged to show no rate are let go (a window's worth
                # stays before the next): a line that never shows one holds
                # bounded memory however long the capture
                cut = step * (self._windows - KEEP_WINDOWS)
                self.level = self._level_at(cut)
                self.ticks = t = t[cut:]
                self._windows = KEEP_WINDOWS
                self._dropped_windows += 1
        # no rate in all those windows: the line is said to show none, and holds
        # only its latest edges (the level stays known)
        cut = max(0, t.size - WINDOW)
        self.level = self._level_at(cut)
        self.ticks = t[cut:]
        return None

    def _idle_and_format(self, start: int) -> tuple[int, Verdict]:
        """The idle level and the format the first characters from edge ``start``
        show (ties: the level the line rests at); a level the line clearly rests
        at through its silences is kept unless the other reads far better."""
        bit = self._known_bit
        t = self.ticks[start:start + FORMAT_EDGES]
        level = self._level_at(start)
        end = self.end if start + FORMAT_EDGES >= self.ticks.size else int(self.ticks[start + FORMAT_EDGES])
        rests, sure = idle_level(t, level, end, bit, begin=int(self.ticks[start - 1]) if start else 0)
        best = None
        for idle in (rests, 1 - rests):
            self.idle = idle
            if self.fmt_given:
                chars = self._read(t, level, self.fmt, bit, end, probe=True)[0]
                verdict = Verdict(self.fmt, sum(1 for c in chars if c.fault is not None))
            else:
                verdict = tell_format([self._reading(t, level, width, end) for width in WIDTHS])
            errors = verdict.errors
            if idle != rests and sure:
                errors = errors * 2 + 2
            elif not sure:   # a line starts and ends a capture idle, most often
                errors += 2 * ((idle != level) + (idle != self._level_at(start + t.size)))
            key = (errors, idle != rests)
            if best is None or key < best[0]:
                best = (key, idle, verdict)
        assert best is not None   # (both levels were tried)
        _, idle, verdict = best
        self.idle = idle
        if not self.fmt_given:
            chars = self._read(t, level, verdict.fmt, bit, end, probe=True)[0]
            verdict = verdict._replace(fmt=verdict.fmt._replace(
                stop_bits=stop_bits([c.tick for c in chars], verdict.fmt, bit)))
        return idle, verdict

    def _reading(self, ticks: np.ndarray, level: int, width: int, end: int) -> Reading:
        chars = self._read(ticks, level, LineFormat(width), self._known_bit, end, probe=True)[0]
        values = [c.value for c in chars if c.fault is None and c.value is not None]
        return Reading(width, values, len(chars) - len(values), [c.tick for c in chars])

    def _filter_glitches(self) -> None:
        """Drop pulses shorter than a quarter bit, both edges (the level goes back),
        counting each once; the last edge waits until the next is known."""
        t = self.ticks
        if t.size - self._clean_upto < 1 or self.bit is None:
            return
        self.ticks, removed = without_glitches(t, max(self._clean_upto - 1, 0), self.bit / 4)
        self.report.glitches += removed
        self._clean_upto = self.ticks.size

    # ------------------------------------------------------------------ decoding
    def decode(self, final: bool = False) -> list[Char]:
        """Every character complete in the edges so far (``final``: the line has ended)."""
        out: list[Char] = []
        changes = 0
        while True:
            # (a few changes a block at most: noise must not send it measuring forever)
            if changes < MAX_CHANGES:
                change = self._hinted() or self._faster_burst(final)
                if change is not None:
                    tick, new_bit = change
                    self._decode_before(tick, out)
                    if new_bit is None:
                        return out
                    self._switch(tick, new_bit)
                    changes += 1
                    continue
            self._filter_glitches()
            chars, used, level = self._read(self.ticks, self.level, self.fmt, self._known_bit, self.end)
            slowed = self._slowed_down(chars) if changes < MAX_CHANGES else None
            if slowed is None:
                held = None if final or changes >= MAX_CHANGES else self._held_back(chars)
                if held is not None:
                    # a run of errors still too short to judge: read again with
                    # the next edges, however the capture is cut into blocks
                    self._commit(chars[:held], out)
                    self._cut_at(chars[held].tick)
                    return out
                self._commit(chars, out)
                self.ticks, self.level = self.ticks[used:], level
                self._clean_upto = max(0, self._clean_upto - used)
                return out
            keep, new_bit = slowed
            changes += 1
            # the characters before the change stand; read the rest at the new rate
            self._commit(chars[:keep], out)
            self._switch(chars[keep].tick, new_bit)

    def _decode_before(self, tick: int, out: list[Char]) -> None:
        """The characters before ``tick`` at the present rate; the edges from there stay."""
        cut = int(np.searchsorted(self.ticks, tick, side="left"))
        if cut == 0:
            return
        head, removed = without_glitches(self.ticks[:cut], max(self._clean_upto - 1, 0), self._known_bit / 4)
        self.report.glitches += removed
        chars, _, _ = self._read(head, self.level, self.fmt, self._known_bit, int(tick))
        self._commit(chars, out)
        self._cut_at(tick)
        self._clean_upto = 0

    def _switch(self, tick: int, new_bit: float) -> None:
        """Read from ``tick`` on at ``new_bit`` ticks a bit (a rate change)."""
        self._cut_at(tick)
        self._clean_upto = 0    # glitches are judged again against the new bit time
        r = self.report
        r.rate_changes.append(RateChange(tick / self.rate, self.rate / self._known_bit, self.rate / new_bit))
        self.bit = new_bit
        r.measured = self.rate / new_bit
        r.nominal = named_rate(r.measured)

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
                # counted with the characters they are of, as they stand: a break
                # is no character, and characters read again after a rate change
                # were never committed the first time
                r.characters += 1
                r.off_grid += c.off_grid
        out.extend(chars)

    # ------------------------------------------------------------------ rate changes
    def _hinted(self) -> tuple[int, float] | None:
        """The protocol layer's rate change, as (tick, bit): the edges from its
        tick measured again, the hinted rate where they show none near it."""
        if self._hint is None:
            return None
        tick, new_bit = self._hint
        self._hint = None
        bit = self._known_bit
        if abs(new_bit - bit) / bit < SAME_RATE:
            return None       # the UART followed the change itself already
        i = int(np.searchsorted(self.ticks, tick, side="left"))
        m = measure_bit(self.ticks[i:i + WINDOW], self.min_bit)
        if m is not None and abs(m.bit - new_bit) / new_bit <= NEAR:
            new_bit = m.bit
        return int(np.ceil(tick)), new_bit

    def _faster_burst(self, final: bool) -> tuple[int, float | None] | None:
        """A run of pulses under a quarter bit after a silence that reads as
        characters at a faster rate: the link sped up. Returns the first edge's
        tick and the new bit time, or None for the bit time while the burst is
        too short to judge (its edges wait, undecoded). Glitches and ringing read
        as no rate, or as garbage, and stay glitches."""
        t = self.ticks
        lo = int(np.searchsorted(t, self._burst_checked, side="right"))
        if t.size - lo < BURST_PULSES:
            return None
        short = np.flatnonzero(np.diff(t[lo:]) < self._known_bit / 4)
        if short.size < BURST_PULSES:
            return None
        first = lo + int(short[0])
        # back to the silence before the first short pulse: a rate changes between messages
        silence = 1.5 * (self.fmt.bits + 1) * self._known_bit
        gaps = np.flatnonzero(np.diff(t[:first + 1]) > silence)
        start = int(gaps[-1]) + 1 if gaps.size else 0
        window = t[start:start + WINDOW]
        if window.size < WINDOW and not final:
            return int(t[start]), None
        self._burst_checked = int(window[-1])
        m = measure_bit(window, self.min_bit)
        if m is None or m.bit > self._known_bit / 2:
            return None
        chars = self._read(window, self._level_at(start), self.fmt, m.bit, int(window[-1]), probe=True)[0]
        if len(chars) < 4 or sum(1 for c in chars if c.fault is not None) * 8 > len(chars):
            return None
        return int(t[start]), m.bit

    def _slowed_down(self, chars: list[Char]) -> tuple[int, float] | None:
        """After a silence, a run of framing errors and breaks where there were
        none: the link's rate changed (Table 4's rate-set commands; a slower
        rate's start bit reads as a break). Returns (the first character at the
        new rate, its bit time), when the edges from there measure a rate that
        reads them better."""
        if self.report.given or len(chars) < RATE_ERRORS:
            return None
        bad = _misread(chars)
        if len(bad) < RATE_ERRORS:
            return None
        keep = self._run_start(chars, bad[0])
        after = chars[keep:]
        if sum(1 for c in after if c.fault is not None) < max(RATE_ERRORS, len(after) // 4):
            return None
        start = int(np.searchsorted(self.ticks, chars[keep].tick, side="left"))
        m = measure_bit(self.ticks[start:start + 4 * WINDOW], self.min_bit)
        bit = self._known_bit
        if m is None or abs(m.bit - bit) / bit < SAME_RATE:
            return None
        level = self._level_at(start)
        again = self._read(self.ticks[start:], level, self.fmt, m.bit, self.end, probe=True)[0]
        if sum(1 for c in again if c.fault is not None) * 2 >= sum(1 for c in after if c.fault is not None):
            return None
        return keep, m.bit

    def _run_start(self, chars: list[Char], first: int, gap: float | None = None) -> int:
        """The first character of the run that holds ``chars[first]``: back to
        the silence before it (a rate changes between messages): ``gap`` ticks,
        by default two characters, or longer where the run's characters come
        further apart (a slower rate's, read at this one)."""
        if gap is None:
            gap = 2 * self.fmt.bits * self._known_bit
            ticks = [c.tick for c in chars[first:]]
            if len(ticks) > 2:
                gap = max(gap, 1.5 * float(np.median(np.diff(ticks))))
        keep = first
        while keep > 0 and chars[keep].tick - chars[keep - 1].tick < gap:
            keep -= 1
        return keep

    def _held_back(self, chars: list[Char]) -> int | None:
        """Where to stop committing ``chars`` when the last of them are a run
        after a silence that may still turn out to be at another rate: a few
        characters, or errors fewer than ``_slowed_down`` judges, with no silence
        after them yet. The run's first character is returned, and the run is
        read again once more edges came, so a rate change is seen however the
        capture is cut into blocks. None: commit them all. Held edges stay few:
        past HOLD_EDGES the run is what it is."""
        if self.report.given or not chars:
            return None
        if self.end - int(self.ticks[-1]) > 3 * self.fmt.bits * self._known_bit:
            return None    # the line is silent since: the run has ended
        # back over characters up to a character of half this rate apart (a
        # slower rate's first ones may read as valid): holding a few more is harmless
        keep = self._run_start(chars, len(chars) - 1, gap=2.5 * (self.fmt.bits + 1) * self._known_bit)
        run = chars[keep:]
        bad = len(_misread(run))
        if bad >= RATE_ERRORS or (bad == 0 and len(run) > RATE_ERRORS):
            return None
        if self.ticks.size - int(np.searchsorted(self.ticks, run[0].tick, side="left")) > HOLD_EDGES:
            return None
        return keep

    def _cut_at(self, tick: int) -> None:
        """Drop the edges before ``tick`` (their characters are committed)."""
        cut = int(np.searchsorted(self.ticks, tick, side="left"))
        self.level = self._level_at(cut)
        self.ticks = self.ticks[cut:]
        self._clean_upto = max(0, self._clean_upto - cut)

    # ------------------------------------------------------------------ reading
    def _read(self, ticks: np.ndarray, level: int, fmt: LineFormat, bit: float, end: int,
              probe: bool = False) -> tuple[list[Char], int, int]:
        """The characters whose stop bit is before ``end``: (characters, edges
        used, the level before the first edge left)."""
        if ticks.size == 0:
            return [], 0, level
        span = (fmt.bits + 0.5) * bit          # start edge to the middle of the (first) stop bit
        starts, used = _start_bits(ticks, level, 1 - self.idle, bit, span, end)
        if not starts:
            return [], used, level ^ (used & 1)
        return self._characters(ticks, level, fmt, bit, span, starts, probe), used, level ^ (used & 1)

    def _characters(self, ticks: np.ndarray, level: int, fmt: LineFormat, bit: float, span: float,
                    starts: list[int], probe: bool) -> list[Char]:
        """The characters at ``starts``: every bit sampled at its middle, for all
        of them at once; then the receiver's errors."""
        n = fmt.bits
        s_arr = np.asarray(starts, dtype=np.float64)
        offs = (np.arange(n + 1) + 0.5) * bit              # the start bit's middle, then each bit's
        at = (s_arr[:, None] + offs[None, :]).astype(np.int64)
        idx = np.searchsorted(ticks, at, side="right") - 1
        lv = np.where(idx < 0, level, level ^ 1 ^ (idx & 1))
        logical = lv if self.idle == 1 else 1 - lv
        data = logical[:, 1:1 + fmt.data_bits]
        values = (data << np.arange(fmt.data_bits)).sum(axis=1)
        framing = logical[:, n] == 0
        if fmt.parity != "N":
            pbit = logical[:, 1 + fmt.data_bits]
            ones = data.sum(axis=1) + pbit
            parity_bad = (ones % 2 == 1) if fmt.parity == "E" else (ones % 2 == 0) if fmt.parity == "O" else \
                (pbit != 1) if fmt.parity == "M" else (pbit != 0)
        else:
            parity_bad = np.zeros(len(starts), dtype=bool)
        brk = framing & (data.sum(axis=1) == 0)
        off_grid = np.zeros(len(starts), dtype=bool) if probe else _off_grid(ticks, s_arr, span, bit)
        chars: list[Char] = []
        for i, s in enumerate(starts):
            if brk[i]:
                chars.append(Char(s, None, LINE_BREAK.problem(f"line held at the active level from {s / self.rate:.6f} s")))
            elif framing[i]:
                chars.append(Char(s, int(values[i]), LINE_FRAMING.problem(
                    f"stop bit at the active level (0x{int(values[i]):02X})"), bool(off_grid[i])))
            elif parity_bad[i]:
                chars.append(Char(s, int(values[i]), LINE_PARITY.problem(f"{fmt.parity} parity bit wrong"),
                                  bool(off_grid[i])))
            else:
                chars.append(Char(s, int(values[i]), None, bool(off_grid[i])))
        return chars


def _start_bits(ticks: np.ndarray, level: int, active: int, bit: float, span: float,
                end: int) -> tuple[list[int], int]:
    """The sequential part of reading: which edges start a character (each one
    after the last's stop bit), and how many edges that uses up. ``level``: the
    level before ``ticks[0]``; ``span``: start edge to the middle of the stop bit."""
    after = level ^ 1 ^ (np.arange(ticks.size) & 1)     # the level after each edge
    edge = ticks[after == active]
    # a receiver checks the start bit in its middle: back at idle there, the
    # edge was a pulse (noise, ringing), no start bit (an edge whose middle is
    # past ``end`` is not judged yet: it ends the loop below)
    k = np.searchsorted(ticks, (edge + 0.5 * bit).astype(np.int64), side="right") - 1
    cand = edge[((level ^ 1 ^ (k & 1)) == active) | (edge + span >= end)].tolist()
    starts: list[int] = []
    j = 0
    while j < len(cand):
        s = cand[j]
        if s + span >= end:
            break
        starts.append(s)
        j = bisect_right(cand, s + span, j + 1)
    if starts:
        used = int(np.searchsorted(ticks, starts[-1] + span, side="right"))
    else:
        used = 0
    if j < len(cand):
        # the first edge not judged yet stays, with all after it
        used = max(used, int(np.searchsorted(ticks, cand[j], side="left")))
    else:
        used = max(used, ticks.size - 1)   # every start judged: the last edge waits for the next
    return starts, used


def _misread(chars: list[Char]) -> list[int]:
    """The indices of characters read with a framing error or as a break: what a
    wrong rate gives (a parity error alone is a disturbed bit)."""
    return [i for i, c in enumerate(chars) if c.fault is not None and c.fault.id is not LINE_PARITY]


def _off_grid(ticks: np.ndarray, starts: np.ndarray, span: float, bit: float) -> np.ndarray:
    """For each character (by its start), whether an edge inside it is off the bit
    grid by OFF_GRID bits. Edges between characters (false starts, noise) are of
    none: only those up to a character's stop bit are judged."""
    off_grid = np.zeros(starts.size, dtype=bool)
    inside = ticks[(ticks > starts[0]) & (ticks < starts[-1] + span)]
    if inside.size:
        which = np.searchsorted(starts, inside, side="right") - 1
        phase = (inside - starts[which]) / bit
        off = (phase < span / bit) & (np.abs(phase - np.rint(phase)) > OFF_GRID)
        off_grid[which[off]] = True
    return off_grid

