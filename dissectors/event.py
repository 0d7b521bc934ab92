"""The one event type every layer shares: deframer output, pairing input and output,
JSON Lines objects, filter subjects.

Field names here are the JSON Lines contract (README, "Event contract"); the filter
language, the statistics, MCAP recordings and the TUI use the same names.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

# Event kinds. A single-line tap first yields "frame" for every frame; pairing then
# decides between command and result (docs/decoding.md, "Pairing").
COMMAND = "command"
RESULT = "result"
ACK = "ack"
NAK = "nak"
NIC = "nic"
NOISE = "noise"
FRAME = "frame"

# Command statuses (set by pairing).
OK = "ok"
ST_NAK = "nak"
ST_NIC = "nic"
NO_ACK = "no_ack"
NO_RESULT = "no_result"
PENDING = "pending"

# Problem categories: every problem string starts with one of these, optionally
# followed by ": detail". Filters match on the category (`"bad checksum" in problems`).
P_CHECKSUM = "bad checksum"
P_LENGTH = "bad length byte"
P_TRUNCATED = "truncated frame"
P_NOISE = "noise"
P_MALFORMED = "malformed payload"
P_RANGE = "value out of range"
P_RESERVED = "reserved code"
P_LOWERCASE = "lower-case hex"
P_UNKNOWN = "unknown command"
P_UNANSWERED = "unanswered"
P_NO_RESULT = "missing result"
P_RETRANSMISSION = "retransmission"
P_ORPHAN = "orphan"
P_LATE = "late answer"


def format_address(address) -> str:
    """A device address as people write it, "group.port.device" (``(1, 1, 2)`` ->
    ``"1.1.2"``). The one place addresses become text."""
    try:
        return _address_text(address)
    except TypeError:   # a list, not a tuple: unhashable for the cache
        return _address_text(tuple(address))


@lru_cache(maxsize=4096)
def _address_text(address: tuple[int, int, int]) -> str:
    # Cached: a capture has a handful of addresses, so every event of a device
    # shares one string instead of holding its own (memory at a million events).
    g, p, d = address
    return f"{g}.{p}.{d}"


# Shared, never mutated: most events have no fields and no problems.
NO_FIELDS: dict = {}
NO_PROBLEMS: tuple = ()


class Event:
    """One thing seen on a line: a frame, a simple response byte, or a run of noise.

    Events are plain mutable records: the deframer fills the wire facts, dissection
    fills ``command``/``fields``, pairing fills ``txn``/``status``/``latency``.
    ``fields`` may be shared between events with identical payloads, and
    ``problems`` starts as a shared empty tuple: treat both as read-only and add
    problems with ``note``.

    ``device`` is the gimbal the event belongs to, as text shows it ("1.1.2"):
    a command's destination; a result's sender, which its header gives as the
    source group with the port and device kept (Table 3); an ACK, NAK or NIC
    carries no address, so pairing copies its command's. Orphan handshakes and
    noise have none. ``dst`` stays the literal header.
    """

    __slots__ = (
        "number", "line", "offset", "t", "t_end", "kind", "raw",
        "dst", "src", "payload", "checksum_ok",
        "command", "fields", "problems",
        "txn", "status", "latency", "retransmission", "request",
        "entry", "_device",
    )

    def __init__(self, line: str, offset: int, kind: str, raw: bytes,
                 t: float | None = None, t_end: float | None = None,
                 dst: tuple[int, int, int] | None = None, src: int | None = None,
                 payload: bytes | None = None, checksum_ok: bool | None = None) -> None:
        self.number = 0
        self.line = line
        self.offset = offset
        self.t = t
        self.t_end = t_end
        self.kind = kind
        self.raw = raw
        self.dst = dst
        self.src = src
        self.payload = payload
        self.checksum_ok = checksum_ok
        self.command = None
        self.fields = NO_FIELDS
        self.problems = NO_PROBLEMS
        self.txn = None
        self.status = None
        self.latency = None
        self.retransmission = False
        self.request = None
        self.entry = None  # the command-table entry, for summaries (not serialised)
        self._device = None  # an answer's device, set by pairing (answers have no header)

    @property
    def end(self) -> int:
        """Offset one past the event's last byte on its line."""
        return self.offset + len(self.raw)

    @property
    def device(self) -> str | None:
        """The device's "group.port.device" (class docstring), or None."""
        dst = self.dst
        if self._device is not None or dst is None:
            return self._device
        kind = self.kind
        if kind == COMMAND:
            return format_address(dst)
        if kind == RESULT:
            return format_address((self.src, dst[1], dst[2]))
        return None   # an unclassified single-line frame: its direction is not known yet

    @device.setter
    def device(self, value: str | None) -> None:
        self._device = value

    def add_problem(self, category: str, detail: str = "") -> None:
        self.note(f"{category}: {detail}" if detail else category)

    def note(self, *problems: str) -> None:
        """Attach problem strings. ``problems`` starts as a shared empty tuple (one
        allocation fewer per event on the hot path) and becomes a list when used."""
        if problems:
            self.problems = [*self.problems, *problems]

    def has_problem(self, category: str) -> bool:
        return any(p == category or p.startswith(category + ":") for p in self.problems)

    def to_dict(self) -> dict[str, Any]:
        """The JSON Lines object (README, "Event contract")."""
        from .wire import payload_text

        payload = self.payload
        t = self.t
        t_end = self.t_end
        # tuples stay tuples: JSON encoders write them as arrays
        return {
            "number": self.number,
            "t": round(t, 9) if t is not None else None,
            "t_end": round(t_end, 9) if t_end is not None else None,
            "line": self.line,
            "offset": self.offset,
            "kind": self.kind,
            "command": self.command,
            "dst": self.dst,
            "src": self.src,
            "payload": payload_text(payload) if payload is not None else None,
            "checksum_ok": self.checksum_ok,
            "fields": self.fields,
            "problems": self.problems,
            "txn": self.txn,
            "status": self.status,
            "latency": self.latency,
            "retransmission": self.retransmission,
            "request": self.request,
            "raw": self.raw.hex(),
            "device": self.device,   # last: the keys before it keep their places
        }

    def __repr__(self) -> str:
        return (f"Event(#{self.number} {self.line}@{self.offset} {self.kind} "
                f"{self.command or ''} raw={self.raw.hex()} problems={self.problems})")
