"""What a tap's chunks, events and notes are as topic messages: the one place
that builds the messages of an MCAP recording and of a live Foxglove server
(``analyzer/listeners/foxglove.py``), so both carry the same topics, times and
keys (docs/foxglove.md).

``Messages`` hands each message to ``emit(topic, schema_key, log_time_ns, message)``;
``schema_key`` names its schema in ``schemas.SCHEMAS``. Message times (log_time)
are capture times (docs/time.md, "Message times"): ``start_time`` plus the wire
time. Inputs without time (raw dumps) get wire times from their byte offsets at
the baud rate (``wire_byte_time``): as if each line's bytes followed each other
without pause, which keeps every line in order.

The messages follow the schemas' rules (``schemas`` module doc): no ``null``
values (the key is left out), bytes as base64. They leave out what the
recording already holds elsewhere (docs/foxglove.md, "Size"): an event's,
transaction's or position's time is its message's log time (the capture's
start plus ``t``, to the nanosecond), and an event's bytes are on its line's raw
topic at its ``offset``; the raw chunks keep their ``t``, the ground truth that
decoding reads.

A lean recording (``lean=True``, docs/mcap.md, "Lean recordings") leaves
``/events`` out (the events are decoded again from the raw reads) and batches
the raw reads: one ``/serial/reads`` message holds up to ``READS_PER_MESSAGE``
consecutive reads of every line, in the order they were read, each with its
line, ``t`` and bytes. One list across the lines, rather than a batch per line
with sequence numbers, keeps the order the reads arrived in without anything to
merge: reading the list back gives the chunks exactly as the tap gave them, so
decoding places every chunk as it did live (timed decoding puts a chunk after
the other line's earlier chunks). A batch spans at most ``READS_SPAN`` seconds
of wire time, so its log time (its first read's) stays near its reads; a live
recording ends the batch in progress whenever it flushes (``flush_reads``).
"""

from __future__ import annotations

import time
from binascii import b2a_base64
from collections.abc import Callable
from typing import Any, NamedTuple

from dissectors.event import NO_ACK, NOISE, ST_NAK, Event
from dissectors.wire import payload_text

from ..analysis.positions import POSITION_COMMANDS, PositionTracker
from ..analysis.transactions import TransactionRows, without_nulls
from ..lines import Chunk
from ..outfile import show
from . import mcap_schemas as S
from .marks import MARK_NAME, UNMARK_NAME

Emit = Callable[[str, str, int, dict], None]

# the optional keys of an event message, in the JSON Lines order (docs/json-lines.md)
_OPTIONAL_BEFORE_FIELDS = ("command", "dst", "src")
_OPTIONAL_AFTER_FIELDS = ("txn", "status", "latency")

# lean recordings: the most reads a /serial/reads message holds, and the most wire
# time between its first and last read (docs/mcap.md, "Lean recordings")
READS_PER_MESSAGE = 64
READS_SPAN = 1.0


class Topic(NamedTuple):
    """A topic every recording (or live server) of a profile has from the start."""

    topic: str
    key: str                    # its schema's, in ``schemas.ALL_SCHEMAS``
    metadata: dict[str, str]    # its channel's


def fixed_topics(lines: tuple[str, ...], lean: bool = False) -> list[Topic]:
    """The topics of a tap on ``lines`` that exist from the start, in the default
    profile or the lean one (module doc), in the order their channels are made:
    the raw bytes (a topic per line, or a lean recording's one topic of reads,
    whose metadata says which lines), events (not lean), transactions and log. A
    gimbal's position topic comes when the gimbal is first seen."""
    if lean:
        first = [Topic(S.READS_TOPIC, "reads", {"lines": ",".join(lines)})]
    else:
        first = [*(Topic(S.RAW_TOPIC.format(line=line), "raw", {}) for line in lines),
                 Topic(S.EVENTS_TOPIC, "event", {})]
    return [*first, Topic(S.TRANSACTIONS_TOPIC, "txn", {}), Topic(S.LOG_TOPIC, "log", {})]


def base64(data: bytes) -> str:
    return b2a_base64(data, newline=False).decode("ascii")


def event_message(ev: Event) -> dict[str, Any]:
    """The /events message of ``ev`` (schemas.EVENT): the JSON Lines object without
    its null values, its ``t`` (the message's log time) and its ``raw`` (on the raw
    topic of its line, at its offset)."""
    msg: dict[str, Any] = {"number": ev.number}
    t_end = ev.t_end
    if t_end is not None:
        msg["t_end"] = round(t_end, 9)
    msg["line"] = ev.line
    msg["offset"] = ev.offset
    msg["kind"] = ev.kind
    for key in _OPTIONAL_BEFORE_FIELDS:
        value = getattr(ev, key)
        if value is not None:
            msg[key] = value
    payload = ev.payload
    if payload is not None:
        msg["payload"] = payload_text(payload)
    if ev.checksum_ok is not None:
        msg["checksum_ok"] = ev.checksum_ok
    msg["fields"] = without_nulls(ev.fields)
    msg["problems"] = ev.problems
    for key in _OPTIONAL_AFTER_FIELDS:
        value = getattr(ev, key)
        if value is not None:
            msg[key] = value
    msg["retransmission"] = ev.retransmission
    if ev.request is not None:
        msg["request"] = ev.request
    device = ev.device
    if device is not None:
        msg["device"] = device
    return msg


def log_message(ts: int, level: int, message: str, name: str, file: str = "", line: int = 0) -> dict[str, Any]:
    """A foxglove.Log message (schemas.LOG)."""
    return {"timestamp": {"sec": ts // 1_000_000_000, "nsec": ts % 1_000_000_000}, "level": level,
            "message": message, "name": name, "file": file, "line": line}


class WireClock:
    """Capture times as epoch nanoseconds (module doc): the start plus the wire
    time, or for untimed input the byte offset at the line's rate. Shared by
    MCAP messages and pcapng packets (analyzer/writers/pcapng.py), so both put
    an event at the same instant."""

    def __init__(self, start_time: float | None = None, wire_byte_time: float | None = None) -> None:
        self.wire_byte_time = wire_byte_time   # untimed input: seconds per byte offset
        self.start_ns = int((start_time if start_time is not None else time.time()) * 1e9)

    def time_ns(self, t: float | None, order: int, offset: int | None = None) -> int:
        if t is None:
            if offset is not None and self.wire_byte_time is not None:
                return self.start_ns + round(offset * self.wire_byte_time * 1e9)
            return self.start_ns + order
        return self.start_ns + round(t * 1e9)


class Messages(WireClock):
    """Turns a tap's input into topic messages, handed to ``emit`` (module doc)."""

    def __init__(self, emit: Emit, *, start_time: float | None = None,
                 wire_byte_time: float | None = None, lean: bool = False) -> None:
        super().__init__(start_time, wire_byte_time)
        self.emit = emit
        self.lean = lean
        self._reads: list[dict] = []     # lean: the batch in progress
        self._reads_ts = 0               # and its log time (its first read's)
        self._reads_t: float | None = None
        self.positions = PositionTracker()
        self._seq = 0
        self._offsets: dict[str, int] = {}
        self._transactions = TransactionRows()
        self._position_topics: dict[str, str] = {}

    def raw(self, chunk: Chunk, offset: int, line_errors: list[dict] | None = None) -> None:
        """Bytes read from a line (``offset`` of their first byte), with the
        receiver's own errors on them (analyzer/formats/mcap_lines.py), if any."""
        if not chunk.data:
            return
        line = chunk.line
        self._offsets[line] = offset + len(chunk.data)
        self._seq += 1
        if self.lean:
            self._read(line, chunk.t, base64(chunk.data), offset, line_errors)
            return
        msg = {"line": line, "offset": offset, "data": base64(chunk.data)}
        if chunk.t is not None:
            msg["t"] = chunk.t
        if line_errors:
            msg["line_errors"] = line_errors
        self.emit(S.RAW_TOPIC.format(line=line), "raw", self.time_ns(chunk.t, self._seq, offset), msg)

    def end_marker(self, t: float | None, line: str) -> None:
        """Time ran on to ``t`` with nothing more on the wire (an empty raw chunk on
        ``line``), so decoding the recording expires the same timeouts live did."""
        if t is None:
            return
        if self.lean:
            self._read(line, t, "", self._offsets.get(line, 0))
            return
        self.emit(S.RAW_TOPIC.format(line=line), "raw", self.time_ns(t, 0),
                  {"line": line, "offset": self._offsets.get(line, 0), "t": t, "data": ""})

    def _read(self, line: str, t: float | None, data: str, offset: int,
              line_errors: list[dict] | None = None) -> None:
        """Lean: a read joins the batch in progress, which goes out when full or
        when this read is more than ``READS_SPAN`` after its first."""
        reads = self._reads
        if reads and (len(reads) >= READS_PER_MESSAGE
                      or (t is not None and self._reads_t is not None and t - self._reads_t > READS_SPAN)):
            self.flush_reads()
            reads = self._reads
        if not reads:
            self._reads_ts = self.time_ns(t, self._seq, offset)
            self._reads_t = t
        read: dict[str, Any] = {"line": line, "t": t, "data": data} if t is not None else {"line": line, "data": data}
        if line_errors:
            read["line_errors"] = line_errors
        reads.append(read)

    def flush_reads(self) -> None:
        """Lean: the batch of reads in progress as a message, now (a live recording
        flushing, the end of the input, a part closing)."""
        reads = self._reads
        if reads:
            self._reads = []
            self.emit(S.READS_TOPIC, "reads", self._reads_ts, {"reads": reads})

    def note(self, message: str, t: float | None, level: int = S.WARNING) -> None:
        """A tap's own message (a port lost and back, the skew estimate) on /log."""
        ts = self.time_ns(t, 0)
        self.emit(S.LOG_TOPIC, "log", ts, log_message(ts, level, show(message), "gimbalscope tap"))

    def mark(self, number: int, t: float | None, note: str, removed: bool = False) -> None:
        """Event ``number`` marked (or unmarked) with ``note``, on /marks (analyzer/formats/marks.py)."""
        ts = self.time_ns(t, number)
        self.emit(S.MARKS_TOPIC, "log", ts, log_message(ts, S.INFO, note, UNMARK_NAME if removed else MARK_NAME,
                                                       line=number))

    def event(self, ev: Event) -> None:
        ts = self.time_ns(ev.t, ev.number, ev.offset)
        emit = self.emit
        if not self.lean:
            emit(S.EVENTS_TOPIC, "event", ts, event_message(ev))
        if ev.problems:
            emit(S.LOG_TOPIC, "log", ts, self._problem_log(ev, ts))
        self._transaction(ev, ts)
        if ev.command in POSITION_COMMANDS:
            position = self.positions.see(ev)
            if position is not None:
                device, msg = position
                topic = self._position_topics.get(device)
                if topic is None:
                    topic = self._position_topics[device] = S.POSITION_TOPIC.format(device=device)
                msg.pop("t", None)   # the message's log time
                emit(topic, "position", ts, msg)

    def finish(self) -> None:
        """The end of the input: the transaction still open is complete."""
        self.flush_reads()
        txn = self._transactions.finish()
        if txn is not None:
            self.emit(S.TRANSACTIONS_TOPIC, "txn", txn.ts, txn.to_dict())

    @staticmethod
    def _problem_log(ev: Event, ts: int) -> dict:
        level = S.ERROR if ev.kind == NOISE or ev.checksum_ok is False or ev.status in (ST_NAK, NO_ACK) \
            else S.WARNING
        what = ev.command or ev.kind
        return log_message(ts, level, f"#{ev.number} line {ev.line} {what}: " + "; ".join(ev.problems),
                           "gimbalscope", f"line {ev.line}", ev.offset)

    def _transaction(self, ev: Event, ts: int) -> None:
        """A transaction message when a command closes one (analyzer/analysis/transactions.py)."""
        txn = self._transactions.add(ev, ts)
        if txn is not None:
            self.emit(S.TRANSACTIONS_TOPIC, "txn", txn.ts, txn.to_dict())
