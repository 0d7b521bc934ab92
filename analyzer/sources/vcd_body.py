"""The body of a Value Change Dump read a block at a time, vectorised: the
tokens of a block are found with numpy (no Python object per token), the
``#time`` markers parsed digit column by digit column, and each 1-bit
variable's value changes turned into its edges (analyzer/sources/vcd.py reads
the header and streams the blocks).

What the body holds (IEEE 1364-2005 §18.2): ``#<time>``; scalar changes
``<value><id>`` (``0`` ``1`` ``x`` ``z``, upper case too; the 4-state letters
``l``/``h`` of SystemVerilog writers read as 0/1, ``u`` ``w`` ``-`` as x);
vector and real changes ``b<bits> <id>``, ``r<real> <id>`` (skipped: only 1-bit
variables are channels); ``$dumpvars`` ``$dumpall`` ``$dumpon`` ``$dumpoff``
and their ``$end`` (their values are ordinary changes); ``$comment … $end``.

x and z are not levels a UART can read: a channel at x or z keeps the level it
had before (an undriven line reads as its last driven level, which for a
tri-stated UART line at rest is idle). A channel at x from the start has no
level until its first 0 or 1, which is then its level from the start.
"""

from __future__ import annotations

import numpy as np

SPACE = np.zeros(256, dtype=bool)
SPACE[[9, 10, 11, 12, 13, 32]] = True

UNKNOWN = 2        # x, z and the like: the previous level
NOT_SCALAR = 255
SCALAR = np.full(256, NOT_SCALAR, dtype=np.uint8)
for _c in b"0lL":
    SCALAR[_c] = 0
for _c in b"1hH":
    SCALAR[_c] = 1
for _c in b"xXzZuUwW-":
    SCALAR[_c] = UNKNOWN
VECTOR = np.zeros(256, dtype=bool)
VECTOR[list(b"bBrR")] = True
KEEP_GOING = (b"$dumpvars", b"$dumpall", b"$dumpon", b"$dumpoff", b"$end")
SHORT_ID = 8       # ids up to this many bytes are packed into an int64 and looked up vectorised


def pack_id(ident: bytes) -> int:
    return int.from_bytes(ident, "little")


class BodyParser:
    """Turns blocks of the body into each channel's edge times (in the file's
    time unit). ``ids``: identifier code → channel index, 1-bit variables only."""

    def __init__(self, ids: dict[bytes, int], channels: int) -> None:
        self.channels = channels
        self.long_ids = {k: v for k, v in ids.items() if len(k) > SHORT_ID}
        short = sorted((pack_id(k), v) for k, v in ids.items() if len(k) <= SHORT_ID)
        self.keys = np.array([k for k, _ in short], dtype=np.uint64)
        self.key_channel = np.array([v for _, v in short], dtype=np.int64)
        self.time = 0                        # the last #time read
        self.timed = False                   # a #time was read
        self.level = [-1] * channels         # each channel's level (-1: not known yet)
        self.first_level: dict[int, int] = {}   # each channel's first known level: its level from the start
        self.skipping = False                # inside a $comment … $end
        self.ends_bare = False               # the last token read was a #time (no change after it)
        self.bad: tuple[int, str] | None = None   # (byte offset in the block, why) of what stopped the reading

    def parse(self, buf: bytes) -> list[np.ndarray]:
        """Each channel's edge times in ``buf`` (whole tokens). After a token that
        cannot be read, ``bad`` says where and the edges stop before it."""
        b = np.frombuffer(buf, dtype=np.uint8)
        out = [np.zeros(0, dtype=np.int64)] * self.channels
        if b.size == 0:
            return out
        space = SPACE[b]
        word = ~space
        starts = np.flatnonzero(word & np.concatenate(([True], space[:-1])))
        ends = np.flatnonzero(word & np.concatenate((space[1:], [True]))) + 1
        first = b[starts]
        n = starts.size
        skip = self._skipped(buf, starts, ends, first)
        vector = np.flatnonzero(VECTOR[first] & ~skip)
        skip[vector] = True
        skip[vector[vector + 1 < n] + 1] = True          # the vector's identifier
        is_time = (first == ord("#")) & ~skip
        code = SCALAR[first]
        is_value = (code != NOT_SCALAR) & ~skip & (ends - starts > 1)
        times, time_ok = self._times(b, starts, ends, is_time)
        bad = ~(skip | is_value | is_time) | (is_time & ~time_ok)
        if vector.size and vector[-1] + 1 >= n:
            bad[vector[-1]] = True                        # a vector change without its identifier
        cut = n
        if bad.any():
            cut = int(np.argmax(bad))
            self.bad = (int(starts[cut]), "cannot read " + repr(buf[starts[cut]:ends[cut]][:40].decode("latin-1")))
        tix = np.flatnonzero(is_time[:cut])
        tvals = times[tix]
        back = np.flatnonzero(np.diff(np.concatenate(([self.time], tvals))) < 0)
        if back.size:
            at = int(tix[back[0]])
            cut = at
            self.bad = (int(starts[at]), f"time {int(tvals[back[0]])} goes back (after {self.time if back[0] == 0 else int(tvals[back[0] - 1])})")
            tix, tvals = tix[:back[0]], tvals[:back[0]]
        # each token's time: the last #time before it
        marker = np.full(cut, -1, dtype=np.int64)
        marker[tix] = np.arange(tix.size)
        marker = np.maximum.accumulate(marker) if cut else marker
        values = np.flatnonzero(is_value[:cut])
        channel = self._channels(buf, b, starts, ends, values)
        known = channel >= 0
        values, channel = values[known], channel[known]
        at_marker = marker[values]
        value_time = np.where(at_marker >= 0, tvals[np.maximum(at_marker, 0)] if tvals.size else self.time, self.time)
        out = self._edges(channel, code[values], value_time)
        if tvals.size:
            self.time, self.timed = int(tvals[-1]), True
        if tix.size or values.size:
            self.ends_bare = bool(tix.size) and (not values.size or tix[-1] > values[-1])
        return out

    # ------------------------------------------------------------------ parts
    def _skipped(self, buf: bytes, starts: np.ndarray, ends: np.ndarray, first: np.ndarray) -> np.ndarray:
        """Tokens that are no value change: keywords, and everything of a
        ``$comment`` (or any other section) up to its ``$end``."""
        n = starts.size
        delta = np.zeros(n + 1, dtype=np.int32)
        open_at = 0 if self.skipping else -1
        for k in np.flatnonzero(first == ord("$")).tolist():
            word = buf[starts[k]:ends[k]]
            if open_at >= 0:
                if word == b"$end":
                    delta[open_at] += 1
                    delta[k + 1] -= 1
                    open_at = -1
            elif word in KEEP_GOING:
                delta[k] += 1
                delta[k + 1] -= 1
            else:
                open_at = k
        if open_at >= 0:
            delta[open_at] += 1
        self.skipping = open_at >= 0
        return np.cumsum(delta[:n]) > 0

    @staticmethod
    def _times(b: np.ndarray, starts: np.ndarray, ends: np.ndarray, is_time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The value of every ``#time`` token (digit column by digit column), and
        whether it is a number at all."""
        times = np.zeros(starts.size, dtype=np.int64)
        ok = np.zeros(starts.size, dtype=bool)
        tix = np.flatnonzero(is_time)
        if not tix.size:
            return times, ok
        s, digits = starts[tix] + 1, ends[tix] - starts[tix] - 1
        good = (digits > 0) & (digits <= 18)
        value = np.zeros(tix.size, dtype=np.int64)
        for k in range(int(min(digits.max(), 18))):
            inside = k < digits
            d = b[np.minimum(s + k, b.size - 1)].astype(np.int64) - 48
            good &= ~inside | ((d >= 0) & (d <= 9))
            value = np.where(inside, value * 10 + d, value)
        times[tix], ok[tix] = value, good
        return times, ok

    def _channels(self, buf: bytes, b: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                  values: np.ndarray) -> np.ndarray:
        """The channel of each value change's identifier (-1: not a 1-bit variable)."""
        channel = np.full(values.size, -1, dtype=np.int64)
        if not values.size or self.channels == 0:
            return channel
        s, size = starts[values] + 1, ends[values] - starts[values] - 1
        short = size <= SHORT_ID
        key = np.zeros(values.size, dtype=np.uint64)
        for k in range(int(min(size.max(), SHORT_ID))):
            inside = short & (k < size)
            byte = b[np.minimum(s + k, b.size - 1)].astype(np.uint64)
            key = np.where(inside, key | (byte << np.uint64(8 * k)), key)
        if self.keys.size:
            pos = np.minimum(np.searchsorted(self.keys, key), self.keys.size - 1)
            hit = short & (self.keys[pos] == key)
            channel[hit] = self.key_channel[pos[hit]]
        for i in np.flatnonzero(~short).tolist():
            channel[i] = self.long_ids.get(buf[int(s[i]):int(s[i] + size[i])], -1)
        return channel

    def _edges(self, channel: np.ndarray, code: np.ndarray, when: np.ndarray) -> list[np.ndarray]:
        out = [np.zeros(0, dtype=np.int64)] * self.channels
        if not channel.size:
            return out
        order = np.argsort(channel, kind="stable")
        channel, code, when = channel[order], code[order], when[order]
        bounds = np.searchsorted(channel, np.arange(self.channels + 1))
        for ch in range(self.channels):
            a, z = int(bounds[ch]), int(bounds[ch + 1])
            if a == z:
                continue
            v, t = code[a:z].astype(np.int64), when[a:z]
            known = np.where(v != UNKNOWN, np.arange(v.size), -1)
            filled = np.maximum.accumulate(known)
            level = np.where(filled >= 0, v[np.maximum(filled, 0)], self.level[ch])
            last = np.concatenate((t[1:] != t[:-1], [True]))     # the last change at a time stands
            level, t = level[last], t[last]
            before = np.concatenate(([self.level[ch]], level[:-1]))
            out[ch] = t[(level != before) & (before >= 0) & (level >= 0)]
            if level[-1] >= 0:
                if self.level[ch] < 0:
                    self.first_level[ch] = int(level[level >= 0][0])
                self.level[ch] = int(level[-1])
        return out
