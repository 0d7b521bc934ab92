"""A recording made from a logic or USB capture keeps what only the source saw
(docs/mcap.md, "Below the bytes"): a logic capture's line reports as the
``gimbalscope.lines`` metadata record, and the line's own errors (a software
UART's, a USB adapter's) on the raw chunks holding their bytes. ``doctor``,
``stats`` and ``decode`` of the recording then say what they said of the
capture; a recording of a serial capture carries neither and reads as before.

The waveforms are built here sample by sample (tests/waveforms.py) and written
to .sr by sigrok-cli; what is expected is worked out from them: line A's sender
runs 3 % fast (9888 bit/s against 9600), its line rests low (no transceiver)
and carries three glitches; line B's result has one character whose stop bit
is held at the active level.
"""

from __future__ import annotations

import base64
import json
import re
import shutil

import jsonschema
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

import analyzer
from analyzer.cli.common import run_tap
from analyzer.formats import mcap_schemas as S
from analyzer.formats.mcap_lines import LINES_RECORD, lines_record
from analyzer.info import CaptureInfo
from analyzer.lines import Chunk
from analyzer.physical.report import LineReport, RateChange
from analyzer.sources import mcapfile
from analyzer.sources.mcapfile import McapSource
from analyzer.writers.mcap import McapWriter
from analyzer.writers.mcap_recorder import RECORDS_EVERY, McapRecorder
from dissectors import problems
from tests.conftest import SOCAT_LOG, frame, run_cli
from tests.integration.test_logic_sigrok import session
from tests.integration.test_mcap import doctor as mcap_doctor
from tests.usb_captures import FT232R, FTDI_IDLE, UsbCapture, ftdi_packets
from tests.waveforms import back_to_back, uart_levels

needs_sigrok = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")

RATE = 1_000_000
CHAR = 10 / 9600                       # one character at 9600 8N1, seconds
FAST = 9600 * 1.03                     # line A's sender, 3 % fast: 9888 bit/s
CTL, DEV = 0, 1
COMMAND = frame((DEV, 1, 1), CTL, b"P?")             # 9 bytes
ACK = b"\x06"
RESULT = frame((CTL, 1, 1), DEV, b"0FA0FC18")        # 15 bytes
GLITCHES = [0.002, 0.004, 0.006]                     # in line A's idle, before the command
WAVEFORM_FINDINGS = {("line_inverted", "A"), ("clock_off", "A"), ("glitches", "A"), ("framing_errors", "B")}


def held_stop_bit(levels, char_at: float) -> None:
    """The stop bit of the character starting at ``char_at`` (9600 8N1) held at
    the active level: a framing error."""
    stop = int((char_at + 9 / 9600) * RATE)
    levels[stop:stop + int(RATE / 9600)] = 0


def exchange_levels(commands: list[float], bad: list[float], duration: float):
    """Line A: the command at each of ``commands`` (sent 3 % fast, the line
    inverted, glitches in its idle); line B: its ACK 10 ms later and its result
    4 ms after that, whose last character's stop bit is held low for the
    commands in ``bad``."""
    a_chars, b_chars = [], []
    for t in commands:
        a_chars += back_to_back(COMMAND, t, FAST)
        b_chars += back_to_back(ACK, t + 0.010, 9600) + back_to_back(RESULT, t + 0.014, 9600)
    a = uart_levels(a_chars, RATE, FAST, duration, glitches=GLITCHES, inverted=True)
    b = uart_levels(b_chars, RATE, 9600, duration)
    for t in bad:
        held_stop_bit(b, t + 0.014 + 14 * CHAR)
    return a, b


@pytest.fixture
def inverted_fast(tmp_path) -> str:
    """One exchange at 10 ms; its result's last character has the framing error."""
    return session(tmp_path, *exchange_levels([0.010], [0.010], 0.060), name="inv")


def doctor_json(path, *args) -> tuple[int, dict]:
    r = run_cli("doctor", path, "--format", "json", *args)
    assert r.returncode in (0, 1, 3), r.stderr
    return r.returncode, json.loads(r.stdout)


def findings(report: dict) -> dict[tuple[str, str], dict]:
    """Each finding's words, severity and measure, by (id, subject): when it was
    first seen depends on how the input is read, not on what it shows."""
    keep = ("code", "subject", "severity", "title", "detail", "fix", "evidence", "measured")
    return {(f["code"], f["subject"]): {k: f[k] for k in keep} for f in report["findings"]}


def stats_json(path) -> dict:
    r = run_cli("stats", path, "--format", "json")
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def decoded(path, *args) -> list[dict]:
    r = run_cli("decode", path, "--format", "jsonl", *args)
    assert r.returncode == 0, r.stderr
    return [json.loads(line) for line in r.stdout.splitlines()]


def convert(src, out, *args) -> None:
    r = run_cli("convert", src, "-o", out, *args)
    assert r.returncode == 0, r.stderr


def metadata_of(path) -> dict[str, list[dict[str, str]]]:
    """Every metadata record of a recording, by name, in file order."""
    out: dict[str, list[dict[str, str]]] = {}
    with open(path, "rb") as f:
        for record in make_reader(f).iter_metadata():
            out.setdefault(record.name, []).append(dict(record.metadata))
    return out


def raw_messages(path) -> list[tuple[str, dict]]:
    with open(path, "rb") as f:
        return [(channel.topic, json.loads(message.data)) for _s, channel, message in make_reader(f).iter_messages()
                if channel.topic.endswith("/raw") or channel.topic == S.READS_TOPIC]


def validator(schema: dict) -> jsonschema.Draft202012Validator:
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


# ------------------------------------------------------------------ a logic capture

@needs_sigrok
def test_the_doctor_of_a_recording_names_the_waveform_findings_of_its_capture(tmp_path, inverted_fast):
    rec = tmp_path / "x.mcap"
    convert(inverted_fast, rec)
    status_sr, of_sr = doctor_json(inverted_fast)
    status_rec, of_rec = doctor_json(rec)
    sr, recorded = findings(of_sr), findings(of_rec)
    assert WAVEFORM_FINDINGS <= set(sr)
    assert recorded == sr and status_rec == status_sr == 1   # warnings: the same ids, subjects, words, values
    # the values, worked out from the waveform
    clock = recorded[("clock_off", "A")]
    rate, pct = re.search(r"runs at ([\d,]+) bit/s, ([\d.]+) % fast", clock["title"]).groups()
    assert int(rate.replace(",", "")) == round(FAST) and float(pct) == 3.0
    assert "nominal 9600 bit/s, measured over 9 characters" in clock["detail"]
    # for scripts, the line's numbers beside the words
    measured = clock["measured"]
    assert measured["rate"] == pytest.approx(FAST, rel=0.002) and measured["nominal"] == 9600
    assert (measured["channel"], measured["inverted"], measured["characters"], measured["glitches"]) == \
        ("0", True, 9, 3)
    assert recorded[("framing_errors", "B")]["measured"]["framing_errors"] == 1
    assert "(channel 0)" in recorded[("line_inverted", "A")]["title"]
    assert "its 9 characters" in recorded[("line_inverted", "A")]["detail"]
    assert recorded[("glitches", "A")]["title"].startswith("line A: 3 glitches")
    framing = recorded[("framing_errors", "B")]
    assert "1 framing error" in framing["title"] and "16 characters" in framing["title"]   # ACK + 15
    assert f"first at {0.024 + 14 * CHAR:.6f} s" in framing["detail"]
    assert mcap_doctor(rec) == []   # pymcap-cli: only its known false alarms


@needs_sigrok
def test_the_recording_holds_the_line_reports_and_gives_them_back_as_the_capture_did(tmp_path, inverted_fast):
    rec = tmp_path / "x.mcap"
    convert(inverted_fast, rec)
    meta = metadata_of(rec)
    assert meta["gimbalscope"][0]["line_errors"] == "yes"
    record, = meta[LINES_RECORD]
    assert record["version"] == "1" and set(record) == {"version", "A", "B"}
    a, b = json.loads(record["A"]), json.loads(record["B"])
    assert (a["line"], a["channel"], a["samplerate"], a["nominal"], a["given"]) == ("A", "0", RATE, 9600, False)
    assert a["measured"] == pytest.approx(FAST, rel=0.002)
    assert (a["inverted"], a["glitches"], a["characters"], a["format"]) == (True, 3, 9, "8N1")
    assert (b["inverted"], b["framing_errors"], b["characters"], b["first_error"]) == (False, 1, 16, 0.038583)
    assert a["rate_changes"] == [] and a["first_error"] is None and a["possible_formats"] == []
    # read back: the source's reports, exactly as the sampled source's at the end of its capture
    capture = analyzer.open(inverted_fast)
    list(capture)
    source = McapSource(str(rec))
    assert source.physical == capture.source.physical
    assert source.faults == []   # told as the chunks are read
    # the line error is on the same event, and counted the same
    assert decoded(rec) == decoded(inverted_fast)
    result = [e for e in decoded(rec) if e["kind"] == "result"]
    assert result[0]["problems"] == ["line error: stop bit at the active level (0xE4)"]
    assert stats_json(rec)["problems"] == stats_json(inverted_fast)["problems"] == {"line error": 1}


@needs_sigrok
def test_a_lean_recording_and_a_recording_of_the_recording_keep_them_too(tmp_path, inverted_fast):
    lean, again = tmp_path / "lean.mcap", tmp_path / "again.mcap"
    convert(inverted_fast, lean, "--lean")
    convert(lean, again)
    _status, of_sr = doctor_json(inverted_fast)
    for rec in (lean, again):
        assert findings(doctor_json(rec)[1]) == findings(of_sr)
        assert decoded(rec) == decoded(inverted_fast)
        assert mcap_doctor(rec) == []
    raw, reads = validator(S.RAW), validator(S.READS)
    with_errors = 0
    for topic, msg in raw_messages(lean) + raw_messages(again):
        (reads if topic == S.READS_TOPIC else raw).validate(msg)
        with_errors += "line_errors" in json.dumps(msg)
    assert with_errors == 2   # the result's chunk, in each recording


@needs_sigrok
def test_with_swapped_lines_the_reports_go_with_the_bytes(tmp_path, inverted_fast):
    rec = tmp_path / "swapped.mcap"
    convert(inverted_fast, rec, "--swap-lines")
    reports = McapSource(str(rec)).physical
    # the wire on channel 0 (inverted, fast) is recorded as line B
    assert reports["B"].channel == "0" and reports["B"].inverted and reports["B"].line == "B"
    assert reports["A"].channel == "1" and reports["A"].framing_errors == 1
    assert decoded(rec) == decoded(inverted_fast, "--swap-lines")
    assert ("line_inverted", "B") in findings(doctor_json(rec)[1])


@needs_sigrok
def test_a_live_recording_in_parts_keeps_every_line_error_where_it_was(tmp_path, monkeypatch):
    commands = [0.010 + 0.030 * k for k in range(8)]
    bad = commands[1::3]                                   # three framing errors, in three exchanges
    path = session(tmp_path, *exchange_levels(commands, bad, 0.260), name="long")
    capture = analyzer.open(path)
    info = CaptureInfo.of(capture, command="live")
    writer = McapWriter(str(tmp_path / "rec.mcap"), info, live=True, rotate_bytes=400)
    run_tap(capture, "live", writer, info=info, notes=False, say_empty=False)
    parts = writer.recorder.paths
    assert len(parts) >= 3, parts
    whole = decoded(path)
    assert sum(bool(e["problems"]) for e in whole) == 3
    keep = ("number", "kind", "line", "offset", "problems")
    expected = [{k: e[k] for k in keep} for e in whole]
    assert [{k: e[k] for k in keep} for e in map(json.loads, run_cli(
        "decode", "--format", "jsonl", *reversed(parts)).stdout.splitlines())] == expected
    monkeypatch.setattr(mcapfile, "READER_PROCESS_MIN", 0)   # every part read by the reader process
    assert [{k: json.loads(json.dumps(e.to_dict()[k])) for k in keep} for e in analyzer.open(*reversed(parts))] \
        == expected
    # a part alone has its own line errors, on its own events (its answers to a
    # command in the part before are orphans there, which is no line error)
    alone = [(e.kind, e.line, e.raw.hex(), str(p)) for part in parts for e in analyzer.open(part)
             for p in e.problems if problems.LINE.matches(p)]
    assert alone == [(e["kind"], e["line"], e["raw"], p) for e in whole for p in e["problems"]]
    # every part has the line reports, as of its end; read together, the last part's
    last = McapSource(parts[-1]).physical
    assert last["A"].characters == 9 * 8 and last["B"].framing_errors == 3
    assert analyzer.open(*parts).source.physical == last
    assert all(McapSource(part).physical for part in parts)


def test_a_killed_live_recording_keeps_the_line_reports_it_last_wrote(tmp_path):
    """A live recording writes the reports as it flushes, every RECORDS_EVERY
    seconds while they change: a kill loses at most the counts since."""
    path = tmp_path / "live.mcap"
    now = [0.0]
    report = LineReport("AB", "D0", samplerate=RATE, measured=9888.2, nominal=9600, inverted=True)
    rec = McapRecorder(str(path), metadata={"tool": "gimbalscope test", "line_errors": "yes"},
                       start_time=1_795_000_000.0, flush_interval=1.0, clock=lambda: now[0], lines=("AB",),
                       records=lambda: {LINES_RECORD: lines_record({"AB": report})})
    offset = 0

    def send(t: float, clock: float, characters: int) -> None:
        nonlocal offset
        now[0] = clock
        report.characters = characters
        rec.raw(Chunk("AB", COMMAND, t), offset)
        offset += len(COMMAND)

    def killed(name: str) -> McapSource:
        copy = tmp_path / name
        shutil.copyfile(path, copy)   # SIGKILL now: no summary
        return McapSource(str(copy))

    send(0.01, 0.5, 9)                     # no flush yet: nothing written
    assert LINES_RECORD.encode() not in path.read_bytes()
    send(1.01, 1.0, 18)                    # flushed: the reports written with it
    assert killed("k1.mcap").physical["AB"].characters == 18
    send(2.01, 2.0, 27)                    # flushed, but the reports were written less than 10 s ago
    assert killed("k2.mcap").physical["AB"].characters == 18
    report.rate_changes.append(RateChange(2.5, 9600, 19200))
    send(3.01, 1.0 + RECORDS_EVERY, 36)    # due again
    got = killed("k3.mcap").physical["AB"]
    assert got == report and got.rate_changes == [RateChange(2.5, 9600, 19200)]
    now[0] += RECORDS_EVERY
    rec.close()                            # unchanged since: not written again
    # each write its own name (checkers flag a name written twice), the later ones numbered
    assert [name for name in metadata_of(path) if name.startswith(LINES_RECORD)] == [LINES_RECORD,
                                                                                     f"{LINES_RECORD}.2"]
    assert McapSource(str(path)).physical == {"AB": report}
    assert mcap_doctor(path) == []


def test_a_garbled_or_newer_line_reports_record_is_said_and_left_aside(tmp_path):
    for name, record, said in (
            ("newer", {"version": "2", "AB": "{}"}, "version '2', where this gimbalscope reads version 1"),
            ("garbled", {"version": "1", "AB": '{"characters": -1}'}, "line AB: characters=-1"),
            ("not json", {"version": "1", "A": "{"}, "line A is not JSON")):
        path = tmp_path / f"{name}.mcap"
        rec = McapRecorder(str(path), metadata={"tool": "gimbalscope test"}, lines=("AB",),
                           records=lambda record=record: {LINES_RECORD: record})
        rec.raw(Chunk("AB", COMMAND, 0.01), 0)
        rec.close()
        warnings: list[str] = []
        capture = analyzer.open(str(path), on_warning=warnings.append)
        assert capture.source.physical is None
        assert [e.command for e in capture if e.kind == "command"] == ["P?"]
        assert warnings == [(f"{path}: the {LINES_RECORD} metadata record does not read ({said}): the "
                             "waveform's line reports are left out")]


# ------------------------------------------------------------------ a USB capture

def usb_capture(tmp_path) -> str:
    """An FT232R: P? at 1.000 s, its ACK handed over at 1.015 s; its result at
    1.040 s in a packet whose line status says framing error (0x08); a second
    P? at 2.000 s answered at 2.015 s with an overrun (0x02)."""
    c = UsbCapture(bus=3)
    c.enumerate(0.100, 7, **FT232R)
    query, answer = frame((DEV, 1, 2), CTL, "P?"), frame((CTL, 1, 2), DEV, "04D2FE0C")
    c.bulk_out(1.000, 7, 2, query)
    c.bulk_in(1.015, 7, 1, ftdi_packets(ACK))
    c.bulk_in(1.040, 7, 1, ftdi_packets(answer, b"\x01\x68"))
    c.bulk_out(2.000, 7, 2, query)
    c.bulk_in(2.015, 7, 1, ftdi_packets(ACK + answer, b"\x01\x62"))
    for k in range(10):
        c.bulk_in(2.1 + k * 0.016, 7, 1, FTDI_IDLE)
    path = tmp_path / "ftdi.pcap"
    c.write_pcap(path)
    return str(path)


def test_a_usb_capture_converted_keeps_its_line_errors(tmp_path):
    cap = usb_capture(tmp_path)
    rec, lean = tmp_path / "usb.mcap", tmp_path / "usb-lean.mcap"
    convert(cap, rec)
    convert(cap, lean, "--lean")
    events = decoded(cap)
    said = [(e["kind"], e["problems"]) for e in events if e["problems"]]
    assert said == [("result", ["line error: framing error reported by the USB adapter"]),
                    ("ack", ["line error: overrun reported by the USB adapter: bytes were lost before this one"])]
    usb = analyzer.open(cap)
    list(usb)
    for path in (rec, lean):
        assert decoded(path) == events
        assert stats_json(path)["problems"] == stats_json(cap)["problems"] == {"line error": 2}
        assert findings(doctor_json(path)[1]) == findings(doctor_json(cap)[1])
        meta = metadata_of(path)
        assert meta["gimbalscope"][0]["line_errors"] == "yes" and LINES_RECORD not in meta
        recorded = analyzer.open(str(path))
        assert recorded.source.physical is None
        list(recorded)
        assert recorded.source.faults == usb.source.faults   # the same errors, on the same bytes
        assert mcap_doctor(path) == []
    assert [f.problem.id for f in usb.source.faults] == [problems.LINE_FRAMING, problems.LINE_OVERRUN]


# ------------------------------------------------------------------ a serial capture

def test_a_recording_of_a_serial_capture_carries_no_line_reports_and_its_doctor_is_unchanged(tmp_path):
    rec = tmp_path / "plain.mcap"
    convert(SOCAT_LOG, rec)
    meta = metadata_of(rec)
    assert meta["gimbalscope"][0]["line_errors"] == "no" and LINES_RECORD not in meta
    assert not any("line_errors" in msg for _topic, msg in raw_messages(rec))
    source = McapSource(str(rec))
    assert source.physical is None and source.faults is None
    status_log, of_log = doctor_json(SOCAT_LOG)
    status_rec, of_rec = doctor_json(rec)
    assert findings(of_rec) == findings(of_log) and status_rec == status_log
    assert not {code for code, _subject in findings(of_rec)} & {code for code, _subject in WAVEFORM_FINDINGS}


@pytest.mark.foreign_messages   # written off the raw chunk's schema on purpose
def test_line_errors_that_do_not_read_are_left_out(tmp_path):
    """Nothing in a recording is trusted: a raw chunk's line errors that are not
    line errors of its bytes are left out, and the chunk still reads."""
    path = tmp_path / "by-hand.mcap"
    good = {"at": 2, "problem": "LINE_PARITY", "detail": "E parity bit wrong"}
    bad = [{"at": 9, "problem": "LINE_FRAMING"},          # past the chunk's bytes
           {"at": -1, "problem": "LINE_FRAMING"}, {"at": True, "problem": "LINE_FRAMING"},
           {"at": 0, "problem": "CHECKSUM"},              # no line error
           {"at": 0, "problem": "LINE_NOPE"}, {"at": 0, "problem": "LINE_BREAK", "detail": 7}, "LINE_BREAK", None]
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="gimbalscope", library="test_mcap_line_reports")
        schema = w.register_schema(S.RAW["title"], "jsonschema", S.encoded(S.RAW))
        channel = w.register_channel("/serial/AB/raw", "json", schema)
        for k, errors in enumerate(([good] + bad, "not a list", [{"at": 0, "problem": "LINE_OVERRUN"}])):
            msg = {"line": "AB", "offset": 9 * k, "t": 0.01 * (k + 1),
                   "data": base64.b64encode(COMMAND).decode(), "line_errors": errors}
            w.add_message(channel, log_time=10_000_000 * (k + 1), data=json.dumps(msg).encode(),
                          publish_time=10_000_000 * (k + 1))
        w.add_metadata("gimbalscope", {"line_errors": "yes", "lines": "AB"})
        w.finish()
    warnings: list[str] = []
    capture = analyzer.open(str(path), on_warning=warnings.append)
    events = [e for e in capture if e.kind == "command"]
    assert len(events) == 3 and warnings == []
    assert [(f.line, f.offset, f.problem.id) for f in capture.source.faults] == [
        ("AB", 2, problems.LINE_PARITY), ("AB", 18, problems.LINE_OVERRUN)]
    assert [[str(p) for p in e.problems if problems.LINE.matches(p)] for e in events] == [
        ["line error: E parity bit wrong"], [], ["line error"]]
