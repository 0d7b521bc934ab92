"""``gimbalscope recover``: rewrite an MCAP file whose recording was cut short
(killed tap, full disk) into a complete one: every record up to the last
complete chunk, then a summary section and footer."""

from __future__ import annotations

import argparse
import os

from mcap.records import Channel, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from ..sources.files import open_input
from .common import UsageError, warn


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("recover", help="rewrite a cut-short MCAP recording whole",
                       description="Rewrite an MCAP recording that has no summary (a killed tap) into a complete file.")
    p.add_argument("input", metavar="FILE.mcap")
    p.add_argument("-o", "--output", metavar="OUT.mcap", help="default: FILE.recovered.mcap")
    p.add_argument("--force", action="store_true", help="overwrite OUT.mcap if it exists")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    src = args.input
    out = args.output or (src[:-5] if src.endswith(".mcap") else src) + ".recovered.mcap"
    if os.path.exists(out) and not args.force:
        raise UsageError(f"{out}: exists (use --force to overwrite)")
    with open_input(src) as f:
        if f.read(5) != b"\x89MCAP":
            raise UsageError(f"{src}: not an MCAP file")
    messages = 0
    cut = None
    with open_input(src) as f, open(out, "wb") as g:
        writer = Writer(g, compression=CompressionType.ZSTD)
        reader = StreamReader(f, record_size_limit=1 << 30)   # chunks are opened record by record
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        started = False
        try:
            for record in reader.records:
                if not started:
                    profile = record.profile if isinstance(record, Header) else ""
                    writer.start(profile=profile, library="gimbalscope recover")
                    started = True
                if isinstance(record, Schema):
                    schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
                elif isinstance(record, Channel):
                    if record.id not in channels:
                        channels[record.id] = writer.register_channel(
                            record.topic, record.message_encoding, schemas.get(record.schema_id, 0),
                            dict(record.metadata))
                elif isinstance(record, Metadata):
                    writer.add_metadata(record.name, dict(record.metadata))
                elif isinstance(record, Message):
                    writer.add_message(channels[record.channel_id], record.log_time, record.data,
                                       record.publish_time, record.sequence)
                    messages += 1
        except Exception as e:   # the cut end: keep everything before it
            cut = f"{type(e).__name__}: {e}"
        if not started:
            writer.start(profile="", library="gimbalscope recover")
        writer.add_metadata("gimbalscope.recover", {"source": src, "messages": str(messages),
                                                     "cut": cut or "none: the file was complete"})
        writer.finish()
    if cut:
        warn(f"{src}: ends early ({cut}); kept {messages} messages before it")
    print(f"{out}: {messages} messages")
    return 0
