"""The position plots, fed the events as they are shown: per device, the
commanded position (go-to ``P``, Table 11) and the reported one (``P?``
results, Table 15), as time/degree arrays: a day of polling is millions of
points. The plots screen draws them."""

from __future__ import annotations

from array import array
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

from dissectors.event import COMMAND, RESULT, Event


class Series:
    """(time, degrees) points, in columns."""

    __slots__ = ("t", "v")

    def __init__(self) -> None:
        self.t = array("d")
        self.v = array("d")

    def append(self, t: float, v: float) -> None:
        self.t.append(t)
        self.v.append(v)

    def __len__(self) -> int:
        return len(self.t)

    def __getitem__(self, k: int) -> tuple[float, float]:
        return self.t[k], self.v[k]

    def __iter__(self) -> Iterator[tuple[float, float]]:
        return zip(self.t, self.v)


class PositionPlots:
    """``series``: address -> name ("commanded azimuth", …) -> Series."""

    def __init__(self) -> None:
        self.series: dict[str, dict[str, Series]] = {}

    def add(self, events: Sequence[Event], addresses: Sequence[str | None] | None = None) -> None:
        """``events``, and ``addresses``, their devices when already known."""
        for i, ev in enumerate(events):
            command = ev.command
            if command != "P" and command != "P?":   # most events: one test
                continue
            fields = ev.fields
            if not fields or "azimuth_deg" not in fields:
                continue
            device = ev.device if addresses is None else addresses[i]
            if device is None:
                continue
            if ev.kind == COMMAND and command == "P":                  # go to (Table 11)
                self.point(device, "commanded", ev.t, fields)
            elif ev.kind == RESULT and command == "P?" and ev.transaction is not None:
                self.point(device, "reported", ev.t, fields)          # an unpaired answer says nothing

    def merge(self, series: dict[str, dict[str, Series]]) -> None:
        """Points the plots of a decoding process found (a file viewed), after these."""
        for addr, named in series.items():
            mine = self.series.get(addr)
            if mine is None:
                mine = self.series[addr] = {}
            for name, s in named.items():
                m = self._series(mine, name)
                m.t.extend(s.t)
                m.v.extend(s.v)

    def point(self, addr: str, which: str, t: float | None, fields: dict[str, Any]) -> None:
        """A ``commanded`` or ``reported`` position of ``addr`` at ``t`` (none without time)."""
        if t is None:
            return
        series = self.series.get(addr)
        if series is None:
            series = self.series[addr] = {}
        self._series(series, f"{which} azimuth").append(t, fields["azimuth_deg"])
        if "elevation_deg" in fields:
            self._series(series, f"{which} elevation").append(t, fields["elevation_deg"])

    def extend(self, addr: str, name: str, t: Iterable[float], v: Iterable[float]) -> None:
        """Points of series ``name`` of ``addr`` at once (a recording's stored columns)."""
        s = self._series(self.series.setdefault(addr, {}), name)
        s.t.extend(t)
        s.v.extend(v)

    @staticmethod
    def _series(series: dict[str, Series], name: str) -> Series:
        s = series.get(name)
        if s is None:
            s = series[name] = Series()
        return s
