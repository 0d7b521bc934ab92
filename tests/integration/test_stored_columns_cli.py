"""`stats` of a recording that carries its decoded columns (docs/mcap.md, "Stored
columns") reads them instead of decoding, and says exactly what decoding its raw
bytes (``--redecode``) says, on standard output and standard error alike; a
decoding option says in one line that the raw bytes are decoded; a recording
without columns decodes silently."""

from __future__ import annotations

import pytest

import analyzer.capture.capture as capture_module
from analyzer.simulation.traffic import generate
from tests.conftest import BUS, CTL, DEV, SOCAT_LOG, run_cli
from tests.integration.test_mcap_parts import record


def converted(tmp_path, *inputs: str, name: str = "rec.mcap") -> str:
    out = str(tmp_path / name)
    done = run_cli("convert", *inputs, "-o", out)
    assert done.returncode == 0, done.stderr
    return out


@pytest.fixture(params=["two dumps", "socat log", "single line", "hostile line", "parts"])
def recording(request, tmp_path) -> list[str]:
    if request.param == "two dumps":
        return [converted(tmp_path, CTL, DEV)]
    if request.param == "socat log":
        return [converted(tmp_path, SOCAT_LOG)]
    if request.param == "single line":
        return [converted(tmp_path, BUS)]
    if request.param == "hostile line":
        tr = generate(600, baud=9600, seed=7, bit_error_rate=0.03, drop_ack_rate=0.05, noise_rate=0.05)
        (tmp_path / "bus.bin").write_bytes(tr.single_line())
        return [converted(tmp_path, str(tmp_path / "bus.bin"))]
    parts, _info = record(tmp_path / "parts.mcap", [BUS], rotate_bytes=4_000)
    assert len(parts) >= 3
    return parts


def both(*args: str) -> tuple[str, str]:
    """What a command prints reading the columns, and decoding (``--redecode``)."""
    stored, decoded = run_cli(*args), run_cli(*args, "--redecode")
    assert stored.returncode == decoded.returncode, stored.stderr + decoded.stderr   # doctor: 1 with findings
    assert stored.stderr == decoded.stderr
    return stored.stdout, decoded.stdout


def test_stats_says_what_decoding_says(recording):
    for command in (["stats"], ["stats", "--format", "json", "--filter", 'status == "nak" or device == "1.1.2"']):
        stored, decoded = both(*command, *recording)
        assert stored == decoded, command
        assert stored.strip()


def test_stats_of_swapped_lines_warns_as_decoding_does(tmp_path):
    # the wiring check's findings come from the signs the recorder kept
    rec = converted(tmp_path, DEV, CTL)   # the dumps given the other way round
    stored, decoded = both("stats", "--format", "json", rec)
    assert stored == decoded
    assert "swapped" in run_cli("stats", rec).stderr


def test_the_columns_are_read_not_decoded(recording, monkeypatch, capsys):
    from analyzer.cli.main import main

    def no_deframing(*_args, **_kwargs):
        raise AssertionError("the raw bytes were decoded")

    assert main(["stats", "--format", "json", *recording, "--redecode"]) == 0
    decoded = capsys.readouterr().out
    monkeypatch.setattr(capture_module, "Deframer", no_deframing)
    assert main(["stats", "--format", "json", *recording]) == 0
    assert capsys.readouterr().out == decoded


def test_stats_of_every_event_are_the_figures_the_recorder_kept(recording, monkeypatch, capsys):
    # neither the raw bytes nor the columns are read: the record holds the figures
    from analyzer.capture.stored import StoredEvents
    from analyzer.cli.main import main

    assert main(["stats", "--format", "json", *recording, "--redecode"]) == 0
    decoded = capsys.readouterr()

    def unread(*_args, **_kwargs):
        raise AssertionError("read the events")

    monkeypatch.setattr(capture_module, "Deframer", unread)
    monkeypatch.setattr(StoredEvents, "store", unread)
    assert main(["stats", "--format", "json", *recording]) == 0
    stored = capsys.readouterr()
    assert (stored.out, stored.err) == (decoded.out, decoded.err)


def test_parts_read_from_the_second_on_are_not_the_whole_recording(tmp_path):
    # each part's record counts every event since the first part: without the
    # first, those figures are not of the events read, and are left aside
    import json

    parts, _info = record(tmp_path / "parts.mcap", [BUS], rotate_bytes=4_000)
    assert len(parts) >= 3
    whole = json.loads(run_cli("stats", "--format", "json", *parts).stdout)
    later, decoded = run_cli("stats", "--format", "json", *parts[1:]), \
        run_cli("stats", "--format", "json", *parts[1:], "--redecode")
    assert later.returncode == 0, later.stderr
    assert later.stdout == decoded.stdout
    assert 0 < json.loads(later.stdout)["events"] < whole["events"]


def test_a_recording_that_sets_a_rate_keeps_no_figures(tmp_path):
    # following a rate warns as it decodes: stats decodes such a recording
    from analyzer.sources.mcapfile import McapSource
    from dissectors.encode import encode

    # the sample bus, then a command asking gimbal 1.1.1 for 9600 baud (C3, Table 4)
    with open(BUS, "rb") as f:
        bus = f.read() + encode("C", {"rate_code": 3}).frame((1, 1, 1))
    (tmp_path / "bus.bin").write_bytes(bus)
    rec = converted(tmp_path, str(tmp_path / "bus.bin"))
    record_ = McapSource(rec).stored_columns().record
    assert record_ is not None and "stats" not in record_
    plain = converted(tmp_path, BUS, name="plain.mcap")
    assert "stats" in McapSource(plain).stored_columns().record


def test_a_decoding_option_says_the_raw_bytes_are_decoded(tmp_path):
    rec = converted(tmp_path, CTL, DEV)
    done = run_cli("stats", "--baud", "19200", rec)
    assert done.returncode == 0
    said = [line for line in done.stderr.splitlines() if "stored columns" in line]
    assert said == [f"gimbalscope: warning: {rec} (MCAP): --baud given: decoding the raw bytes, not the stored columns"]


def test_a_recording_without_columns_decodes_silently(tmp_path):
    # a recording as made before columns: the same recording with its columns' topic left out
    from mcap.reader import make_reader
    from mcap.writer import Writer

    from analyzer.formats.mcap_schemas import COLUMNS_RECORD, COLUMNS_TOPIC

    rec = converted(tmp_path, BUS)
    old = str(tmp_path / "old.mcap")
    with open(rec, "rb") as f, open(old, "wb") as g:
        reader = make_reader(f)
        writer = Writer(g)
        writer.start(profile=reader.get_header().profile, library=reader.get_header().library)
        schemas, channels = {}, {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.topic == COLUMNS_TOPIC:
                continue
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(channel.topic, channel.message_encoding,
                                                               schemas.get(channel.schema_id, 0),
                                                               dict(channel.metadata))
            writer.add_message(channels[channel.id], message.log_time, message.data, message.publish_time,
                               message.sequence)
        for meta in reader.iter_metadata():
            if meta.name != COLUMNS_RECORD:
                writer.add_metadata(meta.name, dict(meta.metadata))
        writer.finish()
    a, b = run_cli("decode", "--format", "jsonl", old), run_cli("decode", "--format", "jsonl", rec, "--redecode")
    assert a.returncode == 0 and a.stdout == b.stdout
    assert "stored columns" not in a.stderr and a.stderr == b.stderr
