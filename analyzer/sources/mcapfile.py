"""MCAP recordings as a capture source: the raw byte topics (``/serial/A/raw``,
``/serial/B/raw``, or ``/serial/AB/raw``) are read back and re-dissected, so a
newer dissector re-decodes an old recording.

A file from a killed tap has no summary section: it is read record by record up
to its last complete chunk, with a warning (``gimbalscope recover`` rewrites it).

Large files are read in a second process: decompressing and parsing the raw
messages cost as much as dissecting them, and a second core does it meanwhile
(re-dissection went from 42% to over 50% of raw-dump decode speed).
"""

from __future__ import annotations

import json
import os
import pickle
import struct
import subprocess
import sys
from functools import partial
from typing import Iterator

from io import BytesIO

from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Chunk as McapChunk, Message
from mcap.stream_reader import get_chunk_data_stream

try:
    from orjson import loads as json_loads
except ImportError:  # pragma: no cover
    json_loads = json.loads

from .base import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Source
from .files import open_input

RAW_TOPICS = {f"/serial/{line}/raw": line for line in (LINE_A, LINE_B, LINE_AB)}

# MCAP record layout inside a chunk (spec: opcode u8, length u64, body)
_RECORD = struct.Struct("<BQ")
_CHANNEL_HEAD = struct.Struct("<HHI")     # id, schema id, topic length
_MESSAGE_HEAD = 22                         # channel u16, sequence u32, log and publish times u64
_LOG_TIME = struct.Struct("<Q")            # at byte 6 of a message record
_OP_FOOTER, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 0x02, 0x04, 0x05, 0x06
_MAGIC_LEN = 8

READER_PROCESS_MIN = 8 << 20   # bytes: smaller files are read inline (a process costs ~0.1 s to start)
_BATCH = 4096                  # chunks per message from the reader process
_as_chunk = partial(tuple.__new__, Chunk)   # a (line, data, t) tuple as a Chunk, in C


class McapSource(Source):
    def __init__(self, path: str) -> None:
        super().__init__()
        self.path = path
        self.description = f"{path} (MCAP)"
        lines, timed, start = self._survey()
        self.lines = lines
        self.timed = timed
        self.start_time = start

    def _messages(self, topics: list[str], as_chunks: bool = False) -> Iterator:
        """(line, log time in ns, raw message) in file order, or with ``as_chunks``
        the ``Chunk`` each message holds; stops with a warning at a cut end.

        Records are stepped over by their opcode and length (MCAP's framing); the
        mcap library parses the ones needed (Channel, Message, Chunk) and
        decompresses the chunks. Inside a chunk, messages of other topics (events,
        transactions, log: most of a recording) and every index record are skipped
        by length, never parsed: the library's full reader parses them all, which
        made re-dissection 3-4 times slower."""
        wanted: dict[int, str] = {}
        unpack_record, unpack_channel = _RECORD.unpack_from, _CHANNEL_HEAD.unpack_from
        with open_input(self.path) as f:
            size_on_disk = os.fstat(f.fileno()).st_size
            f.read(_MAGIC_LEN)
            while True:
                head = f.read(9)
                if len(head) < 9:
                    self._cut("no footer" if not head else "a record header is cut short")
                    return
                op, length = unpack_record(head, 0)
                if op == _OP_FOOTER:
                    return
                if op not in (_OP_CHUNK, _OP_CHANNEL, _OP_MESSAGE):
                    if f.tell() + length > size_on_disk:
                        self._cut("the last record is cut short")
                        return
                    f.seek(length, 1)   # indexes, summary, metadata: not needed to re-dissect
                    continue
                body = f.read(length)
                if len(body) < length:
                    self._cut("the last record is cut short")
                    return
                try:
                    stream = ReadDataStream(BytesIO(body))
                    if op == _OP_CHANNEL:
                        record = Channel.read(stream)
                        if record.topic in topics:
                            wanted[record.id] = RAW_TOPICS[record.topic]
                        continue
                    if op == _OP_MESSAGE:
                        record = Message.read(stream, length)
                        line = wanted.get(record.channel_id)
                        if line is not None:
                            msg = json_loads(record.data)
                            yield (Chunk(line, bytes.fromhex(msg["data"]), msg.get("t")) if as_chunks
                                   else (line, record.log_time, msg))
                        continue
                    chunk_stream, size = get_chunk_data_stream(McapChunk.read(stream))
                    data = chunk_stream.read(size)
                except Exception as e:   # a damaged record: keep what came before it
                    self._cut(f"{type(e).__name__}: {e}")
                    return
                pos = 0
                while pos + 9 <= size:
                    op, length = unpack_record(data, pos)
                    pos += 9
                    if op == _OP_MESSAGE:
                        line = wanted.get(data[pos] | data[pos + 1] << 8)
                        if line is not None:
                            msg = json_loads(data[pos + _MESSAGE_HEAD:pos + length])
                            if as_chunks:   # the re-dissection path: one per read, kept lean
                                yield Chunk(line, bytes.fromhex(msg["data"]), msg.get("t"))
                            else:
                                yield line, _LOG_TIME.unpack_from(data, pos + 6)[0], msg
                    elif op == _OP_CHANNEL:
                        cid, _schema, n = unpack_channel(data, pos)
                        topic = data[pos + 8:pos + 8 + n].decode()
                        if topic in topics:
                            wanted[cid] = RAW_TOPICS[topic]
                    pos += length

    def _cut(self, why: str) -> None:
        self.warn(f"{self.path}: ends early ({why}); read up to the last complete chunk "
                  f"(a killed recording? 'gimbalscope recover' rewrites it)")

    def _survey(self) -> tuple[tuple[str, ...], bool, float | None]:
        """Which lines the recording has, whether it carries time, and when it
        started (the first raw message's log time less its wire time)."""
        lines: set[str] = set()
        first: tuple[int, float | None] | None = None
        for line, log_time, msg in self._messages(list(RAW_TOPICS)):
            if first is None:
                first = (log_time, msg.get("t"))
            lines.add(line)
            if len(lines) == 2 or LINE_AB in lines:
                break
        if first is None:
            raise CaptureError(f"{self.path}: MCAP file without gimbalscope raw topics "
                               f"({', '.join(RAW_TOPICS)})")
        log_time, t = first
        start = log_time / 1e9 - (t or 0)
        return ((LINE_AB,) if LINE_AB in lines else (LINE_A, LINE_B)), t is not None, start

    def chunks(self) -> Iterator[Chunk]:
        if os.path.getsize(self.path) < READER_PROCESS_MIN:
            return self._messages(list(RAW_TOPICS), as_chunks=True)
        return self._chunks_from_reader_process()

    def _chunks_from_reader_process(self) -> Iterator[Chunk]:
        # A fresh interpreter (not multiprocessing's fork: with the TUI's or a tap's
        # threads running, a forked child can inherit a lock one of them holds; and
        # its spawn re-imports the caller's main module).
        proc = subprocess.Popen([sys.executable, "-m", __name__, self.path], stdin=subprocess.DEVNULL,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        try:
            while True:
                try:
                    item = pickle.load(proc.stdout)
                except (EOFError, pickle.UnpicklingError):
                    raise CaptureError(f"{self.path}: the MCAP reader process ended unexpectedly") from None
                if item is None:
                    return
                if isinstance(item, tuple):       # ("warn" | "error", message)
                    if item[0] == "error":
                        raise CaptureError(item[1])
                    self.warn(item[1])
                    continue
                yield from map(_as_chunk, item)
        finally:
            if proc.poll() is None:
                proc.kill()   # the consumer stopped early (| head, quit)
            proc.stdout.close()
            proc.wait()

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        return self._messages([f"/serial/{line}/raw"], as_chunks=True)


def _read_in_child(path: str, out) -> None:
    """The reader process: raw chunks as pickled lists of (line, data, t) tuples,
    warnings as ("warn", text), a failure as ("error", text), then None."""
    def send(item) -> None:
        pickle.dump(item, out, protocol=pickle.HIGHEST_PROTOCOL)

    try:
        src = McapSource.__new__(McapSource)   # the survey already ran in the parent
        Source.__init__(src)
        src.path = path
        src.warn = lambda msg: send(("warn", msg))
        batch = []
        for chunk in src._messages(list(RAW_TOPICS), as_chunks=True):
            batch.append(tuple(chunk))
            if len(batch) >= _BATCH:
                send(batch)
                batch = []
        send(batch)
        send(None)
        out.flush()
    except CaptureError as e:
        send(("error", str(e)))
    except (BrokenPipeError, KeyboardInterrupt):
        pass   # the parent went away
    except Exception as e:   # noqa: BLE001 - said in one line by the parent
        send(("error", f"{path}: cannot read: {type(e).__name__}: {e}"))


if __name__ == "__main__":   # python -m analyzer.sources.mcapfile FILE: the reader process
    _read_in_child(sys.argv[1], sys.stdout.buffer)
    sys.stdout.buffer.flush()
