"""Where each gimbal was sent and where it said it was: the per-device position
topic (``/gimbal/<group.port.device>/position``, docs/foxglove.md).

A pure function of the event stream, like pairing: fed events in wire order, it
returns the position message an event makes, or None.

- A target is commanded by ``P`` (go to pan-tilt position, Table 11, Table 15),
  or by ``Pnn`` (go to preset) once the preset's position is known: from a result
  of ``P?nn`` or ``S?nn`` (Table 15).
- A position is reported by a result of ``P?`` (current position query).

Frames with a bad checksum say nothing: the gimbal ignores such a command, and a
garbled report is not a position. Wildcard addresses (255 at any level) name no
one gimbal and get no topic.
"""

from __future__ import annotations

from typing import Any

from dissectors.event import COMMAND, RESULT, Event, format_address
from dissectors.wire import WILDCARD

AZ, EL = "azimuth_deg", "elevation_deg"
_PRESET_QUERIES = ("P?nn", "S?nn")   # results: a preset's stored position
# the commands whose events can say anything here: one set test turns the rest away
POSITION_COMMANDS = frozenset(("P", "Pnn", "P?", *_PRESET_QUERIES))


class PositionTracker:
    """Targets, presets and pending preset queries, per device."""

    def __init__(self) -> None:
        self._targets: dict[str, dict[str, float]] = {}
        self._presets: dict[tuple[str, int], dict[str, float]] = {}
        self._asked: dict[int, tuple[str, int]] = {}   # preset query's event number -> (device, preset)

    def see(self, ev: Event) -> tuple[str, dict[str, Any]] | None:
        """(device, message) when ``ev`` moves a target or reports a position."""
        if ev.command not in POSITION_COMMANDS:
            return None
        kind = ev.kind
        if kind == COMMAND:
            return self._command(ev)
        if kind == RESULT:
            return self._result(ev)
        return None

    def _command(self, ev: Event) -> tuple[str, dict[str, Any]] | None:
        command = ev.command
        if command == "P?" or ev.checksum_ok is False:
            return None
        dst = ev.dst
        if dst is None or WILDCARD in dst:
            return None
        device = format_address(dst)   # a command's device: its destination
        fields = ev.fields
        if command in _PRESET_QUERIES:
            if "preset" in fields:
                self._asked[ev.number] = (device, fields["preset"])
                if len(self._asked) > 64:   # queries never answered do not pile up
                    del self._asked[next(iter(self._asked))]
            return None
        extra: dict[str, Any] = {}
        if command == "P":
            target = _angles(fields)
        else:
            preset = fields.get("preset")
            target = self._presets.get((device, preset)) if preset is not None else None
            extra["preset"] = preset
        if target is None:
            return None
        self._targets[device] = target
        return device, _message(ev, device, "command", target=target, **extra)

    def _result(self, ev: Event) -> tuple[str, dict[str, Any]] | None:
        if ev.checksum_ok is not True:
            return None
        command = ev.command
        if command in _PRESET_QUERIES:
            asked = self._asked.pop(ev.request, None) if ev.request is not None else None
            angles = _angles(ev.fields)
            if asked is not None and angles is not None:
                self._presets[asked] = angles
            return None
        if command != "P?":
            return None
        device = ev.device
        reported = _angles(ev.fields)
        if device is None or reported is None:
            return None
        return device, _message(ev, device, "result", target=self._targets.get(device), reported=reported)


def _angles(fields: dict[str, Any]) -> dict[str, float] | None:
    az, el = fields.get(AZ), fields.get(EL)
    if az is None or el is None:
        return None
    return {AZ: az, EL: el}


def _message(ev: Event, device: str, source: str, **parts: Any) -> dict[str, Any]:
    """The position message (schemas.POSITION): keys without a value left out."""
    msg: dict[str, Any] = {"device": device, "number": ev.number, "source": source}
    if ev.t is not None:
        msg["t"] = round(ev.t, 9)
    for key, value in parts.items():
        if value is not None:
            msg[key] = value
    return msg
