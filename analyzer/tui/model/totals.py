"""What the shown events add up to: the error and checksum-error counts the
status line shows, and the statistics and device map the statistics screen
shows. The counts follow the events as they are shown; the statistics and the
device map are worked out from the store's columns when asked
(analyzer/formats/store_stats.py) and kept until the rows change."""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Iterable
from typing import Protocol

import numpy as np

from dissectors.event import Event

from ...analysis.stats import Stats, checksum_problem
from ...formats.store import EventStore
from ...formats.store_stats import DeviceInfo, devices_of, stats_of
from .filter import FilterView


class Counted(Protocol):
    """What the totals read of the model (capture.py)."""
    store: EventStore
    shown: int
    filter: FilterView


class Totals:
    def __init__(self, model: Counted) -> None:
        self.model = model
        self.checksum_errors = 0   # shown events with a checksum problem
        self._stats: tuple[tuple[int, int, int | None], Stats] | None = None   # (the rows it is of, the Stats)
        self._devices: tuple[int, dict[str, DeviceInfo]] | None = None        # (shown, the device map)

    def learn(self, events: Iterable[Event]) -> None:
        """``events`` are shown now."""
        self.checksum_errors += sum(1 for ev in events if ev.problems and checksum_problem(ev))

    def forget(self) -> None:
        """The shown events are shown again from the start (a replay went back)."""
        self.checksum_errors = 0

    @property
    def errors(self) -> int:
        """Error events among the shown ones."""
        m = self.model
        return bisect_right(m.store.errors, m.shown)

    @property
    def shown_errors(self) -> int:
        """Errors among the settled rows the filter lets through (``errors``
        without a filter)."""
        f = self.model.filter
        return self.errors if f.view is None else f.errors

    @property
    def stats(self) -> Stats:
        """The statistics of the shown events, or of the rows the filter shows."""
        m = self.model
        view = m.filter.view
        key = (m.shown, id(view), None if view is None else len(view))
        if self._stats is None or self._stats[0] != key:
            rows = None if view is None else np.frombuffer(view.tobytes(), dtype=np.int32)
            self._stats = (key, stats_of(m.store, m.shown, rows))
        return self._stats[1]

    @property
    def devices(self) -> dict[str, DeviceInfo]:
        """The device map of the shown events."""
        m = self.model
        if self._devices is None or self._devices[0] != m.shown:
            self._devices = (m.shown, devices_of(m.store, m.shown))
        return self._devices[1]
