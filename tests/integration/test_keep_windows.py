"""`--keep FILTER --before --after`: an unattended tap keeps only windows around
the events that match. The demo's simulated gimbals with their faults, tapped on
pseudo-terminals: the events the tap printed are the truth; each window holds
exactly the events from `before` ahead of its first match to `after` beyond its
last, windows whose spans would overlap are one, and every byte is either kept in
a window or counted as dropped."""

from __future__ import annotations

import json
import re

import pytest
from mcap.reader import make_reader

from analyzer.formats.mcap_schemas import EVENTS_TOPIC
from tests.conftest import run_cli

BEFORE, AFTER = 0.4, 0.3
TRIGGER = 'status == "nak" or "bad checksum" in problems'


def _matches(ev: dict) -> bool:
    return ev.get("status") == "nak" or any(p.startswith("bad checksum") for p in ev.get("problems", []))


def _recorded(path) -> tuple[list[dict], dict]:
    """A window's events as the tap recorded them, and its metadata."""
    events, meta = [], {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for _schema, channel, message in reader.iter_messages(topics=[EVENTS_TOPIC]):
            events.append(json.loads(message.data))
        for record in reader.iter_metadata():
            if record.name == "gimbalscope":
                meta = dict(record.metadata)
    return events, meta


@pytest.fixture(scope="module")
def kept(tmp_path_factory):
    folder = tmp_path_factory.mktemp("keep") / "windows"
    done = run_cli("demo", "--no-tui", "--seconds", "8", "--format", "jsonl", "--record", folder,
                   "--keep", TRIGGER, "--before", f"{BEFORE}s", "--after", f"{AFTER * 1000:.0f}ms", timeout=90)
    assert done.returncode == 0, done.stderr
    events = [json.loads(line) for line in done.stdout.splitlines()]
    return folder, events, done.stderr


def _expected_windows(events: list[dict], matches=_matches, before: float = BEFORE,
                      after: float = AFTER) -> list[tuple[float, float]]:
    """From the matches: [t - before, t + after], a match within `before` of a
    window's end continuing it."""
    spans: list[list[float]] = []
    for ev in events:
        if matches(ev):
            t = ev["t"]
            if spans and t - before <= spans[-1][1]:
                spans[-1][1] = t + after
            else:
                spans.append([t - before, t + after])
    return [(a, b) for a, b in spans]


def _windows_hold_their_spans(folder, events: list[dict], spans: list[tuple[float, float]], trigger: str) -> None:
    files = sorted(folder.glob("window-*.mcap"))
    assert len(files) == len(spans)
    for path, (start, end) in zip(files, spans, strict=True):
        recorded, meta = _recorded(path)
        expected = [ev["number"] for ev in events if start <= ev["t"] <= end]
        assert [ev["number"] for ev in recorded] == expected, path.name
        assert meta.get("trigger") == trigger and meta.get("window") == path.name[7:11].lstrip("0")


def test_each_window_holds_exactly_the_events_around_its_matches(kept):
    folder, events, _stderr = kept
    spans = _expected_windows(events)
    assert len(spans) >= 2, "the demo's faults should give several matches"
    _windows_hold_their_spans(folder, events, spans, TRIGGER)


@pytest.mark.parametrize(("before", "windows"), [(0.4, 2), (1.0, 1)])
def test_windows_merge_exactly_when_their_spans_would_overlap(tmp_path, before, windows):
    # the sample's two NAKs, 4.961 s and 5.820 s into it: 0.3 s after the first and
    # 0.4 s before the second leave a gap (two windows); 1.0 s before, they overlap (one).
    # The sample read as a file: its times are its own, whatever the machine's load
    import analyzer
    from analyzer.analysis.filter import compile_filter
    from analyzer.info import CaptureInfo
    from analyzer.runner import TapRunner
    from analyzer.writers.windows import WindowKeeper
    from tests.conftest import SOCAT_LOG

    nak = 'status == "nak"'
    capture = analyzer.open(SOCAT_LOG)
    info = CaptureInfo.of(capture, command="live")
    keeper = WindowKeeper(str(tmp_path), info, compile_filter(nak), nak, before=before, after=0.3)
    TapRunner(capture, [keeper], info=info).run()
    events = [ev.to_dict() for ev in analyzer.open(SOCAT_LOG)]
    spans = _expected_windows(events, lambda ev: ev.get("status") == "nak", before, 0.3)
    assert len(spans) == windows and keeper.windows == windows and keeper.matched == 2
    _windows_hold_their_spans(tmp_path, events, spans, nak)
    assert keeper.kept_bytes + keeper.dropped_bytes == sum(len(ev["raw"]) // 2 for ev in events)


def test_the_summary_counts_windows_matches_and_dropped_bytes(kept):
    _folder, events, stderr = kept
    spans = _expected_windows(events)
    said = re.search(r"(\d+) windows? kept in .*: (\d+) events? matched .*, ([\d,]+) bytes kept, ([\d,]+) dropped",
                     stderr)
    assert said, stderr
    assert int(said.group(1)) == len(spans)
    assert int(said.group(2)) == sum(1 for ev in events if _matches(ev))
    kept_bytes, dropped = (int(said.group(k).replace(",", "")) for k in (3, 4))
    # every byte the tap read is in a window or dropped: the events' bytes (noise included) add up
    assert kept_bytes + dropped == sum(len(ev["raw"]) // 2 for ev in events)
    assert dropped > 0 and kept_bytes > 0


def test_windows_open_as_recordings(kept):
    # readers we did not write take each window whole; gimbalscope decodes it
    from tests.integration.test_mcap import doctor, go_read

    folder, _events, _stderr = kept
    for path in sorted(folder.glob("window-*.mcap")):
        assert doctor(path) == [], path.name
        report = go_read(path)
        assert report["metadata"]["gimbalscope"]["trigger"] == TRIGGER
        assert "/gimbalscope/columns" not in report["messages"]   # decoded from its bytes (module doc)
        done = run_cli("stats", "--format", "json", path)
        assert done.returncode == 0, done.stderr
        assert json.loads(done.stdout)["events"] > 0


def test_keep_without_a_folder_or_with_a_bad_filter_is_one_line(tmp_path):
    for args, said in ((["--keep", TRIGGER], "--keep needs --record DIR"),
                       (["--keep", "status ==", "--record", tmp_path / "w"], "--keep column 10"),
                       (["--max-windows", "2"], "--max-windows goes with --keep"),
                       (["--keep", TRIGGER, "--record", tmp_path / "w", "--before", "3x"],
                        "argument --before: '3x': must be a duration")):
        done = run_cli("demo", "--no-tui", "--seconds", "1", *args)
        assert done.returncode == 2, (args, done.stderr)
        assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
        assert said in done.stderr, done.stderr


def test_max_windows_stops_the_tap_once_that_many_are_written(tmp_path):
    folder = tmp_path / "one"
    done = run_cli("demo", "--no-tui", "--seconds", "20", "--format", "jsonl", "--record", folder,
                   "--keep", TRIGGER, "--before", "0.2s", "--after", "0.2s", "--max-windows", "1", timeout=90)
    assert done.returncode == 0, done.stderr
    assert [p.name for p in folder.glob("window-*.mcap")] == ["window-0001.mcap"]
    events = [json.loads(line) for line in done.stdout.splitlines()]
    first = next(ev["t"] for ev in events if _matches(ev))
    # stopped once the window closed (its end, then `before` more to see whether the next continues it),
    # long before the demo's 20 s
    assert events[-1]["t"] < first + 0.2 + 0.2 + 2.0


def test_stop_after_ends_a_live_tap_by_itself(tmp_path):
    import os
    import subprocess
    import sys
    import time
    import tty

    master, slave = os.openpty()
    tty.setraw(slave)
    started = time.monotonic()
    try:
        done = subprocess.run([sys.executable, "-m", "analyzer", "live", os.ttyname(slave), "--no-tui",
                               "--stop-after", "1s", "--record", str(tmp_path / "night.mcap")],
                              capture_output=True, text=True, timeout=60, check=False)
    finally:
        os.close(master)
        os.close(slave)
    assert done.returncode == 0, done.stderr
    assert time.monotonic() - started < 30
    assert (tmp_path / "night.mcap").stat().st_size > 0
    assert run_cli("stats", tmp_path / "night.mcap").returncode == 0
