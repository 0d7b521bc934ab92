"""A replay's part of the model: the file is stored as it loads, and the
playback shows it up to a capture time that advances with the wall clock
(``speed`` times as fast, while playing), or moves by a seek."""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass
from typing import Protocol

from ...formats.store import EventStore


@dataclass
class Playback:
    """Replay pace: the capture time shown so far advances with the wall clock,
    ``speed`` times as fast, while playing. ``speed`` 0 shows everything at once."""
    speed: float = 1.0
    playing: bool = True
    position: float = 0.0       # capture time (s) shown up to
    _anchor: float | None = None  # wall clock at the last update

    def toggle(self, wall: float) -> None:
        """Play or pause at ``wall``: the time paused does not count (the
        position is brought up to ``wall`` first, at the old state)."""
        self.tick(wall)
        self.playing = not self.playing

    def tick(self, wall: float) -> float:
        if self.playing and self._anchor is not None:
            self.position += (wall - self._anchor) * self.speed
        self._anchor = wall
        return self.position


class Played(Protocol):
    """What a replay reads and moves of the model (capture.py)."""
    store: EventStore
    shown: int
    done: bool

    def show_first(self, k: int) -> int: ...


class Replay:
    """``playback`` is None but for a replay (``start``)."""

    def __init__(self, model: Played) -> None:
        self.model = model
        self.playback: Playback | None = None

    def start(self, speed: float) -> None:
        self.playback = Playback(speed=speed)

    @property
    def position(self) -> float | None:
        return self.playback.position if self.playback is not None else None

    def advance(self, wall: float) -> int:
        """Move a replay on to ``wall`` clock time; returns rows newly shown."""
        pb = self.playback
        if pb is None:
            return 0
        store = self.model.store
        if pb.speed == 0:
            return self.model.show_first(len(store))
        if not self.model.shown and len(store) and pb.position == 0.0:
            pb.position = store.t[0]   # playing starts at the first event
        shown = self.model.show_first(bisect_right(store.t, pb.tick(wall)))
        n = len(store)
        if self.model.done and n and self.model.shown == n and pb.position >= store.t[n - 1]:
            # played to the end of a file that has ended: the playback stops there
            # (and the screen's pace with it), as a player does
            pb.position = store.t[n - 1]
            pb.playing = False
        return shown

    def seek(self, seconds: float) -> None:
        """Move a replay's position by ``seconds`` of capture time (either way)."""
        pb = self.playback
        store = self.model.store
        if pb is None or not len(store):
            return
        first, last = store.t[0], store.t[len(store) - 1]
        pb.position = min(max(pb.position + seconds, first), last)
        self.model.show_first(bisect_right(store.t, pb.position))
