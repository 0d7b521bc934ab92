"""``gimbalscope recover``: rewrite an MCAP recording that was cut short (killed
tap, full disk) or damaged into a complete file holding everything intact.

The input is walked record by record without trusting its lengths
(analyzer/sources/mcapwalk.py). Every intact chunk and top-level record is kept;
a damaged chunk is skipped by its length and the walk goes on with the next
record; a chunk whose CRC fails but that decompresses is kept message by message
up to its first record that does not read as written. Channels and schemas
defined only in the summary (a complete file whose first chunk is damaged) are
taken from there. What was kept and dropped is said, with byte offsets.

The output is written beside its target and renamed at the end (analyzer/outfile):
never over the input, never half-written. A file with nothing to keep is an
error (exit 1) and leaves no output.
"""

from __future__ import annotations

import argparse
import os
import stat
import sys
from typing import BinaryIO

from mcap.records import Attachment, Channel, Header, McapRecord, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from ..formats.mcap_schemas import COLUMNS_RECORD
from ..listeners.progress import ReadProgress, wanted
from ..outfile import AtomicOutput, check_output, show, write_error
from ..sources.files import open_input
from ..sources.mcapwalk import (
    MAGIC,
    OP_ATTACHMENT,
    OP_CHANNEL,
    OP_CHUNK,
    OP_HEADER,
    OP_MESSAGE,
    OP_METADATA,
    OP_SCHEMA,
    RECORD,
    RECORD_HEAD,
    Damaged,
    Walk,
    intact_prefix,
    op_name,
    parse,
    read_chunk,
    read_cut_chunk,
    summary_records,
)
from ..words import counted
from .common import Subcommands, UsageError, add_quiet_arg, warn

EXIT_NOTHING_KEPT = 1
_TOP = frozenset((OP_HEADER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_METADATA, OP_ATTACHMENT))


def register(sub: Subcommands) -> None:
    p = sub.add_parser("recover", help="rewrite a cut-short or damaged MCAP recording whole",
                       description="Rewrite an MCAP recording that has no summary (a killed tap) or a damaged "
                                   "chunk into a complete file with everything intact.")
    p.add_argument("input", metavar="FILE.mcap")
    p.add_argument("-o", "--output", metavar="OUT.mcap", help="default: FILE.recovered.mcap")
    p.add_argument("--force", action="store_true", help="overwrite OUT.mcap if it exists")
    add_quiet_arg(p)
    p.set_defaults(run=run)


def default_output(src: str) -> str:
    return (src.removesuffix(".mcap")) + ".recovered.mcap"


def run(args: argparse.Namespace) -> int:
    src = args.input
    out = args.output or default_output(src)
    _check_input(src)
    check_output(out, [src], force=args.force)
    with open_input(src) as f, AtomicOutput(out) as target:
        size = os.fstat(f.fileno()).st_size
        salvage = Salvage(Writer(target.file, compression=CompressionType.ZSTD))
        try:
            with ReadProgress(enabled=wanted()):   # a bar of the input read, on a terminal, when it is long
                salvage.read(f, size)
            if salvage.messages:
                salvage.finish(src)
        except OSError as e:   # the output's disk is full, or the like
            raise write_error(out, e) from None
        problems = salvage.report()
        if not salvage.messages:   # one line, and no output: an empty file would only mislead
            target.discard()
            print(f"gimbalscope: error: {show(src)}: nothing to recover, no intact message"
                  + (f" ({'; '.join(problems)})" if problems else ""), file=sys.stderr)
            return EXIT_NOTHING_KEPT
        for line in problems:
            warn(f"{show(src)}: {line}")
    print(f"{show(out)}: {counted(salvage.messages, 'message')}")
    return 0


def _check_input(src: str) -> None:
    """An MCAP file that can be read at any offset (a pipe cannot)."""
    if src == "-":
        raise UsageError("recover reads a file, not standard input: save the recording to a file first")
    with open_input(src) as f:
        if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
            raise UsageError(f"{show(src)}: not a regular file: save the recording to a file first")
        if f.read(len(MAGIC)) != MAGIC:
            raise UsageError(f"{show(src)}: not an MCAP file (it does not start with the MCAP magic bytes)")


class Salvage:
    """Copies what reads as written from an MCAP file into ``writer``, and keeps
    count of what it dropped and why (``report``)."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.started = False
        self.profile = ""
        self.messages = 0
        self.cut: str | None = None                   # where and why the records ended early
        self.schemas: dict[int, Schema] = {}          # as defined in the input, by its ids
        self.channels: dict[int, Channel] = {}
        self.encodings: dict[int, str] = {}           # channel id → message encoding (CRC salvage)
        self.schema_ids: dict[int, int] = {}          # input id → output id, once registered
        self.channel_ids: dict[int, int] = {}
        # what was dropped, by kind: (count, first offset, first reason)
        self.dropped: dict[str, list] = {}
        self.partial: list[tuple[int, int, str | None]] = []   # CRC-failed chunks: (offset, messages kept, why)
        self.from_cut = 0                             # messages kept from a chunk cut short
        self.columns_record: dict[str, str] | None = None

    # ------------------------------------------------------------- reading
    def read(self, f: BinaryIO, size: int) -> None:
        # channels and schemas a damaged chunk defined may be in the summary too
        for op, body in summary_records(f, size, (OP_SCHEMA, OP_CHANNEL)):
            try:
                record = parse(op, body)
            except Damaged:
                continue   # the summary is a second copy: its damage costs nothing
            if isinstance(record, (Schema, Channel)):
                self._define(record)
        walk = Walk(f, size)
        for offset, op, body in walk.records(_TOP):
            if op == OP_CHUNK:
                self._chunk(offset, body)
                continue
            try:
                record = parse(op, body)
            except Damaged as e:
                self._drop("damaged record", offset, str(e))
                continue
            self._top(record)
        if walk.tail is not None:
            self._cut_chunk(*walk.tail)
        if walk.stop:
            self.cut = walk.stop

    def _top(self, record: McapRecord) -> None:
        if isinstance(record, Header):
            self.profile = record.profile
        elif isinstance(record, (Schema, Channel)):
            self._define(record)
        elif isinstance(record, Message):
            self._message(record, None)
        elif isinstance(record, Metadata) and record.name == COLUMNS_RECORD:
            self.columns_record = dict(record.metadata)   # kept only if nothing is lost (``finish``)
        elif isinstance(record, Metadata):
            self._start()
            self.writer.add_metadata(record.name, dict(record.metadata))
        elif isinstance(record, Attachment):
            self._start()
            self.writer.add_attachment(record.create_time, record.log_time, record.name, record.media_type,
                                       record.data)

    def _define(self, record: Schema | Channel) -> None:
        if isinstance(record, Schema):
            self.schemas.setdefault(record.id, record)
        else:
            self.channels.setdefault(record.id, record)
            self.encodings.setdefault(record.id, record.message_encoding)

    def _chunk(self, offset: int, body: bytes) -> None:
        try:
            records, crc_ok = read_chunk(body)
        except Damaged as e:
            self._drop("damaged chunk", offset, str(e))
            return
        end, why = len(records), None
        if not crc_ok:
            end, _count, why = intact_prefix(records, dict(self.encodings))
        before = self.messages
        stop = self._chunk_records(records, end, offset)
        if not crc_ok:
            self.partial.append((offset, self.messages - before, why))
        elif stop is not None:
            self._drop("damaged chunk", offset, f"{stop}; kept the {counted(self.messages - before, 'message')} before it")

    def _cut_chunk(self, offset: int, body: bytes) -> None:
        """A chunk cut short by the end of the file: the messages of its first part
        that read as written."""
        try:
            records = read_cut_chunk(body)
        except Damaged:
            return
        end, _count, _why = intact_prefix(records, dict(self.encodings))
        before = self.messages
        self._chunk_records(records, end, offset)
        self.from_cut = self.messages - before

    def _chunk_records(self, records: bytes, end: int, offset: int) -> str | None:
        """Copy the records of a chunk up to ``end``; returns why it stopped early."""
        pos = 0
        while pos < end:
            if end - pos < RECORD_HEAD:
                return f"a record header cut short at byte {pos} of its records"
            op, length = RECORD.unpack_from(records, pos)
            body = pos + RECORD_HEAD
            if length > end - body:
                return f"a {op_name(op)} record at byte {pos} of its records runs past their end"
            if op in (OP_SCHEMA, OP_CHANNEL, OP_MESSAGE):
                try:
                    record = parse(op, records[body:body + length])
                except Damaged as e:
                    return f"{e} at byte {pos} of its records"
                if isinstance(record, Message):
                    self._message(record, offset)
                elif isinstance(record, (Schema, Channel)):
                    self._define(record)
            pos = body + length
        return None

    # ------------------------------------------------------------- writing
    def _start(self) -> None:
        if not self.started:
            self.writer.start(profile=self.profile, library="gimbalscope recover")
            self.started = True

    def _message(self, record: Message, offset: int | None) -> None:
        channel = self._channel(record.channel_id)
        if channel is None:
            self._drop("message on an unknown channel", offset, f"channel {record.channel_id}")
            return
        self.writer.add_message(channel, record.log_time, record.data, record.publish_time, record.sequence)
        self.messages += 1

    def _channel(self, cid: int) -> int | None:
        """The output's id for the input's channel ``cid``, registered (with its
        schema) just before its first message: a channel registered with no message
        after it would be written only in the summary."""
        out = self.channel_ids.get(cid)
        if out is not None:
            return out
        channel = self.channels.get(cid)
        if channel is None:
            return None
        self._start()
        schema_id = 0
        schema = self.schemas.get(channel.schema_id)
        if schema is not None:
            known = self.schema_ids.get(schema.id)
            if known is None:
                known = self.schema_ids[schema.id] = self.writer.register_schema(
                    schema.name, schema.encoding, schema.data)
            schema_id = known
        out = self.channel_ids[cid] = self.writer.register_channel(
            channel.topic, channel.message_encoding, schema_id, dict(channel.metadata))
        return out

    def finish(self, src: str) -> None:
        self._start()
        # the stored columns' record says they hold every event (docs/mcap.md, "Stored
        # columns"): with anything dropped or cut it would not be true, and the
        # recovered file is decoded from its raw bytes when opened
        if self.columns_record is not None and not self.report():
            self.writer.add_metadata(COLUMNS_RECORD, self.columns_record)
        self.writer.add_metadata("gimbalscope.recover", {
            "source": show(src), "messages": str(self.messages),
            "cut": self.cut or "none: the file was complete",
            "dropped": "; ".join(self.report()) or "nothing"})
        self.writer.finish()

    # ------------------------------------------------------------- report
    def _drop(self, kind: str, offset: int | None, why: str) -> None:
        seen = self.dropped.get(kind)
        if seen is None:
            self.dropped[kind] = [1, offset, why]
        else:
            seen[0] += 1

    def report(self) -> list[str]:
        """One line per kind of problem: what was kept, what was dropped, where."""
        lines = []
        for kind, (count, offset, why) in self.dropped.items():
            where = f" at byte {offset}" if offset is not None else ""
            if count == 1:
                lines.append(f"dropped a {kind}{where} ({why})")
            else:
                lines.append(f"dropped {count} of: {kind} (the first{where}: {why})")
        if self.partial:
            offset, kept, why = self.partial[0]
            rest = f"dropped the rest from {why}" if why else "none dropped, but some bytes may be altered"
            if len(self.partial) == 1:
                lines.append(f"the chunk at byte {offset} fails its CRC check: kept its first "
                             f"{counted(kept, 'message')}, {rest}")
            else:
                kept = sum(k for _o, k, _w in self.partial)
                lines.append(f"{len(self.partial)} chunks fail their CRC check: kept {kept} of their "
                             f"messages, each up to its first bad record (the first at byte {offset}: {rest})")
        if self.cut:
            lines.append(f"ends early ({self.cut}); kept {counted(self.messages, 'message')} before it"
                         + (f", {self.from_cut} of them from the part of the cut chunk that is there"
                            if self.from_cut else ""))
        return lines

