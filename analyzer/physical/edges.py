"""Level changes of sampled lines: the common form every logic capture is read
into (sigrok sessions and sample streams as packed samples; VCD and Saleae
exports as transitions already).

A capture is a ``Waveform``: its channels as the file names them, its tick rate
(samples a second), and ``blocks()``, each block the edges of every channel up
to a tick. An edge is the tick of the first sample at the new level; lines are
binary, so levels alternate and a block carries only its starting level.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator
from typing import Any, NamedTuple

import numpy as np

NO_EDGES = np.zeros(0, dtype=np.int64)


class Edges(NamedTuple):
    """One channel's level changes within a block."""
    ticks: np.ndarray   # int64, ascending: the first sample at each new level
    level: int          # the level before ticks[0] (at the block's start)


class Block(NamedTuple):
    """Every channel's edges from the previous block's end up to ``end`` (a tick,
    exclusive): the levels are known up to there."""
    end: int
    edges: dict[int, Edges]   # channel index → its edges


class Waveform(ABC):
    """A logic capture: channels, their tick rate, and their edges block by block."""

    samplerate: float = 0.0          # ticks a second
    sampled: bool = True             # ticks are samples (the 4-samples-a-bit rule applies)
    start_time: float | None = None  # epoch of tick 0, when the file says
    name: str = ""                   # the input, for messages

    def __init__(self) -> None:
        self.channels: list[str] = []          # as the file names them, in its order
        self.numbers: list[str] = []           # the same channels' numbers or probe ids ("0", "D0"), if any
        self.problem: str | None = None        # said once read: a damaged end ("read up to …")

    @abstractmethod
    def blocks(self) -> Iterator[Block]:
        """The channels' edges in blocks, in time order."""

    def close(self) -> None:
        pass


def edges_of_samples(samples: np.ndarray, start: int, previous: int | None,
                     bits: dict[int, int]) -> dict[int, Edges]:
    """The edges of the channels at ``bits`` (channel index → bit of the sample
    word) in ``samples`` (uint8/uint16/uint32 words, one a sample), the first
    being sample ``start``; ``previous`` is the word before it (None at the start
    of the capture). One pass over the words finds where any bit changed; each
    channel then keeps the changes of its bit."""
    out: dict[int, Edges] = {}
    if samples.size == 0:
        for ch, bit in bits.items():
            out[ch] = Edges(NO_EDGES, (previous >> bit) & 1 if previous is not None else 0)
        return out
    if previous is None:
        previous = int(samples[0])
    changed = samples[1:] ^ samples[:-1]
    where = np.flatnonzero(changed)
    what = changed[where]
    first = previous ^ int(samples[0])
    for ch, bit in bits.items():
        mask = 1 << bit
        ticks = where[(what & mask) != 0].astype(np.int64)
        ticks += start + 1
        if first & mask:
            ticks = np.concatenate(([start], ticks))
        out[ch] = Edges(ticks, (previous >> bit) & 1)
    return out


class PackedSamples(Waveform):
    """A waveform read as packed sample words (``unitsize`` bytes a sample, channel
    ``i`` at bit ``i``), from an iterator of byte strings cut anywhere: a sigrok
    session's ``logic-1-N`` chunks, ``sigrok-cli -O binary`` on a pipe."""

    def __init__(self, chunks: Iterator[bytes], unitsize: int, channels: list[str], samplerate: float,
                 bits: list[int] | None = None, name: str = "") -> None:
        super().__init__()
        self.chunks = chunks
        self.unitsize = unitsize
        self.channels = list(channels)
        self.bits = list(bits) if bits is not None else list(range(len(channels)))
        self.samplerate = samplerate
        self.name = name
        self.samples = 0   # read so far

    def blocks(self) -> Iterator[Block]:
        dtypes: dict[int, np.dtype[Any]] = {1: np.dtype(np.uint8), 2: np.dtype("<u2"), 4: np.dtype("<u4")}
        dtype = dtypes[self.unitsize]
        bits = dict(enumerate(self.bits))
        previous: int | None = None
        left = b""
        for data in self.chunks:
            if left:
                data = left + data
            cut = len(data) - len(data) % self.unitsize
            left = data[cut:]
            if not cut:
                continue
            words = np.frombuffer(data, dtype=dtype, count=cut // self.unitsize)
            start = self.samples
            edges = edges_of_samples(words, start, previous, bits)
            previous = int(words[-1])
            self.samples += words.size
            yield Block(self.samples, edges)
