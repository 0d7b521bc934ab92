"""The event store's columns as Arrow IPC: what a recording carries beside its
raw bytes so that opening it needs no decoding (docs/mcap.md, "Stored columns").

One message is one Arrow IPC stream holding one record batch: the events one
store handed on (``EventStore.take``, a ``StoreChunk``), a column each, and in
the schema's metadata the tables their codes index (lines, devices, commands),
whole in every message so that each reads on its own. The columns are those of
the store with three changes that make them small and plain to other readers:
times are integer nanoseconds (``t_ns``, and ``duration_ns`` to the event's end:
the event contract keeps times to the nanosecond, so nothing a reader shows is
lost), the raw bytes are a binary column (their ends follow from it), and the
rows of events with problems or kept fields carry them as JSON text.

Written and read with nanoarrow, Apache Arrow's small C library (no pyarrow in
the base install); pyarrow, DuckDB and Polars read the same bytes.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import io
import os
from array import array
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import nanoarrow as na
import nanoarrow.ipc as na_ipc
import numpy as np
import orjson

from dissectors.commands import BAUD_CODES, COMMANDS
from dissectors.event import COMMAND, FRAME, RATE
from dissectors.problems import Problem, by_name, parse

from ..version import __version__
from .store import CHECKSUM_OK, ERROR, FRAMED, KIND_CODE, KINDS, STATUSES, UNTIMED, StoreChunk

VERSION = "1"          # the layout below; a reader that does not know it decodes the raw bytes
MEDIA_TYPE = "application/vnd.apache.arrow.stream"
MIN_FRAME = 7          # start, address (3), source, length, checksum: a frame's bytes at the least (Table 1)

# (name, Arrow type, numpy dtype) in the record batch's order
_COLUMNS: tuple[tuple[str, Any, str], ...] = (
    ("number", na.int64(), "i8"),         # the event's number
    ("t_ns", na.int64(), "i8"),           # its time, ns of capture time (0 when untimed: flags & 1)
    ("duration_ns", na.int64(), "i8"),    # t_end - t, ns
    ("offset", na.int64(), "i8"),         # of its first byte on its line
    ("kind", na.uint8(), "u1"),           # index into ``kinds``
    ("line", na.uint8(), "u1"),           # index into ``lines`` (0: none)
    ("status", na.uint8(), "u1"),         # index into ``statuses`` (0: none)
    ("flags", na.uint8(), "u1"),          # the store's flag bits (analyzer/formats/store.py)
    ("command", na.uint32(), "u4"),       # index into ``commands`` (0: none)
    ("device", na.uint32(), "u4"),        # index into ``devices`` (0: none)
    ("latency", na.float64(), "f8"),      # seconds; NaN: none
    ("request", na.int64(), "i8"),        # the command's event number, for an answer (0: none)
    ("txn", na.int64(), "i8"),            # the transaction's number + 1 (0: none)
)
_NUMERIC = tuple(name for name, _type, _dtype in _COLUMNS)
_SCHEMA_FIELDS = {name: arrow_type for name, arrow_type, _dtype in _COLUMNS} | {
    "raw": na.binary(),                   # the event's bytes, as on the wire
    "problems": na.string(),              # JSON [[problem id, text], ...]; "" without problems
    "fields": na.string(),                # JSON object of fields re-dissection does not give; ""
    # the position a go-to command (P) sent or a position answer (P?) gave, NaN for
    # every other event: the TUI's position plots, without decoding a payload
    "azimuth_deg": na.float64(),
    "elevation_deg": na.float64(),
}
# store columns the recorded ones are converted to (the store widens H/I as it needs)
_STORE_TYPES = {"offset": "I", "kind": "B", "line": "B", "status": "B", "flags": "B", "command": "I",
                "device": "I", "latency": "d", "request": "i", "txn": "i"}


class ColumnsError(ValueError):
    """A message that is not stored columns this reader knows."""


@dataclass
class Tables:
    """What the codes of a recording's columns stand for, as its latest message
    says (each message carries the whole tables)."""
    lines: list[str | None]
    devices: list[str | None]
    commands: list[list[Any] | None]   # [command id, place in COMMANDS (None: no entry, an unknown id)]


def nanoseconds(seconds: np.ndarray) -> np.ndarray:
    """Seconds as integer nanoseconds, rounded as the event contract rounds them
    (Python's ``round(t, 9)``, correctly rounded). ``t * 1e9`` is off by far less
    than a nanosecond's thousandth for any capture time, so rounding it gives the
    same but where it falls that near a half: those few are rounded as Python does."""
    scaled = seconds * 1e9
    ns = np.rint(scaled)
    near = np.flatnonzero(np.abs(scaled - np.floor(scaled) - 0.5) < 1e-3)
    for i in near.tolist():
        ns[i] = round(round(float(seconds[i]), 9) * 1e9)
    return ns.astype("i8")


def raw_offsets(chunk: StoreChunk) -> np.ndarray:
    """Where each of the chunk's events starts in ``chunk.raw``, and where the last
    one ends (n + 1 offsets): its ``end`` column counts from the capture's first raw byte."""
    column = chunk.columns["end"]
    ends = np.frombuffer(column, dtype=np.dtype(column.typecode)).astype("i8") if len(column) else np.zeros(0, "i8")
    first = int(ends[-1]) - len(chunk.raw) if len(ends) else 0   # the raw bytes before the chunk's
    return np.concatenate(([0], ends - first))


_RATE_SETTING = (KIND_CODE[COMMAND], KIND_CODE[FRAME])
_RATE_CODES = np.array([ord(f"{code:X}") for code in BAUD_CODES], "u1")   # the hex digit after "C"


def sets_a_rate(chunk: StoreChunk) -> bool:
    """Does the chunk hold a rate change, or a frame that asks for one (``C0``-``C7``,
    Table 4: ``rate.rate_set``'s rule, on the columns)? Following a rate warns as it
    decodes, which the columns do not keep: such a recording is decoded."""
    cols = chunk.columns
    kind = np.frombuffer(cols["kind"], "u1")
    if not len(kind):
        return False
    if (kind == KIND_CODE[RATE]).any():
        return True
    flags = np.frombuffer(cols["flags"], "u1")
    offsets = raw_offsets(chunk)
    starts, lengths = offsets[:-1], np.diff(offsets)
    # a frame with a good checksum and a two-byte payload (7 bytes of frame around it, Table 1)
    rows = np.flatnonzero(np.isin(kind, _RATE_SETTING) & ((flags & FRAMED) != 0) & ((flags & CHECKSUM_OK) != 0)
                          & (lengths == 9))
    if not len(rows):
        return False
    raw = np.frombuffer(chunk.raw, "u1")
    return bool(((raw[starts[rows] + 6] == ord("C")) & np.isin(raw[starts[rows] + 7], _RATE_CODES)).any())


def encode(chunk: StoreChunk, tables: Tables, decoder: str,
           positions: tuple[np.ndarray, np.ndarray] | None = None) -> bytes:
    """One message: the events of ``chunk`` and the whole ``tables`` so far;
    ``positions``, the azimuth and elevation columns (none: all NaN)."""
    cols = chunk.columns
    n = len(cols["kind"])
    flags = np.frombuffer(cols["flags"], dtype="u1") if n else np.zeros(0, "u1")
    timed = (flags & UNTIMED) == 0
    t = np.frombuffer(cols["t"], dtype="f8") if n else np.zeros(0)
    t_end = np.frombuffer(cols["t_end"], dtype="f8") if n else np.zeros(0)
    t_ns = np.zeros(n, "i8")
    end_ns = np.zeros(n, "i8")
    t_ns[timed] = nanoseconds(t[timed])
    end_ns[timed] = nanoseconds(t_end[timed])
    values: dict[str, np.ndarray] = {
        "number": np.arange(chunk.start + 1, chunk.start + n + 1, dtype="i8"),
        "t_ns": t_ns, "duration_ns": end_ns - t_ns,
    }
    for name, _type, dtype in _COLUMNS[3:]:
        values[name] = np.asarray(cols[name], dtype=dtype) if n else np.zeros(0, dtype)
    offsets = raw_offsets(chunk).astype("i4")
    arrays = [na.c_array_from_buffers(arrow_type, n, [None, values[name]]) for name, arrow_type, _d in _COLUMNS]
    arrays.append(na.c_array_from_buffers(na.binary(), n, [None, offsets, chunk.raw]))
    arrays.append(_sparse_text(n, chunk.start, {i: [[p.id.name if isinstance(p, Problem) else None, str(p)]
                                                      for p in ps] for i, ps in chunk.problems.items()}))
    arrays.append(_sparse_text(n, chunk.start, chunk.fields))
    for column in positions or (np.full(n, np.nan), np.full(n, np.nan)):
        arrays.append(na.c_array_from_buffers(na.float64(), n, [None, np.ascontiguousarray(column, "f8")]))
    metadata = {
        "gimbalscope.columns": VERSION, "decoder": decoder,
        "kinds": orjson.dumps(list(KINDS)).decode(), "statuses": orjson.dumps(list(STATUSES)).decode(),
        "lines": orjson.dumps(tables.lines).decode(), "devices": orjson.dumps(tables.devices).decode(),
        "commands": orjson.dumps(tables.commands).decode(),
    }
    schema = na.c_schema(na.struct(_SCHEMA_FIELDS, nullable=False)).modify(metadata=metadata)
    batch = na.c_array_from_buffers(schema, n, [None], children=arrays)
    out = io.BytesIO()
    with na_ipc.StreamWriter.from_writable(out) as writer:
        writer.write_stream(na.c_array_stream(batch))
    return out.getvalue()


def _sparse_text(n: int, start: int, by_index: dict[int, Any]) -> Any:
    """A string column of ``n`` rows: the JSON of ``by_index``'s values at their
    rows, "" elsewhere. Built from offsets and one data buffer (most rows empty)."""
    lengths = np.zeros(n, "i4")
    parts: list[bytes] = []
    for i in sorted(by_index):
        text = orjson.dumps(by_index[i])
        lengths[i - start] = len(text)
        parts.append(text)
    offsets = np.zeros(n + 1, "i4")
    np.cumsum(lengths, out=offsets[1:])
    return na.c_array_from_buffers(na.string(), n, [None, offsets, b"".join(parts)])


@dataclass
class Decoded:
    """One message read: the events as a ``StoreChunk`` whose codes are the
    message's own (``tables``), the decoder that made them, and the positions
    (azimuth, elevation) of the position commands and answers."""
    chunk: StoreChunk
    tables: Tables
    decoder: str
    positions: tuple[np.ndarray, np.ndarray]


def decode(data: bytes, raw_base: int) -> Decoded:
    """Read one message. ``raw_base``: the raw bytes of the events before it
    (the store's ``end`` counts from the capture's first raw byte). Raises
    ``ColumnsError`` for what is not stored columns of this version."""
    try:
        stream = na.ArrayStream.from_readable(io.BytesIO(data))
        schema = stream.schema
        batches = list(stream)
    except Exception as e:   # noqa: BLE001 - whatever the Arrow reader says of bytes it cannot read: one reason
        raise ColumnsError(f"not an Arrow IPC stream ({type(e).__name__}: {e})") from None
    try:
        meta = {k.decode(): v.decode() for k, v in (schema.metadata or {}).items()}
        names = [schema.field(i).name for i in range(schema.n_fields)]
    except UnicodeDecodeError as e:
        raise ColumnsError(f"the stored columns' metadata or names are not text ({e})") from None
    if meta.get("gimbalscope.columns") != VERSION:
        raise ColumnsError(f"stored columns of version {meta.get('gimbalscope.columns')!r}, not {VERSION}")
    if names != list(_SCHEMA_FIELDS):
        raise ColumnsError(f"columns {names} are not those of version {VERSION}")
    if len(batches) != 1:
        raise ColumnsError(f"{len(batches)} record batches where one is written")
    try:
        tables = Tables(orjson.loads(meta["lines"]), orjson.loads(meta["devices"]), orjson.loads(meta["commands"]))
        for c in tables.commands[1:]:
            if not (isinstance(c, list) and len(c) == 2 and (c[1] is None or isinstance(c[1], int) and 0 <= c[1] < len(COMMANDS))):
                raise ValueError(f"a command entry {c!r}")
    except (KeyError, ValueError, TypeError) as e:
        raise ColumnsError(f"the tables of the stored columns do not read ({e})") from None
    try:
        return _decoded(batches[0], names, tables, meta.get("decoder", ""), raw_base)
    except ColumnsError:
        raise
    except (RuntimeError, ValueError, IndexError) as e:   # buffers that do not add up (nanoarrow, numpy)
        raise ColumnsError(f"the stored columns do not read ({type(e).__name__}: {e})") from None


def _decoded(batch: Any, names: list[str], tables: Tables, decoder: str, raw_base: int) -> Decoded:
    """``decode``'s record batch read into a chunk."""
    n = len(batch)
    child = {name: batch.child(i) for i, name in enumerate(names)}
    num = {name: np.frombuffer(child[name].buffer(1), dtype=dtype)[:n] if n else np.zeros(0, dtype)
           for name, _t, dtype in _COLUMNS}
    start = int(num["number"][0]) - 1 if n else -1
    flags = num["flags"]
    untimed = (flags & UNTIMED) != 0
    index = np.arange(start, start + n, dtype="f8")
    t = np.where(untimed, index, num["t_ns"] / 1e9)
    t_end = np.where(untimed, np.nan, (num["t_ns"] + num["duration_ns"]) / 1e9)
    raw_child = child["raw"]
    offsets = np.frombuffer(raw_child.buffer(1), dtype="i4")[:n + 1] if n else np.zeros(1, "i4")
    raw = bytes(raw_child.buffer(2))[:int(offsets[-1])] if n else b""
    lengths = np.diff(offsets)
    if n and (offsets[0] != 0 or np.any(lengths < 0) or int(offsets[-1]) != len(raw)):
        raise ColumnsError("the raw bytes' offsets do not add up")
    if n and np.any(((flags & FRAMED) != 0) & (lengths < MIN_FRAME)):
        raise ColumnsError("a frame shorter than a frame's header and checksum")
    ends = raw_base + offsets[1:].astype("i8")
    columns = {"end": _store_array("q" if n and ends[-1] >= 2 ** 32 else "I", ends),
               "t": _store_array("d", t), "t_end": _store_array("d", t_end)}
    for name, typecode in _STORE_TYPES.items():
        if name == "offset" and n and int(num[name].max()) >= 1 << 32:
            typecode = "q"   # a line past 4 GB: as the store widens it
        columns[name] = _store_array(typecode, num[name])
    columns["errors"] = _store_array("i", np.flatnonzero(flags & ERROR) + start + 1)
    for name, values in (("kind", KINDS), ("status", STATUSES)):
        if n and int(num[name].max()) >= len(values):
            raise ColumnsError(f"a {name} code past the {len(values)} values of its table")
    if n and (np.any(num["request"] < 0) or np.any(num["request"] >= num["number"])):
        raise ColumnsError("an answer whose command does not come before it")
    try:
        problems: dict[int, Sequence[Problem]] = {
            i: [parse(text) if name is None else by_name(name).with_text(text) for name, text in ps]
            for i, ps in _sparse_values(child["problems"], n, start).items()}
        fields = _sparse_values(child["fields"], n, start)
    except (KeyError, ValueError, TypeError) as e:   # orjson's errors are ValueErrors
        raise ColumnsError(f"the problems or fields of the stored columns do not read ({type(e).__name__}: {e})") from None
    # the tables whole; ``Joiner`` hands on only what a receiving store lacks
    chunk = StoreChunk(start, columns, raw, problems, fields, list(tables.lines), list(tables.devices),
                       [(c[0], c[1]) for c in tables.commands if c is not None])
    positions = (_floats(child["azimuth_deg"], n), _floats(child["elevation_deg"], n))
    return Decoded(chunk, tables, decoder, positions)


def _floats(column: Any, n: int) -> np.ndarray:
    return np.frombuffer(column.buffer(1), dtype="f8")[:n] if n else np.zeros(0)


def _store_array(typecode: str, values: np.ndarray) -> array:
    out = array(typecode)
    out.frombytes(np.ascontiguousarray(values, dtype=np.dtype(typecode)).tobytes())
    return out


def _sparse_values(column: Any, n: int, start: int) -> dict[int, Any]:
    """The JSON values of a string column's non-empty rows, by store index."""
    if not n:
        return {}
    offsets = np.frombuffer(column.buffer(1), dtype="i4")[:n + 1]
    rows = np.flatnonzero(np.diff(offsets))
    if not len(rows):
        return {}
    data = bytes(column.buffer(2))
    return {start + int(i): orjson.loads(data[offsets[i]:offsets[i + 1]]) for i in rows}


class Joiner:
    """The messages of one recording, or of its parts in order, as the chunks of
    one store: each message's codes mapped to this reader's tables (parts code
    their values each their own way), the new values handed on with the chunk
    (``EventStore.append_chunk`` learns them), the raw ends made continuous."""

    def __init__(self) -> None:
        self.lines: dict[Any, int] = {None: 0}
        self.devices: dict[Any, int] = {None: 0}
        self.commands: dict[Any, int] = {None: 0}
        self.raw_base = 0
        self.events = 0          # events handed on: the next chunk starts there
        self.decoder: str | None = None
        self.positions: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros(0))   # the last chunk's

    def chunk(self, data: bytes) -> StoreChunk:
        """The next message as a chunk; ``ColumnsError`` if it does not read or
        does not follow the last one."""
        decoded = decode(data, self.raw_base)
        chunk, tables = decoded.chunk, decoded.tables
        n = len(chunk.columns["kind"])
        if n and chunk.start != self.events:
            raise ColumnsError(f"stored columns from event {chunk.start + 1} do not follow event {self.events}")
        chunk.start = self.events   # an empty message has no first number: it sits where the joiner is
        if self.decoder is None:
            self.decoder = decoded.decoder
        elif decoded.decoder != self.decoder:
            raise ColumnsError(f"stored columns of two decoders ({self.decoder}, {decoded.decoder})")
        chunk.lines = self._remap(chunk, "line", tables.lines, self.lines, lambda v: v)
        chunk.devices = self._remap(chunk, "device", tables.devices, self.devices, lambda v: v)
        new_commands = self._remap(chunk, "command", tables.commands, self.commands,
                                   lambda v: None if v is None else (v[0], v[1]))
        chunk.commands = [(c[0], c[1]) for c in new_commands if c is not None]
        self.raw_base += len(chunk.raw)
        self.events += n
        self.positions = decoded.positions
        return chunk

    def known(self) -> tuple[list[Any], list[Any], list[Any]]:
        """Every value coded so far, in code order from code 1 (lines, devices,
        commands as (id, place)): what a store of one chunk must learn first."""
        return tuple([k for k, _c in sorted(table.items(), key=lambda kv: kv[1])][1:]   # type: ignore[return-value]
                     for table in (self.lines, self.devices, self.commands))

    @staticmethod
    def _remap(chunk: StoreChunk, name: str, values: list[Any], known: dict[Any, int],
               key: Any) -> list[Any]:
        """Map column ``name``'s codes (indices into ``values``) to ``known``'s,
        coding the values it lacks; those values, in their new codes' order."""
        new: list[Any] = []
        mapping = np.zeros(max(len(values), 1), dtype="i8")
        for i, v in enumerate(values):
            k = key(v)
            k = tuple(k) if isinstance(k, list) else k
            code = known.get(k)
            if code is None:
                code = known[k] = len(known)
                new.append(v)
            mapping[i] = code
        column = chunk.columns[name]
        codes = np.frombuffer(column, dtype=np.dtype(column.typecode)) if len(column) else np.zeros(0, "i8")
        if len(codes) and int(codes.max()) >= len(values):
            raise ColumnsError(f"a {name} code past the {len(values)} values of its table")
        mapped = mapping[codes]
        wide = "I" if len(mapped) and int(mapped.max()) >= 1 << 16 else "H"   # as narrow as the store keeps it
        chunk.columns[name] = _store_array("B" if name == "line" else wide, mapped)
        return new


# the modules whose code decides what a recording's events are, and what the
# doctor's findings kept beside them say: stored columns made by another version
# of any of them are not used (the raw bytes are decoded)
_DECODER_MODULES = ("dissectors", "analyzer.capture", "analyzer.analysis.pairing", "analyzer.analysis.rate",
                    "analyzer.analysis.echo", "analyzer.analysis.align", "analyzer.analysis.skew",
                    "analyzer.analysis.doctor", "analyzer.analysis.findings", "analyzer.analysis.signs",
                    "analyzer.analysis.stats",
                    "analyzer.sources.mcapfile", "analyzer.sources.mcapwalk", "analyzer.sources.mcapparts",
                    "analyzer.formats.mcap_lines", "analyzer.formats.store")


@functools.cache
def decoder_version() -> str:
    """The package's version and a digest of the decoding code (``_DECODER_MODULES``):
    any change to how events are made, released or not, gives another."""
    digest = hashlib.sha256()
    for name in _DECODER_MODULES:
        spec = importlib.util.find_spec(name)
        if spec is None or spec.origin is None:
            continue
        paths = ([os.path.join(d, f) for d in spec.submodule_search_locations or () for f in sorted(os.listdir(d))
                  if f.endswith(".py")] if spec.submodule_search_locations else [spec.origin])
        for path in sorted(paths):
            with open(path, "rb") as f:
                digest.update(os.path.basename(path).encode() + b"\0" + f.read())
    return f"{__version__}+{digest.hexdigest()[:12]}"
