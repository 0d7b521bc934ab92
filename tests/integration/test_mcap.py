"""MCAP recordings: written by convert (and by the recorder a live tap uses),
read back by readers we did not write (pymcap-cli doctor, the official Go
library), re-dissected into the same events, and readable after a kill."""

import base64
import json
import os
import random
import shutil
import subprocess
import sys

import pytest

import analyzer
from analyzer.sources.base import Chunk
from analyzer.writers.mcap_recorder import McapRecorder
from tests.conftest import ROOT, frame, run_cli

CHECKER_DIR = os.path.join(ROOT, "tests", "interop")
CHECKER = os.path.join(CHECKER_DIR, "mcapcheck")
SAMPLES = os.path.join(ROOT, "captures")


def go_checker() -> str:
    if not os.path.exists(CHECKER):
        if shutil.which("go") is None:
            if os.environ.get("CI"):
                pytest.fail("the Go MCAP checker is not built (.ci/run builds it)")
            pytest.skip("go is not installed")
        subprocess.run(["go", "build", "-o", "mcapcheck", "."], cwd=CHECKER_DIR, check=True, timeout=300)
    return CHECKER


def go_read(path) -> dict:
    out = subprocess.run([go_checker(), str(path)], capture_output=True, text=True, timeout=60, check=False)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


# pymcap-cli reports a SummaryOffset for an empty AttachmentIndex group as an error:
# the Python writer emits that offset even when a file has no attachments (a known
# false alarm; we write no attachments), and likewise for an empty ChunkIndex group
# in a recording without messages (written unchunked). Anything else fails the test.
KNOWN_FALSE_ALARMS = {"SUMMARY_OFFSET_WITHOUT_GROUP"}
EMPTY_GROUPS = ("AttachmentIndex", "ChunkIndex")


# the checker installed beside the interpreter running the tests (the venv's, also when
# the venv is not activated), else the one on PATH
PYMCAP_CLI = shutil.which("pymcap-cli", path=os.path.dirname(sys.executable)) or "pymcap-cli"


def doctor(path) -> list[dict]:
    out = subprocess.run([PYMCAP_CLI, "doctor", "--format", "jsonl", str(path)],
                         capture_output=True, text=True, timeout=120, check=False)
    rows = [json.loads(line) for line in out.stdout.splitlines() if line.strip().startswith("{")]
    assert rows, out.stdout + out.stderr
    problems = []
    for row in rows:
        for item in row.get("diagnostics", [row]):
            sev = item.get("severity")
            if sev in ("error", "warning") and not (item.get("code") in KNOWN_FALSE_ALARMS
                                                    and any(group in item.get("message", "") for group in EMPTY_GROUPS)):
                problems.append(item)
    return problems


def jsonl(*args) -> list[dict]:
    out = run_cli("decode", *args, "--format", "jsonl")
    assert out.returncode == 0, out.stderr
    return [json.loads(x) for x in out.stdout.splitlines()]


@pytest.mark.parametrize("inputs", [["demo-socat.log"], ["demo-ctl.bin", "demo-dev.bin"], ["demo-bus.bin"]])
def test_convert_then_decode_gives_the_same_events(tmp_path, inputs):
    paths = [os.path.join(SAMPLES, p) for p in inputs]
    out = tmp_path / "c.mcap"
    r = run_cli("convert", *paths, "-o", out)
    assert r.returncode == 0, r.stderr
    assert jsonl(out) == jsonl(*paths)
    # both independent readers accept the file
    assert doctor(out) == []
    report = go_read(out)
    events = jsonl(*paths)
    assert report["profile"] == "gimbalscope" and report["summary"]
    assert report["messages"]["/events"] == len(events)
    assert report["messages"]["/transactions"] == sum(e["kind"] == "command" for e in events)
    assert report["messages"]["/log"] == sum(bool(e["problems"]) for e in events)
    assert report["schemas"]["/log"] == "foxglove.Log (jsonschema)"
    meta = report["metadata"]["gimbalscope"]
    assert meta["tool"].startswith("gimbalscope ") and meta["baud"] == "9600" and meta["host"]
    assert set(meta["lines"].split(",")) == ({"AB"} if len(inputs) == 1 and inputs[0].endswith(".bin") else {"A", "B"})


def raw_only_recorder(path) -> McapRecorder:
    """A live recorder (flushing as it goes) fed the raw bytes of 20 exchanges and
    no events, left open: a tap killed now leaves what it flushed."""
    rec = McapRecorder(str(path), metadata={"tool": "gimbalscope test", "baud": "9600"},
                       start_time=1_795_000_000.0, flush_interval=0.0)
    cmd = frame((1, 1, 1), 0, "P?")
    res = frame((0, 1, 1), 1, "0FA0FC18")
    offsets = {"A": 0, "B": 0}
    for k in range(20):
        t = k * 0.1
        for line, data, when in (("A", cmd, t), ("B", b"\x06", t + 0.02), ("B", res, t + 0.025)):
            rec.raw(Chunk(line, data, when), offsets[line])
            offsets[line] += len(data)
    return rec


def test_killed_recorder_leaves_a_file_that_reads_and_recovers(tmp_path):
    path = tmp_path / "live.mcap"
    rec = raw_only_recorder(path)
    # SIGKILL now: no summary, no footer; what was flushed is on disk
    killed = tmp_path / "killed.mcap"
    shutil.copyfile(path, killed)
    events = list(analyzer.open(str(killed)))
    assert [e.kind for e in events[:3]] == ["command", "ack", "result"]
    assert sum(e.kind == "command" for e in events) == 20
    assert events[2].fields == {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    assert all(e.status == "ok" for e in events if e.kind == "command")
    r = run_cli("recover", killed, "-o", tmp_path / "fixed.mcap")
    assert r.returncode == 0, r.stderr
    assert "60 messages" in r.stdout
    assert doctor(tmp_path / "fixed.mcap") == []
    fixed = go_read(tmp_path / "fixed.mcap")
    assert fixed["messages"]["/serial/A/raw"] == 20
    assert fixed["metadata"]["gimbalscope"]["baud"] == "9600"     # written at the start, kept
    assert fixed["metadata"]["gimbalscope.recover"]["messages"] == "60"
    assert jsonl(tmp_path / "fixed.mcap") == jsonl(killed)
    rec.close()


def test_cut_file_reads_with_a_warning(tmp_path):
    full = tmp_path / "full.mcap"
    run_cli("convert", os.path.join(SAMPLES, "demo-socat.log"), "-o", full)
    data = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) - 200])   # summary and footer gone
    out = run_cli("decode", cut)
    assert out.returncode == 0
    assert "ends early" in out.stderr and "Traceback" not in out.stderr


@pytest.mark.parametrize("args,fragment", [
    (["convert", "captures/demo-bus.bin"], "the following arguments are required: -o/--output"),
    (["convert", "captures/demo-bus.bin", "-o", "/nonexistent-dir/x.mcap"], "cannot write"),
    (["recover", "captures/demo-bus.bin", "-o", "/tmp/never.mcap"], "not an MCAP file"),
])
def test_convert_and_recover_errors(args, fragment):
    out = run_cli(*args)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and fragment in out.stderr


def test_convert_refuses_to_overwrite(tmp_path):
    out = tmp_path / "x.mcap"
    out.write_bytes(b"keep me")
    r = run_cli("convert", os.path.join(SAMPLES, "demo-bus.bin"), "-o", out)
    assert r.returncode == 2 and "exists" in r.stderr and out.read_bytes() == b"keep me"


def test_reader_process_gives_the_same_events_and_warnings(tmp_path, monkeypatch):
    """Large recordings are read in a second process; every file goes that way here."""
    from analyzer.sources import mcapfile

    full = tmp_path / "full.mcap"
    assert run_cli("convert", os.path.join(SAMPLES, "demo-socat.log"), "-o", full).returncode == 0
    data = full.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) - 200])
    inline = {p: [e.to_dict() for e in analyzer.open(str(p))] for p in (full, cut)}
    monkeypatch.setattr(mcapfile, "READER_PROCESS_MIN", 0)
    for p in (full, cut):
        warnings = []
        cap = analyzer.open(str(p), on_warning=warnings.append)
        assert [e.to_dict() for e in cap] == inline[p]
        assert any("ends early" in w for w in warnings) == (p == cut)
    # a consumer that stops early stops the reader process too
    from analyzer import worker_process

    started = []
    real_start = worker_process.start
    monkeypatch.setattr(worker_process, "start", lambda *a, **kw: started.append(real_start(*a, **kw))
                        or started[-1])
    it = iter(analyzer.open(str(full)))
    next(it)
    it.close()
    assert len(started) == 1 and not started[0].is_alive()


@pytest.mark.parametrize("lines", [1, 2])
def test_convert_of_an_empty_capture_is_a_whole_recording(tmp_path, lines):
    """No bytes at all: the recording still holds its schemas and raw channels (so
    other readers accept it and it says which lines it had), and reads back as an
    empty capture rather than being rejected."""
    inputs = []
    for k in range(lines):
        p = tmp_path / f"empty{k}.bin"
        p.write_bytes(b"")
        inputs.append(p)
    out = tmp_path / "empty.mcap"
    r = run_cli("convert", *inputs, "-o", out)
    assert r.returncode == 0, r.stderr
    assert doctor(out) == []
    seen = go_read(out)
    assert seen["profile"] == "gimbalscope" and seen["summary"] is True
    from mcap.reader import make_reader
    with open(out, "rb") as f:
        summary = make_reader(f).get_summary()
    topics = {c.topic for c in summary.channels.values()}
    expected = {"/serial/AB/raw"} if lines == 1 else {"/serial/A/raw", "/serial/B/raw"}
    assert expected <= topics and len(summary.schemas) == 5   # raw, event, transaction, log, position
    for cmd in (["decode", out, "--format", "jsonl"], ["stats", out], ["replay", out, "--no-tui", "--speed", "max"]):
        r = run_cli(*cmd)
        assert r.returncode == 0 and r.stdout.strip() == "" or cmd[0] == "stats", (cmd, r.stdout, r.stderr)
        assert "no bytes in this capture" in r.stderr and "error" not in r.stderr, (cmd, r.stderr)


def test_a_recording_in_parts_names_the_part_being_written(tmp_path):
    """A live recording rotated by size: every part is a whole recording, the writer
    names the part it writes now (the TUI shows it and its size), and the parts
    together hold every event."""
    from analyzer.info import CaptureInfo
    from analyzer.runner import Listener, TapRunner
    from analyzer.writers.mcap import McapWriter

    sample = os.path.join(ROOT, "captures", "demo-socat.log")
    capture = analyzer.open(sample)
    info = CaptureInfo.of(capture, command="live")
    writer = McapWriter(str(tmp_path / "rec.mcap"), info, live=True, rotate_bytes=20_000)
    seen: list[str | None] = []

    class Watch(Listener):
        def on_events(self, events):
            seen.append(writer.current_path)

    n = TapRunner(capture, [writer, Watch()], info=info).run()
    parts = sorted(str(p) for p in tmp_path.glob("rec-*.mcap"))
    assert len(parts) >= 3 and parts == writer.recorder.paths
    assert seen[0] == parts[0] and seen[-1] == parts[-1] and set(seen) <= set(parts)
    assert writer.current_path is None   # stopped
    for part in parts:
        assert doctor(part) == []
    assert sum(1 for p in parts for _ in analyzer.open(p)) >= n - len(parts)


# The raw chunk schema of recordings made before the Foxglove schemas: hex bytes,
# null time as a type union.
OLD_RAW_SCHEMA = {"title": "gimbalscope.RawChunk", "type": "object", "properties": {
    "line": {"type": "string", "enum": ["A", "B", "AB"]}, "offset": {"type": "integer"},
    "t": {"type": ["number", "null"]}, "data": {"type": "string", "description": "the bytes, lower-case hex"}},
    "required": ["line", "offset", "t", "data"]}


def test_a_recording_with_hex_bytes_decodes_as_before(tmp_path):
    """Recordings keep their bytes in base64 now; older ones, in hex, still decode."""
    import base64

    from mcap.reader import make_reader
    from mcap.writer import Writer

    new = tmp_path / "new.mcap"
    assert run_cli("convert", os.path.join(SAMPLES, "demo-socat.log"), "-o", new).returncode == 0
    old = tmp_path / "old.mcap"
    with open(new, "rb") as src, open(old, "wb") as dst:
        reader = make_reader(src)
        w = Writer(dst)
        w.start(profile="gimbalscope", library="a recording from before")
        schema = w.register_schema("gimbalscope.RawChunk", "jsonschema", json.dumps(OLD_RAW_SCHEMA).encode())
        channels: dict[str, int] = {}
        for _s, channel, m in reader.iter_messages():
            if not channel.topic.endswith("/raw"):
                continue
            if channel.topic not in channels:
                channels[channel.topic] = w.register_channel(channel.topic, "json", schema)
            msg = json.loads(m.data)
            msg["data"] = base64.b64decode(msg["data"]).hex()
            msg.setdefault("t", None)
            w.add_message(channels[channel.topic], log_time=m.log_time, data=json.dumps(msg).encode(),
                          publish_time=m.publish_time)
        for meta in reader.iter_metadata():   # the recording's settings, as it was written with
            w.add_metadata(meta.name, meta.metadata)
        w.finish()
    decoded = [run_cli("decode", path, "--format", "jsonl") for path in (new, old)]
    assert all(r.returncode == 0 for r in decoded), [r.stderr for r in decoded]
    assert decoded[0].stdout.count("\n") > 100 and decoded[0].stdout == decoded[1].stdout


def test_a_recording_is_indexed_for_the_app_and_its_times_are_its_log_times(tmp_path):
    """Recording layout (docs/foxglove.md, "Size"): every chunk has a message index
    for each channel it holds (the Foxglove app's indexed reader takes a chunk's
    messages from them), and a message's log time is the capture's start plus the
    event's t, to the nanosecond: /events, /transactions and positions carry no t of
    their own, nor /events the bytes, which are on the raw topics."""
    from mcap.reader import make_reader
    from mcap.records import ChunkIndex

    log = os.path.join(SAMPLES, "demo-socat.log")
    out = tmp_path / "c.mcap"
    assert run_cli("convert", log, "-o", out).returncode == 0
    events = jsonl(log)
    with open(out, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary.chunk_indexes
        assert all(isinstance(c, ChunkIndex) and c.message_index_offsets for c in summary.chunk_indexes)
        indexed = {cid for c in summary.chunk_indexes for cid in c.message_index_offsets}
        by_topic: dict[str, list] = {}
        for _schema, channel, msg in reader.iter_messages(log_time_order=False):
            data = json.loads(msg.data) if channel.message_encoding == "json" else msg.data   # stored columns: Arrow IPC
            by_topic.setdefault(channel.topic, []).append((msg.log_time, data))
            assert channel.id in indexed
    recorded = by_topic["/events"]
    assert [m["number"] for _ts, m in recorded] == [e["number"] for e in events]
    first_raw_ts, first_raw = by_topic["/serial/A/raw"][0]
    start_ns = first_raw_ts - round(first_raw["t"] * 1e9)
    for (ts, msg), ev in zip(recorded, events):
        assert "t" not in msg and "raw" not in msg
        assert ts - start_ns == round(ev["t"] * 1e9), ev["number"]
    commands = {e["number"]: e for e in events if e["kind"] == "command"}
    for ts, txn in by_topic["/transactions"]:
        assert "t" not in txn and ts - start_ns == round(commands[txn["number"]]["t"] * 1e9)
    # an event's bytes are on its line's raw topic at its offset
    lines = {line: b"".join(base64.b64decode(m["data"]) for _ts, m in by_topic[f"/serial/{line}/raw"])
             for line in "AB"}
    for ev in events:
        assert lines[ev["line"]][ev["offset"]:ev["offset"] + len(ev["raw"]) // 2].hex() == ev["raw"]


def test_a_recording_read_by_the_reader_process_reports_its_progress(tmp_path, monkeypatch):
    # large recordings are read by a second process; its bytes read reach the
    # progress bar's meter as it goes (after every 4096 raw chunks), up to the
    # whole file at the end
    from analyzer.simulation.traffic import generate
    from analyzer.sources import mcapfile
    from analyzer.sources.meter import READS

    log = tmp_path / "tap.log"
    log.write_text(generate(4000, baud=115200, seed=2).socat_log())
    rec = tmp_path / "rec.mcap"
    assert run_cli("convert", log, "--baud", "115200", "-o", rec).returncode == 0
    monkeypatch.setattr(mcapfile, "READER_PROCESS_MIN", 0)
    READS.clear()
    seen = []
    for k, _ev in enumerate(analyzer.open(str(rec))):
        if k % 500 == 0:
            seen.append(READS.done())
    size = rec.stat().st_size
    assert READS.total() == size and READS.done() == size
    assert seen == sorted(seen) and any(0 < n < size for n in seen)
    READS.clear()


def test_a_chunk_that_zstd_would_make_larger_is_stored_as_it_is(tmp_path):
    # a live tap closes a chunk every second: at a quiet moment it holds one
    # read, a burst of line noise (random bytes) that zstd cannot make smaller;
    # a busy second's chunk compresses
    from mcap.reader import make_reader

    path = tmp_path / "quiet.mcap"
    now = [0.0]                                 # the tap's clock: a flush a second
    rec = McapRecorder(str(path), metadata={"tool": "gimbalscope test", "baud": "9600"},
                       start_time=1_795_000_000.0, flush_interval=1.0, clock=lambda: now[0])
    now[0] = 1.0
    rec.raw(Chunk("B", b"\x06", 0.5), 0)        # the first chunk: with the schemas and channels
    noise = random.Random(16).randbytes(16)
    now[0] = 2.0
    rec.raw(Chunk("B", noise, 0.6), 1)          # alone in its chunk
    cmd = frame((1, 1, 1), 0, "P?")
    for k in range(200):                        # 200 polls in one chunk, within the second
        rec.raw(Chunk("A", cmd, 1.0 + k * 0.01), k * len(cmd))
    rec.close()
    with open(path, "rb") as f:
        chunks = list(make_reader(f).get_summary().chunk_indexes)
    assert [c.compression for c in chunks] == ["zstd", "", "zstd"]
    assert chunks[1].compressed_size == chunks[1].uncompressed_size
    assert all(c.compressed_size < c.uncompressed_size for c in chunks if c.compression)
    assert doctor(path) == []
    assert [e["kind"] for e in jsonl(path)][:3] == ["ack", "noise", "command"]
