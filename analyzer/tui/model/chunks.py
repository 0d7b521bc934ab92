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

import numpy as np

from dissectors.event import COMMAND, RESULT, Event

from ...analysis.stats import CHECKSUM_CATEGORIES, checksum_problem, problem_categories
from ...formats.store import KIND_CODE, LINKED, UNTIMED, EventStore, StoreChunk
from .plots import PositionPlots, Series


@dataclass
class ModelChunk:
    stored: StoreChunk
    points: dict[str, dict[str, Series]]   # the plots' new points (``PositionPlots.series``)
    checksum_errors: int                   # events with a checksum problem among them


def stored_model_chunk(chunk: StoreChunk, known: tuple[list, list, list],
                       positions: tuple[np.ndarray, np.ndarray]) -> ModelChunk:
    """A recording's stored chunk (analyzer/capture/stored.py) as the screen's
    chunk, with what the plots and the checksum count learn from its events,
    from the columns: the problems, and ``positions`` (azimuth, elevation: the
    recording's position columns, analyzer/formats/store_ipc.py) under
    ``PositionPlots.add``'s rule. ``known``: every value the chunk's codes may
    name (``Joiner.known()``)."""
    checksum = sum(1 for ps in chunk.problems.values()
                   if any(cat in CHECKSUM_CATEGORIES for cat in problem_categories(ps)))
    plots = PositionPlots()
    _lines, devices, commands = known
    ids = [None, *(command for command, _place in commands)]
    azimuth, elevation = positions
    if len(azimuth) and ("P" in ids or "P?" in ids):
        cols = chunk.columns
        command = np.frombuffer(cols["command"], cols["command"].typecode)
        flags = np.frombuffer(cols["flags"], "u1")
        kind = np.frombuffer(cols["kind"], "u1")
        device = np.frombuffer(cols["device"], cols["device"].typecode)
        usable = ~np.isnan(azimuth) & (flags & UNTIMED == 0) & (device != 0)
        is_id = {name: np.isin(command, [c for c, i in enumerate(ids) if i == name]) for name in ("P", "P?")}
        which = np.where(usable & is_id["P"] & (kind == KIND_CODE[COMMAND]), 1,
                         np.where(usable & is_id["P?"] & (kind == KIND_CODE[RESULT]) & (flags & LINKED != 0), 2, 0))
        rows = np.flatnonzero(which)
        t = np.frombuffer(cols["t"], "f8")
        for d in dict.fromkeys(device[rows].tolist()):   # devices in the order they first come
            mine = rows[device[rows] == d]
            for w in dict.fromkeys(which[mine].tolist()):
                these = mine[which[mine] == w]
                name = "commanded" if w == 1 else "reported"
                address = devices[d - 1]
                plots.extend(address, f"{name} azimuth", t[these].tolist(), azimuth[these].tolist())
                with_elevation = these[~np.isnan(elevation[these])]
                if len(with_elevation):
                    plots.extend(address, f"{name} elevation", t[with_elevation].tolist(),
                                 elevation[with_elevation].tolist())
    return ModelChunk(chunk, plots.series, checksum)


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
