"""Saleae Logic 2's CSV exports: the raw digital CSV, read here, and the Async
Serial data table (analyzer/sources/saleae_table.py), one reader for both.

The raw digital CSV (File → Export Data → CSV, digital channels):
``Time [s],<channel names…>``, then one row a time at which some channel changed,
the time in seconds and each channel's level, ``0``, ``1`` or ``X`` (no data: a
gap, a channel off). docs/instruments.md, "Saleae Logic 2".

The rows are transitions, not samples (``sampled`` False); a tick is a
nanosecond, finer than any Logic samples at, so the times are kept as exported.
Times count from Logic's time origin, usually the trigger: rows before it have
negative times and keep them. The first row gives every channel's level at the
start; ``X`` keeps a channel's previous level (a gap is not an edge).

Read in blocks of a few MB: numpy parses a block whole; a block it refuses (an
``X``, a damaged row) is read row by row, up to the first row that is not a
time and levels, which ends the reading (said in one line, with the line number).
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterator

import numpy as np

from ..errors import CaptureError
from ..physical.edges import NO_EDGES, Block, Edges, Waveform
from ..words import counted
from .base import ReadSettings, Source
from .files import Input
from .saleae_table import AsyncSerialTable
from .signatures import BOM, looks_like_table
from .vcd import LEVELS_HOLD

TICKS_A_SECOND = 1e9
MAX_SECONDS = 1e9             # a time beyond this (or NaN) is damage: ticks stay within int64
BLOCK_BYTES = 4 << 20
ROW_LIMIT = 16 << 20          # a row this long is no export's (1000 channels take 2 KB): damage, not read on
_NUMBERED = re.compile(r"^Channel (\d+)$", re.IGNORECASE)
_LEVEL = {"0": 0, "1": 1, "X": -1, "x": -1}


class SaleaeDigitalCsv(Waveform):
    samplerate = TICKS_A_SECOND
    sampled = False

    def __init__(self, inp: Input) -> None:
        super().__init__()
        self.input = inp
        self.name = inp.name
        self.stream = inp.stream()
        first = self.stream.readline()
        first = first.removeprefix(BOM)
        names = next(csv.reader([first.decode("utf-8", "replace")]), [])[1:]
        if not names:
            raise CaptureError(f"{inp.name}: a Saleae CSV with no channel column (line 1: Time [s],<channels>)")
        self.channels = [n.strip() for n in names]
        numbered = [_NUMBERED.match(n) for n in self.channels]
        self.numbers = [m.group(1) if m else str(i) for i, m in enumerate(numbered)]

    def blocks(self) -> Iterator[Block]:
        width = len(self.channels)
        levels: list[int] = [-1] * width
        line, left = 2, b""                     # the line the next block starts on
        last = -np.inf                          # the time of the last row read
        while True:
            data = self.stream.read(BLOCK_BYTES)
            ended = not data
            data, old = left + data, len(left)
            # left holds no line end: only the new bytes are looked through
            cut = len(data) if ended else data.rfind(b"\n", old) + 1
            if cut <= 0 and not ended and len(data) <= ROW_LIMIT:
                left = data
                continue
            if cut <= 0 and not ended:
                body, left = b"", b""
                times, values = np.zeros(0), np.zeros((0, width), dtype=np.int8)
                bad: tuple[int, str] | None = (0, f"a row of over {ROW_LIMIT >> 20} MB")
            else:
                body, left = data[:cut], data[cut:]
                times, values, unread = _parse(body, width)
                bad = None if unread is None else (
                    unread[0], f"cannot read {unread[1][:60]!r} (a time and {counted(width, 'level')} of 0, 1 or X)")
            with np.errstate(invalid="ignore"):
                back = np.flatnonzero((np.diff(np.concatenate(([last], times))) < 0) | ~(np.abs(times) < MAX_SECONDS))
            if back.size and (bad is None or back[0] < bad[0]):
                bad = (int(back[0]), f"time {times[back[0]]!r} is not after the one before")
                times, values = times[:back[0]], values[:back[0]]
            if times.size:
                last = float(times[-1])
            if bad is not None:
                row, why = bad
                self.problem = f"{self.name}: line {line + row}: {why}: read up to there"
            if times.size:
                yield self._block(times, values, levels)
            if (bad is not None or ended) and last > -np.inf:
                # no row says when the capture ended: the levels hold a while (vcd.LEVELS_HOLD)
                hold_end = round((last + LEVELS_HOLD) * TICKS_A_SECOND)
                yield Block(hold_end, {c: Edges(NO_EDGES, max(levels[c], 0) if levels[c] >= 0 else 1)
                                       for c in range(width)})
            if bad is not None or ended:
                if ended and self.input.problem and self.problem is None:
                    self.problem = self.input.problem
                return
            line += body.count(b"\n")

    def _block(self, times: np.ndarray, values: np.ndarray, levels: list[int]) -> Block:
        ticks = np.rint(times * TICKS_A_SECOND).astype(np.int64)
        edges = {}
        for ch in range(len(self.channels)):
            v = values[:, ch]
            known = np.where(v >= 0, np.arange(v.size), -1)
            filled = np.maximum.accumulate(known)
            level = np.where(filled >= 0, v[np.maximum(filled, 0)], levels[ch])
            before = np.concatenate(([levels[ch]], level[:-1]))
            at = ticks[(level != before) & (before >= 0) & (level >= 0)]
            start = levels[ch] if levels[ch] >= 0 else (int(level[level >= 0][0]) if (level >= 0).any() else 1)
            edges[ch] = Edges(at, start)
            if level[-1] >= 0:
                levels[ch] = int(level[-1])
        return Block(int(ticks[-1]) + 1, edges)

    def close(self) -> None:
        self.input.close()


def _parse(body: bytes, width: int) -> tuple[np.ndarray, np.ndarray, tuple[int, str] | None]:
    """(times, levels (rows × channels, -1 for X), (row, text) of the first row
    that does not read)."""
    if not body.strip():
        return np.zeros(0), np.zeros((0, width), dtype=np.int8), None
    try:
        table = np.loadtxt(io.BytesIO(body), delimiter=",", dtype=np.float64, ndmin=2, encoding="latin-1")
        if table.shape[1] == width + 1 and np.isin(table[:, 1:], (0.0, 1.0)).all():
            return table[:, 0], table[:, 1:].astype(np.int8), None
    except ValueError:
        pass
    times: list[float] = []
    rows: list[list[int]] = []
    bad = None
    for i, raw in enumerate(body.split(b"\n")):
        text = raw.decode("latin-1").strip()
        if not text:
            continue
        fields = [f.strip() for f in text.split(",")]
        try:
            if len(fields) != width + 1:
                raise ValueError
            t = float(fields[0])
            row = [_LEVEL[f] for f in fields[1:]]
        except (ValueError, KeyError):
            bad = (i, text)
            break
        times.append(t)
        rows.append(row)
    return (np.array(times, dtype=np.float64), np.array(rows, dtype=np.int8).reshape(-1, width), bad)


def open_saleae_csv(inputs: list[Input], settings: ReadSettings) -> Source:
    if looks_like_table(inputs[0].head):
        return AsyncSerialTable(inputs[0], settings)
    from .sampled import SampledSource
    wave = SaleaeDigitalCsv(inputs[0])
    what = f"Saleae digital CSV, {counted(len(wave.channels), 'channel')}"
    return SampledSource(wave, settings, inputs[0].describe(what))
