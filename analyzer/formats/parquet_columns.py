"""The dataset's ``events`` and ``transactions`` rows (``parquet_schema.py``)
made from a recording's stored columns (``store_ipc.py``) rather than from
events: column by column, with no event object made (docs/dataset.md,
"Exporting a recording").

Every value is the one ``parquet_rows`` writes for the same event:

- a frame's ``dst``, ``src`` and ``payload`` are cut from its raw bytes (Table 1);
- a command's and a result's decoded fields are those re-dissecting its payload
  gives (``store.natural_fields``), worked out once per distinct payload of a
  command (a day of polling repeats a few payloads many times), except the
  positions, which the columns carry: a go-to command's (``P``) and a position
  answer's (``P?``) fields are exactly its ``azimuth_deg`` and ``elevation_deg``
  (Table 11, Table 15; NaN: the payload did not decode, and it is dissected);
- a transaction is a command with the answers pairing linked to it (their
  ``request``) before the next command, as ``analysis/transactions.py`` closes it:
  a command's transaction stays open across batches until the next one comes.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from dissectors.commands import COMMANDS, Command
from dissectors.event import ACK, COMMAND, NAK, NIC, RESULT
from dissectors.wire import payload_text

from . import parquet_schema as S
from .parquet_rows import constant, timestamps, values_array
from .store import (
    CHECKSUM_BAD,
    CHECKSUM_OK,
    FRAMED,
    KIND_CODE,
    KINDS,
    RETRANSMISSION,
    STATUSES,
    UNTIMED,
    StoreChunk,
    natural_fields,
)
from .store_ipc import raw_offsets

_POSITION_COMMANDS = ("P", "P?")   # whose fields the position columns hold (store_ipc.py)
_MEMO_MAX = 65_536                  # distinct payloads' fields kept between batches
_CMD, _RES = KIND_CODE[COMMAND], KIND_CODE[RESULT]
_ACKS = np.array([KIND_CODE[ACK], KIND_CODE[NAK]])
_NIC = KIND_CODE[NIC]
_FIELD_TYPES = {name: kind for name, _column, kind in S.EVENT_FIELDS}


@dataclass
class Tables:
    """What the codes of the joined columns stand for (``store_ipc.Joiner.known``), code 0 first."""
    lines: pa.Array
    devices: pa.Array
    commands: pa.Array                  # command ids
    entries: list[Command | None]       # their table entries


class TablesSoFar:
    """A joiner's tables (``Joiner.known``) as ``Tables``, chunk by chunk: only the
    values a chunk adds are made (a joiner's codes are only ever added to, and a
    noisy line names new garbled commands in most chunks)."""

    def __init__(self) -> None:
        self.tables = Tables(_strings([None]), _strings([None]), _strings([None]), [None])

    def of(self, known: tuple[list[Any], list[Any], list[Any]]) -> Tables:
        t = self.tables
        lines, devices, commands = (values[len(array) - 1:] for values, array
                                    in zip(known, (t.lines, t.devices, t.commands), strict=True))
        if lines or devices or commands:
            self.tables = Tables(_grown(t.lines, lines), _grown(t.devices, devices),
                                 _grown(t.commands, [c[0] for c in commands]),
                                 t.entries + [_entry(c) for c in commands])
        return self.tables


def _entry(command: Any) -> Command | None:
    """A joined command's table entry (its place in ``COMMANDS``; None: an id the table lacks)."""
    return COMMANDS[command[1]] if isinstance(command[1], int) else None


def _strings(values: list[str | None]) -> pa.Array:
    return pa.array(values, pa.string())


def _grown(array: pa.Array, more: list[str | None]) -> pa.Array:
    return pa.concat_arrays([array, _strings(more)]) if more else array


@dataclass
class _Fields:
    """A batch's decoded fields: per field name present, its column and which
    rows have a value for it at all (a value of the wrong type is null in the
    column but still there: a result's such value covers its command's)."""
    columns: dict[str, pa.Array]
    present: dict[str, np.ndarray]


def _column(store_column: Any) -> np.ndarray:
    return np.frombuffer(store_column, dtype=np.dtype(store_column.typecode)) if len(store_column) else \
        np.zeros(0, np.dtype(store_column.typecode))


def _masked(values: np.ndarray, valid: np.ndarray, kind: pa.DataType) -> pa.Array:
    return pa.array(values, kind, mask=~valid)


def _binary(data: bytes, offsets: np.ndarray, valid: np.ndarray | None = None) -> pa.Array:
    """A binary array of ``data`` cut at ``offsets`` (n + 1), null where not ``valid``."""
    n = len(offsets) - 1
    bitmap = None if valid is None or valid.all() else pa.py_buffer(np.packbits(valid, bitorder="little"))
    return pa.Array.from_buffers(pa.binary(), n, [bitmap, pa.py_buffer(offsets.astype("i4")), pa.py_buffer(data)])


def _gather(raw: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> tuple[bytes, np.ndarray]:
    """The byte ranges ``raw[starts[i]:starts[i] + lengths[i]]`` laid end to end, and their offsets."""
    offsets = np.zeros(len(lengths) + 1, "i8")
    np.cumsum(lengths, out=offsets[1:])
    total = int(offsets[-1])
    index = np.repeat(starts - offsets[:-1], lengths) + np.arange(total)
    return raw[index].tobytes(), offsets


class StoredRows:
    """Rows of the ``events`` and ``transactions`` tables from stored chunks in
    order (``add``), and the transaction still open at the end (``finish``)."""

    def __init__(self, capture: str, site: str | None, start_time: float | None) -> None:
        self.capture = capture
        self.site = site
        self.start_time = start_time
        # (kind code, command code, payload) -> its fields: the joiner's codes stay one capture's
        self._memo: dict[tuple[int, int, bytes], dict[str, Any]] = {}
        self._open: pa.Table | None = None   # the open transaction's rows: its command and what came after

    # ------------------------------------------------------------------ events
    def add(self, chunk: StoreChunk, tables: Tables, positions: tuple[np.ndarray, np.ndarray]
            ) -> tuple[pa.RecordBatch, pa.RecordBatch | None]:
        """The chunk's ``events`` rows (``positions``: the azimuth and elevation
        columns its message carried), and the ``transactions`` rows of the
        commands it closes (None: none)."""
        events, window = self._events(chunk, tables, positions)
        if self._open is not None:   # the open transaction's rows first; fields either lacks are null
            window = pa.concat_tables([self._open, window], promote_options="default")
        transactions, self._open = transaction_rows(window, False, self.capture, self.site, self.start_time)
        return events, transactions

    def finish(self) -> pa.RecordBatch | None:
        """The transaction still open (the last command's), once every chunk is in."""
        window, self._open = self._open, None
        if window is None:
            return None
        return transaction_rows(window, True, self.capture, self.site, self.start_time)[0]

    def _events(self, chunk: StoreChunk, tables: Tables, positions: tuple[np.ndarray, np.ndarray]
                ) -> tuple[pa.RecordBatch, pa.Table]:
        cols = chunk.columns
        n = len(cols["kind"])
        start = chunk.start
        kind = _column(cols["kind"])
        flags = _column(cols["flags"])
        offsets = raw_offsets(chunk)
        starts, stops = offsets[:-1], offsets[1:]
        raw = np.frombuffer(chunk.raw, "u1")
        timed = (flags & UNTIMED) == 0
        framed = (flags & FRAMED) != 0
        t = pa.array(np.asarray(cols["t"], "f8"), pa.float64(), mask=~timed)
        t_end = pa.array(np.asarray(cols["t_end"], "f8"), pa.float64(), mask=~timed)
        # a frame: start, address (3), source, length, payload, checksum (Table 1)
        fs = starts[framed]
        dst_values = np.stack([raw[fs + 1], raw[fs + 2], raw[fs + 3]], axis=1).reshape(-1).astype("i8")
        dst_offsets = np.zeros(n + 1, "i4")
        np.cumsum(np.where(framed, 3, 0), out=dst_offsets[1:])
        dst = pa.ListArray.from_arrays(pa.array(dst_offsets), pa.array(dst_values, pa.int64()),
                                       mask=pa.array(~framed))
        src = np.zeros(n, "i8")
        src[framed] = raw[fs + 4]
        lengths = np.where(framed, stops - starts - 7, 0)
        payload_data, payload_offsets = _gather(raw, starts + 6, lengths)
        payloads = _binary(payload_data, payload_offsets, framed)
        checksum = (flags & (CHECKSUM_OK | CHECKSUM_BAD)) != 0
        txn = _column(cols["txn"]).astype("i8")
        request = _column(cols["request"]).astype("i8")
        command = _column(cols["command"]).astype("i8")
        status = _column(cols["status"])
        latency = np.asarray(cols["latency"], "f8")
        numbers = np.arange(start + 1, start + n + 1, dtype="i8")
        fields = self._fields(chunk, tables, kind, framed, command, starts, stops, positions)
        arrays: dict[str, pa.Array] = {
            "capture": constant(self.capture, n),
            "site": constant(self.site, n),
            "number": pa.array(numbers),
            "ts": timestamps(t, self.start_time),
            "t": t,
            "t_end": t_end,
            "line": tables.lines.take(pa.array(_column(cols["line"]))),
            "offset": pa.array(_column(cols["offset"]).astype("i8")),
            "kind": pa.array(KINDS, pa.string()).take(pa.array(kind)),
            "command": tables.commands.take(pa.array(command)),
            "device": tables.devices.take(pa.array(_column(cols["device"]))),
            "dst": dst,
            "src": _masked(src, framed, pa.int64()),
            "payload": self._texts(payloads, payload_data, payload_offsets),
            "checksum_ok": _masked((flags & CHECKSUM_OK) != 0, checksum, pa.bool_()),
            "problems": self._problems(chunk.problems, start, n),
            "txn": _masked(txn - 1, txn != 0, pa.int64()),
            "status": pa.array(STATUSES, pa.string()).take(pa.array(status)),
            "latency": pa.array(latency, pa.float64(), from_pandas=True),
            "retransmission": pa.array((flags & RETRANSMISSION) != 0),
            "request": _masked(request, request != 0, pa.int64()),
            "raw": _binary(chunk.raw, offsets),
        }
        nulls = {arrow_type: pa.nulls(n, arrow_type) for _n, _c, arrow_type in S.EVENT_FIELDS}
        columns = [arrays[name] for name, _ in S.EVENT_COLUMNS]
        columns += [fields.columns.get(name, nulls[arrow_type]) for name, _c, arrow_type in S.EVENT_FIELDS]
        batch = pa.RecordBatch.from_arrays(columns, schema=S.EVENTS)
        # what the transactions are made of: the batch's own columns, and which rows have each field
        window = pa.table({"number": arrays["number"], "kind": pa.array(kind), "request": pa.array(request),
                           "t": t, "txn": arrays["txn"], "device": arrays["device"], "command": arrays["command"],
                           "status": arrays["status"], "retransmission": arrays["retransmission"],
                           "latency": arrays["latency"], "problems": arrays["problems"],
                           **{f"f:{name}": column for name, column in fields.columns.items()},
                           **{f"p:{name}": pa.array(mask) for name, mask in fields.present.items()}})
        return batch, window

    def _texts(self, payloads: pa.Array, data: bytes, offsets: np.ndarray) -> pa.Array:
        """The payloads as ``payload_text`` writes them: printable ASCII as it is
        (every payload of a clean line: a cast), the others escaped one by one."""
        raw = np.frombuffer(data, "u1")
        bad = (raw < 0x20) | (raw > 0x7E) | (raw == 0x5C)   # not printable ASCII, or a backslash
        counts = np.concatenate(([0], np.cumsum(bad)))
        rows = np.flatnonzero(counts[offsets[1:]] - counts[offsets[:-1]])
        text = payloads.cast(pa.binary()).view(pa.string()) if not len(rows) else None
        if text is not None:
            return text
        escaped = [payload_text(data[offsets[i]:offsets[i + 1]]) for i in rows.tolist()]
        plain = _binary(data, offsets, ~np.isin(np.arange(len(offsets) - 1), rows) & payloads.is_valid()
                        .to_numpy(zero_copy_only=False)).view(pa.string())
        mask = np.zeros(len(offsets) - 1, bool)
        mask[rows] = True
        return pc.replace_with_mask(plain, pa.array(mask), pa.array(escaped, pa.string()))

    @staticmethod
    def _problems(problems: dict[int, Any], start: int, n: int) -> pa.Array:
        counts = np.zeros(n, "i4")
        texts: list[str] = []
        for i in sorted(problems):
            ps = problems[i]
            counts[i - start] = len(ps)
            texts.extend(str(p) for p in ps)
        offsets = np.zeros(n + 1, "i4")
        np.cumsum(counts, out=offsets[1:])
        return pa.ListArray.from_arrays(pa.array(offsets), pa.array(texts, pa.string()))

    # ------------------------------------------------------------------ fields
    def _fields(self, chunk: StoreChunk, tables: Tables, kind: np.ndarray, framed: np.ndarray,
                command: np.ndarray, starts: np.ndarray, stops: np.ndarray,
                positions: tuple[np.ndarray, np.ndarray]) -> _Fields:
        """Each row's decoded fields, as one set of field values per distinct
        payload of a command: ``unique`` holds the sets, ``of_row`` each row's (-1: none)."""
        n = len(kind)
        unique: list[dict[str, Any]] = []
        of_row = np.full(n, -1, "i8")
        dissected = framed & ((kind == _CMD) | (kind == _RES))
        memo = self._memo
        if len(memo) > _MEMO_MAX:
            memo.clear()
        azimuth, elevation = positions
        # a position command's or answer's fields: the position columns (NaN: not decoded, dissected below)
        ids = tables.commands.to_pylist()
        placed = dissected & ~np.isnan(azimuth) & np.isin(command, [c for c, i in enumerate(ids)
                                                                   if i in _POSITION_COMMANDS])
        rows = np.flatnonzero(dissected & ~placed)
        raw, entries = chunk.raw, tables.entries
        # the distinct payloads (with what each is dissected as) found with numpy, and
        # dissected once each: most repeat, a row by row loop of look-ups was most of this
        first, of_distinct = _distinct(kind[rows], command[rows], np.frombuffer(raw, "u1"), starts[rows] + 6,
                                       stops[rows] - 1)
        first = rows[first]
        for k, code, a, b in zip(kind[first].tolist(), command[first].tolist(), (starts[first] + 6).tolist(),
                                 (stops[first] - 1).tolist(), strict=True):
            key = (k, code, raw[a:b])
            values = memo.get(key)
            if values is None:
                values = memo[key] = natural_fields(KINDS[k], key[2], entries[code])
            unique.append(values)
        of_row[rows] = of_distinct
        for i, values in chunk.fields.items():   # kept: a rate change's, an event's with no payload to dissect
            of_row[i - chunk.start] = len(unique)
            unique.append(values)
        fields = _laid_out(unique, of_row)
        if placed.any():
            for name, degrees in (("azimuth_deg", azimuth), ("elevation_deg", elevation)):
                there = placed & ~np.isnan(degrees)
                column = pa.array(degrees, pa.float64(), mask=~there)
                if name in fields.columns:
                    column = pc.if_else(pa.array(placed), column, fields.columns[name])
                fields.columns[name] = column
                fields.present[name] = fields.present.get(name, np.zeros(n, bool)) | there
        return fields


def _distinct(kind: np.ndarray, command: np.ndarray, raw: np.ndarray, starts: np.ndarray,
              stops: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows that differ in kind, command code or payload (``raw[starts:stops]``):
    the first row of each distinct one, and each row's place among them (in the
    order they first come)."""
    n = len(kind)
    if not n:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    # a row's key: kind (1 byte) and command code (4: the store widens its codes as
    # needed), then the payload; the keys found by Arrow's hash table, which codes
    # them in the order they first come (sorting them, or a look-up a row, cost ten times more)
    head = 5
    lengths = stops - starts
    offsets = np.zeros(n + 1, "i8")
    np.cumsum(lengths + head, out=offsets[1:])
    keys = np.empty(int(offsets[-1]), "u1")
    at = offsets[:-1]
    keys[at] = kind
    keys[(at[:, None] + np.arange(1, head)).ravel()] = command.astype("<u4").view("u1")
    within = np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)   # a byte's place in its payload
    keys[np.repeat(at + head, lengths) + within] = raw[np.repeat(starts, lengths) + within]
    place = pc.dictionary_encode(_binary(keys.tobytes(), offsets)).indices.to_numpy().astype(np.intp)
    seen = np.maximum.accumulate(place)
    first = np.flatnonzero(np.concatenate(([True], seen[1:] > seen[:-1])))   # where a new code comes
    return first, place


def _laid_out(unique: list[dict[str, Any]], of_row: np.ndarray) -> _Fields:
    """Per field name present, its column over the rows (``of_row``: each row's set in ``unique``)."""
    count = len(unique)
    # the sets grouped by their names (every payload of one command gives the same
    # ones): a field's values are then gathered a group at a time, not a value at a time
    groups: dict[tuple[str, ...], list[int]] = {}
    for u, fields in enumerate(unique):
        groups.setdefault(tuple(fields), []).append(u)
    names = list(dict.fromkeys(name for keys in groups for name in keys if name in _FIELD_TYPES))
    # the sets in group order, and the set of none last: a row's place among them
    order = [u for us in groups.values() for u in us]
    place = np.empty(count + 1, np.intp)
    place[order] = np.arange(count)
    place[count] = count
    rows = place[np.where(of_row >= 0, of_row, count)]
    children = []
    present: dict[str, np.ndarray] = {}
    for name in names:
        values: list[Any] = []
        there: list[np.ndarray] = []
        for keys, us in groups.items():
            if name in keys:
                these = [unique[u][name] for u in us]
                values += these
                # a value of None is no value (one of the wrong type is: it is null, but there)
                there.append(np.array([v is not None for v in these]) if None in these else np.ones(len(us), bool))
            else:
                values += [None] * len(us)
                there.append(np.zeros(len(us), bool))
        values.append(None)
        there.append(np.zeros(1, bool))
        children.append(values_array(values, _FIELD_TYPES[name]))
        present[name] = np.concatenate(there)[rows]
    kept = [i for i, name in enumerate(names) if present[name].any()]   # a name only ever None is not there
    names = [names[i] for i in kept]
    return _Fields(_taken_together([children[i] for i in kept], names, rows), {name: present[name] for name in names})


def _taken_together(arrays: list[pa.Array], names: list[str], rows: np.ndarray) -> dict[str, pa.Array]:
    """Each of ``arrays`` (by its name) taken at ``rows``, in one take of them all
    as one struct: a take an array was most of the cost of making the fields."""
    if not names:
        return {}
    taken = pa.StructArray.from_arrays(arrays, names=names).take(pa.array(rows))
    return {name: taken.field(i) for i, name in enumerate(names)}


def _last_per(group: np.ndarray, rows: np.ndarray, size: int) -> np.ndarray:
    """For each group 0..size-1, the largest row of ``rows`` in it (-1: none)."""
    out = np.full(size, -1, "i8")
    np.maximum.at(out, group, rows)
    return out


def transaction_rows(window: pa.Table, final: bool, capture: str, site: str | None,
                     start_time: float | None) -> tuple[pa.RecordBatch | None, pa.Table | None]:
    """The transactions of ``window``'s commands that it closes (all of them when
    ``final``), and the rows to carry: from its last command on, still open."""
    kind = window.column("kind").to_numpy()
    commands = np.flatnonzero(kind == _CMD)
    if not len(commands):
        return None, None   # no command: nothing opens, nothing before it belongs anywhere
    closed = commands if final else commands[:-1]
    carry = None if final else window.slice(int(commands[-1]))
    if not len(closed):
        return None, carry
    m = window.num_rows
    number = window.column("number").to_numpy()
    request = window.column("request").to_numpy()
    # each answer's command (pairing linked it: its request), if that command's
    # transaction is still open when it comes: before the next command
    answers = np.flatnonzero(request > 0)
    k = np.searchsorted(number[commands], request[answers])
    k = np.minimum(k, len(commands) - 1)
    next_command = np.append(commands[1:], m)
    linked = (number[commands][k] == request[answers]) & (answers < next_command[k])
    answers, k = answers[linked], k[linked]
    keep = k < len(closed)
    answers, k = answers[keep], k[keep]
    size = len(closed)
    akind = kind[answers]
    ack = _last_per(k[np.isin(akind, _ACKS)], answers[np.isin(akind, _ACKS)], size)
    nic = _last_per(k[akind == _NIC], answers[akind == _NIC], size)
    result = _last_per(k[akind == _RES], answers[akind == _RES], size)

    # the window's columns whole (the open transaction's rows and the batch's are
    # two chunks): every take below is then of one array
    window = window.combine_chunks()

    def rows_of(names: list[str], rows: np.ndarray) -> pa.Table:   # -1: a null row
        return window.select(names).take(pa.array(rows, pa.int64(), mask=rows < 0))

    present = set(window.column_names)
    cmd = rows_of(["txn", "number", "t", "device", "command", "status", "retransmission"], closed)
    res = rows_of(["number", "latency"], result)
    acks = rows_of(["number", "latency"], ack)
    t = cmd.column("t")
    arrays: dict[str, Any] = {
        "capture": constant(capture, size),
        "site": constant(site, size),
        "ts": timestamps(t.chunk(0) if t.num_chunks == 1 else t.combine_chunks(), start_time),
        "t": t,
        "ack_latency": acks.column("latency"),
        "result_latency": res.column("latency"),
        "ack": acks.column("number"),
        "nic": rows_of(["number"], nic).column("number"),
        "result": res.column("number"),
        "problems": _transaction_problems(window, closed, answers, k),
    }
    columns = [arrays[name] if name in arrays else cmd.column(name) for name, _ in S.TRANSACTION_COLUMNS]
    # a field's value: the command's, or its result's where the result has one
    # (to_dict's update); the fields that take the same rows are taken together
    has_result = result >= 0
    of_result = np.maximum(result, 0)
    groups: dict[bytes, tuple[np.ndarray, list[str]]] = {}   # the rows' bytes -> (rows, field names)
    for name, _column_name, _kind_type in S.TRANSACTION_FIELDS:
        if f"f:{name}" in present:
            there = window.column(f"p:{name}").chunk(0).fill_null(False).to_numpy(zero_copy_only=False)
            rows = np.where(has_result & there[of_result], result, closed)
            groups.setdefault(rows.tobytes(), (rows, []))[1].append(name)
    taken: dict[str, pa.Array] = {}
    for rows, names in groups.values():
        taken.update(_taken_together([window.column(f"f:{n}").chunk(0) for n in names], names, rows))
    columns += [taken[name] if name in taken else pa.nulls(size, kind_type) for name, _c, kind_type in S.TRANSACTION_FIELDS]
    columns = [c.chunk(0) if isinstance(c, pa.ChunkedArray) and c.num_chunks == 1
               else c.combine_chunks() if isinstance(c, pa.ChunkedArray) else c for c in columns]
    return pa.RecordBatch.from_arrays(columns, schema=S.TRANSACTIONS), carry


def _transaction_problems(window: pa.Table, closed: np.ndarray, answers: np.ndarray, k: np.ndarray) -> pa.Array:
    """A transaction's problems: its command's, then its answers' in wire order."""
    problems = window.column("problems").combine_chunks()
    counts = pc.list_value_length(problems).to_numpy(zero_copy_only=False)
    size = len(closed)
    rows = np.concatenate((closed, answers))
    owner = np.concatenate((np.arange(size), k))
    order = np.lexsort((rows, owner))    # by transaction, then wire order (the command first)
    rows, owner = rows[order], owner[order]
    offsets = np.zeros(size + 1, "i4")
    np.cumsum(np.bincount(owner, weights=counts[rows], minlength=size).astype("i4"), out=offsets[1:])
    return pa.ListArray.from_arrays(pa.array(offsets), problems.take(pa.array(rows)).flatten())


def stored_batches(rows: StoredRows, chunks: Iterator[tuple[StoreChunk, Tables, tuple[np.ndarray, np.ndarray]]]
                   ) -> Iterator[tuple[str, pa.RecordBatch]]:
    """(table, rows) of every chunk in turn, the last open transaction at the end."""
    for chunk, tables, positions in chunks:
        events, transactions = rows.add(chunk, tables, positions)
        yield "events", events
        if transactions is not None:
            yield "transactions", transactions
    last = rows.finish()
    if last is not None:
        yield "transactions", last
