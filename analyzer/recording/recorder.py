"""The MCAP recorder: a sink for raw chunks and decoded events.

Writes raw byte chunks per line, decoded events, transactions (a command with
its answers) and a foxglove.Log message per anomaly, into zstd-compressed
chunks. With ``flush_interval`` set (live taps), the chunk in progress is closed
and written at least that often, so a killed tap loses at most about that much;
such a file has no summary and still reads (``analyzer.sources.mcapfile``).

Message times (log_time): ``start_time`` plus the event's wire time. Inputs
without time get ``start_time`` plus the event number in nanoseconds, which keeps
their order.
"""

from __future__ import annotations

import os
import time
from typing import Any, Callable

from mcap.writer import CompressionType, Writer

from dissectors.event import COMMAND, NOISE, Event

from ..output import dumps
from ..sources.base import Chunk
from . import schemas as S


class RecordingError(Exception):
    """The recording file cannot be written; the message names it."""


class McapRecorder:
    def __init__(self, path: str, *, metadata: dict[str, str], start_time: float | None = None,
                 flush_interval: float | None = None, clock: Callable[[], float] = time.monotonic,
                 lines: tuple[str, ...] = ("A", "B")) -> None:
        self.path = path
        try:
            self._file = open(path, "wb")
        except OSError as e:
            raise RecordingError(f"{path}: cannot write: {e.strerror or e}") from None
        self._writer = Writer(self._file, compression=CompressionType.ZSTD, chunk_size=1 << 20)
        self._writer.start(profile=S.PROFILE, library="gimbalscope")
        self.start_ns = int((start_time if start_time is not None else time.time()) * 1e9)
        self._metadata = dict(metadata)
        self._flush_interval = flush_interval
        self._clock = clock
        self._last_flush = clock()
        self._seq = 0
        ids = {}
        for name, schema in (("raw", S.RAW), ("event", S.EVENT), ("txn", S.TRANSACTION), ("log", S.LOG)):
            ids[name] = self._writer.register_schema(schema["title"], "jsonschema", S.encoded(schema))
        self._raw_schema = ids["raw"]
        self._raw_channels = {line: self._writer.register_channel(S.RAW_TOPIC.format(line=line), "json", ids["raw"])
                              for line in lines}
        self._events = self._writer.register_channel(S.EVENTS_TOPIC, "json", ids["event"])
        self._txns = self._writer.register_channel(S.TRANSACTIONS_TOPIC, "json", ids["txn"])
        self._log = self._writer.register_channel(S.LOG_TOPIC, "json", ids["log"])
        self._open_txn: dict[str, Any] | None = None
        self._offsets: dict[str, int] = {}
        self.messages = 0
        self.message_bytes = 0   # before compression
        self._closed = False
        if self._metadata:   # written first, so a killed recording still says what it is
            self._writer.add_metadata(S.METADATA_NAME, self._metadata)

    # ---------------------------------------------------------------- input
    def raw(self, chunk: Chunk, offset: int) -> None:
        """Record bytes read from a line (``offset`` of their first byte)."""
        if not chunk.data:
            return
        self._offsets[chunk.line] = offset + len(chunk.data)
        channel = self._raw_channels.get(chunk.line)
        if channel is None:
            channel = self._raw_channels[chunk.line] = self._writer.register_channel(
                S.RAW_TOPIC.format(line=chunk.line), "json", self._raw_schema)
        self._seq += 1
        ts = self._time_ns(chunk.t, self._seq)
        self._write(channel, ts, {"line": chunk.line, "offset": offset, "t": chunk.t, "data": chunk.data.hex()})

    def end_marker(self, t: float | None) -> None:
        """Record that time ran on to ``t`` with nothing more on the wire (an empty
        raw chunk), so decoding the recording expires the same timeouts live did."""
        if t is None:
            return
        line = next(iter(self._raw_channels))
        self._write(self._raw_channels[line], self._time_ns(t, 0),
                    {"line": line, "offset": self._offsets.get(line, 0), "t": t, "data": ""})

    def note(self, message: str, t: float | None, level: int = S.WARNING) -> None:
        """A tap's own message (a port lost and back, the skew estimate) on /log."""
        ts = self._time_ns(t, 0)
        self._write(self._log, ts, {"timestamp": {"sec": ts // 1_000_000_000, "nsec": ts % 1_000_000_000},
                                    "level": level, "message": message, "name": "gimbalscope tap",
                                    "file": "", "line": 0})

    def event(self, ev: Event) -> None:
        ts = self._time_ns(ev.t, ev.number)
        self._write(self._events, ts, ev.to_dict())
        if ev.problems:
            self._write(self._log, ts, self._log_message(ev, ts))
        self._transaction(ev, ts)

    def close(self, metadata: dict[str, str] | None = None) -> None:
        """Finish the file: summary, statistics, and ``metadata`` when the
        recording only knows it at the end (conversions). Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self._end_txn()
        if metadata:
            self._writer.add_metadata(S.METADATA_NAME, metadata)
        self._writer.finish()
        self._file.close()

    def __enter__(self) -> "McapRecorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------- internals
    def _time_ns(self, t: float | None, order: int) -> int:
        if t is None:
            return self.start_ns + order
        return self.start_ns + int(round(t * 1e9))

    def _write(self, channel: int, ts: int, obj: dict) -> None:
        data = dumps(obj)
        self._writer.add_message(channel, log_time=ts, data=data, publish_time=ts)
        self.messages += 1
        self.message_bytes += len(data)
        if self._flush_interval is not None and self._clock() - self._last_flush >= self._flush_interval:
            self.flush()

    def flush(self) -> None:
        """Close the chunk in progress and push it to disk (a killed tap keeps it)."""
        self._writer.flush()
        os.fsync(self._file.fileno())
        self._last_flush = self._clock()

    @staticmethod
    def _log_message(ev: Event, ts: int) -> dict:
        level = S.ERROR if ev.kind == NOISE or ev.checksum_ok is False or ev.status in ("nak", "no_ack") \
            else S.WARNING
        what = ev.command or ev.kind
        return {"timestamp": {"sec": ts // 1_000_000_000, "nsec": ts % 1_000_000_000}, "level": level,
                "message": f"#{ev.number} line {ev.line} {what}: " + "; ".join(ev.problems),
                "name": "gimbalscope", "file": f"line {ev.line}", "line": ev.offset}

    def _transaction(self, ev: Event, ts: int) -> None:
        """A command opens a transaction; its answers (which follow it in the
        stream) fill it; the next command or the end writes it."""
        if ev.kind == COMMAND:
            self._end_txn()
            g, p, d = ev.dst
            self._open_txn = {"ts": ts, "msg": {
                "txn": ev.txn, "number": ev.number, "t": ev.t, "command": ev.command, "device": f"{g}.{p}.{d}",
                "status": ev.status, "retransmission": ev.retransmission, "ack_latency": None,
                "result_latency": None, "answers": [], "fields": dict(ev.fields), "problems": list(ev.problems)}}
            return
        txn = self._open_txn
        if txn is None or ev.txn is None or ev.txn != txn["msg"]["txn"]:
            return
        msg = txn["msg"]
        msg["answers"].append(ev.number)
        if ev.kind in ("ack", "nak") and msg["ack_latency"] is None:
            msg["ack_latency"] = ev.latency
        elif ev.kind == "result":
            msg["result_latency"] = ev.latency
            msg["fields"].update(ev.fields)
        msg["problems"].extend(ev.problems)

    def _end_txn(self) -> None:
        if self._open_txn is not None:
            self._write(self._txns, self._open_txn["ts"], self._open_txn["msg"])
            self._open_txn = None


class RotatingRecorder:
    """Long unattended captures: a new numbered file (``name-0001.mcap``, …) when
    the current one holds ``max_bytes`` of messages (counted before compression:
    the writer keeps a chunk in memory until it flushes) or is ``max_seconds``
    old; each part is a whole MCAP with its own metadata (``part``)."""

    def __init__(self, path: str, *, max_bytes: int | None = None, max_seconds: float | None = None,
                 clock: Callable[[], float] = time.monotonic, **kw) -> None:
        self.base, ext = os.path.splitext(path)
        self.ext = ext or ".mcap"
        self.max_bytes, self.max_seconds, self.clock = max_bytes, max_seconds, clock
        self.kw = kw
        self.part = 0
        self.paths: list[str] = []
        self.messages = 0
        self._open()

    def _open(self) -> None:
        self.part += 1
        path = f"{self.base}-{self.part:04d}{self.ext}"
        kw = dict(self.kw)
        kw["metadata"] = {**kw.get("metadata", {}), "part": str(self.part)}
        self.current = McapRecorder(path, **kw)
        self.paths.append(path)
        self.opened = self.clock()

    def _maybe_rotate(self) -> None:
        cur = self.current
        too_big = self.max_bytes is not None and cur.message_bytes >= self.max_bytes
        too_old = self.max_seconds is not None and self.clock() - self.opened >= self.max_seconds
        if too_big or too_old:
            self.messages += cur.messages
            cur.close()
            self._open()

    def raw(self, chunk: Chunk, offset: int) -> None:
        self.current.raw(chunk, offset)
        self._maybe_rotate()

    def event(self, ev: Event) -> None:
        self.current.event(ev)

    def end_marker(self, t: float | None) -> None:
        self.current.end_marker(t)

    def note(self, message: str, t: float | None, level: int = S.WARNING) -> None:
        self.current.note(message, t, level)

    def close(self) -> None:
        self.messages += self.current.messages
        self.current.close()
