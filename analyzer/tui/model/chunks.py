"""What a process decoding a file for the screen hands it (decode_process.py):
the events as store columns (``StoreChunk``) and what the model's other parts
would have learnt from them as objects (the position plots' points, the
checksum errors), so the screen's thread copies arrays instead of handling a
million events.

``ChunkMaker`` is the decoding process's half: it stores the events as the
screen's store would, then hands on what it stored since the last chunk.
``CaptureModel.add_chunk`` is the screen's half.
"""

from __future__ import annotations

from dataclasses import dataclass

from dissectors.event import Event

from ...analysis.stats import checksum_problem
from ...formats.store import EventStore, StoreChunk
from .plots import PositionPlots, Series


@dataclass
class ModelChunk:
    stored: StoreChunk
    points: dict[str, dict[str, Series]]   # the plots' new points (``PositionPlots.series``)
    checksum_errors: int                   # events with a checksum problem among them


class ChunkMaker:
    def __init__(self) -> None:
        self.store = EventStore()
        self.plots = PositionPlots()
        self.checksum_errors = 0

    def __len__(self) -> int:
        """Events added since the last chunk."""
        return len(self.store)

    def add(self, events: list[Event]) -> None:
        devices = self.store.append(events)
        self.plots.add(events, devices)
        self.checksum_errors += sum(1 for ev in events if ev.problems and checksum_problem(ev))

    def take(self) -> ModelChunk:
        chunk = ModelChunk(self.store.take(), self.plots.series, self.checksum_errors)
        self.plots = PositionPlots()
        self.checksum_errors = 0
        return chunk
