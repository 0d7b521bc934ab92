"""Walking an MCAP file without trusting it: recordings cut short by a killed
tap, files with a damaged chunk, files made by hand or by other tools.

Every length is checked before it is used: a record's against what remains of
the file (or of its chunk), a chunk's declared uncompressed size against a
ceiling and against what its compression can expand to. Nothing is allocated
because a file says so, and every problem is a ``Damaged`` with the byte offset.

Used by the MCAP capture source (``mcapfile``) and by ``gimbalscope recover``, so
both keep the same records of a damaged file.
"""

from __future__ import annotations

import json
import struct
import zlib
from collections.abc import Container, Iterator
from io import BytesIO
from typing import BinaryIO, NamedTuple

# lz4 and zstandard: dependencies of mcap's reader and writer
import lz4.frame as lz4frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile
from mcap.records import Attachment, Channel, Header, McapRecord, Message, Metadata, Schema

from ..words import counted

MAGIC = b"\x89MCAP0\r\n"
RECORD = struct.Struct("<BQ")             # opcode u8, body length u64
RECORD_HEAD = RECORD.size                 # 9

OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
OP_CHUNK_INDEX, OP_ATTACHMENT, OP_METADATA, OP_DATA_END = 0x08, 0x09, 0x0C, 0x0F
OP_NAMES = {0x01: "Header", 0x02: "Footer", 0x03: "Schema", 0x04: "Channel", 0x05: "Message", 0x06: "Chunk",
            0x07: "MessageIndex", 0x08: "ChunkIndex", 0x09: "Attachment", 0x0A: "AttachmentIndex",
            0x0B: "Statistics", 0x0C: "Metadata", 0x0D: "MetadataIndex", 0x0E: "SummaryOffset", 0x0F: "DataEnd"}

MESSAGE_HEAD = 22                         # channel u16, sequence u32, log and publish times u64
_CHUNK_HEAD = struct.Struct("<QQQII")     # start and end times, uncompressed size, CRC, compression length
_U64 = struct.Struct("<Q")
# a ChunkIndex's fields before its message index offsets: start and end times, the
# chunk's start offset and length, the offsets' byte length; then (channel u16, offset u64) each
_CHUNK_INDEX_HEAD = struct.Struct("<QQQQI")
_INDEX_OFFSET = struct.Struct("<HQ")
_FOOTER_BODY = 20                         # summary start u64, summary offset start u64, summary CRC u32
_FOOTER_SIZE = RECORD_HEAD + _FOOTER_BODY + len(MAGIC)

# A chunk may declare at most this much uncompressed data (real writers use 1-8
# MiB; a declared 2^60 is damage, not a reason to allocate) ...
MAX_CHUNK_BYTES = 1 << 30
# ... and no more than its compression can give: zstd's best case is an RLE block,
# 4 bytes for 128 KiB; an LZ4 sequence adds at most 255 bytes per input byte.
_EXPANSION = {"zstd": 1 << 15, "lz4": 256, "": 1}
_SLACK = 1 << 16   # frame headers and the like


class Damaged(Exception):
    """A record that cannot be read as written; the message says what (the caller
    adds where)."""


def op_name(op: int) -> str:
    return OP_NAMES.get(op, f"opcode 0x{op:02x}")


class _Exact(ReadDataStream):
    """mcap's record parsers over a record's bytes, where a field running past the
    end is an error (the library returns what is there, so a cut string reads as
    a shorter one)."""

    def read(self, length: int) -> bytes:
        data = super().read(length)
        if len(data) != length:
            raise EndOfFile()
        return data


_PARSERS = {OP_HEADER: Header.read, OP_SCHEMA: Schema.read, OP_CHANNEL: Channel.read,
            OP_METADATA: Metadata.read, OP_ATTACHMENT: Attachment.read}


def parse(op: int, body: bytes) -> McapRecord:
    """The mcap record in ``body`` (Header, Schema, Channel, Message, Metadata,
    Attachment); every field must fit in the body and every string be UTF-8."""
    stream = _Exact(BytesIO(body))
    try:
        if op == OP_MESSAGE:
            if len(body) < MESSAGE_HEAD:
                raise EndOfFile()
            return Message.read(stream, len(body))
        return _PARSERS[op](stream)
    except (EndOfFile, struct.error):
        raise Damaged(f"a {op_name(op)} record whose fields run past its end") from None
    except UnicodeDecodeError:
        raise Damaged(f"a {op_name(op)} record with text that is not UTF-8") from None


class Walk:
    """The top-level records of an MCAP file in order, up to its DataEnd record
    (the summary after it repeats what a reader needs) or its Footer.

    ``records(wanted)`` yields ``(offset, opcode, body)`` for the records with
    opcodes in ``wanted``; the others are skipped by seeking, never read. When the
    walk stops early, ``stop`` says where and why, and a wanted Chunk record cut
    short by the end of the file is in ``tail`` (its first part may still read).
    """

    def __init__(self, f: BinaryIO, size: int) -> None:
        self.f, self.size = f, size
        self.stop: str | None = None     # why the records ended before the DataEnd or Footer
        self.tail: tuple[int, bytes] | None = None   # (offset, what there is) of a Chunk record cut short
        self.lost = False                # the cut went through a record of a wanted kind

    def records(self, wanted: Container[int]) -> Iterator[tuple[int, int, bytes]]:
        f, size = self.f, self.size
        pos = len(MAGIC)
        f.seek(pos)
        while True:
            head = f.read(RECORD_HEAD)
            if len(head) < RECORD_HEAD:
                self.stop = (f"no summary and footer after byte {pos}" if not head else
                             f"the {op_name(head[0])} record header at byte {pos} cut short: {len(head)} of "
                             f"{RECORD_HEAD} bytes")
                self.lost = bool(head) and head[0] in wanted   # its first byte is the opcode
                return
            op, length = RECORD.unpack(head)
            start = pos + RECORD_HEAD
            if length > size - start:
                self.stop = (f"the {op_name(op)} record at byte {pos} claims {counted(length, 'byte')} but only "
                             f"{size - start} remain")
                self.lost = op in wanted
                if op == OP_CHUNK and op in wanted:
                    self.tail = (pos, f.read(size - start))
                return
            if op == OP_FOOTER:
                return
            if op == OP_DATA_END:
                if _footer(f, size) is None:   # the data is whole; the summary after it is not
                    self.stop = f"no summary and footer after the DataEnd record at byte {pos}"
                return
            if op in wanted:
                body = f.read(length)
                if len(body) != length:   # the file shrank while being read
                    self.stop = f"the {op_name(op)} record at byte {pos} is cut short"
                    self.lost = True
                    return
                yield pos, op, body
                f.seek(start + length)   # the caller may have read elsewhere meanwhile
            else:
                f.seek(length, 1)
            pos = start + length


def summary_records(f: BinaryIO, size: int, wanted: Container[int]) -> list[tuple[int, bytes]]:
    """``(opcode, body)`` of the summary section's records with opcodes in
    ``wanted`` (Schema and Channel records: a channel registered without any
    message is only there). Best effort: a missing or damaged summary gives what
    could be read of it, or nothing."""
    start = _footer(f, size)
    end = size - _FOOTER_SIZE
    if start is None:
        return []
    if not len(MAGIC) <= start < end:
        return []
    found = []
    f.seek(start)
    pos = start
    while pos + RECORD_HEAD <= end:
        op, length = RECORD.unpack(f.read(RECORD_HEAD))
        pos += RECORD_HEAD
        if length > end - pos:
            break
        if op in wanted:
            found.append((op, f.read(length)))
        else:
            f.seek(length, 1)
        pos += length
    return found


class ChunkPlace(NamedTuple):
    """Where a chunk is (its record's start offset and length) and the channels it
    has messages of, as its ChunkIndex record says."""
    offset: int
    length: int
    channels: set[int]


def chunk_channels(body: bytes) -> ChunkPlace:
    """A ChunkIndex record's chunk place and the channels it has messages of: what
    a reader needs to pass over a chunk, or to go to it. Read from the record's
    leading fields alone: the mcap library's reader makes the whole record, a tenth
    of a second for the 6,000 chunks of ten million events, and opening a recording
    reads them all. Raises ``Damaged`` when they do not add up."""
    if len(body) < _CHUNK_INDEX_HEAD.size:
        raise Damaged(f"a chunk index of {len(body)} bytes")
    *_times, offset, length, size = _CHUNK_INDEX_HEAD.unpack_from(body)
    start = _CHUNK_INDEX_HEAD.size
    if size % _INDEX_OFFSET.size or size > len(body) - start:
        raise Damaged(f"a chunk index's message index offsets of {size} bytes")
    return ChunkPlace(offset, length, {channel for channel, _at in _INDEX_OFFSET.iter_unpack(body[start:start + size])})


def _footer(f: BinaryIO, size: int) -> int | None:
    """The summary's start offset from the file's Footer (0: no summary), or
    ``None`` when the file does not end with a Footer and the magic."""
    if size < len(MAGIC) + _FOOTER_SIZE:
        return None
    f.seek(size - _FOOTER_SIZE)
    tail = f.read(_FOOTER_SIZE)
    if len(tail) != _FOOTER_SIZE or tail[-len(MAGIC):] != MAGIC:
        return None
    op, length = RECORD.unpack_from(tail)
    if op != OP_FOOTER or length != _FOOTER_BODY:
        return None
    return _U64.unpack_from(tail, RECORD_HEAD)[0]


def read_chunk(body: bytes) -> tuple[bytes, bool]:
    """The records a Chunk record holds, decompressed, and whether they match the
    chunk's CRC (``True`` when it has none). Raises ``Damaged`` when they cannot
    be had."""
    size, crc, compression, data = chunk_parts(body, cut=False)
    records = _decompress(compression, data, size)
    if len(records) != size:
        raise Damaged(f"it decompresses to {counted(len(records), 'byte')}, not the {size} it declares")
    return records, crc == 0 or zlib.crc32(records) == crc


def read_cut_chunk(body: bytes) -> bytes:
    """The first part of the records of a Chunk record cut short by the end of the
    file: what its compressed bytes that are there decompress to (zstd and LZ4
    work in blocks, and every whole block decompresses). There is no CRC to check
    it against; ``intact_prefix`` keeps its records that read as written."""
    size, _crc, compression, data = chunk_parts(body, cut=True)
    limit = min(size, len(data) * _EXPANSION[compression] + _SLACK)
    if compression == "":
        return data[:limit]
    try:
        if compression == "zstd":
            reader = zstandard.ZstdDecompressor().stream_reader(BytesIO(data))
            parts, got = [], 0
            try:
                while got < limit:
                    part = reader.read(min(1 << 20, limit - got))
                    if not part:
                        break
                    parts.append(part)
                    got += len(part)
            except zstandard.ZstdError:
                pass   # the cut block, or damage: what came before it stands
            return b"".join(parts)
        if compression == "lz4":
            return lz4frame.LZ4FrameDecompressor().decompress(data, max_length=limit)
    except RuntimeError:   # lz4's errors
        pass
    return b""


def chunk_parts(body: bytes, cut: bool) -> tuple[int, int, str, bytes]:
    """A Chunk record's uncompressed size, CRC, compression and compressed data,
    each length checked; with ``cut``, the data is what the body holds of it."""
    if len(body) < _CHUNK_HEAD.size:
        raise Damaged(f"its header is cut short ({counted(len(body), 'byte')})")
    _start, _end, size, crc, name_len = _CHUNK_HEAD.unpack_from(body)
    pos = _CHUNK_HEAD.size
    if name_len > len(body) - pos - 8:
        raise Damaged(f"its compression name claims {counted(name_len, 'byte')}, more than the chunk holds")
    try:
        compression = body[pos:pos + name_len].decode("utf-8")
    except UnicodeDecodeError:
        raise Damaged("its compression name is not UTF-8") from None
    pos += name_len
    data_len = _U64.unpack_from(body, pos)[0]
    pos += 8
    if data_len > len(body) - pos and not cut:
        raise Damaged(f"its data claims {counted(data_len, 'byte')}, {len(body) - pos} remain")
    data = body[pos:pos + data_len]
    if compression not in _EXPANSION:
        raise Damaged(f"compression {compression!r} is not one gimbalscope reads (zstd, lz4, none)")
    if size > MAX_CHUNK_BYTES or size > data_len * _EXPANSION[compression] + _SLACK:
        raise Damaged(f"it declares {size} bytes uncompressed from {data_len} {compression or 'uncompressed'} "
                      "bytes")
    return size, crc, compression, data


def _decompress(compression: str, data: bytes, size: int) -> bytes:
    if compression == "":
        return data
    if compression == "zstd":
        try:
            # a frame that states its size is decompressed to that size, whatever
            # the limit: check it against the chunk's before allocating it
            framed = zstandard.frame_content_size(data)
            if framed not in (-1, size):
                raise Damaged(f"its zstd frame holds {counted(framed, 'byte')}, the chunk declares {size}")
            return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
        except zstandard.ZstdError as e:
            raise Damaged(f"zstd: {e}") from None
    try:
        return lz4frame.LZ4FrameDecompressor().decompress(data, max_length=size + 1)
    except RuntimeError as e:   # lz4's errors
        raise Damaged(f"lz4: {e}") from None


def intact_prefix(records: bytes, encodings: dict[int, str]) -> tuple[int, int, str | None]:
    """For a chunk whose CRC fails: how far its records read as written, message by
    message. Returns (end offset, messages before it, why it stops or ``None``).

    A record stops it when its fields do not fit, when a message's channel is
    unknown, or when a JSON channel's message is not JSON. ``encodings`` (channel
    id → message encoding) is updated with the chunk's channels before the stop.
    """
    pos, end, messages = 0, len(records), 0
    while pos < end:
        if end - pos < RECORD_HEAD:
            return pos, messages, f"a record header cut short at byte {pos} of the chunk"
        op, length = RECORD.unpack_from(records, pos)
        if length > end - pos - RECORD_HEAD:
            return pos, messages, f"a {op_name(op)} record at byte {pos} of the chunk that runs past its end"
        body = records[pos + RECORD_HEAD:pos + RECORD_HEAD + length]
        if op in (OP_CHANNEL, OP_SCHEMA, OP_MESSAGE):
            try:
                record = parse(op, body)
            except Damaged as e:
                return pos, messages, f"{e} at byte {pos} of the chunk"
            if isinstance(record, Channel):
                encodings[record.id] = record.message_encoding
            elif isinstance(record, Message):
                encoding = encodings.get(record.channel_id)
                if encoding is None:
                    return pos, messages, f"a message on unknown channel {record.channel_id} at byte {pos} of the chunk"
                if encoding == "json" and not _is_json(record.data):
                    return pos, messages, f"a JSON message that is not JSON at byte {pos} of the chunk"
                messages += 1
        pos += RECORD_HEAD + length
    return pos, messages, None


def _is_json(data: bytes) -> bool:
    try:
        json.loads(data)
    except (ValueError, RecursionError):
        return False
    return True
