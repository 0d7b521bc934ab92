"""A device of the device map: which lines its answers came on, how many
commands it was sent and answered, and which commands it answered with NIC
(§1.4.2). The statistics screen shows the map, which the model works out from
the store's columns when asked (analyzer/tui/store_stats.py, ``devices_of``)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class DeviceInfo:
    """One device of the device map."""
    address: str
    lines: set[str] = field(default_factory=set)       # lines its answers came on
    commands: int = 0
    answered: int = 0
    nic: set[str] = field(default_factory=set)         # commands it answered with NIC
