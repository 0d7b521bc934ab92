"""The TUI's device map and position plots, fed the events as they are shown.

The device map says, per device, which lines its answers came on, how many
commands it was sent and answered, and which commands it answered with NIC
(§1.4.2). The plots hold, per device, the commanded position (go-to ``P``,
Table 11) and the reported one (``P?`` results, Table 15), as time/degree
arrays: a day of polling is millions of points.
"""

from __future__ import annotations

from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field

from dissectors.event import ACK, COMMAND, NAK, NIC, RESULT, ST_NIC


@dataclass
class DeviceInfo:
    """One device of the device map."""
    address: str
    lines: set[str] = field(default_factory=set)       # lines its answers came on
    commands: int = 0
    answered: int = 0
    nic: set[str] = field(default_factory=set)         # commands it answered with NIC


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


_MAPPED = frozenset((COMMAND, RESULT, ACK, NAK, NIC))


class DeviceMap:
    """``devices``: address -> DeviceInfo; ``series``: address -> name -> Series."""

    def __init__(self) -> None:
        self.devices: dict[str, DeviceInfo] = {}
        self.series: dict[str, dict[str, Series]] = {}

    def add(self, events) -> None:
        devices = self.devices
        for ev in events:
            kind = ev.kind
            if kind not in _MAPPED:
                continue
            if kind != COMMAND and ev.transaction is None:
                continue   # an unpaired answer says nothing about where a device answers
            addr = ev.device
            if addr is None:
                continue
            info = devices.get(addr)
            if info is None:
                info = devices[addr] = DeviceInfo(addr)
            if kind == COMMAND:
                info.commands += 1
                if ev.status == ST_NIC and ev.command:
                    info.nic.add(ev.command)
                fields = ev.fields
                if ev.command == "P" and fields and "azimuth_deg" in fields:   # go to (Table 11)
                    self._point(addr, "commanded", ev.t, fields)
                continue
            info.lines.add(ev.line)
            if kind == ACK or kind == NAK:
                info.answered += 1
            elif kind == RESULT and ev.command == "P?" and ev.fields and "azimuth_deg" in ev.fields:
                self._point(addr, "reported", ev.t, ev.fields)

    def _point(self, addr: str, which: str, t: float | None, fields: dict) -> None:
        if t is None:
            return
        series = self.series.get(addr)
        if series is None:
            series = self.series[addr] = {}
        self._series(series, f"{which} azimuth").append(t, fields["azimuth_deg"])
        if "elevation_deg" in fields:
            self._series(series, f"{which} elevation").append(t, fields["elevation_deg"])

    @staticmethod
    def _series(series: dict[str, Series], name: str) -> Series:
        s = series.get(name)
        if s is None:
            s = series[name] = Series()
        return s

