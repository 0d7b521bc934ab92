"""The device map, fed the events as they are shown: per device, which lines
its answers came on, how many commands it was sent and answered, and which
commands it answered with NIC (§1.4.2). The statistics screen shows it."""

from __future__ import annotations

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


_MAPPED = frozenset((COMMAND, RESULT, ACK, NAK, NIC))


class DeviceMap:
    """``devices``: address -> DeviceInfo."""

    def __init__(self) -> None:
        self.devices: dict[str, DeviceInfo] = {}

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
                continue
            info.lines.add(ev.line)
            if kind == ACK or kind == NAK:
                info.answered += 1
