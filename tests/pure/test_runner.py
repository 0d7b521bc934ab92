"""The tap runner: what its listeners hear, in which order, and what they may ask."""

from __future__ import annotations

import datetime
import os
import threading

import pytest

import analyzer
from analyzer import writers
from analyzer.info import CaptureInfo
from analyzer.outfile import OutputRefused
from analyzer.runner import CAPTURE, INFO, RUNNER, WARNING, Listener, Note, TapRunner
from analyzer.writers import open_writer, writer_class
from tests.conftest import ROOT, frame

ACK = b"\x06"


def two_dumps(tmp_path, commands: int = 3):
    """Line A: `commands` P? polls to 1.1.2 from group 0; line B: an ACK for each."""
    poll = frame((1, 1, 2), 0, b"P?")
    a = tmp_path / "a.bin"
    b = tmp_path / "b.bin"
    a.write_bytes(poll * commands)
    b.write_bytes(ACK * commands)
    return str(a), str(b)


class Journal(Listener):
    """Writes down every call, in order."""

    def __init__(self, name: str, log: list) -> None:
        self.name, self.log = name, log

    def on_start(self, runner) -> None:
        self.log.append((self.name, "start"))

    def on_chunk(self, chunk, offset) -> None:
        self.log.append((self.name, "chunk", chunk.line, offset, len(chunk.data)))

    def on_events(self, events) -> None:
        self.log.append((self.name, "events", [ev.kind for ev in events]))

    def on_note(self, note: Note) -> None:
        self.log.append((self.name, "note", note.origin, note.text))

    def on_stop(self) -> None:
        self.log.append((self.name, "stop"))


def test_a_listener_holds_nothing_to_close_and_says_nothing_for_the_screen_alone():
    # (a Foxglove server overrides both: it serves from the moment it is made)
    listener = Listener()
    listener.close()
    assert listener.announcement is None


def test_every_listener_hears_start_chunks_events_and_stop_in_order(tmp_path):
    log: list = []
    capture = analyzer.open(*two_dumps(tmp_path))
    n = TapRunner(capture, [Journal("one", log), Journal("two", log)]).run()
    assert n == 6   # 3 commands, 3 ACKs
    assert log[:2] == [("one", "start"), ("two", "start")]
    assert log[-2:] == [("one", "stop"), ("two", "stop")]
    # each line's bytes arrive as chunks at their offsets on the line (9-byte P? frames:
    # start, 3 address bytes, source, length, 2 payload bytes, checksum)
    chunks = [e for e in log if e[0] == "one" and e[1] == "chunk"]
    assert ("one", "chunk", "A", 0, 27) in chunks and ("one", "chunk", "B", 0, 3) in chunks
    kinds = [k for e in log if e[0] == "one" and e[1] == "events" for k in e[2]]
    assert kinds == ["command", "ack"] * 3
    # listeners are fed in the order given, step by step
    steps = [e[0] for e in log if e[1] == "events"]
    assert steps == ["one", "two"] * (len(steps) // 2)


def test_one_pass_gives_every_listener_the_events_iterating_gives(tmp_path):
    paths = two_dumps(tmp_path, 5)
    expected = [ev.to_dict() for ev in analyzer.open(*paths)]

    class Keep(Listener):
        def __init__(self):
            self.got = []

        def on_events(self, events):
            self.got += [ev.to_dict() for ev in events]

    a, b = Keep(), Keep()
    TapRunner(analyzer.open(*paths), [a, b]).run()
    assert a.got == expected and b.got == expected


def test_capture_warnings_become_notes(tmp_path):
    log = tmp_path / "tap.log"
    # a socat header, then a stray line the reader warns about
    log.write_text("> 2026/01/01 00:00:00.000100  length=1 from=0 to=0\n 06\n--\nthis is not socat\n")
    notes: list[Note] = []

    class Notes(Listener):
        def on_note(self, note):
            notes.append(note)

    TapRunner(analyzer.open(str(log)), [Notes()]).run()
    assert notes and all(n.origin == CAPTURE and n.level == WARNING for n in notes)
    assert any(n.text.startswith(f"{log}:4: ") for n in notes), [n.text for n in notes]


def test_a_listener_can_post_a_note_every_listener_hears(tmp_path):
    log: list = []

    class Poster(Listener):
        def on_start(self, runner):
            self.runner = runner

        def on_events(self, events):
            if any(ev.kind == "ack" for ev in events):
                self.runner.post("an ACK went by", INFO)

    TapRunner(analyzer.open(*two_dumps(tmp_path, 1)), [Poster(), Journal("j", log)]).run()
    assert ("j", "note", RUNNER, "an ACK went by") in log


def test_every_listener_stops_when_the_source_fails_and_the_failure_is_raised(tmp_path):
    log: list = []

    class Boom(Listener):
        def on_events(self, events):
            raise RuntimeError("listener failed")

    with pytest.raises(RuntimeError, match="listener failed"):
        TapRunner(analyzer.open(*two_dumps(tmp_path)), [Journal("a", log), Boom(), Journal("b", log)]).run()
    assert ("a", "stop") in log and ("b", "stop") in log


def test_a_failing_stop_is_raised_after_every_listener_stopped(tmp_path):
    log: list = []

    class BadStop(Listener):
        def on_stop(self):
            raise OSError("disk gone")

    with pytest.raises(OSError, match="disk gone"):
        TapRunner(analyzer.open(*two_dumps(tmp_path)), [BadStop(), Journal("after", log)]).run()
    assert log[-1] == ("after", "stop")


def test_swap_is_a_request_and_reads_as_swap_lines_does():
    """A swap asked for at the start gives what ``--swap-lines`` gives; the runner
    says so to every listener."""
    sample = os.path.join(ROOT, "captures", "demo-socat.log")
    expected = [ev.to_dict() for ev in analyzer.open(sample, swap_lines=True)]
    assert expected != [ev.to_dict() for ev in analyzer.open(sample)]
    notes: list[Note] = []
    got: list[dict] = []

    class SwapAtOnce(Listener):
        def on_start(self, runner):
            runner.request_swap()

        def on_events(self, events):
            got.extend(ev.to_dict() for ev in events)

        def on_note(self, note):
            notes.append(note)

    runner = TapRunner(analyzer.open(sample), [SwapAtOnce()])
    runner.run()
    assert runner.swapped and got == expected
    assert any(n.origin == RUNNER and n.text.startswith("lines swapped") for n in notes)


def test_listeners_added_and_removed_while_running_hear_start_and_stop(tmp_path):
    log: list = []
    late = Journal("late", log)

    class Adder(Listener):
        def on_start(self, runner):
            self.runner, self.steps = runner, 0

        def on_events(self, events):
            self.steps += 1
            if self.steps == 1:
                self.runner.add_listener(late)
            elif self.steps == 2:
                self.runner.remove_listener(late)

    TapRunner(analyzer.open(*two_dumps(tmp_path)), [Adder()]).run()
    calls = [e[1] for e in log]
    assert calls[0] == "start" and calls[-1] == "stop" and calls.count("stop") == 1


def test_stop_from_another_thread_ends_a_file_run(tmp_path):
    a, b = two_dumps(tmp_path, 2000)
    runner = TapRunner(analyzer.open(a, b), [])

    class StopAtFirst(Listener):
        def on_events(self, events):
            if events:
                t = threading.Thread(target=runner.stop)
                t.start()
                t.join()

    runner.add_listener(StopAtFirst())
    assert runner.run() < 4000


def test_capture_info_is_the_recordings_metadata(tmp_path):
    a, b = two_dumps(tmp_path)
    capture = analyzer.open(a, b, baud=19200, parity="E")
    info = CaptureInfo.of(capture, command="convert")
    meta = info.metadata(part="2")
    assert meta["mode"] == "convert" and meta["inputs"] == f"{a} {b}" and meta["lines"] == "A,B"
    assert meta["line_roles"] == f"A={a} (controller→device), B={b} (device→controller)"
    assert (meta["baud"], meta["data_bits"], meta["parity"], meta["stop_bits"]) == ("19200", "8", "E", "1")
    assert meta["timed"] == "no" and meta["part"] == "2" and meta["clocks"] == "0"
    # a raw dump starts at its modification time less its duration: 11 bits a byte at 19200 8E1
    longest, last = max(os.path.getsize(p) for p in (a, b)), max(os.path.getmtime(p) for p in (a, b))
    start = datetime.datetime.fromisoformat(meta["start_time"]).timestamp()
    assert start == pytest.approx(last - longest * 11 / 19200, abs=1e-6)
    assert meta["time_origin"] == "file modification time less the capture's duration"
    assert info.serial_settings == "19200 8E1"
    when = CaptureInfo.of(capture).__class__(**{**info.__dict__, "start_time": 1_800_000_000.25})
    parsed = datetime.datetime.fromisoformat(when.metadata()["start_time"])
    assert parsed.timestamp() == 1_800_000_000.25 and parsed.utcoffset() == datetime.timedelta(0)


def test_writers_are_found_by_suffix_and_a_new_one_is_one_entry(tmp_path, monkeypatch):
    with pytest.raises(OutputRefused, match=r"unknown output format '\.txt'; use one of \.mcap, \.jsonl"):
        writer_class("x.txt")

    class CountWriter(Listener):
        def __init__(self, path, info, *, file=None):
            self.path, self.n = path, 0

        def on_events(self, events):
            self.n += len(events)

        def on_stop(self):
            with open(self.path, "w") as f:
                f.write(f"{self.n}\n")

    monkeypatch.setitem(writers.WRITERS, ".count", f"{__name__}:CountWriter")
    monkeypatch.setattr(__import__(__name__, fromlist=["x"]), "CountWriter", CountWriter, raising=False)
    capture = analyzer.open(*two_dumps(tmp_path))
    info = CaptureInfo.of(capture)
    out = tmp_path / "n.count"
    TapRunner(capture, [open_writer(str(out), info)], info=info).run()
    assert out.read_text() == "6\n"
