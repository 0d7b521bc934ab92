"""The one event type every layer shares: deframer output, pairing input and output,
JSON Lines objects, filter subjects.

Field names here are the JSON Lines contract (docs/json-lines.md); the filter
language, the statistics, MCAP recordings and the TUI use the same names.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol

from . import problems as _problems
from .problems import Problem, ProblemInfo
from .wire import payload_text

if TYPE_CHECKING:
    from .commands import Command

# Event kinds. A single-line tap first yields "frame" for every frame; pairing then
# decides between command and result (docs/decoding.md, "Pairing").
COMMAND = "command"
RESULT = "result"
ACK = "ack"
NAK = "nak"
NIC = "nic"
NOISE = "noise"
FRAME = "frame"
# Not seen on the wire: the link's rate changed here (a rate-set command, Table 4,
# was ACKed; docs/time.md, "Rate changes"). Its fields say from and to what.
RATE = "rate"

# Command statuses (set by pairing).
OK = "ok"
ST_NAK = "nak"
ST_NIC = "nic"
NO_ACK = "no_ack"
NO_RESULT = "no_result"
PENDING = "pending"

# Every kind an event has once paired, and every status a command ends with, in
# the order JSON Schemas, filters and reports list them.
KINDS = (COMMAND, RESULT, ACK, NAK, NIC, NOISE, RATE)
STATUSES = (OK, ST_NAK, ST_NIC, NO_ACK, NO_RESULT, PENDING)

# Problem categories as text: every problem string starts with one of these,
# optionally followed by ": detail". Filters match on the category (`"bad checksum"
# in problems`). The table, with ids and severities, is ``dissectors.problems``.
P_CHECKSUM = _problems.CHECKSUM.text
P_LENGTH = _problems.LENGTH.text
P_TRUNCATED = _problems.TRUNCATED.text
P_NOISE = _problems.NOISE.text
P_MALFORMED = _problems.MALFORMED.text
P_RANGE = _problems.OUT_OF_RANGE.text
P_RESERVED = _problems.RESERVED.text
P_LOWERCASE = _problems.LOWERCASE_HEX.text
P_UNKNOWN = _problems.UNKNOWN_COMMAND.text
P_UNANSWERED = _problems.UNANSWERED.text
P_NO_RESULT = _problems.NO_RESULT.text
P_RETRANSMISSION = _problems.RETRANSMISSION.text
P_ORPHAN = _problems.ORPHAN.text
P_LATE = _problems.LATE.text


# Address texts by address. A capture has a handful of addresses, so every event
# of a device shares one string instead of holding its own (memory at a million
# events); emptied when garbled input names thousands. A plain dict: pairing
# formats every command's address, and a dict lookup costs a fraction of an LRU
# cache's bookkeeping.
_ADDRESS_TEXT: dict[Sequence[int | None], str] = {}   # keyed by tuples
_ADDRESS_TEXT_MAX = 4096


def format_address(address: Sequence[int | None]) -> str:
    """A device address as people write it, "group.port.device" (``(1, 1, 2)`` ->
    ``"1.1.2"``). The one place addresses become text."""
    try:
        text = _ADDRESS_TEXT.get(address)
    except TypeError:   # a list, not a tuple: unhashable as a key
        address = tuple(address)
        text = _ADDRESS_TEXT.get(address)
    if text is None:
        if len(_ADDRESS_TEXT) >= _ADDRESS_TEXT_MAX:
            _ADDRESS_TEXT.clear()
        g, p, d = address
        text = _ADDRESS_TEXT[address] = f"{g}.{p}.{d}"
    return text


def parse_address(text: str, top: int = 255) -> tuple[int, int, int]:
    """``"1.1.2"`` -> ``(1, 1, 2)``: ``format_address`` the other way. ValueError
    for anything but three whole numbers 0..``top`` (255 is the wildcard; gimbals
    have addresses up to 254)."""
    parts = text.split(".")
    if len(parts) != 3:
        raise ValueError(text)
    g, p, d = (int(x) for x in parts)
    if not all(0 <= v <= top for v in (g, p, d)):
        raise ValueError(text)
    return g, p, d


class PairingRecord(Protocol):
    """What a reader of any event may ask of its pairing record
    (``Event.transaction``): pairing's ``analyzer.analysis.pairing.Transaction``,
    a rebuilt event's link (``analyzer.formats.store``) or a device given by hand."""

    @property
    def command(self) -> str | None:
        """The command's id."""

    @property
    def device(self) -> str | None:
        """The device's "group.port.device"."""


class DeviceOnly:
    """The part of a pairing record an address-less event reads, for events given
    a device by hand rather than by pairing: no command."""

    __slots__ = ("device",)
    command = None

    def __init__(self, device: str) -> None:
        self.device = device


# Payload texts by payload: polls repeat their payloads, and the text is the one
# part of an event's JSON that costs a pass over its bytes. Bounded like the
# dissector's memos.
_PAYLOAD_TEXT: dict[bytes, str] = {}
_PAYLOAD_TEXT_MAX = 8192

# Shared, never mutated: most events have no fields and no problems.
NO_FIELDS: dict[str, Any] = {}
NO_PROBLEMS: tuple[Problem, ...] = ()


class Origin:
    """Where a capture's events come from: ``source`` names it (its inputs as
    given), ``start_time`` is the epoch of its t = 0 (None when unknown). One
    object per capture, shared by its events."""

    __slots__ = ("source", "start_time")

    def __init__(self, source: str, start_time: float | None) -> None:
        self.source = source
        self.start_time = start_time

    def __repr__(self) -> str:
        return f"Origin({self.source!r}, {self.start_time!r})"


class Event:
    """One thing seen on a line: a frame, a simple response byte, or a run of noise.

    Events are plain mutable records: the deframer fills the wire facts, dissection
    fills ``command``/``fields``, pairing fills ``txn``/``status``/``latency``.
    ``fields`` may be shared between events with identical payloads, and
    ``problems`` starts as a shared empty tuple: treat both as read-only and add
    problems with ``add_problem`` or ``note`` (``dissectors.problems``).

    ``device`` is the gimbal the event belongs to, as text shows it ("1.1.2"):
    a command's destination; a result's sender, which its header gives as the
    source group with the port and device kept (Table 3); an ACK, NAK or NIC
    carries no address: it is its transaction's. Orphan handshakes and noise
    have none. ``dst`` stays the literal header.

    ``transaction`` is the pairing record (``analyzer.analysis.pairing.Transaction``) of
    a command and of each answer pairing linked to it; None otherwise.
    """

    __slots__ = (
        "checksum_ok",
        "command",
        "dst",
        "entry",
        "fields",
        "kind",
        "latency",
        "line",
        "number",
        "offset",
        "origin",
        "payload",
        "problems",
        "raw",
        "request",
        "retransmission",
        "src",
        "status",
        "t",
        "t_end",
        "transaction",
        "txn",
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
        self.command: str | None = None
        self.fields: dict[str, Any] = NO_FIELDS
        self.problems: Sequence[Problem] = NO_PROBLEMS
        self.txn: int | None = None
        self.status: str | None = None
        self.latency: float | None = None
        self.retransmission = False
        self.request: int | None = None
        self.entry: Command | None = None  # the command-table entry, for summaries (not serialised)
        # set by pairing: the command's and its answers' record
        self.transaction: PairingRecord | None = None
        # set by the capture: an ``Origin`` (where, and when t = 0 was)
        self.origin: Origin | None = None

    @property
    def source(self) -> str | None:
        """The capture the event comes from (its inputs as given), or None."""
        origin = self.origin
        return origin.source if origin is not None else None

    @property
    def ts(self) -> float | None:
        """Absolute time of the event's first byte, epoch seconds (None without
        time, or when the capture's start is unknown)."""
        origin = self.origin
        t = self.t
        if origin is None or t is None or origin.start_time is None:
            return None
        return origin.start_time + t

    @property
    def datetime(self) -> _dt.datetime | None:
        """``ts`` as an aware datetime in UTC."""
        ts = self.ts
        return None if ts is None else _dt.datetime.fromtimestamp(ts, _dt.UTC)

    @property
    def end(self) -> int:
        """Offset one past the event's last byte on its line."""
        return self.offset + len(self.raw)

    @property
    def device(self) -> str | None:
        """The device's "group.port.device" (class docstring), or None."""
        dst = self.dst
        if dst is None:   # an ACK, NAK or NIC names no device: its transaction does
            txn = self.transaction
            return txn.device if txn is not None else None
        kind = self.kind
        if kind == COMMAND:
            return format_address(dst)
        if kind == RESULT:
            return format_address((self.src, dst[1], dst[2]))
        return None   # an unclassified single-line frame: its direction is not known yet

    @device.setter
    def device(self, value: str | None) -> None:
        """For events linked without pairing (built by hand): a stand-in record
        that only names the device."""
        self.transaction = DeviceOnly(value) if value is not None else None

    def add_problem(self, info: ProblemInfo | str, detail: str = "") -> None:
        """Attach one problem: ``info`` is its entry in ``dissectors.problems``
        (``CHECKSUM``); a category's text ("bad checksum") names its entry."""
        if not isinstance(info, ProblemInfo):
            info = _problems.parse(info).id
        self.problems = [*self.problems, info.problem(detail)]

    def note(self, *problems: Problem | str) -> None:
        """Attach problems. ``problems`` starts as a shared empty tuple (one
        allocation fewer per event on the hot path) and becomes a list when used.
        A plain "category: detail" string gets its category's id (and raises
        ValueError when the category is not in the table): every problem has one."""
        if problems:
            self.problems = [*self.problems, *map(_problems.parse, problems)]

    def has_problem(self, what: ProblemInfo | str) -> bool:
        """Does the event carry this problem? ``what`` is an id of the table (a
        category id also matches its sub-cases) or a category's text."""
        if isinstance(what, ProblemInfo):
            return any(what.matches(p) for p in self.problems)
        return any(p == what or p.startswith(what + ":") for p in self.problems)

    def to_dict(self) -> dict[str, Any]:
        """The JSON Lines object (docs/json-lines.md)."""
        # Written out flat (no property, no helper per key): it runs once per event
        # of every JSON Lines output, recording and filter.
        payload = self.payload
        if payload is not None:
            try:
                text = _PAYLOAD_TEXT.get(payload)
            except TypeError:   # a bytearray set by hand: not a key
                payload = bytes(payload)
                text = _PAYLOAD_TEXT.get(payload)
            if text is None:
                if len(_PAYLOAD_TEXT) >= _PAYLOAD_TEXT_MAX:
                    _PAYLOAD_TEXT.clear()
                text = _PAYLOAD_TEXT[payload] = payload_text(payload)
        else:
            text = None
        t = self.t
        t_end = self.t_end
        dst = self.dst
        kind = self.kind
        # Event.device, inline
        if dst is None:
            txn = self.transaction
            device = txn.device if txn is not None else None
        elif kind == COMMAND:
            device = format_address(dst)
        elif kind == RESULT:
            device = format_address((self.src, dst[1], dst[2]))
        else:
            device = None
        # tuples stay tuples: JSON encoders write them as arrays
        return {
            "number": self.number,
            "t": round(t, 9) if t is not None else None,
            "t_end": round(t_end, 9) if t_end is not None else None,
            "line": self.line,
            "offset": self.offset,
            "kind": kind,
            "command": self.command,
            "dst": dst,
            "src": self.src,
            "payload": text,
            "checksum_ok": self.checksum_ok,
            "fields": self.fields,
            "problems": self.problems,
            "txn": self.txn,
            "status": self.status,
            "latency": self.latency,
            "retransmission": self.retransmission,
            "request": self.request,
            "raw": self.raw.hex(),
            "device": device,   # last: the keys before it keep their places
        }

    def __repr__(self) -> str:
        return (f"Event(#{self.number} {self.line}@{self.offset} {self.kind} "
                f"{self.command or ''} raw={self.raw.hex()} problems={self.problems})")
