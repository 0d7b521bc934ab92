"""Recordings carry their decoded events as the store's columns (docs/mcap.md,
"Stored columns"). A store filled from a recording's stored columns must hold
exactly the events that decoding its raw bytes gives (``redecode``), for
recordings made by ``convert`` and by a live tap's writer, of the samples and of
hostile lines, in one file or in rotated parts; a killed tap's recording has no
complete columns and is decoded; columns made by another decoder are left aside
with a one-line reason."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

import analyzer
from analyzer.capture.stored import stored_events
from analyzer.formats.mcap_schemas import COLUMNS_RECORD, COLUMNS_TOPIC
from analyzer.formats.store import EventStore
from analyzer.simulation.traffic import generate
from tests.conftest import BUS, CTL, DEV, SOCAT_LOG, run_cli
from tests.integration.test_mcap import raw_only_recorder
from tests.integration.test_mcap_parts import record
from tests.pure.test_tui_store import same

SAMPLES = {"socat": [SOCAT_LOG], "two-dumps": [CTL, DEV], "bus": [BUS]}


def from_columns(*paths: str) -> tuple[EventStore, int]:
    """The store filled from the recording's stored columns, and their message count."""
    stored, why = stored_events(analyzer.open(*paths))
    assert stored is not None, why
    assert why is None
    store = EventStore()
    messages = 0
    for chunk in stored.chunks():
        store.append_chunk(chunk)
        messages += 1
    assert len(store) == stored.events
    return store, messages


def check_equal(*paths: str) -> int:
    """Stored columns against the raw bytes decoded, event for event; the events."""
    store, _messages = from_columns(*paths)
    events = list(analyzer.open(*paths, redecode=True))
    assert len(store) == len(events) > 0
    for i, ev in enumerate(events):
        same(store.event(i), ev)
    return len(events)


def columns_messages(path) -> list[bytes]:
    with open(path, "rb") as f:
        return [m.data for _s, _c, m in make_reader(f).iter_messages(topics=[COLUMNS_TOPIC], log_time_order=False)]


def columns_record(path) -> dict[str, str] | None:
    with open(path, "rb") as f:
        return next((m.metadata for m in make_reader(f).iter_metadata() if m.name == COLUMNS_RECORD), None)


def converted(tmp_path: Path, inputs: list[str], *args: str, name: str = "c.mcap") -> str:
    out = tmp_path / name
    r = run_cli("convert", *inputs, "-o", out, *args)
    assert r.returncode == 0, r.stderr
    return str(out)


def hostile_inputs(tmp_path: Path, form: str) -> list[str]:
    tr = generate(500, baud=9600, seed=11, bit_error_rate=0.03, drop_ack_rate=0.05, noise_rate=0.05)
    if form == "single":
        (tmp_path / "bus.bin").write_bytes(tr.single_line())
        return [str(tmp_path / "bus.bin")]
    if form == "two":
        (tmp_path / "a.bin").write_bytes(tr.line_bytes("A"))
        (tmp_path / "b.bin").write_bytes(tr.line_bytes("B"))
        return [str(tmp_path / "a.bin"), str(tmp_path / "b.bin")]
    (tmp_path / "socat.log").write_text(tr.socat_log(nanoseconds=True))
    return [str(tmp_path / "socat.log")]


# ------------------------------------------------------------------ equal to decoding


@pytest.mark.parametrize("name", list(SAMPLES))
def test_converted_samples_read_from_their_columns_as_decoded(tmp_path, name):
    out = converted(tmp_path, SAMPLES[name])
    n = check_equal(out)
    record = columns_record(out)
    assert record is not None and record["version"] == "1" and record["events"] == str(n)
    assert record["messages"] == str(len(columns_messages(out)))
    assert record["media_type"] == "application/vnd.apache.arrow.stream"


@pytest.mark.parametrize("form", ["single", "two", "socat"])
def test_converted_hostile_lines_read_from_their_columns_as_decoded(tmp_path, form):
    out = converted(tmp_path, hostile_inputs(tmp_path, form))
    check_equal(out)


@pytest.mark.parametrize("name", list(SAMPLES))
def test_a_live_writers_recording_reads_from_its_columns_as_decoded(tmp_path, name):
    parts, _info = record(tmp_path / "live.mcap", SAMPLES[name])
    assert len(parts) == 1
    check_equal(*parts)


@pytest.mark.parametrize("name", ["socat", "two-dumps"])
def test_a_recording_in_rotated_parts_reads_from_their_columns_as_one(tmp_path, name):
    rotate = {"socat": 20_000, "two-dumps": 4_000}[name]
    parts, _info = record(tmp_path / "rec.mcap", SAMPLES[name], rotate_bytes=rotate)
    assert len(parts) >= 3, parts
    assert all(columns_record(p) is not None for p in parts)
    n = check_equal(*parts)
    assert sum(int(columns_record(p)["events"]) for p in parts) == n
    # the parts given in another order are still one capture
    check_equal(*reversed(parts))


def test_demo_record_reads_from_its_columns_as_decoded(tmp_path):
    out = tmp_path / "demo.mcap"
    r = run_cli("demo", "--record", out, "--seconds", "2", timeout=120)
    assert r.returncode == 0, r.stderr
    check_equal(str(out))


def test_redecode_leaves_the_columns_aside_silently(tmp_path):
    out = converted(tmp_path, [SOCAT_LOG])
    assert stored_events(analyzer.open(out, redecode=True)) == (None, None)


# ------------------------------------------------------------------ killed, other decoder, lean


def test_a_recorder_fed_raw_bytes_alone_says_nothing_of_columns(tmp_path):
    """McapRecorder given raw bytes and no events: no columns record (it would say
    0 events where decoding makes 60), killed or closed; both decode."""
    path = tmp_path / "live.mcap"
    rec = raw_only_recorder(path)
    killed = tmp_path / "killed.mcap"   # SIGKILL now: no summary, no footer, no columns record
    shutil.copyfile(path, killed)
    rec.close()
    for p in (killed, path):
        assert columns_record(p) is None if p == path else True
        assert stored_events(analyzer.open(str(p))) == (None, None)
        events = list(analyzer.open(str(p)))
        assert sum(e.kind == "command" for e in events) == 20


def stream_columns(path) -> list[bytes]:
    """The columns messages a file without summary holds, read front to back."""
    from mcap.reader import NonSeekingReader

    out = []
    with open(path, "rb") as f:
        try:
            for _s, channel, m in NonSeekingReader(f).iter_messages():
                if channel.topic == COLUMNS_TOPIC:
                    out.append(m.data)
        except Exception:   # noqa: BLE001, S110 - the file ends mid-record: what came before is what we want
            pass
    return out


def test_a_killed_live_recording_is_decoded_and_its_columns_lag_at_most_behind(tmp_path):
    from analyzer.formats.store_ipc import Joiner

    parts, _info = record(tmp_path / "live.mcap", [SOCAT_LOG])
    data = Path(parts[0]).read_bytes()
    whole = list(analyzer.open(parts[0], redecode=True))
    for fraction in (3, 2):
        killed = tmp_path / f"killed{fraction}.mcap"
        killed.write_bytes(data[:len(data) * (fraction - 1) // fraction])
        assert stored_events(analyzer.open(str(killed)))[0] is None
        events = list(analyzer.open(str(killed)))
        assert 0 < len(events) <= len(whole)
        # the columns written so far are the first events, whole
        store, joiner = EventStore(), Joiner()
        for message in stream_columns(killed):
            store.append_chunk(joiner.chunk(message))
        assert len(store) <= len(events)
        for i in range(len(store)):
            same(store.event(i), whole[i])


def test_a_recording_cut_short_is_decoded(tmp_path):
    out = converted(tmp_path, [SOCAT_LOG])
    data = Path(out).read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:len(data) * 2 // 3])
    stored, _why = stored_events(analyzer.open(str(cut)))
    assert stored is None
    assert len(list(analyzer.open(str(cut)))) > 0


def many_messages(tmp_path, monkeypatch) -> str:
    """A recording of the bus sample whose columns are many small messages."""
    from analyzer.writers import mcap_columns
    monkeypatch.setattr(mcap_columns, "BATCH", 50)
    monkeypatch.setattr(mcap_columns, "STORE_EVERY", 25)
    [path], _info = record(tmp_path / "many.mcap", [BUS])
    assert len(columns_messages(path)) >= 5
    return path


def reading_threads() -> list:
    import threading
    return [t for t in threading.enumerate() if t.name.startswith("gimbalscope-columns")]


def test_a_reader_that_stops_early_leaves_no_thread_reading(tmp_path, monkeypatch):
    # the next message is read ahead by a thread (analyzer/sources/mcapfile.py)
    stored, _why = stored_events(analyzer.open(many_messages(tmp_path, monkeypatch)))
    assert stored is not None
    chunks = stored.chunks(None)
    next(chunks), next(chunks)
    assert reading_threads()
    chunks.close()
    assert not reading_threads()


def test_a_damaged_message_after_good_ones_is_refused_in_its_turn(tmp_path, monkeypatch):
    from analyzer.formats.store_ipc import ColumnsError
    from tests.hostile.test_mcap_hostile import chunks_in

    path = many_messages(tmp_path, monkeypatch)
    data = bytearray(Path(path).read_bytes())
    columns = [(o, n) for o, n, counts in chunks_in(bytes(data)) if COLUMNS_TOPIC in counts]
    offset, length = columns[3]
    data[offset + length - 20] ^= 0xFF   # in the fourth message's chunk: it does not read
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    stored, _why = stored_events(analyzer.open(str(damaged)))
    assert stored is not None
    read = 0
    with pytest.raises(ColumnsError, match=f"the chunk at byte {offset}"):
        for chunk in stored.chunks(None):
            read += len(chunk.columns["kind"]) == 50   # each whole
    assert read == 3   # the three before it
    assert not reading_threads()


def test_the_chunk_indexes_read_as_the_mcap_library_reads_them(tmp_path, monkeypatch):
    # opening a recording reads every chunk index for which chunks hold only columns
    from analyzer.sources.mcapwalk import OP_CHUNK_INDEX, Damaged, chunk_channels, summary_records

    path = many_messages(tmp_path, monkeypatch)
    with open(path, "rb") as f:
        indexes = make_reader(f).get_summary().chunk_indexes
        bodies = [body for _op, body in summary_records(f, os.fstat(f.fileno()).st_size, (OP_CHUNK_INDEX,))]
    assert len(bodies) == len(indexes) > 10
    channels = set()
    for body, index in zip(bodies, indexes, strict=True):
        assert chunk_channels(body) == (index.chunk_start_offset, index.chunk_length, set(index.message_index_offsets))
        channels |= set(index.message_index_offsets)
    assert len(channels) >= 3   # raw lines and the columns
    for cut in (10, 35, 40):
        with pytest.raises(Damaged):
            chunk_channels(bodies[0][:cut])


def test_a_summary_that_lost_a_chunk_index_of_columns_is_refused_and_the_recording_decoded(tmp_path, monkeypatch):
    # the columns' chunks are found by the summary's chunk indexes; with one of them
    # gone (its record's opcode made one no reader knows), the messages read skip a
    # chunk, which the joiner refuses (a message says which event it starts at): export decodes instead
    import struct

    import pyarrow.parquet as pq

    from analyzer.formats.store_ipc import ColumnsError
    from analyzer.sources.mcapwalk import OP_CHUNK_INDEX, chunk_channels

    path = many_messages(tmp_path, monkeypatch)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    columns = next(cid for cid, c in summary.channels.items() if c.topic == COLUMNS_TOPIC)
    data = bytearray(Path(path).read_bytes())
    footer = len(data) - 8 - (1 + 8 + 20)   # the Footer record: summary start, summary offset start, CRC
    pos = struct.unpack_from("<Q", data, footer + 9)[0]
    while pos < footer:
        op, length = struct.unpack_from("<BQ", data, pos)
        if op == OP_CHUNK_INDEX and chunk_channels(bytes(data[pos + 9:pos + 9 + length])).channels == {columns}:
            data[pos] = 0x80
            break
        pos += 9 + length
    else:
        raise AssertionError("no chunk index of columns alone")
    struct.pack_into("<I", data, footer + 25, 0)   # no summary CRC to check: the summary is what it says
    damaged = tmp_path / "lost-index.mcap"
    damaged.write_bytes(data)

    stored, _why = stored_events(analyzer.open(str(damaged)))
    assert stored is not None
    with pytest.raises(ColumnsError, match="do not follow"):
        for _chunk in stored.chunks(None):
            pass
    out = run_cli("export", damaged, "-o", tmp_path / "ds")
    assert out.returncode == 0, out.stderr
    assert "stored columns not read" in out.stderr and "decoding the raw bytes" in out.stderr
    assert pq.read_table(tmp_path / "ds" / "events").num_rows == stored.events == len(list(analyzer.open(path)))


def rewritten(src: str, dst: Path, **record: str) -> None:
    """``src`` copied to ``dst`` with its columns record's values changed."""
    with open(src, "rb") as f, open(dst, "wb") as out:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
        writer = Writer(out)
        writer.start(profile=header.profile, library=header.library)
        schemas = {sid: writer.register_schema(s.name, s.encoding, s.data) for sid, s in summary.schemas.items()}
        channels = {cid: writer.register_channel(c.topic, c.message_encoding, schemas.get(c.schema_id, 0),
                                                 metadata=c.metadata) for cid, c in summary.channels.items()}
        for _s, channel, m in reader.iter_messages(log_time_order=False):
            writer.add_message(channels[channel.id], log_time=m.log_time, data=m.data, publish_time=m.publish_time,
                               sequence=m.sequence)
        for md in reader.iter_metadata():
            writer.add_metadata(md.name, {**md.metadata, **record} if md.name == COLUMNS_RECORD else md.metadata)
        writer.finish()


def test_columns_of_another_decoder_are_left_aside_in_one_line(tmp_path):
    out = converted(tmp_path, [SOCAT_LOG])
    same_copy = tmp_path / "same.mcap"
    rewritten(out, same_copy)
    check_equal(str(same_copy))   # the rewrite alone changes nothing
    other = tmp_path / "other.mcap"
    rewritten(out, other, decoder="0.0.1+000000000000")
    stored, why = stored_events(analyzer.open(str(other)))
    assert stored is None and why is not None
    assert "\n" not in why and "0.0.1+000000000000" in why and "decoding the raw bytes" in why
    assert [e.to_dict() for e in analyzer.open(str(other))] == [e.to_dict() for e in analyzer.open(out, redecode=True)]


def test_columns_of_another_version_are_left_aside_in_one_line(tmp_path):
    out = converted(tmp_path, [SOCAT_LOG])
    other = tmp_path / "v9.mcap"
    rewritten(out, other, version="9")
    stored, why = stored_events(analyzer.open(str(other)))
    assert stored is None and why is not None and "'9'" in why and "\n" not in why


def test_options_that_change_decoding_leave_the_columns_aside(tmp_path):
    out = converted(tmp_path, [SOCAT_LOG])
    stored, why = stored_events(analyzer.open(out, baud=19200))
    assert stored is None and why is not None and "--baud" in why
    stored, why = stored_events(analyzer.open(out, swap_lines=True))
    assert stored is None and why is not None and "--swap-lines" in why


def test_a_record_that_miscounts_its_events_is_refused_when_read(tmp_path):
    out = converted(tmp_path, [SOCAT_LOG])
    other = tmp_path / "miscount.mcap"
    rewritten(out, other, events="5")
    stored, _why = stored_events(analyzer.open(str(other)))
    assert stored is not None
    from analyzer.formats.store_ipc import ColumnsError
    with pytest.raises(ColumnsError, match="their record says 5"):
        for _chunk in stored.chunks():
            pass


def test_a_lean_recording_carries_no_columns_and_is_decoded(tmp_path):
    """``convert --lean``: the recorder stores no columns in a lean recording
    (McapRecorder: ``columns and not lean``); reading it decodes, silently."""
    out = converted(tmp_path, [SOCAT_LOG], "--lean")
    assert columns_record(out) is None and columns_messages(out) == []
    assert stored_events(analyzer.open(out)) == (None, None)
    plain = converted(tmp_path, [SOCAT_LOG], name="plain.mcap")
    assert [e.to_dict() for e in analyzer.open(out)] == [e.to_dict() for e in analyzer.open(plain, redecode=True)]


# ------------------------------------------------------------------ MCAP readers we did not write


@pytest.mark.parametrize("args", [(), ("--lean",)], ids=["default", "lean"])
def test_pymcap_doctor_and_the_go_checker_read_the_columns_whole(tmp_path, args):
    from tests.integration.test_mcap import doctor, go_read

    out = converted(tmp_path, [SOCAT_LOG], *args)
    assert doctor(out) == []
    report = go_read(out)
    messages = columns_messages(out)
    if args:   # lean: none
        assert COLUMNS_TOPIC not in report["messages"] and COLUMNS_RECORD not in report["metadata"]
        return
    assert report["messages"][COLUMNS_TOPIC] == len(messages) == int(columns_record(out)["messages"]) >= 1
    assert report["metadata"][COLUMNS_RECORD] == columns_record(out)
    assert COLUMNS_TOPIC not in report["schemas"]   # schemaless: the Arrow stream carries its schema


def test_pymcap_doctor_and_the_go_checker_read_rotated_parts_whole(tmp_path):
    from tests.integration.test_mcap import doctor, go_read

    parts, _info = record(tmp_path / "rec.mcap", [SOCAT_LOG], rotate_bytes=20_000)
    for part in parts:
        assert doctor(part) == [], part
        assert go_read(part)["messages"].get(COLUMNS_TOPIC, 0) == len(columns_messages(part)), part


def test_the_columns_are_in_chunks_of_their_own(tmp_path):
    out = converted(tmp_path, [SOCAT_LOG])
    with open(out, "rb") as f:
        summary = make_reader(f).get_summary()
    columns = next(cid for cid, c in summary.channels.items() if c.topic == COLUMNS_TOPIC)
    holding = [ci for ci in summary.chunk_indexes if columns in ci.message_index_offsets]
    assert holding and all(list(ci.message_index_offsets) == [columns] for ci in holding)
    assert os.path.getsize(out) > 0
