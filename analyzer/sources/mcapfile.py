"""MCAP recordings as a capture source: the raw byte topics (``/serial/A/raw``,
``/serial/B/raw``, or ``/serial/AB/raw``) are read back and re-dissected, so a
newer dissector re-decodes an old recording.

Nothing in the file is trusted (``mcapwalk`` bounds every length). What cannot be
read is said once, with its byte offset, and the rest is read:

- a file from a killed tap has no summary: it is read up to where it ends;
- a damaged chunk is skipped by its length; one whose CRC fails but that
  decompresses is read up to its first record that does not read as written
  (``gimbalscope recover`` keeps the same records);
- a message on a raw topic that is not a gimbalscope raw chunk (other tools, by
  hand) is counted and skipped: one warning per topic.

A lean recording (docs/mcap.md, "Lean recordings") has no per-line raw topics:
its reads are batched on ``/serial/reads``, a list of reads of every line in the
order they were read, each with its line, ``t`` and bytes. The list is read back
as the chunks it holds, in its order, so the chunks come out exactly as a
recording with per-line topics gives them (the same order across the lines, the
same times). A message whose list does not read whole is not ours, as above.

A raw chunk's bytes are base64 when its channel's schema says
``"contentEncoding": "base64"`` (recordings since docs/foxglove.md), hex in older
recordings: both decode.

A file with no raw chunk to decode is one error naming why; one with our raw
channels and no messages at all is an empty capture.

The ``gimbalscope`` metadata record (analyzer/info.py) is read too, from the
summary's metadata index or, without one, by a walk that seeks over chunks: a
killed live recording has it near its start, a converted one at its end, a cut
one may have lost it. A garbled record is said in ``metadata_problem``, never
raised: the raw chunks decode without it. Several recordings of one tap are read
as one capture by ``mcapparts`` (docs/time.md, "Parts").

What the capture's source knew below the bytes comes back as that source gave
it (docs/mcap.md, "Below the bytes"; analyzer/formats/mcap_lines.py): a logic
capture's line reports (``physical``, from the latest ``gimbalscope.lines``
record that reads; one that does not is a warning), and, when the metadata says
the source saw them (``line_errors: yes``), the line's own errors on the raw
chunks (``faults``, each told before the chunk holding its byte, at its offset
on its line as this recording reads it).

Large files are read in a second process (analyzer/worker_process.py): decompressing
and parsing the raw messages cost as much as dissecting them, and a second core
does it meanwhile (re-dissection went from 42% to over 50% of raw-dump decode
speed). Where no process can be had, the file is read here.
"""

from __future__ import annotations

import json
import os
import pickle
import struct
from binascii import a2b_base64
from collections.abc import Callable, Generator, Iterator
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from itertools import chain
from typing import Any, BinaryIO

from mcap.records import Channel, Message, Metadata, Schema
from orjson import loads as json_loads

from .. import worker_process
from ..errors import CaptureError
from ..formats.mcap_lines import LINES_RECORD, faults_of, reports_of
from ..formats.mcap_schemas import (
    COLUMNS_ENCODING,
    COLUMNS_RECORD,
    COLUMNS_TOPIC,
    READS_TOPIC,  # lean recordings: the reads of every line, batched
)
from ..formats.store_ipc import ColumnsError
from ..lines import LINE_A, LINE_AB, LINE_B, Chunk, LineFault
from ..outfile import show
from .base import ReadSettings, Source, StoredColumns
from .files import Input, open_input
from .mcapwalk import (
    MAGIC,
    MESSAGE_HEAD,
    OP_CHANNEL,
    OP_CHUNK,
    OP_CHUNK_INDEX,
    OP_DATA_END,
    OP_FOOTER,
    OP_MESSAGE,
    OP_METADATA,
    OP_SCHEMA,
    RECORD,
    RECORD_HEAD,
    ChunkPlace,
    Damaged,
    Walk,
    chunk_channels,
    chunk_parts,
    intact_prefix,
    op_name,
    parse,
    read_chunk,
    read_cut_chunk,
    summary_records,
)
from .meter import READS

_BATCHED = "reads"              # the "line" of the reads topic's channels (each read names its own)
_LINES = (LINE_A, LINE_B, LINE_AB)
RAW_TOPICS = {**{f"/serial/{line}/raw": line for line in _LINES}, READS_TOPIC: _BATCHED}

_LOG_TIME = struct.Struct("<Q")            # at byte 6 of a message record's body
_BODIES = frozenset((OP_CHUNK, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE))   # top-level records read; the rest are skipped

# A raw chunk's time ("t", seconds since the capture's first byte) must be a number
# within this; beyond it no recording is that long, and times that large break the
# arithmetic of re-recording it (nanosecond log times are 64-bit).
MAX_T = 1e9
# A recording's start (its first log time less its t) is an epoch time in this range,
# else unknown: log times on another clock (boot time, a simulator's) are not dates.
EPOCH = (1e9, 9e9)
# What a message that is not ours raises in the fast path (orjson's errors are ValueErrors)
_NOT_OURS = (ValueError, TypeError, KeyError, AttributeError, RecursionError)

# kinds of problem found while reading, each said with its own ending
_CUT, _LOST, _DAMAGE, _FOREIGN = "cut", "lost", "damage", "foreign"   # _LOST: a cut through a record
_ENDINGS = {
    _CUT: "; read everything before it (a killed recording? 'gimbalscope recover' rewrites it whole)",
    _LOST: "; read everything before it (a killed recording? 'gimbalscope recover' rewrites it whole)",
    _DAMAGE: "; read on after it ('gimbalscope recover' keeps every intact chunk)",
    _FOREIGN: "; read the rest",
}

READER_PROCESS_MIN = 8 << 20   # bytes: smaller files are read inline (a process costs ~0.1 s to start)
_BATCH = 4096                  # chunks per message from the reader process
_as_chunk = partial(tuple.__new__, Chunk)   # a (line, data, t) tuple as a Chunk, in C

Note = Callable[[str, str], None]   # (kind, text): a problem found while reading


class McapSource(Source):
    """``path`` is read; ``name`` (default: the path) is what messages call it, e.g.
    the user's name for a recording copied to a temporary file."""

    carries_metadata = True

    def __init__(self, path: str, name: str | None = None) -> None:
        super().__init__()
        self.path = path
        self.label = show(name if name is not None else path)
        self.description = f"{self.label} (MCAP)"
        self._said: set[str] = set()
        self._raw_channels: set[str] = set()   # lines with a raw channel, after a whole read
        # log times (ns, on whatever clock the recording used) of its first raw chunk
        # and of t = 0: where the recording sits among others of the same tap
        self.first_log_ns: int | None = None
        self.origin_ns: int | None = None
        lines, timed, start = self._survey()
        self.lines = lines
        self.timed = timed
        self.start_time = start
        # the ``gimbalscope`` metadata record (None: none readable), and why one of that
        # name could not be read
        self.metadata, self.metadata_problem = self._read_metadata()
        self.clocks = self._count_clocks()
        self.wire_times = (self.metadata or {}).get("wire_times") == "yes"
        # what the capture's source knew below the bytes (module doc)
        self.physical = self._read_line_reports()
        self.faults: list[LineFault] | None = [] if (self.metadata or {}).get("line_errors") == "yes" else None

    # ------------------------------------------------------------------ reading
    def _batches(self, topics: list[str], pairs: bool = False, need_t: bool | None = None,
                 note: Note | None = None, only: str | None = None,
                 errors: list[LineFault] | None = None) -> Generator[list]:
        """The raw chunks of ``topics`` in file order, a list per MCAP chunk: ``Chunk``s,
        or with ``pairs`` (log time in ns, ``Chunk``). ``need_t``: the recording has
        time (True), has none (False), or not known yet (None); a message that
        disagrees is not a raw chunk of this recording. Problems go to ``note``.
        ``only``: the chunks of that line only (of a lean recording's reads).
        ``errors``: where the chunks' line errors go (``faults``), before their list."""
        p = _Pass(topics, pairs, need_t, only, errors)
        yield from _raw_batches(self.path, self.label, p, note or self._say)
        self._raw_channels = p.raw_channels()

    def _say(self, kind: str, text: str) -> None:
        """A problem as a warning, once (two-line untimed recordings are read a
        line at a time, each pass finding the same damage)."""
        msg = _problem(self.label, kind, text)
        if msg not in self._said:
            self._said.add(msg)
            self.warn(msg)

    def _survey(self) -> tuple[tuple[str, ...], bool, float | None]:
        """Which lines the recording has, whether it carries time, and when it
        started (the first raw message's log time less its wire time)."""
        notes: list[tuple[str, str]] = []
        seen: set[str] = set()
        first: tuple[int, float | None] | None = None
        batches = self._batches(list(RAW_TOPICS), pairs=True, note=lambda kind, text: notes.append((kind, text)))
        for batch in batches:
            for log_time, chunk in batch:
                if first is None:
                    first = (log_time, chunk.t)
                seen.add(chunk.line)
            if len(seen) == 2 or LINE_AB in seen:
                break
        batches.close()   # its problems are said when the chunks are read
        if first is None:
            if notes or not self._raw_channels:
                raise CaptureError(self._nothing_to_read(notes))
            # our raw channels and no message: an empty capture
            return ((LINE_AB,) if self._raw_channels == {LINE_AB} else (LINE_A, LINE_B)), False, None
        log_time, t = first
        self.first_log_ns = log_time
        self.origin_ns = log_time - (round(t * 1e9) if t is not None else 0)   # as the recorder adds it
        start = log_time / 1e9 - (t or 0)
        lines = (LINE_AB,) if LINE_AB in seen else (LINE_A, LINE_B)
        return lines, t is not None, (start if EPOCH[0] <= start <= EPOCH[1] else None)

    def _nothing_to_read(self, notes: list[tuple[str, str]]) -> str:
        """Why there is nothing to decode: no raw topic, or damage that may have
        taken them (a record cut or damaged: say that, not that they are missing)."""
        said = "; ".join(text for _kind, text in notes)
        if any(kind != _CUT for kind, _text in notes):
            return f"{self.label}: no gimbalscope raw chunks to decode: {said}"
        return (f"{self.label}: MCAP file without gimbalscope raw topics ({', '.join(RAW_TOPICS)})"
                + (f"; it also {said}" if said else ""))

    # ------------------------------------------------------------ metadata
    def _read_line_reports(self) -> dict | None:
        """The line reports of the logic capture the recording was made from (its
        latest ``gimbalscope.lines`` record); None when it has none, or none that
        reads (said once)."""
        try:
            with open_input(self.path) as f:
                record, why = read_metadata(f, os.fstat(f.fileno()).st_size, LINES_RECORD, last=True)
        except (OSError, CaptureError, struct.error):   # the file changed under us
            return None
        if record is not None:
            try:
                return reports_of(record)
            except ValueError as e:
                why = str(e)
        if why:
            self.warn_later(f"{self.label}: the {LINES_RECORD} metadata record does not read ({why}): the "
                            "waveform's line reports are left out")
        return None

    def _read_metadata(self) -> tuple[dict[str, str] | None, str | None]:
        """The ``gimbalscope`` metadata record and why it cannot be read (module
        doc); a file that cannot be opened again has none."""
        try:
            with open_input(self.path) as f:
                return read_metadata(f, os.fstat(f.fileno()).st_size)
        except (OSError, CaptureError, struct.error):   # the file changed under us
            return None, None

    def stored_columns(self) -> StoredColumns:
        """The recording's stored columns, when its ``gimbalscope.columns`` record
        says they are complete (a killed tap's recording has none to use: its
        record is written as it closes)."""
        try:
            with open_input(self.path) as f:
                record, problem = read_metadata(f, os.fstat(f.fileno()).st_size, COLUMNS_RECORD)
        except (OSError, CaptureError, struct.error):
            return StoredColumns(None, None)
        if record is None:
            return StoredColumns(None, problem and f"{self.label}: stored columns not used: {problem}")
        return StoredColumns(record, None, lambda: _read_ahead(_column_messages(self.path)))

    def _count_clocks(self) -> int:
        """How many clocks stamped the chunks (docs/time.md, "Clocks"): as the
        metadata says, or as the tap that made it had them. Without time there is
        no clock, whatever a record says."""
        if not self.timed:
            return 0
        meta = self.metadata or {}
        said = meta.get("clocks")
        if said in ("1", "2"):
            return int(said)
        if len(meta.get("ports", "").split()) == 2:
            return 2
        if meta.get("mode") in ("live", "demo") and self.lines == (LINE_A, LINE_B):
            return 2   # a tap's two adapters, each stamping its own line
        return 1

    def last_log_ns(self) -> int | None:
        """The log time (ns) of the recording's last message, events included:
        from the summary's statistics, else from the chunks' headers (a file
        without summary). None when it has no message or cannot be read again."""
        try:
            with open_input(self.path) as f:
                return last_log_time(f, os.fstat(f.fileno()).st_size)
        except (OSError, CaptureError, struct.error):   # the file changed under us
            return None

    def _topics(self) -> list[str]:
        """The raw topics of the recording's lines, and the reads topic of a lean one."""
        return [*(f"/serial/{line}/raw" for line in self.lines), READS_TOPIC]

    def chunks(self) -> Iterator[Chunk]:
        if os.path.getsize(self.path) < READER_PROCESS_MIN:
            return self._chunks_here()
        return self._chunks_from_reader_process()

    def _chunks_here(self) -> Iterator[Chunk]:
        return chain.from_iterable(self._batches(self._topics(), need_t=self.timed, errors=self.faults))

    def _chunks_from_reader_process(self) -> Iterator[Chunk]:
        worker = worker_process.start(_read_in_process, (self.path, self.label, self._topics(), self.timed,
                                                         self.faults is not None))
        if worker is None:   # no process to be had: read here
            yield from self._chunks_here()
            return
        try:
            while True:
                try:
                    item = worker.messages.recv()
                except (EOFError, pickle.UnpicklingError):
                    raise CaptureError(f"{self.label}: the MCAP reader process ended unexpectedly") from None
                if isinstance(item, list):
                    yield from map(_as_chunk, item)
                elif isinstance(item, tuple):
                    self._hear_reader(*item)
                else:   # None: the file is read
                    return
        finally:
            worker.messages.close()   # first: a reader still sending (| head, quit) is ended by it
            worker.end()

    def _hear_reader(self, kind: str, what: Any) -> None:
        """What the reader process says beside the chunks (``_read_in_process``)."""
        if kind == "faults":     # line errors, before the chunks holding their bytes
            assert self.faults is not None   # sent only when asked for
            self.faults.extend(what)
        elif kind == "progress":
            READS.report(self.path, what)   # the progress bar's (analyzer/listeners/progress.py)
        elif kind == "error":
            raise CaptureError(what)
        elif what not in self._said:   # a warning
            self._said.add(what)
            self.warn(what)

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        return chain.from_iterable(self._batches([f"/serial/{line}/raw", READS_TOPIC], need_t=self.timed,
                                                 only=line, errors=self.faults))


def open_mcap(inputs: list[Input], settings: ReadSettings) -> McapSource:
    """The source of an MCAP input (analyzer/sources/registry.py). It is read with
    random access (surveyed, then read, large ones by a second process): one that
    arrives through a pipe or compressed is copied to a temporary file first,
    removed when the source closes or the run ends. Its chunks carry their own
    times, so ``settings`` are not used."""
    inp, = inputs
    path, temporary = inp.as_regular_file()
    problem = inp.problem
    inp.close()
    try:
        source = McapSource(path, name=inp.name)
    except BaseException:
        if temporary:
            _remove(path)
        raise
    if temporary:
        source.on_close(lambda: _remove(path))
        source.description = inp.describe("MCAP")   # the user's name, not the copy's
    if problem:
        source.warn_later(problem)
    return source


def _read_ahead(messages: Generator[bytes, None, None]) -> Iterator[bytes]:
    """``messages``, the next one read by a thread of its own while the caller
    handles this one: reading a chunk (the file, zstd, the CRC) lets go of the
    interpreter, so on a second core it overlaps the caller's work (a third of
    what reading a million events' columns took). The thread has at most one
    message read ahead; its errors are raised here, in turn."""
    pool = ThreadPoolExecutor(1, thread_name_prefix="gimbalscope-columns")
    try:
        pending = pool.submit(next, messages, None)
        while (data := pending.result()) is not None:
            pending = pool.submit(next, messages, None)
            yield data
    finally:
        pool.shutdown(wait=True, cancel_futures=True)   # the read under way ends first
        messages.close()


def _column_messages(path: str) -> Generator[bytes, None, None]:
    """The messages of ``COLUMNS_TOPIC`` in order, from the chunks that hold them:
    the summary's chunk indexes lead to them. Each chunk
    must carry a CRC that its records match: the Arrow reader trusts the bytes it
    is given (a damaged message can crash it), so only bytes written as they are
    reach it. What does not read raises ``ColumnsError``: the caller decodes the
    raw bytes instead."""
    try:
        with open(path, "rb") as f:
            # the summary's records as they are (the chunk indexes' leading fields only): a
            # summary cut short gives fewer messages, which the events' count then refuses
            summary = summary_records(f, os.fstat(f.fileno()).st_size, (OP_CHANNEL, OP_CHUNK_INDEX))
            if not summary:
                raise ColumnsError("the recording has no summary to find its stored columns by")
            channels = _columns_channels(summary)
            if any(c.message_encoding != COLUMNS_ENCODING for c in channels):
                raise ColumnsError(f"stored columns not encoded as {COLUMNS_ENCODING}")
            ids = {c.id for c in channels}
            places = sorted((place for place in _chunk_places(summary) if ids & place.channels),
                            key=lambda place: place.offset)
            for place in places:   # ours are each a chunk of their own; another writer's may share them
                yield from _chunk_columns(f, place.offset, place.length, ids)
    except ColumnsError:
        raise
    except Exception as e:   # noqa: BLE001 - whatever the MCAP library says of a file it cannot read: one reason
        raise ColumnsError(f"stored columns do not read: {type(e).__name__}: {e}") from None


def _chunk_columns(f: BinaryIO, offset: int, length: int, ids: set[int]) -> Iterator[bytes]:
    """The columns messages of the chunk record at ``offset``, whose CRC holds."""
    f.seek(offset)
    record = f.read(length)
    if len(record) != length or length < RECORD_HEAD:
        raise ColumnsError(f"the chunk at byte {offset} is cut short")
    op, size = RECORD.unpack_from(record)
    if op != OP_CHUNK or size != length - RECORD_HEAD:
        raise ColumnsError(f"no chunk at byte {offset}, where the index says one is")
    body = record[RECORD_HEAD:]
    if chunk_parts(body, cut=False)[1] == 0:
        raise ColumnsError(f"the chunk at byte {offset} has no CRC to check its stored columns by")
    try:
        records, crc_ok = read_chunk(body)
    except Damaged as e:
        raise ColumnsError(f"the chunk at byte {offset}: {e}") from None
    if not crc_ok:
        raise ColumnsError(f"the chunk at byte {offset} fails its CRC check")
    pos = 0
    while pos < len(records):
        if len(records) - pos < RECORD_HEAD:
            raise ColumnsError(f"a record cut short in the chunk at byte {offset}")
        op, size = RECORD.unpack_from(records, pos)
        start = pos + RECORD_HEAD
        pos = start + size
        if pos > len(records):
            raise ColumnsError(f"a record runs past its chunk at byte {offset}")
        if op == OP_MESSAGE:
            message = parse(op, records[start:pos])
            assert isinstance(message, Message)
            if message.channel_id in ids:
                yield message.data


def _remove(path: str) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


# ----------------------------------------------------- metadata and time span
METADATA_NAME = "gimbalscope"      # analyzer/formats/mcap_schemas.py (not imported: it loads the recorder's writer)
_MAX_METADATA = 1 << 20            # bytes: a record of key=value strings; larger is damage
_OP_STATISTICS, _OP_METADATA_INDEX = 0x0B, 0x0D
_U32, _U64 = struct.Struct("<I"), struct.Struct("<Q")
_INDEX_HEAD = struct.Struct("<QQI")  # a MetadataIndex: record offset, record length, name length
_MESSAGE_END = slice(34, 42)        # message_end_time in a Statistics record's body
_TIMES = struct.Struct("<QQ")       # a Chunk's first and last message log times, at its start
_MESSAGE_LOG_TIME = 6               # in a Message record's body, after its channel and sequence

Found = tuple[dict[str, str] | None, str | None]   # (metadata, why it cannot be read)


def read_metadata(f: BinaryIO, size: int, name: str = METADATA_NAME, last: bool = False) -> Found:
    """The metadata record ``name`` (the ``gimbalscope`` one by default) of the MCAP
    file ``f`` (``size`` bytes): through the summary's metadata index when it has
    one, else by walking the data section; the first that reads, or with ``last``
    the last one of a record written again as the recording went on (its later
    writes named ``NAME.2``, ``NAME.3``…: analyzer/writers/mcap_recorder.py).
    ``(None, None)`` when there is none; ``(None, why)`` when one is there but
    garbled. Nothing in the file is trusted and nothing raises."""
    problem = None
    offsets = _indexed_metadata(f, size, name, last)
    for offset in reversed(offsets or ()) if last else offsets or ():
        meta, why = _metadata_at(f, size, offset, name, last)
        if meta is not None:
            return meta, None
        problem = problem or why
    if offsets is not None and problem is None:
        return None, None   # the index lists every metadata record, and none is ours
    walk = Walk(f, size)
    found = None
    for offset, _op, body in walk.records((OP_METADATA,)):
        if not _is_named(_metadata_name(body), name, last):
            continue
        meta, why = _metadata_of(body, offset, name)
        if meta is not None:
            if not last:
                return meta, None
            found = meta
        else:
            problem = problem or why
    return (found, None) if found is not None else (None, problem)


def _is_named(found: str | None, name: str, written_again: bool = False) -> bool:
    """Is a record named ``found`` the record ``name`` (or, ``written_again``,
    one of its later writes, ``NAME.n``)?"""
    if found == name:
        return True
    return written_again and found is not None and found.startswith(name + ".") \
        and found[len(name) + 1:].isdigit()


def _indexed_metadata(f: BinaryIO, size: int, name: str, written_again: bool = False) -> list[int] | None:
    """The offsets the summary's metadata index gives for records named ``name``
    (``written_again``: and its later writes), in file order, or None when there
    is no index to go by (no summary, none in it, or damaged)."""
    bodies = [body for _op, body in summary_records(f, size, (_OP_METADATA_INDEX,))]
    if not bodies:
        return None
    offsets = []
    for body in bodies:
        if len(body) < _INDEX_HEAD.size:
            return None
        offset, _length, name_len = _INDEX_HEAD.unpack_from(body)
        named = body[_INDEX_HEAD.size:_INDEX_HEAD.size + name_len]
        if len(named) != name_len:
            return None
        if _is_named(named.decode("utf-8", "replace"), name, written_again):
            offsets.append(offset)
    return sorted(offsets)


def _metadata_at(f: BinaryIO, size: int, offset: int, name: str, written_again: bool = False) -> Found:
    """The record the metadata index points to at ``offset``."""
    where = f"the metadata index points to byte {offset}"
    if not len(MAGIC) <= offset <= size - RECORD_HEAD:
        return None, f"{where}, outside the file"
    f.seek(offset)
    head = f.read(RECORD_HEAD)
    if len(head) < RECORD_HEAD:   # the file shrank since its size was taken
        return None, f"{where}, past the end of the file"
    op, length = RECORD.unpack(head)
    if op != OP_METADATA:
        return None, f"{where}, where a {op_name(op)} record is, not the {name} metadata"
    if length > min(_MAX_METADATA, size - offset - RECORD_HEAD):
        return None, f"the {name} metadata record at byte {offset} claims {length} bytes"
    body = f.read(length)
    if not _is_named(_metadata_name(body), name, written_again):
        return None, f"{where}, where the Metadata record is not named {name!r}"
    return _metadata_of(body, offset, name)


def _metadata_name(body: bytes) -> str | None:
    """The name a Metadata record's body starts with, if it reads."""
    if len(body) < _U32.size:
        return None
    end = _U32.size + _U32.unpack_from(body)[0]
    if end > len(body):
        return None
    try:
        return body[_U32.size:end].decode("utf-8")
    except UnicodeDecodeError:
        return None


def _metadata_of(body: bytes, offset: int, name: str = METADATA_NAME) -> Found:
    """A record named ``name`` read as a map of strings."""
    where = f"the {name} metadata record at byte {offset}"
    if len(body) > _MAX_METADATA:
        return None, f"{where} claims {len(body)} bytes"
    try:
        record = parse(OP_METADATA, body)
    except Damaged as e:
        return None, f"{where} is damaged ({e})"
    assert isinstance(record, Metadata)   # as parsed for OP_METADATA
    meta = record.metadata
    if not isinstance(meta, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in meta.items()):
        return None, f"{where} holds values that are not strings"
    return dict(meta), None


def last_log_time(f: BinaryIO, size: int) -> int | None:
    """The log time (ns) of the last message of the MCAP file ``f``: the summary's
    statistics when it has them, else the latest of its chunks' headers and of
    the messages outside chunks, found by seeking from record to record."""
    for _op, body in summary_records(f, size, (_OP_STATISTICS,)):
        if len(body) >= _MESSAGE_END.stop and _U64.unpack_from(body)[0] > 0:   # message_count
            return _U64.unpack(body[_MESSAGE_END])[0]
    latest = None
    for op, body_at in _record_heads(f, size):
        f.seek(body_at + (_MESSAGE_LOG_TIME if op == OP_MESSAGE else 0))
        head = f.read(_TIMES.size)
        if len(head) == _TIMES.size:
            last = _TIMES.unpack(head)[1] if op == OP_CHUNK else _U64.unpack_from(head)[0]
            latest = last if latest is None else max(latest, last)
    return latest


def _record_heads(f: BinaryIO, size: int) -> Iterator[tuple[int, int]]:
    """(opcode, body offset) of each Chunk and Message record of the data section
    long enough to hold its times, read by their headers only; up to the first
    record that runs past the end."""
    pos = len(MAGIC)
    while pos + RECORD_HEAD <= size:
        f.seek(pos)
        head = f.read(RECORD_HEAD)
        if len(head) < RECORD_HEAD:
            return
        op, length = RECORD.unpack(head)
        body_at = pos + RECORD_HEAD
        if op in (OP_DATA_END, OP_FOOTER) or length > size - body_at:
            return
        if (op == OP_CHUNK and length >= _TIMES.size) or (op == OP_MESSAGE and length >= MESSAGE_HEAD):
            yield op, body_at
        pos = body_at + length


class _Pass:
    """What one read through the file knows so far."""

    __slots__ = (
        "base64",
        "batched_lines",
        "encodings",
        "errors",
        "foreign",
        "lines",
        "need_t",
        "only",
        "pairs",
        "sent",
        "wanted",
    )

    def __init__(self, topics: list[str], pairs: bool, need_t: bool | None, only: str | None = None,
                 errors: list[LineFault] | None = None) -> None:
        self.lines = {topic: RAW_TOPICS[topic] for topic in topics}
        self.pairs, self.need_t, self.only = pairs, need_t, only
        self.errors = errors                  # where the chunks' line errors go (None: not read)
        self.sent: dict[str, int] = {}        # and each line's bytes so far, their offsets' base
        self.batched_lines: set[str] = set()  # the lines a reads channel says it carries
        self.wanted: dict[int, tuple] = {}    # channel id → (line, decode of 'data'), for the topics asked for
        self.base64: set[int] = set()         # schema ids whose 'data' is base64 (else hex)
        self.encodings: dict[int, str] = {}   # every channel id → its message encoding
        self.foreign: dict[str, list] = {}    # line → [messages that are not ours, the first one]

    def raw_channels(self) -> set[str]:
        """The lines with a raw channel (known after a whole read)."""
        return {line for line, _decode in self.wanted.values() if line != _BATCHED} | self.batched_lines


def _problem(label: str, kind: str, text: str) -> str:
    """A problem found while reading ``label``, as the warning says it."""
    return f"{label}: {text}{_ENDINGS[kind]}"


def _raw_batches(path: str, label: str, p: _Pass, note: Note) -> Iterator[list]:
    """``McapSource._batches`` of the file ``path`` (``label`` in messages), with
    what the read knows so far in ``p``."""
    with open_input(path) as f:
        size = os.fstat(f.fileno()).st_size
        if f.read(len(MAGIC)) != MAGIC:
            raise CaptureError(f"{label}: not an MCAP file (it does not start with the MCAP magic "
                               "bytes of version 0)")
        # channels registered without any message are only in the summary
        summary = summary_records(f, size, (OP_SCHEMA, OP_CHANNEL, OP_CHUNK_INDEX))
        for op, body in summary:
            if op != OP_CHUNK_INDEX:
                _read_records(_record(op, body), p, [])
        columns_only = _columns_chunks(summary)
        walk = Walk(f, size)
        for offset, op, body in walk.records(_BODIES):
            if op == OP_CHUNK and offset in columns_only:
                continue   # the stored columns, in chunks of their own: no raw bytes there
            out = _read_record(offset, op, body, p, note)
            if out:
                yield out
        salvaged: list = []
        if walk.tail is not None:   # a chunk cut short by the end of the file: its first part
            _read_records(_cut_chunk_records(walk.tail[1], p.encodings), p, salvaged)
            if salvaged:
                yield salvaged
        if walk.stop:
            note(_LOST if walk.lost else _CUT, f"ends early ({walk.stop})" + (
                f"; {len(salvaged)} raw chunks read from the part of it that is there" if salvaged else ""))
    for line, (count, first) in p.foreign.items():
        if line == _BATCHED:
            topic, why = READS_TOPIC, _diagnose_reads(first, p.need_t)
        else:
            topic, why = f"/serial/{line}/raw", _diagnose(first, p.need_t)
        note(_FOREIGN, f"{count} messages on {topic} were not gimbalscope raw chunks (the first: {why})"
             if count > 1 else f"1 message on {topic} was not a gimbalscope raw chunk ({why})")


def _columns_chunks(summary: list[tuple[int, bytes]]) -> set[int]:
    """The offsets of the chunks that, as the summary's chunk indexes say, hold
    only stored columns (docs/mcap.md): decoding the raw bytes passes them over
    unopened. A summary that does not read gives none: every chunk is read."""
    try:
        ids = {c.id for c in _columns_channels(summary)}
        if not ids:
            return set()
        places = _chunk_places(summary)
    except Exception:   # noqa: BLE001 - a summary that does not read only costs the skip
        return set()
    return {place.offset for place in places if place.channels and place.channels <= ids}


def _columns_channels(summary: list[tuple[int, bytes]]) -> list[Channel]:
    """The summary's channels of the stored columns (``COLUMNS_TOPIC``)."""
    channels = (parse(op, body) for op, body in summary if op == OP_CHANNEL)
    return [c for c in channels if isinstance(c, Channel) and c.topic == COLUMNS_TOPIC]


def _chunk_places(summary: list[tuple[int, bytes]]) -> list[ChunkPlace]:
    """Every chunk's place and channels, as the summary's chunk indexes say."""
    return [chunk_channels(body) for op, body in summary if op == OP_CHUNK_INDEX]


def _read_record(offset: int, op: int, body: bytes, p: _Pass, note: Note) -> list:
    """The raw chunks in one top-level record: a chunk, or a channel or message
    outside chunks (files written without chunking). Its damage goes to ``note``."""
    out: list = []
    if op != OP_CHUNK:
        stop = _read_records(_record(op, body), p, out)
        if stop is not None:
            note(_DAMAGE, f"the {op_name(op)} record at byte {offset} is damaged ({stop[1]})")
        return out
    where = f"the chunk at byte {offset}"
    try:
        records, crc_ok = read_chunk(body)
    except Damaged as e:
        note(_DAMAGE, f"{where} is damaged ({e})")
        return out
    if crc_ok:
        stop = _read_records(records, p, out)
        if stop is not None:
            note(_DAMAGE, f"{where} is damaged inside ({stop[1]} at byte {stop[0]} of its records)"
                          + (f": read the {len(out)} raw chunks before it" if out else ""))
        return out
    # the records changed since they were written: keep those that still read as written
    end, _messages, why = intact_prefix(records, dict(p.encodings))
    _read_records(records[:end], p, out)
    note(_DAMAGE, f"{where} fails its CRC check: " + (
        "all of it read (some bytes may be altered)" if why is None else
        f"read the {len(out)} raw chunks before {why}" if out else f"none of it read ({why})"))
    return out


def _read_records(records: bytes, p: _Pass, out: list) -> tuple[int, str] | None:
    """Append the raw chunks among ``records`` (a chunk's content) to ``out``;
    returns (offset, what) of a record that does not fit, where reading stopped.

    The hot path of re-dissection: messages of other topics (events,
    transactions, log: most of a recording) and index records are skipped by
    length, never parsed; a raw message is parsed once, its shape checked by
    what parsing it raises (``_NOT_OURS``) and a comparison of its time."""
    unpack_record, loads, append = RECORD.unpack_from, json_loads, out.append
    wanted, pairs, need_t, errors = p.wanted, p.pairs, p.need_t, p.errors
    lo, hi = -MAX_T, MAX_T
    pos, end = 0, len(records)
    try:
        while pos < end:
            op, length = unpack_record(records, pos)   # struct.error: a header cut short
            body = pos + 9                              # RECORD_HEAD, as a constant: this loop is hot
            nxt = body + length
            if nxt > end:
                return pos, f"a {op_name(op)} record longer than what remains"
            if op == 5:                                 # OP_MESSAGE
                if length < 22:                         # MESSAGE_HEAD
                    return pos, "a Message record shorter than its header"
                raw = wanted.get(records[body] | records[body + 1] << 8)
                if raw is not None:
                    line, decode = raw
                    if line == _BATCHED:
                        _read_reads_message(records, body, nxt, p, out)
                        pos = nxt
                        continue
                    try:
                        msg = loads(records[body + 22:nxt])
                        data = decode(msg["data"])
                        t = msg.get("t")
                        if need_t:
                            if not lo <= t <= hi:       # None raises: not ours either
                                raise ValueError
                        elif t is not None and (need_t is False or not lo <= t <= hi):
                            raise ValueError
                    except _NOT_OURS:
                        _count_foreign(p.foreign, line, records[body + 22:nxt])
                    else:
                        if errors is not None:   # a recording that keeps the line's own errors
                            _line_errors(p, line, len(data), msg.get("line_errors"))
                        if pairs:
                            append((_LOG_TIME.unpack_from(records, body + 6)[0], Chunk(line, data, t)))
                        else:
                            append(Chunk(line, data, t))
            elif (op == OP_CHANNEL or op == OP_SCHEMA) and (damage := _define(p, op, records[body:nxt])):
                return pos, damage
            pos = nxt
    except struct.error:
        return pos, "a record header cut short"
    return None


def _define(p: _Pass, op: int, body: bytes) -> str | None:
    """Learn a Channel or Schema record's definition; what is damaged in it, if it is."""
    try:
        record = parse(op, body)
    except Damaged as e:
        return str(e)
    if isinstance(record, Channel):
        _channel(p, record)
    elif isinstance(record, Schema) and _data_is_base64(record):
        p.base64.add(record.id)
    return None


def _channel(p: _Pass, channel: Channel) -> None:
    p.encodings[channel.id] = channel.message_encoding
    line = p.lines.get(channel.topic)
    if line is None:
        p.wanted.pop(channel.id, None)   # an id given to another topic
    elif line == _BATCHED:   # always base64 (lean recordings came after hex)
        p.wanted[channel.id] = (line, _from_base64)
        said = str(channel.metadata.get("lines", "")).split(",") if isinstance(channel.metadata, dict) else []
        p.batched_lines.update([x for x in said if x in _LINES] or (LINE_A, LINE_B))   # unsaid: a pair
    else:
        p.wanted[channel.id] = (line, _from_base64 if channel.schema_id in p.base64 else bytes.fromhex)


def _line_errors(p: _Pass, line: str, size: int, entries: Any) -> None:
    """Count a raw chunk of ``size`` bytes on ``line``, and tell its line errors
    (its ``line_errors``, if any) at their offsets on the line."""
    base = p.sent.get(line, 0)
    p.sent[line] = base + size
    if entries:
        assert p.errors is not None   # counted only for a recording that keeps them
        p.errors.extend(faults_of(line, base, size, entries))


def _read_reads_message(records: bytes, body: int, end: int, p: _Pass, out: list) -> None:
    """A lean recording's reads message (its record's body from ``body`` to
    ``end`` in ``records``): its chunks appended to ``out``, or it is counted as
    not ours."""
    payload = records[body + MESSAGE_HEAD:end]
    try:
        _read_batch(payload, _LOG_TIME.unpack_from(records, body + 6)[0], p, out)
    except _NOT_OURS:
        _count_foreign(p.foreign, _BATCHED, payload)


def _read_batch(payload: bytes, log_time: int, p: _Pass, out: list) -> None:
    """Append the chunks of a lean recording's reads message to ``out``, in its
    order (of ``p.only``'s line only); raises one of ``_NOT_OURS`` (appending
    nothing) when the message does not read whole as reads of this recording.
    With ``p.pairs``, each chunk's log time is the message's (its first read's)
    moved on by the read's wire time since the first read's, as the recorder
    computes log times."""
    reads = json_loads(payload)["reads"]
    if type(reads) is not list or not reads:
        raise ValueError
    need_t, only, pairs = p.need_t, p.only, p.pairs
    lo, hi = -MAX_T, MAX_T
    chunks: list = []
    append = chunks.append
    # (line, size, line errors) of each read kept
    counted: list[tuple[str, int, Any]] | None = [] if p.errors is not None else None
    t0 = reads[0].get("t")
    for read in reads:
        line = read["line"]
        if line not in _LINES:                        # an unhashable line raises TypeError: not ours
            raise ValueError
        data = _from_base64(read["data"])
        t = read.get("t")
        if need_t:
            if not lo <= t <= hi:
                raise ValueError
        elif t is not None and (need_t is False or not lo <= t <= hi):
            raise ValueError
        if only is not None and line != only:
            continue
        if counted is not None:
            counted.append((line, len(data), read.get("line_errors")))
        if pairs:
            at = log_time if t is None or t0 is None else log_time + round(t * 1e9) - round(t0 * 1e9)
            append((at, Chunk(line, data, t)))
        else:
            append(Chunk(line, data, t))
    out.extend(chunks)
    for line, size, entries in counted or ():
        _line_errors(p, line, size, entries)


def _from_base64(text: str) -> bytes:
    return a2b_base64(text, strict_mode=True)


def _data_is_base64(schema: Schema) -> bool:
    """Does a raw chunk schema give its bytes in base64 (``"contentEncoding":
    "base64"``, recordings since the Foxglove schemas) rather than hex (before)?"""
    if b"contentEncoding" not in schema.data:
        return False
    try:
        return json.loads(schema.data)["properties"]["data"]["contentEncoding"] == "base64"
    except (ValueError, TypeError, KeyError, RecursionError):
        return False


def _count_foreign(foreign: dict[str, list], line: str, payload: bytes) -> None:
    """Count a message on a raw topic that is not a raw chunk; keep the first."""
    seen = foreign.get(line)
    if seen is None:
        foreign[line] = [1, payload]
    else:
        seen[0] += 1


def _cut_chunk_records(body: bytes, encodings: dict[int, str]) -> bytes:
    """The records of a chunk cut short that read as written (see ``read_cut_chunk``)."""
    try:
        records = read_cut_chunk(body)
    except Damaged:
        return b""
    end, _messages, _why = intact_prefix(records, dict(encodings))
    return records[:end]


def _record(op: int, body: bytes) -> bytes:
    """A top-level record's bytes again, to be read like a chunk's content."""
    return RECORD.pack(op, len(body)) + body


def _json_object(payload: bytes) -> tuple[dict | None, str]:
    """A message's JSON object, or None and why it is none."""
    try:
        msg = json.loads(payload)
    except (ValueError, RecursionError):
        return None, "not JSON"
    if not isinstance(msg, dict):
        return None, f"JSON {type(msg).__name__}, not an object"
    return msg, ""


def _diagnose(payload: bytes, need_t: bool | None) -> str:
    """Why a message on a raw topic is not a gimbalscope raw chunk, in a few words
    (said for the first such message only)."""
    msg, why = _json_object(payload)
    if msg is None:
        return why
    data = msg.get("data")
    if not isinstance(data, str):
        return "no 'data' field" if data is None else "'data' is not a string"
    try:
        bytes.fromhex(data)
    except ValueError:
        try:
            _from_base64(data)
        except ValueError:
            return "'data' is neither hex nor base64"
    t = msg.get("t")
    if t is not None and (isinstance(t, bool) or not isinstance(t, (int, float))):
        return "'t' is not a number"
    if t is not None and not -MAX_T <= t <= MAX_T:
        return f"'t' is {t!r}, out of range"
    if need_t and t is None:
        return "no time ('t') in a recording with time"
    if need_t is False and t is not None:
        return "a time ('t') in a recording without time"
    return "not a gimbalscope raw chunk"


def _diagnose_reads(payload: bytes, need_t: bool | None) -> str:
    """Why a message on the reads topic is not a gimbalscope reads message."""
    msg, why = _json_object(payload)
    if msg is None:
        return why
    reads = msg.get("reads")
    if not isinstance(reads, list) or not reads:
        return "no 'reads' list" if reads is None else "'reads' is not a list of reads"
    for k, read in enumerate(reads):
        if not isinstance(read, dict):
            return f"read {k} is not an object"
        if read.get("line") not in _LINES:
            return f"read {k} has no line A, B or AB"
        raw = {key: value for key, value in read.items() if key != "line"}
        why = _diagnose(json.dumps(raw).encode(), need_t) if isinstance(raw.get("data"), str) else (
            "no 'data' field" if "data" not in raw else "'data' is not a string")
        if why != "not a gimbalscope raw chunk":
            return f"read {k}: {why}"
    return "not gimbalscope reads"


def _read_in_process(path: str, label: str, topics: list[str], timed: bool, faults: bool,
                     sender: worker_process.Sender) -> None:
    """The reader process (analyzer/worker_process.py): raw chunks as lists of
    (line, data, t) tuples, after each list the file's bytes read so far as
    ("progress", n), warnings as ("warn", text), a failure as ("error", text),
    then None. With ``faults``, the chunks' line errors as ("faults",
    [LineFault…]) before the list holding their chunks."""
    errors: list[LineFault] | None = [] if faults else None
    told = 0

    def send_chunks(batch: list[tuple]) -> None:
        nonlocal told
        if errors is not None and told < len(errors):
            sender.send(("faults", errors[told:]))
            told = len(errors)
        sender.send(batch)

    def note(kind: str, text: str) -> None:
        sender.send(("warn", _problem(label, kind, text)))   # said once by the source

    try:
        batch: list[tuple] = []
        for chunks in _raw_batches(path, label, _Pass(topics, False, timed, errors=errors), note):
            batch.extend(map(tuple, chunks))
            if len(batch) >= _BATCH:
                send_chunks(batch)
                sender.send(("progress", READS.done()))
                batch = []
        send_chunks(batch)
        sender.send(("progress", os.path.getsize(path)))   # read to its end (the summary needs no reading)
        sender.send(None)
    except CaptureError as e:
        sender.send(("error", str(e)))
    except BrokenPipeError:
        pass   # the source went away
    except Exception as e:   # noqa: BLE001 - said in one line by the source
        sender.send(("error", f"{label}: cannot read: {type(e).__name__}: {e}"))
