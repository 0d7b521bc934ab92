"""Lean recordings' messages (docs/mcap.md, "Lean recordings"): no /events, the
raw reads of every line batched on /serial/reads in the order they were read,
with their times; transactions, positions and /log as in the default profile.
Expectations are worked out by hand from the reads given."""

from __future__ import annotations

import base64

from analyzer.formats import mcap_messages as M
from analyzer.formats import mcap_schemas as S
from analyzer.lines import Chunk
from tests.interop.foxglove_schema import parse_json_schema

START = 1_795_000_000.0
START_NS = 1_795_000_000_000_000_000


def collect(**kw):
    out = []
    return out, M.Messages(lambda topic, key, ts, msg: out.append((topic, key, ts, msg)), start_time=START,
                           lean=True, **kw)


def b64(data: bytes) -> str:
    return base64.b64encode(data).decode()


def test_reads_of_both_lines_go_into_one_message_in_the_order_read():
    out, m = collect()
    m.raw(Chunk("A", b"\x02ab", 0.5), 0)
    m.raw(Chunk("B", b"\x06", 0.25), 0)     # read later, stamped earlier (another adapter's clock)
    m.raw(Chunk("A", b"cd", 0.75), 3)
    m.raw(Chunk("A", b"", 0.8), 5)          # an empty read is nothing, as in the default profile
    assert out == []                        # a batch waits until it is full or the input ends
    m.finish()
    assert out == [("/serial/reads", "reads", START_NS + 500_000_000, {"reads": [
        {"line": "A", "t": 0.5, "data": "AmFi"},
        {"line": "B", "t": 0.25, "data": "Bg=="},
        {"line": "A", "t": 0.75, "data": "Y2Q="},
    ]})]


def test_a_batch_holds_at_most_its_count_of_reads():
    out, m = collect()
    n = M.READS_PER_MESSAGE
    for k in range(2 * n + 1):
        m.raw(Chunk("AB", bytes([k % 256]), k * 0.001), k)
    m.finish()
    sizes = [len(msg["reads"]) for _topic, _key, _ts, msg in out]
    assert sizes == [n, n, 1]
    # each message's log time is its first read's
    assert [ts for _topic, _key, ts, _msg in out] == [START_NS, START_NS + n * 1_000_000, START_NS + 2 * n * 1_000_000]
    reads = [r for *_x, msg in out for r in msg["reads"]]
    assert [base64.b64decode(r["data"])[0] for r in reads] == [k % 256 for k in range(2 * n + 1)]


def test_a_batch_spans_at_most_its_time():
    out, m = collect()
    m.raw(Chunk("A", b"x", 1.0), 0)
    m.raw(Chunk("B", b"y", 1.0 + M.READS_SPAN), 0)           # exactly the span: same batch
    m.raw(Chunk("A", b"z", 1.0 + M.READS_SPAN + 0.001), 1)   # beyond it: a new batch
    m.finish()
    assert [[r["data"] for r in msg["reads"]] for *_x, msg in out] == [[b64(b"x"), b64(b"y")], [b64(b"z")]]


def test_untimed_reads_have_no_t_and_their_batch_is_at_its_first_byte_offset():
    out = []
    m = M.Messages(lambda *a: out.append(a), start_time=START, wire_byte_time=0.001, lean=True)
    m.raw(Chunk("A", b"abc"), 10)
    m.raw(Chunk("B", b"d"), 0)
    m.finish()
    assert out == [("/serial/reads", "reads", START_NS + 10_000_000,
                    {"reads": [{"line": "A", "data": "YWJj"}, {"line": "B", "data": "ZA=="}]})]


def test_the_end_marker_is_an_empty_read_at_the_end():
    out, m = collect()
    m.raw(Chunk("A", b"x", 0.1), 0)
    m.end_marker(2.0, "A")
    m.finish()
    assert [msg["reads"] for *_x, msg in out] == [[{"line": "A", "t": 0.1, "data": "eA=="}],
                                                 [{"line": "A", "t": 2.0, "data": ""}]]


def test_flush_reads_sends_the_batch_in_progress():
    out, m = collect()
    m.flush_reads()
    assert out == []
    m.raw(Chunk("A", b"x", 0.1), 0)
    m.flush_reads()
    m.raw(Chunk("B", b"y", 0.2), 0)
    m.finish()
    assert [len(msg["reads"]) for *_x, msg in out] == [1, 1]


def test_no_events_topic_but_transactions_and_positions():
    from analyzer.analysis.pairing import Pairer
    from dissectors.deframer import Deframer
    from tests.conftest import frame

    out, m = collect()
    pairer = Pairer()
    deframers = {"A": Deframer(line="A"), "B": Deframer(line="B")}
    for line, data, t in (("A", frame((1, 1, 1), 0, "P?"), 0.0), ("B", b"\x06", 0.02),
                          ("B", frame((0, 1, 1), 1, "0FA0FC18"), 0.03)):
        m.raw(Chunk(line, data, t), 0)
        for ev in pairer.push_many(deframers[line].feed(data, t)):
            m.event(ev)
    m.finish()
    topics = [topic for topic, *_x in out]
    assert S.EVENTS_TOPIC not in topics
    assert topics.count(S.READS_TOPIC) == 1 and topics.count(S.TRANSACTIONS_TOPIC) == 1
    assert "/gimbal/1.1.1/position" in topics     # the P? report
    (reads,) = [msg["reads"] for topic, *_x, msg in out if topic == S.READS_TOPIC]
    assert [(r["line"], r["t"]) for r in reads] == [("A", 0.0), ("B", 0.02), ("B", 0.03)]


def test_the_reads_schema_reads_in_the_app_and_lean_recordings_register_no_event_schema():
    types = {name: {f["name"]: f for f in fields}
             for name, fields in parse_json_schema(S.READS, S.READS["title"]).items()}
    assert types["gimbalscope.RawReads"]["reads"] == {"name": "reads", "type": "gimbalscope.RawReads.reads",
                                                      "isComplex": True, "isArray": True}
    read = types["gimbalscope.RawReads.reads"]
    assert read["data"] == {"name": "data", "type": "uint8", "isArray": True}
    assert read["t"]["type"] == "float64" and read["line"]["type"] == "string"
    assert set(S.LEAN_SCHEMAS) == {"reads", "txn", "log", "position"}
    assert "reads" not in S.SCHEMAS   # the default recording is as it was
