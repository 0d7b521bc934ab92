"""Counting a run's events into statistics (analyzer/analysis/stats.py), for
``gimbalscope stats``."""

from __future__ import annotations

from ..analysis.stats import Stats
from ..runner import Listener


class StatsListener(Listener):
    """Counts every event ``keep`` accepts (all without a filter)."""

    def __init__(self, keep=None) -> None:
        self.stats = Stats()
        self.keep = keep

    def on_events(self, events) -> None:
        add, keep = self.stats.add, self.keep
        for ev in events:
            if keep is None or keep(ev):
                add(ev)
