"""Lean recordings (docs/mcap.md, "Lean recordings"): no /events, the raw reads
batched on /serial/reads in the order they were read across the lines. They
decode to exactly the events of the capture they were made from (times and
line order included), in one file or in parts; the readers we did not write
(pymcap-cli doctor, the official Go library, the jsonschema package through
tests/conftest.py) accept them; the metadata says the profile."""

from __future__ import annotations

import base64
import json
import os
import shutil

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

import analyzer
from analyzer.cli.common import run_tap
from analyzer.formats import mcap_schemas as S
from analyzer.info import CaptureInfo
from analyzer.simulation.traffic import generate
from analyzer.sources.base import Chunk
from analyzer.writers.mcap import McapWriter
from analyzer.writers.mcap_recorder import McapRecorder
from tests.conftest import BUS, CTL, DEV, SOCAT_LOG, frame, run_cli
from tests.integration.test_mcap import doctor, go_read, jsonl
from tests.integration.test_mcap_parts import opened

SAMPLES = {"socat log": [SOCAT_LOG], "two dumps": [CTL, DEV], "single-line dump": [BUS]}


def mcap_messages(path) -> list[tuple[str, int, dict]]:
    """(topic, log time, message) in file order, read by the mcap library."""
    with open(path, "rb") as f:
        return [(channel.topic, message.log_time, json.loads(message.data))
                for _schema, channel, message in make_reader(f).iter_messages(log_time_order=False)
                if channel.message_encoding == "json"]   # not the stored columns (Arrow IPC)


def reads_of(path) -> list[tuple]:
    """The reads a recording holds, in file order, as (line, bytes, t): from a
    lean recording's /serial/reads, or a default one's per-line raw topics."""
    out = []
    for topic, _ts, msg in mcap_messages(path):
        for read in msg["reads"] if topic == "/serial/reads" else [msg] if topic.endswith("/raw") else []:
            out.append((read["line"], base64.b64decode(read["data"], validate=True), read.get("t")))
    return out


def record(path, inputs: list[str], *, rotate_bytes: int) -> list[str]:
    """Record ``inputs`` lean, in parts, as a live tap does; the files written."""
    capture = opened(inputs)
    info = CaptureInfo.of(capture, command="live")
    writer = McapWriter(str(path), info, live=True, rotate_bytes=rotate_bytes, lean=True)
    run_tap(capture, "live", writer, info=info, notes=False, say_empty=False)
    return list(writer.recorder.paths)


def convert(tmp_path, inputs, name, *extra):
    out = tmp_path / name
    r = run_cli("convert", *inputs, "-o", out, *extra)
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.parametrize("inputs", list(SAMPLES.values()), ids=list(SAMPLES))
def test_a_lean_recording_decodes_to_the_events_of_its_capture(tmp_path, inputs):
    lean = convert(tmp_path, inputs, "lean.mcap", "--lean")
    default = convert(tmp_path, inputs, "default.mcap")
    events = jsonl(*inputs)
    assert jsonl(lean) == events
    # the same reads, in the same order across the lines, as the default recording's raw topics
    assert reads_of(lean) == reads_of(default)
    assert os.path.getsize(lean) < os.path.getsize(default)
    assert doctor(lean) == []
    report = go_read(lean)
    assert report["summary"] and report["profile"] == "gimbalscope"
    topics = set(report["messages"])
    assert "/events" not in topics and not any(t.endswith("/raw") for t in topics)
    assert report["messages"]["/transactions"] == sum(e["kind"] == "command" for e in events)
    assert report["messages"]["/log"] == sum(bool(e["problems"]) for e in events)
    assert report["schemas"]["/serial/reads"] == "gimbalscope.RawReads (jsonschema)"
    assert report["metadata"]["gimbalscope"]["profile"] == "lean"
    assert "profile" not in go_read(default)["metadata"]["gimbalscope"]   # the default is as it was


def test_bench_traffic_decodes_the_same_from_a_lean_recording(tmp_path):
    """Saturated traffic with line errors (bench/mcap_bench.py's, shorter): many
    reads a message, both lines interleaved within milliseconds."""
    tr = generate(1500, baud=115200, seed=1, bit_error_rate=0.002, drop_ack_rate=0.002, noise_rate=0.002,
                  think=(0.0, 0.0002), answer_delay=(0.0002, 0.0005))
    log = tmp_path / "tap.log"
    log.write_text(tr.socat_log())
    lean = convert(tmp_path, [log, "--baud", "115200"], "lean.mcap", "--lean")
    default = convert(tmp_path, [log, "--baud", "115200"], "default.mcap")
    events = jsonl(log, "--baud", "115200")
    assert len(events) > 3000
    assert jsonl(lean) == events
    reads = reads_of(lean)
    assert reads == reads_of(default)
    batches = [len(msg["reads"]) for topic, _ts, msg in mcap_messages(lean) if topic == "/serial/reads"]
    assert sum(batches) == len(reads) and max(batches) > 1 and len(batches) < len(reads) / 8
    # each batch's log time is its first read's time on the capture's clock
    first_t = [msg["reads"][0]["t"] for topic, _ts, msg in mcap_messages(lean) if topic == "/serial/reads"]
    times = [ts for topic, ts, _msg in mcap_messages(lean) if topic == "/serial/reads"]
    origin = times[0] - round(first_t[0] * 1e9)
    assert times == [origin + round(t * 1e9) for t in first_t]
    assert doctor(lean) == []
    go_read(lean)


def test_a_large_lean_recording_read_by_the_reader_process_gives_the_same_events(tmp_path, monkeypatch):
    lean = convert(tmp_path, [SOCAT_LOG], "lean.mcap", "--lean")
    inline = [e.to_dict() for e in analyzer.open(str(lean))]
    monkeypatch.setattr("analyzer.sources.mcapfile.READER_PROCESS_MIN", 0)
    assert [e.to_dict() for e in analyzer.open(str(lean))] == inline


@pytest.mark.parametrize("inputs,rotate_bytes", [([SOCAT_LOG], 4_000), ([BUS], 1_000), ([CTL, DEV], 300)],
                         ids=["socat log", "single-line dump", "two dumps"])
def test_a_lean_recording_in_parts_decodes_as_the_whole_capture(tmp_path, inputs, rotate_bytes):
    parts = record(tmp_path / "rec.mcap", inputs, rotate_bytes=rotate_bytes)
    assert len(parts) >= 2, parts
    whole = [e.to_dict() for e in opened(inputs)]
    assert [e.to_dict() for e in analyzer.open(*parts[::-1])] == whole
    for part in parts:
        meta = go_read(part)["metadata"]["gimbalscope"]
        assert meta["profile"] == "lean" and meta["part"]
    assert doctor(parts[1]) == []


def test_a_killed_lean_recording_keeps_what_it_flushed(tmp_path):
    """A live recording flushes its batch of reads with its chunk: a kill loses
    at most what came since the last flush."""
    path = tmp_path / "live.mcap"
    now = [0.0]

    def clock():
        now[0] += 0.1
        return now[0]

    rec = McapRecorder(str(path), metadata={"tool": "gimbalscope test", "profile": "lean"},
                       start_time=1_795_000_000.0, flush_interval=1.0, clock=clock, lean=True)
    cmd = frame((1, 1, 1), 0, "P?")
    res = frame((0, 1, 1), 1, "0FA0FC18")
    offsets = {"A": 0, "B": 0}
    for k in range(20):
        for line, data, when in (("A", cmd, k * 0.1), ("B", b"\x06", k * 0.1 + 0.02), ("B", res, k * 0.1 + 0.025)):
            rec.raw(Chunk(line, data, when), offsets[line])
            offsets[line] += len(data)
    killed = tmp_path / "killed.mcap"
    shutil.copyfile(path, killed)    # SIGKILL now: no summary, the batch in progress lost
    rec.close()
    events = list(analyzer.open(str(killed)))
    commands = sum(e.kind == "command" for e in events)
    assert 15 <= commands < 20
    assert [e.kind for e in events[:3]] == ["command", "ack", "result"]
    assert events[2].fields == {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    whole = [e.to_dict() for e in analyzer.open(str(path))]
    assert sum(e["kind"] == "command" for e in whole) == 20
    # up to its last command (whose answers may be cut off), the events of the whole recording
    cut = max(i for i, e in enumerate(events) if e.kind == "command")
    assert [e.to_dict() for e in events[:cut]] == whole[:cut]
    r = run_cli("recover", killed, "-o", tmp_path / "fixed.mcap")
    assert r.returncode == 0, r.stderr
    assert doctor(tmp_path / "fixed.mcap") == []


def test_an_empty_lean_recording_is_an_empty_capture(tmp_path):
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    out = convert(tmp_path, [empty], "lean.mcap", "--lean")
    assert jsonl(out) == []
    assert doctor(out) == []
    assert go_read(out)["metadata"]["gimbalscope"]["profile"] == "lean"


def test_messages_on_the_reads_topic_that_are_not_reads_are_counted_and_skipped(tmp_path):
    path = tmp_path / "hand.mcap"
    good = {"reads": [{"line": "A", "t": 0.0, "data": base64.b64encode(frame((1, 1, 1), 0, "HO")).decode()},
                      {"line": "B", "t": 0.01, "data": "Bg=="}]}
    bad = [b"not json", b"[]", b'{"reads": []}', b'{"reads": [{"line": "C", "t": 0.2, "data": ""}]}',
           b'{"reads": [{"line": "A", "t": 0.3, "data": "%%%"}]}']
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="", library="test")
        sid = w.register_schema("other.Reads", "jsonschema", S.encoded(S.READS))   # not checked as ours
        ch = w.register_channel("/serial/reads", "json", sid)
        w.add_message(ch, log_time=1, publish_time=1, data=json.dumps(good).encode())
        for k, data in enumerate(bad):
            w.add_message(ch, log_time=2 + k, publish_time=2 + k, data=data)
        w.finish()
    out = run_cli("decode", path, "--format", "jsonl")
    assert out.returncode == 0, out.stderr
    kinds = [json.loads(x)["kind"] for x in out.stdout.splitlines()]
    assert kinds == ["command", "ack"]
    assert "5 messages on /serial/reads were not gimbalscope raw chunks (the first: not JSON)" in out.stderr


def test_lean_is_for_mcap_recordings_only(tmp_path):
    r = run_cli("convert", SOCAT_LOG, "-o", tmp_path / "x.jsonl", "--lean")
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "--lean is for MCAP recordings" in r.stderr
    assert not (tmp_path / "x.jsonl").exists()


def test_demo_records_lean_with_the_flag(tmp_path):
    out = tmp_path / "demo.mcap"
    r = run_cli("demo", "--no-tui", "--seconds", "1", "--format", "jsonl", "--record", out, "--lean")
    assert r.returncode == 0, r.stderr
    printed = [json.loads(x) for x in r.stdout.splitlines()]
    assert printed and jsonl(out) == printed
    report = go_read(out)
    assert report["metadata"]["gimbalscope"]["profile"] == "lean" and "/events" not in report["messages"]
    assert doctor(out) == []
