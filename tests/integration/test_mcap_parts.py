"""Several MCAP recordings of one tap read as one capture (docs/time.md, "Parts"):
the parts of a recording in parts decode, in whatever order they are given, to
the events of the capture they were recorded from, numbered on and paired
across every boundary; recordings of another tap, or of overlapping times, are
refused in one line; and the recording's ``gimbalscope`` metadata record is read
back (``McapSource.metadata``), a garbled one said and left aside."""

from __future__ import annotations

import base64
import dataclasses
import json
import random
from collections.abc import Iterator
from itertools import chain
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

import analyzer
from analyzer.cli.common import run_tap
from analyzer.info import CaptureInfo
from analyzer.sources import LINE_A, LINE_AB, LINE_B, CaptureError, Chunk, Source, detect
from analyzer.sources.mcapfile import McapSource
from analyzer.sources.mcapparts import McapPartsSource
from analyzer.writers.mcap import McapWriter
from tests.conftest import BUS, CTL, DEV, SOCAT_LOG, run_cli

# the sample, and how much to record per part for it to come out in several parts
SAMPLES = {"socat log": ([SOCAT_LOG], 20_000), "single-line dump": ([BUS], 4_000), "two dumps": ([CTL, DEV], 4_000)}
FIELDS = ("number", "kind", "line", "command", "status", "latency", "request", "txn")
START = 1_795_000_000.0
SLICE = 64   # bytes per chunk of a raw dump read in slices


class Sliced(Source):
    """Raw dumps read a few bytes at a time, as a live tap without time would:
    a raw dump is otherwise one chunk, and a recording of it one part."""

    timed = False

    def __init__(self, paths: list[str]) -> None:
        super().__init__()
        self.lines = (LINE_AB,) if len(paths) == 1 else (LINE_A, LINE_B)
        self.data = {}
        for line, path in zip(self.lines, paths):
            with open(path, "rb") as f:
                self.data[line] = f.read()
        self.description = " ".join(paths) + " (in slices)"

    def line_chunks(self, line: str) -> Iterator[Chunk]:
        data = self.data[line]
        return (Chunk(line, data[i:i + SLICE]) for i in range(0, len(data), SLICE))

    def chunks(self) -> Iterator[Chunk]:
        return chain.from_iterable(map(self.line_chunks, self.lines))


def opened(inputs: list[str]) -> analyzer.Capture:
    """The capture of ``inputs``; raw dumps read in slices."""
    if inputs[0].endswith(".bin"):
        capture = analyzer.Capture(Sliced(inputs))
        capture.inputs = tuple(inputs)
        return capture
    return analyzer.open(*inputs)


def record(path, inputs: list[str], *, rotate_bytes: int | None = None, start_time: float | None = None,
           **metadata: str) -> tuple[list[str], CaptureInfo]:
    """Record ``inputs`` as a live tap does (metadata first, flushed as it goes);
    ``metadata`` overrides keys of its record. Returns the files written."""
    capture = opened(inputs)
    info = CaptureInfo.of(capture, command="live")
    if start_time is not None:
        info = dataclasses.replace(info, start_time=start_time)
    writer = McapWriter(str(path), info, live=True, rotate_bytes=rotate_bytes, metadata=metadata)
    run_tap(capture, "live", writer, info=info, notes=False, say_empty=False)
    rec = writer.recorder
    return (list(rec.paths) if rotate_bytes else [str(path)]), info


def summary(events) -> list[tuple]:
    return [tuple(getattr(ev, name) for name in FIELDS) for ev in events]


def shuffled(paths: list[str]) -> list[str]:
    out = list(paths)
    random.Random(7).shuffle(out)
    assert out != paths
    return out


@pytest.fixture(params=list(SAMPLES))
def rotated(request, tmp_path):
    inputs, rotate_bytes = SAMPLES[request.param]
    parts, _info = record(tmp_path / "rec.mcap", inputs, rotate_bytes=rotate_bytes)
    assert len(parts) >= 3, parts
    return inputs, parts


# ------------------------------------------------------------------ parts as one capture

def test_parts_in_any_order_decode_as_the_whole_capture(rotated):
    inputs, parts = rotated
    whole = summary(analyzer.open(*inputs))
    capture = analyzer.open(*shuffled(parts))
    assert isinstance(capture.source, McapPartsSource)
    assert capture.source.description == f"{parts[0]} + {len(parts) - 1} more parts (MCAP)"
    events = summary(capture)
    assert events == whole
    assert [e[0] for e in events] == list(range(1, len(events) + 1))
    assert capture.warnings == []


def test_the_cli_decodes_parts_given_in_any_order(rotated):
    inputs, parts = rotated
    out = run_cli("decode", "--format", "jsonl", *shuffled(parts))
    assert out.returncode == 0, out.stderr
    whole = run_cli("decode", "--format", "jsonl", *inputs)
    keep = ("number", "kind", "command", "status", "latency", "request", "txn", "t")
    assert [{k: e[k] for k in keep} for e in map(json.loads, out.stdout.splitlines())] == \
        [{k: e[k] for k in keep} for e in map(json.loads, whole.stdout.splitlines())]


def raw_spans(path: str) -> dict[str, tuple[int, int]]:
    """Each line's byte offsets a part holds, from its raw messages."""
    spans: dict[str, tuple[int, int]] = {}
    with open(path, "rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages():
            if channel.topic.endswith("/raw"):
                raw = json.loads(message.data)
                lo, hi = spans.get(raw["line"], (raw["offset"], raw["offset"]))
                size = len(base64.b64decode(raw["data"], validate=True))
                spans[raw["line"]] = (min(lo, raw["offset"]), max(hi, raw["offset"] + size))
    return spans


def test_a_command_answered_in_the_next_part_pairs(tmp_path):
    # where a part ends depends on its size limit and on when events reach the
    # recorder: record at several limits, and check every answer read in the part
    # after its command's (there must be some)
    def part_of(spans: list, ev) -> int:
        return next(k for k, s in enumerate(spans) if s[ev.line][0] <= ev.offset < s[ev.line][1])

    across = []
    for k, limit in enumerate(range(3_000, 12_000, 1_000)):
        parts, _info = record(tmp_path / f"rec{k}.mcap", [SOCAT_LOG], rotate_bytes=limit)
        spans = [raw_spans(p) for p in parts]
        events = list(analyzer.open(*shuffled(parts)))
        by_number = {ev.number: ev for ev in events}
        across += [(by_number[ev.request], ev) for ev in events
                   if ev.request is not None and part_of(spans, ev) == part_of(spans, by_number[ev.request]) + 1]
    assert across, "no transaction spans a part boundary in these recordings"
    for command, answer in across:
        assert command.kind == "command" and command.status == "ok"
        assert answer.latency is not None and answer.latency > 0


def test_each_part_says_its_own_damage_and_large_parts_use_the_reader_process(tmp_path, monkeypatch):
    from analyzer.sources import mcapfile

    parts, _info = record(tmp_path / "rec.mcap", [SOCAT_LOG], rotate_bytes=20_000)
    whole = summary(analyzer.open(SOCAT_LOG))
    monkeypatch.setattr(mcapfile, "READER_PROCESS_MIN", 0)   # every part read as a large one
    assert summary(analyzer.open(*shuffled(parts))) == whole
    with open(parts[-1], "rb") as f:
        data = f.read()
    with open(parts[-1], "wb") as f:   # the last part of a killed tap: no summary
        f.write(data[:-300])
    warnings: list[str] = []
    events = summary(analyzer.open(*shuffled(parts), on_warning=warnings.append))
    assert events == whole
    assert [w for w in warnings if "ends early" in w] and all(w.startswith(parts[-1]) for w in warnings
                                                              if "ends early" in w)


def test_a_part_with_nothing_recorded_is_passed_over_with_a_warning(tmp_path):
    parts, info = record(tmp_path / "rec.mcap", [SOCAT_LOG], rotate_bytes=20_000)
    last = tmp_path / f"rec-{len(parts) + 1:04d}.mcap"
    with open(last, "wb") as f:   # killed before the new part's first flush: its start and metadata only
        w = Writer(f)
        w.start(profile="gimbalscope", library="test_mcap_parts")
        w.add_metadata("gimbalscope", {**info.metadata(), "part": str(len(parts) + 1)})
    warnings: list[str] = []
    events = summary(analyzer.open(str(last), *parts, on_warning=warnings.append))
    assert events == summary(analyzer.open(SOCAT_LOG))
    assert f"{last}: nothing recorded (a part opened just before its tap stopped?); read the other parts" in warnings


def test_a_single_recording_is_read_as_before(tmp_path):
    paths, _info = record(tmp_path / "one.mcap", [SOCAT_LOG])
    with detect(paths, 10 / 9600) as src:
        assert type(src) is McapSource
        assert src.description == f"{paths[0]} (MCAP)"


def test_recordings_of_one_tap_one_after_the_other_follow_on_in_time(tmp_path):
    later, _ = record(tmp_path / "later.mcap", [SOCAT_LOG], start_time=START + 100, capture_id="", host="rig")
    first, _ = record(tmp_path / "first.mcap", [SOCAT_LOG], start_time=START, capture_id="", host="rig")
    one = list(analyzer.open(*first))
    capture = analyzer.open(*later, *first)
    both = list(capture)
    assert capture.source.start_time == pytest.approx(START)
    assert len(both) == 2 * len(one)
    assert [e.number for e in both] == list(range(1, len(both) + 1))
    assert [e.t for e in both[len(one):]] == pytest.approx([e.t + 100 for e in one])


# ------------------------------------------------------------------ refused

def refused(*paths) -> str:
    out = run_cli("decode", *paths)
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    return lines[0]


def test_recordings_of_two_taps_are_refused_in_one_line(tmp_path):
    a, _ = record(tmp_path / "a.mcap", [SOCAT_LOG], start_time=START, capture_id="", host="rig-1",
                  ports="/dev/ttyUSB2 /dev/ttyUSB3")
    b, _ = record(tmp_path / "b.mcap", [SOCAT_LOG], start_time=START + 100, capture_id="", host="rig-2",
                  ports="/dev/ttyUSB0 /dev/ttyUSB1")
    line = refused(*a, *b)
    assert line == (f"gimbalscope: error: {b[0]}: recorded by another tap than {a[0]} (ports /dev/ttyUSB0 "
                    "/dev/ttyUSB1 on host rig-2, not /dev/ttyUSB2 /dev/ttyUSB3 on host rig-1): "
                    "give one tap's recordings together")


def test_recordings_of_two_runs_are_told_apart_by_their_capture_id(tmp_path):
    a, info_a = record(tmp_path / "a.mcap", [SOCAT_LOG], start_time=START)
    b, info_b = record(tmp_path / "b.mcap", [SOCAT_LOG], start_time=START + 100)
    line = refused(*b, *a)
    assert f"{a[0]}: recorded by another tap than {b[0]}" in line
    assert f"capture {info_a.capture_id}, not {info_b.capture_id}" in line


def test_recordings_whose_times_overlap_are_refused(tmp_path):
    a, _ = record(tmp_path / "a.mcap", [SOCAT_LOG], start_time=START, capture_id="", host="rig")
    b, _ = record(tmp_path / "b.mcap", [SOCAT_LOG], start_time=START + 2, capture_id="", host="rig")
    line = refused(*b, *a)
    assert f"{b[0]}: starts at " in line and f"before {a[0]} ends" in line
    assert "recordings whose times overlap cannot be parts of one capture" in line


def test_a_part_given_twice_is_refused(tmp_path):
    parts, _ = record(tmp_path / "rec.mcap", [SOCAT_LOG], rotate_bytes=20_000)
    assert refused(parts[0], parts[1], parts[0]).endswith(f"{parts[0]}: given twice: give each recording once")


@pytest.mark.parametrize("other", [BUS, SOCAT_LOG])
def test_a_recording_with_another_kind_of_input_is_refused(tmp_path, other):
    paths, _ = record(tmp_path / "a.mcap", [SOCAT_LOG])
    for given in ([*paths, other], [other, *paths]):
        assert refused(*given) == (f"gimbalscope: error: {other}: not an MCAP recording; several inputs must "
                                   "all be recordings of one tap")


def test_three_raw_dumps_are_still_three_inputs_too_many():
    assert refused(CTL, DEV, BUS) == ("gimbalscope: error: 3 inputs given: expected one capture file, "
                                      "or two raw dumps (line A then line B)")


# ------------------------------------------------------------------ metadata

def hand_made(path, start_ns: int, metadata: dict | None = None) -> str:
    """A single-line recording of a command and its ACK, written with the mcap
    library, with ``metadata`` as its gimbalscope record (none: no record)."""
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="gimbalscope", library="test_mcap_parts")
        cid = w.register_channel("/serial/AB/raw", "json", w.register_schema("raw", "jsonschema", b"{}"))
        if metadata is not None:
            w.add_metadata("gimbalscope", metadata)
        offset = 0
        for data, t in ((bytes.fromhex("f80101010002503f94"), 0.0), (b"\x06", 0.02)):
            payload = json.dumps({"line": "AB", "offset": offset, "t": t, "data": data.hex()}).encode()
            w.add_message(cid, log_time=start_ns + int(t * 1e9), data=payload, publish_time=0)
            offset += len(data)
        w.finish()
    return str(path)


class NotUtf8(str):
    """A value the mcap library writes as bytes that are not UTF-8."""

    def encode(self, *args, **kwargs) -> bytes:
        return b"\xff\xfe"


def test_metadata_is_the_record_the_writer_wrote(tmp_path):
    paths, info = record(tmp_path / "one.mcap", [SOCAT_LOG])
    src = McapSource(paths[0])
    assert src.metadata == info.metadata() and src.metadata_problem is None
    # a killed tap's file (no summary): the record is found by walking from the start
    cut = tmp_path / "killed.mcap"
    cut.write_bytes(Path(paths[0]).read_bytes()[:-300])
    assert McapSource(str(cut)).metadata == info.metadata()
    parts, parts_info = record(tmp_path / "rec.mcap", [SOCAT_LOG], rotate_bytes=20_000)
    for number, part in enumerate(parts, 1):
        assert McapSource(part).metadata == {**parts_info.metadata(), "part": str(number)}
    assert analyzer.open(*parts).source.metadata == {**parts_info.metadata(), "part": "1"}


def test_a_garbled_metadata_record_is_said_and_decoding_goes_on(tmp_path):
    path = hand_made(tmp_path / "garbled.mcap", int(START * 1e9), {"host": NotUtf8("rig"), "tool": "t"})
    src = McapSource(path)
    assert src.metadata is None
    assert src.metadata_problem and "gimbalscope metadata record" in src.metadata_problem \
        and "not UTF-8" in src.metadata_problem
    assert [e.kind for e in analyzer.open(path)] == ["command", "ack"]


def test_no_metadata_is_none_without_a_problem(tmp_path):
    src = McapSource(hand_made(tmp_path / "bare.mcap", int(START * 1e9)))
    assert src.metadata is None and src.metadata_problem is None


def test_parts_without_metadata_are_read_with_one_warning(tmp_path):
    a = hand_made(tmp_path / "a.mcap", int(START * 1e9))
    b = hand_made(tmp_path / "b.mcap", int((START + 10) * 1e9), {"host": NotUtf8("rig")})
    warnings: list[str] = []
    events = list(analyzer.open(b, a, on_warning=warnings.append))
    assert [(e.number, e.kind) for e in events] == [(1, "command"), (2, "ack"), (3, "command"), (4, "ack")]
    assert events[2].t == pytest.approx(10.0)
    unchecked = [w for w in warnings if "not checked" in w]
    assert len(unchecked) == 1 and unchecked[0].startswith(f"{a}, {b}: no readable gimbalscope metadata")
    assert "not UTF-8" in unchecked[0] and "read as parts of one capture" in unchecked[0]


@pytest.mark.parametrize("metadata, clocks", [
    ({"clocks": "2"}, 2),
    ({"clocks": "1", "ports": "/dev/ttyUSB0 /dev/ttyUSB1"}, 1),
    ({"ports": "/dev/ttyUSB0 /dev/ttyUSB1"}, 2),
    ({"ports": "/dev/ttyUSB0"}, 1),
    ({"clocks": "seven"}, 1),
    (None, 1),
])
def test_clocks_come_from_the_metadata_or_the_tap_it_names(tmp_path, metadata, clocks):
    assert McapSource(hand_made(tmp_path / "c.mcap", int(START * 1e9), metadata)).clocks == clocks


def test_an_untimed_recording_has_no_clock(tmp_path):
    paths, _ = record(tmp_path / "bus.mcap", [BUS])
    src = McapSource(paths[0])
    assert not src.timed and src.clocks == 0


def test_parts_that_cannot_be_one_capture_raise_capture_error(tmp_path):
    timed = hand_made(tmp_path / "timed.mcap", int(START * 1e9))
    untimed, _ = record(tmp_path / "bus.mcap", [BUS])
    with pytest.raises(CaptureError) as e:
        analyzer.open(timed, *untimed)
    assert "recorded by another tap" in str(e.value)
