"""Which gimbals a run has positions for, for ``gimbalscope foxglove layout``:
one position plot per gimbal found."""

from __future__ import annotations

from dissectors.event import Event

from ..analysis.positions import PositionTracker
from ..runner import Listener


class PositionFinder(Listener):
    """The gimbals the events make a position message for (as recordings and live
    servers publish them: analyzer/formats/mcap_messages.py)."""

    def __init__(self) -> None:
        self.tracker = PositionTracker()
        self.devices: set[str] = set()

    def on_events(self, events: list[Event]) -> None:
        see, devices = self.tracker.see, self.devices
        for ev in events:
            found = see(ev)
            if found is not None:
                devices.add(found[0])
