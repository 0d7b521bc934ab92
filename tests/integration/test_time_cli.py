"""The time model end to end through the CLI (docs/time.md): recordings that keep
their settings, capture times in recordings, time zones. MCAP files are read back
with the mcap library, not with our reader."""

from __future__ import annotations

import calendar
import datetime
import os
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from analyzer.simulation.traffic import generate
from tests.conftest import CTL, DEV, run_cli


def messages(path: str, topic: str) -> list:
    with open(path, "rb") as f:
        return [(m.log_time, m.data) for _s, ch, m in make_reader(f).iter_messages() if ch.topic == topic]


def metadata(path: str) -> dict[str, str]:
    with open(path, "rb") as f:
        return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}["gimbalscope"]


@pytest.fixture(scope="module")
def log_115200(tmp_path_factory) -> str:
    """A socat log of a conversation at 115200 bit/s."""
    path = tmp_path_factory.mktemp("rate") / "tap115.log"
    path.write_text(generate(1500, baud=115200, seed=4, bit_error_rate=0.003).socat_log())
    return str(path)


def stats_lines(*args) -> list[str]:
    r = run_cli("stats", *args)
    assert r.returncode == 0, r.stderr
    return r.stdout.splitlines()[:3], r.stderr


def test_a_recording_decodes_at_the_rate_it_was_made_at(log_115200, tmp_path):
    rec = tmp_path / "rec.mcap"
    r = run_cli("convert", log_115200, "--baud", "115200", "-o", rec)
    assert r.returncode == 0, r.stderr
    assert metadata(str(rec))["baud"] == "115200"
    given, _ = stats_lines(log_115200, "--baud", "115200")
    recorded, warned = stats_lines(rec)           # no --baud: the recording's own
    assert recorded == given and "warning" not in warned
    # at 9600, 12 times too slow, commands overlap their answers: many go unanswered
    wrong, _ = stats_lines(log_115200)
    assert wrong != given


def test_an_explicit_flag_overrides_the_recording_and_says_so_once(log_115200, tmp_path):
    rec = tmp_path / "rec.mcap"
    assert run_cli("convert", log_115200, "--baud", "115200", "-o", rec).returncode == 0
    r = run_cli("decode", rec, "--baud", "9600", "--format", "jsonl")
    said = [line for line in r.stderr.splitlines() if "overrides" in line]
    assert said == [f"gimbalscope: warning: --baud 9600 overrides the 115200 {rec} was recorded with"]
    # the same value as the recording's: nothing to say
    r = run_cli("decode", rec, "--baud", "115200", "--format", "jsonl")
    assert "overrides" not in r.stderr


def test_garbled_metadata_falls_back_to_the_defaults_with_one_warning(log_115200, tmp_path):
    good = tmp_path / "good.mcap"
    assert run_cli("convert", log_115200, "--baud", "115200", "-o", good).returncode == 0
    bad = tmp_path / "bad.mcap"
    with open(good, "rb") as f, open(bad, "wb") as out:
        reader = make_reader(f)
        summary = reader.get_summary()
        w = Writer(out)
        w.start(profile="", library="test")
        ids = {}
        for sid, schema in summary.schemas.items():
            ids[sid] = w.register_schema(schema.name, schema.encoding, schema.data)
        chans = {cid: w.register_channel(ch.topic, ch.message_encoding, ids.get(ch.schema_id, 0))   # 0: schemaless
                 for cid, ch in summary.channels.items()}
        for _s, ch, m in reader.iter_messages():
            w.add_message(chans[ch.id], m.log_time, m.data, m.publish_time)
        w.add_metadata("gimbalscope", {"baud": "fast", "lines": "A,B"})
        w.finish()
    r = run_cli("stats", bad)
    assert r.returncode == 0, r.stderr
    warned = [line for line in r.stderr.splitlines() if "metadata" in line]
    assert warned == [(f"gimbalscope: warning: {bad}: the gimbalscope metadata is garbled (baud='fast'): "
                       "decoding with the options given and the defaults (9600 8N1)")]
    # decoded at the default 9600, as the good recording is with --baud 9600
    assert r.stdout.splitlines()[:3] == stats_lines(good, "--baud", "9600")[0]


def test_raw_dumps_are_recorded_at_their_start_time(tmp_path):
    rec = tmp_path / "dumps.mcap"
    r = run_cli("convert", CTL, DEV, "--start-time", "2026-11-21T08:35:52Z", "-o", rec)
    assert r.returncode == 0, r.stderr
    start = calendar.timegm((2026, 11, 21, 8, 35, 52, 0, 0, 0)) * 10**9
    raw_a = messages(str(rec), "/serial/A/raw")
    assert raw_a[0][0] == start
    # later chunks of line A at their byte offsets, 1/960 s a byte at 9600 8N1
    import json
    for log_time, data in raw_a:
        offset = json.loads(data)["offset"]
        assert log_time == start + round(offset * 10**9 / 960)
    meta = metadata(str(rec))
    assert meta["time_origin"] == "--start-time" and meta["start_time"] == "2026-11-21T08:35:52.000000+00:00"


def test_without_a_start_time_a_dump_ends_at_its_modification_time(tmp_path):
    a, b = tmp_path / "ctl.bin", tmp_path / "dev.bin"
    a.write_bytes(Path(CTL).read_bytes())
    b.write_bytes(Path(DEV).read_bytes())
    mtime = 1_790_000_000
    for p in (a, b):
        os.utime(p, (mtime, mtime))
    rec = tmp_path / "dumps.mcap"
    assert run_cli("convert", a, b, "-o", rec).returncode == 0
    longest = max(os.path.getsize(a), os.path.getsize(b))
    start = messages(str(rec), "/serial/A/raw")[0][0] / 1e9
    assert start == pytest.approx(mtime - longest / 960, abs=1e-6)
    assert metadata(str(rec))["time_origin"] == "file modification time less the capture's duration"


def test_a_socat_log_is_recorded_at_its_own_stamps(tmp_path):
    log = tmp_path / "tap.log"
    log.write_text("> 2026/11/21 08:35:52.009375000  length=9 from=0 to=8\n"
                   " f8 01 01 01 00 02 50 3f 94                       ......P?.\n--\n"
                   "< 2026/11/21 08:35:52.020000000  length=1 from=0 to=0\n"
                   " 06                                               .\n--\n")
    rec = tmp_path / "tap.mcap"
    r = run_cli("convert", log, "--tz", "UTC", "-o", rec)
    assert r.returncode == 0, r.stderr
    # the command was read at 08:35:52.009375 UTC; its first byte started 9 byte times earlier
    read = calendar.timegm((2026, 11, 21, 8, 35, 52, 0, 0, 0)) + 0.009375
    first = messages(str(rec), "/serial/A/raw")[0][0]
    assert first == round((read - 9 / 960) * 10**9)
    started = datetime.datetime.fromisoformat(metadata(str(rec))["start_time"]).timestamp()
    assert started == pytest.approx(read - 9 / 960, abs=1e-6)


def test_bad_time_options_are_one_line_and_exit_2(tmp_path):
    r = run_cli("decode", CTL, DEV, "--tz", "Mars/Base")
    assert r.returncode == 2 and "Mars/Base" in r.stderr and "Traceback" not in r.stderr
    r = run_cli("decode", CTL, DEV, "--start-time", "yesterday")
    assert r.returncode == 2 and "ISO 8601" in r.stderr and "Traceback" not in r.stderr
