"""Hostile MCAP files: made by hand, by other tools, cut short or damaged. Every
command that reads a recording gives events with counted warnings, or one error
line (exit 2), never a traceback; ``recover`` keeps everything intact and says
what it dropped, with byte offsets.

The corpus is generated here: MCAP records built byte by byte (independently of
the code under test), foreign files written with the mcap library, recordings
written by gimbalscope's recorder and then cut or damaged."""

from __future__ import annotations

import json
import os
import random
import struct
import zlib
from io import BytesIO

import pytest
from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Chunk, Message
from mcap.stream_reader import breakup_chunk
from mcap.writer import Writer

from analyzer.capture import Capture
from analyzer.sources.base import Chunk as RawChunk
from analyzer.writers.mcap_recorder import McapRecorder
from tests.conftest import frame, run_cli
from tests.integration.test_mcap import doctor, go_read

MAGIC = b"\x89MCAP0\r\n"
RAW_AB = "/serial/AB/raw"
CMD = frame((1, 1, 1), 0, "P?")
ACK = b"\x06"
RES = frame((0, 1, 1), 1, "0FA0FC18")

# ------------------------------------------------------------------ building files


def record(op: int, body: bytes) -> bytes:
    """An MCAP record (spec: opcode u8, length u64, body)."""
    return bytes([op]) + struct.pack("<Q", len(body)) + body


def text(s: str) -> bytes:
    b = s.encode()
    return struct.pack("<I", len(b)) + b


HEADER = record(0x01, text("") + text("by hand"))


def chunk_record(records: bytes, *, size: int | None = None, compression: str = "", crc: int = 0) -> bytes:
    """A Chunk record holding ``records`` as they are (no compression)."""
    body = struct.pack("<QQQI", 0, 0, len(records) if size is None else size, crc) + text(compression)
    return record(0x06, body + struct.pack("<Q", len(records)) + records)


def schema_record(sid: int) -> bytes:
    return record(0x03, struct.pack("<H", sid) + text("raw") + text("jsonschema") + text('{"type": "object"}'))


def channel_record(cid: int, topic: str, encoding: str = "json", schema: int = 0) -> bytes:
    return record(0x04, struct.pack("<HH", cid, schema) + text(topic) + text(encoding) + struct.pack("<I", 0))


def message_record(cid: int, data: bytes, log_time: int = 1) -> bytes:
    return record(0x05, struct.pack("<HIQQ", cid, 0, log_time, log_time) + data)


def raw_payload(data: bytes, t: float | None, line: str = "AB", offset: int = 0) -> bytes:
    return json.dumps({"line": line, "offset": offset, "t": t, "data": data.hex()}).encode()


def conversation(commands: int) -> list[tuple[bytes, float]]:
    """A command, its ACK and its result, repeated: (bytes, wire time)."""
    out = []
    for k in range(commands):
        t = 0.1 * k
        out += [(CMD, t), (ACK, t + 0.02), (RES, t + 0.025)]
    return out


def foreign_file(path, payloads: list[bytes], valid: int = 0, topic: str = RAW_AB) -> None:
    """A file another tool wrote on our raw topic: ``valid`` raw chunks of ours (a
    conversation), then ``payloads`` that are not ours."""
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="", library="another tool")
        cid = w.register_channel(topic, "json", w.register_schema("x", "jsonschema", b"{}"))
        offset = 0
        for data, t in conversation(valid)[:valid]:
            w.add_message(cid, log_time=1_795_000_000_000_000_000 + int(t * 1e9),
                          data=raw_payload(data, t, offset=offset), publish_time=0)
            offset += len(data)
        for i, p in enumerate(payloads):
            w.add_message(cid, log_time=1_795_000_001_000_000_000 + i, data=p, publish_time=0)
        w.finish()


FOREIGN = [
    b'{"t": 1}',                                  # no data
    bytes(range(256)),                            # binary
    b'{"line": "AB", "data": "zz", "t": 0.5}',    # bad hex
    b'{"line": "AB", "data": "f8", "t": 1e308}',  # a time no recording has
    b'{"line": "AB", "data": "f8", "t": "soon"}',
    b'{"line": "AB", "data": 7, "t": 0}',
    b"[1, 2, 3]",
    b'"f8"',
    b"[" * 5000 + b"]" * 5000,
]


def our_recording(path, commands: int = 20, *, each_in_own_chunk: bool = False) -> int:
    """A recording by gimbalscope's recorder, raw chunks only (a single-line tap);
    returns how many messages it holds."""
    rec = McapRecorder(str(path), metadata={"tool": "gimbalscope test", "baud": "9600"},
                       start_time=1_795_000_000.0, flush_interval=0.0 if each_in_own_chunk else None,
                       lines=("AB",))
    offset = 0
    written = 0
    for data, t in conversation(commands):
        rec.raw(RawChunk("AB", data, t), offset)
        offset += len(data)
        written += 1
    rec.close()
    return written


def top_records(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, opcode, record length) of the data section's records."""
    out, pos = [], len(MAGIC)
    while pos + 9 <= len(data):
        op, length = struct.unpack_from("<BQ", data, pos)
        out.append((pos, op, 9 + length))
        if op in (0x0F, 0x02):
            break
        pos += 9 + length
    return out


def chunks_in(data: bytes) -> list[tuple[int, int, dict[str, int]]]:
    """(offset, length, messages per topic) of every chunk, read with the mcap library."""
    topics: dict[int, str] = {}
    out = []
    for offset, op, length in top_records(data):
        if op != 0x06:
            continue
        chunk = Chunk.read(ReadDataStream(BytesIO(data[offset + 9:offset + length])))
        counts: dict[str, int] = {}
        for r in breakup_chunk(chunk):
            if isinstance(r, Channel):
                topics[r.id] = r.topic
            elif isinstance(r, Message):
                counts[topics[r.channel_id]] = counts.get(topics[r.channel_id], 0) + 1
        out.append((offset, length, counts))
    return out


def chunk_data_offset(data: bytes, chunk_offset: int) -> int:
    """Where a chunk's compressed data starts (after its header fields)."""
    pos = chunk_offset + 9 + 8 + 8 + 8 + 4
    (name_len,) = struct.unpack_from("<I", data, pos)
    return pos + 4 + name_len + 8


def flipped(data: bytes, at: int) -> bytes:
    return data[:at] + bytes([data[at] ^ 0xFF]) + data[at + 1:]


def corpus(tmp_path) -> dict[str, bytes]:
    """Files no command may raise on."""
    rng = random.Random(1)
    soup = MAGIC + HEADER + b"".join(
        bytes([rng.randrange(256)]) + struct.pack("<Q", rng.choice([0, 1, 7, 30, 2**32, 2**63]))
        + bytes(rng.randrange(256) for _ in range(rng.randrange(40))) for _ in range(200))
    files = {
        "magic-only.mcap": MAGIC,
        "nine-bytes.mcap": MAGIC + b"\x01",
        "header-only.mcap": MAGIC + HEADER,
        "huge-record.mcap": MAGIC + HEADER + b"\x06" + struct.pack("<Q", 2**60) + b"x" * 16,
        "huge-uncompressed.mcap": MAGIC + HEADER + chunk_record(channel_record(1, RAW_AB), size=2**40,
                                                                compression="zstd"),
        "huge-inner-record.mcap": MAGIC + HEADER + chunk_record(
            channel_record(1, RAW_AB) + b"\x05" + struct.pack("<Q", 2**62) + b"\x01\x00"),
        "short-message.mcap": MAGIC + HEADER + channel_record(1, RAW_AB) + record(0x05, b"\x01\x00\x00"),
        "bad-topic-text.mcap": MAGIC + HEADER + record(0x04, struct.pack("<HH", 1, 0) + struct.pack("<I", 2)
                                                         + b"\xff\xfe" + text("json") + struct.pack("<I", 0)),
        "unknown-compression.mcap": MAGIC + HEADER + chunk_record(channel_record(1, RAW_AB), compression="brotli"),
        "opcode-soup.mcap": soup,
    }
    for i, p in enumerate(FOREIGN):
        foreign_file(tmp_path / "f.mcap", [p])
        files[f"foreign-{i}.mcap"] = (tmp_path / "f.mcap").read_bytes()
    foreign_file(tmp_path / "f.mcap", FOREIGN, valid=9)
    files["foreign-mixed.mcap"] = (tmp_path / "f.mcap").read_bytes()
    foreign_file(tmp_path / "f.mcap", [b'{"x": 1}'], topic="/events")
    files["no-raw-topic.mcap"] = (tmp_path / "f.mcap").read_bytes()
    our_recording(tmp_path / "r.mcap")
    whole = (tmp_path / "r.mcap").read_bytes()
    (offset, length, _counts), = chunks_in(whole)
    for at in (9, offset + 4, offset + 60, offset + length // 2, offset + length - 1, len(whole) - 30):
        files[f"cut-{at}.mcap"] = whole[:at]
    for at in (offset + 20, chunk_data_offset(whole, offset) + 2, offset + length // 2, offset + length - 3):
        files[f"flipped-{at}.mcap"] = flipped(whole, at)
    return files


COMMANDS = {
    "decode": ["decode"],
    "stats": ["stats"],
    "doctor": ["doctor"],
    "convert": ["convert", "-o", "{out}", "--force"],
    "replay": ["replay", "--no-tui", "--speed", "max"],
}


def run_command(command: str, path, tmp_path):
    args = [a.format(out=tmp_path / "converted.mcap") for a in COMMANDS[command]]
    return run_cli(args[0], path, *args[1:])


def assert_events_or_one_error(out, name: str) -> None:
    """Events with each warning said once, or one error line and exit 2."""
    assert "Traceback" not in out.stderr, name + "\n" + out.stderr
    lines = out.stderr.strip().splitlines()
    if out.returncode == 0:
        assert not any(line.startswith("gimbalscope: error") for line in lines), name
        assert len(lines) == len(set(lines)), f"{name}: a warning repeated:\n{out.stderr}"
        assert len(lines) <= 6, f"{name}: warnings not counted:\n{out.stderr}"
    else:
        assert out.returncode == 2, f"{name}: exit {out.returncode}\n{out.stderr}"
        assert len(lines) == 1 and lines[0].startswith("gimbalscope: error: "), f"{name}:\n{out.stderr}"
        assert name in lines[0]


# ------------------------------------------------------------------ every command


@pytest.mark.parametrize("command", list(COMMANDS))
def test_no_hostile_file_raises(tmp_path, command):
    files = corpus(tmp_path)
    for name, data in files.items():
        path = tmp_path / name
        path.write_bytes(data)
        assert_events_or_one_error(run_command(command, path, tmp_path), name)


# ------------------------------------------------------------------ lengths


@pytest.mark.parametrize("data,offset", [
    (MAGIC + b"\x01", len(MAGIC)),
    (MAGIC + HEADER + b"\x06" + struct.pack("<Q", 2**60), len(MAGIC) + len(HEADER)),
])
def test_a_length_beyond_the_file_is_one_line_with_its_offset(tmp_path, data, offset):
    path = tmp_path / "hand.mcap"
    path.write_bytes(data)
    out = run_cli("decode", path)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    assert f"byte {offset}" in out.stderr


def test_a_huge_declared_uncompressed_size_is_damage_not_an_allocation(tmp_path):
    raw = [message_record(1, raw_payload(data, t)) for data, t in conversation(3)]
    good = chunk_record(channel_record(1, RAW_AB) + b"".join(raw))
    bad = chunk_record(b"", size=2**40, compression="zstd")
    path = tmp_path / "hand.mcap"
    path.write_bytes(MAGIC + HEADER + bad + good)
    out = run_cli("decode", path, "--format", "jsonl")
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
    assert f"chunk at byte {len(MAGIC) + len(HEADER)}" in out.stderr
    events = [json.loads(line) for line in out.stdout.splitlines()]
    assert [e["kind"] for e in events] == ["command", "ack", "result"] * 3


# ------------------------------------------------------------------ foreign messages


def test_messages_that_are_not_ours_are_counted_and_the_rest_decodes(tmp_path):
    valid = 9
    mixed, ours = tmp_path / "mixed.mcap", tmp_path / "ours.mcap"
    foreign_file(mixed, FOREIGN, valid=valid)
    foreign_file(ours, [], valid=valid)
    out = run_cli("decode", mixed, "--format", "jsonl")
    assert out.returncode == 0, out.stderr
    expected = run_cli("decode", ours, "--format", "jsonl")
    assert expected.returncode == 0 and out.stdout == expected.stdout
    assert len(out.stdout.splitlines()) == valid
    assert out.stderr.count(f"{len(FOREIGN)} messages on {RAW_AB} were not gimbalscope raw chunks") == 1
    # and, written by hand without our metadata record, the one line that says the defaults are used
    others = [line for line in out.stderr.strip().splitlines() if "were not gimbalscope raw chunks" not in line]
    assert others == [(f"gimbalscope: warning: {mixed}: it has no gimbalscope metadata record: decoding with "
                       "the options given and the defaults (9600 8N1)")]


def test_a_raw_topic_with_nothing_of_ours_is_one_line(tmp_path):
    path = tmp_path / "foreign.mcap"
    foreign_file(path, FOREIGN * 3)
    for command in COMMANDS:
        out = run_command(command, path, tmp_path)
        assert out.returncode == 2 and "Traceback" not in out.stderr, (command, out.stderr)
        assert len(out.stderr.strip().splitlines()) == 1
        assert f"{3 * len(FOREIGN)} messages on {RAW_AB} were not gimbalscope raw chunks" in out.stderr


def test_a_recording_of_our_raw_channels_without_messages_is_an_empty_capture(tmp_path):
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    rec = tmp_path / "empty.mcap"
    assert run_cli("convert", empty, "-o", rec).returncode == 0
    for args in (["decode", rec], ["stats", rec, "--format", "json"], ["replay", rec, "--no-tui", "--speed", "max"]):
        out = run_cli(*args)
        assert out.returncode == 0 and "Traceback" not in out.stderr, (args, out.stderr)
        assert "no bytes" in out.stderr
    assert json.loads(run_cli("stats", rec, "--format", "json").stdout)["events"] == 0


# ------------------------------------------------------------------ damage


def test_a_cut_single_chunk_recording_is_reported_as_cut_with_the_offset(tmp_path):
    our_recording(tmp_path / "whole.mcap")
    whole = (tmp_path / "whole.mcap").read_bytes()
    (offset, _length, _counts), = chunks_in(whole)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[:offset + 40])   # inside the chunk's header: nothing of it reads
    out = run_cli("decode", cut)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "without gimbalscope raw topics" not in out.stderr
    assert "ends early" in out.stderr and f"byte {offset}" in out.stderr


@pytest.mark.parametrize("where", [0.5, 0.9])
def test_a_flipped_byte_in_a_single_chunk_recording_is_reported_as_damage_at_its_chunk(tmp_path, where):
    our_recording(tmp_path / "whole.mcap")
    whole = (tmp_path / "whole.mcap").read_bytes()
    (offset, length, _counts), = chunks_in(whole)
    start = chunk_data_offset(whole, offset)
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(flipped(whole, start + int((offset + length - start) * where)))
    out = run_cli("decode", damaged)
    assert out.returncode in (0, 2) and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    assert "without gimbalscope raw topics" not in out.stderr
    assert f"chunk at byte {offset}" in out.stderr


def test_a_damaged_chunk_is_skipped_and_the_next_ones_read(tmp_path):
    commands = 10
    path = tmp_path / "rec.mcap"
    our_recording(path, commands, each_in_own_chunk=True)
    whole = path.read_bytes()
    chunks = chunks_in(whole)
    offset, _length, counts = chunks[4]   # one raw chunk: the ACK of the second command
    assert counts == {RAW_AB: 1}
    damaged = tmp_path / "damaged.mcap"
    at = chunk_data_offset(whole, offset)
    damaged.write_bytes(whole[:at] + b"\0\0\0\0" + whole[at + 4:])   # no zstd frame there any more
    out = run_cli("decode", damaged, "--format", "jsonl")
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
    assert f"chunk at byte {offset} is damaged" in out.stderr
    events = [json.loads(line) for line in out.stdout.splitlines()]
    assert sum(e["kind"] == "command" for e in events) == commands
    assert sum(e["kind"] == "ack" for e in events) == commands - 1


# ------------------------------------------------------------------ recover


def test_recover_keeps_every_message_before_the_cut(tmp_path):
    path = tmp_path / "rec.mcap"
    total = our_recording(path, 20, each_in_own_chunk=True)
    whole = path.read_bytes()
    chunks = chunks_in(whole)
    assert sum(sum(c.values()) for _o, _l, c in chunks) == total
    offset, length, _counts = chunks[len(chunks) // 2]
    kept = sum(sum(c.values()) for o, _l, c in chunks if o < offset)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[:offset + length // 2])
    fixed = tmp_path / "fixed.mcap"
    out = run_cli("recover", cut, "-o", fixed)
    assert out.returncode == 0, out.stderr
    assert f"{kept} messages" in out.stdout
    assert f"byte {offset}" in out.stderr and f"kept {kept} messages" in out.stderr
    assert doctor(fixed) == []
    assert go_read(fixed)["messages"] == {RAW_AB: kept}
    decoded = run_cli("decode", fixed, "--format", "jsonl")
    assert decoded.returncode == 0 and decoded.stderr == ""
    assert len(decoded.stdout.splitlines()) == kept


def test_recover_skips_a_damaged_chunk_and_keeps_the_rest(tmp_path):
    path = tmp_path / "rec.mcap"
    total = our_recording(path, 10, each_in_own_chunk=True)
    whole = path.read_bytes()
    offset, _length, counts = chunks_in(whole)[7]
    at = chunk_data_offset(whole, offset)
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(whole[:at] + b"\0\0\0\0" + whole[at + 4:])
    fixed = tmp_path / "fixed.mcap"
    out = run_cli("recover", damaged, "-o", fixed)
    assert out.returncode == 0, out.stderr
    assert f"{total - sum(counts.values())} messages" in out.stdout
    assert f"byte {offset}" in out.stderr
    assert doctor(fixed) == []
    assert go_read(fixed)["messages"] == {RAW_AB: total - sum(counts.values())}


def test_recover_keeps_a_chunk_whose_crc_fails_up_to_its_first_bad_record(tmp_path):
    """An uncompressed chunk whose fifth message record claims more bytes than the
    chunk has: its CRC fails, the four messages before it are kept, and so is the
    next chunk."""
    raw = [message_record(1, raw_payload(data, t)) for data, t in conversation(3)]
    definitions = schema_record(1) + channel_record(1, RAW_AB, schema=1)
    records = definitions + b"".join(raw)
    bad_at = len(definitions) + sum(len(r) for r in raw[:4])
    broken = records[:bad_at + 1] + struct.pack("<Q", 2**40) + records[bad_at + 9:]
    first = chunk_record(broken, crc=zlib.crc32(records))   # the CRC as written, before the damage
    second = chunk_record(b"".join(message_record(1, raw_payload(CMD, 5.0 + k)) for k in range(2)))
    path = tmp_path / "hand.mcap"
    path.write_bytes(MAGIC + HEADER + first + second)
    fixed = tmp_path / "fixed.mcap"
    out = run_cli("recover", path, "-o", fixed)
    assert out.returncode == 0, out.stderr
    assert "6 messages" in out.stdout
    assert f"chunk at byte {len(MAGIC) + len(HEADER)} fails its CRC check: kept its first 4 messages" in out.stderr
    assert doctor(fixed) == []
    assert go_read(fixed)["messages"] == {RAW_AB: 6}


def test_recover_with_nothing_intact_exits_1_and_writes_nothing(tmp_path):
    our_recording(tmp_path / "whole.mcap")
    whole = (tmp_path / "whole.mcap").read_bytes()
    (offset, _length, _counts), = chunks_in(whole)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[:offset + 40])
    out = run_cli("recover", cut, "-o", tmp_path / "fixed.mcap")
    assert out.returncode == 1 and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "nothing to recover" in out.stderr
    assert sorted(os.listdir(tmp_path)) == ["cut.mcap", "whole.mcap"]


def test_recover_never_writes_over_its_input(tmp_path):
    path = tmp_path / "rec.mcap"
    our_recording(path, each_in_own_chunk=True)
    whole = path.read_bytes()
    path.write_bytes(whole[:len(whole) // 2])
    before = path.read_bytes()
    link = tmp_path / "link.mcap"
    link.symlink_to(path)
    for out_path in (path, link):
        out = run_cli("recover", path, "-o", out_path, "--force")
        assert out.returncode != 0 and "Traceback" not in out.stderr
        assert len(out.stderr.strip().splitlines()) == 1 and "input" in out.stderr
        assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["link.mcap", "rec.mcap"]


@pytest.mark.parametrize("where", ["missing folder", "directory"])
def test_recover_to_an_impossible_output_is_one_line(tmp_path, where):
    path = tmp_path / "rec.mcap"
    our_recording(path)
    target = tmp_path / "nowhere" / "x.mcap" if where == "missing folder" else tmp_path
    out = run_cli("recover", path, "-o", target, "--force")
    assert out.returncode != 0 and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and out.stderr.startswith("gimbalscope: error: ")


def test_recover_a_file_whose_name_is_not_utf8(tmp_path):
    folder = os.fsencode(tmp_path)
    name = os.path.join(folder, b"rec-\xff.mcap")
    total = our_recording(os.fsdecode(name), each_in_own_chunk=True)
    with open(name, "rb") as f:
        whole = f.read()
    with open(name, "wb") as f:
        f.write(whole[:-40])   # the footer gone: a file to recover
    out = run_cli("recover", os.fsdecode(name))
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
    fixed = os.path.join(folder, b"rec-\xff.recovered.mcap")
    assert os.path.exists(fixed)
    assert "rec-\\xff.recovered.mcap" in out.stdout and f"{total} messages" in out.stdout
    assert go_read(os.fsdecode(fixed))["metadata"]["gimbalscope.recover"]["source"].endswith("rec-\\xff.mcap")


# ------------------------------------------------------------------ the API


def test_a_source_reports_under_the_name_it_is_given(tmp_path):
    from analyzer.sources.mcapfile import McapSource

    path = tmp_path / "spool-1234.mcap"
    our_recording(path, each_in_own_chunk=True)
    whole = path.read_bytes()
    path.write_bytes(whole[:len(whole) * 2 // 3])
    warnings: list[str] = []
    capture = Capture(McapSource(str(path), name="site.mcap.gz"), on_warning=warnings.append)
    assert sum(1 for _ in capture) > 0
    assert warnings and all(w.startswith("site.mcap.gz: ") for w in warnings)
    assert capture.source.description.startswith("site.mcap.gz")
