"""Events, transactions and findings as Arrow record batches of the dataset's
schemas (``parquet_schema.py``, docs/dataset.md).

The builders take rows one at a time and give a batch when asked, so a day-long
capture is written in pieces and memory stays flat. Each keeps a Python list
per column; the decoded fields, which most events lack, are kept sparsely (row,
value) and laid out only when a batch is made. ``ts`` and the partition date
are computed column-wise from ``t`` and the capture's start. A value of the
wrong type for its column (garbled input can decode to anything) becomes null:
bytes from the wire never raise.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from dissectors.event import Event, Origin
from dissectors.wire import payload_text

from . import parquet_schema as S
from .marks import Mark
from .store_ipc import nanoseconds

if TYPE_CHECKING:
    from ..analysis.transactions import OpenTransaction

_EPOCH = dt.date(1970, 1, 1)


def values_array(values: list, kind: pa.DataType) -> pa.Array:
    """``values`` as an array of ``kind``; values that do not fit become null."""
    try:
        return pa.array(values, kind)
    except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, ValueError, OverflowError):
        fixed = []
        for v in values:
            try:
                pa.array([v], kind)
            except (pa.ArrowInvalid, pa.ArrowTypeError, TypeError, ValueError, OverflowError):
                v = None
            fixed.append(v)
        return pa.array(fixed, kind)


def to_the_ns(t: pa.Array) -> pa.Array:
    """Times rounded to the nanosecond as the event contract rounds them
    (``store_ipc.nanoseconds``): what a recording's stored columns keep, so that
    a dataset is the same made from them or from decoding (docs/dataset.md)."""
    if t.null_count == len(t):
        return t
    values = t.to_numpy(zero_copy_only=False)   # nulls as NaN
    valid = ~np.isnan(values)
    out = values.copy()
    out[valid] = nanoseconds(values[valid]) / 1e9
    return pa.array(out, pa.float64(), mask=~valid)


def constant(value: str | None, n: int) -> pa.Array:
    """``n`` rows of one text (a capture's name, its site): repeated by Arrow,
    not converted from a list of ``n`` Python strings."""
    return pa.repeat(pa.scalar(value, pa.string()), n)


def timestamps(t: pa.Array, start_time: float | None) -> pa.Array:
    """Absolute times (UTC, microseconds) of wire times ``t`` (seconds since
    the capture's start); null without time or without a known start."""
    n = len(t)
    if start_time is None:
        return pa.nulls(n, S.TIME)
    us = pc.cast(pc.round(pc.multiply(t, 1e6)), pa.int64())
    return pc.cast(pc.add(us, round(start_time * 1e6)), S.TIME)


def dates(ts: pa.Array) -> pa.Array:
    """The UTC date of each timestamp (null stays null)."""
    return pc.cast(ts, pa.date32())


def day_of(start_time: float | None) -> str:
    """The UTC date of an epoch time, or the null partition."""
    if start_time is None:
        return S.UNDATED
    return dt.datetime.fromtimestamp(start_time, dt.UTC).date().isoformat()


def partitions(batch: pa.RecordBatch, ts_column: str, undated: str = S.UNDATED) -> Iterable[tuple[str, pa.RecordBatch]]:
    """``batch`` split by the UTC date of ``ts_column``: (``YYYY-MM-DD``, rows
    of that day); rows without time go to ``undated`` (an untimed capture's
    rows: the day it started, when known)."""
    days = dates(batch.column(ts_column))
    if days.null_count == len(days):
        yield undated, batch
        return
    if days.null_count == 0:
        first = days[0]
        if pc.all(pc.equal(days, first)).as_py():   # the usual case: one day
            yield first.as_py().isoformat(), batch
            return
    for day in pc.unique(days).to_pylist():
        mask = pc.is_null(days) if day is None else pc.fill_null(pc.equal(days, pa.scalar(day, pa.date32())), False)
        yield (undated if day is None else day.isoformat()), batch.filter(mask)


class _Fields:
    """Decoded values kept sparsely: field name -> [(row, value)]."""

    def __init__(self, columns: list[tuple[str, str, pa.DataType]]) -> None:
        self.columns = columns
        self.known = {name for name, _, _ in columns}
        self.values: dict[str, list[tuple[int, Any]]] = {}

    def add(self, row: int, fields: dict) -> None:
        values = self.values
        for name, value in fields.items():
            if value is not None:
                got = values.get(name)
                if got is None:
                    values[name] = [(row, value)]
                else:
                    got.append((row, value))

    def arrays(self, n: int) -> list[pa.Array]:
        out = []
        for name, _column, kind in self.columns:
            got = self.values.get(name)
            if not got:
                out.append(pa.nulls(n, kind))
                continue
            values: list = [None] * n
            for row, value in got:
                values[row] = value
            out.append(values_array(values, kind))
        self.values = {}
        return out


_PAYLOAD_TEXT: dict[bytes, str] = {}


class EventBatches:
    """Rows of the ``events`` table."""

    _NAMES = tuple(name for name, _ in S.EVENT_COLUMNS if name not in ("capture", "site", "ts"))

    def __init__(self, capture: str, site: str | None, start_time: float | None) -> None:
        self.capture = capture
        self.site = site
        self.start_time = start_time
        self.fields = _Fields(S.EVENT_FIELDS)
        self._reset()

    def _reset(self) -> None:
        self.cols: dict[str, list] = {name: [] for name in self._NAMES}
        # the lists' append methods in _NAMES order: one unpacking per row, no lookups
        self._appends = tuple(self.cols[name].append for name in self._NAMES)
        self.n = 0

    def __len__(self) -> int:
        return self.n

    def add(self, ev: Event) -> None:
        (number, t, t_end, line, offset, kind, command, device, dst, src, payload_, checksum_ok, problems,
         txn, status, latency, retransmission, request, raw) = self._appends
        number(ev.number)
        t(ev.t)
        t_end(ev.t_end)
        line(ev.line)
        offset(ev.offset)
        kind(ev.kind)
        command(ev.command)
        device(ev.device)
        dst(ev.dst)
        src(ev.src)
        payload = ev.payload
        text = None
        if payload is not None:
            payload = bytes(payload)
            text = _PAYLOAD_TEXT.get(payload)
            if text is None:
                if len(_PAYLOAD_TEXT) > 8192:
                    _PAYLOAD_TEXT.clear()
                text = _PAYLOAD_TEXT[payload] = payload_text(payload)
        payload_(text)
        checksum_ok(ev.checksum_ok)
        problems(ev.problems)
        txn(ev.txn)
        status(ev.status)
        latency(ev.latency)
        retransmission(ev.retransmission)
        request(ev.request)
        raw(bytes(ev.raw))
        if ev.fields:
            self.fields.add(self.n, ev.fields)
        self.n += 1

    def batch(self) -> pa.RecordBatch:
        """The rows added since the last batch."""
        n, c = self.n, self.cols
        arrays = {name: values_array(c[name], kind) for name, kind in S.EVENT_COLUMNS if name in c}
        arrays["t"], arrays["t_end"] = to_the_ns(arrays["t"]), to_the_ns(arrays["t_end"])
        arrays["capture"] = constant(self.capture, n)
        arrays["site"] = constant(self.site, n)
        arrays["ts"] = timestamps(arrays["t"], self.start_time)
        columns = [arrays[name] for name, _ in S.EVENT_COLUMNS] + self.fields.arrays(n)
        self._reset()
        return pa.RecordBatch.from_arrays(columns, schema=S.EVENTS)


class TransactionBatches:
    """Rows of the ``transactions`` table, from ``analyzer.analysis.transactions.OpenTransaction``."""

    _NAMES = tuple(name for name, _ in S.TRANSACTION_COLUMNS if name not in ("capture", "site", "ts"))

    def __init__(self, capture: str, site: str | None, start_time: float | None) -> None:
        self.capture = capture
        self.site = site
        self.start_time = start_time
        self.fields = _Fields(S.TRANSACTION_FIELDS)
        self._reset()

    def _reset(self) -> None:
        self.cols: dict[str, list] = {name: [] for name in self._NAMES}
        self.n = 0

    def __len__(self) -> int:
        return self.n

    def add(self, txn: OpenTransaction) -> None:
        row = txn.to_dict()
        ack, nic, result = txn.answer_numbers()
        c = self.cols
        c["txn"].append(row["txn"])
        c["number"].append(row["number"])
        c["t"].append(txn.command.t)
        c["device"].append(row["device"])
        c["command"].append(row.get("command"))
        c["status"].append(row.get("status"))
        c["retransmission"].append(row["retransmission"])
        c["ack_latency"].append(row.get("ack_latency"))
        c["result_latency"].append(row.get("result_latency"))
        c["ack"].append(ack)
        c["nic"].append(nic)
        c["result"].append(result)
        c["problems"].append(row["problems"])
        if row["fields"]:
            self.fields.add(self.n, row["fields"])
        self.n += 1

    def batch(self) -> pa.RecordBatch:
        n, c = self.n, self.cols
        arrays = {name: values_array(c[name], kind) for name, kind in S.TRANSACTION_COLUMNS if name in c}
        arrays["t"] = to_the_ns(arrays["t"])
        arrays["capture"] = constant(self.capture, n)
        arrays["site"] = constant(self.site, n)
        arrays["ts"] = timestamps(arrays["t"], self.start_time)
        columns = [arrays[name] for name, _ in S.TRANSACTION_COLUMNS] + self.fields.arrays(n)
        self._reset()
        return pa.RecordBatch.from_arrays(columns, schema=S.TRANSACTIONS)


def findings_batch(findings: list, capture: str, site: str | None, start_time: float | None,
                   first_t: float | None, last_t: float | None) -> pa.RecordBatch:
    """The ``findings`` rows of one capture (``analyzer.analysis.doctor.Finding``), each
    with the capture's span."""
    n = len(findings)

    def at(t: float | None) -> pa.Array:
        return timestamps(pa.array([t] * n, pa.float64()), start_time)

    first_seen = pa.array([f.first_seen for f in findings], pa.float64())
    arrays = {
        "capture": constant(capture, n),
        "site": constant(site, n),
        "start": at(first_t),
        "end": at(last_t),
        "code": pa.array([f.code for f in findings], pa.string()),
        "severity": pa.array([f.severity for f in findings], pa.string()),
        "subject": pa.array([f.subject for f in findings], pa.string()),
        "title": pa.array([f.title for f in findings], pa.string()),
        "detail": pa.array([f.detail for f in findings], pa.string()),
        "fix": pa.array([f.fix for f in findings], pa.string()),
        "evidence": pa.array([list(f.evidence) for f in findings], pa.list_(pa.int64())),
        "first_seen": first_seen,
        "first_seen_ts": timestamps(first_seen, start_time),
        "first_seen_event": pa.array([f.first_seen_event for f in findings], pa.int64()),
    }
    return pa.RecordBatch.from_arrays([arrays[name] for name, _ in S.FINDING_COLUMNS], schema=S.FINDINGS)


def marks_batch(marks: Sequence[Mark], capture: str, site: str | None, start_time: float | None) -> pa.RecordBatch:
    """The ``marks`` rows of one capture (analyzer/formats/marks.py)."""
    n = len(marks)
    t = pa.array([m.t for m in marks], pa.float64())
    arrays = {
        "capture": constant(capture, n),
        "site": constant(site, n),
        "number": pa.array([m.number for m in marks], pa.int64()),
        "t": t,
        "ts": timestamps(t, start_time),
        "note": pa.array([m.note for m in marks], pa.string()),
    }
    return pa.RecordBatch.from_arrays([arrays[name] for name, _ in S.MARK_COLUMNS], schema=S.MARKS)


class EventSource(Protocol):
    """What ``events_table`` reads: a capture (``analyzer.capture.Capture``)."""

    @property
    def origin(self) -> Origin: ...

    def batches(self) -> Iterator[list[Event]]: ...


def events_table(capture: EventSource, keep: Callable[[Event], bool] | None = None,
                 batch_rows: int = 65536) -> pa.Table:
    """Every event of ``capture`` (those ``keep`` accepts) as one Table (the API's
    ``Capture.to_arrow``)."""
    origin = capture.origin
    rows = None
    batches = []
    for events in capture.batches():
        if rows is None:
            rows = EventBatches(origin.source, None, origin.start_time)
        for ev in events:
            if keep is None or keep(ev):
                rows.add(ev)
        if len(rows) >= batch_rows:
            batches.append(rows.batch())
    if rows is not None and len(rows):
        batches.append(rows.batch())
    return pa.Table.from_batches(batches, schema=S.EVENTS)
