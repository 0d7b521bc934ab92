"""The event store's columns as Arrow IPC (analyzer/formats/store_ipc.py): what a
recording carries so that opening it needs no decoding. A store's chunks
encoded and read back, in batches of any size and across parts that code their
tables each their own way, must give back exactly the events stored; bytes
that are not such columns must raise ``ColumnsError`` and nothing else; and
other readers (pyarrow, DuckDB, Polars) must read the same bytes with the
documented columns."""

from __future__ import annotations

import io
import json
import tempfile
from decimal import Decimal
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import analyzer
from analyzer.formats.store import EventStore
from analyzer.formats.store_ipc import ColumnsError, Joiner, Tables, decode, encode
from analyzer.simulation.traffic import generate
from dissectors.event import NOISE, Event
from tests.pure.test_tui_store import SAMPLES, same

DECODER = "test+000000000000"
COLUMN_TYPES = {   # docs/mcap.md, "Stored columns": the record batch's columns, in order
    "number": "int64", "t_ns": "int64", "duration_ns": "int64", "offset": "int64",
    "kind": "uint8", "line": "uint8", "status": "uint8", "flags": "uint8",
    "command": "uint32", "device": "uint32", "latency": "double", "request": "int64", "txn": "int64",
    "raw": "binary", "problems": "string", "fields": "string", "azimuth_deg": "double", "elevation_deg": "double",
}
HOSTILE = {"bit_error_rate": 0.03, "drop_ack_rate": 0.05, "noise_rate": 0.05}

_cache: dict[str, list[Event]] = {}


def sample(paths: tuple[str, ...]) -> list[Event]:
    key = "|".join(paths)
    if key not in _cache:
        _cache[key] = list(analyzer.open(*paths))
    return _cache[key]


def hostile(form: str, seed: int = 7, commands: int = 400) -> list[Event]:
    """The events of a hostile line (bit errors, dropped ACKs, noise) as ``form``:
    one untimed raw dump, two untimed raw dumps, or a timed socat log."""
    key = f"{form}/{seed}/{commands}"
    if key in _cache:
        return _cache[key]
    tr = generate(commands, baud=9600, seed=seed, **HOSTILE)
    folder = Path(tempfile.mkdtemp(prefix="store-ipc-"))   # shared by the property tests' examples
    if form == "single":
        (folder / "bus.bin").write_bytes(tr.single_line())
        paths = [folder / "bus.bin"]
    elif form == "two":
        (folder / "a.bin").write_bytes(tr.line_bytes("A"))
        (folder / "b.bin").write_bytes(tr.line_bytes("B"))
        paths = [folder / "a.bin", folder / "b.bin"]
    else:
        (folder / "socat.log").write_text(tr.socat_log(nanoseconds=form == "socat-ns"))
        paths = [folder / "socat.log"]
    events = _cache[key] = list(analyzer.open(*map(str, paths)))
    return events


def encoded(events: list[Event], sizes: list[int], store: EventStore | None = None) -> list[bytes]:
    """``events`` as the recorder writes them: a message each ``sizes`` events (the
    rest in one more), each with the store's whole tables so far."""
    store = store if store is not None else EventStore()
    out = []
    k = 0
    for n in [*sizes, len(events) - sum(sizes)]:
        store.append(events[k:k + n])
        k += n
        tables = Tables(store.line_values, store.device_values, store.command_places)
        out.append(encode(store.take(), tables, DECODER))
    return out


def read_back(messages: list[bytes]) -> EventStore:
    joiner, store = Joiner(), EventStore()
    for data in messages:
        store.append_chunk(joiner.chunk(data))
    assert joiner.decoder == DECODER
    return store


def same_events(store: EventStore, events: list[Event]) -> None:
    assert len(store) == len(events)
    for i, ev in enumerate(events):
        same(store.event(i), ev)


def round_trip(events: list[Event], sizes: list[int]) -> EventStore:
    direct = EventStore()
    direct.append(events)
    store = read_back(encoded(events, sizes))
    same_events(store, events)
    # what the store's readers read: the error rows, the codes' values
    assert list(store.errors) == list(direct.errors)
    assert [store.line_values[c] for c in store.line] == [direct.line_values[c] for c in direct.line]
    assert [store.device_values[c] for c in store.device] == [direct.device_values[c] for c in direct.device]
    return store


# ------------------------------------------------------------------ round trips


@pytest.mark.parametrize("paths", SAMPLES, ids=lambda p: p[0].split("/")[-1])
@pytest.mark.parametrize("sizes", [[], [1], [0, 1, 0], [1, 50, 0, 200], [7] * 20], ids=str)
def test_sample_captures_come_back_whole_in_batches_of_any_size(paths, sizes):
    round_trip(sample(paths), sizes)


@pytest.mark.parametrize("form", ["single", "two", "socat", "socat-ns"])
def test_hostile_lines_come_back_whole(form):
    events = hostile(form)
    assert any(e.problems for e in events) and any(e.kind == NOISE for e in events)
    assert (events[0].t is None) == (form in ("single", "two"))
    round_trip(events, [1, 0, 97, 300])


def test_one_event_and_no_event_are_messages_too():
    events = sample(SAMPLES[1])
    store = read_back(encoded(events[:1], []))
    same_events(store, events[:1])
    empty = encoded([], [])
    assert len(empty) == 1
    assert len(read_back(empty)) == 0
    # an empty message between two others changes nothing
    messages = encoded(events, [10, 0])
    assert len(messages) == 3
    same_events(read_back(messages), events)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(form=st.sampled_from(["single", "two", "socat"]), seed=st.integers(1, 4),
       sizes=st.lists(st.integers(0, 200), max_size=8))
def test_hostile_lines_in_any_batches_come_back_whole(form, seed, sizes):
    events = hostile(form, seed, commands=150)
    left = len(events)
    fitted = []
    for n in sizes:
        fitted.append(min(n, left))
        left -= fitted[-1]
    round_trip(events, fitted)


def test_parts_that_code_their_tables_differently_join_as_one_store():
    """Each part of a recording in parts has a store of its own: its codes number
    the values in the order that part met them. The joiner maps every part's
    codes to one store's."""
    events = hostile("two")
    # a cut where the next part meets line B (and new devices) first
    cut = next(i for i, ev in enumerate(events) if i > 50 and ev.line == "B" and events[i - 1].line == "A")
    first = encoded(events[:cut], [cut // 2])
    second_store = EventStore()
    second_store.base = cut   # the next part's recorder numbers on
    second = encoded(events[cut:], [40], store=second_store)
    one = decode(first[-1], 0).tables
    two = decode(second[0], 0).tables
    assert one.lines != two.lines and set(one.lines) == set(two.lines)   # B is code 1 in the second
    assert one.commands != two.commands[:len(one.commands)]
    store = read_back(first + second)
    same_events(store, events)
    direct = EventStore()
    direct.append(events)
    assert store.line_values == direct.line_values


def test_a_part_that_does_not_follow_on_is_refused():
    events = sample(SAMPLES[1])
    messages = encoded(events, [100])
    joiner = Joiner()
    joiner.chunk(messages[0])
    joiner.chunk(messages[1])
    with pytest.raises(ColumnsError, match="do not follow"):
        joiner.chunk(messages[1])   # the same events again
    other = Joiner()
    with pytest.raises(ColumnsError, match="do not follow"):
        other.chunk(messages[1])   # not from the first event


def test_messages_of_two_decoders_are_refused():
    events = sample(SAMPLES[1])
    store = EventStore()
    store.append(events[:10])
    a = encode(store.take(), Tables(store.line_values, store.device_values, store.command_places), "one")
    store.append(events[10:20])
    b = encode(store.take(), Tables(store.line_values, store.device_values, store.command_places), "two")
    joiner = Joiner()
    joiner.chunk(a)
    with pytest.raises(ColumnsError, match="two decoders"):
        joiner.chunk(b)


# ------------------------------------------------------------------ what is not ours


pa = pytest.importorskip("pyarrow")


def a_message(n: int = 30) -> bytes:
    return encoded(sample(SAMPLES[1])[:n], [])[0]


def rewritten(data: bytes, change) -> bytes:
    """``data`` read by pyarrow, its table changed by ``change``, written back."""
    table = pa.ipc.open_stream(data).read_all()
    table = change(table)
    sink = io.BytesIO()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table)
    return sink.getvalue()


def with_metadata(data: bytes, **changes: str | None) -> bytes:
    def change(table):
        meta = {k.decode(): v.decode() for k, v in table.schema.metadata.items()}
        for k, v in changes.items():
            if v is None:
                meta.pop(k, None)
            else:
                meta[k] = v
        return table.replace_schema_metadata(meta)
    return rewritten(data, change)


def with_column(data: bytes, name: str, values) -> bytes:
    def change(table):
        i = table.schema.get_field_index(name)
        return table.set_column(i, table.schema.field(i), pa.array(values, table.schema.field(i).type))
    return rewritten(data, change)


def refused(data: bytes) -> str:
    with pytest.raises(ColumnsError) as e:
        Joiner().chunk(data)
    return str(e.value)


def test_our_bytes_rewritten_by_pyarrow_still_read():
    # the checks below change one thing; unchanged, pyarrow's rewrite reads as ours
    data = a_message()
    same_events(read_back([rewritten(data, lambda t: t)]), sample(SAMPLES[1])[:30])


@pytest.mark.parametrize("data", [b"", b"\x00", b"PAR1", b"\xff\xff\xff\xff\x08\x00\x00\x00garbage!", bytes(range(256))],
                         ids=["empty", "zero", "parquet", "bad-ipc", "bytes"])
def test_bytes_that_are_not_arrow_are_refused(data):
    assert refused(data)


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=2000))
def test_random_bytes_are_refused(data):
    refused(data)


def test_a_message_cut_short_is_refused():
    data = a_message()
    for cut in (1, 8, len(data) // 3, len(data) // 2, len(data) - 9):
        refused(data[:cut])


def test_another_version_is_refused():
    assert "version '2'" in refused(with_metadata(a_message(), **{"gimbalscope.columns": "2"}))
    assert "version None" in refused(with_metadata(a_message(), **{"gimbalscope.columns": None}))


def test_another_column_list_is_refused():
    data = a_message()
    assert "columns" in refused(rewritten(data, lambda t: t.drop_columns(["fields"])))
    assert "columns" in refused(rewritten(data, lambda t: t.rename_columns([*t.column_names[:-1], "other"])))
    assert "columns" in refused(rewritten(data, lambda t: t.select(list(reversed(t.column_names)))))


def test_an_arrow_stream_that_is_not_ours_is_refused():
    table = pa.table({"x": [1, 2, 3]})
    sink = io.BytesIO()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table)
    refused(sink.getvalue())


def test_two_record_batches_are_refused():
    table = pa.ipc.open_stream(a_message()).read_all()
    sink = io.BytesIO()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table.slice(0, 10))
        writer.write_table(table.slice(10))
    assert "record batches" in refused(sink.getvalue())


@pytest.mark.parametrize("name", ["lines", "devices", "commands"])
def test_tables_that_do_not_read_are_refused(name):
    assert "tables" in refused(with_metadata(a_message(), **{name: "{not json"}))
    assert "tables" in refused(with_metadata(a_message(), **{name: None}))


def test_a_command_entry_past_the_command_table_is_refused():
    data = a_message()
    meta = pa.ipc.open_stream(data).schema.metadata
    commands = json.loads(meta[b"commands"])
    commands[1] = [commands[1][0], 10_000]   # no such place in COMMANDS
    assert "command entry" in refused(with_metadata(data, commands=json.dumps(commands)))


@pytest.mark.parametrize("name", ["command", "device", "line"])
def test_a_code_past_its_table_is_refused(name):
    data = a_message()
    table = pa.ipc.open_stream(data).read_all()
    values = table.column(name).to_pylist()
    values[3] = 200
    assert "past" in refused(with_column(data, name, values))


# ------------------------------------------------------------------ other readers


def events_and_table(events: list[Event]):
    data = encoded(events, [])[0]
    return data, pa.ipc.open_stream(data).read_all()


def ns(t: float) -> int:
    """``round(t, 9)`` as the event contract writes it, in nanoseconds, exactly."""
    return int(Decimal(repr(round(t, 9))).scaleb(9))


@pytest.mark.parametrize("events", [lambda: sample(SAMPLES[1]), lambda: hostile("socat-ns"), lambda: hostile("two")],
                         ids=["socat", "hostile-socat-ns", "hostile-untimed"])
def test_pyarrow_reads_the_documented_columns(events):
    events = events()
    _data, table = events_and_table(events)
    assert {f.name: str(f.type) for f in table.schema} == COLUMN_TYPES
    assert list(table.column_names) == list(COLUMN_TYPES)
    meta = {k.decode(): v.decode() for k, v in table.schema.metadata.items()}
    assert meta["gimbalscope.columns"] == "1" and meta["decoder"] == DECODER
    kinds, statuses = json.loads(meta["kinds"]), json.loads(meta["statuses"])
    lines, devices = json.loads(meta["lines"]), json.loads(meta["devices"])
    commands = json.loads(meta["commands"])
    rows = table.to_pylist()
    assert len(rows) == len(events)
    for row, ev in zip(rows, events):
        assert row["number"] == ev.number
        assert kinds[row["kind"]] == ev.kind and statuses[row["status"]] == ev.status
        assert lines[row["line"]] == ev.line and devices[row["device"]] == ev.device
        assert (commands[row["command"]] or [None])[0] == ev.command
        assert row["raw"] == ev.raw and row["offset"] == ev.offset
        assert (row["request"] or None) == ev.request
        assert (row["txn"] - 1 if row["txn"] else None) == ev.txn
        if ev.t is None:
            assert row["flags"] & 1 and row["t_ns"] == 0
        else:
            assert not row["flags"] & 1
            assert row["t_ns"] == ns(ev.t) and row["t_ns"] + row["duration_ns"] == ns(ev.t_end)
        problems = json.loads(row["problems"]) if row["problems"] else []
        assert [text for _id, text in problems] == [str(p) for p in ev.problems]


def test_times_by_hand():
    # the first events of the sample socat log, their times read off the log
    events = sample(SAMPLES[1])
    _data, table = events_and_table(events)
    t_ns = table.column("t_ns").to_pylist()
    dur = table.column("duration_ns").to_pylist()
    for i in (0, 1, 2, 100, len(events) - 1):
        d = events[i].to_dict()
        assert t_ns[i] == round(Decimal(str(d["t"])) * 10 ** 9)
        assert t_ns[i] + dur[i] == round(Decimal(str(d["t_end"])) * 10 ** 9)
    assert t_ns[0] == 0 and events[0].t == 0.0
    assert events[5].to_dict()["t"] == 0.082935 and t_ns[5] == 82_935_000


def test_times_with_nanoseconds_by_hand():
    events = hostile("socat-ns")
    _data, table = events_and_table(events)
    t_ns = table.column("t_ns").to_pylist()
    with_ns = [i for i, ev in enumerate(events) if ev.t is not None and ns(ev.t) % 1000][:5]
    assert with_ns, "the log's times have nanoseconds"
    for i in with_ns:
        assert t_ns[i] == ns(events[i].t)
        assert Decimal(t_ns[i]) / 10 ** 9 == Decimal(repr(events[i].to_dict()["t"]))


def test_duckdb_reads_the_columns():
    duckdb = pytest.importorskip("duckdb")
    events = sample(SAMPLES[1])
    _data, table = events_and_table(events)
    con = duckdb.connect()
    con.register("cols", table)
    types = dict(con.execute("select column_name, column_type from (describe cols)").fetchall())
    assert types == {"number": "BIGINT", "t_ns": "BIGINT", "duration_ns": "BIGINT", "offset": "BIGINT",
                     "kind": "UTINYINT", "line": "UTINYINT", "status": "UTINYINT", "flags": "UTINYINT",
                     "command": "UINTEGER", "device": "UINTEGER", "latency": "DOUBLE", "request": "BIGINT",
                     "txn": "BIGINT", "raw": "BLOB", "problems": "VARCHAR", "fields": "VARCHAR",
                     "azimuth_deg": "DOUBLE", "elevation_deg": "DOUBLE"}
    kinds = json.loads(table.schema.metadata[b"kinds"])
    got = con.execute("select kind, count(*) from cols group by kind").fetchall()
    want: dict[str, int] = {}
    for ev in events:
        want[ev.kind] = want.get(ev.kind, 0) + 1
    assert {kinds[k]: n for k, n in got} == want
    first = con.execute("select number, t_ns, raw from cols order by number limit 3").fetchall()
    assert [(n, t, bytes(r)) for n, t, r in first] == [(ev.number, ns(ev.t), ev.raw) for ev in events[:3]]


def test_polars_reads_the_columns():
    pl = pytest.importorskip("polars")
    events = sample(SAMPLES[1])
    data, _table = events_and_table(events)
    frame = pl.read_ipc_stream(io.BytesIO(data))
    assert frame.columns == list(COLUMN_TYPES)
    assert dict(zip(frame.columns, map(str, frame.dtypes))) == {
        "number": "Int64", "t_ns": "Int64", "duration_ns": "Int64", "offset": "Int64",
        "kind": "UInt8", "line": "UInt8", "status": "UInt8", "flags": "UInt8",
        "command": "UInt32", "device": "UInt32", "latency": "Float64", "request": "Int64", "txn": "Int64",
        "raw": "Binary", "problems": "String", "fields": "String", "azimuth_deg": "Float64",
        "elevation_deg": "Float64"}
    assert frame["t_ns"].to_list() == [ns(ev.t) for ev in events]
    assert frame["raw"].to_list() == [ev.raw for ev in events]


@pytest.mark.parametrize("name", ["kind", "status"])
def test_a_kind_or_status_code_past_its_table_is_refused(name):
    data = a_message()
    values = pa.ipc.open_stream(data).read_all().column(name).to_pylist()
    values[2] = 99
    assert "past" in refused(with_column(data, name, values))


def test_an_answer_before_its_command_is_refused():
    data = a_message()
    values = pa.ipc.open_stream(data).read_all().column("request").to_pylist()
    values[1] = 5   # event 2 answering event 5
    assert "before" in refused(with_column(data, "request", values))


@pytest.mark.parametrize("text", ["{not json", '[["no_such_problem", "x"]]', '"a string"', "[[1, 2, 3]]"])
def test_problems_that_do_not_read_are_refused(text):
    data = a_message()
    values = pa.ipc.open_stream(data).read_all().column("problems").to_pylist()
    values[4] = text
    assert "problems or fields" in refused(with_column(data, "problems", values))


def test_fields_that_do_not_read_are_refused():
    data = a_message()
    values = pa.ipc.open_stream(data).read_all().column("fields").to_pylist()
    values[0] = "{nope"
    assert "problems or fields" in refused(with_column(data, "fields", values))


def test_metadata_that_is_not_text_is_refused():
    def change(table):
        return table.replace_schema_metadata({**table.schema.metadata, b"lines": b"[null, \"\xff\"]"})
    assert "not text" in refused(rewritten(a_message(), change))


# nanoarrow's IPC reader trusts the bytes it is given (0.9.0 can crash on a changed
# stream that pyarrow refuses), so a recording's columns reach it only from a chunk
# whose CRC holds (analyzer/sources/mcapfile.py): changed bytes anywhere in the
# columns' chunk are refused, never a crash. Run in a process of its own, where a
# crash is an exit status.
FLIPPED = """
import random, sys
sys.path.insert(0, {root!r})
import analyzer
from analyzer.capture.stored import stored_events
from analyzer.formats.store_ipc import ColumnsError
from tests.hostile.test_mcap_hostile import chunks_in
whole = open({path!r}, "rb").read()
offset, length = next((o, n) for o, n, counts in chunks_in(whole) if "/gimbalscope/columns" in counts)
rng = random.Random(1)
refused = 0
for _ in range(300):   # one to four bytes of the columns' chunk record, changed
    b = bytearray(whole)
    for _ in range(rng.randint(1, 4)):
        b[offset + rng.randrange(length)] = rng.randrange(256)
    open({path!r} + ".flipped", "wb").write(bytes(b))
    try:
        stored, _why = stored_events(analyzer.open({path!r} + ".flipped"))
        if stored is not None:
            stored.store()
    except ColumnsError:
        refused += 1
    except analyzer.CaptureError:
        refused += 1
print("no crash", refused)
"""


def test_changed_bytes_in_a_recordings_columns_are_refused_never_a_crash(tmp_path):
    import subprocess
    import sys

    from tests.conftest import ROOT, SOCAT_LOG, run_cli
    path = str(tmp_path / "rec.mcap")
    assert run_cli("convert", SOCAT_LOG, "-o", path).returncode == 0
    out = subprocess.run([sys.executable, "-c", FLIPPED.format(root=ROOT, path=path)], capture_output=True,
                         text=True, timeout=300, check=False, cwd=ROOT)
    assert out.returncode == 0, (out.returncode, out.stderr[-500:])
    said, refused = out.stdout.strip().rsplit(" ", 1)
    assert said == "no crash" and int(refused) > 250   # nearly every change is caught (a few hit padding)
