"""How far a capture has seen the wire, for pairing's timeouts (docs/time.md)."""

from __future__ import annotations

from dissectors.event import Event


class WireClock:
    """``latest``: the latest wire time any chunk or idle tick showed (None without
    time). After an idle tick, ``ticked`` is set and ``now`` is the time pairing
    may run on to: time passed with no bytes, so timeouts expire while the line is
    quiet."""

    __slots__ = ("latest", "now", "ticked")

    def __init__(self) -> None:
        self.latest: float | None = None
        self.now = 0.0        # (read only once ticked)
        self.ticked = False

    def seen(self, t: float | None) -> None:
        if t is not None and (self.latest is None or t > self.latest):
            self.latest = t

    def tick(self, now: float) -> None:
        self.now, self.ticked = now, True

    def at_end(self) -> list[Event]:
        """Everything is released: let pairing run on to the latest time seen, so a
        recording decodes with the same timeouts its live tap applied. (No events:
        the empty batch that carries the tick.)"""
        if self.latest is not None:
            self.tick(self.latest)
        return []
