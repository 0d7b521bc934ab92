"""The MCAP recorder: a sink for raw chunks and decoded events.

Writes raw byte chunks per line, decoded events, transactions (a command with
its answers) and a foxglove.Log message per anomaly, into zstd-compressed
chunks. With ``flush_interval`` set (live taps), the chunk in progress is closed
and written at least that often, so a killed tap loses at most about that much;
such a file has no summary and still reads (``analyzer.sources.mcapfile``).

Metadata records the recording only knows as it goes (``records``: the line
reports of a logic capture, analyzer/formats/mcap_lines.py) are written when the
recording closes, and by a live one also as it flushes, at most every
``RECORDS_EVERY`` seconds and only when they changed: the latest one written is
the one that counts, so a killed tap's recording keeps them as of then. MCAP
checkers flag two metadata records of one name, so a record's n-th write from
the second on is named ``NAME.n`` (``gimbalscope.lines.2``).

The messages, their topics and their times are built by ``messages.Messages``,
the same as a live Foxglove server's; this module writes them.

Write errors (a full disk) go one of two ways. Without ``on_error`` (convert,
writing into a temporary file) they raise ``RecordingError``, one line, and the
caller throws the file away. With ``on_error`` (live taps) the recorder stops,
closes the file as well as it can, says so once through ``on_error``, and every
later call does nothing: the tap goes on. "As well as it can": a record cut short
is cut off, then a data end and footer are added if there is room (a whole MCAP
without summary); without room the file ends at its last whole record, which
readers take up to its last complete chunk. A recording that kept no message is
removed: nothing useful was written.
"""

from __future__ import annotations

import errno
import os
import stat
import time
from collections.abc import Callable
from typing import IO, Any, Self

from mcap.data_stream import RecordBuilder
from mcap.records import DataEnd, Footer
from mcap.writer import MCAP0_MAGIC, IndexType

from dissectors.event import Event

from ..errors import RecordingError
from ..formats import mcap_schemas as S
from ..formats.marks import Mark
from ..formats.mcap_messages import Messages, fixed_topics
from ..formats.store_ipc import MEDIA_TYPE, VERSION
from ..lines import Chunk
from ..outfile import reason, show
from ..output import dumps
from ..words import counted
from .mcap_columns import ColumnBatches, RecordingTally
from .mcap_internals import chunk_writer

# The recording's layout (docs/foxglove.md, "Size"): chunks of 1 MiB compressed
# with zstd at level 9 (mcap_internals.ZSTD_LEVEL), with every index. Level 9
# makes the chunks a fifth smaller than the writer's default level (3) for about
# 4 µs more per event (a sixth of what recording an event costs). The message
# indexes (16 bytes a message, uncompressed) are a third of the file, but they
# stay: the Foxglove app's indexed reader takes a chunk's messages from them (a
# chunk without them shows nothing), and readers that seek by time (the app,
# the official Go library) need the chunk index. A chunk that zstd does not
# make smaller is stored as it is (mcap_internals.py).
CHUNK_SIZE = 1 << 20
INDEXES = IndexType.ALL

RECORDS_EVERY = 10.0   # seconds between a live recording's writes of its changing metadata records


def _tail() -> bytes:
    """What closes an MCAP that has no summary: data end, footer, magic."""
    b = RecordBuilder()
    DataEnd(0).write(b)
    Footer(0, 0, 0).write(b)
    return b.end() + MCAP0_MAGIC


class _Output:
    """The stream the MCAP writer writes to, counting the bytes that reached the
    file whole (``good``): after a failed write, what follows ``good`` is a record
    cut short. A path is opened unbuffered (no buffer left to fail again at
    close); an open file (convert's temporary file) is written through."""

    def __init__(self, path: str, file: IO[bytes] | None) -> None:
        self.file = file
        self.fd = file.fileno() if file is not None else os.open(
            path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o666)
        self.good = file.tell() if file is not None else 0

    @property
    def own(self) -> bool:
        return self.file is None

    def write(self, data: bytes) -> int:
        if self.file is not None:
            self.file.write(data)
        else:
            view = memoryview(data)
            while view:
                n = os.write(self.fd, view)   # a disk filling up takes part, then fails
                if n <= 0:
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
                view = view[n:]
        self.good += len(data)
        return len(data)

    def tell(self) -> int:
        return self.good

    def flush(self) -> None:
        if self.file is not None:
            self.file.flush()

    def sync(self) -> None:
        """Push to the disk; a target that is no disk file (``/dev/null``) cannot sync."""
        self.flush()
        try:
            os.fsync(self.fd)
        except OSError as e:
            if e.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EROFS):
                raise

    def restart(self) -> None:
        """Empty the file, to write it again from its first byte."""
        if self.file is not None:
            self.file.flush()
            self.file.seek(0)
            self.file.truncate()
        else:
            os.ftruncate(self.fd, 0)
            os.lseek(self.fd, 0, os.SEEK_SET)
        self.good = 0

    def write_at(self, pos: int, data: bytes) -> None:
        """Cut the file at ``pos`` and write ``data`` there (own files only)."""
        os.ftruncate(self.fd, pos)
        os.lseek(self.fd, pos, os.SEEK_SET)
        self.good = pos
        self.write(data)

    def close(self) -> None:
        if self.own and self.fd >= 0:
            fd, self.fd = self.fd, -1
            os.close(fd)


class McapRecorder:
    """Records to ``path``, or into ``file`` (an open binary file the caller owns
    and closes; ``path`` then only names it in messages). See the module doc for
    ``on_error``."""

    def __init__(self, path: str, *, metadata: dict[str, str], start_time: float | None = None,
                 flush_interval: float | None = None, clock: Callable[[], float] = time.monotonic,
                 lines: tuple[str, ...] = ("A", "B"), file: IO[bytes] | None = None,
                 on_error: Callable[[str], None] | None = None, wire_byte_time: float | None = None,
                 lean: bool = False, records: Callable[[], dict[str, dict[str, str]]] | None = None,
                 columns: bool = True, tally: RecordingTally | None = None, ack_timeout: float = 0.5) -> None:
        self.path = path
        self.ack_timeout = ack_timeout   # the tap's: the kept doctor's rules judge by it
        # docs/mcap.md, "Stored columns": a lean recording carries none (they would
        # add half its size again); reading it decodes, as before
        self.columns = columns and not lean
        # what the columns' record says of the whole recording (parts share one: each says it so far)
        self._tally = tally
        # metadata records known as the recording goes (module doc): name → values, as of now
        self._records = records
        self._records_due = 0.0
        self.lean = lean   # docs/mcap.md, "Lean recordings": no /events, raw reads batched
        self._flushing = False
        self.wire_byte_time = wire_byte_time   # untimed input: seconds per byte offset
        self.on_error = on_error
        self.failed: str | None = None   # why the recording stopped early
        self.removed = False             # stopped with nothing kept: the file is gone
        self.messages = 0                # in the recording (after a failure: those kept)
        self.message_bytes = 0           # before compression
        self._kept = 0                   # messages whose chunk reached the file whole
        self._closed = False
        try:
            self._out = _Output(path, file)
        except OSError as e:
            raise RecordingError(f"{show(path)}: cannot write: {reason(e)}", reason(e)) from None
        try:
            self._start_args = (metadata, start_time, lines)
            self._start(*self._start_args)
        except OSError as e:   # the disk was full from the start: nothing useful written
            self._remove()
            raise RecordingError(f"{show(path)}: cannot write: {reason(e)}", reason(e)) from None
        self._flush_interval = flush_interval
        self._clock = clock
        self._last_flush = clock()

    def _start(self, metadata: dict[str, str], start_time: float | None, lines: tuple[str, ...],
               chunked: bool = True) -> None:
        self._writer = chunk_writer(self._out, chunk_size=CHUNK_SIZE, index_types=INDEXES, use_chunking=chunked)
        self._writer.start(profile=S.PROFILE, library="gimbalscope")
        self._messages = Messages(self._emit, start_time=start_time, wire_byte_time=self.wire_byte_time,
                                  lean=self.lean)
        self.start_ns = self._messages.start_ns
        schemas = S.LEAN_SCHEMAS if self.lean else S.SCHEMAS
        self._schemas = {key: self._writer.register_schema(schema["title"], "jsonschema", S.encoded(schema))
                         for key, schema in schemas.items()}
        self._channels: dict[str, int] = {}
        # the fixed topics exist from the start, also in a recording without messages;
        # a device's position topic when it is first seen
        for topic, key, channel_metadata in fixed_topics(lines, self.lean):
            self._channel(topic, key, channel_metadata)
        self._columns: ColumnBatches | None = None
        if self.columns:   # schemaless: the Arrow IPC stream carries its schema
            self._columns_channel = self._writer.register_channel(
                S.COLUMNS_TOPIC, S.COLUMNS_ENCODING, 0, metadata={"media_type": MEDIA_TYPE, "version": VERSION})
            if self._tally is None:
                self._tally = RecordingTally(lines, self.ack_timeout)
            self._columns = ColumnBatches(self._write_columns, self._tally)
        self._lines = lines
        self._records_written: dict[str, dict[str, str]] = {}   # by name: the values last written
        self._records_count: dict[str, int] = {}                 # and how many times
        if metadata:   # written first, so a killed recording still says what it is
            self._writer.add_metadata(S.METADATA_NAME, encodable(metadata))

    def _channel(self, topic: str, key: str, metadata: dict[str, str] | None = None) -> int:
        channel = self._channels[topic] = self._writer.register_channel(topic, "json", self._schemas[key],
                                                                        metadata=metadata or {})
        return channel

    # ---------------------------------------------------------------- input
    def raw(self, chunk: Chunk, offset: int, line_errors: list[dict] | None = None) -> None:
        """Record bytes read from a line (``offset`` of their first byte), with the
        receiver's own errors on them (analyzer/formats/mcap_lines.py)."""
        if not self._closed:
            self._messages.raw(chunk, offset, line_errors)
            if self._columns is not None:
                self._columns.raw(chunk)
            if self.lean:   # reads wait in a batch: flush on time here too
                self._maybe_flush()

    def end_marker(self, t: float | None) -> None:
        """Record that time ran on to ``t`` with nothing more on the wire (an empty
        raw chunk), so decoding the recording expires the same timeouts live did."""
        if not self._closed:
            self._messages.end_marker(t, self._lines[0] if self._lines else "A")

    def note(self, message: str, t: float | None, level: int = S.WARNING) -> None:
        """A tap's own message (a port lost and back, the skew estimate) on /log."""
        if not self._closed:
            self._messages.note(message, t, level)

    def mark(self, mark: Mark) -> None:
        """An event marked (or unmarked) by whoever watches the tap, on /marks."""
        if not self._closed:
            self._messages.mark(mark.number, mark.t, mark.note, mark.removed)

    def event(self, ev: Event) -> None:
        if not self._closed:
            self._messages.event(ev)
            if self._columns is not None:
                self._columns.add(ev, self._log_time)

    def _log_time(self, ev: Event) -> int:
        return self._messages.time_ns(ev.t, ev.number, ev.offset)

    def close(self, metadata: dict[str, str] | None = None) -> None:
        """Finish the file: summary, statistics, and ``metadata`` when the
        recording only knows it at the end (conversions). Safe to call twice."""
        if self._closed:
            return
        self._messages.finish()
        self.flush()   # the last chunk first: a failure after it loses only the summary
        if self._closed:
            return
        data_end = before = self._out.good
        columns = self._columns.record(part="part" in self._start_args[0]) if self._columns is not None else None
        try:
            if self.messages == 0:
                self._write_empty()
                data_end = before = self._out.good
            if metadata:
                self._writer.add_metadata(S.METADATA_NAME, encodable(metadata))
                data_end = self._out.good
            if columns is not None:   # last: a recording cut before it has columns that may be incomplete
                self._writer.add_metadata(S.COLUMNS_RECORD, columns)
                data_end = self._out.good
            self._write_records()
            data_end = self._out.good
            self._writer.finish()
            self._out.sync()
        except OSError as e:
            self._fail(e, before, self.messages, cut_at=data_end)
            return
        self._closed = True
        self._out.close()

    def _write_empty(self) -> None:
        """A recording without a single message (an empty capture) is written again
        without chunks: the MCAP writer drops a chunk that holds no message, and with
        it the schema and channel records, which readers then miss. Unchunked, they
        stand in the data section, and the file still says which lines it had."""
        self._out.restart()
        self._start(*self._start_args, chunked=False)

    def summary(self) -> str:
        """What a finished recording says: how many messages, where."""
        return f"recorded {counted(self.messages, 'message')} to {show(self.path)}"

    @property
    def kept(self) -> int:
        """Messages on disk in whole chunks so far: what the file holds if the tap is
        killed now, and what a failed write leaves (the count its stop line gives)."""
        return self._kept

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------- internals
    def _emit(self, topic: str, key: str, ts: int, obj: dict) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            before = self._out.good
            try:
                channel = self._channel(topic, key)
            except OSError as e:   # unchunked (an empty recording) writes channels at once
                self._fail(e, before, self.messages)
                return
        self._write(channel, ts, obj)

    def _write(self, channel: int, ts: int, obj: dict) -> None:
        if not self._closed:
            self._write_data(channel, ts, dumps(obj))

    def _write_columns(self, data: bytes, ts: int) -> None:
        """A message of stored columns, in a chunk of its own: a reader that wants
        only the columns decompresses only their chunks."""
        if self._closed:
            return
        before = self._out.good
        try:
            self._writer.flush()   # the other topics' chunk in progress
        except OSError as e:
            self._fail(e, before, self.messages)
            return
        self._kept = self.messages
        self._write_data(self._columns_channel, ts, data)
        if self._closed:
            return
        before = self._out.good
        try:
            self._writer.flush()
        except OSError as e:
            self._fail(e, before, self.messages)
            return
        self._kept = self.messages

    def _write_data(self, channel: int, ts: int, data: bytes) -> None:
        before = self._out.good
        try:
            self._writer.add_message(channel, log_time=ts, data=data, publish_time=ts)
        except OSError as e:   # a full chunk was being written: it holds this message too
            self._fail(e, before, self.messages + 1)
            return
        self.messages += 1
        self.message_bytes += len(data)
        if self._out.good != before:   # a full chunk went out, this message in it
            self._kept = self.messages
        self._maybe_flush()

    def _maybe_flush(self) -> None:
        if self._flush_interval is not None and not self._flushing \
                and self._clock() - self._last_flush >= self._flush_interval:
            self.flush()

    def flush(self) -> None:
        """Close the chunk in progress and push it to disk (a killed tap keeps it);
        a lean recording's batch of reads in progress goes into it first."""
        if self._closed:
            return
        self._flushing = True
        try:
            if self.lean:
                self._messages.flush_reads()
            if self._columns is not None and not self._closed:   # at most one flush behind the raw bytes
                self._columns.flush()
        finally:
            self._flushing = False
        if self._closed:   # writing the batch failed
            return
        before = self._out.good
        try:
            self._writer.flush()
            self._out.sync()
        except OSError as e:
            self._fail(e, before, self.messages)
            return
        self._kept = self.messages
        self._last_flush = self._clock()
        if self._records is not None and self._last_flush >= self._records_due:
            self._records_due = self._last_flush + RECORDS_EVERY
            before = self._out.good
            try:
                if self._write_records():
                    self._out.sync()
            except OSError as e:
                self._fail(e, before, self.messages)

    def _write_records(self) -> bool:
        """The metadata records known so far (module doc) that changed since
        they were last written; whether any was."""
        if self._records is None:
            return False
        wrote = False
        for name, values in self._records().items():
            values = encodable(values)
            if self._records_written.get(name) != values:
                n = self._records_count.get(name, 0) + 1
                self._writer.add_metadata(name if n == 1 else f"{name}.{n}", values)
                self._records_written[name], self._records_count[name] = values, n
                wrote = True
        return wrote

    def _fail(self, e: OSError, before: int, pending: int, cut_at: int | None = None) -> None:
        """A write failed: stop. ``pending`` messages were handed to the writer; if
        anything reached the file whole since ``before``, their chunk did."""
        if self._out.good > before:
            self._kept = max(self._kept, pending)
        self.failed = reason(e)
        self.messages = self._kept
        self._closed = True
        if self.on_error is None:
            raise RecordingError(f"{show(self.path)}: cannot write: {self.failed}", self.failed) from None
        self._salvage(self._out.good if cut_at is None else cut_at)
        kept = "nothing kept, file removed" if self.removed else \
            f"{counted(self.messages, 'message')} kept"
        self.on_error(f"{show(self.path)}: recording stopped: {self.failed} ({kept})")

    def _salvage(self, cut_at: int) -> None:
        """Close a live recording after a failed write (module doc)."""
        if not self._out.own:
            return
        if self._kept == 0:
            self._remove()
            return
        try:
            self._out.write_at(cut_at, _tail())
            self._out.sync()
        except OSError:
            try:   # no room for the tail: end at the last whole record
                os.ftruncate(self._out.fd, cut_at)
            except OSError:
                pass
        try:
            self._out.close()
        except OSError:
            pass

    def _remove(self) -> None:
        """Remove a file this recorder made that holds nothing useful."""
        if not self._out.own:
            return
        try:
            regular = stat.S_ISREG(os.fstat(self._out.fd).st_mode)
            self._out.close()
            if regular:   # never a device or anything else the path might name
                os.unlink(self.path)
                self.removed = True
        except OSError:
            pass


def encodable(metadata: dict[str, str]) -> dict[str, str]:
    """MCAP metadata strings must be UTF-8: names the OS gave as undecodable bytes
    (surrogate escapes) are stored as ``\\xNN``."""
    return {show(k): show(v) for k, v in metadata.items()}


def part_path(path: str, part: int) -> str:
    """The file of part ``part`` (from 1) of a recording in parts named ``path``:
    ``tap.mcap`` → ``tap-0001.mcap`` (``tap`` → ``tap-0001.mcap``)."""
    base, ext = os.path.splitext(path)
    return f"{base}-{part:04d}{ext or '.mcap'}"


class RotatingRecorder:
    """Long unattended captures: a new numbered file (``name-0001.mcap``, …) when
    the current one holds ``max_bytes`` of messages (counted before compression:
    the writer keeps a chunk in memory until it flushes) or is ``max_seconds``
    old; each part is a whole MCAP with its own metadata (``part``). A write
    failure stops the whole recording (no new parts on a full disk) and goes to
    ``on_error`` once, as with ``McapRecorder``."""

    def __init__(self, path: str, *, max_bytes: int | None = None, max_seconds: float | None = None,
                 clock: Callable[[], float] = time.monotonic,
                 on_error: Callable[[str], None] | None = None, **kw: Any) -> None:
        self.path = path
        self.max_bytes, self.max_seconds, self.clock = max_bytes, max_seconds, clock
        self.on_error = on_error
        self.failed: str | None = None
        self.kw = kw
        self.part = 0
        self.paths: list[str] = []
        self.messages = 0
        self.current: McapRecorder | None = None
        self.tally = RecordingTally(kw.get("lines", ("A", "B")), kw.get("ack_timeout", 0.5))   # of every part so far (McapRecorder)
        self._open()

    def _open(self) -> None:
        self.part += 1
        path = part_path(self.path, self.part)
        kw = dict(self.kw)
        kw["metadata"] = {**kw.get("metadata", {}), "part": str(self.part)}
        kw["tally"] = self.tally
        try:
            self.current = McapRecorder(path, on_error=self._part_failed, **kw)
        except RecordingError as e:
            if self.part == 1:   # before the tap starts: the caller says it
                raise
            self.current = None
            self.failed = e.reason
            self._report(f"{show(path)}: recording stopped: {e.reason} ({self._kept()})")
            return
        self.paths.append(path)
        self.opened = self.clock()

    def update_metadata(self, **changes: str) -> None:
        """Parts opened from now on carry ``changes`` in their metadata (the link's
        rate changed: a part decoded alone must start at the new one)."""
        self.kw["metadata"] = {**self.kw.get("metadata", {}), **changes}

    def _kept(self) -> str:
        return f"{counted(self.messages, 'message')} kept in {counted(len(self.paths), 'file')}"

    def _part_failed(self, message: str) -> None:
        cur = self.current
        self.failed = cur.failed if cur is not None else "write error"
        if cur is not None and cur.removed:
            self.paths.remove(cur.path)
        self._report(message)

    def _report(self, message: str) -> None:
        if self.on_error is None:
            raise RecordingError(message, self.failed or "")
        self.on_error(message)

    def _maybe_rotate(self) -> None:
        cur = self.current
        if cur is None or self.failed:
            return
        too_big = self.max_bytes is not None and cur.message_bytes >= self.max_bytes
        too_old = self.max_seconds is not None and self.clock() - self.opened >= self.max_seconds
        if too_big or too_old:
            cur.close()
            self.messages += cur.messages
            self.current = None
            if not self.failed:
                self._open()

    def raw(self, chunk: Chunk, offset: int, line_errors: list[dict] | None = None) -> None:
        if self.current is not None:
            self.current.raw(chunk, offset, line_errors)
            self._maybe_rotate()

    def event(self, ev: Event) -> None:
        if self.current is not None:
            self.current.event(ev)

    def mark(self, mark: Mark) -> None:
        if self.current is not None:
            self.current.mark(mark)

    def end_marker(self, t: float | None) -> None:
        if self.current is not None:
            self.current.end_marker(t)

    def note(self, message: str, t: float | None, level: int = S.WARNING) -> None:
        if self.current is not None:
            self.current.note(message, t, level)

    def summary(self) -> str:
        """What a finished recording says: how many messages, in which files."""
        return f"recorded {counted(self.messages, 'message')} to {', '.join(map(show, self.paths))}"

    def close(self, metadata: dict[str, str] | None = None) -> None:
        """Finish the current part; ``metadata`` as ``McapRecorder.close`` takes it, into that part."""
        cur = self.current
        if cur is not None:
            cur.close(metadata)   # still current: a failure here is reported against it
            self.messages += cur.messages
        self.current = None
