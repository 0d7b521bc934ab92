"""Saleae Logic 2's binary export (File → Export Data → Binary): one file a
digital channel, ``digital_0.bin``, ``digital_1.bin``, … (docs/instruments.md,
"Saleae Logic 2"). Several files given together are the channels, in the order
given, each named by its file (``digital_0``, number ``0``).

Layout, little-endian (Saleae's "Binary Export Format", versions 0 and 1):
``<SALEAE>``, int32 version, int32 type (0 digital, 1 analog); then

- version 0: uint32 initial_state, double begin_time, double end_time,
  uint64 num_transitions, num_transitions doubles (seconds);
- version 1: uint64 chunk_count, and for each chunk uint32 initial_state,
  double sample_rate, double begin_time, double end_time, uint64
  num_transitions and the doubles; chunks are separated by gaps (no data).

Levels alternate from the initial state at each transition. Version 1 gives the
sample rate: the ticks are samples (``sampled``). Version 0 does not: a tick is
a nanosecond and the times are transitions. A chunk that starts at another level
than the previous one ended at changes at its start. Times are kept as
exported (Logic's origin, usually the trigger: negative before it).

The transitions are streamed a few MB at a time from each file and merged into
blocks up to the earliest time every channel is known to.
"""

from __future__ import annotations

import math
import os
import struct
from collections.abc import Iterator
from typing import BinaryIO

import numpy as np

from ..errors import CaptureError
from ..physical.edges import Block, Edges, Waveform
from ..words import counted
from .base import ReadSettings, Source
from .files import Input
from .signatures import MAGIC

NANOSECONDS = 1e9
READ_TIMES = 1 << 18          # transitions read at a time from a file (2 MB)
TICK_LIMIT = 2.0 ** 62        # a time beyond this many ticks is damage, not a time
NO_TICKS = np.zeros(0, dtype=np.int64)
_V0 = struct.Struct("<Iddq")  # initial_state, begin_time, end_time, num_transitions
_V1 = struct.Struct("<Idddq")  # initial_state, sample_rate, begin_time, end_time, num_transitions


def _read(f: BinaryIO, n: int) -> bytes:
    data = f.read(n)
    if len(data) < n:
        raise EOFError
    return data


class ChannelFile:
    """One exported channel: its header, then its transitions chunk by chunk."""

    def __init__(self, inp: Input) -> None:
        self.input = inp
        self.name = os.path.splitext(os.path.basename(inp.path))[0] if inp.path != "-" else "stdin"
        self.number = self.name.rsplit("_", 1)[-1] if self.name.rsplit("_", 1)[-1].isdigit() else ""
        self.f = inp.stream()
        self.problem: str | None = None
        try:
            magic, self.version, kind = struct.unpack("<8sii", _read(self.f, 16))
            if magic != MAGIC:
                raise CaptureError(f"{inp.name}: not a Saleae binary export (no <SALEAE> at the start)")
            if kind != 0:
                raise CaptureError(f"{inp.name}: a Saleae {'analog' if kind == 1 else f'type {kind}'} export: "
                                   "export the digital channels (File → Export Data → Binary, digital)")
            if self.version not in (0, 1):
                raise CaptureError(f"{inp.name}: Saleae binary export version {self.version} "
                                   "(versions 0 and 1 are read)")
            self.chunks_left = 1 if self.version == 0 else struct.unpack("<q", _read(self.f, 8))[0]
            self.chunk = self._chunk_header()
        except (EOFError, struct.error):
            raise CaptureError(f"{inp.name}: a Saleae binary export cut short in its header") from None
        rate = self.chunk[1]
        self.rate = rate if math.isfinite(rate) and 1 <= rate <= 1e12 else 0.0   # else: no rate given

    def _chunk_header(self) -> tuple[int, float, float, float, int]:
        """(initial_state, sample_rate or 0, begin, end, transitions)."""
        self.chunks_left -= 1
        if self.version == 0:
            state, begin, end, count = _V0.unpack(_read(self.f, _V0.size))
            return state & 1, 0.0, begin, end, count
        state, rate, begin, end, count = _V1.unpack(_read(self.f, _V1.size))
        return state & 1, rate, begin, end, count

    def times(self, scale: float) -> Iterator[tuple[np.ndarray, int, int]]:
        """(edge ticks, the level before them, the tick known up to) a piece at
        a time; a damaged end (cut, or a time that is none or goes back) sets
        ``problem`` and stops."""
        name = self.input.name
        state, _rate, begin, end, count = self.chunk
        level = state
        last = _tick(begin, scale)
        if last is None:
            self.problem = f"{name}: its begin time {begin!r} is not a time: nothing read"
            return
        yield NO_TICKS, level, last
        read = 0
        while True:
            left = count
            while left > 0:
                n = min(left, READ_TIMES)
                data = self.f.read(8 * n)
                got = np.frombuffer(data[:len(data) // 8 * 8], dtype="<f8")
                with np.errstate(all="ignore"):
                    scaled = got * scale
                    ok = np.isfinite(scaled) & (np.abs(scaled) < TICK_LIMIT)
                    ticks = np.rint(np.where(ok, scaled, 0)).astype(np.int64)
                bad = ~ok | (ticks < np.concatenate(([last], ticks[:-1])))
                first_bad = int(np.argmax(bad)) if bad.any() else None
                if first_bad is not None:
                    ticks = ticks[:first_bad]
                yield ticks, level, int(ticks[-1]) + 1 if ticks.size else last
                level ^= ticks.size & 1
                left -= ticks.size
                read += ticks.size
                last = int(ticks[-1]) if ticks.size else last
                if first_bad is not None:
                    self.problem = (f"{name}: transition {read + 1:,}: {float(got[first_bad])!r} s is not a time after the "
                                    "one before: read up to there")
                    return
                if got.size < n:
                    self.problem = (f"{name}: cut short: {read:,} of its {counted(count, 'transition')} read: "
                                    "read up to there")
                    return
            if self.chunks_left <= 0:
                stop = _tick(end, scale)
                yield NO_TICKS, level, max(stop, last + 1) if stop is not None else last + 1
                return
            try:
                state, _rate, begin, end, count = self.chunk = self._chunk_header()
            except (EOFError, struct.error):
                self.problem = f"{name}: cut short in a chunk header: read up to there"
                return
            first = _tick(begin, scale)
            if first is None or first < last:
                self.problem = f"{name}: a chunk begins at {begin!r} s, before the one before ends: read up to there"
                return
            yield (np.array([first], dtype=np.int64) if state != level else NO_TICKS), level, first + 1
            level, last = state, first


def _tick(seconds: float, scale: float) -> int | None:
    """A time from the file as a tick; None if it is none (NaN, infinite, absurd)."""
    t = seconds * scale
    return round(t) if math.isfinite(t) and abs(t) < TICK_LIMIT else None


class SaleaeBinary(Waveform):
    def __init__(self, inputs: list[Input]) -> None:
        super().__init__()
        self.files = [ChannelFile(i) for i in inputs]
        self.name = " + ".join(i.name for i in inputs)
        self.channels = [f.name for f in self.files]
        self.numbers = [f.number or str(k) for k, f in enumerate(self.files)]
        rates = [f.rate for f in self.files if f.rate > 0]
        self.sampled = bool(rates)
        self.samplerate = max(rates) if rates else NANOSECONDS

    def blocks(self) -> Iterator[Block]:
        pieces = [f.times(self.samplerate) for f in self.files]
        n = len(pieces)
        held: list[list[np.ndarray]] = [[] for _ in range(n)]   # ticks read, not yet in a block
        level = [0] * n                                         # the level before held[c]
        known = [0] * n                                         # each channel known up to this tick
        done = [False] * n
        for c, p in enumerate(pieces):
            first = next(p, None)
            if first is None:           # its begin time is damaged: the channel has nothing
                done[c] = True
            else:
                _, level[c], known[c] = first
        edge_level = list(level)
        last_end = min(known)
        while True:
            for c in range(n):
                while not done[c] and not any(a.size for a in held[c]):
                    try:
                        ticks, _, known[c] = next(pieces[c])
                    except StopIteration:
                        done[c] = True
                        break
                    held[c].append(ticks)
            if all(done) and not any(a.size for h in held for a in h):
                break
            end = min(known[c] for c in range(n) if not done[c]) if not all(done) else max(known) + 1
            edges = {}
            for c in range(n):
                ticks = np.concatenate(held[c]) if held[c] else np.zeros(0, dtype=np.int64)
                take = int(np.searchsorted(ticks, end))
                edges[c] = Edges(ticks[:take], edge_level[c])
                edge_level[c] ^= take & 1
                held[c] = [ticks[take:]] if take < ticks.size else []
            yield Block(end, edges)
            last_end = end
        if max(known) > last_end:       # the export's end_time: the levels hold up to there
            yield Block(max(known), {c: Edges(np.zeros(0, dtype=np.int64), edge_level[c]) for c in range(n)})
        for f in self.files:
            if f.problem and self.problem is None:
                self.problem = f.problem

    def close(self) -> None:
        for f in self.files:
            f.input.close()


def open_saleae_binary(inputs: list[Input], settings: ReadSettings) -> Source:
    from .sampled import SampledSource
    wave = SaleaeBinary(inputs)
    kind = f"Saleae binary export, version {wave.files[0].version}"
    return SampledSource(wave, settings, " + ".join(i.describe(kind) for i in inputs))
