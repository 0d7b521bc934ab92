"""Logic captures in the formats other tools export (docs/instruments.md): VCD
(written by sigrok-cli itself, and by hand with other time scales and
variables that are not channels) and Saleae Logic 2's raw digital CSV, binary
export (versions 0 and 1) and Async Serial data table.

Each carries the same conversation, placed by hand: a position query on line A
at 10 ms, the gimbal's ACK on line B at 20 ms and its result at 24 ms. The
expectations are worked out from those times: a character at 9600 8N1 lasts
10/9600 s, the command's 9 characters end at 10 ms + 9 characters, and the ACK's
latency is from there to its start bit.
"""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

import analyzer
from analyzer.errors import CaptureError
from dissectors import problems
from tests.conftest import frame, run_cli
from tests.waveforms import back_to_back, pack, uart_levels

RATE = 1_000_000                      # samples a second of the waveforms made here
BAUD = 9600
CHAR = 10 / BAUD
CTL, DEV = 0, 1
COMMAND = frame((DEV, 1, 1), CTL, b"P?")             # 9 bytes
ACK = b"\x06"
RESULT = frame((CTL, 1, 1), DEV, b"0FA0FC18")        # 15 bytes: az +40.00°, el -10.00°
COMMAND_AT, ACK_AT, RESULT_AT = 0.010, 0.020, 0.024
DURATION = 0.060
ACK_LATENCY = ACK_AT - (COMMAND_AT + len(COMMAND) * CHAR)       # 0.625 ms
RESULT_LATENCY = RESULT_AT - (COMMAND_AT + len(COMMAND) * CHAR)

needs_sigrok = pytest.mark.skipif(shutil.which("sigrok-cli") is None, reason="sigrok-cli is not installed")


def conversation() -> tuple[np.ndarray, np.ndarray]:
    a = uart_levels(back_to_back(COMMAND, COMMAND_AT, BAUD), RATE, BAUD, DURATION)
    b = uart_levels(back_to_back(ACK, ACK_AT, BAUD) + back_to_back(RESULT, RESULT_AT, BAUD), RATE, BAUD, DURATION)
    return a, b


def edges(levels: np.ndarray) -> np.ndarray:
    """Sample numbers at which the level changes."""
    return np.flatnonzero(np.diff(levels.astype(np.int8))) + 1


def check_conversation(events: list, offset: float = 0.0, tol: float = 3e-6) -> None:
    command = next(e for e in events if e.kind == "command")
    ack = next(e for e in events if e.kind == "ack")
    result = next(e for e in events if e.kind == "result")
    assert (command.command, command.status, command.line, command.device) == ("P?", "ok", "A", "1.1.1")
    assert command.t == pytest.approx(COMMAND_AT + offset, abs=tol)
    assert ack.line == "B" and ack.request == command.number
    assert ack.latency == pytest.approx(ACK_LATENCY, abs=2 * tol)
    assert result.request == command.number and result.latency == pytest.approx(RESULT_LATENCY, abs=2 * tol)
    assert result.fields == {"azimuth_deg": 40.0, "elevation_deg": -10.0}
    assert not any(e.problems for e in events)


def decode_jsonl(*paths, args=()) -> tuple[list[dict], str]:
    run = run_cli("decode", *paths, "--format", "jsonl", *args)
    assert run.returncode == 0, run.stderr
    return [json.loads(line) for line in run.stdout.splitlines()], run.stderr


def check_jsonl(rows: list[dict], offset: float = 0.0, tol: float = 3e-6) -> None:
    command, ack, result = rows[:3]
    assert (command["kind"], command["command"], command["status"], command["device"]) == ("command", "P?", "ok", "1.1.1")
    assert command["t"] == pytest.approx(COMMAND_AT + offset, abs=tol)
    assert (ack["kind"], ack["request"]) == ("ack", command["number"])
    assert ack["latency"] == pytest.approx(ACK_LATENCY, abs=2 * tol)
    assert result["fields"] == {"azimuth_deg": 40.0, "elevation_deg": -10.0}


def our_bytes(path, **kw) -> dict[str, bytes]:
    out: dict[str, bytearray] = {}
    for ev in analyzer.open(str(path), **kw):
        if ev.raw:
            out.setdefault(ev.line, bytearray()).extend(ev.raw)
    return {line: bytes(b) for line, b in out.items()}


# ------------------------------------------------------------------ VCD
def sigrok_vcd(tmp_path) -> str:
    raw = tmp_path / "raw.bin"
    raw.write_bytes(pack(*conversation()))
    sr, vcd = tmp_path / "cap.sr", tmp_path / "cap.vcd"
    subprocess.run(["sigrok-cli", "-I", f"binary:numchannels=2:samplerate={RATE}", "-i", str(raw), "-o", str(sr)],
                   check=True, capture_output=True, timeout=60)
    subprocess.run(["sigrok-cli", "-i", str(sr), "-O", "vcd", "-o", str(vcd)], check=True, capture_output=True,
                   timeout=60)
    return str(vcd)


def sigrok_uart(path: str, channel: str) -> bytes:
    """What sigrok-cli's own uart decoder reads on ``channel`` of a VCD."""
    return subprocess.run(["sigrok-cli", "-I", "vcd", "-i", path, "-P", f"uart:baudrate={BAUD}:rx={channel}",
                           "-B", "uart=rx"], check=True, capture_output=True, timeout=60).stdout


@needs_sigrok
def test_a_vcd_written_by_sigrok_cli_reads_as_the_conversation(tmp_path):
    path = sigrok_vcd(tmp_path)
    rows, _ = decode_jsonl(path)
    check_jsonl(rows)
    cap = analyzer.open(path)
    check_conversation(list(cap))
    # sigrok says the rate it sampled at: the ticks are samples
    assert cap.source.waveform.sampled and cap.source.waveform.samplerate == RATE
    ours = our_bytes(path)
    assert ours["A"] == COMMAND == sigrok_uart(path, "0")
    assert ours["B"] == ACK + RESULT == sigrok_uart(path, "1")
    # the same events as the session the VCD was written from
    assert decode_jsonl(str(tmp_path / "cap.sr"))[0] == rows


def write_vcd(path, timescale: str, unit: float, cut_after: int | None = None) -> str:
    """A VCD as a simulator writes one: nested scopes, a multi-character id, an
    8-bit bus and a real that are not channels, lines at x before they are
    driven, a comment and bus changes among the value changes."""
    a, b = conversation()
    changes: dict[int, list[str]] = {}
    for ident, lv in (("!", a), ("rx_", b)):
        for s in edges(lv):
            changes.setdefault(round(s / RATE / unit), []).append(f"{lv[s]}{ident}")
    text = [f"$date today $end\n$version a simulator $end\n$timescale {timescale} $end\n",
            "$scope module top $end\n$var wire 8 # data [7:0] $end\n$var real 64 % volts $end\n",
            "$scope module uart $end\n$var wire 1 ! tx $end\n$var reg 1 rx_ rx $end\n$upscope $end\n",
            "$upscope $end\n$enddefinitions $end\n#0\n$dumpvars\nx!\nzrx_\nb0 #\nr0 %\n$end\n",
            f"#{round(0.001 / unit)}\n1!\n1rx_\n$comment the bus wakes up $end\nb10100101 #\n"]
    for t in sorted(changes):
        text.append(f"#{t}\n" + "\n".join(changes[t]) + "\n")
    text.append(f"#{round(DURATION / unit)}\n")
    body = "".join(text)
    if cut_after is not None:
        body = body[:cut_after]
    with open(path, "w") as f:
        f.write(body)
    return str(path)


@pytest.mark.parametrize("timescale, unit, tol", [
    ("1 ns", 1e-9, 3e-6), ("10 us", 10e-6, 12e-6), ("1ps", 1e-12, 3e-6), ("100ns", 100e-9, 3e-6)])
def test_a_vcd_of_any_time_scale_reads_its_one_bit_wires(tmp_path, timescale, unit, tol):
    path = write_vcd(tmp_path / "sim.vcd", timescale, unit)
    said: list[str] = []
    cap = analyzer.open(path, on_warning=said.append)
    check_conversation(list(cap), tol=tol)
    wave = cap.source.waveform
    assert wave.channels == ["tx", "rx"] and wave.numbers == ["0", "1"]
    assert not wave.sampled and wave.samplerate == pytest.approx(1 / unit)
    assert any("2 variables wider than 1 bit left out (data[7:0], volts)" in s for s in said)
    rows, _ = decode_jsonl(path, args=("--channels", "A=tx,B=rx"))
    check_jsonl(rows, tol=tol)


def test_vcd_channels_are_chosen_by_name_and_a_wrong_name_lists_them(tmp_path):
    path = write_vcd(tmp_path / "sim.vcd", "1 ns", 1e-9)
    # the lines the other way round: rx is line A
    assert our_bytes(path, channels={"A": "rx", "B": "tx"}) == {"A": ACK + RESULT, "B": COMMAND}
    run = run_cli("decode", path, "--channels", "A=TXD,B=rx")
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.strip().splitlines() == [(f"gimbalscope: error: {path}: no channel 'TXD'; the channels are "
                                                "tx (0), rx (1)")]


def test_a_vcd_cut_in_the_middle_is_read_up_to_there_and_said(tmp_path):
    whole = Path(write_vcd(tmp_path / "whole.vcd", "1 ns", 1e-9)).read_text()
    # cut inside the result, mid-line: the command and the ACK are whole
    at = whole.index(f"#{round((RESULT_AT + 5 * CHAR) * RATE) * 1000}") + 6
    path = write_vcd(tmp_path / "cut.vcd", "1 ns", 1e-9, cut_after=at)
    rows, stderr = decode_jsonl(path)
    assert [r["kind"] for r in rows[:2]] == ["command", "ack"] and rows[0]["command"] == "P?"
    line = whole[:at].count("\n") + 1
    # after the note on the variables left out, one line
    assert stderr.strip().splitlines()[1:] == [(f"gimbalscope: warning: {path}: ends in the middle of line {line} "
                                                "(cut short?): read up to there")]


def test_a_damaged_vcd_line_is_said_with_its_number(tmp_path):
    text = Path(write_vcd(tmp_path / "whole.vcd", "1 ns", 1e-9)).read_text().splitlines(keepends=True)
    at = next(i for i, ln in enumerate(text) if ln.startswith(f"#{round(ACK_AT * 1e9)}"))
    text.insert(at, "garbage\n")
    path = tmp_path / "bad.vcd"
    path.write_text("".join(text))
    rows, stderr = decode_jsonl(str(path))
    assert [r["kind"] for r in rows] == ["command"]
    assert stderr.strip().splitlines()[1:] == [(f"gimbalscope: warning: {path}: line {at + 1}: cannot read 'garbage': "
                                                "read up to there")]


def test_a_vcd_header_cut_short_is_one_line(tmp_path):
    path = tmp_path / "head.vcd"
    path.write_text("$timescale 1 ns $end\n$scope module top $end\n$var wire 1 ! tx $end\n")
    with pytest.raises(CaptureError, match=r"no \$enddefinitions: cut short in its header"):
        analyzer.open(str(path))


# ------------------------------------------------------------------ Saleae digital CSV
def write_digital_csv(path, offset: float = 0.0, damage_at: float | None = None) -> str:
    a, b = conversation()
    rows = np.union1d(edges(a), edges(b))
    out = ["Time [s],Channel 0,RX\n", f"{offset:.9f},1,1\n"]
    for s in rows:
        if damage_at is not None and s / RATE >= damage_at:
            out.append(f"{s / RATE + offset:.9f},1;0\n")
            damage_at = None
        out.append(f"{s / RATE + offset:.9f},{a[s]},{b[s]}\n")
    with open(path, "w") as f:
        f.write("".join(out))
    return str(path)


def test_a_saleae_digital_csv_keeps_its_times(tmp_path):
    # exported with the trigger 5 ms after the capture's start: times before it are negative
    path = write_digital_csv(tmp_path / "digital.csv", offset=-0.005)
    cap = analyzer.open(path)
    check_conversation(list(cap), offset=-0.005, tol=1e-8)
    wave = cap.source.waveform
    assert wave.channels == ["Channel 0", "RX"] and wave.numbers == ["0", "1"] and not wave.sampled
    rows, _ = decode_jsonl(path, args=("--channels", "A=0,B=RX"))
    check_jsonl(rows, offset=-0.005, tol=1e-8)


def test_a_damaged_digital_csv_row_is_said_and_what_came_before_decoded(tmp_path):
    path = write_digital_csv(tmp_path / "digital.csv", damage_at=RESULT_AT)
    lines = Path(path).read_text().splitlines()
    bad = next(i for i, ln in enumerate(lines) if ";" in ln) + 1
    rows, stderr = decode_jsonl(path, args=("--baud", "9600"))   # line B's one byte shows no rate
    assert [r["kind"] for r in rows] == ["command", "ack"]
    assert stderr.strip() == (f"gimbalscope: warning: {path}: line {bad}: cannot read '{lines[bad - 1]}' (a time "
                              "and 2 levels of 0, 1 or X): read up to there")


# ------------------------------------------------------------------ Saleae Async Serial table
def write_table(path, damage: bool = False, framing_on: int | None = None) -> str:
    rows = []
    for name, data, at in (("TX", COMMAND, COMMAND_AT), ("RX", ACK, ACK_AT), ("RX", RESULT, RESULT_AT)):
        for t, value in back_to_back(data, at, BAUD):
            rows.append((t, name, value))
    rows.sort()
    # columns in another order than Logic's, with error and address
    out = ["start_time,name,data,type,duration,error,address\n"]
    for i, (t, name, value) in enumerate(rows):
        error = "framing" if i == framing_on else ""
        out.append(f'{t:.9f},"Async Serial [{name}]",0x{value:02X},"data",{9.5 / BAUD:.9f},{error},\n')
        if damage and name == "RX" and value == 0x06:
            out.append('0.02x,"Async Serial [RX]",0xZZ,"data",0.0009,,\n')
    with open(path, "w") as f:
        f.write("".join(out))
    return str(path)


def test_a_saleae_async_serial_table_reads_its_bytes(tmp_path):
    path = write_table(tmp_path / "table.csv")
    cap = analyzer.open(path)
    check_conversation(list(cap), tol=1e-8)
    assert cap.options.baud == 9600   # from the rows' durations
    rows, _ = decode_jsonl(path)
    check_jsonl(rows, tol=1e-8)
    # named the other way round
    swapped = our_bytes(path, channels={"A": "Async Serial [RX]", "B": "Async Serial [TX]"})
    assert swapped == {"A": ACK + RESULT, "B": COMMAND}


def test_a_framing_error_in_the_table_is_a_line_fault_on_its_event(tmp_path):
    path = write_table(tmp_path / "table.csv", framing_on=3)   # the command's fourth byte
    command = next(e for e in analyzer.open(path) if e.kind == "command")
    assert [p.id for p in command.problems] == [problems.LINE_FRAMING]


def test_a_table_analyzer_not_in_the_file_lists_them(tmp_path):
    path = write_table(tmp_path / "table.csv")
    run = run_cli("decode", path, "--channels", "A=UART,B=Async Serial [RX]")
    assert run.returncode == 2
    assert run.stderr.strip().splitlines() == [(f"gimbalscope: error: {path}: no analyzer 'UART' in the table; the "
                                                "analyzers are Async Serial [TX], Async Serial [RX]")]


def test_a_damaged_table_row_is_said_and_what_came_before_decoded(tmp_path):
    path = write_table(tmp_path / "table.csv", damage=True)
    bad = Path(path).read_text().splitlines().index('0.02x,"Async Serial [RX]",0xZZ,"data",0.0009,,') + 1
    rows, stderr = decode_jsonl(path)
    assert [r["kind"] for r in rows] == ["command", "ack"]
    assert stderr.strip().splitlines() == [
        (f"gimbalscope: warning: {path}: line {bad}: cannot read '0.02x,Async Serial [RX],0xZZ,data,0.0009,,' (a data "
         "table row: name,type,start_time,duration,data): read up to there")]


# ------------------------------------------------------------------ Saleae binary export
def write_binary(folder, version: int, cut: bool = False) -> list[str]:
    """digital_0.bin and digital_1.bin, one channel each."""
    paths = []
    for i, levels in enumerate(conversation()):
        times = edges(levels) / RATE
        head = b"<SALEAE>" + struct.pack("<ii", version, 0)
        if version == 0:
            head += struct.pack("<Iddq", int(levels[0]), 0.0, DURATION, times.size)
        else:
            head += struct.pack("<q", 1) + struct.pack("<Idddq", int(levels[0]), RATE, 0.0, DURATION, times.size)
        data = head + times.astype("<f8").tobytes()
        if cut and i == 1:
            data = data[:len(head) + 8 * 4 + 5]          # the ACK's 4 edges, then half a double
        path = folder / f"digital_{i}.bin"
        path.write_bytes(data)
        paths.append(str(path))
    return paths


@pytest.mark.parametrize("version", [0, 1])
def test_a_saleae_binary_export_reads_one_file_a_channel(tmp_path, version):
    paths = write_binary(tmp_path, version)
    cap = analyzer.open(*paths)
    check_conversation(list(cap), tol=1e-8)
    wave = cap.source.waveform
    assert wave.channels == ["digital_0", "digital_1"] and wave.numbers == ["0", "1"]
    assert wave.sampled == (version == 1)          # version 1 gives its sample rate
    rows, _ = decode_jsonl(*paths)
    check_jsonl(rows, tol=1e-8)
    # the files the other way round are the lines the other way round
    assert our_bytes(paths[1], channels={"A": "digital_1"}) == {"AB": ACK + RESULT}


def test_a_saleae_binary_export_cut_short_is_said(tmp_path):
    paths = write_binary(tmp_path, 1, cut=True)
    rows, stderr = decode_jsonl(*paths, args=("--baud", "9600"))
    assert [r["kind"] for r in rows] == ["command", "ack"]
    assert stderr.strip().splitlines() == [(f"gimbalscope: warning: {paths[1]}: cut short: 4 of its 70 transitions "
                                            "read: read up to there")]


def test_a_csv_that_is_no_saleae_export_is_one_line(tmp_path):
    path = tmp_path / "notes.csv"
    path.write_text("when,what\n1,hello\n")
    with pytest.raises(CaptureError, match="not a Saleae Logic 2 export"):
        analyzer.open(str(path))
