"""Logic captures in sigrok sessions (docs/instruments.md): waveforms of known
traffic, written to .sr by sigrok-cli itself from raw samples, and real
captures from the sigrok project's example dumps, read by our software UART
and checked against sigrok-cli's own ``uart`` decoder.

Expectations are computed by hand from the frames placed on the wire (Table 1)
and the times they were placed at; a character at 9600 8N1 lasts 10/9600 s.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import analyzer
from analyzer.errors import CaptureError
from dissectors import problems
from tests.conftest import ROOT, frame, run_cli
from tests.waveforms import back_to_back, sigrok_session, uart_levels

pytestmark = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")

DUMPS = os.path.join(ROOT, "tests", "data", "sigrok-dumps")
RATE = 1_000_000
CHAR = 10 / 9600                      # one character at 9600 8N1, seconds
CTL, DEV = 0, 1
COMMAND = frame((DEV, 1, 1), CTL, b"P?")             # 9 bytes
ACK = b"\x06"
RESULT = frame((CTL, 1, 1), DEV, b"0FA0FC18")        # 15 bytes
COMMAND_AT, ACK_AT, RESULT_AT = 0.010, 0.020, 0.024
DURATION = 0.060


def session(tmp_path, *channels, samplerate=RATE, name="cap") -> str:
    """A .sr written by sigrok-cli from the channels' levels (channel i is named "i")."""
    return sigrok_session(tmp_path, *channels, samplerate=samplerate, name=name)


def sigrok_bytes(path: str, channel: str, baud: int, **opts) -> bytes:
    """What sigrok-cli's uart decoder reads on ``channel``."""
    extra = "".join(f":{k}={v}" for k, v in opts.items())
    got = subprocess.run(["sigrok-cli", "-i", path, "-P", f"uart:baudrate={baud}:rx={channel}{extra}",
                          "-B", "uart=rx"], check=True, capture_output=True, timeout=60)
    return got.stdout


def our_bytes(cap) -> dict[str, bytes]:
    out: dict[str, bytearray] = {}
    for ev in cap:
        if ev.raw:
            out.setdefault(ev.line, bytearray()).extend(ev.raw)
    return {line: bytes(b) for line, b in out.items()}


def conversation(baud_a=9600, baud_b=9600, **kw_a):
    a = uart_levels(back_to_back(COMMAND, COMMAND_AT, baud_a), RATE, baud_a, DURATION, **kw_a)
    b = uart_levels(back_to_back(ACK, ACK_AT, baud_b) + back_to_back(RESULT, RESULT_AT, baud_b), RATE, baud_b,
                    DURATION)
    return a, b


def test_a_session_written_by_sigrok_cli_reads_as_the_conversation(tmp_path):
    path = session(tmp_path, *conversation())
    cap = analyzer.open(path)
    events = list(cap)
    command = next(e for e in events if e.kind == "command")
    ack = next(e for e in events if e.kind == "ack")
    result = next(e for e in events if e.kind == "result")
    assert command.command == "P?" and command.status == "ok" and command.line == "A"
    assert command.t == pytest.approx(COMMAND_AT, abs=2e-6)
    # the ACK's first byte after the command's last: 9 characters from 10 ms
    assert ack.latency == pytest.approx(ACK_AT - (COMMAND_AT + 9 * CHAR), abs=3e-6)
    assert result.request == command.number
    assert not any(e.problems for e in events)
    # the same bytes as sigrok-cli's own uart decoder, line by line
    ours = our_bytes(analyzer.open(path))
    assert ours["A"] == COMMAND == sigrok_bytes(path, "0", 9600)
    assert ours["B"] == ACK + RESULT == sigrok_bytes(path, "1", 9600)


def test_the_rate_is_measured_and_a_fast_clock_said(tmp_path):
    # line A's sender runs 3 % fast: 9888 bit/s against 9600
    path = session(tmp_path, *conversation(baud_a=9888))
    cap = analyzer.open(path)
    assert [e.command for e in cap if e.kind == "command"] == ["P?"]
    a = cap.source.physical["A"]
    assert a.nominal == 9600 and a.measured == pytest.approx(9888, rel=0.002)
    assert a.error_pct == pytest.approx(3.0, abs=0.2)
    assert cap.source.physical["B"].measured == pytest.approx(9600, rel=0.002)
    assert cap.options.baud == 9600
    assert our_bytes(analyzer.open(path))["A"] == sigrok_bytes(path, "0", 9888) == COMMAND


def test_an_inverted_line_reads_and_is_said(tmp_path):
    a, b = conversation()
    path = session(tmp_path, a, b ^ 1)
    cap = analyzer.open(path)
    assert [e.status for e in cap if e.kind == "command"] == ["ok"]
    assert cap.source.physical["B"].inverted and not cap.source.physical["A"].inverted
    assert our_bytes(analyzer.open(path))["B"] == sigrok_bytes(path, "1", 9600, invert_rx="yes") == ACK + RESULT


def test_glitches_are_counted_and_do_not_change_the_bytes(tmp_path):
    # three pulses of a tenth of a bit: in the idle line, and near bit edges inside
    # the command (away from the middles a receiver samples)
    bit = 1 / 9600
    glitches = [0.005, COMMAND_AT + 2.1 * bit, COMMAND_AT + CHAR * 4 + 5.05 * bit]
    path = session(tmp_path, *conversation(glitches=glitches))
    cap = analyzer.open(path)
    assert [e.status for e in cap if e.kind == "command"] == ["ok"]
    assert cap.source.physical["A"].glitches == 3
    assert our_bytes(analyzer.open(path))["A"] == sigrok_bytes(path, "0", 9600) == COMMAND


def test_a_break_and_a_framing_error_are_problems_on_their_events(tmp_path):
    # line A: the command, then a break (held low 5 characters), then the command again
    chars = back_to_back(COMMAND, COMMAND_AT, 9600) + back_to_back(COMMAND, 0.040, 9600)
    a = uart_levels(chars, RATE, 9600, DURATION, breaks=[(0.030, 5 * CHAR)])
    # line B: the ACK, and a result whose last character's stop bit is held low
    b = uart_levels(back_to_back(ACK, ACK_AT, 9600), RATE, 9600, DURATION)
    res = uart_levels(back_to_back(RESULT, RESULT_AT, 9600), RATE, 9600, DURATION)
    stop = int((RESULT_AT + 14 * CHAR + 9 * (1 / 9600)) * RATE)
    res[stop:stop + int(RATE / 9600)] = 0
    b &= res
    path = session(tmp_path, a, b)
    cap = analyzer.open(path)
    events = list(cap)
    second = [e for e in events if e.kind == "command"][1]
    assert problems.LINE_BREAK in [p.id for p in second.problems]
    framing = [e for e in events if problems.LINE_FRAMING in [p.id for p in e.problems]]
    assert len(framing) == 1 and framing[0].line == "B" and framing[0].t == pytest.approx(RESULT_AT, abs=3e-6)
    report = cap.source.physical
    assert report["A"].breaks == 1 and report["B"].framing_errors == 1


def test_a_rate_change_is_followed(tmp_path):
    # line A: a command twice at 9600, then after a silence three times at 19200
    chars = back_to_back(COMMAND * 2, COMMAND_AT, 9600)
    a1 = uart_levels(chars, RATE, 9600, DURATION)
    a2 = uart_levels(back_to_back(COMMAND * 3, 0.030, 19200), RATE, 19200, DURATION)
    a = a1 & a2
    b = uart_levels([], RATE, 9600, DURATION)
    path = session(tmp_path, a, b)
    cap = analyzer.open(path, channels={"A": "0"})
    assert our_bytes(cap)["AB"] == COMMAND * 5
    changes = cap.source.physical["AB"].rate_changes
    assert len(changes) == 1 and changes[0].after == pytest.approx(19200, rel=0.01)
    assert changes[0].t == pytest.approx(0.030, abs=1e-4)


def test_lines_sending_at_once_keep_their_wire_times_and_so_does_their_recording(tmp_path):
    # the result runs on line B from 18 ms to 33.6 ms; a command on line A starts
    # at 25 ms, inside it: a waveform's times are the start bits', not read times
    a = uart_levels(back_to_back(COMMAND, 0.025, 9600), RATE, 9600, DURATION)
    b = uart_levels(back_to_back(RESULT, 0.018, 9600), RATE, 9600, DURATION)
    path = session(tmp_path, a, b)
    events = list(analyzer.open(path))
    command = next(e for e in events if e.kind == "command")
    assert command.t == pytest.approx(0.025, abs=2e-6)
    rec = tmp_path / "at-once.mcap"
    assert run_cli("convert", path, "-o", rec).returncode == 0
    again = next(e for e in analyzer.open(str(rec)) if e.kind == "command")
    assert again.t == pytest.approx(0.025, abs=2e-6)


def test_channels_by_name_or_number_and_a_bad_one_listed(tmp_path):
    a, b = conversation()
    idle = uart_levels([], RATE, 9600, DURATION)
    path = session(tmp_path, idle, b, a)        # the lines on channel 2 (A) and 1 (B)
    cap = analyzer.open(path, channels={"A": "2", "B": "1"})
    assert [e.status for e in cap if e.kind == "command"] == ["ok"]
    # chosen by itself: the first two that toggle, 1 then 2 (B's bytes as line A)
    cap = analyzer.open(path)
    assert cap.source.channel_of == {"A": 1, "B": 2}
    # sigrok-cli takes a channel it does not have as channel 0; we say so
    r = run_cli("decode", path, "--channels", "A=TX,B=1")
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert "no channel 'TX'; the channels are 0, 1, 2" in r.stderr
    r = run_cli("decode", path, "--channels", "A=2,B=0", "--format", "jsonl")
    assert r.returncode == 0
    assert "channel 0 (line B) never toggles" in r.stderr


def test_too_few_samples_a_bit_is_an_error_naming_the_rate_needed(tmp_path):
    # 9600 bit/s sampled at 20 kHz: 2 samples a bit
    a = uart_levels(back_to_back(COMMAND * 8, 0.01, 9600), 20_000, 9600, 0.2)
    path = session(tmp_path, a, samplerate=20_000)
    with pytest.raises(CaptureError, match=r"sampled at 20 kHz, under 4 samples a bit at 9,600 bit/s .* "
                                           r"capture at 38.4 kHz or more"):
        analyzer.open(path)


def test_a_session_cut_short_reads_what_came_before(tmp_path):
    a, b = conversation()
    path = session(tmp_path, a, b)
    data = Path(path).read_bytes()
    cut = tmp_path / "cut.sr"
    cut.write_bytes(data[:len(data) - 40])      # the central directory gone
    r = run_cli("decode", str(cut), "--format", "jsonl")
    assert r.returncode == 0, r.stderr
    assert '"command":"P?"' in r.stdout
    assert "cut short or damaged" in r.stderr


# ------------------------------------------------------------------ real captures
REAL = [
    # file, channel, baud, sigrok-cli's options for it
    ("hello_world_8n1_9600.sr", "TX", 9600, {}),
    ("mtk3339_8n1_9600.sr", "TX", 9600, {}),
    ("ampel64_4800_8n1_ok.sr", "TX", 4800, {}),
    ("ampel64_4800_8n1_frame_errors.sr", "TX", 4800, {}),
    ("hello_world_8e1_115200.sr", "TX", 115200, {"parity": "even"}),
    ("max3232e_hello_world_57600_8n1.sr", "MAX3232E DOUT1", 57600, {"invert_rx": "yes"}),
    ("max3232e_hello_world_57600_8n1.sr", "MAX3232E DIN1", 57600, {}),
]


@pytest.mark.parametrize("name,channel,baud,opts", REAL, ids=[f"{r[0]}:{r[1]}" for r in REAL])
def test_real_captures_read_as_sigrok_reads_them(name, channel, baud, opts):
    path = os.path.join(DUMPS, name)
    cap = analyzer.open(path, channels={"A": channel})
    ours = our_bytes(cap)["AB"]
    theirs = sigrok_bytes(path, channel, baud, **opts)
    assert ours == theirs and len(ours) >= 8
    report = cap.source.physical["AB"]
    assert report.nominal == baud                       # measured, not given
    assert report.inverted == (opts.get("invert_rx") == "yes")
    assert report.parity == ("E" if opts.get("parity") == "even" else "N")


def test_the_glitch_dumps_read_the_characters_sent():
    # sigrok's uart decoder samples each bit once, in its middle: a glitch there
    # changes its byte. We drop pulses under a quarter bit first (as a receiver's
    # majority vote over the bit would), so we read the character that was sent.
    cap = analyzer.open(os.path.join(DUMPS, "glitch_0x4f_0x4b_0x0a.sr"), channels={"A": "TX"})
    assert our_bytes(cap)["AB"] == b"OK\n"
    assert cap.source.physical["AB"].glitches >= 1


# ------------------------------------------------------------------ the doctor from the waveform
def doctor_json(path, *args):
    import json
    r = run_cli("doctor", path, "--format", "json", *args)
    return r.returncode, json.loads(r.stdout)


def codes(report) -> dict[str, dict]:
    return {(f["code"], f["subject"]): f for f in report["findings"]}


def test_a_clean_capture_gives_no_warning(tmp_path):
    status, report = doctor_json(session(tmp_path, *conversation()))
    assert status == 0
    assert [f for f in report["findings"] if f["severity"] != "info"] == []


def test_the_doctor_names_a_fast_clock(tmp_path):
    status, report = doctor_json(session(tmp_path, *conversation(baud_a=9888)))
    f = codes(report)[("clock_off", "A")]
    assert f["severity"] == "warning" and status == 1
    assert f["title"] == "line A runs at 9,888 bit/s, 3.0 % fast"
    status, report = doctor_json(session(tmp_path, *conversation(baud_b=9100), name="slow"))
    f = codes(report)[("clock_off", "B")]
    assert f["severity"] == "error" and status == 3
    assert f["title"] == "line B runs at 9,100 bit/s, 5.2 % slow"


def test_a_rate_far_from_every_standard_one_decodes_as_measured_and_is_said(tmp_path):
    # both lines at 12,500 bit/s: 30 % over 9600, 35 % under 19200, no standard rate
    # near it; the conversation decodes at the rate measured, and the doctor says so
    path = session(tmp_path, *conversation(baud_a=12500, baud_b=12500))
    cap = analyzer.open(path)
    assert [(e.kind, e.status) for e in cap if e.kind == "command"] == [("command", "ok")]
    assert cap.source.physical["A"].nominal == 12500 and cap.options.baud == 12500
    status, report = doctor_json(path)
    f = codes(report)[("rate_nonstandard", "A")]
    assert f["severity"] == "warning" and status == 1
    assert f["title"] == "line A runs at 12,500 bit/s, no standard rate"
    assert "the nearest standard rate is 14,400 bit/s" in f["detail"]
    # MIDI's 31,250 is a standard rate: named, not said
    path = session(tmp_path, *conversation(baud_a=31250, baud_b=31250), name="midi")
    assert analyzer.open(path).source.physical["A"].nominal == 31250
    assert not [f for f in doctor_json(path)[1]["findings"] if f["code"] == "rate_nonstandard"]


def test_the_doctor_names_an_inverted_line_glitches_and_framing_errors(tmp_path):
    bit = 1 / 9600
    glitches = [0.002, 0.004, 0.006]
    a, b = conversation(glitches=glitches)
    b = uart_levels(back_to_back(ACK, ACK_AT, 9600) + back_to_back(RESULT, RESULT_AT, 9600), RATE, 9600,
                    DURATION, breaks=[(0.045, 3 * CHAR)])
    status, report = doctor_json(session(tmp_path, a ^ 1, b))
    found = codes(report)
    assert found[("line_inverted", "A")]["severity"] == "warning"
    assert found[("glitches", "A")]["title"] == "line A: 3 glitches (pulses under a quarter bit)"
    assert found[("framing_errors", "B")]["title"] == "line B: 1 break"   # a break is no character
    assert status == 1
    assert bit   # (a tenth of a bit each: tests/waveforms.py's default)


def test_two_senders_at_once_on_one_line(tmp_path):
    # a single line (half duplex): a device starts answering 0.4 bit into the
    # controller's characters, five times; the line carries the AND of both
    # (the active level wins, as on a bus)
    bit = 1 / 9600
    ctl = back_to_back(COMMAND * 5, 0.005, 9600)
    dev = [(t + 0.4 * bit, 0x55) for t, _v in ctl[3::9]]
    line = uart_levels(ctl, RATE, 9600, DURATION) & uart_levels(dev, RATE, 9600, DURATION)
    status, report = doctor_json(session(tmp_path, line))
    found = codes(report)
    assert ("two_drivers", "AB") in found and found[("two_drivers", "AB")]["severity"] == "error"
    assert status == 3
